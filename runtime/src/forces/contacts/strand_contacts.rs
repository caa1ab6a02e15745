//! The contacts of one strand: penalty forces at sample points of its centreline against
//! the scene's bodies (the paper's section 4.2: "a normal elastic response together with
//! a tangential viscous friction force", anisotropic by "a cosine function \[of\] the
//! orientation of hair fibers with respect to their sliding motion") and against the
//! points of other strands it was paired with (hair–hair, [`super::hair_hair`]), with
//! their stiffness and damping in the implicit step's matrices.
//!
//! Everything is computed in head coordinates. A sample at arc length s sits at y(s); a
//! body attached to the head is fixed there, a body fixed in the world moves through the
//! head frame with velocity `u = −(Rᵀ Ẋ + ω × y)`, and a body on its own motion (state
//! `X_b`, `R_b`, `Ẋ_b`, `ω_b` at the time of the query, placed once per time in
//! [`StrandContacts`]) with `u = Rᵀ(Ẋ_b + R_b (ω_b × z) − Ẋ) − ω × y`, where
//! `z = R_bᵀ(X + R y − X_b)` is the point in the body's coordinates. For a sample of weight w (the arc
//! length it stands for) at depth δ = r − d (d the signed distance to the surface, n the
//! outward normal):
//!
//! ```text
//! f_n = k w min(δ, δ_max) n                         normal penalty (elastic)
//! f_d = −c w (n · v) n,  c = 2 ζ √(k ρS)            normal damping (dissipative)
//! f_t = −μ(θ) |f_n| P v / v_s                       viscous friction, P = I − n nᵀ
//!     or −k_t w P (y − a), |f_t| ≤ μ_s(θ) |f_n|     Coulomb: spring to an anchor a
//! μ(θ) = μ (1 + α cos θ),  cos θ = t̂ · (sliding direction)
//! ```
//!
//! v is the point's velocity relative to the body. The generalized force is Jᵀ f; the
//! stiffness `−k w Jᵀ n nᵀ J − k_t w Jᵀ P J` plus the Hessian of y contracted with the
//! elastic forces; the damping `−Jᵀ (c w n nᵀ + c_t P) J`. Both matrices of the contact
//! part are symmetric negative semidefinite: they make the linearly implicit step stable
//! at any penalty stiffness. Beyond δ_max the normal force is constant (no stiffness): a
//! strand that starts inside a body is pushed out over several steps, never kicked.

use super::config::{Friction, STANDARD_GRAVITY};
use super::predicted::PredictedContacts;
use crate::bodies::{Attachment, Body, Placement};
use crate::forces::head_motion::HeadState;
use crate::kernels::kernel::{StrandKernel, StrandTerms, Terms};
use crate::model::ends::ROOT_JOINT_FRACTION;
use crate::model::reconstruction::positions_at_sorted;
use crate::model::strand::StrandGeometry;
use faer::Mat;
use nalgebra::{Matrix3, Vector3};
use std::sync::Arc;
use superhelix_kernels::collider::Mount;
use superhelix_kernels::collider::Proximity;
use superhelix_kernels::contact::body::{
    self, add_generalized_force, Anchor, BodyContacts, BodyHit, ColliderSet, ContactSink,
    TermsAsked,
};
use superhelix_kernels::contact::predicted;
pub use superhelix_kernels::contact::ContactParams;
use superhelix_kernels::storage::Square;
use superhelix_kernels::strand_terms::StrandPoints;

use superhelix_kernels::contact::partners;
pub use superhelix_kernels::contact::partners::{
    HairHairParams, PartnerAnchor, PartnerContacts, PartnerPoint,
};

/// A Coulomb anchor as a checkpoint keeps it ([`Anchor`]: a point of a body in that
/// body's coordinates, and whether it slid over the last step).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
struct SavedAnchor {
    body: usize,
    point: Vector3<f64>,
    sliding: bool,
}

impl From<Anchor> for SavedAnchor {
    fn from(a: Anchor) -> Self {
        SavedAnchor {
            body: a.body,
            point: a.point,
            sliding: a.sliding,
        }
    }
}

impl From<SavedAnchor> for Anchor {
    fn from(a: SavedAnchor) -> Self {
        Anchor {
            body: a.body,
            point: a.point,
            sliding: a.sliding,
        }
    }
}

/// What the last evaluation found, for diagnostics and tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ContactSummary {
    /// Samples touching a body.
    pub body_contacts: usize,
    /// Samples touching another strand.
    pub hair_contacts: usize,
    /// Deepest sample inside a body (distance of the centreline below the surface,
    /// not the contact radius), m (0: none inside).
    pub max_penetration: f64,
    /// Sum of the normal forces of the bodies (elastic part), N.
    pub normal_force: f64,
}

pub use superhelix_kernels::contact::body::SWEEP_SPACING;

/// The contacts of one strand (see the module page).
pub struct StrandContacts {
    bodies: Arc<[Body]>,
    /// Whether a body moves on its own motion: then `frames` holds the bodies' frames.
    moving: bool,
    /// The frame of each body on its own motion at the time and rest flag of `placed`
    /// (`None` for the others).
    frames: Vec<Option<HeadState>>,
    placed: Option<(f64, bool)>,
    /// The q of the poses in `poses` (empty: none).
    posed: Vec<f64>,
    params: ContactParams,
    hair: Option<HairHairParams>,
    /// Arc lengths and weights of the samples.
    samples: Vec<(f64, f64)>,
    anchors: Vec<Option<Anchor>>,
    /// Scratch of [`Self::step_acceptable`]: each sample's effective depth at the step's
    /// start, m (0: it touched nothing).
    start_depth: Vec<f64>,
    /// Depth each sample may have without force: what it had at the start, less what
    /// [`ContactParams::depenetration_speed`] took away since (see [`Self::after_step`]).
    allowance: Vec<f64>,
    /// The root zone: the first `root_zone.1` samples do not touch body `root_zone.0`,
    /// the body the strand grows from (see [`Self::start`]).
    root_zone: (usize, usize),
    partners: Vec<PartnerPoint>,
    /// Scratch: positions on the strand of the partners in `partner_near` (or, in
    /// [`Self::step_acceptable`], of those it checks at the step's end).
    partner_y: Vec<Vector3<f64>>,
    /// Scratch of [`Self::step_acceptable`]: the partners' points at the step's start.
    partner_y0: Vec<Vector3<f64>>,
    /// Scratch: the partners the samples do not rule out (see [`Self::near_partners`]).
    partner_near: Vec<usize>,
    /// Scratch of [`Self::step_acceptable`]: the sample positions at the step's start.
    sample_y0: Vec<Vector3<f64>>,
    /// Scratch: the Jacobian at a self pair's other point, and `J(s) − J(s')`.
    jac_other: Vec<Vector3<f64>>,
    jac_diff: Vec<Vector3<f64>>,
    /// The self pairs within reach at the last [`Self::add_self_pairs`].
    self_touching: usize,
    /// Positions and unit tangents of the samples at the last [`Self::sample_poses`].
    poses: Vec<(Vector3<f64>, Vector3<f64>)>,
    aj: Vec<Vector3<f64>>,
    summary: ContactSummary,
    /// The contacts predicted to start within the coming step ([`super::predicted`]).
    predicted: PredictedContacts,
    /// Scratch of [`Self::deepest_inside`].
    sweep: Vec<Vector3<f64>>,
    /// The time of the last [`Self::start`] or [`Self::after_step`], s.
    updated: Option<f64>,
    /// Whether the contacts that start within a step are predicted ([`Self::predict`]).
    predicting: bool,
}

/// What a strand's contacts carry from one step to the next (a checkpoint's part): the
/// friction anchors, the allowances, the root zone and the last evaluation's summary.
/// The rest is recomputed at each step (the partners, the predicted contacts) or is a
/// cache of a pure function of the time or of q (the bodies' frames, the sample poses).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StrandContactsState {
    anchors: Vec<Option<SavedAnchor>>,
    allowance: Vec<f64>,
    root_zone: (usize, usize),
    summary: ContactSummary,
    self_touching: usize,
}

impl StrandContacts {
    /// What the next step needs (see [`StrandContactsState`]).
    pub fn state(&self) -> StrandContactsState {
        StrandContactsState {
            anchors: self
                .anchors
                .iter()
                .map(|a| a.map(SavedAnchor::from))
                .collect(),
            allowance: self.allowance.clone(),
            root_zone: self.root_zone,
            summary: self.summary,
            self_touching: self.self_touching,
        }
    }

    /// Continue from `state`; an error when its samples are not this strand's.
    pub fn restore(&mut self, state: StrandContactsState) -> Result<(), String> {
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
            .map(|a| a.map(Anchor::from))
            .collect();
        self.allowance = state.allowance;
        self.root_zone = state.root_zone;
        self.summary = state.summary;
        self.self_touching = state.self_touching;
        self.updated = None;
        Ok(())
    }
}

/// The contact samples of a strand of geometry `geom`: arc lengths and weights by
/// [`superhelix_kernels::contact::sample_points`], the root's joint of
/// [`ROOT_JOINT_FRACTION`] of the length left without samples.
pub(crate) fn sample_points(
    geom: &StrandGeometry,
    per: usize,
    free_ends: [bool; 2],
) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(geom.lengths.len() * per + 2);
    superhelix_kernels::contact::sample_points(
        &geom.lengths,
        per,
        free_ends,
        ROOT_JOINT_FRACTION,
        |s, w| out.push((s, w)),
    );
    out
}

impl StrandContacts {
    /// The contacts of a strand of geometry `geom` with `bodies` (and other strands when
    /// `hair` is given), `per` samples per element; `free_ends` (root, tip): the ends
    /// that take a sample where they are (see [`super::ContactConfig::end_samples`]).
    pub fn new(
        geom: &StrandGeometry,
        bodies: Arc<[Body]>,
        params: ContactParams,
        hair: Option<HairHairParams>,
        per: usize,
        free_ends: [bool; 2],
    ) -> Self {
        let samples = sample_points(geom, per.max(1), free_ends);
        let n = samples.len();
        let moving = bodies.iter().any(|b| b.attached.is_motion());
        StrandContacts {
            frames: if moving {
                vec![None; bodies.len()]
            } else {
                Vec::new()
            },
            moving,
            placed: None,
            bodies,
            posed: Vec::new(),
            params,
            hair,
            anchors: vec![None; n],
            start_depth: vec![0.0; n],
            allowance: vec![0.0; n],
            root_zone: (0, 0),
            partners: Vec::new(),
            partner_y: Vec::new(),
            partner_y0: Vec::new(),
            partner_near: Vec::new(),
            sample_y0: Vec::new(),
            jac_other: Vec::new(),
            jac_diff: Vec::new(),
            self_touching: 0,
            poses: vec![(Vector3::zeros(), Vector3::zeros()); n],
            aj: vec![Vector3::zeros(); geom.dofs()],
            samples,
            summary: ContactSummary::default(),
            predicted: PredictedContacts::new(n),
            sweep: Vec::new(),
            updated: None,
            predicting: true,
        }
    }

    /// The same contacts, predicting the contacts that start within a step or not
    /// ([`super::ContactConfig::predict`]; on by default).
    pub fn with_prediction(mut self, predicting: bool) -> Self {
        self.predicting = predicting;
        self
    }

    /// The parameters.
    pub fn params(&self) -> &ContactParams {
        &self.params
    }

    /// The partner points of the coming step (hair–hair).
    pub fn partners(&self) -> &[PartnerPoint] {
        &self.partners
    }

    /// The hair–hair parameters, when hair–hair interaction is on.
    pub fn hair_params(&self) -> Option<&HairHairParams> {
        self.hair.as_ref()
    }

    /// Arc lengths and weights of the samples.
    pub fn samples(&self) -> &[(f64, f64)] {
        &self.samples
    }

    /// What the last evaluation found.
    pub fn summary(&self) -> ContactSummary {
        self.summary
    }

    /// Set the partner points of the coming step (hair–hair).
    pub fn set_partners(&mut self, partners: Vec<PartnerPoint>) {
        // in arc-length order: their positions are then one pass along the strand
        self.partners = in_arc_order(partners);
    }

    /// The partner points of the coming step, to be written in arc-length order (their
    /// positions are then one pass along the strand; [`Self::set_partners`] orders them).
    pub fn partners_mut(&mut self) -> &mut Vec<PartnerPoint> {
        &mut self.partners
    }

    /// Whether the strand has partner points for the coming step.
    pub fn has_partners(&self) -> bool {
        !self.partners.is_empty()
    }

    /// Whether the contact energy may change between steps without the strand moving
    /// (anchors slide, partners change): then the energy of a step's start must be
    /// measured again rather than taken from the end of the previous step.
    pub fn has_history(&self) -> bool {
        self.hair.is_some()
            || matches!(self.params.friction, Friction::Coulomb { .. })
            || self.allowance.iter().any(|a| *a > 0.0)
    }

    /// Whether what the strand may touch moves relative to the head frame between `start`
    /// and `end` (the two ends of a step): other strands; a body on its own motion unless
    /// it is still over the whole step and the head still at both ends; a body fixed in
    /// the world while the head moves at either end. Then contacts can do work on the
    /// strand even while the head moves uniformly.
    pub fn moves_relative(&self, start: &Placement, end: &Placement) -> bool {
        !self.partners.is_empty() || bodies_move_relative(&self.bodies, start, end)
    }

    /// Place the bodies on their own motion at `at` (once per time; nothing without such
    /// bodies).
    fn place(&mut self, at: &Placement) {
        if !self.moving || self.placed == Some((at.time, at.at_rest)) {
            return;
        }
        for (f, b) in self.frames.iter_mut().zip(self.bodies.iter()) {
            *f = if b.attached.is_motion() {
                b.frame(at)
            } else {
                None
            };
        }
        self.placed = Some((at.time, at.at_rest));
    }

    /// The partners the samples' poses (head in `head`) do not rule out, into `near`
    /// (indices, in arc-length order; [`PartnerContacts::near`]).
    fn near_partners(&self, head: &HeadState, near: &mut Vec<usize>) {
        near.clear();
        partners::near(&self.partners, &self.samples, head, &self.poses, |i| {
            near.push(i)
        });
    }

    /// The partners' view with the hair–hair parameters `hh`.
    fn partner_view<'a>(&'a self, hh: &'a HairHairParams) -> PartnerContacts<'a> {
        PartnerContacts {
            params: hh,
            partners: &self.partners,
            samples: &self.samples,
        }
    }

    /// [`Self::near_partners`] into `partner_near`, and their points on the strand at q
    /// into `partner_y` (one pass; the samples must be posed at q).
    fn place_near_partners(&mut self, head: &HeadState, geom: &StrandGeometry, q: &[f64]) {
        let mut near = std::mem::take(&mut self.partner_near);
        self.near_partners(head, &mut near);
        let arcs = near.iter().map(|&i| self.partners[i].s);
        positions_at_sorted(geom, q, arcs, &mut self.partner_y);
        self.partner_near = near;
    }

    /// The sample positions of the last [`Self::sample_poses`], head coordinates.
    pub fn sample_positions(&self) -> impl Iterator<Item = Vector3<f64>> + '_ {
        self.poses.iter().map(|p| p.0)
    }

    /// Positions y(s) and unit tangents of the samples at q, head coordinates.
    pub fn sample_poses(&mut self, geom: &StrandGeometry, q: &[f64]) {
        if self.posed == q {
            return;
        }
        self.posed.clear();
        self.posed.extend_from_slice(q);
        superhelix_kernels::contact::sample_poses(
            &geom.root_pose(q),
            &geom.lengths,
            q,
            &self.samples,
            &mut self.poses,
        );
    }

    /// The body contacts' view of this strand (bodies on their own motion as last
    /// placed): the queries and the law of `superhelix_kernels::contact::body`.
    fn view(&self) -> BodyContacts<'_, PlacedBodies<'_>> {
        BodyContacts {
            colliders: PlacedBodies {
                bodies: &self.bodies,
                frames: &self.frames,
            },
            params: &self.params,
            samples: &self.samples,
            anchors: &self.anchors,
            allowance: &self.allowance,
            root_zone: self.root_zone,
        }
    }

    /// The body sample `k` at head-frame `y` touches most deeply (within the contact
    /// radius), with the head in `head`; a sample of the root zone does not touch the
    /// body its strand grows from.
    fn body_hit(&self, head: &HeadState, k: usize, y: &Vector3<f64>) -> Option<BodyHit> {
        self.view().sample_hit(head, k, y)
    }

    /// Add the contact forces at (q, q̇) with the bodies placed at `at` to `out` (force, and the
    /// stiffness and damping when `terms` asks): see the module page. The stiffness holds
    /// the curvature of the strand under the contact forces (the Hessian of y(s)
    /// contracted with the force) only when `curvature`. Returns whether a contact added
    /// stiffness. `jac` is 3N columns of scratch.
    #[allow(clippy::too_many_arguments)]
    pub fn add_to_terms(
        &mut self,
        at: &Placement,
        kernel: &mut dyn StrandKernel,
        geom: &StrandGeometry,
        q: &[f64],
        v: &[f64],
        terms: Terms,
        curvature: bool,
        jac: &mut [Vector3<f64>],
        out: &mut StrandTerms,
    ) -> bool {
        let asked = TermsAsked {
            force: terms.force,
            stiffness: terms.stiffness,
            curvature,
            damping: terms.damping,
        };
        let mut aj = std::mem::take(&mut self.aj);
        let mut sink = TermsSink {
            kernel: &mut *kernel,
            q,
            out: &mut *out,
            aj: &mut aj,
        };
        let stiffened = self.add_terms_to(at, geom, q, v, asked, jac, &mut sink);
        self.aj = aj;
        stiffened
    }

    /// [`Self::add_to_terms`] into the one step's arrays (force, stiffness, damping),
    /// the strand's points from the step's own terms.
    #[allow(clippy::too_many_arguments)]
    pub fn add_step_terms(
        &mut self,
        at: &Placement,
        geom: &StrandGeometry,
        points: &mut dyn StrandPoints<f64>,
        (q, v): (&[f64], &[f64]),
        curvature: bool,
        jac: &mut [Vector3<f64>],
        force: &mut [f64],
        stiffness: &mut Square<'_, f64>,
        damping: &mut Square<'_, f64>,
    ) -> bool {
        let asked = TermsAsked {
            force: true,
            stiffness: true,
            curvature,
            damping: true,
        };
        let mut aj = std::mem::take(&mut self.aj);
        let mut sink = SquareSink {
            points,
            q,
            force,
            stiffness: stiffness.reborrow(),
            damping: damping.reborrow(),
            aj: &mut aj,
        };
        let stiffened = self.add_terms_to(at, geom, q, v, asked, jac, &mut sink);
        self.aj = aj;
        stiffened
    }

    /// [`Self::add_to_terms`] into any sink of the contact terms (the runtime's terms,
    /// or the one step's arrays), the strand's geometry `geom`.
    #[allow(clippy::too_many_arguments)]
    fn add_terms_to(
        &mut self,
        at: &Placement,
        geom: &StrandGeometry,
        q: &[f64],
        v: &[f64],
        asked: TermsAsked,
        jac: &mut [Vector3<f64>],
        sink: &mut impl ContactSink,
    ) -> bool {
        self.place(at);
        let head = &at.head;
        self.sample_poses(geom, q);
        let (body, mut stiffened) = self
            .view()
            .add_terms(head, &self.poses, v, asked, jac, sink);
        let mut summary = ContactSummary {
            body_contacts: body.contacts,
            max_penetration: body.max_penetration,
            normal_force: body.normal_force,
            ..ContactSummary::default()
        };
        if let Some(hh) = self.hair {
            // the partners the samples do not rule out are placed on the strand first (one
            // pass); J is computed only for those within reach (a partner's force acts
            // along the Jacobian only: no curvature). A coupled pair's penalty and damping
            // are the pair solve's, after the step (`crate::solver::pair_coupling`)
            self.place_near_partners(head, geom, q);
            let (touching, partner_stiffness) = self.partner_view(&hh).add_terms(
                head,
                &self.partner_near,
                &self.partner_y,
                v,
                TermsAsked {
                    curvature: false,
                    ..asked
                },
                jac,
                &mut *sink,
            );
            summary.hair_contacts += touching;
            stiffened |= partner_stiffness;
        }
        if let Some(hh) = self.hair {
            // the pairs of two parts of this strand, stepped on both parts
            self.self_touching = 0;
            if self.partners.iter().any(|p| p.partner_s.is_some()) {
                let mut other = std::mem::take(&mut self.jac_other);
                let mut diff = std::mem::take(&mut self.jac_diff);
                other.resize(jac.len(), Vector3::zeros());
                diff.resize(jac.len(), Vector3::zeros());
                let (touching, self_stiffness) = self.partner_view(&hh).add_self_terms(
                    v,
                    TermsAsked {
                        curvature: false,
                        ..asked
                    },
                    jac,
                    &mut other,
                    &mut diff,
                    &mut *sink,
                );
                self.self_touching = touching;
                stiffened |= self_stiffness;
                (self.jac_other, self.jac_diff) = (other, diff);
            }
            summary.hair_contacts += self.self_touching;
        }
        self.summary = summary;
        stiffened
    }

    /// The energy of the pairs of two parts of this strand at q (penalty and friction
    /// springs; the samples must be posed at q). Internal: no work through motion
    /// ([`PartnerContacts::self_energy`]).
    fn self_pairs_energy(&mut self, hh: &HairHairParams, geom: &StrandGeometry, q: &[f64]) -> f64 {
        let mut buf = std::mem::take(&mut self.sweep);
        let potential = self.partner_view(hh).self_energy(&self.poses, |lo, hi| {
            positions_at_sorted(geom, q, [lo, hi], &mut buf);
            Some((*buf.first()?, *buf.get(1)?))
        });
        self.sweep = buf;
        potential
    }

    /// The contact potential at q with the bodies placed at `at` (normal penalty, Coulomb
    /// springs, hair–hair penalty), J; and its rate at fixed q through the motion of what
    /// the strand touches (bodies fixed in the world while the head moves, bodies on their
    /// own motion, partner points moving at their velocities), W.
    pub fn energy(&mut self, at: &Placement, geom: &StrandGeometry, q: &[f64]) -> (f64, f64) {
        self.place(at);
        let head = &at.head;
        self.sample_poses(geom, q);
        let (mut potential, mut rate) = self.view().energy(head, &self.poses);
        if let Some(hh) = self.hair {
            // only the partners the samples do not rule out (most of those the search
            // keeps are beyond reach, and contribute nothing) are placed on the strand
            self.place_near_partners(head, geom, q);
            (potential, rate) = self.partner_view(&hh).energy(
                head,
                &self.partner_near,
                &self.partner_y,
                &self.poses,
                (potential, rate),
            );
            potential += self.self_pairs_energy(&hh, geom, q);
        }
        (potential, rate)
    }

    /// The power, W, at (q, q̇) that the damping and viscous friction of the bodies on their
    /// own motion put into the strand through the bodies' velocity u: both act on the
    /// velocity relative to the body, `f = −c (ẏ − u)` (normal damping along n, viscous
    /// friction in the tangent plane), and their part `c u` does the work `c u · ẏ` (the
    /// part `−c ẏ` only dissipates). The same for the hair–hair damping of the partners
    /// within reach, `f = −c_h w (ẏ − v_p)`, through the partner's velocity v_p. With
    /// [`Self::energy`]'s rate it is the work the energy balance allows a step; 0 without
    /// such bodies or partners (nothing is computed).
    pub fn drag_power(
        &mut self,
        at: &Placement,
        kernel: &mut dyn StrandKernel,
        geom: &StrandGeometry,
        q: &[f64],
        v: &[f64],
        jac: &mut [Vector3<f64>],
    ) -> f64 {
        self.drag_power_with(at, geom, q, v, jac, &mut |s, jac| {
            kernel.point(q, s, jac, None)
        })
    }

    /// [`Self::drag_power`] with the strand's points from `point` (y(s) at q, J(s) into
    /// the columns given), the strand's geometry `geom`.
    pub fn drag_power_with(
        &mut self,
        at: &Placement,
        geom: &StrandGeometry,
        q: &[f64],
        v: &[f64],
        jac: &mut [Vector3<f64>],
        point: &mut StrandPointFn<'_>,
    ) -> f64 {
        if !self.moving {
            return self.partner_drag_power(&at.head, geom, q, v, jac, point);
        }
        self.place(at);
        let head = &at.head;
        self.sample_poses(geom, q);
        let power = self.view().drag_power(head, &self.poses, v, jac, |s, jac| {
            point(s, jac);
        });
        power + self.partner_drag_power(head, geom, q, v, jac, point)
    }

    /// The power `c_h w v_p · ẏ` of the hair–hair damping of the partners within reach
    /// through their velocities v_p (head frame), at (q, q̇) (see [`Self::drag_power`]).
    fn partner_drag_power(
        &mut self,
        head: &HeadState,
        geom: &StrandGeometry,
        q: &[f64],
        v: &[f64],
        jac: &mut [Vector3<f64>],
        point: &mut StrandPointFn<'_>,
    ) -> f64 {
        let Some(hh) = self.hair else { return 0.0 };
        // a coupled pair's damping is not the step's (see `add_to_terms`)
        if self.partners.is_empty() || hh.coupled {
            return 0.0;
        }
        self.sample_poses(geom, q);
        self.place_near_partners(head, geom, q);
        self.partner_view(&hh)
            .drag_power(head, &self.partner_near, &self.partner_y, v, jac, point)
    }

    /// Whether the strand may touch a body.
    pub fn has_bodies(&self) -> bool {
        !self.bodies.is_empty()
    }

    /// The contacts predicted for the coming step and their buffers.
    pub fn predicted_mut(&mut self) -> &mut PredictedContacts {
        &mut self.predicted
    }

    /// Find the samples that may reach a body within the coming step
    /// ([`superhelix_kernels::contact::predicted::list`]), with the bodies placed at the
    /// step's end `at`: those that do not touch a body at the linearisation point `q_lin`
    /// (their stiffness is not in the step's matrix) and come within one and a half
    /// contact radii of a body at the predicted end `q_pred`. Keeps `q_lin`. Returns
    /// whether there is any.
    pub fn predict(
        &mut self,
        at: &Placement,
        geom: &StrandGeometry,
        q_lin: &[f64],
        q_pred: &[f64],
    ) -> bool {
        if !self.predicting || self.bodies.is_empty() {
            // nothing predicted: the step's resolution finds no linearisation point
            self.predicted.forget();
            return false;
        }
        let mut pc = std::mem::take(&mut self.predicted);
        self.place(at);
        let head = at.head;
        self.sample_poses(geom, q_lin);
        // the tip, beyond the last sample: guarded at the end check
        let lin_tip = self.tip_at(geom, q_lin);
        predicted::begin(&mut pc, &self.view(), &head, q_lin, &self.poses, lin_tip);
        self.sample_poses(geom, q_pred);
        let any = predicted::list(&mut pc, &self.view(), &head, q_lin.len(), &self.poses);
        self.predicted = pc;
        any
    }

    /// The end check of the contacts predicted in `pc` at the end `q_end` of a step's
    /// solve, the bodies placed at `at` ([`superhelix_kernels::contact::predicted::check`]).
    /// Returns the number of candidates before it.
    pub fn check_predicted(
        &mut self,
        pc: &mut PredictedContacts,
        at: &Placement,
        geom: &StrandGeometry,
        q_end: &[f64],
    ) -> usize {
        self.place(at);
        let head = at.head;
        self.sample_poses(geom, q_end);
        let tip_end = self.tip_at(geom, q_end);
        predicted::check(
            pc,
            &self.view(),
            &head,
            q_end.len(),
            &self.poses,
            tip_end,
            geom.length(),
        )
    }

    /// The tip's position at q, head coordinates.
    fn tip_at(&mut self, geom: &StrandGeometry, q: &[f64]) -> Option<Vector3<f64>> {
        let mut tip = std::mem::take(&mut self.sweep);
        positions_at_sorted(geom, q, [geom.length()], &mut tip);
        let end = tip.first().copied();
        self.sweep = tip;
        end
    }

    /// The deepest point of the centreline inside a body at q (bodies placed at `at`),
    /// m (0: none), checked on a dense sweep: points every [`SWEEP_SPACING`] of arc
    /// length from the root to the tip, not only the contact samples. The root zone
    /// (the first samples, which do not touch the body the strand grows from) is
    /// excluded from that body up to its last sample's half weight beyond it.
    ///
    /// Between two points of the sweep the depth differs from theirs by at most half the
    /// spacing (the distance to a body is 1-Lipschitz along a unit-speed curve); at the
    /// deepest point of a centreline that crosses a smooth surface the depth is
    /// stationary along the curve, so there the sweep's error is of second order in the
    /// spacing.
    pub fn deepest_inside(&mut self, at: &Placement, geom: &StrandGeometry, q: &[f64]) -> f64 {
        self.place(at);
        self.view()
            .deepest_inside(&at.head, &geom.root_pose(q), &geom.lengths, q)
    }

    /// The deepest penetration of the contact radius by a sample at q, m (0: none).
    pub fn max_depth(&mut self, at: &Placement, geom: &StrandGeometry, q: &[f64]) -> f64 {
        self.place(at);
        let head = &at.head;
        self.sample_poses(geom, q);
        (0..self.samples.len())
            .filter_map(|k| self.body_hit(head, k, &self.poses[k].0))
            .map(|h| self.params.radius - h.distance)
            .fold(0.0, f64::max)
    }

    /// Whether a step from `q0` to `q1` (bodies placed at `start` and `end` at its two
    /// ends) is acceptable for the contacts: no sample went deeper into a body than
    /// [`ContactParams::split_depth`] beyond its depth at the start (0 for one that touched
    /// nothing), nor a sample that was apart from a partner that far into its ball (a fast
    /// approach is resolved by substeps rather than met by a deep penalty). The depth in a partner's ball is measured along the line of
    /// centres at the start, so that a step that carries a point through the other strand
    /// counts as deep.
    pub fn step_acceptable(
        &mut self,
        start: &Placement,
        end: &Placement,
        geom: &StrandGeometry,
        q0: &[f64],
        q1: &[f64],
    ) -> bool {
        let split = self.params.split_depth;
        let head = &end.head;
        // how deep the samples are at the start: for a body on the head or in the world, as
        // the step's matrix has them (q0 with the head at the end); for a body on its own
        // motion, where it is at the start, so that a body sweeping into the strand within
        // the step makes new, checked contacts
        self.sample_poses(geom, q0);
        if self.moving {
            self.place(start);
            for k in 0..self.samples.len() {
                let y = self.poses[k].0;
                self.start_depth[k] = self.view().depth_among(&start.head, k, &y, Some(true));
            }
            self.place(end);
            for k in 0..self.samples.len() {
                let y = self.poses[k].0;
                let d = self.view().depth_among(head, k, &y, Some(false));
                self.start_depth[k] = self.start_depth[k].max(d);
            }
        } else {
            for k in 0..self.samples.len() {
                let y = self.poses[k].0;
                self.start_depth[k] = self.view().depth_among(head, k, &y, None);
            }
        }
        // a coupled pair's normal force is not the step's: its approach is not checked
        let coupled = self.hair.is_some_and(|h| h.coupled);
        let has_partners = self
            .partners
            .iter()
            .any(|p| p.partner_s.is_some() || !coupled);
        if has_partners {
            self.sample_y0.clear();
            self.sample_y0.extend(self.poses.iter().map(|p| p.0));
        }
        self.sample_poses(geom, q1);
        if self.view().too_deep(head, &self.poses, &self.start_depth) {
            return false;
        }
        if !has_partners {
            return true;
        }
        let Some(hh) = self.hair else {
            return true;
        };
        let split = hh.split_depth.unwrap_or(split);
        // a partner is checked on the strand only when the samples do not settle it
        // ([`PartnerContacts::unsettled`])
        let mut near = std::mem::take(&mut self.partner_near);
        near.clear();
        self.partner_view(&hh)
            .unsettled(head, &self.sample_y0, &self.poses, split, |i| near.push(i));
        let (mut y0, mut y1) = (
            std::mem::take(&mut self.partner_y0),
            std::mem::take(&mut self.partner_y),
        );
        let arcs = || near.iter().map(|&i| self.partners[i].s);
        positions_at_sorted(geom, q0, arcs(), &mut y0);
        positions_at_sorted(geom, q1, arcs(), &mut y1);
        let ok = self
            .partner_view(&hh)
            .approach_acceptable(head, &near, &y0, &y1, split);
        (self.partner_near, self.partner_y0, self.partner_y) = (near, y0, y1);
        ok && self.self_pairs_acceptable(geom, q0, q1, split)
    }

    /// [`Self::step_acceptable`] for the pairs of two parts of this strand
    /// ([`PartnerContacts::self_approach_acceptable`]).
    fn self_pairs_acceptable(
        &mut self,
        geom: &StrandGeometry,
        q0: &[f64],
        q1: &[f64],
        split: f64,
    ) -> bool {
        let Some(hh) = self.hair else {
            return true;
        };
        let mut buf = std::mem::take(&mut self.sweep);
        let ok = self
            .partner_view(&hh)
            .self_approach_acceptable(split, |end, lo, hi| {
                positions_at_sorted(geom, if end { q1 } else { q0 }, [lo, hi], &mut buf);
                (buf[0], buf[1])
            });
        self.sweep = buf;
        ok
    }

    /// The samples that touch a body at q (bodies placed at `at`, root zone as
    /// [`Self::start`] sets it; call that first) and that the body meets first: none of
    /// the samples beside them along the strand is deeper in it. For each, the generalized
    /// force of a unit normal force there, `Jᵀ n` (one entry per coordinate of q), in
    /// sample order. A sag-free start with contacts chooses how much each carries.
    ///
    /// A sample with a deeper neighbour is left out: as the strand settles onto the
    /// penalty by the depth that carries its load (micrometres), the neighbour takes the
    /// load first, and a load put on the shallower sample would move onto it in the run,
    /// changing the shape (a strand whose free end lies on the crown of a cylinder: the
    /// end sample is deeper than the one a third of a part inside, which the elastic
    /// choice alone would load; the 10 cm strand of the propped-cantilever test then sagged
    /// 34 µm between its ends in its first 0.1 s).
    pub fn support_directions(
        &mut self,
        at: &Placement,
        kernel: &mut dyn StrandKernel,
        q: &[f64],
    ) -> Vec<Vec<f64>> {
        self.place(at);
        let head = at.head;
        self.sample_poses(kernel.geometry(), q);
        let hits: Vec<Option<BodyHit>> = (0..self.samples.len())
            .map(|k| self.body_hit(&head, k, &self.poses[k].0))
            .collect();
        let depth = |k: usize| hits[k].as_ref().map(|h| -h.distance);
        let mut jac = vec![Vector3::zeros(); q.len()];
        let mut out = Vec::new();
        for (k, hit) in hits.iter().enumerate() {
            let Some(hit) = hit else {
                continue;
            };
            let deeper = |j: Option<usize>| j.and_then(depth).is_some_and(|d| d > -hit.distance);
            if deeper(k.checked_sub(1)) || deeper((k + 1 < hits.len()).then_some(k + 1)) {
                continue;
            }
            kernel.point(q, self.samples[k].0, &mut jac, None);
            out.push(jac.iter().map(|j| j.dot(&hit.normal)).collect());
        }
        out
    }

    /// Before the first step (state q, bodies placed at `at`): a point that starts inside a body
    /// (within the contact radius, deeper than where its penalty is a hundred times the
    /// strand's weight) is allowed its depth, so that it is let out at
    /// [`ContactParams::depenetration_speed`] rather than kicked out; Coulomb anchors
    /// are set where the touching points are.
    ///
    /// A strand grows from a body (its root within the contact radius of the scalp): its
    /// samples from the root on that lie within the contact radius of that body, up to the
    /// first one that does not and at most a quarter of the strand's length, are its root
    /// zone, which does not touch that body. They stand for the hair leaving its follicle:
    /// pushed out, they could not leave (the root is clamped) and would bend the strand
    /// by a penalty of up to 10⁴ times its weight; a groom at rest would not stay at rest.
    pub fn start(&mut self, at: &Placement, geom: &StrandGeometry, q: &[f64]) {
        self.updated = Some(at.time);
        self.place(at);
        let head = &at.head;
        self.sample_poses(geom, q);
        // a free root is not held by the body it starts on: no root zone
        let root = (!geom.floating).then_some(&geom.root_position);
        self.root_zone = (0, 0);
        self.root_zone =
            self.view()
                .root_zone_at(head, root, &self.poses, geom.lengths.iter().sum());
        // a depth whose penalty is within a hundred times the strand's weight is harmless
        // and left to the penalty (a strand laid on a body at rest)
        let harmless = 100.0 * geom.mass_per_length * STANDARD_GRAVITY / self.params.stiffness;
        for k in 0..self.samples.len() {
            self.allowance[k] = self
                .view()
                .start_allowance(head, k, &self.poses[k].0, harmless);
        }
        self.update_anchors(head, geom, q);
    }

    /// After an accepted step of `h` seconds (state q, bodies placed at `at`): shrink the
    /// allowances of the points that started inside a body by the depenetration speed
    /// times h (and to their present depth); update the Coulomb anchors.
    pub fn after_step(&mut self, at: &Placement, geom: &StrandGeometry, q: &[f64], h: f64) {
        // the time since the last bookkeeping (a step's pieces each have theirs)
        let h = self.updated.map_or(h, |t0| (at.time - t0).clamp(0.0, h));
        self.updated = Some(at.time);
        self.place(at);
        let head = &at.head;
        if self.allowance.iter().any(|a| *a > 0.0) {
            self.sample_poses(geom, q);
            for k in 0..self.samples.len() {
                self.allowance[k] = self.view().allowance_after(head, k, &self.poses[k].0, h);
            }
        }
        self.update_anchors(head, geom, q);
    }

    /// Stick new contact points where they are, drag sliding anchors to the friction
    /// cone's edge, release the points that left their body (Coulomb friction only).
    fn update_anchors(&mut self, head: &HeadState, geom: &StrandGeometry, q: &[f64]) {
        if !matches!(self.params.friction, Friction::Coulomb { .. }) {
            return;
        }
        self.sample_poses(geom, q);
        for k in 0..self.samples.len() {
            let (y, t) = self.poses[k];
            self.anchors[k] = self.view().anchor_after(head, k, &y, &t);
        }
    }
}

/// `partners` in arc-length order (`s` increasing; equal arc lengths keep their order, as
/// a stable sort), each moved once: the order is sorted on the arc lengths alone (a
/// partner point is some 200 bytes), and a list already in order is taken as it is.
fn in_arc_order(partners: Vec<PartnerPoint>) -> Vec<PartnerPoint> {
    if partners
        .windows(2)
        .all(|w| w[0].s.total_cmp(&w[1].s).is_le())
    {
        return partners;
    }
    let mut order: Vec<(f64, usize)> = partners.iter().map(|p| p.s).zip(0..).collect();
    order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    order.into_iter().map(|(_, i)| partners[i]).collect()
}

/// `force += Jᵀ f`.
fn add_force(jac: &[Vector3<f64>], f: &Vector3<f64>, force: &mut [f64]) {
    add_generalized_force(jac, f, force);
}

/// `m += Jᵀ A J` (A symmetric), `aj` scratch of 3N columns (see
/// [`superhelix_kernels::contact::body::add_projected`]).
fn add_projected(
    jac: &[Vector3<f64>],
    a: &Matrix3<f64>,
    aj: &mut [Vector3<f64>],
    m: &mut Mat<f64>,
) {
    body::add_projected(jac, a, aj, |i, j, x| m[(i, j)] += x);
}

/// Whether one of `bodies` moves relative to the head frame between `start` and `end`
/// (the two ends of a step): a body on its own motion unless it is still over the whole
/// step and the head still at both ends; a body fixed in the world while the head moves
/// at either end.
fn bodies_move_relative(bodies: &[Body], start: &Placement, end: &Placement) -> bool {
    let head_moves = |h: &HeadState| h.velocity != Vector3::zeros() || h.omega != Vector3::zeros();
    let head_still = !head_moves(&start.head) && !head_moves(&end.head);
    bodies.iter().any(|b| match &b.attached {
        Attachment::Head => false,
        Attachment::World => !head_still,
        Attachment::Motion(m) => {
            let s = m.state(start.time);
            let still = start.at_rest
                || (m.uniform_over(start.time, end.time)
                    && s.velocity == Vector3::zeros()
                    && s.omega == Vector3::zeros());
            !(still && head_still)
        }
    })
}

/// A scene's bodies as the colliders of the fixed-N step
/// (`superhelix_kernels::fixed::StepColliders`): placed at each time the step asks, the
/// bodies on their own motion in their frames of that time.
#[derive(Clone)]
pub struct BodyColliders {
    bodies: Arc<[Body]>,
    frames: Vec<Option<HeadState>>,
    placed: Option<f64>,
}

impl BodyColliders {
    /// The colliders of `bodies`.
    pub fn new(bodies: Arc<[Body]>) -> Self {
        BodyColliders {
            frames: vec![None; bodies.len()],
            bodies,
            placed: None,
        }
    }

    fn placed(&self) -> PlacedBodies<'_> {
        PlacedBodies {
            bodies: &self.bodies,
            frames: &self.frames,
        }
    }
}

impl ColliderSet for BodyColliders {
    fn count(&self) -> usize {
        self.bodies.len()
    }
    fn proximity(&self, b: usize, local: &Vector3<f64>) -> Proximity {
        self.placed().proximity(b, local)
    }
    fn farther_than(&self, b: usize, local: &Vector3<f64>, r: f64) -> bool {
        self.placed().farther_than(b, local, r)
    }
    fn mount(&self, b: usize) -> Mount {
        self.placed().mount(b)
    }
    fn on_own_motion(&self, b: usize) -> bool {
        self.placed().on_own_motion(b)
    }
}

impl superhelix_kernels::fixed::StepColliders for BodyColliders {
    fn place(&mut self, t: f64, head: &HeadState) {
        if self.placed == Some(t) {
            return;
        }
        let at = Placement::new(*head, t);
        for (f, b) in self.frames.iter_mut().zip(self.bodies.iter()) {
            *f = if b.attached.is_motion() {
                b.frame(&at)
            } else {
                None
            };
        }
        self.placed = Some(t);
    }
    fn moves_relative(&self, t0: f64, t1: f64, head0: &HeadState, head1: &HeadState) -> bool {
        bodies_move_relative(
            &self.bodies,
            &Placement::new(*head0, t0),
            &Placement::new(*head1, t1),
        )
    }
}

/// The runtime's bodies placed at a time, as the colliders of
/// `superhelix_kernels::contact::body`: each body's shape, and its frame when it moves on
/// its own motion (as [`StrandContacts::place`] last placed it).
struct PlacedBodies<'a> {
    bodies: &'a [Body],
    frames: &'a [Option<HeadState>],
}

impl ColliderSet for PlacedBodies<'_> {
    fn count(&self) -> usize {
        self.bodies.len()
    }
    fn proximity(&self, b: usize, local: &Vector3<f64>) -> Proximity {
        self.bodies[b].shape.query(local)
    }
    fn farther_than(&self, b: usize, local: &Vector3<f64>, r: f64) -> bool {
        self.bodies[b].shape.farther_than(local, r)
    }
    fn mount(&self, b: usize) -> Mount {
        match self.bodies[b].attached {
            Attachment::Head => Mount::Head,
            Attachment::World => Mount::World,
            Attachment::Motion(_) => Mount::Frame(
                self.frames
                    .get(b)
                    .copied()
                    .flatten()
                    .unwrap_or_else(HeadState::rest),
            ),
        }
    }
    fn on_own_motion(&self, b: usize) -> bool {
        self.bodies[b].attached.is_motion()
    }
}

/// A strand's terms as the sink of the body contacts' terms: the kernel's points at q,
/// the force, stiffness and damping of `out`.
struct TermsSink<'a> {
    kernel: &'a mut dyn StrandKernel,
    q: &'a [f64],
    out: &'a mut StrandTerms,
    aj: &'a mut [Vector3<f64>],
}

impl ContactSink for TermsSink<'_> {
    fn point(
        &mut self,
        s: f64,
        jac: &mut [Vector3<f64>],
        curvature: Option<Vector3<f64>>,
    ) -> Vector3<f64> {
        let hess = curvature.map(|f| (f, &mut self.out.stiffness));
        self.kernel.point(self.q, s, jac, hess)
    }
    fn add_force(&mut self, jac: &[Vector3<f64>], f: &Vector3<f64>) {
        add_force(jac, f, &mut self.out.force);
    }
    fn add_stiffness(&mut self, jac: &[Vector3<f64>], a: &Matrix3<f64>) {
        add_projected(jac, a, self.aj, &mut self.out.stiffness);
    }
    fn add_damping(&mut self, jac: &[Vector3<f64>], a: &Matrix3<f64>) {
        add_projected(jac, a, self.aj, &mut self.out.damping);
    }
}

/// The strand's point y(s) at the state in question, J(s) into the columns given.
pub type StrandPointFn<'a> = dyn FnMut(f64, &mut [Vector3<f64>]) -> Vector3<f64> + 'a;

/// The one step's arrays as the sink of the contact terms, the strand's points from the
/// step's own terms.
struct SquareSink<'a, 'm> {
    points: &'a mut dyn StrandPoints<f64>,
    q: &'a [f64],
    force: &'a mut [f64],
    stiffness: Square<'m, f64>,
    damping: Square<'m, f64>,
    aj: &'a mut [Vector3<f64>],
}

impl ContactSink for SquareSink<'_, '_> {
    fn point(
        &mut self,
        s: f64,
        jac: &mut [Vector3<f64>],
        curvature: Option<Vector3<f64>>,
    ) -> Vector3<f64> {
        match curvature {
            Some(c) => self
                .points
                .point_curvature(self.q, s, jac, c, &mut self.stiffness),
            None => self.points.point(self.q, s, jac),
        }
    }
    fn add_force(&mut self, jac: &[Vector3<f64>], f: &Vector3<f64>) {
        add_force(jac, f, self.force);
    }
    fn add_stiffness(&mut self, jac: &[Vector3<f64>], a: &Matrix3<f64>) {
        let m = &mut self.stiffness;
        body::add_projected(jac, a, self.aj, |i, j, x| m[j][i] += x);
    }
    fn add_damping(&mut self, jac: &[Vector3<f64>], a: &Matrix3<f64>) {
        let m = &mut self.damping;
        body::add_projected(jac, a, self.aj, |i, j, x| m[j][i] += x);
    }
}

#[cfg(test)]
mod pruning_tests {
    //! The shortcuts of the partner loops against doing without them: the partners
    //! [`StrandContacts::near_partners`] rules out are beyond reach (so the sums over the
    //! others are the sums over all), and the bound that lets
    //! [`StrandContacts::step_acceptable`] skip a partner never changes its verdict.
    use super::*;
    use crate::forces::contacts::ContactConfig;
    use crate::forces::contacts::HairHairConfig;
    use crate::model::material::Material;

    /// A small deterministic generator (xorshift), uniform in [−1, 1).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        }
    }

    fn setup(n: usize) -> (StrandGeometry, StrandContacts, HairHairParams) {
        let material = Material {
            mass_per_length: 1e-5,
            stiffness: [1e-9, 1.3e-9, 1.3e-9],
            rotary_inertia: [1e-15, 5e-16, 5e-16],
        };
        let geom = StrandGeometry::new(
            Vector3::zeros(),
            Matrix3::identity(),
            vec![0.02; n],
            &material,
        );
        let config = ContactConfig {
            // the partners as balls: the terms of a strand's own step are checked here
            hair_hair: Some(HairHairConfig {
                coupling: crate::forces::contacts::Coupling::Ball,
                ..HairHairConfig::default()
            }),
            ..ContactConfig::default()
        };
        let hair = config.hair_hair.as_ref().expect("set").params(1e-5);
        let contacts = StrandContacts::new(
            &geom,
            Arc::<[Body]>::from(Vec::new()),
            config.params(1e-5),
            Some(hair),
            3,
            [false, false],
        );
        (geom, contacts, hair)
    }

    /// Partner points scattered around the strand at `q`, some within reach.
    fn partners(
        rng: &mut Rng,
        geom: &StrandGeometry,
        q: &[f64],
        reach: f64,
        count: usize,
    ) -> Vec<PartnerPoint> {
        let length = geom.length();
        let mut out = Vec::new();
        let mut y = Vec::new();
        for _ in 0..count {
            let s = 0.5 * (rng.next() + 1.0) * length;
            positions_at_sorted(geom, q, [s], &mut y);
            let off = Vector3::new(rng.next(), rng.next(), rng.next()) * (3.0 * reach);
            out.push(PartnerPoint {
                s,
                weight: 1e-3,
                point: y[0] + off,
                velocity: Vector3::zeros(),
                reach,
                anchor: None,
                partner_s: None,
                pair: 0,
                normal: Vector3::zeros(),
            });
        }
        out
    }

    #[test]
    fn the_partners_ruled_out_are_beyond_reach() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let n = 6;
        let (geom, mut contacts, hair) = setup(n);
        let head = HeadState::rest();
        let reach = 2.0 * hair.radius;
        let (mut kept, mut ruled_out) = (0, 0);
        let mut y = Vec::new();
        for _ in 0..200 {
            let q: Vec<f64> = (0..3 * n).map(|_| 20.0 * rng.next()).collect();
            contacts.set_partners(partners(&mut rng, &geom, &q, reach, 30));
            contacts.sample_poses(&geom, &q);
            let mut near = Vec::new();
            contacts.near_partners(&head, &mut near);
            for (i, p) in contacts.partners.iter().enumerate() {
                if near.contains(&i) {
                    kept += 1;
                    continue;
                }
                ruled_out += 1;
                positions_at_sorted(&geom, &q, [p.s], &mut y);
                let d = (y[0] - p.point).norm();
                assert!(d >= p.reach, "ruled out at {d} < reach {}", p.reach);
            }
        }
        // the test means something: both kinds occur
        assert!(
            kept > 100 && ruled_out > 100,
            "{kept} kept, {ruled_out} ruled out"
        );
    }

    #[test]
    fn the_approach_checks_shortcut_never_changes_its_verdict() {
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        let n = 5;
        let (geom, mut contacts, hair) = setup(n);
        let at = Placement::at_rest(0.0);
        let reach = 2.0 * hair.radius;
        let split = contacts.params().split_depth;
        let (mut passed, mut failed, mut skipped) = (0, 0, 0);
        let (mut y0, mut y1) = (Vec::new(), Vec::new());
        for _ in 0..400 {
            let q0: Vec<f64> = (0..3 * n).map(|_| 15.0 * rng.next()).collect();
            let q1: Vec<f64> = q0.iter().map(|x| x + 3.0 * rng.next()).collect();
            // partners around where the strand starts and around where it ends (those
            // it reaches within the step)
            let mut list = partners(&mut rng, &geom, &q0, reach, 6);
            list.extend(partners(&mut rng, &geom, &q1, reach, 6));
            contacts.set_partners(list);
            let verdict = contacts.step_acceptable(&at, &at, &geom, &q0, &q1);
            // the partners the shortcut settled without the exact check
            skipped += contacts.partners.len() - contacts.partner_near.len();
            // every partner checked exactly, as the shortcut's bound stands in for
            let exact = contacts.partners.iter().all(|p| {
                positions_at_sorted(&geom, &q0, [p.s], &mut y0);
                positions_at_sorted(&geom, &q1, [p.s], &mut y1);
                let d0 = y0[0] - p.point;
                let norm = d0.norm();
                norm == 0.0
                    || norm < p.reach
                    || p.reach - (y1[0] - p.point).dot(&(d0 / norm)) <= split
            });
            assert_eq!(verdict, exact);
            if verdict {
                passed += 1;
            } else {
                failed += 1;
            }
        }
        // the test means something: both verdicts occur, and the shortcut settles many
        assert!(
            passed > 50 && failed > 20 && skipped > 500,
            "{passed} passed, {failed} failed, {skipped} settled by the bound"
        );
    }
}
