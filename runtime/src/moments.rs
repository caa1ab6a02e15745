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

use crate::element::{element_jets, local_pose};
use crate::quadrature::gauss_legendre;
use crate::reconstruction::Pose;
use nalgebra::{Matrix3, Vector3};

/// Integrals over one element, u ∈ [0, l], in the element's start frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ElementMoments {
    /// ∫ p du.
    pub first: Vector3<f64>,
    /// ∫ p pᵀ du.
    pub second: Matrix3<f64>,
    /// `dfirst[i]` = ∫ ∂p/∂d_i du.
    pub dfirst: [Vector3<f64>; 3],
    /// `cross[i]` = ∫ p × ∂p/∂d_i du.
    pub cross: [Vector3<f64>; 3],
    /// `gram[i][j]` = ∫ ∂p/∂d_i · ∂p/∂d_j du.
    pub gram: Matrix3<f64>,
    /// ∫ E D Eᵀ du, D = diag(rotary inertia).
    pub rot: Matrix3<f64>,
    /// `rot_w[j]` = ∫ E D Eᵀ w_j du.
    pub rot_w: [Vector3<f64>; 3],
    /// `rot_ww[i][j]` = ∫ w_iᵀ E D Eᵀ w_j du.
    pub rot_ww: Matrix3<f64>,
}

impl ElementMoments {
    /// The moments by `points`-point Gauss–Legendre quadrature (the reference).
    pub fn by_quadrature(d: &Vector3<f64>, l: f64, rotary: &[f64; 3], points: usize) -> Self {
        let rule = gauss_legendre(points);
        let dmat = Matrix3::from_diagonal(&Vector3::from(*rotary));
        let mut m = ElementMoments::default();
        for (x, wgl) in rule.nodes.iter().zip(&rule.weights) {
            let u = 0.5 * l * (x + 1.0);
            let w = 0.5 * l * wgl;
            let jets = element_jets(d, u, true);
            let p = jets.p_value();
            let dp = [jets.dp(0), jets.dp(1), jets.dp(2)];
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
                for j in 0..3 {
                    m.gram[(i, j)] += dp[i].dot(&dp[j]) * w;
                    m.rot_ww[(i, j)] += wv[i].dot(&(inertia * wv[j])) * w;
                }
            }
        }
        m
    }
}

/// Derivatives at the end of element Q, head coordinates: `dp[i]` = F_Q ∂p(l)/∂d_i,
/// `dtheta[i]` = F_Q w_i(l).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EndDerivatives {
    /// Derivative of the end position.
    pub dp: [Vector3<f64>; 3],
    /// Angular derivative of the end frame.
    pub dtheta: [Vector3<f64>; 3],
}

/// Mass, first moment and second moment (∫ y yᵀ) of a set of elements about the origin,
/// plus the summed rotary inertia: a composite rigid body.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Body {
    mass: f64,
    first: Vector3<f64>,
    second: Matrix3<f64>,
    rot: Matrix3<f64>,
}

impl Body {
    /// Linear and angular "momentum" of the rigid velocity field v + ω × y over the body
    /// (per unit ρS for the first two): `∫ (v + ω × y) dm` and `∫ y × (v + ω × y) dm`.
    fn momentum(&self, v: &Vector3<f64>, w: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
        let lin = v * self.mass + w.cross(&self.first);
        let ang =
            self.first.cross(v) + (Matrix3::identity() * self.second.trace() - self.second) * w;
        (lin, ang)
    }
}

/// M (3N × 3N, column-major into `mass`) and the generalized force of a uniform force
/// per length `c0` (`force`), from element ends, end derivatives and element moments.
/// `rho_s` is the mass per length; `bodies` is scratch of length N + 1.
#[allow(clippy::too_many_arguments)]
pub fn assemble_mass_and_gravity(
    bodies: &mut [Body],
    rho_s: f64,
    lengths: &[f64],
    ends: &[Pose],
    end_derivs: &[EndDerivatives],
    moments: &[ElementMoments],
    c0: &Vector3<f64>,
    mass: &mut [f64],
    force: &mut [f64],
    first_moment: &mut Vector3<f64>,
) {
    let n = lengths.len();
    let dofs = 3 * n;
    // suffix bodies B(P) = elements P..N-1, B(N) empty
    bodies[n] = Body::default();
    for p in (0..n).rev() {
        let f = ends[p].frame;
        let r = ends[p].position;
        let m = &moments[p];
        let a = f * m.first;
        let next = bodies[p + 1];
        bodies[p] = Body {
            mass: next.mass + lengths[p],
            first: next.first + r * lengths[p] + a,
            second: next.second
                + r * r.transpose() * lengths[p]
                + r * a.transpose()
                + a * r.transpose()
                + f * m.second * f.transpose(),
            rot: next.rot + f * m.rot * f.transpose(),
        };
    }
    *first_moment = bodies[0].first * rho_s;
    mass.iter_mut().for_each(|x| *x = 0.0);
    for q in 0..n {
        let e = &end_derivs[q];
        let r_end = ends[q + 1].position;
        let fq = ends[q].frame;
        let mq = &moments[q];
        for i in 0..3 {
            let k = 3 * q + i;
            let w = e.dtheta[i];
            let v = e.dp[i] - w.cross(&r_end);
            // force: rigid part beyond Q plus own part
            let (lin, _) = bodies[q + 1].momentum(&v, &w);
            force[k] = c0.dot(&(lin + fq * mq.dfirst[i]));
            // same element (both own in Q): rigid beyond + gram + rotary
            for j in i..3 {
                let l = 3 * q + j;
                let wl = e.dtheta[j];
                let vl = e.dp[j] - wl.cross(&r_end);
                let (lin, ang) = bodies[q + 1].momentum(&vl, &wl);
                let val = rho_s * (v.dot(&lin) + w.dot(&ang) + mq.gram[(i, j)])
                    + w.dot(&(bodies[q + 1].rot * wl))
                    + mq.rot_ww[(i, j)];
                mass[l * dofs + k] = val;
                mass[k * dofs + l] = val;
            }
            // later elements Q' > Q: rigid beyond Q' plus the mixed own part in Q'
            for q2 in q + 1..n {
                let e2 = &end_derivs[q2];
                let r2_end = ends[q2 + 1].position;
                let f2 = ends[q2].frame;
                let r2 = ends[q2].position;
                let m2 = &moments[q2];
                let base = v + w.cross(&r2);
                let (lin, ang) = bodies[q2 + 1].momentum(&v, &w);
                for j in 0..3 {
                    let l = 3 * q2 + j;
                    let wl = e2.dtheta[j];
                    let vl = e2.dp[j] - wl.cross(&r2_end);
                    let rigid = vl.dot(&lin) + wl.dot(&ang);
                    let mixed = base.dot(&(f2 * m2.dfirst[j])) + w.dot(&(f2 * m2.cross[j]));
                    let val = rho_s * (rigid + mixed)
                        + w.dot(&(bodies[q2 + 1].rot * wl))
                        + w.dot(&(f2 * m2.rot_w[j]));
                    mass[l * dofs + k] = val;
                    mass[k * dofs + l] = val;
                }
            }
        }
    }
}

/// End derivatives of element `q` (frame `frame` at its start) from its jets at u = l.
pub fn end_derivatives(frame: &Matrix3<f64>, d: &Vector3<f64>, l: f64) -> EndDerivatives {
    let jets = element_jets(d, l, true);
    EndDerivatives {
        dp: [frame * jets.dp(0), frame * jets.dp(1), frame * jets.dp(2)],
        dtheta: [
            frame * jets.w_value(0),
            frame * jets.w_value(1),
            frame * jets.w_value(2),
        ],
    }
}
