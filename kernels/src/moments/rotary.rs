//! Rotary-inertia parts of b and ∂b/∂q̇ for the moment-based kernels.
//!
//! The cross-sections' kinetic energy `½ ∫ Ωsᵀ I Ωs` (design note: it makes M positive
//! definite) gives `b_k = ∫ Θ_k · (I α + Ωs × I Ωs)`, α = Θ̇ q̇. For an upstream column
//! Θ_k is the constant dθ_k, so each element needs only a few integrals of its own
//! (resultant torque, a 3 × 3 matrix Λ and the contractions with its own angular
//! derivatives w_i(u)); the strand is assembled from their suffix sums in O(N²).
//!
//! These per-element integrals are taken by Gauss–Legendre quadrature (the rotary
//! terms are ~r²/l² ≈ 1e-6 of the centreline terms, so an order that resolves the
//! element's frequencies keeps them far below the kernels' 1e-10 agreement); M's rotary
//! part uses the closed-form moments `rot`, `rot_w`, `rot_ww`.

use crate::element::LaneRotaryPoints;
use crate::element::RotaryPoints;
use crate::float::{Arith, Float};
use crate::lane::{Lane, Lanes};
use crate::lanes::{
    add, cross, cross_matrix, dot, mat_add, mat_mul, mat_scale, mat_vec, scale, transpose, Real, M,
    V,
};
use crate::lanes::{m3, matrix, sub, v3, vector};
use crate::moments::{ElementMoments, EndDerivatives, FrameMotion};
use crate::pose::Pose;
use crate::quadrature::gauss_legendre;
use nalgebra::{Matrix3, Vector3};

type V3<T = f64> = Vector3<T>;
type M3<T = f64> = Matrix3<T>;

/// Gauss–Legendre points per element for the rotary integrals at W·l = `wl`. The
/// integrands reach frequency 4W, but their parts above ~1.5W are small: against the
/// generic kernel at high order (`superhelix compare-kernels`, 1000 configurations per
/// N, W·l up to 100) `4 + ⌈0.75 W·l⌉` points still agree to 2.5e-12 and `4 + ⌈0.5 W·l⌉`
/// fails (1e-3 at W·l = 100); at small W·l with fast own rotation the base matters
/// (`tests/kernel_moments.rs`, velocities up to 30 rad/s per unit q: `4 + ⌈W·l⌉` gives
/// 5.9e-10 at N = 1, W·l = 2, `5 +` 2.2e-11, `6 +` 3.2e-13). This rule, `6 + ⌈W·l⌉`,
/// keeps that margin. Capped at 246 (W·l = 240, where the generic kernel's rule is capped
/// too): beyond, an element is a coil of more than 38 turns and its rotary terms are
/// under-resolved rather than a step taking seconds.
pub fn rotary_points(wl: f64) -> usize {
    6 + crate::math::ceil(wl).min(240.0) as usize
}

/// Per-element rotary integrals, head coordinates.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RotaryElement<T: Arith = f64> {
    /// ∫ τ, τ = I α + Ωs × I Ωs.
    pub torque: V3<T>,
    /// ∫ w_i · τ (element frame w_i, τ in the element frame).
    pub b_own: [T; 3],
    /// ∫ Λ, `Λ = −I[Ωs]× + [Ωs]× I − [IΩs]×`.
    pub lambda: M3<T>,
    /// ∫ Λᵀ F w_i.
    pub lambda_w: [V3<T>; 3],
    /// ∫ ψ_j for the own columns j.
    pub psi: [V3<T>; 3],
    /// `own[(i, j)]` = ∫ F w_i · ψ_j.
    pub own: M3<T>,
    /// ∫ I (head coordinates).
    pub rot: M3<T>,
    /// ∫ I F w_i (head coordinates).
    pub rot_w: [V3<T>; 3],
}

/// The integrands of [`RotaryElement`] at one quadrature point (or, with `T` =
/// [`crate::lanes::F4`] or [`crate::lanes::F32x4`], at four at once, one per lane), each
/// already multiplied by the point's weight `wt`:
/// summed over the points in order they are the element's integrals in its start frame.
struct PointTerms<T> {
    torque: V<T>,
    b_own: [T; 3],
    lambda: M<T>,
    lambda_w: [V<T>; 3],
    psi: [V<T>; 3],
    /// `own[j][i]` = wt w_i · ψ_j.
    own: M<T>,
}

/// What [`point_terms`] reads that is the same at every point of an element: the
/// start frame's angular velocity `om` and acceleration `al` (element start frame), the
/// own velocities `qd`, their products `qq` and the diagonal `rotary` of D.
struct ElementMotion<T> {
    om: V<T>,
    al: V<T>,
    qd: [T; 3],
    qq: [[T; 3]; 3],
    rotary: [T; 3],
}

/// The weighted integrands at a point with frame `e` (by columns) and angular
/// derivatives `w`, `dw` (the Jacobian parts only when `jacobian`):
///
/// - τ = I α + Ωs × I Ωs with I = E D Eᵀ, Ωs = Ω + Σ w_i q̇_i,
///   α = α₀ + Ω × Σ w_i q̇_i + Σ ∂w_i/∂d_j q̇_i q̇_j;
/// - Λ = [Ωs]× I − I [Ωs]× − [IΩs]×, and for the own columns
///   ψ_j = I (Ω × w_j + Σ_i (∂w_j/∂d_i + ∂w_i/∂d_j) q̇_i) + Ωs × I w_j − IΩs × w_j.
#[inline(always)]
fn point_terms<T: Real>(
    m: &ElementMotion<T>,
    e: &M<T>,
    w: &[V<T>; 3],
    dw: &[[V<T>; 3]; 3],
    wt: T,
    jacobian: bool,
) -> PointTerms<T> {
    let (om, qd, qq, rotary) = (&m.om, &m.qd, &m.qq, &m.rotary);
    // I = E D Eᵀ = Σ_k D_k c_k c_kᵀ (symmetric)
    let sym = |a: usize, b: usize| {
        rotary[0] * e[0][a] * e[0][b]
            + rotary[1] * e[1][a] * e[1][b]
            + rotary[2] * e[2][a] * e[2][b]
    };
    let (i00, i01, i02, i11, i12, i22) = (
        sym(0, 0),
        sym(0, 1),
        sym(0, 2),
        sym(1, 1),
        sym(1, 2),
        sym(2, 2),
    );
    let inertia = [[i00, i01, i02], [i01, i11, i12], [i02, i12, i22]];
    let w_hat = add(
        &add(&scale(&w[0], qd[0]), &scale(&w[1], qd[1])),
        &scale(&w[2], qd[2]),
    );
    let omega_s = add(om, &w_hat);
    let mut alpha = add(&m.al, &cross(om, &w_hat));
    for i in 0..3 {
        for j in 0..3 {
            alpha = add(&alpha, &scale(&dw[i][j], qq[i][j]));
        }
    }
    let i_omega = mat_vec(&inertia, &omega_s);
    let tau = add(&mat_vec(&inertia, &alpha), &cross(&omega_s, &i_omega));
    let zero = T::zero();
    let mut out = PointTerms {
        torque: scale(&tau, wt),
        b_own: [
            wt * dot(&w[0], &tau),
            wt * dot(&w[1], &tau),
            wt * dot(&w[2], &tau),
        ],
        lambda: [[zero; 3]; 3],
        lambda_w: [[zero; 3]; 3],
        psi: [[zero; 3]; 3],
        own: [[zero; 3]; 3],
    };
    if jacobian {
        // Λ = [Ω]× I − I [Ω]× − [IΩ]× = A + Aᵀ − [IΩ]×, A = [Ω]× I (I symmetric)
        let a = mat_mul(&cross_matrix(&omega_s), &inertia);
        let a_sym = mat_add(&a, &transpose(&a), false);
        out.lambda = mat_scale(&mat_add(&a_sym, &cross_matrix(&i_omega), true), wt);
        for i in 0..3 {
            // Λᵀ w = (A + Aᵀ) w + (IΩ) × w
            out.lambda_w[i] = scale(&add(&mat_vec(&a_sym, &w[i]), &cross(&i_omega, &w[i])), wt);
        }
        for j in 0..3 {
            let mut rate = cross(om, &w[j]);
            for i in 0..3 {
                rate = add(&rate, &scale(&add(&dw[j][i], &dw[i][j]), qd[i]));
            }
            // ψ_j = I rate_j + Ω × (I w_j) − (IΩ) × w_j
            let iw = mat_vec(&inertia, &w[j]);
            let p = add(
                &add(&mat_vec(&inertia, &rate), &cross(&omega_s, &iw)),
                &cross(&w[j], &i_omega),
            );
            out.psi[j] = scale(&p, wt);
            for i in 0..3 {
                out.own[j][i] = wt * dot(&w[i], &p);
            }
        }
    }
    out
}

/// Points evaluated together by [`rotary_element`] (the lanes of [`Float::Lanes`]).
const LANES: usize = 4;

/// Lane `k` of a vector of lanes.
#[inline(always)]
fn lane<T: Float>(a: &V<T::Lanes>, k: usize) -> V3<T> {
    V3::new(T::lane(&a[0], k), T::lane(&a[1], k), T::lane(&a[2], k))
}

/// The rotary integrals of one element of length `l`, start pose
/// `pose`, start-frame motion `motion` and own velocities `qd`, by `points`-point
/// quadrature, the element's local functions from `eval(u, out)`, which fills lane k
/// of `out` for the abscissa `u[k]` (up to four at a time, see
/// `MomentSource::rotary_points`); the Jacobian parts only when `jacobian`.
///
/// The integrands are evaluated four points at a time (in the lanes of
/// [`Float::Lanes`]: [`crate::lanes::F4`] in f64, [`crate::lanes::F32x4`] in f32) and
/// summed point by point in order: the same values, bit for bit, as one point at a time
/// with nalgebra (the unit tests check this in f64).
///
/// Like the generated kernels, it is compiled twice, for the baseline target and with
/// AVX2 (four lanes in one register), and runs the AVX2 copy when the CPU has it; both
/// give the same bits (Rust does not fuse a multiply and an add on its own).
#[allow(clippy::too_many_arguments)]
pub fn rotary_element<T: Float>(
    eval: &dyn Fn(&[T], &mut RotaryPoints<T>),
    l: T,
    rotary: &[T; 3],
    moments: &ElementMoments<T>,
    pose: &Pose<T>,
    motion: &FrameMotion<T>,
    qd: &[T],
    points: usize,
    jacobian: bool,
) -> RotaryElement<T> {
    #[cfg(all(target_arch = "x86_64", feature = "std", not(target_feature = "avx2")))]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe {
                rotary_element_avx2(eval, l, rotary, moments, pose, motion, qd, points, jacobian)
            };
        }
    }
    rotary_element_body(eval, l, rotary, moments, pose, motion, qd, points, jacobian)
}

/// [`rotary_element`] compiled with AVX2.
#[cfg(all(target_arch = "x86_64", feature = "std", not(target_feature = "avx2")))]
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
fn rotary_element_avx2<T: Float>(
    eval: &dyn Fn(&[T], &mut RotaryPoints<T>),
    l: T,
    rotary: &[T; 3],
    moments: &ElementMoments<T>,
    pose: &Pose<T>,
    motion: &FrameMotion<T>,
    qd: &[T],
    points: usize,
    jacobian: bool,
) -> RotaryElement<T> {
    rotary_element_body(eval, l, rotary, moments, pose, motion, qd, points, jacobian)
}

/// The body of [`rotary_element`].
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn rotary_element_body<T: Float>(
    eval: &dyn Fn(&[T], &mut RotaryPoints<T>),
    l: T,
    rotary: &[T; 3],
    moments: &ElementMoments<T>,
    pose: &Pose<T>,
    motion: &FrameMotion<T>,
    qd: &[T],
    points: usize,
    jacobian: bool,
) -> RotaryElement<T> {
    let f = pose.frame;
    let om = f.transpose() * motion.omega;
    let al = f.transpose() * motion.alpha;
    let rule = gauss_legendre(points);
    let splat = |a: &V3<T>| {
        [
            T::Lanes::splat(a[0]),
            T::Lanes::splat(a[1]),
            T::Lanes::splat(a[2]),
        ]
    };
    let motion = ElementMotion {
        om: splat(&om),
        al: splat(&al),
        qd: core::array::from_fn(|i| T::Lanes::splat(qd[i])),
        qq: core::array::from_fn(|i| core::array::from_fn(|j| T::Lanes::splat(qd[i] * qd[j]))),
        rotary: rotary.map(T::Lanes::splat),
    };
    let mut out = RotaryElement::default();
    let mut lambda = M3::zeros();
    let mut lw = [V3::zeros(); 3];
    let mut psi = [V3::zeros(); 3];
    let mut torque = V3::zeros();
    // the points' frames and angular derivatives, one point per lane; lanes beyond
    // `used` are never summed
    let mut points = RotaryPoints::default();
    let mut u = [T::zero(); LANES];
    let (half, one) = (T::of(0.5), T::one());
    for (nodes, wgl) in rule.nodes().chunks(LANES).zip(rule.weights().chunks(LANES)) {
        let used = nodes.len();
        let mut weights = <T::Lanes as num_traits::Zero>::zero();
        for k in 0..used {
            u[k] = half * l * (T::of(nodes[k]) + one);
            T::set_lane(&mut weights, k, half * l * T::of(wgl[k]));
        }
        eval(&u[..used], &mut points);
        let (e, w, dw) = (&points.frame, &points.w, &points.dw);
        let terms = point_terms(&motion, e, w, dw, weights, jacobian);
        for k in 0..used {
            torque += lane::<T>(&terms.torque, k);
            for i in 0..3 {
                out.b_own[i] += T::lane(&terms.b_own[i], k);
            }
            if jacobian {
                for c in 0..3 {
                    for r in 0..3 {
                        lambda[(r, c)] += T::lane(&terms.lambda[c][r], k);
                        out.own[(r, c)] += T::lane(&terms.own[c][r], k);
                    }
                }
                for i in 0..3 {
                    lw[i] += lane::<T>(&terms.lambda_w[i], k);
                    psi[i] += lane::<T>(&terms.psi[i], k);
                }
            }
        }
    }
    out.torque = f * torque;
    out.lambda = f * lambda * f.transpose();
    out.rot = f * moments.rot * f.transpose();
    for i in 0..3 {
        out.lambda_w[i] = f * lw[i];
        out.psi[i] = f * psi[i];
        out.rot_w[i] = f * moments.rot_w[i];
    }
    out
}

/// The rotary integrals of [`rotary_element`] for element k of W strands at once, one
/// strand per lane (docs/architecture.md, "Strands in lanes"): lane k gives, bit for
/// bit, what [`rotary_element`] gives for its strand with `points[k]` points. The lanes'
/// abscissae are taken one at a time (`eval(u, out)` fills the W elements' frames and
/// angular derivatives at the lanes' abscissae `u`, as
/// `superhelix_generated::element_rotary_points_lanes` does); a lane with fewer points
/// than another stops adding once its own are summed.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn rotary_element_lanes<const W: usize>(
    eval: &mut impl FnMut(Lanes<f64, W>, &mut LaneRotaryPoints<W>),
    l: Lanes<f64, W>,
    rotary: &[Lanes<f64, W>; 3],
    moments: &ElementMoments<Lanes<f64, W>>,
    pose: &Pose<Lanes<f64, W>>,
    motion: &FrameMotion<Lanes<f64, W>>,
    qd: &[Lanes<f64, W>],
    points: [usize; W],
    jacobian: bool,
) -> RotaryElement<Lanes<f64, W>> {
    type L<const W: usize> = Lanes<f64, W>;
    let f = m3(&pose.frame);
    let ft = transpose(f);
    let om = mat_vec(&ft, v3(&motion.omega));
    let al = mat_vec(&ft, v3(&motion.alpha));
    let motion = ElementMotion {
        om,
        al,
        qd: [qd[0], qd[1], qd[2]],
        qq: core::array::from_fn(|i| core::array::from_fn(|j| qd[i] * qd[j])),
        rotary: *rotary,
    };
    let rules = points.map(gauss_legendre);
    let most = points.iter().copied().max().unwrap_or(0);
    let zero = Lanes([0.0; W]);
    let (mut torque, mut b_own, mut lambda) = ([zero; 3], [zero; 3], [[zero; 3]; 3]);
    let (mut own, mut lw, mut psi) = ([[zero; 3]; 3], [[zero; 3]; 3], [[zero; 3]; 3]);
    let mut at = LaneRotaryPoints::default();
    for m in 0..most {
        // lane k's abscissa m of its own rule (its last one again once past its count,
        // never summed)
        let node = |k: usize| {
            let rule = &rules[k];
            let m = m.min(rule.nodes().len() - 1);
            (rule.nodes()[m], rule.weights()[m])
        };
        let u = L::<W>::from_fn(|k| 0.5 * l.0[k] * (node(k).0 + 1.0));
        let weights = L::<W>::from_fn(|k| 0.5 * l.0[k] * node(k).1);
        let summed = crate::lane::Mask(core::array::from_fn(|k| m < points[k]));
        eval(u, &mut at);
        let terms = point_terms(&motion, &at.frame, &at.w, &at.dw, weights, jacobian);
        let sum = |a: L<W>, b: L<W>| L::<W>::select(summed, a + b, a);
        let sum_v =
            |a: &V<L<W>>, b: &V<L<W>>| -> V<L<W>> { core::array::from_fn(|r| sum(a[r], b[r])) };
        torque = sum_v(&torque, &terms.torque);
        b_own = sum_v(&b_own, &terms.b_own);
        if jacobian {
            for c in 0..3 {
                lambda[c] = sum_v(&lambda[c], &terms.lambda[c]);
                own[c] = sum_v(&own[c], &terms.own[c]);
            }
            for i in 0..3 {
                lw[i] = sum_v(&lw[i], &terms.lambda_w[i]);
                psi[i] = sum_v(&psi[i], &terms.psi[i]);
            }
        }
    }
    RotaryElement {
        torque: vector(mat_vec(f, &torque)),
        b_own,
        lambda: matrix(mat_mul(&mat_mul(f, &lambda), &ft)),
        lambda_w: lw.map(|x| vector(mat_vec(f, &x))),
        psi: psi.map(|x| vector(mat_vec(f, &x))),
        own: matrix(own),
        rot: matrix(mat_mul(&mat_mul(f, m3(&moments.rot)), &ft)),
        rot_w: moments.rot_w.map(|x| vector(mat_vec(f, v3(&x)))),
    }
}

/// Adds the rotary-inertia part of b to `b` when given, and of ∂b/∂q̇ to `jac` (column-major 3N × 3N) when given. `elements` from
/// [`rotary_element`]; `motions` from `moments::frame_motions`;
/// `beyond_scratch` of length N.
#[inline(always)]
pub fn add_rotary_terms<T: Arith>(
    end_derivs: &[EndDerivatives<T>],
    elements: &[RotaryElement<T>],
    motions: &[FrameMotion<T>],
    velocities: &[T],
    b: Option<&mut [T]>,
    jac: Option<&mut [T]>,
    beyond_scratch: &mut [(M3<T>, M3<T>)],
) {
    let n = end_derivs.len();
    let dofs = 3 * n;
    // b: own part plus dθ_k · (torque beyond)
    if let Some(b) = b {
        let mut beyond = [T::zero(); 3];
        for q in (0..n).rev() {
            for i in 0..3 {
                b[3 * q + i] += elements[q].b_own[i] + dot(v3(&end_derivs[q].dtheta[i]), &beyond);
            }
            beyond = add(&beyond, v3(&elements[q].torque));
        }
    }
    let Some(jac) = jac else { return };
    // suffix sums beyond element X of ∫ I and ∫ Λ: `beyond[X]` = Σ_{P > X}
    let beyond = beyond_scratch;
    beyond[n - 1] = (M3::<T>::zeros(), M3::<T>::zeros());
    for p in (0..n - 1).rev() {
        let e = &elements[p + 1];
        beyond[p] = (
            matrix(mat_add(m3(&beyond[p + 1].0), m3(&e.rot), false)),
            matrix(mat_add(m3(&beyond[p + 1].1), m3(&e.lambda), false)),
        );
    }
    for q2 in 0..n {
        let e2 = &end_derivs[q2];
        let qd2 = &velocities[3 * q2..3 * q2 + 3];
        let om_start = v3(&motions[q2].omega);
        let om_end = v3(&motions[q2 + 1].omega);
        for j in 0..3 {
            let col = 3 * q2 + j;
            let t = v3(&e2.dtheta[j]);
            let mut e_m = sub(&cross(om_start, t), &cross(t, om_end));
            for i in 0..3 {
                e_m = add(
                    &e_m,
                    &scale(&add(v3(&e2.dw[j][i]), v3(&e2.dw[i][j])), qd2[i]),
                );
            }
            // rows in elements ≤ q2, elements beyond q2
            let (rot, lambda) = (m3(&beyond[q2].0), m3(&beyond[q2].1));
            let g = add(&mat_vec(rot, &e_m), &mat_vec(lambda, t));
            for q in 0..=q2 {
                for i in 0..3 {
                    jac[col * dofs + 3 * q + i] += dot(v3(&end_derivs[q].dtheta[i]), &g);
                }
            }
            // rows upstream of q2 on element q2 itself, and own rows of q2
            for q in 0..q2 {
                for i in 0..3 {
                    jac[col * dofs + 3 * q + i] +=
                        dot(v3(&end_derivs[q].dtheta[i]), v3(&elements[q2].psi[j]));
                }
            }
            for i in 0..3 {
                jac[col * dofs + 3 * q2 + i] += m3(&elements[q2].own)[j][i];
            }
            // rows downstream: own part on their element, then beyond
            for q in q2 + 1..n {
                let el = &elements[q];
                let (rot, lambda) = (m3(&beyond[q].0), m3(&beyond[q].1));
                let g = add(&mat_vec(rot, &e_m), &mat_vec(lambda, t));
                for i in 0..3 {
                    jac[col * dofs + 3 * q + i] += dot(&e_m, v3(&el.rot_w[i]))
                        + dot(t, v3(&el.lambda_w[i]))
                        + dot(v3(&end_derivs[q].dtheta[i]), &g);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::{local_pose, ElementPoint};
    #[allow(unused_imports)]
    use std::{format, vec, vec::Vec};

    /// The rotary integrals one point at a time with nalgebra: the code the lane version
    /// replaced, kept as the reference it must match bit for bit.
    #[allow(clippy::too_many_arguments)]
    fn reference(
        eval: &dyn Fn(f64, &mut ElementPoint),
        l: f64,
        rotary: &[f64; 3],
        moments: &ElementMoments,
        pose: &Pose,
        motion: &FrameMotion,
        qd: &[f64],
        points: usize,
        jacobian: bool,
    ) -> RotaryElement {
        let f = pose.frame;
        let om = f.transpose() * motion.omega;
        let al = f.transpose() * motion.alpha;
        let rule = gauss_legendre(points);
        let mut out = RotaryElement::default();
        let (mut lambda, mut lw, mut psi, mut torque) =
            (M3::zeros(), [V3::zeros(); 3], [V3::zeros(); 3], V3::zeros());
        let mut qq = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                qq[i][j] = qd[i] * qd[j];
            }
        }
        let mut point = ElementPoint::default();
        for (x, wgl) in rule.nodes().iter().zip(rule.weights()) {
            let wt = 0.5 * l * wgl;
            eval(0.5 * l * (x + 1.0), &mut point);
            let e = &point.frame;
            let (c0, c1, c2) = (e.column(0), e.column(1), e.column(2));
            let sym = |a: usize, b: usize| {
                rotary[0] * c0[a] * c0[b] + rotary[1] * c1[a] * c1[b] + rotary[2] * c2[a] * c2[b]
            };
            let inertia = M3::new(
                sym(0, 0),
                sym(0, 1),
                sym(0, 2),
                sym(0, 1),
                sym(1, 1),
                sym(1, 2),
                sym(0, 2),
                sym(1, 2),
                sym(2, 2),
            );
            let (w, dw) = (&point.w, &point.dw);
            let w_hat = w[0] * qd[0] + w[1] * qd[1] + w[2] * qd[2];
            let omega_s = om + w_hat;
            let mut alpha = al + om.cross(&w_hat);
            for i in 0..3 {
                for j in 0..3 {
                    alpha += dw[i][j] * qq[i][j];
                }
            }
            let i_omega = inertia * omega_s;
            let tau = inertia * alpha + omega_s.cross(&i_omega);
            torque += tau * wt;
            for i in 0..3 {
                out.b_own[i] += wt * w[i].dot(&tau);
            }
            if jacobian {
                let a = omega_s.cross_matrix() * inertia;
                let a_sym = a + a.transpose();
                lambda += (a_sym - i_omega.cross_matrix()) * wt;
                let iw = [inertia * w[0], inertia * w[1], inertia * w[2]];
                for i in 0..3 {
                    lw[i] += (a_sym * w[i] + i_omega.cross(&w[i])) * wt;
                }
                for j in 0..3 {
                    let mut rate = om.cross(&w[j]);
                    for i in 0..3 {
                        rate += (dw[j][i] + dw[i][j]) * qd[i];
                    }
                    let p = inertia * rate + omega_s.cross(&iw[j]) + w[j].cross(&i_omega);
                    psi[j] += p * wt;
                    for i in 0..3 {
                        out.own[(i, j)] += wt * w[i].dot(&p);
                    }
                }
            }
        }
        out.torque = f * torque;
        out.lambda = f * lambda * f.transpose();
        out.rot = f * moments.rot * f.transpose();
        for i in 0..3 {
            out.lambda_w[i] = f * lw[i];
            out.psi[i] = f * psi[i];
            out.rot_w[i] = f * moments.rot_w[i];
        }
        out
    }

    fn bits(r: &RotaryElement) -> Vec<u64> {
        let mut v: Vec<f64> = Vec::new();
        v.extend(r.torque.iter());
        v.extend(r.b_own.iter());
        v.extend(r.lambda.iter());
        v.extend(r.own.iter());
        v.extend(r.rot.iter());
        for i in 0..3 {
            v.extend(r.lambda_w[i].iter());
            v.extend(r.psi[i].iter());
            v.extend(r.rot_w[i].iter());
        }
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// A linear congruential sequence of values in [−1, 1).
    fn sequence(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    /// The Darboux vectors' scales the tests draw: straight to W l = 40.
    const SCALES: [f64; 5] = [0.0, 1e-3, 1.0, 100.0, 400.0];

    /// One element of a strand in motion: its Darboux vector, length, rotary inertia,
    /// start pose and frame motion, own velocities, moments and point count.
    struct Case {
        d: V3,
        l: f64,
        rotary: [f64; 3],
        pose: Pose,
        motion: FrameMotion,
        qd: [f64; 3],
        moments: ElementMoments,
        points: usize,
    }

    impl Case {
        /// An element from `next`, its Darboux vector of size up to `scale`, its
        /// quadrature by `points` points.
        fn random(next: &mut impl FnMut() -> f64, scale: f64, points: usize) -> Case {
            let l = 0.01 + 0.05 * (next() + 1.0);
            let d = V3::new(next(), next(), next()) * scale;
            let rotary = [
                1e-9 * (1.5 + next()),
                5e-10 * (1.5 + next()),
                5e-10 * (1.5 + next()),
            ];
            let (frame, position) = local_pose(&V3::new(next(), next(), next()), 1.0);
            Case {
                d,
                l,
                rotary,
                pose: Pose { position, frame },
                motion: FrameMotion {
                    omega: V3::new(next(), next(), next()) * 30.0,
                    alpha: V3::new(next(), next(), next()) * 300.0,
                    ..Default::default()
                },
                qd: [30.0 * next(), 30.0 * next(), 30.0 * next()],
                moments: ElementMoments::by_quadrature(&d, l, &rotary, 8),
                points,
            }
        }

        /// The element's rotary points at the abscissae `u`, lane k for `u[k]`.
        fn eval(&self, u: &[f64], out: &mut RotaryPoints) {
            for (k, &u) in u.iter().enumerate() {
                out.set_lane(k, &ElementPoint::by_jets(&self.d, u));
            }
        }
    }

    /// Four points per lane batch, partial last batches (1 to 13 points), with and without
    /// the Jacobian parts, over Darboux vectors from straight to W l = 40: the same bits as
    /// the one-point nalgebra code, from the dispatched copy and the baseline one alike.
    #[test]
    fn lanes_match_one_point_at_a_time_bit_for_bit() {
        let mut next = sequence(0x9e37_79b9_7f4a_7c15);
        let mut checked = 0;
        for case in 0..120 {
            let c = Case::random(&mut next, SCALES[case % 5], 1 + case % 13);
            let eval = |u: f64, out: &mut ElementPoint| *out = ElementPoint::by_jets(&c.d, u);
            for jacobian in [false, true] {
                let args = (
                    &|u: &[f64], out: &mut RotaryPoints| c.eval(u, out),
                    c.l,
                    &c.rotary,
                    &c.moments,
                    &c.pose,
                    &c.motion,
                    &c.qd[..],
                    c.points,
                    jacobian,
                );
                let expected = bits(&reference(
                    &eval, args.1, args.2, args.3, args.4, args.5, args.6, args.7, args.8,
                ));
                let dispatched = rotary_element(
                    args.0, args.1, args.2, args.3, args.4, args.5, args.6, args.7, args.8,
                );
                let portable = rotary_element_body(
                    args.0, args.1, args.2, args.3, args.4, args.5, args.6, args.7, args.8,
                );
                assert_eq!(
                    bits(&dispatched),
                    expected,
                    "case {case}, jacobian {jacobian}"
                );
                assert_eq!(
                    bits(&portable),
                    expected,
                    "case {case}, jacobian {jacobian}"
                );
                checked += 1;
            }
        }
        assert_eq!(checked, 240);
    }

    /// Element k of four strands in lanes, each with its own element, motion and point
    /// count (1 to 13, different within a call): every lane gives [`rotary_element`]'s
    /// bits for its strand; and [`add_rotary_terms`] on those lanes gives each strand's
    /// b and ∂b/∂q̇ bits.
    #[test]
    fn strands_in_lanes_match_each_strand_bit_for_bit() {
        use crate::lane::soa::Soa;
        let mut next = sequence(0x2545_f491_4f6c_dd1d);
        for round in 0..30 {
            let cases: [Case; 4] = core::array::from_fn(|k| {
                let scale = SCALES[(round + k) % 5];
                Case::random(&mut next, scale, 1 + (round * 4 + k * 3) % 13)
            });
            let c = cases.each_ref();
            let mut eval = |u: Lanes<f64, 4>, out: &mut LaneRotaryPoints<4>| {
                for (k, case) in cases.iter().enumerate() {
                    let p = ElementPoint::by_jets(&case.d, u.0[k]);
                    for col in 0..3 {
                        for r in 0..3 {
                            out.frame[col][r].0[k] = p.frame[(r, col)];
                        }
                    }
                    for i in 0..3 {
                        for m in 0..3 {
                            out.w[i][m].0[k] = p.w[i][m];
                            for j in 0..3 {
                                out.dw[i][j][m].0[k] = p.dw[i][j][m];
                            }
                        }
                    }
                }
            };
            let qd: [Lanes<f64, 4>; 3] = Soa::load(c.map(|x| &x.qd));
            for jacobian in [false, true] {
                let lanes = rotary_element_lanes(
                    &mut eval,
                    Soa::load(c.map(|x| &x.l)),
                    &Soa::load(c.map(|x| &x.rotary)),
                    &Soa::load(c.map(|x| &x.moments)),
                    &Soa::load(c.map(|x| &x.pose)),
                    &Soa::load(c.map(|x| &x.motion)),
                    &qd,
                    c.map(|x| x.points),
                    jacobian,
                );
                let mut one_by_one = [RotaryElement::default(); 4];
                for (k, x) in cases.iter().enumerate() {
                    one_by_one[k] = rotary_element(
                        &|u: &[f64], out: &mut RotaryPoints| x.eval(u, out),
                        x.l,
                        &x.rotary,
                        &x.moments,
                        &x.pose,
                        &x.motion,
                        &x.qd,
                        x.points,
                        jacobian,
                    );
                    let lane = Soa::store(&lanes, k);
                    assert_eq!(bits(&lane), bits(&one_by_one[k]), "round {round}, lane {k}");
                }
                // the strand's rotary b and ∂b/∂q̇ from these elements (a strand of one
                // element per lane, and of the four as one strand)
                let derivs: [EndDerivatives; 4] = core::array::from_fn(|_| EndDerivatives {
                    dtheta: core::array::from_fn(|_| V3::new(next(), next(), next())),
                    dw: core::array::from_fn(|_| {
                        core::array::from_fn(|_| V3::new(next(), next(), next()))
                    }),
                    ..Default::default()
                });
                let motions: [FrameMotion; 5] = core::array::from_fn(|_| FrameMotion {
                    omega: V3::new(next(), next(), next()),
                    ..Default::default()
                });
                let v: [f64; 12] = core::array::from_fn(|_| next());
                let (mut b, mut jac) = ([0.5; 12], [0.25; 144]);
                let mut scratch = [(M3::zeros(), M3::zeros()); 4];
                add_rotary_terms(
                    &derivs,
                    &one_by_one,
                    &motions,
                    &v,
                    Some(&mut b),
                    Some(&mut jac),
                    &mut scratch,
                );
                let lane_elements: [RotaryElement<Lanes<f64, 4>>; 4] =
                    core::array::from_fn(|p| Soa::load([&one_by_one[p]; 4]));
                let (mut lb, mut ljac) = ([Lanes([0.5; 4]); 12], [Lanes([0.25; 4]); 144]);
                let mut lane_scratch = [(M3::zeros(), M3::zeros()); 4];
                add_rotary_terms(
                    &Soa::load([&derivs; 4]),
                    &lane_elements,
                    &Soa::load([&motions; 4]),
                    &Soa::load([&v; 4]),
                    Some(&mut lb),
                    Some(&mut ljac),
                    &mut lane_scratch,
                );
                for k in 0..4 {
                    assert!(b
                        .iter()
                        .zip(&lb)
                        .all(|(x, y)| x.to_bits() == y.0[k].to_bits()));
                    assert!(jac
                        .iter()
                        .zip(&ljac)
                        .all(|(x, y)| x.to_bits() == y.0[k].to_bits()));
                }
            }
        }
    }
}
