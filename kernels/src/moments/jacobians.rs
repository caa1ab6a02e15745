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

use crate::float::Arith;
use crate::lanes::{self as la, m3, matrix, v3, Ring, M, V};
use crate::moments::{
    axial, cross_moment, ElementMoments, EndDerivatives, FrameMotion, SuffixBody,
};
use crate::pose::Pose;
use nalgebra::{Matrix3, Vector3};

/// Twist (v, ω) of upstream column i of element Q about the point `at`:
/// J(y) = v + ω × (y − at), given `lever` = at − r_{Q+1}.
#[inline(always)]
fn twist<T: Arith>(e: &EndDerivatives<T>, lever: &V<T>, i: usize) -> (V<T>, V<T>) {
    let w = *v3(&e.dtheta[i]);
    (la::add(v3(&e.dp[i]), &la::cross(&w, lever)), w)
}

/// `∫ g` and `∫ x × g` over a body for g = W (v + ω × x), x relative to its reference.
#[inline(always)]
fn weighted_rigid<T: Arith>(w: &M<T>, body: &SuffixBody<T>, v: &V<T>, om: &V<T>) -> (V<T>, V<T>) {
    let first = v3(&body.first);
    let wv = la::mat_vec(w, v);
    let lin = la::add(
        &la::scale(&wv, body.mass),
        &la::mat_vec(w, &la::cross(om, first)),
    );
    let spin = matrix(la::mat_mul(w, &la::cross_matrix(om)));
    let ang = la::add(
        &la::cross(first, &wv),
        v3(&cross_moment(&spin, &body.second)),
    );
    (lin, ang)
}

/// `-a`, entry by entry.
#[inline(always)]
fn negated<T: Ring>(a: &M<T>) -> M<T> {
    a.map(|column| column.map(|x| -x))
}

/// Adds `scale · ∫ J_k · W J_l ds` to `out(k, l)` for all k, l (`out` column-major,
/// 3N × 3N), for any 3 × 3 W: the damping (W = C2) and the linear-field part of the
/// stiffness (W = C1). `bodies` from [`crate::moments::suffix_bodies`] (positions only
/// needed). On lanes, W is taken as symmetric (or antisymmetric) when it is in every
/// lane.
#[inline(always)]
pub fn add_weighted_gram<T: Arith>(
    w: &Matrix3<T>,
    scale: T,
    ends: &[Pose<T>],
    end_derivs: &[EndDerivatives<T>],
    moments: &[ElementMoments<T>],
    bodies: &[SuffixBody<T>],
    out: &mut [T],
) {
    let n = end_derivs.len();
    let dofs = 3 * n;
    let w = m3(w);
    let wt = la::transpose(w);
    let symmetric = *w == wt;
    // an antisymmetric W gives an antisymmetric result: (l, k) = −(k, l), one pass
    let antisymmetric = !symmetric && *w == negated(&wt);
    let zero = [T::zero(); 3];
    // pass 0: W, entries (k, l) with k in elements ≤ that of l;
    // pass 1: Wᵀ, entries (l, k) with k in elements < that of l
    for (pass, weight) in [w, &wt].into_iter().enumerate() {
        if pass == 1 && (symmetric || antisymmetric) {
            break;
        }
        for q2 in 0..n {
            let f = m3(&ends[q2].frame);
            let r = v3(&ends[q2].position);
            let r_end = v3(&ends[q2 + 1].position);
            let m2 = &moments[q2];
            let a_w = la::mat_mul(&la::mat_mul(&la::transpose(f), weight), f);
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
                        let own = la::sum_of_products(&a_w, m3(&m2.dpdp[i][j]));
                        out[l * dofs + k] +=
                            scale * (own + la::dot(&vk, &lin) + la::dot(&wk, &ang));
                    }
                }
                // rows upstream: own part of l on element q2 plus the rigid part beyond
                // (about r_{q2})
                let lin_own = la::mat_vec(weight, &la::mat_vec(f, v3(&m2.dfirst[j])));
                let ang_own = la::mat_vec(f, v3(&cross_moment(&matrix(a_w), &m2.pdp[j])));
                let ang = la::add(&ang, &la::cross(&la::sub(r_end, r), &lin));
                let ang = la::add(&ang, &ang_own);
                let lin = la::add(&lin, &lin_own);
                for q in 0..q2 {
                    let lever = la::sub(r, v3(&ends[q + 1].position));
                    for i in 0..3 {
                        let k = 3 * q + i;
                        let (vk, wk) = twist(&end_derivs[q], &lever, i);
                        let val = scale * (la::dot(&vk, &lin) + la::dot(&wk, &ang));
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
#[inline(always)]
pub fn add_field_hessian<T: Arith>(
    c0: &Vector3<T>,
    c1: &Matrix3<T>,
    ends: &[Pose<T>],
    end_derivs: &[EndDerivatives<T>],
    moments: &[ElementMoments<T>],
    bodies: &[SuffixBody<T>],
    out: &mut [T],
) {
    let n = end_derivs.len();
    let dofs = 3 * n;
    let (c0, c1_matrix) = (v3(c0), c1);
    let c1 = m3(c1);
    for q2 in 0..n {
        let f = m3(&ends[q2].frame);
        let r = v3(&ends[q2].position);
        let r_end = v3(&ends[q2 + 1].position);
        let m2 = &moments[q2];
        let e2 = &end_derivs[q2];
        let body = &bodies[q2 + 1];
        let (first, second) = (v3(&body.first), m3(&body.second));
        // the field over the body beyond q2 (x = y − r_end, f = c_end + C1 x):
        // ∫f, ∫ x fᵀ, ∫ x × f
        let c_end = la::add(c0, &la::mat_vec(c1, r_end));
        let res = la::add(&la::scale(&c_end, body.mass), &la::mat_vec(c1, first));
        let y_rho = la::mat_add(
            &la::outer(first, &c_end),
            &la::mat_mul(second, &la::transpose(c1)),
            false,
        );
        let t_rho = la::add(
            &la::cross(first, &c_end),
            v3(&cross_moment(c1_matrix, &body.second)),
        );
        let ft = la::transpose(f);
        let a0 = la::mat_vec(&ft, &la::add(c0, &la::mat_vec(c1, r)));
        let a = la::mat_mul(&la::mat_mul(&ft, c1), f);
        let tr_y = la::trace(&y_rho);
        // same element: own part and rigid part beyond (ρ = y − r_end)
        for i in 0..3 {
            for j in i..3 {
                let own = la::dot(&a0, v3(&m2.d2first[i][j]))
                    + la::trace(&la::mat_mul(&a, m3(&m2.pd2p[i][j])));
                let (ti, tj) = (v3(&e2.dtheta[i]), v3(&e2.dtheta[j]));
                let rigid = la::dot(v3(&e2.d2p[i][j]), &res)
                    + la::dot(v3(&e2.dw[i][j]), &t_rho)
                    + la::dot(ti, &la::mat_vec(&y_rho, tj))
                    - la::dot(ti, tj) * tr_y;
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
            let (vl, wl) = twist(e2, &[T::zero(); 3], j);
            let pdp_t = matrix(la::transpose(m3(&m2.pdp[j])));
            let own = la::add(
                &la::cross(v3(&m2.dfirst[j]), &a0),
                v3(&cross_moment(&matrix(a), &pdp_t)),
            );
            let own = la::mat_vec(f, &own);
            let u = la::add(
                &la::add(&own, &la::cross(&vl, &res)),
                &la::mat_vec(&y_rho, &wl),
            );
            let u = la::sub(&u, &la::scale(&wl, tr_y));
            for q in 0..q2 {
                for i in 0..3 {
                    let k = 3 * q + i;
                    let val = la::dot(v3(&end_derivs[q].dtheta[i]), &u);
                    out[l * dofs + k] += val;
                    out[k * dofs + l] += val;
                }
            }
        }
    }
}

/// `∫ g` and `∫ x × g` over a body for g = A + γ × x + t × ẏ, x relative to the body's
/// reference point.
#[inline(always)]
fn jdot_rigid<T: Arith>(body: &SuffixBody<T>, a: &V<T>, gamma: &V<T>, t: &V<T>) -> (V<T>, V<T>) {
    let x = m3(&body.moment_velocity);
    let (first, second) = (v3(&body.first), m3(&body.second));
    let lin = la::add(&la::scale(a, body.mass), &la::cross(gamma, first));
    let lin = la::add(&lin, &la::cross(t, v3(&body.velocity)));
    let ang = la::add(&la::cross(first, a), &la::scale(gamma, la::trace(second)));
    let ang = la::sub(&ang, &la::mat_vec(second, gamma));
    let ang = la::add(&ang, &la::scale(t, la::trace(x)));
    let ang = la::sub(&ang, &la::mat_vec(&la::transpose(x), t));
    (lin, ang)
}

/// Coefficients of one row of [`add_velocity_jacobian`] downstream of the column.
#[derive(Debug, Clone, Copy, Default)]
pub struct VelocityRow<T: Arith = f64> {
    a: V<T>,
    beyond: V<T>,
    own: V<T>,
    gamma: V<T>,
    t: V<T>,
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
#[inline(always)]
pub fn add_velocity_jacobian<T: Arith>(
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
        let f = m3(&ends[q].frame);
        let mq = &moments[q];
        let (omega, velocity) = (v3(&motions[q].omega), v3(&motions[q].velocity));
        let body = &bodies[q + 1];
        let qd = &velocities[3 * q..3 * q + 3];
        let x = m3(&body.moment_velocity);
        let (first, second) = (v3(&body.first), m3(&body.second));
        let (tr_s, tr_x) = (la::trace(second), la::trace(x));
        for i in 0..3 {
            let (vk, wk) = (v3(&end_derivs[q].dp[i]), v3(&end_derivs[q].dtheta[i]));
            // rigid part beyond q: vk·lin + wk·ang of `jdot_rigid`
            let r_a = la::add(&la::scale(vk, body.mass), &la::cross(wk, first));
            let r_g = la::add(&la::cross(first, vk), &la::scale(wk, tr_s));
            let r_g = la::sub(&r_g, &la::mat_vec(second, wk));
            let r_t = la::add(&la::cross(v3(&body.velocity), vk), &la::scale(wk, tr_x));
            let r_t = la::sub(&r_t, &la::mat_vec(x, wk));
            // own part on q: D·(A + γ × (r_Q − r_m) + t × ṙ_Q) + C·γ + P·t
            let d = la::mat_vec(f, v3(&mq.dfirst[i]));
            let c = la::mat_vec(f, v3(&mq.cross[i]));
            let pdp = m3(&mq.pdp[i]);
            let mut own_t = la::mat_vec(pdp, &la::mat_vec(&la::transpose(f), omega));
            for cc in 0..3 {
                own_t = la::add(&own_t, &la::scale(v3(&axial(&mq.dpdp[cc][i])), qd[cc]));
            }
            let p = la::sub(&la::mat_vec(f, &own_t), &la::scale(omega, la::trace(pdp)));
            rows[3 * q + i] = VelocityRow {
                a: la::add(&r_a, &d),
                beyond: r_a,
                own: d,
                gamma: la::add(&r_g, &c),
                t: la::add(&la::add(&r_t, &la::cross(velocity, &d)), &p),
            };
        }
    }
    for q2 in 0..n {
        let f2 = m3(&ends[q2].frame);
        let r2 = v3(&ends[q2].position);
        let r_m = v3(&ends[q2 + 1].position);
        let m2 = &moments[q2];
        let e2 = &end_derivs[q2];
        let om2 = v3(&motions[q2].omega);
        let om2_local = la::mat_vec(&la::transpose(f2), om2);
        let qd2 = &velocities[3 * q2..3 * q2 + 3];
        let vel_end = v3(&motions[q2 + 1].velocity);
        for j in 0..3 {
            let l = 3 * q2 + j;
            let t = *v3(&e2.dtheta[j]);
            // J̇_l beyond q2 = A + γ × (y − r_m) + t × ẏ
            let mut a = la::sub(&la::cross(om2, v3(&e2.dp[j])), &la::cross(&t, vel_end));
            let mut gamma = la::cross(om2, &t);
            for i in 0..3 {
                a = la::add(&a, &la::scale(v3(&e2.d2p[j][i]), qd2[i]));
                gamma = la::add(&gamma, &la::scale(v3(&e2.dw[j][i]), qd2[i]));
            }
            // own part of J̇_l on q2: F h, h = Ω × ∂_j p + Σ_i q̇_i ∂²_ji p (element frame)
            let pdp = m3(&m2.pdp[j]);
            let mut h1 = la::cross(&om2_local, v3(&m2.dfirst[j]));
            let mut hx = la::sub(
                &la::scale(&om2_local, la::trace(pdp)),
                &la::mat_vec(&la::transpose(pdp), &om2_local),
            );
            for i in 0..3 {
                h1 = la::add(&h1, &la::scale(v3(&m2.d2first[j][i]), qd2[i]));
                hx = la::add(&hx, &la::scale(v3(&m2.cross2[j][i]), qd2[i]));
            }
            let zero = [T::zero(); 3];
            let (lin_b, ang_b) = jdot_rigid(&bodies[q2 + 1], &a, &gamma, &t);
            // rows of element q2 itself (twists about r_m)
            for i in 0..3 {
                let k = 3 * q2 + i;
                let (vk, wk) = twist(e2, &zero, i);
                let mut own = la::dot(&om2_local, v3(&axial(&m2.dpdp[j][i])));
                for c in 0..3 {
                    own += m2.dpd2p[i][j][c] * qd2[c];
                }
                out[l * dofs + k] += scale * (own + la::dot(&vk, &lin_b) + la::dot(&wk, &ang_b));
            }
            // rows upstream (about r2)
            let lin_own = la::mat_vec(f2, &h1);
            let ang = la::add(&ang_b, &la::cross(&la::sub(r_m, r2), &lin_b));
            let ang = la::add(&ang, &la::mat_vec(f2, &hx));
            let lin = la::add(&lin_b, &lin_own);
            for q in 0..q2 {
                let lever = la::sub(r2, v3(&ends[q + 1].position));
                for i in 0..3 {
                    let (vk, wk) = twist(&end_derivs[q], &lever, i);
                    out[l * dofs + 3 * q + i] += scale * (la::dot(&vk, &lin) + la::dot(&wk, &ang));
                }
            }
            // rows downstream: element q's own part, then the rigid part beyond q
            for q in q2 + 1..n {
                let g_own = la::cross(&gamma, &la::sub(v3(&ends[q].position), r_m));
                let g_beyond = la::cross(&gamma, &la::sub(v3(&ends[q + 1].position), r_m));
                for i in 0..3 {
                    let row = &rows[3 * q + i];
                    out[l * dofs + 3 * q + i] += scale
                        * (la::dot(&row.a, &a)
                            + la::dot(&row.beyond, &g_beyond)
                            + la::dot(&row.own, &g_own)
                            + la::dot(&row.gamma, &gamma)
                            + la::dot(&row.t, &t));
                }
            }
        }
    }
}
