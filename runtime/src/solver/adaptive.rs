//! The step of one strand and its adaptive splitting: an implicit step is checked after
//! the fact (failure, element rotation, energy balance) and split into halves,
//! recursively, when it is not acceptable; RK4 takes the step as it is.

use super::bdf2::{bdf2, record_history, BDF2_MAX_RATIO};
use super::energy_balance::{self, StateEnergy};
use super::free_root_momentum;
use super::linearly_implicit::linearly_implicit_euler;
use super::newton::newton_implicit_euler;
use super::predicted_contacts::resolve_again;
use super::rk4::rk4;
use super::stats::StepStats;
use super::system::{HeadInterval, StrandState, StrandSystem, StrandWorkspace};
use crate::config::IntegratorKind;
use superhelix_kernels::fixed::phase_cut;

pub use superhelix_kernels::energy::{
    energy_splits, loss_ratio, loss_split_levels, predicted_split_levels, rotation_split_levels,
    ENERGY_SPLIT_FRACTION, LOSS_SPLIT_FRACTION, MAX_ELEMENT_ROTATION, MAX_SUBSTEP_DEPTH,
    TRUSTED_ELEMENT_ROTATION, WORK_SPLIT_FRACTION,
};

/// Advance one strand's `state` over `interval` (from t by h) with the integrator of
/// the system's context; the head's states come from the interval (its two ends, and
/// the midpoint for RK4). Implicit steps are checked after the fact: split into halves,
/// recursively, when they fail, rotate an element by more than [`MAX_ELEMENT_ROTATION`]
/// or create energy ([`crate::solver::energy_balance`]), with the excess energy of the
/// deepest (or a nearly right) step removed from its velocities; Newton solves that do
/// not converge are replaced by the linearly implicit step (see `implicit_adaptive`; the
/// counts are in [`StepStats`]). On failure, returns the cause.
pub fn step(
    system: &mut StrandSystem,
    interval: &HeadInterval,
    state: &mut StrandState,
    stats: &mut StepStats,
) -> Result<(), String> {
    if super::one_step::covers(system) {
        return super::one_step::step(system, interval, state, stats);
    }
    system.workspace.solver.forget_repeat();
    if system.context.integrator == IntegratorKind::Rk4 {
        rk4(system, interval, state)?;
    } else {
        // a step that holds a change of the head's motion phase is taken as two, cut
        // there, so that an inertial phase's ceiling is its start's energy (`phase_cut`)
        let end = interval.t + interval.h;
        let mut piece = *interval;
        loop {
            let cut = phase_cut(interval.motion, piece.t, end);
            if let Some(b) = cut {
                piece = HeadInterval::new(interval.motion, piece.t, b - piece.t);
            }
            implicit_step(system, &piece, state, stats)?;
            match cut {
                Some(b) => piece = HeadInterval::new(interval.motion, b, end - b),
                None => break,
            }
        }
    }
    let (q, v) = (&state.q, &state.v);
    if let Some(i) = q.iter().chain(v.iter()).position(|x| !x.is_finite()) {
        let what = if i < q.len() { "q" } else { "q̇" };
        return Err(format!("non-finite {what}[{}] after the step", i % q.len()));
    }
    Ok(())
}

/// One implicit step over `interval` (within which the head keeps its motion phase),
/// checked and split ([`split`]). (A tolerance is the one step's: validation refuses it
/// with the integrators this step serves.)
fn implicit_step(
    system: &mut StrandSystem,
    interval: &HeadInterval,
    state: &mut StrandState,
    stats: &mut StepStats,
) -> Result<(), String> {
    let kind = system.context.integrator;
    // without the energy balance no energy is measured: the start's stands empty
    let (start, continued) = if system.context.energy_balance {
        start_energy(system, interval, state)
    } else {
        let ws = &system.workspace;
        (
            StateEnergy::default(),
            ws.last_q == state.q && ws.last_v == state.v,
        )
    };
    // the linearly implicit step starts as finely as its last step ended (the
    // other integrators take their own whole step first; a strand with contacts
    // tries its whole step, see `implicit_adaptive`)
    let levels = if continued
        && kind == IntegratorKind::LinearlyImplicitEuler
        && system.contacts.is_none()
    {
        system
            .workspace
            .split_hint
            .min(system.context.max_split_depth)
    } else {
        0
    };
    system.workspace.rotation_estimate = 0.0;
    system.workspace.loss_estimate = 0.0;
    let end = split(system, interval, state, &start, stats, levels)?;
    let ws = &mut system.workspace;
    ws.split_hint = predicted_split_levels(ws.rotation_estimate, ws.loss_estimate);
    ws.last_energy = Some(end);
    ws.last_q.copy_from_slice(&state.q);
    ws.last_v.copy_from_slice(&state.v);
    Ok(())
}

/// The energy of the state at the interval's start: the end of the previous step when it
/// is that state (the usual case; then true), measured otherwise.
pub(super) fn start_energy(
    system: &mut StrandSystem,
    interval: &HeadInterval,
    state: &StrandState,
) -> (StateEnergy, bool) {
    let t = interval.t;
    let ws = &system.workspace;
    let history = system.contacts.as_ref().is_some_and(|c| c.has_history());
    let partners = system.contacts.as_ref().is_some_and(|c| c.has_partners());
    if let Some(e) = ws.last_energy.filter(|_| !history || partners) {
        if (e.time - t).abs() <= 1e-12 * t.abs().max(1.0)
            && ws.last_q == state.q
            && ws.last_v == state.v
        {
            if !history {
                return (e, true);
            }
            // the partners moved since: the contact part measured again (equal to a fresh
            // measurement to round-off, at a fraction of its cost: what a strand among
            // hundreds of partners pays at every step); a history of anchors or
            // allowances alone is measured afresh
            let e =
                energy_balance::remeasure_contacts(system, &interval.start, &state.q, &state.v, &e);
            return (e, true);
        }
    }
    (
        energy_balance::measure(system, &interval.start, t, &state.q, &state.v),
        false,
    )
}

/// Largest l_Q |Δd_Q| between two states.
fn max_element_rotation(lengths: &[f64], q: &[f64], q0: &[f64]) -> f64 {
    lengths
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let d: f64 = (0..3).map(|i| (q[3 * k + i] - q0[3 * k + i]).powi(2)).sum();
            l * d.sqrt()
        })
        .fold(0.0, f64::max)
}

/// Steps of the bisection of [`pull_back`]: the step's change of q is kept to within
/// 2⁻¹⁰ of the largest fraction that balances.
const PULL_BACK_BISECTIONS: usize = 10;

/// At the deepest split, a step whose end has more potential energy than its bound
/// allows (so that no scaling of the velocities balances it): the largest fraction λ of
/// its change of q, `q₀ + λ (q − q₀)`, whose end the velocities can bring down to the
/// bound (bisection, [`PULL_BACK_BISECTIONS`] steps; the velocities as the solve left
/// them, limited by the caller), with its energy and balance. `None` (the state as it
/// was) when not even the start's configuration can be balanced. Energy evaluations
/// only, no solve: the step budget holds.
fn pull_back(
    system: &mut StrandSystem,
    interval: &HeadInterval,
    state: &mut StrandState,
    start: &StateEnergy,
    inertial: bool,
    to_bound: bool,
) -> Option<(StateEnergy, energy_balance::Balance)> {
    let time = interval.t + interval.h;
    // the solve's end (the step's scratch is free once its solve is done)
    let mut end_q = std::mem::take(&mut system.workspace.scratch[4]);
    end_q.clear();
    end_q.extend_from_slice(&state.q);
    let set = |system: &mut StrandSystem, state: &mut StrandState, lambda: f64| {
        let q0 = &system.workspace.saved_q;
        for ((x, a), b) in state.q.iter_mut().zip(q0).zip(&end_q) {
            *x = a + lambda * (b - a);
        }
        let end = energy_balance::measure(system, &interval.end, time, &state.q, &state.v);
        let balance = energy_balance::balance(start, &end, inertial);
        let ok = balance.limited_kinetic(&end, to_bound).is_some();
        (ok, end, balance)
    };
    let result = if set(system, state, 0.0).0 {
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..PULL_BACK_BISECTIONS {
            let mid = 0.5 * (lo + hi);
            if set(system, state, mid).0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let (_, end, balance) = set(system, state, lo);
        Some((end, balance))
    } else {
        state.q.copy_from_slice(&end_q);
        None
    };
    system.workspace.scratch[4] = end_q;
    result
}

/// The cause a run stops with when the deepest split of a step still rotates an element
/// by `rotation` (> [`MAX_ELEMENT_ROTATION`]) within its piece of `h` s from `t`.
fn unresolved_motion(rotation: f64, h: f64, t: f64) -> String {
    format!(
        "an element turns by {rotation:.2} rad within {h:.3e} s (from t = {t:.6} s), the shortest piece a step splits into ([simulation] dt / 2^{MAX_SUBSTEP_DEPTH}), beyond the {MAX_ELEMENT_ROTATION} rad a step can follow: the loads or the head accelerate the strand faster than the steps resolve, and limiting the step would take momentum away (the strand would no longer follow F = ma); lower [simulation] dt, or the loads"
    )
}

/// Scale the change of q since the step's start (`saved_q`) and the velocities by
/// `TRUSTED_ELEMENT_ROTATION / rotation`.
fn limit_rotation(system: &mut StrandSystem, state: &mut StrandState, rotation: f64) {
    let lambda = TRUSTED_ELEMENT_ROTATION / rotation;
    let q0 = &system.workspace.saved_q;
    for (x, x0) in state.q.iter_mut().zip(q0) {
        *x = x0 + lambda * (*x - x0);
    }
    for x in state.v.iter_mut() {
        *x *= lambda;
    }
}

/// One implicit step of `state` over `interval` (t to t + h; the state's energy at t is
/// `start`), checked after the fact and split into the interval's two halves
/// (recursively, at most [`MAX_SUBSTEP_DEPTH`] deep) when it is not acceptable. Returns
/// the energy of the end state.
///
/// - A Newton solve that does not converge (or meets a singular Jacobian) is never
///   accepted: the linearly implicit step of the same h replaces it, under the same checks
///   (counted in [`StepStats::newton_unconverged`]).
/// - A step that fails (a singular matrix, non-finite values) or rotates an element by
///   more than [`MAX_ELEMENT_ROTATION`] ([`TRUSTED_ELEMENT_ROTATION`] for BDF2 and for a
///   strand with contacts, whose numerical loss is not checked) is split;
///   at the deepest substep a failure is an error and a rotation beyond
///   [`TRUSTED_ELEMENT_ROTATION`] is limited to it. A rotation r splits into the 2^j pieces of
///   [`rotation_split_levels`] at once (r / 2^j within the limit): the levels between
///   would mostly be solved only to be rejected. A strand with contacts splits level by
///   level: a contact that starts or ends within the step makes its motion far from
///   uniform, and the pieces away from it pass at a coarser level (on the first 6 frames
///   of the 200-guide head of `scenes/full-head-smooth.toml` the jump took 3 % more
///   solves, 30,390 against 29,398, and 11 % more CPU time; starting each step as finely
///   as the last as well, 22 % more solves and 35 % more time).
/// - The energy balance ([`energy_balance::balance`]): E(end) must not exceed its bound
///   plus an allowance. With the head moving uniformly the bound is the ceiling (the
///   energy at the start of that phase less the estimated dissipation since, or E(start)
///   when higher) and the allowance round-off; otherwise E(start) plus the head's work W
///   (trapezoidal estimate) and the allowance covers the estimate's error. A step whose
///   excess is above [`ENERGY_SPLIT_FRACTION`] S (uniform head) or
///   [`WORK_SPLIT_FRACTION`] S (moving head) is split. A smaller excess, or any at the
///   deepest substep, is removed by scaling the velocities by the λ < 1 that brings E
///   down to the bound itself (`Balance::limited_kinetic`, [`StepStats::energy_limited`]): the exact dynamics
///   cannot gain more (friction and drag only dissipate), the excess of a first-order step
///   is its local error, so the correction is of the order of the error the step makes
///   anyway (it moves q̇ by excess / (2T) relative), and it is what keeps a step that
///   cannot resolve the motion from feeding energy in. When the potential energy alone
///   exceeds the bound, the step is split, or, at the deepest substep, accepted as it is
///   and counted ([`StepStats::energy_unbalanced`]), for the caller's own checks.
/// - The numerical loss ([`loss_ratio`]): with the head moving uniformly, a linearly or
///   Newton implicit Euler step of a strand without contacts that loses more than
///   [`LOSS_SPLIT_FRACTION`] S beyond the dissipation bound is split into the pieces of
///   [`loss_split_levels`] (counted in [`StepStats::energy_rejected`]). It keeps the
///   accuracy of fast inertial motion (a swinging strand) that a tighter rotation limit
///   bought by splitting every fast step.
fn implicit_adaptive(
    system: &mut StrandSystem,
    interval: &HeadInterval,
    state: &mut StrandState,
    start: &StateEnergy,
    stats: &mut StepStats,
) -> Result<StateEnergy, String> {
    let kind = system.context.integrator;
    let h = interval.h;
    let ws = &mut system.workspace;
    ws.saved_q.copy_from_slice(&state.q);
    ws.saved_v.copy_from_slice(&state.v);
    let prev_h = ws.prev_h;
    let max_depth = system.context.max_split_depth.min(MAX_SUBSTEP_DEPTH);
    let deepest = interval.depth >= max_depth;
    let unconverged_before = stats.newton_unconverged;
    if let Some(c) = system.contacts.as_mut() {
        // no contacts predicted for this solve yet
        c.predicted_mut().forget();
    }
    let mut outcome = match kind {
        IntegratorKind::NewtonImplicitEuler => {
            newton_implicit_euler(system, interval, state, stats)
        }
        // BDF2 takes whole steps; a step split for rotating too much is taken as linearly
        // implicit Euler substeps
        IntegratorKind::Bdf2
            if interval.depth == 0 && prev_h > 0.0 && h <= BDF2_MAX_RATIO * prev_h =>
        {
            bdf2(system, interval, state, stats)
        }
        _ => linearly_implicit_euler(system, interval, state, stats),
    };
    if kind == IntegratorKind::NewtonImplicitEuler
        && (outcome.is_err() || stats.newton_unconverged > unconverged_before)
    {
        // never accept an unconverged (or failed) Newton solve: take the linearly implicit
        // step instead, under the same checks
        stats.newton_unconverged = unconverged_before + 1;
        state.q.copy_from_slice(&system.workspace.saved_q);
        state.v.copy_from_slice(&system.workspace.saved_v);
        outcome = linearly_implicit_euler(system, interval, state, stats);
    }
    stats.attempts += 1;
    let finite = state.q.iter().chain(state.v.iter()).all(|x| x.is_finite());
    let mut rotation = if outcome.is_ok() && finite {
        max_element_rotation(
            &system.strand.geometry.lengths,
            &state.q,
            &system.workspace.saved_q,
        )
    } else {
        f64::INFINITY
    };
    // the numerical loss of a first-order step without contacts is checked (below): it
    // may rotate further. A strand with contacts keeps the tighter limit: at 0.8 rad a
    // wavy N = 5 strand under a bar on a head shaking at 5 Hz went 1.4 mm into it
    let rotation_limit = if kind == IntegratorKind::Bdf2 || system.contacts.is_some() {
        TRUSTED_ELEMENT_ROTATION
    } else {
        MAX_ELEMENT_ROTATION
    };
    // at the deepest split the contacts' approach check could not split the step: skipped
    let acceptable = outcome.is_ok()
        && finite
        && rotation <= rotation_limit
        && (deepest
            || match &mut system.contacts {
                Some(c) => c.step_acceptable(
                    &interval.at_start(),
                    &interval.at_end(),
                    &system.strand.geometry,
                    &system.workspace.saved_q,
                    &state.q,
                ),
                None => true,
            });
    let mut energy_levels = 0;
    if acceptable || deepest {
        outcome?;
        if !finite {
            return Err(format!(
                "non-finite state after a substep of {h:.3e} s (at the deepest split)"
            ));
        }
        if deepest
            && rotation > MAX_ELEMENT_ROTATION
            && system.contacts.is_none()
            && system.context.max_split_depth >= MAX_SUBSTEP_DEPTH
        {
            // the shortest piece the step splits into still turns an element beyond any
            // limit a step may take, with nothing pushing the strand out of a body: a load
            // (or the head, or a holder pulled out of reach) accelerates it faster than
            // the steps resolve. Limiting the rotation would take momentum away silently
            // (a free rod under a large load no longer follows F = ma): the run stops,
            // naming the cause
            if let Some(reach) = system.held.as_ref().and_then(|held| {
                held.beyond_reach(&system.strand.geometry, &state.q, interval.t + h)
            }) {
                return Err(reach.to_string());
            }
            // a free rod, or one under point loads: limiting would break F = ma. A strand
            // held at its root and released from a violent shape (the stress cases'
            // kinks, 3 rad an element) is limited instead: its root takes the momentum,
            // and what the limit takes is energy, which the balance allows
            if system.strand.geometry.floating || !system.strand.point_loads.is_empty() {
                return Err(unresolved_motion(rotation, h, interval.t));
            }
        }
        if deepest && rotation > rotation_limit {
            // the deepest split allowed still rotates an element beyond what an unchecked
            // step may: the change of q and the velocities are scaled to that limit (beyond
            // it the step's linearisation of M(q) and b no longer holds, and nothing splits
            // the step where it loses or creates energy)
            limit_rotation(system, state, rotation);
            stats.rotation_limited += 1;
            // the scaled end is checked for contacts again (its shape is not on the line
            // from the start to the solve's end: q → y(q) is not linear); what that adds
            // is limited too: the limit keeps the next step's linearisation, and with it
            // the run, stable (a strand that a body sweeps deep into within one step is
            // let out over several)
            if system.contacts.is_some() {
                resolve_again(
                    system,
                    &interval.at_end(),
                    &mut state.q,
                    &mut state.v,
                    stats,
                    false,
                )?;
                let again = max_element_rotation(
                    &system.strand.geometry.lengths,
                    &state.q,
                    &system.workspace.saved_q,
                );
                if again > TRUSTED_ELEMENT_ROTATION {
                    limit_rotation(system, state, again);
                }
            }
            rotation = TRUSTED_ELEMENT_ROTATION;
        }
        let ws = &mut system.workspace;
        ws.rotation_estimate = ws
            .rotation_estimate
            .max(rotation * (1u64 << interval.depth) as f64);
        if !system.context.energy_balance {
            record_history(kind, &mut system.workspace, h);
            return Ok(*start);
        }
        let end =
            energy_balance::measure(system, &interval.end, interval.t + h, &state.q, &state.v);
        // contacts with what moves relative to the head (a world body while the head
        // moves, a body on its own motion, other strands) do work: the step is then
        // balanced against work
        let bodies_work = system
            .contacts
            .as_ref()
            .is_some_and(|c| c.moves_relative(&interval.at_start(), &interval.at_end()));
        let inertial = interval.uniform
            && !bodies_work
        // follower loads work without a potential, and a driven holder works
        && !system.strand.has_follower_loads()
        && !system.held.as_ref().is_some_and(|h| h.is_driven());
        let balance = energy_balance::balance(start, &end, inertial);
        let excess = balance.excess;
        // beyond the trusted rotation the energy asks for pieces too (only first-order
        // steps without contacts rotate that far: `rotation_limit`); the loss of the
        // pieces predicts the next step
        let splits = energy_splits(&balance, start, &end, rotation, interval.depth, deepest);
        let ws = &mut system.workspace;
        ws.loss_estimate = ws
            .loss_estimate
            .max(splits.loss * (1u64 << (2 * interval.depth)) as f64);
        energy_levels = splits
            .levels()
            .min(max_depth.saturating_sub(interval.depth));
        // an accepted step: its end bounds the next, and it is BDF2's history
        let accept = |ws: &mut StrandWorkspace, mut end: StateEnergy| {
            end.ceiling = energy_balance::end_ceiling(start, &end, inertial);
            record_history(kind, ws, h);
            Ok(end)
        };
        if energy_levels == 0 && excess <= 0.0 {
            return accept(&mut system.workspace, end);
        }
        let fraction = if inertial {
            ENERGY_SPLIT_FRACTION
        } else {
            WORK_SPLIT_FRACTION
        };
        let split = energy_levels > 0 || (!deepest && excess > fraction * start.scale);
        let (mut end, mut balance) = (end, balance);
        if !split && deepest && balance.limited_kinetic(&end, !bodies_work).is_none() {
            // the potential energy alone is above what the step may end with, and the step
            // cannot be split further: its change of q is pulled back towards the start
            // until the velocities can bring E down to the bound
            if let Some((e, b)) = pull_back(system, interval, state, start, inertial, !bodies_work)
            {
                (end, balance) = (e, b);
                stats.energy_pulled_back += 1;
            }
        }
        if !split {
            // the kinetic energy that brings E down to the bound (to its allowance's edge
            // when moving bodies work, see `limited_kinetic`)
            if let Some(kinetic) = balance.limited_kinetic(&end, !bodies_work) {
                let lambda = if free_root_momentum::applies(system) {
                    // a free strand keeps its momentum: its motion about the centre of
                    // mass is scaled
                    free_root_momentum::scale_to_kinetic(
                        system,
                        &state.q,
                        &mut state.v,
                        end.kinetic,
                        kinetic,
                    )
                } else {
                    let lambda = (kinetic / end.kinetic).sqrt();
                    for x in state.v.iter_mut() {
                        *x *= lambda;
                    }
                    lambda
                };
                end.scale_velocities(lambda);
                stats.energy_limited += 1;
                return accept(&mut system.workspace, end);
            }
            if deepest {
                stats.energy_unbalanced += 1;
                return accept(&mut system.workspace, end);
            }
        }
        stats.energy_rejected += 1;
    }
    state.q.copy_from_slice(&system.workspace.saved_q);
    state.v.copy_from_slice(&system.workspace.saved_v);
    // a step rejected for its rotation alone goes down as many levels as the rotation
    // asks for at once; with contacts, level by level (the motion within a step is then
    // far from uniform: a contact starts or ends in it, and the quiet pieces pass coarse)
    let levels = if !acceptable
        && system.contacts.is_none()
        && rotation.is_finite()
        && rotation > rotation_limit
    {
        rotation_split_levels(rotation, rotation_limit, interval.depth)
            .min(max_depth - interval.depth)
    } else {
        energy_levels.max(1)
    };
    if system.context.explicit_field_stiffness {
        // with the field stiffness explicit, a step that must be split is one the explicit
        // stiffness may not resolve at any substep (energy created by the contact forces'
        // curvature on the twist, whose inertia is small; a strand thrown into a body):
        // its pieces take the projected stiffness
        system.context.explicit_field_stiffness = false;
        let end = split(system, interval, state, start, stats, levels);
        system.context.explicit_field_stiffness = true;
        return end;
    }
    split(system, interval, state, start, stats, levels)
}

/// `interval` halved `levels` times (each halving counted in [`StepStats::substeps`]),
/// its pieces stepped in order by [`implicit_adaptive`].
fn split(
    system: &mut StrandSystem,
    interval: &HeadInterval,
    state: &mut StrandState,
    start: &StateEnergy,
    stats: &mut StepStats,
    levels: usize,
) -> Result<StateEnergy, String> {
    if levels == 0 {
        return implicit_adaptive(system, interval, state, start, stats);
    }
    stats.substeps += 1;
    let first = interval.first_half();
    let middle = split(system, &first, state, start, stats, levels - 1)?;
    let middle = between_steps(system, &first, state, middle);
    let second = interval.second_half(&first);
    split(system, &second, state, &middle, stats, levels - 1)
}

/// Between two accepted steps within a step of the scene (error-controlled steps, and the
/// pieces of a split fixed step), the contacts' bookkeeping of `piece`'s end, as the scene
/// does after its own step: the Coulomb anchors stick, slide or let go, and the allowances
/// of the points that started inside a body shrink. A sliding point's anchor is dragged
/// behind it at every accepted step, not once per step of the scene: held where the
/// scene's step began, the kinetic force of every point that slid on within the step, or
/// newly touched, would be missing or spent: a rope run over a drum beyond its holding
/// ratio ran up to twice as far as the sliding law allows under the error control. The
/// start energy of the next piece (`end`) is measured again where the anchors moved.
pub(super) fn between_steps(
    system: &mut StrandSystem,
    piece: &HeadInterval,
    state: &StrandState,
    end: StateEnergy,
) -> StateEnergy {
    let Some(c) = system.contacts.as_mut() else {
        return end;
    };
    c.after_step(&piece.at_end(), &system.strand.geometry, &state.q, piece.h);
    if !system.context.energy_balance || !c.has_history() {
        return end;
    }
    energy_balance::remeasure_contacts(system, &piece.end, &state.q, &state.v, &end)
}
