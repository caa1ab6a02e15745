//! The variable-step two-step BDF (BDF2) on the linearly implicit Euler step's matrix,
//! the `bdf2` integrator of both engines (its history lent with the strand,
//! `StrandView::history`; contacts and point loads in its solve as in the linearly
//! implicit one's).

use super::contacts::ContactHooks;
use super::step::{
    assemble, max_element_rotation, non_finite, scaled_lu_solve, solve_factored_f64, step_matrix,
    StepError, StepInput, StepReport,
};
use super::workspace::FixedWorkspace;
use super::FixedStrand;
use crate::float::Float;
use crate::storage::{StrandView, WorkView};
use crate::strand_terms::{MomentSource, PointsOf, StepTerms};

/// Largest ratio of a BDF2 step to the step before it: variable-step BDF2 is zero-stable only for ratios
/// below 1 + √2 (Grigorieff 1983; Hairer, Nørsett & Wanner, *Solving ODEs I*, III.5); a
/// step split once and then resumed has ratio 2. Beyond it a linearly implicit Euler step
/// restarts the scheme.
pub const BDF2_MAX_RATIO: f64 = 2.0;

/// The state a BDF2 step continues from besides the strand's: the state one step
/// earlier and the length of the step between the two.
#[derive(Debug, Clone, Copy)]
pub struct Bdf2History<'a, T: Float = f64> {
    /// q one step before the strand's present state (3N).
    pub q: &'a [T],
    /// q̇ one step before the strand's present state (3N).
    pub v: &'a [T],
    /// The length of that step, s (> 0).
    pub h: f64,
}

/// Advance `strand` by `h` seconds by one step of the variable-step two-step BDF
/// (Hairer, Nørsett & Wanner, *Solving ODEs I*, III.5) on the equations of motion
/// (paper eq. 6), `q̇ = v`, `M(q) v̇ = F(q, v)`, from the strand's state y = (q, q̇) and
/// the one before it, y₋ = (`previous.q`, `previous.v`), a step `previous.h` earlier.
/// With ω = h / h₋,
///
/// ```text
/// y⁺ − a₁ y + a₂ y₋ = β h f(t + h, y⁺),   a₁ = (1+ω)²/(1+2ω), a₂ = ω²/(1+2ω), β = (1+ω)/(1+2ω)
/// ```
///
/// linearised once about the extrapolation ỹ = y + ω (y − y₋) with the linearly implicit
/// Euler step's treatment of the terms ([`super::linearly_implicit`]) at the step βh:
///
/// ```text
/// (M̃ − βh D_v + (βh/2) B̃ − β²h² D_q) q̇⁺ = M̃ q̇̂ + βh (F̃ + b̃ − D_v q̇̃ + D_q (q̂ − q̃))
/// q⁺ = q̂ + βh q̇⁺,      ŷ = a₁ y − a₂ y₋
/// ```
///
/// Second order whatever the Jacobian's error (what the linearisation leaves out is
/// multiplied by y⁺ − ỹ = O(h²)), L-stable, one assembly and one LU solve. Variable-step
/// BDF2 is zero-stable for ω below 1 + √2; the error-controlled step
/// ([`super::step_to_tolerance`]) keeps ω ≤ 2. Allocates nothing; on failure the strand
/// keeps its state.
pub fn bdf2<
    S: MomentSource<T>,
    const N: usize,
    const D: usize,
    const E: usize,
    const B: usize,
    T: Float,
>(
    source: &S,
    strand: &mut FixedStrand<N, D, B, T>,
    previous: &Bdf2History<'_, T>,
    input: &StepInput,
    h: f64,
    ws: &mut FixedWorkspace<N, D, E, T>,
) -> Result<StepReport, StepError> {
    let mut ws = ws.view();
    let stack = ws.take_stack();
    bdf2_step(
        &mut &*source,
        &mut strand.view(),
        previous,
        input,
        h,
        &mut ws,
        stack,
        None,
    )
}

/// [`bdf2`] on any storage (`stack`: six vectors of n), with contacts: their terms at
/// the extrapolated state with the colliders placed at the step's end, time `t`
/// (`contacts = Some((hooks, t))`), and the contacts that start within the step
/// predicted along the solution and resolved on the step's factors (at the step βh).
#[allow(clippy::too_many_arguments)]
pub(crate) fn bdf2_step<'c, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    strand: &mut StrandView<'_, T>,
    previous: &Bdf2History<'_, T>,
    input: &StepInput,
    h: f64,
    ws: &mut WorkView<'_, T, NC>,
    stack: &mut [T],
    contacts: Option<(&mut (dyn ContactHooks<T> + 'c), f64)>,
) -> Result<StepReport, StepError> {
    if !(h.is_finite() && h > 0.0 && previous.h.is_finite() && previous.h > 0.0) {
        return Err(StepError::TimeStep);
    }
    let n = crate::storage::sized::<NC>(strand.dofs());
    if previous.q.len() != n || previous.v.len() != n {
        return Err(StepError::TimeStep);
    }
    let w = h / previous.h;
    let beta = (1.0 + w) / (1.0 + 2.0 * w);
    let a1 = T::of((1.0 + w) * (1.0 + w) / (1.0 + 2.0 * w));
    let a2 = T::of(w * w / (1.0 + 2.0 * w));
    let bh = T::of(beta * h);
    let w = T::of(w);
    let (qt, stack) = stack.split_at_mut(n);
    let (vt, stack) = stack.split_at_mut(n);
    let (qh, stack) = stack.split_at_mut(n);
    let (vh, stack) = stack.split_at_mut(n);
    let (dq, stack) = stack.split_at_mut(n);
    {
        let (q, v) = (&*strand.q, &*strand.v);
        for i in 0..n {
            qt[i] = q[i] + w * (q[i] - previous.q[i]);
            vt[i] = v[i] + w * (v[i] - previous.v[i]);
            qh[i] = a1 * q[i] - a2 * previous.q[i];
            vh[i] = a1 * v[i] - a2 * previous.v[i];
        }
    }
    let mut contacts = contacts;
    let (field_stiffness, loaded) = assemble(
        source,
        &strand.params,
        qt,
        vt,
        input,
        ws,
        contacts.as_mut().map(|(c, t)| (&mut **c, *t)),
        None,
    );
    let (projection, use_h) = step_matrix(strand, field_stiffness, loaded, bh, ws, stack);
    let p = &strand.params;
    // D_q (q̂ − q̃), D_q = H⁻ − K
    for i in 0..n {
        dq[i] = -p.stiffness[i] * (qh[i] - qt[i]);
    }
    if use_h {
        for j in 0..n {
            let xj = qh[j] - qt[j];
            let col = &ws.stiffness[j];
            for i in 0..n {
                dq[i] += col[i] * xj;
            }
        }
    }
    for i in 0..n {
        ws.rhs[i] = bh * (ws.force[i] + ws.velocity_term[i] + dq[i]);
    }
    let mass = &*ws.assembly.mass;
    for j in 0..n {
        let (m, d) = (&mass[j * n..j * n + n], &ws.damping[j]);
        for i in 0..n {
            ws.rhs[i] += m[i] * vh[j] - bh * d[i] * vt[j];
        }
    }
    *ws.factors_piece = 0.0;
    if !scaled_lu_solve::<T, NC>(&mut ws.matrix_a, ws.rhs, ws.pivots, p.scale) {
        return Err(StepError::SingularMatrix);
    }
    let q_new = qh;
    for i in 0..n {
        q_new[i] += bh * ws.rhs[i];
    }
    let mut contacts_predicted = 0;
    if let Some((c, t)) = contacts {
        // the contacts that start within the step, predicted along the solution from
        // the extrapolation and resolved on the step's factors
        c.predict(qt, q_new, t, &input.head);
        let (a, pivots, v_new) = (&ws.matrix_a, &*ws.pivots, &mut *ws.rhs);
        let mut solve = |x: &mut [f64]| solve_factored_f64(a, pivots, p.scale, x, stack);
        let bh = bh.as_f64();
        let mut points = PointsOf {
            source: &mut *source,
            shape: p.shape(),
            scratch: &mut ws.points,
        };
        contacts_predicted = c
            .resolve(
                &mut points,
                q_new,
                v_new,
                Some((bh, bh)),
                t,
                &input.head,
                &mut solve,
            )
            .map_err(|_| StepError::SingularMatrix)?;
    }
    if let Some(e) = non_finite(q_new, ws.rhs) {
        return Err(e);
    }
    let rotation = max_element_rotation(p.lengths, q_new, strand.q);
    strand.q.copy_from_slice(q_new);
    strand.v.copy_from_slice(ws.rhs);
    Ok(StepReport {
        max_element_rotation: rotation.as_f64(),
        projection,
        contacts_predicted,
        loaded,
    })
}
