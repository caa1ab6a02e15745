//! The embedded engine: strands stepped by the fixed-N step of `superhelix-kernels` (the
//! step an engine embeds), kept in arrays of literal size, with one workspace per worker
//! instead of one per strand.
//!
//! A strand costs [`FixedStrand::BYTES`] here (1768 B at N = 5) against the runtime
//! engine's per-strand buffers (≈ 74 kB at N = 5): what lets a full head of 150,000
//! strands fit in memory (417 MB). The step is the checked fixed-N step
//! (`superhelix_kernels::fixed::step`): the runtime's linearly implicit Euler step with
//! its checks after the fact (energy balance, splitting a step that rotates an element
//! too far), the same steps to round-off (`runtime/tests/fixed_step.rs`).

use crate::model::strand::Strand;
use rayon::prelude::*;
use superhelix_generated::ClosedForm;
use superhelix_kernels::field_split::FieldRule;
use superhelix_kernels::fixed::{
    self, Effects, FixedParams, FixedStrand, FixedWorkspace, HeadTrajectory, StepCounts,
    StepHistory, ToleranceReport,
};

/// Strands of one N stepped by the fixed-N step.
pub trait EmbeddedGroup: Send + Sync {
    /// Number of strands.
    fn len(&self) -> usize;
    /// True when there are none.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Add a strand at state (q, q̇ = 0); false when its N is not this group's.
    fn push(&mut self, strand: &Strand, q0: &[f64]) -> bool;
    /// Step every strand from `t` by `h` in parallel, one workspace per chunk of strands:
    /// the checked fixed-N step, adding the checks' counters to `counts`, or with a
    /// `tolerance` the error-controlled one (`fixed::step_to_tolerance`), adding what it
    /// did to `report`. The first failure as (position in the group, cause).
    #[allow(clippy::too_many_arguments)]
    fn step(
        &mut self,
        head: &(dyn HeadTrajectory + Sync),
        effects: &Effects,
        t: f64,
        h: f64,
        tolerance: Option<f64>,
        counts: &mut StepCounts,
        report: &mut ToleranceReport,
    ) -> Option<(usize, String)>;
    /// What the error-controlled steps of strand `i` did so far (`None`: none taken).
    fn strand_report(&self, i: usize) -> Option<&ToleranceReport>;
    /// q of strand `i`.
    fn q(&self, i: usize) -> &[f64];
    /// q̇ of strand `i`.
    fn v(&self, i: usize) -> &[f64];
    /// Set the state of strand `i` (lengths must be 3N).
    fn set_state(&mut self, i: usize, q: &[f64], v: &[f64]);
    /// What every strand carries from one step to the next (a checkpoint's part), in
    /// order.
    fn state(&self) -> Vec<FixedStrandState>;
    /// Continue from `states` (one per strand, as [`Self::state`] gave them); an error
    /// when they do not fit this group's strands.
    fn restore(&mut self, states: Vec<FixedStrandState>) -> Result<(), String>;
    /// Bytes one strand keeps.
    fn strand_bytes(&self) -> usize;
    /// Bytes of one workspace.
    fn workspace_bytes(&self) -> usize;
    /// How the steps take the field stiffness into their matrix.
    fn set_field_rule(&mut self, rule: FieldRule);
}

/// [`EmbeddedGroup`] for N elements (D = 3N coordinates, E = N + 1 ends, a kept
/// eigenbasis of B = D/2 columns).
pub struct Group<const N: usize, const D: usize, const E: usize, const B: usize> {
    strands: Vec<FixedStrand<N, D, B>>,
    /// Per strand, the error-controlled step's history and what it did (empty until the
    /// first step with a tolerance).
    histories: Vec<(StepHistory<D>, ToleranceReport)>,
    field_rule: FieldRule,
}

impl<const N: usize, const D: usize, const E: usize, const B: usize> Default for Group<N, D, E, B> {
    fn default() -> Self {
        Group {
            strands: Vec::new(),
            histories: Vec::new(),
            field_rule: FieldRule::default(),
        }
    }
}

/// The fixed-N parameters of a runtime strand (`None` when it does not have N elements
/// and 3N natural values).
pub fn fixed_params<const N: usize, const D: usize>(s: &Strand) -> Option<FixedParams<N, D>> {
    let g = &s.geometry;
    if g.lengths.len() != N || s.natural.len() != D {
        return None;
    }
    let stiffness = s.stiffness_diagonal();
    Some(FixedParams {
        root_position: g.root_position,
        root_frame: g.root_frame,
        lengths: core::array::from_fn(|k| g.lengths[k]),
        natural: core::array::from_fn(|i| s.natural[i]),
        stiffness: core::array::from_fn(|i| stiffness[i]),
        friction: core::array::from_fn(|i| g.lengths[i / 3] * s.internal_friction),
        mass_per_length: g.mass_per_length,
        air_drag: s.air_drag,
        rotary_inertia: g.rotary_inertia,
    })
}

impl<const N: usize, const D: usize, const E: usize, const B: usize> EmbeddedGroup
    for Group<N, D, E, B>
{
    fn len(&self) -> usize {
        self.strands.len()
    }
    fn push(&mut self, strand: &Strand, q0: &[f64]) -> bool {
        let Some(params) = fixed_params::<N, D>(strand) else {
            return false;
        };
        if q0.len() != D {
            return false;
        }
        let mut s = FixedStrand::at_rest(params);
        s.q.copy_from_slice(q0);
        self.strands.push(s);
        true
    }
    fn step(
        &mut self,
        head: &(dyn HeadTrajectory + Sync),
        effects: &Effects,
        t: f64,
        h: f64,
        tolerance: Option<f64>,
        counts: &mut StepCounts,
        report: &mut ToleranceReport,
    ) -> Option<(usize, String)> {
        // a quarter of a thread's share per chunk (load balance), at least 64 strands
        // (one workspace per chunk: making one costs about as much as a step)
        let threads = rayon::current_num_threads().max(1);
        let chunk = self.strands.len().div_ceil(4 * threads).max(64);
        type Partial = (Option<(usize, String)>, StepCounts, ToleranceReport);
        let merge = |(a, mut ca, mut ra): Partial, (b, cb, rb): Partial| {
            ca.add(&cb);
            ra.add(&rb);
            let first = match (a, b) {
                (Some(a), Some(b)) => Some(if a.0 <= b.0 { a } else { b }),
                (a, b) => a.or(b),
            };
            (first, ca, ra)
        };
        let empty = || (None, StepCounts::default(), ToleranceReport::default());
        let (failure, total, steps) = match tolerance {
            None => self
                .strands
                .par_chunks_mut(chunk)
                .enumerate()
                .map(|(c, strands)| {
                    let mut ws = Box::new(FixedWorkspace::<N, D, E>::new());
                    ws.set_field_rule(self.field_rule);
                    let mut first = None;
                    let mut counts = StepCounts::default();
                    for (k, s) in strands.iter_mut().enumerate() {
                        let r =
                            fixed::step(&ClosedForm, s, head, effects, t, h, &mut ws, &mut counts);
                        if let Err(e) = r {
                            first.get_or_insert((c * chunk + k, e.to_string()));
                        }
                    }
                    (first, counts, ToleranceReport::default())
                })
                .reduce(empty, merge),
            Some(tolerance) => {
                self.histories
                    .resize(self.strands.len(), Default::default());
                self.strands
                    .par_chunks_mut(chunk)
                    .zip(self.histories.par_chunks_mut(chunk))
                    .enumerate()
                    .map(|(c, (strands, histories))| {
                        let mut ws = Box::new(FixedWorkspace::<N, D, E>::new());
                        ws.set_field_rule(self.field_rule);
                        let mut first = None;
                        let mut total = ToleranceReport::default();
                        for (k, (s, (history, done))) in
                            strands.iter_mut().zip(histories.iter_mut()).enumerate()
                        {
                            let mut r = ToleranceReport::default();
                            let outcome = fixed::step_to_tolerance(
                                &ClosedForm,
                                s,
                                history,
                                head,
                                effects,
                                t,
                                h,
                                tolerance,
                                &mut ws,
                                &mut r,
                            );
                            done.add(&r);
                            total.add(&r);
                            if let Err(e) = outcome {
                                first.get_or_insert((c * chunk + k, e.to_string()));
                            }
                        }
                        (first, StepCounts::default(), total)
                    })
                    .reduce(empty, merge)
            }
        };
        counts.add(&total);
        report.add(&steps);
        failure
    }
    fn strand_report(&self, i: usize) -> Option<&ToleranceReport> {
        self.histories.get(i).map(|(_, r)| r)
    }
    fn q(&self, i: usize) -> &[f64] {
        &self.strands[i].q
    }
    fn v(&self, i: usize) -> &[f64] {
        &self.strands[i].v
    }
    fn set_state(&mut self, i: usize, q: &[f64], v: &[f64]) {
        let s = &mut self.strands[i];
        s.q.copy_from_slice(q);
        s.v.copy_from_slice(v);
        s.basis_k = 0;
        s.last_energy = None;
        if let Some((history, _)) = self.histories.get_mut(i) {
            history.forget();
        }
    }
    fn state(&self) -> Vec<FixedStrandState> {
        self.strands
            .iter()
            .enumerate()
            .map(|(i, s)| FixedStrandState {
                q: s.q.to_vec(),
                v: s.v.to_vec(),
                basis: s.basis[..s.basis_k].iter().flatten().copied().collect(),
                basis_negative: s.basis_negative,
                split_hint: s.split_hint,
                last_energy: s.last_energy.as_ref().map(super::system::energy_words),
                history: self.histories.get(i).map(|(h, r)| HistoryState {
                    q: h.q.to_vec(),
                    v: h.v.to_vec(),
                    h: h.h,
                    next_h: h.next_h,
                    report: ReportState::of(r),
                }),
            })
            .collect()
    }
    fn restore(&mut self, states: Vec<FixedStrandState>) -> Result<(), String> {
        if states.len() != self.strands.len() {
            return Err(format!(
                "{} strands of {N} elements in the checkpoint, {} in the scene",
                states.len(),
                self.strands.len()
            ));
        }
        let histories = states.iter().filter(|s| s.history.is_some()).count();
        if histories != 0 && histories != states.len() {
            return Err("some strands have an error-control history and some not".into());
        }
        let mut restored = Vec::with_capacity(histories);
        for (s, state) in self.strands.iter_mut().zip(states) {
            let size = |len: usize| len == D;
            if !size(state.q.len())
                || !size(state.v.len())
                || state.basis.len() % D.max(1) != 0
                || state.basis.len() / D.max(1) > B
            {
                return Err(format!("a strand state that is not of {N} elements"));
            }
            s.q.copy_from_slice(&state.q);
            s.v.copy_from_slice(&state.v);
            s.basis_k = state.basis.len() / D.max(1);
            for (column, values) in s.basis.iter_mut().zip(state.basis.chunks(D.max(1))) {
                column.copy_from_slice(values);
            }
            s.basis_negative = state.basis_negative;
            s.split_hint = state.split_hint;
            s.last_energy = state
                .last_energy
                .as_ref()
                .map(super::system::energy_from_words);
            if let Some(h) = state.history {
                if !size(h.q.len()) || !size(h.v.len()) {
                    return Err(format!("a step history that is not of {N} elements"));
                }
                let mut history = StepHistory::<D>::default();
                history.q.copy_from_slice(&h.q);
                history.v.copy_from_slice(&h.v);
                history.h = h.h;
                history.next_h = h.next_h;
                restored.push((history, h.report.report()));
            }
        }
        self.histories = restored;
        Ok(())
    }
    fn strand_bytes(&self) -> usize {
        FixedStrand::<N, D, B>::BYTES
    }
    fn workspace_bytes(&self) -> usize {
        FixedWorkspace::<N, D, E>::BYTES
    }
    fn set_field_rule(&mut self, rule: FieldRule) {
        self.field_rule = rule;
    }
}

/// What one strand of the embedded engine carries from one step to the next (a
/// checkpoint's part): q, q̇, the kept eigenbasis, the split hint, the last step's end
/// energy, and with a tolerance the error-controlled step's history.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FixedStrandState {
    q: Vec<f64>,
    v: Vec<f64>,
    /// The kept basis's columns in use, each of length 3N.
    basis: Vec<f64>,
    basis_negative: bool,
    split_hint: u8,
    last_energy: Option<[f64; super::system::ENERGY_WORDS]>,
    history: Option<HistoryState>,
}

/// A strand's error-controlled step history and report (see [`FixedStrandState`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
struct HistoryState {
    q: Vec<f64>,
    v: Vec<f64>,
    h: f64,
    next_h: f64,
    report: ReportState,
}

/// A [`ToleranceReport`] as a checkpoint writes it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ReportState {
    steps: usize,
    rejected: usize,
    solves: usize,
    energy_limited: usize,
    largest_error: f64,
    smallest_step: f64,
    largest_step: f64,
}

impl ReportState {
    /// `r` as written.
    pub fn of(r: &ToleranceReport) -> Self {
        ReportState {
            steps: r.steps,
            rejected: r.rejected,
            solves: r.solves,
            energy_limited: r.energy_limited,
            largest_error: r.largest_error,
            smallest_step: r.smallest_step,
            largest_step: r.largest_step,
        }
    }

    /// The report written.
    pub fn report(&self) -> ToleranceReport {
        ToleranceReport {
            steps: self.steps,
            rejected: self.rejected,
            solves: self.solves,
            energy_limited: self.energy_limited,
            largest_error: self.largest_error,
            smallest_step: self.smallest_step,
            largest_step: self.largest_step,
        }
    }
}

/// Makes the empty [`Group`] of the visited size.
struct MakeGroup;

impl superhelix_generated::SizeVisitor for MakeGroup {
    type Output = Box<dyn EmbeddedGroup>;
    fn visit<const N: usize, const D: usize, const E: usize, const B: usize>(self) -> Self::Output {
        Box::new(Group::<N, D, E, B>::default())
    }
}

/// An empty group for strands of `n` elements, when this build has the fixed-N code
/// for that N (`superhelix_generated::fixed::SIZES`: the checked-in sizes and those of
/// `SUPERHELIX_N`).
pub fn group_for(n: usize) -> Option<Box<dyn EmbeddedGroup>> {
    superhelix_generated::visit_size(n, MakeGroup)
}
