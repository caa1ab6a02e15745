//! Dense linear solves of the step (faer), with workspaces allocated once per strand:
//! Cholesky for the SPD systems, partial-pivoting LU as the fallback.

use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::linalg::evd;
use faer::linalg::lu::partial_pivoting as lu;
use faer::{Mat, MatMut, Par};

use crate::solver::spectral_projection::SpectralProjection;

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
    spectral: SpectralProjection,
    /// The matrix to project, column-major with both triangles.
    dense: Vec<f64>,
    /// Projections where the partial eigendecomposition failed its checks and faer's
    /// full one was used.
    pub projections_full: u64,
    /// The last projection's input (lower triangle, column-major) and result (full):
    /// a step split in two starts again from the same state, so the same stiffness.
    last_input: Vec<f64>,
    last_output: Vec<f64>,
    last_valid: bool,
    /// Projections that repeated the last one's input exactly.
    pub projections_repeated: u64,
    /// Scale S of the coordinates (`None`: 1): the systems solved are `(S A S) y = S b`,
    /// `x = S y`, and projections are taken of `S H S`, so that coordinates of very
    /// different units (a pinned root's joint, [`crate::model::ends`]) keep their digits.
    scale: Option<Vec<f64>>,
    /// Factorisations so far: which factors `matrix` holds
    /// ([`Self::factorizations`]).
    factorizations: u64,
}

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
            spectral: SpectralProjection::new(n),
            dense: vec![0.0; n * n],
            projections_full: 0,
            last_input: vec![0.0; n * n],
            last_output: vec![0.0; n * n],
            last_valid: false,
            projections_repeated: 0,
            scale: None,
            factorizations: 0,
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

    /// How many factorisations ([`Self::solve_general`], [`Self::solve_spd`]) this
    /// workspace made: the factors in `matrix` are those of the factorisation with this
    /// number, which a caller keeps to know they are still there.
    pub fn factorizations(&self) -> u64 {
        self.factorizations
    }

    /// Replace the symmetric matrix `h` (lower triangle read) by its negative
    /// semidefinite part `U min(Λ, 0) Uᵀ`: the stabilising part of a stiffness. Returns
    /// false (leaving `h` unchanged) if the eigendecomposition fails.
    ///
    /// The same input as the last call (a split step starts again from the same state)
    /// returns the last result. A negative definite `h` (a hanging strand) is its own projection, which a
    /// Cholesky factorisation of −h says for a fraction of the cost. Otherwise
    /// [`SpectralProjection`] computes it from the eigenvectors of the smaller side of
    /// the spectrum, reusing the last basis while it still splits `h` (see there); faer's
    /// full decomposition is the fallback when that fails its checks.
    pub fn project_negative_semidefinite(&mut self, h: &mut Mat<f64>) -> bool {
        let Some(s) = self.scale.take() else {
            return self.project_cached(h);
        };
        let scale = |h: &mut Mat<f64>, inverse: bool| {
            for j in 0..s.len() {
                for (i, x) in h.col_as_slice_mut(j).iter_mut().enumerate() {
                    let f = s[i] * s[j];
                    *x = if inverse { *x / f } else { *x * f };
                }
            }
        };
        scale(h, false);
        let ok = self.project_cached(h);
        scale(h, true);
        self.scale = Some(s);
        ok
    }

    /// Forget the last projection's input and result: a projection repeats the last one
    /// only within a step (a split step's first half), so that a step's result depends on
    /// the state it starts from and the kept basis, not on what the step before projected.
    pub fn forget_repeat(&mut self) {
        self.last_valid = false;
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

    /// [`Self::project_negative_semidefinite`] on `h` as it is (scaled).
    fn project_cached(&mut self, h: &mut Mat<f64>) -> bool {
        let n = h.nrows();
        let repeated = self.last_valid
            && (0..n).all(|j| {
                let col = &h.col_as_slice(j)[j..n];
                let last = &self.last_input[j * n + j..(j + 1) * n];
                col.iter()
                    .zip(last)
                    .all(|(a, b)| a.to_bits() == b.to_bits())
            });
        if repeated {
            self.projections_repeated += 1;
            for j in 0..n {
                h.col_as_slice_mut(j)[..n].copy_from_slice(&self.last_output[j * n..(j + 1) * n]);
            }
            return true;
        }
        for j in 0..n {
            self.last_input[j * n + j..(j + 1) * n].copy_from_slice(&h.col_as_slice(j)[j..n]);
        }
        self.last_valid = self.project_uncached(h);
        if self.last_valid {
            for j in 0..n {
                self.last_output[j * n..(j + 1) * n].copy_from_slice(&h.col_as_slice(j)[..n]);
            }
        }
        self.last_valid
    }

    /// [`Self::project_negative_semidefinite`] without the repeat check.
    fn project_uncached(&mut self, h: &mut Mat<f64>) -> bool {
        let n = h.nrows();
        // −H positive definite (shared with the embedded step's decision)
        for j in 0..n {
            for (i, &x) in h.col_as_slice(j)[..n].iter().enumerate().skip(j) {
                self.dense[j * n + i] = -x;
            }
        }
        if superhelix_kernels::projection::cholesky(&mut self.dense, n) {
            return true;
        }
        for j in 0..n {
            for (i, &x) in h.col_as_slice(j)[..n].iter().enumerate().skip(j) {
                self.dense[j * n + i] = x;
                self.dense[i * n + j] = x;
            }
        }
        if self.spectral.negative_part(&mut self.dense) {
            for j in 0..n {
                h.col_as_slice_mut(j)[..n].copy_from_slice(&self.dense[j * n..(j + 1) * n]);
            }
            return true;
        }
        self.spectral.forget_basis();
        self.projections_full += 1;
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

    /// Projections that reused the basis of an earlier one.
    pub fn projections_reused(&self) -> u64 {
        self.spectral.reused
    }

    /// Projections that needed a (partial) eigendecomposition.
    pub fn projections_decomposed(&self) -> u64 {
        self.spectral.decomposed
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
        self.factorizations += 1;
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

    /// LU-factor `matrix` with partial pivoting and solve in place. Returns false when
    /// the solution is not finite (singular matrix).
    pub fn solve_general(&mut self) -> bool {
        self.factorizations += 1;
        self.rescale(false, true, true);
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
        self.rescale(false, false, true);
        all_finite(self.rhs.as_mut())
    }
}

impl DenseSolver {
    /// Solve `A x = b` in place in `x` (n entries) with the LU factors of the last
    /// [`Self::solve_general`] (no factorisation). Returns false when the solution is not
    /// finite.
    pub fn solve_factored(&mut self, x: &mut [f64]) -> bool {
        let n = self.matrix.nrows();
        if let Some(s) = &self.scale {
            x.iter_mut().zip(s).for_each(|(x, s)| *x *= s);
        }
        let perm = faer::perm::PermRef::new_checked(&self.perm, &self.perm_inv, n);
        let stack = MemStack::new(&mut self.buffer);
        let rhs = MatMut::from_column_major_slice_mut(x, n, 1);
        lu::solve::solve_in_place(
            self.matrix.as_ref(),
            self.matrix.as_ref(),
            perm,
            rhs,
            Par::Seq,
            stack,
        );
        if let Some(s) = &self.scale {
            x.iter_mut().zip(s).for_each(|(x, s)| *x *= s);
        }
        x.iter().all(|v| v.is_finite())
    }
}

impl DenseSolver {
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
        assert_eq!((s.projections_decomposed(), s.projections_reused()), (1, 0));
        // the first call is exact
        let exact0 = exact_projection(&h0);
        assert!(frobenius(&(&p - &exact0)) < 1e-12 * frobenius(&h0));
        // a small change: the basis is reused; the result is negative semidefinite and
        // within the dropped coupling (≤ 2 ‖ΔH‖_F to first order) of the exact part
        let dh = symmetric(n, 11, 1e-3);
        let h1 = &h0 + &dh;
        let mut p = h1.clone();
        assert!(s.project_negative_semidefinite(&mut p));
        assert_eq!((s.projections_decomposed(), s.projections_reused()), (1, 1));
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
        assert_eq!((s.projections_decomposed(), s.projections_reused()), (2, 1));
        assert!(frobenius(&(&p - &exact_projection(&h2))) < 1e-12 * frobenius(&h2));
    }

    /// A split step projects the same stiffness again: the cached result comes back
    /// without a decomposition, and any change of the input (one ulp) is projected anew.
    #[test]
    fn repeated_input_returns_the_cached_projection() {
        let n = 15;
        let mut s = DenseSolver::new(n);
        let h0 = symmetric(n, 21, 1.0);
        let mut first = h0.clone();
        assert!(s.project_negative_semidefinite(&mut first));
        let mut again = h0.clone();
        assert!(s.project_negative_semidefinite(&mut again));
        assert_eq!(s.projections_repeated, 1);
        assert_eq!(s.projections_decomposed() + s.projections_reused(), 1);
        assert!(frobenius(&(&first - &again)) == 0.0);
        let mut changed = h0.clone();
        changed[(3, 2)] = f64::from_bits(changed[(3, 2)].to_bits() + 1);
        assert!(s.project_negative_semidefinite(&mut changed));
        assert_eq!(s.projections_repeated, 1);
        assert_eq!(s.projections_decomposed() + s.projections_reused(), 2);
    }
}
