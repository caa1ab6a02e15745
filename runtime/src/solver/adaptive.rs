//! The step of one strand: the implicit integrators on the one step of
//! `superhelix-kernels` ([`super::one_step`]: the checked step's split rule and energy
//! balance, BDF2, Newton's solves and the error-controlled step, written once for every
//! engine), RK4 ([`super::rk4`]) as it is, without checks after the fact.

use super::rk4::rk4;
use super::stats::StepStats;
use super::system::{HeadInterval, StrandState, StrandSystem};

/// Advance one strand's `state` over `interval` (from t by h) with the integrator of
/// the system's context; the head's states come from the interval (its two ends, and
/// the midpoint for RK4). The implicit integrators take the one step
/// (`superhelix_kernels::fixed::step_views`, `step_to_tolerance_views`): checked after
/// the fact and split into halves, recursively, when they fail, rotate an element too
/// far or create energy, with the excess energy of the deepest (or a nearly right)
/// step removed from its velocities (the counts are in [`StepStats`]). On failure,
/// returns the cause.
pub fn step(
    system: &mut StrandSystem,
    interval: &HeadInterval,
    state: &mut StrandState,
    stats: &mut StepStats,
) -> Result<(), String> {
    if super::one_step::covers(system) {
        return super::one_step::step(system, interval, state, stats);
    }
    rk4(system, interval, state)?;
    let (q, v) = (&state.q, &state.v);
    if let Some(i) = q.iter().chain(v.iter()).position(|x| !x.is_finite()) {
        let what = if i < q.len() { "q" } else { "q̇" };
        return Err(format!("non-finite {what}[{}] after the step", i % q.len()));
    }
    Ok(())
}
