//! The runtime-N storage (feature `alloc`): a strand and a step's scratch in vectors of
//! the strand's size, for any number of elements N, stepped by the same functions as a
//! fixed-N strand ([`step`], [`linearly_implicit`], [`step_to_tolerance`], [`energy`]),
//! whose terms come from any [`StepTerms`] (for a `MomentSource` `m`, pass `&mut &m`).
//! What a caller that learns N at run time (the runtime's generic path, a tool reading
//! grooms) holds; an engine with N known when it builds takes the fixed-N storage of
//! `crate::fixed` and the generated modules instead.

extern crate alloc;

use super::square::Square;
use super::views::{ParamsView, ProjectionView, StrandView, WorkView, STACK_VECTORS};
use crate::energy::{StateEnergy, MAX_SUBSTEP_DEPTH};
use crate::field_split::FieldRule;
use crate::fixed::params::{checked_params, ParamsInput, ParamsOut};
use crate::fixed::{
    ContactHooks, Effects, HeadTrajectory, ParamsError, StepCounts, StepError, StepInput,
    StepReport, ToleranceReport,
};
use crate::float::Float;
use crate::head::HeadState;
use crate::material::SectionTerms;
use crate::moments::jacobians::VelocityRow;
use crate::moments::rotary::RotaryElement;
use crate::moments::{ElementMoments, EndDerivatives, FrameMotion, SuffixBody};
use crate::pose::Pose;
use crate::strand_terms::{MomentBuffers, PointScratch, StepTerms};
use alloc::vec;
use alloc::vec::Vec;
use nalgebra::{Matrix3, Vector3};

/// A strand of any number of elements N: its parameters, state and what it keeps
/// between steps (the fields of `crate::fixed::FixedStrand`, in vectors).
#[derive(Debug, Clone)]
pub struct HeapStrand<T: Float = f64> {
    params: HeapParams<T>,
    /// Generalized coordinates q (3N), rad/m.
    pub q: Vec<T>,
    /// Generalized velocities q̇ (3N), rad/(m·s).
    pub v: Vec<T>,
    basis: Vec<T>,
    basis_k: usize,
    basis_negative: bool,
    split_hint: u8,
    last_energy: Option<StateEnergy<T>>,
}

impl<T: Float> HeapStrand<T> {
    /// A strand at rest in its natural shape, from the inputs of
    /// `crate::fixed::FixedParams::new` (N = `lengths.len()`, `natural` 3N long), checked
    /// the same way.
    #[allow(clippy::too_many_arguments)]
    pub fn at_rest(
        root_position: [f64; 3],
        root_frame: [[f64; 3]; 3],
        lengths: &[f64],
        section: &SectionTerms,
        natural: &[f64],
        internal_friction: f64,
        air_drag: f64,
    ) -> Result<Self, ParamsError> {
        let n = 3 * lengths.len();
        let zero = || vec![T::zero(); n];
        let (mut l, mut nat, mut k, mut g) =
            (vec![T::zero(); lengths.len()], zero(), zero(), zero());
        let (root_position, root_frame, mass_per_length, air_drag, rotary_inertia) =
            checked_params(
                &ParamsInput {
                    root_position,
                    root_frame,
                    lengths,
                    section,
                    natural,
                    internal_friction,
                    air_drag,
                },
                ParamsOut {
                    lengths: &mut l,
                    natural: &mut nat,
                    stiffness: &mut k,
                    friction: &mut g,
                },
            )?;
        Ok(HeapStrand {
            q: nat.clone(),
            v: zero(),
            params: HeapParams {
                root_position,
                root_frame,
                lengths: l,
                natural: nat,
                stiffness: k,
                friction: g,
                mass_per_length,
                air_drag,
                rotary_inertia,
            },
            basis: vec![T::zero(); n * (n / 2)],
            basis_k: 0,
            basis_negative: true,
            split_hint: 0,
            last_energy: None,
        })
    }

    /// A strand at rest in its natural shape with the parameters of `params` (another
    /// storage's, e.g. a fixed-N strand's `params.view()`), taken as they are.
    pub fn from_params(params: &ParamsView<'_, T>) -> Self {
        let n = params.dofs();
        HeapStrand {
            q: params.natural.to_vec(),
            v: vec![T::zero(); n],
            params: HeapParams {
                root_position: params.root_position,
                root_frame: params.root_frame,
                lengths: params.lengths.to_vec(),
                natural: params.natural.to_vec(),
                stiffness: params.stiffness.to_vec(),
                friction: params.friction.to_vec(),
                mass_per_length: params.mass_per_length,
                air_drag: params.air_drag,
                rotary_inertia: params.rotary_inertia,
            },
            basis: vec![T::zero(); n * (n / 2)],
            basis_k: 0,
            basis_negative: true,
            split_hint: 0,
            last_energy: None,
        }
    }

    /// N.
    pub fn elements(&self) -> usize {
        self.params.lengths.len()
    }

    /// The elements a workspace is sized for to step this strand: N, or N + 1 with a free
    /// root's translation (3N + 3 coordinates, [`ParamsView::free_root`]).
    pub fn work_elements(&self) -> usize {
        self.q.len().div_ceil(3)
    }

    /// The step's view of the parameters.
    pub fn params(&self) -> ParamsView<'_, T> {
        self.params.view()
    }

    /// The step's view of this strand.
    pub fn view(&mut self) -> StrandView<'_, T> {
        StrandView {
            params: self.params.view(),
            q: &mut self.q,
            v: &mut self.v,
            basis: &mut self.basis,
            basis_k: &mut self.basis_k,
            basis_negative: &mut self.basis_negative,
            split_hint: &mut self.split_hint,
            last_energy: &mut self.last_energy,
            history: None,
            end: None,
        }
    }

    /// Set the state (q, q̇; 3N each, else `false` and nothing changes), forgetting the
    /// kept basis and the last energy.
    pub fn set_state(&mut self, q: &[T], v: &[T]) -> bool {
        if q.len() != self.q.len() || v.len() != self.v.len() {
            return false;
        }
        self.q.copy_from_slice(q);
        self.v.copy_from_slice(v);
        self.basis_k = 0;
        self.last_energy = None;
        true
    }
}

/// A strand's parameters in vectors (`crate::fixed::FixedParams`'s fields).
#[derive(Debug, Clone)]
struct HeapParams<T: Float> {
    root_position: Vector3<T>,
    root_frame: Matrix3<T>,
    lengths: Vec<T>,
    natural: Vec<T>,
    stiffness: Vec<T>,
    friction: Vec<T>,
    mass_per_length: T,
    air_drag: T,
    rotary_inertia: [T; 3],
}

impl<T: Float> HeapParams<T> {
    fn view(&self) -> ParamsView<'_, T> {
        ParamsView {
            root_position: self.root_position,
            root_frame: self.root_frame,
            lengths: &self.lengths,
            natural: &self.natural,
            stiffness: &self.stiffness,
            friction: &self.friction,
            mass_per_length: self.mass_per_length,
            air_drag: self.air_drag,
            rotary_inertia: self.rotary_inertia,
            loads: &[],
            scale: &[],
        }
    }
}

/// The scratch of one step at any N (the fields of `crate::fixed::FixedWorkspace`, in
/// vectors), sized for the strand it steps: stepping a strand of another N resizes it
/// (the only allocation; a worker that steps strands of one N allocates once).
#[derive(Debug, Clone)]
pub struct HeapWorkspace<T: Float = f64> {
    elements: usize,
    ends: Vec<Pose<T>>,
    darboux: Vec<Vector3<T>>,
    end_derivs: Vec<EndDerivatives<T>>,
    moments: Vec<ElementMoments<T>>,
    motions: Vec<FrameMotion<T>>,
    bodies: Vec<SuffixBody<T>>,
    rotary: Vec<RotaryElement<T>>,
    beyond: Vec<(Matrix3<T>, Matrix3<T>)>,
    velocity_rows: Vec<VelocityRow<T>>,
    mass_valid: bool,
    prepared: Vec<T>,
    mass_prepared: Vec<T>,
    /// n² each: mass, gram, matrix, stiffness, damping, ∂b/∂q̇, A, projection's a, hu,
    /// coupling, dense, last input, last output, eigen, the split's work.
    squares: [Vec<T>; 15],
    /// 2n²: the projection's rotated.
    rotated: Vec<T>,
    /// n each: vector, force, velocity term, rhs, eigenvalues, split scale.
    vectors: [Vec<T>; 6],
    /// 11 n: the projection's vectors.
    projection_vectors: Vec<T>,
    first_moment: Vector3<T>,
    pivots: Vec<usize>,
    split_order: Vec<usize>,
    pivot: Vec<bool>,
    last_valid: bool,
    field_rule: FieldRule,
    max_split_depth: usize,
    energy_balance: bool,
    newton: bool,
    factors_piece: f64,
    rotation_estimate: f64,
    loss_estimate: f64,
    stack: Vec<T>,
    end_pairs: Vec<Pose<T>>,
    point_jac: Vec<Vector3<T>>,
    point_ends: Vec<Pose<T>>,
    point_derivs: Vec<EndDerivatives<T>>,
}

impl<T: Float> Default for HeapWorkspace<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Float> HeapWorkspace<T> {
    /// An empty workspace (sized by the first strand it steps).
    pub fn new() -> Self {
        HeapWorkspace {
            elements: 0,
            ends: Vec::new(),
            darboux: Vec::new(),
            end_derivs: Vec::new(),
            moments: Vec::new(),
            motions: Vec::new(),
            bodies: Vec::new(),
            rotary: Vec::new(),
            beyond: Vec::new(),
            velocity_rows: Vec::new(),
            mass_valid: false,
            prepared: Vec::new(),
            mass_prepared: Vec::new(),
            squares: Default::default(),
            rotated: Vec::new(),
            vectors: Default::default(),
            projection_vectors: Vec::new(),
            first_moment: Vector3::zeros(),
            pivots: Vec::new(),
            split_order: Vec::new(),
            pivot: Vec::new(),
            last_valid: false,
            field_rule: FieldRule::default(),
            max_split_depth: MAX_SUBSTEP_DEPTH,
            energy_balance: true,
            newton: false,
            factors_piece: 0.0,
            rotation_estimate: 0.0,
            loss_estimate: 0.0,
            stack: Vec::new(),
            end_pairs: Vec::new(),
            point_jac: Vec::new(),
            point_ends: Vec::new(),
            point_derivs: Vec::new(),
        }
    }

    /// The number of elements the buffers are sized for (0: none yet).
    pub fn elements(&self) -> usize {
        self.elements
    }

    /// Size the buffers for strands of `elements` elements (nothing when they are).
    pub fn fit(&mut self, elements: usize) {
        if self.elements == elements && !self.prepared.is_empty() {
            return;
        }
        let (m, n) = (elements, 3 * elements);
        self.elements = m;
        self.ends = vec![Pose::default(); m + 1];
        self.darboux = vec![Vector3::zeros(); m];
        self.end_derivs = vec![EndDerivatives::default(); m];
        self.moments = vec![ElementMoments::default(); m];
        self.motions = vec![FrameMotion::default(); m + 1];
        self.bodies = vec![SuffixBody::default(); m + 1];
        self.rotary = vec![RotaryElement::default(); m];
        self.beyond = vec![(Matrix3::zeros(), Matrix3::zeros()); m];
        self.velocity_rows = vec![VelocityRow::default(); n];
        self.mass_valid = false;
        self.prepared = vec![T::nan(); n];
        self.mass_prepared = vec![T::nan(); n];
        for s in self.squares.iter_mut() {
            *s = vec![T::zero(); n * n];
        }
        self.rotated = vec![T::zero(); 2 * n * n];
        for v in self.vectors.iter_mut() {
            *v = vec![T::zero(); n];
        }
        self.projection_vectors = vec![T::zero(); 11 * n];
        self.pivots = vec![0; n];
        self.split_order = vec![0; n];
        self.pivot = vec![false; n];
        self.last_valid = false;
        self.stack = vec![T::zero(); STACK_VECTORS * n];
        self.end_pairs = vec![Pose::default(); 2 * (m + 1)];
        self.point_jac = vec![Vector3::zeros(); n];
        self.point_ends = vec![Pose::default(); m + 1];
        self.point_derivs = vec![EndDerivatives::default(); m];
    }

    /// Find the field stiffness's part in the step's matrix by `rule`
    /// (`crate::fixed::FixedWorkspace::set_field_rule`).
    pub fn set_field_rule(&mut self, rule: FieldRule) {
        self.field_rule = rule;
    }

    /// Split a checked step at most `depth` levels deep
    /// (`crate::fixed::FixedWorkspace::set_max_split_depth`).
    pub fn set_max_split_depth(&mut self, depth: usize) {
        self.max_split_depth = depth.min(MAX_SUBSTEP_DEPTH);
    }

    /// Keep the energy balance of the checked step (the default) or not.
    pub fn set_energy_balance(&mut self, on: bool) {
        self.energy_balance = on;
    }

    /// Newton-iterated implicit Euler solves in the checked step
    /// (`crate::fixed::FixedWorkspace::set_newton`).
    pub fn set_newton(&mut self, on: bool) {
        self.newton = on;
    }

    /// The factors the last step on this workspace left, when its last factorisation was
    /// a linearly implicit Euler piece's: the piece's length, the LU factors of its
    /// matrix `S A S` (n × n column-major, S the coordinates' scale the strand's
    /// parameters lent, `ParamsView::scale`) and their pivots. What a caller that solves
    /// more on the step's own matrix after the step keeps (the pair solve of hair–hair
    /// contacts); `fixed::lu_solve_factored` solves with them.
    pub fn last_factors(&self) -> Option<(f64, &[T], &[usize])> {
        let n = 3 * self.elements;
        (self.factors_piece > 0.0 && self.pivots.len() == n).then(|| {
            (
                self.factors_piece,
                &self.squares[6][..n * n],
                &self.pivots[..n],
            )
        })
    }

    /// The step's view of this workspace, sized for strands of `elements` elements.
    pub fn view(&mut self, elements: usize) -> WorkView<'_, T> {
        self.fit(elements);
        let n = 3 * elements;
        let [mass, gram, matrix, stiffness, damping, velocity_jacobian, matrix_a, a, hu, coupling, dense, last_input, last_output, eigen, split_work] =
            &mut self.squares;
        let [vector, force, velocity_term, rhs, eigenvalues, split_scale] = &mut self.vectors;
        WorkView {
            assembly: MomentBuffers {
                ends: &mut self.ends,
                darboux: &mut self.darboux,
                end_derivs: &mut self.end_derivs,
                moments: &mut self.moments,
                motions: &mut self.motions,
                bodies: &mut self.bodies,
                rotary: &mut self.rotary,
                beyond: &mut self.beyond,
                velocity_rows: &mut self.velocity_rows,
                mass,
                gram,
                mass_valid: &mut self.mass_valid,
                matrix,
                vector,
                prepared: &mut self.prepared,
                mass_prepared: &mut self.mass_prepared,
            },
            stiffness: square(stiffness, n),
            damping: square(damping, n),
            velocity_jacobian: square(velocity_jacobian, n),
            matrix_a: square(matrix_a, n),
            factors_piece: &mut self.factors_piece,
            force,
            velocity_term,
            first_moment: &mut self.first_moment,
            rhs,
            pivots: &mut self.pivots,
            projection: ProjectionView {
                a: square(a, n),
                vectors: &mut self.projection_vectors,
                pivot: &mut self.pivot,
                hu: square(hu, n),
                coupling: square(coupling, n),
                rotated: &mut self.rotated,
                dense: square(dense, n),
                last_input: square(last_input, n),
                last_output: square(last_output, n),
                last_valid: &mut self.last_valid,
                eigen: square(eigen, n),
                eigenvalues,
            },
            field_rule: &mut self.field_rule,
            max_split_depth: self.max_split_depth,
            energy_balance: self.energy_balance,
            newton: self.newton,
            split_work: square(split_work, n),
            split_scale,
            split_order: &mut self.split_order,
            rotation_estimate: &mut self.rotation_estimate,
            loss_estimate: &mut self.loss_estimate,
            stack: &mut self.stack,
            ends: &mut self.end_pairs,
            points: PointScratch {
                jac: &mut self.point_jac,
                ends: &mut self.point_ends,
                derivs: &mut self.point_derivs,
            },
        }
    }
}

/// `v` (n² long: `fit` sizes every square so) as an n × n matrix.
fn square<T: Copy>(v: &mut [T], n: usize) -> Square<'_, T> {
    Square::new(v, n).unwrap_or_else(Square::empty)
}

/// [`crate::fixed::step_with_contacts`] for a strand of any N.
#[allow(clippy::too_many_arguments)]
pub fn step<'c, S: StepTerms<T> + ?Sized, T: Float>(
    source: &mut S,
    strand: &mut HeapStrand<T>,
    head: &dyn HeadTrajectory,
    effects: &Effects,
    t: f64,
    h: f64,
    ws: &mut HeapWorkspace<T>,
    counts: &mut StepCounts,
    contacts: Option<&mut (dyn ContactHooks<T> + 'c)>,
) -> Result<StepReport, StepError> {
    let elements = strand.work_elements();
    crate::fixed::step_views(
        source,
        &mut strand.view(),
        head,
        effects,
        t,
        h,
        ws.view(elements),
        counts,
        contacts,
    )
}

/// [`crate::fixed::linearly_implicit`] for a strand of any N.
pub fn linearly_implicit<S: StepTerms<T> + ?Sized, T: Float>(
    source: &mut S,
    strand: &mut HeapStrand<T>,
    input: &StepInput,
    h: f64,
    ws: &mut HeapWorkspace<T>,
) -> Result<StepReport, StepError> {
    let mut ws = ws.view(strand.work_elements());
    let stack = ws.take_stack();
    crate::fixed::step::solve_step(
        source,
        &mut strand.view(),
        input,
        (h, 0.0),
        &mut ws,
        stack,
        None,
    )
}

/// [`crate::fixed::step_to_tolerance`] for a strand of any N, its history in `history`
/// (q and q̇ one step back, 3N each; that step's length and the next's, s).
#[allow(clippy::too_many_arguments)]
pub fn step_to_tolerance<S: StepTerms<T> + ?Sized, T: Float>(
    source: &mut S,
    strand: &mut HeapStrand<T>,
    history: &mut HeapHistory<T>,
    head: &dyn HeadTrajectory,
    effects: &Effects,
    t: f64,
    h: f64,
    tolerance: f64,
    ws: &mut HeapWorkspace<T>,
    report: &mut ToleranceReport,
) -> Result<StepReport, StepError> {
    let n = strand.q.len();
    if history.q.len() != n || history.v.len() != n {
        history.q = vec![T::zero(); n];
        history.v = vec![T::zero(); n];
        history.h = 0.0;
        history.next_h = 0.0;
    }
    let elements = strand.work_elements();
    let mut hv = crate::fixed::HistoryView {
        q: &mut history.q,
        v: &mut history.v,
        h: &mut history.h,
        next_h: &mut history.next_h,
    };
    crate::fixed::step_to_tolerance_views(
        source,
        &mut strand.view(),
        &mut hv,
        head,
        effects,
        (t, h),
        tolerance,
        ws.view(elements),
        report,
        None,
    )
}

/// The error-controlled step's history at any N (`crate::fixed::StepHistory`).
#[derive(Debug, Clone, Default)]
pub struct HeapHistory<T: Float = f64> {
    /// q one step back.
    pub q: Vec<T>,
    /// q̇ one step back.
    pub v: Vec<T>,
    /// The length of that step, s (0: no history).
    pub h: f64,
    /// The step size to try next, s (0: the caller's step).
    pub next_h: f64,
}

/// [`crate::fixed::energy`] for a strand of any N.
pub fn energy<S: StepTerms<T> + ?Sized, T: Float>(
    source: &mut S,
    strand: &HeapStrand<T>,
    effects: &Effects,
    head: &HeadState,
    t: f64,
    ws: &mut HeapWorkspace<T>,
) -> StateEnergy<T> {
    let elements = strand.work_elements();
    crate::fixed::energy_views(
        source,
        &strand.params(),
        (&strand.q, &strand.v),
        effects,
        head,
        t,
        ws.view(elements),
    )
}

/// The step's stiffness projection ([`crate::projection::SpectralProjection`]: the
/// negative semidefinite part of a symmetric matrix from a partial eigendecomposition,
/// reusing the kept basis while it still splits the matrix) on vectors of any n, its
/// basis kept from one call to the next: what a caller that projects outside a step
/// (a benchmark, a test against known spectra) holds.
pub struct HeapProjection<T: Float = f64> {
    n: usize,
    basis: Vec<T>,
    basis_k: usize,
    basis_negative: bool,
    a: Vec<T>,
    /// The scratch's eleven vectors of n.
    vectors: Vec<T>,
    pivot: Vec<bool>,
    hu: Vec<T>,
    coupling: Vec<T>,
    rotated: Vec<T>,
}

impl<T: Float> HeapProjection<T> {
    /// Storage for n × n matrices, no basis kept.
    pub fn new(n: usize) -> Self {
        HeapProjection {
            n,
            basis: vec![T::zero(); n * n],
            basis_k: 0,
            basis_negative: true,
            a: vec![T::zero(); n * n],
            vectors: vec![T::zero(); 11 * n],
            pivot: vec![false; n],
            hu: vec![T::zero(); n * n],
            coupling: vec![T::zero(); n * n],
            rotated: vec![T::zero(); 2 * n * n],
        }
    }

    /// Forget the kept basis: the next call decomposes.
    pub fn forget_basis(&mut self) {
        self.basis_k = 0;
    }

    /// The kept basis: how many columns, and whether they span the negative
    /// eigenvalues (the smaller side of the spectrum is kept).
    pub fn basis(&self) -> (usize, bool) {
        (self.basis_k, self.basis_negative)
    }

    /// Replace the symmetric matrix `h` (n × n, column-major, both triangles filled) by
    /// its negative semidefinite part, saying how; `Failed` leaves `h` unchanged (a value
    /// that is not finite, an eigenpair that fails its residual check).
    pub fn negative_part(&mut self, h: &mut [T]) -> crate::projection::ProjectionOutcome {
        use crate::projection::{ProjectionBasis, ProjectionOutcome, ProjectionScratch};
        let projection = crate::projection::SpectralProjection::<T>::new(
            self.n,
            ProjectionBasis {
                vectors: &mut self.basis,
                k: &mut self.basis_k,
                negative: &mut self.basis_negative,
            },
            ProjectionScratch::on(
                self.n,
                &mut self.a,
                &mut self.vectors,
                &mut self.pivot,
                (&mut self.hu, &mut self.coupling, &mut self.rotated),
            ),
        );
        match projection {
            Some(mut p) => p.negative_part(h),
            None => ProjectionOutcome::Failed,
        }
    }
}
