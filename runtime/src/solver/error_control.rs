//! The error-controlled step (`[simulation] tolerance`): each strand chooses its own
//! steps within every time step of the scene so that the estimated local error stays
//! below the tolerance.
//!
//! **The scheme** is the variable-step BDF2 of [`super::bdf2`] (one linearised solve per
//! step, L-stable, second order), with its error estimated from the distance between its
//! solution and the linear extrapolation of its history,
//!
//! ```text
//! ỹ = y + ω (y − y₋)      (ω = h / h₋; q and q̇)
//! ```
//!
//! which differs from the exact solution by ½ h (h + h₋) ÿ + O(h³): the estimate is that
//! of a first-order predictor, and it bounds the BDF2 step's own O(h³) error. BDF2 has no
//! internal stages, so its order holds on the stiff twist of nearly straight elements,
//! where a one-step extrapolation loses it (measured: the linearly implicit Euler step
//! extrapolated once, the scheme's start below, reached 17–335 τ on the floppy
//! frictionless strand of `superhelix study` against 1.5–2.1 τ for this one). A strand
//! without a history (its first step, after `Simulation::set_state`) starts with that
//! one-step scheme: a step of h gives `y₁`, two steps of h/2 give `y₂`, it keeps
//! `2 y₂ − y₁` (L-stable: `2/(1 − z/2)² − 1/(1 − z)` vanishes as z → −∞), and its
//! estimate is `y₂ − y₁`; a step in which a contact acts keeps `y₂` (extrapolating
//! across a contact's onset overshoots).
//!
//! **The error norm**, the largest of three measures of the difference d between the two
//! solutions:
//!
//! ```text
//! err = max( max over the element ends |y(q) − y(q̃)| / L,     (centreline, head frame)
//!            max over Q  l_Q ‖d_q,Q‖,                           (each element's angles)
//!            max over Q  l_Q ‖d_q̇,Q‖ h )                        (what a velocity error turns in a step)
//! ```
//!
//! (L the strand's length, l_Q an element's length). A step is accepted when `err ≤ τ`;
//! the next is `h · clamp(0.9 (τ/err)^½, 0.2, 2)` and at most 2 h₋ (variable-step BDF2
//! is zero-stable below 1 + √2); a rejected step is retried at that size from the same
//! history. A strand's steps end on the scene's time steps (so frames land on their
//! output times; a remainder shorter than two steps is taken in two equal ones) and its
//! step size and history carry over to the next. The rotation limit and the step
//! splitting of [`super::adaptive`] do not act on these steps (the error control takes
//! their place); the energy balance does, on each accepted step (`limit_energy`).
//!
//! Measured: `runtime/tests/error_control.rs` (the swing against the same scheme far
//! tighter) and `superhelix study`'s `tolerance` problem (against the study's
//! references; docs/time-stepping.md).

use super::bdf2::{bdf2, BDF2_MAX_RATIO};
use super::energy_balance::{self, StateEnergy};
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
/// Relative margin of the decisions on the time left in an interval.
const SLACK: f64 = 1e-9;

/// One strand's state of the error-controlled step, and its buffers (sized at the first
/// step).
#[derive(Debug, Clone, Default)]
pub struct ErrorControl {
    /// The step size to try next, s (0: none yet).
    pub next_h: f64,
    /// The smallest step accepted so far, s (0: none).
    pub smallest_h: f64,
    /// The largest step accepted so far, s.
    pub largest_h: f64,
    /// The largest estimated error of an accepted step so far, relative to the length.
    pub largest_error: f64,
    /// What the accepted steps since the last [`ErrorControl::take_window`] did.
    window: StepWindow,
    start_q: Vec<f64>,
    start_v: Vec<f64>,
    /// The solution the kept one is compared with: BDF2's predictor, or the start's single
    /// step of h.
    other_q: Vec<f64>,
    other_v: Vec<f64>,
    ends_other: Vec<Pose>,
    ends_kept: Vec<Pose>,
}

/// What the error-controlled step carries from one step to the next (a checkpoint's
/// part): the step size to try, what the accepted steps did so far and since the last
/// frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ErrorControlState {
    next_h: f64,
    smallest_h: f64,
    largest_h: f64,
    largest_error: f64,
    window: StepWindow,
}

impl ErrorControl {
    /// What the next step needs (see [`ErrorControlState`]).
    pub fn state(&self) -> ErrorControlState {
        ErrorControlState {
            next_h: self.next_h,
            smallest_h: self.smallest_h,
            largest_h: self.largest_h,
            largest_error: self.largest_error,
            window: self.window,
        }
    }

    /// Continue from `state`.
    pub fn restore(&mut self, state: ErrorControlState) {
        self.next_h = state.next_h;
        self.smallest_h = state.smallest_h;
        self.largest_h = state.largest_h;
        self.largest_error = state.largest_error;
        self.window = state.window;
    }
}

/// What one strand's accepted error-controlled steps did over a stretch of time (a frame).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
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
    /// Add what the one step's error-controlled steps did over one call (`report`, of
    /// that call alone) to the sizes and errors so far and to the window.
    pub(super) fn record(&mut self, report: &superhelix_kernels::fixed::ToleranceReport) {
        if report.steps == 0 {
            return;
        }
        let window = StepWindow {
            largest_error: report.largest_error,
            smallest_h: report.smallest_step,
            largest_h: report.largest_step,
        };
        self.window = self.window.merge(&window);
        self.largest_error = self.largest_error.max(report.largest_error);
        self.largest_h = self.largest_h.max(report.largest_step);
        self.smallest_h = if self.smallest_h > 0.0 {
            self.smallest_h.min(report.smallest_step)
        } else {
            report.smallest_step
        };
    }

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
        ec.other_q = vec![0.0; n];
        ec.other_v = vec![0.0; n];
        ec.ends_other = vec![pose; ends];
        ec.ends_kept = vec![pose; ends];
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
    let balance = system.context.energy_balance;
    // the energy the last step ended with (its ceiling carried on), as the fixed steps
    let mut energy = if balance {
        super::adaptive::start_energy(system, interval, state).0
    } else {
        StateEnergy::default()
    };
    let mut h = if ec.next_h > 0.0 {
        ec.next_h
    } else {
        interval.h
    };
    let length = system.strand.geometry.length();
    let n = state.q.len();
    // the last step ends on the interval's end exactly
    while end - t > 1e-12 * end.abs().max(1.0) {
        if system.workspace.prev_h > 0.0 {
            // variable-step BDF2 is zero-stable for step ratios below 1 + √2
            h = h.min(BDF2_MAX_RATIO * system.workspace.prev_h);
        }
        // decided with a margin of round-off, so that the same steps are taken whatever
        // the time's origin (a caller's clock from 0 or the scene's)
        let last = h >= (end - t) * (1.0 - SLACK);
        // two steps rather than a long one and a short one
        let hh = if last {
            end - t
        } else if 2.0 * h > (end - t) * (1.0 + SLACK) {
            0.5 * (end - t)
        } else {
            h
        };
        ec.start_q.copy_from_slice(&state.q);
        ec.start_v.copy_from_slice(&state.v);
        let whole = if last && t == interval.t {
            *interval
        } else {
            HeadInterval::new(interval.motion, t, hh)
        };
        let multistep = system.workspace.prev_h > 0.0;
        let mut touched = false;
        if multistep {
            // BDF2 from the history; the estimate is its distance from the linear
            // extrapolation of the history, q + ω (q − q₋) (and q̇ likewise)
            let ws = &mut system.workspace;
            let w = hh / ws.prev_h;
            for i in 0..n {
                ec.other_q[i] = state.q[i] + w * (state.q[i] - ws.prev_q[i]);
                ec.other_v[i] = state.v[i] + w * (state.v[i] - ws.prev_v[i]);
            }
            bdf2(system, &whole, state, stats)?;
            stats.attempts += 1;
        } else {
            let predicted = stats.contacts_predicted;
            linearly_implicit_euler(system, &whole, state, stats)?;
            touched = touches(system);
            ec.other_q.copy_from_slice(&state.q);
            ec.other_v.copy_from_slice(&state.v);
            state.q.copy_from_slice(&ec.start_q);
            state.v.copy_from_slice(&ec.start_v);
            let first = whole.first_half();
            linearly_implicit_euler(system, &first, state, stats)?;
            touched |= touches(system);
            linearly_implicit_euler(system, &whole.second_half(&first), state, stats)?;
            touched |= touches(system) || stats.contacts_predicted != predicted;
            stats.attempts += 3;
        }
        system.kernel.element_ends(&ec.other_q, &mut ec.ends_other);
        system.kernel.element_ends(&state.q, &mut ec.ends_kept);
        let error = ec
            .ends_other
            .iter()
            .zip(&ec.ends_kept)
            .map(|(a, b)| (a.position - b.position).norm())
            .fold(0.0, f64::max)
            / length;
        let lengths = &system.strand.geometry.lengths;
        let angles = element_angles(lengths, &state.q, &ec.other_q, 1.0);
        // a velocity error becomes a position error: over the step, as much
        let speeds = element_angles(lengths, &state.v, &ec.other_v, hh);
        let error = error.max(angles).max(speeds);
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
            // the step's start is the next step's history
            let ws = &mut system.workspace;
            ws.prev_q.copy_from_slice(&ec.start_q);
            ws.prev_v.copy_from_slice(&ec.start_v);
            ws.prev_h = hh;
            if !touched && !multistep {
                for i in 0..n {
                    state.q[i] = 2.0 * state.q[i] - ec.other_q[i];
                    state.v[i] = 2.0 * state.v[i] - ec.other_v[i];
                }
            }
            if balance && !touched {
                energy = limit_energy(system, &whole, &energy, state, stats);
            } else if balance {
                // a step with contacts is not extrapolated (it is implicit Euler's, which
                // dissipates); its end starts the next balance
                energy = energy_balance::measure(
                    system,
                    &whole.end,
                    whole.t + whole.h,
                    &state.q,
                    &state.v,
                );
            }
            stats.error_steps += 1;
            ec.largest_error = ec.largest_error.max(error);
            ec.window.add(error, hh);
            ec.largest_h = ec.largest_h.max(hh);
            ec.smallest_h = if ec.smallest_h > 0.0 {
                ec.smallest_h.min(hh)
            } else {
                hh
            };
            if !last {
                // the contacts' bookkeeping at every accepted step within the scene's
                // (the last one's is the caller's)
                energy = super::adaptive::between_steps(system, &whole, state, energy);
            }
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
    if balance {
        let ws = &mut system.workspace;
        ws.last_energy = Some(energy);
        ws.last_q.copy_from_slice(&state.q);
        ws.last_v.copy_from_slice(&state.v);
    }
    Ok(())
}

/// The energy balance of an accepted step from `start` over `whole` (see
/// [`super::adaptive`]): energy above the bound (the ceiling with the head still or
/// translating uniformly, E(start) plus the head's work otherwise) is taken from the
/// velocities, as the fixed steps do at their deepest split; neither BDF2 nor the
/// extrapolated start is strictly dissipative, and without this a frictionless strand
/// gains energy of the order of the tolerance per step. Returns the energy of the end.
fn limit_energy(
    system: &mut StrandSystem,
    whole: &HeadInterval,
    start: &StateEnergy,
    state: &mut StrandState,
    stats: &mut StepStats,
) -> StateEnergy {
    let time = whole.t + whole.h;
    let mut end = energy_balance::measure(system, &whole.end, time, &state.q, &state.v);
    let bodies_work = system
        .contacts
        .as_ref()
        .is_some_and(|c| c.moves_relative(&whole.at_start(), &whole.at_end()));
    let inertial = whole.uniform
        && !bodies_work
        // follower loads work without a potential, and a driven holder works
        && !system.strand.has_follower_loads()
        && !system.held.as_ref().is_some_and(|h| h.is_driven());
    let balance = energy_balance::balance(start, &end, inertial);
    if balance.excess > 0.0 && end.kinetic > 0.0 {
        let kinetic = balance.limited_kinetic(&end, !bodies_work).unwrap_or(0.0);
        let lambda = (kinetic / end.kinetic).sqrt();
        for x in state.v.iter_mut() {
            *x *= lambda;
        }
        end.scale_velocities(lambda);
        stats.energy_limited += 1;
    }
    end.ceiling = energy_balance::end_ceiling(start, &end, inertial);
    end
}

/// Largest `scale · l_Q ‖a_Q − b_Q‖` over the elements Q (three coordinates each).
fn element_angles(lengths: &[f64], a: &[f64], b: &[f64], scale: f64) -> f64 {
    lengths
        .iter()
        .zip(a.chunks_exact(3).zip(b.chunks_exact(3)))
        .map(|(l, (x, y))| {
            let d: f64 = x.iter().zip(y).map(|(p, q)| (p - q) * (p - q)).sum();
            scale * l * d.sqrt()
        })
        .fold(0.0, f64::max)
}

/// Whether the last solve's contact forces acted (a sample touched a body or a partner).
fn touches(system: &StrandSystem) -> bool {
    system.contacts.as_ref().is_some_and(|c| {
        let s = c.summary();
        s.body_contacts + s.hair_contacts > 0
    })
}
