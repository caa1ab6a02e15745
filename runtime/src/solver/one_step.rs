//! The runtime engine's strands on the one step of `superhelix-kernels`
//! (`superhelix_kernels::fixed::step_views`, `step_to_tolerance_views`): the checked
//! step of every implicit integrator — linearly implicit Euler, Newton-iterated implicit
//! Euler, BDF2 — with the split rule, the energy balance, the pull-back, the field
//! stiffness's split or projection, and the error-controlled step, written once for
//! every engine, here on the runtime's own storage (the strand's q and q̇, its
//! parameters and kept state lent as a `StrandView`, a workspace per thread and N as the
//! `WorkView`) with the strand's kernel as its terms ([`KernelTerms`]), its contacts and
//! held tip as the step's hooks ([`ContactHook`], [`HeldHook`]). RK4 is the runtime's
//! own (`super::rk4`).

use super::contact_hook::ContactHook;
use super::held_end::HeldHook;
use super::stats::StepStats;
use super::system::{HeadInterval, StrandState, StrandSystem};
use crate::config::IntegratorKind;
use crate::kernels::step_terms::KernelTerms;
use std::cell::RefCell;
use superhelix_kernels::field_split::FieldRule;
use superhelix_kernels::fixed::{
    factor_step_views, step_to_tolerance_views, step_views, ContactHooks, Effects, HistoryView,
    StepCounts, StepInput, ToleranceReport,
};
use superhelix_kernels::storage::heap::HeapWorkspace;
use superhelix_kernels::storage::{ParamsView, StrandView};

thread_local! {
    /// The step's scratch, one per thread and number of elements (it holds nothing from
    /// one step to the next).
    static WORKSPACES: RefCell<Vec<HeapWorkspace>> = const { RefCell::new(Vec::new()) };
}

/// Whether the one step takes this strand's steps: every implicit integrator (linearly
/// implicit Euler, Newton-iterated implicit Euler, BDF2) with fixed steps, or the
/// error-controlled step (with or without the energy balance), its root clamped, pinned (the joint's coordinates scaled as the runtime's
/// solver scales them, `ParamsView::scale`) or free (the root's translation after the
/// chain's coordinates, its momentum kept by the step). Point loads, and the charges'
/// forces of electrostatics with them, are the one step's, and so is a held tip, through
/// [`HeldHook`] (the scene allows it the linearly implicit Euler step with fixed steps),
/// and so are contacts with bodies and hair–hair contacts, through [`ContactHook`]
/// (with `coupling = "pair"` the factors of the step's last piece kept for the pair
/// solve).
pub fn covers(system: &StrandSystem) -> bool {
    let ctx = &system.context;
    matches!(
        ctx.integrator,
        IntegratorKind::LinearlyImplicitEuler
            | IntegratorKind::Bdf2
            | IntegratorKind::NewtonImplicitEuler
    )
}

/// Advance a strand that [`covers`] takes over `interval` (the head's phase changes cut
/// within: the one step lands on them), its counts added to `stats`.
pub fn step(
    system: &mut StrandSystem,
    interval: &HeadInterval,
    state: &mut StrandState,
    stats: &mut StepStats,
) -> Result<(), String> {
    let StrandSystem {
        strand,
        kernel,
        workspace: ws,
        context: ctx,
        held,
        contacts,
    } = system;
    let n = state.q.len();
    // the state the last step ended in, or one set from outside (its energy measured
    // afresh)
    if ws.last_q != state.q || ws.last_v != state.v {
        ws.last_energy = None;
    }
    let mut split_hint = u8::try_from(ws.split_hint).unwrap_or(u8::MAX);
    let g = &strand.geometry;
    let ((basis, basis_k, basis_negative), scale) = ws.solver.projection_basis_parts();
    let params = ParamsView {
        root_position: g.root_position,
        root_frame: g.root_frame,
        lengths: &g.lengths,
        natural: &strand.natural,
        stiffness: &ws.stiffness,
        friction: &ws.friction,
        mass_per_length: g.mass_per_length,
        air_drag: strand.air_drag,
        rotary_inertia: g.rotary_inertia,
        loads: &strand.point_loads,
        // a pinned root's joint: its coordinates in the solver's units (θ = l₀ d₀)
        scale,
    };
    let mut view = StrandView {
        params,
        q: &mut state.q,
        v: &mut state.v,
        basis,
        basis_k,
        basis_negative,
        split_hint: &mut split_hint,
        last_energy: &mut ws.last_energy,
        history: None,
        end: None,
    };
    // a held tip: the one step's hook on the runtime's constraint
    let mut held = held.as_mut().map(|tip| HeldHook {
        tip,
        geometry: &strand.geometry,
    });
    if let Some(hook) = held.as_mut() {
        view.end = Some(hook);
    }
    let effects = Effects {
        gravity: ctx.effects.gravity,
        head_moves: ctx.effects.head_moves,
    };
    let rule = if ctx.explicit_field_stiffness {
        FieldRule::Explicit
    } else if ctx.field_split {
        FieldRule::Split
    } else {
        FieldRule::Projected
    };
    let mut counts = StepCounts::default();
    let mut report = ToleranceReport::default();
    // contacts: the one step's hooks on the runtime's storage
    // a strand in pairs of `coupling = "pair"`: the simulation solves the pairs after
    // the steps on the factors of each one's last piece, and does the contacts'
    // bookkeeping of the step's end after that
    let coupled = contacts
        .as_ref()
        .is_some_and(|c| c.hair_params().is_some_and(|p| p.coupled));
    let mut contacts = contacts.as_mut().map(|contacts| ContactHook {
        contacts,
        geometry: &strand.geometry,
        jac: &mut ws.jac,
        last_contact: &mut ws.last_contact,
        end_deferred: coupled.then_some(interval.t + interval.h),
    });
    let kept_factors = &mut ws.one_step_factors;
    let mut source = KernelTerms::new(kernel.as_mut(), &mut ws.terms, &mut ws.flat);
    let mut history = HistoryView {
        q: &mut ws.prev_q,
        v: &mut ws.prev_v,
        h: &mut ws.prev_h,
        next_h: &mut ws.error_control.next_h,
    };
    let outcome = WORKSPACES.with(|cell| {
        let mut pool = cell.borrow_mut();
        let elements = n / 3;
        let k = match pool.iter().position(|w| w.elements() == elements) {
            Some(k) => k,
            None => {
                pool.push(HeapWorkspace::new());
                pool.len() - 1
            }
        };
        let work = &mut pool[k];
        work.set_field_rule(rule);
        work.set_max_split_depth(ctx.max_split_depth);
        work.set_energy_balance(ctx.energy_balance);
        work.set_newton(ctx.integrator == IntegratorKind::NewtonImplicitEuler);
        let outcome = match ctx.tolerance {
            None => {
                // BDF2 with fixed steps: its history lent with the strand
                if ctx.integrator == IntegratorKind::Bdf2 {
                    view.history = Some(history);
                }
                step_views(
                    &mut source,
                    &mut view,
                    interval.motion,
                    &effects,
                    interval.t,
                    interval.h,
                    work.view(elements),
                    &mut counts,
                    contacts.as_mut().map(|c| c as &mut dyn ContactHooks<f64>),
                )
            }
            Some(tolerance) => step_to_tolerance_views(
                &mut source,
                &mut view,
                &mut history,
                interval.motion,
                &effects,
                (interval.t, interval.h),
                tolerance,
                work.view(elements),
                &mut report,
                contacts.as_mut().map(|c| c as &mut dyn ContactHooks<f64>),
            ),
        };
        if coupled && outcome.is_ok() {
            let own = work.last_factors().is_some();
            if !own {
                // the step's last solve was BDF2's or Newton's: the linearly implicit
                // step's matrix at its end, factored for the pair solve
                let input = StepInput {
                    head: interval.end,
                    gravity: effects.gravity,
                    head_moves: effects.head_moves,
                };
                factor_step_views(
                    &mut source,
                    &mut view,
                    &input,
                    (interval.h, interval.t + interval.h),
                    work.view(elements),
                    contacts.as_mut().map(|c| c as &mut dyn ContactHooks<f64>),
                );
            }
            kept_factors.keep(work.last_factors(), view.params.scale, own);
        }
        outcome
    });
    ws.error_control.record(&report);
    stats.error_steps += report.steps;
    stats.error_rejected += report.rejected;
    stats.error_rejected_deep += report.rejected_deep;
    stats.attempts += report.solves;
    stats.energy_limited += report.energy_limited;
    stats.field_split += report.field_split;
    stats.field_projected += report.field_projected;
    stats.field_undamped += report.field_undamped;
    stats.contacts_predicted += report.contacts_predicted;
    ws.split_hint = usize::from(split_hint);
    stats.substeps += counts.substeps;
    stats.attempts += counts.attempts;
    stats.energy_rejected += counts.energy_rejected;
    stats.energy_limited += counts.energy_limited;
    stats.energy_unbalanced += counts.energy_unbalanced;
    stats.energy_pulled_back += counts.energy_pulled_back;
    stats.field_split += counts.field_split;
    stats.field_projected += counts.field_projected;
    stats.field_undamped += counts.field_undamped;
    stats.contacts_predicted += counts.contacts_predicted;
    stats.rotation_limited += counts.rotation_limited;
    stats.newton_iterations += counts.newton_iterations;
    stats.newton_unconverged += counts.newton_unconverged;
    outcome.map_err(|e| e.to_string())?;
    ws.last_q.copy_from_slice(&state.q);
    ws.last_v.copy_from_slice(&state.v);
    Ok(())
}
