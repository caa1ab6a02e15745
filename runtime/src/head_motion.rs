//! Rigid motion of the head (placeholder until the scene branch lands).
use nalgebra::{Matrix3, Vector3};

/// Rigid head motion.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum HeadMotion {
    /// The head does not move.
    #[default]
    Still,
}

/// Kinematic state of the head: world point x = position + rotation · y.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeadState {
    /// X, world.
    pub position: Vector3<f64>,
    /// R.
    pub rotation: Matrix3<f64>,
    /// Ẋ, world.
    pub velocity: Vector3<f64>,
    /// Ẍ, world.
    pub acceleration: Vector3<f64>,
    /// ω, head coordinates.
    pub omega: Vector3<f64>,
    /// α, head coordinates.
    pub alpha: Vector3<f64>,
}

impl HeadState {
    /// At rest at the origin.
    pub fn rest() -> Self {
        HeadState {
            position: Vector3::zeros(),
            rotation: Matrix3::identity(),
            velocity: Vector3::zeros(),
            acceleration: Vector3::zeros(),
            omega: Vector3::zeros(),
            alpha: Vector3::zeros(),
        }
    }
}

impl HeadMotion {
    /// State at time t.
    pub fn state(&self, _t: f64) -> HeadState {
        HeadState::rest()
    }
}
