//! # superhelix (Python)
//!
//! The Python module `superhelix`: Super-Helix scenes built from TOML text, a file or a
//! dict, checked as `superhelix validate` checks them, run as `superhelix run` runs them
//! with every frame returned as numpy arrays, or stepped by hand; the embedded fixed-N
//! strand step with the head pose given per step (the C ABI's batch); and the studies of
//! `superhelix study` and `superhelix stress`, their results as dicts. Built with maturin
//! as an abi3 wheel (`pip install ./python`); documented in `docs/python.md`.
//!
//! | Python | Rust |
//! |---|---|
//! | `Scene` ([`scene`]) | `superhelix_runtime::parse_scene_reporting`, `validate_scene_at`, `SimulationSetup` |
//! | `Scene.run` → `RunResult` ([`run`]) | `superhelix_runtime::output::run_streaming` |
//! | `Simulation` ([`simulation`]) | `superhelix_runtime::Simulation` |
//! | `Batch`, `StepReport` ([`batch`]) | `superhelix_kernels::fixed::{step, linearly_implicit, step_to_tolerance}` over `superhelix_generated`'s sizes |
//! | `study`, `stress` ([`studies`]) | `superhelix_studies::study::run_study`, `superhelix_studies::stress::{select_cases, run_cases}` |
//! | `SceneError`, `SimulationError`, `StepError` ([`errors`]) | `superhelix_runtime::Error`, `superhelix_kernels::fixed::StepError` |

mod arrays;
mod batch;
mod convert;
mod energy;
mod errors;
mod run;
mod scene;
mod simulation;
mod studies;

use pyo3::prelude::*;

/// Super-Helix hair dynamics (Bertails et al. 2006) from Python.
///
/// Scene.from_toml / from_file / from_dict / default -> Scene; scene.validate();
/// scene.run() -> RunResult (numpy arrays of every frame); scene.simulation() ->
/// Simulation (step by hand); Batch (the embedded fixed-N step, the head pose per step);
/// study(...) and stress(...) (the studies of `superhelix study` and `superhelix stress`).
/// Errors: SceneError (ValueError), SimulationError and StepError (RuntimeError).
/// docs/python.md in the repository describes it all.
#[pymodule]
mod superhelix {
    use pyo3::prelude::*;

    #[pymodule_export]
    use crate::batch::{Batch, StepReport};
    #[pymodule_export]
    use crate::errors::{SceneError, SimulationError, StepError};
    #[pymodule_export]
    use crate::run::RunResult;
    #[pymodule_export]
    use crate::scene::Scene;
    #[pymodule_export]
    use crate::simulation::Simulation;
    #[pymodule_export]
    use crate::studies::{stress, study};

    /// supported_elements() -> list[int]
    ///
    /// The numbers of elements N this build has generated fixed-N code for: the N a
    /// Batch takes, and the N the embedded engine steps.
    #[pyfunction]
    fn supported_elements() -> Vec<usize> {
        crate::batch::supported_elements()
    }

    #[pymodule_init]
    fn init(m: &Bound<'_, PyModule>) -> PyResult<()> {
        m.add("__version__", env!("CARGO_PKG_VERSION"))?;
        Ok(())
    }
}
