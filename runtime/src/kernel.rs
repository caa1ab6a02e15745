//! placeholder
/// placeholder
pub trait KernelFactory {}
/// placeholder
pub trait StrandKernel {}
/// placeholder
pub struct StrandTerms;
/// placeholder
pub struct EvalInput;
/// placeholder
pub struct Terms;
