//! A capsule: the points within a radius of a segment; exact signed distance
//! `|y − p(y)| − r` with p(y) the closest point of the segment.

use super::proximity::{any_unit, Proximity};
use nalgebra::Vector3;

/// The points within `radius` of the segment from `start` to `end`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capsule {
    /// One end of the axis, m.
    pub start: Vector3<f64>,
    /// The other end, m.
    pub end: Vector3<f64>,
    /// Radius, m (> 0).
    pub radius: f64,
}

impl Capsule {
    /// The point of the axis segment closest to `y`.
    pub fn axis_point(&self, y: &Vector3<f64>) -> Vector3<f64> {
        self.start + (self.end - self.start) * self.axis_parameter(y)
    }

    /// t in [0, 1] of the axis point `start + t (end − start)` closest to `y`.
    fn axis_parameter(&self, y: &Vector3<f64>) -> f64 {
        let axis = self.end - self.start;
        let length2 = axis.norm_squared();
        if length2 == 0.0 {
            return 0.0;
        }
        ((y - self.start).dot(&axis) / length2).clamp(0.0, 1.0)
    }

    /// Signed distance, outward normal and closest surface point of `y`. On the axis,
    /// where a whole circle of surface points is closest, the normal is a unit vector
    /// perpendicular to the axis.
    pub fn query(&self, y: &Vector3<f64>) -> Proximity {
        let axis = self.end - self.start;
        let t = self.axis_parameter(y);
        let p = self.start + axis * t;
        let mut offset = y - p;
        if t > 0.0 && t < 1.0 {
            // beside the axis the offset is perpendicular to it: drop the rounding along it
            offset -= axis * (offset.dot(&axis) / axis.norm_squared());
        }
        let r = offset.norm();
        let normal = if r > 0.0 { offset / r } else { any_unit(&axis) };
        Proximity {
            distance: r - self.radius,
            normal,
            closest: p + normal * self.radius,
        }
    }
}
