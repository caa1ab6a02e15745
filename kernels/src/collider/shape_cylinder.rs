//! A solid cylinder with flat caps; exact signed distance (the round side, the caps, and
//! their rims).

use super::proximity::{any_unit, Proximity};
use nalgebra::Vector3;

/// The points within `radius` of the axis from `start` to `end` and between the planes
/// through the two ends perpendicular to it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cylinder {
    /// Centre of one cap, m.
    pub start: Vector3<f64>,
    /// Centre of the other cap, m (different from `start`).
    pub end: Vector3<f64>,
    /// Radius, m (> 0).
    pub radius: f64,
}

impl Cylinder {
    /// Signed distance, outward normal and closest surface point of `y`. Inside, the
    /// nearer of the side and the caps; outside beyond a rim, the rim's nearest point.
    pub fn query(&self, y: &Vector3<f64>) -> Proximity {
        let axis = self.end - self.start;
        let length = axis.norm();
        let a = if length > 0.0 {
            axis / length
        } else {
            Vector3::z()
        };
        let half = 0.5 * length;
        let centre = 0.5 * (self.start + self.end);
        let x = y - centre;
        let along = x.dot(&a);
        let radial = x - a * along;
        let rho = radial.norm();
        let r_hat = if rho > 0.0 {
            radial / rho
        } else {
            any_unit(&a)
        };
        let cap = if along >= 0.0 { a } else { -a };
        let d_side = rho - self.radius;
        let d_cap = along.abs() - half;
        let (distance, normal) = if d_side > 0.0 && d_cap > 0.0 {
            let d = crate::math::sqrt(d_side * d_side + d_cap * d_cap);
            (d, (r_hat * d_side + cap * d_cap) / d)
        } else if d_side >= d_cap {
            (d_side, r_hat)
        } else {
            (d_cap, cap)
        };
        Proximity {
            distance,
            normal,
            closest: y - normal * distance,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> Cylinder {
        Cylinder {
            start: Vector3::new(0.0, 0.0, -1.0),
            end: Vector3::new(0.0, 0.0, 1.0),
            radius: 0.5,
        }
    }

    #[test]
    fn distances_to_the_side_the_caps_and_the_rim_are_exact() {
        let c = unit();
        let side = c.query(&Vector3::new(2.0, 0.0, 0.3));
        assert!((side.distance - 1.5).abs() < 1e-15 && (side.normal - Vector3::x()).norm() < 1e-15);
        let cap = c.query(&Vector3::new(0.1, 0.2, 3.0));
        assert!((cap.distance - 2.0).abs() < 1e-15 && (cap.normal - Vector3::z()).norm() < 1e-15);
        let rim = c.query(&Vector3::new(0.0, 3.5, -5.0));
        assert!((rim.distance - 5.0).abs() < 1e-14, "{}", rim.distance);
        assert!((rim.closest - Vector3::new(0.0, 0.5, -1.0)).norm() < 1e-14);
        let inside = c.query(&Vector3::new(0.4, 0.0, 0.0));
        assert!((inside.distance + 0.1).abs() < 1e-15);
        let near_cap = c.query(&Vector3::new(0.0, 0.0, -0.95));
        assert!(
            (near_cap.distance + 0.05).abs() < 1e-15
                && (near_cap.normal + Vector3::z()).norm() < 1e-15
        );
    }

    /// The distance's gradient is the normal (central differences, away from the rims).
    #[test]
    fn the_normal_is_the_gradient_of_the_distance() {
        let c = Cylinder {
            start: Vector3::new(0.1, -0.2, 0.0),
            end: Vector3::new(0.5, 0.3, 0.9),
            radius: 0.2,
        };
        for y in [
            Vector3::new(0.9, 0.1, 0.2),
            Vector3::new(0.3, 0.0, 0.45),
            Vector3::new(1.0, 1.0, 1.5),
        ] {
            let q = c.query(&y);
            let h = 1e-6;
            let g = Vector3::from_fn(|i, _| {
                let e = Vector3::from_fn(|j, _| if i == j { h } else { 0.0 });
                (c.query(&(y + e)).distance - c.query(&(y - e)).distance) / (2.0 * h)
            });
            assert!(
                (g - q.normal).norm() < 1e-6,
                "{y:?}: {g:?} vs {:?}",
                q.normal
            );
        }
    }
}
