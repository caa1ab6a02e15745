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
//! semidefinite part of H (`K + |H| ⪰ 0`), and needs an eigendecomposition.
//!
//! This module takes `H̃ = H − E` with E ⪰ 0 such that `H̃ = H − E ⪯ 0`, as the projection
//! does, but E from one factorisation instead of an eigendecomposition: then
//! `K − H̃ ⪰ K ⪰ 0` and `K + H − 2H̃ = K + (E − H) + E ⪰ 0`, both conditions hold, and the
//! part left explicit covers the directions where the field pulls away from the
//! configuration, as the projection's `E = H⁺` does (so the step damps those
//! directions as the projection's does: a rule that left less of H explicit, E from
//! `K − H`, changed f32/f64 agreement and the rod tests' step-size consistency). E comes
//! from a factorisation of `−H` in the metric of the step matrix's diagonal
//! `w_j = M_jj/h² + K_j` (`A = −W^{-1/2} H W^{-1/2}`, so that E's scaled size is the
//! fraction of the step matrix left explicit): `P A Pᵀ = L D Lᵀ` with 1 × 1 pivots and
//! `E = W^{1/2} Pᵀ L (D⁺ − D) Lᵀ P W^{1/2}`, `D⁺ = max(D, 0)` (Cheng & Higham, SIAM J.
//! Matrix Anal. Appl. 19, 1998, whose D⁺ keeps a floor where this one keeps zero: the
//! step's matrix holds M/h² + K besides). Then `E − H = W^{1/2}Pᵀ L D⁺ Lᵀ P W^{1/2} ⪰ 0`
//! exactly, and E has the rank of the number of positive eigenvalues of H (Sylvester's
//! law of inertia): E = 0 when −H is positive semidefinite (the projection's "definite"
//! case), otherwise the few directions the field destabilises (a wavy or curly strand
//! whose curls hang to one side is unstable in twist under gravity; the head's
//! fictitious forces add a few more). E differs from H⁺ in its size along those
//! directions, not in its rank.
//!
//! The pivots follow the strand's order (root first) unless a later diagonal is more
//! than [`PIVOT_MARGIN`] times the current one in magnitude (threshold pivoting): a
//! pivot order chosen among near ties changes E from one step to the next and between
//! f32 and f64, which lightly damped strands amplify (`runtime/tests/fixed_step_f32.rs`:
//! pivoting on the largest diagonal at every column parted the f32 and f64 runs of a
//! wavy N = 20 strand after a sudden stop by 76 ε₃₂, 64 allowed; with the margin, 2.7 ε₃₂;
//! a margin of 2 let the 3 Hz shake of `tests/stability.rs` grow a strand's mean kinetic
//! energy 2.3-fold, 1.5 allowed, and 4 holds both).
//! One factorisation, O(n³/6), and an O(n² r) update for r positive directions. Without
//! 2 × 2 pivots the factorisation may break down (a pivot far smaller than its column:
//! an entry of L beyond [`SPLIT_GROWTH`]); the caller then takes the spectral projection
//! ([`crate::projection`]), counted. On the embedded N = 5 and N = 10 benches and the
//! shaking head that fallback did not occur (docs/performance.md).
//!
//! The identity above is the linearised motion's. The step's nonlinearity (M(q), H(q)
//! taken at the step's start) creates energy of a higher order in h. The steps take the
//! split for strands with internal friction or air drag, whose dissipation is first
//! order in h; a strand with neither keeps the projection, whose E = H⁺ is the smallest
//! that holds (`tests/stability.rs`,
//! `a_frictionless_curly_strand_falling_does_not_gain_energy`). The runtime keeps the
//! projection too for a strand that touches a body or another strand, is held at an end
//! or carries point loads: their stiffness is in H there and the rod tests' step-size
//! consistency was set on the projection's treatment of it.
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
    /// default: see docs/performance.md for what keeps the split from being it).
    #[default]
    Projected,
    /// No field stiffness in the step's matrix (the runtime's `field_stiffness =
    /// "explicit"`, the step budget's): only the contacts' stiffness along their
    /// Jacobians, without the strand's curvature, unprojected. A step that must be split
    /// takes [`FieldRule::Projected`] in its pieces.
    Explicit,
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
    /// No shift: all of H goes into the step's matrix (E = 0, −H positive
    /// semidefinite).
    Whole,
    /// H less a low-rank E ⪰ 0 that makes `H − E` negative semidefinite.
    Shifted,
    /// The factorisation broke down, or a value is not finite: take the spectral
    /// projection.
    Beyond,
}

/// Largest entry of the unit lower factor [`dissipative_split`] accepts: beyond, the
/// factorisation without 2 × 2 pivots has broken down (a pivot far smaller than its
/// column) and the caller takes the spectral projection.
pub const SPLIT_GROWTH: f64 = 1e3;

/// How much larger in magnitude a later diagonal must be than the current one for
/// [`dissipative_split`] to pivot on it (threshold pivoting: near ties keep the strand's
/// order, so E does not jump between pivot orders from one step to the next or between
/// f32 and f64).
pub const PIVOT_MARGIN: f64 = 4.0;

/// The dissipative split of the symmetric field stiffness `h` (n × n, column-major, both
/// triangles) in the metric `metric` (w_j > 0; the step's `M_jj/h² + K_j`), by a modified
/// L D Lᵀ factorisation with a low-rank E (Cheng & Higham, "A modified Cholesky algorithm
/// based on a symmetric indefinite factorization", SIAM J. Matrix Anal. Appl. 19, 1998,
/// with 1 × 1 pivots): `A = −W^{-1/2} H W^{-1/2}` is factorised as `P A Pᵀ = L D Lᵀ`
/// with threshold pivoting on the diagonal ([`PIVOT_MARGIN`]), and
/// `E = W^{1/2} Pᵀ L (D⁺ − D) Lᵀ P W^{1/2}`, `D⁺ = max(D, 0)`. Then
/// `E − H = W^{1/2} Pᵀ L D⁺ Lᵀ P W^{1/2} ⪰ 0` exactly, and E ⪰ 0 has the rank of the
/// number of positive eigenvalues of H (Sylvester's law of inertia). On success `h` is
/// replaced by `H̃ = H − E ⪯ 0` and [`SplitOutcome::Whole`] (E = 0) or
/// [`SplitOutcome::Shifted`] is returned; [`SplitOutcome::Beyond`] (h unchanged) when an
/// input is not finite or an entry of L exceeds [`SPLIT_GROWTH`]. `work` (n²), `scale` (n)
/// and `order` (n) are scratch. With K the step's elastic stiffness, `K − H̃ ⪰ K` and
/// `K + H − 2H̃ ⪰ K + E`: the linearised step is dissipative (module page).
pub fn dissipative_split<T: Float>(
    n: usize,
    h: &mut [T],
    metric: &[T],
    work: &mut [T],
    scale: &mut [T],
    order: &mut [usize],
) -> SplitOutcome {
    if h.len() < n * n
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
    // the scaled A = −W^{-1/2} H W^{-1/2}, its lower triangle by rows
    // (`work[i * n + k]`, k ≤ i); the strict upper triangle holds, while column j is
    // eliminated, that column's multipliers (`work[j * n + k]`, k > j)
    let work = &mut work[..n * n];
    for i in 0..n {
        for k in 0..=i {
            let a = -h[k * n + i] * scale[i] * scale[k];
            if !a.is_finite() {
                return SplitOutcome::Beyond;
            }
            work[i * n + k] = a;
        }
    }
    let growth = T::of(SPLIT_GROWTH);
    let margin = T::of(PIVOT_MARGIN);
    let mut negative = false;
    // P A Pᵀ = L D Lᵀ: 1 × 1 pivots, the largest remaining diagonal magnitude when it
    // exceeds the current one by the margin; L below the diagonal (unit diagonal), D on it
    for j in 0..n {
        let mut q = j;
        for i in j + 1..n {
            if work[i * n + i].abs() > work[q * n + q].abs() {
                q = i;
            }
        }
        if work[q * n + q].abs() <= margin * work[j * n + j].abs() {
            q = j;
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
    // H̃ = H − E = H + W^{1/2} Pᵀ F P W^{1/2}, F = Σ_{D_j < 0} D_j l_j l_jᵀ (l_j column j
    // of L, unit at j). L's columns, in the final pivot order in the lower triangle (a
    // later swap exchanges rows there, not in the multipliers' upper copies), go to the
    // strict upper triangle's rows (`work[j * n + k]`, k > j); F is summed in the lower
    // triangle by rows, pivots from the last, so that D_j is still on the diagonal when
    // its pivot is met and each pivot's update is contiguous in each row. F's strict
    // lower triangle starts at zero, its diagonal at D (a negative D_j is its own pivot's
    // term D_j · 1 · 1; a non-negative one is cleared when its pivot is met)
    for i in 1..n {
        for k in 0..i {
            work[k * n + i] = work[i * n + k];
        }
        work[i * n..i * n + i].fill(T::zero());
    }
    for j in (0..n).rev() {
        let d = work[j * n + j];
        if d >= T::zero() {
            work[j * n + j] = T::zero();
            continue;
        }
        let (head, tail) = work.split_at_mut((j + 1) * n);
        let l = &head[j * n + j + 1..j * n + n];
        for (r, row) in tail.chunks_exact_mut(n).enumerate() {
            // row i = j + 1 + r of F, columns j..=i
            let a = d * l[r];
            row[j] += a;
            for (x, &lk) in row[j + 1..j + 2 + r].iter_mut().zip(&l[..=r]) {
                *x += a * lk;
            }
        }
    }
    // into H, each unordered pair of H's indices once (i ≥ k in the pivot order), read
    // from H's upper triangle and written to both, so that H̃ is exactly symmetric
    for i in 0..n {
        let r = order[i];
        for k in 0..=i {
            let c = order[k];
            let (lo, hi) = if r <= c { (r, c) } else { (c, r) };
            let x = h[hi * n + lo] + work[i * n + k] / (scale[r] * scale[c]);
            h[hi * n + lo] = x;
            h[lo * n + hi] = x;
        }
    }
    SplitOutcome::Shifted
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`dissipative_split`] of n × n inputs on fresh scratch: H̃ into `h`.
    fn split<T: Float>(h: &mut [T], metric: &[T]) -> SplitOutcome {
        let n = metric.len();
        let mut work = std::vec![T::zero(); n * n];
        let mut scale = std::vec![T::zero(); n];
        let mut order = std::vec![0usize; n];
        dissipative_split(n, h, metric, &mut work, &mut scale, &mut order)
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
    fn a_negative_definite_field_stiffness_goes_whole_into_the_matrix() {
        let n = 9;
        // H = S − (n + 0.1) I: S's eigenvalues are below n (Gershgorin), so −H ≻ 0
        let mut h = symmetric(n, 3);
        for j in 0..n {
            h[j * n + j] -= n as f64 + 0.1;
        }
        let before = h.clone();
        let metric = std::vec![5.0; n];
        assert_eq!(split(&mut h, &metric), SplitOutcome::Whole);
        assert_eq!(h, before);
    }

    #[test]
    fn an_indefinite_field_stiffness_is_split_dissipatively_with_e_of_its_positive_rank() {
        // the reference count of negative eigenvalues itself, on known spectra
        assert_eq!(negative_count(2, &[0.0, 1.0, 1.0, 0.0], 1e-12), 1);
        assert_eq!(negative_count(2, &[2.0, 1.0, 1.0, 2.0], 1e-12), 0);
        // R diag(−2, −1, 3) Rᵀ with R a rotation: two negative eigenvalues
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
        let mut shifted = 0;
        for seed in 0..40 {
            let n = 3 + (seed as usize % 13);
            let h = symmetric(n, seed);
            let metric: std::vec::Vec<f64> = (0..n).map(|i| 1.0 + (i % 4) as f64).collect();
            let mut ht = h.clone();
            let outcome = split(&mut ht, &metric);
            if outcome == SplitOutcome::Beyond {
                // a breakdown leaves h as it was, for the projection
                assert_eq!(ht, h, "seed {seed}");
                continue;
            }
            assert_eq!(outcome, SplitOutcome::Shifted, "seed {seed}");
            shifted += 1;
            let mut minus_h = std::vec![0.0; n * n]; // −H
            let mut minus_ht = std::vec![0.0; n * n]; // −H̃
            let mut e = std::vec![0.0; n * n]; // H − H̃
            for j in 0..n {
                for i in 0..n {
                    let x = j * n + i;
                    minus_h[x] = -h[x];
                    minus_ht[x] = -ht[x];
                    e[x] = h[x] - ht[x];
                    // H̃ stays exactly symmetric
                    assert_eq!(ht[x], ht[i * n + j], "seed {seed}");
                }
            }
            let scale = 1.0 + e.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let tol = 1e-10 * scale;
            // H̃ ⪯ 0 and E ⪰ 0: with any K ⪰ 0, K − H̃ ⪰ 0 and K + H − 2H̃ = K − H̃ + E ⪰ 0
            assert!(at_least(n, &minus_ht, tol), "seed {seed}");
            assert!(at_least(n, &e, tol), "seed {seed}");
            let positive = negative_count(n, &minus_h, tol);
            assert!(positive > 0, "seed {seed}: H has a positive direction");
            // rank of E: the number of positive eigenvalues of H
            let minus_e: std::vec::Vec<f64> = e.iter().map(|x| -x).collect();
            assert_eq!(negative_count(n, &minus_e, tol), positive, "seed {seed}");
        }
        // random symmetric matrices rarely break the 1 × 1 pivots down
        assert!(shifted >= 36, "{shifted} of 40 split");
    }

    #[test]
    fn a_diagonal_field_stiffness_leaves_exactly_its_positive_part_explicit() {
        // with H diagonal the factorisation is the matrix itself: E = H⁺, the projection's
        let n = 5;
        let hd = [0.5f64, -2.5, 0.2, 4.0, -1.0];
        let mut h = std::vec![0.0; n * n];
        for j in 0..n {
            h[j * n + j] = hd[j];
        }
        let metric = [7.0, 1.0, 3.0, 0.2, 5.0];
        assert_eq!(split(&mut h, &metric), SplitOutcome::Shifted);
        for j in 0..n {
            let e = hd[j] - h[j * n + j];
            let expected = hd[j].max(0.0);
            assert!((e - expected).abs() <= 1e-14, "{j}: {e} against {expected}");
        }
    }

    #[test]
    fn near_ties_keep_the_strands_order_and_a_clear_maximum_is_pivoted_on() {
        // −H's diagonal (1, 1.5, −(m + 1)), m the margin: 1.5 is within the margin of the
        // first pivot, the magnitude m + 1 beyond it, so the last coordinate is pivoted on
        // first and the others keep their order; with (1, 1.5, −(m − 0.1)) nothing is
        // beyond the margin, before or after the first elimination (m + 0.15 < 1.5 m)
        let n = 3;
        let m = PIVOT_MARGIN;
        let mut h = std::vec![-1.0, 0.0, 0.5, 0.0, -1.5, 0.0, 0.5, 0.0, m + 1.0];
        let metric = [1.0; 3];
        let mut work = std::vec![0.0; 9];
        let (mut scale, mut order) = (std::vec![0.0; 3], std::vec![0usize; 3]);
        assert_eq!(
            dissipative_split(n, &mut h, &metric, &mut work, &mut scale, &mut order),
            SplitOutcome::Shifted
        );
        assert_eq!(order, [2, 1, 0]);
        let mut h = std::vec![-1.0, 0.0, 0.5, 0.0, -1.5, 0.0, 0.5, 0.0, m - 0.1];
        assert_eq!(
            dissipative_split(n, &mut h, &metric, &mut work, &mut scale, &mut order),
            SplitOutcome::Shifted
        );
        assert_eq!(order, [0, 1, 2]);
    }

    #[test]
    fn a_breakdown_or_a_value_not_finite_asks_for_the_projection() {
        // [[0, 1], [1, 0]]: no 1 × 1 pivot (the zero diagonal with its column not zero)
        let metric = [1.0, 1.0];
        let mut h = std::vec![0.0, 1.0, 1.0, 0.0];
        let before = h.clone();
        assert_eq!(split(&mut h, &metric), SplitOutcome::Beyond);
        assert_eq!(h, before);
        let n = 6;
        let mut bad = symmetric(n, 11);
        bad[7] = f64::NAN;
        assert_eq!(split(&mut bad, &std::vec![1.0; n]), SplitOutcome::Beyond);
    }

    #[test]
    fn the_split_in_f32_matches_f64() {
        let n = 7;
        let h = symmetric(n, 5);
        let metric = std::vec![2.0; n];
        let mut h64 = h.clone();
        assert_eq!(split(&mut h64, &metric), SplitOutcome::Shifted);
        let mut h32: std::vec::Vec<f32> = h.iter().map(|&x| x as f32).collect();
        let m32 = std::vec![2.0f32; n];
        assert_eq!(split(&mut h32, &m32), SplitOutcome::Shifted);
        for (a, b) in h64.iter().zip(&h32) {
            assert!((a - *b as f64).abs() <= 1e-4 * (1.0 + a.abs()), "{a} {b}");
        }
    }
}
