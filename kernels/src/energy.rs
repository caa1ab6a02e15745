//! The a-posteriori energy-balance test of implicit steps (issue #4; README "Time
//! stepping" and "Hard cases (stress)").
//!
//! Written in the head frame, the strand's energy `E = T + U + V` (T kinetic relative to
//! the head, U elastic, V the potential of the uniform part c0 of the body field and of
//! the point loads f_l, at the head state of the time) changes under the exact dynamics
//! as
//!
//! ```text
//! dE/dt = q̇ᵀ ∫ Jᵀ C1 y ds − ċ0 · ∫ y ds − Σ ḟ_l · y_l − D,
//! D = q̇ᵀ Γ q̇ + ν ∫ |ẏ|² ds ≥ 0
//! ```
//!
//! (the Coriolis force is normal to ẏ and does no work; ḟ_l = −ω × f_l is the rate of a
//! point load in head coordinates, f_l = Rᵀ f_world). The first three terms are the work
//! W the head's motion does on the strand, D what internal friction and air drag
//! dissipate.
//!
//! - When the head moves uniformly over a step (no rotation, constant velocity:
//!   the runtime's `HeadMotion::uniform_over`), C1 = 0 and c0, f_l are constant: W = 0, and
//!   from the start of such a phase E can only decrease, by at least ∫ D. The bound of a
//!   step's end is then its *ceiling*: the energy at the start of the phase less the
//!   dissipation estimated since (trapezoidal rule on D), or the energy at the start of
//!   the step when that is higher. Without friction and drag the ceiling is the energy at
//!   the start of the phase: a step may give back energy that earlier steps dissipated
//!   numerically, never more; the step-to-step bound alone would ratchet the energy down
//!   (an implicit Euler step in a fast, large motion errs by O(h²) in E with either
//!   sign, and only the positive errors would be removed).
//! - Otherwise the bound is E(start) + W, W by the trapezoidal rule over the step, with an
//!   allowance for the error of that estimate ([`WORK_ALLOWANCE`]).

use crate::float::Float;
use nalgebra::Vector3;

/// The energy of one state (q, q̇) at one time, with what the balance of a step needs.
///
/// In the step's float type `T`, but for the time (`f64`, as the head trajectory's).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StateEnergy<T: Float = f64> {
    /// Time of the state, s.
    pub time: f64,
    /// T = ½ q̇ᵀ M(q) q̇, J.
    pub kinetic: T,
    /// U = ½ Σ K (q − q_n)², J.
    pub elastic: T,
    /// V = −c0 · ∫ y ds − Σ f_l · y_l (head coordinates, at the head state of `time`), J.
    pub potential: T,
    /// ∫ y ds, m².
    pub moment: Vector3<T>,
    /// c0 (N/m) of the head state at `time`.
    pub uniform: Vector3<T>,
    /// Power of the fictitious forces linear in y: q̇ᵀ ∫ Jᵀ C1 y ds, W.
    pub power: T,
    /// Σ f_l · y_l of the point loads, J (the part of −V they make).
    pub load_moment: T,
    /// −Σ ḟ_l · y_l = Σ (ω × f_l) · y_l: the rate of V through the point loads' rotation
    /// at fixed q, W.
    pub load_rate: T,
    /// A bound on the dissipation rate D: q̇ᵀ Γ q̇ + (2ν/ρS) T (ν ∫|ẏ|² with the rotary
    /// part of T counted too), W.
    pub dissipation: T,
    /// The most energy the state may have, unless it is below E (see the module
    /// documentation), J; E itself after a step with a moving head.
    pub ceiling: T,
    /// Scale of the energy that can change hands: T + U + |c0| L², J.
    pub scale: T,
}

impl<T: Float> StateEnergy<T> {
    /// E = T + U + V, J.
    pub fn total(&self) -> T {
        self.kinetic + self.elastic + self.potential
    }

    /// A bound on the round-off of [`StateEnergy::total`]: its parts' magnitudes times
    /// [`ROUNDOFF`] (f64) or [`ROUNDOFF_F32`] (f32), [`Float::ENERGY_ROUNDOFF`].
    pub fn roundoff(&self) -> T {
        T::ENERGY_ROUNDOFF
            * (self.kinetic.abs()
                + self.elastic.abs()
                + self.potential.abs()
                + self.load_moment.abs()
                + self.scale)
    }

    /// Scale the velocities by λ (T by λ², the power and the dissipation with them).
    pub fn scale_velocities(&mut self, lambda: T) {
        let kinetic = lambda * lambda * self.kinetic;
        self.scale += kinetic - self.kinetic;
        self.kinetic = kinetic;
        self.power *= lambda;
        self.dissipation *= lambda * lambda;
    }
}

/// Relative round-off allowed in an energy: E is a sum of O(3N²) products, each good to
/// 1e-16, and is evaluated to ~1e-14 of its parts (`stress`, the energy of a still head two
/// ways); 1e-12 (4504 ε) leaves a margin of 100.
pub const ROUNDOFF: f64 = 1e-12;

/// [`ROUNDOFF`] for the f32 step: 64 f32 epsilons, 7.6e-6. The f32 energy of the f32
/// fixed-N step's states is within 1.4 ε of the f64 energy of the same states (relative
/// to the parts |T| + |U| + |V| + S, over the runs of `runtime/tests/fixed_step_f32.rs`),
/// and 64 ε also covers the 45 ε the f64 energy reaches in the hard cases, in ε, should
/// f32 reach as many. [`ROUNDOFF`] in the ratio of the epsilons (4504 ε = 5.4e-4) would
/// be of the order of the excess the balance acts on ([`ENERGY_SPLIT_FRACTION`]): it
/// let pass, unlimited, steps that created 4e-4 to 1.5e-3 of the energy scale, which the
/// f64 step limited or split (`examples/fixed-n7`, the f32 test).
pub const ROUNDOFF_F32: f32 = 64.0 * f32::EPSILON;

/// The energy balance of one step from `start` to `end`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Balance<T: Float = f64> {
    /// The most energy the end state may have before the allowance, J: with the head
    /// moving uniformly, the larger of E(start) and the start's ceiling less the estimated
    /// dissipation over the step (which is also the end's ceiling); otherwise E(start)
    /// plus the head's work (trapezoidal estimate).
    pub bound: T,
    /// What E(end) may exceed `bound` by: round-off, plus the allowance for the error of
    /// the work estimate when the head does not move uniformly, J.
    pub allowance: T,
    /// The head moved uniformly over the step.
    pub inertial: bool,
    /// E(end) − bound − allowance, J (≤ 0: the step is balanced).
    pub excess: T,
    /// E(end) − bound − round-off, J: what a step that is not balanced gives up when its
    /// velocities are scaled ([`Balance::limited_kinetic`]).
    pub overshoot: T,
}

impl<T: Float> Balance<T> {
    /// The kinetic energy of the end state once a step that is not balanced
    /// (`excess > 0`) is limited: `T(end) − overshoot`, which brings E(end) down to the
    /// bound plus round-off, not to the bound plus the allowance. The allowance covers
    /// the error of the work estimate when deciding whether a step stands as it is; a
    /// step that does not is brought to the best estimate, E(start) + W. Limited to the
    /// edge of the allowance instead, every limited step of a strand whipping on a moving
    /// head gains its whole allowance (of the order of ∫|P| dt, P the head's power), and
    /// since P grows with the strand's speed that feeds itself: `superhelix stress` found
    /// the mean kinetic energy of a smooth N = 20 strand on a head shaking at 5 Hz grow
    /// 2.3-fold from the first second to the second at a rotation limit of 0.4 rad, where
    /// converged references hold it level (0.36 and 0.32 of the case's budget). With the
    /// head moving uniformly the allowance is round-off, and the two agree.
    ///
    /// `to_bound = false` keeps the allowance: for a step in which a body moving relative
    /// to the head does work through contacts, whose estimate (the contact potential's
    /// rate at the step's two ends) misses a body that meets the strand within the step;
    /// the allowance is then the only room for that work, and taking it would hold the
    /// strand in the body's way (a wavy N = 5 strand under a bar on a head shaking at
    /// 5 Hz went 1.8 mm into the bar, against 0.03 mm keeping the allowance).
    ///
    /// When the potential energy alone is above the bound plus round-off, the velocities
    /// can only bring E down to the bound plus the allowance; `None` when not even that
    /// (the step is then split, or counted as unbalanced at the deepest substep).
    pub fn limited_kinetic(&self, end: &StateEnergy<T>, to_bound: bool) -> Option<T> {
        let first = if to_bound { 0 } else { 1 };
        [self.overshoot, self.excess][first..]
            .iter()
            .map(|&removed| end.kinetic - removed)
            .find(|&kinetic| kinetic >= T::zero() && end.kinetic > T::zero())
    }
}

/// Relative allowance for the error of the trapezoidal estimate of the head's work over a
/// step (of the magnitudes of its terms): the estimate is exact for work linear in time
/// and off by O(h³) otherwise, which at the paper's step and a 5 Hz shake (the head turns
/// ~1 rad per step) is a sizeable fraction of it. The test is meant to catch steps that
/// create energy out of all proportion to the head's work (an unstable step multiplies
/// the kinetic energy), not to measure the work.
pub const WORK_ALLOWANCE: f64 = 1.0;

/// The balance of a step; `inertial` when the head moves uniformly over it.
pub fn balance<T: Float>(
    start: &StateEnergy<T>,
    end: &StateEnergy<T>,
    inertial: bool,
) -> Balance<T> {
    let roundoff = start.roundoff() + end.roundoff();
    let h = T::of(end.time - start.time);
    let half = T::of(0.5);
    let (bound, allowance) = if inertial {
        let dissipated = half * h * (start.dissipation + end.dissipation);
        ((start.ceiling - dissipated).max(start.total()), roundoff)
    } else {
        let powers = [
            half * h * start.power,
            half * h * end.power,
            half * h * start.load_rate,
            half * h * end.load_rate,
            // −ċ0 · ∫y ds by the trapezoidal rule: −Δc0 · (mean ∫y ds)
            -(end.uniform - start.uniform).dot(&((start.moment + end.moment) * half)),
        ];
        let work: T = powers.iter().copied().sum();
        let magnitude: T = powers.iter().map(|p| p.abs()).sum();
        (
            start.total() + work,
            roundoff + T::of(WORK_ALLOWANCE) * magnitude,
        )
    };
    Balance {
        bound,
        allowance,
        inertial,
        excess: end.total() - bound - allowance,
        overshoot: end.total() - bound - roundoff,
    }
}

/// The ceiling of a step's end state, once accepted (its velocities limited if needed):
/// with the head moving uniformly, the start's ceiling less the estimated dissipation over
/// the step (not raised to the end's energy when that is higher, within round-off or by
/// the fallback to E(start): the next step's bound takes the larger of the two anyway, and
/// a ceiling raised by round-off step after step would creep); its energy otherwise.
pub fn end_ceiling<T: Float>(start: &StateEnergy<T>, end: &StateEnergy<T>, inertial: bool) -> T {
    if inertial {
        let h = T::of(end.time - start.time);
        start.ceiling - T::of(0.5) * h * (start.dissipation + end.dissipation)
    } else {
        end.total()
    }
}

/// Largest rotation an implicit step may put into one element, radians: the change of
/// `l_Q |d_Q|` over the step. Beyond it the step's linearisation of M(q), b and the
/// forces no longer holds and energy can be created, so the step is split.
///
/// Chosen by measurement (docs/time-stepping.md, "Step splitting"): at 0.8 rad a
/// 2000-strand head shaking at 5 Hz takes 1.33 solves per strand-step where 0.2 rad took
/// 5.30, and `superhelix stress` finds no energy created. The accuracy a tighter limit
/// bought on fast inertial motion (a swinging strand) is kept by the numerical-loss split
/// ([`LOSS_SPLIT_FRACTION`]), which splits only the steps that lose it.
pub const MAX_ELEMENT_ROTATION: f64 = 0.8;

/// Largest rotation of a step whose numerical loss is not checked, radians: a BDF2 step
/// (second order, not split by its loss: at [`MAX_ELEMENT_ROTATION`] the twist seeded at
/// 1e-6 rad/m in a round fibre released horizontal at 1/30 s grew to 3.5e-2 rad/m, where
/// within this limit it stays at 1e-6); a step of a strand with contacts (the runtime's:
/// their friction dissipates beyond the bound, so its loss is not measured; at
/// [`MAX_ELEMENT_ROTATION`] strands on a shaking head went up to 2.8 mm into the bodies
/// of `superhelix stress`); and a piece of such a step at the deepest split allowed, which
/// is limited to it instead of split (the runtime's step budget: at one solve per
/// strand-step the limit is what holds a head's 200 guides within 1 mm of its bodies; a
/// runtime strand without contacts whose deepest piece still turns beyond
/// [`MAX_ELEMENT_ROTATION`] stops the run instead).
pub const TRUSTED_ELEMENT_ROTATION: f64 = 0.2;
/// How many times a step may be halved (down to h / 2^depth).
pub const MAX_SUBSTEP_DEPTH: usize = 8;

/// How many halvings a step that rotated an element by `rotation` (> `limit`, the
/// integrator's: [`MAX_ELEMENT_ROTATION`] or [`TRUSTED_ELEMENT_ROTATION`]) takes at once,
/// at `depth`: the smallest j with `rotation / 2^j ≤ limit` (the rotation of a step is
/// about proportional to its length), at least 1, at most down to [`MAX_SUBSTEP_DEPTH`].
/// The 2^j pieces are the intervals that halving j times gives, each checked as any step:
/// halving level by level would solve every level in between, only to reject it.
pub fn rotation_split_levels(rotation: f64, limit: f64, depth: usize) -> usize {
    if rotation.is_nan() {
        return 1;
    }
    let room = MAX_SUBSTEP_DEPTH.saturating_sub(depth).max(1);
    let mut levels = 1;
    let mut r = 0.5 * rotation;
    while r > limit && levels < room {
        r *= 0.5;
        levels += 1;
    }
    levels
}
/// With the head moving uniformly (inertial head frame), a step that creates more energy
/// than this fraction of the energy scale S = T + U + |c0| L² (beyond round-off) is split
/// in two; a smaller excess is removed from the velocities instead (see
/// the adaptive step). A step of a first-order scheme that resolves the motion errs by
/// O(h²) in E; one that creates 0.1 % of S at once does not resolve it (the straight
/// strands after a stop created 1.6e-4 to 1.1 S per step, the kinked ones far more), and
/// its halves are more accurate. Below it, halving again mostly costs: a strand whose
/// fastest motion is far beyond any substep (the 3 rad kinks) errs in E at every depth.
pub const ENERGY_SPLIT_FRACTION: f64 = 1e-3;
/// The same as [`ENERGY_SPLIT_FRACTION`] for a head that rotates or accelerates, where
/// the head's work over the step is a trapezoidal estimate: ordinary steps of the demo
/// scene (2 Hz, ±30° at 1/30 s) exceed estimate plus allowance by up to 1e-2 S, so a
/// lower threshold only splits steps that are fine; the instabilities it is for create
/// more than S per step.
pub const WORK_SPLIT_FRACTION: f64 = 1e-2;

/// How many times the next step of a strand is halved before it is first tried, from the
/// last step's pieces: the larger of what the rotation asks for ([`rotation_split_levels`]
/// of `rotation`, the largest `2^depth r` over the (sub)steps that were accepted, r their
/// element rotation at their depth; 0 when it is within [`MAX_ELEMENT_ROTATION`]) and what
/// the numerical loss asks for ([`loss_split_levels`] of `loss`, the largest `4^depth ℓ`
/// over the pieces, ℓ their [`loss_ratio`]). At most [`MAX_SUBSTEP_DEPTH`]. A strand
/// whipping on a shaking head needs about as many pieces from one step to the next; trying
/// the whole step first would only be rejected. The prediction follows the motion both
/// ways: slower pieces give smaller estimates, and the next step starts coarser.
pub fn predicted_split_levels(rotation: f64, loss: f64) -> usize {
    let by_rotation = if rotation.is_nan() || rotation <= MAX_ELEMENT_ROTATION {
        0
    } else {
        rotation_split_levels(rotation, MAX_ELEMENT_ROTATION, 0)
    };
    by_rotation.max(loss_split_levels(loss, 0))
}

/// With the head moving uniformly, a step of a first-order implicit scheme (linearly
/// implicit or Newton implicit Euler) that loses more than this fraction of the energy
/// scale S beyond the physical dissipation is split ([`loss_ratio`]).
///
/// Implicit Euler damps what it does not resolve: in the inertial phase the balance
/// measures that numerical loss exactly (E(start) − E(end) − ∫D, the dissipation D a
/// bound on the physical one), and it is O(h²) per step, the error of a swinging
/// strand's trajectory. A tight rotation limit kept it small by splitting every fast
/// step; with the limit at [`MAX_ELEMENT_ROTATION`] this splits only the steps that lose
/// more than 0.4 % of S at once, down to [`LOSS_SPLIT_DEPTH`]. Measured on the study's
/// `swing` at 1/30 s (1 to 20 elements) against the 0.2 rad limit: 4e-3 keeps every error
/// within +3.1 %, 6e-3 lets N = 2 lose 11 %. A shaking head's steps are not inertial and
/// are never split by it; BDF2, second order, loses far less and is not split by it.
pub const LOSS_SPLIT_FRACTION: f64 = 4e-3;

/// How deep the numerical-loss split goes: a step is split by its loss into at most
/// 2^LOSS_SPLIT_DEPTH pieces (the loss of a piece falls as h², by 16 at this depth).
/// Deeper pieces are accepted whatever they lose: loss is never a danger to the run.
pub const LOSS_SPLIT_DEPTH: usize = 2;

/// The numerical loss of an inertial step from `start` to `end` over
/// [`LOSS_SPLIT_FRACTION`] S: `(E(start) − ½h (D(start) + D(end)) − E(end) − round-off) /
/// (ε S)`, at least 0 (a step that gains energy is the balance's concern). Above 1 the
/// step is split ([`loss_split_levels`]).
pub fn loss_ratio<T: Float>(start: &StateEnergy<T>, end: &StateEnergy<T>) -> f64 {
    let h = T::of(end.time - start.time);
    let dissipated = T::of(0.5) * h * (start.dissipation + end.dissipation);
    let loss = start.total() - dissipated - end.total() - start.roundoff() - end.roundoff();
    let scale = T::of(LOSS_SPLIT_FRACTION) * start.scale;
    if scale > T::zero() {
        (loss / scale).as_f64().max(0.0)
    } else {
        0.0
    }
}

/// What the energy balance of an accepted-size step asks beyond its excess, for a step
/// that rotated an element by `rotation`: [`energy_splits`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergySplits {
    /// Its [`loss_ratio`] (0 unless the head moved uniformly and the step rotated beyond
    /// [`TRUSTED_ELEMENT_ROTATION`]).
    pub loss: f64,
    /// The halvings the loss asks for ([`loss_split_levels`]).
    pub loss_levels: usize,
    /// The halvings that bring a step beyond [`TRUSTED_ELEMENT_ROTATION`] which ends above
    /// its bound (even within the work estimate's allowance) within that rotation (0 at
    /// the deepest split).
    pub trust_levels: usize,
}

impl EnergySplits {
    /// The halvings the energy asks for (0: none).
    pub fn levels(&self) -> usize {
        self.loss_levels.max(self.trust_levels)
    }
}

/// The splits a step's energy asks for, the same for both engines. Beyond
/// [`TRUSTED_ELEMENT_ROTATION`] a step is accepted only when its energy holds: with the
/// head moving uniformly, a loss within [`LOSS_SPLIT_FRACTION`] S ([`loss_ratio`]); and
/// an end not above its bound, even within the work estimate's allowance. Such a step is
/// split into pieces within that rotation rather than accepted or limited: its
/// linearisation is what errs, and limiting it to the estimate pumps a strand whipping on
/// a moving head (a 1 m wavy strand, N = 20, on a head shaking at 5 Hz at 100 fps: mean
/// kinetic energy 0.32 of its budget limited, 0.16 split, 0.05 with BDF2 at 0.2 rad).
pub fn energy_splits<T: Float>(
    balance: &Balance<T>,
    start: &StateEnergy<T>,
    end: &StateEnergy<T>,
    rotation: f64,
    depth: usize,
    deepest: bool,
) -> EnergySplits {
    let beyond = rotation > TRUSTED_ELEMENT_ROTATION;
    let loss = if balance.inertial && beyond {
        loss_ratio(start, end)
    } else {
        0.0
    };
    let trust_levels = if !deepest && beyond && balance.overshoot > T::zero() {
        rotation_split_levels(rotation, TRUSTED_ELEMENT_ROTATION, depth)
    } else {
        0
    };
    EnergySplits {
        loss,
        loss_levels: loss_split_levels(loss, depth),
        trust_levels,
    }
}

/// How many halvings a step at `depth` whose [`loss_ratio`] is `ratio` takes at once: 0
/// when `ratio ≤ 1` or at [`LOSS_SPLIT_DEPTH`]; otherwise the smallest j ≥ 1 with
/// `ratio / 4^j ≤ 1` (the loss of a step goes as h²: a quarter per halving), at most down
/// to [`LOSS_SPLIT_DEPTH`].
pub fn loss_split_levels(ratio: f64, depth: usize) -> usize {
    if ratio.is_nan() || ratio <= 1.0 || depth >= LOSS_SPLIT_DEPTH {
        return 0;
    }
    let room = LOSS_SPLIT_DEPTH - depth;
    let mut levels = 1;
    let mut r = 0.25 * ratio;
    while r > 1.0 && levels < room {
        r *= 0.25;
        levels += 1;
    }
    levels
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rotation_splits_into_the_pieces_that_bring_it_within_the_limit() {
        let limit = MAX_ELEMENT_ROTATION;
        let rotation_split_levels_at = |r, depth| rotation_split_levels(r, limit, depth);
        // r / 2^j ≤ limit with the smallest j ≥ 1
        assert_eq!(rotation_split_levels_at(1.0001 * limit, 0), 1);
        assert_eq!(rotation_split_levels_at(2.0 * limit, 0), 1);
        assert_eq!(rotation_split_levels_at(2.0001 * limit, 0), 2);
        assert_eq!(rotation_split_levels_at(4.0 * limit, 0), 2);
        assert_eq!(rotation_split_levels_at(4.0001 * limit, 0), 3);
        // never below the deepest substep, always at least one halving
        assert_eq!(rotation_split_levels_at(1e9, 0), MAX_SUBSTEP_DEPTH);
        assert_eq!(rotation_split_levels_at(1e9, MAX_SUBSTEP_DEPTH - 2), 2);
        assert_eq!(rotation_split_levels_at(1e9, MAX_SUBSTEP_DEPTH), 1);
        assert_eq!(rotation_split_levels_at(f64::NAN, 0), 1);
        assert_eq!(
            rotation_split_levels_at(f64::INFINITY, 3),
            MAX_SUBSTEP_DEPTH - 3
        );
    }

    #[test]
    fn the_next_step_starts_whole_unless_the_last_one_needed_pieces() {
        let limit = MAX_ELEMENT_ROTATION;
        assert_eq!(predicted_split_levels(0.0, 0.0), 0);
        assert_eq!(predicted_split_levels(limit, 1.0), 0);
        assert_eq!(predicted_split_levels(f64::NAN, f64::NAN), 0);
        assert_eq!(predicted_split_levels(1.5 * limit, 0.0), 1);
        assert_eq!(predicted_split_levels(3.0 * limit, 0.0), 2);
        assert_eq!(
            predicted_split_levels(f64::INFINITY, 0.0),
            MAX_SUBSTEP_DEPTH
        );
        // the loss asks for pieces too, the larger of the two wins
        assert_eq!(predicted_split_levels(0.0, 3.0), 1);
        assert_eq!(predicted_split_levels(3.0 * limit, 3.0), 2);
        assert_eq!(predicted_split_levels(0.0, 1e9), LOSS_SPLIT_DEPTH);
    }

    #[test]
    fn a_loss_splits_into_the_pieces_that_bring_it_within_the_fraction() {
        // r / 4^j ≤ 1 with the smallest j ≥ 1, never below the loss split's depth
        assert_eq!(loss_split_levels(1.0, 0), 0);
        assert_eq!(loss_split_levels(f64::NAN, 0), 0);
        assert_eq!(loss_split_levels(1.0001, 0), 1);
        assert_eq!(loss_split_levels(4.0, 0), 1);
        assert_eq!(loss_split_levels(4.0001, 0), 2.min(LOSS_SPLIT_DEPTH));
        assert_eq!(loss_split_levels(1e9, 0), LOSS_SPLIT_DEPTH);
        assert_eq!(loss_split_levels(1e9, LOSS_SPLIT_DEPTH - 1), 1);
        assert_eq!(loss_split_levels(1e9, LOSS_SPLIT_DEPTH), 0);
    }

    #[test]
    fn the_loss_is_what_a_step_loses_beyond_the_dissipation_bound() {
        let mut start = state(0.0, 1e-6, 0.0);
        start.dissipation = 2e-5;
        let mut end = start;
        end.time = 0.01;
        // the bound dissipated 2e-7 J over the step: losing that much is no loss
        end.kinetic = start.kinetic - 2e-7;
        assert_eq!(loss_ratio(&start, &end), 0.0);
        // gaining energy is no loss either
        end.kinetic = start.kinetic + 1e-7;
        assert_eq!(loss_ratio(&start, &end), 0.0);
        // 3e-7 J lost beyond the bound, of ε S
        end.kinetic = start.kinetic - 5e-7;
        let expected = 3e-7 / (LOSS_SPLIT_FRACTION * start.scale);
        assert!((loss_ratio(&start, &end) - expected).abs() < 1e-6 * expected);
    }

    /// A state of a strand on a moving head: E = T + U + V with the head's power.
    fn state(time: f64, kinetic: f64, power: f64) -> StateEnergy {
        StateEnergy {
            time,
            kinetic,
            elastic: 2e-6,
            potential: -1e-6,
            power,
            ceiling: kinetic + 1e-6,
            scale: kinetic + 3e-6,
            ..Default::default()
        }
    }

    #[test]
    fn a_limited_step_is_brought_to_the_bound_not_to_the_edge_of_its_allowance() {
        // moving head: bound E(start) + W, allowance 100 % of the work terms
        let start = state(0.0, 1e-6, 3e-5);
        let end = state(0.01, 1.6e-6, 3e-5);
        let b = balance(&start, &end, false);
        let work = 0.5 * 0.01 * (3e-5 + 3e-5);
        assert!((b.bound - (start.total() + work)).abs() < 1e-20);
        // E(end) = E(start) + 6e-7 = bound + 3e-7: beyond the allowance (3e-7 + round-off)?
        // no: within it, and so the step stands as it is
        assert!(b.excess <= 0.0, "{b:?}");
        let end = state(0.01, 1.7e-6, 3e-5);
        let b = balance(&start, &end, false);
        assert!(b.excess > 0.0, "{b:?}");
        let kinetic = b.limited_kinetic(&end, true).expect("limited");
        // keeping the allowance, E goes to its edge
        let kept = b.limited_kinetic(&end, false).expect("limited");
        assert!((end.kinetic - kept - b.excess).abs() < 1e-20);
        let limited = StateEnergy { kinetic, ..end };
        // E brought to the bound plus round-off: the allowance (3e-7 J) is not kept
        let roundoff = start.roundoff() + end.roundoff();
        assert!(
            (limited.total() - (b.bound + roundoff)).abs() < 1e-18,
            "{limited:?}"
        );
        assert!(limited.total() < b.bound + 0.01 * b.allowance);
        // uniform head: the allowance is round-off and the two agree
        let (s, e) = (state(0.0, 1e-6, 0.0), state(0.01, 1.2e-6, 0.0));
        let b = balance(&s, &e, true);
        assert_eq!(b.allowance, s.roundoff() + e.roundoff());
        assert_eq!(b.overshoot, b.excess);
        // a potential above the bound by more than round-off but within the allowance:
        // the velocities bring E to the bound plus the allowance, the most they can
        // (U + V = 2.45e-6 J between the bound, 2.3e-6 J, and bound plus allowance,
        // 2.6e-6 J; T = 3e-7 J puts E above the allowance)
        let high = StateEnergy {
            elastic: 3.45e-6,
            kinetic: 3e-7,
            ..end
        };
        let b = balance(&start, &high, false);
        assert!(b.excess > 0.0 && high.kinetic < b.overshoot, "{b:?}");
        let kinetic = b
            .limited_kinetic(&high, true)
            .expect("limited to the allowance");
        assert!((high.kinetic - kinetic - b.excess).abs() < 1e-20);
        // and none when not even the allowance can be reached
        let higher = StateEnergy {
            elastic: high.elastic + 1e-6,
            ..high
        };
        assert_eq!(
            balance(&start, &higher, false).limited_kinetic(&higher, true),
            None
        );
    }
}
