//! The generated kernels as the runtime sees them. For an N with a per-N module in
//! `superhelix-generated` ([`sizes()`]: the checked-in sizes and those of `SUPERHELIX_N`
//! at build time) the generated fixed-N code ([`FixedKernel`]); for every other N the
//! runtime-N moment assembly fed by the same generated closed forms
//! ([`MomentKernel<ClosedForm>`](MomentKernel)), never the quadrature-based generic
//! kernel.

use crate::kernels::fixed_kernel::fixed_kernel;
pub use crate::kernels::fixed_kernel::FixedKernel;
use crate::kernels::kernel::{KernelFactory, StrandKernel};
use crate::kernels::moments::kernel::MomentKernel;
use crate::model::strand::StrandGeometry;
pub use superhelix_generated::ClosedForm;

/// Numbers of elements with generated fixed-N code in this build, ascending:
/// `superhelix_generated::sizes::CHECKED_IN_SIZES` and those `SUPERHELIX_N` added when
/// it was built.
pub fn sizes() -> Vec<usize> {
    superhelix_generated::fixed::SIZES.to_vec()
}

/// The moment path: the runtime-N moment assembly fed by the generated closed forms.
pub type GeneratedKernel = MomentKernel<ClosedForm>;

/// The moment path's kernel for `geometry` (any N ≥ 1).
pub fn moment_kernel(geometry: &StrandGeometry) -> Box<dyn StrandKernel> {
    Box::new(MomentKernel::new(geometry.clone(), ClosedForm))
}

/// Creates, for a strand of N elements, the generated fixed-N kernel when this build
/// has a per-N module for N, else the moment path ([`moment_kernel`]). Its
/// [`KernelFactory::available`] lists the N with fixed-N code ([`sizes()`]), which is
/// what `kernels = "generated"` requires.
#[derive(Debug, Clone, Copy, Default)]
pub struct GeneratedFactory;

impl KernelFactory for GeneratedFactory {
    fn create(&self, geometry: &StrandGeometry) -> Option<Box<dyn StrandKernel>> {
        if geometry.elements() == 0 {
            return None;
        }
        Some(fixed_kernel(geometry).unwrap_or_else(|| moment_kernel(geometry)))
    }
    fn available(&self) -> Vec<usize> {
        sizes()
    }
}

/// The generated kernels of this build (see [`GeneratedFactory`]).
pub fn kernel_factory() -> &'static dyn KernelFactory {
    static FACTORY: GeneratedFactory = GeneratedFactory;
    &FACTORY
}
