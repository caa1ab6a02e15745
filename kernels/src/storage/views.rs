//! What one strand's step reads and writes, as views of its owner's memory: the
//! strand's parameters ([`ParamsView`]), its state and what it keeps between steps
//! ([`StrandView`]), and the step's scratch ([`WorkView`]). The fixed-N storage
//! (`crate::fixed`: arrays of literal size) and the runtime-N storage
//! ([`super::heap`]: vectors of the strand's size) lend the same views, so the step is
//! written once.

use super::square::Square;
use crate::energy::StateEnergy;
use crate::field_split::FieldRule;
use crate::fixed::{EndHooks, HistoryView};
use crate::float::Float;
use crate::point_load::PointLoad;
use crate::pose::Pose;
use crate::strand_terms::{MomentBuffers, PointScratch, StrandShape};
use nalgebra::{Matrix3, Vector3};

/// The vectors of n values a step takes from its scratch at most at once (the checked
/// step's start, a saved state per split level, the pull-back's end, the solve's new q
/// and the split's metric; the error-controlled step's states and BDF2's
/// extrapolations).
pub const STACK_VECTORS: usize = 2 * (crate::energy::MAX_SUBSTEP_DEPTH + 1) + 8;

/// n as the step's loops take it: `NC` when the storage knows it at compile time (its
/// arrays are NC long, so `n` is NC), else `n`.
#[inline(always)]
pub(crate) fn sized<const NC: usize>(n: usize) -> usize {
    if NC != 0 {
        NC
    } else {
        n
    }
}

/// A strand's parameters (see `crate::fixed::FixedParams` for each field's meaning and
/// unit): slices N long (`lengths`) and 3N long (the others).
#[derive(Debug, Clone, Copy)]
pub struct ParamsView<'a, T: Float = f64> {
    /// Root position r_0, head coordinates, m.
    pub root_position: Vector3<T>,
    /// Root frame F_0, head coordinates (columns n0, n1, n2).
    pub root_frame: Matrix3<T>,
    /// Element lengths l_Q, m (N).
    pub lengths: &'a [T],
    /// Natural twist and curvatures q_n, rad/m (3N).
    pub natural: &'a [T],
    /// Diagonal of K, N·m (3N).
    pub stiffness: &'a [T],
    /// Diagonal of the internal friction γ l_Q, kg·m⁴/s (3N).
    pub friction: &'a [T],
    /// ρS, kg/m.
    pub mass_per_length: T,
    /// Air drag ν, kg/(m·s).
    pub air_drag: T,
    /// Rotary inertia per unit length (ρ(I1 + I2), ρI1, ρI2), kg·m.
    pub rotary_inertia: [T; 3],
    /// Point loads ([`crate::point_load`]; the charges' forces of electrostatics among
    /// them), constant over a step: empty for none.
    pub loads: &'a [PointLoad],
    /// A scale S of the coordinates (3N; empty: 1 throughout): the step solves
    /// `(S A S) y = S b`, `x = S y`, and projects `S H S`, so that coordinates of very
    /// different units keep their digits (a pinned root's joint, an element of a sliver's
    /// length whose coordinates are scaled by its inverse length).
    pub scale: &'a [T],
}

impl<'a, T: Float> ParamsView<'a, T> {
    /// 3N, the strand's coordinates.
    #[inline(always)]
    pub fn dofs(&self) -> usize {
        self.natural.len()
    }

    /// Whether the strand's root is free: its translation X (3 coordinates, m) follows
    /// the chain's 3N coordinates, so that `natural`, `stiffness` and `friction` are
    /// 3N + 3 long (X without stiffness nor friction) and the step keeps the strand's
    /// linear momentum ([`crate::fixed`]'s `free_root`).
    pub fn free_root(&self) -> bool {
        self.natural.len() == 3 * self.lengths.len() + 3
    }

    /// Whether the strand dissipates at first order in the step (internal friction or
    /// air drag): only such a strand's solves take the dissipative split of the field
    /// stiffness ([`crate::field_split`]).
    pub fn dissipative(&self) -> bool {
        self.air_drag > T::zero() || self.friction.iter().any(|&g| g > T::zero())
    }

    /// The shape the moment assembly reads.
    pub fn shape(&self) -> StrandShape<'a, T> {
        StrandShape {
            root_position: self.root_position,
            root_frame: self.root_frame,
            lengths: self.lengths,
            mass_per_length: self.mass_per_length,
            rotary_inertia: self.rotary_inertia,
        }
    }

    /// Total length L, m.
    pub fn length(&self) -> T {
        self.lengths.iter().copied().sum()
    }
}

/// A strand as its step sees it: its parameters, its state (q, q̇, 3N each) and what
/// it keeps from one step to the next.
#[derive(Debug)]
pub struct StrandView<'a, T: Float = f64> {
    /// The parameters.
    pub params: ParamsView<'a, T>,
    /// Generalized coordinates q, rad/m.
    pub q: &'a mut [T],
    /// Generalized velocities q̇, rad/(m·s).
    pub v: &'a mut [T],
    /// The projection's kept eigenbasis: columns of 3N, ⌊3N/2⌋ of them.
    pub basis: &'a mut [T],
    /// Columns of `basis` in use.
    pub basis_k: &'a mut usize,
    /// Whether the basis spans the negative (else the positive) eigenvalues.
    pub basis_negative: &'a mut bool,
    /// How many times the next checked step is halved before it is first tried.
    pub split_hint: &'a mut u8,
    /// The energy of the state the last checked step ended in.
    pub last_energy: &'a mut Option<StateEnergy<T>>,
    /// BDF2's history: lent, the checked step takes BDF2 where the history allows (a
    /// whole step, not longer than [`crate::fixed::BDF2_MAX_RATIO`] times the last
    /// accepted piece) and linearly implicit Euler pieces elsewhere, each accepted piece
    /// recorded as the history of the next; `None`, linearly implicit Euler throughout.
    pub history: Option<HistoryView<'a, T>>,
    /// The strand's held tip: lent, the checked linearly implicit Euler step keeps it
    /// ([`crate::fixed::EndHooks`]); `None`, a free tip.
    pub end: Option<&'a mut (dyn EndHooks<T> + 'a)>,
}

impl<T: Float> StrandView<'_, T> {
    /// 3N.
    #[inline(always)]
    pub fn dofs(&self) -> usize {
        self.q.len()
    }
}

/// The projection's scratch and the step's cache of its last input and output (n × n
/// matrices, n-long vectors).
#[derive(Debug)]
pub struct ProjectionView<'a, T: Float = f64> {
    pub(crate) a: Square<'a, T>,
    /// 11 vectors of n.
    pub(crate) vectors: &'a mut [T],
    pub(crate) pivot: &'a mut [bool],
    pub(crate) hu: Square<'a, T>,
    pub(crate) coupling: Square<'a, T>,
    /// 2n².
    pub(crate) rotated: &'a mut [T],
    pub(crate) dense: Square<'a, T>,
    pub(crate) last_input: Square<'a, T>,
    pub(crate) last_output: Square<'a, T>,
    pub(crate) last_valid: &'a mut bool,
    pub(crate) eigen: Square<'a, T>,
    pub(crate) eigenvalues: &'a mut [T],
}

/// The scratch of one step of a strand of n = 3N coordinates (see
/// `crate::fixed::FixedWorkspace`; `NC`: n when the storage knows it at compile time, as
/// the fixed-N arrays do, else 0): the moment assembly's buffers, the terms, the step's
/// matrix and its factors, the projection's and the dissipative split's scratch, the
/// step's rules, and [`STACK_VECTORS`] vectors of n for what the step saves.
pub struct WorkView<'a, T: Float = f64, const NC: usize = 0> {
    pub(crate) assembly: MomentBuffers<'a, T>,
    /// ∂F/∂q less ∂b/∂q (then H, then H⁻).
    pub(crate) stiffness: Square<'a, T>,
    /// ∂F/∂q̇ less ∂b/∂q̇.
    pub(crate) damping: Square<'a, T>,
    /// ∂b/∂q̇.
    pub(crate) velocity_jacobian: Square<'a, T>,
    /// The step matrix and its LU factors.
    pub(crate) matrix_a: Square<'a, T>,
    /// The length of the linearly implicit Euler piece whose factors `matrix_a` holds
    /// (0: the last factorisation was BDF2's).
    pub(crate) factors_piece: &'a mut f64,
    pub(crate) force: &'a mut [T],
    pub(crate) velocity_term: &'a mut [T],
    pub(crate) first_moment: &'a mut Vector3<T>,
    pub(crate) rhs: &'a mut [T],
    pub(crate) pivots: &'a mut [usize],
    pub(crate) projection: ProjectionView<'a, T>,
    pub(crate) field_rule: &'a mut FieldRule,
    pub(crate) max_split_depth: usize,
    pub(crate) energy_balance: bool,
    /// The checked step's solves are Newton-iterated implicit Euler's
    /// (`crate::fixed::newton`), the linearly implicit one where they do not converge.
    pub(crate) newton: bool,
    pub(crate) split_work: Square<'a, T>,
    pub(crate) split_scale: &'a mut [T],
    pub(crate) split_order: &'a mut [usize],
    pub(crate) rotation_estimate: &'a mut f64,
    pub(crate) loss_estimate: &'a mut f64,
    /// [`STACK_VECTORS`] × n.
    pub(crate) stack: &'a mut [T],
    /// 2(N + 1) poses (the error estimate's two centrelines).
    pub(crate) ends: &'a mut [Pose<T>],
    /// The point loads' scratch: J(s) (3N), the chain's ends (N + 1) and their
    /// derivatives (N).
    pub(crate) points: PointScratch<'a, T>,
}

impl<'a, T: Float, const NC: usize> WorkView<'a, T, NC> {
    /// Forget the element moments of the last strand (the next evaluation computes them
    /// afresh).
    pub fn forget(&mut self) {
        self.assembly.prepared[0] = T::nan();
        self.assembly.mass_prepared[0] = T::nan();
        *self.assembly.mass_valid = false;
        *self.projection.last_valid = false;
    }

    /// The scratch's vectors, taken out of the view (the step hands them down its calls
    /// beside the view).
    pub(crate) fn take_stack(&mut self) -> &'a mut [T] {
        core::mem::take(&mut self.stack)
    }
}
