//! The step's LU with partial pivoting for W matrices at once, one per lane (the
//! matrices of W strands of one N in structure of arrays, part 4 of docs/architecture.md's
//! "Strands in lanes"): each lane chooses its own
//! pivot rows, and each lane's factors and solution are, bit for bit, what
//! [`crate::fixed::lu_solve`] gives for that lane's matrix (the same operations in the
//! same order; a lane's pivot search is masked compares, its row swap a swap of its own
//! entries).
//!
//! A matrix is `[[Lanes<T, W>; D]; D]`, column-major as the scalar step's (`a[c][r]`), D ≤ 255
//! (a strand of up to 85 elements).

use super::{Lane, Lanes, Mask};
use crate::float::Float;

/// Factor each lane's `a` (P A = L U, L unit lower, both in `a`; lane k's pivot row of
/// column j in `pivots[j][k]`) and solve `a x = b` in place (`b` becomes x). Returns the
/// lanes that failed, as [`crate::fixed::lu_solve`] fails: a zero or non-finite pivot, or
/// a non-finite solution (those lanes hold unspecified values; the others are exact).
///
/// Compiled twice, for the baseline target and with AVX2 (the same bits), as the scalar
/// LU is.
pub fn lu_solve_lanes<T: Float, const W: usize, const D: usize>(
    a: &mut [[Lanes<T, W>; D]; D],
    b: &mut [Lanes<T, W>; D],
    pivots: &mut [[u8; W]; D],
) -> Mask<W> {
    #[cfg(all(target_arch = "x86_64", feature = "std", not(target_feature = "avx2")))]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { lu_solve_lanes_avx2(a, b, pivots) };
        }
    }
    lu_solve_lanes_body(a, b, pivots)
}

/// [`lu_solve_lanes`] compiled with AVX2.
#[cfg(all(target_arch = "x86_64", feature = "std", not(target_feature = "avx2")))]
#[target_feature(enable = "avx2")]
fn lu_solve_lanes_avx2<T: Float, const W: usize, const D: usize>(
    a: &mut [[Lanes<T, W>; D]; D],
    b: &mut [Lanes<T, W>; D],
    pivots: &mut [[u8; W]; D],
) -> Mask<W> {
    lu_solve_lanes_body(a, b, pivots)
}

/// The body of [`lu_solve_lanes`].
#[inline(always)]
fn lu_solve_lanes_body<T: Float, const W: usize, const D: usize>(
    a: &mut [[Lanes<T, W>; D]; D],
    b: &mut [Lanes<T, W>; D],
    pivots: &mut [[u8; W]; D],
) -> Mask<W> {
    // pivot rows are kept in a u8
    const { assert!(D <= 255, "lu_solve_lanes: D must be at most 255") };
    let zero = Lanes::splat(T::zero());
    let mut failed = Mask([false; W]);
    for k in 0..D {
        // pivot: the largest entry of column k at or below the diagonal, the first one
        // among equals (a later row is taken only when strictly larger)
        let mut best = a[k][k].abs();
        // the pivot rows as values of the lanes' type (exact: rows < 2²⁴)
        let mut row = Lanes::splat(T::of(k as f64));
        for r in k + 1..D {
            let x = a[k][r].abs();
            let larger = best.lt(x);
            best = Lanes::select(larger, x, best);
            row = Lanes::select(larger, Lanes::splat(T::of(r as f64)), row);
        }
        let mut p = [k as u8; W];
        for lane in 0..W {
            let v = best.0[lane];
            if v == T::zero() || !v.is_finite() {
                failed.0[lane] = true;
            }
            p[lane] = row.0[lane].as_f64() as u8;
            let p = p[lane] as usize;
            if p != k {
                for c in a.iter_mut() {
                    let x = c[k].0[lane];
                    c[k].0[lane] = c[p].0[lane];
                    c[p].0[lane] = x;
                }
            }
        }
        pivots[k] = p;
        let inv = Lanes::splat(T::one()) / a[k][k];
        for r in k + 1..D {
            a[k][r] *= inv;
        }
        for c in k + 1..D {
            let akc = a[c][k];
            // the scalar LU skips a zero multiplier (which keeps a −0 entry's sign)
            let skip = akc.abs().le(zero);
            let lk = a[k];
            let col = &mut a[c];
            if skip.any() {
                for r in k + 1..D {
                    col[r] = Lanes::select(skip, col[r], col[r] - lk[r] * akc);
                }
            } else {
                for r in k + 1..D {
                    col[r] -= lk[r] * akc;
                }
            }
        }
    }
    failed | lu_solve_factored_lanes(a, pivots, b)
}

/// Solve with the factors [`lu_solve_lanes`] left in `a` and `pivots`, `b` becoming x;
/// returns the lanes whose solution is not finite.
#[inline(always)]
pub fn lu_solve_factored_lanes<T: Float, const W: usize, const D: usize>(
    a: &[[Lanes<T, W>; D]; D],
    pivots: &[[u8; W]; D],
    b: &mut [Lanes<T, W>; D],
) -> Mask<W> {
    // P b, lane by lane, then L y = P b (unit lower), then U x = y
    for (k, p) in pivots.iter().enumerate() {
        for (lane, &p) in p.iter().enumerate() {
            let p = p as usize;
            if p != k {
                let x = b[k].0[lane];
                b[k].0[lane] = b[p].0[lane];
                b[p].0[lane] = x;
            }
        }
    }
    for c in 0..D {
        let bc = b[c];
        let col = &a[c];
        for r in c + 1..D {
            b[r] -= col[r] * bc;
        }
    }
    for c in (0..D).rev() {
        let col = &a[c];
        b[c] /= col[c];
        let bc = b[c];
        for r in 0..c {
            b[r] -= col[r] * bc;
        }
    }
    Mask(core::array::from_fn(|lane| {
        b.iter().any(|x| !x.0[lane].is_finite())
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixed::dense::tests::values;
    use crate::fixed::lu_solve;
    use crate::storage::Square;

    /// W matrices: random, pivoting on every column, with ties, zeros and −0 entries,
    /// one singular; each lane's solution and factors are the scalar LU's bits.
    fn check<const W: usize, const D: usize>(seed: u64) {
        let mut next = values(seed);
        let mats: [[[f64; D]; D]; W] = core::array::from_fn(|lane| {
            let mut m: [[f64; D]; D] = core::array::from_fn(|_| core::array::from_fn(|_| next()));
            match lane % 4 {
                // ties in a column: the first of equals is the pivot
                1 => {
                    m[0][0] = 2.0;
                    m[0][D - 1] = -2.0;
                }
                // zero and −0 multipliers
                2 => {
                    m[0][0] = 2.0;
                    for c in 1..D {
                        if c % 2 == 1 {
                            m[c][1] = -0.0;
                        }
                        m[c][0] = if c % 2 == 0 { 0.0 } else { -0.0 };
                    }
                }
                // singular (a zero column)
                3 if lane == 3 => m[4] = [0.0; D],
                _ => {}
            }
            m
        });
        let rhs: [[f64; D]; W] = core::array::from_fn(|_| core::array::from_fn(|_| next()));
        let mut a: [[Lanes<f64, W>; D]; D] = core::array::from_fn(|c| {
            core::array::from_fn(|r| Lanes::from_fn(|lane| mats[lane][c][r]))
        });
        let mut b: [Lanes<f64, W>; D] =
            core::array::from_fn(|r| Lanes::from_fn(|lane| rhs[lane][r]));
        let mut pivots = [[0u8; W]; D];
        let failed = lu_solve_lanes(&mut a, &mut b, &mut pivots);
        for lane in 0..W {
            let (mut m, mut x, mut piv) = (mats[lane], rhs[lane], [0usize; D]);
            let ok = lu_solve(&mut Square::of_array(&mut m), &mut x, &mut piv);
            assert_eq!(failed.0[lane], !ok, "lane {lane}");
            if !ok {
                continue;
            }
            for r in 0..D {
                assert_eq!(
                    b[r].lane(lane).to_bits(),
                    x[r].to_bits(),
                    "lane {lane} x[{r}]"
                );
                assert_eq!(pivots[r][lane] as usize, piv[r], "lane {lane} pivot {r}");
                for c in 0..D {
                    assert_eq!(a[c][r].lane(lane).to_bits(), m[c][r].to_bits());
                }
            }
        }
        if W > 3 {
            assert!(failed.0[3] && failed.count() == 1);
        }
    }

    #[test]
    fn every_lane_is_the_scalar_lu_bit_for_bit() {
        check::<4, 15>(3);
        check::<8, 15>(5);
        check::<8, 30>(7);
        check::<16, 15>(11);
        check::<2, 6>(13);
    }
}
