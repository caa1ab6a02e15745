//! The functions a(x) = sin x / x, b(x) = (1 − cos x)/x², c(x) = (x − sin x)/x³ of the
//! closed-form helix (paper appendix A, design page "Reconstruction"), written as
//! functions of z = x² together with their first two z-derivatives.
//!
//! They are even and entire in x, hence smooth in z = x² = u²|d|², so derivatives with
//! respect to the Darboux vector d never meet the singularity of |d| at 0. Below
//! [`SERIES_LIMIT`] the Taylor series in z is summed (no cancellation: for z ≤ 16 the
//! largest term is within a factor 5 of the sum); above it the closed forms are used,
//! where they lose at most one digit.

/// Value, first and second derivative with respect to z of one function.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Series3 {
    /// f(z)
    pub f: f64,
    /// df/dz
    pub d1: f64,
    /// d²f/dz²
    pub d2: f64,
}

/// a, b, c at one z, each with two derivatives.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Abc {
    /// a = sin x / x
    pub a: Series3,
    /// b = (1 − cos x)/x²
    pub b: Series3,
    /// c = (x − sin x)/x³
    pub c: Series3,
}

/// Below this z = x² the series is summed; above it, the closed forms.
pub const SERIES_LIMIT: f64 = 16.0;

/// Most terms summed in the series: for z ≤ 16 the 24th term is below 1e-25 of the sum
/// (fewer are summed for a smaller z: see `series`).
const TERMS: usize = 24;

/// The coefficients (−1)^n / (2n + k)! of the series of a (k = 1), b (2) and c (3),
/// computed once at compile time by the recurrence c_{n+1} = −c_n / ((2n+k+1)(2n+k+2))
/// (the same operations, so the same bits, as computing them term by term).
const fn coefficients(k: usize) -> [f64; TERMS] {
    let mut out = [0.0; TERMS];
    let mut coef = 1.0;
    let mut m = 1;
    while m <= k {
        coef /= m as f64;
        m += 1;
    }
    let mut n = 0;
    while n < TERMS {
        out[n] = coef;
        let m = (2 * n + k) as f64;
        coef = -coef / ((m + 1.0) * (m + 2.0));
        n += 1;
    }
    out
}

/// [`coefficients`] of a, b and c.
const COEFFICIENTS: [[f64; TERMS]; 3] = [coefficients(1), coefficients(2), coefficients(3)];

/// Sum f(z) = Σ (−z)^n / (2n + k)!, and two z-derivatives, for k = 1 (a), 2 (b), 3 (c).
fn series(z: f64, k: usize) -> Series3 {
    // coefficient of z^n: (−1)^n / (2n + k)!, from the table (no division in the loop)
    let coefs = &COEFFICIENTS[k - 1];
    let mut out = Series3::default();
    let mut zn = 1.0; // z^n
    let mut zn1 = 0.0; // z^(n−1) (0 for n = 0)
    let mut zn2 = 0.0; // z^(n−2)
    for (n, &coef) in coefs.iter().enumerate() {
        let nf = n as f64;
        let (t0, t1, t2) = (coef * zn, coef * nf * zn1, coef * nf * (nf - 1.0) * zn2);
        out.f += t0;
        out.d1 += t1;
        out.d2 += t2;
        // the series alternates and its terms decrease from here on (z ≤ 16 < (2n+k+1)(2n+k+2)
        // for n ≥ 2): the error of stopping is below the next term, and with every term
        // just added below 1e-17 of its sum it is below a tenth of the sums' last bit
        if n >= 2
            && t0.abs() <= 1e-17 * out.f.abs()
            && t1.abs() <= 1e-17 * out.d1.abs()
            && t2.abs() <= 1e-17 * out.d2.abs()
        {
            break;
        }
        zn2 = zn1;
        zn1 = zn;
        zn *= z;
    }
    out
}

/// a, b, c and their z-derivatives at z = x² ≥ 0.
pub fn abc(z: f64) -> Abc {
    if z < SERIES_LIMIT {
        return Abc {
            a: series(z, 1),
            b: series(z, 2),
            c: series(z, 3),
        };
    }
    let x = crate::math::sqrt(z);
    let (s, co) = crate::math::sin_cos(x);
    let a = s / x;
    let b = (1.0 - co) / z;
    let c = (x - s) / (z * x);
    // Relations from differentiating the definitions (all exact):
    let a1 = 0.5 * (c - b);
    let b1 = (a - 2.0 * b) / (2.0 * z);
    let c1 = (b - 3.0 * c) / (2.0 * z);
    let a2 = 0.5 * (c1 - b1);
    let b2 = (a1 - 4.0 * b1) / (2.0 * z);
    let c2 = (b1 - 5.0 * c1) / (2.0 * z);
    Abc {
        a: Series3 {
            f: a,
            d1: a1,
            d2: a2,
        },
        b: Series3 {
            f: b,
            d1: b1,
            d2: b2,
        },
        c: Series3 {
            f: c,
            d1: c1,
            d2: c2,
        },
    }
}

/// Values only of a, b, c at z (cheaper than [`abc`] when no derivative is needed).
pub fn abc_values(z: f64) -> (f64, f64, f64) {
    if z < 1e-2 {
        // four terms suffice below z = 1e-2: the next is below 1e-11 · z⁴/... < 1e-18
        let a = 1.0 - z / 6.0 * (1.0 - z / 20.0 * (1.0 - z / 42.0 * (1.0 - z / 72.0)));
        let b = 0.5 * (1.0 - z / 12.0 * (1.0 - z / 30.0 * (1.0 - z / 56.0 * (1.0 - z / 90.0))));
        let c = (1.0 - z / 20.0 * (1.0 - z / 42.0 * (1.0 - z / 72.0 * (1.0 - z / 110.0)))) / 6.0;
        return (a, b, c);
    }
    if z < SERIES_LIMIT {
        let r = abc(z);
        return (r.a.f, r.b.f, r.c.f);
    }
    let x = crate::math::sqrt(z);
    let (s, co) = crate::math::sin_cos(x);
    (s / x, (1.0 - co) / z, (x - s) / (z * x))
}

#[cfg(test)]
mod tests {
    use super::*;
    #[allow(unused_imports)]
    use std::{format, vec, vec::Vec};

    fn closed(x: f64) -> (f64, f64, f64) {
        (
            x.sin() / x,
            (1.0 - x.cos()) / (x * x),
            (x - x.sin()) / (x * x * x),
        )
    }

    #[test]
    fn series_and_closed_forms_agree_at_the_switch_and_beyond() {
        for &x in &[0.5, 1.0, 2.0, 3.0, 3.999, 4.0, 4.001, 7.0] {
            let r = abc(x * x);
            let (a, b, c) = closed(x);
            assert!((r.a.f - a).abs() < 1e-15, "a at {x}");
            assert!((r.b.f - b).abs() < 1e-15, "b at {x}");
            assert!(
                (r.c.f - c).abs() < 2e-15 * c.abs().max(1e-3),
                "c at {x}: {} vs {c}",
                r.c.f
            );
        }
    }

    #[test]
    fn derivatives_match_finite_differences_on_both_sides_of_the_switch() {
        for &z in &[1e-8f64, 0.3, 2.0, 15.9, 16.1, 40.0, 400.0] {
            let h = 1e-5 * z.max(1e-3);
            let p = abc(z + h);
            let m = abc(z - h);
            let r = abc(z);
            for (s, sp, sm) in [(r.a, p.a, m.a), (r.b, p.b, m.b), (r.c, p.c, m.c)] {
                let d1 = (sp.f - sm.f) / (2.0 * h);
                let d2 = (sp.d1 - sm.d1) / (2.0 * h);
                assert!(
                    (d1 - s.d1).abs() < 1e-7 * s.d1.abs().max(1e-4),
                    "d1 at z={z}"
                );
                assert!(
                    (d2 - s.d2).abs() < 1e-6 * s.d2.abs().max(1e-5),
                    "d2 at z={z}"
                );
            }
        }
    }

    #[test]
    fn cheap_values_match_full_series() {
        for &z in &[0.0, 1e-12, 1e-6, 9.9e-3, 1e-2, 3.0, 20.0] {
            let (a, b, c) = abc_values(z);
            let r = abc(z);
            // within two ulps of values of order one
            assert!(
                (a - r.a.f).abs() < 5e-16 && (b - r.b.f).abs() < 5e-16 && (c - r.c.f).abs() < 5e-16
            );
        }
        assert_eq!(abc(0.0).a.f, 1.0);
        assert_eq!(abc(0.0).b.f, 0.5);
    }
}
