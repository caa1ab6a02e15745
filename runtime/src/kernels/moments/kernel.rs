//! A strand kernel assembled from element moments (docs/moment-assembly.md): M and the
//! gravity force in O(N²) ([`crate::kernels::moments::assemble_mass_and_gravity`]), the full force
//! (field and −b) in O(N) ([`crate::kernels::moments::assemble_force`]), the damping, field stiffness
//! and ∂b/∂q̇ in O(N²) ([`crate::kernels::moments::jacobians`]), rotary inertia from
//! [`crate::kernels::moments::rotary`].
//!
//! The element moments come from a [`MomentSource`]: the generated closed forms
//! (`superhelix-generated`) or, as a reference, [`QuadratureMoments`]. Buffers are sized
//! once at construction; `evaluate` allocates nothing.

use crate::kernels::kernel::{EvalInput, StrandKernel, StrandTerms};
use crate::kernels::moments::jacobians::VelocityRow;
use crate::kernels::moments::rotary::RotaryElement;
use crate::kernels::moments::{ElementMoments, EndDerivatives, FrameMotion, SuffixBody};
use crate::model::reconstruction::Pose;
use crate::model::strand::StrandGeometry;
use faer::Mat;
use nalgebra::{Matrix3, Vector3};
use superhelix_kernels::strand_point;
pub use superhelix_kernels::strand_terms::MomentSource;
use superhelix_kernels::strand_terms::{
    self, evaluate_terms, MomentBuffers, TermMatrix, TermVectors,
};

/// Element moments by Gauss–Legendre quadrature with `16 + 2⌈W·l⌉` points (or a fixed
/// number): the reference the closed forms are checked against.
#[derive(Debug, Clone, Copy, Default)]
pub struct QuadratureMoments {
    /// Fixed number of points, or `None` for `16 + 2⌈W·l⌉`.
    pub points: Option<usize>,
}

impl MomentSource for QuadratureMoments {
    fn moments(&self, d: &Vector3<f64>, l: f64, rotary: &[f64; 3], out: &mut ElementMoments) {
        let n = self
            .points
            .unwrap_or(16 + 2 * (d.norm() * l).ceil().min(400.0) as usize);
        *out = ElementMoments::by_quadrature(d, l, rotary, n);
    }
    fn describe(&self) -> &'static str {
        "quadrature moments"
    }
    fn is_generated(&self) -> bool {
        false
    }
}

/// A kernel assembled from element moments.
pub struct MomentKernel<S: MomentSource + Send> {
    geom: StrandGeometry,
    source: S,
    ends: Vec<Pose>,
    darboux: Vec<Vector3<f64>>,
    end_derivs: Vec<EndDerivatives>,
    moments: Vec<ElementMoments>,
    motions: Vec<FrameMotion>,
    bodies: Vec<SuffixBody>,
    rotary: Vec<RotaryElement>,
    beyond: Vec<(Matrix3<f64>, Matrix3<f64>)>,
    velocity_rows: Vec<VelocityRow>,
    /// Column-major 3N × 3N scratch.
    matrix: Vec<f64>,
    /// M at the prepared q (column-major), once assembled: the integrator asks for M
    /// twice at the same q (a step's end energy, then the next step).
    mass: Vec<f64>,
    /// The centreline Gram matrix ∫ JᵀJ ds at the prepared q, with `mass`: an isotropic
    /// drag's damping is −ν times it.
    gram: Vec<f64>,
    mass_valid: bool,
    vector: Vec<f64>,
    /// The q the element ends, end derivatives and moments were prepared for (NaN before
    /// the first evaluation: equal to no q).
    prepared: Vec<f64>,
    /// The q the mass fields of `moments` hold (`MomentBuffers::mass_prepared`).
    mass_prepared: Vec<f64>,
    /// The scratch of [`StrandKernel::point`] (apart from the prepared element data, so
    /// that a point at another q leaves them alone) and what it holds.
    point_ends: Vec<Pose>,
    point_derivs: Vec<EndDerivatives>,
    point_chain: PointChain,
}

impl<S: MomentSource + Send> MomentKernel<S> {
    /// A kernel for this geometry with moments from `source`.
    pub fn new(geom: StrandGeometry, source: S) -> Self {
        let n = geom.elements();
        MomentKernel {
            source,
            ends: vec![Pose::default(); n + 1],
            darboux: vec![Vector3::zeros(); n],
            end_derivs: vec![EndDerivatives::default(); n],
            moments: vec![ElementMoments::default(); n],
            motions: vec![FrameMotion::default(); n + 1],
            bodies: vec![SuffixBody::default(); n + 1],
            rotary: vec![RotaryElement::default(); n],
            beyond: vec![(Matrix3::zeros(), Matrix3::zeros()); n],
            velocity_rows: vec![VelocityRow::default(); 3 * n],
            matrix: vec![0.0; 9 * n * n],
            mass: vec![0.0; 9 * n * n],
            gram: vec![0.0; 9 * n * n],
            mass_valid: false,
            vector: vec![0.0; 3 * n],
            prepared: vec![f64::NAN; 3 * n],
            mass_prepared: vec![f64::NAN; 3 * n],
            point_ends: vec![Pose::default(); n + 1],
            point_derivs: vec![EndDerivatives::default(); n],
            point_chain: PointChain::new(3 * n),
            geom,
        }
    }
}

/// Copy a column-major n × n `src` into `mat` (overwrite).
pub(crate) fn store(src: &[f64], mat: &mut Mat<f64>) {
    let n = mat.nrows();
    for c in 0..n {
        mat.col_as_slice_mut(c)
            .copy_from_slice(&src[c * n..(c + 1) * n]);
    }
}

impl<S: MomentSource + Send> StrandKernel for MomentKernel<S> {
    fn geometry(&self) -> &StrandGeometry {
        &self.geom
    }

    fn description(&self) -> String {
        format!(
            "moment assembly ({}), N = {}",
            self.source.describe(),
            self.geom.elements()
        )
    }

    fn is_generated(&self) -> bool {
        self.source.is_generated()
    }

    fn evaluate(&mut self, input: &EvalInput<'_>, out: &mut StrandTerms) {
        let MomentKernel {
            geom,
            source,
            ends,
            darboux,
            end_derivs,
            moments,
            motions,
            bodies,
            rotary,
            beyond,
            velocity_rows,
            matrix,
            mass,
            gram,
            mass_valid,
            vector,
            prepared,
            mass_prepared,
            ..
        } = self;
        let mut buffers = MomentBuffers {
            ends,
            darboux,
            end_derivs,
            moments,
            motions,
            bodies,
            rotary,
            beyond,
            velocity_rows,
            mass,
            gram,
            mass_valid,
            matrix,
            vector,
            prepared,
            mass_prepared,
        };
        let StrandTerms {
            mass: out_mass,
            force,
            velocity_term,
            stiffness,
            damping,
            velocity_term_jacobian,
            first_moment,
        } = out;
        let mut vectors = TermVectors {
            force,
            velocity_term,
            first_moment,
        };
        evaluate_terms(
            &*source,
            &StrandGeometry::shape(geom),
            &mut buffers,
            input.q,
            input.v,
            &input.field,
            input.terms,
            &mut vectors,
            &mut |which, m| {
                let target = match which {
                    TermMatrix::Mass => &mut *out_mass,
                    TermMatrix::Stiffness => &mut *stiffness,
                    TermMatrix::Damping => &mut *damping,
                    TermMatrix::VelocityTermJacobian => &mut *velocity_term_jacobian,
                };
                store(m, target);
            },
        );
    }

    fn element_ends(&mut self, q: &[f64], ends: &mut [Pose]) {
        strand_terms::element_ends(&self.source, &StrandGeometry::shape(&self.geom), q, ends);
    }

    fn point(
        &mut self,
        q: &[f64],
        s: f64,
        jac: &mut [Vector3<f64>],
        hessian: Option<(Vector3<f64>, &mut Mat<f64>)>,
    ) -> Vector3<f64> {
        point_from_source(
            &self.source,
            &self.geom,
            &mut self.point_ends,
            &mut self.point_derivs,
            Some(&mut self.point_chain),
            q,
            s,
            jac,
            hessian,
        )
    }
}

/// What [`point_from_source`] may keep between calls: the q its scratch `ends` and
/// `end_derivs` were computed for and how many elements of the chain they hold. Points
/// asked in a row at the same q (a strand's contact samples and partners, in arc-length
/// order, at every solve) then chain each element once, not once per point.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct PointChain {
    q: Vec<f64>,
    valid: usize,
}

impl PointChain {
    /// An empty chain for `dofs` coordinates.
    pub(crate) fn new(dofs: usize) -> Self {
        PointChain {
            q: vec![f64::NAN; dofs],
            valid: 0,
        }
    }
}

/// y(s) and J(s) (into `jac`, 3N columns), and c · ∂²y/∂q² added to H when `hessian` is
/// (c, H), for a strand of geometry `geom` at q, from the element points of `source`:
/// the chain of rigid element ends up to the element holding s (`ends`, N + 1 long, and
/// `end_derivs`, N long, are scratch and hold q's values up to that element afterwards).
/// With `chain`, the elements it records for this q are not chained again (the scratch
/// must then be left alone between calls).
#[allow(clippy::too_many_arguments)]
pub(crate) fn point_from_source<S: MomentSource + ?Sized>(
    source: &S,
    geom: &StrandGeometry,
    ends: &mut [Pose],
    end_derivs: &mut [EndDerivatives],
    chain: Option<&mut PointChain>,
    q: &[f64],
    s: f64,
    jac: &mut [Vector3<f64>],
    hessian: Option<(Vector3<f64>, &mut Mat<f64>)>,
) -> Vector3<f64> {
    let root = Pose {
        position: geom.root_position,
        frame: geom.root_frame,
    };
    let chain = chain.map(|c| strand_point::PointChain {
        q: &mut c.q,
        valid: &mut c.valid,
    });
    let (c, mut h) = match hessian {
        Some((c, h)) => (c, Some(h)),
        None => (Vector3::zeros(), None),
    };
    let asked = h.is_some();
    let mut add = |k: usize, l: usize, v: f64| {
        if let Some(h) = h.as_deref_mut() {
            h[(k, l)] += v;
        }
    };
    strand_point::strand_point(
        source,
        &root,
        &geom.lengths,
        ends,
        end_derivs,
        chain,
        q,
        s,
        jac,
        asked.then_some((c, &mut add)),
    )
}
