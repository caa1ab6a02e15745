//! Time stepping and statics (paper section 3.4, design page "Time stepping"): the
//! [`StrandSystem`] a step works on and its shared assembly ([`system`]), one file per
//! integrator (linearly implicit Euler, the default; Newton-iterated implicit Euler;
//! linearised BDF2; explicit RK4), the adaptive splitting with its energy balance, the
//! static equilibrium, and the dense linear algebra they need.
//!
//! A step reads as the physics: [`step`]`(system, interval, state, stats)` advances one
//! strand's state over one [`HeadInterval`].

pub mod adaptive;
pub mod contact_hook;
pub mod continuation;
pub mod dense_solve;
pub mod embedded;
pub mod error_control;
mod free_root_momentum;
pub mod held_end;
pub mod initial_state;
pub mod one_step;
pub mod pair_coupling;
mod predicted_contacts;
pub mod rk4;
pub mod spectral_projection;
pub mod statics;
pub mod stats;
pub mod system;

pub use adaptive::step;
pub use error_control::StepWindow;
pub use statics::{solve_static, StaticReport};
pub use stats::StepStats;
pub use system::{HeadInterval, StepContext, StrandState, StrandSystem, StrandWorkspace};
