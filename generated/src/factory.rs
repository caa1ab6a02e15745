//! The generated kernels as the runtime sees them: the closed-form element integrals
//! ([`crate::element_moments`]) as a [`MomentSource`], assembled by the runtime's
//! [`MomentKernel`], for the numbers of elements this build was generated for
//! ([`sizes()`]: the checked-in list plus `SUPERHELIX_N` at build time).

use superhelix_runtime::kernels::moments::kernel::{MomentKernel, MomentSource};
use superhelix_runtime::kernels::moments::ElementMoments;
use superhelix_runtime::model::element::{ElementPoint, RotaryPoints};
use superhelix_runtime::{KernelFactory, StrandGeometry, StrandKernel, Vector3};

include!(concat!(env!("OUT_DIR"), "/extra_sizes.rs"));

/// Numbers of elements with kernels in this build: [`crate::sizes::CHECKED_IN_SIZES`]
/// and those requested by `SUPERHELIX_N` when it was built.
pub fn sizes() -> Vec<usize> {
    let mut all: Vec<usize> = crate::sizes::CHECKED_IN_SIZES
        .iter()
        .chain(EXTRA_SIZES)
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
        crate::element_moments_into(d, l, rotary, out);
    }
    fn moments_batch(
        &self,
        d: &[Vector3<f64>],
        l: &[f64],
        rotary: &[f64; 3],
        out: &mut [ElementMoments],
    ) {
        crate::element_moments_batch_into(d, l, rotary, out);
    }
    fn point(&self, d: &Vector3<f64>, u: f64, out: &mut ElementPoint) {
        crate::element_point_into(d, u, out);
    }
    fn rotary_point(&self, d: &Vector3<f64>, u: f64, out: &mut ElementPoint) {
        crate::element_rotary_point_into(d, u, out);
    }
    fn rotary_points(&self, d: &Vector3<f64>, u: &[f64], out: &mut RotaryPoints) {
        crate::element_rotary_points_into(d, u, out);
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
