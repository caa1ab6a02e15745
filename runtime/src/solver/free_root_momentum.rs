//! A free root's linear momentum kept through the pair solve of `coupling = "pair"`.
//!
//! A strand with a free root carries its root's translation X among its coordinates
//! (the last three), and its linear momentum is `P(q, q̇) = M_X(q) q̇` with `M_X` the
//! mass matrix's X rows (`∫ ρS J ds`, since ∂y/∂X = I). The step keeps it
//! (`superhelix_kernels::fixed`'s free root: the momentum at the end is the start's plus
//! the step's impulse); the pair solve changes q̇ by its impulses on the step's factors,
//! and moves Ẋ after it so that the momentum at the end is the step's plus the pairs'
//! impulse: `Ẋ += (P_target − M_X(q⁺) q̇⁺)/m`. It costs one mass matrix at q⁺, on
//! free-root strands in pairs only.

use super::system::StrandSystem;
use crate::kernels::kernel::{EvalInput, Terms};
use crate::model::ends::RootEnd;
use superhelix_kernels::body_field::BodyField;

/// Whether the strand's momentum is kept here: a free root and no held tip (with a held
/// tip the holder's multipliers carry the momentum's change).
pub(super) fn applies(system: &StrandSystem) -> bool {
    system.strand.ends.root == RootEnd::Free && system.held.is_none()
}

/// The mass matrix at `q` into the workspace's terms.
fn evaluate_mass(system: &mut StrandSystem, q: &[f64], v: &[f64]) {
    let terms = Terms {
        mass: true,
        ..Default::default()
    };
    let field = BodyField::zero();
    let ws = &mut system.workspace;
    system
        .kernel
        .evaluate(&EvalInput { q, v, field, terms }, &mut ws.terms);
}

/// `M_X v` from the mass matrix held in the workspace's terms: the momentum at the
/// configuration they were evaluated at.
fn momentum(system: &StrandSystem, v: &[f64]) -> [f64; 3] {
    let m = &system.workspace.terms.mass;
    let x = v.len() - 3;
    let mut p = [0.0; 3];
    for (k, pk) in p.iter_mut().enumerate() {
        for (j, vj) in v.iter().enumerate() {
            *pk += m[(x + k, j)] * vj;
        }
    }
    p
}

/// The momentum `M_X(q) v` (evaluates the mass matrix at q into the workspace's terms).
pub(super) fn momentum_at(system: &mut StrandSystem, q: &[f64], v: &[f64]) -> [f64; 3] {
    evaluate_mass(system, q, v);
    momentum(system, v)
}

/// Move Ẋ so that the momentum at (`q`, `v`) is `target`.
pub(super) fn correct(system: &mut StrandSystem, q: &[f64], v: &mut [f64], target: [f64; 3]) {
    evaluate_mass(system, q, v);
    let p = momentum(system, v);
    let x = v.len() - 3;
    let mass = system.workspace.terms.mass[(x, x)];
    for k in 0..3 {
        v[x + k] += (target[k] - p[k]) / mass;
    }
}
