//! The negative semidefinite part `H⁻ = U min(Λ, 0) Uᵀ` of a symmetric matrix from a
//! partial eigendecomposition: only the eigenvectors of the smaller side of the spectrum
//! (the negative eigenvalues, or the positive ones with `H⁻ = H − H⁺`).
//!
//! The step needs H⁻ of the field stiffness (see `solver/system.rs`), and a full
//! eigendecomposition (~150k instructions for 15 × 15 with faer's `self_adjoint_evd`) was
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
//! returns false and the caller falls back to a full decomposition, so a failure here
//! costs time, never accuracy.
//!
//! The storage is the caller's: [`ProjectionBasis`] is what a strand keeps from one step
//! to the next (the basis, ⌊n/2⌋ columns at most), [`ProjectionScratch`] what a worker
//! can share between strands. Allocates nothing.

use crate::float::Float;

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

/// What a strand keeps for [`SpectralProjection::negative_part`]: the basis of its last
/// decomposition.
pub struct ProjectionBasis<'a, T: Float = f64> {
    /// Columns of length n, column-major; at least n·⌊n/2⌋ long (the basis spans the
    /// smaller side of the spectrum).
    pub vectors: &'a mut [T],
    /// Columns of `vectors` that hold the last decomposition's basis (0: none).
    pub k: &'a mut usize,
    /// Whether that basis spans the negative (else the positive) eigenvalues.
    pub negative: &'a mut bool,
}

/// The scratch of [`SpectralProjection::negative_part`] for n × n matrices: `a`, `hu`
/// and `coupling` n² long, `rotated` 2n², `pivot` and the others n.
pub struct ProjectionScratch<'a, T: Float = f64> {
    /// Column-major copy of the matrix; the Householder vectors below its subdiagonal.
    pub a: &'a mut [T],
    /// Householder factors.
    pub tau: &'a mut [T],
    /// Diagonal of T.
    pub diag: &'a mut [T],
    /// Off-diagonal of T.
    pub off: &'a mut [T],
    /// Eigenvalues of T.
    pub eigenvalues: &'a mut [T],
    /// Eigenvalues of the side being computed.
    pub selected: &'a mut [T],
    /// Scratch vector.
    pub scratch: &'a mut [T],
    /// Diagonal of U of the shifted tridiagonal LU (reciprocals).
    pub u0: &'a mut [T],
    /// First superdiagonal of U.
    pub u1: &'a mut [T],
    /// Second superdiagonal of U.
    pub u2: &'a mut [T],
    /// Multipliers of L.
    pub mult: &'a mut [T],
    /// Row swaps of L.
    pub pivot: &'a mut [bool],
    /// The iterate of the inverse iteration.
    pub x: &'a mut [T],
    /// `H U` (n × k).
    pub hu: &'a mut [T],
    /// Its part outside span(U) (n × k).
    pub coupling: &'a mut [T],
    /// `Uᵀ H U` (k × k), then G (n × n) after it.
    pub rotated: &'a mut [T],
}

impl<'a, T: Float> ProjectionScratch<'a, T> {
    /// The scratch for n × n matrices on a caller's buffers: `a`, `hu` and `coupling`
    /// n², `rotated` 2n², `pivot` n, and `vectors` the eleven vectors of n (tau, diag,
    /// off, eigenvalues, selected, scratch, u0, u1, u2, mult, x) one after the other
    /// (a short `vectors` leaves the last ones empty: [`SpectralProjection::new`] then
    /// refuses).
    pub fn on(
        n: usize,
        a: &'a mut [T],
        vectors: &'a mut [T],
        pivot: &'a mut [bool],
        (hu, coupling, rotated): (&'a mut [T], &'a mut [T], &'a mut [T]),
    ) -> Self {
        let mut vectors = vectors.chunks_exact_mut(n.max(1));
        let mut next = || vectors.next().unwrap_or_default();
        let (tau, diag, off, eigenvalues, selected, scratch) =
            (next(), next(), next(), next(), next(), next());
        let (u0, u1, u2, mult, x) = (next(), next(), next(), next(), next());
        ProjectionScratch {
            a,
            tau,
            diag,
            off,
            eigenvalues,
            selected,
            scratch,
            u0,
            u1,
            u2,
            mult,
            pivot,
            x,
            hu,
            coupling,
            rotated,
        }
    }
}

/// How [`SpectralProjection::negative_part`] went.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProjectionOutcome {
    /// The kept basis still splits the matrix: projected in it.
    Reused,
    /// A (partial) eigendecomposition.
    Decomposed,
    /// The zero matrix: its own part.
    Trivial,
    /// A value was not finite or an eigenpair failed its check: `h` unchanged, the basis
    /// forgotten; the caller falls back to a full decomposition.
    Failed,
}

/// The negative semidefinite part of an n × n symmetric matrix, on the caller's storage.
pub struct SpectralProjection<'a, T: Float = f64, const NC: usize = 0> {
    n: usize,
    a: &'a mut [T],
    tau: &'a mut [T],
    diag: &'a mut [T],
    off: &'a mut [T],
    eigenvalues: &'a mut [T],
    selected: &'a mut [T],
    vectors: &'a mut [T],
    scratch: &'a mut [T],
    u0: &'a mut [T],
    u1: &'a mut [T],
    u2: &'a mut [T],
    mult: &'a mut [T],
    pivot: &'a mut [bool],
    x: &'a mut [T],
    hu: &'a mut [T],
    coupling: &'a mut [T],
    rotated: &'a mut [T],
    basis_k: &'a mut usize,
    basis_negative: &'a mut bool,
}

impl<'a, T: Float, const NC: usize> SpectralProjection<'a, T, NC> {
    /// The projection of n × n matrices on this storage (lengths as documented on
    /// [`ProjectionBasis`] and [`ProjectionScratch`]; `None` when one is too short).
    pub fn new(
        n: usize,
        basis: ProjectionBasis<'a, T>,
        s: ProjectionScratch<'a, T>,
    ) -> Option<Self> {
        let nn = n * n;
        let long_enough = basis.vectors.len() >= n * (n / 2)
            && s.a.len() >= nn
            && s.hu.len() >= nn
            && s.coupling.len() >= nn
            && s.rotated.len() >= 2 * nn
            && [
                s.tau.len(),
                s.diag.len(),
                s.off.len(),
                s.eigenvalues.len(),
                s.selected.len(),
                s.scratch.len(),
                s.u0.len(),
                s.u1.len(),
                s.u2.len(),
                s.mult.len(),
                s.x.len(),
                s.pivot.len(),
            ]
            .iter()
            .all(|&l| l >= n);
        if !long_enough || n == 0 || (NC != 0 && n != NC) {
            return None;
        }
        Some(SpectralProjection {
            n,
            a: &mut s.a[..nn],
            tau: &mut s.tau[..n],
            diag: &mut s.diag[..n],
            off: &mut s.off[..n],
            eigenvalues: &mut s.eigenvalues[..n],
            selected: &mut s.selected[..n],
            vectors: basis.vectors,
            scratch: &mut s.scratch[..n],
            u0: &mut s.u0[..n],
            u1: &mut s.u1[..n],
            u2: &mut s.u2[..n],
            mult: &mut s.mult[..n],
            pivot: &mut s.pivot[..n],
            x: &mut s.x[..n],
            hu: &mut s.hu[..nn],
            coupling: &mut s.coupling[..nn],
            rotated: &mut s.rotated[..2 * nn],
            basis_k: basis.k,
            basis_negative: basis.negative,
        })
    }

    /// The matrices' size: `NC` when it is not 0 (a size the compiler knows), else the
    /// size given to [`Self::new`].
    #[inline(always)]
    fn n(&self) -> usize {
        if NC != 0 {
            NC
        } else {
            self.n
        }
    }

    /// Forget the basis of the last decomposition: the next call decomposes.
    pub fn forget_basis(&mut self) {
        *self.basis_k = 0;
    }

    /// Replace the symmetric matrix `h` (n × n, column-major, both triangles filled) by
    /// its negative semidefinite part. Returns false, leaving `h` unchanged, when it holds
    /// a value that is not finite or an eigenpair fails its residual check.
    pub fn negative_part(&mut self, h: &mut [T]) -> ProjectionOutcome {
        let outcome = self.negative_part_inner(h);
        if outcome == ProjectionOutcome::Failed {
            *self.basis_k = 0;
        }
        outcome
    }

    fn negative_part_inner(&mut self, h: &mut [T]) -> ProjectionOutcome {
        use ProjectionOutcome::*;
        let n = self.n();
        if h.len() != n * n {
            return Failed;
        }
        let largest = h.iter().fold(T::zero(), |m, x| m.max(x.abs()));
        if !largest.is_finite() {
            return Failed;
        }
        if largest == T::zero() {
            return Trivial;
        }
        if *self.basis_k > 0 && self.project_in_basis(h) {
            return Reused;
        }
        *self.basis_k = 0;
        // work on H / 2^e with its largest entry in [0.5, 1) (exact): the QL rotations
        // may then take sqrt(f² + g²) instead of hypot without overflow or underflow
        let scale = largest.power_of_two_above();
        let inverse = T::one() / scale;
        for (a, x) in self.a.iter_mut().zip(h.iter()) {
            *a = *x * inverse;
        }
        self.tridiagonalise();
        self.eigenvalues.copy_from_slice(self.diag);
        // e[i] couples diag i and i + 1
        self.scratch.copy_from_slice(self.off);
        if !ql_eigenvalues(self.eigenvalues, self.scratch) {
            return Failed;
        }
        let t_norm = self.tridiagonal_norm();
        if !t_norm.is_finite() {
            return Failed;
        }
        let negative = self.eigenvalues.iter().filter(|&&l| l < T::zero()).count();
        let positive = self.eigenvalues.iter().filter(|&&l| l > T::zero()).count();
        if negative == 0 {
            h.fill(T::zero());
            return Decomposed;
        }
        if positive == 0 {
            return Decomposed;
        }
        // the smaller side: H⁻ = Σ_{λ<0} λ u uᵀ, or H − Σ_{λ>0} λ u uᵀ
        let from_negative = negative <= positive;
        let mut k = 0;
        for i in 0..n {
            let l = self.eigenvalues[i];
            if (from_negative && l < T::zero()) || (!from_negative && l > T::zero()) {
                self.selected[k] = l;
                k += 1;
            }
        }
        // nearby eigenvalues adjacent after sorting, for the reorthogonalisation
        self.selected[..k].sort_unstable_by(T::total_order);
        let cluster = T::of(1e-3) * t_norm;
        let tolerance = T::of(RESIDUAL_TOLERANCE * n as f64) * T::EPSILON * t_norm;
        let perturbation = T::EPSILON * t_norm;
        let mut cluster_start = 0;
        for j in 0..k {
            if j > 0 && self.selected[j] - self.selected[j - 1] > cluster {
                cluster_start = j;
            }
            if !self.inverse_iteration(j, cluster_start, perturbation, tolerance) {
                return Failed;
            }
        }
        // back to the original coordinates, u = Q y, in place; kept for the next call
        self.apply_q(k);
        *self.basis_k = k;
        *self.basis_negative = from_negative;
        // the rank-k sum, lower triangle, then mirrored
        let sign = if from_negative { T::one() } else { -T::one() };
        for c in 0..n {
            let col = &mut self.a[c * n + c..(c + 1) * n];
            if from_negative {
                col.fill(T::zero());
            } else {
                for (a, x) in col.iter_mut().zip(&h[c * n + c..(c + 1) * n]) {
                    *a = *x * inverse;
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
            return Failed;
        }
        for c in 0..n {
            for r in c..n {
                let x = self.a[c * n + r] * scale;
                h[c * n + r] = x;
                h[r * n + c] = x;
            }
        }
        Decomposed
    }

    /// The reuse branch of [`Self::negative_part`] (see the module page): false, with
    /// `h` unchanged, when the basis of the last decomposition does not qualify.
    fn project_in_basis(&mut self, h: &mut [T]) -> bool {
        let (n, k) = (self.n(), *self.basis_k);
        let u = &self.vectors[..k * n];
        let total: T = h.iter().map(|&x| x * x).sum();
        let bound = T::of(BASIS_REUSE_TOLERANCE * BASIS_REUSE_TOLERANCE) * total;
        // W = H U, B = Uᵀ W (k × k), column by column; with U orthonormal the coupling
        // ‖C‖² = ‖W − U B‖² = Σ_j ‖w_j‖² − ‖b_j‖², so a basis that does not qualify is
        // refused as soon as its columns so far exceed the bound (with a margin of 1 %
        // over it for the rounding; the exact ‖C‖ below decides)
        let screen = T::of(1.01) * bound;
        let mut partial = T::zero();
        for j in 0..k {
            let w = &mut self.hu[j * n..(j + 1) * n];
            gemm(
                w,
                n,
                1,
                n,
                h,
                false,
                &u[j * n..(j + 1) * n],
                false,
                T::one(),
                false,
                false,
            );
            let b = &mut self.rotated[j * k..(j + 1) * k];
            gemm(b, k, 1, n, u, true, w, false, T::one(), false, false);
            let ww: T = w.iter().map(|&x| x * x).sum();
            let bb: T = b.iter().map(|&x| x * x).sum();
            partial += ww - bb;
            if partial.not_a_number() || partial > screen {
                return false;
            }
        }
        // C = W − U B
        self.coupling[..n * k].copy_from_slice(&self.hu[..n * k]);
        gemm(
            &mut self.coupling[..n * k],
            n,
            k,
            k,
            u,
            false,
            &self.rotated[..k * k],
            false,
            -T::one(),
            true,
            false,
        );
        let coupling: T = self.coupling[..n * k].iter().map(|&x| x * x).sum();
        if coupling.not_a_number() || coupling > bound {
            return false;
        }
        let norm = total.sqrt();
        let cut = T::of(NEGLIGIBLE_EIGENVALUE) * norm;
        let negative = *self.basis_negative;
        // the k × k block: −B positive definite (negative side) or B + cut I positive
        // semidefinite up to the cut (positive side), into `a`
        for j in 0..k {
            for i in 0..k {
                let b = self.rotated[j * k + i];
                self.a[j * k + i] = if negative {
                    -b
                } else {
                    b + if i == j { cut } else { T::zero() }
                };
            }
        }
        if !cholesky(self.a, k) {
            return false;
        }
        // G = (I − UUᵀ) H (I − UUᵀ) = H − U Wᵀ − C Uᵀ (lower triangle), and the other
        // side's check: G + cut I + ‖H‖ UUᵀ (negative side: the rest non-negative up to
        // the cut) or −G + ‖H‖ UUᵀ (positive side: the rest negative definite)
        let sign = if negative { T::one() } else { -T::one() };
        let (_, g_all) = self.rotated.split_at_mut(k * k);
        let g_all = &mut g_all[..n * n];
        g_all.copy_from_slice(h);
        gemm(
            g_all,
            n,
            n,
            k,
            u,
            false,
            &self.hu[..n * k],
            true,
            -T::one(),
            true,
            true,
        );
        gemm(
            g_all,
            n,
            n,
            k,
            &self.coupling[..n * k],
            false,
            u,
            true,
            -T::one(),
            true,
            true,
        );
        gemm(
            &mut self.a[..n * n],
            n,
            n,
            k,
            u,
            false,
            u,
            true,
            norm,
            false,
            true,
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
        if !cholesky(self.a, n) {
            return false;
        }
        if negative {
            // U B Uᵀ: (U B) into `coupling`, then (U B) Uᵀ
            let (b, _) = self.rotated.split_at(k * k);
            gemm(
                &mut self.coupling[..n * k],
                n,
                k,
                k,
                u,
                false,
                b,
                false,
                T::one(),
                false,
                false,
            );
            gemm(
                h,
                n,
                n,
                k,
                &self.coupling[..n * k],
                false,
                u,
                true,
                T::one(),
                false,
                true,
            );
            // exactly symmetric
            mirror_lower(h, n);
        } else {
            h.copy_from_slice(&self.rotated[k * k..k * k + n * n]);
            mirror_lower(h, n);
        }
        true
    }

    /// Householder reduction of `a` (both triangles read and updated) to tridiagonal form: `diag`,
    /// `off` (coupling i and i + 1), the reflector `I − τ_k v_k v_kᵀ` (acting on rows
    /// k + 1 ..) stored as v_k in column k from row k + 1 and τ_k in `tau`.
    fn tridiagonalise(&mut self) {
        let n = self.n();
        let p = &mut self.x;
        for k in 0..n.saturating_sub(2) {
            let m = n - k - 1;
            let (head, tail) = self.a.split_at_mut((k + 1) * n);
            let v = &mut head[k * n + k + 1..];
            let x0 = v[0];
            let sigma: T = v[1..].iter().map(|&x| x * x).sum();
            if sigma == T::zero() {
                self.tau[k] = T::zero();
                self.off[k] = x0;
                continue;
            }
            let norm = (x0 * x0 + sigma).sqrt();
            let alpha = if x0 >= T::zero() { -norm } else { norm };
            v[0] = x0 - alpha;
            let tau = T::of(2.0) / (v[0] * v[0] + sigma);
            self.tau[k] = tau;
            self.off[k] = alpha;
            let v = &*v;
            // p = τ A₂₂ v over rows/columns k + 1 .. (both triangles held): column by
            // column, so that no sum is a chain of dependent additions
            let p = &mut p[..m];
            p.fill(T::zero());
            for (jj, &vj) in v.iter().enumerate() {
                let col = &tail[jj * n + k + 1..(jj + 1) * n];
                for (pi, &aij) in p.iter_mut().zip(col) {
                    *pi += aij * vj;
                }
            }
            let mut vp = T::zero();
            for (pi, &vi) in p.iter_mut().zip(v) {
                *pi *= tau;
                vp += vi * *pi;
            }
            // w = p − (τ/2)(vᵀp) v; A₂₂ −= v wᵀ + w vᵀ (both triangles)
            let half = T::of(0.5) * tau * vp;
            for (pi, &vi) in p.iter_mut().zip(v) {
                *pi -= half * vi;
            }
            for (jj, (&vj, &wj)) in v.iter().zip(p.iter()).enumerate() {
                let col = &mut tail[jj * n + k + 1..(jj + 1) * n];
                for ((aij, &vi), &wi) in col.iter_mut().zip(v).zip(p.iter()) {
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
        self.off[n - 1] = T::zero();
    }

    /// `max_i |e_{i−1}| + |d_i| + |e_i|`: the 1-norm of T (= ‖H‖₁ up to rounding's
    /// change of basis; a bound of ‖T‖₂).
    fn tridiagonal_norm(&self) -> T {
        let n = self.n();
        let mut m = T::zero();
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
        perturbation: T,
        tolerance: T,
    ) -> bool {
        let n = self.n();
        let lambda = self.selected[j];
        self.factor_shifted(lambda, perturbation);
        // a deterministic start vector with components in every direction
        let mut state = 0x9E37_79B9_7F4A_7C15u64 ^ (j as u64).wrapping_mul(0xD1B5_4A32_D192_ED03);
        for i in 0..n {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            self.x[i] = T::of(0.5 + (state >> 11) as f64 / (1u64 << 53) as f64);
        }
        // after the residual test passes, one more sweep (LAPACK's `dstein` takes two)
        // takes the vector from "good enough" to rounding level
        let mut converged = false;
        for _ in 0..MAX_INVERSE_ITERATIONS {
            self.solve_shifted();
            // reorthogonalise against the cluster (modified Gram–Schmidt)
            for c in cluster_start..j {
                let y = &self.vectors[c * n..(c + 1) * n];
                let mut dot = T::zero();
                for i in 0..n {
                    dot += y[i] * self.x[i];
                }
                for i in 0..n {
                    self.x[i] -= dot * y[i];
                }
            }
            let norm = self.x.iter().map(|&v| v * v).sum::<T>().sqrt();
            if !(norm.is_finite() && norm > T::zero()) {
                return false;
            }
            let inverse = T::one() / norm;
            for v in self.x.iter_mut() {
                *v *= inverse;
            }
            if converged {
                self.vectors[j * n..(j + 1) * n].copy_from_slice(self.x);
                return true;
            }
            converged = self.residual(lambda) <= tolerance;
        }
        false
    }

    /// `‖T x − λ x‖₂` for the unit vector `x`.
    fn residual(&self, lambda: T) -> T {
        let n = self.n();
        let (d, e, x) = (&self.diag, &self.off, &self.x);
        let mut s = T::zero();
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
    fn factor_shifted(&mut self, lambda: T, perturbation: T) {
        let n = self.n();
        let (d, e) = (&self.diag, &self.off);
        let mut cur_d = d[0] - lambda;
        let mut cur_u1 = if n > 1 { e[0] } else { T::zero() };
        for i in 0..n - 1 {
            let below_d = e[i];
            let below_u1 = d[i + 1] - lambda;
            let below_u2 = if i + 2 < n { e[i + 1] } else { T::zero() };
            if cur_d.abs() >= below_d.abs() {
                if cur_d == T::zero() {
                    cur_d = perturbation;
                }
                let m = below_d / cur_d;
                self.u0[i] = cur_d;
                self.u1[i] = cur_u1;
                self.u2[i] = T::zero();
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
        self.u0[n - 1] = if cur_d == T::zero() {
            perturbation
        } else {
            cur_d
        };
        // the back substitution multiplies by the reciprocal pivots: its chain of
        // dependent operations then has no division (each factorisation serves two or
        // more solves)
        for u in self.u0[..n].iter_mut() {
            *u = T::one() / *u;
        }
    }

    /// Solve `(T − λI) x_new = x` in place with the factors of [`Self::factor_shifted`].
    fn solve_shifted(&mut self) {
        let n = self.n();
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
        let n = self.n();
        for r in (0..n.saturating_sub(2)).rev() {
            let tau = self.tau[r];
            if tau == T::zero() {
                continue;
            }
            let v = &self.a[r * n + r + 1..(r + 1) * n];
            for y in self.vectors[..k * n].chunks_exact_mut(n) {
                let y = &mut y[r + 1..];
                let dot: T = v.iter().zip(y.iter()).map(|(&a, &b)| a * b).sum();
                let s = tau * dot;
                for (yi, &vi) in y.iter_mut().zip(v) {
                    *yi -= s * vi;
                }
            }
        }
    }
}

/// Copy the lower triangle of the n × n column-major `a` onto its upper triangle.
fn mirror_lower<T: Float>(a: &mut [T], n: usize) {
    for c in 0..n {
        for r in c + 1..n {
            a[r * n + c] = a[c * n + r];
        }
    }
}

/// Cholesky factorisation in place of the m × m matrix at the start of `a`
/// (column-major, stride m, lower triangle read and overwritten by the factor): whether
/// it is numerically positive definite (every pivot finite and > 0).
///
/// Compiled twice, for the baseline target and with AVX2 (the same bits), as [`gemm`].
pub fn cholesky<T: Float>(a: &mut [T], m: usize) -> bool {
    #[cfg(all(target_arch = "x86_64", feature = "std", not(target_feature = "avx2")))]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { cholesky_avx2(a, m) };
        }
    }
    cholesky_body(a, m)
}

/// [`cholesky`] compiled with AVX2.
#[cfg(all(target_arch = "x86_64", feature = "std", not(target_feature = "avx2")))]
#[target_feature(enable = "avx2")]
fn cholesky_avx2<T: Float>(a: &mut [T], m: usize) -> bool {
    cholesky_body(a, m)
}

/// The body of [`cholesky`].
#[inline(always)]
fn cholesky_body<T: Float>(a: &mut [T], m: usize) -> bool {
    if a.len() < m * m {
        return false;
    }
    // column j less the products of the columns before it, in their order (each entry
    // as the textbook's inner loop sums it), down the columns: contiguous, in vector
    // registers
    for j in 0..m {
        let (done, rest) = a.split_at_mut(j * m);
        let col = &mut rest[j..m];
        for p in 0..j {
            let before = &done[p * m + j..(p + 1) * m];
            let apj = before[0];
            for (x, &y) in col.iter_mut().zip(before) {
                *x -= y * apj;
            }
        }
        let d = col[0];
        if d.not_a_number() || d <= T::zero() || !d.is_finite() {
            return false;
        }
        let d = d.sqrt();
        col[0] = d;
        let inverse = T::one() / d;
        for x in &mut col[1..] {
            *x *= inverse;
        }
    }
    true
}

/// `c = α op(a) op(b)` (or `c += …` when `accumulate`), c m × n column-major, op(a)
/// m × inner (`a` stored inner × m when `a_t`), op(b) inner × n (`b` stored n × inner
/// when `b_t`). With `lower`, only the lower triangle of c (m = n) is asked for: the
/// blocks of rows wholly above the diagonal are left as they were (the entries of a
/// block computed above it are correct too).
///
/// Each entry is `α s` with `s` summed over the inner index in order (`c + α s` when
/// accumulating), whichever loop order computes it: with `a` as stored (not `a_t`) the
/// sums of a block of rows are carried together down the columns of `a` (contiguous, so
/// the inner loop runs in vector registers), with `a_t` one entry at a time along a row
/// of `a`.
///
/// Compiled twice, for the baseline target and with AVX2, as [`crate::moments::rotary`]
/// is: the AVX2 copy runs when the CPU has it, with the same bits.
#[allow(clippy::too_many_arguments)]
fn gemm<T: Float>(
    c: &mut [T],
    m: usize,
    n: usize,
    inner: usize,
    a: &[T],
    a_t: bool,
    b: &[T],
    b_t: bool,
    alpha: T,
    accumulate: bool,
    lower: bool,
) {
    #[cfg(all(target_arch = "x86_64", feature = "std", not(target_feature = "avx2")))]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { gemm_avx2(c, m, n, inner, a, a_t, b, b_t, alpha, accumulate, lower) };
        }
    }
    gemm_body(c, m, n, inner, a, a_t, b, b_t, alpha, accumulate, lower)
}

/// [`gemm`] compiled with AVX2.
#[cfg(all(target_arch = "x86_64", feature = "std", not(target_feature = "avx2")))]
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
fn gemm_avx2<T: Float>(
    c: &mut [T],
    m: usize,
    n: usize,
    inner: usize,
    a: &[T],
    a_t: bool,
    b: &[T],
    b_t: bool,
    alpha: T,
    accumulate: bool,
    lower: bool,
) {
    gemm_body(c, m, n, inner, a, a_t, b, b_t, alpha, accumulate, lower)
}

/// The body of [`gemm`].
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn gemm_body<T: Float>(
    c: &mut [T],
    m: usize,
    n: usize,
    inner: usize,
    a: &[T],
    a_t: bool,
    b: &[T],
    b_t: bool,
    alpha: T,
    accumulate: bool,
    lower: bool,
) {
    let b_at = |p: usize, j: usize| if b_t { b[p * n + j] } else { b[j * inner + p] };
    let put = |c: &mut [T], at: usize, s: T| {
        if accumulate {
            c[at] += alpha * s;
        } else {
            c[at] = alpha * s;
        }
    };
    if a_t {
        // four sums at a time, each its own chain of additions (in order)
        for j in 0..n {
            let mut i = 0;
            while i + 4 <= m {
                let rows = [0, 1, 2, 3].map(|r| &a[(i + r) * inner..(i + r + 1) * inner]);
                let mut s = [T::zero(); 4];
                for p in 0..inner {
                    let bpj = b_at(p, j);
                    for (sr, row) in s.iter_mut().zip(&rows) {
                        *sr += row[p] * bpj;
                    }
                }
                for (r, &sr) in s.iter().enumerate() {
                    put(c, j * m + i + r, sr);
                }
                i += 4;
            }
            for i in i..m {
                let row = &a[i * inner..(i + 1) * inner];
                let mut s = T::zero();
                for (p, &aip) in row.iter().enumerate() {
                    s += aip * b_at(p, j);
                }
                put(c, j * m + i, s);
            }
        }
        return;
    }
    // eight rows of two columns at a time in registers (each column of `a` loaded once
    // for both), then the last rows by four, two and one
    let store = |out: &mut [T], s: &[T]| {
        if accumulate {
            for (ci, &si) in out.iter_mut().zip(s) {
                *ci += alpha * si;
            }
        } else {
            for (ci, &si) in out.iter_mut().zip(s) {
                *ci = alpha * si;
            }
        }
    };
    let mut start = 0;
    while start + 8 <= m {
        gemm_rows::<T, 8>(c, m, n, inner, a, &b_at, start, &store, lower);
        start += 8;
    }
    if start + 4 <= m {
        gemm_rows::<T, 4>(c, m, n, inner, a, &b_at, start, &store, lower);
        start += 4;
    }
    if start + 2 <= m {
        gemm_rows::<T, 2>(c, m, n, inner, a, &b_at, start, &store, lower);
        start += 2;
    }
    if start < m {
        gemm_rows::<T, 1>(c, m, n, inner, a, &b_at, start, &store, lower);
    }
}

/// Rows `start .. start + W` of every column of [`gemm`]'s product (`a` as stored), two
/// columns at a time, the sums in registers; `store` writes a column's W sums.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn gemm_rows<T: Float, const W: usize>(
    c: &mut [T],
    m: usize,
    n: usize,
    inner: usize,
    a: &[T],
    b_at: &impl Fn(usize, usize) -> T,
    start: usize,
    store: &impl Fn(&mut [T], &[T]),
    lower: bool,
) {
    let mut j = 0;
    while j < n {
        let pair = j + 1 < n;
        if lower && start + W <= j {
            // every row of the block above the diagonal of both columns, and of every
            // column after them
            break;
        }
        let mut s0 = [T::zero(); W];
        let mut s1 = [T::zero(); W];
        for p in 0..inner {
            let col = &a[p * m + start..p * m + start + W];
            let b0 = b_at(p, j);
            for (si, &aip) in s0.iter_mut().zip(col) {
                *si += aip * b0;
            }
            if pair {
                let b1 = b_at(p, j + 1);
                for (si, &aip) in s1.iter_mut().zip(col) {
                    *si += aip * b1;
                }
            }
        }
        store(&mut c[j * m + start..j * m + start + W], &s0);
        if pair {
            store(&mut c[(j + 1) * m + start..(j + 1) * m + start + W], &s1);
        }
        j += if pair { 2 } else { 1 };
    }
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
fn ql_eigenvalues<T: Float>(d: &mut [T], e: &mut [T]) -> bool {
    let n = d.len();
    if n == 0 {
        return true;
    }
    // e2[i] = e[i]², e2[n − 1] = 0 (stops the search for a negligible coupling)
    let e2 = e;
    for x in e2[..n - 1].iter_mut() {
        *x *= *x;
    }
    e2[n - 1] = T::zero();
    // f: the shifts so far (d[l..] hold eigenvalues minus f); t, b = ε t, c = b²
    let (mut f, mut t, mut b, mut c) = (T::zero(), T::zero(), T::zero(), T::zero());
    for l in 0..n {
        let size = d[l].abs() + e2[l].sqrt();
        if t < size {
            t = size;
            b = T::EPSILON * t;
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
            let p = (d[l + 1] - g) / (T::of(2.0) * s);
            let r = (p * p + T::one()).sqrt();
            d[l] = s / (p + r.copysign(p));
            let h = g - d[l];
            for x in d[l + 1..].iter_mut() {
                *x -= h;
            }
            f += h;
            // the rational QL sweep from m up to l
            let mut g = d[m];
            if g == T::zero() {
                g = b;
            }
            let mut h = g;
            let mut s = T::zero();
            for i in (l..m).rev() {
                let p = g * h;
                let r = p + e2[i];
                e2[i + 1] = s * r;
                s = e2[i] / r;
                d[i + 1] = h + s * (h + d[i]);
                g = d[i] - e2[i] / g;
                if g == T::zero() {
                    g = b;
                }
                h = g * p / r;
            }
            e2[l] = s * g;
            d[l] = h;
            // converged (guarding the test against underflow)
            if h == T::zero() || e2[l].abs() <= (c / h).abs() {
                break;
            }
            e2[l] *= h;
            if e2[l] == T::zero() {
                break;
            }
        }
        d[l] += f;
    }
    d.iter().all(|x| x.is_finite())
}
