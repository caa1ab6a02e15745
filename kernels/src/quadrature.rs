//! Gauss–Legendre quadrature rules: computed once per order and cached with the `std`
//! feature, computed on the stack at each call without it.

/// Highest order available.
pub const MAX_ORDER: usize = 256;

/// Nodes in [-1, 1] and weights of one rule (fixed capacity, no allocation).
#[derive(Debug, Clone)]
pub struct GaussLegendre {
    n: usize,
    nodes: [f64; MAX_ORDER],
    weights: [f64; MAX_ORDER],
}

impl GaussLegendre {
    /// Nodes, ascending.
    pub fn nodes(&self) -> &[f64] {
        &self.nodes[..self.n]
    }
    /// Weights (sum 2).
    pub fn weights(&self) -> &[f64] {
        &self.weights[..self.n]
    }
}

/// The n-point rule, 1 ≤ n ≤ [`MAX_ORDER`].
pub fn compute(n: usize) -> GaussLegendre {
    let n = n.clamp(1, MAX_ORDER);
    let mut rule = GaussLegendre {
        n,
        nodes: [0.0; MAX_ORDER],
        weights: [0.0; MAX_ORDER],
    };
    let (nodes, weights) = (&mut rule.nodes, &mut rule.weights);
    for i in 0..n.div_ceil(2) {
        // Tricomi's initial guess, then Newton on P_n.
        let mut x = crate::math::cos(core::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5));
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            // p1 = P_n(x), p0 = P_{n-1}(x)
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        nodes[i] = -x;
        nodes[n - 1 - i] = x;
        weights[i] = w;
        weights[n - 1 - i] = w;
    }
    if n % 2 == 1 {
        nodes[n / 2] = 0.0;
    }
    rule
}

/// A rule as [`gauss_legendre`] returns it: a reference into the cache with `std`, the
/// rule itself (on the stack) without.
#[cfg(feature = "std")]
pub type Rule = &'static GaussLegendre;
/// A rule as [`gauss_legendre`] returns it: a reference into the cache with `std`, the
/// rule itself (on the stack) without.
#[cfg(not(feature = "std"))]
pub type Rule = GaussLegendre;

/// The n-point rule (1 ≤ n ≤ [`MAX_ORDER`], clamped), cached after the first call.
#[cfg(feature = "std")]
pub fn gauss_legendre(n: usize) -> Rule {
    use std::boxed::Box;
    use std::sync::OnceLock;
    use std::vec::Vec;
    static RULES: OnceLock<Vec<OnceLock<Box<GaussLegendre>>>> = OnceLock::new();
    let n = n.clamp(1, MAX_ORDER);
    let rules = RULES.get_or_init(|| (0..=MAX_ORDER).map(|_| OnceLock::new()).collect());
    rules[n].get_or_init(|| Box::new(compute(n)))
}

/// The n-point rule (1 ≤ n ≤ [`MAX_ORDER`], clamped), computed at each call (no
/// allocation; build with `std` to cache it).
#[cfg(not(feature = "std"))]
pub fn gauss_legendre(n: usize) -> Rule {
    compute(n)
}

#[cfg(test)]
mod tests {
    use super::*;
    #[allow(unused_imports)]
    use std::{format, vec, vec::Vec};

    #[test]
    fn integrates_polynomials_exactly_up_to_degree_2n_minus_1() {
        for n in [1, 2, 3, 5, 8, 20, 64] {
            let r = gauss_legendre(n);
            let total: f64 = r.weights().iter().sum();
            assert!((total - 2.0).abs() < 1e-13, "n={n}");
            let deg = 2 * n - 1;
            let integral: f64 = r
                .nodes()
                .iter()
                .zip(r.weights())
                .map(|(x, w)| w * x.powi(deg as i32 - 1))
                .sum();
            // ∫_{-1}^{1} x^(deg-1) = 2/deg for even deg-1
            assert!((integral - 2.0 / deg as f64).abs() < 1e-13, "n={n}");
        }
    }

    #[test]
    fn integrates_a_fast_oscillation() {
        // ∫_{-1}^{1} cos(30 x) dx = sin(30)/15
        let r = gauss_legendre(40);
        let v: f64 = r
            .nodes()
            .iter()
            .zip(r.weights())
            .map(|(x, w)| w * (30.0 * x).cos())
            .sum();
        assert!((v - 30f64.sin() / 15.0).abs() < 1e-13);
    }
}
