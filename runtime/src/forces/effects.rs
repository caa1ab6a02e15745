//! The effects a scene can ask for, composed per strand and per step.
//!
//! Gravity, head motion (its fictitious forces) and air drag act through one
//! [`BodyField`] per strand and step (eq. 5a written in the head frame, design page
//! "Energies and the equation of motion"); internal friction and elasticity are diagonal
//! in q; point loads go through J(s)ᵀ. An effect the scene does not name is `None` or
//! zero here and costs nothing: no field term, no point evaluation.

use crate::forces::head_motion::HeadState;
use crate::kernels::kernel::BodyField;
use nalgebra::{Matrix3, Vector3};

/// Global effects of a simulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlobalEffects {
    /// Gravity in world coordinates, when the scene has gravity.
    pub gravity: Option<Vector3<f64>>,
    /// Whether the head moves (fictitious forces are built only then).
    pub head_moves: bool,
}

/// The force per unit length on a strand of mass per length `rho_s` and air drag `nu`
/// with the head in state `head`:
///
/// ```text
/// c0 = ρS Rᵀ(g − Ẍ) − ν RᵀẊ
/// C1 = −ρS([α]× + [ω]×²) − ν[ω]×
/// C2 = −2ρS[ω]× − ν I
/// ```
pub fn body_field(effects: &GlobalEffects, head: &HeadState, rho_s: f64, nu: f64) -> BodyField {
    let mut field = BodyField::zero();
    let rt = head.rotation.transpose();
    if let Some(g) = effects.gravity {
        field.uniform += rt * g * rho_s;
    }
    if nu != 0.0 {
        field.velocity -= Matrix3::identity() * nu;
    }
    if effects.head_moves {
        let w = head.omega.cross_matrix();
        field.uniform -= rt * (head.acceleration * rho_s + head.velocity * nu);
        field.linear -= (head.alpha.cross_matrix() + w * w) * rho_s + w * nu;
        field.velocity -= w * (2.0 * rho_s);
    }
    field
}
