//! Dense linear solves of the step (faer), with workspaces allocated once per strand:
//! Cholesky for the SPD systems, partial-pivoting LU as the fallback.

use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::linalg::evd;
use faer::linalg::lu::partial_pivoting as lu;
use faer::{Mat, MatMut, MatRef, Par};

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
    /// The kept eigenbasis U (column-major n × n) and its spectrum (diag Uᵀ H U).
    basis: Vec<f64>,
    spectrum: Vec<f64>,
    /// Column-major n × n scratch: the full H, H U, Uᵀ H U.
    full: Vec<f64>,
    work: Vec<f64>,
    rotated: Vec<f64>,
    /// `basis` holds the eigenbasis of an earlier projection.
    basis_valid: bool,
    /// Projections that refined the eigenbasis of an earlier one (Jacobi sweeps).
    pub projections_reused: u64,
    /// Jacobi sweeps those refinements took.
    pub jacobi_sweeps: u64,
    /// Jacobi rotations those sweeps applied.
    pub jacobi_rotations: u64,
    /// Projections that needed an eigendecomposition.
    pub projections_decomposed: u64,
}

/// How close to diagonal `B = Uᵀ H U` must be for the kept eigenbasis U, refined by
/// Jacobi sweeps, to stand as H's in [`DenseSolver::project_negative_semidefinite`]:
/// `‖B − diag B‖_F ≤ tol ‖B‖_F`, which bounds the projection's error by `tol ‖H‖_F`.
pub const EIGENBASIS_TOLERANCE: f64 = 1e-3;

/// Jacobi sweeps tried on the kept basis before H is decomposed afresh.
pub const MAX_JACOBI_SWEEPS: usize = 3;

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
            basis: vec![0.0; n * n],
            spectrum: vec![0.0; n],
            full: vec![0.0; n * n],
            work: vec![0.0; n * n],
            rotated: vec![0.0; n * n],
            basis_valid: false,
            projections_reused: 0,
            jacobi_sweeps: 0,
            jacobi_rotations: 0,
            projections_decomposed: 0,
        }
    }

    /// Replace the symmetric matrix `h` (lower triangle read) by its negative
    /// semidefinite part `U min(Λ, 0) Uᵀ`: the stabilising part of a stiffness. Returns
    /// false (leaving `h` unchanged) if the eigendecomposition fails.
    ///
    /// The stiffness changes little from one step to the next, so the eigenbasis U kept
    /// from the previous call is refined rather than recomputed: `B = Uᵀ H U` is brought
    /// to within [`EIGENBASIS_TOLERANCE`] of diagonal (`‖B − diag B‖_F ≤ tol ‖B‖_F`) by
    /// cyclic Jacobi sweeps (at most [`MAX_JACOBI_SWEEPS`]; usually none or one), U
    /// rotated with it, and the result is `U min(diag B, 0) Uᵀ`: negative semidefinite by
    /// construction and, the projection onto the negative semidefinite cone being
    /// non-expansive in the Frobenius norm, within `‖B − diag B‖_F` of the exact part.
    /// When the sweeps do not get there (or on the first call), H is decomposed (faer)
    /// and its eigenbasis kept.
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
        if self.basis_valid && self.refine_previous_basis(h) {
            self.projections_reused += 1;
            self.store_negative_part(h);
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
            self.basis[j * n..(j + 1) * n].copy_from_slice(self.eigenvectors.col_as_slice(j));
            self.spectrum[j] = self.eigenvalues[j];
        }
        self.store_negative_part(h);
        true
    }

    /// `h = U min(diag, 0) Uᵀ` from the kept basis and spectrum: the negative columns
    /// of U, scaled, times their transpose.
    fn store_negative_part(&mut self, h: &mut Mat<f64>) {
        let n = h.nrows();
        let mut k = 0;
        for j in 0..n {
            let lambda = self.spectrum[j];
            if lambda < 0.0 {
                let u = &self.basis[j * n..(j + 1) * n];
                self.work[k * n..(k + 1) * n].copy_from_slice(u);
                for (x, y) in self.full[k * n..(k + 1) * n].iter_mut().zip(u) {
                    *x = lambda * y;
                }
                k += 1;
            }
        }
        if k == 0 {
            h.fill(0.0);
            return;
        }
        let scaled = MatRef::from_column_major_slice(&self.full[..k * n], n, k);
        let negative = MatRef::from_column_major_slice(&self.work[..k * n], n, k);
        faer::linalg::matmul::matmul(
            h.as_mut(),
            faer::Accum::Replace,
            scaled,
            negative.transpose(),
            1.0,
            Par::Seq,
        );
    }

    /// The refinement branch of [`Self::project_negative_semidefinite`]: `B = Uᵀ H U`
    /// for the kept basis U, Jacobi sweeps until B is within [`EIGENBASIS_TOLERANCE`] of
    /// diagonal (U rotated along, diag B into the kept spectrum). False when that takes
    /// more than [`MAX_JACOBI_SWEEPS`] sweeps (or meets a non-finite value); the basis
    /// is then to be recomputed.
    fn refine_previous_basis(&mut self, h: &Mat<f64>) -> bool {
        let n = h.nrows();
        // W = H U (H symmetric from its lower triangle), then B = Uᵀ W
        for j in 0..n {
            for i in j..n {
                let x = h[(i, j)];
                self.full[j * n + i] = x;
                self.full[i * n + j] = x;
            }
        }
        {
            let basis = MatRef::from_column_major_slice(&self.basis, n, n);
            faer::linalg::matmul::matmul(
                MatMut::from_column_major_slice_mut(&mut self.work, n, n),
                faer::Accum::Replace,
                MatRef::from_column_major_slice(&self.full, n, n),
                basis,
                1.0,
                Par::Seq,
            );
            faer::linalg::matmul::matmul(
                MatMut::from_column_major_slice_mut(&mut self.rotated, n, n),
                faer::Accum::Replace,
                basis.transpose(),
                MatRef::from_column_major_slice(&self.work, n, n),
                1.0,
                Par::Seq,
            );
        }
        let b = &mut self.rotated;
        // symmetric to round-off; exactly so from here
        for j in 0..n {
            for i in 0..j {
                let x = 0.5 * (b[j * n + i] + b[i * n + j]);
                b[j * n + i] = x;
                b[i * n + j] = x;
            }
        }
        let total: f64 = b.iter().map(|x| x * x).sum();
        let limit = EIGENBASIS_TOLERANCE * EIGENBASIS_TOLERANCE * total;
        // entries below tol ‖B‖_F / n are left: all of them together are within the target
        let skip = EIGENBASIS_TOLERANCE * total.sqrt() / n as f64;
        let off = |b: &[f64]| -> f64 {
            let mut s = 0.0;
            for j in 0..n {
                for i in 0..j {
                    s += 2.0 * b[j * n + i] * b[j * n + i];
                }
            }
            s
        };
        let mut sweeps = 0;
        loop {
            let o = off(b);
            if !o.is_finite() || !total.is_finite() {
                return false;
            }
            if o <= limit {
                break;
            }
            if sweeps == MAX_JACOBI_SWEEPS {
                return false;
            }
            sweeps += 1;
            for p in 0..n {
                for q in p + 1..n {
                    let bpq = b[q * n + p];
                    if bpq.abs() <= skip {
                        continue;
                    }
                    // the rotation that zeroes b_pq (Golub & Van Loan, sym.schur2)
                    let (bpp, bqq) = (b[p * n + p], b[q * n + q]);
                    let tau = (bqq - bpp) / (2.0 * bpq);
                    let t = if tau >= 0.0 {
                        1.0 / (tau + (1.0 + tau * tau).sqrt())
                    } else {
                        -1.0 / (-tau + (1.0 + tau * tau).sqrt())
                    };
                    let c = 1.0 / (1.0 + t * t).sqrt();
                    let s = t * c;
                    self.jacobi_rotations += 1;
                    {
                        let (lo, hi) = b.split_at_mut(q * n);
                        rotate(&mut lo[p * n..(p + 1) * n], &mut hi[..n], c, s);
                    }
                    // the rows from the columns (B symmetric)
                    for k in 0..n {
                        b[k * n + p] = b[p * n + k];
                        b[k * n + q] = b[q * n + k];
                    }
                    b[p * n + p] = bpp - t * bpq;
                    b[q * n + q] = bqq + t * bpq;
                    b[q * n + p] = 0.0;
                    b[p * n + q] = 0.0;
                    let (lo, hi) = self.basis.split_at_mut(q * n);
                    rotate(&mut lo[p * n..(p + 1) * n], &mut hi[..n], c, s);
                }
            }
        }
        self.jacobi_sweeps += sweeps as u64;
        for k in 0..n {
            self.spectrum[k] = b[k * n + k];
        }
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

/// `(x, y) ← (c x − s y, s x + c y)`, elementwise (a Jacobi rotation of two columns).
fn rotate(x: &mut [f64], y: &mut [f64], c: f64, s: f64) {
    for (a, b) in x.iter_mut().zip(y.iter_mut()) {
        let (u, v) = (*a, *b);
        *a = c * u - s * v;
        *b = s * u + c * v;
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
    fn projection_refines_the_previous_eigenbasis_within_its_bound() {
        let n = 15;
        let mut s = DenseSolver::new(n);
        let h0 = symmetric(n, 7, 1.0);
        let mut p = h0.clone();
        assert!(s.project_negative_semidefinite(&mut p));
        assert_eq!((s.projections_decomposed, s.projections_reused), (1, 0));
        // the first call is exact
        let exact0 = exact_projection(&h0);
        assert!(frobenius(&(&p - &exact0)) < 1e-12 * frobenius(&h0));
        // the same H again: the kept basis is its eigenbasis, no sweep needed
        let mut p = h0.clone();
        assert!(s.project_negative_semidefinite(&mut p));
        assert_eq!((s.projections_decomposed, s.projections_reused), (1, 1));
        assert_eq!(s.jacobi_sweeps, 0);
        assert!(frobenius(&(&p - &exact0)) < 1e-12 * frobenius(&h0));
        // changes of 1 % and 10 %: the basis is refined by Jacobi sweeps, not recomputed;
        // the result is negative semidefinite and within the tolerance of the exact part
        let mut reused = 1;
        for (seed, size) in [(11, 1e-2), (17, 1e-1)] {
            let h1 = &h0 + &symmetric(n, seed, size);
            let mut p = h1.clone();
            assert!(s.project_negative_semidefinite(&mut p));
            reused += 1;
            assert_eq!(
                (s.projections_decomposed, s.projections_reused),
                (1, reused)
            );
            let err = frobenius(&(&p - &exact_projection(&h1)));
            assert!(
                err <= EIGENBASIS_TOLERANCE * frobenius(&h1),
                "{size}: {err:.3e}"
            );
            let eig = p.self_adjoint_eigen(faer::Side::Lower).unwrap();
            for k in 0..n {
                assert!(eig.S()[k] <= 1e-14 * frobenius(&h1), "{}", eig.S()[k]);
            }
        }
        assert!(s.jacobi_sweeps >= 2, "{}", s.jacobi_sweeps);
        // an unrelated H: more than the allowed sweeps, decomposed again, exact
        let h2 = symmetric(n, 13, 1.0);
        let mut p = h2.clone();
        assert!(s.project_negative_semidefinite(&mut p));
        assert_eq!(
            (s.projections_decomposed, s.projections_reused),
            (2, reused)
        );
        assert!(frobenius(&(&p - &exact_projection(&h2))) < 1e-12 * frobenius(&h2));
    }
}
