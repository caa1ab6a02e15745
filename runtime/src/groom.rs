//! Grooms: many strands made at once, rooted over a scalp region of a body or read from
//! curve files, and optionally started in equilibrium.
//!
//! A strand is clamped at its root to the head by a position and a material frame
//! (n0, n1, n2), and its shape is the twist and curvatures q of its N helical elements
//! (Bertails et al. 2006, section 3.1, eq. 1–3; the reconstruction of section 3.2 and
//! appendix A). A groom makes these for many strands:
//!
//! - **roots on a surface** ([`roots`]): Poisson-disk positions over a region
//!   ([`region`]: a cap around an axis and an optional plane cut) of a sphere, an
//!   ellipsoid, a capsule or a closed mesh ([`surface`]), by weighted sample elimination
//!   ([`poisson`]), with frames from the surface normal (optionally tilted) and a
//!   combing direction;
//! - **curves from files** ([`curves`]: OBJ polylines, [`curves_obj`]; USD `BasisCurves`
//!   in text form, [`curves_usda`]), each made a Super-Helix by fitting q, the length
//!   and the root tangent to its points ([`fit`]), with the fit's error reported;
//! - **a sag-free start** ([`sag_free`]): natural curvatures solved so that the shape is
//!   an equilibrium under gravity (inverse statics, `q_n = q − K⁻¹ G(q)`).
//!
//! The scene table `[[grooms]]` (`docs/scene-format.md`, `docs/grooms.md`) puts these
//! together; [`GroomReport`] is what it reports of each groom.

pub mod curves;
pub mod curves_obj;
pub mod curves_usda;
pub mod fit;
pub mod poisson;
pub mod region;
pub mod report;
pub mod roots;
pub mod sag_free;
pub mod surface;

pub use curves::Curve;
pub use fit::{
    fit_curve, FitError, FitSettings, FittedCurve, DEFAULT_MAX_FIT_ERROR, MAX_LENGTH_MISMATCH,
};
pub use report::{ClearanceReport, CurveReport, GroomReport, GroomSource};
pub use roots::{sample_roots, Root, RootCount, RootSettings, Roots};
pub use sag_free::sag_free_natural;
pub use surface::Surface;

use std::path::Path;

/// The curves of an `.obj` or `.usda` file, by its extension (case-insensitive). The
/// error names the file (and the line, for a malformed file).
pub fn read_curves(path: &Path) -> Result<Vec<Curve>, String> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("obj") => curves_obj::read_obj_curves(path),
        Some("usda") => curves_usda::read_usda_curves(path),
        _ => Err(format!(
            "'{}': curves are read from .obj (polylines) or .usda (BasisCurves) files",
            path.display()
        )),
    }
}

#[cfg(test)]
mod tests;
