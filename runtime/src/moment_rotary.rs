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

use crate::element::ElementPoint;
use crate::moments::{ElementMoments, EndDerivatives, FrameMotion};
use crate::quadrature::gauss_legendre;
use crate::reconstruction::Pose;
use nalgebra::{Matrix3, Vector3};

type V3 = Vector3<f64>;
type M3 = Matrix3<f64>;

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
    6 + wl.ceil().min(240.0) as usize
}

/// Per-element rotary integrals, head coordinates.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RotaryElement {
    /// ∫ τ, τ = I α + Ωs × I Ωs.
    pub torque: V3,
    /// ∫ w_i · τ (element frame w_i, τ in the element frame).
    pub b_own: [f64; 3],
    /// ∫ Λ, `Λ = −I[Ωs]× + [Ωs]× I − [IΩs]×`.
    pub lambda: M3,
    /// ∫ Λᵀ F w_i.
    pub lambda_w: [V3; 3],
    /// ∫ ψ_j for the own columns j.
    pub psi: [V3; 3],
    /// `own[(i, j)]` = ∫ F w_i · ψ_j.
    pub own: M3,
    /// ∫ I (head coordinates).
    pub rot: M3,
    /// ∫ I F w_i (head coordinates).
    pub rot_w: [V3; 3],
}

/// The rotary integrals of one element of length `l`, start pose
/// `pose`, start-frame motion `motion` and own velocities `qd`, by `points`-point
/// quadrature, the element's local functions from `eval(u, out)` (of which only
/// `frame`, `w` and `dw` are read: `eval` need not fill `d2p`, see
/// `MomentSource::rotary_point`); the Jacobian parts only when `jacobian`.
#[allow(clippy::too_many_arguments)]
pub fn rotary_element(
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
    let mut lambda = M3::zeros();
    let mut lw = [V3::zeros(); 3];
    let mut psi = [V3::zeros(); 3];
    let mut torque = V3::zeros();
    // qd_i qd_j and the symmetrised own-velocity weights, once per element
    let mut qq = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            qq[i][j] = qd[i] * qd[j];
        }
    }
    let mut point = ElementPoint::default();
    for (x, wgl) in rule.nodes.iter().zip(&rule.weights) {
        let u = 0.5 * l * (x + 1.0);
        let wt = 0.5 * l * wgl;
        eval(u, &mut point);
        // I = E D Eᵀ = Σ_k D_k c_k c_kᵀ (symmetric)
        let e = &point.frame;
        let (c0, c1, c2) = (e.column(0), e.column(1), e.column(2));
        let sym = |a: usize, b: usize| {
            rotary[0] * c0[a] * c0[b] + rotary[1] * c1[a] * c1[b] + rotary[2] * c2[a] * c2[b]
        };
        let (i00, i01, i02, i11, i12, i22) = (
            sym(0, 0),
            sym(0, 1),
            sym(0, 2),
            sym(1, 1),
            sym(1, 2),
            sym(2, 2),
        );
        let inertia = M3::new(i00, i01, i02, i01, i11, i12, i02, i12, i22);
        let w = &point.w;
        let dw = &point.dw;
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
            // Λ = [Ω]× I − I [Ω]× − [IΩ]× = A + Aᵀ − [IΩ]×, A = [Ω]× I (I symmetric)
            let a = omega_s.cross_matrix() * inertia;
            let a_sym = a + a.transpose();
            lambda += (a_sym - i_omega.cross_matrix()) * wt;
            // A w_i = Ω × (I w_i), shared by Λᵀ w_i and ψ_i
            let iw = [inertia * w[0], inertia * w[1], inertia * w[2]];
            for i in 0..3 {
                // Λᵀ w = (A + Aᵀ) w + (IΩ) × w
                lw[i] += (a_sym * w[i] + i_omega.cross(&w[i])) * wt;
            }
            for j in 0..3 {
                let mut rate = om.cross(&w[j]);
                for i in 0..3 {
                    rate += (dw[j][i] + dw[i][j]) * qd[i];
                }
                // ψ_j = I rate_j + Ω × (I w_j) − (IΩ) × w_j
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

/// Adds the rotary-inertia part of b to `b` when given, and of ∂b/∂q̇ to `jac` (column-major 3N × 3N) when given. `elements` from
/// [`rotary_element`]; `motions` from `moments::frame_motions`;
/// `beyond_scratch` of length N.
pub fn add_rotary_terms(
    end_derivs: &[EndDerivatives],
    elements: &[RotaryElement],
    motions: &[FrameMotion],
    velocities: &[f64],
    b: Option<&mut [f64]>,
    jac: Option<&mut [f64]>,
    beyond_scratch: &mut [(M3, M3)],
) {
    let n = end_derivs.len();
    let dofs = 3 * n;
    // b: own part plus dθ_k · (torque beyond)
    if let Some(b) = b {
        let mut beyond = V3::zeros();
        for q in (0..n).rev() {
            for i in 0..3 {
                b[3 * q + i] += elements[q].b_own[i] + end_derivs[q].dtheta[i].dot(&beyond);
            }
            beyond += elements[q].torque;
        }
    }
    let Some(jac) = jac else { return };
    // suffix sums beyond element X of ∫ I and ∫ Λ: `beyond[X]` = Σ_{P > X}
    let beyond = beyond_scratch;
    beyond[n - 1] = (M3::zeros(), M3::zeros());
    for p in (0..n - 1).rev() {
        let e = &elements[p + 1];
        beyond[p] = (beyond[p + 1].0 + e.rot, beyond[p + 1].1 + e.lambda);
    }
    for q2 in 0..n {
        let e2 = &end_derivs[q2];
        let qd2 = &velocities[3 * q2..3 * q2 + 3];
        let om_start = motions[q2].omega;
        let om_end = motions[q2 + 1].omega;
        for j in 0..3 {
            let col = 3 * q2 + j;
            let t = e2.dtheta[j];
            let mut e_m = om_start.cross(&t) - t.cross(&om_end);
            for i in 0..3 {
                e_m += (e2.dw[j][i] + e2.dw[i][j]) * qd2[i];
            }
            // rows in elements ≤ q2, elements beyond q2
            let g = beyond[q2].0 * e_m + beyond[q2].1 * t;
            for q in 0..=q2 {
                for i in 0..3 {
                    jac[col * dofs + 3 * q + i] += end_derivs[q].dtheta[i].dot(&g);
                }
            }
            // rows upstream of q2 on element q2 itself, and own rows of q2
            for q in 0..q2 {
                for i in 0..3 {
                    jac[col * dofs + 3 * q + i] +=
                        end_derivs[q].dtheta[i].dot(&elements[q2].psi[j]);
                }
            }
            for i in 0..3 {
                jac[col * dofs + 3 * q2 + i] += elements[q2].own[(i, j)];
            }
            // rows downstream: own part on their element, then beyond
            for q in q2 + 1..n {
                let el = &elements[q];
                let g = beyond[q].0 * e_m + beyond[q].1 * t;
                for i in 0..3 {
                    jac[col * dofs + 3 * q + i] += e_m.dot(&el.rot_w[i])
                        + t.dot(&el.lambda_w[i])
                        + end_derivs[q].dtheta[i].dot(&g);
                }
            }
        }
    }
}
