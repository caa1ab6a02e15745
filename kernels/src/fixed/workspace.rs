//! The scratch of one fixed-N step, one per worker thread.

use crate::moments::jacobians::VelocityRow;
use crate::moments::rotary::RotaryElement;
use crate::moments::{ElementMoments, EndDerivatives, FrameMotion, SuffixBody, Wrench};
use crate::pose::Pose;
use crate::strand_terms::MomentBuffers;
use nalgebra::{Matrix3, Vector3};

/// Everything a step computes and does not keep: element moments, the assembled terms,
/// the step matrix and its factorisation. Shared by every strand a worker steps (a step
/// starts by forgetting what the previous strand left), so its size is paid once per
/// thread: [`FixedWorkspace::BYTES`].
#[derive(Debug, Clone)]
pub struct FixedWorkspace<const N: usize, const D: usize, const E: usize> {
    pub(super) assembly: Assembly<N, D, E>,
    /// ∂F/∂q less ∂b/∂q (then H, then H⁻), column-major.
    pub(super) stiffness: [[f64; D]; D],
    /// ∂F/∂q̇ less ∂b/∂q̇, column-major.
    pub(super) damping: [[f64; D]; D],
    /// ∂b/∂q̇, column-major.
    pub(super) velocity_jacobian: [[f64; D]; D],
    /// The step matrix and its LU factors, column-major.
    pub(super) matrix_a: [[f64; D]; D],
    pub(super) force: [f64; D],
    pub(super) velocity_term: [f64; D],
    pub(super) first_moment: Vector3<f64>,
    pub(super) rhs: [f64; D],
    pub(super) pivots: [usize; D],
    /// Scratch of the projection: the shared algorithm's
    /// ([`crate::projection::ProjectionScratch`]) and the full Jacobi fallback's.
    pub(super) projection: ProjectionArrays<D>,
}

/// The projection's scratch and the step's cache of its last input and output.
#[derive(Debug, Clone)]
pub(super) struct ProjectionArrays<const D: usize> {
    pub(super) a: [[f64; D]; D],
    pub(super) vectors: [[f64; D]; 11],
    pub(super) pivot: [bool; D],
    pub(super) hu: [[f64; D]; D],
    pub(super) coupling: [[f64; D]; D],
    pub(super) rotated: [[[f64; D]; D]; 2],
    pub(super) dense: [[f64; D]; D],
    pub(super) last_input: [[f64; D]; D],
    pub(super) last_output: [[f64; D]; D],
    pub(super) last_valid: bool,
    pub(super) eigen: [[f64; D]; D],
    pub(super) eigenvalues: [f64; D],
}

/// The moment assembly's buffers at a fixed N (the [`MomentBuffers`] of
/// [`crate::strand_terms::evaluate_terms`] in arrays of literal size): what a fixed-N
/// kernel of the runtime keeps, and part of a [`FixedWorkspace`].
#[derive(Debug, Clone)]
pub struct Assembly<const N: usize, const D: usize, const E: usize> {
    pub(super) ends: [Pose; E],
    pub(super) darboux: [Vector3<f64>; N],
    pub(super) end_derivs: [EndDerivatives; N],
    pub(super) moments: [ElementMoments; N],
    pub(super) motions: [FrameMotion; E],
    pub(super) bodies: [SuffixBody; E],
    pub(super) wrenches: [Wrench; N],
    pub(super) rotary: [RotaryElement; N],
    pub(super) beyond: [(Matrix3<f64>, Matrix3<f64>); N],
    pub(super) velocity_rows: [VelocityRow; D],
    pub(super) mass: [[f64; D]; D],
    pub(super) gram: [[f64; D]; D],
    pub(super) mass_valid: bool,
    pub(super) matrix: [[f64; D]; D],
    pub(super) vector: [f64; D],
    pub(super) prepared: [f64; D],
}

impl<const N: usize, const D: usize, const E: usize> Default for FixedWorkspace<N, D, E> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize, const D: usize, const E: usize> FixedWorkspace<N, D, E> {
    /// Bytes of one workspace.
    pub const BYTES: usize = core::mem::size_of::<Self>();

    /// A workspace (large at big N: keep it in a static, a thread-local or a `Box`
    /// rather than on a small stack).
    pub fn new() -> Self {
        FixedWorkspace {
            assembly: Assembly::new(),
            stiffness: [[0.0; D]; D],
            damping: [[0.0; D]; D],
            velocity_jacobian: [[0.0; D]; D],
            matrix_a: [[0.0; D]; D],
            force: [0.0; D],
            velocity_term: [0.0; D],
            first_moment: Vector3::zeros(),
            rhs: [0.0; D],
            pivots: [0; D],
            projection: ProjectionArrays {
                a: [[0.0; D]; D],
                vectors: [[0.0; D]; 11],
                pivot: [false; D],
                hu: [[0.0; D]; D],
                coupling: [[0.0; D]; D],
                rotated: [[[0.0; D]; D]; 2],
                dense: [[0.0; D]; D],
                last_input: [[0.0; D]; D],
                last_output: [[0.0; D]; D],
                last_valid: false,
                eigen: [[0.0; D]; D],
                eigenvalues: [0.0; D],
            },
        }
    }

    /// Forget the element moments of the last strand (the next evaluation computes
    /// them afresh).
    pub fn forget(&mut self) {
        self.assembly.prepared[0] = f64::NAN;
        self.assembly.mass_valid = false;
        self.projection.last_valid = false;
    }
}

impl<const N: usize, const D: usize, const E: usize> Default for Assembly<N, D, E> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize, const D: usize, const E: usize> Assembly<N, D, E> {
    /// Empty buffers (nothing prepared).
    pub fn new() -> Self {
        Assembly {
            ends: [Pose::default(); E],
            darboux: [Vector3::zeros(); N],
            end_derivs: [EndDerivatives::default(); N],
            moments: [ElementMoments::default(); N],
            motions: [FrameMotion::default(); E],
            bodies: [SuffixBody::default(); E],
            wrenches: [Wrench::default(); N],
            rotary: [RotaryElement::default(); N],
            beyond: [(Matrix3::zeros(), Matrix3::zeros()); N],
            velocity_rows: [VelocityRow::default(); D],
            mass: [[0.0; D]; D],
            gram: [[0.0; D]; D],
            mass_valid: false,
            matrix: [[0.0; D]; D],
            vector: [0.0; D],
            prepared: [f64::NAN; D],
        }
    }

    /// The moment assembly's view of the buffers.
    pub fn buffers(&mut self) -> MomentBuffers<'_> {
        MomentBuffers {
            ends: &mut self.ends,
            darboux: &mut self.darboux,
            end_derivs: &mut self.end_derivs,
            moments: &mut self.moments,
            motions: &mut self.motions,
            bodies: &mut self.bodies,
            wrenches: &mut self.wrenches,
            rotary: &mut self.rotary,
            beyond: &mut self.beyond,
            velocity_rows: &mut self.velocity_rows,
            mass: self.mass.as_flattened_mut(),
            gram: self.gram.as_flattened_mut(),
            mass_valid: &mut self.mass_valid,
            matrix: self.matrix.as_flattened_mut(),
            vector: &mut self.vector,
            prepared: &mut self.prepared,
        }
    }
}
