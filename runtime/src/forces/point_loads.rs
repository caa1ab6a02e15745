//! Point loads: a constant force f (world coordinates) at arc length s of a strand
//! ([`PointLoad`]), acting on q through J(s)ᵀ. In the head frame the force is
//! f_head = Rᵀ f, which turns with the head; its potential is V = −f · y(s) (design page
//! "Energies and the equation of motion").

use crate::kernels::kernel::{StrandKernel, StrandTerms, Terms};
use crate::model::strand::PointLoad;
use nalgebra::{Matrix3, Vector3};

/// Add the loads' generalized forces J(s)ᵀ f_head to `out.force` (when `terms.force`)
/// and f_head · ∂²y(s)/∂q∂q to `out.stiffness` (when `terms.stiffness`), with the head
/// at orientation `rotation` (R, head to world). `jac` holds 3N columns of J.
pub fn add_point_loads(
    loads: &[PointLoad],
    rotation: &Matrix3<f64>,
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
        let f = rt * load.force;
        let hess = terms.stiffness.then_some((f, &mut out.stiffness));
        kernel.point(q, load.s, jac, hess);
        if terms.force {
            for (i, col) in jac.iter().enumerate() {
                out.force[i] += col.dot(&f);
            }
        }
    }
}

/// The loads' potential V = −Σ f · y(s) with the head at rest (R = I), J. `jac` is
/// scratch for the kernel's point evaluation (3N columns).
pub fn point_load_potential(
    loads: &[PointLoad],
    kernel: &mut dyn StrandKernel,
    q: &[f64],
    jac: &mut [Vector3<f64>],
) -> f64 {
    loads
        .iter()
        .map(|l| -kernel.point(q, l.s, jac, None).dot(&l.force))
        .sum()
}
