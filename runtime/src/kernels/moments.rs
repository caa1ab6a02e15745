//! The moment-based assembly of a strand's terms (docs/moment-assembly.md): the element
//! moments and the assembly live in `superhelix-kernels` (no_std, shared with the
//! generated fixed-N kernels) and are re-exported here; [`kernel::MomentKernel`] is the
//! runtime-N kernel built on them, fed by the generated closed forms or by quadrature.

pub use superhelix_kernels::moments::*;

pub mod kernel;
