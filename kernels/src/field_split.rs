//! The field stiffness in the implicit step's matrix without an eigendecomposition: a
//! dissipative split by a modified Cholesky factorisation.
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
//! This module takes `H̃ = H − E` with E ⪰ 0 diagonal such that `K − H + E ⪰ 0`: then
//! `K − H̃ = K − H + E ⪰ 0` and `K + H − 2H̃ = (K − H + E) + E ⪰ 0`, both conditions
//! hold. E is what a modified Cholesky factorisation `P (K − H + E) Pᵀ = L D Lᵀ` adds to
//! the diagonal (Gill, Murray & Wright, *Practical Optimization*, 1981, §4.4.2.2): the
//! pivot `d_j = max(δ, |c_jj|, θ_j²/β²)`, θ_j the largest entry of the column below it,
//! bounds the factor's entries by β, and the symmetric pivoting takes the largest
//! remaining diagonal first; E is zero when the strand's total stiffness `K − H` is
//! comfortably positive definite (a strand near a stable rest). One factorisation,
//! O(n³/6). The factorisation is taken in the metric of the step matrix's diagonal,
//! `w_j = M_jj/h² + K_j`, so that a scaled shift `E_j/w_j` is the fraction of the step
//! matrix's diagonal left explicit; GMW's floors δ = ε(γ + ξ) and β² are taken relative
//! to the matrix (in this metric K − H is of the order of h²K/M, far below 1 at small h,
//! and an absolute ε would be a large shift in f32). When a scaled shift exceeds the
//! caller's limit ([`SPLIT_LIMIT`]) the split returns [`SplitOutcome::Beyond`] and the
//! caller takes the spectral projection ([`crate::projection`]) instead, counted: a
//! wavy or curly strand whose curls hang to one side is unstable in twist under gravity
//! (its twist stiffness GJ is far below the weight's moment about the tangent), and the
//! diagonal shift that covers such a direction is of the order of the step matrix's
//! diagonal, where the projection, which leaves exactly that direction explicit, is the
//! better split. (Without pivoting, twice as many solves went beyond the limit on the
//! N = 5 bench; at a limit of 1 the f32 step parts from the f64 one on a head that stops
//! suddenly, where the two types cross the limit at different steps.)
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

/// Largest fraction of the step matrix's diagonal a dissipative split may leave explicit
/// (`E_j / (M_jj/h² + K_j)`) before the step takes the spectral projection instead.
pub const SPLIT_LIMIT: f64 = 0.3;

/// How the part of the field stiffness in the step's matrix is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FieldRule {
    /// The dissipative split of this module, the spectral projection where it would
    /// leave more than [`SPLIT_LIMIT`] explicit (or for a strand without internal
    /// friction or drag).
    Split,
    /// The spectral projection on the negative semidefinite part at every solve (the
    /// default, until the split's fallback is rare on a shaking head).
    #[default]
    Projected,
}

/// What [`dissipative_split`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SplitOutcome {
    /// No shift: all of H goes into the step's matrix (E = 0, `K − H` positive
    /// definite).
    Whole,
    /// A diagonal E ⪰ 0 within the limit makes `K − H + E` positive definite.
    Shifted,
    /// The split would leave more than the limit explicit, or a value is not finite:
    /// take the spectral projection.
    Beyond,
}

/// The dissipative split of the symmetric field stiffness `h` (n × n, column-major, both
/// triangles) against the elastic stiffness `stiffness` (K's diagonal), in the metric
/// `metric` (w_j > 0; the step's `M_jj/h² + K_j`): fills `shift` with E's diagonal (in
/// the units of H) and returns [`SplitOutcome::Whole`] or [`SplitOutcome::Shifted`];
/// [`SplitOutcome::Beyond`] when a scaled shift `E_j/w_j` exceeds `limit` or an input is
/// not finite (`shift` then undefined). `work` (n², column-major) is scratch; `h` is
/// read only: the caller subtracts E from its diagonal.
pub fn dissipative_split<T: Float>(
    n: usize,
    h: &[T],
    stiffness: &[T],
    metric: &[T],
    limit: T,
    work: &mut [T],
    shift: &mut [T],
    order: &mut [usize],
) -> SplitOutcome {
    if h.len() < n * n
        || stiffness.len() < n
        || metric.len() < n
        || work.len() < n * n
        || shift.len() < n
        || order.len() < n
    {
        return SplitOutcome::Beyond;
    }
    let (shift, order) = (&mut shift[..n], &mut order[..n]);
    // the scaled total stiffness a = W^{-1/2} (K − H) W^{-1/2}, lower triangle
    let fill = |work: &mut [T], shift: &mut [T]| -> bool {
        for j in 0..n {
            let wj = metric[j];
            if wj.not_a_number() || wj <= T::zero() || !wj.is_finite() {
                return false;
            }
            shift[j] = T::one() / wj.sqrt();
        }
        for j in 0..n {
            for i in j..n {
                let mut a = -h[j * n + i];
                if i == j {
                    a += stiffness[j];
                }
                let a = a * shift[i] * shift[j];
                if !a.is_finite() {
                    return false;
                }
                work[j * n + i] = a;
            }
        }
        true
    };
    if !fill(work, shift) {
        return SplitOutcome::Beyond;
    }
    // full symmetric copy (the lower triangle filled above)
    for j in 0..n {
        for i in j + 1..n {
            work[i * n + j] = work[j * n + i];
        }
    }
    // Gill–Murray–Wright: γ, ξ the largest diagonal and off-diagonal magnitudes
    let (mut gamma, mut xi) = (T::zero(), T::zero());
    for j in 0..n {
        gamma = gamma.max(work[j * n + j].abs());
        for i in j + 1..n {
            xi = xi.max(work[j * n + i].abs());
        }
    }
    let eps = T::EPSILON;
    let off_bound = if n > 1 {
        xi / T::of((n * n - 1) as f64).sqrt()
    } else {
        T::zero()
    };
    // (relative to the matrix, not GMW's absolute floors max(·, ε) and max(·, 1): in the
    // metric of the step's matrix K − H is of the order of h²K/M, far below 1 at small h,
    // and an absolute ε would be a large shift in f32 there)
    let beta2 = gamma.max(off_bound);
    let delta = eps * (gamma + xi);
    // right-looking L D Lᵀ = P (A + E) Pᵀ with symmetric pivoting on the largest
    // remaining diagonal (GMW's choice): order[k] is the coordinate in position k
    for (k, o) in order.iter_mut().enumerate() {
        *o = k;
    }
    for j in 0..n {
        {
            let mut q = j;
            for i in j + 1..n {
                if work[i * n + i].abs() > work[q * n + q].abs() {
                    q = i;
                }
            }
            if q != j {
                for k in 0..n {
                    work.swap(k * n + j, k * n + q);
                }
                for k in 0..n {
                    work.swap(j * n + k, q * n + k);
                }
                order.swap(j, q);
            }
        }
        let c_jj = work[j * n + j];
        let mut theta = T::zero();
        for i in j + 1..n {
            theta = theta.max(work[j * n + i].abs());
        }
        let bound = if beta2 > T::zero() {
            theta * theta / beta2
        } else {
            T::zero()
        };
        let d = delta.max(c_jj.abs()).max(bound);
        let e = d - c_jj;
        if e.not_a_number() || e > limit {
            return SplitOutcome::Beyond;
        }
        let inverse = if d > T::zero() {
            T::one() / d
        } else {
            T::zero()
        };
        // the trailing Schur complement, both triangles
        for k in j + 1..n {
            let ck = work[j * n + k];
            let f = ck * inverse;
            for i in k..n {
                let v = work[k * n + i] - f * work[j * n + i];
                work[k * n + i] = v;
                work[i * n + k] = v;
            }
        }
        for i in j + 1..n {
            work[j * n + i] *= inverse;
            work[i * n + j] = work[j * n + i];
        }
        // (d_j is not read again: the diagonal keeps the scaled shift)
        work[j * n + j] = e;
    }
    // unscaled E of coordinate order[j]: e_j w = e_j / scale², the scales read before
    // `shift` is overwritten
    for j in 0..n {
        let scale = shift[order[j]];
        work[j * n + j] /= scale * scale;
    }
    for j in 0..n {
        shift[order[j]] = work[j * n + j];
    }
    if shift.iter().all(|&e| e == T::zero()) {
        return SplitOutcome::Whole;
    }
    SplitOutcome::Shifted
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`dissipative_split`] of n × n inputs on fresh scratch; the shift into `shift`.
    fn split<T: Float>(
        h: &[T],
        k: &[T],
        metric: &[T],
        limit: f64,
        shift: &mut [T],
    ) -> SplitOutcome {
        let n = k.len();
        let mut work = std::vec![T::zero(); n * n];
        let mut order = std::vec![0usize; n];
        dissipative_split(n, h, k, metric, T::of(limit), &mut work, shift, &mut order)
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

    #[test]
    fn a_positive_definite_total_stiffness_keeps_the_whole_field() {
        let n = 9;
        let h = symmetric(n, 3);
        // K above n, H's largest eigenvalue's bound (Gershgorin): K − H positive definite
        let k = std::vec![n as f64 + 0.1; n];
        let metric = std::vec![5.0; n];
        let mut shift = std::vec![1.0; n];
        let out = split(&h, &k, &metric, 10.0, &mut shift);
        assert_eq!(out, SplitOutcome::Whole);
        assert!(shift.iter().all(|&e| e == 0.0));
    }

    #[test]
    fn an_indefinite_total_stiffness_is_shifted_to_a_dissipative_split() {
        // the two conditions of the module's energy identity, K − H̃ ⪰ 0 and
        // K + H − 2H̃ ⪰ 0 with H̃ = H − E, checked by eigenvalues for 40 random cases
        for seed in 0..40 {
            let n = 3 + (seed as usize % 13);
            let h = symmetric(n, seed);
            let k: std::vec::Vec<f64> = (0..n).map(|i| 0.2 + 0.1 * (i % 3) as f64).collect();
            let metric: std::vec::Vec<f64> = (0..n).map(|i| 1.0 + (i % 4) as f64).collect();
            let mut shift = std::vec![0.0; n];
            let out = split(&h, &k, &metric, 1e9, &mut shift);
            assert_eq!(out, SplitOutcome::Shifted, "seed {seed}");
            assert!(shift.iter().all(|&e| e >= 0.0));
            let mut total = std::vec![0.0; n * n]; // K − H + E
            let mut dissipation = std::vec![0.0; n * n]; // K + H − 2(H − E)
            for j in 0..n {
                for i in 0..n {
                    let diag = if i == j { 1.0 } else { 0.0 };
                    total[j * n + i] = diag * (k[j] + shift[j]) - h[j * n + i];
                    dissipation[j * n + i] = diag * (k[j] + 2.0 * shift[j]) - h[j * n + i];
                }
            }
            let scale = 1.0 + shift.iter().cloned().fold(0.0, f64::max);
            assert!(at_least(n, &total, 1e-12 * scale), "seed {seed}");
            assert!(at_least(n, &dissipation, 1e-12 * scale), "seed {seed}");
            // and the split is not the trivial one: K − H itself is indefinite
            let bare: std::vec::Vec<f64> = (0..n * n)
                .map(|x| if x % (n + 1) == 0 { k[x / n] } else { 0.0 } - h[x])
                .collect();
            assert!(!at_least(n, &bare, 0.0), "seed {seed}");
        }
    }

    #[test]
    fn a_shift_beyond_the_limit_asks_for_the_projection() {
        let n = 6;
        let h = symmetric(n, 11);
        let k = std::vec![0.01; n];
        let metric = std::vec![1.0; n];
        let mut shift = std::vec![0.0; n];
        assert_eq!(
            split(&h, &k, &metric, 1e-3, &mut shift),
            SplitOutcome::Beyond
        );
        let mut bad = h.clone();
        bad[7] = f64::NAN;
        assert_eq!(
            split(&bad, &k, &metric, 1e9, &mut shift),
            SplitOutcome::Beyond
        );
    }

    #[test]
    fn the_split_in_f32_shifts_as_in_f64() {
        let n = 7;
        let h = symmetric(n, 5);
        let k = std::vec![0.3; n];
        let metric = std::vec![2.0; n];
        let mut shift = std::vec![0.0; n];
        split(&h, &k, &metric, 1e9, &mut shift);
        let h32: std::vec::Vec<f32> = h.iter().map(|&x| x as f32).collect();
        let (k32, m32) = (std::vec![0.3f32; n], std::vec![2.0f32; n]);
        let mut s32 = std::vec![0.0f32; n];
        let out = split(&h32, &k32, &m32, 1e9, &mut s32);
        assert_eq!(out, SplitOutcome::Shifted);
        for (a, b) in shift.iter().zip(&s32) {
            assert!((a - *b as f64).abs() <= 1e-4 * (1.0 + a.abs()), "{a} {b}");
        }
    }
}
