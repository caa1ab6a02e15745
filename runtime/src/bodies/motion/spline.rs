//! Clamped cubic spline (zero end velocity) through keys, for several components at once.

use nalgebra::SVector;

/// A value and its first two time derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Jet<const D: usize> {
    pub value: SVector<f64, D>,
    pub rate: SVector<f64, D>,
    pub accel: SVector<f64, D>,
}

/// A C2 cubic spline in time of a `D`-vector, with zero velocity at the first and last
/// key and held constant outside them. Stored as knot times, values and second
/// derivatives ("moments") at the knots.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct ClampedSpline<const D: usize> {
    times: Vec<f64>,
    values: Vec<SVector<f64, D>>,
    moments: Vec<SVector<f64, D>>,
}

impl<const D: usize> ClampedSpline<D> {
    /// The spline through `(times[i], values[i])`. `times` must be strictly increasing
    /// and as long as `values` (the caller checks); one key gives a constant.
    pub(super) fn new(times: Vec<f64>, values: Vec<SVector<f64, D>>) -> Self {
        let moments = clamped_moments(&times, &values);
        Self {
            times,
            values,
            moments,
        }
    }

    /// Value, velocity and acceleration at time `t`.
    pub(super) fn eval(&self, t: f64) -> Jet<D> {
        let n = self.times.len();
        let hold = |i: usize| Jet {
            value: self.values[i],
            rate: SVector::zeros(),
            accel: SVector::zeros(),
        };
        if n < 2 || t.is_nan() || t <= self.times[0] {
            return hold(0);
        }
        if t >= self.times[n - 1] {
            return hold(n - 1);
        }
        // First knot strictly after t; 1 <= i1 <= n - 1 here.
        let i1 = self.times.partition_point(|&tk| tk <= t);
        self.eval_in(i1 - 1, t)
    }

    /// The cubic of interval `[t_i, t_{i+1}]` at t.
    fn eval_in(&self, i: usize, t: f64) -> Jet<D> {
        let h = self.times[i + 1] - self.times[i];
        let a = (self.times[i + 1] - t) / h;
        let b = 1.0 - a;
        let (y0, y1) = (self.values[i], self.values[i + 1]);
        let (m0, m1) = (self.moments[i], self.moments[i + 1]);
        Jet {
            value: y0 * a + y1 * b + (m0 * (a * a * a - a) + m1 * (b * b * b - b)) * (h * h / 6.0),
            rate: (y1 - y0) / h + (m1 * (3.0 * b * b - 1.0) - m0 * (3.0 * a * a - 1.0)) * (h / 6.0),
            accel: m0 * a + m1 * b,
        }
    }
}

/// Second derivatives at the knots of the clamped spline: the tridiagonal system
/// `h_{i−1} M_{i−1} + 2(h_{i−1} + h_i) M_i + h_i M_{i+1} = 6 (Δ_i/h_i − Δ_{i−1}/h_{i−1})`
/// with zero end slopes, solved by the Thomas algorithm (it is diagonally dominant).
fn clamped_moments<const D: usize>(
    times: &[f64],
    values: &[SVector<f64, D>],
) -> Vec<SVector<f64, D>> {
    let n = times.len();
    if n < 2 {
        return vec![SVector::zeros(); n];
    }
    let h: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    let slope: Vec<SVector<f64, D>> = (0..n - 1)
        .map(|i| (values[i + 1] - values[i]) / h[i])
        .collect();
    // Row i: sub[i] M_{i-1} + diag[i] M_i + sup[i] M_{i+1} = rhs[i].
    let zero = SVector::<f64, D>::zeros();
    let row = |i: usize| -> (f64, f64, f64, SVector<f64, D>) {
        let (h_left, s_left) = if i == 0 {
            (0.0, zero)
        } else {
            (h[i - 1], slope[i - 1])
        };
        let (h_right, s_right) = if i == n - 1 {
            (0.0, zero)
        } else {
            (h[i], slope[i])
        };
        (
            h_left,
            2.0 * (h_left + h_right),
            h_right,
            (s_right - s_left) * 6.0,
        )
    };
    // Forward sweep, storing the modified super-diagonal and right-hand side.
    let mut sup_mod = Vec::with_capacity(n);
    let mut rhs_mod: Vec<SVector<f64, D>> = Vec::with_capacity(n);
    for i in 0..n {
        let (sub, diag, sup, rhs) = row(i);
        let (prev_sup, prev_rhs) = if i == 0 {
            (0.0, zero)
        } else {
            (sup_mod[i - 1], rhs_mod[i - 1])
        };
        let denom = diag - sub * prev_sup;
        sup_mod.push(sup / denom);
        rhs_mod.push((rhs - prev_rhs * sub) / denom);
    }
    // Back substitution.
    let mut moments = rhs_mod;
    for i in (0..n - 1).rev() {
        let next = moments[i + 1];
        moments[i] -= next * sup_mod[i];
    }
    moments
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector1;

    fn spline(times: &[f64], values: &[f64]) -> ClampedSpline<1> {
        ClampedSpline::new(
            times.to_vec(),
            values.iter().map(|&v| Vector1::new(v)).collect(),
        )
    }

    #[test]
    fn passes_through_keys_with_zero_end_velocity() {
        let s = spline(&[0.0, 0.4, 1.0, 1.7], &[1.0, -2.0, 0.5, 3.0]);
        for (t, v) in [(0.0, 1.0), (0.4, -2.0), (1.0, 0.5), (1.7, 3.0)] {
            assert!((s.eval(t).value[0] - v).abs() < 1e-14);
        }
        assert!(s.eval(0.0 + 1e-12).rate[0].abs() < 1e-9);
        assert!(s.eval(1.7 - 1e-12).rate[0].abs() < 1e-9);
        assert_eq!(s.eval(-1.0).value[0], 1.0);
        assert_eq!(s.eval(5.0).value[0], 3.0);
    }

    #[test]
    fn is_c2_at_interior_knots() {
        let s = spline(&[0.0, 0.4, 1.0, 1.7], &[1.0, -2.0, 0.5, 3.0]);
        let e = 1e-9;
        for t in [0.4, 1.0] {
            let (l, r) = (s.eval(t - e), s.eval(t + e));
            assert!((l.rate[0] - r.rate[0]).abs() < 1e-6);
            assert!((l.accel[0] - r.accel[0]).abs() < 1e-6);
        }
    }

    #[test]
    fn reproduces_a_clamped_cubic() {
        // y = 3t² − 2t³ on [0, 1] has y'(0) = y'(1) = 0: the spline is exact.
        let times: Vec<f64> = (0..=4).map(|i| f64::from(i) / 4.0).collect();
        let f = |t: f64| 3.0 * t * t - 2.0 * t * t * t;
        let values: Vec<f64> = times.iter().map(|&t| f(t)).collect();
        let s = spline(&times, &values);
        let j = s.eval(0.3);
        assert!((j.value[0] - f(0.3)).abs() < 1e-14);
        assert!((j.rate[0] - (6.0 * 0.3 - 6.0 * 0.09)).abs() < 1e-13);
        assert!((j.accel[0] - (6.0 - 12.0 * 0.3)).abs() < 1e-12);
    }
}
