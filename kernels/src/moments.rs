//! Assembly from element moments (design page "Efficient assembly"): a change of q in
//! element Q moves everything beyond element Q rigidly, so M and the first-moment
//! Jacobian need, per element, only integrals over the element of its local centreline
//! p(u), of the derivatives ∂p/∂d_i and of the rotary inertia; the part beyond an
//! element enters through the suffix sums of mass, first and second moments, as for
//! composite rigid bodies. O(N²) work with O(1) per entry, no quadrature at run time
//! once the moments are closed forms.
//!
//! [`ElementMoments::by_quadrature`] is the reference the generated closed forms are
//! checked against; [`assemble_mass_and_gravity`] is the assembly both feed.
//!
//! The runtime's kernel built on them is its `MomentKernel`; the Jacobians of the implicit
//! step are in [`jacobians`], the rotary-inertia quadrature in [`rotary`].

pub mod jacobians;
pub mod rotary;

use crate::body_field::BodyField;
use crate::element::{element_jets, local_pose};
use crate::float::{Arith, Float};
use crate::lanes::{self as la, m3, matrix, v3, vector, Ring, M, V};
use crate::pose::Pose;
use crate::quadrature::gauss_legendre;
use nalgebra::{Matrix3, Vector3};

/// Integrals over one element, u ∈ [0, l], in the element's start frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ElementMoments<T: Arith = f64> {
    /// ∫ p du.
    pub first: Vector3<T>,
    /// ∫ p pᵀ du.
    pub second: Matrix3<T>,
    /// `dfirst[i]` = ∫ ∂p/∂d_i du.
    pub dfirst: [Vector3<T>; 3],
    /// `cross[i]` = ∫ p × ∂p/∂d_i du.
    pub cross: [Vector3<T>; 3],
    /// `gram[i][j]` = ∫ ∂p/∂d_i · ∂p/∂d_j du.
    pub gram: Matrix3<T>,
    /// ∫ E D Eᵀ du, D = diag(rotary inertia).
    pub rot: Matrix3<T>,
    /// `rot_w[j]` = ∫ E D Eᵀ w_j du.
    pub rot_w: [Vector3<T>; 3],
    /// `rot_ww[i][j]` = ∫ w_iᵀ E D Eᵀ w_j du.
    pub rot_ww: Matrix3<T>,
    /// `pdp[i]` = ∫ p (∂p/∂d_i)ᵀ du, full 3×3: entry (a, b) = ∫ p_a ∂p_b/∂d_i du
    /// (`cross[i]` is its antisymmetric part). Force only.
    pub pdp: [Matrix3<T>; 3],
    /// `d2first[i][j]` = ∫ ∂²p/∂d_i∂d_j du (symmetric in i, j). Force only.
    pub d2first: [[Vector3<T>; 3]; 3],
    /// `cross2[i][j]` = ∫ p × ∂²p/∂d_i∂d_j du (symmetric in i, j). Force only.
    pub cross2: [[Vector3<T>; 3]; 3],
    /// `pd2p[i][j]` = ∫ p (∂²p/∂d_i∂d_j)ᵀ du, full 3×3 (`cross2` is its antisymmetric
    /// part; symmetric in i, j). Stiffness of a linear field only.
    pub pd2p: [[Matrix3<T>; 3]; 3],
    /// `dpdp[i][j]` = ∫ ∂p/∂d_i (∂p/∂d_j)ᵀ du, full 3×3 (`gram` holds its traces).
    /// Force only.
    pub dpdp: [[Matrix3<T>; 3]; 3],
    /// `dpd2p[i][j][k]` = ∫ ∂p/∂d_i · ∂²p/∂d_j∂d_k du (symmetric in j, k). Force only.
    pub dpd2p: [[[T; 3]; 3]; 3],
}

impl ElementMoments<f64> {
    /// The moments by `points`-point Gauss–Legendre quadrature (the reference).
    pub fn by_quadrature(d: &Vector3<f64>, l: f64, rotary: &[f64; 3], points: usize) -> Self {
        let rule = gauss_legendre(points);
        let dmat = Matrix3::from_diagonal(&Vector3::from(*rotary));
        let mut m = ElementMoments::default();
        for (x, wgl) in rule.nodes().iter().zip(rule.weights()) {
            let u = 0.5 * l * (x + 1.0);
            let w = 0.5 * l * wgl;
            let jets = element_jets(d, u, true);
            let p = jets.p_value();
            let dp = [jets.dp(0), jets.dp(1), jets.dp(2)];
            let d2p: [[Vector3<f64>; 3]; 3] =
                core::array::from_fn(|i| core::array::from_fn(|j| jets.d2p(i, j)));
            let (e, _) = local_pose(d, u);
            let inertia = e * dmat * e.transpose();
            let wv = [jets.w_value(0), jets.w_value(1), jets.w_value(2)];
            m.first += p * w;
            m.second += p * p.transpose() * w;
            m.rot += inertia * w;
            for i in 0..3 {
                m.dfirst[i] += dp[i] * w;
                m.cross[i] += p.cross(&dp[i]) * w;
                m.rot_w[i] += inertia * wv[i] * w;
                m.pdp[i] += p * dp[i].transpose() * w;
                for j in 0..3 {
                    m.gram[(i, j)] += dp[i].dot(&dp[j]) * w;
                    m.rot_ww[(i, j)] += wv[i].dot(&(inertia * wv[j])) * w;
                    m.d2first[i][j] += d2p[i][j] * w;
                    m.cross2[i][j] += p.cross(&d2p[i][j]) * w;
                    m.pd2p[i][j] += p * d2p[i][j].transpose() * w;
                    m.dpdp[i][j] += dp[i] * dp[j].transpose() * w;
                    for k in 0..3 {
                        m.dpd2p[i][j][k] += dp[i].dot(&d2p[j][k]) * w;
                    }
                }
            }
        }
        m
    }
}

/// Derivatives at the end of element Q, head coordinates: `dp[i]` = F_Q ∂p(l)/∂d_i,
/// `dtheta[i]` = F_Q w_i(l), and the second derivatives the velocity recursions of
/// [`assemble_force`] need.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EndDerivatives<T: Arith = f64> {
    /// Derivative of the end position.
    pub dp: [Vector3<T>; 3],
    /// Angular derivative of the end frame.
    pub dtheta: [Vector3<T>; 3],
    /// `d2p[i][j]` = F_Q ∂²p(l)/∂d_i∂d_j.
    pub d2p: [[Vector3<T>; 3]; 3],
    /// `dw[i][j]` = F_Q ∂w_i(l)/∂d_j.
    pub dw: [[Vector3<T>; 3]; 3],
}

/// Integrals over the elements P..N−1 (per unit mass per length) with x = y − r_P, the
/// position relative to the body's start: a composite body with the velocity field of
/// the strand. (About r_P rather than the head origin, so that curls far from the root
/// keep their digits.)
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SuffixBody<T: Arith = f64> {
    /// Length ∫ ds.
    pub mass: T,
    /// ∫ x.
    pub first: Vector3<T>,
    /// ∫ x xᵀ.
    pub second: Matrix3<T>,
    /// ∫ ẏ.
    pub velocity: Vector3<T>,
    /// ∫ x ẏᵀ.
    pub moment_velocity: Matrix3<T>,
    /// Σ ∫ E D Eᵀ, the rotary inertia (head coordinates, not per unit mass).
    pub rot: Matrix3<T>,
}

impl<T: Arith> SuffixBody<T> {
    /// The same body about a reference point `delta` behind the current one
    /// (x' = x + delta).
    #[inline(always)]
    fn shifted(&self, delta: &Vector3<T>) -> SuffixBody<T> {
        let (d, first) = (v3(delta), v3(&self.first));
        // second + first δᵀ + δ firstᵀ + (δ δᵀ) mass, summed left to right
        let second = la::mat_add(m3(&self.second), &la::outer(first, d), false);
        let second = la::mat_add(&second, &la::outer(d, first), false);
        let second = la::mat_add(&second, &la::mat_scale(&la::outer(d, d), self.mass), false);
        let moment_velocity = la::outer(d, v3(&self.velocity));
        SuffixBody {
            mass: self.mass,
            first: vector(la::add(first, &la::scale(d, self.mass))),
            second: matrix(second),
            velocity: self.velocity,
            moment_velocity: matrix(la::mat_add(
                m3(&self.moment_velocity),
                &moment_velocity,
                false,
            )),
            rot: self.rot,
        }
    }

    /// Linear and angular "momentum" of the rigid velocity field v + ω × x over the body
    /// (per unit ρS): `∫ (v + ω × x)` and `∫ x × (v + ω × x)`.
    #[inline(always)]
    fn momentum(&self, v: &V<T>, w: &V<T>) -> (V<T>, V<T>) {
        let first = v3(&self.first);
        let lin = la::add(&la::scale(v, self.mass), &la::cross(w, first));
        let second = m3(&self.second);
        let spread = la::identity_times_minus(la::trace(second), second);
        let ang = la::add(&la::cross(first, v), &la::mat_vec(&spread, w));
        (lin, ang)
    }
}

/// `[a]ₓ`, the matrix of `x ↦ a × x`: nalgebra's `cross_matrix`, its entries in its
/// order, for any [`Arith`] (nalgebra asks a field of it).
#[inline(always)]
pub fn cross_matrix<T: Arith>(a: &Vector3<T>) -> Matrix3<T> {
    Matrix3::new(
        T::zero(),
        -a[2],
        a[1],
        a[2],
        T::zero(),
        -a[0],
        -a[1],
        a[0],
        T::zero(),
    )
}

/// `f a fᵀ`.
#[inline(always)]
fn rotated<T: Ring>(f: &M<T>, a: &M<T>) -> M<T> {
    la::mat_mul(&la::mat_mul(f, a), &la::transpose(f))
}

/// One element's contribution to [`SuffixBody`] (with or without the velocity parts).
#[inline(always)]
fn element_body<T: Arith>(
    pose: &Pose<T>,
    l: T,
    m: &ElementMoments<T>,
    motion: &FrameMotion<T>,
    qd: &[T],
    with_velocity: bool,
) -> SuffixBody<T> {
    let f = m3(&pose.frame);
    let a = la::mat_vec(f, v3(&m.first));
    let fs = rotated(f, m3(&m.second));
    let zero = T::zero();
    let (mut velocity, mut moment_velocity) = ([zero; 3], [[zero; 3]; 3]);
    if with_velocity {
        let mut pi = [zero; 3];
        let mut n_pi = [[zero; 3]; 3];
        for j in 0..3 {
            pi = la::add(&pi, &la::scale(v3(&m.dfirst[j]), qd[j]));
            n_pi = la::mat_add(&n_pi, &la::mat_scale(m3(&m.pdp[j]), qd[j]), false);
        }
        let (omega, vel) = (v3(&motion.omega), v3(&motion.velocity));
        velocity = la::add(
            &la::add(&la::scale(vel, l), &la::cross(omega, &a)),
            &la::mat_vec(f, &pi),
        );
        moment_velocity = la::mat_add(
            &la::mat_add(
                &la::outer(&a, vel),
                &la::mat_mul(&fs, &la::cross_matrix(omega)),
                true,
            ),
            &rotated(f, &n_pi),
            false,
        );
    }
    SuffixBody {
        mass: l,
        first: vector(a),
        second: matrix(fs),
        velocity: vector(velocity),
        moment_velocity: matrix(moment_velocity),
        rot: matrix(rotated(f, m3(&m.rot))),
    }
}

/// `bodies[P]` = elements P..N−1 about r_P, `bodies[N]` empty. The velocity parts are filled
/// when `with_velocity` (they need `motions` and q̇). Generic over [`Arith`]: one strand,
/// or W strands in lanes with the same bits per lane.
#[inline(always)]
pub fn suffix_bodies<T: Arith>(
    ends: &[Pose<T>],
    lengths: &[T],
    moments: &[ElementMoments<T>],
    motions: &[FrameMotion<T>],
    velocities: &[T],
    with_velocity: bool,
    bodies: &mut [SuffixBody<T>],
) {
    let n = lengths.len();
    bodies[n] = SuffixBody::default();
    for p in (0..n).rev() {
        let e = element_body(
            &ends[p],
            lengths[p],
            &moments[p],
            &motions[p],
            &velocities[3 * p..3 * p + 3],
            with_velocity,
        );
        let delta = la::sub(v3(&ends[p + 1].position), v3(&ends[p].position));
        let next = bodies[p + 1].shifted(&vector(delta));
        let sum = |a: &Matrix3<T>, b: &Matrix3<T>| matrix(la::mat_add(m3(a), m3(b), false));
        bodies[p] = SuffixBody {
            mass: next.mass + e.mass,
            first: vector(la::add(v3(&next.first), v3(&e.first))),
            second: sum(&next.second, &e.second),
            velocity: vector(la::add(v3(&next.velocity), v3(&e.velocity))),
            moment_velocity: sum(&next.moment_velocity, &e.moment_velocity),
            rot: sum(&next.rot, &e.rot),
        };
    }
}

/// The suffix bodies of [`suffix_bodies`] without the velocity parts, in a new vector:
/// the convenient call for a strand at rest (tests, statics).
#[cfg(feature = "std")]
pub fn bodies_at_rest(
    ends: &[Pose],
    lengths: &[f64],
    moments: &[ElementMoments],
) -> std::vec::Vec<SuffixBody> {
    let n = lengths.len();
    let mut bodies = std::vec![SuffixBody::default(); n + 1];
    suffix_bodies(
        ends,
        lengths,
        moments,
        &std::vec![FrameMotion::default(); n + 1],
        &std::vec![0.0; 3 * n],
        false,
        &mut bodies,
    );
    bodies
}

/// M (3N × 3N, column-major into `mass`) and the generalized force of a uniform force
/// per length `c0` (`force`), from element ends, end derivatives, element moments and
/// the suffix bodies ([`suffix_bodies`], positions part). `rho_s` is the mass per length.
#[allow(clippy::too_many_arguments)]
pub fn assemble_mass_and_gravity<T: Arith>(
    bodies: &[SuffixBody<T>],
    rho_s: T,
    lengths: &[T],
    ends: &[Pose<T>],
    end_derivs: &[EndDerivatives<T>],
    moments: &[ElementMoments<T>],
    c0: &Vector3<T>,
    mass: &mut [T],
    force: &mut [T],
    first_moment: &mut Vector3<T>,
) {
    assemble_mass_gram_and_gravity(
        bodies,
        rho_s,
        lengths,
        ends,
        end_derivs,
        moments,
        c0,
        mass,
        None,
        force,
        first_moment,
    );
}

/// [`assemble_mass_and_gravity`], and with it, when `gram` is given, the centreline's
/// Gram matrix `∫ J_kᵀ J_l ds` (column-major, 3N × 3N): M without ρS and the rotary
/// inertia, which is all the damping of an isotropic drag needs (`−ν ∫ JᵀJ ds`).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn assemble_mass_gram_and_gravity<T: Arith>(
    bodies: &[SuffixBody<T>],
    rho_s: T,
    lengths: &[T],
    ends: &[Pose<T>],
    end_derivs: &[EndDerivatives<T>],
    moments: &[ElementMoments<T>],
    c0: &Vector3<T>,
    mass: &mut [T],
    mut gram: Option<&mut [T]>,
    force: &mut [T],
    first_moment: &mut Vector3<T>,
) {
    let n = lengths.len();
    let dofs = 3 * n;
    let first = la::add(
        v3(&bodies[0].first),
        &la::scale(v3(&ends[0].position), bodies[0].mass),
    );
    *first_moment = vector(la::scale(&first, rho_s));
    let c0 = v3(c0);
    mass.iter_mut().for_each(|x| *x = T::zero());
    // entry (k, l) and its mirror of M (and of the Gram matrix, centreline part only)
    let mut put = |k: usize, l: usize, val: T, centreline: T| {
        mass[l * dofs + k] = val;
        mass[k * dofs + l] = val;
        if let Some(g) = gram.as_deref_mut() {
            g[l * dofs + k] = centreline;
            g[k * dofs + l] = centreline;
        }
    };
    for q in 0..n {
        let e = &end_derivs[q];
        let fq = m3(&ends[q].frame);
        let mq = &moments[q];
        let beyond = &bodies[q + 1];
        let rot_beyond = m3(&beyond.rot);
        for i in 0..3 {
            let k = 3 * q + i;
            // J_k = v + w × (y − r_{Q+1}) beyond Q
            let w = v3(&e.dtheta[i]);
            let v = v3(&e.dp[i]);
            // force: rigid part beyond Q plus own part
            let (lin, _) = beyond.momentum(v, w);
            force[k] = la::dot(c0, &la::add(&lin, &la::mat_vec(fq, v3(&mq.dfirst[i]))));
            // same element (both own in Q): rigid beyond + gram + rotary
            for j in i..3 {
                let wl = v3(&e.dtheta[j]);
                let vl = v3(&e.dp[j]);
                let (lin, ang) = beyond.momentum(vl, wl);
                let centreline = la::dot(v, &lin) + la::dot(w, &ang) + m3(&mq.gram)[j][i];
                let val = rho_s * centreline
                    + la::dot(w, &la::mat_vec(rot_beyond, wl))
                    + m3(&mq.rot_ww)[j][i];
                put(k, 3 * q + j, val, centreline);
            }
        }
    }
    // pairs across elements Q < Q': rigid beyond Q' plus the mixed own part in Q'; column
    // by column, so that the column's own products are formed once for all rows upstream
    for q2 in 1..n {
        let e2 = &end_derivs[q2];
        let f2 = m3(&ends[q2].frame);
        let m2 = &moments[q2];
        let beyond = &bodies[q2 + 1];
        // per column j: F ∂_j∫p, F ∫p × ∂_j p, ∫I beyond · θ_j and F ∫I w_j
        let columns: [[V<T>; 4]; 3] = core::array::from_fn(|j| {
            [
                la::mat_vec(f2, v3(&m2.dfirst[j])),
                la::mat_vec(f2, v3(&m2.cross[j])),
                la::mat_vec(m3(&beyond.rot), v3(&e2.dtheta[j])),
                la::mat_vec(f2, v3(&m2.rot_w[j])),
            ]
        });
        for q in 0..q2 {
            let e = &end_derivs[q];
            let r_end = v3(&ends[q + 1].position);
            for i in 0..3 {
                let k = 3 * q + i;
                let w = v3(&e.dtheta[i]);
                let v = v3(&e.dp[i]);
                // J_k at r_{Q'} and at r_{Q'+1}
                let base = la::add(v, &la::cross(w, &la::sub(v3(&ends[q2].position), r_end)));
                let at_end = la::add(
                    v,
                    &la::cross(w, &la::sub(v3(&ends[q2 + 1].position), r_end)),
                );
                let (lin, ang) = beyond.momentum(&at_end, w);
                for (j, [dfirst, cross, rot_beyond, rot_own]) in columns.iter().enumerate() {
                    let rigid = la::dot(v3(&e2.dp[j]), &lin) + la::dot(v3(&e2.dtheta[j]), &ang);
                    let mixed = la::dot(&base, dfirst) + la::dot(w, cross);
                    let val =
                        rho_s * (rigid + mixed) + la::dot(w, rot_beyond) + la::dot(w, rot_own);
                    put(k, 3 * q2 + j, val, rigid + mixed);
                }
            }
        }
    }
}

/// End derivatives of element `q` (frame `frame` at its start) from its jets at u = l.
pub fn end_derivatives<T: Float>(frame: &Matrix3<T>, d: &Vector3<T>, l: T) -> EndDerivatives<T> {
    end_derivatives_from(frame, &crate::element::ElementPoint::by_jets(d, l))
}

/// End derivatives from the element's local derivatives at u = l.
pub fn end_derivatives_from<T: Float>(
    frame: &Matrix3<T>,
    e: &crate::element::ElementPoint<T>,
) -> EndDerivatives<T> {
    EndDerivatives {
        dp: e.dp.map(|v| frame * v),
        dtheta: e.w.map(|v| frame * v),
        d2p: e.d2p.map(|row| row.map(|v| frame * v)),
        dw: e.dw.map(|row| row.map(|v| frame * v)),
    }
}

/// Force and torque (about the element's start) that the force per length exerts on one
/// element.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Wrench<T: Arith = f64> {
    /// Resultant ∫ f du.
    pub force: Vector3<T>,
    /// Moment about the element's start r_P: ∫ (y − r_P) × f du.
    pub torque: Vector3<T>,
}

/// `∫ x × z` from `k` = ∫ x zᵀ.
#[inline(always)]
pub fn axial<T: Arith>(k: &Matrix3<T>) -> Vector3<T> {
    let k = m3(k);
    vector([k[2][1] - k[1][2], k[0][2] - k[2][0], k[1][0] - k[0][1]])
}

/// `∫ x × (A z)` from `n` = ∫ x zᵀ.
#[inline(always)]
pub fn cross_moment<T: Arith>(a: &Matrix3<T>, n: &Matrix3<T>) -> Vector3<T> {
    axial(&matrix(la::mat_mul(m3(n), &la::transpose(m3(a)))))
}

/// Motion of an element's start frame at velocities q̇ and q̈ = 0 (head coordinates).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FrameMotion<T: Arith = f64> {
    /// Angular velocity Ω of the frame.
    pub omega: Vector3<T>,
    /// Angular acceleration Ω̇ (q̈ = 0).
    pub alpha: Vector3<T>,
    /// Velocity ṙ of the start point.
    pub velocity: Vector3<T>,
    /// Acceleration r̈ of the start point (q̈ = 0).
    pub acceleration: Vector3<T>,
}

/// The velocity parts of [`frame_motions`] alone (Ω and ṙ, the same values; `alpha` and
/// `acceleration` zero), from `dp` and `dtheta` of the end derivatives: what a kinetic
/// energy needs, and the first pass of [`frame_motions`].
#[inline(always)]
pub fn frame_velocities<T: Arith>(
    ends: &[Pose<T>],
    end_derivs: &[EndDerivatives<T>],
    velocities: &[T],
    motions: &mut [FrameMotion<T>],
) {
    let n = end_derivs.len();
    motions[0] = FrameMotion::default();
    for p in 0..n {
        let m = motions[p];
        let e = &end_derivs[p];
        let span = la::sub(v3(&ends[p + 1].position), v3(&ends[p].position));
        let (w_hat, pi_l) = first_order(e, &velocities[3 * p..3 * p + 3]);
        let (omega, velocity) = (v3(&m.omega), v3(&m.velocity));
        motions[p + 1] = FrameMotion {
            omega: vector(la::add(omega, &w_hat)),
            alpha: Vector3::zeros(),
            velocity: vector(la::add(&la::add(velocity, &la::cross(omega, &span)), &pi_l)),
            acceleration: Vector3::zeros(),
        };
    }
}

/// `(Σ dθ_i q̇_i, Σ dp_i q̇_i)` of one element's end derivatives.
#[inline(always)]
fn first_order<T: Arith>(e: &EndDerivatives<T>, qd: &[T]) -> (V<T>, V<T>) {
    let mut w_hat = [T::zero(); 3];
    let mut pi_l = [T::zero(); 3];
    for i in 0..3 {
        w_hat = la::add(&w_hat, &la::scale(v3(&e.dtheta[i]), qd[i]));
        pi_l = la::add(&pi_l, &la::scale(v3(&e.dp[i]), qd[i]));
    }
    (w_hat, pi_l)
}

/// The recursion of docs/moment-assembly.md ("Velocity and acceleration of the base
/// frame"): `motions[P]` for P = 0..=N (the root is fixed in head coordinates).
#[inline(always)]
pub fn frame_motions<T: Arith>(
    ends: &[Pose<T>],
    end_derivs: &[EndDerivatives<T>],
    velocities: &[T],
    motions: &mut [FrameMotion<T>],
) {
    frame_velocities(ends, end_derivs, velocities, motions);
    for p in 0..end_derivs.len() {
        let m = motions[p];
        let e = &end_derivs[p];
        let span = la::sub(v3(&ends[p + 1].position), v3(&ends[p].position));
        let qd = &velocities[3 * p..3 * p + 3];
        let (w_hat, pi_l) = first_order(e, qd);
        let mut w_dot = [T::zero(); 3];
        let mut pidot_l = [T::zero(); 3];
        for i in 0..3 {
            for j in 0..3 {
                let qq = qd[i] * qd[j];
                w_dot = la::add(&w_dot, &la::scale(v3(&e.dw[i][j]), qq));
                pidot_l = la::add(&pidot_l, &la::scale(v3(&e.d2p[i][j]), qq));
            }
        }
        let (omega, alpha) = (v3(&m.omega), v3(&m.alpha));
        let next = &mut motions[p + 1];
        next.alpha = vector(la::add(&la::add(alpha, &la::cross(omega, &w_hat)), &w_dot));
        let two = T::one() + T::one();
        let acceleration = la::add(v3(&m.acceleration), &la::cross(alpha, &span));
        let acceleration = la::add(&acceleration, &la::cross(omega, &la::cross(omega, &span)));
        let acceleration = la::add(&acceleration, &la::scale(&la::cross(omega, &pi_l), two));
        next.acceleration = vector(la::add(&acceleration, &pidot_l));
    }
}

/// The generalized force `force` = ∫ Jᵀ(c0 + C1 y + C2 ẏ) ds − b(q, q̇) of the
/// centreline (rotary inertia not included) in O(N), from element ends, end derivatives
/// and element moments (docs/moment-assembly.md, "Generalized force").
///
/// `motions` ([`frame_motions`]) carry the angular velocity Ω, angular acceleration Ω̇
/// (at q̈ = 0), velocity ṙ and acceleration r̈ of each element's start frame; on element P the force
/// per length, inertial term −ρS ÿ included, is affine in p, π = Σ ∂_i p q̇_i and
/// π̇ = Σ ∂²_ij p q̇_i q̇_j, so its own columns and its wrench are moment contractions.
/// The elements are taken from the tip: each adds the wrenches summed beyond it to its
/// columns.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn assemble_force<T: Arith>(
    rho_s: T,
    lengths: &[T],
    ends: &[Pose<T>],
    end_derivs: &[EndDerivatives<T>],
    moments: &[ElementMoments<T>],
    motions: &[FrameMotion<T>],
    velocities: &[T],
    field: &BodyField<T>,
    force: &mut [T],
) {
    let mut beyond = Wrench::default();
    for p in (0..lengths.len()).rev() {
        let c = ForceContractions::of(&moments[p], velocities, p);
        let setup = ForceSetup::of(field, rho_s, &ends[p], &motions[p]);
        element_force(
            setup,
            &c,
            p,
            lengths,
            ends,
            end_derivs,
            moments,
            &mut beyond,
            force,
        );
    }
}

/// [`assemble_force`] twice at once, for the two parts the step keeps apart:
/// `inertial` = the force of (ρS, no field), which is −b(q, q̇), and `field_force` = that
/// of (ρS = 0, `field`), ∫ Jᵀ(c0 + C1 y + C2 ẏ) ds; the same bits as the two calls, for
/// one set of the moment contractions with q̇.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn assemble_inertial_and_field_force<T: Arith>(
    rho_s: T,
    lengths: &[T],
    ends: &[Pose<T>],
    end_derivs: &[EndDerivatives<T>],
    moments: &[ElementMoments<T>],
    motions: &[FrameMotion<T>],
    velocities: &[T],
    field: &BodyField<T>,
    inertial: &mut [T],
    field_force: &mut [T],
) {
    let no_field = BodyField::zero();
    let (mut beyond_i, mut beyond_f) = (Wrench::default(), Wrench::default());
    for p in (0..lengths.len()).rev() {
        let c = ForceContractions::of(&moments[p], velocities, p);
        let setup = ForceSetup::of(&no_field, rho_s, &ends[p], &motions[p]);
        element_force(
            setup,
            &c,
            p,
            lengths,
            ends,
            end_derivs,
            moments,
            &mut beyond_i,
            inertial,
        );
        let setup = ForceSetup::of(field, T::zero(), &ends[p], &motions[p]);
        element_force(
            setup,
            &c,
            p,
            lengths,
            ends,
            end_derivs,
            moments,
            &mut beyond_f,
            field_force,
        );
    }
}

/// The element moments of [`assemble_force`] contracted with the element's q̇ (they do
/// not depend on the field or on ρS).
struct ForceContractions<T: Arith> {
    /// ∫ π.
    pi1: V<T>,
    /// ∫ p πᵀ.
    n_pi: M<T>,
    /// ∫ π̇.
    pi2: V<T>,
    /// ∫ p × π̇.
    c_pi2: V<T>,
    /// ∫ ∂_i p πᵀ.
    g_pi: [M<T>; 3],
    /// ∫ ∂_i p · π̇.
    t: [T; 3],
}

impl<T: Arith> ForceContractions<T> {
    #[inline(always)]
    fn of(m: &ElementMoments<T>, velocities: &[T], p: usize) -> Self {
        let qd = [
            velocities[3 * p],
            velocities[3 * p + 1],
            velocities[3 * p + 2],
        ];
        let zero = T::zero();
        let mut pi1 = [zero; 3];
        let mut n_pi = [[zero; 3]; 3];
        let mut pi2 = [zero; 3];
        let mut c_pi2 = [zero; 3];
        for j in 0..3 {
            pi1 = la::add(&pi1, &la::scale(v3(&m.dfirst[j]), qd[j]));
            n_pi = la::mat_add(&n_pi, &la::mat_scale(m3(&m.pdp[j]), qd[j]), false);
            for k in 0..3 {
                let qq = qd[j] * qd[k];
                pi2 = la::add(&pi2, &la::scale(v3(&m.d2first[j][k]), qq));
                c_pi2 = la::add(&c_pi2, &la::scale(v3(&m.cross2[j][k]), qq));
            }
        }
        let mut g_pi = [[[zero; 3]; 3]; 3];
        let mut t = [zero; 3];
        for i in 0..3 {
            for j in 0..3 {
                g_pi[i] = la::mat_add(&g_pi[i], &la::mat_scale(m3(&m.dpdp[i][j]), qd[j]), false);
                for k in 0..3 {
                    t[i] += m.dpd2p[i][j][k] * qd[j] * qd[k];
                }
            }
        }
        ForceContractions {
            pi1,
            n_pi,
            pi2,
            c_pi2,
            g_pi,
            t,
        }
    }
}

/// The force per length on one element in its frame, `a0 + A p + B π − ρS π̇`.
#[derive(Clone, Copy)]
struct ForceSetup<T: Arith> {
    rho_s: T,
    a0: V<T>,
    a: M<T>,
    b: M<T>,
}

impl<T: Arith> ForceSetup<T> {
    #[inline(always)]
    fn of(field: &BodyField<T>, rho_s: T, start: &Pose<T>, motion: &FrameMotion<T>) -> Self {
        let (c0, c1, c2) = (v3(&field.uniform), m3(&field.linear), m3(&field.velocity));
        let f = m3(&start.frame);
        let (omega, alpha) = (v3(&motion.omega), v3(&motion.alpha));
        let (vel, acc) = (v3(&motion.velocity), v3(&motion.acceleration));
        // f(u) = g0 + G1 F p + H2 F π − ρS F π̇, in the element frame: a0 + A p + B π − ρS π̇
        let wx = la::cross_matrix(omega);
        let g0 = la::add(c0, &la::mat_vec(c1, v3(&start.position)));
        let g0 = la::sub(&la::add(&g0, &la::mat_vec(c2, vel)), &la::scale(acc, rho_s));
        let spin = la::mat_add(&la::cross_matrix(alpha), &la::mat_mul(&wx, &wx), false);
        let g1 = la::mat_add(c1, &la::mat_mul(c2, &wx), false);
        let g1 = la::mat_add(&g1, &la::mat_scale(&spin, rho_s), true);
        let two = T::one() + T::one();
        let h2 = la::mat_add(c2, &la::mat_scale(&wx, two * rho_s), true);
        let ft = la::transpose(f);
        ForceSetup {
            rho_s,
            a0: la::mat_vec(&ft, &g0),
            a: la::mat_mul(&la::mat_mul(&ft, &g1), f),
            b: la::mat_mul(&la::mat_mul(&ft, &h2), f),
        }
    }
}

/// Element p's own columns of the force (plus the wrench `beyond` of the elements past
/// it, about r_{p+1}), then its own wrench added to `beyond`, moved to r_p.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn element_force<T: Arith>(
    s: ForceSetup<T>,
    c: &ForceContractions<T>,
    p: usize,
    lengths: &[T],
    ends: &[Pose<T>],
    end_derivs: &[EndDerivatives<T>],
    moments: &[ElementMoments<T>],
    beyond: &mut Wrench<T>,
    force: &mut [T],
) {
    let m = &moments[p];
    let f = m3(&ends[p].frame);
    // own columns: ∫ ∂_i p · Fᵀf
    for i in 0..3 {
        let own = la::dot(v3(&m.dfirst[i]), &s.a0) + la::trace(&la::mat_mul(&s.a, m3(&m.pdp[i])));
        force[3 * p + i] = own + la::mat_dot(&s.b, &c.g_pi[i]) - s.rho_s * c.t[i];
    }
    // upstream columns: dp_k · ΣR + ω_k · Στ over the elements beyond, torques about
    // r_{p+1} (moved along the chain element by element, never through the origin)
    let e = &end_derivs[p];
    let (beyond_force, beyond_torque) = (*v3(&beyond.force), *v3(&beyond.torque));
    for i in 0..3 {
        force[3 * p + i] +=
            la::dot(v3(&e.dp[i]), &beyond_force) + la::dot(v3(&e.dtheta[i]), &beyond_torque);
    }
    // wrench of element p about the origin of its frame, then about its start r_p
    let first = v3(&m.first);
    let res = la::add(&la::scale(&s.a0, lengths[p]), &la::mat_vec(&s.a, first));
    let res = la::sub(
        &la::add(&res, &la::mat_vec(&s.b, &c.pi1)),
        &la::scale(&c.pi2, s.rho_s),
    );
    let mom = la::add(
        &la::cross(first, &s.a0),
        v3(&cross_moment(&matrix(s.a), &m.second)),
    );
    let mom = la::add(&mom, v3(&cross_moment(&matrix(s.b), &matrix(c.n_pi))));
    let mom = la::sub(&mom, &la::scale(&c.c_pi2, s.rho_s));
    let delta = la::sub(v3(&ends[p + 1].position), v3(&ends[p].position));
    let turn = la::add(&la::cross(&delta, &beyond_force), &la::mat_vec(f, &mom));
    beyond.torque = vector(la::add(&beyond_torque, &turn));
    beyond.force = vector(la::add(&beyond_force, &la::mat_vec(f, &res)));
}

#[cfg(test)]
mod tests {
    use super::jacobians::{
        add_field_hessian, add_velocity_jacobian, add_weighted_gram, VelocityRow,
    };
    use super::*;
    use crate::lane::soa::Soa;
    use crate::lane::Lanes;
    use std::vec::Vec;

    /// A strand's inputs of N = 5: arbitrary values over many magnitudes with signed
    /// zeros (the assembly is arithmetic without branches on values, so every input is
    /// one it takes), and a body field with all three parts.
    struct Input<T: Arith> {
        ends: [Pose<T>; 6],
        derivs: [EndDerivatives<T>; 5],
        moments: [ElementMoments<T>; 5],
        velocities: [T; 15],
        lengths: [T; 5],
        field: BodyField<T>,
    }

    /// Pseudo-random values over many magnitudes, with signed zeros.
    struct Values(u64);

    impl Values {
        fn x(&mut self) -> f64 {
            let s = &mut self.0;
            *s ^= *s << 13;
            *s ^= *s >> 7;
            *s ^= *s << 17;
            let u = (*s >> 11) as f64 / (1u64 << 52) as f64 - 1.0;
            if *s % 19 == 0 {
                -0.0
            } else {
                u * 10f64.powi((*s % 7) as i32 - 3)
            }
        }
        fn v(&mut self) -> Vector3<f64> {
            Vector3::new(self.x(), self.x(), self.x())
        }
        fn m(&mut self) -> Matrix3<f64> {
            Matrix3::from_columns(&[self.v(), self.v(), self.v()])
        }
        fn vs(&mut self) -> [Vector3<f64>; 3] {
            core::array::from_fn(|_| self.v())
        }
        fn ms(&mut self) -> [Matrix3<f64>; 3] {
            core::array::from_fn(|_| self.m())
        }
    }

    fn input(seed: u64) -> Input<f64> {
        let mut r = Values(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1);
        let ends = core::array::from_fn(|_| Pose {
            position: r.v(),
            frame: r.m(),
        });
        let derivs = core::array::from_fn(|_| EndDerivatives {
            dp: r.vs(),
            dtheta: r.vs(),
            d2p: core::array::from_fn(|_| r.vs()),
            dw: core::array::from_fn(|_| r.vs()),
        });
        let moments = core::array::from_fn(|_| ElementMoments {
            first: r.v(),
            second: r.m(),
            dfirst: r.vs(),
            cross: r.vs(),
            gram: r.m(),
            rot: r.m(),
            rot_w: r.vs(),
            rot_ww: r.m(),
            pdp: r.ms(),
            d2first: core::array::from_fn(|_| r.vs()),
            cross2: core::array::from_fn(|_| r.vs()),
            pd2p: core::array::from_fn(|_| r.ms()),
            dpdp: core::array::from_fn(|_| r.ms()),
            dpd2p: core::array::from_fn(|_| core::array::from_fn(|_| r.v().into())),
        });
        Input {
            ends,
            derivs,
            moments,
            velocities: core::array::from_fn(|_| r.x()),
            lengths: core::array::from_fn(|_| r.x().abs()),
            field: BodyField {
                uniform: r.v(),
                linear: r.m(),
                velocity: r.m(),
            },
        }
    }

    /// Every output of the step's assembly (frame motions, suffix bodies, M, the Gram
    /// matrix, gravity, the inertial and field forces, the field's Hessian, the weighted
    /// Gram matrix of the field's velocity part and ∂b/∂q̇) as a flat list of bits.
    fn assembled<T: Arith>(x: &Input<T>, with_velocity: bool, out: impl Fn(&T) -> u64) -> Vec<u64> {
        let mut motions = [FrameMotion::default(); 6];
        frame_motions(&x.ends, &x.derivs, &x.velocities, &mut motions);
        let mut bodies = [SuffixBody::default(); 6];
        suffix_bodies(
            &x.ends,
            &x.lengths,
            &x.moments,
            &motions,
            &x.velocities,
            with_velocity,
            &mut bodies,
        );
        let mut vectors = [[T::zero(); 15]; 3];
        let [force, inertial, field_force] = &mut vectors;
        let mut matrices = [[T::zero(); 225]; 5];
        let [mass, gram, hessian, weighted, velocity] = &mut matrices;
        let mut first = Vector3::zeros();
        let rho_s = x.lengths[3];
        assemble_mass_gram_and_gravity(
            &bodies,
            rho_s,
            &x.lengths,
            &x.ends,
            &x.derivs,
            &x.moments,
            &x.field.uniform,
            mass,
            Some(gram),
            force,
            &mut first,
        );
        let (ends, derivs, moments) = (&x.ends, &x.derivs, &x.moments);
        assemble_inertial_and_field_force(
            rho_s,
            &x.lengths,
            ends,
            derivs,
            moments,
            &motions,
            &x.velocities,
            &x.field,
            inertial,
            field_force,
        );
        let (c0, c1, c2) = (&x.field.uniform, &x.field.linear, &x.field.velocity);
        add_field_hessian(c0, c1, ends, derivs, moments, &bodies, hessian);
        add_weighted_gram(c2, rho_s, ends, derivs, moments, &bodies, weighted);
        let mut rows = [VelocityRow::default(); 15];
        let v = &x.velocities;
        add_velocity_jacobian(
            rho_s, ends, derivs, moments, &motions, &bodies, v, &mut rows, velocity,
        );
        let mut bits = Vec::new();
        for m in &motions {
            for v in [&m.omega, &m.alpha, &m.velocity, &m.acceleration] {
                bits.extend(v.iter().map(&out));
            }
        }
        for b in &bodies {
            bits.push(out(&b.mass));
            for m in [&b.second, &b.moment_velocity, &b.rot] {
                bits.extend(m.iter().map(&out));
            }
            for v in [&b.first, &b.velocity] {
                bits.extend(v.iter().map(&out));
            }
        }
        bits.extend(vectors.iter().flatten().map(&out));
        bits.extend(first.iter().map(&out));
        bits.extend(matrices.iter().flatten().map(&out));
        bits
    }

    /// The assembly written once over `Arith` gives, in each of four lanes, the bits it
    /// gives for that lane's strand alone.
    #[test]
    fn the_assembly_on_lanes_gives_each_strands_bits() {
        for round in 0..8 {
            let inputs: [Input<f64>; 4] = core::array::from_fn(|k| input(4 * round + k as u64 + 1));
            let r = inputs.each_ref();
            let lanes = Input::<Lanes<f64, 4>> {
                ends: Soa::load(r.map(|x| &x.ends)),
                derivs: Soa::load(r.map(|x| &x.derivs)),
                moments: Soa::load(r.map(|x| &x.moments)),
                velocities: Soa::load(r.map(|x| &x.velocities)),
                lengths: Soa::load(r.map(|x| &x.lengths)),
                field: Soa::load(r.map(|x| &x.field)),
            };
            for with_velocity in [false, true] {
                for (k, x) in inputs.iter().enumerate() {
                    let one = assembled(x, with_velocity, |v| v.to_bits());
                    let lane = assembled(&lanes, with_velocity, |v| v.0[k].to_bits());
                    assert_eq!(one, lane, "lane {k}, with_velocity {with_velocity}");
                }
            }
        }
    }
}
