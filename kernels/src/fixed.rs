//! One strand of N elements with every size a constant: the step an engine embeds.
//!
//! A fixed-N strand is three things, all plain data of literal size, no allocation:
//!
//! - [`FixedStrand`]: what a strand keeps from one step to the next (its parameters
//!   [`FixedParams`], its state q, q̇ and the eigenbasis its projection reuses):
//!   1768 B at N = 5 ([`FixedStrand::BYTES`]);
//! - [`FixedWorkspace`]: the scratch of one step, shared by every strand a worker steps
//!   (one per thread, not per strand);
//! - [`step`]: the linearly implicit Euler step of paper section 3.4 with the runtime's
//!   treatment of its terms ([`linearly_implicit`]), checked after the fact and split as
//!   the runtime's step is (energy balance, element rotation);
//! - [`step_with_contacts`]: [`step`] with a strand's contacts with colliders
//!   ([`ContactHooks`]; [`FixedContacts`] on the caller's [`ContactStore`], the colliders
//!   a [`StepColliders`] such as a slice of (collider, mount) pairs): their penalty,
//!   friction and damping in every solve, their energy in the balance, a step split where
//!   a sample goes deeper than the split depth, the anchors and allowances kept between
//!   steps; colliders on poses of their own placed over the step by [`PosedColliders`];
//! - [`step_to_tolerance`]: the error-controlled step instead (variable-step BDF2,
//!   [`bdf2`], with its own steps chosen to keep the estimated local error below a
//!   tolerance), whose history a strand keeps in a [`StepHistory`] beside it;
//! - [`batch`]: one of these steps per strand of a batch as an engine calls it once a
//!   frame (the head given at the step's end), shared by the C ABI and Python.
//!
//! The const parameters are N (elements), D = 3N (coordinates), E = N + 1 (element
//! ends) and B = ⌊D/2⌋ (columns of the kept eigenbasis); `superhelix-generated` writes,
//! for each N it is generated for, a module with these literal sizes and the generated
//! closed forms as the [`MomentSource`].
//!
//! Each is generic over its float type `T` ([`Float`]: `f64`, the default, or `f32`),
//! from one source: in `f64` the step gives the bits it always gave (the runtime's
//! tests compare it with the runtime's step); in `f32` the strand, the workspace and
//! every operation of the step are `f32`, on the generated f32 closed forms. Times (`t`,
//! `h`), the head's motion and gravity stay `f64` in both (an engine's clock and head
//! pose; they are rounded to `T` where the step uses them).

pub(crate) mod adaptive;
pub mod batch;
mod bdf2;
mod contacts;
pub(crate) mod dense;
mod end_hooks;
pub(crate) mod error_control;
mod free_root;
mod newton;
pub(crate) mod params;
mod posed_colliders;
pub(crate) mod step;
mod workspace;

pub use adaptive::{
    energy, energy_views, phase_cut, step, step_views, step_with_contacts, Effects,
    ExtrapolatedHead, HeadTrajectory, StepCounts, StillHead, PHASE_CUT_MARGIN,
};
pub use bdf2::{bdf2, Bdf2History, BDF2_MAX_RATIO};
pub use contacts::{
    ContactHooks, ContactScalars, ContactStore, FixedContacts, PartnerStore, StepColliders,
    STANDARD_GRAVITY,
};
pub use dense::{lu_solve, lu_solve_factored, negative_semidefinite_part, Projection};
pub use end_hooks::{EndHooks, HeldError, REACH_MARGIN};
pub use error_control::{
    min_tolerance, step_to_tolerance, step_to_tolerance_views, step_within, HistoryView,
    StepHistory, ToleranceReport, MAX_FORCED_STEPS, MAX_TOLERANCE, MIN_STEP, MIN_TOLERANCE,
};
pub use newton::{NEWTON_MAX_ITERATIONS, NEWTON_TOLERANCE};
pub use params::{FixedParams, ParamsError};
pub use posed_colliders::{Carrier, PosedColliders};
pub use step::{
    centreline, evaluate, factor_step_views, linearly_implicit, linearly_implicit_with, StepError,
    StepInput, StepReport,
};
pub use workspace::{Assembly, FixedWorkspace};

use crate::energy::StateEnergy;
use crate::float::Float;
use crate::storage::StrandView;
use crate::strand_terms::MomentSource;

/// What a fixed-N strand keeps between steps: its parameters, its state and the basis
/// of the last spectral projection (reused while it still splits the stiffness).
#[derive(Debug, Clone)]
pub struct FixedStrand<const N: usize, const D: usize, const B: usize, T: Float = f64> {
    /// Geometry, material, natural shape, friction and drag.
    pub params: FixedParams<N, D, T>,
    /// Generalized coordinates q (twist and curvatures per element), rad/m.
    pub q: [T; D],
    /// Generalized velocities q̇, rad/(m·s).
    pub v: [T; D],
    /// The kept eigenbasis of the projection (columns of length D, `basis_k` of them).
    pub basis: [[T; D]; B],
    /// Columns of `basis` in use (0: none).
    pub basis_k: usize,
    /// Whether the basis spans the negative (else the positive) eigenvalues.
    pub basis_negative: bool,
    /// How many times the next checked step is halved before it is first tried
    /// ([`crate::energy::predicted_split_levels`] of the last step; used only when the
    /// next step continues from the last one's end, `last_energy`).
    pub split_hint: u8,
    /// The energy of the state the last checked step ended in (the next step's start).
    pub last_energy: Option<StateEnergy<T>>,
}

impl<const N: usize, const D: usize, const B: usize, T: Float> FixedStrand<N, D, B, T> {
    /// Bytes a strand keeps (its size in memory).
    pub const BYTES: usize = core::mem::size_of::<Self>();

    /// A strand at rest in its natural shape (q = q_n, q̇ = 0).
    pub fn at_rest(params: FixedParams<N, D, T>) -> Self {
        FixedStrand {
            q: params.natural,
            v: [T::zero(); D],
            params,
            basis: [[T::zero(); D]; B],
            basis_k: 0,
            basis_negative: true,
            split_hint: 0,
            last_energy: None,
        }
    }

    /// The same strand in the float type `U`: its parameters and state rounded to `U`,
    /// the kept basis and the last energy forgotten (the next step starts afresh).
    pub fn cast<U: Float>(&self) -> FixedStrand<N, D, B, U> {
        let c = |x: &T| U::of(x.as_f64());
        let mut s = FixedStrand::at_rest(self.params.cast());
        s.q = self.q.each_ref().map(c);
        s.v = self.v.each_ref().map(c);
        s
    }

    /// The step's view of this strand.
    pub fn view(&mut self) -> StrandView<'_, T> {
        StrandView {
            params: self.params.view(),
            q: &mut self.q,
            v: &mut self.v,
            basis: self.basis.as_flattened_mut(),
            basis_k: &mut self.basis_k,
            basis_negative: &mut self.basis_negative,
            split_hint: &mut self.split_hint,
            last_energy: &mut self.last_energy,
            history: None,
            end: None,
        }
    }

    /// Set the state (q, q̇), forgetting the kept basis.
    pub fn set_state(&mut self, q: &[T; D], v: &[T; D]) {
        self.q = *q;
        self.v = *v;
        self.basis_k = 0;
        self.last_energy = None;
    }
}

/// The closed forms as a source, for code generic over the source.
pub trait Source<T: Float = f64>: MomentSource<T> {}
impl<T: Float, S: MomentSource<T>> Source<T> for S {}
