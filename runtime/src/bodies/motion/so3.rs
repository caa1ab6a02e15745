//! Rotations from rotation vectors: `exp([φ]×)`, the right Jacobian `J_r(φ)` and its time
//! derivative, with the coefficient functions evaluated by Taylor series near φ = 0.

use crate::model::helix_functions::abc;
use nalgebra::{Matrix3, Vector3};

/// The coefficient functions of the rotation formulas at θ = |φ|, written in x = θ²:
/// `a = sinθ/θ`, `b = (1 − cosθ)/θ²`, `c = (θ − sinθ)/θ³`, and `db/dx`, `dc/dx` — the
/// same functions as the helix element's, from [`crate::model::helix_functions::abc`].
#[derive(Debug, Clone, Copy)]
pub(super) struct Coefficients {
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub db_dx: f64,
    pub dc_dx: f64,
}

impl Coefficients {
    /// The coefficients at x = θ² ≥ 0.
    pub(super) fn at(x: f64) -> Self {
        let f = abc(x);
        Self {
            a: f.a.f,
            b: f.b.f,
            c: f.c.f,
            db_dx: f.b.d1,
            dc_dx: f.c.d1,
        }
    }
}

/// The cross-product matrix `[v]×`.
pub(crate) fn hat(v: &Vector3<f64>) -> Matrix3<f64> {
    v.cross_matrix()
}

/// `exp([φ]×) = I + a K + b K²`, `K = [φ]×`: the rotation by |φ| about φ/|φ|.
pub(crate) fn exp(phi: &Vector3<f64>) -> Matrix3<f64> {
    let k = hat(phi);
    let co = Coefficients::at(phi.norm_squared());
    Matrix3::identity() + k * co.a + k * k * co.b
}

/// The right Jacobian `J_r(φ) = I − b K + c K²`: `Rᵀ Ṙ = [J_r(φ) φ̇]×` for `R = exp([φ]×)`.
pub(crate) fn right_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    let k = hat(phi);
    let co = Coefficients::at(phi.norm_squared());
    Matrix3::identity() - k * co.b + k * k * co.c
}

/// The time derivative of `J_r(φ(t))` given φ and φ̇.
pub(crate) fn right_jacobian_rate(phi: &Vector3<f64>, phi_dot: &Vector3<f64>) -> Matrix3<f64> {
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
    fn coefficients_match_the_textbook_forms() {
        // away from 0, where the textbook forms lose at most a few digits
        for theta in [0.25, 1.0, 3.0, 4.5] {
            let ours = as_array(Coefficients::at(theta * theta));
            let textbook = closed_form(theta);
            for i in 0..5 {
                assert!(
                    (ours[i] - textbook[i]).abs() <= 1e-10 * textbook[i].abs(),
                    "{i} at {theta}"
                );
            }
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
