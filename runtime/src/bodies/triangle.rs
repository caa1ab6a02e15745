//! The exact closest point of a triangle to a point (Ericson, *Real-Time Collision
//! Detection*, 5.1.5), with the feature it lies on: a vertex, an edge or the face. The
//! feature chooses the pseudonormal that signs the distance ([`super::mesh_distance`]).

use nalgebra::Vector3;

/// Where on a triangle `[a, b, c]` its closest point lies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Feature {
    /// Vertex k (0 = a, 1 = b, 2 = c).
    Vertex(u8),
    /// Edge k: 0 = ab, 1 = bc, 2 = ca.
    Edge(u8),
    /// The interior of the face.
    Face,
}

/// The point of triangle `t` closest to `p`, and its feature. The triangle must have a
/// non-zero area.
pub fn closest_point(p: &Vector3<f64>, t: &[Vector3<f64>; 3]) -> (Vector3<f64>, Feature) {
    let [a, b, c] = t;
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (*a, Feature::Vertex(0));
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (*b, Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + ab * v, Feature::Edge(0));
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (*c, Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + ac * w, Feature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, Feature::Edge(1));
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    (a + ab * v + ac * w, Feature::Face)
}

/// The interior angle of triangle `t` at vertex k, radians.
pub fn angle_at(t: &[Vector3<f64>; 3], k: usize) -> f64 {
    let u = t[(k + 1) % 3] - t[k];
    let v = t[(k + 2) % 3] - t[k];
    u.cross(&v).norm().atan2(u.dot(&v))
}
