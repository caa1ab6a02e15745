//! The checked fixed-N step: a linearly implicit Euler step checked after the fact and
//! split into halves when it is not acceptable, with the runtime's rules (the same
//! constants, the same energy balance, [`crate::energy`]):
//!
//! - a step that fails (singular matrix, non-finite values) or rotates an element by more
//!   than [`MAX_ELEMENT_ROTATION`] is split in two, recursively, at most
//!   [`MAX_SUBSTEP_DEPTH`](crate::energy::MAX_SUBSTEP_DEPTH) deep (a rotation r at once into the 2^j pieces of
//!   [`rotation_split_levels`], r / 2^j within the limit);
//! - E(end) must not exceed its bound (see [`crate::energy::balance`]); a step whose
//!   excess is above [`ENERGY_SPLIT_FRACTION`] (head moving uniformly) or
//!   [`WORK_SPLIT_FRACTION`] (otherwise) of the energy scale is split, a smaller excess
//!   removed by scaling the velocities;
//! - with the head moving uniformly, a step that loses more than
//!   [`crate::energy::LOSS_SPLIT_FRACTION`] of the energy scale beyond the dissipation
//!   bound is split into the pieces of [`crate::energy::loss_split_levels`] (at most
//!   [`crate::energy::LOSS_SPLIT_DEPTH`] deep).
//!
//! Without these checks a strand on a head shaking at 2 Hz by ±30° overflows within a
//! second at dt = 1/30 and 1/60 s (the demo scene); with them it does not.

use super::bdf2::{bdf2_step, Bdf2History, BDF2_MAX_RATIO};
use super::contacts::ContactHooks;
use super::dense::Projection;
use super::end_hooks::{EndHooks, HeldError};
use super::free_root;
use super::newton::{newton_step, NewtonOutcome};
use super::step::{
    max_element_rotation, non_finite, solve_factored_f64, solve_step, StepError, StepInput,
    StepReport,
};
use super::workspace::FixedWorkspace;
use super::FixedStrand;
use crate::energy::{
    balance, end_ceiling, energy_splits, predicted_split_levels, rotation_split_levels, Balance,
    StateEnergy, ENERGY_SPLIT_FRACTION, MAX_ELEMENT_ROTATION, MAX_SUBSTEP_DEPTH,
    TRUSTED_ELEMENT_ROTATION, WORK_SPLIT_FRACTION,
};
use crate::field_split::FieldRule;
use crate::float::Float;
use crate::head::{body_field, HeadState};
use crate::point_load::{self, any_follows};
use crate::storage::{ParamsView, StrandView, WorkView};
use crate::strand_terms::{MomentSource, PointsOf, StepTerms, StrandPoints};
use nalgebra::{Matrix3, Vector3};

/// The head's motion as the checked step sees it: its state at any time of the step
/// (the step's ends, and the ends of the substeps it splits into).
pub trait HeadTrajectory {
    /// The head at time t.
    fn state(&self, t: f64) -> HeadState;
    /// Whether the head moves uniformly over [t0, t1] (no rotation, constant velocity):
    /// then the head does no work and the energy can only decrease.
    fn uniform_over(&self, t0: f64, t1: f64) -> bool;
    /// The earliest time in the open interval (t0, t1) at which the head starts or stops
    /// moving uniformly (where [`HeadTrajectory::uniform_over`] changes), if the motion
    /// has one there: the checked steps land on it (see [`phase_cut`]), so that an
    /// inertial phase's energy ceiling is the energy at the phase's exact start. The
    /// default, `None`, is right for a motion that is uniform everywhere or nowhere.
    fn phase_change(&self, t0: f64, t1: f64) -> Option<f64> {
        let _ = (t0, t1);
        None
    }
}

/// Fraction of a step within which a phase change ([`HeadTrajectory::phase_change`]) is
/// taken to fall on the step's end rather than cut it: round-off of accumulated times
/// (a stop at 0.6 s reached by 18 steps of 1/30 s) must not leave a piece of 1e-16 s.
pub const PHASE_CUT_MARGIN: f64 = 1e-9;

/// Where a step from t0 to t1 is cut so that its pieces land on the head's phase
/// changes: the first phase change inside the step, more than [`PHASE_CUT_MARGIN`] of the
/// step from either end, or `None`. Both engines step [t0, cut] and [cut, t1] as two
/// steps (each checked and split as any step), so an inertial phase starts exactly at its
/// time: its ceiling is E there (`crate::energy`), the invariant `superhelix stress`
/// checks.
pub fn phase_cut(head: &dyn HeadTrajectory, t0: f64, t1: f64) -> Option<f64> {
    let margin = PHASE_CUT_MARGIN * (t1 - t0);
    head.phase_change(t0 + margin, t1 - margin)
        .filter(|&b| b > t0 + margin && b < t1 - margin)
}

/// A head that does not move.
#[derive(Debug, Clone, Copy, Default)]
pub struct StillHead;

impl HeadTrajectory for StillHead {
    fn state(&self, _t: f64) -> HeadState {
        HeadState::rest()
    }
    fn uniform_over(&self, _t0: f64, _t1: f64) -> bool {
        true
    }
}

/// A head known by its state at one time, moved on from it with constant acceleration
/// and angular acceleration: `X(t) = X0 + Ẋ0 τ + ½ Ẍ0 τ²`, `R(t) = R0 exp([ω0 τ + ½ α0 τ²]×)`
/// (τ = t − t0): what an engine that sets the head's pose and its derivatives once per
/// frame gives the step (the substeps inside the frame follow this motion).
#[derive(Debug, Clone, Copy)]
pub struct ExtrapolatedHead {
    /// The time of `state`, seconds.
    pub t0: f64,
    /// The head at t0.
    pub state: HeadState,
}

/// exp([w]×) by Rodrigues' formula.
fn rotation_exp(w: &Vector3<f64>) -> Matrix3<f64> {
    let theta = crate::math::sqrt(w.dot(w));
    let k = w.cross_matrix();
    if theta < 1e-8 {
        return Matrix3::identity() + k + k * k * 0.5;
    }
    let (s, c) = crate::math::sin_cos(theta);
    Matrix3::identity() + k * (s / theta) + k * k * ((1.0 - c) / (theta * theta))
}

impl HeadTrajectory for ExtrapolatedHead {
    fn state(&self, t: f64) -> HeadState {
        let tau = t - self.t0;
        let s = &self.state;
        let turn = s.omega * tau + s.alpha * (0.5 * tau * tau);
        HeadState {
            position: s.position + s.velocity * tau + s.acceleration * (0.5 * tau * tau),
            rotation: s.rotation * rotation_exp(&turn),
            velocity: s.velocity + s.acceleration * tau,
            acceleration: s.acceleration,
            omega: s.omega + s.alpha * tau,
            alpha: s.alpha,
        }
    }
    fn uniform_over(&self, _t0: f64, _t1: f64) -> bool {
        let s = &self.state;
        s.omega == Vector3::zeros()
            && s.alpha == Vector3::zeros()
            && s.acceleration == Vector3::zeros()
    }
}

/// What the world does to every strand: gravity and whether the head moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Effects {
    /// Gravity in world coordinates, m/s² (`None`: none).
    pub gravity: Option<Vector3<f64>>,
    /// Whether the head moves (its fictitious forces are built only then).
    pub head_moves: bool,
}

/// Counters of the checks of one or more checked steps.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StepCounts {
    /// Steps split into halves (each split counts once).
    pub substeps: usize,
    /// Linearly implicit (sub)steps solved, accepted or not.
    pub attempts: usize,
    /// Steps split for the energy balance: they created energy or, with the head moving
    /// uniformly, lost too much of it numerically ([`crate::energy::loss_ratio`]).
    pub energy_rejected: usize,
    /// Steps whose excess energy was removed from the velocities.
    pub energy_limited: usize,
    /// Deepest substeps accepted although their potential energy alone exceeded the
    /// bound.
    pub energy_unbalanced: usize,
    /// Deepest substeps whose potential energy exceeded the bound and whose change of q
    /// was pulled back towards the start until it did not ([`crate::energy`]'s balance;
    /// no solve).
    pub energy_pulled_back: usize,
    /// Solves whose field stiffness went into the matrix by the dissipative split
    /// ([`crate::field_split`]), whole or shifted.
    pub field_split: usize,
    /// Solves whose field stiffness was projected by the spectral projection (the split's
    /// fallback, or the rule [`crate::field_split::FieldRule::Projected`]).
    pub field_projected: usize,
    /// Solves of a strand without internal friction or air drag, or touching a collider,
    /// under [`crate::field_split::FieldRule::Split`]: the rule keeps the spectral
    /// projection for it (see [`crate::field_split`]).
    pub field_undamped: usize,
    /// Contacts that started within a step and pushed ([`crate::contact::predicted`]).
    pub contacts_predicted: usize,
    /// Deepest substeps of a strand with contacts whose rotation was scaled to the
    /// trusted limit.
    pub rotation_limited: usize,
    /// Newton iterations (each an evaluation of the terms; `set_newton`).
    pub newton_iterations: usize,
    /// Newton solves replaced by the linearly implicit solve of the same piece (not
    /// converged, or a singular Jacobian).
    pub newton_unconverged: usize,
}

impl StepCounts {
    /// Add another count.
    pub fn add(&mut self, other: &StepCounts) {
        self.substeps += other.substeps;
        self.attempts += other.attempts;
        self.energy_rejected += other.energy_rejected;
        self.energy_limited += other.energy_limited;
        self.energy_unbalanced += other.energy_unbalanced;
        self.energy_pulled_back += other.energy_pulled_back;
        self.field_split += other.field_split;
        self.field_projected += other.field_projected;
        self.field_undamped += other.field_undamped;
        self.contacts_predicted += other.contacts_predicted;
        self.rotation_limited += other.rotation_limited;
        self.newton_iterations += other.newton_iterations;
        self.newton_unconverged += other.newton_unconverged;
    }
}

/// Scale the step from `saved_q` to the strand's state to the trusted rotation: the change
/// of q and the velocities by `TRUSTED_ELEMENT_ROTATION / rotation`.
fn limit_rotation<T: Float>(strand: &mut StrandView<'_, T>, saved_q: &[T], rotation: f64) {
    let lambda = T::of(TRUSTED_ELEMENT_ROTATION / rotation);
    for i in 0..strand.dofs() {
        strand.q[i] = saved_q[i] + lambda * (strand.q[i] - saved_q[i]);
        strand.v[i] *= lambda;
    }
}

/// One (sub)step's time interval and the head's state at its two ends.
#[derive(Debug, Clone, Copy)]
struct Interval {
    t: f64,
    h: f64,
    start: HeadState,
    end: HeadState,
    uniform: bool,
    depth: usize,
    /// Whether the interval ends where the step does (no piece follows it).
    last: bool,
}

impl Interval {
    fn new(head: &dyn HeadTrajectory, t: f64, h: f64) -> Self {
        Interval {
            t,
            h,
            start: head.state(t),
            end: head.state(t + h),
            uniform: head.uniform_over(t, t + h),
            depth: 0,
            last: true,
        }
    }
    fn first_half(&self, head: &dyn HeadTrajectory) -> Self {
        let h = 0.5 * self.h;
        Interval {
            h,
            end: head.state(self.t + h),
            uniform: head.uniform_over(self.t, self.t + h),
            depth: self.depth + 1,
            last: false,
            ..*self
        }
    }
    fn second_half(&self, first: &Interval, head: &dyn HeadTrajectory) -> Self {
        let t = first.t + first.h;
        let h = first.h;
        let end_time = t + h;
        Interval {
            t,
            h,
            start: first.end,
            end: if end_time == self.t + self.h {
                self.end
            } else {
                head.state(end_time)
            },
            uniform: head.uniform_over(t, end_time),
            depth: first.depth,
            last: self.last,
        }
    }
}

/// The energy of the state (q, q̇) at time t with the head in `head` (the runtime's
/// `energy_balance::measure`): with the strand's point loads and its contacts. With `prepare_terms`,
/// `ws` is left prepared for q (a solve from this state follows: it reuses the element
/// moments, see [`crate::strand_terms::evaluate_energy`]).
#[allow(clippy::too_many_arguments)]
pub(crate) fn measure<'c, 'e, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    p: &ParamsView<'_, T>,
    effects: &Effects,
    head: &HeadState,
    t: f64,
    q: &[T],
    v: &[T],
    ws: &mut WorkView<'_, T, NC>,
    prepare_terms: bool,
    contacts: Option<&mut (dyn ContactHooks<T> + 'c)>,
    end: Option<&(dyn EndHooks<T> + 'e)>,
) -> StateEnergy<T> {
    let n = crate::storage::sized::<NC>(p.dofs());
    let rho_s = p.mass_per_length;
    let full = body_field(effects.gravity, effects.head_moves, head, rho_s, p.air_drag);
    // ½ q̇ᵀ M q̇, ∫ρS y ds and the power of C1 (a rotating head) in O(N), from the
    // moments of M alone
    let shape = p.shape();
    let measured = source.energy(
        &shape,
        &mut ws.assembly,
        q,
        v,
        full.has_linear().then_some(&full.linear),
        prepare_terms,
    );
    let half = T::of(0.5);
    let kinetic = measured.kinetic;
    let elastic: T = (0..n)
        .map(|i| {
            let x = q[i] - p.natural[i];
            half * p.stiffness[i] * (x * x)
        })
        .sum();
    let mut power = measured.power;
    let moment = measured.first_moment / rho_s;
    let dissipation = (0..n).map(|i| p.friction[i] * v[i] * v[i]).sum::<T>()
        + T::of(2.0) * p.air_drag / rho_s * kinetic;
    let length = p.length();
    // the contact potential joins V (as the runtime's point loads' part), its rate at
    // fixed q (with the work of moving colliders' damping) the loads' rate
    let (mut load_moment, mut load_rate) = (T::zero(), T::zero());
    if !p.loads.is_empty() {
        // the dead loads' −V and its rate through the head's turning; the follower
        // loads' power joins the work
        let loads = point_load::energy(p.loads, source, &shape, head, q, v, &mut ws.points);
        load_moment += loads.moment;
        load_rate += loads.rate;
        power += loads.power;
    }
    if let Some(end) = end {
        // a driven holder works through its reaction
        power += T::of(end.power(t));
    }
    if let Some(c) = contacts {
        let mut points = PointsOf {
            source: &mut *source,
            shape,
            scratch: &mut ws.points,
        };
        let (potential, rate) = c.energy(&mut points, q, v, t, head);
        load_moment -= T::of(potential);
        load_rate += T::of(rate);
        *c.last_contact() = (potential, rate);
    }
    let potential = -full.uniform.dot(&moment) - load_moment;
    StateEnergy {
        time: t,
        kinetic,
        elastic,
        potential,
        moment,
        uniform: full.uniform,
        power,
        load_moment,
        load_rate,
        dissipation,
        ceiling: kinetic + elastic + potential,
        scale: kinetic + elastic + full.uniform.norm() * length * length,
    }
}

/// The energy of the strand's state at time `t` with the head in `head`, as the checked
/// step measures it for its energy balance (kinetic, elastic and potential energy, the
/// energy scale, the head's power, the dissipation rate): what an engine can watch, and
/// what the tests compare between float types.
pub fn energy<
    S: MomentSource<T>,
    const N: usize,
    const D: usize,
    const E: usize,
    const B: usize,
    T: Float,
>(
    source: &S,
    strand: &FixedStrand<N, D, B, T>,
    effects: &Effects,
    head: &HeadState,
    t: f64,
    ws: &mut FixedWorkspace<N, D, E, T>,
) -> StateEnergy<T> {
    let p = strand.params.view();
    energy_views(
        &mut &*source,
        &p,
        (&strand.q, &strand.v),
        effects,
        head,
        t,
        ws.view(),
    )
}

/// [`energy`] on views of any storage: the state (q, q̇) of a strand of parameters
/// `params`, measured on the workspace `ws`.
pub fn energy_views<S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    params: &ParamsView<'_, T>,
    (q, v): (&[T], &[T]),
    effects: &Effects,
    head: &HeadState,
    t: f64,
    mut ws: WorkView<'_, T, NC>,
) -> StateEnergy<T> {
    ws.forget();
    let e = measure(
        source, params, effects, head, t, q, v, &mut ws, false, None, None,
    );
    ws.forget();
    e
}

/// `energy` (measured at this (q, q̇), head state and time) with its contact part
/// measured again: what changes between two pieces of a step without the strand moving
/// when the contacts have a history (anchors slid, allowances shrank). The runtime's
/// `energy_balance::remeasure_contacts`.
pub(super) fn remeasure_contacts<T: Float>(
    c: &mut dyn ContactHooks<T>,
    points: &mut dyn StrandPoints<T>,
    head: &HeadState,
    q: &[T],
    v: &[T],
    energy: &StateEnergy<T>,
) -> StateEnergy<T> {
    let mut e = *energy;
    let (potential, rate) = c.energy(points, q, v, energy.time, head);
    let (old_potential, old_rate) = *c.last_contact();
    e.load_moment += T::of(old_potential - potential);
    e.potential += T::of(potential - old_potential);
    e.load_rate += T::of(rate - old_rate);
    // the contact potential's new reference shifts the bound the steps carry with it
    e.ceiling = energy.ceiling + T::of(potential - old_potential);
    *c.last_contact() = (potential, rate);
    e
}

/// Advance `strand` from time `t` by `h` seconds with the head moving as `head`: the
/// linearly implicit Euler step ([`super::linearly_implicit`]) checked after the fact and split
/// when it is not acceptable (see the module page), exactly the runtime's
/// `linearly-implicit-euler` step for a strand without point loads. A step that holds a
/// change of the head's motion phase is taken as two, cut there ([`phase_cut`]). The
/// strand keeps the energy of its end state for its next step. Allocates nothing; on
/// failure the strand keeps the state of its last accepted substep and the error says
/// why.
#[allow(clippy::too_many_arguments)]
pub fn step<
    S: MomentSource<T>,
    const N: usize,
    const D: usize,
    const E: usize,
    const B: usize,
    T: Float,
>(
    source: &S,
    strand: &mut FixedStrand<N, D, B, T>,
    head: &dyn HeadTrajectory,
    effects: &Effects,
    t: f64,
    h: f64,
    ws: &mut FixedWorkspace<N, D, E, T>,
    counts: &mut StepCounts,
) -> Result<StepReport, StepError> {
    step_with_contacts(source, strand, head, effects, t, h, ws, counts, None)
}

/// [`step`] with contacts: their terms in every solve, their energy in the balance, a
/// (sub)step whose samples go deeper than the split depth split (at most as deep as any
/// step), the bookkeeping (anchors, allowances) between the pieces of a split step and
/// at the step's end; the first step starts them ([`ContactHooks::start`]). The
/// runtime's step for a strand with body contacts, except the contacts predicted to
/// start within a step (here caught by the depth check alone).
#[allow(clippy::too_many_arguments)]
pub fn step_with_contacts<
    'c,
    S: MomentSource<T>,
    const N: usize,
    const D: usize,
    const E: usize,
    const B: usize,
    T: Float,
>(
    source: &S,
    strand: &mut FixedStrand<N, D, B, T>,
    head: &dyn HeadTrajectory,
    effects: &Effects,
    t: f64,
    h: f64,
    ws: &mut FixedWorkspace<N, D, E, T>,
    counts: &mut StepCounts,
    contacts: Option<&mut (dyn ContactHooks<T> + 'c)>,
) -> Result<StepReport, StepError> {
    let mut source = source;
    step_views(
        &mut source,
        &mut strand.view(),
        head,
        effects,
        t,
        h,
        ws.view(),
        counts,
        contacts,
    )
}

/// [`step_with_contacts`] on views of any storage: a strand's and a workspace's of the
/// same n (a caller that keeps its strands' state in its own memory and lends it, as the
/// runtime engine does; `storage::heap::step` for a strand in vectors).
#[allow(clippy::too_many_arguments)]
pub fn step_views<'c, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    strand: &mut StrandView<'_, T>,
    head: &dyn HeadTrajectory,
    effects: &Effects,
    t: f64,
    h: f64,
    mut ws: WorkView<'_, T, NC>,
    counts: &mut StepCounts,
    contacts: Option<&mut (dyn ContactHooks<T> + 'c)>,
) -> Result<StepReport, StepError> {
    if !views_fit(strand, &ws) {
        return Err(StepError::Sizes);
    }
    let stack = ws.take_stack();
    checked_step(
        source, strand, head, effects, t, h, &mut ws, stack, counts, contacts,
    )
}

/// Whether a strand's view (its state, parameters, kept basis and any history it lends)
/// and a workspace's are of one size n, as the steps on views need them.
pub(crate) fn views_fit<T: Float, const NC: usize>(
    strand: &StrandView<'_, T>,
    ws: &WorkView<'_, T, NC>,
) -> bool {
    let n = crate::storage::sized::<NC>(strand.dofs());
    ws.force.len() == n
        && ws.matrix_a.n() == n
        && ws.stack.len() >= crate::storage::STACK_VECTORS * n
        && 2 * (n / 3 + 1) <= ws.ends.len()
        && strand.q.len() == n
        && strand.v.len() == n
        && strand.params.natural.len() == n
        && strand.params.stiffness.len() == n
        && strand.params.friction.len() == n
        && (3 * strand.params.lengths.len() == n || strand.params.free_root())
        && strand.basis.len() >= n * (n / 2)
        && strand
            .history
            .as_ref()
            .is_none_or(|p| p.q.len() == n && p.v.len() == n)
}

/// [`step_with_contacts`] on any storage (`stack`: [`crate::storage::STACK_VECTORS`]
/// vectors of n).
#[allow(clippy::too_many_arguments)]
pub(crate) fn checked_step<'c, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    strand: &mut StrandView<'_, T>,
    head: &dyn HeadTrajectory,
    effects: &Effects,
    t: f64,
    h: f64,
    ws: &mut WorkView<'_, T, NC>,
    stack: &mut [T],
    counts: &mut StepCounts,
    mut contacts: Option<&mut (dyn ContactHooks<T> + 'c)>,
) -> Result<StepReport, StepError> {
    if !(h.is_finite() && h > 0.0 && t.is_finite()) {
        return Err(StepError::TimeStep);
    }
    if strand.end.is_some() && strand.history.is_some() {
        // a held tip is kept by linearly implicit Euler steps, not BDF2's
        return Err(StepError::Held(HeldError::Unsupported));
    }
    if let Some(c) = contacts.as_deref_mut() {
        if !c.started() {
            c.start(strand.q, t, &head.state(t));
        }
    }
    let (q0, stack) = stack.split_at_mut(strand.dofs());
    q0.copy_from_slice(strand.q);
    let end = t + h;
    let mut now = t;
    loop {
        let cut = phase_cut(head, now, end);
        // the caller's step as it is when no phase change cuts it: end − t differs from
        // it in the last bits, more so the later t is, and a step would otherwise depend
        // on the clock's origin (a run continued from a state set at t > 0 would not be
        // the same run begun from it)
        let piece = match cut {
            Some(b) => b - now,
            None if now == t => h,
            None => end - now,
        };
        step_piece(
            source,
            strand,
            head,
            effects,
            now,
            piece,
            ws,
            stack,
            counts,
            contacts.as_deref_mut(),
        )?;
        if let Some(e) = non_finite(strand.q, strand.v) {
            return Err(e);
        }
        match cut {
            Some(b) => now = b,
            None => break,
        }
    }
    if let Some(c) = contacts {
        // the step's end: anchors stick, slide or let go; allowances shrink
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

/// One checked step from `t` by `h` within which the head keeps its motion phase.
#[allow(clippy::too_many_arguments)]
fn step_piece<'c, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    strand: &mut StrandView<'_, T>,
    head: &dyn HeadTrajectory,
    effects: &Effects,
    t: f64,
    h: f64,
    ws: &mut WorkView<'_, T, NC>,
    stack: &mut [T],
    counts: &mut StepCounts,
    mut contacts: Option<&mut (dyn ContactHooks<T> + 'c)>,
) -> Result<(), StepError> {
    ws.forget();
    let interval = Interval::new(head, t, h);
    // contacts with a history (anchors, allowances) are measured afresh; a strand with
    // contacts tries its whole step first
    let history = contacts.as_deref().is_some_and(|c| c.has_history());
    let continued = strand
        .last_energy
        .is_some_and(|e| (e.time - t).abs() <= 1e-12 * t.abs().max(1.0));
    // the step starts as finely as its last step ended; a strand with contacts, and
    // BDF2, try their whole step first
    let hint = if contacts.is_some() || strand.history.is_some() || ws.newton {
        0
    } else {
        usize::from(*strand.split_hint).min(ws.max_split_depth)
    };
    let (start, levels) = match *strand.last_energy {
        // without the energy balance no energy is measured: the start's stands empty
        _ if !ws.energy_balance => {
            let start = StateEnergy {
                time: t,
                ..StateEnergy::default()
            };
            (start, if continued { hint } else { 0 })
        }
        Some(e) if !history && continued => (e, hint),
        // the partners moved since: the contact part measured again (equal to a fresh
        // measure to round-off, at a fraction of its cost); a history of anchors or
        // allowances alone is measured afresh
        Some(e) if continued && contacts.as_deref().is_some_and(|c| c.has_partners()) => {
            match contacts.as_deref_mut() {
                Some(c) => (
                    remeasure_contacts(
                        c,
                        &mut PointsOf {
                            source: &mut *source,
                            shape: strand.params.shape(),
                            scratch: &mut ws.points,
                        },
                        &interval.start,
                        strand.q,
                        strand.v,
                        &e,
                    ),
                    hint,
                ),
                None => (e, hint),
            }
        }
        _ => {
            // the step's first solve starts from this state
            let e = measure(
                source,
                &strand.params,
                effects,
                &interval.start,
                t,
                strand.q,
                strand.v,
                ws,
                true,
                contacts.as_deref_mut(),
                strand.end.as_deref(),
            );
            (e, 0)
        }
    };
    *ws.rotation_estimate = 0.0;
    *ws.loss_estimate = 0.0;
    let end = split(
        source, strand, head, effects, &interval, &start, ws, stack, counts, levels, contacts,
    )?;
    *strand.last_energy = Some(end);
    *strand.split_hint = predicted_split_levels(*ws.rotation_estimate, *ws.loss_estimate) as u8;
    Ok(())
}

/// The runtime's `implicit_adaptive` for the linearly implicit Euler step (`stack`: two
/// vectors of n for its start, the rest for its pieces).
#[allow(clippy::too_many_arguments)]
fn adaptive<'c, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    strand: &mut StrandView<'_, T>,
    head: &dyn HeadTrajectory,
    effects: &Effects,
    interval: &Interval,
    start: &StateEnergy<T>,
    ws: &mut WorkView<'_, T, NC>,
    stack: &mut [T],
    counts: &mut StepCounts,
    mut contacts: Option<&mut (dyn ContactHooks<T> + 'c)>,
) -> Result<StateEnergy<T>, StepError> {
    let h = interval.h;
    let n = crate::storage::sized::<NC>(strand.dofs());
    let (saved, stack) = stack.split_at_mut(2 * n);
    let (saved_q, saved_v) = saved.split_at_mut(n);
    saved_q.copy_from_slice(strand.q);
    saved_v.copy_from_slice(strand.v);
    let max_depth = ws.max_split_depth;
    let deepest = interval.depth >= max_depth;
    let input = StepInput {
        head: interval.end,
        gravity: effects.gravity,
        head_moves: effects.head_moves,
    };
    let t_end = interval.t + h;
    if let Some(c) = contacts.as_deref_mut() {
        // no contacts predicted for this solve yet
        c.forget();
    }
    // BDF2 takes whole steps, not longer than BDF2_MAX_RATIO times the last accepted
    // piece; a step split for rotating too much is taken as linearly implicit Euler pieces
    let outcome = match strand.history.take() {
        Some(p) if interval.depth == 0 && *p.h > 0.0 && h <= BDF2_MAX_RATIO * *p.h => {
            let previous = Bdf2History {
                q: p.q,
                v: p.v,
                h: *p.h,
            };
            let outcome = bdf2_step(
                source,
                strand,
                &previous,
                &input,
                h,
                ws,
                stack,
                contacts.as_deref_mut().map(|c| (c, t_end)),
            );
            strand.history = Some(p);
            outcome
        }
        history => {
            strand.history = history;
            // Newton's solve where the workspace asks for it; never an unconverged one:
            // the linearly implicit solve of the same piece instead, under the same checks
            let newton = if ws.newton && strand.history.is_none() {
                let outcome = newton_step(
                    source,
                    strand,
                    &input,
                    (h, t_end),
                    ws,
                    stack,
                    contacts.as_deref_mut(),
                    &mut counts.newton_iterations,
                );
                match outcome {
                    NewtonOutcome::Converged(report) => Some(report),
                    NewtonOutcome::Unconverged => {
                        counts.newton_unconverged += 1;
                        None
                    }
                }
            } else {
                None
            };
            match newton {
                Some(report) => Ok(report),
                None => solve_step(
                    source,
                    strand,
                    &input,
                    (h, t_end),
                    ws,
                    stack,
                    contacts.as_deref_mut().map(|c| (c, t_end)),
                ),
            }
        }
    };
    counts.attempts += 1;
    if let Ok(report) = &outcome {
        counts.contacts_predicted += report.contacts_predicted;
        match field_counter(report, *ws.field_rule, strand.params.dissipative()) {
            Some(FieldCounter::Split) => counts.field_split += 1,
            Some(FieldCounter::Projected) => counts.field_projected += 1,
            Some(FieldCounter::Undamped) => counts.field_undamped += 1,
            None => {}
        }
    }
    let finite = outcome.is_ok();
    let mut rotation = if finite {
        max_element_rotation(strand.params.lengths, strand.q, saved_q).as_f64()
    } else {
        f64::INFINITY
    };
    // a strand with contacts, and BDF2 (its pieces included), keep the tighter limit
    // (their numerical loss is not checked)
    let rotation_limit = if contacts.is_some() || strand.history.is_some() {
        TRUSTED_ELEMENT_ROTATION
    } else {
        MAX_ELEMENT_ROTATION
    };
    // at the deepest split the contacts' depth check could not split the step: skipped
    let acceptable = finite
        && rotation <= rotation_limit
        && (deepest
            || contacts.as_deref_mut().is_none_or(|c| {
                c.acceptable(
                    saved_q,
                    strand.q,
                    interval.t,
                    &interval.start,
                    t_end,
                    &interval.end,
                )
            }));
    let mut energy_levels = 0;
    if acceptable || deepest {
        outcome?;
        if !finite {
            return Err(StepError::SingularMatrix);
        }
        let unresolved = deepest
            && rotation > rotation_limit
            && contacts.is_none()
            && max_depth >= MAX_SUBSTEP_DEPTH;
        if unresolved {
            // the shortest piece the step splits into still turns an element beyond any
            // limit a step may take, with nothing pushing the strand out of a body: a
            // holder pulled out of reach is named
            if let Some(e) = strand
                .end
                .as_deref()
                .and_then(|e| e.beyond_reach(strand.q, t_end))
            {
                return Err(StepError::Held(e));
            }
        }
        if unresolved && (!strand.params.loads.is_empty() || strand.params.free_root()) {
            // a free rod, or one under point loads: the loads (or the head) accelerate
            // the strand faster than the steps resolve. Limiting the rotation would take
            // momentum away silently (the strand would no longer follow F = ma): the
            // step fails, naming the cause
            return Err(StepError::UnresolvedMotion {
                rotation,
                h,
                t: interval.t,
            });
        }
        if deepest && rotation > rotation_limit {
            // the deepest split allowed still rotates an element beyond what an unchecked
            // step may: the change of q and the velocities are scaled to that limit (a
            // strand rooted on the head: what the limit takes is energy, which the
            // balance allows)
            limit_rotation(strand, saved_q, rotation);
            counts.rotation_limited += 1;
            // the scaled end is checked for the contacts that start within the step again
            // (its shape is not on the line from the start to the solve's end: q → y(q)
            // is not linear); what that adds is limited too
            if let Some(c) = contacts.as_deref_mut() {
                let (a, pivots) = (&ws.matrix_a, &*ws.pivots);
                let scratch = &mut *stack;
                let mut solve =
                    |x: &mut [f64]| solve_factored_f64(a, pivots, strand.params.scale, x, scratch);
                let mut points = PointsOf {
                    source: &mut *source,
                    shape: strand.params.shape(),
                    scratch: &mut ws.points,
                };
                c.resolve(
                    &mut points,
                    strand.q,
                    strand.v,
                    None,
                    t_end,
                    &interval.end,
                    &mut solve,
                )
                .map_err(|_| StepError::SingularMatrix)?;
                let again = max_element_rotation(strand.params.lengths, strand.q, saved_q).as_f64();
                if again > TRUSTED_ELEMENT_ROTATION {
                    limit_rotation(strand, saved_q, again);
                }
            }
            rotation = TRUSTED_ELEMENT_ROTATION;
        }
        *ws.rotation_estimate = ws
            .rotation_estimate
            .max(rotation * (1u64 << interval.depth) as f64);
        if !ws.energy_balance {
            record_history(strand, saved_q, saved_v, h);
            // nothing measured: the end stands as empty as the start
            return Ok(StateEnergy {
                time: t_end,
                ..StateEnergy::default()
            });
        }
        let mut end = measure(
            source,
            &strand.params,
            effects,
            &interval.end,
            interval.t + h,
            strand.q,
            strand.v,
            ws,
            // a later piece of the step starts from this state
            !interval.last,
            contacts.as_deref_mut(),
            strand.end.as_deref(),
        );
        // contacts with what moves relative to the head do work: the step is then
        // balanced against work
        let bodies_work = contacts
            .as_deref()
            .is_some_and(|c| c.moves_relative(interval.t, t_end, &interval.start, &interval.end));
        // follower loads work without a potential, and a driven holder works
        let inertial = interval.uniform
            && !bodies_work
            && !any_follows(strand.params.loads)
            && !strand.end.as_deref().is_some_and(|e| e.driven());
        let balance = balance(start, &end, inertial);
        let excess = balance.excess;
        // beyond the trusted rotation the energy asks for pieces too; the loss of the
        // pieces predicts the next step
        let splits = energy_splits(&balance, start, &end, rotation, interval.depth, deepest);
        *ws.loss_estimate = ws
            .loss_estimate
            .max(splits.loss * (1u64 << (2 * interval.depth)) as f64);
        energy_levels = splits
            .levels()
            .min(max_depth.saturating_sub(interval.depth));
        if energy_levels == 0 && excess <= T::zero() {
            end.ceiling = end_ceiling(start, &end, inertial);
            record_history(strand, saved_q, saved_v, h);
            return Ok(end);
        }
        let fraction = if inertial {
            ENERGY_SPLIT_FRACTION
        } else {
            WORK_SPLIT_FRACTION
        };
        let split = energy_levels > 0 || (!deepest && excess > T::of(fraction) * start.scale);
        let mut balance = balance;
        if !split && deepest && balance.limited_kinetic(&end, !bodies_work).is_none() {
            // the potential energy alone is above what the step may end with, and the step
            // cannot be split further: its change of q is pulled back towards the start
            // (the runtime's `pull_back`)
            if let Some((e, b)) = pull_back(
                source,
                strand,
                effects,
                interval,
                start,
                saved_q,
                ws,
                stack,
                (contacts.as_deref_mut(), !bodies_work),
            ) {
                (end, balance) = (e, b);
                counts.energy_pulled_back += 1;
            }
        }
        if !split {
            // the kinetic energy that brings E down to the bound
            if let Some(kinetic) = balance.limited_kinetic(&end, !bodies_work) {
                let lambda = if strand.params.free_root() && strand.end.is_none() {
                    // a free strand keeps its momentum: its motion about the centre of
                    // mass is scaled
                    free_root::scale_to_kinetic(
                        source,
                        &strand.params,
                        strand.q,
                        strand.v,
                        (end.kinetic, kinetic),
                        ws,
                    )
                } else {
                    let lambda = (kinetic / end.kinetic).sqrt();
                    for x in strand.v.iter_mut() {
                        *x *= lambda;
                    }
                    lambda
                };
                end.scale_velocities(lambda);
                counts.energy_limited += 1;
                end.ceiling = end_ceiling(start, &end, inertial);
                record_history(strand, saved_q, saved_v, h);
                return Ok(end);
            }
            if deepest {
                counts.energy_unbalanced += 1;
                end.ceiling = end_ceiling(start, &end, inertial);
                record_history(strand, saved_q, saved_v, h);
                return Ok(end);
            }
        }
        counts.energy_rejected += 1;
    }
    strand.q.copy_from_slice(saved_q);
    strand.v.copy_from_slice(saved_v);
    // with contacts, level by level (a contact starts or ends within the step: the
    // quiet pieces pass coarse)
    let levels =
        if !acceptable && contacts.is_none() && rotation.is_finite() && rotation > rotation_limit {
            rotation_split_levels(rotation, rotation_limit, interval.depth)
                .min(max_depth - interval.depth)
        } else {
            energy_levels.max(1)
        };
    if *ws.field_rule == FieldRule::Explicit {
        // with the field stiffness explicit, a step that must be split is one the
        // explicit stiffness may not resolve at any substep (energy created by the
        // contact forces' curvature on the twist; a strand thrown into a body): its
        // pieces take the projected stiffness
        *ws.field_rule = FieldRule::Projected;
        let end = split(
            source, strand, head, effects, interval, start, ws, stack, counts, levels, contacts,
        );
        *ws.field_rule = FieldRule::Explicit;
        return end;
    }
    split(
        source, strand, head, effects, interval, start, ws, stack, counts, levels, contacts,
    )
}

/// How a solve's field stiffness went into its matrix, as the counters of
/// [`StepCounts`] and [`super::ToleranceReport`] take it.
pub(crate) enum FieldCounter {
    /// By the dissipative split.
    Split,
    /// By the spectral projection.
    Projected,
    /// By the projection the split's rule keeps (a strand that does not dissipate,
    /// touches or carries point loads).
    Undamped,
}

/// The counter a solve of `report` adds to under `rule` (`dissipative`: the strand has
/// internal friction or drag); `None` for a solve without field stiffness or with it
/// unprojected.
pub(crate) fn field_counter(
    report: &StepReport,
    rule: FieldRule,
    dissipative: bool,
) -> Option<FieldCounter> {
    match report.projection {
        Some(Projection::Whole | Projection::Shifted) => Some(FieldCounter::Split),
        Some(Projection::Unprojected) | None => None,
        // the split's rule keeps the projection for a strand that does not dissipate
        // and for one that touches or is loaded
        Some(_) if rule == FieldRule::Split && (!dissipative || report.loaded) => {
            Some(FieldCounter::Undamped)
        }
        Some(_) => Some(FieldCounter::Projected),
    }
}

/// After an accepted piece of `h` seconds from (`saved_q`, `saved_v`): that start state
/// is BDF2's history (when the strand lends one).
fn record_history<T: Float>(strand: &mut StrandView<'_, T>, saved_q: &[T], saved_v: &[T], h: f64) {
    if let Some(p) = strand.history.as_mut() {
        p.q.copy_from_slice(saved_q);
        p.v.copy_from_slice(saved_v);
        *p.h = h;
    }
}

/// Steps of the bisection of [`pull_back`].
const PULL_BACK_BISECTIONS: usize = 10;

/// At the deepest split, a step whose end has more potential energy than its bound
/// allows: the largest fraction λ of its change of q from `q0` whose end the velocities
/// can bring down to the bound (bisection), with its energy and balance, the strand set
/// to it; `None` (the strand as it was) when not even `q0` balances. The runtime's
/// `solver::adaptive::pull_back`. `stack`: one vector of n.
#[allow(clippy::too_many_arguments)]
fn pull_back<'c, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    strand: &mut StrandView<'_, T>,
    effects: &Effects,
    interval: &Interval,
    start: &StateEnergy<T>,
    q0: &[T],
    ws: &mut WorkView<'_, T, NC>,
    stack: &mut [T],
    (mut contacts, to_bound): (Option<&mut (dyn ContactHooks<T> + 'c)>, bool),
) -> Option<(StateEnergy<T>, Balance<T>)> {
    let n = crate::storage::sized::<NC>(strand.dofs());
    let end_q = &mut stack[..n];
    end_q.copy_from_slice(strand.q);
    let end_q = &*end_q;
    let time = interval.t + interval.h;
    let mut eval = |strand: &mut StrandView<'_, T>,
                    ws: &mut WorkView<'_, T, NC>,
                    lambda: f64,
                    prepare: bool| {
        for i in 0..n {
            strand.q[i] = q0[i] + T::of(lambda) * (end_q[i] - q0[i]);
        }
        let end = measure(
            source,
            &strand.params,
            effects,
            &interval.end,
            time,
            strand.q,
            strand.v,
            ws,
            prepare,
            contacts.as_deref_mut(),
            strand.end.as_deref(),
        );
        let b = balance(start, &end, interval.uniform && to_bound);
        (b.limited_kinetic(&end, to_bound).is_some(), end, b)
    };
    if !eval(strand, ws, 0.0, false).0 {
        strand.q.copy_from_slice(end_q);
        return None;
    }
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..PULL_BACK_BISECTIONS {
        let mid = 0.5 * (lo + hi);
        if eval(strand, ws, mid, false).0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    // a later piece of the step starts from this state
    let (_, end, b) = eval(strand, ws, lo, !interval.last);
    Some((end, b))
}

/// `interval` halved `levels` times (each halving counted in [`StepCounts::substeps`]),
/// its pieces stepped in order by [`adaptive`]: the runtime's `split`.
#[allow(clippy::too_many_arguments)]
fn split<'c, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    strand: &mut StrandView<'_, T>,
    head: &dyn HeadTrajectory,
    effects: &Effects,
    interval: &Interval,
    start: &StateEnergy<T>,
    ws: &mut WorkView<'_, T, NC>,
    stack: &mut [T],
    counts: &mut StepCounts,
    levels: usize,
    mut contacts: Option<&mut (dyn ContactHooks<T> + 'c)>,
) -> Result<StateEnergy<T>, StepError> {
    if levels == 0 {
        return adaptive(
            source, strand, head, effects, interval, start, ws, stack, counts, contacts,
        );
    }
    counts.substeps += 1;
    let first = interval.first_half(head);
    let mut middle = split(
        source,
        strand,
        head,
        effects,
        &first,
        start,
        ws,
        stack,
        counts,
        levels - 1,
        contacts.as_deref_mut(),
    )?;
    if let Some(c) = contacts.as_deref_mut() {
        // between two accepted pieces, the contacts' bookkeeping of the first's end (the
        // runtime's `between_steps`), its energy measured again where the anchors moved
        let t = first.t + first.h;
        c.after_step(strand.q, t, &first.end, first.h);
        if ws.energy_balance && c.has_history() {
            let mut points = PointsOf {
                source: &mut *source,
                shape: strand.params.shape(),
                scratch: &mut ws.points,
            };
            middle = remeasure_contacts(c, &mut points, &first.end, strand.q, strand.v, &middle);
        }
    }
    let second = interval.second_half(&first, head);
    split(
        source,
        strand,
        head,
        effects,
        &second,
        &middle,
        ws,
        stack,
        counts,
        levels - 1,
        contacts,
    )
}
