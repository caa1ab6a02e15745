//! Dense linear solves of the step (faer), with workspaces allocated once per strand:
//! Cholesky for the SPD systems, partial-pivoting LU as the fallback.

use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::linalg::evd;
use faer::linalg::lu::partial_pivoting as lu;
use faer::{Mat, MatMut, Par};

/// Workspace for solving `A x = b` with a 3N × 3N matrix.
pub struct DenseSolver {
    /// The matrix to factor; filled by the caller, overwritten by the factorisation.
    pub matrix: Mat<f64>,
    /// The right-hand side; overwritten by the solution.
    pub rhs: Mat<f64>,
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
    buffer: MemBuffer,
    eigenvalues: Diag<f64>,
    eigenvectors: Mat<f64>,
    scaled: Mat<f64>,
    work: Mat<f64>,
    rotated: Mat<f64>,
    /// `eigenvectors` hold the eigenbasis of an earlier projection.
    basis_valid: bool,
    /// Projections that reused the eigenbasis of an earlier one.
    pub projections_reused: u64,
    /// Projections that needed an eigendecomposition.
    pub projections_decomposed: u64,
}

/// Largest coupling, relative to the matrix, between the negative and the non-negative
/// directions of an earlier eigenbasis for [`DenseSolver::project_negative_semidefinite`]
/// to reuse that basis instead of decomposing: `‖B_NP‖_F ≤ tol ‖B‖_F` with `B = Uᵀ H U`.
pub const EIGENBASIS_REUSE_TOLERANCE: f64 = 0.01;

/// Relative size (to the largest |B_ii|) below which a negative diagonal entry of the
/// rotated matrix is counted with the non-negative ones when the basis is reused: an
/// eigenvalue crossing zero then does not force a decomposition.
const NEGLIGIBLE_EIGENVALUE: f64 = 1e-3;

impl DenseSolver {
    /// Workspace for dimension n.
    pub fn new(n: usize) -> Self {
        let req = llt::factor::cholesky_in_place_scratch::<f64>(n, Par::Seq, Default::default())
            .or(llt::solve::solve_in_place_scratch::<f64>(n, 1, Par::Seq))
            .or(lu::factor::lu_in_place_scratch::<usize, f64>(
                n,
                n,
                Par::Seq,
                Default::default(),
            ))
            .or(lu::solve::solve_in_place_scratch::<usize, f64>(
                n,
                1,
                Par::Seq,
            ))
            .or(evd::self_adjoint_evd_scratch::<f64>(
                n,
                evd::ComputeEigenvectors::Yes,
                Par::Seq,
                Default::default(),
            ));
        DenseSolver {
            matrix: Mat::zeros(n, n),
            rhs: Mat::zeros(n, 1),
            perm: vec![0; n],
            perm_inv: vec![0; n],
            buffer: MemBuffer::new(req),
            eigenvalues: Diag::zeros(n),
            eigenvectors: Mat::zeros(n, n),
            scaled: Mat::zeros(n, n),
            work: Mat::zeros(n, n),
            rotated: Mat::zeros(n, n),
            basis_valid: false,
            projections_reused: 0,
            projections_decomposed: 0,
        }
    }

    /// Replace the symmetric matrix `h` (lower triangle read) by its negative
    /// semidefinite part `U min(Λ, 0) Uᵀ`: the stabilising part of a stiffness. Returns
    /// false (leaving `h` unchanged) if the eigendecomposition fails.
    ///
    /// The stiffness changes little from one step to the next, so the eigenbasis U of the
    /// previous decomposition is tried first: with `B = Uᵀ H U`, N the indices of B's
    /// negative diagonal and P the others, when the coupling `‖B_NP‖_F` is at most
    /// [`EIGENBASIS_REUSE_TOLERANCE`] `‖B‖_F` and `B_NN` is negative definite, the result
    /// is `U_N B_NN U_Nᵀ`: negative semidefinite by construction, and within
    /// `‖B_NP‖_F` of the exact part (the coupling it drops). Otherwise H is decomposed
    /// and its eigenbasis kept for the next call.
    pub fn project_negative_semidefinite(&mut self, h: &mut Mat<f64>) -> bool {
        let n = h.nrows();
        // fast path: a negative definite h (a hanging strand) is its own projection,
        // and a Cholesky factorisation of −h says so for a fraction of the cost
        for j in 0..n {
            for i in j..n {
                self.scaled[(i, j)] = -h[(i, j)];
            }
        }
        let stack = MemStack::new(&mut self.buffer);
        if llt::factor::cholesky_in_place(
            self.scaled.as_mut(),
            Default::default(),
            Par::Seq,
            stack,
            Default::default(),
        )
        .is_ok()
        {
            return true;
        }
        if self.basis_valid && self.project_in_previous_basis(h) {
            self.projections_reused += 1;
            return true;
        }
        self.projections_decomposed += 1;
        let stack = MemStack::new(&mut self.buffer);
        let ok = evd::self_adjoint_evd(
            h.as_ref(),
            self.eigenvalues.as_mut(),
            Some(self.eigenvectors.as_mut()),
            Par::Seq,
            stack,
            Default::default(),
        )
        .is_ok();
        self.basis_valid = ok;
        if !ok {
            return false;
        }
        for j in 0..n {
            let lambda = self.eigenvalues[j].min(0.0);
            for i in 0..n {
                self.scaled[(i, j)] = self.eigenvectors[(i, j)] * lambda;
            }
        }
        faer::linalg::matmul::matmul(
            h.as_mut(),
            faer::Accum::Replace,
            self.scaled.as_ref(),
            self.eigenvectors.transpose(),
            1.0,
            Par::Seq,
        );
        true
    }

    /// The reuse branch of [`Self::project_negative_semidefinite`]: false (leaving `h`
    /// unchanged) when the earlier eigenbasis does not qualify.
    fn project_in_previous_basis(&mut self, h: &mut Mat<f64>) -> bool {
        let n = h.nrows();
        // the full symmetric H from its lower triangle
        for j in 0..n {
            for i in j..n {
                let x = h[(i, j)];
                self.scaled[(i, j)] = x;
                self.scaled[(j, i)] = x;
            }
        }
        // B = Uᵀ H U
        faer::linalg::matmul::matmul(
            self.work.as_mut(),
            faer::Accum::Replace,
            self.scaled.as_ref(),
            self.eigenvectors.as_ref(),
            1.0,
            Par::Seq,
        );
        faer::linalg::matmul::matmul(
            self.rotated.as_mut(),
            faer::Accum::Replace,
            self.eigenvectors.transpose(),
            self.work.as_ref(),
            1.0,
            Par::Seq,
        );
        let b = &self.rotated;
        // N: the diagonal entries below −δ; those in [−δ, 0) join P, which drops them
        // (an error of at most δ each, far inside the coupling bound)
        let mut scale = 0.0f64;
        for j in 0..n {
            scale = scale.max(b[(j, j)].abs());
        }
        let cut = -NEGLIGIBLE_EIGENVALUE * scale;
        let mut negative = 0;
        let mut total = 0.0;
        let mut coupling = 0.0;
        for j in 0..n {
            for i in 0..n {
                let x = b[(i, j)] * b[(i, j)];
                total += x;
                if (b[(i, i)] < cut) != (b[(j, j)] < cut) {
                    coupling += x;
                }
            }
            if b[(j, j)] < cut {
                self.perm[negative] = j;
                negative += 1;
            }
        }
        // (a NaN coupling fails too)
        if coupling.is_nan()
            || coupling > EIGENBASIS_REUSE_TOLERANCE * EIGENBASIS_REUSE_TOLERANCE * total
        {
            return false;
        }
        if negative == 0 {
            h.fill(0.0);
            return true;
        }
        let k = negative;
        // −B_NN must be positive definite (an eigenvalue that crossed zero: decompose)
        for c in 0..k {
            for r in 0..k {
                self.scaled[(r, c)] = -b[(self.perm[r], self.perm[c])];
            }
        }
        let stack = MemStack::new(&mut self.buffer);
        if llt::factor::cholesky_in_place(
            self.scaled.as_mut().submatrix_mut(0, 0, k, k),
            Default::default(),
            Par::Seq,
            stack,
            Default::default(),
        )
        .is_err()
        {
            return false;
        }
        // U_N into work's first k columns, B_NN into scaled, U_N B_NN into rotated
        for c in 0..k {
            for r in 0..n {
                self.work[(r, c)] = self.eigenvectors[(r, self.perm[c])];
            }
            for r in 0..k {
                self.scaled[(r, c)] = self.rotated[(self.perm[r], self.perm[c])];
            }
        }
        faer::linalg::matmul::matmul(
            self.rotated.as_mut().submatrix_mut(0, 0, n, k),
            faer::Accum::Replace,
            self.work.as_ref().submatrix(0, 0, n, k),
            self.scaled.as_ref().submatrix(0, 0, k, k),
            1.0,
            Par::Seq,
        );
        faer::linalg::matmul::matmul(
            h.as_mut(),
            faer::Accum::Replace,
            self.rotated.as_ref().submatrix(0, 0, n, k),
            self.work.as_ref().submatrix(0, 0, n, k).transpose(),
            1.0,
            Par::Seq,
        );
        true
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
            return false;
        }
        let stack = MemStack::new(&mut self.buffer);
        llt::solve::solve_in_place(self.matrix.as_ref(), self.rhs.as_mut(), Par::Seq, stack);
        all_finite(self.rhs.as_mut())
    }

    /// LU-factor `matrix` with partial pivoting and solve in place. Returns false when
    /// the solution is not finite (singular matrix).
    pub fn solve_general(&mut self) -> bool {
        let stack = MemStack::new(&mut self.buffer);
        let (_, perm) = lu::factor::lu_in_place(
            self.matrix.as_mut(),
            &mut self.perm,
            &mut self.perm_inv,
            Par::Seq,
            stack,
            Default::default(),
        );
        let stack = MemStack::new(&mut self.buffer);
        lu::solve::solve_in_place(
            self.matrix.as_ref(),
            self.matrix.as_ref(),
            perm,
            self.rhs.as_mut(),
            Par::Seq,
            stack,
        );
        all_finite(self.rhs.as_mut())
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
    fn cholesky_and_lu_solve_and_detect_failure() {
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
        let nonsym = [[0.0, 2.0, 1.0], [1.0, 0.0, 3.0], [2.0, 1.0, 0.0]];
        let b: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|j| nonsym[i][j] * x[j]).sum())
            .collect();
        fill(&mut s, &nonsym, [b[0], b[1], b[2]]);
        assert!(!s.solve_spd());
        fill(&mut s, &nonsym, [b[0], b[1], b[2]]);
        assert!(s.solve_general());
        for i in 0..3 {
            assert!((s.solution()[i] - x[i]).abs() < 1e-14);
        }
        // projection keeps the negative part: diag(-2, 3) rotated -> its -2 part
        let mut h = Mat::<f64>::zeros(3, 3);
        let (c, sn) = (0.6, 0.8);
        let u = [[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]];
        let lam = [-2.0, 3.0, 0.0];
        for i in 0..3 {
            for j in 0..3 {
                h[(i, j)] = (0..3).map(|k| u[i][k] * lam[k] * u[j][k]).sum();
            }
        }
        assert!(s.project_negative_semidefinite(&mut h));
        for i in 0..3 {
            for j in 0..3 {
                let expected = u[i][0] * -2.0 * u[j][0];
                assert!((h[(i, j)] - expected).abs() < 1e-14);
            }
        }
        // a negative definite matrix is its own projection (Cholesky fast path)
        let mut h = Mat::from_fn(3, 3, |i, j| -spd[i][j]);
        assert!(s.project_negative_semidefinite(&mut h));
        for i in 0..3 {
            for j in 0..3 {
                assert_eq!(h[(i, j)], -spd[i][j]);
            }
        }
        let singular = [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [1.0, 0.0, 1.0]];
        fill(&mut s, &singular, [1.0, 1.0, 1.0]);
        assert!(!s.solve_general());
    }

    /// Symmetric n × n from a deterministic pseudo-random sequence.
    fn symmetric(n: usize, seed: u64, scale: f64) -> Mat<f64> {
        let mut state = seed;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let mut h = Mat::<f64>::zeros(n, n);
        for j in 0..n {
            for i in j..n {
                let x = scale * next();
                h[(i, j)] = x;
                h[(j, i)] = x;
            }
        }
        h
    }

    fn exact_projection(h: &Mat<f64>) -> Mat<f64> {
        let n = h.nrows();
        let evd = h.self_adjoint_eigen(faer::Side::Lower).unwrap();
        let (u, s) = (evd.U(), evd.S());
        Mat::from_fn(n, n, |i, j| {
            (0..n).map(|k| u[(i, k)] * s[k].min(0.0) * u[(j, k)]).sum()
        })
    }

    fn frobenius(m: &Mat<f64>) -> f64 {
        let mut s = 0.0;
        for j in 0..m.ncols() {
            for i in 0..m.nrows() {
                s += m[(i, j)] * m[(i, j)];
            }
        }
        s.sqrt()
    }

    #[test]
    fn projection_reuses_the_previous_eigenbasis_within_its_bound() {
        let n = 15;
        let mut s = DenseSolver::new(n);
        let h0 = symmetric(n, 7, 1.0);
        let mut p = h0.clone();
        assert!(s.project_negative_semidefinite(&mut p));
        assert_eq!((s.projections_decomposed, s.projections_reused), (1, 0));
        // the first call is exact
        let exact0 = exact_projection(&h0);
        assert!(frobenius(&(&p - &exact0)) < 1e-12 * frobenius(&h0));
        // a small change: the basis is reused; the result is negative semidefinite and
        // within the dropped coupling (≤ 2 ‖ΔH‖_F to first order) of the exact part
        let dh = symmetric(n, 11, 1e-3);
        let h1 = &h0 + &dh;
        let mut p = h1.clone();
        assert!(s.project_negative_semidefinite(&mut p));
        assert_eq!((s.projections_decomposed, s.projections_reused), (1, 1));
        let err = frobenius(&(&p - &exact_projection(&h1)));
        assert!(err <= 2.0 * frobenius(&dh), "{err:.3e}");
        assert!(err > 0.0);
        let eig = p.self_adjoint_eigen(faer::Side::Lower).unwrap();
        for k in 0..n {
            assert!(eig.S()[k] <= 1e-14 * frobenius(&h1), "{}", eig.S()[k]);
        }
        // a large change: decomposed again, exact
        let h2 = symmetric(n, 13, 1.0);
        let mut p = h2.clone();
        assert!(s.project_negative_semidefinite(&mut p));
        assert_eq!((s.projections_decomposed, s.projections_reused), (2, 1));
        assert!(frobenius(&(&p - &exact_projection(&h2))) < 1e-12 * frobenius(&h2));
    }
}
