//! What the checked step asks of a strand's held tip ([`EndHooks`]): a holonomic
//! constraint `g(q, t) = 0` on the tip's pose (its position, across an axis, and its
//! frame), kept by multipliers on the step's own factors.
//!
//! The step calls the hooks where the constraint enters the linearly implicit Euler step
//! (paper section 3.4):
//!
//! - in the assembly, the holder's reaction of the last step pulls on the tip as a point
//!   load at s = L would: its stiffness `f · ∂²y(L)/∂q²` (the tension's geometric
//!   stiffness, [`EndHooks::tip_force`]) and a clamped tip's torque stiffness
//!   ([`EndHooks::add_stiffness`]) go into the matrix, unless the field stiffness is
//!   explicit;
//! - after the solve of q̇⁺, the multipliers λ on the same factors A:
//!   `q̇⁺ ← q̇⁺ − A⁻¹Gᵀλ` with `G q̇⁺ = −g(q, t + h)/h`, so that the linearised tip
//!   lands on the holder at the step's end ([`EndHooks::constrain`]); the reaction is
//!   `−λ/h`;
//! - after q⁺, the drift the linearised constraint leaves projected out
//!   ([`EndHooks::project`]; a step fails when it stays beyond the hook's limit);
//! - at the deepest piece of a step that still turns an element beyond what a step can
//!   follow, the holder out of reach is named ([`EndHooks::beyond_reach`]);
//! - in the energy balance, a driven holder's power joins the work and makes the
//!   balance non-inertial ([`EndHooks::power`], [`EndHooks::driven`]).
//!
//! A held tip is stepped by the linearly implicit Euler step with fixed steps (the
//! checked step): BDF2 and the error-controlled step refuse it
//! ([`HeldError::Unsupported`]). The hooks see the strand's points through
//! [`StrandPoints`], from whatever gives the step its terms.

use crate::float::Float;
use crate::head::HeadState;
use crate::storage::Square;
use crate::strand_terms::StrandPoints;
use nalgebra::Vector3;

/// The fraction of a rod's length within which a holder at that distance from the root
/// counts as out of reach when the tip cannot be kept: the rod is then all but straight
/// and its constraints all but dependent.
pub const REACH_MARGIN: f64 = 1e-3;

/// Why a held tip could not be kept.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HeldError {
    /// The holder is within [`REACH_MARGIN`] of the rod's length from the root, or
    /// beyond (from the root to the axis for a sliding holder).
    BeyondReach {
        /// What holds the tip (`pinned`, `clamped`, `sliding`, `clamped-sliding`).
        kind: &'static str,
        /// Distance of the holder from the root, m.
        distance: f64,
        /// The rod's length, m.
        length: f64,
        /// Time, s.
        t: f64,
    },
    /// The projection left the tip this far off (relative to the length, or in
    /// radians) beyond the hook's limit.
    NotKept {
        /// What holds the tip.
        kind: &'static str,
        /// The drift left.
        off: f64,
    },
    /// The step's factors gave no finite solution for the constraint's columns.
    SingularStep,
    /// The constraints are dependent (`G A⁻¹ Gᵀ` singular).
    Dependent,
    /// A held tip on a step that does not hold it (BDF2, the error-controlled step).
    Unsupported,
}

impl core::fmt::Display for HeldError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            HeldError::BeyondReach {
                kind,
                distance,
                length,
                t,
            } => write!(
                f,
                "the holder of the tip ({kind}) is {distance:.6} m from the root at t = {t:.4} s, at or beyond the rod's reach (its length, {length:.6} m, less {REACH_MARGIN:e} of it): a rod held taut or pulled beyond its length cannot be stepped; keep the holder within the length"
            ),
            HeldError::NotKept { kind, off } => write!(
                f,
                "the held tip ({kind}) could not be kept: {off:.3e} off after projection"
            ),
            HeldError::SingularStep => write!(f, "held tip: singular step matrix"),
            HeldError::Dependent => write!(
                f,
                "held tip: the constraints are dependent (singular G A⁻¹ Gᵀ)"
            ),
            HeldError::Unsupported => write!(
                f,
                "a held tip is stepped by the linearly implicit Euler step with fixed steps (not BDF2, not under a tolerance)"
            ),
        }
    }
}

/// A strand's held tip as the checked step calls it (see the module).
pub trait EndHooks<T: Float = f64>: core::fmt::Debug {
    /// The holder's force on the tip of the last step, head coordinates, N: its
    /// stiffness `f · ∂²y(L)/∂q²` goes into the step's matrix (zero: none).
    fn tip_force(&self, head: &HeadState) -> Vector3<T>;
    /// Add the holder's further stiffness at q (a clamped tip's torque through the
    /// turning of its frame) to `stiffness`; whether anything was added.
    fn add_stiffness(
        &mut self,
        points: &mut dyn StrandPoints<T>,
        q: &[T],
        stiffness: &mut Square<'_, T>,
    ) -> bool;
    /// After the step's solve from q: the velocities `v` constrained with the
    /// multipliers on the step's factors (`solve`: A⁻¹ in place, false when not
    /// finite), so that the linearised tip lands on the holder at `t_end`, a step of `h`
    /// seconds; the reaction recorded.
    #[allow(clippy::too_many_arguments)]
    fn constrain(
        &mut self,
        points: &mut dyn StrandPoints<T>,
        solve: &mut dyn FnMut(&mut [f64]) -> bool,
        q: &[T],
        v: &mut [T],
        t_end: f64,
        h: f64,
    ) -> Result<(), HeldError>;
    /// After the step's q: the drift of the constraint at `t` projected out.
    fn project(
        &mut self,
        points: &mut dyn StrandPoints<T>,
        q: &mut [T],
        t: f64,
    ) -> Result<(), HeldError>;
    /// Why the holder is out of the rod's reach at (q, t); `None` within reach.
    fn beyond_reach(&self, q: &[T], t: f64) -> Option<HeldError>;
    /// The power the holder puts into the strand at `t` through its last reaction, W
    /// (0 for a holder at rest).
    fn power(&self, t: f64) -> f64;
    /// Whether the holder moves (the step's energy balance then weighs work).
    fn driven(&self) -> bool;
}
