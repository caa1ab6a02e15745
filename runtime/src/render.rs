//! Render strands from guides (Bertails et al. 2006, section 4.1 and Figure 4): the
//! simulated strands are sparse guides; the hair that is drawn is generated from them at
//! every frame by a semi-interpolating scheme, interpolated near the scalp and clumped
//! near the tips, with no interpolation between guides whose tips are far apart.
//!
//! - [`settings`]: what the scene's `[render]` table asks for ([`RenderSettings`]) and
//!   the clumping profile along a strand.
//! - [`render_roots`]: the render roots, placed once (seeded) among the guide roots by a
//!   local triangulation, with their guides and blend weights ([`RenderRoots`]).
//! - [`semi_interpolation`]: the per-frame blend ([`SemiInterpolation`]): allocation-free,
//!   in parallel over render strands, f32 output.
//! - [`clearance`]: the render strands kept out of the scene's bodies ([`KeepOut`]), and
//!   [`clearance_bodies`]: how each body pushes a point out.
//! - [`neighbours`]: nearest guide roots through a grid of cells.
//!
//! `docs/interpolation.md` describes the model and its parameters.

pub mod clearance;
pub mod clearance_bodies;
mod lanes;
pub mod neighbours;
pub mod render_roots;
pub mod semi_interpolation;
pub mod settings;

pub use clearance::KeepOut;
pub use render_roots::{RenderRoot, RenderRoots, RootSites};
pub use semi_interpolation::SemiInterpolation;
pub use settings::RenderSettings;

#[cfg(test)]
mod tests;
