//! Backward Euler solved by Newton iterations: the solve of the reference integrator
//! `newton-implicit-euler`, which the checked step ([`super::adaptive`]) calls in place
//! of the linearly implicit Euler solve when its workspace asks for it
//! (`set_newton(true)`); its split rule, energy balance and contacts are the checked
//! step's, and a solve that does not converge is replaced by the linearly implicit one of
//! the same piece.

use super::contacts::ContactHooks;
use super::step::{assemble_terms, max_element_rotation, scaled_lu_solve, StepInput, StepReport};
use crate::float::Float;
use crate::storage::{StrandView, WorkView};
use crate::strand_terms::StepTerms;

/// Most Newton iterations of one implicit Euler solve.
pub const NEWTON_MAX_ITERATIONS: usize = 20;

/// The residual a Newton solve converges to, relative to the step's force scale.
pub const NEWTON_TOLERANCE: f64 = 1e-10;

/// What a Newton solve came to.
pub(crate) enum NewtonOutcome {
    /// Converged: the strand holds the solve's end.
    Converged(StepReport),
    /// Not converged (or a singular Jacobian): the strand is as it was.
    Unconverged,
}

/// Backward Euler `M(q⁺)(v⁺ − v) = h F(q⁺, v⁺)`, `q⁺ = q + h v⁺`, solved by Newton
/// iterations on v⁺ with the Jacobian `M − h(D_v − ∂b/∂q̇) − h² D_q` (∂M/∂q and ∂b/∂q
/// are left out: they enter at relative order h and only slow convergence), to a
/// residual of [`NEWTON_TOLERANCE`] of the step's force scale (the largest of M Δv,
/// h K(q − q_n) and the other forces times h), at most [`NEWTON_MAX_ITERATIONS`]
/// iterations (each counted in `iterations`). The terms (point loads and contacts
/// among them) are those of the step's end, with the head in `input.head` and the
/// colliders at `t_end`; the paper's section 3.4 takes the linearly implicit step instead,
/// which this solve is the reference for.
///
/// Without ∂M/∂q and ∂b/∂q the iterations converge linearly, at a rate that degrades as
/// h grows (in fast large rotations: 0.03 per iteration at a substep of 0.13 ms, 0.12 at
/// 0.26 ms, none at 1 ms). From the third residual on, the solve stops as unconverged as
/// soon as the residual no longer decreases or its rate of decrease cannot reach the
/// tolerance within the remaining iterations: the caller takes the linearly implicit
/// step instead, and iterating on would only cost. (`stack`: three vectors of n.) A held
/// tip or a free root is not taken (validation refuses them with this integrator): the
/// solve reports itself unconverged.
#[allow(clippy::too_many_arguments)]
pub(crate) fn newton_step<'c, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    strand: &mut StrandView<'_, T>,
    input: &StepInput,
    (h, t_end): (f64, f64),
    ws: &mut WorkView<'_, T, NC>,
    stack: &mut [T],
    mut contacts: Option<&mut (dyn ContactHooks<T> + 'c)>,
    iterations: &mut usize,
) -> NewtonOutcome {
    if strand.end.is_some() || strand.params.free_root() || !(h.is_finite() && h > 0.0) {
        return NewtonOutcome::Unconverged;
    }
    let n = crate::storage::sized::<NC>(strand.dofs());
    let hh = T::of(h);
    let (v_new, stack) = stack.split_at_mut(n);
    let (q_new, stack) = stack.split_at_mut(n);
    let residual = &mut stack[..n];
    let p = &strand.params;
    let (q, v) = (&*strand.q, &*strand.v);
    v_new.copy_from_slice(v);
    // the Jacobian's factors are not a linearly implicit piece's (a pair solve assembles
    // its own)
    *ws.factors_piece = 0.0;
    let mut previous = f64::INFINITY;
    let mut converged = false;
    let mut touching = false;
    for iteration in 0..NEWTON_MAX_ITERATIONS {
        for i in 0..n {
            q_new[i] = q[i] + hh * v_new[i];
        }
        let (_, loaded) = assemble_terms(
            source,
            p,
            q_new,
            v_new,
            input,
            ws,
            contacts.as_deref_mut().map(|c| (c, t_end)),
            None,
            true,
        );
        touching = loaded;
        *iterations += 1;
        let mass = &*ws.assembly.mass;
        let mut scale = T::of(1e-300);
        let mut worst = T::zero();
        for i in 0..n {
            let mut mdv = T::zero();
            for j in 0..n {
                mdv += mass[j * n + i] * (v_new[j] - v[j]);
            }
            residual[i] = mdv - hh * ws.force[i];
            // the scale of the terms that cancel in the residual: at rest the net force
            // is zero while elasticity and gravity are not
            let elastic = p.stiffness[i] * (q_new[i] - p.natural[i]);
            let others = ws.force[i] + elastic;
            scale = scale
                .max(mdv.abs())
                .max((hh * elastic).abs())
                .max((hh * others).abs());
            worst = worst.max(residual[i].abs());
        }
        let relative = (worst / scale).as_f64();
        if relative <= NEWTON_TOLERANCE {
            converged = true;
            break;
        }
        if iteration >= 2 {
            let rate = relative / previous;
            let left = (NEWTON_MAX_ITERATIONS - 1 - iteration) as f64;
            // a NaN rate (a NaN residual) is no progress either
            let progressing = rate < 1.0;
            if !progressing || libm::log(NEWTON_TOLERANCE / relative) / libm::log(rate) > left {
                break;
            }
        }
        previous = relative;
        for j in 0..n {
            let (a, st, d, b) = (
                &mut ws.matrix_a[j],
                &ws.stiffness[j],
                &ws.damping[j],
                &ws.velocity_jacobian[j],
            );
            let m = &mass[j * n..j * n + n];
            for i in 0..n {
                a[i] = m[i] - hh * (d[i] - b[i]) - hh * hh * st[i];
            }
        }
        for i in 0..n {
            ws.rhs[i] = -residual[i];
        }
        if !scaled_lu_solve::<T, NC>(&mut ws.matrix_a, ws.rhs, ws.pivots, p.scale) {
            return NewtonOutcome::Unconverged;
        }
        for i in 0..n {
            v_new[i] += ws.rhs[i];
        }
    }
    if !converged {
        return NewtonOutcome::Unconverged;
    }
    for i in 0..n {
        q_new[i] = q[i] + hh * v_new[i];
    }
    if q_new.iter().chain(v_new.iter()).any(|x| !x.is_finite()) {
        return NewtonOutcome::Unconverged;
    }
    let rotation = max_element_rotation(p.lengths, q_new, q);
    strand.q.copy_from_slice(q_new);
    strand.v.copy_from_slice(v_new);
    NewtonOutcome::Converged(StepReport {
        max_element_rotation: rotation.as_f64(),
        projection: None,
        contacts_predicted: 0,
        loaded: touching,
    })
}
