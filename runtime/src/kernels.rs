//! Strand kernels: the dynamic terms of one strand (paper eq. 4–6: M(q), the forces,
//! their Jacobians) behind the [`StrandKernel`] trait. [`generic`] is the runtime-N
//! kernel (Gauss–Legendre quadrature); [`moments`] assembles a strand from element
//! moments, the path the generated closed forms of `superhelix-generated` feed.

pub mod closed_form;
pub mod generic;
pub mod kernel;
pub mod moments;

pub use generic::{GenericKernel, GenericKernelFactory, QuadratureRule};
pub use kernel::{BodyField, EvalInput, KernelFactory, StrandKernel, StrandTerms, Terms};
