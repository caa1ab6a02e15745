//! # superhelix-runtime
//!
//! The runtime of the Super-Helix hair model (Bertails, Audoly, Cani et al., 2006):
//! the generic runtime-N strand kernel (closed-form reconstruction, numerical
//! quadrature of the dynamic terms), the integrators, the forces, scenes and outputs.
//!
//! Conventions (units, ordering of `q`, frames, stiffness formulas): see `docs/model.md`
//! in the repository.
//!
//! The runtime reaches a strand's dynamic terms only through the [`StrandKernel`]
//! trait, implemented here by [`GenericKernel`] (any N, Gauss–Legendre quadrature) and
//! by the generated fixed-N kernels of the `superhelix-generated` crate.
//!
//! ## Map
//!
//! | folder | holds |
//! |---|---|
//! | [`model`] | the helix model and its reconstruction: strand, material, helical element, centreline and frames from q |
//! | [`kernels`] | the [`StrandKernel`] trait and its implementations: generic runtime-N, assembly from element moments |
//! | [`bodies`] | the bodies of a scene (head, obstacles) as signed distance fields: spheres, ellipsoids, capsules, cylinders, planes exact; closed OBJ meshes sampled on a grid; attached to the head or fixed in the world |
//! | [`forces`] | effects and head motion: environment, body field, head motion, point loads, contacts with bodies and between strands, static electricity |
//! | [`groom`] | many strands at once: Poisson-disk roots over a scalp region of a body, curves read from OBJ or USDA files and fitted as Super-Helices, a sag-free start (inverse statics) |
//! | [`render`] | render strands generated from the guides at every frame: root placement, semi-interpolation (paper section 4.1) |
//! | [`config`] | the settings of a run and the [`SimulationSetup`] a simulation is built from (plain data) |
//! | [`solver`] | time stepping and statics: the strand system, one file per integrator, the adaptive splitting, energy balance, dense solves |
//! | [`simulation`] | [`Simulation`]: built from a setup, advanced by `step` |
//! | [`scene`] | scene files (TOML) read into a [`SimulationSetup`] |
//! | [`output`] | the run driver that streams frames to files, the file formats (frames.json, .npy, .usda, pictures, .obj), the output plan |
//!
//! Data flows scene → [`SimulationSetup`] → [`Simulation::new`] (one
//! [`solver::StrandSystem`] per strand) → [`Simulation::step`] → the solver's step →
//! kernels → output. Each module uses only the ones before it in the order
//! error → model → kernels → bodies → forces → groom → render → config → output → solver →
//! simulation → scene
//! (`runtime/tests/architecture.rs` checks it); the output reaches a simulation only
//! through its [`FrameSource`] trait, which [`Simulation`] implements.
#![warn(missing_docs)]
// Numerical kernels index several arrays in step; explicit index loops read best there.
#![allow(clippy::needless_range_loop, clippy::too_many_arguments)]

pub mod bodies;
pub mod config;
pub mod error;
pub mod forces;
pub mod groom;
pub mod input;
pub mod kernels;
pub mod memory_plan;
pub mod model;
pub mod output;
pub mod render;
pub mod scene;
pub mod simulation;
pub mod solver;

pub use bodies::{Bodies, BodySetup, PlacedBodies, Proximity};
pub use config::{
    IntegratorKind, KernelChoice, Mode, SimulationConfig, SimulationSetup, StrandSetup,
};
pub use error::{Error, FieldError, Result};
pub use forces::environment::Environment;
pub use forces::head_motion::{HeadMotion, HeadState};
pub use kernels::generic::{GenericKernel, GenericKernelFactory, QuadratureRule};
pub use kernels::kernel::{EvalInput, KernelFactory, StrandKernel, StrandTerms, Terms};
pub use model::material::{CrossSection, HelixForm, Material, Preset};
pub use model::strand::{PointLoad, Strand, StrandGeometry};
pub use simulation::{check_memory, engine_for, Simulation};
pub use solver::StepStats;

pub use forces::head_motion::{Keyframe, KeyframeTrack};
/// Re-exported so that users of the trait need not name nalgebra themselves.
pub use nalgebra::{Matrix3, Vector3};
pub use output::{run_to_frames, FrameSource, Frames, RunSummary, StrandFrames};
pub use scene::{
    parse_scene, parse_scene_at, parse_scene_reporting, validate_scene, validate_scene_at,
    validate_scene_with,
};
