//! The one trait through which the runtime reaches a strand's dynamic terms.
//!
//! Implemented by [`crate::GenericKernel`] (runtime N, Gauss–Legendre quadrature), by the
//! moment assembly ([`crate::kernels::moments::kernel::MomentKernel`]) and by the generated
//! fixed-N kernels ([`crate::kernels::fixed_kernel::FixedKernel`]); they are
//! interchangeable and compared in tests.
//!
//! All quantities are in head coordinates (design page "Energies and the equation of
//! motion"). External forces per unit length are described by a [`BodyField`], affine
//! in the position y and the relative velocity ẏ = J q̇ of the centreline:
//! `F(s) = c0 + C1 y(s) + C2 ẏ(s)`, which covers gravity, the fictitious forces of
//! head motion and air drag (eq. 5a in the head frame).

use crate::model::reconstruction::{element_ends, Pose};
use crate::model::strand::StrandGeometry;
use faer::Mat;
use nalgebra::Vector3;
pub use superhelix_kernels::body_field::BodyField;

pub use superhelix_kernels::strand_terms::Terms;

/// Input of one evaluation.
#[derive(Debug, Clone, Copy)]
pub struct EvalInput<'a> {
    /// Generalized coordinates (3N).
    pub q: &'a [f64],
    /// Generalized velocities (3N).
    pub v: &'a [f64],
    /// External force per unit length.
    pub field: BodyField,
    /// What to compute.
    pub terms: Terms,
}

/// Outputs of one evaluation, sized once for a strand.
#[derive(Debug, Clone)]
pub struct StrandTerms {
    /// M(q), 3N × 3N, symmetric positive definite.
    pub mass: Mat<f64>,
    /// ∫ Jᵀ F ds − b(q, q̇), 3N.
    pub force: Vec<f64>,
    /// b(q, q̇) = ∫ ρS Jᵀ (J̇ q̇) ds, 3N.
    pub velocity_term: Vec<f64>,
    /// ∂(∫ Jᵀ (c0 + C1 y) ds)/∂q, 3N × 3N.
    pub stiffness: Mat<f64>,
    /// ∫ Jᵀ C2 J ds, 3N × 3N.
    pub damping: Mat<f64>,
    /// ∂b/∂q̇, 3N × 3N.
    pub velocity_term_jacobian: Mat<f64>,
    /// ∫ ρS y ds (with `mass` or `force`): the gravity potential is −(first moment)·g.
    pub first_moment: Vector3<f64>,
}

impl StrandTerms {
    /// Buffers for `dofs` = 3N generalized coordinates.
    pub fn new(dofs: usize) -> Self {
        StrandTerms {
            mass: Mat::zeros(dofs, dofs),
            force: vec![0.0; dofs],
            velocity_term: vec![0.0; dofs],
            stiffness: Mat::zeros(dofs, dofs),
            damping: Mat::zeros(dofs, dofs),
            velocity_term_jacobian: Mat::zeros(dofs, dofs),
            first_moment: Vector3::zeros(),
        }
    }
}

/// The terms of one strand's equation of motion, for one strand geometry.
///
/// A kernel instance belongs to one strand and may keep scratch space, hence `&mut self`.
pub trait StrandKernel: Send {
    /// The strand's geometry.
    fn geometry(&self) -> &StrandGeometry;

    /// Human-readable description (`generic (adaptive Gauss-Legendre)`,
    /// `generated fixed-N (N = 5)`, `moment assembly (closed form), N = 40`).
    fn description(&self) -> String;

    /// True for kernels on generated code: the generated fixed-N kernels and the moment
    /// assembly fed by the generated closed forms.
    fn is_generated(&self) -> bool;

    /// Fill the requested terms of the equation of motion at (q, q̇).
    fn evaluate(&mut self, input: &EvalInput<'_>, out: &mut StrandTerms);

    /// Position y(s), and J(s) written into `jac` (3N columns of 3-vectors). When
    /// `hessian` is given as (c, H), adds c · ∂²y(s)/∂q∂q to H.
    fn point(
        &mut self,
        q: &[f64],
        s: f64,
        jac: &mut [Vector3<f64>],
        hessian: Option<(Vector3<f64>, &mut Mat<f64>)>,
    ) -> Vector3<f64>;

    /// Poses at the N + 1 element ends.
    fn element_ends(&mut self, q: &[f64], ends: &mut [Pose]) {
        element_ends(self.geometry(), q, ends);
    }
}

/// Makes kernels for strands; the generated crate provides one for the N it was built
/// with.
pub trait KernelFactory: Send + Sync {
    /// A kernel for this geometry, or `None` when this factory has none for its N.
    fn create(&self, geometry: &StrandGeometry) -> Option<Box<dyn StrandKernel>>;
    /// The numbers of elements this factory has generated fixed-N code for (what
    /// `kernels = "generated"` requires); `create` may serve other N too.
    fn available(&self) -> Vec<usize>;
}
