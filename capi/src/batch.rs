//! The strands of a batch at one N behind an object-safe trait, and the workspace of
//! one step, so that the C functions need not know N.

use crate::colliders::{Colliders, StepSet};
use crate::contacts::{ContactScratch, ContactSettings, StrandContacts};
use crate::sizes::{visit_size, SizeVisitor};
use core::any::Any;
use core::cell::UnsafeCell;
use superhelix_generated::ClosedForm;
use superhelix_kernels::fixed::batch::{
    head_at_end, step_batch_strand, BatchOutcome, BatchSettings, BatchStrandSpec,
};
use superhelix_kernels::fixed::{
    self, Effects, ExtrapolatedHead, FixedStrand, FixedWorkspace, ParamsError, StepCounts,
    StepError, StepHistory, ToleranceReport,
};
use superhelix_kernels::head::HeadState;
use superhelix_kernels::pose::Pose;

/// Why a batch could not be made: the strand and its parameter error, or no memory.
pub(crate) enum BuildError {
    Params(usize, ParamsError),
    OutOfMemory,
}

/// One checked step of `strand` by `dt` with its contacts with `colliders`
/// (`fixed::step_with_contacts`, as the runtime's embedded engine steps a strand), or
/// with a tolerance the error-controlled step with them (`fixed::step_to_tolerance_views`,
/// the strand's `history`), on the strand's own clock (`contacts.time`, the step's
/// start): the head as `settings` say at the step's end, a collider on a pose of its own
/// moving from its start pose to its end pose over the step. On failure the strand, its
/// history and its contacts are back in the state they had.
#[allow(clippy::too_many_arguments)]
pub(crate) fn step_strand_with_contacts<
    const N: usize,
    const D: usize,
    const E: usize,
    const B: usize,
>(
    strand: &mut FixedStrand<N, D, B>,
    history: Option<&mut StepHistory<D>>,
    contacts: &mut StrandContacts,
    colliders: &Colliders,
    settings: &BatchSettings,
    dt: f64,
    ws: &mut FixedWorkspace<N, D, E>,
    scratch: &mut ContactScratch,
    counts: &mut StepCounts,
    report: &mut ToleranceReport,
) -> Result<f64, StepError> {
    let input = &settings.input;
    let t = contacts.time;
    let head = ExtrapolatedHead {
        t0: t + dt,
        state: head_at_end(input),
    };
    let effects = Effects {
        gravity: input.gravity,
        head_moves: input.head_moves,
    };
    let m = contacts.samples.len();
    scratch.fit(N, m, colliders.items.len());
    let (q, v) = (strand.q, strand.v);
    scratch.kept_anchors[..m].copy_from_slice(&contacts.anchors);
    scratch.kept_allowance[..m].copy_from_slice(&contacts.allowance);
    let scalars = contacts.scalars;
    let outcome = {
        let (frames, mut parts) = scratch.parts();
        let lengths = strand.params.lengths;
        let params = strand.params;
        let Some(mut set) = StepSet::new(&colliders.items, frames, t, dt) else {
            // (the scratch is fitted to the colliders above: never reached)
            return Err(StepError::SingularMatrix);
        };
        let mut hooks = contacts.hooks(&params, &lengths, &mut set, &mut parts);
        match (settings.tolerance, history) {
            (Some(tolerance), Some(history)) => {
                let kept = history.clone();
                fixed::step_to_tolerance_views(
                    &mut &ClosedForm,
                    &mut strand.view(),
                    &mut history.view(),
                    &head,
                    &effects,
                    (t, dt),
                    tolerance,
                    ws.view(),
                    report,
                    Some(&mut hooks),
                )
                .inspect_err(|_| *history = kept)
            }
            _ => fixed::step_with_contacts(
                &ClosedForm,
                strand,
                &head,
                &effects,
                t,
                dt,
                ws,
                counts,
                Some(&mut hooks),
            ),
        }
    };
    match outcome {
        Ok(r) => {
            contacts.time = t + dt;
            Ok(r.max_element_rotation)
        }
        Err(e) => {
            strand.set_state(&q, &v);
            contacts.anchors.copy_from_slice(&scratch.kept_anchors[..m]);
            contacts
                .allowance
                .copy_from_slice(&scratch.kept_allowance[..m]);
            contacts.scalars = scalars;
            Err(e)
        }
    }
}

/// The strands of one batch, all with the same N.
pub(crate) trait Group: Send + Sync {
    /// N.
    fn elements(&self) -> usize;
    /// Number of strands.
    fn len(&self) -> usize;
    /// Bytes one strand keeps.
    fn strand_bytes(&self) -> usize;
    /// A workspace for this N.
    fn new_workspace(&self) -> Workspace;
    /// Step strands `first..first + count` (in range) with `ws` (of this N; else
    /// `None`). Every strand is stepped; one whose step fails keeps its state.
    ///
    /// # Safety
    /// No other reference to those strands may be in use during the call: the caller
    /// steps disjoint ranges from different threads, and nothing else meanwhile.
    ///
    /// With contacts set ([`Self::set_contacts`]) and `colliders` given, each strand
    /// takes the checked step with its contacts ([`step_strand_with_contacts`]).
    unsafe fn step_range(
        &self,
        first: usize,
        count: usize,
        settings: &BatchSettings,
        dt: f64,
        ws: &mut Workspace,
        colliders: Option<&Colliders>,
    ) -> Option<BatchOutcome>;
    /// Give every strand contacts under `settings` (`None`: none), not started: the next
    /// step of each starts them. An error when there is no memory for them.
    fn set_contacts(&mut self, settings: Option<&ContactSettings>) -> Result<(), BuildError>;
    /// Whether the strands have contacts.
    fn has_contacts(&self) -> bool;
    /// Strand `i`'s deepest centreline point inside a collider at the end of its last
    /// step, m (the dense sweep; 0: none), and its samples touching a collider at the
    /// last evaluation of its contact terms; `None` without contacts.
    fn contact_report(
        &mut self,
        i: usize,
        colliders: &Colliders,
        head: &HeadState,
        scratch: &mut ContactScratch,
    ) -> Option<(f64, usize)>;
    /// Bytes the strands' contacts keep (0 without contacts).
    fn contact_bytes(&self) -> usize;
    /// Forget the energy each strand kept of its state (after a change of the world
    /// that changes it: gravity, whether the head moves).
    fn forget_energy(&mut self);
    /// Give every strand a history of the error-controlled step (once; an error when
    /// there is no memory for them).
    fn keep_histories(&mut self) -> Result<(), BuildError>;
    /// The N + 1 element ends of strand `i` in world coordinates into `out` (3(N + 1)
    /// values).
    fn centreline(&self, i: usize, head: &HeadState, out: &mut [f64]);
    /// q and (when given) q̇ of strand `i` into the first 3N values of each.
    fn state(&self, i: usize, q: &mut [f64], v: Option<&mut [f64]>);
    /// Set q and q̇ (zero when `None`) of strand `i` from 3N values each.
    fn set_state(&mut self, i: usize, q: &[f64], v: Option<&[f64]>);
}

/// The scratch of one step at one N.
pub(crate) struct Workspace {
    /// N.
    pub elements: usize,
    /// Bytes of the fixed-N workspace.
    pub bytes: usize,
    inner: Box<dyn Any + Send>,
    /// The contacts' scratch (empty until the first step with contacts).
    pub contacts: ContactScratch,
}

/// The strands of a batch at N elements.
struct Strands<const N: usize, const D: usize, const E: usize, const B: usize> {
    strands: Box<[UnsafeCell<FixedStrand<N, D, B>>]>,
    /// Per strand, the error-controlled step's history (empty until a tolerance is set).
    histories: Box<[UnsafeCell<StepHistory<D>>]>,
    /// Per strand, its contacts (empty without contacts).
    contacts: Box<[UnsafeCell<StrandContacts>]>,
}

// SAFETY: the strands are plain numbers (no pointers, no interior state besides the
// cells). Shared access from several threads happens only through `Group::step_range`
// (each call on its own disjoint range, as its safety contract requires) and the
// read-only methods, which the C API documents must not run concurrently with a step
// of the same strands.
unsafe impl<const N: usize, const D: usize, const E: usize, const B: usize> Sync
    for Strands<N, D, E, B>
{
}

impl<const N: usize, const D: usize, const E: usize, const B: usize> Strands<N, D, E, B> {
    fn strand(&self, i: usize) -> &FixedStrand<N, D, B> {
        // SAFETY: no `&mut` to a strand outlives `step_range` or `set_state`, and neither
        // runs concurrently with a reader (the C API's contract), so this shared
        // reference aliases no live mutable one.
        unsafe { &*self.strands[i].get() }
    }
}

impl<const N: usize, const D: usize, const E: usize, const B: usize> Group for Strands<N, D, E, B> {
    fn elements(&self) -> usize {
        N
    }

    fn len(&self) -> usize {
        self.strands.len()
    }

    fn strand_bytes(&self) -> usize {
        FixedStrand::<N, D, B>::BYTES
    }

    fn new_workspace(&self) -> Workspace {
        workspace::<N, D, E>()
    }

    unsafe fn step_range(
        &self,
        first: usize,
        count: usize,
        settings: &BatchSettings,
        dt: f64,
        ws: &mut Workspace,
        colliders: Option<&Colliders>,
    ) -> Option<BatchOutcome> {
        let scratch = &mut ws.contacts;
        let ws = ws.inner.downcast_mut::<FixedWorkspace<N, D, E>>()?;
        let range = first..first.checked_add(count)?;
        let cells = self.strands.get(range.clone())?;
        let histories = self.histories.get(range.clone());
        let contacts = colliders.and_then(|c| Some((c, self.contacts.get(range)?)));
        let mut outcome = BatchOutcome::default();
        for (k, cell) in cells.iter().enumerate() {
            // SAFETY: the caller guarantees that nothing else uses the strands of this
            // range during the call, so this is the only reference to the strand and to
            // its history.
            let strand = unsafe { &mut *cell.get() };
            // SAFETY: as for the strand: the history of a strand of this range is used by
            // this call alone.
            let history = histories
                .and_then(|h| h.get(k))
                .map(|h| unsafe { &mut *h.get() });
            let mut report = ToleranceReport::default();
            let stepped = match contacts {
                Some((colliders, cells)) => {
                    // SAFETY: as for the strand: its contacts are used by this call alone.
                    let c = unsafe { &mut *cells[k].get() };
                    step_strand_with_contacts(
                        strand,
                        history,
                        c,
                        colliders,
                        settings,
                        dt,
                        ws,
                        scratch,
                        &mut outcome.counts,
                        &mut report,
                    )
                }
                None => step_batch_strand(
                    &ClosedForm,
                    strand,
                    history,
                    settings,
                    dt,
                    ws,
                    &mut outcome.counts,
                    &mut report,
                ),
            };
            outcome.record(first + k, stepped, &report);
        }
        Some(outcome)
    }

    fn set_contacts(&mut self, settings: Option<&ContactSettings>) -> Result<(), BuildError> {
        let Some(settings) = settings else {
            self.contacts = Box::new([]);
            return Ok(());
        };
        let mut contacts = Vec::new();
        contacts
            .try_reserve_exact(self.strands.len())
            .map_err(|_| BuildError::OutOfMemory)?;
        for s in self.strands.iter_mut() {
            let p = &s.get_mut().params;
            contacts.push(UnsafeCell::new(StrandContacts::new(
                settings,
                &p.lengths,
                p.mass_per_length,
            )));
        }
        self.contacts = contacts.into_boxed_slice();
        // the energies kept were measured without the contacts
        self.forget_energy();
        Ok(())
    }

    fn has_contacts(&self) -> bool {
        !self.contacts.is_empty()
    }

    fn contact_report(
        &mut self,
        i: usize,
        colliders: &Colliders,
        head: &HeadState,
        scratch: &mut ContactScratch,
    ) -> Option<(f64, usize)> {
        let strand = self.strands.get_mut(i)?.get_mut();
        let contacts = self.contacts.get_mut(i)?.get_mut();
        let deepest = crate::contacts::deepest(strand, contacts, colliders, head, scratch);
        Some((deepest, contacts.scalars.summary.contacts))
    }

    fn contact_bytes(&self) -> usize {
        use core::mem::size_of;
        self.contacts
            .iter()
            .map(|c| {
                // SAFETY: read only, outside any step (the C API's contract for the
                // read functions).
                let c = unsafe { &*c.get() };
                size_of::<StrandContacts>()
                    + c.samples.capacity() * size_of::<(f64, f64)>()
                    + c.anchors.capacity()
                        * size_of::<Option<superhelix_kernels::contact::Anchor>>()
                    + c.allowance.capacity() * size_of::<f64>()
            })
            .sum()
    }

    fn forget_energy(&mut self) {
        for s in self.strands.iter_mut() {
            s.get_mut().last_energy = None;
        }
    }

    fn keep_histories(&mut self) -> Result<(), BuildError> {
        if self.histories.len() == self.strands.len() {
            return Ok(());
        }
        let mut histories = Vec::new();
        histories
            .try_reserve_exact(self.strands.len())
            .map_err(|_| BuildError::OutOfMemory)?;
        histories.resize_with(self.strands.len(), || {
            UnsafeCell::new(StepHistory::default())
        });
        self.histories = histories.into_boxed_slice();
        Ok(())
    }

    fn centreline(&self, i: usize, head: &HeadState, out: &mut [f64]) {
        let mut ends = [Pose::default(); E];
        fixed::centreline(&ClosedForm, self.strand(i), &mut ends);
        for (end, xyz) in ends.iter().zip(out.chunks_exact_mut(3)) {
            let w = head.to_world(&end.position);
            xyz.copy_from_slice(w.as_slice());
        }
    }

    fn state(&self, i: usize, q: &mut [f64], v: Option<&mut [f64]>) {
        let s = self.strand(i);
        q[..D].copy_from_slice(&s.q);
        if let Some(v) = v {
            v[..D].copy_from_slice(&s.v);
        }
    }

    fn set_state(&mut self, i: usize, q: &[f64], v: Option<&[f64]>) {
        let s = self.strands[i].get_mut();
        let mut qq = [0.0; D];
        qq.copy_from_slice(&q[..D]);
        let mut vv = [0.0; D];
        if let Some(v) = v {
            vv.copy_from_slice(&v[..D]);
        }
        s.set_state(&qq, &vv);
        if let Some(h) = self.histories.get_mut(i) {
            h.get_mut().forget();
        }
        if let Some(c) = self.contacts.get_mut(i) {
            c.get_mut().restart();
        }
    }
}

/// A workspace at N elements.
fn workspace<const N: usize, const D: usize, const E: usize>() -> Workspace {
    Workspace {
        elements: N,
        bytes: FixedWorkspace::<N, D, E>::BYTES,
        inner: Box::new(FixedWorkspace::<N, D, E>::new()),
        contacts: ContactScratch::default(),
    }
}

/// Builds the strands of a batch.
struct Build<'a, 'b> {
    specs: &'a [BatchStrandSpec<'b>],
}

impl SizeVisitor for Build<'_, '_> {
    type Output = Result<Box<dyn Group>, BuildError>;

    fn visit<const N: usize, const D: usize, const E: usize, const B: usize>(self) -> Self::Output {
        let mut strands = Vec::new();
        strands
            .try_reserve_exact(self.specs.len())
            .map_err(|_| BuildError::OutOfMemory)?;
        for (i, s) in self.specs.iter().enumerate() {
            let params = s.params::<N, D>().map_err(|e| BuildError::Params(i, e))?;
            strands.push(UnsafeCell::new(FixedStrand::<N, D, B>::at_rest(params)));
        }
        Ok(Box::new(Strands::<N, D, E, B> {
            strands: strands.into_boxed_slice(),
            histories: Box::new([]),
            contacts: Box::new([]),
        }))
    }
}

/// The strands of `specs` (each with N elements: `lengths` N values, `natural` 3N), at
/// rest in their natural shape; `None` when N has no generated code.
pub(crate) fn build(
    n: usize,
    specs: &[BatchStrandSpec<'_>],
) -> Option<Result<Box<dyn Group>, BuildError>> {
    visit_size(n, Build { specs })
}

struct MakeWorkspace;

impl SizeVisitor for MakeWorkspace {
    type Output = Workspace;
    fn visit<const N: usize, const D: usize, const E: usize, const B: usize>(self) -> Self::Output {
        workspace::<N, D, E>()
    }
}

/// A workspace for `n` elements; `None` when N has no generated code.
pub(crate) fn new_workspace(n: usize) -> Option<Workspace> {
    visit_size(n, MakeWorkspace)
}

/// Bytes of one strand and of one workspace at N elements.
struct Bytes;

impl SizeVisitor for Bytes {
    type Output = (usize, usize);
    fn visit<const N: usize, const D: usize, const E: usize, const B: usize>(self) -> Self::Output {
        (
            FixedStrand::<N, D, B>::BYTES,
            FixedWorkspace::<N, D, E>::BYTES,
        )
    }
}

/// (bytes per strand, bytes per workspace) at `n` elements; `None` when N has no
/// generated code.
pub(crate) fn bytes(n: usize) -> Option<(usize, usize)> {
    visit_size(n, Bytes)
}
