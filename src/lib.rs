//! # superhelix
//!
//! Super-Helix hair dynamics: the runtime (`superhelix-runtime`) with the generated
//! fixed-N kernels of this build (`superhelix-generated`), and the library half of the
//! `superhelix` command: running a scene to `frames.json`, validating scenes, and the
//! measurements of `bench`, `compare-kernels`, `quadrature-table`, `study` ([`study`])
//! and `stress` ([`stress`]).
#![warn(missing_docs)]

pub mod bench;
pub mod compare;
pub mod cpu_time;
pub mod quadrature_table;
pub mod stress;
pub mod study;
pub mod study_plot;

pub use superhelix_generated as generated;
pub use superhelix_runtime as runtime;
pub use superhelix_runtime::{
    parse_scene, validate_scene, Error, FieldError, FrameSource, Frames, HeadMotion, KernelFactory,
    Result, RunSummary, Simulation, SimulationSetup,
};

use std::path::{Path, PathBuf};

/// The scene `superhelix run` uses without a scene file: the four presets of the paper
/// (smooth, wavy, curly, fuzzy) on a head shaking at 2 Hz by ±30° for 2 s.
pub const DEFAULT_SCENE: &str = include_str!("default_scene.toml");

/// Name of the file `run` writes in its output directory.
pub const FRAMES_FILE: &str = "frames.json";

/// The generated kernels of this build (for the N of `superhelix_generated::factory::sizes`;
/// other N use the generic runtime-N kernel under `kernels = "auto"`).
pub fn kernel_factory() -> Option<&'static dyn KernelFactory> {
    superhelix_generated::kernel_factory()
}

/// A running simulation of `setup`, as the output driver sees it.
///
/// The physics engine ([`Simulation`]) is being written concurrently; until it
/// implements [`FrameSource`] this returns an error instead of running. Once it does,
/// the body is `Ok(Box::new(Simulation::new(setup, kernel_factory())?))`.
pub fn open_simulation(setup: SimulationSetup) -> Result<Box<dyn FrameSource>> {
    Ok(Box::new(Simulation::new(setup, kernel_factory())?))
}

/// Run a parsed scene on `source` and write `out_dir/frames.json`. `progress(step,
/// total)` is called after every step. Returns the summary and the file written.
pub fn run_setup<S: FrameSource + ?Sized>(
    setup: &SimulationSetup,
    source: &mut S,
    out_dir: &Path,
    progress: impl FnMut(usize, usize),
) -> Result<(RunSummary, PathBuf)> {
    let (frames, summary) =
        runtime::output::run_to_frames(source, &setup.config, setup.samples_per_element, progress)?;
    let path = out_dir.join(FRAMES_FILE);
    runtime::output::write_frames(&path, &frames)?;
    Ok((summary, path))
}

/// Parse `scene_text`, simulate it and write `out_dir/frames.json`.
pub fn run_scene(
    scene_text: &str,
    out_dir: &Path,
    progress: impl FnMut(usize, usize),
) -> Result<(RunSummary, PathBuf)> {
    let setup = parse_scene(scene_text)?;
    let mut source = open_simulation(setup.clone())?;
    run_setup(&setup, source.as_mut(), out_dir, progress)
}

/// Number of strands and of time steps of a valid scene, or every problem found: those
/// of the scene file and those `run` meets before its first step (the simulation is built
/// with this build's generated kernels and its initial state checked).
pub fn check_scene(scene_text: &str) -> std::result::Result<(usize, usize), Vec<FieldError>> {
    let setup = parse_scene(scene_text).map_err(|_| validate_scene(scene_text))?;
    let counts = (setup.strands.len(), runtime::scene::step_count(&setup));
    match Simulation::new(setup, kernel_factory()) {
        Ok(_) => Ok(counts),
        Err(Error::Invalid(problems)) => Err(problems),
        Err(other) => Err(vec![FieldError::new("<scene>", other.to_string())]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_scene_is_valid_and_shows_every_preset() {
        let setup = match parse_scene(DEFAULT_SCENE) {
            Ok(s) => s,
            Err(e) => panic!("{e}"),
        };
        for preset in ["smooth", "wavy", "curly", "fuzzy"] {
            assert!(
                setup
                    .strands
                    .iter()
                    .any(|s| s.strand.name.starts_with(preset)),
                "{preset}"
            );
        }
        assert!(matches!(setup.head, HeadMotion::Oscillate { .. }));
        assert_eq!(check_scene(DEFAULT_SCENE), Ok((setup.strands.len(), 60)));
    }

    /// `scenes/cantilever.toml` (incompressible, ν = 0.5) bends as beam theory says:
    /// δ = F L³/(3EI), less the midpoint-rule error 1/(4N²) of N elements of constant
    /// curvature (`runtime/tests/physics.rs`); the load keeps δ/L ≈ 2.7e-3, so geometric
    /// nonlinearity (of order (δ/L)² ≈ 7e-6) is below the 1e-4 tolerance.
    #[test]
    fn the_cantilever_scene_is_incompressible_and_deflects_as_beam_theory() {
        let text = include_str!("../scenes/cantilever.toml");
        let setup = match parse_scene(text) {
            Ok(s) => s,
            Err(e) => panic!("{e}"),
        };
        let strand = setup.strands[0].strand.clone();
        let m = strand.material;
        assert!(
            (m.stiffness[0] / m.stiffness[1] - 2.0 / 3.0).abs() < 1e-14,
            "G = E/3"
        );
        let length: f64 = strand.geometry.lengths.iter().sum();
        let n = strand.geometry.elements() as f64;
        let force = -strand.point_loads[0].force.z;
        let beam = force * length.powi(3) / (3.0 * m.stiffness[1]);
        let mut sim = match Simulation::new(setup, kernel_factory()) {
            Ok(s) => s,
            Err(e) => panic!("{e}"),
        };
        let report = match sim.solve_static() {
            Ok(r) => r[0],
            Err(e) => panic!("{e}"),
        };
        assert!(report.converged, "{report:?}");
        let tip = -sim.position_at(0, length).z;
        let expected = beam * (1.0 - 1.0 / (4.0 * n * n));
        assert!(
            (tip / expected - 1.0).abs() < 1e-4,
            "tip {tip:e} vs {expected:e} (beam theory {beam:e})"
        );
    }
}
