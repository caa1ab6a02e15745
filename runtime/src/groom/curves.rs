//! A hair curve read from a file: the polyline of its centreline, root first.

use nalgebra::{Matrix3, Vector3};

/// A polyline, root first, in metres (head coordinates once placed).
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// The points, root first.
    pub points: Vec<Vector3<f64>>,
    /// Where the curve comes from, for messages (`file.obj line 12`).
    pub origin: String,
}

impl Curve {
    /// Length of the polyline (sum of its segments), m.
    pub fn polyline_length(&self) -> f64 {
        self.points.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
    }

    /// The curve placed by `x ↦ rotation (scale x) + translation`.
    pub fn placed(&self, scale: f64, rotation: &Matrix3<f64>, translation: &Vector3<f64>) -> Self {
        Curve {
            points: self
                .points
                .iter()
                .map(|p| rotation * (p * scale) + translation)
                .collect(),
            origin: self.origin.clone(),
        }
    }

    /// The points with repeated ones (a segment of zero length) left out.
    pub fn distinct_points(&self) -> Vec<Vector3<f64>> {
        let mut out: Vec<Vector3<f64>> = Vec::with_capacity(self.points.len());
        for p in &self.points {
            if out.last() != Some(p) {
                out.push(*p);
            }
        }
        out
    }
}
