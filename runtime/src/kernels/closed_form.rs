//! The generated kernels as the runtime sees them: the closed-form element integrals of
//! `superhelix-generated` ([`ClosedForm`]), assembled by the runtime's
//! [`MomentKernel`], for the numbers of elements that build was generated for
//! ([`sizes()`]: the checked-in list plus `SUPERHELIX_N` at build time).

use crate::kernels::kernel::{KernelFactory, StrandKernel};
use crate::kernels::moments::kernel::MomentKernel;
use crate::model::strand::StrandGeometry;
use superhelix_generated as generated;
pub use superhelix_generated::ClosedForm;

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
