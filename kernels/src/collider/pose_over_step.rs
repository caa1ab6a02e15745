//! A collider's frame given by its poses at the two ends of a step, as a game engine hands
//! them (it knows where a body is each frame, not its motion between): the state at any
//! time of the step for [`super::Mount::Frame`], with the position moving uniformly and
//! the rotation turning at a constant rate about one axis,
//!
//! ```text
//! X(s) = X₀ + s (X₁ − X₀),   R(s) = R₀ exp(s [Θ]×),   Θ = log(R₀ᵀ R₁),   s = (t − t₀) / h
//! Ẋ = (X₁ − X₀) / h,         ω = Θ / h (body coordinates: Ṙ = R [ω]×),   Ẍ = 0,  ω̇ = 0.
//! ```
//!
//! The turn over one step is taken as the shortest one (|Θ| ≤ π): a body that turns
//! half a revolution or more within one step is seen turning the other way.

use crate::head::HeadState;
use nalgebra::{Matrix3, Rotation3, Vector3};

/// The poses of a collider's frame at the start and the end of a step (rotation: the
/// frame's coordinates to the world's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseOverStep {
    /// X₀, m.
    pub start_position: Vector3<f64>,
    /// R₀ (a rotation matrix).
    pub start_rotation: Matrix3<f64>,
    /// X₁, m.
    pub end_position: Vector3<f64>,
    /// R₁ (a rotation matrix).
    pub end_rotation: Matrix3<f64>,
}

impl PoseOverStep {
    /// A frame that does not move over the step.
    pub fn still(position: Vector3<f64>, rotation: Matrix3<f64>) -> Self {
        Self {
            start_position: position,
            start_rotation: rotation,
            end_position: position,
            end_rotation: rotation,
        }
    }

    /// Θ = log(R₀ᵀ R₁), the turn over the step in the frame's coordinates.
    pub fn turn(&self) -> Vector3<f64> {
        Rotation3::from_matrix_unchecked(self.start_rotation.transpose() * self.end_rotation)
            .scaled_axis()
    }

    /// The frame's state at fraction `s` of a step of length `h` (> 0), s: module page.
    pub fn state(&self, s: f64, h: f64) -> HeadState {
        let theta = self.turn();
        let delta = self.end_position - self.start_position;
        HeadState {
            position: self.start_position + delta * s,
            rotation: self.start_rotation * Rotation3::from_scaled_axis(theta * s).into_inner(),
            velocity: delta / h,
            acceleration: Vector3::zeros(),
            omega: theta / h,
            alpha: Vector3::zeros(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose() -> PoseOverStep {
        PoseOverStep {
            start_position: Vector3::new(0.1, -0.2, 0.3),
            start_rotation: Rotation3::from_euler_angles(0.3, -0.5, 1.1).into_inner(),
            end_position: Vector3::new(0.12, -0.19, 0.27),
            end_rotation: Rotation3::from_euler_angles(0.35, -0.42, 1.3).into_inner(),
        }
    }

    /// The state starts and ends at the given poses, and its velocity and angular
    /// velocity are the rates of its position and rotation (central differences in s,
    /// 1e-6 of the step): `Ẋ = dX/dt`, `R [ω]× = dR/dt`.
    #[test]
    fn the_state_joins_the_two_poses_at_the_rates_it_reports() {
        let p = pose();
        let h = 1.0 / 60.0;
        let start = p.state(0.0, h);
        assert_eq!(start.position, p.start_position);
        assert!((start.rotation - p.start_rotation).norm() < 1e-15);
        let end = p.state(1.0, h);
        assert!((end.position - p.end_position).norm() < 1e-15);
        assert!((end.rotation - p.end_rotation).norm() < 1e-14);
        let ds = 1e-6;
        for s in [0.0, 0.3, 0.8, 1.0] {
            let state = p.state(s, h);
            let (before, after) = (p.state(s - ds, h), p.state(s + ds, h));
            let velocity = (after.position - before.position) / (2.0 * ds * h);
            assert!((velocity - state.velocity).norm() < 1e-8 * state.velocity.norm());
            let rate = (after.rotation - before.rotation) / (2.0 * ds * h);
            let expected = state.rotation * state.omega.cross_matrix();
            assert!((rate - expected).norm() < 1e-7 * expected.norm(), "s = {s}");
        }
        let still = PoseOverStep::still(p.start_position, p.start_rotation).state(0.4, h);
        assert_eq!(still.velocity, Vector3::zeros());
        assert_eq!(still.omega, Vector3::zeros());
        assert_eq!(still.position, p.start_position);
    }
}
