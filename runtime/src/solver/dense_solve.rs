//! The dense SPD solves of the runtime's own computations (faer): RK4's accelerations
//! `M q̈ = F`, the static solve's Newton steps and its held tip, with a
//! workspace allocated once per strand; and the strand's kept basis of the stiffness
//! projection, which it lends to the one step. The implicit step's LU is the kernels'
//! (`superhelix_kernels::fixed`).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::{Mat, MatMut, Par};

use crate::solver::spectral_projection::SpectralProjection;

/// Workspace for solving `A x = b` with a 3N × 3N symmetric positive definite matrix.
pub struct DenseSolver {
    /// The matrix to factor; filled by the caller, overwritten by the factorisation.
    pub matrix: Mat<f64>,
    /// The right-hand side; overwritten by the solution.
    pub rhs: Mat<f64>,
    buffer: MemBuffer,
    spectral: SpectralProjection,
    /// Scale S of the coordinates (`None`: 1): the systems solved are `(S A S) y = S b`,
    /// `x = S y`, and the step's projections are taken of `S H S`, so that coordinates of
    /// very different units (a pinned root's joint, [`crate::model::ends`]) keep their
    /// digits.
    scale: Option<Vec<f64>>,
}

impl DenseSolver {
    /// Workspace for dimension n.
    pub fn new(n: usize) -> Self {
        let req = llt::factor::cholesky_in_place_scratch::<f64>(n, Par::Seq, Default::default())
            .or(llt::solve::solve_in_place_scratch::<f64>(n, 1, Par::Seq));
        DenseSolver {
            matrix: Mat::zeros(n, n),
            rhs: Mat::zeros(n, 1),
            buffer: MemBuffer::new(req),
            spectral: SpectralProjection::new(n),
            scale: None,
        }
    }

    /// This workspace with coordinates scaled by `scale` (see the field `scale`).
    pub fn with_scale(mut self, scale: Option<Vec<f64>>) -> Self {
        self.scale = scale;
        self
    }

    /// `m_ij *= (s_i s_j)^power`, `b_i *= s_i^power` with power ±1.
    fn rescale(&mut self, inverse: bool, matrix: bool, rhs: bool) {
        let Some(s) = &self.scale else { return };
        let f = |x: f64| if inverse { 1.0 / x } else { x };
        if matrix {
            for j in 0..s.len() {
                let col = self.matrix.col_as_slice_mut(j);
                for (i, m) in col.iter_mut().enumerate() {
                    *m *= f(s[i] * s[j]);
                }
            }
        }
        if rhs {
            let b = self.rhs.col_as_slice_mut(0);
            for (i, x) in b.iter_mut().enumerate() {
                *x *= f(s[i]);
            }
        }
    }

    /// The kept basis of the spectral projection (see
    /// [`SpectralProjection::basis`](super::spectral_projection::SpectralProjection::basis)).
    pub fn projection_basis(&self) -> (Vec<f64>, bool) {
        self.spectral.basis()
    }

    /// The spectral projection's kept basis, lent to the one step
    /// ([`SpectralProjection::basis_parts`](super::spectral_projection::SpectralProjection::basis_parts)),
    /// and the coordinates' scale (empty: none, [`Self::with_scale`]).
    pub fn projection_basis_parts(&mut self) -> ((&mut [f64], &mut usize, &mut bool), &[f64]) {
        (
            self.spectral.basis_parts(),
            self.scale.as_deref().unwrap_or(&[]),
        )
    }

    /// Keep `vectors` as the spectral projection's basis (see
    /// [`SpectralProjection::set_basis`](super::spectral_projection::SpectralProjection::set_basis)).
    pub fn set_projection_basis(&mut self, vectors: &[f64], negative: bool) -> bool {
        self.spectral.set_basis(vectors, negative)
    }

    /// The right-hand side as a slice.
    pub fn rhs_mut(&mut self) -> &mut [f64] {
        self.rhs.col_as_slice_mut(0)
    }

    /// The solution (after a successful solve) as a slice.
    pub fn solution(&self) -> &[f64] {
        self.rhs.col_as_slice(0)
    }

    /// Cholesky-factor `matrix` (lower triangle read) and solve in place. Returns false,
    /// leaving `rhs` untouched, when the matrix is not numerically positive definite.
    pub fn solve_spd(&mut self) -> bool {
        self.rescale(false, true, true);
        let stack = MemStack::new(&mut self.buffer);
        let ok = llt::factor::cholesky_in_place(
            self.matrix.as_mut(),
            Default::default(),
            Par::Seq,
            stack,
            Default::default(),
        )
        .is_ok();
        if !ok {
            self.rescale(true, false, true);
            return false;
        }
        let stack = MemStack::new(&mut self.buffer);
        llt::solve::solve_in_place(self.matrix.as_ref(), self.rhs.as_mut(), Par::Seq, stack);
        self.rescale(false, false, true);
        all_finite(self.rhs.as_mut())
    }

    /// Solve `A x = b` in place in `x` with the Cholesky factor of the last successful
    /// [`Self::solve_spd`] (no factorisation). Returns false when the solution is not
    /// finite.
    pub fn solve_factored_spd(&mut self, x: &mut [f64]) -> bool {
        let n = self.matrix.nrows();
        if let Some(s) = &self.scale {
            x.iter_mut().zip(s).for_each(|(x, s)| *x *= s);
        }
        let stack = MemStack::new(&mut self.buffer);
        let rhs = MatMut::from_column_major_slice_mut(x, n, 1);
        llt::solve::solve_in_place(self.matrix.as_ref(), rhs, Par::Seq, stack);
        if let Some(s) = &self.scale {
            x.iter_mut().zip(s).for_each(|(x, s)| *x *= s);
        }
        x.iter().all(|v| v.is_finite())
    }

    /// The coordinates' scale (see [`Self::with_scale`]).
    pub fn scale(&self) -> Option<&[f64]> {
        self.scale.as_deref()
    }
}

fn all_finite(m: MatMut<'_, f64>) -> bool {
    (0..m.nrows()).all(|i| m[(i, 0)].is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fill(s: &mut DenseSolver, a: &[[f64; 3]; 3], b: [f64; 3]) {
        for i in 0..3 {
            for j in 0..3 {
                s.matrix[(i, j)] = a[i][j];
            }
        }
        s.rhs_mut().copy_from_slice(&b);
    }

    #[test]
    fn cholesky_solves_and_detects_failure() {
        let spd = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]];
        let x = [1.0, -2.0, 0.5];
        let b: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|j| spd[i][j] * x[j]).sum())
            .collect();
        let mut s = DenseSolver::new(3);
        fill(&mut s, &spd, [b[0], b[1], b[2]]);
        assert!(s.solve_spd());
        for i in 0..3 {
            assert!((s.solution()[i] - x[i]).abs() < 1e-14);
        }
        // scaled coordinates: the same solution
        let mut s = DenseSolver::new(3).with_scale(Some(vec![1e-3, 1.0, 1e3]));
        fill(&mut s, &spd, [b[0], b[1], b[2]]);
        assert!(s.solve_spd());
        for i in 0..3 {
            assert!((s.solution()[i] - x[i]).abs() < 1e-12);
        }
        let nonsym = [[0.0, 2.0, 1.0], [1.0, 0.0, 3.0], [2.0, 1.0, 0.0]];
        fill(&mut s, &nonsym, [1.0, 1.0, 1.0]);
        assert!(!s.solve_spd());
        // untouched on failure (scaled and scaled back)
        assert!(s.solution().iter().all(|x| (x - 1.0).abs() < 1e-15));
        // the factors solve again
        let mut s = DenseSolver::new(3);
        fill(&mut s, &spd, [b[0], b[1], b[2]]);
        assert!(s.solve_spd());
        let mut again = b.clone();
        assert!(s.solve_factored_spd(&mut again));
        for i in 0..3 {
            assert!((again[i] - x[i]).abs() < 1e-14);
        }
    }
}
