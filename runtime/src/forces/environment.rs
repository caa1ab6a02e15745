//! The environment shared by all strands.

use nalgebra::Vector3;

/// Gravity and still air.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Environment {
    /// Gravity in world coordinates, m/s². `None`: the scene has no gravity effect.
    pub gravity: Option<Vector3<f64>>,
}

impl Default for Environment {
    fn default() -> Self {
        Self {
            gravity: Some(Vector3::new(0.0, 0.0, -9.81)),
        }
    }
}
