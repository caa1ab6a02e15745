//! The effects a scene can ask for, composed per strand and per step.
//!
//! Gravity, head motion (its fictitious forces) and air drag act through one
//! [`BodyField`] per strand and step (eq. 5a written in the head frame, design page
//! "Energies and the equation of motion"); internal friction and elasticity are diagonal
//! in q; point loads go through J(s)ᵀ. An effect the scene does not name is `None` or
//! zero here and costs nothing: no field term, no point evaluation.

use crate::forces::head_motion::HeadState;
use crate::kernels::kernel::BodyField;
use nalgebra::Vector3;

/// Global effects of a simulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlobalEffects {
    /// Gravity in world coordinates, when the scene has gravity.
    pub gravity: Option<Vector3<f64>>,
    /// Whether the head moves (fictitious forces are built only then).
    pub head_moves: bool,
}

/// The force per unit length on a strand of mass per length `rho_s` and air drag `nu`
/// with the head in state `head` ([`superhelix_kernels::head::body_field`]).
pub fn body_field(effects: &GlobalEffects, head: &HeadState, rho_s: f64, nu: f64) -> BodyField {
    superhelix_kernels::head::body_field(effects.gravity, effects.head_moves, head, rho_s, nu)
}
