//! The pose (position and frame) of a point of the strand, and the Darboux vector of an
//! element read from q.

use crate::float::{Arith, Float};
use nalgebra::{Matrix3, Vector3};

/// A point of the centreline with its material frame (columns n0, n1, n2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose<T: Arith = f64> {
    /// Position.
    pub position: Vector3<T>,
    /// Material frame; column 0 is the tangent.
    pub frame: Matrix3<T>,
}

impl<T: Arith> Default for Pose<T> {
    fn default() -> Self {
        Pose {
            position: Vector3::zeros(),
            frame: Matrix3::identity(),
        }
    }
}

/// Darboux vector d_Q of element `q_index` read from `q`.
pub fn darboux<T: Float>(q: &[T], element: usize) -> Vector3<T> {
    Vector3::new(q[3 * element], q[3 * element + 1], q[3 * element + 2])
}
