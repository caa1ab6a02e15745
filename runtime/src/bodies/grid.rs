//! A scalar field sampled on a regular grid, evaluated by trilinear interpolation (value
//! and gradient), and extended beyond the grid's box.
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

use nalgebra::Vector3;

/// Samples of a field at the nodes `origin + cell · (i, j, k)`, `i < dims[0]`, ….
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    origin: Vector3<f64>,
    cell: f64,
    dims: [usize; 3],
    /// Node (i, j, k) at `i + dims[0] (j + dims[1] k)`.
    values: Vec<f64>,
}

impl Grid {
    /// The grid of `values` (node (i, j, k) at `i + dims[0] (j + dims[1] k)`); `None`
    /// unless every dimension is at least 2, `values` has one value per node and the cell
    /// is finite and > 0.
    pub fn new(
        origin: Vector3<f64>,
        cell: f64,
        dims: [usize; 3],
        values: Vec<f64>,
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

    /// Value at node `n`.
    pub fn node(&self, n: [usize; 3]) -> f64 {
        self.values[n[0] + self.dims[0] * (n[1] + self.dims[1] * n[2])]
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
            let i = u[axis].floor().clamp(0.0, last_cell);
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
