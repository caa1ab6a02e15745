//! Strand kernels: the dynamic terms of one strand (paper eq. 4–6: M(q), the forces,
//! their Jacobians) behind the [`StrandKernel`] trait. [`generic`] is the runtime-N
//! kernel (Gauss–Legendre quadrature); [`moments`] assembles a strand from element
//! moments, the path the generated closed forms of `superhelix-generated` feed (any N);
//! [`fixed_kernel`] runs the same assembly on the generated fixed-N code, for the N with a
//! per-N module; [`closed_form`] chooses between the two; [`floating`] wraps any of them
//! for a rod with a free root; [`step_terms`] hands any of them to the step of
//! `superhelix-kernels`.

pub mod closed_form;
pub mod fixed_kernel;
pub mod floating;
pub mod generic;
pub mod kernel;
pub mod moments;
pub mod step_terms;

pub use generic::{GenericKernel, GenericKernelFactory, QuadratureRule};
pub use kernel::{BodyField, EvalInput, KernelFactory, StrandKernel, StrandTerms, Terms};
