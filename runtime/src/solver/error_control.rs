//! The error-controlled step (`[simulation] tolerance`): each strand chooses its own
//! steps within every time step of the scene so that the estimated local error stays
//! below the tolerance.
//!
//! The scheme is the linearly implicit Euler step of [`super::linearly_implicit`]
//! extrapolated once (Richardson; the first level of Deuflhard's extrapolated linearly
//! implicit Euler, LIMEX): a step of h gives `y₁`, two steps of h/2 give `y₂`, and the
//! step keeps `2 y₂ − y₁` for q and q̇, second order, and as stable as the step it
//! extrapolates (its stability function `2/(1 − z/2)² − 1/(1 − z)` vanishes as
//! z → −∞: L-stable). The error estimate is the distance between the two solutions on
//! the centreline,
//!
//! ```text
//! err = max over the element ends |y(q₂) − y(q₁)| / L
//! ```
//!
//! (positions in the head's frame, L the strand's length): the error of the two half
//! steps, which bounds that of the extrapolated state the step keeps. A step is accepted
//! when `err ≤ τ` and the next is `h · clamp(0.9 (τ/err)^½, 0.2, 2)` (rejected: retried
//! at that size); a strand's steps end on the scene's time steps (so frames land on
//! their output times) and its step size carries over to the next. Each step costs
//! three solves. Only the linearly implicit Euler step can be extrapolated this way;
//! the energy balance, the rotation limit and the step splitting of
//! [`super::adaptive`] do not act on these steps (the error control takes their place).
//!
//! Measured on the study's `swing` (a straight 20 cm strand released horizontal, N = 5,
//! 0.5 s, against the same scheme at τ = 1e-10): the largest error of the tip over L
//! is 0.5 to 1.7 τ for τ from 1e-1 to 1e-5 with the preset's friction and drag, and up
//! to 11 τ without any (`runtime/tests/error_control.rs`).

use super::linearly_implicit::linearly_implicit_euler;
use super::stats::StepStats;
use super::system::{HeadInterval, StrandState, StrandSystem};
use crate::model::reconstruction::Pose;
use nalgebra::{Matrix3, Vector3};

/// Smallest factor the step size may shrink by after a step.
const SHRINK: f64 = 0.2;
/// Largest factor the step size may grow by after a step.
const GROW: f64 = 2.0;
/// Safety factor of the controller.
const SAFETY: f64 = 0.9;
/// A step shorter than this, s, is accepted whatever its error.
const MIN_STEP: f64 = 1e-9;

/// One strand's state of the error-controlled step, and its buffers (sized at the first
/// step).
#[derive(Debug, Clone, Default)]
pub struct ErrorControl {
    /// The step size to try next, s (0: none yet).
    pub next_h: f64,
    /// The smallest step accepted so far, s (0: none).
    pub smallest_h: f64,
    /// The largest estimated error of an accepted step so far, relative to the length.
    pub largest_error: f64,
    /// What the accepted steps since the last [`ErrorControl::take_window`] did.
    window: StepWindow,
    start_q: Vec<f64>,
    start_v: Vec<f64>,
    full_q: Vec<f64>,
    full_v: Vec<f64>,
    ends_full: Vec<Pose>,
    ends_half: Vec<Pose>,
}

/// What one strand's accepted error-controlled steps did over a stretch of time (a frame).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepWindow {
    /// The largest estimated error of a step, relative to the strand's length.
    pub largest_error: f64,
    /// The smallest step, s (0: no step).
    pub smallest_h: f64,
    /// The largest step, s.
    pub largest_h: f64,
}

impl StepWindow {
    fn add(&mut self, error: f64, h: f64) {
        self.largest_error = self.largest_error.max(error);
        self.smallest_h = if self.smallest_h > 0.0 {
            self.smallest_h.min(h)
        } else {
            h
        };
        self.largest_h = self.largest_h.max(h);
    }

    /// Both windows as one.
    pub fn merge(&self, other: &StepWindow) -> StepWindow {
        let mut m = *self;
        if other.smallest_h > 0.0 {
            m.add(other.largest_error, other.smallest_h);
            m.largest_h = m.largest_h.max(other.largest_h);
        }
        m
    }
}

impl ErrorControl {
    /// What the accepted steps did since the last call (or the start), and start anew.
    pub fn take_window(&mut self) -> StepWindow {
        std::mem::take(&mut self.window)
    }
}

/// Advance `state` over `interval` in error-controlled steps of tolerance `tolerance`
/// (see the module page). Counts every solve in [`StepStats::attempts`], accepted steps
/// in [`StepStats::error_steps`] and rejected ones in [`StepStats::error_rejected`].
pub fn step(
    system: &mut StrandSystem,
    interval: &HeadInterval,
    state: &mut StrandState,
    stats: &mut StepStats,
    tolerance: f64,
) -> Result<(), String> {
    let n = state.q.len();
    let mut ec = std::mem::take(&mut system.workspace.error_control);
    if ec.start_q.len() != n {
        let ends = system.strand.geometry.lengths.len() + 1;
        let pose = Pose {
            position: Vector3::zeros(),
            frame: Matrix3::identity(),
        };
        ec.start_q = vec![0.0; n];
        ec.start_v = vec![0.0; n];
        ec.full_q = vec![0.0; n];
        ec.full_v = vec![0.0; n];
        ec.ends_full = vec![pose; ends];
        ec.ends_half = vec![pose; ends];
    }
    let result = advance(system, interval, state, stats, tolerance, &mut ec);
    system.workspace.error_control = ec;
    result
}

fn advance(
    system: &mut StrandSystem,
    interval: &HeadInterval,
    state: &mut StrandState,
    stats: &mut StepStats,
    tolerance: f64,
    ec: &mut ErrorControl,
) -> Result<(), String> {
    let end = interval.t + interval.h;
    let mut t = interval.t;
    let mut h = if ec.next_h > 0.0 {
        ec.next_h
    } else {
        interval.h
    };
    let length = system.strand.geometry.length();
    let n = state.q.len();
    // the last step ends on the interval's end exactly
    while end - t > 1e-12 * end.abs().max(1.0) {
        let last = h >= end - t;
        let hh = if last { end - t } else { h };
        ec.start_q.copy_from_slice(&state.q);
        ec.start_v.copy_from_slice(&state.v);
        let whole = if last && t == interval.t {
            *interval
        } else {
            HeadInterval::new(interval.motion, t, hh)
        };
        let predicted = stats.contacts_predicted;
        linearly_implicit_euler(system, &whole, state, stats)?;
        let mut touched = touches(system);
        ec.full_q.copy_from_slice(&state.q);
        ec.full_v.copy_from_slice(&state.v);
        state.q.copy_from_slice(&ec.start_q);
        state.v.copy_from_slice(&ec.start_v);
        let first = whole.first_half();
        linearly_implicit_euler(system, &first, state, stats)?;
        touched |= touches(system);
        linearly_implicit_euler(system, &whole.second_half(&first), state, stats)?;
        touched |= touches(system) || stats.contacts_predicted != predicted;
        stats.attempts += 3;
        system.kernel.element_ends(&ec.full_q, &mut ec.ends_full);
        system.kernel.element_ends(&state.q, &mut ec.ends_half);
        let error = ec
            .ends_full
            .iter()
            .zip(&ec.ends_half)
            .map(|(a, b)| (a.position - b.position).norm())
            .fold(0.0, f64::max)
            / length;
        if !error.is_finite() {
            return Err(format!(
                "error-controlled step: non-finite error estimate at t = {t:.6e} s"
            ));
        }
        let factor = if error > 0.0 {
            (SAFETY * (tolerance / error).sqrt()).clamp(SHRINK, GROW)
        } else {
            GROW
        };
        if error <= tolerance || hh <= MIN_STEP {
            if !touched {
                for i in 0..n {
                    state.q[i] = 2.0 * state.q[i] - ec.full_q[i];
                    state.v[i] = 2.0 * state.v[i] - ec.full_v[i];
                }
            }
            stats.error_steps += 1;
            ec.largest_error = ec.largest_error.max(error);
            ec.window.add(error, hh);
            ec.smallest_h = if ec.smallest_h > 0.0 {
                ec.smallest_h.min(hh)
            } else {
                hh
            };
            t = if last { end } else { t + hh };
            // a step cut short to end on the interval does not shrink the next
            h = if last {
                h.max(hh * factor)
            } else {
                hh * factor
            };
        } else {
            state.q.copy_from_slice(&ec.start_q);
            state.v.copy_from_slice(&ec.start_v);
            stats.error_rejected += 1;
            h = hh * factor;
        }
    }
    ec.next_h = h;
    Ok(())
}

/// Whether the last solve's contact forces acted (a sample touched a body or a partner).
fn touches(system: &StrandSystem) -> bool {
    system.contacts.as_ref().is_some_and(|c| {
        let s = c.summary();
        s.body_contacts + s.hair_contacts > 0
    })
}
