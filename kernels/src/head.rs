//! The head's state at one time and the force per unit length it puts on a strand
//! (gravity, the fictitious forces of its motion, air drag), written in the head frame
//! (paper eq. 5a).

use crate::body_field::BodyField;
use crate::float::Float;
use nalgebra::{Matrix3, Vector3};

/// The head's position, orientation and their first two time derivatives at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeadState {
    /// X: world position of the head origin, metres.
    pub position: Vector3<f64>,
    /// R: orientation, head coordinates to world coordinates.
    pub rotation: Matrix3<f64>,
    /// Ẋ, world coordinates, m/s.
    pub velocity: Vector3<f64>,
    /// Ẍ, world coordinates, m/s².
    pub acceleration: Vector3<f64>,
    /// ω, head coordinates, rad/s: `Ṙ = R [ω]×`.
    pub omega: Vector3<f64>,
    /// α = dω/dt, head coordinates, rad/s².
    pub alpha: Vector3<f64>,
}

impl HeadState {
    /// The head at rest at the origin: X = 0, R = I, all derivatives zero.
    pub fn rest() -> Self {
        Self {
            position: Vector3::zeros(),
            rotation: Matrix3::identity(),
            velocity: Vector3::zeros(),
            acceleration: Vector3::zeros(),
            omega: Vector3::zeros(),
            alpha: Vector3::zeros(),
        }
    }

    /// World coordinates `X + R y` of the point with head coordinates `y`.
    pub fn to_world(&self, y: &Vector3<f64>) -> Vector3<f64> {
        self.position + self.rotation * y
    }
}

impl Default for HeadState {
    fn default() -> Self {
        Self::rest()
    }
}

/// The force per unit length on a strand of mass per length `rho_s` and air drag `nu`
/// with the head in state `head`:
///
/// ```text
/// c0 = ρS Rᵀ(g − Ẍ) − ν RᵀẊ
/// C1 = −ρS([α]× + [ω]×²) − ν[ω]×
/// C2 = −2ρS[ω]× − ν I
/// ```
///
/// In the type of `rho_s` and `nu`: the head's state and gravity (`f64`, as the head
/// trajectory gives them) are rounded to it first.
pub fn body_field<T: Float>(
    gravity: Option<Vector3<f64>>,
    head_moves: bool,
    head: &HeadState,
    rho_s: T,
    nu: T,
) -> BodyField<T> {
    let mut field = BodyField::zero();
    let rt: Matrix3<T> = head.rotation.transpose().map(T::of);
    if let Some(g) = gravity {
        field.uniform += rt * g.map(T::of) * rho_s;
    }
    if nu != T::zero() {
        field.velocity -= Matrix3::identity() * nu;
    }
    if head_moves {
        let w = head.omega.map(T::of).cross_matrix();
        field.uniform -=
            rt * (head.acceleration.map(T::of) * rho_s + head.velocity.map(T::of) * nu);
        field.linear -= (head.alpha.map(T::of).cross_matrix() + w * w) * rho_s + w * nu;
        field.velocity -= w * (T::of(2.0) * rho_s);
    }
    field
}
