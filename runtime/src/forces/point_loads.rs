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
