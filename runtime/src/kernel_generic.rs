//! placeholder
/// Quadrature of the generic kernel.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum QuadratureRule {
    /// Order adapts to |d|·l per element.
    #[default]
    Adaptive,
    /// Fixed number of Gauss–Legendre points per element.
    Fixed(usize),
}
/// placeholder
pub struct GenericKernel;
/// placeholder
pub struct GenericKernelFactory;
