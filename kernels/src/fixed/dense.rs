//! Dense linear algebra of the step on column-major n × n matrices ([`Square`]: `a[c][r]`
//! is row r of column c, T = f64 or f32): LU with partial pivoting, and the negative
//! semidefinite part of a symmetric matrix.

use crate::float::Float;
use crate::storage::Square;

/// LU-factor `a` with partial pivoting (Golub & Van Loan, algorithm 3.4.1) and solve
/// `a x = b` in place (`b`, n long, becomes x; `pivots` n long). Returns false, with `a`
/// and `b` overwritten, when a pivot is zero or the solution is not finite.
pub fn lu_solve<T: Float>(a: &mut Square<'_, T>, b: &mut [T], pivots: &mut [usize]) -> bool {
    lu_solve_sized::<T, 0>(a, b, pivots)
}

/// [`lu_solve`] with the matrices' size `NC` known at compile time (0: not known; false
/// when `a` is of another size).
///
/// Compiled twice, for the baseline target and with AVX2 (the same bits), as the
/// spectral projection's products are.
pub(crate) fn lu_solve_sized<T: Float, const NC: usize>(
    a: &mut Square<'_, T>,
    b: &mut [T],
    pivots: &mut [usize],
) -> bool {
    #[cfg(all(target_arch = "x86_64", feature = "std", not(target_feature = "avx2")))]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { lu_solve_avx2::<T, NC>(a, b, pivots) };
        }
    }
    lu_solve_body::<T, NC>(a, b, pivots)
}

/// [`lu_solve_sized`] compiled with AVX2.
#[cfg(all(target_arch = "x86_64", feature = "std", not(target_feature = "avx2")))]
#[target_feature(enable = "avx2")]
fn lu_solve_avx2<T: Float, const NC: usize>(
    a: &mut Square<'_, T>,
    b: &mut [T],
    pivots: &mut [usize],
) -> bool {
    lu_solve_body::<T, NC>(a, b, pivots)
}

/// The body of [`lu_solve_sized`].
#[inline(always)]
fn lu_solve_body<T: Float, const NC: usize>(
    a: &mut Square<'_, T>,
    b: &mut [T],
    pivots: &mut [usize],
) -> bool {
    let n = if NC != 0 { NC } else { a.n() };
    if a.n() != n || b.len() != n || pivots.len() != n {
        return false;
    }
    for k in 0..n {
        // pivot: the largest entry of column k at or below the diagonal
        let mut p = k;
        let mut best = a[k][k].abs();
        for r in k + 1..n {
            let x = a[k][r].abs();
            if x > best {
                best = x;
                p = r;
            }
        }
        pivots[k] = p;
        if best == T::zero() || !best.is_finite() {
            return false;
        }
        if p != k {
            a.swap_rows(k, p);
        }
        let inv = T::one() / a[k][k];
        for r in k + 1..n {
            a[k][r] *= inv;
        }
        for c in k + 1..n {
            let akc = a[c][k];
            if akc != T::zero() {
                let (lk, col) = a.column_pair(k, c);
                for r in k + 1..n {
                    col[r] -= lk[r] * akc;
                }
            }
        }
    }
    lu_solve_factored(a, pivots, b)
}

/// Solve `a x = b` in place (`b`, n long, becomes x) with the factors [`lu_solve`] left
/// in `a` and `pivots`: another right-hand side of the same matrix (the columns of the
/// contacts that start within a step, on the step's matrix) for two triangular solves.
/// Returns false when the solution is not finite.
pub fn lu_solve_factored<T: Float>(a: &Square<'_, T>, pivots: &[usize], b: &mut [T]) -> bool {
    let n = a.n();
    if b.len() != n || pivots.len() != n {
        return false;
    }
    // P b, then L y = P b (unit lower), then U x = y
    for k in 0..n {
        b.swap(k, pivots[k]);
    }
    for c in 0..n {
        let bc = b[c];
        let col = &a[c];
        for r in c + 1..n {
            b[r] -= col[r] * bc;
        }
    }
    for c in (0..n).rev() {
        let col = &a[c];
        b[c] /= col[c];
        let bc = b[c];
        for r in 0..c {
            b[r] -= col[r] * bc;
        }
    }
    b.iter().all(|x| x.is_finite())
}

/// How the stabilising part of the field stiffness was obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Projection {
    /// The dissipative split ([`crate::field_split`]): K − H is positive semidefinite,
    /// all of H is in the step's matrix.
    Whole,
    /// The dissipative split: H less a low-rank E ⪰ 0 that makes K − H + E positive
    /// semidefinite.
    Shifted,
    /// −H is positive definite (a Cholesky factorisation succeeded): H is its own part.
    Definite,
    /// By an eigendecomposition (partial, of the smaller side of the spectrum, or the
    /// full Jacobi decomposition when that fails its checks).
    Decomposed,
    /// In the eigenbasis the strand kept from an earlier step (it still splits H).
    Reused,
    /// The same H as the last projection of this step (a split step starts again from
    /// the same state): the same result.
    Repeated,
    /// The matrix holds a value that is not finite: left unchanged, the stiffness stays
    /// explicit.
    Failed,
    /// Not projected ([`crate::field_split::FieldRule::Explicit`]): the contacts'
    /// stiffness along their Jacobians, negative semidefinite as it is.
    Unprojected,
}

/// Cholesky factorisation of the symmetric `a` (lower triangle read; the factor
/// overwrites it). False when `a` is not numerically positive definite.
fn cholesky<T: Float>(a: &mut Square<'_, T>) -> bool {
    let n = a.n();
    for j in 0..n {
        let mut d = a[j][j];
        for k in 0..j {
            d -= a[k][j] * a[k][j];
        }
        if d.not_a_number() || d <= T::zero() || !d.is_finite() {
            return false;
        }
        let d = d.sqrt();
        a[j][j] = d;
        for i in j + 1..n {
            let mut s = a[j][i];
            for k in 0..j {
                s -= a[k][i] * a[k][j];
            }
            a[j][i] = s / d;
        }
    }
    true
}

/// Replace the symmetric `h` (both triangles) by its negative semidefinite part
/// `U min(Λ, 0) Uᵀ`: itself when −h is positive definite (one Cholesky factorisation
/// says so), else from the cyclic Jacobi eigendecomposition (Golub & Van Loan,
/// algorithm 8.5.3) in `vectors`, `values`.
pub fn negative_semidefinite_part<T: Float>(
    h: &mut Square<'_, T>,
    vectors: &mut Square<'_, T>,
    values: &mut [T],
) -> Projection {
    let n = h.n();
    if !h.as_slice().iter().all(|x| x.is_finite()) {
        return Projection::Failed;
    }
    for c in 0..n {
        for r in 0..n {
            vectors[c][r] = -h[c][r];
        }
    }
    if cholesky(vectors) {
        return Projection::Definite;
    }
    // Jacobi on h itself (its values are not needed after), v = I
    let scale: T = h.as_slice().iter().map(|&x| x * x).sum();
    let a = &mut *h;
    for c in 0..n {
        for r in 0..n {
            vectors[c][r] = if r == c { T::one() } else { T::zero() };
        }
    }
    // the off-diagonal part below (ε²-level, 1e-32 in f64) of the whole: converged
    let converged = T::of(1e-32 * T::EPSILON_RATIO * T::EPSILON_RATIO);
    for _sweep in 0..60 {
        let mut off = T::zero();
        for c in 0..n {
            for r in 0..c {
                off += a[c][r] * a[c][r];
            }
        }
        if off <= converged * scale {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[q][p];
                if apq == T::zero() {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (T::of(2.0) * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + T::one()).sqrt());
                let t = if theta == T::zero() { T::one() } else { t };
                let cs = T::one() / (t * t + T::one()).sqrt();
                let sn = t * cs;
                // A ← Jᵀ A J on rows and columns p, q
                for k in 0..n {
                    let (akp, akq) = (a[p][k], a[q][k]);
                    a[p][k] = cs * akp - sn * akq;
                    a[q][k] = sn * akp + cs * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[k][p], a[k][q]);
                    a[k][p] = cs * apk - sn * aqk;
                    a[k][q] = sn * apk + cs * aqk;
                }
                for k in 0..n {
                    let (vkp, vkq) = (vectors[p][k], vectors[q][k]);
                    vectors[p][k] = cs * vkp - sn * vkq;
                    vectors[q][k] = sn * vkp + cs * vkq;
                }
            }
        }
    }
    for i in 0..n {
        values[i] = h[i][i].min(T::zero());
    }
    for c in 0..n {
        for r in 0..=c {
            let mut s = T::zero();
            for k in 0..n {
                s += vectors[k][r] * values[k] * vectors[k][c];
            }
            h[c][r] = s;
            h[r][c] = s;
        }
    }
    Projection::Decomposed
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Deterministic values in [-1, 1] (also the lane LU's test values).
    pub(crate) fn values(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed;
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        }
    }

    #[test]
    fn lu_solve_gives_a_small_residual_and_refuses_a_singular_matrix() {
        const D: usize = 15;
        let mut next = values(7);
        let a: [[f64; D]; D] = core::array::from_fn(|_| core::array::from_fn(|_| next()));
        let b: [f64; D] = core::array::from_fn(|_| next());
        let (mut lu, mut x, mut piv) = (a, b, [0; D]);
        assert!(lu_solve(&mut Square::of_array(&mut lu), &mut x, &mut piv));
        for r in 0..D {
            let ax: f64 = (0..D).map(|c| a[c][r] * x[c]).sum();
            assert!((ax - b[r]).abs() < 1e-12, "row {r}: {ax} vs {}", b[r]);
        }
        // another right-hand side on the factors: the bits of a fresh solve
        let c: [f64; D] = core::array::from_fn(|_| next());
        let (mut fresh, mut again) = ((a, c), c);
        assert!(lu_solve(
            &mut Square::of_array(&mut fresh.0),
            &mut fresh.1,
            &mut [0; D]
        ));
        assert!(lu_solve_factored(
            &Square::of_array(&mut lu),
            &piv,
            &mut again
        ));
        assert_eq!(fresh.1, again);
        let mut singular = a;
        singular[3] = singular[5];
        let (mut x, mut piv) = (b, [0; D]);
        assert!(
            !lu_solve(&mut Square::of_array(&mut singular), &mut x, &mut piv)
                || x.iter().any(|v| v.abs() > 1e12)
        );
    }

    #[test]
    fn negative_part_of_a_known_spectrum() {
        const D: usize = 6;
        // Q diag(λ) Qᵀ with Q a product of plane rotations
        let lambda = [-3.0, -1e-3, 0.0, 2.0, 5.0, -0.5];
        let mut q = [[0.0; D]; D];
        for i in 0..D {
            q[i][i] = 1.0;
        }
        let mut next = values(11);
        for _ in 0..20 {
            let (i, j) = (
                (next().abs() * 6.0) as usize % D,
                (next().abs() * 6.0) as usize % D,
            );
            if i == j {
                continue;
            }
            let th = next() * 3.0;
            let (s, c) = crate::math::sin_cos(th);
            for k in 0..D {
                let (a, b) = (q[i][k], q[j][k]);
                q[i][k] = c * a - s * b;
                q[j][k] = s * a + c * b;
            }
        }
        let build = |l: &[f64; D]| -> [[f64; D]; D] {
            core::array::from_fn(|c| {
                core::array::from_fn(|r| (0..D).map(|k| q[k][r] * l[k] * q[k][c]).sum())
            })
        };
        let mut h = build(&lambda);
        let expected = build(&lambda.map(|l: f64| l.min(0.0)));
        let (mut v, mut w) = ([[0.0; D]; D], [0.0; D]);
        assert_eq!(
            negative_semidefinite_part(
                &mut Square::of_array(&mut h),
                &mut Square::of_array(&mut v),
                &mut w
            ),
            Projection::Decomposed
        );
        for c in 0..D {
            for r in 0..D {
                assert!((h[c][r] - expected[c][r]).abs() < 1e-12, "({r}, {c})");
            }
        }
        // negative definite: its own part, by Cholesky
        let mut nd = build(&[-1.0, -2.0, -3.0, -0.5, -4.0, -1e-2]);
        let copy = nd;
        assert_eq!(
            negative_semidefinite_part(
                &mut Square::of_array(&mut nd),
                &mut Square::of_array(&mut v),
                &mut w
            ),
            Projection::Definite
        );
        assert_eq!(nd, copy);
        // not finite: refused, unchanged
        let mut bad = copy;
        bad[2][1] = f64::NAN;
        assert_eq!(
            negative_semidefinite_part(
                &mut Square::of_array(&mut bad),
                &mut Square::of_array(&mut v),
                &mut w
            ),
            Projection::Failed
        );
    }
}
