//! `[[grooms]]`: strands rooted over a scalp region of a body (Poisson-disk roots) or
//! fitted to the curves of a file, optionally started sag-free (`crate::groom`;
//! `docs/grooms.md`).

use super::assembly::{Names, MAX_STRANDS};
use super::reader::{boolean, Bound, Node, Range};
use super::strands::{
    read_template, strand_rng, StrandDefaults, Template, MAX_CURVATURE, MAX_LENGTH,
};
use crate::bodies::{Attachment, Bodies, Body, BodySetup, Placement, Shape};
use crate::config::StrandSetup;
use crate::forces::contacts::{ContactConfig, StrandContacts};
use crate::groom::fit::{fit_curve, FitSettings, FittedCurve};
use crate::groom::read_curves;
use crate::groom::region::{PlaneCut, Region};
use crate::groom::report::{ClearanceReport, CurveReport, GroomReport, GroomSource};
use crate::groom::roots::{root_frame, sample_roots, Root, RootCount, RootSettings};
use crate::groom::sag_free::{groom_kernel, sag_free_natural, sag_free_supported};
use crate::groom::surface::Surface;
use crate::model::reconstruction::sample_centreline;
use crate::model::strand::StrandGeometry;
use nalgebra::{Rotation3, Vector3};
use rand::RngExt;
use rayon::prelude::*;
use std::path::Path;
use std::sync::Arc;
use superhelix_kernels::pose::darboux;

/// Largest root density, roots per m² (a scalp has about 2·10⁶).
pub const MAX_DENSITY: f64 = 1e9;
/// Largest tilt of the root tangent from the surface normal, degrees (excluded).
pub const MAX_TILT_DEG: f64 = 90.0;

/// What grooms need from the rest of the scene.
pub(super) struct GroomContext<'a> {
    /// The scene's bodies.
    pub bodies: &'a [BodySetup],
    /// Gravity in head coordinates at t = 0 (`None`: no gravity).
    pub gravity: Option<Vector3<f64>>,
    /// The scene file's folder: curve files are resolved against it.
    pub scene_dir: &'a Path,
    /// The reports of the grooms read so far.
    pub reports: Vec<GroomReport>,
    /// How far from the surface of its body a groomed strand stays beyond its root zone,
    /// m: the contact radius with `[contacts]`, else 0.
    pub clearance: f64,
    /// The scene's `[contacts]`: a sag-free start lets the bodies carry what they can.
    pub contacts: Option<&'a ContactConfig>,
}

/// Fields of a strand a groom makes itself: refused in a `[[grooms]]` entry of either
/// kind.
const NOT_IN_GROOMS: [(&str, &str); 3] = [
    (
        "direction",
        "a groom's strands leave along the surface normal or the curve: use comb and tilt_deg",
    ),
    ("normal", "a groom sets each root frame's n1 from comb"),
    ("point_loads", "grooms do not take point loads"),
];

/// Fields a curves groom takes from its file: refused in it.
const NOT_WITH_CURVES: [&str; 10] = [
    "length",
    "element_lengths",
    "natural",
    "natural_profile",
    "helix_radius",
    "helix_step",
    "helix_form",
    "q0",
    "initial",
    "curvature_variation",
];

/// Fields of roots on a surface: refused with `curves`.
const SURFACE_ONLY: [&str; 10] = [
    "body",
    "count",
    "density",
    "axis",
    "max_angle_deg",
    "center",
    "cut_normal",
    "cut_point",
    "tilt_deg",
    "length_variation",
];

/// Fields of curves: refused with `body`.
const CURVES_ONLY: [&str; 5] = [
    "curves",
    "scale",
    "rotation_axis_angle_deg",
    "translation",
    "max_fit_error",
];

/// A `[[grooms]]` entry: its strands go to `out`, its report to `ctx.reports`.
pub(super) fn read_groom(
    n: &mut Node<'_>,
    index: usize,
    defaults: &StrandDefaults,
    ctx: &mut GroomContext<'_>,
    names: &mut Names,
    out: &mut Vec<StrandSetup>,
) {
    let name = n.optional("name", format!("groom{index}"), |n, k| {
        n.string(k).map(str::to_string)
    });
    for (key, why) in NOT_IN_GROOMS {
        if n.has(key) {
            n.error(key, why);
        }
    }
    // one kind or the other; with both or neither the entry is read as roots on a
    // surface (so that its fields are checked) and makes no strand
    let has_body = n.has("body");
    let from_curves = n.has("curves") && !has_body;
    let kind_known = has_body != n.has("curves");
    if has_body && !from_curves && n.has("curves") {
        n.error(
            "curves",
            "give either body (roots on a surface) or curves (a file), not both",
        );
    }
    if !kind_known && !has_body {
        n.missing::<()>(
            "body",
            "the name of a body in [[bodies]] to root the strands on (or curves = a file)",
        );
    }
    let refused: Vec<&'static str> = if from_curves {
        SURFACE_ONLY
            .iter()
            .chain(&NOT_WITH_CURVES)
            .copied()
            .collect()
    } else {
        CURVES_ONLY
            .iter()
            .copied()
            .filter(|&k| kind_known || k != "curves")
            .collect()
    };
    let why = if from_curves {
        "not taken by a groom with curves: the roots and shapes come from the file"
    } else {
        "not taken by a groom with body: it applies to curves read from a file"
    };
    for key in refused {
        if n.has(key) {
            n.error(key, why);
        }
    }
    let sag_free = boolean(n, "sag_free", from_curves);
    let defaults = StrandDefaults {
        length_from_data: from_curves,
        ..*defaults
    };
    let built = if from_curves {
        read_curves_groom(n, &defaults, ctx)
    } else {
        read_surface_groom(n, &defaults, ctx)
    };
    let (Some(name), Some(sag_free), Some((template, source)), true) =
        (name, sag_free, built, kind_known)
    else {
        return;
    };
    let seed = template.seed.unwrap_or(index as u64);
    let (strands, source, clearance) = match source {
        Built::Surface {
            body,
            roots,
            length_variation,
            comb,
            tilt,
        } => {
            if !claim(n, names, roots.roots.len(), "count") {
                return;
            }
            let shape = match ctx
                .bodies
                .iter()
                .find(|b| b.name == body)
                .map(|b| Bodies::build(std::slice::from_ref(b)))
            {
                Some(Ok(built)) => built.as_slice()[0].shape.clone(),
                Some(Err(e)) => {
                    n.error("body", e.to_string());
                    return;
                }
                None => {
                    n.error("body", format!("no body named '{body}' in [[bodies]]"));
                    return;
                }
            };
            let mut clearance = ClearanceReport {
                clearance: ctx.clearance,
                lifted: 0,
                aimed: 0,
                max_roll_deg: 0.0,
                max_lift_deg: 0.0,
                entering: 0,
            };
            let mut strands = Vec::with_capacity(roots.roots.len());
            for (k, root) in roots.roots.iter().enumerate() {
                let strand_name = format!("{name}_{k}");
                names.claim(n, &strand_name);
                let mut rng = strand_rng(seed, 1 + k as u64);
                let Some(mut s) =
                    template.build(strand_name, name.clone(), root.position, &mut rng)
                else {
                    return;
                };
                s.strand.geometry.root_frame = root.frame;
                if length_variation > 0.0 {
                    let factor = 1.0 + length_variation * rng.random_range(-1.0..=1.0);
                    for l in &mut s.strand.geometry.lengths {
                        *l *= factor;
                    }
                }
                strands.push(s);
            }
            let lifts: Vec<Option<Lift>> = strands
                .par_iter_mut()
                .zip(&roots.roots)
                .map(|(s, root)| lift(&shape, s, root, &comb, tilt, ctx.clearance))
                .collect();
            for l in lifts {
                match l {
                    Some(l) if l.roll == 0.0 && l.tilt == 0.0 && !l.aimed => {}
                    Some(l) => {
                        clearance.lifted += 1;
                        clearance.aimed += usize::from(l.aimed);
                        clearance.max_roll_deg = clearance.max_roll_deg.max(l.roll.to_degrees());
                        clearance.max_lift_deg = clearance.max_lift_deg.max(l.tilt.to_degrees());
                    }
                    None => clearance.entering += 1,
                }
            }
            let source = GroomSource::Surface {
                body,
                area: roots.area,
                min_spacing: roots.min_spacing,
                packing_spacing: roots.packing_spacing,
            };
            (strands, source, Some(clearance))
        }
        Built::Curves { path, fits } => {
            if !claim(n, names, fits.len(), "curves") {
                return;
            }
            let mut strands = Vec::with_capacity(fits.len());
            let mut reports = Vec::with_capacity(fits.len());
            let elements = fits.first().map_or(0, |(_, _, f)| f.lengths.len());
            for (k, (origin, points, fit)) in fits.into_iter().enumerate() {
                let strand_name = format!("{name}_{k}");
                names.claim(n, &strand_name);
                let mut rng = strand_rng(seed, 1 + k as u64);
                let Some(mut s) =
                    template.build(strand_name.clone(), name.clone(), fit.root, &mut rng)
                else {
                    return;
                };
                s.strand.geometry = StrandGeometry::new(
                    fit.root,
                    fit.frame,
                    fit.lengths.clone(),
                    &s.strand.material,
                );
                s.strand.natural = fit.q.clone();
                s.q0 = fit.q.clone();
                reports.push(CurveReport {
                    strand: strand_name,
                    origin,
                    points,
                    length: fit.length,
                    polyline_length: fit.polyline_length,
                    error: fit.error,
                });
                strands.push(s);
            }
            let source = GroomSource::Curves {
                path,
                elements,
                curves: reports,
            };
            (strands, source, None)
        }
    };
    let mut strands = strands;
    let (sag_free_change, sag_free_carried) = if sag_free {
        match apply_sag_free(n, &mut strands, ctx) {
            Some((change, carried)) => (Some(change), carried),
            None => return,
        }
    } else {
        (None, None)
    };
    ctx.reports.push(GroomReport {
        name,
        strands: strands.len(),
        source,
        sag_free_change,
        sag_free_carried,
        clearance,
    });
    out.extend(strands);
}

/// Step of the tilt reduction of [`lift`], radians.
const LIFT_STEP: f64 = 2.5 * std::f64::consts::PI / 180.0;
/// Step of the roll of [`lift`], radians.
const ROLL_STEP: f64 = 15.0 * std::f64::consts::PI / 180.0;

/// How [`lift`] turned a root frame: a roll about the root tangent and a reduction of
/// the tilt, radians.
#[derive(Debug, Clone, Copy)]
struct Lift {
    roll: f64,
    tilt: f64,
    /// Whether the helix axis was aimed where the groom aims the tangent.
    aimed: bool,
}

/// Whether the centreline of `s` (its q0) stays at least `clearance` from the surface of
/// `shape` beyond its root zone: the points from the root on that are within the
/// clearance, up to the first that is not and at most a quarter of the length (the
/// contacts' root zone, which does not touch the body the strand grows from).
fn clears(shape: &Shape, s: &StrandSetup, clearance: f64, points: &mut Vec<Vector3<f64>>) -> bool {
    const PER_ELEMENT: usize = 8;
    sample_centreline(&s.strand.geometry, &s.q0, PER_ELEMENT, points);
    let quarter = 0.25 * s.strand.geometry.lengths.iter().sum::<f64>();
    let mut arc = 0.0;
    let mut in_zone = true;
    let mut k = 0;
    for &l in &s.strand.geometry.lengths {
        for j in 1..=PER_ELEMENT {
            k += 1;
            let s_k = arc + l * j as f64 / PER_ELEMENT as f64;
            let d = shape.query(&points[k]).distance;
            if in_zone && (d >= clearance || s_k > quarter) {
                in_zone = false;
            }
            if !in_zone && d < clearance {
                return false;
            }
        }
        arc += l;
    }
    true
}

/// Keep a groomed strand out of the body it grows from. A curl leaves its root tangent
/// sideways (the axis of a helix of curvature κ and torsion τ, its Darboux vector, is at
/// atan(κ/τ) from its tangent), so a wavy or curly strand combed along its scalp, or
/// even standing along the normal, can curl back into it. When the groomed shape does
/// not [`clears`] the body, these root frames are tried in turn, and the first that clears
/// is kept:
///
/// 1. the groomed frame rolled about the root tangent by ±15°, ±30°, … up to 180° (which
///    side the curl goes to is set by the roll, which the groom does not prescribe);
/// 2. the frame that aims the axis of the first element's helix (its Darboux vector)
///    where the groom aims the tangent (the normal tilted towards the comb), rolled about
///    that direction by 0°, ±15°, … up to 180°: the curl winds around the groomed
///    direction instead of leaving it;
/// 3. both again with the tilt reduced by 2.5°, 5°, … towards the normal.
///
/// Returns what was turned (zero: as groomed), or `None` when nothing clears (the
/// strand is left as groomed).
fn lift(
    shape: &Shape,
    s: &mut StrandSetup,
    root: &Root,
    comb: &Vector3<f64>,
    tilt: f64,
    clearance: f64,
) -> Option<Lift> {
    let mut points = Vec::new();
    if clears(shape, s, clearance, &mut points) {
        return Some(Lift {
            roll: 0.0,
            tilt: 0.0,
            aimed: false,
        });
    }
    let groomed = s.strand.geometry.root_frame;
    let tilt_steps = (tilt / LIFT_STEP).ceil() as usize;
    let rolls = (std::f64::consts::PI / ROLL_STEP).round() as usize;
    // the first element's helix axis in the root frame (none for a straight element)
    let omega = darboux(&s.q0, 0);
    let axis = (omega.norm() > 0.0).then(|| omega.normalize());
    for k in 0..=tilt_steps {
        let t = (tilt - k as f64 * LIFT_STEP).max(0.0);
        let frame = root_frame(&root.normal, comb, t);
        let direction = frame.column(0).into_owned();
        // the same frame turned so that the helix axis is where the tangent was
        let aimed = axis.map(|a| {
            let from = frame * a;
            match Rotation3::rotation_between(&from, &direction) {
                Some(r) => r.into_inner() * frame,
                // the axis opposite the direction: a half turn about n1
                None => {
                    Rotation3::from_axis_angle(
                        &nalgebra::Unit::new_normalize(frame.column(1).into_owned()),
                        std::f64::consts::PI,
                    )
                    .into_inner()
                        * frame
                }
            }
        });
        for (is_aimed, base) in [(false, Some(frame)), (true, aimed)] {
            let Some(base) = base else { continue };
            for r in 0..=rolls {
                for sign in [1.0, -1.0] {
                    if sign < 0.0 && (r == 0 || r == rolls) {
                        continue;
                    }
                    let phi = sign * r as f64 * ROLL_STEP;
                    let turn =
                        Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(direction), phi);
                    s.strand.geometry.root_frame = turn.into_inner() * base;
                    if clears(shape, s, clearance, &mut points) {
                        return Some(Lift {
                            roll: phi.abs(),
                            tilt: tilt - t,
                            aimed: is_aimed,
                        });
                    }
                }
            }
        }
    }
    s.strand.geometry.root_frame = groomed;
    None
}

/// Count `count` more strands against the cap; an error on `field` when over it.
fn claim(n: &Node<'_>, names: &mut Names, count: usize, field: &str) -> bool {
    if names.count + count > MAX_STRANDS {
        n.error(
            field,
            format!("{count} strands would bring the scene over the cap of {MAX_STRANDS} strands"),
        );
        names.count += count;
        return false;
    }
    true
}

/// What a groom's own fields give before its strands are made.
enum Built {
    Surface {
        body: String,
        roots: crate::groom::roots::Roots,
        length_variation: f64,
        comb: Vector3<f64>,
        tilt: f64,
    },
    Curves {
        path: String,
        /// Each curve's origin, number of points and fit.
        fits: Vec<(String, usize, FittedCurve)>,
    },
}

/// The natural curvatures of every strand made sag-free at its q0 (with `[contacts]`, the
/// bodies carrying what they can: [`sag_free_supported`]); the largest change, and with
/// contacts the share of the weight the bodies carry.
fn apply_sag_free(
    n: &Node<'_>,
    strands: &mut [StrandSetup],
    ctx: &GroomContext<'_>,
) -> Option<(f64, Option<f64>)> {
    let Some(g) = ctx.gravity else {
        return Some((0.0, None));
    };
    // the bodies the strands touch, at rest (t = 0, the head at its rest pose)
    let touched = ctx.contacts.and_then(|c| {
        let bodies: Vec<BodySetup> = ctx
            .bodies
            .iter()
            .filter(|b| c.touches(&b.name))
            .cloned()
            .collect();
        let built = Bodies::build(&bodies).ok()?;
        let arc: Arc<[Body]> = built.as_slice().iter().cloned().collect();
        (!arc.is_empty()).then_some((c, arc))
    });
    let solved: Vec<(Vec<f64>, f64, f64)> = strands
        .par_iter()
        .map(|s| {
            let weight = s.strand.material.mass_per_length
                * g.norm()
                * s.strand.geometry.lengths.iter().sum::<f64>();
            match &touched {
                None => (sag_free_natural(&s.strand, &s.q0, &g), 0.0, weight),
                Some((c, bodies)) => {
                    let geom = &s.strand.geometry;
                    let rho_s = s.strand.material.mass_per_length;
                    let mut contacts = StrandContacts::new(
                        geom,
                        bodies.clone(),
                        c.params(rho_s),
                        None,
                        c.samples_per_element,
                        c.free_ends(
                            s.strand.ends.root == crate::model::ends::RootEnd::Free,
                            s.tip.is_none(),
                        ),
                    );
                    let at = Placement::at_rest(0.0);
                    contacts.start(&at, geom, &s.q0);
                    let mut kernel = groom_kernel(geom);
                    let supports = contacts.support_directions(&at, kernel.as_mut(), &s.q0);
                    let supported = sag_free_supported(&s.strand, &s.q0, &g, &supports);
                    let carried: f64 = supported.forces.iter().sum();
                    (supported.natural, carried, weight)
                }
            }
        })
        .collect();
    let (mut carried, mut weight) = (0.0, 0.0);
    let naturals: Vec<Vec<f64>> = solved
        .into_iter()
        .map(|(natural, c, w)| {
            carried += c;
            weight += w;
            natural
        })
        .collect();
    let mut change = 0.0f64;
    for (s, natural) in strands.iter_mut().zip(naturals) {
        if let Some(x) = natural
            .iter()
            .find(|x| !x.is_finite() || x.abs() > MAX_CURVATURE)
        {
            n.error(
                "sag_free",
                format!(
                    "strand '{}' would need a natural curvature of {x:e} rad/m to hold its \
                     shape under gravity, beyond the allowed {MAX_CURVATURE:e}: make it \
                     stiffer or shorter, or set sag_free = false",
                    s.strand.name
                ),
            );
            return None;
        }
        for (old, new) in s.strand.natural.iter().zip(&natural) {
            change = change.max((new - old).abs());
        }
        s.strand.natural = natural;
    }
    let share = touched.map(|_| if weight > 0.0 { carried / weight } else { 0.0 });
    Some((change, share))
}

/// The roots of a groom on a body (fields `body`, `count`/`density`, the region, the
/// comb and tilt) and its template.
fn read_surface_groom(
    n: &mut Node<'_>,
    defaults: &StrandDefaults,
    ctx: &GroomContext<'_>,
) -> Option<(Template, Built)> {
    let body_name = n.string("body").map(str::to_string);
    let count_given = n.has("count");
    let density_given = n.has("density");
    let count = if count_given {
        n.count("count", 1, MAX_STRANDS as i64, "the cap on strands")
            .map(RootCount::Exact)
    } else {
        None
    };
    let density = if density_given {
        n.f64(
            "density",
            Range::new(Bound::Excl(0.0), Bound::Incl(MAX_DENSITY)),
        )
        .map(RootCount::Density)
    } else {
        None
    };
    let center = if n.has("center") {
        n.vec3("center").map(Some)
    } else {
        Some(None)
    };
    let axis = n.optional("axis", Vector3::z(), Node::unit);
    let angle = n.optional_f64(
        "max_angle_deg",
        180.0,
        Range::new(Bound::Excl(0.0), Bound::Incl(180.0)),
    );
    let cut_normal = if n.has("cut_normal") {
        n.unit("cut_normal").map(Some)
    } else {
        Some(None)
    };
    let cut_point = if n.has("cut_point") {
        n.vec3("cut_point").map(Some)
    } else {
        Some(None)
    };
    let comb = n.optional("comb", -Vector3::z(), Node::unit);
    let tilt = n.optional_f64(
        "tilt_deg",
        0.0,
        Range::new(Bound::Incl(0.0), Bound::Excl(MAX_TILT_DEG)),
    );
    let length_variation = n.optional_f64(
        "length_variation",
        0.0,
        Range::new(Bound::Incl(0.0), Bound::Excl(1.0)),
    );
    let template = read_template(n, defaults, false);
    if count_given == density_given {
        let message = if count_given {
            "give either count or density, not both"
        } else {
            "required: count (roots) or density (roots per m^2)"
        };
        n.error("count", message);
        return None;
    }
    if cut_point.is_some_and(|p| p.is_some()) && cut_normal.is_some_and(|c| c.is_none()) {
        n.error(
            "cut_point",
            "needs cut_normal (the side of the plane that is kept)",
        );
        return None;
    }
    let body_name = body_name?;
    let Some(body) = ctx.bodies.iter().find(|b| b.name == body_name) else {
        n.error("body", format!("no body named '{body_name}' in [[bodies]]"));
        return None;
    };
    if body.attached != Attachment::Head {
        n.error(
            "body",
            format!("'{body_name}' is attached to the world: roots move with the head, so the body must be attached = \"head\""),
        );
        return None;
    }
    let surface = match Surface::from_shape(&body.shape) {
        Ok(s) => s,
        Err(message) => {
            n.error("body", format!("'{body_name}': {message}"));
            return None;
        }
    };
    let (count, center, axis, angle, cut_normal, cut_point, comb, tilt, length_variation) = (
        count.or(density)?,
        center?,
        axis?,
        angle?,
        cut_normal?,
        cut_point?,
        comb?,
        tilt?,
        length_variation?,
    );
    let center = center.unwrap_or_else(|| surface.center());
    let region = Region {
        center,
        axis,
        max_angle: angle.to_radians(),
        cut: cut_normal.map(|normal| PlaneCut {
            point: cut_point.unwrap_or(center),
            normal,
        }),
    };
    let settings = RootSettings {
        region,
        count,
        comb,
        tilt: tilt.to_radians(),
        seed: template.seed.unwrap_or(0),
        max_count: MAX_STRANDS,
    };
    match sample_roots(&surface, &settings) {
        Ok(roots) => Some((
            template,
            Built::Surface {
                body: body_name,
                roots,
                length_variation,
                comb,
                tilt: tilt.to_radians(),
            },
        )),
        Err(e) => {
            n.error(e.field, e.message);
            None
        }
    }
}

/// The curves of a groom's file (fields `curves`, `scale`, `rotation_axis_angle_deg`,
/// `translation`, `max_fit_error`), fitted with the template's N, and its template.
fn read_curves_groom(
    n: &mut Node<'_>,
    defaults: &StrandDefaults,
    ctx: &GroomContext<'_>,
) -> Option<(Template, Built)> {
    let path = n.string("curves").map(str::to_string);
    let scale = n.optional_f64("scale", 1.0, Range::new(Bound::Excl(0.0), Bound::Incl(1e6)));
    let rotation = n
        .optional("rotation_axis_angle_deg", Vector3::zeros(), Node::vec3)
        .map(|v| Rotation3::new(v * 1f64.to_radians()).into_inner());
    let translation = n.optional("translation", Vector3::zeros(), Node::vec3);
    let max_error = if n.has("max_fit_error") {
        n.f64(
            "max_fit_error",
            Range::new(Bound::Excl(0.0), Bound::Incl(1.0)),
        )
        .map(Some)
    } else {
        Some(None)
    };
    let comb = if n.has("comb") {
        n.unit("comb").map(Some)
    } else {
        Some(None)
    };
    let template = read_template(n, defaults, false);
    let (path, scale, rotation, translation, max_error, comb) =
        (path?, scale?, rotation?, translation?, max_error?, comb?);
    if path.is_empty() {
        n.error("curves", "must name an .obj or .usda file");
        return None;
    }
    let elements = template.elements()?;
    let curves = match read_curves(&ctx.scene_dir.join(&path)) {
        Ok(c) => c,
        Err(message) => {
            n.error("curves", message);
            return None;
        }
    };
    if curves.len() > MAX_STRANDS {
        n.error(
            "curves",
            format!(
                "'{path}' has {} curves, more than the cap of {MAX_STRANDS} strands",
                curves.len()
            ),
        );
        return None;
    }
    let settings = FitSettings::new(elements);
    let fits: Vec<Result<(String, usize, FittedCurve), String>> = curves
        .par_iter()
        .map(|c| {
            let placed = c.placed(scale, &rotation, &translation);
            fit_curve(&placed, &settings, comb.as_ref())
                .map(|f| (c.origin.clone(), c.points.len(), f))
                .map_err(|e| format!("{}: {e}", c.origin))
        })
        .collect();
    let mut out = Vec::with_capacity(fits.len());
    for fit in fits {
        match fit {
            Ok((origin, points, f)) => {
                let bound = max_error.unwrap_or(crate::groom::DEFAULT_MAX_FIT_ERROR);
                if let Some(why) = f.refusal(bound) {
                    let field = if max_error.is_some() && f.error.max > bound {
                        "max_fit_error"
                    } else {
                        "curves"
                    };
                    n.error(field, format!("{origin}: {why}"));
                    return None;
                }
                if let Some(x) = f.q.iter().find(|x| x.abs() > MAX_CURVATURE) {
                    n.error(
                        "curves",
                        format!(
                            "{origin}: the fit needs a curvature of {x:e} rad/m, beyond the \
                             allowed {MAX_CURVATURE:e} (check scale: the file may not be in metres)"
                        ),
                    );
                    return None;
                }
                if f.length > MAX_LENGTH {
                    n.error(
                        "curves",
                        format!(
                            "{origin}: the curve is {:.3e} m long, more than {MAX_LENGTH} m \
                             (check scale: the file may not be in metres)",
                            f.length
                        ),
                    );
                    return None;
                }
                out.push((origin, points, f));
            }
            Err(message) => {
                n.error("curves", message);
                return None;
            }
        }
    }
    Some((template, Built::Curves { path, fits: out }))
}
