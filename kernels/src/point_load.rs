//! Point loads: a force f at arc length s of a strand, acting on q through J(s)ᵀ, in
//! the step's terms and its energy balance.
//!
//! A dead load is constant in the world: in the head frame (where the step works) it
//! is f_head = Rᵀ f, which turns with the head; its potential is V = −f_head · y(s)
//! (design page "Energies and the equation of motion"), whose rate at fixed q through
//! the head's turning is (ω × f_head) · y(s) (Ṙ = R[ω]×). A follower load
//! ([`PointLoad::follows`]) has its components along the material frame at s: f_head =
//! F(s, q) f (section 3.1 of the Super-Helix paper for F; the terminal follower load of
//! figure 3 of Sobottka & Weber 2006). It has no potential: its power f_head · J(s) q̇
//! joins the work of the energy balance. The step's matrix takes, for both, the
//! stiffness a dead load of the same force has, f_head · ∂²y(s)/∂q∂q (symmetric); the
//! part from the turning of F is left explicit. The charges' forces of electrostatics
//! reach a strand as dead loads, constant over a step.

use crate::float::Float;
use crate::head::HeadState;
use crate::storage::Square;
use crate::strand_terms::{PointScratch, StepTerms, StrandShape};
use nalgebra::{Matrix3, Vector3};

/// A constant force applied at one point of a strand.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointLoad {
    /// Arc length of the point, metres, in [0, L].
    pub s: f64,
    /// Force, newtons: in world coordinates (rotated into head coordinates each step), or,
    /// for a follower load, its components along the material frame at s (n0 the tangent,
    /// n1, n2).
    pub force: Vector3<f64>,
    /// A follower load: the force turns with the material frame at s (the terminal
    /// follower load of figure 3 of Sobottka & Weber 2006). It has no potential: its work
    /// enters the energy balance as a power, and a static solve refuses it.
    pub follows: bool,
    /// A couple at the same point, N·m, world coordinates (a dead couple: rotated into
    /// head coordinates each step, whatever `follows` says of the force). Its generalized
    /// force is `G_rot(s)ᵀ T_head`, G_rot the angular Jacobian of the material frame at s;
    /// in three dimensions it has no potential: its power `T_head · ω(s)` joins the work
    /// of the energy balance, and a static solve refuses it. Zero: no couple.
    pub torque: Vector3<f64>,
}

/// Whether any of `loads` carries a couple ([`PointLoad::torque`]).
pub fn any_couple(loads: &[PointLoad]) -> bool {
    loads.iter().any(|l| l.torque != Vector3::zeros())
}

/// Whether any of `loads` follows the material frame or carries a couple: the loads
/// then work without a potential, and the energy balance counts their power even when
/// the head moves uniformly.
pub fn any_follows(loads: &[PointLoad]) -> bool {
    loads.iter().any(|l| l.follows) || any_couple(loads)
}

/// A load's force in head coordinates: Rᵀ f for a dead load (`rt` = Rᵀ), F(s, q) f for a
/// follower load.
fn head_force<T: Float, S: StepTerms<T> + ?Sized>(
    load: &PointLoad,
    rt: &Matrix3<f64>,
    source: &mut S,
    shape: &StrandShape<'_, T>,
    q: &[T],
    scratch: &mut PointScratch<'_, T>,
) -> Vector3<T> {
    if load.follows {
        source.frame(shape, q, T::of(load.s), scratch) * load.force.map(T::of)
    } else {
        (rt * load.force).map(T::of)
    }
}

/// Add the loads' generalized forces J(s)ᵀ f_head to `force` and, with `stiffness`,
/// f_head · ∂²y(s)/∂q∂q to it, at q with the head at orientation `rotation` (R, head to
/// world).
#[allow(clippy::too_many_arguments)]
pub fn add_terms<T: Float, S: StepTerms<T> + ?Sized>(
    loads: &[PointLoad],
    source: &mut S,
    shape: &StrandShape<'_, T>,
    rotation: &Matrix3<f64>,
    q: &[T],
    scratch: &mut PointScratch<'_, T>,
    force: &mut [T],
    mut stiffness: Option<&mut Square<'_, T>>,
) {
    let rt = rotation.transpose();
    for load in loads {
        let f = head_force(load, &rt, source, shape, q, scratch);
        let hessian = stiffness.as_deref_mut().map(|h| (f, h));
        source.point(shape, q, T::of(load.s), scratch, hessian);
        for (fi, col) in force.iter_mut().zip(scratch.jac.iter()) {
            *fi += col.dot(&f);
        }
        if load.torque != Vector3::zeros() {
            add_couple(shape, q, load.s, &(rt * load.torque), force);
        }
    }
}

/// Add the generalized force `G_rot(s)ᵀ T` of a couple T (head coordinates) on the
/// material frame at s to `force`. The frames chain from the root as
/// `F_{k+1} = F_k exp(l_k [d_k]×)` (section 3.2 of the Super-Helix paper: an element's
/// Darboux vector is constant in its material frame); varying d_k turns every frame
/// beyond element k by `F_{k+1} J_r(l_k d_k) l_k δd_k`, and the element holding s, at u
/// into it, turns F(s) by `F(s) J_r(u d) u δd` (J_r the right Jacobian of SO(3)); beyond
/// s the couple does no work. Its stiffness is left out of the step's matrix (explicit,
/// as the turning part of a follower load's).
fn add_couple<T: Float>(
    shape: &StrandShape<'_, T>,
    q: &[T],
    s: f64,
    torque: &Vector3<f64>,
    force: &mut [T],
) {
    let n = shape.lengths.len();
    let mut frame: Matrix3<f64> = shape.root_frame.map(|x| x.as_f64());
    let mut start = 0.0;
    for k in 0..n {
        let l = shape.lengths[k].as_f64();
        // the element of s (an element end belongs to the element before it)
        let last = s <= start + l || k + 1 == n;
        let u = if last { (s - start).clamp(0.0, l) } else { l };
        let phi = crate::pose::darboux(q, k).map(|x| x.as_f64() * u);
        frame *= rotation_exp(&phi);
        let g = (frame * right_jacobian(&phi) * u).transpose() * torque;
        for i in 0..3 {
            force[3 * k + i] += T::of(g[i]);
        }
        if last {
            break;
        }
        start += l;
    }
}

/// exp([φ]×) by Rodrigues' formula (its series below 1e-4 rad).
fn rotation_exp(phi: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = phi.dot(phi);
    let (a, b) = if t2 < 1e-8 {
        (1.0 - t2 / 6.0, 0.5 - t2 / 24.0)
    } else {
        let t = crate::math::sqrt(t2);
        let (sin, cos) = crate::math::sin_cos(t);
        (sin / t, (1.0 - cos) / t2)
    };
    let k = phi.cross_matrix();
    Matrix3::identity() + k * a + k * k * b
}

/// The right Jacobian of SO(3), `J_r(φ) = I − (1 − cos θ)/θ² [φ]× + (θ − sin θ)/θ³ [φ]×²`
/// (θ = |φ|; its series below 1e-4 rad): `δ exp([φ]×) = exp([φ]×) [J_r(φ) δφ]×`.
fn right_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = phi.dot(phi);
    let (a, b) = if t2 < 1e-8 {
        (0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0)
    } else {
        let t = crate::math::sqrt(t2);
        let (sin, cos) = crate::math::sin_cos(t);
        ((1.0 - cos) / t2, (t - sin) / (t2 * t))
    };
    let k = phi.cross_matrix();
    Matrix3::identity() - k * a + k * k * b
}

/// What the energy balance takes from a strand's point loads at one state
/// ([`crate::energy::StateEnergy`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LoadEnergy<T: Float = f64> {
    /// Σ f_head · y(s) over the dead loads (−V), J.
    pub moment: T,
    /// Σ (ω × f_head) · y(s) over the dead loads: V's rate at fixed q through the head's
    /// turning, W.
    pub rate: T,
    /// Σ f_head · J(s) q̇ over the follower loads: their power, W.
    pub power: T,
}

/// The loads' part of the energy balance at (q, q̇) with the head in `head`.
pub fn energy<T: Float, S: StepTerms<T> + ?Sized>(
    loads: &[PointLoad],
    source: &mut S,
    shape: &StrandShape<'_, T>,
    head: &HeadState,
    q: &[T],
    v: &[T],
    scratch: &mut PointScratch<'_, T>,
) -> LoadEnergy<T> {
    let rt = head.rotation.transpose();
    let omega = head.omega.map(T::of);
    let mut e = LoadEnergy::default();
    for load in loads {
        let f = head_force(load, &rt, source, shape, q, scratch);
        let y = source.point(shape, q, T::of(load.s), scratch, None);
        if load.follows {
            let velocity: Vector3<T> = scratch
                .jac
                .iter()
                .zip(v)
                .fold(Vector3::zeros(), |acc, (c, &vi)| acc + c * vi);
            e.power += f.dot(&velocity);
        } else {
            e.moment += f.dot(&y);
            e.rate += omega.cross(&f).dot(&y);
        }
        if load.torque != Vector3::zeros() {
            // its power: its generalized force times q̇
            let mut g = [T::zero(); MAX_COUPLE_DOFS];
            let n = q.len().min(MAX_COUPLE_DOFS);
            add_couple(shape, &q[..n], load.s, &(rt * load.torque), &mut g[..n]);
            e.power += g[..n].iter().zip(v).map(|(g, v)| *g * *v).sum::<T>();
        }
    }
    e
}

/// The largest 3N of a strand whose couples' power [`energy`] measures (their
/// generalized force is gathered without allocating; the scene's strands have at most
/// 200 elements).
pub const MAX_COUPLE_DOFS: usize = 3 * 256;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::moments::EndDerivatives;
    use crate::pose::Pose;
    use crate::strand_point::tests::Jets;
    use std::vec;
    use std::vec::Vec;

    const LENGTHS: [f64; 4] = [0.03, 0.05, 0.04, 0.02];

    fn shape() -> StrandShape<'static, f64> {
        StrandShape {
            root_position: Vector3::new(0.01, -0.02, 0.05),
            root_frame: nalgebra::Rotation3::from_euler_angles(0.2, -0.4, 0.9).into_inner(),
            lengths: &LENGTHS,
            mass_per_length: 6e-5,
            rotary_inertia: [0.0; 3],
        }
    }

    fn state() -> Vec<f64> {
        (0..12)
            .map(|i| [3.0, 25.0, -8.0, 0.5][i % 4] + 0.1 * i as f64)
            .collect()
    }

    /// Scratch for a strand of `LENGTHS`.
    struct Scratch(Vec<Vector3<f64>>, Vec<Pose>, Vec<EndDerivatives>);
    impl Scratch {
        fn new() -> Self {
            Scratch(
                vec![Vector3::zeros(); 12],
                vec![Pose::default(); 5],
                vec![EndDerivatives::default(); 4],
            )
        }
        fn view(&mut self) -> PointScratch<'_, f64> {
            PointScratch {
                jac: &mut self.0,
                ends: &mut self.1,
                derivs: &mut self.2,
            }
        }
    }

    /// The head turned by `omega · t` from `r0` (Ṙ = R[ω]×, ω constant).
    fn head_at(r0: &Matrix3<f64>, omega: &Vector3<f64>, t: f64) -> HeadState {
        let mut head = HeadState::rest();
        head.rotation = r0 * nalgebra::Rotation3::new(omega * t).into_inner();
        head.omega = *omega;
        head
    }

    /// The dead loads' generalized force is −∂V/∂q and their stiffness ∂(Jᵀf)/∂q (central
    /// differences, 1e-6 in q, of V = −f·y from `energy` and of the force from
    /// `add_terms`), on a turned head; V's rate at fixed q is its time derivative as
    /// the head turns (central differences in t).
    #[test]
    fn a_dead_loads_force_stiffness_and_rate_are_the_derivatives_of_its_potential() {
        let loads = [
            PointLoad {
                s: 0.06,
                force: Vector3::new(0.3, -1.2, 0.7),
                follows: false,
                torque: nalgebra::Vector3::zeros(),
            },
            PointLoad {
                s: 0.14,
                force: Vector3::new(-0.5, 0.2, 0.9),
                follows: false,
                torque: nalgebra::Vector3::zeros(),
            },
        ];
        let shape = shape();
        let q = state();
        let v = vec![0.0; 12];
        let r0 = nalgebra::Rotation3::from_euler_angles(-0.3, 0.5, 0.1).into_inner();
        let omega = Vector3::new(0.4, -2.0, 1.1);
        let head = head_at(&r0, &omega, 0.0);
        let mut scratch = Scratch::new();
        let mut source = &Jets;
        let mut force = vec![0.0; 12];
        let mut stiffness_data = vec![0.0; 144];
        let mut stiffness = Square::new(&mut stiffness_data, 12).expect("12 × 12");
        add_terms(
            &loads,
            &mut source,
            &shape,
            &head.rotation,
            &q,
            &mut scratch.view(),
            &mut force,
            Some(&mut stiffness),
        );
        let moment = |q: &[f64], head: &HeadState, scratch: &mut Scratch| {
            energy(&loads, &mut &Jets, &shape, head, q, &v, &mut scratch.view())
        };
        let e = moment(&q, &head, &mut scratch);
        assert_eq!(e.power, 0.0);
        let step = 1e-6;
        let fscale = force.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let hscale = stiffness_data.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for k in 0..12 {
            let (mut up, mut down) = (q.clone(), q.clone());
            up[k] += step;
            down[k] -= step;
            // force = −∂V/∂q = ∂(Σ f·y)/∂q
            let numeric = (moment(&up, &head, &mut scratch).moment
                - moment(&down, &head, &mut scratch).moment)
                / (2.0 * step);
            assert!(
                (numeric - force[k]).abs() <= 1e-7 * fscale,
                "force[{k}]: {} against −∂V/∂q = {numeric}",
                force[k]
            );
            let (mut fu, mut fd) = (vec![0.0; 12], vec![0.0; 12]);
            for (x, f) in [(&up, &mut fu), (&down, &mut fd)] {
                add_terms(
                    &loads,
                    &mut &Jets,
                    &shape,
                    &head.rotation,
                    x,
                    &mut scratch.view(),
                    f,
                    None,
                );
            }
            for l in 0..12 {
                let numeric = (fu[l] - fd[l]) / (2.0 * step);
                assert!(
                    (numeric - stiffness_data[l + 12 * k]).abs() <= 1e-6 * hscale,
                    "stiffness({l}, {k}): {} against {numeric}",
                    stiffness_data[l + 12 * k]
                );
            }
        }
        // dV/dt at fixed q = −d(Σ f·y)/dt
        let dt = 1e-6;
        let numeric = -(moment(&q, &head_at(&r0, &omega, dt), &mut scratch).moment
            - moment(&q, &head_at(&r0, &omega, -dt), &mut scratch).moment)
            / (2.0 * dt);
        assert!(
            (numeric - e.rate).abs() <= 1e-8 * e.moment.abs().max(e.rate.abs()),
            "rate {} against dV/dt {numeric}",
            e.rate
        );
        assert!(e.rate.abs() > 1e-3 * e.moment.abs(), "{e:?}");
    }

    /// A couple's generalized force is its virtual work per unit of each coordinate,
    /// `T_head · ω_k` (ω_k: central differences of the frame at s, 1e-6 in q), at points
    /// inside elements and at their ends; its power is that force times q̇.
    #[test]
    fn a_couples_force_is_its_virtual_work_and_its_power_that_force_times_qdot() {
        let shape = shape();
        let q = state();
        let v: Vec<f64> = (0..12).map(|i| 0.3 - 0.05 * i as f64).collect();
        let r0 = nalgebra::Rotation3::from_euler_angles(-0.3, 0.5, 0.1).into_inner();
        let torque = Vector3::new(0.3, -1.2, 0.7);
        let th = r0.transpose() * torque;
        let mut scratch = Scratch::new();
        for s in [0.0, 0.02, 0.03, 0.061, 0.08, 0.13, 0.14] {
            let load = [PointLoad {
                s,
                force: Vector3::zeros(),
                follows: false,
                torque,
            }];
            let mut force = vec![0.0; 12];
            add_terms(
                &load,
                &mut &Jets,
                &shape,
                &r0,
                &q,
                &mut scratch.view(),
                &mut force,
                None,
            );
            let frame =
                |q: &[f64], scratch: &mut Scratch| (&Jets).frame(&shape, q, s, &mut scratch.view());
            let f0 = frame(&q, &mut scratch);
            for k in 0..12 {
                let (mut up, mut down) = (q.clone(), q.clone());
                up[k] += 1e-6;
                down[k] -= 1e-6;
                let w =
                    (frame(&up, &mut scratch) - frame(&down, &mut scratch)) * f0.transpose() / 2e-6;
                let omega = Vector3::new(w[(2, 1)], w[(0, 2)], w[(1, 0)]);
                let expected = th.dot(&omega);
                assert!(
                    (force[k] - expected).abs() <= 1e-8 * (1.0 + expected.abs()),
                    "s = {s}, q[{k}]: {} against {expected}",
                    force[k]
                );
            }
            let mut head = HeadState::rest();
            head.rotation = r0;
            let e = energy(
                &load,
                &mut &Jets,
                &shape,
                &head,
                &q,
                &v,
                &mut scratch.view(),
            );
            let expected: f64 = force.iter().zip(&v).map(|(f, v)| f * v).sum();
            assert!(
                (e.power - expected).abs() <= 1e-8 * (1.0 + expected.abs()),
                "s = {s}: power {} against {expected}",
                e.power
            );
        }
    }

    /// A follower load's force is J(s)ᵀ F(s) f, its power that force times q̇, and it has
    /// no potential; F(s) is the material frame whose columns are the tangent (against
    /// central differences of y in s) and two normals.
    #[test]
    fn a_follower_load_pushes_along_the_material_frame_and_works_without_a_potential() {
        let f = Vector3::new(0.2, 1.0, -0.4);
        let load = [PointLoad {
            s: 0.1,
            force: f,
            follows: true,
            torque: nalgebra::Vector3::zeros(),
        }];
        let shape = shape();
        let q = state();
        let v: Vec<f64> = (0..12).map(|i| 0.3 - 0.05 * i as f64).collect();
        let head = head_at(&Matrix3::identity(), &Vector3::new(0.0, 1.0, 0.0), 0.3);
        let mut scratch = Scratch::new();
        let mut source = &Jets;
        let frame = source.frame(&shape, &q, 0.1, &mut scratch.view());
        assert!((frame.transpose() * frame - Matrix3::identity()).norm() < 1e-12);
        let ds = 1e-6;
        let tangent = (source.point(&shape, &q, 0.1 + ds, &mut scratch.view(), None)
            - source.point(&shape, &q, 0.1 - ds, &mut scratch.view(), None))
            / (2.0 * ds);
        assert!(
            (tangent - frame.column(0)).norm() < 1e-8,
            "{tangent} against {}",
            frame.column(0)
        );
        let mut force = vec![0.0; 12];
        add_terms(
            &load,
            &mut source,
            &shape,
            &head.rotation,
            &q,
            &mut scratch.view(),
            &mut force,
            None,
        );
        source.point(&shape, &q, 0.1, &mut scratch.view(), None);
        let expected: Vec<f64> = scratch.0.iter().map(|c| c.dot(&(frame * f))).collect();
        for (a, b) in force.iter().zip(&expected) {
            assert!((a - b).abs() <= 1e-14 * (1.0 + b.abs()), "{a} against {b}");
        }
        let e = energy(
            &load,
            &mut source,
            &shape,
            &head,
            &q,
            &v,
            &mut scratch.view(),
        );
        let power: f64 = force.iter().zip(&v).map(|(a, b)| a * b).sum();
        assert!((e.power - power).abs() <= 1e-14 * power.abs().max(1e-300));
        assert!(power.abs() > 0.0);
        assert_eq!((e.moment, e.rate), (0.0, 0.0));
        assert!(any_follows(&load));
    }
}
