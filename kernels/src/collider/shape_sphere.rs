//! A ball: exact signed distance `|y − c| − r`.

use super::proximity::{any_unit, Proximity};
use nalgebra::Vector3;

/// A ball of centre `center` and radius `radius`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre, m.
    pub center: Vector3<f64>,
    /// Radius, m (> 0).
    pub radius: f64,
}

impl Sphere {
    /// Signed distance, outward normal and closest surface point of `y`. At the centre,
    /// where every surface point is closest, the normal is +z.
    pub fn query(&self, y: &Vector3<f64>) -> Proximity {
        let offset = y - self.center;
        let r = offset.norm();
        let normal = if r > 0.0 {
            offset / r
        } else {
            any_unit(&Vector3::zeros())
        };
        Proximity {
            distance: r - self.radius,
            normal,
            closest: self.center + normal * self.radius,
        }
    }
}
