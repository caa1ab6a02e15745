//! The generated fixed-N code as a runtime kernel: the moment assembly
//! (`superhelix_kernels::strand_terms::evaluate_terms`, paper eq. 4–6) over the buffers of
//! literal size of `superhelix_kernels::fixed::Assembly<N, D, E>`, fed by the generated
//! closed forms ([`ClosedForm`]), for the N that `superhelix-generated` has a per-N module
//! for (`superhelix_generated::fixed`, reached through
//! [`superhelix_generated::visit_size`]). The same terms as
//! [`MomentKernel<ClosedForm>`](crate::kernels::moments::kernel::MomentKernel) (the
//! runtime-N moment path, buffers in `Vec`s), bit for bit.

use crate::kernels::kernel::{EvalInput, StrandKernel, StrandTerms};
use crate::kernels::moments::kernel::{point_from_source, store, PointChain};
use crate::kernels::moments::EndDerivatives;
use crate::model::reconstruction::Pose;
use crate::model::strand::StrandGeometry;
use faer::Mat;
use nalgebra::Vector3;
use superhelix_generated::{ClosedForm, SizeVisitor};
use superhelix_kernels::fixed::Assembly;
use superhelix_kernels::strand_terms::{self, evaluate_terms, TermMatrix, TermVectors};

/// What a fixed-N kernel keeps besides its geometry: the assembly's buffers and the
/// scratch of [`StrandKernel::point`] (apart, so that a point at another q leaves the
/// prepared element data alone).
struct Buffers<const N: usize, const D: usize, const E: usize> {
    assembly: Assembly<N, D, E>,
    point_ends: [Pose; E],
    point_derivs: [EndDerivatives; N],
    point_chain: PointChain,
}

/// A strand kernel on the generated fixed-N code of N elements (D = 3N coordinates,
/// E = N + 1 element ends).
pub struct FixedKernel<const N: usize, const D: usize, const E: usize> {
    geom: StrandGeometry,
    buffers: Box<Buffers<N, D, E>>,
}

impl<const N: usize, const D: usize, const E: usize> FixedKernel<N, D, E> {
    /// A kernel for `geom`, or `None` when the strand does not have N elements (or the
    /// const parameters are not D = 3N, E = N + 1).
    pub fn new(geom: StrandGeometry) -> Option<Self> {
        if geom.elements() != N || D != 3 * N || E != N + 1 {
            return None;
        }
        Some(FixedKernel {
            geom,
            buffers: Box::new(Buffers {
                assembly: Assembly::new(),
                point_ends: [Pose::default(); E],
                point_derivs: [EndDerivatives::default(); N],
                point_chain: PointChain::new(D),
            }),
        })
    }
}

impl<const N: usize, const D: usize, const E: usize> StrandKernel for FixedKernel<N, D, E> {
    fn geometry(&self) -> &StrandGeometry {
        &self.geom
    }

    fn description(&self) -> String {
        format!("generated fixed-N (N = {N})")
    }

    fn is_generated(&self) -> bool {
        true
    }

    fn evaluate(&mut self, input: &EvalInput<'_>, out: &mut StrandTerms) {
        let StrandTerms {
            mass,
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
            &ClosedForm,
            &StrandGeometry::shape(&self.geom),
            &mut self.buffers.assembly.buffers(),
            input.q,
            input.v,
            &input.field,
            input.terms,
            &mut vectors,
            &mut |which, m| {
                let target = match which {
                    TermMatrix::Mass => &mut *mass,
                    TermMatrix::Stiffness => &mut *stiffness,
                    TermMatrix::Damping => &mut *damping,
                    TermMatrix::VelocityTermJacobian => &mut *velocity_term_jacobian,
                };
                store(m, target);
            },
        );
    }

    fn point(
        &mut self,
        q: &[f64],
        s: f64,
        jac: &mut [Vector3<f64>],
        hessian: Option<(Vector3<f64>, &mut Mat<f64>)>,
    ) -> Vector3<f64> {
        let b = &mut *self.buffers;
        point_from_source(
            &ClosedForm,
            &self.geom,
            &mut b.point_ends,
            &mut b.point_derivs,
            Some(&mut b.point_chain),
            q,
            s,
            jac,
            hessian,
        )
    }

    fn element_ends(&mut self, q: &[f64], ends: &mut [Pose]) {
        strand_terms::element_ends(&ClosedForm, &StrandGeometry::shape(&self.geom), q, ends);
    }
}

/// Makes the [`FixedKernel`] of the visited size for one geometry.
struct MakeFixedKernel<'a> {
    geometry: &'a StrandGeometry,
}

impl SizeVisitor for MakeFixedKernel<'_> {
    type Output = Option<Box<dyn StrandKernel>>;
    fn visit<const N: usize, const D: usize, const E: usize, const B: usize>(self) -> Self::Output {
        FixedKernel::<N, D, E>::new(self.geometry.clone())
            .map(|k| Box::new(k) as Box<dyn StrandKernel>)
    }
}

/// The generated fixed-N kernel for `geometry`, when this build has a per-N module for
/// its N ([`superhelix_generated::fixed::SIZES`]).
pub fn fixed_kernel(geometry: &StrandGeometry) -> Option<Box<dyn StrandKernel>> {
    superhelix_generated::visit_size(geometry.elements(), MakeFixedKernel { geometry }).flatten()
}
