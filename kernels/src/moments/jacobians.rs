//! The Jacobians the implicit step needs, from element moments (docs/moment-assembly.md,
//! "Jacobians"): the damping ∫ Jᵀ C2 J, the field stiffness ∂(∫ Jᵀ(c0 + C1 y))/∂q and
//! B = ∂b/∂q̇ of the centreline, each O(N²) with O(1) work per entry.
//!
//! Every column k of an element Q moves the strand beyond Q rigidly,
//! `J_k(y) = v_k + ω_k × y`; a vector field g integrated against it needs only
//! `∫ g` and `∫ y × g` over the part beyond Q. Those two integrals come from the suffix
//! bodies ([`crate::moments::SuffixBody`]: mass, ∫y, ∫y yᵀ, ∫ẏ, ∫y ẏᵀ) when g is affine in y and ẏ,
//! which holds for C1 J_l, C2 J_l, f·∂²y and J̇_m. The own columns of an element
//! (`J_i = F ∂p/∂d_i`) contract with its moments.
//!
//! The rotary-inertia parts of b and ∂b/∂q̇ are in [`crate::moments::rotary`].

use crate::float::Float;
use crate::moments::{
    axial, cross_moment, ElementMoments, EndDerivatives, FrameMotion, SuffixBody,
};
use crate::pose::Pose;
use nalgebra::{Matrix3, Vector3};

type V3<T> = Vector3<T>;
type M3<T> = Matrix3<T>;

/// Twist (v, ω) of upstream column i of element Q about the point `at`:
/// J(y) = v + ω × (y − at), given `lever` = at − r_{Q+1}.
fn twist<T: Float>(e: &EndDerivatives<T>, lever: &V3<T>, i: usize) -> (V3<T>, V3<T>) {
    let w = e.dtheta[i];
    (e.dp[i] + w.cross(lever), w)
}

/// `∫ g` and `∫ x × g` over a body for g = W (v + ω × x), x relative to its reference.
fn weighted_rigid<T: Float>(
    w: &M3<T>,
    body: &SuffixBody<T>,
    v: &V3<T>,
    om: &V3<T>,
) -> (V3<T>, V3<T>) {
    let wv = w * v;
    let lin = wv * body.mass + w * om.cross(&body.first);
    let ang = body.first.cross(&wv) + cross_moment(&(w * om.cross_matrix()), &body.second);
    (lin, ang)
}

/// Adds `scale · ∫ J_k · W J_l ds` to `out(k, l)` for all k, l (`out` column-major,
/// 3N × 3N), for any 3 × 3 W: the damping (W = C2) and the linear-field part of the
/// stiffness (W = C1). `bodies` from [`crate::moments::suffix_bodies`] (positions only
/// needed).
pub fn add_weighted_gram<T: Float>(
    w: &M3<T>,
    scale: T,
    ends: &[Pose<T>],
    end_derivs: &[EndDerivatives<T>],
    moments: &[ElementMoments<T>],
    bodies: &[SuffixBody<T>],
    out: &mut [T],
) {
    let n = end_derivs.len();
    let dofs = 3 * n;
    let wt = w.transpose();
    let symmetric = w == &wt;
    // an antisymmetric W gives an antisymmetric result: (l, k) = −(k, l), one pass
    let antisymmetric = !symmetric && *w == -wt;
    let zero = V3::<T>::zeros();
    // pass 0: W, entries (k, l) with k in elements ≤ that of l;
    // pass 1: Wᵀ, entries (l, k) with k in elements < that of l
    for (pass, weight) in [w, &wt].into_iter().enumerate() {
        if pass == 1 && (symmetric || antisymmetric) {
            break;
        }
        for q2 in 0..n {
            let f = ends[q2].frame;
            let r = ends[q2].position;
            let r_end = ends[q2 + 1].position;
            let m2 = &moments[q2];
            let a_w = f.transpose() * weight * f;
            for j in 0..3 {
                let l = 3 * q2 + j;
                // twists about r_{q2+1}, the reference of the body beyond q2
                let (vl, wl) = twist(&end_derivs[q2], &zero, j);
                let (lin, ang) = weighted_rigid(weight, &bodies[q2 + 1], &vl, &wl);
                // own rows of element q2 (pass 0 only: the whole block)
                if pass == 0 {
                    for i in 0..3 {
                        let k = 3 * q2 + i;
                        let (vk, wk) = twist(&end_derivs[q2], &zero, i);
                        let own = a_w.component_mul(&m2.dpdp[i][j]).sum();
                        out[l * dofs + k] += scale * (own + vk.dot(&lin) + wk.dot(&ang));
                    }
                }
                // rows upstream: own part of l on element q2 plus the rigid part beyond
                // (about r_{q2})
                let lin_own = weight * (f * m2.dfirst[j]);
                let ang_own = f * cross_moment(&a_w, &m2.pdp[j]);
                let ang = ang + (r_end - r).cross(&lin) + ang_own;
                let lin = lin + lin_own;
                for q in 0..q2 {
                    let lever = r - ends[q + 1].position;
                    for i in 0..3 {
                        let k = 3 * q + i;
                        let (vk, wk) = twist(&end_derivs[q], &lever, i);
                        let val = scale * (vk.dot(&lin) + wk.dot(&ang));
                        if pass == 0 {
                            out[l * dofs + k] += val;
                            if symmetric {
                                out[k * dofs + l] += val;
                            } else if antisymmetric {
                                out[k * dofs + l] -= val;
                            }
                        } else {
                            out[k * dofs + l] += val;
                        }
                    }
                }
            }
        }
    }
}

/// Adds `∫ f · ∂²y/∂q_k∂q_l ds` for f = c0 + C1 y to `out(k, l)` (symmetric): the
/// Hessian part of the field stiffness (the rest is [`add_weighted_gram`] with C1).
pub fn add_field_hessian<T: Float>(
    c0: &V3<T>,
    c1: &M3<T>,
    ends: &[Pose<T>],
    end_derivs: &[EndDerivatives<T>],
    moments: &[ElementMoments<T>],
    bodies: &[SuffixBody<T>],
    out: &mut [T],
) {
    let n = end_derivs.len();
    let dofs = 3 * n;
    for q2 in 0..n {
        let f = ends[q2].frame;
        let r = ends[q2].position;
        let r_end = ends[q2 + 1].position;
        let m2 = &moments[q2];
        let e2 = &end_derivs[q2];
        let body = &bodies[q2 + 1];
        // the field over the body beyond q2 (x = y − r_end, f = c_end + C1 x):
        // ∫f, ∫ x fᵀ, ∫ x × f
        let c_end = c0 + c1 * r_end;
        let res = c_end * body.mass + c1 * body.first;
        let y_rho = body.first * c_end.transpose() + body.second * c1.transpose();
        let t_rho = body.first.cross(&c_end) + cross_moment(c1, &body.second);
        let a0 = f.transpose() * (c0 + c1 * r);
        let a = f.transpose() * c1 * f;
        // same element: own part and rigid part beyond (ρ = y − r_end)
        for i in 0..3 {
            for j in i..3 {
                let own = a0.dot(&m2.d2first[i][j]) + (a * m2.pd2p[i][j]).trace();
                let (ti, tj) = (e2.dtheta[i], e2.dtheta[j]);
                let rigid =
                    e2.d2p[i][j].dot(&res) + e2.dw[i][j].dot(&t_rho) + ti.dot(&(y_rho * tj))
                        - ti.dot(&tj) * y_rho.trace();
                let (k, l) = (3 * q2 + i, 3 * q2 + j);
                out[l * dofs + k] += own + rigid;
                if i != j {
                    out[k * dofs + l] += own + rigid;
                }
            }
        }
        // pairs k upstream of l: ω_k · ∫ J_l × f
        for j in 0..3 {
            let l = 3 * q2 + j;
            let (vl, wl) = twist(e2, &V3::<T>::zeros(), j);
            let own = f * (m2.dfirst[j].cross(&a0) + cross_moment(&a, &m2.pdp[j].transpose()));
            let u = own + vl.cross(&res) + y_rho * wl - wl * y_rho.trace();
            for q in 0..q2 {
                for i in 0..3 {
                    let k = 3 * q + i;
                    let val = end_derivs[q].dtheta[i].dot(&u);
                    out[l * dofs + k] += val;
                    out[k * dofs + l] += val;
                }
            }
        }
    }
}

/// `∫ g` and `∫ x × g` over a body for g = A + γ × x + t × ẏ, x relative to the body's
/// reference point.
fn jdot_rigid<T: Float>(
    body: &SuffixBody<T>,
    a: &V3<T>,
    gamma: &V3<T>,
    t: &V3<T>,
) -> (V3<T>, V3<T>) {
    let x = &body.moment_velocity;
    let lin = a * body.mass + gamma.cross(&body.first) + t.cross(&body.velocity);
    let ang = body.first.cross(a) + gamma * body.second.trace() - body.second * gamma
        + t * x.trace()
        - x.transpose() * t;
    (lin, ang)
}

/// Coefficients of one row of [`add_velocity_jacobian`] downstream of the column.
#[derive(Debug, Clone, Copy, Default)]
pub struct VelocityRow<T: Float = f64> {
    a: V3<T>,
    beyond: V3<T>,
    own: V3<T>,
    gamma: V3<T>,
    t: V3<T>,
}

/// Adds `scale · ∫ J_k · J̇_l ds` to `out(k, l)` for all k, l: with scale = 2ρS this is
/// the centreline part of B = ∂b/∂q̇ (b = ∫ ρS Jᵀ J̇ q̇, and J̇_l = ∂ẏ/∂q_l).
/// `bodies` from [`crate::moments::suffix_bodies`] with velocities, `motions` from [`crate::moments::frame_motions`];
/// `rows` is scratch of length 3N.
///
/// A row k = (Q, i) downstream of a column l = (Q2, j) receives `J_k · J̇_l` integrated
/// over element Q (own part) and beyond it (rigid part), both linear in the column's
/// (A, γ, t) of "J̇_l beyond Q2 = A + γ × (y − r_m) + t × ẏ": the row's coefficients of
/// A, γ and t ([`VelocityRow`]) are formed once per row, so each such entry costs a few
/// dot products.
#[allow(clippy::too_many_arguments)]
pub fn add_velocity_jacobian<T: Float>(
    scale: T,
    ends: &[Pose<T>],
    end_derivs: &[EndDerivatives<T>],
    moments: &[ElementMoments<T>],
    motions: &[FrameMotion<T>],
    bodies: &[SuffixBody<T>],
    velocities: &[T],
    rows: &mut [VelocityRow<T>],
    out: &mut [T],
) {
    let n = end_derivs.len();
    let dofs = 3 * n;
    // per row k = (q, i): the entry for a column with (a, γ, t) and r_m upstream of q is
    // a·(R_a + D) + (γ × (r_{Q+1} − r_m))·R_a + (γ × (r_Q − r_m))·D + γ·X_γ + t·X_t
    for q in 1..n {
        let f = ends[q].frame;
        let mq = &moments[q];
        let mo = &motions[q];
        let body = &bodies[q + 1];
        let qd = &velocities[3 * q..3 * q + 3];
        let x = &body.moment_velocity;
        let (tr_s, tr_x) = (body.second.trace(), x.trace());
        for i in 0..3 {
            let (vk, wk) = (end_derivs[q].dp[i], end_derivs[q].dtheta[i]);
            // rigid part beyond q: vk·lin + wk·ang of `jdot_rigid`
            let r_a = vk * body.mass + wk.cross(&body.first);
            let r_g = body.first.cross(&vk) + wk * tr_s - body.second * wk;
            let r_t = body.velocity.cross(&vk) + wk * tr_x - x * wk;
            // own part on q: D·(A + γ × (r_Q − r_m) + t × ṙ_Q) + C·γ + P·t
            let d = f * mq.dfirst[i];
            let c = f * mq.cross[i];
            let mut own_t = mq.pdp[i] * (f.transpose() * mo.omega);
            for cc in 0..3 {
                own_t += axial(&mq.dpdp[cc][i]) * qd[cc];
            }
            let p = f * own_t - mo.omega * mq.pdp[i].trace();
            rows[3 * q + i] = VelocityRow {
                a: r_a + d,
                beyond: r_a,
                own: d,
                gamma: r_g + c,
                t: r_t + mo.velocity.cross(&d) + p,
            };
        }
    }
    for q2 in 0..n {
        let f2 = ends[q2].frame;
        let r2 = ends[q2].position;
        let r_m = ends[q2 + 1].position;
        let m2 = &moments[q2];
        let e2 = &end_derivs[q2];
        let om2 = motions[q2].omega;
        let om2_local = f2.transpose() * om2;
        let qd2 = &velocities[3 * q2..3 * q2 + 3];
        let vel_end = motions[q2 + 1].velocity;
        for j in 0..3 {
            let l = 3 * q2 + j;
            let t = e2.dtheta[j];
            // J̇_l beyond q2 = A + γ × (y − r_m) + t × ẏ
            let mut a = om2.cross(&e2.dp[j]) - t.cross(&vel_end);
            let mut gamma = om2.cross(&t);
            for i in 0..3 {
                a += e2.d2p[j][i] * qd2[i];
                gamma += e2.dw[j][i] * qd2[i];
            }
            // own part of J̇_l on q2: F h, h = Ω × ∂_j p + Σ_i q̇_i ∂²_ji p (element frame)
            let mut h1 = om2_local.cross(&m2.dfirst[j]);
            let mut hx = om2_local * m2.pdp[j].trace() - m2.pdp[j].transpose() * om2_local;
            for i in 0..3 {
                h1 += m2.d2first[j][i] * qd2[i];
                hx += m2.cross2[j][i] * qd2[i];
            }
            let zero = V3::<T>::zeros();
            let (lin_b, ang_b) = jdot_rigid(&bodies[q2 + 1], &a, &gamma, &t);
            // rows of element q2 itself (twists about r_m)
            for i in 0..3 {
                let k = 3 * q2 + i;
                let (vk, wk) = twist(e2, &zero, i);
                let mut own = om2_local.dot(&axial(&m2.dpdp[j][i]));
                for c in 0..3 {
                    own += m2.dpd2p[i][j][c] * qd2[c];
                }
                out[l * dofs + k] += scale * (own + vk.dot(&lin_b) + wk.dot(&ang_b));
            }
            // rows upstream (about r2)
            let lin_own = f2 * h1;
            let ang = ang_b + (r_m - r2).cross(&lin_b) + f2 * hx;
            let lin = lin_b + lin_own;
            for q in 0..q2 {
                let lever = r2 - ends[q + 1].position;
                for i in 0..3 {
                    let (vk, wk) = twist(&end_derivs[q], &lever, i);
                    out[l * dofs + 3 * q + i] += scale * (vk.dot(&lin) + wk.dot(&ang));
                }
            }
            // rows downstream: element q's own part, then the rigid part beyond q
            for q in q2 + 1..n {
                let g_own = gamma.cross(&(ends[q].position - r_m));
                let g_beyond = gamma.cross(&(ends[q + 1].position - r_m));
                for i in 0..3 {
                    let row = &rows[3 * q + i];
                    out[l * dofs + 3 * q + i] += scale
                        * (row.a.dot(&a)
                            + row.beyond.dot(&g_beyond)
                            + row.own.dot(&g_own)
                            + row.gamma.dot(&gamma)
                            + row.t.dot(&t));
                }
            }
        }
    }
}
