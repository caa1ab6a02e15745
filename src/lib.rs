//! superhelix facade (interim; replaced by the scene-cli branch)
pub use superhelix_runtime as runtime;
/// Generated kernels, when built.
pub fn kernel_factory() -> Option<&'static dyn superhelix_runtime::KernelFactory> {
    None
}
