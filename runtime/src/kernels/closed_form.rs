//! The generated kernels as the runtime sees them: the closed-form element integrals of
//! `superhelix-generated` as a [`MomentSource`], assembled by the runtime's
//! [`MomentKernel`], for the numbers of elements that build was generated for
//! ([`sizes()`]: the checked-in list plus `SUPERHELIX_N` at build time).

use crate::kernels::kernel::{KernelFactory, StrandKernel};
use crate::kernels::moments::kernel::{MomentKernel, MomentSource};
use crate::kernels::moments::ElementMoments;
use crate::model::element::{ElementPoint, RotaryPoints};
use crate::model::strand::StrandGeometry;
use nalgebra::Vector3;
use superhelix_generated as generated;

/// Numbers of elements with kernels in this build: [`generated::sizes::CHECKED_IN_SIZES`]
/// and those requested by `SUPERHELIX_N` when it was built.
pub fn sizes() -> Vec<usize> {
    let mut all: Vec<usize> = generated::sizes::CHECKED_IN_SIZES
        .iter()
        .chain(generated::EXTRA_SIZES)
        .copied()
        .collect();
    all.sort_unstable();
    all.dedup();
    all
}

/// The closed-form element integrals and local functions.
#[derive(Debug, Clone, Copy, Default)]
pub struct ClosedForm;

impl MomentSource for ClosedForm {
    fn moments(&self, d: &Vector3<f64>, l: f64, rotary: &[f64; 3], out: &mut ElementMoments) {
        generated::element_moments_into(d, l, rotary, out);
    }
    fn moments_batch(
        &self,
        d: &[Vector3<f64>],
        l: &[f64],
        rotary: &[f64; 3],
        out: &mut [ElementMoments],
    ) {
        generated::element_moments_batch_into(d, l, rotary, out);
    }
    fn point(&self, d: &Vector3<f64>, u: f64, out: &mut ElementPoint) {
        generated::element_point_into(d, u, out);
    }
    fn rotary_point(&self, d: &Vector3<f64>, u: f64, out: &mut ElementPoint) {
        generated::element_rotary_point_into(d, u, out);
    }
    fn rotary_points(&self, d: &Vector3<f64>, u: &[f64], out: &mut RotaryPoints) {
        generated::element_rotary_points_into(d, u, out);
    }
    fn describe(&self) -> String {
        "closed form".to_string()
    }
    fn is_generated(&self) -> bool {
        true
    }
}

/// A generated kernel for one strand.
pub type GeneratedKernel = MomentKernel<ClosedForm>;

/// Creates [`GeneratedKernel`]s for the sizes of this build.
#[derive(Debug, Clone, Copy, Default)]
pub struct GeneratedFactory;

impl KernelFactory for GeneratedFactory {
    fn create(&self, geometry: &StrandGeometry) -> Option<Box<dyn StrandKernel>> {
        let n = geometry.elements();
        sizes().contains(&n).then(|| {
            Box::new(MomentKernel::new(geometry.clone(), ClosedForm)) as Box<dyn StrandKernel>
        })
    }
    fn available(&self) -> Vec<usize> {
        sizes()
    }
}

/// The generated kernels of this build (see [`sizes()`]).
pub fn kernel_factory() -> &'static dyn KernelFactory {
    static FACTORY: GeneratedFactory = GeneratedFactory;
    &FACTORY
}
