//! The helix model and its reconstruction: the strand's static description (geometry,
//! material, natural shape, point loads), the closed-form helical element (paper
//! appendix A), the reconstruction of the centreline and frames from q, and the small
//! algebra and quadrature they are built on. Depends on nothing but `nalgebra` and serde.

pub mod element;
pub mod helix_functions;
pub mod jet;
pub mod lanes;
pub mod material;
pub mod quadrature;
pub mod reconstruction;
pub mod strand;
