//! # superhelix-runtime
//!
//! The runtime of the Super-Helix hair model (Bertails, Audoly, Cani et al., 2006):
//! the generic runtime-N strand kernel (closed-form reconstruction, numerical
//! quadrature of the dynamic terms), the integrators, the forces, scenes and outputs.
//!
//! Conventions (units, ordering of `q`, frames, stiffness formulas) follow the design
//! page `shared/design/superhelix-model.md`; the README summarises them.
//!
//! The runtime reaches a strand's dynamic terms only through the [`StrandKernel`]
//! trait, implemented here by [`GenericKernel`] (any N, Gauss–Legendre quadrature) and
//! by the generated fixed-N kernels of the `superhelix-generated` crate.
#![warn(missing_docs)]
// Numerical kernels index several arrays in step; explicit index loops read best there.
#![allow(clippy::needless_range_loop, clippy::too_many_arguments)]

pub mod dense_solve;
pub mod effects;
pub mod element;
pub mod energy_balance;
pub mod environment;
pub mod error;
pub mod head_motion;
pub mod helix_functions;
pub mod initial_state;
pub mod integrator;
pub mod jet;
pub mod kernel;
pub mod kernel_generic;
pub mod kernel_moments;
pub mod lanes;
pub mod material;
pub mod moment_jacobians;
pub mod moment_rotary;
pub mod moments;
pub mod output;
pub mod quadrature;
pub mod reconstruction;
pub mod scene;
pub mod simulation;
pub mod spectral_projection;
pub mod statics;
pub mod strand;

pub use environment::Environment;
pub use error::{Error, FieldError, Result};
pub use head_motion::{HeadMotion, HeadState};
pub use kernel::{EvalInput, KernelFactory, StrandKernel, StrandTerms, Terms};
pub use kernel_generic::{GenericKernel, GenericKernelFactory, QuadratureRule};
pub use material::{CrossSection, HelixForm, Material, Preset};
pub use simulation::{
    IntegratorKind, KernelChoice, Mode, Simulation, SimulationConfig, SimulationSetup, StrandSetup,
};
pub use strand::{PointLoad, Strand, StrandGeometry};

pub use head_motion::{Keyframe, KeyframeTrack};
/// Re-exported so that users of the trait need not name nalgebra themselves.
pub use nalgebra::{Matrix3, Vector3};
pub use output::{run_to_frames, write_frames, FrameSource, Frames, RunSummary, StrandFrames};
pub use scene::{parse_scene, validate_scene, validate_scene_with};
