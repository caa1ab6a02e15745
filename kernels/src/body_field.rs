//! External forces per unit length affine in the centreline's position and velocity:
//! gravity, the fictitious forces of head motion and air drag (paper eq. 5a, written in
//! the head frame).

use crate::float::Arith;
use nalgebra::{Matrix3, Vector3};

/// An external force per unit length affine in position and velocity:
/// `F = uniform + linear · y + velocity · ẏ` (N/m), head coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyField<T: Arith = f64> {
    /// c0, N/m: gravity ρS Rᵀ(g − Ẍ) and the drag of the head's translation −ν RᵀẊ.
    pub uniform: Vector3<T>,
    /// C1, N/m²: `−ρS([α]× + [ω]×²) − ν[ω]×` (Euler, centrifugal, drag of rotation).
    pub linear: Matrix3<T>,
    /// C2, N·s/m²: `−2ρS[ω]× − ν I` (Coriolis and drag of the strand's own motion).
    pub velocity: Matrix3<T>,
}

impl<T: Arith> BodyField<T> {
    /// No force.
    pub fn zero() -> Self {
        BodyField {
            uniform: Vector3::zeros(),
            linear: Matrix3::zeros(),
            velocity: Matrix3::zeros(),
        }
    }
    /// True when the linear part is zero (no head rotation).
    pub fn has_linear(&self) -> bool {
        self.linear != Matrix3::zeros()
    }
    /// If the velocity part is a multiple of the identity, that multiple.
    pub fn isotropic_velocity(&self) -> Option<T> {
        let c = self.velocity[(0, 0)];
        (self.velocity == Matrix3::identity() * c).then_some(c)
    }
}
