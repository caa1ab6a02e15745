//! The linearly implicit Euler step (paper section 3.4), the default integrator.

use super::free_root_momentum;
use super::predicted_contacts::resolve;
use super::stats::StepStats;
use super::system::{HeadInterval, StrandState, StrandSystem};
use crate::kernels::kernel::Terms;
use crate::kernels::step_terms::KernelPoints;

/// One Newton step of backward Euler (design page "Time stepping"), with the velocity
/// term taken semi-implicitly:
///
/// ```text
/// (M − h D_v + (h/2) B − h² D_q) v⁺ = M v + h (F + b) − h D_v v,   q⁺ = q + h v⁺
/// ```
///
/// - D_q = H⁻ − K, where H is the symmetric part of the field and point-load stiffness
///   and H⁻ its negative semidefinite part (eigenvalues clamped at 0; H itself when a
///   Cholesky factorisation of −H succeeds): a destabilising stiffness (gravity on a
///   strand pointing up, centrifugal force) stays explicit, because in the matrix it
///   amplifies by 1/(1 − h²λ), which explodes as h²λ → 1. This is a convex–concave
///   splitting (Eyre): the convex part of the potential implicit, the concave part
///   explicit. Taking H whole whenever K − H is positive definite (one Cholesky instead
///   of an eigendecomposition) is cheaper but lets the step create energy: a
///   frictionless fuzzy strand falling at N = 10–20 gained up to 0.11 of its energy scale
///   within 0.2 s (`superhelix stress`, conservative group; regression test in
///   `tests/stability.rs`).
/// - D_v = ∂F/∂q̇ less ∂b/∂q̇: friction and drag and, when the head turns, the Coriolis
///   term (skew).
/// - b(q, q̇) is quadratic in q̇ with ∂b/∂q̇ = B and B q̇ = 2b, so `b ≈ ½ B(q, q̇) q̇⁺`
///   is exact at q̇⁺ = q̇ and linear in q̇⁺ (the semi-implicit Coriolis treatment of
///   multibody codes). Left explicit, as in the paper, a whipping strand (q̇ l h of
///   order 1: a fine strand on a 3 Hz, ±40° shake) grows as v_{k+1} ~ h v_k² and
///   overflows within ten steps; `tests/stability.rs` is that case.
///
/// The matrix is not symmetric (B, Coriolis): partial-pivoting LU.
pub fn linearly_implicit_euler(
    system: &mut StrandSystem,
    interval: &HeadInterval,
    state: &mut StrandState,
    stats: &mut StepStats,
) -> Result<(), String> {
    let h = interval.h;
    let (q, v) = (&mut state.q[..], &mut state.v[..]);
    let terms = Terms::all();
    let assembled = system.assemble(&interval.at_end(), q, v, terms);
    let n = q.len();
    let ws = &mut system.workspace;
    ws.step_matrix(assembled, h, stats);
    let t = &ws.terms;
    // r_i = h (F + b)_i + Σ_j (M − h D_v)_ij v_j, summed over j in order, column by column
    let rhs = &mut ws.solver.rhs_mut()[..n];
    for (i, r) in rhs.iter_mut().enumerate() {
        *r = h * (t.force[i] + t.velocity_term[i]);
    }
    for (j, &vj) in v.iter().enumerate() {
        let mass = &t.mass.col_as_slice(j)[..n];
        let damping = &t.damping.col_as_slice(j)[..n];
        for i in 0..n {
            rhs[i] += (mass[i] - h * damping[i]) * vj;
        }
    }
    if !ws.solver.solve_general() {
        return Err("linearly implicit Euler: singular step matrix".into());
    }
    ws.implicit_factors = Some((ws.solver.factorizations(), h));
    v.copy_from_slice(system.workspace.solver.solution());
    let t_end = interval.t + h;
    if let Some(held) = system.held.as_mut() {
        // the held tip's multipliers on the same factors
        let solver = &mut system.workspace.solver;
        held.constrain_velocities(
            &mut KernelPoints(system.kernel.as_mut()),
            &system.strand.geometry,
            &mut |x| solver.solve_factored(x),
            q,
            v,
            t_end,
            h,
        )
        .map_err(|e| e.to_string())?;
    }
    let has_contacts = system.contacts.is_some();
    if has_contacts {
        system.workspace.scratch[5].copy_from_slice(q);
    }
    for i in 0..n {
        q[i] += h * v[i];
    }
    if has_contacts {
        // the contacts that start within the step, predicted along the solution
        let at = interval.at_end();
        let ws = &system.workspace;
        if let Some(c) = system.contacts.as_mut() {
            c.predict(&at, &system.strand.geometry, &ws.scratch[5], q);
        }
        resolve(system, &at, (h, h), q, v, stats)?;
    }
    if free_root_momentum::applies(system) {
        // a free root's momentum changes by the step's impulse, the contacts that start
        // within the step included
        let target = free_root_momentum::target(system, v, h);
        free_root_momentum::correct(system, q, v, target);
    }
    if let Some(held) = system.held.as_mut() {
        // the drift the linearised constraint leaves, projected out
        held.project(
            &mut KernelPoints(system.kernel.as_mut()),
            &system.strand.geometry,
            q,
            t_end,
        )
        .map_err(|e| e.to_string())?;
    }
    Ok(())
}
