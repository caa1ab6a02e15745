//! The helix model and its reconstruction: the strand's static description (geometry,
//! material, natural shape, point loads), the closed-form helical element (paper
//! appendix A), the reconstruction of the centreline and frames from q, and what they
//! are built on: the helix functions a, b, c, jets, the four-lane algebra ([`lanes`],
//! also the kernels'), Gauss–Legendre rules. Uses no other module of the crate.

pub mod element;
pub mod helix_functions;
pub mod jet;
pub mod lanes;
pub mod material;
pub mod quadrature;
pub mod reconstruction;
pub mod strand;
