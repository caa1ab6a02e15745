//! The scratch of one fixed-N step, one per worker thread.

use crate::energy::MAX_SUBSTEP_DEPTH;
use crate::field_split::FieldRule;
use crate::float::Float;
use crate::moments::jacobians::VelocityRow;
use crate::moments::rotary::RotaryElement;
use crate::moments::{ElementMoments, EndDerivatives, FrameMotion, SuffixBody};
use crate::pose::Pose;
use crate::storage::{ProjectionView, Square, WorkView, STACK_VECTORS};
use crate::strand_terms::{MomentBuffers, PointScratch};
use nalgebra::{Matrix3, Vector3};

/// Everything a step computes and does not keep: element moments, the assembled terms,
/// the step matrix and its factorisation. Shared by every strand a worker steps (a step
/// starts by forgetting what the previous strand left), so its size is paid once per
/// thread: [`FixedWorkspace::BYTES`].
#[derive(Debug, Clone)]
pub struct FixedWorkspace<const N: usize, const D: usize, const E: usize, T: Float = f64> {
    pub(super) assembly: Assembly<N, D, E, T>,
    /// ∂F/∂q less ∂b/∂q (then H, then H⁻), column-major.
    pub(super) stiffness: [[T; D]; D],
    /// ∂F/∂q̇ less ∂b/∂q̇, column-major.
    pub(super) damping: [[T; D]; D],
    /// ∂b/∂q̇, column-major.
    pub(super) velocity_jacobian: [[T; D]; D],
    /// The step matrix and its LU factors, column-major.
    pub(super) matrix_a: [[T; D]; D],
    pub(super) force: [T; D],
    pub(super) velocity_term: [T; D],
    pub(super) first_moment: Vector3<T>,
    pub(super) rhs: [T; D],
    pub(super) pivots: [usize; D],
    /// Scratch of the projection: the shared algorithm's
    /// ([`crate::projection::ProjectionScratch`]) and the full Jacobi fallback's.
    pub(super) projection: ProjectionArrays<D, T>,
    /// How the field stiffness's part in the step's matrix is found.
    pub(super) field_rule: FieldRule,
    /// The deepest split of a checked step (0: one solve per step, the step budget).
    pub(super) max_split_depth: usize,
    /// Whether the checked step keeps its energy balance.
    pub(super) energy_balance: bool,
    /// Newton-iterated implicit Euler solves in the checked step.
    pub(super) newton: bool,
    /// See `WorkView::factors_piece`.
    pub(super) factors_piece: f64,
    /// Scratch of the dissipative split ([`crate::field_split`]): its factor, the
    /// metric's scales and the pivot order.
    pub(super) split_work: [[T; D]; D],
    pub(super) split_scale: [T; D],
    pub(super) split_order: [usize; D],
    /// The checked step's largest `2^depth r` over its accepted pieces so far (see
    /// [`crate::energy::predicted_split_levels`]).
    pub(super) rotation_estimate: f64,
    /// The checked step's largest `4^depth ℓ` over its pieces so far, ℓ their
    /// [`crate::energy::loss_ratio`] (see [`crate::energy::predicted_split_levels`]).
    pub(super) loss_estimate: f64,
    /// What the step saves: [`STACK_VECTORS`] vectors of D.
    pub(super) stack: [[T; D]; STACK_VECTORS],
    /// The error estimate's two centrelines.
    pub(super) ends: [[Pose<T>; E]; 2],
    /// The point loads' scratch: J(s), the chain's ends and their derivatives.
    pub(super) point_jac: [Vector3<T>; D],
    pub(super) point_ends: [Pose<T>; E],
    pub(super) point_derivs: [EndDerivatives<T>; N],
}

/// The projection's scratch and the step's cache of its last input and output.
#[derive(Debug, Clone)]
pub(super) struct ProjectionArrays<const D: usize, T: Float> {
    pub(super) a: [[T; D]; D],
    pub(super) vectors: [[T; D]; 11],
    pub(super) pivot: [bool; D],
    pub(super) hu: [[T; D]; D],
    pub(super) coupling: [[T; D]; D],
    pub(super) rotated: [[[T; D]; D]; 2],
    pub(super) dense: [[T; D]; D],
    pub(super) last_input: [[T; D]; D],
    pub(super) last_output: [[T; D]; D],
    pub(super) last_valid: bool,
    pub(super) eigen: [[T; D]; D],
    pub(super) eigenvalues: [T; D],
}

/// The moment assembly's buffers at a fixed N (the [`MomentBuffers`] of
/// [`crate::strand_terms::evaluate_terms`] in arrays of literal size): what a fixed-N
/// kernel of the runtime keeps, and part of a [`FixedWorkspace`].
#[derive(Debug, Clone)]
pub struct Assembly<const N: usize, const D: usize, const E: usize, T: Float = f64> {
    pub(super) ends: [Pose<T>; E],
    pub(super) darboux: [Vector3<T>; N],
    pub(super) end_derivs: [EndDerivatives<T>; N],
    pub(super) moments: [ElementMoments<T>; N],
    pub(super) motions: [FrameMotion<T>; E],
    pub(super) bodies: [SuffixBody<T>; E],
    pub(super) rotary: [RotaryElement<T>; N],
    pub(super) beyond: [(Matrix3<T>, Matrix3<T>); N],
    pub(super) velocity_rows: [VelocityRow<T>; D],
    pub(super) mass: [[T; D]; D],
    pub(super) gram: [[T; D]; D],
    pub(super) mass_valid: bool,
    pub(super) matrix: [[T; D]; D],
    pub(super) vector: [T; D],
    pub(super) prepared: [T; D],
    pub(super) mass_prepared: [T; D],
}

impl<const N: usize, const D: usize, const E: usize, T: Float> Default
    for FixedWorkspace<N, D, E, T>
{
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize, const D: usize, const E: usize, T: Float> FixedWorkspace<N, D, E, T> {
    /// Bytes of one workspace.
    pub const BYTES: usize = core::mem::size_of::<Self>();

    /// A workspace (large at big N: keep it in a static, a thread-local or a `Box`
    /// rather than on a small stack).
    pub fn new() -> Self {
        FixedWorkspace {
            assembly: Assembly::new(),
            stiffness: [[T::zero(); D]; D],
            damping: [[T::zero(); D]; D],
            velocity_jacobian: [[T::zero(); D]; D],
            matrix_a: [[T::zero(); D]; D],
            force: [T::zero(); D],
            velocity_term: [T::zero(); D],
            first_moment: Vector3::zeros(),
            rhs: [T::zero(); D],
            pivots: [0; D],
            projection: ProjectionArrays {
                a: [[T::zero(); D]; D],
                vectors: [[T::zero(); D]; 11],
                pivot: [false; D],
                hu: [[T::zero(); D]; D],
                coupling: [[T::zero(); D]; D],
                rotated: [[[T::zero(); D]; D]; 2],
                dense: [[T::zero(); D]; D],
                last_input: [[T::zero(); D]; D],
                last_output: [[T::zero(); D]; D],
                last_valid: false,
                eigen: [[T::zero(); D]; D],
                eigenvalues: [T::zero(); D],
            },
            field_rule: FieldRule::default(),
            max_split_depth: MAX_SUBSTEP_DEPTH,
            energy_balance: true,
            newton: false,
            factors_piece: 0.0,
            split_work: [[T::zero(); D]; D],
            split_scale: [T::zero(); D],
            split_order: [0; D],
            rotation_estimate: 0.0,
            loss_estimate: 0.0,
            stack: [[T::zero(); D]; STACK_VECTORS],
            ends: [[Pose::default(); E]; 2],
            point_jac: [Vector3::zeros(); D],
            point_ends: [Pose::default(); E],
            point_derivs: [EndDerivatives::default(); N],
        }
    }

    /// The step's view of this workspace (for [`super::step_views`] and
    /// [`super::step_to_tolerance_views`], e.g. with a strand's view whose parameters
    /// carry point loads).
    pub fn view(&mut self) -> WorkView<'_, T, D> {
        let p = &mut self.projection;
        WorkView {
            assembly: self.assembly.buffers(),
            stiffness: Square::of_array(&mut self.stiffness),
            damping: Square::of_array(&mut self.damping),
            velocity_jacobian: Square::of_array(&mut self.velocity_jacobian),
            matrix_a: Square::of_array(&mut self.matrix_a),
            factors_piece: &mut self.factors_piece,
            force: &mut self.force,
            velocity_term: &mut self.velocity_term,
            first_moment: &mut self.first_moment,
            rhs: &mut self.rhs,
            pivots: &mut self.pivots,
            projection: ProjectionView {
                a: Square::of_array(&mut p.a),
                vectors: p.vectors.as_flattened_mut(),
                pivot: &mut p.pivot,
                hu: Square::of_array(&mut p.hu),
                coupling: Square::of_array(&mut p.coupling),
                rotated: p.rotated.as_flattened_mut().as_flattened_mut(),
                dense: Square::of_array(&mut p.dense),
                last_input: Square::of_array(&mut p.last_input),
                last_output: Square::of_array(&mut p.last_output),
                last_valid: &mut p.last_valid,
                eigen: Square::of_array(&mut p.eigen),
                eigenvalues: &mut p.eigenvalues,
            },
            field_rule: &mut self.field_rule,
            max_split_depth: self.max_split_depth,
            energy_balance: self.energy_balance,
            newton: self.newton,
            split_work: Square::of_array(&mut self.split_work),
            split_scale: &mut self.split_scale,
            split_order: &mut self.split_order,
            rotation_estimate: &mut self.rotation_estimate,
            loss_estimate: &mut self.loss_estimate,
            stack: self.stack.as_flattened_mut(),
            ends: self.ends.as_flattened_mut(),
            points: PointScratch {
                jac: &mut self.point_jac,
                ends: &mut self.point_ends,
                derivs: &mut self.point_derivs,
            },
        }
    }

    /// Find the field stiffness's part in the step's matrix by `rule` (the default:
    /// [`FieldRule::Projected`]).
    pub fn set_field_rule(&mut self, rule: FieldRule) {
        self.field_rule = rule;
    }

    /// How the field stiffness's part in the step's matrix is found.
    pub fn field_rule(&self) -> FieldRule {
        self.field_rule
    }

    /// Split a checked step at most `depth` levels deep (clamped to
    /// [`MAX_SUBSTEP_DEPTH`], the default; 0: one solve per step, the runtime's step
    /// budget `max_split_depth`). At the deepest level a step is accepted with its
    /// rotation limited, as the runtime's.
    pub fn set_max_split_depth(&mut self, depth: usize) {
        self.max_split_depth = depth.min(MAX_SUBSTEP_DEPTH);
    }

    /// The deepest split of a checked step.
    pub fn max_split_depth(&self) -> usize {
        self.max_split_depth
    }

    /// Keep the energy balance of the checked step (the default) or not (the runtime's
    /// `energy_balance = false`: no energy is measured, no step is split or limited for
    /// it).
    pub fn set_energy_balance(&mut self, on: bool) {
        self.energy_balance = on;
    }

    /// Whether the checked step keeps its energy balance.
    pub fn energy_balance(&self) -> bool {
        self.energy_balance
    }

    /// Solve the checked step's pieces by Newton-iterated implicit Euler (the reference
    /// integrator `newton-implicit-euler`: backward Euler to a residual of
    /// [`super::NEWTON_TOLERANCE`], the linearly implicit solve of the same piece where
    /// it does not converge) instead of the linearly implicit Euler step (the default).
    /// The split rule, the energy balance and the contacts are the same; BDF2's history,
    /// a held tip and a free root keep the linearly implicit solve, and so does the
    /// error-controlled step.
    pub fn set_newton(&mut self, on: bool) {
        self.newton = on;
    }

    /// Whether the checked step solves by Newton iterations.
    pub fn newton(&self) -> bool {
        self.newton
    }

    /// Forget the element moments of the last strand (the next evaluation computes
    /// them afresh).
    pub fn forget(&mut self) {
        self.view().forget();
    }

    /// The factors of the last step's solve when it was a linearly implicit Euler
    /// piece's: the piece's length, the LU factors of its matrix `S A S` (D × D
    /// column-major, S the coordinates' scale of the strand's parameters,
    /// `ParamsView::scale`) and their pivots, as `storage::heap::HeapWorkspace::last_factors`
    /// lends them. What a caller that solves more on the step's own matrix after the
    /// step keeps (the pair solve of hair–hair contacts); [`super::lu_solve_factored`]
    /// solves with them.
    pub fn last_factors(&self) -> Option<(f64, &[T], &[usize])> {
        (self.factors_piece > 0.0).then(|| {
            (
                self.factors_piece,
                self.matrix_a.as_flattened(),
                &self.pivots[..],
            )
        })
    }

    /// The scratch of a strand's points ([`crate::strand_terms::StepTerms::point`]) and
    /// the moment assembly's buffers, for evaluations outside a step (the points and the
    /// free root's momentum a pair solve asks for after it).
    pub fn point_scratch(&mut self) -> (PointScratch<'_, T>, MomentBuffers<'_, T>) {
        (
            PointScratch {
                jac: &mut self.point_jac,
                ends: &mut self.point_ends,
                derivs: &mut self.point_derivs,
            },
            self.assembly.buffers(),
        )
    }
}

impl<const N: usize, const D: usize, const E: usize, T: Float> Default for Assembly<N, D, E, T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize, const D: usize, const E: usize, T: Float> Assembly<N, D, E, T> {
    /// Empty buffers (nothing prepared).
    pub fn new() -> Self {
        Assembly {
            ends: [Pose::default(); E],
            darboux: [Vector3::zeros(); N],
            end_derivs: [EndDerivatives::default(); N],
            moments: [ElementMoments::default(); N],
            motions: [FrameMotion::default(); E],
            bodies: [SuffixBody::default(); E],
            rotary: [RotaryElement::default(); N],
            beyond: [(Matrix3::zeros(), Matrix3::zeros()); N],
            velocity_rows: [VelocityRow::default(); D],
            mass: [[T::zero(); D]; D],
            gram: [[T::zero(); D]; D],
            mass_valid: false,
            matrix: [[T::zero(); D]; D],
            vector: [T::zero(); D],
            prepared: [T::nan(); D],
            mass_prepared: [T::nan(); D],
        }
    }

    /// The moment assembly's view of the buffers.
    pub fn buffers(&mut self) -> MomentBuffers<'_, T> {
        MomentBuffers {
            ends: &mut self.ends,
            darboux: &mut self.darboux,
            end_derivs: &mut self.end_derivs,
            moments: &mut self.moments,
            motions: &mut self.motions,
            bodies: &mut self.bodies,
            rotary: &mut self.rotary,
            beyond: &mut self.beyond,
            velocity_rows: &mut self.velocity_rows,
            mass: self.mass.as_flattened_mut(),
            gram: self.gram.as_flattened_mut(),
            mass_valid: &mut self.mass_valid,
            matrix: self.matrix.as_flattened_mut(),
            vector: &mut self.vector,
            prepared: &mut self.prepared,
            mass_prepared: &mut self.mass_prepared,
        }
    }
}
