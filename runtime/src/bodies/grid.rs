//! A scalar field sampled on a regular grid, on values this type owns: the runtime's
//! sampled mesh fields ([`super::mesh_sdf`]). The sampling — trilinear inside the box,
//! `f(p) + |x − p|` beyond it — is superhelix-kernels' [`GridView`] on these values (the
//! same code an engine's signed-distance grid is read with).

use nalgebra::Vector3;
use superhelix_kernels::collider::GridView;

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
    /// is finite and > 0 ([`GridView::new`]).
    pub fn new(
        origin: Vector3<f64>,
        cell: f64,
        dims: [usize; 3],
        values: Vec<f64>,
    ) -> Option<Self> {
        GridView::new(origin, cell, dims, &values)?;
        Some(Self {
            origin,
            cell,
            dims,
            values,
        })
    }

    /// The grid as the kernels read it.
    pub fn view(&self) -> GridView<'_> {
        GridView::new(self.origin, self.cell, self.dims, &self.values)
            .expect("a Grid's layout was checked when it was made and never changes")
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
        self.view().corner()
    }

    /// Position of node `n`.
    pub fn node_position(&self, n: [usize; 3]) -> Vector3<f64> {
        self.view().node_position(n)
    }

    /// Value at node `n`.
    pub fn node(&self, n: [usize; 3]) -> f64 {
        self.view().node(n)
    }

    /// Value and gradient at `x`: trilinear inside the box, extended outside
    /// ([`GridView::sample`]).
    pub fn sample(&self, x: &Vector3<f64>) -> (f64, Vector3<f64>) {
        self.view().sample(x)
    }
}
