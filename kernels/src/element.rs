//! One helical element in its own start frame (paper appendix A, eq. 7; design page
//! "Reconstruction"): with `K = [d]×`, W = |d|, x = uW,
//!
//! ```text
//! E(u) = exp(uK) = I + u a(x) K + u² b(x) K²
//! P(u) = ∫₀ᵘ E   = u I + u² b(x) K + u³ c(x) K²
//! ```
//!
//! The frame at u is `F_Q E(u)`, the centreline `r_Q + F_Q P(u) e0`. The derivative of
//! the frame with respect to d_i is `∂E/∂d_i = [P(u) e_i]× E(u)` (the left Jacobian of
//! SO(3) times u is P(u)), so `w_i(u) = P(u) e_i` is the element's angular derivative.

use crate::float::Float;
use crate::helix_functions::{abc, abc_values};
use crate::jet::{cross, Jet};
use crate::lane::Lanes;
use crate::lanes::{M, V};
use nalgebra::{Matrix3, Vector3};

/// Frame rotation E(u) and position p(u) = P(u) e0 of an element with Darboux vector
/// `d` at local abscissa `u`, values only.
pub fn local_pose(d: &Vector3<f64>, u: f64) -> (Matrix3<f64>, Vector3<f64>) {
    let z = u * u * d.norm_squared();
    let (a, b, c) = abc_values(z);
    let k = d.cross_matrix();
    let k2 = k * k;
    let e = Matrix3::identity() + k * (u * a) + k2 * (u * u * b);
    let p = Vector3::new(u, 0.0, 0.0) + k.column(0) * (u * u * b) + k2.column(0) * (u * u * u * c);
    (e, p)
}

/// Derivatives of an element's position p(u) = P(u)e0 (value, gradient and Hessian with
/// respect to d) and of its angular derivatives w_i(u) = P(u)e_i (with gradients).
#[derive(Debug, Clone, Copy, Default)]
pub struct ElementJets {
    /// Components of p(u), each a jet in d.
    pub p: [Jet; 3],
    /// `w[i]` = components of P(u) e_i, each a jet in d.
    pub w: [[Jet; 3]; 3],
}

impl ElementJets {
    /// ∂p/∂d_i as a vector.
    pub fn dp(&self, i: usize) -> Vector3<f64> {
        Vector3::new(self.p[0].g[i], self.p[1].g[i], self.p[2].g[i])
    }
    /// ∂²p/∂d_i∂d_j as a vector.
    pub fn d2p(&self, i: usize, j: usize) -> Vector3<f64> {
        Vector3::new(self.p[0].h[i][j], self.p[1].h[i][j], self.p[2].h[i][j])
    }
    /// p(u).
    pub fn p_value(&self) -> Vector3<f64> {
        Vector3::new(self.p[0].v, self.p[1].v, self.p[2].v)
    }
    /// w_i(u) = P(u) e_i.
    pub fn w_value(&self, i: usize) -> Vector3<f64> {
        Vector3::new(self.w[i][0].v, self.w[i][1].v, self.w[i][2].v)
    }
    /// ∂w_i/∂d_j.
    pub fn dw(&self, i: usize, j: usize) -> Vector3<f64> {
        Vector3::new(self.w[i][0].g[j], self.w[i][1].g[j], self.w[i][2].g[j])
    }
}

/// Everything the moment-based kernels need of one element at one abscissa u, in the
/// element's start frame: E(u), p(u), ∂p/∂d_i, ∂²p/∂d_i∂d_j, w_i(u) = P(u) e_i and
/// ∂w_i/∂d_j. The generated crate evaluates it in closed form; [`ElementPoint::by_jets`]
/// is the reference.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ElementPoint<T: Float = f64> {
    /// E(u).
    pub frame: Matrix3<T>,
    /// p(u).
    pub p: Vector3<T>,
    /// `dp[i]` = ∂p/∂d_i.
    pub dp: [Vector3<T>; 3],
    /// `d2p[i][j]` = ∂²p/∂d_i∂d_j.
    pub d2p: [[Vector3<T>; 3]; 3],
    /// `w[i]` = P(u) e_i.
    pub w: [Vector3<T>; 3],
    /// `dw[i][j]` = ∂w_i/∂d_j.
    pub dw: [[Vector3<T>; 3]; 3],
}

/// The fields of [`ElementPoint`] that the rotary-inertia quadrature
/// (`kernels::moments::rotary::rotary_element`) reads, E(u), w_i(u) and ∂w_i/∂d_j, at up to four
/// abscissae of one element, one per lane of [`Float::Lanes`] (the layout the
/// quadrature evaluates its integrands in: [`crate::lanes::F4`] in f64).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RotaryPoints<T: Float = f64> {
    /// E(u) by columns: `frame[c][r]` = E(u)`[(r, c)]`.
    pub frame: M<T::Lanes>,
    /// `w[i]` = P(u) e_i (`w[0]` = p).
    pub w: [V<T::Lanes>; 3],
    /// `dw[i][j]` = ∂w_i/∂d_j.
    pub dw: [[V<T::Lanes>; 3]; 3],
}

/// The fields of [`ElementPoint`] the rotary-inertia quadrature reads, for W elements at
/// one abscissa each, one per lane (element k of W strands: what a step that advances W
/// strands per call evaluates its rotary integrands in).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaneRotaryPoints<const W: usize> {
    /// E(u) by columns: `frame[c][r]` = E(u)`[(r, c)]`.
    pub frame: M<Lanes<f64, W>>,
    /// `w[i]` = P(u) e_i (`w[0]` = p).
    pub w: [V<Lanes<f64, W>>; 3],
    /// `dw[i][j]` = ∂w_i/∂d_j.
    pub dw: [[V<Lanes<f64, W>>; 3]; 3],
}

impl<const W: usize> Default for LaneRotaryPoints<W> {
    fn default() -> Self {
        let zero = Lanes([0.0; W]);
        LaneRotaryPoints {
            frame: [[zero; 3]; 3],
            w: [[zero; 3]; 3],
            dw: [[[zero; 3]; 3]; 3],
        }
    }
}

impl<T: Float> RotaryPoints<T> {
    /// Lane `k` set from the fields of `point`.
    ///
    /// # Panics
    ///
    /// When `k ≥ 4` (there are four lanes).
    pub fn set_lane(&mut self, k: usize, point: &ElementPoint<T>) {
        for c in 0..3 {
            for r in 0..3 {
                T::set_lane(&mut self.frame[c][r], k, point.frame[(r, c)]);
            }
        }
        for i in 0..3 {
            for m in 0..3 {
                T::set_lane(&mut self.w[i][m], k, point.w[i][m]);
            }
            for j in 0..3 {
                for m in 0..3 {
                    T::set_lane(&mut self.dw[i][j][m], k, point.dw[i][j][m]);
                }
            }
        }
    }
}

impl<T: Float> ElementPoint<T> {
    /// By second-order jets in d ([`element_jets`]) and [`local_pose`], computed in f64
    /// and rounded to `T`.
    pub fn by_jets(d: &Vector3<T>, u: T) -> Self {
        let (d, u) = (d.map(T::as_f64), u.as_f64());
        let jets = element_jets(&d, u, true);
        let (frame, p) = local_pose(&d, u);
        let v = |x: Vector3<f64>| x.map(T::of);
        ElementPoint {
            frame: frame.map(T::of),
            p: v(p),
            dp: core::array::from_fn(|i| v(jets.dp(i))),
            d2p: core::array::from_fn(|i| core::array::from_fn(|j| v(jets.d2p(i, j)))),
            w: core::array::from_fn(|i| v(jets.w_value(i))),
            dw: core::array::from_fn(|i| core::array::from_fn(|j| v(jets.dw(i, j)))),
        }
    }
}

/// P(u) e applied to a jet vector e, given jet d, B = b(z), C = c(z) and |d|²:
/// `u e + u² B (d × e) + u³ C (d (d·e) − |d|² e)`.
fn p_times(u: f64, d: &[Jet; 3], b: Jet, c: Jet, dd: Jet, e: &[Jet; 3]) -> [Jet; 3] {
    let dxe = cross(d, e);
    let de = d[0] * e[0] + d[1] * e[1] + d[2] * e[2];
    let mut out = [Jet::ZERO; 3];
    for m in 0..3 {
        out[m] = u * e[m] + (u * u) * (b * dxe[m]) + (u * u * u) * (c * (d[m] * de - dd * e[m]));
    }
    out
}

/// Jets of p(u) and, when `with_w`, of w_i(u), for Darboux vector `d` at abscissa `u`.
pub fn element_jets(d: &Vector3<f64>, u: f64, with_w: bool) -> ElementJets {
    let dj = [Jet::var(d[0], 0), Jet::var(d[1], 1), Jet::var(d[2], 2)];
    let dd = dj[0] * dj[0] + dj[1] * dj[1] + dj[2] * dj[2];
    let z = dd.scale(u * u);
    let f = abc(z.v);
    let b = z.compose(f.b);
    let c = z.compose(f.c);
    let basis = |i: usize| {
        let mut e = [Jet::constant(0.0); 3];
        e[i] = Jet::constant(1.0);
        e
    };
    let mut out = ElementJets {
        p: p_times(u, &dj, b, c, dd, &basis(0)),
        w: [[Jet::ZERO; 3]; 3],
    };
    if with_w {
        for i in 0..3 {
            out.w[i] = p_times(u, &dj, b, c, dd, &basis(i));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    #[allow(unused_imports)]
    use std::{format, vec, vec::Vec};

    #[test]
    fn pose_is_a_rotation_and_p_integrates_the_tangent() {
        for d in [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(3.0, -20.0, 7.0),
            Vector3::new(1e-7, 2e-7, 0.0),
        ] {
            let u = 0.05;
            let (e, _) = local_pose(&d, u);
            assert!((e.transpose() * e - Matrix3::identity()).norm() < 1e-14);
            assert!((e.determinant() - 1.0).abs() < 1e-14);
            // p' = E e0: compare with a 4th-order central difference
            let h = 1e-4;
            let dp = (-local_pose(&d, u + 2.0 * h).1 + 8.0 * local_pose(&d, u + h).1
                - 8.0 * local_pose(&d, u - h).1
                + local_pose(&d, u - 2.0 * h).1)
                / (12.0 * h);
            assert!((dp - e.column(0)).norm() < 1e-10);
        }
    }

    #[test]
    fn angular_derivative_is_p_times_basis() {
        // dE/dd_i E^T = [w_i]x, checked by central differences in d.
        let d = Vector3::new(4.0, -9.0, 13.0);
        let u = 0.07;
        let jets = element_jets(&d, u, true);
        let (e, _) = local_pose(&d, u);
        for i in 0..3 {
            let mut dp = d;
            let mut dm = d;
            dp[i] += 1e-6;
            dm[i] -= 1e-6;
            let de = (local_pose(&dp, u).0 - local_pose(&dm, u).0) / 2e-6;
            let omega = de * e.transpose();
            let w = jets.w_value(i);
            assert!((omega - w.cross_matrix()).norm() < 1e-8, "i={i}");
        }
    }
}
