//! The pose (position and frame) of a point of the strand, and the Darboux vector of an
//! element read from q.

use nalgebra::{Matrix3, Vector3};

/// A point of the centreline with its material frame (columns n0, n1, n2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Position.
    pub position: Vector3<f64>,
    /// Material frame; column 0 is the tangent.
    pub frame: Matrix3<f64>,
}

impl Default for Pose {
    fn default() -> Self {
        Pose {
            position: Vector3::zeros(),
            frame: Matrix3::identity(),
        }
    }
}

/// Darboux vector d_Q of element `q_index` read from `q`.
pub fn darboux(q: &[f64], element: usize) -> Vector3<f64> {
    Vector3::new(q[3 * element], q[3 * element + 1], q[3 * element + 2])
}
