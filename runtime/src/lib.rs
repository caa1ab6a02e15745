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

pub mod error;
pub mod helix_functions;
pub mod jet;
pub mod element;
pub mod quadrature;
pub mod material;
pub mod strand;
pub mod reconstruction;
pub mod kernel;
pub mod kernel_generic;
pub mod environment;
pub mod head_motion;
pub mod effects;
pub mod dense_solve;
pub mod integrator;
pub mod statics;
pub mod simulation;
pub mod scene;
pub mod output;

pub use error::{Error, FieldError, Result};
pub use kernel::{EvalInput, KernelFactory, StrandKernel, StrandTerms, Terms};
pub use kernel_generic::{GenericKernel, GenericKernelFactory, QuadratureRule};
pub use material::{CrossSection, HelixForm, Material, Preset};
pub use strand::{PointLoad, Strand, StrandGeometry};
pub use environment::Environment;
pub use head_motion::{HeadMotion, HeadState};
pub use simulation::{IntegratorKind, KernelChoice, Mode, Simulation, SimulationConfig, SimulationSetup, StrandSetup};

/// Re-exported so that users of the trait need not name nalgebra themselves.
pub use nalgebra::{Matrix3, Vector3};
pub use head_motion::{Keyframe, KeyframeTrack};
pub use output::{run_to_frames, write_frames, FrameSource, Frames, RunSummary, StrandFrames};
pub use scene::{parse_scene, validate_scene};
