//! The embedded engine's strands in the pair solve of `coupling = "pair"`
//! ([`super::super::pair_coupling`]): a group's strand after its step as a
//! [`CoupledStrand`], on a worker's workspace, colliders and scratch.

use super::{free_root, ContactScratch, HeldSlot, StrandContactBuffers, StrandExtras, Worker};
use crate::bodies::Placement;
use crate::forces::contacts::strand_contacts::BodyColliders;
use crate::solver::embedded::CoupledPass;
use crate::solver::pair_coupling::{self, CoupledStrand, StrandSides};
use crate::solver::stats::StepStats;
use superhelix_generated::ClosedForm;
use superhelix_kernels::contact::partners::{HairHairParams, PartnerPoint};
use superhelix_kernels::fixed::{ContactHooks, FixedStrand, FixedWorkspace};
use superhelix_kernels::floating::{Floating, FloatingScratch};
use superhelix_kernels::moments::EndDerivatives;
use superhelix_kernels::pose::Pose;
use superhelix_kernels::strand_terms::{PointsOf, StepTerms};

/// The chain of element ends the pair solve's points of one strand are placed along,
/// kept while its q is the same (`superhelix_kernels::strand_point::PointChain`: a
/// strand's partners and samples, in arc-length order, chain each element once), as the
/// runtime's kernels keep theirs.
#[derive(Default)]
pub(super) struct PairPoints {
    ends: Vec<Pose>,
    derivs: Vec<EndDerivatives>,
    chain_q: Vec<f64>,
    pub(super) valid: usize,
}

impl PairPoints {
    /// For a chain of `elements` elements, nothing kept.
    pub(super) fn new(elements: usize) -> Self {
        PairPoints {
            ends: vec![Pose::default(); elements + 1],
            derivs: vec![EndDerivatives::default(); elements],
            chain_q: vec![f64::NAN; 3 * elements],
            valid: 0,
        }
    }
}

/// The pair solve's `pass` on the coupled strands of one worker's chunk (the group's
/// strands from `first_index`, with their extras, contacts and sides): the first
/// failure (position in the group, cause) and the counts.
pub(super) fn chunk_pass<const N: usize, const D: usize, const E: usize, const B: usize>(
    strands: &mut [FixedStrand<N, D, B>],
    extras: &mut [StrandExtras],
    buffers: &mut [StrandContactBuffers],
    sides: &mut [StrandSides],
    worker: &mut Worker<N, D, E>,
    first_index: usize,
    pass: &CoupledPass<'_>,
) -> (Option<(usize, String)>, StepStats) {
    let Worker {
        ws,
        contacts,
        floating: floating_scratch,
        pair_points,
    } = worker;
    let mut stats = StepStats::default();
    let Some((colliders, scratch)) = contacts.as_mut() else {
        return (
            Some((first_index, "a worker without contact scratch".into())),
            stats,
        );
    };
    let mut first = None;
    for (k, (((s, x), b), side)) in strands
        .iter_mut()
        .zip(extras.iter_mut())
        .zip(buffers.iter_mut())
        .zip(sides.iter_mut())
        .enumerate()
    {
        if x.coupled.is_none() {
            continue;
        }
        let floating = if free_root::<N, D>() {
            match FloatingScratch::on(floating_scratch, 3 * N) {
                Some(scratch) => Some(Floating {
                    chain: &ClosedForm,
                    scratch,
                }),
                None => {
                    first.get_or_insert((
                        first_index + k,
                        "a free root's scratch is too short".into(),
                    ));
                    continue;
                }
            }
        } else {
            None
        };
        // (the chain kept was another strand's)
        pair_points.valid = 0;
        let mut strand = EmbeddedStrand {
            strand: s,
            extras: x,
            buffers: b,
            colliders,
            scratch,
            ws,
            floating,
            points: pair_points,
        };
        if let Err(e) = pass(&mut strand, side, &mut stats) {
            first.get_or_insert((first_index + k, e));
        }
    }
    (first, stats)
}

/// A strand of a [`Group`] after its step, as the pair solve sees it
/// ([`CoupledStrand`]): its arrays, extras and contacts, with a worker's workspace,
/// colliders and scratch for its points, its free root's momentum and its contacts'
/// bookkeeping.
struct EmbeddedStrand<'a, const N: usize, const D: usize, const E: usize, const B: usize> {
    strand: &'a mut FixedStrand<N, D, B>,
    extras: &'a mut StrandExtras,
    buffers: &'a mut StrandContactBuffers,
    colliders: &'a mut BodyColliders,
    scratch: &'a mut ContactScratch,
    ws: &'a mut FixedWorkspace<N, D, E>,
    /// A free root's terms over the closed forms (`None`: a chain of 3N coordinates).
    floating: Option<Floating<'a, &'static ClosedForm>>,
    /// The chain its points are placed along.
    points: &'a mut PairPoints,
}

/// `$points`, the strand's points ([`StrandPoints`]) on the closed forms or a free
/// root's terms `$floating`, at the parameters `$params`, with the workspace `$ws`'s
/// point scratch.
macro_rules! strand_points {
    ($points:ident, $ws:expr, $floating:expr, $params:expr) => {
        let (mut point_scratch, _) = $ws.point_scratch();
        let mut chain = &ClosedForm;
        let source: &mut dyn StepTerms<f64> = match $floating.as_mut() {
            Some(f) => f,
            None => &mut chain,
        };
        let mut $points = PointsOf {
            source,
            shape: $params.shape(),
            scratch: &mut point_scratch,
        };
    };
}

impl<const N: usize, const D: usize, const E: usize, const B: usize>
    EmbeddedStrand<'_, N, D, E, B>
{
    /// The strand's linear momentum at its end (a free root's; zero otherwise).
    fn linear_momentum(&mut self) -> nalgebra::Vector3<f64> {
        let Some(f) = self.floating.as_mut() else {
            return nalgebra::Vector3::zeros();
        };
        // (the workspace's moments were another strand's)
        self.ws.forget();
        let (_, mut buffers) = self.ws.point_scratch();
        f.momentum(
            &self.strand.params.shape(),
            &mut buffers,
            &self.strand.q,
            &self.strand.v,
        )
    }
}

impl<const N: usize, const D: usize, const E: usize, const B: usize> CoupledStrand
    for EmbeddedStrand<'_, N, D, E, B>
{
    fn coupled_law(&self) -> Option<HairHairParams> {
        self.buffers.hair.filter(|h| h.coupled)
    }
    fn partners(&self) -> &[PartnerPoint] {
        &self.buffers.partners
    }
    fn samples(&self) -> &[(f64, f64)] {
        &self.buffers.samples
    }
    fn end(&self) -> (&[f64], &[f64]) {
        (&self.strand.q, &self.strand.v)
    }
    /// The closed forms' point through the chain kept ([`PairPoints`]); with a free root
    /// the chain's point moved by the translation, its last three columns the identity
    /// (as `superhelix_kernels::floating::Floating` places it).
    fn point(&mut self, s: f64, jac: &mut [nalgebra::Vector3<f64>]) -> nalgebra::Vector3<f64> {
        let n = 3 * N;
        let params = &self.strand.params;
        let root = Pose {
            position: params.root_position,
            frame: params.root_frame,
        };
        let p = &mut *self.points;
        let y = superhelix_kernels::strand_point::strand_point(
            &ClosedForm,
            &root,
            &params.lengths,
            &mut p.ends,
            &mut p.derivs,
            Some(superhelix_kernels::strand_point::PointChain {
                q: &mut p.chain_q[..n],
                valid: &mut p.valid,
            }),
            &self.strand.q[..n],
            s,
            &mut jac[..n],
            superhelix_kernels::strand_point::NO_HESSIAN,
        );
        if !free_root::<N, D>() {
            return y;
        }
        for (k, col) in jac[n..n + 3].iter_mut().enumerate() {
            let mut e = nalgebra::Vector3::zeros();
            e[k] = 1.0;
            *col = e;
        }
        let q = &self.strand.q;
        y + nalgebra::Vector3::new(q[n], q[n + 1], q[n + 2])
    }
    fn factors(&self) -> (f64, bool) {
        self.extras
            .coupled
            .as_ref()
            .map_or((0.0, false), |f| (f.piece, f.own))
    }
    fn solve(&mut self, x: &mut [f64]) -> bool {
        self.extras.coupled.as_mut().is_some_and(|f| f.solve(x))
    }
    fn holds_tip(&self) -> bool {
        self.extras.held.is_some()
    }
    fn prepare_held(&mut self, t: f64) -> Result<(), String> {
        let StrandExtras { held, coupled, .. } = &mut *self.extras;
        let Some(held) = held.as_mut() else {
            return Ok(());
        };
        let Some(factors) = coupled.as_mut() else {
            return Err("held tip: no step matrix kept".into());
        };
        let HeldSlot { tip, geometry } = &mut **held;
        strand_points!(points, self.ws, self.floating, self.strand.params);
        tip.prepare_change(
            &mut points,
            geometry,
            &mut |x| factors.solve(x),
            &self.strand.q,
            t,
        )
        .ok_or_else(|| "held tip: singular step matrix".to_string())
    }
    fn constrain_held(&mut self, u: &mut [f64]) -> Result<nalgebra::Vector6<f64>, String> {
        pair_coupling::constrain(self.extras.held.as_deref().map(|h| &h.tip), u)
    }
    fn keeps_momentum(&self) -> bool {
        free_root::<N, D>() && self.extras.held.is_none()
    }
    fn momentum(&mut self) -> [f64; 3] {
        self.linear_momentum().into()
    }
    fn move_end(&mut self, dv: &[f64], c: f64) {
        pair_coupling::move_by(&mut self.strand.q, &mut self.strand.v, dv, c);
        // the end the step measured is not the strand's any more: the next step measures
        // its start's energy afresh (as the runtime engine does for a state it did not
        // end in)
        self.strand.last_energy = None;
    }
    fn resolve_again(&mut self, at: &Placement, stats: &mut StepStats) -> Result<(), String> {
        let Some(factors) = self.extras.coupled.as_mut() else {
            return Ok(());
        };
        let FixedStrand { params, q, v, .. } = &mut *self.strand;
        let lengths = params.lengths;
        let mut contacts = self
            .buffers
            .contacts(params, &lengths, self.colliders, self.scratch);
        strand_points!(points, self.ws, self.floating, params);
        let pushed = contacts
            .resolve(&mut points, q, v, None, at.time, &at.head, &mut |x| {
                factors.solve(x)
            })
            .map_err(|_| "contacts within the step: singular step matrix".to_string())?;
        stats.contacts_predicted += pushed;
        Ok(())
    }
    fn correct_momentum(&mut self, target: [f64; 3]) {
        if self.floating.is_none() {
            return;
        }
        let p = self.linear_momentum();
        // ρS L, as the free root's mass matrix has it
        let shape = self.strand.params.shape();
        let length: f64 = shape.lengths.iter().copied().sum();
        let mass = shape.mass_per_length * length;
        let x = D - 3;
        for k in 0..3 {
            self.strand.v[x + k] += (target[k] - p[k]) / mass;
        }
    }
    fn finish_held(
        &mut self,
        lambda: &nalgebra::Vector6<f64>,
        sigma: f64,
        t: f64,
    ) -> Result<(), String> {
        let Some(held) = self.extras.held.as_mut() else {
            return Ok(());
        };
        let HeldSlot { tip, geometry } = &mut **held;
        tip.add_impulse(lambda, sigma, t);
        let FixedStrand { params, q, .. } = &mut *self.strand;
        strand_points!(points, self.ws, self.floating, params);
        tip.project(&mut points, geometry, q, t)
            .map(|_| ())
            .map_err(|e| e.to_string())
    }
    fn end_contacts(&mut self, at: &Placement, h: f64) {
        let lengths = self.strand.params.lengths;
        let mut contacts =
            self.buffers
                .contacts(&self.strand.params, &lengths, self.colliders, self.scratch);
        contacts.after_step(&self.strand.q, at.time, &at.head, h);
    }
}
