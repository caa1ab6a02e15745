//! The error-controlled step (`[simulation] tolerance`), allocation-free, on any storage,
//! for an engine that asks for an accuracy rather than a step.
//!
//! Within the caller's step [t, t + h] the strand takes steps of its own so that the
//! estimated local error of each stays below the tolerance τ:
//!
//! - **the scheme** is variable-step BDF2 ([`super::bdf2`]); its error is estimated by
//!   the distance between its solution and the linear extrapolation of the history,
//!   ỹ = y + ω (y − y₋), which differs from the exact solution by ½ h (h + h₋) ÿ + O(h³)
//!   and so bounds the BDF2 step's own O(h³) error. A strand without a history (its first
//!   step, after [`StepHistory::forget`]) starts with the linearly implicit Euler step
//!   extrapolated once: y₁ from one step of h, y₂ from two of h/2, it keeps 2 y₂ − y₁
//!   and its estimate is |y₂ − y₁|;
//! - **the error norm** is the largest of the centreline's distance between the two
//!   solutions at the element ends divided by the strand's length L, each element's
//!   l_Q ‖Δq_Q‖, and each element's l_Q ‖Δq̇_Q‖ h (what a velocity error turns in a step);
//! - **the controller**: a step is accepted when its error is at most τ; the next is
//!   h · clamp(0.9 (τ/err)^½, 0.2, 2), at most 2 h₋ (variable-step BDF2 is zero-stable
//!   for ratios below 1 + √2); a rejected step (or one whose solve fails) is retried at
//!   that size from the same history. The steps end on t + h exactly (a remainder
//!   shorter than two steps is taken in two equal ones); the next call starts with the
//!   step size and the history this one left ([`StepHistory`]);
//! - **the energy balance** of the checked step acts on each accepted step: energy above
//!   the bound of [`crate::energy::balance`] is taken from the velocities (neither BDF2
//!   nor the extrapolated start is strictly dissipative), unless the workspace has it
//!   off (`FixedWorkspace::set_energy_balance`): then nothing is measured;
//! - **contacts** ([`ContactHooks`], when given): their terms and the contacts that start
//!   within a step in every solve, their energy in the balance (with the work of
//!   colliders that move relative to the head), their anchors and allowances updated
//!   after every accepted step; a start step in which a contact acts keeps y₂ (an
//!   extrapolation across a contact's onset overshoots), and a step in which a sample
//!   goes deeper than the contacts' split depth beyond its start's depth is rejected and
//!   retried at half its size, as the checked step splits it (the two solutions the
//!   estimate compares go into a collider alike, so the estimate does not see it).
//!
//! Both engines take it (`runtime/tests/error_control.rs` compares them on a swinging
//! strand; `runtime/tests/embedded_contacts.rs` with contacts).

use super::adaptive::{
    field_counter, measure, phase_cut, remeasure_contacts, views_fit, Effects, FieldCounter,
    HeadTrajectory,
};
use super::bdf2::{bdf2_step, Bdf2History, BDF2_MAX_RATIO};
use super::contacts::ContactHooks;
use super::end_hooks::HeldError;
use super::step::{max_element_rotation, non_finite, solve_step, StepError, StepInput, StepReport};
use super::workspace::FixedWorkspace;
use super::FixedStrand;
use crate::energy::{balance, end_ceiling, StateEnergy};
use crate::field_split::FieldRule;
use crate::float::Float;
use crate::pose::Pose;
use crate::storage::{StrandView, WorkView};
use crate::strand_terms::{MomentSource, PointsOf, StepTerms};

/// Smallest tolerance of the error-controlled step (in `f64`; `f32` strands take at
/// least [`min_tolerance`]).
pub const MIN_TOLERANCE: f64 = 1e-8;
/// Largest tolerance of the error-controlled step.
pub const MAX_TOLERANCE: f64 = 0.5;
/// Smallest factor the step size may shrink by after a step.
const SHRINK: f64 = 0.2;
/// Largest factor the step size may grow by after a step.
const GROW: f64 = 2.0;
/// Safety factor of the controller.
const SAFETY: f64 = 0.9;
/// A step shorter than this, s, is accepted whatever its error.
pub const MIN_STEP: f64 = 1e-9;
/// Steps in a row the error-controlled step accepts at [`MIN_STEP`] above its tolerance
/// before it stops with [`StepError::ToleranceUnmet`].
pub const MAX_FORCED_STEPS: usize = 8;
/// Relative margin of the decisions on the time left in the caller's step.
const SLACK: f64 = 1e-9;

/// The step to take of a proposed `next` when `left` seconds remain to the next end the
/// steps must land on, and whether it lands there: all of `left` when `next` reaches it
/// (decided with a margin of round-off, so that the same steps are taken whatever the
/// time's origin), half of it when `next` would leave a remainder shorter than itself
/// (two steps rather than a long one and a short one), else `next`.
pub fn step_within(next: f64, left: f64) -> (f64, bool) {
    if next >= left * (1.0 - SLACK) {
        (left, true)
    } else if 2.0 * next > left * (1.0 + SLACK) {
        (0.5 * left, false)
    } else {
        (next, false)
    }
}

/// The smallest tolerance a strand of float type `T` takes: [`MIN_TOLERANCE`] in `f64`,
/// 1000 ε (1.2e-4) in `f32`, whose round-off would otherwise be mistaken for the error.
pub fn min_tolerance<T: Float>() -> f64 {
    MIN_TOLERANCE.max(1e3 * T::EPSILON.as_f64())
}

/// What a strand keeps between error-controlled steps besides its state: its state one
/// step back (the BDF2 history) and the step size to try next. Kept apart from
/// [`FixedStrand`] so that strands stepped with fixed steps do not pay for it
/// ([`StepHistory::BYTES`]: 256 B at N = 5 in `f64`).
#[derive(Debug, Clone)]
pub struct StepHistory<const D: usize, T: Float = f64> {
    /// q one accepted step before the strand's state.
    pub q: [T; D],
    /// q̇ one accepted step before the strand's state.
    pub v: [T; D],
    /// The length of that step, s (0: no history; the next step starts the scheme).
    pub h: f64,
    /// The step size to try next, s (0: none yet; the first try is the caller's step).
    pub next_h: f64,
}

impl<const D: usize, T: Float> StepHistory<D, T> {
    /// The history as [`step_to_tolerance_views`] takes it.
    pub fn view(&mut self) -> HistoryView<'_, T> {
        HistoryView {
            q: &mut self.q,
            v: &mut self.v,
            h: &mut self.h,
            next_h: &mut self.next_h,
        }
    }
}

impl<const D: usize, T: Float> Default for StepHistory<D, T> {
    fn default() -> Self {
        StepHistory {
            q: [T::zero(); D],
            v: [T::zero(); D],
            h: 0.0,
            next_h: 0.0,
        }
    }
}

impl<const D: usize, T: Float> StepHistory<D, T> {
    /// Bytes a history keeps.
    pub const BYTES: usize = core::mem::size_of::<Self>();

    /// Forget the history and the step size (after the strand's state was set): the next
    /// step starts the scheme afresh.
    pub fn forget(&mut self) {
        self.h = 0.0;
        self.next_h = 0.0;
    }
}

/// What error-controlled steps did: counts, the largest estimated error and the step
/// sizes (accumulated over calls until reset).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ToleranceReport {
    /// Steps accepted.
    pub steps: usize,
    /// Steps rejected (their error above the tolerance, or their solve failed) and retried.
    pub rejected: usize,
    /// Of those, steps rejected by the contacts' depth check (a sample that went deeper
    /// than the contacts' split depth beyond its start's depth, whatever the estimate)
    /// and retried at half their size.
    pub rejected_deep: usize,
    /// Linear solves, accepted or not.
    pub solves: usize,
    /// Accepted steps whose excess energy was removed from the velocities.
    pub energy_limited: usize,
    /// The largest estimated error of an accepted step, relative to the strand's length.
    pub largest_error: f64,
    /// The smallest accepted step, s (0: none).
    pub smallest_step: f64,
    /// The largest accepted step, s.
    pub largest_step: f64,
    /// Solves whose field stiffness went in by the dissipative split, by the spectral
    /// projection, and by the projection the split's rule keeps (the checked step's
    /// `StepCounts::field_split`, `field_projected`, `field_undamped`).
    pub field_split: usize,
    /// See [`Self::field_split`].
    pub field_projected: usize,
    /// See [`Self::field_split`].
    pub field_undamped: usize,
    /// Solves in which contacts that start within the step were predicted and resolved.
    pub contacts_predicted: usize,
}

impl ToleranceReport {
    /// Count how a solve's field stiffness went into its matrix.
    fn count_field(&mut self, report: &StepReport, rule: FieldRule, dissipative: bool) {
        match field_counter(report, rule, dissipative) {
            Some(FieldCounter::Split) => self.field_split += 1,
            Some(FieldCounter::Projected) => self.field_projected += 1,
            Some(FieldCounter::Undamped) => self.field_undamped += 1,
            None => {}
        }
    }

    fn accept(&mut self, error: f64, h: f64) {
        self.steps += 1;
        self.largest_error = self.largest_error.max(error);
        self.smallest_step = if self.smallest_step > 0.0 {
            self.smallest_step.min(h)
        } else {
            h
        };
        self.largest_step = self.largest_step.max(h);
    }

    /// Add another report (counts summed, extremes kept).
    pub fn add(&mut self, other: &ToleranceReport) {
        self.steps += other.steps;
        self.rejected += other.rejected;
        self.rejected_deep += other.rejected_deep;
        self.solves += other.solves;
        self.energy_limited += other.energy_limited;
        self.field_split += other.field_split;
        self.field_projected += other.field_projected;
        self.field_undamped += other.field_undamped;
        self.contacts_predicted += other.contacts_predicted;
        self.largest_error = self.largest_error.max(other.largest_error);
        if other.smallest_step > 0.0 {
            self.smallest_step = if self.smallest_step > 0.0 {
                self.smallest_step.min(other.smallest_step)
            } else {
                other.smallest_step
            };
        }
        self.largest_step = self.largest_step.max(other.largest_step);
    }
}

/// Advance `strand` from time `t` to `t + h` with the head moving as `head`, in steps
/// of its own chosen so that each one's estimated local error stays below `tolerance`
/// (relative to the strand's length; see the module page), adding what it did to
/// `report`. `tolerance` must lie in [[`min_tolerance`], [`MAX_TOLERANCE`]]. The strand
/// keeps the energy of its end state and `history` the scheme's history and next step
/// size for the next call. Allocates nothing; on failure the strand keeps the state of
/// its last accepted step and the error says why. The report's `max_element_rotation`
/// is that of the whole interval.
#[allow(clippy::too_many_arguments)]
pub fn step_to_tolerance<
    S: MomentSource<T>,
    const N: usize,
    const D: usize,
    const E: usize,
    const B: usize,
    T: Float,
>(
    source: &S,
    strand: &mut FixedStrand<N, D, B, T>,
    history: &mut StepHistory<D, T>,
    head: &dyn HeadTrajectory,
    effects: &Effects,
    t: f64,
    h: f64,
    tolerance: f64,
    ws: &mut FixedWorkspace<N, D, E, T>,
    report: &mut ToleranceReport,
) -> Result<StepReport, StepError> {
    let mut history = history.view();
    let mut source = source;
    step_to_tolerance_views(
        &mut source,
        &mut strand.view(),
        &mut history,
        head,
        effects,
        (t, h),
        tolerance,
        ws.view(),
        report,
        None,
    )
}

/// A [`StepHistory`] on any storage: q and q̇ one step back (n each), that step's
/// length (0: no history) and the step size to try next (0: the caller's step).
#[derive(Debug)]
pub struct HistoryView<'a, T: Float = f64> {
    /// q one step back.
    pub q: &'a mut [T],
    /// q̇ one step back.
    pub v: &'a mut [T],
    /// The length of that step, s.
    pub h: &'a mut f64,
    /// The step size to try next, s.
    pub next_h: &'a mut f64,
}

/// [`step_to_tolerance`] on views of any storage (a strand's, its history's and a
/// workspace's, of the same n; `fixed::step_views` for the checked step), with the
/// strand's contacts when given ([`ContactHooks`]): their terms and the contacts that
/// start within a step in every solve, their energy in the balance (the work of moving
/// colliders with it), their bookkeeping after every accepted step; a start step in
/// which a contact acts keeps its two half steps' end, not the extrapolation (which
/// overshoots across a contact's onset).
#[allow(clippy::too_many_arguments)]
pub fn step_to_tolerance_views<'c, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    strand: &mut StrandView<'_, T>,
    history: &mut HistoryView<'_, T>,
    head: &dyn HeadTrajectory,
    effects: &Effects,
    (t, h): (f64, f64),
    tolerance: f64,
    mut ws: WorkView<'_, T, NC>,
    report: &mut ToleranceReport,
    contacts: Option<&mut (dyn ContactHooks<T> + 'c)>,
) -> Result<StepReport, StepError> {
    let n = strand.dofs();
    if history.q.len() != n || history.v.len() != n || !views_fit(strand, &ws) {
        return Err(StepError::Sizes);
    }
    if strand.end.is_some() {
        // a held tip is kept by the checked linearly implicit Euler step only
        return Err(StepError::Held(HeldError::Unsupported));
    }
    let stack = ws.take_stack();
    tolerance_step(
        source,
        strand,
        history,
        head,
        effects,
        (t, h),
        tolerance,
        &mut ws,
        stack,
        report,
        contacts,
    )
}

/// [`step_to_tolerance_views`] on any storage (`stack`: [`crate::storage::STACK_VECTORS`]
/// vectors of n).
#[allow(clippy::too_many_arguments)]
pub(crate) fn tolerance_step<'c, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    strand: &mut StrandView<'_, T>,
    history: &mut HistoryView<'_, T>,
    head: &dyn HeadTrajectory,
    effects: &Effects,
    (t, h): (f64, f64),
    tolerance: f64,
    ws: &mut WorkView<'_, T, NC>,
    stack: &mut [T],
    report: &mut ToleranceReport,
    mut contacts: Option<&mut (dyn ContactHooks<T> + 'c)>,
) -> Result<StepReport, StepError> {
    if !(h.is_finite() && h > 0.0 && t.is_finite()) {
        return Err(StepError::TimeStep);
    }
    if !(min_tolerance::<T>()..=MAX_TOLERANCE).contains(&tolerance) {
        return Err(StepError::Tolerance);
    }
    ws.forget();
    let n = strand.dofs();
    let end = t + h;
    let (q0, stack) = stack.split_at_mut(n);
    let (start_q, stack) = stack.split_at_mut(n);
    let (start_v, stack) = stack.split_at_mut(n);
    let (other_q, stack) = stack.split_at_mut(n);
    let (other_v, stack) = stack.split_at_mut(n);
    q0.copy_from_slice(strand.q);
    if let Some(c) = contacts.as_deref_mut() {
        if !c.started() {
            c.start(strand.q, t, &head.state(t));
        }
    }
    // the energy the last step ended with, when it ended here; contacts with a history
    // (anchors, allowances) are measured afresh, their partners' part again when they
    // have partners (which moved since); without the energy balance no energy is
    // measured: the start's stands empty
    let balanced = ws.energy_balance;
    let continued = strand
        .last_energy
        .filter(|e| (e.time - t).abs() <= 1e-12 * t.abs().max(1.0));
    let mut energy = match (continued, contacts.as_deref_mut()) {
        _ if !balanced => StateEnergy {
            time: t,
            ..StateEnergy::default()
        },
        (Some(e), None) => e,
        (Some(e), Some(c)) if !c.has_history() => e,
        (Some(e), Some(c)) if c.has_partners() => remeasure_contacts(
            c,
            &mut PointsOf {
                source: &mut *source,
                shape: strand.params.shape(),
                scratch: &mut ws.points,
            },
            &head.state(t),
            strand.q,
            strand.v,
            &e,
        ),
        (_, c) => measure(
            source,
            &strand.params,
            effects,
            &head.state(t),
            t,
            strand.q,
            strand.v,
            ws,
            false,
            c,
            None,
        ),
    };
    let length = strand.params.length().as_f64();
    let mut next = if *history.next_h > 0.0 {
        *history.next_h
    } else {
        h
    };
    let mut now = t;
    let mut forced = 0;
    while end - now > 1e-12 * end.abs().max(1.0) {
        if *history.h > 0.0 {
            next = next.min(BDF2_MAX_RATIO * *history.h);
        }
        // the steps land on the head's phase changes as on the interval's end
        let target = phase_cut(head, now, end).unwrap_or(end);
        let (hh, last) = step_within(next, target - now);
        let t1 = if last { target } else { now + hh };
        start_q.copy_from_slice(strand.q);
        start_v.copy_from_slice(strand.v);
        let input = StepInput {
            head: head.state(t1),
            gravity: effects.gravity,
            head_moves: effects.head_moves,
        };
        let multistep = *history.h > 0.0;
        // whether a contact acted in the start step's solves
        let mut touched = false;
        let solved = if multistep {
            let w = T::of(hh / *history.h);
            for i in 0..n {
                other_q[i] = start_q[i] + w * (start_q[i] - history.q[i]);
                other_v[i] = start_v[i] + w * (start_v[i] - history.v[i]);
            }
            let previous = Bdf2History {
                q: history.q,
                v: history.v,
                h: *history.h,
            };
            report.solves += 1;
            let rule = *ws.field_rule;
            let dissipative = strand.params.dissipative();
            if let Some(c) = contacts.as_deref_mut() {
                c.forget();
            }
            bdf2_step(
                source,
                strand,
                &previous,
                &input,
                hh,
                ws,
                stack,
                contacts.as_deref_mut().map(|c| (c, t1)),
            )
            .map(|r| {
                report.count_field(&r, rule, dissipative);
                report.contacts_predicted += r.contacts_predicted;
            })
        } else {
            report.solves += 3;
            let r = start_step(
                source,
                strand,
                head,
                effects,
                (now, hh),
                &input,
                ws,
                (other_q, other_v),
                stack,
                report,
                contacts.as_deref_mut(),
            )
            .map(|t| touched = t);
            if r.is_err() {
                other_q.fill(T::zero());
                other_v.fill(T::zero());
            }
            r
        };
        let error = match solved {
            Ok(()) => {
                let (ends_other, ends_kept) = ws.ends.split_at_mut(ws.ends.len() / 2);
                estimate(
                    source, strand, other_q, other_v, hh, length, ends_other, ends_kept,
                )
            }
            Err(_) => f64::INFINITY,
        };
        // the contacts' depth check of the checked step: a sample that went deeper than
        // the split depth beyond its start's depth rejects the step, whatever its
        // estimate (the penetration is alike in the two solutions the estimate compares)
        let deep = error.is_finite()
            && hh > MIN_STEP
            && contacts.as_deref_mut().is_some_and(|c| {
                !c.acceptable(start_q, strand.q, now, &head.state(now), t1, &input.head)
            });
        if !deep && (error <= tolerance || (hh <= MIN_STEP && error.is_finite())) {
            let factor = if error > 0.0 {
                (SAFETY * crate::math::sqrt(tolerance / error)).clamp(SHRINK, GROW)
            } else {
                GROW
            };
            history.q.copy_from_slice(start_q);
            history.v.copy_from_slice(start_v);
            *history.h = hh;
            // the energy balance of the checked step
            if !balanced {
                energy.time = t1;
            } else {
                let mut e = measure(
                    source,
                    &strand.params,
                    effects,
                    &input.head,
                    t1,
                    strand.q,
                    strand.v,
                    ws,
                    false,
                    contacts.as_deref_mut(),
                    None,
                );
                if touched {
                    // a start step with contacts is implicit Euler's (it dissipates); its end
                    // starts the next balance
                    energy = e;
                } else {
                    // contacts with what moves relative to the head work on the strand
                    let bodies_work = contacts
                        .as_deref()
                        .is_some_and(|c| c.moves_relative(now, t1, &head.state(now), &input.head));
                    // follower loads work without a potential
                    let inertial = head.uniform_over(now, t1)
                        && !bodies_work
                        && !crate::point_load::any_follows(strand.params.loads);
                    let balance = balance(&energy, &e, inertial);
                    if balance.excess > T::zero() && e.kinetic > T::zero() {
                        let kinetic = balance
                            .limited_kinetic(&e, !bodies_work)
                            .unwrap_or(T::zero());
                        let lambda = (kinetic / e.kinetic).sqrt();
                        for x in strand.v.iter_mut() {
                            *x *= lambda;
                        }
                        e.scale_velocities(lambda);
                        report.energy_limited += 1;
                    }
                    e.ceiling = end_ceiling(&energy, &e, inertial);
                    energy = e;
                }
            }
            report.accept(error, hh);
            if !last {
                if let Some(c) = contacts.as_deref_mut() {
                    // the contacts' bookkeeping at every accepted step within the
                    // caller's (the last one's after the loop)
                    c.after_step(strand.q, t1, &input.head, hh);
                    if balanced && c.has_history() {
                        energy = remeasure_contacts(
                            c,
                            &mut PointsOf {
                                source: &mut *source,
                                shape: strand.params.shape(),
                                scratch: &mut ws.points,
                            },
                            &input.head,
                            strand.q,
                            strand.v,
                            &energy,
                        );
                    }
                }
            }
            now = t1;
            // a step cut short to end on the interval does not shrink the next
            next = if last {
                next.max(hh * factor)
            } else {
                hh * factor
            }
            .max(MIN_STEP);
            // an estimate that does not shrink with the step: the step would crawl at its
            // shortest for ever
            forced = if error > tolerance { forced + 1 } else { 0 };
            if forced >= MAX_FORCED_STEPS {
                *strand.last_energy = None;
                return Err(StepError::ToleranceUnmet {
                    error,
                    tolerance,
                    t: now,
                });
            }
        } else {
            if hh <= MIN_STEP {
                // the shortest step fails: say why, the strand back at its last accepted step
                let failure = solved.err().unwrap_or_else(|| {
                    non_finite(strand.q, strand.v).unwrap_or(StepError::NonFinite {
                        index: 0,
                        velocity: false,
                    })
                });
                strand.q.copy_from_slice(start_q);
                strand.v.copy_from_slice(start_v);
                *strand.last_energy = None;
                report.rejected += 1;
                return Err(failure);
            }
            strand.q.copy_from_slice(start_q);
            strand.v.copy_from_slice(start_v);
            report.rejected += 1;
            report.rejected_deep += usize::from(deep);
            next = if deep {
                // as the checked step splits it
                0.5 * hh
            } else if error.is_finite() && error > 0.0 {
                hh * (SAFETY * crate::math::sqrt(tolerance / error)).clamp(SHRINK, GROW)
            } else {
                hh * SHRINK
            };
            next = next.max(MIN_STEP);
        }
    }
    *history.next_h = next;
    *strand.last_energy = Some(energy);
    if let Some(c) = contacts {
        // the caller's step's end: anchors stick, slide or let go; allowances shrink
        c.after_step(strand.q, end, &head.state(end), h);
    }
    let rotation = max_element_rotation(strand.params.lengths, strand.q, q0);
    Ok(StepReport {
        max_element_rotation: rotation.as_f64(),
        projection: None,
        contacts_predicted: 0,
        loaded: false,
    })
}

/// The start of the scheme over [t, t + h]: y₁ from one linearly implicit Euler step of
/// h, y₂ from two of h/2. The strand ends in 2 y₂ − y₁; y₂, which differs from it by
/// y₂ − y₁ (the estimate), into `(q2, v2)` (`stack`: four vectors of n). With a
/// contact acting in a solve (or predicted within one) the strand ends in y₂ and y₁
/// goes into `(q2, v2)`; returns whether one did.
#[allow(clippy::too_many_arguments)]
fn start_step<'c, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    strand: &mut StrandView<'_, T>,
    head: &dyn HeadTrajectory,
    effects: &Effects,
    (t, h): (f64, f64),
    input: &StepInput,
    ws: &mut WorkView<'_, T, NC>,
    (q2, v2): (&mut [T], &mut [T]),
    stack: &mut [T],
    report: &mut ToleranceReport,
    mut contacts: Option<&mut (dyn ContactHooks<T> + 'c)>,
) -> Result<bool, StepError> {
    let n = strand.dofs();
    let (rule, dissipative) = (*ws.field_rule, strand.params.dissipative());
    let (q, stack) = stack.split_at_mut(n);
    let (v, stack) = stack.split_at_mut(n);
    let (q1, stack) = stack.split_at_mut(n);
    let (v1, stack) = stack.split_at_mut(n);
    q.copy_from_slice(strand.q);
    v.copy_from_slice(strand.v);
    let mut touched = false;
    let mut solve = |strand: &mut StrandView<'_, T>,
                     at: &StepInput,
                     (h, t_end): (f64, f64),
                     ws: &mut WorkView<'_, T, NC>,
                     stack: &mut [T],
                     report: &mut ToleranceReport|
     -> Result<(), StepError> {
        if let Some(c) = contacts.as_deref_mut() {
            c.forget();
        }
        let r = solve_step(
            source,
            strand,
            at,
            (h, t_end),
            ws,
            stack,
            contacts.as_deref_mut().map(|c| (c, t_end)),
        )?;
        report.count_field(&r, rule, dissipative);
        report.contacts_predicted += r.contacts_predicted;
        touched |= r.contacts_predicted > 0 || contacts.as_deref().is_some_and(|c| c.touching());
        Ok(())
    };
    solve(strand, input, (h, t + h), ws, stack, report)?;
    q1.copy_from_slice(strand.q);
    v1.copy_from_slice(strand.v);
    strand.q.copy_from_slice(q);
    strand.v.copy_from_slice(v);
    let middle = StepInput {
        head: head.state(t + 0.5 * h),
        gravity: effects.gravity,
        head_moves: effects.head_moves,
    };
    for (at, h, t_end) in [(&middle, 0.5 * h, t + 0.5 * h), (input, 0.5 * h, t + h)] {
        solve(strand, at, (h, t_end), ws, stack, report)?;
    }
    if touched {
        // a contact acted: keep y₂ (extrapolating across a contact's onset overshoots);
        // the estimate compares it with y₁
        q2.copy_from_slice(q1);
        v2.copy_from_slice(v1);
        return Ok(true);
    }
    // keep 2 y₂ − y₁; the estimate compares it with y₂, which it differs from by y₂ − y₁
    q2.copy_from_slice(strand.q);
    v2.copy_from_slice(strand.v);
    let two = T::of(2.0);
    for i in 0..n {
        strand.q[i] = two * q2[i] - q1[i];
        strand.v[i] = two * v2[i] - v1[i];
    }
    Ok(false)
}

/// The error norm (module page) between the strand's state and (`q`, `v`).
#[allow(clippy::too_many_arguments)]
fn estimate<S: StepTerms<T> + ?Sized, T: Float>(
    source: &mut S,
    strand: &StrandView<'_, T>,
    q: &[T],
    v: &[T],
    h: f64,
    length: f64,
    ends_other: &mut [Pose<T>],
    ends_kept: &mut [Pose<T>],
) -> f64 {
    let shape = strand.params.shape();
    // the element ends the strand has (the workspace may hold more: a free root's
    // translation counts among the coordinates, not among the elements)
    let m = strand.params.lengths.len() + 1;
    let (ends_other, ends_kept) = (&mut ends_other[..m], &mut ends_kept[..m]);
    source.ends(&shape, q, ends_other);
    source.ends(&shape, strand.q, ends_kept);
    let centreline = ends_other
        .iter()
        .zip(ends_kept.iter())
        .map(|(a, b)| {
            let d = a.position - b.position;
            (d.x * d.x + d.y * d.y + d.z * d.z).sqrt().as_f64()
        })
        .fold(0.0, f64::max)
        / length;
    let mut worst = centreline;
    for (k, &l) in strand.params.lengths.iter().enumerate() {
        let mut dq = T::zero();
        let mut dv = T::zero();
        for i in 3 * k..3 * k + 3 {
            dq += (strand.q[i] - q[i]) * (strand.q[i] - q[i]);
            dv += (strand.v[i] - v[i]) * (strand.v[i] - v[i]);
        }
        let l = l.as_f64();
        worst = worst
            .max(l * dq.sqrt().as_f64())
            .max(l * dv.sqrt().as_f64() * h);
    }
    if worst.is_finite() {
        worst
    } else {
        f64::INFINITY
    }
}
