//! The fixed-N step's contacts with colliders: what the checked step asks of a strand's
//! contacts ([`ContactHooks`]: their terms in the step's matrix, the energy they store
//! for the energy balance, whether a step went too deep, the bookkeeping after a step)
//! and its implementation for a strand's body contacts on the caller's storage
//! ([`FixedContacts`], on [`crate::contact::body`]: the law, the queries and the sweep
//! the runtime's contacts use).
//!
//! The step places the colliders at each time it evaluates ([`StepColliders::place`]):
//! at a step's end for its terms (the linearly implicit step's matrix is built there),
//! at both ends for its acceptance. The contacts that start within a step are caught by
//! the acceptance: a sample that ends deeper than [`ContactParams::split_depth`] beyond
//! its start splits the step.
//!
//! Hair–hair contact enters as the strand's *partners* ([`PartnerStore`],
//! [`FixedContacts::with_partners`]): points of other strands the caller's broad phase
//! paired with this strand's samples before the step, each a ball of radius `reach`
//! moving with the other strand's point ([`crate::contact::partners`]: the penalty,
//! damping and rod friction of the runtime's `coupling = "ball"`); a pair of two parts of
//! one strand (self-contact, [`PartnerPoint::partner_s`]) is stepped implicitly on both
//! parts.

use super::params::FixedParams;
use crate::contact::body::{BodyContacts, BodySummary, ColliderSet, ContactSink, TermsAsked};
use crate::contact::partners::{self, HairHairParams, PartnerContacts, PartnerPoint};
use crate::contact::predicted::{self, PredictedArrays, PredictionHost, SingularStep};
use crate::contact::samples::positions_along;
use crate::contact::{sample_poses, Anchor, ContactParams, Friction};
use crate::float::Float;
use crate::head::HeadState;
use crate::moments::EndDerivatives;
use crate::pose::Pose;
use crate::storage::Square;
use crate::strand_point::{strand_point, PointChain};
use crate::strand_terms::{MomentSource, StrandPoints};
use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// Standard gravity, m/s²: the scale of "a hundred times the strand's weight" below which
/// a depth at the start is left to the penalty.
pub const STANDARD_GRAVITY: f64 = 9.80665;

/// Colliders a step places in time: those on their own motion take their pose at `t`.
pub trait StepColliders: ColliderSet {
    /// Place the colliders at time `t`, the head in `head` (nothing for colliders on the
    /// head or in the world).
    fn place(&mut self, t: f64, head: &HeadState);
    /// Whether a collider moves relative to the head frame over the step from `t0` (head
    /// `head0`) to `t1` (head `head1`): then contacts do work on the strand even while the
    /// head moves uniformly (a world collider while the head moves, a collider on its own
    /// motion that moves).
    fn moves_relative(&self, t0: f64, t1: f64, head0: &HeadState, head1: &HeadState) -> bool;
}

/// Colliders placed once and never moved: a set on the head, or in the world.
impl<T: crate::collider::Collider> StepColliders for [(T, crate::collider::Mount)] {
    fn place(&mut self, _t: f64, _head: &HeadState) {}
    fn moves_relative(&self, _t0: f64, _t1: f64, head0: &HeadState, head1: &HeadState) -> bool {
        let moves = |h: &HeadState| h.velocity != V3::zeros() || h.omega != V3::zeros();
        let world = self
            .iter()
            .any(|(_, m)| !matches!(m, crate::collider::Mount::Head));
        world && (moves(head0) || moves(head1))
    }
}

/// What the checked step asks of a strand's contacts. q and q̇ are the step's (`T`, 3N
/// long), its matrices [`Square`]s of 3N; [`FixedContacts`] works in `f64`.
pub trait ContactHooks<T: Float> {
    /// Before the strand's first step, at state q, time t: the root zone, the depths
    /// allowed at the start, the first anchors.
    fn start(&mut self, q: &[T], t: f64, head: &HeadState);
    /// Whether [`Self::start`] was done.
    fn started(&self) -> bool;
    /// Add the contact terms at (q, q̇), time t (the colliders placed there) to the step's
    /// force, stiffness (with the strand's curvature under the forces when `curvature`)
    /// and damping; whether a contact added stiffness. `points` are the strand's, from
    /// the step's own terms (contacts that keep a source of their own need not ask).
    #[allow(clippy::too_many_arguments)]
    fn add_terms(
        &mut self,
        points: &mut dyn StrandPoints<T>,
        q: &[T],
        v: &[T],
        t: f64,
        head: &HeadState,
        curvature: bool,
        force: &mut [T],
        stiffness: &mut Square<'_, T>,
        damping: &mut Square<'_, T>,
    ) -> bool;
    /// The energy the contacts store at (q, q̇), time t, and its rate at fixed q through
    /// the colliders' motion (with the work of moving colliders' damping; `points` as
    /// [`Self::add_terms`] gets them).
    fn energy(
        &mut self,
        points: &mut dyn StrandPoints<T>,
        q: &[T],
        v: &[T],
        t: f64,
        head: &HeadState,
    ) -> (f64, f64);
    /// Whether a step from q0 (time t0) to q1 (time t1) is acceptable for the contacts:
    /// no sample went deeper than the split depth beyond its depth at the start.
    #[allow(clippy::too_many_arguments)]
    fn acceptable(
        &mut self,
        q0: &[T],
        q1: &[T],
        t0: f64,
        head0: &HeadState,
        t1: f64,
        head1: &HeadState,
    ) -> bool;
    /// After an accepted step of `h` seconds ending at (q, t): the allowances shrink, the
    /// anchors stick, slide or let go.
    fn after_step(&mut self, q: &[T], t: f64, head: &HeadState, h: f64);
    /// Whether the contacts carry a history from step to step (anchors, allowances): the
    /// start energy of a step is then measured afresh.
    fn has_history(&self) -> bool;
    /// Whether what the strand touches moves relative to the head frame over the step
    /// ([`StepColliders::moves_relative`], or partners of other strands).
    fn moves_relative(&self, t0: f64, t1: f64, head0: &HeadState, head1: &HeadState) -> bool;
    /// Whether the strand has partners of other strands for the coming step: their
    /// energy at the step's start is then measured again (they moved since the last
    /// step's end), the rest of the start's energy kept.
    fn has_partners(&self) -> bool {
        false
    }
    /// The deepest point of the centreline inside a collider at q, time t, m (0: none).
    fn deepest(&mut self, q: &[T], t: f64, head: &HeadState) -> f64;
    /// What the last [`Self::add_terms`] found.
    fn summary(&self) -> BodySummary;
    /// Whether a contact acted in the last [`Self::add_terms`] (a sample touched a
    /// collider or a partner): the error-controlled step does not extrapolate across it.
    fn touching(&self) -> bool {
        self.summary().contacts > 0
    }
    /// The contact energy and rate of the last measure of the energy balance (kept by
    /// the caller of [`Self::energy`]).
    fn last_contact(&mut self) -> &mut (f64, f64);
    /// Forget the last prediction of the contacts that start within a step (before each
    /// attempt of a step). Nothing for contacts that do not predict.
    fn forget(&mut self) {}
    /// Predict the contacts that start within a step
    /// ([`crate::contact::predicted`]): from the step's linearisation point `q_lin` and
    /// its solution without them `q_pred`, the colliders placed at `t` (the step's end,
    /// head `head`). Whether there is any candidate; false for contacts that do not
    /// predict.
    fn predict(&mut self, q_lin: &[T], q_pred: &[T], t: f64, head: &HeadState) -> bool {
        let _ = (q_lin, q_pred, t, head);
        false
    }
    /// Resolve the predicted contacts at the end (q, q̇) of the step's solve
    /// ([`crate::contact::predicted::resolve`], `map = Some((c, σ))`), or again on an end
    /// changed since (`None`: [`crate::contact::predicted::resolve_again`]), with the
    /// step's factors in `solve` (A x = b in place, f64). The colliders are placed at
    /// `t`. Returns the number of candidates that push. `points` as [`Self::add_terms`]
    /// gets them.
    #[allow(clippy::too_many_arguments)]
    fn resolve(
        &mut self,
        points: &mut dyn StrandPoints<T>,
        q: &mut [T],
        v: &mut [T],
        map: Option<(f64, f64)>,
        t: f64,
        head: &HeadState,
        solve: &mut dyn FnMut(&mut [f64]) -> bool,
    ) -> Result<usize, SingularStep> {
        let _ = (points, q, v, map, t, head, solve);
        Ok(0)
    }
}

/// What a strand's contacts carry from step to step besides the per-sample arrays.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactScalars {
    /// The root zone: `(collider, count)`.
    pub root_zone: (usize, usize),
    /// Whether the start's bookkeeping was done.
    pub started: bool,
    /// The time of the last bookkeeping (start or after a step), s.
    pub updated: Option<f64>,
    /// What the last evaluation of the terms found.
    pub summary: BodySummary,
    /// The contact energy and its rate at the last measure of the energy balance.
    pub last_contact: (f64, f64),
    /// Partners within reach at the last evaluation of the terms.
    pub partners_touching: usize,
}

/// A strand's contact storage, the caller's: per sample its anchor, allowance, pose and
/// depth at a step's start; per coordinate (3N) two Jacobian columns; per element its
/// end pose (N + 1) and end derivatives (N); and the scalars.
pub struct ContactStore<'a> {
    /// Coulomb anchors, one per sample.
    pub anchors: &'a mut [Option<Anchor>],
    /// Allowed depths, one per sample, m.
    pub allowance: &'a mut [f64],
    /// Scratch: depth at a step's start, one per sample.
    pub start_depth: &'a mut [f64],
    /// Scratch: position and unit tangent, one per sample.
    pub poses: &'a mut [(V3, V3)],
    /// Scratch: J(s), a column per coordinate (3N; 3N + 3 with a free root).
    pub jac: &'a mut [V3],
    /// Scratch: A J(s), as many columns as `jac`.
    pub aj: &'a mut [V3],
    /// The q (every coordinate of the strand) the samples' poses in `poses` were last
    /// computed at, when `poses_valid`: asked again at the same q (bit for bit), they are
    /// not computed again. A strand that keeps `poses`, `poses_q` and `poses_valid` as its
    /// own from one step to the next (rather than a worker's scratch shared by its
    /// strands, whose `poses_valid` is then cleared for each strand) also skips them at
    /// the next step's start, which is its last step's end.
    pub poses_q: &'a mut [f64],
    /// Whether `poses` hold the samples' poses at `poses_q`.
    pub poses_valid: &'a mut bool,
    /// Scratch: element end poses, N + 1.
    pub ends: &'a mut [Pose],
    /// Scratch: element end derivatives, N.
    pub end_derivs: &'a mut [EndDerivatives],
    /// Scratch: the q the chain of ends was computed for (3N), and its count.
    pub chain_q: &'a mut [f64],
    /// Elements of the chain valid for `chain_q`.
    pub chain_valid: &'a mut usize,
    /// The rest of what the contacts carry.
    pub scalars: &'a mut ContactScalars,
}

/// A strand's body contacts in the fixed-N step: its colliders, the source of its points
/// (the f64 closed forms), the law, the samples, and its storage.
pub struct FixedContacts<'a, C: StepColliders + ?Sized, P: MomentSource + ?Sized> {
    /// The colliders.
    pub colliders: &'a mut C,
    /// Where the strand's points come from (f64).
    pub source: &'a P,
    /// The contact law's parameters.
    pub params: &'a ContactParams,
    /// Arc length and weight of each sample ([`crate::contact::sample_points`]).
    pub samples: &'a [(f64, f64)],
    /// The strand's root pose, head coordinates.
    pub root: Pose,
    /// Element lengths, m.
    pub lengths: &'a [f64],
    /// Mass per length ρS, kg/m (the scale of a harmless depth at the start).
    pub mass_per_length: f64,
    /// The storage.
    pub store: ContactStore<'a>,
    /// The arrays of the contacts that start within a step (`None`: not predicted; the
    /// step's acceptance by depth catches them): [`Self::with_prediction`].
    pub predicted: Option<PredictedArrays<'a>>,
    /// Hair–hair: the strand's partners and their scratch (`None`: no hair–hair
    /// contact): [`Self::with_partners`].
    pub partners: Option<PartnerStore<'a>>,
    /// The time of the step's end whose bookkeeping ([`ContactHooks::after_step`]) the
    /// caller does itself, after it has moved the strand's end (the pair solve of
    /// coupled hair–hair pairs): [`Self::with_end_deferred`].
    pub end_deferred: Option<f64>,
}

/// A strand's hair–hair partners for the coming step and their scratch, the caller's.
/// The scratch arrays hold at least as many entries as `partners` (`sample_y0` as many
/// as the samples).
pub struct PartnerStore<'a> {
    /// The hair–hair law's parameters.
    pub params: &'a HairHairParams,
    /// The partners, in arc-length order (`s` increasing).
    pub partners: &'a [PartnerPoint],
    /// Scratch: the partners the samples do not rule out.
    pub near: &'a mut [usize],
    /// Scratch: their points on the strand.
    pub near_y: &'a mut [V3],
    /// Scratch: their points on the strand at a step's start.
    pub near_y0: &'a mut [V3],
    /// Scratch: the samples' positions at a step's start, one per sample.
    pub sample_y0: &'a mut [V3],
    /// Scratch of the pairs of two parts of the strand (self-contact): J at the other
    /// part and `J(s) − J(s')`, 3N columns each (empty without such pairs).
    pub other: &'a mut [V3],
    /// See [`Self::other`].
    pub diff: &'a mut [V3],
}

impl PartnerStore<'_> {
    /// Whether the scratch arrays hold the partners, `samples` samples and, with pairs
    /// of two parts of the strand, `dofs` columns.
    fn fits(&self, samples: usize, dofs: usize) -> bool {
        let m = self.partners.len();
        // (the partners looked through only when the columns are missing)
        let columns = self.other.len() == dofs && self.diff.len() == dofs;
        self.near.len() >= m
            && self.near_y.len() >= m
            && self.near_y0.len() >= m
            && self.sample_y0.len() >= samples
            && (columns || !self.partners.iter().any(|p| p.partner_s.is_some()))
    }
}

impl<'a, C: StepColliders + ?Sized, P: MomentSource + ?Sized> FixedContacts<'a, C, P> {
    /// The contacts of the strand of `params` (its root, lengths and ρS), with `colliders`
    /// and `samples`, points from `source`, on `store`.
    pub fn new<const N: usize, const D: usize, T: Float>(
        strand: &FixedParams<N, D, T>,
        lengths: &'a [f64],
        colliders: &'a mut C,
        source: &'a P,
        params: &'a ContactParams,
        samples: &'a [(f64, f64)],
        store: ContactStore<'a>,
    ) -> Self {
        FixedContacts {
            colliders,
            source,
            params,
            samples,
            root: Pose {
                position: strand.root_position.map(|x| x.as_f64()),
                frame: strand.root_frame.map(|x| x.as_f64()),
            },
            lengths,
            mass_per_length: strand.mass_per_length.as_f64(),
            store,
            predicted: None,
            partners: None,
            end_deferred: None,
        }
    }

    /// The same contacts leaving the bookkeeping of a step ending at `t`
    /// ([`ContactHooks::after_step`]) to the caller: the step's own call at `t` does
    /// nothing, the caller's after it (with the store's `updated` still the step's start)
    /// does it.
    pub fn with_end_deferred(mut self, t: Option<f64>) -> Self {
        self.end_deferred = t;
        self
    }

    /// The same contacts touching the partners of `store` too (hair–hair, the runtime's
    /// `coupling = "ball"`; the pairs of two parts of the strand stepped on both parts).
    /// Panics when its scratch arrays are shorter than its partners or than the samples,
    /// or, with pairs of two parts of the strand, its `other` and `diff` are not 3N
    /// columns.
    pub fn with_partners(mut self, store: PartnerStore<'a>) -> Self {
        assert!(
            store.fits(self.samples.len(), self.store.jac.len()),
            "the partners' scratch is shorter than the partners, the samples or 3N"
        );
        self.partners = Some(store);
        self
    }

    /// The partners the samples (posed) do not rule out into the store's `near`, their
    /// points on the strand at q into `near_y`; their count (0 without partners).
    fn place_near_partners(&mut self, head: &HeadState, q: &[f64]) -> usize {
        let Some(ps) = self.partners.as_mut() else {
            return 0;
        };
        let mut m = 0;
        let near = &mut *ps.near;
        partners::near(ps.partners, self.samples, head, self.store.poses, |i| {
            near[m] = i;
            m += 1;
        });
        let (list, y) = (&ps.near[..m], &mut *ps.near_y);
        let arcs = list.iter().map(|&i| ps.partners[i].s);
        let mut j = 0;
        let (root, chain) = chain_at(&self.root, self.lengths, q);
        positions_along(&root, self.lengths, chain, arcs, |_, p| {
            y[j] = p;
            j += 1;
        });
        m
    }

    /// Add the terms of the first `m` partners of the store's `near` (placed at q by
    /// [`Self::place_near_partners`]) at (q, q̇ = `v`) to the step's arrays; the partners
    /// within reach and whether one added stiffness.
    #[allow(clippy::too_many_arguments)]
    fn add_partner_terms(
        &mut self,
        m: usize,
        head: &HeadState,
        q: &[f64],
        v: &[f64],
        force: &mut [f64],
        stiffness: &mut Square<'_, f64>,
        damping: &mut Square<'_, f64>,
    ) -> (usize, bool) {
        let FixedContacts {
            source,
            root,
            lengths,
            samples,
            store,
            partners: Some(ps),
            ..
        } = self
        else {
            return (0, false);
        };
        let mut sink = ArraySink {
            source: *source,
            root,
            lengths,
            ends: store.ends,
            end_derivs: store.end_derivs,
            chain_q: store.chain_q,
            chain_valid: store.chain_valid,
            q,
            aj: store.aj,
            force,
            stiffness: stiffness.reborrow(),
            damping: damping.reborrow(),
        };
        // a partner's force acts along the strand's Jacobian only: no curvature
        let asked = TermsAsked {
            force: true,
            stiffness: true,
            curvature: false,
            damping: true,
        };
        let view = PartnerContacts {
            params: ps.params,
            partners: ps.partners,
            samples,
        };
        let (touching, stiffened) = view.add_terms(
            head,
            &ps.near[..m],
            &ps.near_y[..m],
            v,
            asked,
            store.jac,
            &mut sink,
        );
        if !ps.partners.iter().any(|p| p.partner_s.is_some()) {
            return (touching, stiffened);
        }
        // the pairs of two parts of this strand, stepped on both parts
        let (own, own_stiffness) =
            view.add_self_terms(v, asked, store.jac, ps.other, ps.diff, &mut sink);
        (touching + own, stiffened || own_stiffness)
    }

    /// The power of the partners' damping through their velocities at (q, q̇ = `v`),
    /// the first `m` of the store's `near` placed at q ([`PartnerContacts::drag_power`]);
    /// 0 without partners.
    fn partner_drag_power(&mut self, m: usize, head: &HeadState, q: &[f64], v: &[f64]) -> f64 {
        let FixedContacts {
            source,
            root,
            lengths,
            samples,
            store,
            partners: Some(ps),
            ..
        } = self
        else {
            return 0.0;
        };
        let view = PartnerContacts {
            params: ps.params,
            partners: ps.partners,
            samples,
        };
        let mut points = ChainedPoints {
            source: *source,
            root,
            lengths,
            ends: store.ends,
            derivs: store.end_derivs,
            chain_q: store.chain_q,
            chain_valid: store.chain_valid,
        };
        view.drag_power(
            head,
            &ps.near[..m],
            &ps.near_y[..m],
            v,
            store.jac,
            |s, jac| points.point(q, s, jac),
        )
    }

    /// Whether the step from q0 (samples' positions there in the store's `sample_y0`) to
    /// q1 (samples posed there) passes the partners: none apart at the start ends deeper
    /// than the split depth into its ball ([`PartnerContacts::approach_acceptable`], for
    /// the partners the samples do not settle). True without partners.
    fn partners_acceptable(&mut self, head: &HeadState, q0: &[f64], q1: &[f64]) -> bool {
        let FixedContacts {
            params,
            root,
            lengths,
            samples,
            store,
            partners: Some(ps),
            ..
        } = self
        else {
            return true;
        };
        let split = ps.params.split_depth.unwrap_or(params.split_depth);
        let view = PartnerContacts {
            params: ps.params,
            partners: ps.partners,
            samples,
        };
        let mut m = 0;
        let near = &mut *ps.near;
        view.unsettled(
            head,
            &ps.sample_y0[..samples.len()],
            store.poses,
            split,
            |i| {
                near[m] = i;
                m += 1;
            },
        );
        let arcs = || ps.near[..m].iter().map(|&i| ps.partners[i].s);
        let (y0, y1) = (&mut *ps.near_y0, &mut *ps.near_y);
        let mut j = 0;
        let (root0, chain0) = chain_at(root, lengths, q0);
        positions_along(&root0, lengths, chain0, arcs(), |_, p| {
            y0[j] = p;
            j += 1;
        });
        j = 0;
        let (root1, chain1) = chain_at(root, lengths, q1);
        positions_along(&root1, lengths, chain1, arcs(), |_, p| {
            y1[j] = p;
            j += 1;
        });
        let (root, lengths) = (&*root, &**lengths);
        view.approach_acceptable(
            head,
            &ps.near[..m],
            &ps.near_y0[..m],
            &ps.near_y[..m],
            split,
        ) && view.self_approach_acceptable(split, |end, lo, hi| {
            two_points(root, lengths, if end { q1 } else { q0 }, lo, hi)
        })
    }

    /// The same contacts predicting the contacts that start within a step
    /// ([`crate::contact::predicted`]) on `arrays` (the
    /// runtime's `[contacts] predict = true`), cut from the caller's pools by
    /// [`PredictedArrays::carve`].
    pub fn with_prediction(mut self, arrays: PredictedArrays<'a>) -> Self {
        self.predicted = Some(arrays);
        self
    }

    /// The tip's position at q.
    fn tip(&self, q: &[f64]) -> Option<V3> {
        let length: f64 = self.lengths.iter().sum();
        let mut tip = None;
        let (root, chain) = chain_at(&self.root, self.lengths, q);
        positions_along(&root, self.lengths, chain, [length], |_, y| tip = Some(y));
        tip
    }

    /// The samples' poses at q into the storage (kept when they are there already).
    fn pose(&mut self, q: &[f64]) {
        let s = &mut self.store;
        let same = |a: &[f64]| a.iter().zip(q).all(|(x, y)| x.to_bits() == y.to_bits());
        if *s.poses_valid && s.poses_q.len() == q.len() && same(s.poses_q) {
            return;
        }
        let (root, chain) = chain_at(&self.root, self.lengths, q);
        sample_poses(&root, self.lengths, chain, self.samples, s.poses);
        *s.poses_valid = s.poses_q.len() == q.len();
        if *s.poses_valid {
            s.poses_q.copy_from_slice(q);
        }
    }

    /// Re-anchor every sample (Coulomb friction only), the poses current.
    fn update_anchors(&mut self, head: &HeadState) {
        if !matches!(self.params.friction, Friction::Coulomb { .. }) {
            return;
        }
        for k in 0..self.samples.len() {
            let (y, t) = self.store.poses[k];
            let a = view(self).anchor_after(head, k, &y, &t);
            self.store.anchors[k] = a;
        }
    }
}

/// What a strand's points are made of, and the chain of element ends kept for one q
/// (the ends and their derivatives are the chain's scratch: a point taken without the
/// chain would leave them another q's while the chain still claims them).
struct ChainedPoints<'b, P: MomentSource + ?Sized> {
    source: &'b P,
    root: &'b Pose,
    lengths: &'b [f64],
    ends: &'b mut [Pose],
    derivs: &'b mut [EndDerivatives],
    chain_q: &'b mut [f64],
    chain_valid: &'b mut usize,
}

impl<P: MomentSource + ?Sized> ChainedPoints<'_, P> {
    /// y(s) at q, J(s) into `jac` (no Hessian).
    fn point(&mut self, q: &[f64], s: f64, jac: &mut [V3]) -> V3 {
        let chain = Some(PointChain {
            q: &mut *self.chain_q,
            valid: &mut *self.chain_valid,
        });
        // (the chain from the root as it is, its ends kept for the chain's q; a free
        // root's translation added after)
        let n = (3 * self.lengths.len()).min(q.len());
        let y = strand_point(
            self.source,
            self.root,
            self.lengths,
            self.ends,
            self.derivs,
            chain,
            &q[..n],
            s,
            &mut jac[..n],
            crate::strand_point::NO_HESSIAN,
        );
        translation_columns(jac, n);
        y + translation(self.lengths, q)
    }
}

/// The root's translation X at q: a free root's three coordinates after the chain's 3N
/// ([`crate::storage::ParamsView::free_root`]), zero for a held root.
fn translation(lengths: &[f64], q: &[f64]) -> V3 {
    let n = 3 * lengths.len();
    match q.get(n..n + 3) {
        Some(x) => V3::new(x[0], x[1], x[2]),
        None => V3::zeros(),
    }
}

/// The chain of a strand at q: its root pose moved by the root's translation (a free
/// root's), and the chain's 3N coordinates. Points taken along it are the strand's.
fn chain_at<'q>(root: &Pose, lengths: &[f64], q: &'q [f64]) -> (Pose, &'q [f64]) {
    let n = (3 * lengths.len()).min(q.len());
    (
        Pose {
            position: root.position + translation(lengths, q),
            frame: root.frame,
        },
        &q[..n],
    )
}

/// A point's Jacobian columns of a free root's translation (the identity) after the
/// chain's 3N, when `jac` has them.
fn translation_columns(jac: &mut [V3], chain: usize) {
    if let Some(cols) = jac.get_mut(chain..chain + 3) {
        for (k, c) in cols.iter_mut().enumerate() {
            *c = V3::ith(k, 1.0);
        }
    }
}

/// The strand's points at the arc lengths lo ≤ hi at q (one pass along it).
fn two_points(root: &Pose, lengths: &[f64], q: &[f64], lo: f64, hi: f64) -> (V3, V3) {
    let (root, q) = chain_at(root, lengths, q);
    let root = &root;
    let mut ends = [V3::zeros(); 2];
    let mut j = 0;
    positions_along(root, lengths, q, [lo, hi], |_, p| {
        ends[j] = p;
        j += 1;
    });
    (ends[0], ends[1])
}

/// The body contacts' view of the storage.
fn view<'b, C: StepColliders + ?Sized, P: MomentSource + ?Sized>(
    c: &'b FixedContacts<'_, C, P>,
) -> BodyContacts<'b, &'b C> {
    BodyContacts {
        colliders: &*c.colliders,
        params: c.params,
        samples: c.samples,
        anchors: c.store.anchors,
        allowance: c.store.allowance,
        root_zone: c.store.scalars.root_zone,
    }
}

/// The rest of a [`FixedContacts`]' storage beside its view: what a strand's points are
/// made of, and the scratch they are made in.
struct Parts<'b, P: MomentSource + ?Sized> {
    source: &'b P,
    root: &'b Pose,
    lengths: &'b [f64],
    poses: &'b [(V3, V3)],
    jac: &'b mut [V3],
    aj: &'b mut [V3],
    ends: &'b mut [Pose],
    end_derivs: &'b mut [EndDerivatives],
    chain_q: &'b mut [f64],
    chain_valid: &'b mut usize,
    summary: &'b mut BodySummary,
}

/// The body contacts' view of the storage and the rest of it, borrowed apart.
fn split<'b, C: StepColliders + ?Sized, P: MomentSource + ?Sized>(
    c: &'b mut FixedContacts<'_, C, P>,
) -> (BodyContacts<'b, &'b C>, Parts<'b, P>) {
    let FixedContacts {
        colliders,
        source,
        params,
        samples,
        root,
        lengths,
        store,
        ..
    } = c;
    let view = BodyContacts {
        colliders: &**colliders,
        params,
        samples,
        anchors: store.anchors,
        allowance: store.allowance,
        root_zone: store.scalars.root_zone,
    };
    let parts = Parts {
        source: *source,
        root,
        lengths,
        poses: store.poses,
        jac: store.jac,
        aj: store.aj,
        ends: store.ends,
        end_derivs: store.end_derivs,
        chain_q: store.chain_q,
        chain_valid: store.chain_valid,
        summary: &mut store.scalars.summary,
    };
    (view, parts)
}

/// The fixed step's arrays as the sink of the contact terms.
struct ArraySink<'s, 'm, P: MomentSource + ?Sized> {
    source: &'s P,
    root: &'s Pose,
    lengths: &'s [f64],
    ends: &'s mut [Pose],
    end_derivs: &'s mut [EndDerivatives],
    chain_q: &'s mut [f64],
    chain_valid: &'s mut usize,
    q: &'s [f64],
    aj: &'s mut [V3],
    force: &'s mut [f64],
    stiffness: Square<'m, f64>,
    damping: Square<'m, f64>,
}

impl<P: MomentSource + ?Sized> ContactSink for ArraySink<'_, '_, P> {
    fn point(&mut self, s: f64, jac: &mut [V3], curvature: Option<V3>) -> V3 {
        let st = &mut self.stiffness;
        let mut add = |k: usize, l: usize, v: f64| st[k][l] += v;
        let chain = Some(PointChain {
            q: &mut *self.chain_q,
            valid: &mut *self.chain_valid,
        });
        // (a free root's translation enters y linearly: its columns the identity, no
        // curvature)
        let n = (3 * self.lengths.len()).min(self.q.len());
        let y = strand_point(
            self.source,
            self.root,
            self.lengths,
            self.ends,
            self.end_derivs,
            chain,
            &self.q[..n],
            s,
            &mut jac[..n],
            curvature.map(|c| (c, &mut add)),
        );
        translation_columns(jac, n);
        y + translation(self.lengths, self.q)
    }
    fn add_force(&mut self, jac: &[V3], f: &V3) {
        for (i, c) in jac.iter().enumerate() {
            self.force[i] += c.dot(f);
        }
    }
    fn add_stiffness(&mut self, jac: &[V3], a: &nalgebra::Matrix3<f64>) {
        let m = &mut self.stiffness;
        crate::contact::body::add_projected(jac, a, self.aj, |i, j, x| m[i][j] += x);
    }
    fn add_damping(&mut self, jac: &[V3], a: &nalgebra::Matrix3<f64>) {
        let m = &mut self.damping;
        crate::contact::body::add_projected(jac, a, self.aj, |i, j, x| m[i][j] += x);
    }
}

/// The fixed step as the predicted contacts' host: the strand's points and the step's
/// factors.
struct FixedHost<'h, 'a, C: StepColliders + ?Sized, P: MomentSource + ?Sized> {
    contacts: &'h mut FixedContacts<'a, C, P>,
    solve: &'h mut dyn FnMut(&mut [f64]) -> bool,
    head: &'h HeadState,
    dofs: usize,
}

impl<'a, C: StepColliders + ?Sized, P: MomentSource + ?Sized> PredictionHost<PredictedArrays<'a>>
    for FixedHost<'_, 'a, C, P>
{
    fn solve_factored(&mut self, x: &mut [f64]) -> bool {
        (self.solve)(x)
    }
    fn linearize(&mut self, buffers: &mut PredictedArrays<'a>, from: usize) {
        let (_, p) = split(self.contacts);
        let mut points = ChainedPoints {
            source: p.source,
            root: p.root,
            lengths: p.lengths,
            ends: p.ends,
            derivs: p.end_derivs,
            chain_q: p.chain_q,
            chain_valid: p.chain_valid,
        };
        predicted::linearize(buffers, self.dofs, from, p.jac, |q, s, jac| {
            points.point(q, s, jac);
        });
    }
    fn end_check(&mut self, buffers: &mut PredictedArrays<'a>, q: &[f64]) -> usize {
        let c = &mut *self.contacts;
        c.pose(q);
        let tip = c.tip(q);
        let length: f64 = c.lengths.iter().sum();
        predicted::check(
            buffers,
            &view(c),
            self.head,
            self.dofs,
            c.store.poses,
            tip,
            length,
        )
    }
}

impl<C: StepColliders + ?Sized, P: MomentSource + ?Sized> ContactHooks<f64>
    for FixedContacts<'_, C, P>
{
    fn forget(&mut self) {
        if let Some(p) = self.predicted.as_mut() {
            predicted::forget(p);
        }
    }

    fn predict(&mut self, q_lin: &[f64], q_pred: &[f64], t: f64, head: &HeadState) -> bool {
        let Some(mut pc) = self.predicted.take() else {
            return false;
        };
        if self.colliders.count() == 0 {
            predicted::forget(&mut pc);
            self.predicted = Some(pc);
            return false;
        }
        self.colliders.place(t, head);
        self.pose(q_lin);
        let lin_tip = self.tip(q_lin);
        predicted::begin(&mut pc, &view(self), head, q_lin, self.store.poses, lin_tip);
        self.pose(q_pred);
        let dofs = q_pred.len();
        let any = predicted::list(&mut pc, &view(self), head, dofs, self.store.poses);
        self.predicted = Some(pc);
        any
    }

    fn resolve(
        &mut self,
        _points: &mut dyn StrandPoints<f64>,
        q: &mut [f64],
        v: &mut [f64],
        map: Option<(f64, f64)>,
        t: f64,
        head: &HeadState,
        solve: &mut dyn FnMut(&mut [f64]) -> bool,
    ) -> Result<usize, SingularStep> {
        let Some(mut pc) = self.predicted.take() else {
            return Ok(0);
        };
        if self.colliders.count() == 0 {
            self.predicted = Some(pc);
            return Ok(0);
        }
        self.colliders.place(t, head);
        let tolerance = predicted::GAP_TOLERANCE * self.params.radius;
        let mut host = FixedHost {
            contacts: self,
            solve,
            head,
            dofs: q.len(),
        };
        let result = match map {
            Some(map) => predicted::resolve(&mut pc, &mut host, map, tolerance, q, v),
            None => predicted::resolve_again(&mut pc, &mut host, tolerance, q, v),
        };
        self.predicted = Some(pc);
        result
    }

    fn start(&mut self, q: &[f64], t: f64, head: &HeadState) {
        self.store.scalars.updated = Some(t);
        self.colliders.place(t, head);
        self.pose(q);
        let length: f64 = self.lengths.iter().sum();
        self.store.scalars.root_zone = (0, 0);
        let root = self.root.position;
        let zone = view(self).root_zone_at(head, Some(&root), self.store.poses, length);
        self.store.scalars.root_zone = zone;
        // a depth whose penalty is within a hundred times the strand's weight is harmless
        let harmless = 100.0 * self.mass_per_length * STANDARD_GRAVITY / self.params.stiffness;
        for k in 0..self.samples.len() {
            let y = self.store.poses[k].0;
            let a = view(self).start_allowance(head, k, &y, harmless);
            self.store.allowance[k] = a;
        }
        self.update_anchors(head);
        self.store.scalars.started = true;
    }

    fn started(&self) -> bool {
        self.store.scalars.started
    }

    fn add_terms(
        &mut self,
        _points: &mut dyn StrandPoints<f64>,
        q: &[f64],
        v: &[f64],
        t: f64,
        head: &HeadState,
        curvature: bool,
        force: &mut [f64],
        stiffness: &mut Square<'_, f64>,
        damping: &mut Square<'_, f64>,
    ) -> bool {
        self.colliders.place(t, head);
        self.pose(q);
        let (contacts, p) = split(self);
        let mut sink = ArraySink {
            source: p.source,
            root: p.root,
            lengths: p.lengths,
            ends: p.ends,
            end_derivs: p.end_derivs,
            chain_q: p.chain_q,
            chain_valid: p.chain_valid,
            q,
            aj: p.aj,
            force,
            stiffness: stiffness.reborrow(),
            damping: damping.reborrow(),
        };
        let asked = TermsAsked {
            force: true,
            stiffness: true,
            curvature,
            damping: true,
        };
        let (summary, mut stiffened) =
            contacts.add_terms(head, p.poses, v, asked, p.jac, &mut sink);
        *p.summary = summary;
        if self.partners.is_some() {
            // the partners the samples do not rule out are placed on the strand first
            // (one pass); J is computed only for those within reach
            let m = self.place_near_partners(head, q);
            let (touching, partner_stiffness) =
                self.add_partner_terms(m, head, q, v, force, stiffness, damping);
            self.store.scalars.partners_touching = touching;
            stiffened |= partner_stiffness;
        }
        stiffened
    }

    fn energy(
        &mut self,
        _points: &mut dyn StrandPoints<f64>,
        q: &[f64],
        v: &[f64],
        t: f64,
        head: &HeadState,
    ) -> (f64, f64) {
        self.colliders.place(t, head);
        self.pose(q);
        let (mut potential, mut rate) = view(self).energy(head, self.store.poses);
        // only the partners the samples do not rule out (most of those the search keeps
        // are beyond reach, and contribute nothing) are placed on the strand
        let m = self.place_near_partners(head, q);
        if let Some(ps) = self.partners.as_ref() {
            let view = PartnerContacts {
                params: ps.params,
                partners: ps.partners,
                samples: self.samples,
            };
            (potential, rate) = view.energy(
                head,
                &ps.near[..m],
                &ps.near_y[..m],
                self.store.poses,
                (potential, rate),
            );
            // the pairs of two parts of this strand (internal: no work through motion)
            let (root, lengths) = (&self.root, self.lengths);
            potential += view.self_energy(self.store.poses, |lo, hi| {
                Some(two_points(root, lengths, q, lo, hi))
            });
        }
        let moving = (0..self.colliders.count()).any(|b| self.colliders.on_own_motion(b));
        if !moving {
            if self.partners.is_none() {
                return (potential, rate);
            }
            let power = self.partner_drag_power(m, head, q, v);
            return (potential, rate + power);
        }
        let (contacts, p) = split(self);
        let mut points = ChainedPoints {
            source: p.source,
            root: p.root,
            lengths: p.lengths,
            ends: p.ends,
            derivs: p.end_derivs,
            chain_q: p.chain_q,
            chain_valid: p.chain_valid,
        };
        let power = contacts.drag_power(head, p.poses, v, p.jac, |s, jac| {
            points.point(q, s, jac);
        });
        let power = power + self.partner_drag_power(m, head, q, v);
        (potential, rate + power)
    }

    fn acceptable(
        &mut self,
        q0: &[f64],
        q1: &[f64],
        t0: f64,
        head0: &HeadState,
        t1: f64,
        head1: &HeadState,
    ) -> bool {
        // how deep the samples are at the start: for a collider on the head or in the
        // world, as the step's matrix has them (q0 with the head at the end); for one on
        // its own motion, where it is at the start, so that a collider sweeping into the
        // strand within the step makes new, checked contacts
        self.pose(q0);
        let n = self.samples.len();
        let moving = (0..self.colliders.count()).any(|b| self.colliders.on_own_motion(b));
        if moving {
            self.colliders.place(t0, head0);
            for k in 0..n {
                let y = self.store.poses[k].0;
                self.store.start_depth[k] = view(self).depth_among(head0, k, &y, Some(true));
            }
            self.colliders.place(t1, head1);
            for k in 0..n {
                let y = self.store.poses[k].0;
                let d = view(self).depth_among(head1, k, &y, Some(false));
                self.store.start_depth[k] = self.store.start_depth[k].max(d);
            }
        } else {
            self.colliders.place(t1, head1);
            for k in 0..n {
                let y = self.store.poses[k].0;
                self.store.start_depth[k] = view(self).depth_among(head1, k, &y, None);
            }
        }
        if let Some(ps) = self.partners.as_mut() {
            for (y0, pose) in ps.sample_y0.iter_mut().zip(self.store.poses.iter()) {
                *y0 = pose.0;
            }
        }
        self.pose(q1);
        if view(self).too_deep(head1, self.store.poses, self.store.start_depth) {
            return false;
        }
        self.partners_acceptable(head1, q0, q1)
    }

    fn after_step(&mut self, q: &[f64], t: f64, head: &HeadState, h: f64) {
        if self.end_deferred == Some(t) {
            return;
        }
        let h = self
            .store
            .scalars
            .updated
            .map_or(h, |t0| (t - t0).clamp(0.0, h));
        self.store.scalars.updated = Some(t);
        self.colliders.place(t, head);
        self.pose(q);
        if self.store.allowance.iter().any(|a| *a > 0.0) {
            for k in 0..self.samples.len() {
                let y = self.store.poses[k].0;
                let a = view(self).allowance_after(head, k, &y, h);
                self.store.allowance[k] = a;
            }
        }
        self.update_anchors(head);
    }

    fn has_history(&self) -> bool {
        self.partners.is_some()
            || matches!(self.params.friction, Friction::Coulomb { .. })
            || self.store.allowance.iter().any(|a| *a > 0.0)
    }

    fn moves_relative(&self, t0: f64, t1: f64, head0: &HeadState, head1: &HeadState) -> bool {
        let partners = self
            .partners
            .as_ref()
            .is_some_and(|p| !p.partners.is_empty());
        partners || self.colliders.moves_relative(t0, t1, head0, head1)
    }

    fn has_partners(&self) -> bool {
        self.partners
            .as_ref()
            .is_some_and(|p| !p.partners.is_empty())
    }

    fn deepest(&mut self, q: &[f64], t: f64, head: &HeadState) -> f64 {
        self.colliders.place(t, head);
        let (root, chain) = chain_at(&self.root, self.lengths, q);
        view(self).deepest_inside(head, &root, self.lengths, chain)
    }

    fn summary(&self) -> BodySummary {
        self.store.scalars.summary
    }

    fn touching(&self) -> bool {
        self.store.scalars.summary.contacts + self.store.scalars.partners_touching > 0
    }

    fn last_contact(&mut self) -> &mut (f64, f64) {
        &mut self.store.scalars.last_contact
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collider::{Mount, Sphere};
    use crate::contact::sample_points;
    use crate::fixed::{
        step_with_contacts, Effects, FixedStrand, FixedWorkspace, StepCounts, StillHead,
    };
    use crate::material::section_terms;
    use crate::strand_point::tests::Jets;
    use std::vec;
    use std::vec::Vec;

    const N: usize = 3;
    const D: usize = 9;

    /// A strand of 9 cm, N = 3, held horizontally 1 cm above a ball of radius 5 cm
    /// fixed on the head (what an engine hands the step: a slice of colliders with their
    /// mounts, the storage its own), falls onto it under gravity for 0.6 s at 1/60 s: the
    /// step takes its contacts (the strand ends lying on the ball, within the contact
    /// radius and no point more than 0.5 mm inside), with the contacts that start within
    /// a step predicted (arrays cut from the caller's pools) or caught by the depth check
    /// alone; without the colliders it falls through the ball's top.
    #[test]
    fn a_strand_falls_onto_a_ball_and_stays_out() {
        let section = section_terms(50e-6, 1.0, 1.5e9, 0.48, 1300.0);
        let lengths = [0.03; N];
        let natural = [0.0; D];
        let params = crate::fixed::FixedParams::<N, D>::new(
            [0.0, -0.045, 0.06],
            [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
            lengths,
            &section,
            natural,
            1e-12,
            0.0,
        )
        .expect("params");
        let ball = Sphere {
            center: Vector3::zeros(),
            radius: 0.05,
        };
        let contact = ContactParams {
            radius: 1e-3,
            stiffness: 1e4 * params.mass_per_length * STANDARD_GRAVITY / 1e-3,
            damping: 2.0
                * 0.5
                * libm::sqrt(
                    1e4 * params.mass_per_length * STANDARD_GRAVITY / 1e-3 * params.mass_per_length,
                ),
            max_depth: 1e-3,
            split_depth: 1e-3,
            depenetration_speed: 0.05,
            friction: Friction::None,
            anisotropy: 0.0,
        };
        let mut samples = Vec::new();
        sample_points(&lengths, 4, [false, true], 0.0, |s, w| samples.push((s, w)));
        let m = samples.len();
        let run = |with_ball: bool, predict: bool| {
            // per worker, the prediction's pools
            let sizes = crate::contact::predicted::PoolSizes::of(m, D);
            let mut pscalars = crate::contact::predicted::PredictedScalars::default();
            let mut floats = vec![0.0; sizes.floats];
            let mut flags = vec![false; sizes.flags];
            let mut indices = vec![0usize; sizes.indices];
            let mut cands = vec![crate::contact::predicted::Candidate::NONE; sizes.candidates];
            let mut points = vec![V3::zeros(); sizes.points];
            let mut strand = FixedStrand::<N, D, 4>::at_rest(params);
            let mut ws = FixedWorkspace::<N, D, { N + 1 }>::new();
            let mut colliders = [(ball, Mount::Head)];
            let (mut anchors, mut allowance, mut start_depth) =
                (vec![None; m], vec![0.0; m], vec![0.0; m]);
            let mut poses = vec![(V3::zeros(), V3::zeros()); m];
            let (mut poses_q, mut poses_valid) = (vec![0.0; D], false);
            let (mut jac, mut aj) = (vec![V3::zeros(); D], vec![V3::zeros(); D]);
            let mut ends = vec![Pose::default(); N + 1];
            let mut derivs = vec![EndDerivatives::default(); N];
            let (mut chain_q, mut chain_valid) = (vec![f64::NAN; D], 0usize);
            let mut scalars = ContactScalars::default();
            let effects = Effects {
                gravity: Some(Vector3::new(0.0, 0.0, -9.81)),
                head_moves: false,
            };
            let mut counts = StepCounts::default();
            let (mut deepest, mut t) = (0.0f64, 0.0);
            let h = 1.0 / 60.0;
            for _ in 0..36 {
                let mut contacts = FixedContacts::new(
                    &strand.params,
                    &lengths,
                    &mut colliders[..],
                    &Jets,
                    &contact,
                    &samples,
                    ContactStore {
                        anchors: &mut anchors,
                        allowance: &mut allowance,
                        start_depth: &mut start_depth,
                        poses: &mut poses,
                        poses_q: &mut poses_q,
                        poses_valid: &mut poses_valid,
                        jac: &mut jac,
                        aj: &mut aj,
                        ends: &mut ends,
                        end_derivs: &mut derivs,
                        chain_q: &mut chain_q,
                        chain_valid: &mut chain_valid,
                        scalars: &mut scalars,
                    },
                );
                if predict {
                    let arrays = PredictedArrays::carve(
                        m,
                        D,
                        &mut pscalars,
                        &mut floats,
                        &mut flags,
                        &mut indices,
                        &mut cands,
                        &mut points,
                    )
                    .expect("pools of PoolSizes::of");
                    contacts = contacts.with_prediction(arrays);
                }
                let hooks: Option<&mut dyn ContactHooks<f64>> =
                    if with_ball { Some(&mut contacts) } else { None };
                step_with_contacts(
                    &Jets,
                    &mut strand,
                    &StillHead,
                    &effects,
                    t,
                    h,
                    &mut ws,
                    &mut counts,
                    hooks,
                )
                .expect("step");
                t += h;
                deepest = deepest.max(contacts.deepest(&strand.q, t, &HeadState::rest()));
            }
            // the centreline's distance to the ball's surface, nearest point
            let mut nearest = f64::INFINITY;
            crate::contact::samples::positions_along(
                &Pose {
                    position: strand.params.root_position,
                    frame: strand.params.root_frame,
                },
                &lengths,
                &strand.q,
                (0..=90).map(|i| 0.09 * i as f64 / 90.0),
                |_, y| nearest = nearest.min(y.norm() - ball.radius),
            );
            (deepest, nearest, counts.contacts_predicted)
        };
        for predict in [false, true] {
            let (deepest, nearest, predicted) = run(true, predict);
            assert!(
                deepest <= 5e-4,
                "predict {predict}: {deepest} m inside the ball"
            );
            assert!(
                (-5e-4..=1e-3).contains(&nearest),
                "predict {predict}: the strand ends {nearest} m from the ball"
            );
            // the samples reach the ball within a step: with the prediction some push
            // in the step's own solve
            assert_eq!(
                predicted > 0,
                predict,
                "{predicted} predicted contacts pushed"
            );
        }
        let (_, through, _) = run(false, false);
        assert!(through < -5e-3, "without the ball's contacts: {through} m");
    }
}
