//! A scalar field sampled on a regular grid, evaluated by trilinear interpolation (value
//! and gradient), and extended beyond the grid's box; on values the caller owns (no
//! allocation): the runtime's sampled mesh fields and an engine's signed-distance grid
//! ([`SdfGrid`]) alike.
//!
//! Inside the box the field is the trilinear interpolant of the eight nodes of the cell
//! (continuous; its gradient is the interpolant's, discontinuous across cell faces).
//! Outside, with p the point of the box closest to x,
//!
//! ```text
//! f(x) = f(p) + |x − p|
//! ```
//!
//! continuous across the box and 1-Lipschitz where f is; for a distance field it is an
//! upper bound of the true distance (the true distance is 1-Lipschitz) that stays within
//! f(p) of it. Its gradient is the grid gradient at p along the axes where x is within
//! the box's range, plus `(x − p)/|x − p|`.

use super::proximity::{any_unit, Proximity};
use nalgebra::Vector3;

/// Samples of a field at the nodes `origin + cell · (i, j, k)`, `i < dims[0]`, …, on
/// borrowed values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridView<'a> {
    origin: Vector3<f64>,
    cell: f64,
    dims: [usize; 3],
    /// Node (i, j, k) at `i + dims[0] (j + dims[1] k)`.
    values: &'a [f64],
}

impl<'a> GridView<'a> {
    /// The grid of `values` (node (i, j, k) at `i + dims[0] (j + dims[1] k)`); `None`
    /// unless every dimension is at least 2, `values` has one value per node and the cell
    /// is finite and > 0.
    pub fn new(
        origin: Vector3<f64>,
        cell: f64,
        dims: [usize; 3],
        values: &'a [f64],
    ) -> Option<Self> {
        let nodes = dims.iter().try_fold(1usize, |n, &d| n.checked_mul(d));
        let valid = dims.iter().all(|&n| n >= 2)
            && nodes == Some(values.len())
            && cell.is_finite()
            && cell > 0.0;
        valid.then_some(Self {
            origin,
            cell,
            dims,
            values,
        })
    }

    /// Nodes along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Edge length of a cell, m.
    pub fn cell(&self) -> f64 {
        self.cell
    }

    /// Position of node (0, 0, 0): the smallest corner of the box.
    pub fn origin(&self) -> Vector3<f64> {
        self.origin
    }

    /// The largest corner of the box.
    pub fn corner(&self) -> Vector3<f64> {
        self.node_position([self.dims[0] - 1, self.dims[1] - 1, self.dims[2] - 1])
    }

    /// Position of node `n`.
    pub fn node_position(&self, n: [usize; 3]) -> Vector3<f64> {
        self.origin + Vector3::new(n[0] as f64, n[1] as f64, n[2] as f64) * self.cell
    }

    /// Value at node `n` (`n[a] < dims[a]`).
    pub fn node(&self, n: [usize; 3]) -> f64 {
        self.values[n[0] + self.dims[0] * (n[1] + self.dims[1] * n[2])]
    }

    /// A ball (centre, radius) beyond which the field exceeds the distance to the ball:
    /// a point farther than `radius + r` from the centre has a value above r. Beyond the
    /// box the field is `f(p) + |x − p|` with p on the box's boundary, where f is at least
    /// the least boundary node value m (trilinear), and `|x − p| ≥ |x − c| − R` (c, R: the
    /// box's centre and half-diagonal); so the radius is `R + max(0, −m)`. One pass over
    /// the boundary nodes: a caller keeps the answer.
    pub fn bounding_ball(&self) -> (Vector3<f64>, f64) {
        let [nx, ny, nz] = self.dims;
        let mut least = f64::INFINITY;
        for k in 0..nz {
            for j in 0..ny {
                let whole_row = j == 0 || k == 0 || j + 1 == ny || k + 1 == nz;
                let row = (0..nx).filter(|&i| whole_row || i == 0 || i + 1 == nx);
                for i in row {
                    least = least.min(self.node([i, j, k]));
                }
            }
        }
        let (lo, hi) = (self.origin, self.corner());
        (0.5 * (lo + hi), 0.5 * (hi - lo).norm() + (-least).max(0.0))
    }

    /// Value and gradient at `x`: trilinear inside the box, extended outside (module
    /// documentation).
    pub fn sample(&self, x: &Vector3<f64>) -> (f64, Vector3<f64>) {
        let p = x.sup(&self.origin).inf(&self.corner());
        let (value, gradient) = self.trilinear(&p);
        let outside = x - p;
        let gap = outside.norm();
        if gap == 0.0 {
            return (value, gradient);
        }
        let mut g = outside / gap;
        for axis in 0..3 {
            if outside[axis] == 0.0 {
                g[axis] += gradient[axis];
            }
        }
        (value + gap, g)
    }

    /// The trilinear interpolant and its gradient at `p`, within the box.
    fn trilinear(&self, p: &Vector3<f64>) -> (f64, Vector3<f64>) {
        let u = (p - self.origin) / self.cell;
        let mut base = [0usize; 3];
        let mut t = [0.0; 3];
        for axis in 0..3 {
            let last_cell = (self.dims[axis] - 2) as f64;
            let i = crate::math::floor(u[axis]).clamp(0.0, last_cell);
            base[axis] = i as usize;
            t[axis] = (u[axis] - i).clamp(0.0, 1.0);
        }
        let [nx, ny, _] = self.dims;
        let at = |di: usize, dj: usize, dk: usize| {
            self.values[(base[0] + di) + nx * ((base[1] + dj) + ny * (base[2] + dk))]
        };
        let c = [
            [[at(0, 0, 0), at(0, 0, 1)], [at(0, 1, 0), at(0, 1, 1)]],
            [[at(1, 0, 0), at(1, 0, 1)], [at(1, 1, 0), at(1, 1, 1)]],
        ];
        let [tx, ty, tz] = t;
        let lerp = |a: f64, b: f64, s: f64| a + (b - a) * s;
        // along z, then y, then x; the derivatives from the same differences
        let z = |i: usize, j: usize| lerp(c[i][j][0], c[i][j][1], tz);
        let dz = |i: usize, j: usize| c[i][j][1] - c[i][j][0];
        let y = |i: usize| lerp(z(i, 0), z(i, 1), ty);
        let dy = |i: usize| z(i, 1) - z(i, 0);
        let dzy = |i: usize| lerp(dz(i, 0), dz(i, 1), ty);
        let value = lerp(y(0), y(1), tx);
        let gradient = Vector3::new(
            y(1) - y(0),
            lerp(dy(0), dy(1), tx),
            lerp(dzy(0), dzy(1), tx),
        ) / self.cell;
        (value, gradient)
    }
}

/// A signed distance sampled on a grid ([`GridView`]): the form a game engine builds for
/// hair (a 3D array with origin and spacing), and the runtime's sampled mesh field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SdfGrid<'a> {
    /// The samples of the signed distance, m (negative inside).
    pub grid: GridView<'a>,
}

impl SdfGrid<'_> {
    /// Signed distance (interpolated), unit outward normal (the normalised gradient of the
    /// interpolant; +z where it vanishes) and closest point `y − d n` (first order).
    pub fn query(&self, y: &Vector3<f64>) -> Proximity {
        let (distance, gradient) = self.grid.sample(y);
        let norm = gradient.norm();
        let normal = if norm > 0.0 && norm.is_finite() {
            gradient / norm
        } else {
            any_unit(&Vector3::zeros())
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
    use std::vec::Vec;

    /// The exact signed distance of a ball of radius 0.1 at the origin, sampled on a grid
    /// of cell h = 0.01 over [−0.2, 0.2]³, and read back: inside the box within the
    /// trilinear interpolation bound `(h²/8) Σ|∂²f/∂x_i²| ≤ 3h² / (8 ρ)` (ρ the least
    /// distance from the centre over the cell: the ball's distance has Hessian
    /// `(I − n nᵀ)/|x|`), the normal within 2° of the exact one; beyond the box, the
    /// extension `f(p) + |x − p|` never below the exact distance by more than that bound.
    #[test]
    fn a_sampled_ball_reads_back_within_the_interpolation_bound() {
        let (r, h, n) = (0.1, 0.01, 41usize);
        let origin = Vector3::new(-0.2, -0.2, -0.2);
        let mut values = Vec::with_capacity(n * n * n);
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let x = origin + Vector3::new(i as f64, j as f64, k as f64) * h;
                    values.push(x.norm() - r);
                }
            }
        }
        let grid = GridView::new(origin, h, [n, n, n], &values).expect("a valid grid");
        let sdf = SdfGrid { grid };
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut checked = 0;
        while checked < 400 {
            let x = Vector3::new(next(), next(), next()) * 0.3;
            let rho = x.norm() - 3f64.sqrt() * h;
            if rho < 0.05 {
                continue;
            }
            let bound = 3.0 * h * h / (8.0 * rho) * (1.0 + 1e-9) + 1e-15;
            let got = sdf.query(&x);
            let exact = x.norm() - r;
            let inside = x.iter().all(|c| c.abs() <= 0.2);
            if inside {
                assert!(
                    (got.distance - exact).abs() <= bound,
                    "{x}: {} against {exact}, bound {bound:e}",
                    got.distance
                );
                // each component of the interpolant's gradient is within h max|∂²f| ≤ h/ρ
                // of the exact one; normalising at most doubles the difference
                let turn = (got.normal - x / x.norm()).norm();
                assert!(
                    turn <= 2.0 * 3f64.sqrt() * h / rho,
                    "{x}: normal {}",
                    got.normal
                );
            } else {
                assert!(got.distance >= exact - bound, "{x}: {}", got.distance);
            }
            assert!((got.normal.norm() - 1.0).abs() < 1e-12);
            assert!((got.closest - (x - got.normal * got.distance)).norm() < 1e-15);
            checked += 1;
        }
        // a grid that does not fit its values, or with a cell that is not > 0, is refused
        assert!(GridView::new(origin, h, [n, n, n - 1], &values).is_none());
        assert!(GridView::new(origin, 0.0, [n, n, n], &values).is_none());
        assert!(GridView::new(origin, h, [1, n, n * n], &values).is_none());
    }
}
