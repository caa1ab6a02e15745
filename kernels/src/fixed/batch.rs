//! The step of a batch of fixed-N strands as an engine takes it, one call per frame: what
//! the C ABI's batch (`superhelix-capi`) and the Python module's `Batch` share.
//!
//! Each call steps a strand by `dt` in a time of its own, [0, dt]: the head is given as
//! its state at the *end* of the step and the substeps follow the motion extrapolated
//! back from it ([`ExtrapolatedHead`]); a strand whose step fails is put back in the
//! state it had (and its history as it was). The step is the checked one ([`step`]:
//! energy balance and splitting) by default, the plain linearly implicit step
//! ([`linearly_implicit`]) on request, or the error-controlled step
//! ([`step_to_tolerance`]) at a tolerance ([`BatchSettings`]).
//!
//! [`step`]: super::step
//! [`linearly_implicit`]: super::linearly_implicit
//! [`step_to_tolerance`]: super::step_to_tolerance

use super::{
    Effects, ExtrapolatedHead, FixedParams, FixedStrand, FixedWorkspace, ParamsError, StepCounts,
    StepError, StepHistory, StepInput, ToleranceReport,
};
use crate::head::HeadState;
use crate::material::SectionTerms;
use crate::strand_terms::MomentSource;
use nalgebra::Vector3;

/// How the strands of a batch are stepped: the world and the step's kind.
#[derive(Debug, Clone, Copy)]
pub struct BatchSettings {
    /// The head at the end of the step, gravity and whether the head moves.
    pub input: StepInput,
    /// The checked step (energy balance and splitting, as the runtime); else the plain
    /// linearly implicit step.
    pub checked: bool,
    /// The error-controlled step at this tolerance instead of either.
    pub tolerance: Option<f64>,
}

impl BatchSettings {
    /// The settings of a new batch: the head at rest at the origin, no gravity, the
    /// checked step.
    pub fn initial() -> Self {
        BatchSettings {
            input: StepInput {
                head: HeadState::rest(),
                gravity: None,
                head_moves: false,
            },
            checked: true,
            tolerance: None,
        }
    }
}

/// What stepping some strands of a batch found.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BatchOutcome {
    /// Strands whose step failed (they kept their state).
    pub failed: usize,
    /// The first of them (its index in the batch) and its error.
    pub first: Option<(usize, StepError)>,
    /// Largest `max_element_rotation` over the strands stepped.
    pub max_element_rotation: f64,
    /// The checks' counters, summed over the strands.
    pub counts: StepCounts,
    /// What the error-controlled steps did, over the strands.
    pub tolerance: ToleranceReport,
}

impl BatchOutcome {
    /// Count the step of strand `index`: its result ([`step_batch_strand`]) and its
    /// error-controlled steps' `report`.
    pub fn record(
        &mut self,
        index: usize,
        result: Result<f64, StepError>,
        report: &ToleranceReport,
    ) {
        self.tolerance.add(report);
        match result {
            Ok(rotation) => self.max_element_rotation = self.max_element_rotation.max(rotation),
            Err(e) => {
                self.failed += 1;
                self.first.get_or_insert((index, e));
            }
        }
    }
}

/// The head state of a step: the state as set is the head's at the end of the step; a
/// still head's rates are taken as zero.
pub fn head_at_end(input: &StepInput) -> HeadState {
    let mut state = input.head;
    if !input.head_moves {
        state.velocity = Vector3::zeros();
        state.acceleration = Vector3::zeros();
        state.omega = Vector3::zeros();
        state.alpha = Vector3::zeros();
    }
    state
}

/// One step of `strand` by `dt` as `settings` say, in a time of its own [0, dt]; the
/// error-controlled step needs the strand's `history` (without it, the checked step is
/// taken). Returns the step's largest element rotation; on failure the strand (and its
/// history) are back in the state they had. `counts` gathers the checked step's
/// counters, `report` the error-controlled step's.
#[allow(clippy::too_many_arguments)]
pub fn step_batch_strand<
    S: MomentSource<f64>,
    const N: usize,
    const D: usize,
    const E: usize,
    const B: usize,
>(
    source: &S,
    strand: &mut FixedStrand<N, D, B>,
    history: Option<&mut StepHistory<D>>,
    settings: &BatchSettings,
    dt: f64,
    ws: &mut FixedWorkspace<N, D, E>,
    counts: &mut StepCounts,
    report: &mut ToleranceReport,
) -> Result<f64, StepError> {
    let input = &settings.input;
    if !settings.checked && settings.tolerance.is_none() {
        return super::linearly_implicit(source, strand, input, dt, ws)
            .map(|r| r.max_element_rotation);
    }
    // every step runs in its own time [0, dt]: the energy the strand kept is that of its
    // present state, the start of this step
    if let Some(e) = strand.last_energy.as_mut() {
        e.time = 0.0;
    }
    // the head as set is its state at the end of the step; the substeps follow the
    // motion extrapolated back from it (a still head: its pose throughout)
    let head = ExtrapolatedHead {
        t0: dt,
        state: head_at_end(input),
    };
    let effects = Effects {
        gravity: input.gravity,
        head_moves: input.head_moves,
    };
    let (q, v) = (strand.q, strand.v);
    let outcome = match (settings.tolerance, history) {
        (Some(tolerance), Some(history)) => {
            let kept = history.clone();
            super::step_to_tolerance(
                source, strand, history, &head, &effects, 0.0, dt, tolerance, ws, report,
            )
            .inspect_err(|_| *history = kept)
        }
        _ => super::step(source, strand, &head, &effects, 0.0, dt, ws, counts),
    };
    outcome
        .map(|r| r.max_element_rotation)
        .inspect_err(|_| strand.set_state(&q, &v))
}

/// One strand's parameters in run-time sized form, as a batch is given them.
#[derive(Debug, Clone, Copy)]
pub struct BatchStrandSpec<'a> {
    /// The root's position in the head frame, m.
    pub root_position: [f64; 3],
    /// The root's frame in the head frame, as [`FixedParams::new`] takes it.
    pub root_frame: [[f64; 3]; 3],
    /// The elements' lengths, m (N values).
    pub lengths: &'a [f64],
    /// The section's terms (stiffnesses, mass, inertia).
    pub section: SectionTerms,
    /// The natural twist and curvatures, rad/m (3N values).
    pub natural: &'a [f64],
    /// The internal friction coefficient.
    pub internal_friction: f64,
    /// The air drag coefficient.
    pub air_drag: f64,
}

impl BatchStrandSpec<'_> {
    /// The strand's parameters at N elements, checked by [`FixedParams::new`], from the
    /// first N values of `lengths` and the first D = 3N of `natural` (fewer: an error
    /// naming the field).
    pub fn params<const N: usize, const D: usize>(&self) -> Result<FixedParams<N, D>, ParamsError> {
        let lengths: [f64; N] = self
            .lengths
            .get(..N)
            .and_then(|l| l.try_into().ok())
            .ok_or(ParamsError {
                field: "lengths",
                expected: "N values",
            })?;
        let natural: [f64; D] = self
            .natural
            .get(..D)
            .and_then(|n| n.try_into().ok())
            .ok_or(ParamsError {
                field: "natural",
                expected: "3N values",
            })?;
        FixedParams::new(
            self.root_position,
            self.root_frame,
            lengths,
            &self.section,
            natural,
            self.internal_friction,
            self.air_drag,
        )
    }
}
