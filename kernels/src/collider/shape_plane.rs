//! A half-space: exact signed distance `(y − p) · n`.

use super::proximity::Proximity;
use nalgebra::Vector3;

/// The half-space behind the plane through `point` with unit outward normal `normal`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// A point of the plane, m.
    pub point: Vector3<f64>,
    /// Unit outward normal: the body is on the side the normal points away from.
    pub normal: Vector3<f64>,
}

impl Plane {
    /// Signed distance, outward normal and closest surface point (the foot of the
    /// perpendicular) of `y`.
    pub fn query(&self, y: &Vector3<f64>) -> Proximity {
        let distance = (y - self.point).dot(&self.normal);
        Proximity {
            distance,
            normal: self.normal,
            closest: y - self.normal * distance,
        }
    }
}
