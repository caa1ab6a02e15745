//! Point loads: a constant force f (world coordinates) at arc length s of a strand
//! ([`PointLoad`]), acting on q through J(s)ᵀ. In the head frame the force is
//! f_head = Rᵀ f, which turns with the head; its potential is V = −f · y(s) (design page
//! "Energies and the equation of motion").
//!
//! A follower load ([`PointLoad::follows`]) has its components along the material frame
//! at s: f_head = F(s, q) f (section 3.1 of the Super-Helix paper for F, figure 3 of
//! Sobottka & Weber 2006 for the load). It has no potential; the step's matrix takes the
//! part of its stiffness a dead load of the same force would have, f_head · ∂²y/∂q∂q
//! (symmetric), and the part from the turning of F is left explicit.

use crate::kernels::kernel::{StrandKernel, StrandTerms, Terms};
use crate::model::reconstruction::pose_at;
use crate::model::strand::{PointLoad, StrandGeometry};
use nalgebra::{Matrix3, Vector3};

/// Add the loads' generalized forces J(s)ᵀ f_head to `out.force` (when `terms.force`)
/// and f_head · ∂²y(s)/∂q∂q to `out.stiffness` (when `terms.stiffness`), with the head
/// at orientation `rotation` (R, head to world), on a strand of `geometry`. `jac` holds 3N
/// columns of J.
#[allow(clippy::too_many_arguments)]
pub fn add_point_loads(
    loads: &[PointLoad],
    rotation: &Matrix3<f64>,
    geometry: &StrandGeometry,
    kernel: &mut dyn StrandKernel,
    q: &[f64],
    jac: &mut [Vector3<f64>],
    terms: Terms,
    out: &mut StrandTerms,
) {
    if !(terms.force || terms.stiffness) || loads.is_empty() {
        return;
    }
    let rt = rotation.transpose();
    for load in loads {
        let f = head_force(load, &rt, geometry, q);
        let hess = terms.stiffness.then_some((f, &mut out.stiffness));
        kernel.point(q, load.s, jac, hess);
        if terms.force {
            for (i, col) in jac.iter().enumerate() {
                out.force[i] += col.dot(&f);
            }
            if load.torque != Vector3::zeros() {
                add_couple(geometry, q, load.s, &(rt * load.torque), &mut out.force);
            }
        }
    }
}

/// Add the generalized force `G_rot(s)ᵀ T` of a couple T (head coordinates) on the
/// material frame at s to `force`. Varying element k's Darboux vector d_k turns every
/// frame beyond it by `ω = F_{k+1} J_r(l_k d_k) l_k δd_k` (`F_{k+1} = F_k exp(l_k [d_k]×)`,
/// section 3.2 of the Super-Helix paper; J_r the right Jacobian of SO(3)), and the
/// element holding s, at u into it, turns F(s) by `F(s) J_r(u d) u δd`; beyond s the
/// couple does no work. Its stiffness is left out of the step's matrix (explicit, as the
/// turning part of a follower load's).
pub fn add_couple(
    geometry: &StrandGeometry,
    q: &[f64],
    s: f64,
    torque: &Vector3<f64>,
    force: &mut [f64],
) {
    use crate::bodies::motion::so3::right_jacobian;
    let (element, u) = geometry.locate(s);
    let mut frame = geometry.root_pose(q).frame;
    for (k, &l) in geometry.lengths.iter().enumerate().take(element + 1) {
        let d = crate::model::reconstruction::darboux(q, k);
        let length = if k == element { u } else { l };
        frame *= crate::model::element::local_pose(&d, length).0;
        let columns = frame * right_jacobian(&(d * length)) * length;
        let g = columns.transpose() * torque;
        for i in 0..3 {
            force[3 * k + i] += g[i];
        }
    }
}

/// A load's force in head coordinates: Rᵀ f for a dead load (`rt` = Rᵀ), F(s, q) f for a
/// follower load.
pub fn head_force(
    load: &PointLoad,
    rt: &Matrix3<f64>,
    geometry: &StrandGeometry,
    q: &[f64],
) -> Vector3<f64> {
    if load.follows {
        pose_at(geometry, q, load.s).frame * load.force
    } else {
        rt * load.force
    }
}

/// The power of the follower loads, Σ f_head · ẏ(s) = Σ f_head · J(s) q̇, W (0 without
/// any). `jac` is scratch for the kernel's point evaluation (3N columns).
pub fn follower_power(
    loads: &[PointLoad],
    geometry: &StrandGeometry,
    kernel: &mut dyn StrandKernel,
    q: &[f64],
    v: &[f64],
    jac: &mut [Vector3<f64>],
) -> f64 {
    let mut power = 0.0;
    for load in loads.iter().filter(|l| l.follows) {
        let f = head_force(load, &Matrix3::identity(), geometry, q);
        kernel.point(q, load.s, jac, None);
        let velocity: Vector3<f64> = jac.iter().zip(v).map(|(c, &vi)| c * vi).sum();
        power += f.dot(&velocity);
    }
    power
}

/// The dead loads' potential V = −Σ f · y(s) with the head at rest (R = I), J (follower
/// loads have none). `jac` is scratch for the kernel's point evaluation (3N columns).
pub fn point_load_potential(
    loads: &[PointLoad],
    kernel: &mut dyn StrandKernel,
    q: &[f64],
    jac: &mut [Vector3<f64>],
) -> f64 {
    loads
        .iter()
        .filter(|l| !l.follows)
        .map(|l| -kernel.point(q, l.s, jac, None).dot(&l.force))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::material::Material;
    use nalgebra::Rotation3;

    /// A couple's generalized force is its virtual work per unit of each coordinate:
    /// `Q_k = T · ω_k`, ω_k the world rotation of the frame at s per unit of q_k (central
    /// differences of the reconstruction, 1e-6 in q, ~1e-10 of Q).
    #[test]
    fn a_couples_generalized_force_is_its_virtual_work() {
        let geometry = StrandGeometry::new(
            Vector3::new(0.01, -0.02, 0.05),
            Rotation3::from_euler_angles(0.2, -0.4, 0.9).into_inner(),
            vec![0.03, 0.05, 0.04, 0.02],
            &Material {
                mass_per_length: 1e-7,
                stiffness: [1e-10, 1e-10, 1e-10],
                rotary_inertia: [1e-15, 1e-15, 1e-15],
            },
        );
        let q: Vec<f64> = (0..12)
            .map(|i| [3.0, 25.0, -8.0, 0.5][i % 4] + 0.1 * i as f64)
            .collect();
        let torque = Vector3::new(0.3, -1.2, 0.7);
        for s in [0.0, 0.02, 0.03, 0.061, 0.12, 0.14] {
            let mut force = vec![0.0; 12];
            add_couple(&geometry, &q, s, &torque, &mut force);
            let frame = pose_at(&geometry, &q, s).frame;
            for k in 0..12 {
                let h = 1e-6;
                let at = |d: f64| {
                    let mut p = q.clone();
                    p[k] += d;
                    pose_at(&geometry, &p, s).frame
                };
                let w = (at(h) - at(-h)) * frame.transpose() / (2.0 * h);
                let omega = Vector3::new(w[(2, 1)], w[(0, 2)], w[(1, 0)]);
                let expected = torque.dot(&omega);
                assert!(
                    (force[k] - expected).abs() < 1e-8 * (1.0 + expected.abs()),
                    "s = {s}, q[{k}]: {} against {expected}",
                    force[k]
                );
            }
        }
    }
}
