//! The scalp region of a groom: the part of a body's surface that grows hair. A point
//! belongs to it when it lies in the cap around an axis (the direction from the region's
//! centre to the point within a largest angle of the axis) and, when a plane cut is
//! given, on the side of the plane its normal points to.

use nalgebra::Vector3;

/// A plane cut: keeps the points `x` with `(x − point) · normal ≥ 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneCut {
    /// A point of the plane, m.
    pub point: Vector3<f64>,
    /// Unit normal, pointing to the kept side.
    pub normal: Vector3<f64>,
}

/// A region of a surface: a cap around `axis` seen from `center`, and an optional cut.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Region {
    /// Where directions are measured from, m.
    pub center: Vector3<f64>,
    /// Unit axis of the cap.
    pub axis: Vector3<f64>,
    /// Largest angle between the axis and `x − center`, rad, in (0, π]; π keeps every
    /// direction.
    pub max_angle: f64,
    /// The plane cut, if any.
    pub cut: Option<PlaneCut>,
}

impl Region {
    /// Whether the point `x` lies in the region (the centre itself is in no cap smaller
    /// than the whole sphere of directions).
    pub fn contains(&self, x: &Vector3<f64>) -> bool {
        let in_cut = self.cut.is_none_or(|c| (x - c.point).dot(&c.normal) >= 0.0);
        if !in_cut {
            return false;
        }
        if self.max_angle >= std::f64::consts::PI {
            return true;
        }
        let d = x - self.center;
        let norm = d.norm();
        norm > 0.0 && d.dot(&self.axis) >= norm * self.max_angle.cos()
    }
}
