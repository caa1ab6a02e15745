//! What a scene reports of its grooms: for roots on a surface, their number, the
//! region's area and their spacing; for curves, each curve's fit error; for both, how
//! far the sag-free start moved the natural curvatures.

use super::fit::FitError;
use std::fmt;

/// The fit of one curve.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveReport {
    /// Name of the strand made from it.
    pub strand: String,
    /// Where the curve comes from (`'curls.obj' line 12`).
    pub origin: String,
    /// Points of the curve.
    pub points: usize,
    /// Fitted length, m.
    pub length: f64,
    /// Length of the curve's polyline, m.
    pub polyline_length: f64,
    /// The fit's error, relative to the length.
    pub error: FitError,
}

/// Where a groom's strands come from.
#[derive(Debug, Clone, PartialEq)]
pub enum GroomSource {
    /// Roots sampled on a body's surface.
    Surface {
        /// The body's name.
        body: String,
        /// Area of the region, m².
        area: f64,
        /// Smallest distance between two roots, m.
        min_spacing: f64,
        /// Spacing of the hexagonal packing of as many roots on the area, m.
        packing_spacing: f64,
    },
    /// A `[[strands]]` entry's `polyline`, fitted.
    Polyline {
        /// Elements of the strand.
        elements: usize,
        /// The fit.
        curve: CurveReport,
    },
    /// Curves read from a file and fitted.
    Curves {
        /// The file, as the scene names it.
        path: String,
        /// Elements per strand.
        elements: usize,
        /// Each curve's fit.
        curves: Vec<CurveReport>,
    },
}

/// What a scene reports of one `[[grooms]]` entry.
#[derive(Debug, Clone, PartialEq)]
pub struct GroomReport {
    /// The groom's name (the group of its strands).
    pub name: String,
    /// Number of strands made.
    pub strands: usize,
    /// Where they come from.
    pub source: GroomSource,
    /// With a sag-free start: the largest change of a natural curvature or twist, rad/m
    /// (`None` without it; 0 without gravity).
    pub sag_free_change: Option<f64>,
    /// With a sag-free start and `[contacts]`: the share of the groom's weight that the
    /// bodies carry at rest (0 to 1; `None` otherwise).
    pub sag_free_carried: Option<f64>,
    /// Roots on a surface: how their strands were kept out of the body they grow from.
    pub clearance: Option<ClearanceReport>,
}

/// How the strands of a groom on a surface were kept out of its body: a strand whose
/// groomed shape enters the body (closer to its surface than the clearance beyond its
/// root zone) has its root frame rolled about the root tangent, and if need be its tilt
/// reduced, by as little as clears it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClearanceReport {
    /// Clearance from the surface, m (the contact radius with `[contacts]`, else 0).
    pub clearance: f64,
    /// Strands whose root frame was turned.
    pub lifted: usize,
    /// Of those, the strands whose helix axis was aimed where the groom aims the tangent.
    pub aimed: usize,
    /// The largest roll of a root frame about its tangent, degrees.
    pub max_roll_deg: f64,
    /// The largest reduction of a tilt, degrees.
    pub max_lift_deg: f64,
    /// Strands that enter the body even along the normal (left as groomed).
    pub entering: usize,
}

impl GroomReport {
    /// The largest RMS and the largest maximum fit error over the curves (relative to
    /// each curve's length), and the index of the curve with the largest maximum;
    /// `None` for roots on a surface.
    pub fn worst_fit(&self) -> Option<(f64, f64, usize)> {
        let curves = match &self.source {
            GroomSource::Curves { curves, .. } => &curves[..],
            GroomSource::Polyline { curve, .. } => std::slice::from_ref(curve),
            GroomSource::Surface { .. } => return None,
        };
        let mut worst = (0.0f64, 0.0f64, 0usize);
        for (k, c) in curves.iter().enumerate() {
            worst.0 = worst.0.max(c.error.rms);
            if c.error.max > worst.1 {
                worst.1 = c.error.max;
                worst.2 = k;
            }
        }
        Some(worst)
    }
}

impl fmt::Display for GroomReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let GroomSource::Polyline { elements, curve } = &self.source {
            return write!(
                f,
                "strand '{}': fitted to its polyline of {} points with N = {elements}: length \
                 {:.6e} m (the polyline's {:.6e} m), fit error (relative to the length) RMS \
                 {:.2e}, max {:.2e} (point {})",
                curve.strand,
                curve.points,
                curve.length,
                curve.polyline_length,
                curve.error.rms,
                curve.error.max,
                curve.error.worst_point
            );
        }
        write!(f, "groom '{}': {} strands", self.name, self.strands)?;
        match &self.source {
            GroomSource::Polyline { .. } => {}
            GroomSource::Surface {
                body,
                area,
                min_spacing,
                packing_spacing,
            } => write!(
                f,
                " on '{body}' over {:.1} cm^2, closest roots {:.2} mm apart ({:.2} of the \
                 hexagonal packing's {:.2} mm)",
                area * 1e4,
                min_spacing * 1e3,
                min_spacing / packing_spacing,
                packing_spacing * 1e3
            )?,
            GroomSource::Curves {
                path,
                elements,
                curves,
            } => {
                let (rms, max, k) = self.worst_fit().unwrap_or_default();
                let mean_rms =
                    curves.iter().map(|c| c.error.rms).sum::<f64>() / curves.len().max(1) as f64;
                write!(
                    f,
                    " fitted to the curves of '{path}' with N = {elements}: fit error \
                     (relative to the length) RMS {mean_rms:.2e} on average, {rms:.2e} at \
                     most; max {max:.2e}"
                )?;
                if let Some(c) = curves.get(k) {
                    write!(f, " ({}, {})", c.strand, c.origin)?;
                }
            }
        }
        if let Some(c) = &self.clearance {
            if c.lifted > 0 {
                write!(
                    f,
                    "; {} root frames turned ({} with the curl's axis along the groomed direction; rolled by up to {:.0} deg, tilt reduced by up to {:.1} deg) to clear the body by {:.2} mm",
                    c.lifted,
                    c.aimed,
                    c.max_roll_deg,
                    c.max_lift_deg,
                    c.clearance * 1e3
                )?;
            }
            if c.entering > 0 {
                write!(
                    f,
                    "; {} strands enter the body even along the normal (left as groomed)",
                    c.entering
                )?;
            }
        }
        if let Some(change) = self.sag_free_change {
            write!(
                f,
                "; sag-free: natural curvatures changed by up to {change:.3e} rad/m"
            )?;
        }
        match self.sag_free_carried {
            Some(carried) => write!(
                f,
                ", {:.1} % of the weight carried by the bodies",
                100.0 * carried
            ),
            None => Ok(()),
        }
    }
}
