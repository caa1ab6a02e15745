//! A sag-free start (inverse statics): the natural curvatures that make a given shape an
//! equilibrium under gravity, so that a groomed or imported shape is what the hair looks
//! like at rest instead of the shape it starts from before sagging.
//!
//! At rest (q̇ = 0, head still) the equation of motion (paper eq. 4–5, `docs/model.md`)
//! reduces to the statics `K (q − q_n) = G(q)`, with K = diag(l_Q EI_i) the stiffness of
//! the elastic energy (eq. 5c) and `G(q) = ∫ Jᵀ ρS g ds` the generalized gravity force
//! (eq. 5a, J = ∂y/∂q). For a given q this is linear in q_n, so
//!
//! ```text
//! q_n = q − K⁻¹ G(q)
//! ```
//!
//! in closed form. With these natural curvatures the strand at q feels no net force:
//! it stays where it is (up to round-off, and as long as the equilibrium is stable: a
//! long strand held straight up against gravity is not).

use crate::forces::effects::{body_field, GlobalEffects};
use crate::forces::head_motion::HeadState;
use crate::kernels::closed_form::kernel_factory;
use crate::kernels::generic::{GenericKernel, QuadratureRule};
use crate::kernels::kernel::{EvalInput, StrandKernel, StrandTerms, Terms};
use crate::model::strand::Strand;
use nalgebra::Vector3;

/// The generalized gravity force `G(q) = ∫ Jᵀ ρS g ds` of `strand` at `q` with gravity
/// `gravity` (m/s², head coordinates), computed by the strand's generated kernel (the
/// one `kernels = "auto"` steps it with).
pub fn gravity_force(strand: &Strand, q: &[f64], gravity: &Vector3<f64>) -> Vec<f64> {
    let geometry = &strand.geometry;
    let mut kernel: Box<dyn StrandKernel> =
        kernel_factory().create(geometry).unwrap_or_else(|| {
            Box::new(GenericKernel::new(
                geometry.clone(),
                QuadratureRule::Adaptive,
            ))
        });
    let effects = GlobalEffects {
        gravity: Some(*gravity),
        head_moves: false,
    };
    // no air drag: at q̇ = 0 with a still head it exerts nothing
    let field = body_field(
        &effects,
        &HeadState::rest(),
        strand.material.mass_per_length,
        0.0,
    );
    let zero = vec![0.0; q.len()];
    let mut out = StrandTerms::new(q.len());
    kernel.evaluate(
        &EvalInput {
            q,
            v: &zero,
            field,
            terms: Terms {
                force: true,
                ..Default::default()
            },
        },
        &mut out,
    );
    out.force
}

/// The natural curvatures `q_n = q − K⁻¹ G(q)` that make `q` an equilibrium of `strand`
/// under `gravity` (head coordinates; the module doc). Point loads are not included.
pub fn sag_free_natural(strand: &Strand, q: &[f64], gravity: &Vector3<f64>) -> Vec<f64> {
    let force = gravity_force(strand, q, gravity);
    let stiffness = strand.stiffness_diagonal();
    q.iter()
        .zip(&force)
        .zip(&stiffness)
        .map(|((q, f), k)| q - f / k)
        .collect()
}
