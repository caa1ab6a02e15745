//! The helix model and its reconstruction: the strand's static description (geometry,
//! material and its dependence on the air's humidity, natural shape, point loads), the
//! closed-form helical element (paper appendix A), the reconstruction of the centreline
//! and frames from q and their velocities ([`kinematics`]), and what they are built on: the helix functions a, b, c, jets, the
//! four-lane algebra ([`lanes`], also the kernels'), Gauss–Legendre rules. Uses no other
//! module of the crate.

pub use superhelix_kernels::{element, helix_functions, jet, lanes, quadrature};
pub mod ends;
pub mod humidity;
pub mod kinematics;
pub mod material;
pub mod reconstruction;
pub mod strand;
