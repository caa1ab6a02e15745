//! What a body answers about a point: signed distance, outward normal, closest surface
//! point.

use nalgebra::Vector3;

/// A point's relation to a body's surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Proximity {
    /// Signed distance to the surface, m: negative inside the body.
    pub distance: f64,
    /// The unit outward gradient of the signed distance (the surface normal at the
    /// closest point). Where the closest point is not unique (the centre of a ball, the
    /// axis of a capsule, the medial axis of any body) it is one of the candidates.
    pub normal: Vector3<f64>,
    /// The closest point of the surface: `x − distance · normal` for the analytic shapes
    /// (exact); for a mesh body the same first-order estimate on the interpolated field.
    pub closest: Vector3<f64>,
}

/// A unit vector perpendicular to `axis` (+z when `axis` is zero): the normal chosen where
/// every direction is equally valid.
pub fn any_unit(axis: &Vector3<f64>) -> Vector3<f64> {
    let norm = axis.norm();
    if norm == 0.0 || !norm.is_finite() {
        return Vector3::z();
    }
    let a = axis / norm;
    // the world axis least aligned with `a`, orthogonalised
    let least = (0..3)
        .min_by(|&i, &j| a[i].abs().total_cmp(&a[j].abs()))
        .unwrap_or(2);
    let e = Vector3::ith(least, 1.0);
    (e - a * a.dot(&e)).normalize()
}
