//! The strands of a scene: `[[strands]]` entries one by one, `[[patches]]` as grids of
//! identical strands, `[[tresses]]` as fibres over an elliptic cross-section,
//! `[[scalp_hair]]` on a sphere or ellipsoid, `[[grooms]]` (`super::groom`); names, seeds
//! and the caps on their number.

use super::groom::{read_groom, GroomContext};
use super::reader::{Bound, Node, Range};
use super::strands::{read_template, strand_rng, StrandDefaults, Template, MAX_CURVATURE};
use crate::bodies::{BodySetup, ShapeSetup};
use crate::config::StrandSetup;
use crate::groom::fit::{fit_curve, FitSettings};
use crate::groom::report::{CurveReport, GroomReport, GroomSource};
use crate::model::strand::StrandGeometry;
use nalgebra::Vector3;
use std::collections::HashMap;

/// Most strands a scene may have (all patches included).
pub const MAX_STRANDS: usize = 150_000;
/// Most strands along one side of a patch.
const MAX_PATCH_SIDE: i64 = 1_000;

/// The strands of `[[strands]]` then of `[[patches]]`, in order. Problems are recorded
/// on the nodes; the result then lacks the invalid strands.
pub(super) fn read_strands(
    root: &mut Node<'_>,
    defaults: &StrandDefaults,
    grooms: &mut GroomContext<'_>,
) -> Vec<StrandSetup> {
    let bodies = grooms.bodies;
    let mut names = Names::default();
    let mut out = Vec::new();
    for (i, mut n) in root.tables("strands").into_iter().enumerate() {
        let name = n.optional("name", format!("strand{i}"), |n, k| {
            n.string(k).map(str::to_string)
        });
        let group = read_group(&mut n);
        let polyline = read_polyline(&mut n);
        let root_position = n.optional("root", Vector3::zeros(), Node::position);
        // a polyline gives the length (its fit's), the root and the root frame
        let from_polyline = StrandDefaults {
            length_from_data: true,
            ..*defaults
        };
        let has_polyline = matches!(polyline, Some(Some(_)));
        let template = read_template(
            &mut n,
            if has_polyline {
                &from_polyline
            } else {
                defaults
            },
            true,
        );
        let ends = super::ends::read_ends(&mut n);
        if let (Some(name), Some(group), Some(polyline)) = (name, group, polyline) {
            names.claim(&n, &name);
            let group = group.unwrap_or_else(|| name.clone());
            let mut rng = strand_rng(template.seed.unwrap_or(i as u64), 0);
            let built = match polyline {
                Some(points) => {
                    fit_polyline(&mut n, &template, name, group, points, &mut rng, grooms)
                }
                None => root_position.and_then(|r| template.build(name, group, r, &mut rng)),
            };
            if let (Some(mut setup), Some(ends)) = (built, ends) {
                ends.apply(&n, &mut setup);
                out.push(setup);
            }
        }
        n.finish();
    }
    for (i, mut n) in root.tables("patches").into_iter().enumerate() {
        read_patch(&mut n, i, defaults, &mut names, &mut out);
        n.finish();
    }
    for (i, mut n) in root.tables("tresses").into_iter().enumerate() {
        read_tress(&mut n, i, defaults, &mut names, &mut out);
        n.finish();
    }
    for (i, mut n) in root.tables("scalp_hair").into_iter().enumerate() {
        read_scalp_hair(&mut n, i, defaults, bodies, &mut names, &mut out);
        n.finish();
    }
    for (i, mut n) in root.tables("grooms").into_iter().enumerate() {
        read_groom(&mut n, i, defaults, grooms, &mut names, &mut out);
        n.finish();
    }
    if names.count == 0 {
        root.error(
            "strands",
            "the scene has no strands: add [[strands]], [[patches]], [[tresses]], [[scalp_hair]] or [[grooms]]",
        );
    } else if names.count > MAX_STRANDS {
        let msg = format!(
            "{} strands in total, more than the cap of {MAX_STRANDS}",
            names.count
        );
        root.error("strands", msg);
    }
    out
}

/// Fields a `polyline` replaces.
const NOT_WITH_POLYLINE: [&str; 8] = [
    "root",
    "direction",
    "length",
    "element_lengths",
    "q0",
    "initial",
    "natural_profile",
    "curvature_variation",
];

/// The optional `polyline = [[x, y, z], ...]` of a `[[strands]]` entry (head coordinates,
/// m, root first): `Some(None)` when absent, `None` when invalid (reported).
fn read_polyline(n: &mut Node<'_>) -> Option<Option<Vec<Vector3<f64>>>> {
    let Some(value) = n.raw("polyline") else {
        return Some(None);
    };
    let toml::Value::Array(items) = value else {
        n.error(
            "polyline",
            "expected a list of points [x, y, z] in metres, root first",
        );
        return None;
    };
    for key in NOT_WITH_POLYLINE {
        if n.has(key) {
            n.error(
                key,
                "not with polyline: the polyline gives the root, the root frame, the length and the starting shape",
            );
        }
    }
    let mut points = Vec::with_capacity(items.len());
    for (k, item) in items.iter().enumerate() {
        let p = match item {
            toml::Value::Array(c) if c.len() == 3 => c
                .iter()
                .map(|x| match x {
                    toml::Value::Float(f) => Some(*f),
                    toml::Value::Integer(i) => Some(*i as f64),
                    _ => None,
                })
                .collect::<Option<Vec<f64>>>(),
            _ => None,
        };
        match p {
            Some(c) if c.iter().all(|x| x.is_finite() && x.abs() <= MAX_COORDINATE) => {
                points.push(Vector3::new(c[0], c[1], c[2]))
            }
            _ => {
                n.error(
                    &format!("polyline[{k}]"),
                    format!("expected [x, y, z], three finite numbers within ±{MAX_COORDINATE} m"),
                );
                return None;
            }
        }
    }
    if points.len() < 2 || points.len() > MAX_POLYLINE_POINTS {
        n.error(
            "polyline",
            format!(
                "{} points; allowed 2 to {MAX_POLYLINE_POINTS}",
                points.len()
            ),
        );
        return None;
    }
    Some(Some(points))
}

/// Most points of a `polyline`.
pub const MAX_POLYLINE_POINTS: usize = 100_000;
/// Largest |coordinate| of a polyline's point, m.
const MAX_COORDINATE: f64 = 1e3;

/// The strand of a `[[strands]]` entry with a `polyline`: the Super-Helix of the entry's
/// N elements closest to it ([`fit_curve`]: root at the first point, length and root
/// frame fitted, `normal` the root's n1 when given), starting in that shape, with the
/// entry's rest shape (its `natural`, helix or preset: straight by default). The fit
/// error is reported with the grooms'.
fn fit_polyline(
    n: &mut Node<'_>,
    template: &Template,
    name: String,
    group: String,
    points: Vec<Vector3<f64>>,
    rng: &mut rand_chacha::ChaCha8Rng,
    grooms: &mut GroomContext<'_>,
) -> Option<StrandSetup> {
    let elements = template.elements()?;
    let max_error = if n.has("max_fit_error") {
        n.f64(
            "max_fit_error",
            Range::new(Bound::Excl(0.0), Bound::Incl(1.0)),
        )?
    } else {
        crate::groom::DEFAULT_MAX_FIT_ERROR
    };
    let count = points.len();
    let polyline_length: f64 = points.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
    if polyline_length > super::strands::MAX_LENGTH {
        n.error(
            "polyline",
            format!(
                "{polyline_length:.4e} m long, more than a strand may be ({} m): check the units (metres)",
                super::strands::MAX_LENGTH
            ),
        );
        return None;
    }
    let curve = crate::groom::curves::Curve {
        points,
        origin: n.path("polyline"),
    };
    let hint = template.frame.map(|f| f.column(1).into_owned());
    if let (true, Some(h)) = (n.has("normal"), hint.as_ref()) {
        // the first segment of nonzero length
        let first = curve
            .points
            .windows(2)
            .map(|w| w[1] - w[0])
            .find(|d| d.norm() > 0.0);
        if let Some(t) = first {
            let t = t.normalize();
            if (h - t * t.dot(h)).norm() < 1e-6 {
                n.error(
                    "normal",
                    "along the polyline's first segment: the root's n1 must be across the strand",
                );
                return None;
            }
        }
    }
    let fit = match fit_curve(&curve, &FitSettings::new(elements), hint.as_ref()) {
        Ok(f) => f,
        Err(e) => {
            n.error("polyline", e);
            return None;
        }
    };
    if let Some(why) = fit.refusal(max_error) {
        let field = if (fit.length - fit.polyline_length).abs()
            <= crate::groom::MAX_LENGTH_MISMATCH * fit.polyline_length
            && n.has("max_fit_error")
        {
            "max_fit_error"
        } else {
            "polyline"
        };
        n.error(field, why);
        return None;
    }
    if let Some(loads) = &template.point_loads {
        let mut beyond = false;
        for (k, load) in loads.iter().enumerate() {
            if load.s > fit.length {
                n.error(
                    &format!("point_loads[{k}].s"),
                    format!(
                        "{}: must be in [0, {:.4}] m, the length of the strand fitted to the polyline",
                        load.s, fit.length
                    ),
                );
                beyond = true;
            }
        }
        if beyond {
            return None;
        }
    }
    if let Some(x) = fit.q.iter().find(|x| x.abs() > MAX_CURVATURE) {
        n.error(
            "polyline",
            format!("the fit needs a curvature of {x:e} rad/m, beyond the allowed {MAX_CURVATURE:e}: check the units (metres) or raise elements"),
        );
        return None;
    }
    let mut s = template.build(name.clone(), group, fit.root, rng)?;
    s.strand.geometry =
        StrandGeometry::new(fit.root, fit.frame, fit.lengths.clone(), &s.strand.material);
    s.q0 = fit.q.clone();
    grooms.reports.push(GroomReport {
        name: name.clone(),
        strands: 1,
        source: GroomSource::Polyline {
            elements,
            curve: CurveReport {
                strand: name,
                origin: curve.origin,
                points: count,
                length: fit.length,
                polyline_length: fit.polyline_length,
                error: fit.error,
            },
        },
        sag_free_change: None,
        sag_free_carried: None,
        clearance: None,
    });
    Some(s)
}

/// The optional `group` of a `[[strands]]` entry: `Some(None)` when absent (the strand
/// is its own group), `None` when invalid (reported).
fn read_group(n: &mut Node<'_>) -> Option<Option<String>> {
    if !n.has("group") {
        return Some(None);
    }
    let group = n.string("group")?;
    if group.is_empty() {
        n.error("group", "must be a non-empty name");
        return None;
    }
    Some(Some(group.to_string()))
}

/// Names in use, to reject duplicates; counts the strands declared.
#[derive(Default)]
pub(super) struct Names {
    first_use: HashMap<String, String>,
    pub count: usize,
}

impl Names {
    /// Take `name` for a strand declared by node `n`; a duplicate is an error on `n.name`.
    pub fn claim(&mut self, n: &Node<'_>, name: &str) {
        self.count += 1;
        if let Some(previous) = self.first_use.get(name) {
            n.error(
                "name",
                format!("duplicate strand name '{name}' (already used by {previous})"),
            );
        } else {
            self.first_use
                .insert(name.to_string(), n.own_path().to_string());
        }
    }
}

/// A patch: a grid of `count = [nx, ny]` strands of the same template, roots centred on
/// `center`, spaced by `spacing_u`, `spacing_v`, or spanning `size = [w, h]` along the
/// root frame's n1 and n2. Strand (i, j) is named `<name>_<i>_<j>`.
fn read_patch(
    n: &mut Node<'_>,
    index: usize,
    defaults: &StrandDefaults,
    names: &mut Names,
    out: &mut Vec<StrandSetup>,
) {
    let name = n.optional("name", format!("patch{index}"), |n, k| {
        n.string(k).map(str::to_string)
    });
    let center = n.optional("center", Vector3::zeros(), Node::position);
    let count = n.optional("count", vec![1, 1], |n, k| {
        n.count_list(
            k,
            2,
            (1, MAX_PATCH_SIDE, "the cap on strands along a patch side"),
        )
    });
    let template = read_template(n, defaults, false);
    let steps = read_spacing(n, &template, count.as_deref());
    let (Some(name), Some(center), Some(count), Some((u, v))) = (name, center, count, steps) else {
        return;
    };
    let (nx, ny) = (count[0], count[1]);
    if names.count + nx * ny > MAX_STRANDS {
        let msg = format!(
            "{nx} x {ny} strands would bring the scene over the cap of {MAX_STRANDS} strands"
        );
        n.error("count", msg);
        names.count += nx * ny;
        return;
    }
    let seed = template.seed.unwrap_or(index as u64);
    for i in 0..nx {
        for j in 0..ny {
            let strand_name = format!("{name}_{i}_{j}");
            names.claim(n, &strand_name);
            let offset =
                u * (i as f64 - 0.5 * (nx - 1) as f64) + v * (j as f64 - 0.5 * (ny - 1) as f64);
            let mut rng = strand_rng(seed, 1 + (i * ny + j) as u64);
            out.extend(template.build(strand_name, name.clone(), center + offset, &mut rng));
        }
    }
}

/// A `[[tresses]]` entry: `count` fibres with their roots spread uniformly over an
/// ellipse of semi-axes `semi_axes = [a, b]` around `center`, a along n1 (`normal`) and b
/// along n2 = n0 × n1, in the plane across the fibres' `direction` n0 (the paper's tress
/// of fibres over an elliptic cross-section). Roots follow a sunflower (Fermat spiral)
/// pattern, `r_k = sqrt((k + ½)/count)`, angle `k` times the golden angle, scaled to the
/// ellipse: even in area, no two roots at one point. Fibre k is `<name>_<k>` and draws
/// its curvature variation from the tress `seed` on stream `1 + k`.
fn read_tress(
    n: &mut Node<'_>,
    index: usize,
    defaults: &StrandDefaults,
    names: &mut Names,
    out: &mut Vec<StrandSetup>,
) {
    let name = n.optional("name", format!("tress{index}"), |n, k| {
        n.string(k).map(str::to_string)
    });
    let center = n.optional("center", Vector3::zeros(), Node::position);
    let count = n.required("count", "the number of fibres", |n, k| {
        n.count(k, 1, MAX_STRANDS as i64, "the cap on strands")
    });
    let axes = n.required("semi_axes", "[a, b] in m", |n, k| {
        n.fixed_list(k, 2, Range::new(Bound::Incl(0.0), Bound::Incl(10.0)))
    });
    let template = read_template(n, defaults, false);
    let (Some(name), Some(center), Some(count), Some(axes), Some(frame)) =
        (name, center, count, axes, template.frame)
    else {
        return;
    };
    if names.count + count > MAX_STRANDS {
        let msg =
            format!("{count} fibres would bring the scene over the cap of {MAX_STRANDS} strands");
        n.error("count", msg);
        names.count += count;
        return;
    }
    let (u, v) = (frame.column(1).into_owned(), frame.column(2).into_owned());
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let seed = template.seed.unwrap_or(index as u64);
    for k in 0..count {
        let strand_name = format!("{name}_{k}");
        names.claim(n, &strand_name);
        let r = ((k as f64 + 0.5) / count as f64).sqrt();
        let angle = k as f64 * golden;
        let root = center + u * (axes[0] * r * angle.cos()) + v * (axes[1] * r * angle.sin());
        let mut rng = strand_rng(seed, 1 + k as u64);
        out.extend(template.build(strand_name, name.clone(), root, &mut rng));
    }
}

/// A `[[scalp_hair]]` entry: `count` fibres rooted on the surface of the sphere or
/// ellipsoid body `body`, over the cap of directions within `max_angle_deg` of `axis`
/// (from the body's centre, head coordinates), each leaving along the surface normal and
/// combed towards `comb` (its n1 is `comb` projected on the tangent plane). Directions
/// follow a Fibonacci spiral over the cap (`cos θ_k` uniform, azimuth `k` times the
/// golden angle: even in solid angle); the root is where the ray from the centre meets the
/// surface. Fibre k is `<name>_<k>` and draws its curvature variation from `seed` on
/// stream `1 + k`.
fn read_scalp_hair(
    n: &mut Node<'_>,
    index: usize,
    defaults: &StrandDefaults,
    bodies: &[BodySetup],
    names: &mut Names,
    out: &mut Vec<StrandSetup>,
) {
    let name = n.optional("name", format!("scalp_hair{index}"), |n, k| {
        n.string(k).map(str::to_string)
    });
    let body_name = n.required(
        "body",
        "the name of a sphere or ellipsoid in [[bodies]]",
        |n, k| n.string(k).map(str::to_string),
    );
    let count = n.required("count", "the number of fibres", |n, k| {
        n.count(k, 1, MAX_STRANDS as i64, "the cap on strands")
    });
    let axis = n.optional("axis", Vector3::z(), Node::unit);
    let angle = n.optional_f64(
        "max_angle_deg",
        90.0,
        Range::new(Bound::Excl(0.0), Bound::Incl(180.0)),
    );
    let comb = n.optional("comb", -Vector3::z(), Node::unit);
    for key in ["direction", "normal"] {
        if n.has(key) {
            n.error(key, "scalp hair leaves along the surface normal: remove it");
        }
    }
    let template = read_template(n, defaults, false);
    let (Some(name), Some(body_name), Some(count), Some(axis), Some(angle), Some(comb)) =
        (name, body_name, count, axis, angle, comb)
    else {
        return;
    };
    let shape = bodies
        .iter()
        .find(|b| b.name == body_name)
        .map(|b| &b.shape);
    let (center, radii, rotation) = match shape {
        Some(ShapeSetup::Sphere { center, radius }) => (
            *center,
            Vector3::repeat(*radius),
            nalgebra::Matrix3::identity(),
        ),
        Some(ShapeSetup::Ellipsoid {
            center,
            radii,
            rotation,
        }) => (*center, *radii, *rotation),
        Some(_) => {
            n.error(
                "body",
                format!(
                    "'{body_name}' is not a sphere or an ellipsoid: scalp hair is rooted on those"
                ),
            );
            return;
        }
        None => {
            n.error("body", format!("no body named '{body_name}' in [[bodies]]"));
            return;
        }
    };
    if names.count + count > MAX_STRANDS {
        n.error(
            "count",
            format!("{count} fibres would bring the scene over the cap of {MAX_STRANDS} strands"),
        );
        names.count += count;
        return;
    }
    let (u, v) = {
        let u = crate::model::ends::perpendicular(&axis);
        (u, axis.cross(&u))
    };
    let cos_max = angle.to_radians().cos();
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let seed = template.seed.unwrap_or(index as u64);
    for k in 0..count {
        let z = 1.0 - (1.0 - cos_max) * (k as f64 + 0.5) / count as f64;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = k as f64 * golden;
        let dir = axis * z + u * (r * phi.cos()) + v * (r * phi.sin());
        // The ray centre + t dir meets the ellipsoid where |Rᵀ dir ⊘ radii| t = 1.
        let local = rotation.transpose() * dir;
        let scaled = local.component_div(&radii);
        let root = center + dir / scaled.norm();
        let normal = (rotation * local.component_div(&radii.component_mul(&radii))).normalize();
        let along = comb - normal * normal.dot(&comb);
        let n1 = if along.norm() > 1e-6 {
            along.normalize()
        } else {
            crate::model::ends::perpendicular(&normal)
        };
        let mut t: Template = template.clone();
        t.frame = Some(nalgebra::Matrix3::from_columns(&[
            normal,
            n1,
            normal.cross(&n1),
        ]));
        let strand_name = format!("{name}_{k}");
        names.claim(n, &strand_name);
        let mut rng = strand_rng(seed, 1 + k as u64);
        out.extend(t.build(strand_name, name.clone(), root, &mut rng));
    }
}

/// The vectors between neighbouring roots along i and j.
fn read_spacing(
    n: &mut Node<'_>,
    template: &Template,
    count: Option<&[usize]>,
) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let size_given = n.has("size");
    let size = n.fixed_list("size", 2, Range::NON_NEGATIVE);
    let spacing_given = n.has("spacing_u") | n.has("spacing_v");
    let u = n.optional("spacing_u", Vector3::zeros(), Node::vec3);
    let v = n.optional("spacing_v", Vector3::zeros(), Node::vec3);
    if size_given && spacing_given {
        n.error("size", "give either size or spacing_u/spacing_v, not both");
        return None;
    }
    let count = count?;
    let steps = if size_given {
        let (size, frame) = (size?, template.frame?);
        let step = |k: usize| {
            if count[k] > 1 {
                size[k] / (count[k] - 1) as f64
            } else {
                0.0
            }
        };
        (frame.column(1) * step(0), frame.column(2) * step(1))
    } else {
        (u?, v?)
    };
    let coincide =
        (count[0] > 1 && steps.0.norm() == 0.0) || (count[1] > 1 && steps.1.norm() == 0.0);
    if coincide {
        let key = if spacing_given { "spacing_u" } else { "size" };
        n.error(key, "roots would coincide: give a non-zero size = [w, h] or spacing_u/spacing_v along each side with count > 1");
        return None;
    }
    Some(steps)
}
