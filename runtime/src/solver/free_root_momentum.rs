//! A free root's linear momentum kept through a linearly implicit step.
//!
//! A strand with a free root carries its root's translation X among its coordinates
//! (the last three), and its linear momentum is `P(q, q̇) = M_X(q) q̇` with `M_X` the
//! mass matrix's X rows (`∫ ρS J ds`, since ∂y/∂X = I). Newton's second law for the
//! whole strand is `dP/dt = Σ F` (the X rows of the generalized force, internal forces
//! cancelling), which the equation of motion `M q̈ = F − b` holds because the X rows of
//! the quadratic velocity term are `b_X = Ṁ_X q̇` (paper eq. 6; ∂T/∂X = 0).
//!
//! The step solves its X rows at the start's configuration q₀:
//! `M_X(q₀) (q̇⁺ − q̇) = h F_X − (h/2) (B q̇⁺)_X` (with `b ≈ ½ B q̇⁺`,
//! [`super::linearly_implicit::linearly_implicit_euler`]), and the momentum it ends with
//! is measured at the end's configuration q⁺: `M_X(q⁺) q̇⁺`. Where an element turns
//! within the step the two differ at first order, by much more than the impulse when
//! the rotation is fast (uncorrected, a rod pulled sideways at its tip loses 13 % of
//! `F t` in its first step and keeps the loss), so the run no longer follows F = ma. The correction
//! moves Ẋ alone so that the momentum at the end is the start's plus the step's impulse
//! `h F_X = M_X(q₀) q̇⁺ + (h/2)(B q̇⁺)_X − P(q₀, q̇)`: `Ẋ += (P_target − M_X(q⁺) q̇⁺)/m`,
//! second order in h. It costs one mass matrix at q⁺ a step, on free-root strands only.

use super::system::StrandSystem;
use crate::kernels::kernel::{EvalInput, Terms};
use crate::model::ends::RootEnd;
use superhelix_kernels::body_field::BodyField;

/// Whether the strand's momentum is kept here: a free root and no held tip (with a held
/// tip the holder's multipliers carry the momentum's change).
pub(super) fn applies(system: &StrandSystem) -> bool {
    system.strand.ends.root == RootEnd::Free && system.held.is_none()
}

/// The momentum the step's own impulse gives (`P_target` above), from the terms still
/// held for the start's configuration and the solved velocities `v`.
pub(super) fn target(system: &StrandSystem, v: &[f64], h: f64) -> [f64; 3] {
    let t = &system.workspace.terms;
    let x = v.len() - 3;
    let mut p = [0.0; 3];
    for (k, pk) in p.iter_mut().enumerate() {
        for (j, vj) in v.iter().enumerate() {
            *pk += (t.mass[(x + k, j)] + 0.5 * h * t.velocity_term_jacobian[(x + k, j)]) * vj;
        }
    }
    p
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

/// Scale the velocities `v` at `q` so that the kinetic energy becomes `kinetic`
/// (below the present one), keeping the linear momentum: the motion relative to the
/// centre of mass is scaled, `q̇ → λ q̇ + (1 − λ) e_X V` with `V = P/m` (a uniform
/// translation, Ẋ = V and the chain at rest, carries the momentum P and the kinetic
/// energy ½ m V², and the rest carries no momentum, so the two energies add). When the
/// translation alone holds more than `kinetic`, all velocities are scaled (the bound
/// cannot be met keeping the momentum). Returns λ_eff = √(kinetic / T), which scales
/// the end's energy record.
pub(super) fn scale_to_kinetic(
    system: &mut StrandSystem,
    q: &[f64],
    v: &mut [f64],
    present: f64,
    kinetic: f64,
) -> f64 {
    let plain = (kinetic / present).sqrt();
    evaluate_mass(system, q, v);
    let p = momentum(system, v);
    let x = v.len() - 3;
    let mass = system.workspace.terms.mass[(x, x)];
    let translation = p.iter().map(|c| c * c).sum::<f64>() / (2.0 * mass);
    if kinetic <= translation || present <= translation {
        v.iter_mut().for_each(|x| *x *= plain);
        return plain;
    }
    let lambda = ((kinetic - translation) / (present - translation)).sqrt();
    v.iter_mut().for_each(|x| *x *= lambda);
    for k in 0..3 {
        v[x + k] += (1.0 - lambda) * p[k] / mass;
    }
    plain
}
