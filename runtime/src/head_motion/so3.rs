//! Rotations from rotation vectors: `exp([φ]×)`, the right Jacobian `J_r(φ)` and its time
//! derivative, with the coefficient functions evaluated by Taylor series near φ = 0.

use nalgebra::{Matrix3, Vector3};

/// Below this value of x = θ² the coefficient functions use their Taylor series.
const SERIES_BELOW: f64 = 0.0625;
/// Terms of the Taylor series (the first omitted one is below 1e-30 at the threshold).
const SERIES_TERMS: i32 = 10;

/// The coefficient functions of the rotation formulas at θ = |φ|, written in x = θ²:
/// `a = sinθ/θ`, `b = (1 − cosθ)/θ²`, `c = (θ − sinθ)/θ³`, and `db/dx`, `dc/dx`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Coefficients {
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub db_dx: f64,
    pub dc_dx: f64,
}

/// `Σ_k (−x)^k / (2k + shift)!`, the series of a (shift 1), b (2) and c (3).
fn series(x: f64, shift: i32) -> f64 {
    let mut term = 1.0 / factorial(shift);
    let mut sum = term;
    for k in 1..SERIES_TERMS {
        term *= -x / f64::from((2 * k + shift - 1) * (2 * k + shift));
        sum += term;
    }
    sum
}

/// Derivative in x of [`series`]: `Σ_{k≥1} k (−1)^k x^(k−1) / (2k + shift)!`.
fn series_dx(x: f64, shift: i32) -> f64 {
    // term_k = (−x)^(k−1) (−1) / (2k + shift)!, multiplied by k when summed.
    let mut term = -1.0 / factorial(2 + shift);
    let mut sum = term;
    for k in 2..SERIES_TERMS {
        term *= -x / f64::from((2 * k + shift - 1) * (2 * k + shift));
        sum += f64::from(k) * term;
    }
    sum
}

fn factorial(n: i32) -> f64 {
    (1..=n).map(f64::from).product()
}

impl Coefficients {
    /// The coefficients at x = θ² ≥ 0.
    pub(super) fn at(x: f64) -> Self {
        if x < SERIES_BELOW {
            return Self {
                a: series(x, 1),
                b: series(x, 2),
                c: series(x, 3),
                db_dx: series_dx(x, 2),
                dc_dx: series_dx(x, 3),
            };
        }
        let theta = x.sqrt();
        let sin = theta.sin();
        let one_minus_cos = 2.0 * (0.5 * theta).sin().powi(2);
        let theta_minus_sin = theta - sin;
        Self {
            a: sin / theta,
            b: one_minus_cos / x,
            c: theta_minus_sin / (theta * x),
            db_dx: (theta * sin - 2.0 * one_minus_cos) / (2.0 * x * x),
            dc_dx: (one_minus_cos * theta - 3.0 * theta_minus_sin) / (2.0 * theta * x * x),
        }
    }
}

/// The cross-product matrix `[v]×`.
pub(super) fn hat(v: &Vector3<f64>) -> Matrix3<f64> {
    v.cross_matrix()
}

/// `exp([φ]×) = I + a K + b K²`, `K = [φ]×`: the rotation by |φ| about φ/|φ|.
pub(super) fn exp(phi: &Vector3<f64>) -> Matrix3<f64> {
    let k = hat(phi);
    let co = Coefficients::at(phi.norm_squared());
    Matrix3::identity() + k * co.a + k * k * co.b
}

/// The right Jacobian `J_r(φ) = I − b K + c K²`: `Rᵀ Ṙ = [J_r(φ) φ̇]×` for `R = exp([φ]×)`.
pub(super) fn right_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    let k = hat(phi);
    let co = Coefficients::at(phi.norm_squared());
    Matrix3::identity() - k * co.b + k * k * co.c
}

/// The time derivative of `J_r(φ(t))` given φ and φ̇.
pub(super) fn right_jacobian_rate(phi: &Vector3<f64>, phi_dot: &Vector3<f64>) -> Matrix3<f64> {
    let k = hat(phi);
    let k_dot = hat(phi_dot);
    let co = Coefficients::at(phi.norm_squared());
    let x_dot = 2.0 * phi.dot(phi_dot);
    -k * (co.db_dx * x_dot) - k_dot * co.b
        + k * k * (co.dc_dx * x_dot)
        + (k_dot * k + k * k_dot) * co.c
}

#[cfg(test)]
mod tests {
    use super::*;

    fn closed_form(theta: f64) -> [f64; 5] {
        let x = theta * theta;
        let (s, c) = theta.sin_cos();
        [
            s / theta,
            (1.0 - c) / x,
            (theta - s) / (theta * x),
            (theta * s - 2.0 * (1.0 - c)) / (2.0 * x * x),
            ((1.0 - c) * theta - 3.0 * (theta - s)) / (2.0 * theta * x * x),
        ]
    }

    fn as_array(co: Coefficients) -> [f64; 5] {
        [co.a, co.b, co.c, co.db_dx, co.dc_dx]
    }

    #[test]
    fn series_matches_closed_form_at_the_threshold() {
        let below = as_array(Coefficients::at(SERIES_BELOW * (1.0 - 1e-12)));
        let above = as_array(Coefficients::at(SERIES_BELOW * (1.0 + 1e-12)));
        let textbook = closed_form(SERIES_BELOW.sqrt());
        for i in 0..5 {
            assert!(
                (below[i] - above[i]).abs() <= 1e-11 * above[i].abs(),
                "{i}: {below:?} {above:?}"
            );
            assert!(
                (below[i] - textbook[i]).abs() <= 1e-10 * textbook[i].abs(),
                "{i}"
            );
        }
    }

    #[test]
    fn coefficients_are_finite_and_exact_at_zero() {
        let co = Coefficients::at(0.0);
        assert_eq!([co.a, co.b, co.c], [1.0, 0.5, 1.0 / 6.0]);
        assert!((co.db_dx + 1.0 / 24.0).abs() < 1e-17);
        assert!((co.dc_dx + 1.0 / 120.0).abs() < 1e-17);
    }

    #[test]
    fn exp_matches_nalgebra_rotation() {
        for phi in [Vector3::new(0.3, -1.2, 2.0), Vector3::new(1e-9, 0.0, 2e-9)] {
            let r = exp(&phi);
            let expected = nalgebra::Rotation3::from_scaled_axis(phi);
            assert!((r - expected.matrix()).norm() < 1e-14);
        }
    }
}
