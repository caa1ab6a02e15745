//! A solid ellipsoid: exact signed distance by the robust root-finding of Eberly,
//! "Distance from a Point to an Ellipse, an Ellipsoid, or a Hyperellipsoid" (2013).
//!
//! In the ellipsoid's axes, with half-axes sorted `e0 ≥ e1 ≥ e2` and the point y folded
//! into the first octant, the closest surface point is `xᵢ = rᵢ yᵢ / (s + rᵢ)` with
//! `rᵢ = (eᵢ/e2)²` and s the root of `F(s) = Σ (rᵢ zᵢ / (s + rᵢ))² − 1`, `zᵢ = yᵢ/eᵢ`.
//! F is strictly decreasing on the bracket `[z2 − 1, |(r0 z0, r1 z1, z2)| − 1]` (`[z2 − 1, 0]`
//! inside), so bisection to the last representable midpoint finds it in at most
//! `MAX_BISECTIONS` (1074) steps. The bisection runs in `w = s + 1` (with `rᵢ − 1` formed
//! without cancellation), which keeps full relative precision for points near the
//! shortest axis inside, where s is near −1. Points with a zero coordinate (on a symmetry
//! plane, an axis, the centre) take the lower-dimensional cases of the paper, where the
//! closest point may leave the plane (inside, near the centre).

use super::proximity::Proximity;
use crate::math::sqrt;
use nalgebra::{Matrix3, Vector3};

/// Bisection steps that exhaust a double's bracket: digits − minimum exponent.
const MAX_BISECTIONS: usize = (f64::MANTISSA_DIGITS as i32 - f64::MIN_EXP) as usize;

/// The ellipsoid `|(Rᵀ(y − c))ᵢ / aᵢ|² ≤ 1`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipsoid {
    /// Centre c, m.
    pub center: Vector3<f64>,
    /// Half-axes a, m (each > 0).
    pub radii: Vector3<f64>,
    /// R: the axes (columns) in the body's coordinates.
    pub rotation: Matrix3<f64>,
}

impl Ellipsoid {
    /// Signed distance, outward normal and closest surface point of `y`.
    pub fn query(&self, y: &Vector3<f64>) -> Proximity {
        let local = self.rotation.transpose() * (y - self.center);
        let closest = self.closest_local(&local);
        let inside = (0..3).map(|i| sq(local[i] / self.radii[i])).sum::<f64>() < 1.0;
        let gap = (local - closest).norm();
        let normal = closest.component_div(&self.radii.component_mul(&self.radii));
        let normal = self.rotation * normal.normalize();
        Proximity {
            distance: if inside { -gap } else { gap },
            normal,
            closest: self.center + self.rotation * closest,
        }
    }

    /// Whether `y` is certainly farther than `r` outside the surface, by a cheap bound:
    /// with ρ = |D⁻¹ Rᵀ(y − c)| (D the half-axes), the distance is at least
    /// (ρ − 1) min(a) when ρ > 1 (the ellipsoid scaled by ρ about its centre holds y and
    /// lies at least that far outside it).
    pub fn farther_than(&self, y: &Vector3<f64>, r: f64) -> bool {
        let local = self.rotation.transpose() * (y - self.center);
        let rho = local.component_div(&self.radii).norm();
        (rho - 1.0) * self.radii.min() > r
    }

    /// The closest surface point of `local` (ellipsoid axes, centred).
    fn closest_local(&self, local: &Vector3<f64>) -> Vector3<f64> {
        let a = self.radii;
        let mut order = [0usize, 1, 2];
        // the axes by decreasing radius, equal radii in axis order (a stable insertion
        // sort: no allocation)
        for i in 1..3 {
            let mut j = i;
            while j > 0 && a[order[j - 1]].total_cmp(&a[order[j]]).is_lt() {
                order.swap(j - 1, j);
                j -= 1;
            }
        }
        let e = order.map(|k| a[k]);
        let y = order.map(|k| local[k].abs());
        let x = closest_in_octant(e, y);
        let mut out = Vector3::zeros();
        for (slot, &k) in order.iter().enumerate() {
            out[k] = x[slot].copysign(local[k]);
        }
        out
    }
}

/// `|(a, b, c)|` without overflow.
fn robust_length(v: &[f64]) -> f64 {
    let m = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if m == 0.0 {
        return 0.0;
    }
    m * sqrt(v.iter().map(|x| sq(x / m)).sum::<f64>())
}

/// The root w of `F(w) = Σ (nᵢ / (w + qᵢ))² − 1`, nᵢ = rᵢ zᵢ, qᵢ = rᵢ − 1 (the last q is
/// 0), in the bracket `[z_last, |n|]` (upper end 1 when `g < 0`, the point inside).
///
/// This is Eberly's root in `s = w − 1`: bisecting in w keeps its relative precision
/// where the root is near `s = −1` (inside, near the shortest axis), where `s + 1` would
/// cancel.
fn root<const D: usize>(r: [f64; D], q: [f64; D], z: [f64; D], g: f64) -> f64 {
    let n: [f64; D] = core::array::from_fn(|i| r[i] * z[i]);
    let mut w0 = z[D - 1];
    let mut w1 = if g < 0.0 { 1.0 } else { robust_length(&n) };
    let mut w = w0;
    for _ in 0..MAX_BISECTIONS {
        w = 0.5 * (w0 + w1);
        if w == w0 || w == w1 {
            break;
        }
        let g: f64 = (0..D).map(|i| sq(n[i] / (w + q[i]))).sum::<f64>() - 1.0;
        if g > 0.0 {
            w0 = w;
        } else if g < 0.0 {
            w1 = w;
        } else {
            break;
        }
    }
    w
}

/// `(a/b)² − 1` without cancellation.
fn ratio_excess(a: f64, b: f64) -> f64 {
    (a - b) * (a + b) / (b * b)
}

/// Closest point of the ellipse with half-axes `e0 ≥ e1` to `(y0, y1)`, both ≥ 0.
fn closest_on_ellipse(e0: f64, e1: f64, y0: f64, y1: f64) -> (f64, f64) {
    if y1 > 0.0 {
        if y0 > 0.0 {
            let (z0, z1) = (y0 / e0, y1 / e1);
            let g = z0 * z0 + z1 * z1 - 1.0;
            if g == 0.0 {
                return (y0, y1);
            }
            let r0 = sq(e0 / e1);
            let q0 = ratio_excess(e0, e1);
            let w = root([r0, 1.0], [q0, 0.0], [z0, z1], g);
            (r0 * y0 / (w + q0), y1 / w)
        } else {
            (0.0, e1)
        }
    } else {
        let (numer0, denom0) = (e0 * y0, e0 * e0 - e1 * e1);
        if numer0 < denom0 {
            // inside near the centre on the long axis: the closest point leaves the axis
            let xde0 = numer0 / denom0;
            (e0 * xde0, e1 * sqrt((1.0 - xde0 * xde0).max(0.0)))
        } else {
            (e0, 0.0)
        }
    }
}

/// Closest point of the ellipsoid with half-axes `e0 ≥ e1 ≥ e2` to y, all yᵢ ≥ 0.
fn closest_in_octant(e: [f64; 3], y: [f64; 3]) -> [f64; 3] {
    let [e0, e1, e2] = e;
    let [y0, y1, y2] = y;
    if y2 > 0.0 {
        if y1 > 0.0 {
            if y0 > 0.0 {
                let z = [y0 / e0, y1 / e1, y2 / e2];
                let g = z.iter().map(|v| v * v).sum::<f64>() - 1.0;
                if g == 0.0 {
                    return y;
                }
                let r = [sq(e0 / e2), sq(e1 / e2), 1.0];
                let q = [ratio_excess(e0, e2), ratio_excess(e1, e2), 0.0];
                let w = root(r, q, z, g);
                [r[0] * y0 / (w + q[0]), r[1] * y1 / (w + q[1]), y2 / w]
            } else {
                let (x1, x2) = closest_on_ellipse(e1, e2, y1, y2);
                [0.0, x1, x2]
            }
        } else if y0 > 0.0 {
            let (x0, x2) = closest_on_ellipse(e0, e2, y0, y2);
            [x0, 0.0, x2]
        } else {
            [0.0, 0.0, e2]
        }
    } else {
        let (denom0, denom1) = (e0 * e0 - e2 * e2, e1 * e1 - e2 * e2);
        let (numer0, numer1) = (e0 * y0, e1 * y1);
        if numer0 < denom0 && numer1 < denom1 {
            // inside near the centre in the plane of the two long axes: the closest point
            // may leave the plane
            let (xde0, xde1) = (numer0 / denom0, numer1 / denom1);
            let discr = 1.0 - xde0 * xde0 - xde1 * xde1;
            if discr > 0.0 {
                return [e0 * xde0, e1 * xde1, e2 * sqrt(discr)];
            }
        }
        let (x0, x1) = closest_on_ellipse(e0, e1, y0, y1);
        [x0, x1, 0.0]
    }
}

/// x².
#[inline(always)]
fn sq(x: f64) -> f64 {
    x * x
}

#[cfg(test)]
mod bound_tests {
    use super::*;

    /// The cheap test never calls a point far that is within r of the surface.
    #[test]
    fn farther_than_never_misses_a_near_point() {
        let e = Ellipsoid {
            center: Vector3::new(0.01, -0.02, 0.03),
            radii: Vector3::new(0.075, 0.095, 0.11),
            rotation: nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 0.7).into_inner(),
        };
        let mut far = 0;
        for i in 0..20_000 {
            let t = i as f64;
            let y = e.center
                + Vector3::new((t * 0.731).sin(), (t * 1.313).cos(), (t * 0.419).sin()) * 0.2;
            let d = e.query(&y).distance;
            for r in [0.0, 0.002, 0.02] {
                if e.farther_than(&y, r) {
                    far += 1;
                    assert!(d > r, "{y:?}: distance {d} but called farther than {r}");
                }
            }
        }
        assert!(far > 10_000, "the test should skip most far points: {far}");
    }
}
