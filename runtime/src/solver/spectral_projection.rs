//! The negative semidefinite part `H⁻ = U min(Λ, 0) Uᵀ` of a symmetric matrix from a
//! partial eigendecomposition: only the eigenvectors of the smaller side of the spectrum
//! (the negative eigenvalues, or the positive ones with `H⁻ = H − H⁺`).
//!
//! The step needs H⁻ of the field stiffness (see `solver/system.rs`), and a full
//! eigendecomposition (faer's `self_adjoint_evd`, ~150k instructions for 15 × 15) was
//! the largest single cost of a generated N = 5 step. Neither faer nor nalgebra exposes
//! a subset of eigenvectors (LAPACK's `dstebz`/`dstein` route), so this module does it
//! with the textbook algorithms, allocation-free in a workspace sized once:
//!
//! 1. Householder tridiagonalisation `A = Q T Qᵀ`, the reflectors kept (not Q);
//! 2. all eigenvalues of T by Reinsch's rational QL (implicit Wilkinson shifts on the
//!    squared couplings, no square roots), without vectors;
//! 3. for each eigenvalue of the smaller side, inverse iteration on `T − λI`
//!    (tridiagonal LU with partial pivoting), reorthogonalised against the vectors of
//!    nearby eigenvalues (within `1e-3 ‖T‖`, LAPACK's `dstein` criterion);
//! 4. back-transformation `u = Q y` with the reflectors, and the rank-k sum.
//!
//! On the N = 5 bench strand (15 × 15, 6–10 negative eigenvalues) this costs ~97k
//! instructions against faer's ~150k for the full decomposition.
//!
//! The stiffness changes little from one step to the next, so the basis U (n × k) of
//! the side computed last time is tried first. With `W = H U`, `B = Uᵀ W` and the
//! coupling `C = W − U B` (`‖C‖_F = ‖U_oᵀ H U‖_F`, U_o the other side), when
//! `‖C‖_F ≤` [`BASIS_REUSE_TOLERANCE`] `‖H‖_F` and H still splits with the same signs on
//! the two subspaces (checked by Cholesky factorisations, up to a negligible
//! [`NEGLIGIBLE_EIGENVALUE`] `‖H‖_F` on the dropped side), the result is H compressed
//! to its negative subspace: `U B Uᵀ` when U spans the negative side, else
//! `G = (I − UUᵀ) H (I − UUᵀ) = H − U Wᵀ − C Uᵀ`. Both are negative semidefinite by
//! construction and within `‖C‖_F`-order of the exact part (the coupling they drop).
//!
//! Every eigenpair is checked: its residual `‖T y − λ y‖` must be at most
//! `RESIDUAL_TOLERANCE · n ε ‖T‖`. When one is not (or anything is not finite), the call
//! returns false and the caller falls back to the full decomposition, so a failure here
//! costs time, never accuracy.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};

/// Allowed residual of an eigenpair, in units of `n ε ‖T‖`.
const RESIDUAL_TOLERANCE: f64 = 64.0;

/// Inverse-iteration sweeps per eigenvector before the residual test gives up.
const MAX_INVERSE_ITERATIONS: usize = 6;

/// Rational QL sweeps per eigenvalue before giving up.
const MAX_QL_ITERATIONS: usize = 60;

/// Largest coupling, relative to the matrix, between the two sides of the spectrum in
/// an earlier basis for [`SpectralProjection::negative_part`] to reuse that basis
/// instead of decomposing: `‖Uᵀ H (I − U Uᵀ)‖_F ≤ tol ‖H‖_F`.
pub const BASIS_REUSE_TOLERANCE: f64 = 0.01;

/// Size, relative to `‖H‖_F`, below which a negative eigenvalue of H restricted to the
/// non-negative side of a reused basis is dropped (counted with the non-negative ones):
/// an eigenvalue crossing zero then does not force a decomposition.
pub const NEGLIGIBLE_EIGENVALUE: f64 = 1e-3;

/// Workspace for [`SpectralProjection::negative_part`] at one dimension.
pub struct SpectralProjection {
    n: usize,
    /// Column-major copy of the matrix; the Householder vectors below its subdiagonal.
    a: Vec<f64>,
    tau: Vec<f64>,
    diag: Vec<f64>,
    off: Vec<f64>,
    eigenvalues: Vec<f64>,
    /// Eigenvalues of the side being computed, their indices into `vectors`.
    selected: Vec<f64>,
    /// Eigenvectors of T (column-major, one column per selected eigenvalue).
    vectors: Vec<f64>,
    scratch: Vec<f64>,
    u0: Vec<f64>,
    u1: Vec<f64>,
    u2: Vec<f64>,
    mult: Vec<f64>,
    pivot: Vec<bool>,
    x: Vec<f64>,
    /// `H U` and its part outside span(U) (n × k each), and `Uᵀ H U` (k × k), for the
    /// reuse test.
    hu: Vec<f64>,
    coupling: Vec<f64>,
    rotated: Vec<f64>,
    buffer: MemBuffer,
    /// Columns of `vectors` that hold the last decomposition's basis (0: none).
    basis_k: usize,
    /// Whether that basis spans the negative (else the positive) eigenvalues.
    basis_negative: bool,
    /// Projections that reused the basis of an earlier one.
    pub reused: u64,
    /// Projections that needed a (partial) eigendecomposition.
    pub decomposed: u64,
}

impl SpectralProjection {
    /// Workspace for n × n matrices.
    pub fn new(n: usize) -> Self {
        SpectralProjection {
            n,
            a: vec![0.0; n * n],
            tau: vec![0.0; n],
            diag: vec![0.0; n],
            off: vec![0.0; n],
            eigenvalues: vec![0.0; n],
            selected: vec![0.0; n],
            vectors: vec![0.0; n * n],
            scratch: vec![0.0; n],
            u0: vec![0.0; n],
            u1: vec![0.0; n],
            u2: vec![0.0; n],
            mult: vec![0.0; n],
            pivot: vec![false; n],
            x: vec![0.0; n],
            hu: vec![0.0; n * n],
            coupling: vec![0.0; n * n],
            rotated: vec![0.0; 2 * n * n],
            buffer: MemBuffer::new(llt::factor::cholesky_in_place_scratch::<f64>(
                n,
                Par::Seq,
                Default::default(),
            )),
            basis_k: 0,
            basis_negative: true,
            reused: 0,
            decomposed: 0,
        }
    }

    /// Forget the basis of the last decomposition: the next call decomposes.
    pub fn forget_basis(&mut self) {
        self.basis_k = 0;
    }

    /// Replace the symmetric matrix `h` (n × n, column-major, both triangles filled) by
    /// its negative semidefinite part. Returns false, leaving `h` unchanged, when it holds
    /// a value that is not finite or an eigenpair fails its residual check.
    pub fn negative_part(&mut self, h: &mut [f64]) -> bool {
        let n = self.n;
        assert_eq!(h.len(), n * n, "SpectralProjection: matrix size");
        let largest = h.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if !largest.is_finite() {
            return false;
        }
        if largest == 0.0 {
            return true;
        }
        if self.basis_k > 0 && self.project_in_basis(h) {
            self.reused += 1;
            return true;
        }
        self.basis_k = 0;
        self.decomposed += 1;
        // work on H / 2^e with its largest entry in [0.5, 1) (exact): the QL rotations
        // may then take sqrt(f² + g²) instead of hypot without overflow or underflow
        let scale = power_of_two_above(largest);
        let inverse = 1.0 / scale;
        for (a, x) in self.a.iter_mut().zip(h.iter()) {
            *a = x * inverse;
        }
        self.tridiagonalise();
        self.eigenvalues.copy_from_slice(&self.diag);
        // e[i] couples diag i and i + 1
        self.scratch.copy_from_slice(&self.off);
        if !ql_eigenvalues(&mut self.eigenvalues, &mut self.scratch) {
            return false;
        }
        let t_norm = self.tridiagonal_norm();
        if !t_norm.is_finite() {
            return false;
        }
        let negative = self.eigenvalues.iter().filter(|&&l| l < 0.0).count();
        let positive = self.eigenvalues.iter().filter(|&&l| l > 0.0).count();
        if negative == 0 {
            h.fill(0.0);
            return true;
        }
        if positive == 0 {
            return true;
        }
        // the smaller side: H⁻ = Σ_{λ<0} λ u uᵀ, or H − Σ_{λ>0} λ u uᵀ
        let from_negative = negative <= positive;
        let mut k = 0;
        for i in 0..n {
            let l = self.eigenvalues[i];
            if (from_negative && l < 0.0) || (!from_negative && l > 0.0) {
                self.selected[k] = l;
                k += 1;
            }
        }
        // nearby eigenvalues adjacent after sorting, for the reorthogonalisation
        self.selected[..k].sort_by(f64::total_cmp);
        let cluster = 1e-3 * t_norm;
        let tolerance = RESIDUAL_TOLERANCE * n as f64 * f64::EPSILON * t_norm;
        let perturbation = f64::EPSILON * t_norm;
        let mut cluster_start = 0;
        for j in 0..k {
            if j > 0 && self.selected[j] - self.selected[j - 1] > cluster {
                cluster_start = j;
            }
            if !self.inverse_iteration(j, cluster_start, perturbation, tolerance) {
                return false;
            }
        }
        // back to the original coordinates, u = Q y, in place; kept for the next call
        self.apply_q(k);
        self.basis_k = k;
        self.basis_negative = from_negative;
        // the rank-k sum, lower triangle, then mirrored
        let sign = if from_negative { 1.0 } else { -1.0 };
        for c in 0..n {
            let col = &mut self.a[c * n + c..(c + 1) * n];
            if from_negative {
                col.fill(0.0);
            } else {
                for (a, x) in col.iter_mut().zip(&h[c * n + c..(c + 1) * n]) {
                    *a = x * inverse;
                }
            }
            for j in 0..k {
                let u = &self.vectors[j * n..(j + 1) * n];
                let s = sign * self.selected[j] * u[c];
                for (a, &ur) in col.iter_mut().zip(&u[c..]) {
                    *a += s * ur;
                }
            }
        }
        if !self.a.iter().all(|x| x.is_finite()) {
            return false;
        }
        for c in 0..n {
            for r in c..n {
                let x = self.a[c * n + r] * scale;
                h[c * n + r] = x;
                h[r * n + c] = x;
            }
        }
        true
    }

    /// The reuse branch of [`Self::negative_part`] (see the module page): false, with
    /// `h` unchanged, when the basis of the last decomposition does not qualify.
    fn project_in_basis(&mut self, h: &mut [f64]) -> bool {
        let (n, k) = (self.n, self.basis_k);
        let u = &self.vectors[..k * n];
        let total: f64 = h.iter().map(|x| x * x).sum();
        let bound = BASIS_REUSE_TOLERANCE * BASIS_REUSE_TOLERANCE * total;
        // W = H U, B = Uᵀ W (k × k), C = W − U B (faer's products: runtime-vectorised)
        let um = MatRef::from_column_major_slice(u, n, k);
        let hm = MatRef::from_column_major_slice(&h[..], n, n);
        matmul(
            MatMut::from_column_major_slice_mut(&mut self.hu[..n * k], n, k),
            Accum::Replace,
            hm,
            um,
            1.0,
            Par::Seq,
        );
        let wm = MatRef::from_column_major_slice(&self.hu[..n * k], n, k);
        matmul(
            MatMut::from_column_major_slice_mut(&mut self.rotated[..k * k], k, k),
            Accum::Replace,
            um.transpose(),
            wm,
            1.0,
            Par::Seq,
        );
        self.coupling[..n * k].copy_from_slice(&self.hu[..n * k]);
        matmul(
            MatMut::from_column_major_slice_mut(&mut self.coupling[..n * k], n, k),
            Accum::Add,
            um,
            MatRef::from_column_major_slice(&self.rotated[..k * k], k, k),
            -1.0,
            Par::Seq,
        );
        let coupling: f64 = self.coupling[..n * k].iter().map(|x| x * x).sum();
        if coupling.is_nan() || coupling > bound {
            return false;
        }
        let norm = total.sqrt();
        let cut = NEGLIGIBLE_EIGENVALUE * norm;
        let negative = self.basis_negative;
        // the k × k block: −B positive definite (negative side) or B + cut I positive
        // semidefinite up to the cut (positive side), into `a`
        for j in 0..k {
            for i in 0..k {
                let b = self.rotated[j * k + i];
                self.a[j * k + i] = if negative {
                    -b
                } else {
                    b + if i == j { cut } else { 0.0 }
                };
            }
        }
        if !cholesky(&mut self.a, k, &mut self.buffer) {
            return false;
        }
        // G = (I − UUᵀ) H (I − UUᵀ) = H − U Wᵀ − C Uᵀ (lower triangle), and the other
        // side's check: G + cut I + ‖H‖ UUᵀ (negative side: the rest non-negative up to
        // the cut) or −G + ‖H‖ UUᵀ (positive side: the rest negative definite)
        let sign = if negative { 1.0 } else { -1.0 };
        let g_all = &mut self.rotated[k * k..k * k + n * n];
        g_all.copy_from_slice(h);
        let cm = MatRef::from_column_major_slice(&self.coupling[..n * k], n, k);
        let wm = MatRef::from_column_major_slice(&self.hu[..n * k], n, k);
        {
            let mut gm = MatMut::from_column_major_slice_mut(g_all, n, n);
            matmul(gm.as_mut(), Accum::Add, um, wm.transpose(), -1.0, Par::Seq);
            matmul(gm.as_mut(), Accum::Add, cm, um.transpose(), -1.0, Par::Seq);
        }
        matmul(
            MatMut::from_column_major_slice_mut(&mut self.a[..n * n], n, n),
            Accum::Replace,
            um,
            um.transpose(),
            norm,
            Par::Seq,
        );
        for c in 0..n {
            let m = &mut self.a[c * n + c..(c + 1) * n];
            for (mr, &gr) in m.iter_mut().zip(&g_all[c * n + c..(c + 1) * n]) {
                *mr += sign * gr;
            }
            if negative {
                m[0] += cut;
            }
        }
        if !cholesky(&mut self.a, n, &mut self.buffer) {
            return false;
        }
        if negative {
            // U B Uᵀ: (U B) into `coupling`, then (U B) Uᵀ
            matmul(
                MatMut::from_column_major_slice_mut(&mut self.coupling[..n * k], n, k),
                Accum::Replace,
                um,
                MatRef::from_column_major_slice(&self.rotated[..k * k], k, k),
                1.0,
                Par::Seq,
            );
            matmul(
                MatMut::from_column_major_slice_mut(h, n, n),
                Accum::Replace,
                MatRef::from_column_major_slice(&self.coupling[..n * k], n, k),
                um.transpose(),
                1.0,
                Par::Seq,
            );
            // exactly symmetric
            mirror_lower(h, n);
        } else {
            h.copy_from_slice(&self.rotated[k * k..k * k + n * n]);
            mirror_lower(h, n);
        }
        true
    }

    /// Householder reduction of `a` (lower triangle read) to tridiagonal form: `diag`,
    /// `off` (coupling i and i + 1), the reflector `I − τ_k v_k v_kᵀ` (acting on rows
    /// k + 1 ..) stored as v_k in column k from row k + 1 and τ_k in `tau`.
    fn tridiagonalise(&mut self) {
        let n = self.n;
        let p = &mut self.x;
        for k in 0..n.saturating_sub(2) {
            let m = n - k - 1;
            let (head, tail) = self.a.split_at_mut((k + 1) * n);
            let v = &mut head[k * n + k + 1..];
            let x0 = v[0];
            let sigma: f64 = v[1..].iter().map(|x| x * x).sum();
            if sigma == 0.0 {
                self.tau[k] = 0.0;
                self.off[k] = x0;
                continue;
            }
            let norm = (x0 * x0 + sigma).sqrt();
            let alpha = if x0 >= 0.0 { -norm } else { norm };
            v[0] = x0 - alpha;
            let tau = 2.0 / (v[0] * v[0] + sigma);
            self.tau[k] = tau;
            self.off[k] = alpha;
            let v = &*v;
            // p = τ A₂₂ v over rows/columns k + 1 .. (symmetric, lower triangle)
            let p = &mut p[..m];
            p.fill(0.0);
            for jj in 0..m {
                let col = &tail[jj * n + k + 1 + jj..(jj + 1) * n];
                let vj = v[jj];
                let mut dot = col[0] * vj;
                for ((pi, &aij), &vi) in p[jj + 1..].iter_mut().zip(&col[1..]).zip(&v[jj + 1..]) {
                    *pi += aij * vj;
                    dot += aij * vi;
                }
                p[jj] += dot;
            }
            let mut vp = 0.0;
            for (pi, &vi) in p.iter_mut().zip(v) {
                *pi *= tau;
                vp += vi * *pi;
            }
            // w = p − (τ/2)(vᵀp) v; A₂₂ −= v wᵀ + w vᵀ
            let half = 0.5 * tau * vp;
            for (pi, &vi) in p.iter_mut().zip(v) {
                *pi -= half * vi;
            }
            for jj in 0..m {
                let col = &mut tail[jj * n + k + 1 + jj..(jj + 1) * n];
                let (vj, wj) = (v[jj], p[jj]);
                for ((aij, &vi), &wi) in col.iter_mut().zip(&v[jj..]).zip(&p[jj..]) {
                    *aij -= vi * wj + wi * vj;
                }
            }
        }
        for i in 0..n {
            self.diag[i] = self.a[i * n + i];
        }
        if n >= 2 {
            self.off[n - 2] = self.a[(n - 2) * n + n - 1];
        }
        self.off[n - 1] = 0.0;
    }

    /// `max_i |e_{i−1}| + |d_i| + |e_i|`: the 1-norm of T (= ‖H‖₁ up to rounding's
    /// change of basis; a bound of ‖T‖₂).
    fn tridiagonal_norm(&self) -> f64 {
        let n = self.n;
        let mut m = 0.0f64;
        for i in 0..n {
            let mut s = self.diag[i].abs();
            if i > 0 {
                s += self.off[i - 1].abs();
            }
            if i + 1 < n {
                s += self.off[i].abs();
            }
            m = m.max(s);
        }
        m
    }

    /// Eigenvector j of T for `selected[j]` into column j of `vectors`, orthogonal to
    /// columns `cluster_start .. j` (the nearby eigenvalues). False when it does not
    /// reach the residual tolerance.
    fn inverse_iteration(
        &mut self,
        j: usize,
        cluster_start: usize,
        perturbation: f64,
        tolerance: f64,
    ) -> bool {
        let n = self.n;
        let lambda = self.selected[j];
        self.factor_shifted(lambda, perturbation);
        // a deterministic start vector with components in every direction
        let mut state = 0x9E37_79B9_7F4A_7C15u64 ^ (j as u64).wrapping_mul(0xD1B5_4A32_D192_ED03);
        for i in 0..n {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            self.x[i] = 0.5 + (state >> 11) as f64 / (1u64 << 53) as f64;
        }
        // after the residual test passes, one more sweep (LAPACK's `dstein` takes two)
        // takes the vector from "good enough" to rounding level
        let mut converged = false;
        for _ in 0..MAX_INVERSE_ITERATIONS {
            self.solve_shifted();
            // reorthogonalise against the cluster (modified Gram–Schmidt)
            for c in cluster_start..j {
                let y = &self.vectors[c * n..(c + 1) * n];
                let mut dot = 0.0;
                for i in 0..n {
                    dot += y[i] * self.x[i];
                }
                for i in 0..n {
                    self.x[i] -= dot * y[i];
                }
            }
            let norm = self.x.iter().map(|v| v * v).sum::<f64>().sqrt();
            if !(norm.is_finite() && norm > 0.0) {
                return false;
            }
            let inverse = 1.0 / norm;
            for v in self.x.iter_mut() {
                *v *= inverse;
            }
            if converged {
                self.vectors[j * n..(j + 1) * n].copy_from_slice(&self.x);
                return true;
            }
            converged = self.residual(lambda) <= tolerance;
        }
        false
    }

    /// `‖T x − λ x‖₂` for the unit vector `x`.
    fn residual(&self, lambda: f64) -> f64 {
        let n = self.n;
        let (d, e, x) = (&self.diag, &self.off, &self.x);
        let mut s = 0.0;
        for i in 0..n {
            let mut r = (d[i] - lambda) * x[i];
            if i > 0 {
                r += e[i - 1] * x[i - 1];
            }
            if i + 1 < n {
                r += e[i] * x[i + 1];
            }
            s += r * r;
        }
        s.sqrt()
    }

    /// LU factorisation with partial pivoting of `T − λI`: U with diagonals u0 (stored
    /// as reciprocals), u1, u2, the multipliers and row swaps of L. Zero pivots become
    /// `perturbation` (inverse iteration wants the near-singular solve).
    fn factor_shifted(&mut self, lambda: f64, perturbation: f64) {
        let n = self.n;
        let (d, e) = (&self.diag, &self.off);
        let mut cur_d = d[0] - lambda;
        let mut cur_u1 = if n > 1 { e[0] } else { 0.0 };
        for i in 0..n - 1 {
            let below_d = e[i];
            let below_u1 = d[i + 1] - lambda;
            let below_u2 = if i + 2 < n { e[i + 1] } else { 0.0 };
            if cur_d.abs() >= below_d.abs() {
                if cur_d == 0.0 {
                    cur_d = perturbation;
                }
                let m = below_d / cur_d;
                self.u0[i] = cur_d;
                self.u1[i] = cur_u1;
                self.u2[i] = 0.0;
                self.pivot[i] = false;
                self.mult[i] = m;
                cur_d = below_u1 - m * cur_u1;
                cur_u1 = below_u2;
            } else {
                let m = cur_d / below_d;
                self.u0[i] = below_d;
                self.u1[i] = below_u1;
                self.u2[i] = below_u2;
                self.pivot[i] = true;
                self.mult[i] = m;
                cur_d = cur_u1 - m * below_u1;
                cur_u1 = -m * below_u2;
            }
        }
        self.u0[n - 1] = if cur_d == 0.0 { perturbation } else { cur_d };
        // the back substitution multiplies by the reciprocal pivots: its chain of
        // dependent operations then has no division (each factorisation serves two or
        // more solves)
        for u in self.u0[..n].iter_mut() {
            *u = 1.0 / *u;
        }
    }

    /// Solve `(T − λI) x_new = x` in place with the factors of [`Self::factor_shifted`].
    fn solve_shifted(&mut self) {
        let n = self.n;
        let x = &mut self.x;
        for i in 0..n - 1 {
            if self.pivot[i] {
                x.swap(i, i + 1);
            }
            x[i + 1] -= self.mult[i] * x[i];
        }
        for i in (0..n).rev() {
            let mut s = x[i];
            if i + 1 < n {
                s -= self.u1[i] * x[i + 1];
            }
            if i + 2 < n {
                s -= self.u2[i] * x[i + 2];
            }
            x[i] = s * self.u0[i];
        }
    }

    /// The first k columns of `vectors` from T's coordinates to the matrix's:
    /// `u = H₀ H₁ ⋯ y`.
    fn apply_q(&mut self, k: usize) {
        let n = self.n;
        for r in (0..n.saturating_sub(2)).rev() {
            let tau = self.tau[r];
            if tau == 0.0 {
                continue;
            }
            let v = &self.a[r * n + r + 1..(r + 1) * n];
            for y in self.vectors[..k * n].chunks_exact_mut(n) {
                let y = &mut y[r + 1..];
                let dot: f64 = v.iter().zip(y.iter()).map(|(a, b)| a * b).sum();
                let s = tau * dot;
                for (yi, &vi) in y.iter_mut().zip(v) {
                    *yi -= s * vi;
                }
            }
        }
    }
}

/// The power of two just above the finite positive `x` (1 for a subnormal `x`, which
/// needs no protection from overflow).
fn power_of_two_above(x: f64) -> f64 {
    let exponent = (x.to_bits() >> 52) & 0x7ff;
    if exponent == 0 || exponent >= 0x7fe {
        return 1.0;
    }
    f64::from_bits((exponent + 1) << 52)
}

/// Copy the lower triangle of the n × n column-major `a` onto its upper triangle.
fn mirror_lower(a: &mut [f64], n: usize) {
    for c in 0..n {
        for r in c + 1..n {
            a[r * n + c] = a[c * n + r];
        }
    }
}

/// Cholesky factorisation in place of the m × m matrix at the start of `a`
/// (column-major, stride m, lower triangle read): whether it is positive definite.
fn cholesky(a: &mut [f64], m: usize, buffer: &mut MemBuffer) -> bool {
    let view = MatMut::from_column_major_slice_mut(&mut a[..m * m], m, m);
    llt::factor::cholesky_in_place(
        view,
        Default::default(),
        Par::Seq,
        MemStack::new(buffer),
        Default::default(),
    )
    .is_ok()
}

/// All eigenvalues of the symmetric tridiagonal matrix (`d`, `e` with `e[i]` coupling
/// i and i + 1, `e[n−1]` unused), overwriting `d` (in no particular order); `e` is
/// destroyed. False when an eigenvalue does not converge.
///
/// Reinsch's rational QL method (C. H. Reinsch, "A stable rational QR algorithm for the
/// computation of the eigenvalues of an Hermitian, tridiagonal matrix", Math. Comp. 25,
/// 1971, and Algorithm 464, Comm. ACM 16, 1973; EISPACK's `tqlrat`): implicit QL with Wilkinson shifts carried out on the
/// squared couplings `e²`, with no square root per rotation. The loop-carried chain of
/// a rotation is one multiply-add and one division, against a square root and two
/// divisions in the textbook QL with rotations (which this replaced: the QL sweeps were
/// ~6 % of a generated N = 5 step, latency-bound on that chain). A coupling is
/// negligible when `e² ≤ (ε t)²`, t the largest `|d_l| + |e_l|` met so far: an absolute
/// criterion, so eigenvalues come with errors of order `ε ‖T‖`, which is what the
/// inverse iteration's residual test (`≤ RESIDUAL_TOLERANCE · n ε ‖T‖`) checks each
/// selected one against.
fn ql_eigenvalues(d: &mut [f64], e: &mut [f64]) -> bool {
    let n = d.len();
    if n == 0 {
        return true;
    }
    // e2[i] = e[i]², e2[n − 1] = 0 (stops the search for a negligible coupling)
    let e2 = e;
    for x in e2[..n - 1].iter_mut() {
        *x *= *x;
    }
    e2[n - 1] = 0.0;
    // f: the shifts so far (d[l..] hold eigenvalues minus f); t, b = ε t, c = b²
    let (mut f, mut t, mut b, mut c) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for l in 0..n {
        let size = d[l].abs() + e2[l].sqrt();
        if t < size {
            t = size;
            b = f64::EPSILON * t;
            c = b * b;
        }
        let mut iterations = 0;
        loop {
            // the first negligible coupling at or after l (e2[n − 1] = 0 ≤ c)
            let mut m = l;
            while e2[m] > c {
                m += 1;
            }
            if m == l {
                break;
            }
            iterations += 1;
            if iterations > MAX_QL_ITERATIONS {
                return false;
            }
            // Wilkinson shift from the leading 2 × 2 block, subtracted from d[l..]
            let s = e2[l].sqrt();
            let g = d[l];
            let p = (d[l + 1] - g) / (2.0 * s);
            let r = (p * p + 1.0).sqrt();
            d[l] = s / (p + r.copysign(p));
            let h = g - d[l];
            for x in d[l + 1..].iter_mut() {
                *x -= h;
            }
            f += h;
            // the rational QL sweep from m up to l
            let mut g = d[m];
            if g == 0.0 {
                g = b;
            }
            let mut h = g;
            let mut s = 0.0;
            for i in (l..m).rev() {
                let p = g * h;
                let r = p + e2[i];
                e2[i + 1] = s * r;
                s = e2[i] / r;
                d[i + 1] = h + s * (h + d[i]);
                g = d[i] - e2[i] / g;
                if g == 0.0 {
                    g = b;
                }
                h = g * p / r;
            }
            e2[l] = s * g;
            d[l] = h;
            // converged (guarding the test against underflow)
            if h == 0.0 || e2[l].abs() <= (c / h).abs() {
                break;
            }
            e2[l] *= h;
            if e2[l] == 0.0 {
                break;
            }
        }
        d[l] += f;
    }
    d.iter().all(|x| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic values in [−1, 1).
    fn sequence(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        }
    }

    /// A random orthogonal n × n (column-major) from Householder products.
    fn orthogonal(n: usize, seed: u64) -> Vec<f64> {
        let mut next = sequence(seed);
        let mut q = vec![0.0; n * n];
        for i in 0..n {
            q[i * n + i] = 1.0;
        }
        for _ in 0..3 {
            let v: Vec<f64> = (0..n).map(|_| next()).collect();
            let vv: f64 = v.iter().map(|x| x * x).sum();
            // q ← (I − 2 v vᵀ / vᵀv) q
            for c in 0..n {
                let dot: f64 = (0..n).map(|r| v[r] * q[c * n + r]).sum();
                for r in 0..n {
                    q[c * n + r] -= 2.0 * dot / vv * v[r];
                }
            }
        }
        q
    }

    /// `Q diag(λ) Qᵀ` and its negative part `Q diag(min(λ, 0)) Qᵀ`.
    fn from_spectrum(q: &[f64], lambda: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let n = lambda.len();
        let mut h = vec![0.0; n * n];
        let mut neg = vec![0.0; n * n];
        for c in 0..n {
            for r in 0..n {
                for k in 0..n {
                    let x = q[k * n + r] * q[k * n + c];
                    h[c * n + r] += lambda[k] * x;
                    neg[c * n + r] += lambda[k].min(0.0) * x;
                }
            }
        }
        (h, neg)
    }

    fn max_abs(m: &[f64]) -> f64 {
        m.iter().fold(0.0f64, |a, x| a.max(x.abs()))
    }

    /// Checks the projection of `Q diag(λ) Qᵀ` against the known negative part.
    fn check(lambda: &[f64], seed: u64) {
        let n = lambda.len();
        let q = orthogonal(n, seed);
        let (h, expected) = from_spectrum(&q, lambda);
        let mut p = h.clone();
        let mut s = SpectralProjection::new(n);
        assert!(s.negative_part(&mut p), "failed for λ = {lambda:?}");
        let scale = max_abs(&h).max(f64::MIN_POSITIVE);
        let err = p
            .iter()
            .zip(&expected)
            .fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
        // backward-stable algorithms: error ~ n ε ‖H‖ (eigenvalue errors), plus ε‖H‖/gap
        // for the vectors, which the rank sum over a whole cluster cancels; measured up
        // to 3.8 n ε over these tests (faer's full decomposition: the same order)
        assert!(
            err <= 16.0 * n as f64 * f64::EPSILON * scale,
            "n = {n}: error {err:.3e} against scale {scale:.3e}, λ = {lambda:?}"
        );
    }

    #[test]
    fn random_spectra_of_the_step_sizes() {
        for &n in &[1usize, 2, 3, 6, 15, 30, 45, 60] {
            for seed in 0..20u64 {
                let mut next = sequence(100 + seed);
                let lambda: Vec<f64> = (0..n).map(|_| 10.0 * next()).collect();
                check(&lambda, seed);
            }
        }
    }

    #[test]
    fn repeated_clustered_zero_and_graded_eigenvalues() {
        let n = 15;
        // repeated negative and positive eigenvalues (exact clusters)
        let mut lambda = vec![-1.0; 7];
        lambda.extend(vec![2.0; 8]);
        check(&lambda, 1);
        // a tight cluster straddling zero, and exact zeros
        let lambda: Vec<f64> = (0..n).map(|i| (i as f64 - 7.0) * 1e-9).collect();
        check(&lambda, 2);
        let mut lambda = vec![0.0; n];
        lambda[3] = -5.0;
        lambda[9] = 4.0;
        check(&lambda, 3);
        // graded: eigenvalues over twelve decades, both signs
        let lambda: Vec<f64> = (0..n)
            .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 } * 10f64.powi(i as i32 - 6))
            .collect();
        check(&lambda, 4);
        // everything negative (returned unchanged) or non-negative (zero)
        check(&[-1.0, -2.0, -3.0, -4.0], 5);
        check(&[1.0, 0.0, 3.0, 4.0], 6);
    }

    #[test]
    fn diagonal_tridiagonal_and_zero_matrices() {
        // already diagonal with repeated entries: T splits everywhere
        let n = 6;
        let d = [3.0, -1.0, 3.0, -1.0, 0.0, -1.0];
        let mut h = vec![0.0; n * n];
        for i in 0..n {
            h[i * n + i] = d[i];
        }
        let mut s = SpectralProjection::new(n);
        assert!(s.negative_part(&mut h));
        for c in 0..n {
            for r in 0..n {
                let expected = if r == c { d[r].min(0.0) } else { 0.0 };
                assert!((h[c * n + r] - expected).abs() < 1e-15, "{r} {c}");
            }
        }
        let mut z = vec![0.0; 9];
        assert!(SpectralProjection::new(3).negative_part(&mut z));
        assert!(z.iter().all(|&x| x == 0.0));
    }

    #[test]
    fn non_finite_input_is_refused_and_left_unchanged() {
        for bad in [f64::NAN, f64::INFINITY] {
            let mut h = vec![1.0, bad, bad, -1.0];
            let before: Vec<u64> = h.iter().map(|x| x.to_bits()).collect();
            assert!(!SpectralProjection::new(2).negative_part(&mut h));
            let after: Vec<u64> = h.iter().map(|x| x.to_bits()).collect();
            assert_eq!(after, before);
        }
    }

    /// `p` is the exact negative part `expected` of `h` to 16 n ε max|h| (the bound of
    /// [`check`]).
    fn assert_exact(p: &[f64], expected: &[f64], h: &[f64]) {
        let n = (h.len() as f64).sqrt() as usize;
        let err = p
            .iter()
            .zip(expected)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            err <= 16.0 * n as f64 * f64::EPSILON * max_abs(h),
            "{err:.3e}"
        );
    }

    fn frobenius(m: &[f64]) -> f64 {
        m.iter().map(|x| x * x).sum::<f64>().sqrt()
    }

    fn largest_eigenvalue(m: &[f64], n: usize) -> f64 {
        let a = faer::Mat::from_fn(n, n, |i, j| m[j * n + i]);
        let eig = a.self_adjoint_eigen(faer::Side::Lower).unwrap();
        (0..n).map(|k| eig.S()[k]).fold(f64::NEG_INFINITY, f64::max)
    }

    /// Reuse on either side of the spectrum: a small change keeps the basis, the result
    /// is negative semidefinite and within the dropped coupling of the exact part; a
    /// change that turns a direction of the other side negative is refused.
    #[test]
    fn reused_basis_stays_within_its_bound_and_refuses_a_new_negative_direction() {
        let n = 15;
        for &negatives in &[4usize, 11] {
            let lambda: Vec<f64> = (0..n)
                .map(|i| {
                    if i < negatives {
                        -1.0 - i as f64
                    } else {
                        0.5 + i as f64
                    }
                })
                .collect();
            let q = orthogonal(n, 40 + negatives as u64);
            let (h0, expected0) = from_spectrum(&q, &lambda);
            let mut s = SpectralProjection::new(n);
            let mut p = h0.clone();
            assert!(s.negative_part(&mut p));
            assert_eq!((s.decomposed, s.reused), (1, 0));
            assert_exact(&p, &expected0, &h0);
            // which side the basis holds: the smaller one
            assert_eq!(s.basis_negative, negatives <= n - negatives);
            // a small symmetric change: reused, NSD, within 2 ‖ΔH‖_F of the exact part
            let mut next = sequence(77);
            let mut dh = vec![0.0; n * n];
            for c in 0..n {
                for r in c..n {
                    let x = 1e-3 * next();
                    dh[c * n + r] = x;
                    dh[r * n + c] = x;
                }
            }
            let h1: Vec<f64> = h0.iter().zip(&dh).map(|(a, b)| a + b).collect();
            let mut p = h1.clone();
            assert!(s.negative_part(&mut p));
            assert_eq!((s.decomposed, s.reused), (1, 1), "negatives = {negatives}");
            let mut exact = h1.clone();
            assert!(SpectralProjection::new(n).negative_part(&mut exact));
            let err: Vec<f64> = p.iter().zip(&exact).map(|(a, b)| a - b).collect();
            assert!(
                frobenius(&err) <= 2.0 * frobenius(&dh),
                "{:.3e}",
                frobenius(&err)
            );
            assert!(frobenius(&err) > 0.0);
            assert!(largest_eigenvalue(&p, n) <= 1e-13 * frobenius(&h1));
            // a direction of the non-negative side (eigenvalue 0.5 + negatives) pushed to
            // −1 with no coupling: the basis must not be reused
            let o = negatives;
            let shift = -(1.5 + o as f64);
            let mut h2 = h0.clone();
            for c in 0..n {
                for r in 0..n {
                    h2[c * n + r] += shift * q[o * n + r] * q[o * n + c];
                }
            }
            let mut lambda2 = lambda.clone();
            lambda2[o] = -1.0;
            let (_, expected2) = from_spectrum(&q, &lambda2);
            let mut p = h2.clone();
            assert!(s.negative_part(&mut p));
            assert_eq!((s.decomposed, s.reused), (2, 1), "negatives = {negatives}");
            assert_exact(&p, &expected2, &h2);
        }
    }
}
