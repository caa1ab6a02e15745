//! Solid harmonics: the regular `R_n^m(x)` and irregular `I_n^m(x)` in the scaled form
//! that makes the translation theorems free of normalisation factors.
//!
//! With `r`, `θ`, `φ` the spherical coordinates of `x` and `P_n^m` the associated
//! Legendre functions (Condon–Shortley phase included),
//!
//! ```text
//! R_n^m(x) = r^n P_n^m(cos θ) e^{imφ} / (n + m)!,
//! I_n^m(x) = (n − m)! P_n^m(cos θ) e^{imφ} / r^{n+1},
//! ```
//!
//! both with `X_n^{−m} = (−1)^m conj(X_n^m)`. They are computed in Cartesian
//! coordinates by the recurrences
//!
//! ```text
//! R_0^0 = 1,   R_{m+1}^{m+1} = −(x + iy) R_m^m / (2m + 2),
//! R_{n+1}^m = ((2n + 1) z R_n^m − r² R_{n−1}^m) / ((n + m + 1)(n − m + 1)),
//! I_0^0 = 1/r, I_{m+1}^{m+1} = −(2m + 1)(x + iy) I_m^m / r²,
//! I_{n+1}^m = ((2n + 1) z I_n^m − (n² − m²) I_{n−1}^m) / r²,
//! ```
//!
//! and satisfy, for `|y| < |x|` (the paper's eqs. 2–5 in this normalisation),
//!
//! ```text
//! 1/|x − y| = Σ_{n ≥ 0} Σ_{|m| ≤ n} conj(R_n^m(y)) I_n^m(x),
//! R_n^m(x + y) = Σ_{k ≤ n} Σ_l R_k^l(x) R_{n−k}^{m−l}(y),
//! I_j^k(x − y) = Σ_{n ≥ 0} Σ_m conj(R_n^m(y)) I_{j+n}^{k+m}(x),
//! (∂_x + i∂_y) R_n^m = R_{n−1}^{m+1},  (∂_x − i∂_y) R_n^m = −R_{n−1}^{m−1},  ∂_z R_n^m = R_{n−1}^m.
//! ```
//!
//! Every operator of [`crate::operators`] follows from these; the tests check each
//! identity against direct evaluation.

use num_complex::Complex64 as C;

/// Index of `(n, m)`, `0 ≤ m ≤ n`, in a triangular array of coefficients.
#[inline(always)]
pub fn tri(n: usize, m: usize) -> usize {
    n * (n + 1) / 2 + m
}

/// Number of coefficients `(n, m)` with `0 ≤ m ≤ n ≤ p`.
#[inline(always)]
pub fn tri_len(p: usize) -> usize {
    (p + 1) * (p + 2) / 2
}

/// `X_n^m` for any `|m| ≤ n` from the triangle of `m ≥ 0`.
#[inline(always)]
pub fn signed(t: &[C], n: usize, m: isize) -> C {
    if m >= 0 {
        t[tri(n, m as usize)]
    } else {
        let v = t[tri(n, (-m) as usize)].conj();
        if m & 1 == 1 {
            -v
        } else {
            v
        }
    }
}

/// The regular solid harmonics `R_n^m(x)`, `0 ≤ m ≤ n ≤ p`, into `out` (triangular,
/// [`tri_len`]`(p)` long).
pub fn regular(x: [f64; 3], p: usize, out: &mut [C]) {
    let [x, y, z] = x;
    let r2 = x * x + y * y + z * z;
    let w = C::new(x, y);
    out[0] = C::new(1.0, 0.0);
    for m in 0..=p {
        if m > 0 {
            out[tri(m, m)] = -w * out[tri(m - 1, m - 1)] / (2 * m) as f64;
        }
        if m < p {
            // (2m + 1) z R_m^m / ((2m + 1) · 1), R_{m−1}^m being 0.
            out[tri(m + 1, m)] = z * out[tri(m, m)];
        }
        for n in (m + 1)..p {
            let a = (2 * n + 1) as f64 * z;
            let d = ((n + m + 1) * (n - m + 1)) as f64;
            out[tri(n + 1, m)] = (a * out[tri(n, m)] - r2 * out[tri(n - 1, m)]) / d;
        }
    }
}

/// The irregular solid harmonics `I_n^m(x)`, `0 ≤ m ≤ n ≤ p`, into `out` (triangular).
/// `x` must not be 0.
pub fn irregular(x: [f64; 3], p: usize, out: &mut [C]) {
    let [x, y, z] = x;
    let r2 = x * x + y * y + z * z;
    let inv_r2 = 1.0 / r2;
    let w = C::new(x, y);
    out[0] = C::new(inv_r2.sqrt(), 0.0);
    for m in 0..=p {
        if m > 0 {
            out[tri(m, m)] = -w * out[tri(m - 1, m - 1)] * ((2 * m - 1) as f64 * inv_r2);
        }
        if m < p {
            out[tri(m + 1, m)] = out[tri(m, m)] * ((2 * m + 1) as f64 * z * inv_r2);
        }
        for n in (m + 1)..p {
            let a = (2 * n + 1) as f64 * z;
            let b = (n * n - m * m) as f64;
            out[tri(n + 1, m)] = (out[tri(n, m)] * a - out[tri(n - 1, m)] * b) * inv_r2;
        }
    }
}
