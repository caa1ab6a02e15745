//! Backward Euler solved by Newton iterations to a residual tolerance.

use super::stats::StepStats;
use super::system::{HeadInterval, StrandState, StrandSystem};
use crate::kernels::kernel::Terms;

/// Most Newton iterations of one implicit Euler solve.
pub const NEWTON_MAX_ITERATIONS: usize = 20;

/// Backward Euler `M(q⁺)(v⁺ − v) = h F(q⁺, v⁺)`, `q⁺ = q + h v⁺`, solved by Newton
/// iterations on v⁺ with the Jacobian `M − h(D_v − ∂b/∂q̇) − h² D_q` (∂M/∂q and ∂b/∂q
/// are left out: they enter at relative order h and only slow convergence), to a
/// residual of 1e-10 of the step's force scale (the largest of M Δv, h K(q − q_n) and the
/// other forces times h), at most [`NEWTON_MAX_ITERATIONS`] iterations.
///
/// Without ∂M/∂q and ∂b/∂q the iterations converge linearly, at a rate that degrades as
/// h grows (in fast large rotations: 0.03 per iteration at a substep of 0.13 ms, 0.12 at
/// 0.26 ms, none at 1 ms). From the third residual on, the solve stops as unconverged as
/// soon as the residual no longer decreases or its rate of decrease cannot reach the
/// tolerance within the remaining iterations: the caller splits the step, and iterating on
/// would only cost.
pub fn newton_implicit_euler(
    system: &mut StrandSystem,
    interval: &HeadInterval,
    state: &mut StrandState,
    stats: &mut StepStats,
) -> Result<(), String> {
    const TOLERANCE: f64 = 1e-10;
    let h = interval.h;
    let (q, v) = (&mut state.q[..], &mut state.v[..]);
    let n = q.len();
    let mut s = std::mem::take(&mut system.workspace.scratch);
    let [v_new, q_new, residual, ..] = &mut s;
    v_new.copy_from_slice(v);
    let mut converged = false;
    let mut outcome = Ok(());
    let mut previous = f64::INFINITY;
    for iteration in 0..NEWTON_MAX_ITERATIONS {
        for i in 0..n {
            q_new[i] = q[i] + h * v_new[i];
        }
        system.assemble(&interval.at_end(), q_new, v_new, Terms::all());
        stats.newton_iterations += 1;
        let ws = &mut system.workspace;
        let t = &ws.terms;
        let mut scale: f64 = 1e-300;
        let mut worst: f64 = 0.0;
        for i in 0..n {
            let mut mdv = 0.0;
            for j in 0..n {
                mdv += t.mass[(i, j)] * (v_new[j] - v[j]);
            }
            residual[i] = mdv - h * t.force[i];
            // the scale of the terms that cancel in the residual: at rest the net force is
            // zero while elasticity and gravity are not
            let elastic = ws.stiffness[i] * (q_new[i] - system.strand.natural[i]);
            let others = t.force[i] + elastic;
            scale = scale
                .max(mdv.abs())
                .max(h * elastic.abs())
                .max(h * others.abs());
            worst = worst.max(residual[i].abs());
        }
        let relative = worst / scale;
        if relative <= TOLERANCE {
            converged = true;
            break;
        }
        if iteration >= 2 {
            let rate = relative / previous;
            let left = (NEWTON_MAX_ITERATIONS - 1 - iteration) as f64;
            // a NaN rate (a NaN residual) is no progress either
            let progressing = rate < 1.0;
            if !progressing || (TOLERANCE / relative).ln() / rate.ln() > left {
                break;
            }
        }
        previous = relative;
        for j in 0..n {
            for i in 0..n {
                let dv = t.damping[(i, j)] - t.velocity_term_jacobian[(i, j)];
                ws.solver.matrix[(i, j)] = t.mass[(i, j)] - h * dv - h * h * t.stiffness[(i, j)];
            }
        }
        for i in 0..n {
            ws.solver.rhs_mut()[i] = -residual[i];
        }
        if !ws.solver.solve_general() {
            outcome = Err("Newton implicit Euler: singular Jacobian".to_string());
            break;
        }
        let dv = ws.solver.solution();
        for i in 0..n {
            v_new[i] += dv[i];
        }
    }
    if outcome.is_ok() {
        if !converged {
            stats.newton_unconverged += 1;
        }
        v.copy_from_slice(v_new);
        for i in 0..n {
            q[i] += h * v[i];
        }
    }
    system.workspace.scratch = s;
    outcome
}
