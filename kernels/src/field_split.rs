//! The field stiffness in the implicit step's matrix without an eigendecomposition: a
//! dissipative split by a modified L D Lᵀ factorisation.
//!
//! The linearly implicit step (paper, section 3.4) takes the stiffness of the external
//! field, H = ∂f_field/∂q (gravity and the head's fictitious forces acting through the
//! frame rotations, point loads, contacts), into its matrix. Only a part H̃ of it may go
//! in: with the elastic stiffness K (eq. 5c) the step's matrix is
//! `M + h²(K − H̃) + …`, and the rest, `H − H̃`, acts at the step's start. For the
//! linearised motion `M q̈ = −(K − H) q` one step of linearly implicit Euler changes the
//! energy `E = ½ q̇ᵀMq̇ + ½ qᵀ(K − H)q` by exactly
//!
//! ```text
//! E₁ − E₀ = −½ Δq̇ᵀ M Δq̇ − ½ h² q̇₁ᵀ (K + H − 2H̃) q̇₁,
//! ```
//!
//! so the step is dissipative, whatever h, when `K − H̃ ⪰ 0` (its matrix is then positive
//! definite) and `K + H − 2H̃ ⪰ 0`. The spectral projection takes `H̃ = H⁻`, the negative
//! semidefinite part of H (`K + |H| ⪰ 0`); it needs an eigendecomposition, and leaves all
//! of H⁺ explicit even where the elastic stiffness holds it.
//!
//! This module takes `H̃ = H − E` with E ⪰ 0 such that `K − H + E ⪰ 0`: then
//! `K − H̃ = K − H + E ⪰ 0` and `K + H − 2H̃ = (K − H + E) + E ⪰ 0`, both conditions
//! hold. E comes from one factorisation of the total stiffness, in the metric of the step
//! matrix's diagonal `w_j = M_jj/h² + K_j` (`A = W^{-1/2}(K − H)W^{-1/2}`, so that E's
//! scaled size is the fraction of the step matrix left explicit): `P A Pᵀ = L D Lᵀ` with
//! 1 × 1 pivots, the largest remaining diagonal magnitude first, and
//! `E = W^{1/2} Pᵀ L (D⁺ − D) Lᵀ P W^{1/2}`, `D⁺ = max(D, 0)` (Cheng & Higham, SIAM J.
//! Matrix Anal. Appl. 19, 1998, whose D⁺ keeps a floor where this one keeps zero: the
//! step's matrix holds M/h² besides). Then `K − H + E = W^{1/2}Pᵀ L D⁺ Lᵀ P W^{1/2} ⪰ 0`
//! exactly, and E has the rank of the number of negative eigenvalues of K − H
//! (Sylvester's law of inertia): E = 0 when the strand's total stiffness is positive
//! definite (a strand near a stable rest), and otherwise only the few unstable
//! directions are left explicit — a wavy or curly strand whose curls hang to one side is
//! unstable in twist under gravity (its twist stiffness GJ is far below the weight's
//! moment about the tangent), one or two directions, which a diagonal shift (a
//! Gill–Murray–Wright modified Cholesky) could only cover by shifting every coordinate by
//! a large fraction of the step matrix's diagonal. One factorisation, O(n³/6), and an
//! O(n² r) update for r negative pivots. Without 2 × 2 pivots the factorisation may
//! break down (a pivot far smaller than its column: an entry of L beyond
//! [`SPLIT_GROWTH`]); the caller then takes the spectral projection
//! ([`crate::projection`]), counted. On the embedded N = 5 and N = 10 benches, the
//! shaking head and `superhelix stress --field-stiffness split` that fallback did not
//! occur (docs/performance.md).
//!
//! The identity above is the linearised motion's. The step's nonlinearity (M(q), H(q)
//! taken at the step's start) creates energy of a higher order in h, which the
//! projection's extra dissipation `h² q̇ᵀ (2H⁺) q̇` more than takes out: frictionless
//! falling strands gained up to 0.15 of their energy scale in 0.16 s with this split and
//! the energy balance off (`tests/stability.rs`,
//! `a_frictionless_curly_strand_falling_does_not_gain_energy`), none with the projection.
//! The steps therefore take the split only for strands with internal friction or air
//! drag, whose dissipation is first order in h; a strand with neither keeps the
//! projection.
//!
//! Allocation-free on the caller's storage, f64 and f32.

use crate::float::Float;

/// How the part of the field stiffness in the step's matrix is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FieldRule {
    /// The dissipative split of this module, the spectral projection where its
    /// factorisation breaks down (or for a strand without internal friction or drag).
    Split,
    /// The spectral projection on the negative semidefinite part at every solve (the
    /// default: see docs/performance.md for what the split changes).
    #[default]
    Projected,
}

impl FieldRule {
    /// Whether a strand's solves take the dissipative split under this rule: a strand
    /// with internal friction or air drag (`dissipative`) under [`FieldRule::Split`].
    pub fn splits(self, dissipative: bool) -> bool {
        self == FieldRule::Split && dissipative
    }
}

/// What [`dissipative_split`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SplitOutcome {
    /// No shift: all of H goes into the step's matrix (E = 0, `K − H` positive
    /// semidefinite).
    Whole,
    /// H less a low-rank E ⪰ 0 that makes `K − H + E` positive semidefinite.
    Shifted,
    /// The factorisation broke down, or a value is not finite: take the spectral
    /// projection.
    Beyond,
}

/// Largest entry of the unit lower factor [`dissipative_split`] accepts: beyond, the
/// factorisation without 2 × 2 pivots has broken down (a pivot far smaller than its
/// column) and the caller takes the spectral projection.
pub const SPLIT_GROWTH: f64 = 1e3;

/// The dissipative split of the symmetric field stiffness `h` (n × n, column-major, both
/// triangles) against the elastic stiffness `stiffness` (K's diagonal), in the metric
/// `metric` (w_j > 0; the step's `M_jj/h² + K_j`), by a modified L D Lᵀ factorisation
/// with a low-rank E (Cheng & Higham, "A modified Cholesky algorithm based on a
/// symmetric indefinite factorization", SIAM J. Matrix Anal. Appl. 19, 1998, with 1 × 1
/// pivots): the scaled total stiffness `A = W^{-1/2} (K − H) W^{-1/2}` is factorised as
/// `P A Pᵀ = L D Lᵀ` with symmetric pivoting on the largest remaining diagonal magnitude,
/// and `E = W^{1/2} Pᵀ L (D⁺ − D) Lᵀ P W^{1/2}`, `D⁺ = max(D, 0)`. Then
/// `K − H + E = W^{1/2} Pᵀ L D⁺ Lᵀ P W^{1/2} ⪰ 0` exactly, and E ⪰ 0 has the rank of the
/// number of negative eigenvalues of K − H (Sylvester's law of inertia): only those
/// directions are left explicit, which a diagonal shift cannot do. On success `h` is
/// replaced by `H̃ = H − E` and [`SplitOutcome::Whole`] (E = 0) or
/// [`SplitOutcome::Shifted`] is returned; [`SplitOutcome::Beyond`] (h unchanged) when an
/// input is not finite or an entry of L exceeds [`SPLIT_GROWTH`]. `work` (n²), `scale` (n)
/// and `order` (n) are scratch.
pub fn dissipative_split<T: Float>(
    n: usize,
    h: &mut [T],
    stiffness: &[T],
    metric: &[T],
    work: &mut [T],
    scale: &mut [T],
    order: &mut [usize],
) -> SplitOutcome {
    if h.len() < n * n
        || stiffness.len() < n
        || metric.len() < n
        || work.len() < n * n
        || scale.len() < n
        || order.len() < n
    {
        return SplitOutcome::Beyond;
    }
    let (scale, order) = (&mut scale[..n], &mut order[..n]);
    for j in 0..n {
        let wj = metric[j];
        if wj.not_a_number() || wj <= T::zero() || !wj.is_finite() {
            return SplitOutcome::Beyond;
        }
        scale[j] = T::one() / wj.sqrt();
        order[j] = j;
    }
    // the scaled total stiffness A = W^{-1/2}(K − H)W^{-1/2}, its lower triangle by rows
    // (`work[i * n + k]`, k ≤ i); the strict upper triangle holds, while column j is
    // eliminated, that column's multipliers (`work[j * n + k]`, k > j)
    let work = &mut work[..n * n];
    for i in 0..n {
        for k in 0..=i {
            let mut a = -h[k * n + i];
            if i == k {
                a += stiffness[i];
            }
            let a = a * scale[i] * scale[k];
            if !a.is_finite() {
                return SplitOutcome::Beyond;
            }
            work[i * n + k] = a;
        }
    }
    let growth = T::of(SPLIT_GROWTH);
    let mut negative = false;
    // P A Pᵀ = L D Lᵀ: 1 × 1 pivots, the largest remaining diagonal magnitude first; L
    // below the diagonal (unit diagonal), D on it
    for j in 0..n {
        let mut q = j;
        for i in j + 1..n {
            if work[i * n + i].abs() > work[q * n + q].abs() {
                q = i;
            }
        }
        if q != j {
            // the symmetric swap of rows and columns j and q, in lower storage
            work.swap(j * n + j, q * n + q);
            for k in 0..j {
                work.swap(j * n + k, q * n + k);
            }
            for k in j + 1..q {
                work.swap(k * n + j, q * n + k);
            }
            for k in q + 1..n {
                work.swap(k * n + j, k * n + q);
            }
            order.swap(j, q);
        }
        let d = work[j * n + j];
        if d == T::zero() {
            // a zero pivot: factorisable only when its column is zero too (then L's
            // column is zero and D_j = 0)
            if (j + 1..n).any(|i| work[i * n + j] != T::zero()) {
                return SplitOutcome::Beyond;
            }
            continue;
        }
        if d < T::zero() {
            negative = true;
        }
        let inverse = T::one() / d;
        for i in j + 1..n {
            let l = work[i * n + j] * inverse;
            if l.not_a_number() || l.abs() > growth {
                return SplitOutcome::Beyond;
            }
            work[j * n + i] = l;
        }
        // the Schur complement, row by row: A_ik −= A_ij (A_kj / d)
        for i in j + 1..n {
            let a_ij = work[i * n + j];
            let (head, tail) = work.split_at_mut(i * n);
            let multipliers = &head[j * n + j + 1..j * n + i + 1];
            let row = &mut tail[j + 1..i + 1];
            for (x, &l) in row.iter_mut().zip(multipliers) {
                *x -= a_ij * l;
            }
        }
        for i in j + 1..n {
            work[i * n + j] = work[j * n + i];
        }
    }
    if !negative {
        return SplitOutcome::Whole;
    }
    // H̃ = H − E: each negative pivot adds D_j u uᵀ, u = W^{1/2} Pᵀ l_j (into `scale`'s
    // reciprocal: u_c = l_kj / scale_c at c = order_k); H̃ stays exactly symmetric
    for j in 0..n {
        let d = work[j * n + j];
        if d >= T::zero() {
            continue;
        }
        // u below the pivot, in the strict upper triangle's row j (free once column j
        // is eliminated); u at the pivot is `uj`
        let uj = T::one() / scale[order[j]];
        for k in j + 1..n {
            work[j * n + k] = work[k * n + j] / scale[order[k]];
        }
        let u = |k: usize| if k == j { uj } else { work[j * n + k] };
        for k in j..n {
            let c = order[k];
            let dk = d * u(k);
            for i in j..n {
                let r = order[i];
                if r <= c {
                    let x = h[c * n + r] + dk * u(i);
                    h[c * n + r] = x;
                    h[r * n + c] = x;
                }
            }
        }
    }
    SplitOutcome::Shifted
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`dissipative_split`] of n × n inputs on fresh scratch: H̃ into `h`.
    fn split<T: Float>(h: &mut [T], k: &[T], metric: &[T]) -> SplitOutcome {
        let n = k.len();
        let mut work = std::vec![T::zero(); n * n];
        let mut scale = std::vec![T::zero(); n];
        let mut order = std::vec![0usize; n];
        dissipative_split(n, h, k, metric, &mut work, &mut scale, &mut order)
    }

    /// A symmetric n × n matrix from a seed (entries in [−1, 1]).
    fn symmetric(n: usize, seed: u64) -> std::vec::Vec<f64> {
        let mut state = seed;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let mut a = std::vec![0.0; n * n];
        for j in 0..n {
            for i in j..n {
                let x = next();
                a[j * n + i] = x;
                a[i * n + j] = x;
            }
        }
        a
    }

    /// Whether the symmetric `a` (n × n) has no eigenvalue below `−tol`: `a + tol I`
    /// admits a Cholesky factorisation.
    fn at_least(n: usize, a: &[f64], tol: f64) -> bool {
        let mut b = a.to_vec();
        for j in 0..n {
            b[j * n + j] += tol;
        }
        crate::projection::cholesky(&mut b, n)
    }

    /// The number of eigenvalues of the symmetric `a` (n × n) below −tol, by cyclic
    /// Jacobi rotations (an independent reference for the factorisation's inertia).
    fn negative_count(n: usize, a: &[f64], tol: f64) -> usize {
        let mut m = a.to_vec();
        for _sweep in 0..100 {
            let off: f64 = (0..n)
                .flat_map(|j| (0..n).filter(move |&i| i != j).map(move |i| (i, j)))
                .map(|(i, j)| m[j * n + i] * m[j * n + i])
                .sum();
            if off < 1e-30 {
                break;
            }
            for p in 0..n {
                for q in p + 1..n {
                    let apq = m[q * n + p];
                    if apq == 0.0 {
                        continue;
                    }
                    let theta = (m[q * n + q] - m[p * n + p]) / (2.0 * apq);
                    let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                    let t = if theta == 0.0 { 1.0 } else { t };
                    let c = 1.0 / (t * t + 1.0).sqrt();
                    let s = t * c;
                    for k in 0..n {
                        let (akp, akq) = (m[p * n + k], m[q * n + k]);
                        m[p * n + k] = c * akp - s * akq;
                        m[q * n + k] = s * akp + c * akq;
                    }
                    for k in 0..n {
                        let (apk, aqk) = (m[k * n + p], m[k * n + q]);
                        m[k * n + p] = c * apk - s * aqk;
                        m[k * n + q] = s * apk + c * aqk;
                    }
                }
            }
        }
        (0..n).filter(|&j| m[j * n + j] < -tol).count()
    }

    #[test]
    fn a_positive_definite_total_stiffness_keeps_the_whole_field() {
        let n = 9;
        let mut h = symmetric(n, 3);
        let before = h.clone();
        // K above n, H's largest eigenvalue's bound (Gershgorin): K − H positive definite
        let k = std::vec![n as f64 + 0.1; n];
        let metric = std::vec![5.0; n];
        assert_eq!(split(&mut h, &k, &metric), SplitOutcome::Whole);
        assert_eq!(h, before);
    }

    #[test]
    fn an_indefinite_total_stiffness_is_split_dissipatively_with_e_of_its_negative_rank() {
        // the two conditions of the module's energy identity, K − H̃ ⪰ 0 and
        // K + H − 2H̃ ⪰ 0, and E = H − H̃ ⪰ 0 of rank the number of negative eigenvalues
        // of K − H, checked by eigenvalues for 40 random cases (the reference's count
        // checked first on matrices of known spectrum: {−1, 1}, {1, 3}, {−2, −1, 3})
        assert_eq!(negative_count(2, &[0.0, 1.0, 1.0, 0.0], 1e-12), 1);
        assert_eq!(negative_count(2, &[2.0, 1.0, 1.0, 2.0], 1e-12), 0);
        // diag(−2, −1, 3) turned about the third axis
        let (s1, c1) = (0.8f64, 0.6f64);
        let r = [c1, s1, 0.0, -s1, c1, 0.0, 0.0, 0.0, 1.0];
        let d = [-2.0, -1.0, 3.0];
        let mut m = [0.0; 9];
        for j in 0..3 {
            for i in 0..3 {
                m[j * 3 + i] = (0..3).map(|k| r[k * 3 + i] * d[k] * r[k * 3 + j]).sum();
            }
        }
        assert_eq!(negative_count(3, &m, 1e-12), 2);
        for seed in 0..40 {
            let n = 3 + (seed as usize % 13);
            let h = symmetric(n, seed);
            let k: std::vec::Vec<f64> = (0..n).map(|i| 0.2 + 0.1 * (i % 3) as f64).collect();
            let metric: std::vec::Vec<f64> = (0..n).map(|i| 1.0 + (i % 4) as f64).collect();
            let mut ht = h.clone();
            assert_eq!(
                split(&mut ht, &k, &metric),
                SplitOutcome::Shifted,
                "seed {seed}"
            );
            let mut bare = std::vec![0.0; n * n]; // K − H
            let mut total = std::vec![0.0; n * n]; // K − H̃
            let mut dissipation = std::vec![0.0; n * n]; // K + H − 2H̃
            let mut e = std::vec![0.0; n * n]; // H − H̃
            for j in 0..n {
                for i in 0..n {
                    let diag = if i == j { k[j] } else { 0.0 };
                    let x = j * n + i;
                    bare[x] = diag - h[x];
                    total[x] = diag - ht[x];
                    dissipation[x] = diag + h[x] - 2.0 * ht[x];
                    e[x] = h[x] - ht[x];
                    // H̃ stays symmetric
                    assert!((ht[x] - ht[i * n + j]).abs() <= 1e-12, "seed {seed}");
                }
            }
            let scale = 1.0 + e.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let tol = 1e-10 * scale;
            assert!(at_least(n, &total, tol), "seed {seed}");
            assert!(at_least(n, &dissipation, tol), "seed {seed}");
            assert!(at_least(n, &e, tol), "seed {seed}");
            let negative = negative_count(n, &bare, tol);
            assert!(negative > 0, "seed {seed}: K − H is indefinite");
            // rank of E: its eigenvalues above the tolerance
            let minus_e: std::vec::Vec<f64> = e.iter().map(|x| -x).collect();
            assert_eq!(negative_count(n, &minus_e, tol), negative, "seed {seed}");
        }
    }

    #[test]
    fn a_diagonal_total_stiffness_leaves_exactly_its_negative_part_explicit() {
        // with K − H diagonal the factorisation is the matrix itself: E = (K − H)⁻
        let n = 5;
        let k = [1.0f64, 2.0, 0.5, 3.0, 0.1];
        let hd = [0.5f64, 2.5, 0.2, 4.0, -1.0];
        let mut h = std::vec![0.0; n * n];
        for j in 0..n {
            h[j * n + j] = hd[j];
        }
        let metric = [7.0, 1.0, 3.0, 0.2, 5.0];
        assert_eq!(split(&mut h, &k, &metric), SplitOutcome::Shifted);
        for j in 0..n {
            let e = hd[j] - h[j * n + j];
            let expected = (hd[j] - k[j]).max(0.0);
            assert!((e - expected).abs() <= 1e-14, "{j}: {e} against {expected}");
        }
    }

    #[test]
    fn a_breakdown_or_a_value_not_finite_asks_for_the_projection() {
        // [[0, 1], [1, 0]]: no 1 × 1 pivot (the zero diagonal with its column not zero)
        let k = [0.0, 0.0];
        let metric = [1.0, 1.0];
        let mut h = std::vec![0.0, -1.0, -1.0, 0.0];
        let before = h.clone();
        assert_eq!(split(&mut h, &k, &metric), SplitOutcome::Beyond);
        assert_eq!(h, before);
        let n = 6;
        let mut bad = symmetric(n, 11);
        bad[7] = f64::NAN;
        assert_eq!(
            split(&mut bad, &std::vec![0.1; n], &std::vec![1.0; n]),
            SplitOutcome::Beyond
        );
    }

    #[test]
    fn the_split_in_f32_matches_f64() {
        let n = 7;
        let h = symmetric(n, 5);
        let k = std::vec![0.3; n];
        let metric = std::vec![2.0; n];
        let mut h64 = h.clone();
        assert_eq!(split(&mut h64, &k, &metric), SplitOutcome::Shifted);
        let mut h32: std::vec::Vec<f32> = h.iter().map(|&x| x as f32).collect();
        let (k32, m32) = (std::vec![0.3f32; n], std::vec![2.0f32; n]);
        assert_eq!(split(&mut h32, &k32, &m32), SplitOutcome::Shifted);
        for (a, b) in h64.iter().zip(&h32) {
            assert!((a - *b as f64).abs() <= 1e-4 * (1.0 + a.abs()), "{a} {b}");
        }
    }
}
