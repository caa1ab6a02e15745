//! A body given as a signed distance sampled on a regular grid (`shape = "grid"`): the
//! values read from a `.npy` file, evaluated as the kernels' `SdfGrid` on a [`Grid`]
//! (trilinear inside the box, `f(p) + |x − p|` beyond it) — the code a sampled mesh
//! body and the C ABI's `SH_COLLIDER_GRID` are read with, so a grid handed to both gives
//! the same distances bit for bit.

use super::grid::Grid;
use super::proximity::Proximity;
use super::setup::MAX_GRID_NODES;
use crate::error::FieldError;
use nalgebra::Vector3;
use std::path::Path;
use superhelix_kernels::collider::SdfGrid;

/// A signed distance on a grid, and a ball beyond which a point is certainly farther
/// from the surface than from the ball.
#[derive(Debug, Clone, PartialEq)]
pub struct GridSdf {
    grid: Grid,
    /// Centre and radius of that ball.
    ball: (Vector3<f64>, f64),
}

impl GridSdf {
    /// The body of the values of `path` (float64, C order, shape `(nz, ny, nx)`, each of
    /// nz, ny, nx at least 2, at most [`MAX_GRID_NODES`] in all, every value finite) with
    /// node (0, 0, 0) at `origin` and spacing `cell` (finite, > 0). An error names the
    /// field relative to the body (`path`, `cell`) and what is wrong.
    pub fn read(path: &Path, origin: Vector3<f64>, cell: f64) -> Result<Self, FieldError> {
        let (shape, values) = crate::input::npy::read_f64(path)
            .map_err(|e| FieldError::new("path", format!("'{}': {e}", path.display())))?;
        let bad = |m: String| FieldError::new("path", format!("'{}': {m}", path.display()));
        let [nz, ny, nx] = match shape.as_slice() {
            &[nz, ny, nx] => [nz, ny, nx].map(|n| n as usize),
            other => {
                return Err(bad(format!(
                    "the grid must have 3 axes (nz, ny, nx), the file has shape {other:?}"
                )))
            }
        };
        if [nz, ny, nx].iter().any(|&n| n < 2) {
            return Err(bad(format!(
                "every axis needs at least 2 nodes, the file has shape ({nz}, {ny}, {nx})"
            )));
        }
        if values.len() > MAX_GRID_NODES {
            return Err(bad(format!(
                "{} nodes, more than the cap of {MAX_GRID_NODES}",
                values.len()
            )));
        }
        if let Some(i) = values.iter().position(|x| !x.is_finite()) {
            return Err(bad(format!("value {i} is {}: must be finite", values[i])));
        }
        let values_len = values.len();
        Self::new(origin, cell, [nx, ny, nz], values).ok_or_else(|| {
            bad(format!(
                "a grid of ({nz}, {ny}, {nx}) nodes needs {} values, the file has {}",
                nx * ny * nz,
                // (read_f64 keeps only the whole rows of a cut file)
                values_len
            ))
        })
    }

    /// The body of `values` (node (i, j, k) at `i + dims[0] (j + dims[1] k)`); `None`
    /// unless [`Grid::new`] takes them and `origin` is finite.
    pub fn new(
        origin: Vector3<f64>,
        cell: f64,
        dims: [usize; 3],
        values: Vec<f64>,
    ) -> Option<Self> {
        if !origin.iter().all(|x| x.is_finite()) {
            return None;
        }
        let grid = Grid::new(origin, cell, dims, values)?;
        let ball = grid.view().bounding_ball();
        Some(Self { grid, ball })
    }

    /// The grid of samples.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// A ball (centre, radius) such that a point farther than `radius + r` from its centre
    /// is farther than r from the surface (the kernels' `GridView::bounding_ball`, kept).
    pub fn bounding_ball(&self) -> (Vector3<f64>, f64) {
        self.ball
    }

    /// Signed distance (interpolated), unit outward normal (the normalised gradient of
    /// the interpolant; +z where it vanishes) and closest point `y − d n` (first order).
    pub fn query(&self, y: &Vector3<f64>) -> Proximity {
        SdfGrid {
            grid: self.grid.view(),
        }
        .query(y)
    }

    /// The box of the nodes inside the body (value ≤ 0), as (smallest, largest) corner;
    /// `None` when no node is inside.
    pub fn inside_box(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let [nx, ny, nz] = self.grid.dims();
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    if self.grid.node([i, j, k]) <= 0.0 {
                        let p = self.grid.node_position([i, j, k]);
                        lo = lo.inf(&p);
                        hi = hi.sup(&p);
                    }
                }
            }
        }
        (lo.x <= hi.x).then_some((lo, hi))
    }
}
