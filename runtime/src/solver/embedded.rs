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

use crate::bodies::Body;
use crate::forces::contacts::predicted::PredictedContacts;
use crate::forces::contacts::strand_contacts::{sample_points, BodyColliders};
use crate::forces::contacts::ContactConfig;
use crate::forces::head_motion::HeadState;
use crate::model::strand::{PointLoad, Strand};
use crate::solver::held_end::{HeldHook, HeldTip, HeldTipState};
use crate::solver::pair_coupling::{CoupledStrand, StrandSides};
use crate::solver::stats::StepStats;
use crate::solver::system::OneStepFactors;
use rayon::prelude::*;
use std::sync::Arc;
use superhelix_generated::ClosedForm;
use superhelix_kernels::contact::partners::{HairHairParams, PartnerPoint};
use superhelix_kernels::contact::predicted::PredictedBuffers;
use superhelix_kernels::contact::{Anchor, BodySummary, ContactParams};
use superhelix_kernels::field_split::FieldRule;
use superhelix_kernels::fixed::{
    self, ContactHooks, ContactScalars, ContactStore, Effects, FixedContacts, FixedParams,
    FixedStrand, FixedWorkspace, HeadTrajectory, PartnerStore, StepCounts, StepError, StepHistory,
    StepInput, StepReport, ToleranceReport,
};
use superhelix_kernels::floating::{Floating, FloatingScratch};
use superhelix_kernels::moments::EndDerivatives;
use superhelix_kernels::pose::Pose;
use superhelix_kernels::storage::Square;
use superhelix_kernels::storage::StrandView;
use superhelix_kernels::strand_terms::StepTerms;

mod coupled;

use coupled::PairPoints;

/// `$body` with `$source` the terms of a strand: the closed forms, or with a free root
/// (`$free`) the translation's terms over them on the scratch `$floating` (a chain of
/// `$n` coordinates; `Err(StepError::Sizes)` when it is too short). A macro, so that each
/// source's step is its own monomorphized code.
macro_rules! with_terms {
    ($free:expr, $floating:expr, $n:expr, |$source:ident| $body:expr) => {
        if $free {
            match FloatingScratch::on($floating, $n) {
                Some(scratch) => {
                    let $source = &mut Floating {
                        chain: &ClosedForm,
                        scratch,
                    };
                    $body
                }
                None => Err(StepError::Sizes),
            }
        } else {
            let $source = &mut &ClosedForm;
            $body
        }
    };
}

/// Strands of one N stepped by the fixed-N step.
pub trait EmbeddedGroup: Send + Sync {
    /// Number of strands.
    fn len(&self) -> usize;
    /// True when there are none.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Add a strand at state (q, q̇ = 0), touching `contacts` (the bodies and the
    /// contact settings; the same for every strand of a scene); false when its N is not
    /// this group's.
    /// `held`: its held tip, on the constraint at q0 (`None`: a free tip).
    fn push(
        &mut self,
        strand: &Strand,
        q0: &[f64],
        contacts: Option<&EmbeddedContacts>,
        held: Option<HeldTip>,
    ) -> bool;
    /// Strand `i`'s held tip (`None`: a free tip).
    fn held(&self, i: usize) -> Option<&HeldTip>;
    /// Add strand `i`'s contact forces at its state (q, q̇ = 0), time `t`, the head in
    /// `head`, to `force` (3N), as the runtime engine's assembly adds them; nothing
    /// without contacts. `points`: the strand's points.
    fn add_contact_force(
        &mut self,
        i: usize,
        t: f64,
        head: &HeadState,
        points: &mut dyn superhelix_kernels::strand_terms::StrandPoints<f64>,
        force: &mut [f64],
    );
    /// Strand `i`'s held tip, to change (`None`: a free tip).
    fn held_mut(&mut self, i: usize) -> Option<&mut HeldTip>;
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
    /// Set strand `i`'s point loads (the scene's and the charges' forces), constant over
    /// the next steps.
    fn set_loads(&mut self, i: usize, loads: &[PointLoad]);
    /// Strand `i`'s loads' Σ f_l · y_l at its state grew by `change` (J) without the
    /// strand moving: its last energy and ceiling as the new loads count them
    /// ([`super::system::StrandWorkspace::shift_load_energy`]).
    fn shift_load_energy(&mut self, i: usize, change: f64);
    /// Forget strand `i`'s last energy (its energy balance starts afresh at the next
    /// step; its two-step history is kept).
    fn forget_energy(&mut self, i: usize);
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
    /// The scene's rules for the steps.
    fn set_rules(&mut self, rules: StepRules);
    /// The deepest point of any strand's centreline inside a body at time `t`, the head
    /// in `head` (`None`: no contacts), on the dense sweep of each centreline.
    fn deepest_inside(&mut self, t: f64, head: &HeadState) -> Option<f64>;
    /// What the last evaluation of strand `i`'s contact terms found, and how many of its
    /// partners (hair–hair) were within reach (`None`: no contacts).
    fn contact_summary(&self, i: usize) -> Option<(BodySummary, usize)>;
    /// The twice the hair volume's radius of the strands' hair–hair contacts, m (`None`:
    /// no hair–hair contacts).
    fn hair_reach(&self) -> Option<f64>;
    /// Arc length and weight of the contact samples of strand `i` (empty without
    /// contacts).
    fn samples(&self, i: usize) -> &[(f64, f64)];
    /// Every strand's contact samples' positions at its present state, world
    /// coordinates, the head in `head` (one list per strand, in order; empty lists
    /// without contacts).
    fn sample_positions(&self, head: &HeadState) -> Vec<Vec<nalgebra::Vector3<f64>>>;
    /// Write every strand's partners for the coming step (hair–hair): `fill(p, list)`
    /// writes strand p's into its list (cleared, memory kept; the strands in parallel);
    /// nothing without contacts.
    fn fill_partners(&mut self, fill: &(dyn Fn(usize, &mut Vec<PartnerPoint>) + Sync));
    /// Start every strand's contacts at its present state, time `t`, the head in `head`
    /// (the root zones, the depths allowed at the start, the first anchors), as the
    /// runtime engine does when it is built; nothing without contacts.
    fn start_contacts(&mut self, t: f64, head: &HeadState);
    /// Run `pass` on each strand of the group whose hair–hair pairs are coupled
    /// (`coupling = "pair"`), in parallel, as a coupled strand of the pair solve
    /// ([`pair_coupling`]) with `sides[i]` its sides (`sides`: one per strand of the
    /// group, in its order). The first failure (position, cause) and the counts.
    fn each_coupled(
        &mut self,
        sides: &mut [StrandSides],
        pass: &CoupledPass<'_>,
    ) -> (Option<(usize, String)>, StepStats);
}

/// What [`EmbeddedGroup::each_coupled`] runs on a strand.
pub type CoupledPass<'p> = dyn Fn(&mut dyn CoupledStrand, &mut StrandSides, &mut StepStats) -> Result<(), String>
    + Sync
    + 'p;

/// [`EmbeddedGroup`] for N elements (D = 3N coordinates, E = N + 1 ends, a kept
/// eigenbasis of B = D/2 columns).
pub struct Group<const N: usize, const D: usize, const E: usize, const B: usize> {
    strands: Vec<FixedStrand<N, D, B>>,
    /// Per strand, its point loads and coordinates' scale.
    extras: Vec<StrandExtras>,
    /// The bodies the strands touch and, per strand, its contacts' storage (`None`: no
    /// contacts).
    contacts: Option<(Arc<[Body]>, Vec<StrandContactBuffers>)>,
    /// Per strand, the error-controlled step's history and what it did (empty until the
    /// first step with a tolerance).
    histories: Vec<(StepHistory<D>, ToleranceReport)>,
    rules: StepRules,
    /// What each worker (a chunk of strands) keeps from step to step, so that a step
    /// allocates nothing: one per chunk of the last step.
    workers: Vec<Worker<N, D, E>>,
}

/// What one worker of a [`Group`] keeps from step to step: its workspace under the
/// group's rules and, with contacts, its colliders and contact scratch (sized for the
/// group's strands).
struct Worker<const N: usize, const D: usize, const E: usize> {
    ws: Box<FixedWorkspace<N, D, E>>,
    contacts: Option<(BodyColliders, ContactScratch)>,
    /// A free root's scratch of the translation's terms (`superhelix_kernels::floating`;
    /// empty for strands of 3N coordinates).
    floating: Vec<f64>,
    /// The pair solve's points of a strand ([`EmbeddedStrand`]).
    pair_points: PairPoints,
}

/// The scene's rules for the fixed-N step (`[simulation] field_stiffness`,
/// `max_split_depth`, `energy_balance`), set on each worker's workspace.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepRules {
    /// How the field stiffness enters the step's matrix.
    pub field_rule: FieldRule,
    /// The deepest split of a step.
    pub max_split_depth: usize,
    /// Whether the step keeps its energy balance.
    pub energy_balance: bool,
    /// BDF2 with fixed steps (each strand's history kept, and checkpointed, with it);
    /// else linearly implicit Euler. A tolerance takes the error-controlled step either
    /// way.
    pub bdf2: bool,
    /// Newton-iterated implicit Euler (`newton-implicit-euler`): the checked step's
    /// solves by Newton iterations, the linearly implicit solve where they do not
    /// converge.
    pub newton: bool,
}

impl Default for StepRules {
    fn default() -> Self {
        StepRules {
            field_rule: FieldRule::default(),
            max_split_depth: superhelix_kernels::energy::MAX_SUBSTEP_DEPTH,
            energy_balance: true,
            bdf2: false,
            newton: false,
        }
    }
}

impl StepRules {
    /// A worker's workspace under these rules.
    fn workspace<const N: usize, const D: usize, const E: usize>(
        &self,
    ) -> Box<FixedWorkspace<N, D, E>> {
        let mut ws = Box::new(FixedWorkspace::<N, D, E>::new());
        ws.set_field_rule(self.field_rule);
        ws.set_max_split_depth(self.max_split_depth);
        ws.set_energy_balance(self.energy_balance);
        ws.set_newton(self.newton);
        ws
    }
}

impl<const N: usize, const D: usize, const E: usize, const B: usize> Default for Group<N, D, E, B> {
    fn default() -> Self {
        Group {
            strands: Vec::new(),
            extras: Vec::new(),
            contacts: None,
            histories: Vec::new(),
            rules: StepRules::default(),
            workers: Vec::new(),
        }
    }
}

impl<const N: usize, const D: usize, const E: usize, const B: usize> Group<N, D, E, B> {
    /// The strands per chunk of a step (a quarter of a thread's share: load balance),
    /// and `chunks` workers ready for them.
    fn chunk_workers(&mut self) -> usize {
        let threads = rayon::current_num_threads().max(1);
        let chunk = self.strands.len().div_ceil(4 * threads).max(1);
        let chunks = self.strands.len().div_ceil(chunk);
        while self.workers.len() < chunks {
            let contacts = self.contacts.as_ref().map(|(bodies, buffers)| {
                (
                    BodyColliders::new(bodies.clone()),
                    ContactScratch::for_strands(buffers, N, D),
                )
            });
            self.workers.push(Worker {
                ws: self.rules.workspace::<N, D, E>(),
                contacts,
                floating: if free_root::<N, D>() {
                    vec![0.0; FloatingScratch::<f64>::len(3 * N)]
                } else {
                    Vec::new()
                },
                pair_points: PairPoints::new(N),
            });
        }
        chunk
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
    let friction = s.friction_diagonal();
    Some(FixedParams {
        root_position: g.root_position,
        root_frame: g.root_frame,
        lengths: core::array::from_fn(|k| g.lengths[k]),
        natural: core::array::from_fn(|i| s.natural[i]),
        stiffness: core::array::from_fn(|i| stiffness[i]),
        friction: core::array::from_fn(|i| friction[i]),
        mass_per_length: g.mass_per_length,
        air_drag: s.air_drag,
        rotary_inertia: g.rotary_inertia,
    })
}

/// The runtime-N storage of the step (`superhelix_kernels::storage::heap`) for a
/// runtime strand of any N, at rest in its natural shape, with the parameters
/// [`fixed_params`] gives a fixed-N strand.
pub fn heap_strand(s: &Strand) -> superhelix_kernels::storage::heap::HeapStrand {
    let g = &s.geometry;
    let stiffness = s.stiffness_diagonal();
    let friction: Vec<f64> = (0..s.natural.len())
        .map(|i| g.lengths[i / 3] * s.internal_friction)
        .collect();
    superhelix_kernels::storage::heap::HeapStrand::from_params(
        &superhelix_kernels::storage::ParamsView {
            root_position: g.root_position,
            root_frame: g.root_frame,
            lengths: &g.lengths,
            natural: &s.natural,
            stiffness: &stiffness,
            friction: &friction,
            mass_per_length: g.mass_per_length,
            air_drag: s.air_drag,
            rotary_inertia: g.rotary_inertia,
            loads: &[],
            scale: &[],
        },
    )
}

impl<const N: usize, const D: usize, const E: usize, const B: usize> EmbeddedGroup
    for Group<N, D, E, B>
{
    fn len(&self) -> usize {
        self.strands.len()
    }
    fn push(
        &mut self,
        strand: &Strand,
        q0: &[f64],
        contacts: Option<&EmbeddedContacts>,
        held: Option<HeldTip>,
    ) -> bool {
        let Some(params) = fixed_params::<N, D>(strand) else {
            return false;
        };
        if q0.len() != D {
            return false;
        }
        let mut s = FixedStrand::at_rest(params);
        s.q.copy_from_slice(q0);
        self.strands.push(s);
        let tip_free = held.is_none();
        let coupled = contacts
            .and_then(|c| c.config.hair_hair.as_ref())
            .is_some_and(|h| h.coupling == crate::forces::contacts::Coupling::Pair);
        self.extras.push(StrandExtras {
            loads: strand.point_loads.clone(),
            scale: strand.solver_scale().unwrap_or_default(),
            held: held.map(|tip| {
                Box::new(HeldSlot {
                    tip,
                    geometry: strand.geometry.clone(),
                })
            }),
            coupled: coupled.then(Box::default),
        });
        // (their contact scratch is sized for the strands they had)
        self.workers.clear();
        if let Some(c) = contacts {
            let (_, buffers) = self
                .contacts
                .get_or_insert_with(|| (c.bodies.clone(), Vec::new()));
            buffers.push(StrandContactBuffers::new(strand, &c.config, tip_free));
        }
        true
    }
    fn held(&self, i: usize) -> Option<&HeldTip> {
        self.extras.get(i)?.held.as_ref().map(|h| &h.tip)
    }
    fn held_mut(&mut self, i: usize) -> Option<&mut HeldTip> {
        self.extras.get_mut(i)?.held.as_mut().map(|h| &mut h.tip)
    }
    fn add_contact_force(
        &mut self,
        i: usize,
        t: f64,
        head: &HeadState,
        points: &mut dyn superhelix_kernels::strand_terms::StrandPoints<f64>,
        force: &mut [f64],
    ) {
        let (Some((bodies, buffers)), Some(s)) = (self.contacts.as_mut(), self.strands.get(i))
        else {
            return;
        };
        let Some(b) = buffers.get_mut(i) else { return };
        let mut colliders = BodyColliders::new(bodies.clone());
        let mut scratch = ContactScratch::new(b.samples.len(), N, D);
        let lengths = s.params.lengths;
        let (mut stiffness, mut damping) = (vec![0.0; D * D], vec![0.0; D * D]);
        let (Some(mut stiffness), Some(mut damping)) =
            (Square::new(&mut stiffness, D), Square::new(&mut damping, D))
        else {
            return;
        };
        let zero = [0.0; D];
        b.contacts(&s.params, &lengths, &mut colliders, &mut scratch)
            .add_terms(
                points,
                &s.q,
                &zero,
                t,
                head,
                false,
                force,
                &mut stiffness,
                &mut damping,
            );
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
        let chunk = self.chunk_workers();
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
        // BDF2 with fixed steps: each strand's history lent with it
        let bdf2 = tolerance.is_none() && self.rules.bdf2;
        if bdf2 {
            self.histories
                .resize(self.strands.len(), Default::default());
        }
        let mut history_chunks: Vec<Option<&mut [(StepHistory<D>, ToleranceReport)]>> = if bdf2 {
            self.histories.chunks_mut(chunk).map(Some).collect()
        } else {
            (0..self.strands.len().div_ceil(chunk))
                .map(|_| None)
                .collect()
        };
        let (failure, total, steps) = match (tolerance, self.contacts.as_mut()) {
            (None, Some((_, buffers))) => self
                .strands
                .par_chunks_mut(chunk)
                .zip(buffers.par_chunks_mut(chunk))
                .zip(self.extras.par_chunks_mut(chunk))
                .zip(history_chunks.par_iter_mut())
                .zip(self.workers.par_iter_mut())
                .enumerate()
                .map(|(c, ((((strands, buffers), extras), histories), worker))| {
                    let Worker {
                        ws,
                        contacts,
                        floating,
                        ..
                    } = worker;
                    let Some((colliders, scratch)) = contacts.as_mut() else {
                        return (
                            Some((c * chunk, "a worker without contact scratch".into())),
                            StepCounts::default(),
                            ToleranceReport::default(),
                        );
                    };
                    let mut first = None;
                    let mut counts = StepCounts::default();
                    for (k, ((s, b), extras)) in strands
                        .iter_mut()
                        .zip(buffers.iter_mut())
                        .zip(extras)
                        .enumerate()
                    {
                        let lengths = s.params.lengths;
                        // a coupled strand's end is the pair solve's: its bookkeeping after
                        let deferred = b.coupled().then_some(t + h);
                        let mut contacts = b
                            .contacts(&s.params, &lengths, colliders, scratch)
                            .with_end_deferred(deferred);
                        let history = histories.as_deref_mut().map(|h| &mut h[k].0);
                        let r = step_strand(
                            s,
                            (extras, history),
                            head,
                            effects,
                            (t, h),
                            (ws, floating),
                            &mut counts,
                            Some(&mut contacts),
                        );
                        if let Err(e) = r {
                            first.get_or_insert((c * chunk + k, e.to_string()));
                        }
                    }
                    (first, counts, ToleranceReport::default())
                })
                .reduce(empty, merge),
            (None, None) => self
                .strands
                .par_chunks_mut(chunk)
                .zip(self.extras.par_chunks_mut(chunk))
                .zip(history_chunks.par_iter_mut())
                .zip(self.workers.par_iter_mut())
                .enumerate()
                .map(|(c, (((strands, extras), histories), worker))| {
                    let Worker { ws, floating, .. } = worker;
                    let mut first = None;
                    let mut counts = StepCounts::default();
                    for (k, (s, extras)) in strands.iter_mut().zip(extras).enumerate() {
                        let history = histories.as_deref_mut().map(|h| &mut h[k].0);
                        let r = step_strand(
                            s,
                            (extras, history),
                            head,
                            effects,
                            (t, h),
                            (ws, floating),
                            &mut counts,
                            None,
                        );
                        if let Err(e) = r {
                            first.get_or_insert((c * chunk + k, e.to_string()));
                        }
                    }
                    (first, counts, ToleranceReport::default())
                })
                .reduce(empty, merge),
            (Some(tolerance), contacts) => {
                self.histories
                    .resize(self.strands.len(), Default::default());
                // each strand's contacts, when the scene has them
                let mut buffer_chunks: Vec<Option<&mut [StrandContactBuffers]>> = match contacts {
                    Some((_, buffers)) => buffers.chunks_mut(chunk).map(Some).collect(),
                    None => (0..self.strands.len().div_ceil(chunk))
                        .map(|_| None)
                        .collect(),
                };
                self.strands
                    .par_chunks_mut(chunk)
                    .zip(self.histories.par_chunks_mut(chunk))
                    .zip(self.extras.par_chunks_mut(chunk))
                    .zip(buffer_chunks.par_iter_mut())
                    .zip(self.workers.par_iter_mut())
                    .enumerate()
                    .map(|(c, ((((strands, histories), extras), buffers), worker))| {
                        let Worker {
                            ws,
                            contacts: worker_contacts,
                            floating,
                            ..
                        } = worker;
                        let mut first = None;
                        let mut total = ToleranceReport::default();
                        for (k, ((s, (history, done)), extras)) in strands
                            .iter_mut()
                            .zip(histories.iter_mut())
                            .zip(extras)
                            .enumerate()
                        {
                            let mut r = ToleranceReport::default();
                            let lengths = s.params.lengths;
                            let mut contacts =
                                match (buffers.as_deref_mut(), worker_contacts.as_mut()) {
                                    (Some(b), Some((colliders, scratch))) => {
                                        let deferred = b[k].coupled().then_some(t + h);
                                        Some(
                                            b[k].contacts(&s.params, &lengths, colliders, scratch)
                                                .with_end_deferred(deferred),
                                        )
                                    }
                                    (Some(_), None) => {
                                        first.get_or_insert((
                                            c * chunk + k,
                                            "a worker without contact scratch".into(),
                                        ));
                                        continue;
                                    }
                                    (None, _) => None,
                                };
                            let StrandExtras {
                                loads,
                                scale,
                                held,
                                coupled,
                            } = extras;
                            let mut view = s.view();
                            view.params.loads = loads;
                            view.params.scale = scale;
                            // (a held tip is lent as on fixed steps: this step refuses it)
                            let mut hook = held.as_mut().map(|h| HeldHook {
                                tip: &mut h.tip,
                                geometry: &h.geometry,
                            });
                            if let Some(hook) = hook.as_mut() {
                                view.end = Some(hook);
                            }
                            let mut contacts =
                                contacts.as_mut().map(|c| c as &mut dyn ContactHooks<f64>);
                            let outcome =
                                with_terms!(free_root::<N, D>(), floating, 3 * N, |source| {
                                    let outcome = fixed::step_to_tolerance_views(
                                        source,
                                        &mut view,
                                        &mut history.view(),
                                        head,
                                        effects,
                                        (t, h),
                                        tolerance,
                                        ws.view(),
                                        &mut r,
                                        contacts.as_deref_mut(),
                                    );
                                    if let (Ok(_), Some(slot)) = (&outcome, coupled.as_deref_mut())
                                    {
                                        keep_factors(
                                            slot,
                                            source,
                                            &mut view,
                                            ws,
                                            head,
                                            effects,
                                            (t, h),
                                            contacts,
                                        );
                                    }
                                    outcome
                                });
                            done.add(&r);
                            total.add(&r);
                            if let Err(e) = outcome {
                                first.get_or_insert((c * chunk + k, e.to_string()));
                            }
                        }
                        // the solves' field stiffness and predicted contacts, counted as
                        // the checked step's
                        let counts = StepCounts {
                            field_split: total.field_split,
                            field_projected: total.field_projected,
                            field_undamped: total.field_undamped,
                            contacts_predicted: total.contacts_predicted,
                            ..StepCounts::default()
                        };
                        (first, counts, total)
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
    fn shift_load_energy(&mut self, i: usize, change: f64) {
        if let Some(e) = self.strands.get_mut(i).and_then(|s| s.last_energy.as_mut()) {
            super::system::shift_load_energy(e, change);
        }
    }
    fn set_loads(&mut self, i: usize, loads: &[PointLoad]) {
        if let Some(l) = self.extras.get_mut(i).map(|e| &mut e.loads) {
            l.clear();
            l.extend_from_slice(loads);
        }
    }
    fn forget_energy(&mut self, i: usize) {
        if let Some(s) = self.strands.get_mut(i) {
            s.last_energy = None;
        }
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
                contacts: self
                    .contacts
                    .as_ref()
                    .and_then(|(_, b)| b.get(i))
                    .map(StrandContactBuffers::state),
                held: self.held(i).map(HeldTip::state),
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
        for (position, (s, state)) in self.strands.iter_mut().zip(states).enumerate() {
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
            match (self.contacts.as_mut(), state.contacts) {
                (None, None) => {}
                (Some((_, buffers)), Some(c)) => {
                    let b = buffers
                        .get_mut(position)
                        .ok_or("contacts of fewer strands than the scene's")?;
                    b.restore(c)?;
                }
                (Some(_), None) => return Err("the scene has contacts, the checkpoint none".into()),
                (None, Some(_)) => return Err("the checkpoint has contacts, the scene none".into()),
            }
            match (
                self.extras.get_mut(position).and_then(|e| e.held.as_mut()),
                state.held,
            ) {
                (None, None) => {}
                (Some(slot), Some(h)) => slot.tip.restore(h),
                (Some(_), None) => {
                    return Err("the scene holds a strand's tip, the checkpoint does not".into())
                }
                (None, Some(_)) => {
                    return Err("the checkpoint holds a strand's tip, the scene does not".into())
                }
            }
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
    fn set_rules(&mut self, rules: StepRules) {
        self.rules = rules;
        // (their workspaces were under the old rules)
        self.workers.clear();
    }
    fn contact_summary(&self, i: usize) -> Option<(BodySummary, usize)> {
        self.contacts
            .as_ref()
            .and_then(|(_, b)| b.get(i))
            .map(|b| (b.scalars.summary, b.scalars.partners_touching))
    }
    fn hair_reach(&self) -> Option<f64> {
        let (_, buffers) = self.contacts.as_ref()?;
        buffers
            .iter()
            .filter_map(|b| b.hair.map(|h| 2.0 * h.radius))
            .reduce(f64::max)
    }
    fn samples(&self, i: usize) -> &[(f64, f64)] {
        self.contacts
            .as_ref()
            .and_then(|(_, b)| b.get(i))
            .map_or(&[][..], |b| &b.samples[..])
    }
    fn sample_positions(&self, head: &HeadState) -> Vec<Vec<nalgebra::Vector3<f64>>> {
        let Some((_, buffers)) = self.contacts.as_ref() else {
            return vec![Vec::new(); self.strands.len()];
        };
        self.strands
            .par_iter()
            .zip(buffers.par_iter())
            .map(|(s, b)| {
                // the poses the last step left, when they are those of the strand's state
                let same = b.poses_valid
                    && b.poses_q.len() == s.q.len()
                    && b.poses_q
                        .iter()
                        .zip(&s.q)
                        .all(|(x, y)| x.to_bits() == y.to_bits());
                let place = |poses: &[(nalgebra::Vector3<f64>, nalgebra::Vector3<f64>)]| {
                    poses
                        .iter()
                        .map(|(y, _)| head.position + head.rotation * y)
                        .collect()
                };
                if same {
                    return place(&b.poses);
                }
                // (a free root's translation moves the chain's root)
                let x = if free_root::<N, D>() {
                    nalgebra::Vector3::new(s.q[3 * N], s.q[3 * N + 1], s.q[3 * N + 2])
                } else {
                    nalgebra::Vector3::zeros()
                };
                let root = Pose {
                    position: s.params.root_position + x,
                    frame: s.params.root_frame,
                };
                let zero = nalgebra::Vector3::zeros();
                let mut poses = vec![(zero, zero); b.samples.len()];
                superhelix_kernels::contact::sample_poses(
                    &root,
                    &s.params.lengths,
                    &s.q[..3 * N],
                    &b.samples,
                    &mut poses,
                );
                place(&poses)
            })
            .collect()
    }
    fn fill_partners(&mut self, fill: &(dyn Fn(usize, &mut Vec<PartnerPoint>) + Sync)) {
        let Some((_, buffers)) = self.contacts.as_mut() else {
            return;
        };
        buffers
            .par_iter_mut()
            .enumerate()
            .for_each(|(p, b)| fill(p, &mut b.partners));
    }
    fn start_contacts(&mut self, t: f64, head: &HeadState) {
        use superhelix_kernels::fixed::ContactHooks;
        let Some((bodies, buffers)) = self.contacts.as_mut() else {
            return;
        };
        let mut colliders = BodyColliders::new(bodies.clone());
        let mut scratch = ContactScratch::for_strands(buffers, N, D);
        for (s, b) in self.strands.iter().zip(buffers.iter_mut()) {
            let lengths = s.params.lengths;
            b.contacts(&s.params, &lengths, &mut colliders, &mut scratch)
                .start(&s.q, t, head);
        }
    }
    fn deepest_inside(&mut self, t: f64, head: &HeadState) -> Option<f64> {
        use superhelix_kernels::fixed::ContactHooks;
        self.contacts.as_ref()?;
        let chunk = self.chunk_workers();
        let (_, buffers) = self.contacts.as_mut()?;
        // (the strands in parallel, on the workers' colliders and scratch)
        self.strands
            .par_chunks(chunk)
            .zip(buffers.par_chunks_mut(chunk))
            .zip(self.workers.par_iter_mut())
            .map(|((strands, buffers), worker)| {
                let Some((colliders, scratch)) = worker.contacts.as_mut() else {
                    return 0.0;
                };
                strands
                    .iter()
                    .zip(buffers.iter_mut())
                    .map(|(s, b)| {
                        let lengths = s.params.lengths;
                        b.contacts(&s.params, &lengths, colliders, scratch)
                            .deepest(&s.q, t, head)
                    })
                    .fold(0.0, f64::max)
            })
            .reduce_with(f64::max)
    }
    fn each_coupled(
        &mut self,
        sides: &mut [StrandSides],
        pass: &CoupledPass<'_>,
    ) -> (Option<(usize, String)>, StepStats) {
        let chunk = self.chunk_workers();
        let Some((_, buffers)) = self.contacts.as_mut() else {
            return (None, StepStats::default());
        };
        if sides.len() != self.strands.len() {
            return (
                Some((0, "pair solve: one side per strand is needed".into())),
                StepStats::default(),
            );
        }
        type Partial = (Option<(usize, String)>, StepStats);
        self.strands
            .par_chunks_mut(chunk)
            .zip(self.extras.par_chunks_mut(chunk))
            .zip(buffers.par_chunks_mut(chunk))
            .zip(sides.par_chunks_mut(chunk))
            .zip(self.workers.par_iter_mut())
            .enumerate()
            .map(|(c, ((((strands, extras), buffers), sides), worker))| {
                coupled::chunk_pass(strands, extras, buffers, sides, worker, c * chunk, pass)
            })
            .reduce(
                || (None, StepStats::default()),
                |(a, mut sa): Partial, (b, sb): Partial| {
                    sa.add(&sb);
                    let first = match (a, b) {
                        (Some(a), Some(b)) => Some(if a.0 <= b.0 { a } else { b }),
                        (a, b) => a.or(b),
                    };
                    (first, sa)
                },
            )
    }
}

/// What the embedded engine's strands touch: the bodies and the contact settings.
pub struct EmbeddedContacts {
    /// The bodies the strands may touch.
    pub bodies: Arc<[Body]>,
    /// The scene's contact settings (hair–hair contacts with `coupling = "ball"`).
    pub config: ContactConfig,
}

/// One strand's contacts in the embedded engine: its law, its samples and what they
/// carry from step to step (the rest of the fixed-N step's `ContactStore` is a worker's
/// [`ContactScratch`]).
pub struct StrandContactBuffers {
    params: ContactParams,
    samples: Vec<(f64, f64)>,
    anchors: Vec<Option<Anchor>>,
    allowance: Vec<f64>,
    scalars: ContactScalars,
    /// Whether the contacts that start within a step are predicted
    /// ([`ContactConfig::predict`]).
    predict: bool,
    /// Hair–hair: the law (`None`: no hair–hair contacts) and the partners of the coming
    /// step, in arc-length order.
    hair: Option<HairHairParams>,
    partners: Vec<PartnerPoint>,
    /// A coupled strand's arrays of the contacts that start within a step, its own (the
    /// pair solve resolves them again after every strand has stepped; `None`: the
    /// worker's).
    predicted: Option<Box<PredictedContacts>>,
    /// The samples' poses (head coordinates) at `poses_q` when `poses_valid`: the last
    /// ones the strand's step computed, which are those of its state after the step (the
    /// hair–hair pairs' search and the next step's start take them rather than compute
    /// them again).
    poses: Vec<(nalgebra::Vector3<f64>, nalgebra::Vector3<f64>)>,
    poses_q: Vec<f64>,
    poses_valid: bool,
}

/// The scratch of the contacts of a worker's strands (one per chunk of strands, sized
/// for the most samples among them).
pub struct ContactScratch {
    start_depth: Vec<f64>,
    jac: Vec<nalgebra::Vector3<f64>>,
    aj: Vec<nalgebra::Vector3<f64>>,
    ends: Vec<Pose>,
    end_derivs: Vec<EndDerivatives>,
    chain_q: Vec<f64>,
    chain_valid: usize,
    /// The arrays of the contacts that start within a step.
    predicted: PredictedContacts,
    /// The partners' scratch ([`PartnerStore`]): as many as the most partners of a
    /// strand so far, and the samples at a step's start.
    near: Vec<usize>,
    near_y: Vec<nalgebra::Vector3<f64>>,
    near_y0: Vec<nalgebra::Vector3<f64>>,
    sample_y0: Vec<nalgebra::Vector3<f64>>,
    /// J at the other part of a pair of two parts of a strand, and `J(s) − J(s')`.
    other: Vec<nalgebra::Vector3<f64>>,
    diff: Vec<nalgebra::Vector3<f64>>,
}

impl ContactScratch {
    /// Scratch for strands of `elements` elements (their chain's) and `dofs` coordinates
    /// (3 · `elements`, 3 more with a free root's translation), and at most `samples`
    /// samples.
    pub fn new(samples: usize, elements: usize, dofs: usize) -> Self {
        let zero = nalgebra::Vector3::zeros();
        ContactScratch {
            start_depth: vec![0.0; samples],
            jac: vec![zero; dofs],
            aj: vec![zero; dofs],
            ends: vec![Pose::default(); elements + 1],
            end_derivs: vec![EndDerivatives::default(); elements],
            chain_q: vec![f64::NAN; 3 * elements],
            chain_valid: 0,
            predicted: PredictedContacts::new(samples),
            near: Vec::new(),
            near_y: Vec::new(),
            near_y0: Vec::new(),
            sample_y0: vec![zero; samples],
            other: vec![zero; dofs],
            diff: vec![zero; dofs],
        }
    }

    /// Scratch for the strands of `buffers`, of `elements` elements and `dofs`
    /// coordinates.
    fn for_strands(buffers: &[StrandContactBuffers], elements: usize, dofs: usize) -> Self {
        let samples = buffers.iter().map(|b| b.samples.len()).max().unwrap_or(0);
        ContactScratch::new(samples, elements, dofs)
    }
}

impl StrandContactBuffers {
    /// The buffers of `strand`'s contacts under `config` (the tip free when `tip_free`,
    /// else held: its last samples left to the holder as the runtime engine leaves them;
    /// a free root's first samples are the strand's too).
    pub fn new(strand: &Strand, config: &ContactConfig, tip_free: bool) -> Self {
        let g = &strand.geometry;
        let samples = sample_points(
            g,
            config.samples_per_element.max(1),
            config.free_ends(
                strand.ends.root == crate::model::ends::RootEnd::Free,
                tip_free,
            ),
        );
        let n = samples.len();
        let hair = config
            .hair_hair
            .as_ref()
            .map(|h| h.params(g.mass_per_length));
        let coupled = hair.is_some_and(|h| h.coupled);
        StrandContactBuffers {
            params: config.params(g.mass_per_length),
            anchors: vec![None; n],
            allowance: vec![0.0; n],
            scalars: ContactScalars::default(),
            predict: config.predict,
            hair,
            partners: Vec::new(),
            predicted: (coupled && config.predict).then(|| Box::new(PredictedContacts::new(n))),
            poses: vec![(nalgebra::Vector3::zeros(), nalgebra::Vector3::zeros()); n],
            poses_q: vec![0.0; g.dofs()],
            poses_valid: false,
            samples,
        }
    }

    /// Whether the strand's hair–hair pairs are coupled (`coupling = "pair"`).
    fn coupled(&self) -> bool {
        self.hair.is_some_and(|h| h.coupled)
    }

    /// What the strand's contacts carry from step to step.
    fn state(&self) -> ContactState {
        ContactState {
            anchors: self
                .anchors
                .iter()
                .map(|a| a.map(|a| (a.body, [a.point.x, a.point.y, a.point.z], a.sliding)))
                .collect(),
            allowance: self.allowance.clone(),
            root_zone: self.scalars.root_zone,
            started: self.scalars.started,
            updated: self.scalars.updated,
            last_contact: self.scalars.last_contact,
        }
    }

    /// Continue from `state`; an error when its samples are not this strand's.
    fn restore(&mut self, state: ContactState) -> Result<(), String> {
        let n = self.samples.len();
        if state.anchors.len() != n || state.allowance.len() != n {
            return Err(format!(
                "contacts of {} samples in the checkpoint, {n} in the scene",
                state.anchors.len()
            ));
        }
        self.anchors = state
            .anchors
            .into_iter()
            .map(|a| {
                a.map(|(body, p, sliding)| Anchor {
                    body,
                    point: nalgebra::Vector3::from(p),
                    sliding,
                })
            })
            .collect();
        self.allowance = state.allowance;
        self.scalars = ContactScalars {
            root_zone: state.root_zone,
            started: state.started,
            updated: state.updated,
            last_contact: state.last_contact,
            ..ContactScalars::default()
        };
        Ok(())
    }

    /// The fixed-N step's contacts of the strand of `params` on these buffers and a
    /// worker's `scratch`.
    fn contacts<'a, const N: usize, const D: usize>(
        &'a mut self,
        params: &FixedParams<N, D>,
        lengths: &'a [f64],
        colliders: &'a mut BodyColliders,
        scratch: &'a mut ContactScratch,
    ) -> FixedContacts<'a, BodyColliders, ClosedForm> {
        let m = self.samples.len();
        // the chain of element ends kept in the scratch was another strand's
        scratch.chain_valid = 0;
        let partners = self.partners.len();
        if scratch.near.len() < partners {
            let zero = nalgebra::Vector3::zeros();
            scratch.near.resize(partners, 0);
            scratch.near_y.resize(partners, zero);
            scratch.near_y0.resize(partners, zero);
        }
        let store = ContactStore {
            anchors: &mut self.anchors,
            allowance: &mut self.allowance,
            start_depth: &mut scratch.start_depth[..m],
            poses: &mut self.poses,
            poses_q: &mut self.poses_q,
            poses_valid: &mut self.poses_valid,
            jac: &mut scratch.jac,
            aj: &mut scratch.aj,
            ends: &mut scratch.ends,
            end_derivs: &mut scratch.end_derivs,
            chain_q: &mut scratch.chain_q,
            chain_valid: &mut scratch.chain_valid,
            scalars: &mut self.scalars,
        };
        let contacts = FixedContacts::new(
            params,
            lengths,
            colliders,
            &ClosedForm,
            &self.params,
            &self.samples,
            store,
        );
        let contacts = match (self.predict, self.predicted.as_mut()) {
            (true, Some(own)) => contacts.with_prediction(own.arrays(m + 1, D)),
            (true, None) => contacts.with_prediction(scratch.predicted.arrays(m + 1, D)),
            (false, _) => contacts,
        };
        match &self.hair {
            Some(params) => contacts.with_partners(PartnerStore {
                params,
                partners: &self.partners,
                near: &mut scratch.near,
                near_y: &mut scratch.near_y,
                near_y0: &mut scratch.near_y0,
                sample_y0: &mut scratch.sample_y0[..m],
                other: &mut scratch.other,
                diff: &mut scratch.diff,
            }),
            None => contacts,
        }
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
    /// With contacts, what they carry from step to step.
    contacts: Option<ContactState>,
    /// A held tip's reaction, drift and last residual.
    held: Option<HeldTipState>,
}

/// What a strand's contacts carry from one step to the next in the embedded engine (see
/// [`FixedStrandState`]): per sample its Coulomb anchor (collider, point in its
/// coordinates, sliding) and allowance, the root zone, whether they were started, the
/// time of their last bookkeeping, and the contact energy and its rate at the last
/// measure of the energy balance (the reference the next step's start energy is
/// corrected from when the contacts have a history, as the runtime's checkpoint keeps
/// it).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
struct ContactState {
    anchors: Vec<Option<(usize, [f64; 3], bool)>>,
    allowance: Vec<f64>,
    root_zone: (usize, usize),
    started: bool,
    updated: Option<f64>,
    #[serde(default)]
    last_contact: (f64, f64),
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
    rejected_deep: usize,
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
            rejected_deep: r.rejected_deep,
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
            rejected_deep: self.rejected_deep,
            solves: self.solves,
            energy_limited: self.energy_limited,
            largest_error: self.largest_error,
            smallest_step: self.smallest_step,
            largest_step: self.largest_step,
            // (the engine's counts keep the solves' field stiffness)
            ..ToleranceReport::default()
        }
    }
}

/// What a strand of a [`Group`] lends its step besides its fixed-N arrays: its point
/// loads (empty: none), a pinned root's coordinate scale (empty: none; the joint's
/// θ/l₀ as the runtime engine scales them, `Strand::solver_scale`) and its held tip
/// (`None`: free), the step's end hook as on the runtime engine ([`HeldHook`]).
#[derive(Debug, Clone, Default)]
struct StrandExtras {
    loads: Vec<PointLoad>,
    scale: Vec<f64>,
    held: Option<Box<HeldSlot>>,
    /// In pairs of `coupling = "pair"`: the factors of its step's matrix kept after its
    /// step for the pair solve (`None`: not coupled).
    coupled: Option<Box<OneStepFactors>>,
}

/// A held tip of the embedded engine: the constraint and the geometry its rows are
/// written for.
#[derive(Debug, Clone)]
struct HeldSlot {
    tip: HeldTip,
    geometry: crate::model::strand::StrandGeometry,
}

/// One strand's checked fixed-N step from `t` by `h`, its point loads, scale and (BDF2)
/// its history lent with it.
#[allow(clippy::too_many_arguments)]
fn step_strand<const N: usize, const D: usize, const E: usize, const B: usize>(
    s: &mut FixedStrand<N, D, B>,
    (extras, history): (&mut StrandExtras, Option<&mut StepHistory<D>>),
    head: &dyn HeadTrajectory,
    effects: &Effects,
    (t, h): (f64, f64),
    (ws, floating): (&mut FixedWorkspace<N, D, E>, &mut [f64]),
    counts: &mut StepCounts,
    contacts: Option<&mut dyn ContactHooks<f64>>,
) -> Result<StepReport, StepError> {
    let StrandExtras {
        loads,
        scale,
        held,
        coupled,
    } = extras;
    let mut view = s.view();
    view.params.loads = loads;
    view.params.scale = scale;
    view.history = history.map(|h| h.view());
    // a held tip: the one step's hook on the runtime's constraint, as on the runtime engine
    let mut hook = held.as_mut().map(|h| HeldHook {
        tip: &mut h.tip,
        geometry: &h.geometry,
    });
    if let Some(hook) = hook.as_mut() {
        view.end = Some(hook);
    }
    let mut contacts = contacts;
    with_terms!(free_root::<N, D>(), floating, 3 * N, |source| {
        let outcome = fixed::step_views(
            source,
            &mut view,
            head,
            effects,
            t,
            h,
            ws.view(),
            counts,
            contacts.as_deref_mut(),
        );
        if let (Ok(_), Some(slot)) = (&outcome, coupled.as_deref_mut()) {
            keep_factors(slot, source, &mut view, ws, head, effects, (t, h), contacts);
        }
        outcome
    })
}

/// After a coupled strand's step of `h` from `t`: the factors of its step's matrix kept
/// for the pair solve (`slot`), as the runtime engine keeps them — its last linearly
/// implicit piece's, or after a BDF2 or Newton solve the linearly implicit matrix at the
/// step's end, factored.
#[allow(clippy::too_many_arguments)]
fn keep_factors<S: StepTerms<f64> + ?Sized, const N: usize, const D: usize, const E: usize>(
    slot: &mut OneStepFactors,
    source: &mut S,
    view: &mut StrandView<'_, f64>,
    ws: &mut FixedWorkspace<N, D, E>,
    head: &dyn HeadTrajectory,
    effects: &Effects,
    (t, h): (f64, f64),
    contacts: Option<&mut dyn ContactHooks<f64>>,
) {
    let own = ws.last_factors().is_some();
    if !own {
        let input = StepInput {
            head: head.state(t + h),
            gravity: effects.gravity,
            head_moves: effects.head_moves,
        };
        fixed::factor_step_views(source, view, &input, (h, t + h), ws.view(), contacts);
    }
    slot.keep(ws.last_factors(), view.params.scale, own);
}

/// Whether a group of N elements and D coordinates holds free-root strands (D = 3N + 3:
/// the root's translation after the chain's coordinates).
const fn free_root<const N: usize, const D: usize>() -> bool {
    D == 3 * N + 3
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

/// An empty [`Group`] for free-root strands whose chain has `n` elements (3n + 3
/// coordinates: the root's translation after the chain's; the translation's terms
/// `superhelix_kernels::floating`'s over the closed forms), when this build has the
/// fixed-N code for that N (`superhelix_generated::visit_free_root_size`: the checked-in
/// sizes and those of `SUPERHELIX_N`).
pub fn floating_group_for(n: usize) -> Option<Box<dyn EmbeddedGroup>> {
    superhelix_generated::visit_free_root_size(n, MakeGroup)
}
