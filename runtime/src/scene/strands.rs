//! `[[strands]]` and `[[patches]]`: the strand template shared by both, and the strands
//! it becomes.

use super::reader::{Bound, Node, Range};
use crate::config::StrandSetup;
use crate::model::humidity::HumidityScaling;
use crate::model::material::{
    helix_curvature, CrossSection, HelixForm, Material, Preset, PresetParams,
};
use crate::model::strand::{PointLoad, Strand, StrandGeometry};
use nalgebra::{Matrix3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use toml::Value;

/// Most elements a strand may have.
pub const MAX_ELEMENTS: usize = 200;
const ELEMENTS_CAP: &str = "the cap on elements per strand";
/// Elements of a strand that gives neither `elements` nor `element_lengths`.
pub const DEFAULT_ELEMENTS: usize = 10;
/// Direction of a strand that gives none: hanging down.
const DEFAULT_DIRECTION: [f64; 3] = [0.0, 0.0, -1.0];
/// A normal closer to the direction than this (after orthogonalisation) is "parallel".
const PARALLEL_TOLERANCE: f64 = 1e-6;
/// Longest strand (and element), metres: far beyond hair, and small enough that no
/// product of lengths in the kernels overflows.
pub const MAX_LENGTH: f64 = 100.0;
/// Largest cross-section radius, metres.
pub const MAX_RADIUS: f64 = 1.0;
/// Largest |τ|, |κ1|, |κ2| of `q0` and of the natural curvatures, rad/m: a fibre bent
/// to a radius of 1 µm; the trigonometric terms of the reconstruction stay accurate.
pub const MAX_CURVATURE: f64 = 1e6;
pub use crate::model::strand::MAX_POINT_LOAD;
/// Allowed charge per length, C/m: far beyond any charged fibre (the paper's is
/// ~2.6·10⁻¹¹ C/m).
pub const MAX_CHARGE_RANGE: Range = Range::new(Bound::Incl(-1e-3), Bound::Incl(1e-3));
/// Relative tolerance of `sum(element_lengths) == length`.
const LENGTH_SUM_TOLERANCE: f64 = 1e-9;

/// The initial state of a strand.
#[derive(Debug, Clone, PartialEq)]
enum Initial {
    /// q0 = the natural curvatures (the strand starts at rest in its natural shape).
    Natural,
    /// q0 = 0: a straight, untwisted strand.
    Straight,
    /// q0 given in the scene.
    Given(Vec<f64>),
    /// The whole q of a strand whose root is pinned (the joint's three coordinates first,
    /// 3N + 3) or free (and the root's translation last, 3N + 6), as a run gives it:
    /// checked against the root once the ends are read ([`super::ends`]).
    Whole(Vec<f64>),
}

/// What `[environment]` sets for every strand: the scene-wide air drag (strands that do
/// not set their own take it) and the humidity of the air (preset values follow it).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct StrandDefaults {
    /// `environment.air_drag`.
    pub air_drag: Option<f64>,
    /// The factors of `environment.relative_humidity` over the reference 65 %; `None`
    /// when the scene has no humidity (presets' values as they are).
    pub humidity: Option<HumidityScaling>,
    /// The strands' lengths come from elsewhere (a groom's curves): `length` is not
    /// required, and without it the template has N elements of total length 1.
    pub length_from_data: bool,
}

/// Everything of a strand but its name, root and random variation: the fields shared by
/// `[[strands]]` entries and `[[patches]]`. `None` parts were invalid (and reported).
#[derive(Debug, Clone)]
pub(super) struct Template {
    pub frame: Option<Matrix3<f64>>,
    lengths: Option<Vec<f64>>,
    material: Material,
    natural: Option<Vec<f64>>,
    variation: f64,
    pub seed: Option<u64>,
    internal_friction: f64,
    air_drag: f64,
    initial: Option<Initial>,
    pub(super) point_loads: Option<Vec<PointLoad>>,
    charge_per_length: Option<f64>,
}

/// Read the template fields of a strand or patch table, with the defaults of the
/// scene's `[environment]`; `whole_q`: a `q0` may be a run's whole q (a `[[strands]]`
/// entry, whose root may be pinned or free).
pub(super) fn read_template(
    n: &mut Node<'_>,
    defaults: &StrandDefaults,
    whole_q: bool,
) -> Template {
    let names: Vec<&str> = Preset::ALL.iter().map(|p| p.name()).collect();
    let preset = n.optional("preset", Preset::Smooth, |n, k| {
        n.choice(k, &names, Preset::from_name)
    });
    let params = preset.unwrap_or(Preset::Smooth).params();
    // the preset's section is taken as measured at 65 % RH; the strand's own fields
    // replace the humid values field by field
    let preset_section = match defaults.humidity {
        Some(humidity) => humidity.section(&params.cross_section),
        None => params.cross_section,
    };
    let cross_section = read_cross_section(n, &preset_section);
    let frame = read_frame(n, defaults.length_from_data);
    let (lengths, length) = read_lengths(n, defaults.length_from_data).unzip();
    let natural = read_natural(n, &params, lengths.as_deref(), length);
    let variation = n.optional_f64(
        "curvature_variation",
        0.0,
        Range::new(Bound::Incl(0.0), Bound::Incl(1.0)),
    );
    let seed = if n.has("seed") { n.seed("seed") } else { None };
    let internal_friction = n.optional_f64(
        "internal_friction",
        params.internal_friction,
        Range::new(Bound::Incl(0.0), Bound::Incl(100.0)),
    );
    let air_drag = n.optional_f64(
        "air_drag",
        defaults.air_drag.unwrap_or(params.air_drag),
        Range::AIR_DRAG,
    );
    let initial = read_initial(n, lengths.as_ref().map(|l| 3 * l.len()), whole_q);
    // (a strand from data has its length only once fitted: its loads are checked then)
    let point_loads = read_point_loads(n, length.filter(|_| !defaults.length_from_data));
    let charge_per_length = if n.has("charge_per_length") {
        n.f64("charge_per_length", MAX_CHARGE_RANGE)
    } else {
        None
    };
    let material = cross_section.material();
    check_derived(n, &material, natural.as_deref());
    Template {
        frame,
        lengths,
        material,
        natural,
        variation: variation.unwrap_or(0.0),
        seed,
        internal_friction: internal_friction.unwrap_or(params.internal_friction),
        air_drag: air_drag.unwrap_or(params.air_drag),
        initial,
        point_loads,
        charge_per_length,
    }
}

/// Extreme but allowed inputs can still give a useless strand (a stiffness that
/// underflows to 0, a curvature that overflows): report them on the inputs involved.
fn check_derived(n: &Node<'_>, material: &Material, natural: Option<&[f64]>) {
    let usable = |x: f64| x.is_finite() && x > 0.0;
    if !usable(material.mass_per_length) || !material.stiffness.iter().all(|&k| usable(k)) {
        let msg = format!(
            "radius, youngs_modulus and density give a mass per length of {:e} kg/m and stiffnesses {:?} N m^2; both must be finite and > 0",
            material.mass_per_length, material.stiffness
        );
        n.error("radius", msg);
    }
    if natural.is_some_and(|q| !q.iter().all(|x| x.is_finite())) {
        n.error("natural", "the natural curvatures are not finite: check the magnitudes of helix_radius, helix_step, natural_profile and the element lengths");
    } else if natural.is_some_and(|q| q.iter().any(|x| x.abs() > MAX_CURVATURE)) {
        n.error("natural", format!("the natural curvatures must be within [-{MAX_CURVATURE:e}, {MAX_CURVATURE:e}] rad/m: check helix_radius, helix_step, natural and natural_profile"));
    }
}

impl Template {
    /// N, the number of elements (`None` when the lengths were invalid).
    pub(super) fn elements(&self) -> Option<usize> {
        self.lengths.as_ref().map(Vec::len)
    }

    /// The strand named `name`, of output group `group`, with its root at `root` (head
    /// coordinates). Natural
    /// curvatures get their random variation from `rng` (see [`vary`]). `None` when a
    /// part of the template was invalid.
    pub(super) fn build(
        &self,
        name: String,
        group: String,
        root: Vector3<f64>,
        rng: &mut ChaCha8Rng,
    ) -> Option<StrandSetup> {
        let lengths = self.lengths.clone()?;
        let natural = vary(self.natural.as_deref()?, self.variation, rng);
        let q0 = match self.initial.as_ref()? {
            Initial::Natural => natural.clone(),
            Initial::Straight => vec![0.0; natural.len()],
            Initial::Given(q0) | Initial::Whole(q0) => q0.clone(),
        };
        let geometry = StrandGeometry::new(root, self.frame?, lengths, &self.material);
        let strand = Strand {
            name,
            geometry,
            material: self.material,
            natural,
            internal_friction: self.internal_friction,
            air_drag: self.air_drag,
            point_loads: self.point_loads.clone()?,
            ends: Default::default(),
        };
        Some(StrandSetup {
            strand,
            q0,
            group,
            charge_per_length: self.charge_per_length,
            tip: None,
        })
    }
}

/// The random generator of one strand: ChaCha8 seeded by `seed`, on its own `stream`.
pub(super) fn strand_rng(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

/// Natural curvatures with relative random variation: element Q is scaled by
/// `1 + variation · (g + e_Q) / 2`, with g (one per strand: "across strands") and e_Q
/// (one per element: "along the strand") uniform in [−1, 1]. Scaling (τ, κ1, κ2) together
/// scales the element's helix by `1 / factor` and keeps its pitch angle. Straight
/// strands stay straight.
fn vary(natural: &[f64], variation: f64, rng: &mut ChaCha8Rng) -> Vec<f64> {
    if variation == 0.0 {
        return natural.to_vec();
    }
    let across: f64 = rng.random_range(-1.0..=1.0);
    let mut out = Vec::with_capacity(natural.len());
    for element in natural.chunks(3) {
        let along: f64 = rng.random_range(-1.0..=1.0);
        let factor = 1.0 + variation * 0.5 * (across + along);
        out.extend(element.iter().map(|x| x * factor));
    }
    out
}

/// The section of the strand: each field as the strand gives it, else the preset's
/// (`preset`, at the scene's humidity). The preset's `shear_factor` goes with its Poisson
/// ratio: a strand that sets `poisson` sets G = E / (2(1 + ν)) itself.
fn read_cross_section(n: &mut Node<'_>, preset: &CrossSection) -> CrossSection {
    let shear_factor = if n.has("poisson") {
        1.0
    } else {
        preset.shear_factor
    };
    let mut field = |key: &'static str, default: f64, range: Range| {
        n.optional_f64(key, default, range).unwrap_or(default)
    };
    CrossSection {
        radius: field(
            "radius",
            preset.radius,
            Range::new(Bound::Excl(0.0), Bound::Incl(MAX_RADIUS)),
        ),
        ellipticity: field(
            "ellipticity",
            preset.ellipticity,
            Range::new(Bound::Incl(1.0), Bound::Open),
        ),
        youngs_modulus: field(
            "youngs_modulus",
            preset.youngs_modulus,
            // up to ten times diamond's
            Range::new(Bound::Excl(0.0), Bound::Incl(1e13)),
        ),
        poisson: field(
            "poisson",
            preset.poisson,
            Range::new(Bound::Excl(-1.0), Bound::Incl(0.5)),
        ),
        density: field(
            "density",
            preset.density,
            // up to several times the densest metal's
            Range::new(Bound::Excl(0.0), Bound::Incl(1e5)),
        ),
        shear_factor,
    }
}

/// Root frame (n0, n1, n2) from `direction` and `normal`. For a strand whose shape
/// comes from data (a `polyline`, which has no `direction`), `normal` is n1 and n0 is
/// any direction across it: the fit takes the root frame from the polyline and `normal`
/// only as its n1 (checked against the polyline's first segment there).
fn read_frame(n: &mut Node<'_>, from_data: bool) -> Option<Matrix3<f64>> {
    let direction = n.optional("direction", Vector3::from(DEFAULT_DIRECTION), Node::unit);
    let normal = if n.has("normal") {
        Some(n.unit("normal"))
    } else {
        None
    };
    if from_data {
        if let Some(n1) = normal {
            let n1 = n1?;
            let e = least_aligned_axis(&n1);
            let n0 = (e - n1 * n1.dot(&e)).normalize();
            return Some(Matrix3::from_columns(&[n0, n1, n0.cross(&n1)]));
        }
    }
    let n0 = direction?;
    let raw_n1 = match normal {
        Some(given) => given?,
        None => least_aligned_axis(&n0),
    };
    let n1 = raw_n1 - n0 * n0.dot(&raw_n1);
    if n1.norm() < PARALLEL_TOLERANCE {
        n.error("normal", "must not be parallel to direction");
        return None;
    }
    let n1 = n1.normalize();
    Some(Matrix3::from_columns(&[n0, n1, n0.cross(&n1)]))
}

/// The world axis least aligned with the unit vector `v`.
fn least_aligned_axis(v: &Vector3<f64>) -> Vector3<f64> {
    let k = v.iamin();
    Vector3::ith(k, 1.0)
}

/// Element lengths from `length` and `elements`, or from `element_lengths`; and the
/// strand length (as given, or the sum of `element_lengths`).
fn read_lengths(n: &mut Node<'_>, from_data: bool) -> Option<(Vec<f64>, f64)> {
    let length_given = n.has("length");
    let length_range = Range::new(Bound::Excl(0.0), Bound::Incl(MAX_LENGTH));
    let length = n.f64("length", length_range);
    let elements_given = n.has("elements");
    let elements = n.optional("elements", DEFAULT_ELEMENTS, |n, k| {
        n.count(k, 1, MAX_ELEMENTS as i64, ELEMENTS_CAP)
    });
    if !n.has("element_lengths") {
        return if length_given {
            let (length, count) = (length?, elements?);
            Some((vec![length / count as f64; count], length))
        } else if from_data {
            let count = elements?;
            Some((vec![1.0 / count as f64; count], 1.0))
        } else {
            n.missing(
                "length",
                "the strand length in metres; must be > 0 and finite",
            )
        };
    }
    let list = n.f64_list("element_lengths", length_range);
    if elements_given {
        n.error(
            "element_lengths",
            "give either elements or element_lengths, not both",
        );
        return None;
    }
    let list = list?;
    if list.is_empty() || list.len() > MAX_ELEMENTS {
        let msg = format!(
            "must have between 1 and {MAX_ELEMENTS} values ({ELEMENTS_CAP}), got {}",
            list.len()
        );
        n.error("element_lengths", msg);
        return None;
    }
    let sum: f64 = list.iter().sum();
    if !length_given {
        return Some((list, sum));
    }
    let length = length?;
    if (sum - length).abs() > LENGTH_SUM_TOLERANCE * length {
        n.error(
            "element_lengths",
            format!("must sum to length = {length} (relative 1e-9), sum is {sum}"),
        );
        return None;
    }
    Some((list, length))
}

/// Natural (τ, κ1, κ2) per element: from `natural_profile`, `natural`, or the helix
/// (`helix_radius`, `helix_step`, `helix_form`, preset values by default).
fn read_natural(
    n: &mut Node<'_>,
    preset: &PresetParams,
    lengths: Option<&[f64]>,
    length: Option<f64>,
) -> Option<Vec<f64>> {
    let helix_keys = ["helix_radius", "helix_step", "helix_form"];
    let helix_given: Vec<&str> = helix_keys.into_iter().filter(|&k| n.has(k)).collect();
    let radius = n.optional_f64("helix_radius", preset.helix_radius, Range::NON_NEGATIVE);
    let step = n.optional_f64("helix_step", preset.helix_step, Range::NON_NEGATIVE);
    let forms = ["exact", "paper"];
    let form = n.optional("helix_form", HelixForm::Exact, |n, k| {
        n.choice(k, &forms, parse_helix_form)
    });
    let natural_given = n.has("natural");
    // its range is checked below, with its unit
    let natural = n.vec3_in("natural", Range::ANY);
    let profile_given = n.has("natural_profile");
    let profile = read_profile(n, length);
    if natural_given && profile_given {
        n.error(
            "natural_profile",
            "give either natural or natural_profile, not both",
        );
        return None;
    }
    if (natural_given || profile_given) && !helix_given.is_empty() {
        for key in helix_given {
            n.error(key, "cannot be combined with natural or natural_profile");
        }
        return None;
    }
    let lengths = lengths?;
    if profile_given {
        let profile = profile?;
        return Some(
            lengths_with_offsets(lengths)
                .flat_map(|(a, b)| profile_mean(&profile, a, b))
                .collect(),
        );
    }
    let d = if natural_given {
        natural?.into()
    } else {
        helix_curvature(radius?, step?, form?)
    };
    Some(d.repeat(lengths.len()))
}

fn parse_helix_form(name: &str) -> Option<HelixForm> {
    match name {
        "exact" => Some(HelixForm::Exact),
        "paper" => Some(HelixForm::Paper),
        _ => None,
    }
}

/// `(start, end)` arc lengths of each element.
fn lengths_with_offsets(lengths: &[f64]) -> impl Iterator<Item = (f64, f64)> + '_ {
    lengths.iter().scan(0.0, |start, &l| {
        let a = *start;
        *start += l;
        Some((a, a + l))
    })
}

/// A natural-curvature profile: points `(s, [τ, κ1, κ2])` with strictly increasing s.
type Profile = Vec<(f64, [f64; 3])>;

fn read_profile(n: &mut Node<'_>, length: Option<f64>) -> Option<Profile> {
    let is_empty_list = matches!(n.raw("natural_profile"), Some(Value::Array(a)) if a.is_empty());
    if is_empty_list {
        n.error("natural_profile", "needs at least one point { s, value }");
    }
    let s_range = length.map_or(Range::NON_NEGATIVE, |l| {
        Range::new(Bound::Incl(0.0), Bound::Incl(l))
    });
    let mut points = Vec::new();
    for mut p in n.tables("natural_profile") {
        let s = p.required_f64("s", "arc length in metres", s_range);
        let value = p.required("value", "[tau, kappa1, kappa2] in rad/m", Node::vec3);
        p.finish();
        points.push(s.zip(value).map(|(s, v)| (s, <[f64; 3]>::from(v))));
    }
    for (i, pair) in points.windows(2).enumerate() {
        if let [Some((a, _)), Some((b, _))] = pair {
            if b <= a {
                n.error(
                    &format!("natural_profile[{}].s", i + 1),
                    "must be strictly increasing along the profile",
                );
            }
        }
    }
    let points: Option<Profile> = points.into_iter().collect();
    points.filter(|p| !p.is_empty())
}

/// Piecewise-linear interpolation of the profile at s, constant beyond its ends.
fn profile_at(profile: &[(f64, [f64; 3])], s: f64) -> [f64; 3] {
    let k = profile.partition_point(|(sk, _)| *sk <= s);
    if k == 0 {
        return profile[0].1;
    }
    if k == profile.len() {
        return profile[k - 1].1;
    }
    let ((s0, v0), (s1, v1)) = (profile[k - 1], profile[k]);
    let w = (s - s0) / (s1 - s0);
    [0, 1, 2].map(|i| v0[i] + w * (v1[i] - v0[i]))
}

/// Mean of the profile over `[a, b]` (b > a): the exact integral of the piecewise-linear
/// function (trapezoids between consecutive breakpoints) divided by `b − a`.
fn profile_mean(profile: &[(f64, [f64; 3])], a: f64, b: f64) -> [f64; 3] {
    let mut cuts: Vec<f64> = vec![a];
    cuts.extend(profile.iter().map(|(s, _)| *s).filter(|&s| s > a && s < b));
    cuts.push(b);
    let mut integral = [0.0; 3];
    for w in cuts.windows(2) {
        let (f0, f1) = (profile_at(profile, w[0]), profile_at(profile, w[1]));
        for i in 0..3 {
            integral[i] += 0.5 * (w[1] - w[0]) * (f0[i] + f1[i]);
        }
    }
    integral.map(|x| x / (b - a))
}

fn read_initial(n: &mut Node<'_>, dofs: Option<usize>, whole_q: bool) -> Option<Initial> {
    let kinds = ["natural", "straight"];
    let initial_given = n.has("initial");
    let initial = n.optional("initial", Initial::Natural, |n, k| {
        n.choice(k, &kinds, |name| match name {
            "natural" => Some(Initial::Natural),
            "straight" => Some(Initial::Straight),
            _ => None,
        })
    });
    if !n.has("q0") {
        return initial;
    }
    let q0 = n.f64_list("q0", Range::ANY);
    if initial_given {
        n.error("q0", "give either initial or q0, not both");
        return None;
    }
    let (q0, dofs) = (q0?, dofs?);
    if whole_q && (q0.len() == dofs + 3 || q0.len() == dofs + 6) {
        // a pinned or free root's whole q: checked with the ends
        return Some(Initial::Whole(q0));
    }
    if q0.len() != dofs {
        let whole = if whole_q {
            format!(
                ", or the whole q of a run: 3N + 3 = {} with a pinned root, 3N + 6 = {} with a free one",
                dofs + 3,
                dofs + 6
            )
        } else {
            String::new()
        };
        n.error(
            "q0",
            format!(
                "must have 3N = {dofs} values (N = {} elements){whole}; got {}",
                dofs / 3,
                q0.len()
            ),
        );
        return None;
    }
    let ok = q0
        .iter()
        .enumerate()
        .all(|(i, &x)| n.check(&format!("q0[{i}]"), x, CURVATURE_RANGE).is_some());
    ok.then_some(Initial::Given(q0))
}

/// The range of every curvature and twist of `q0`, rad/m.
pub(super) const CURVATURE_RANGE: Range =
    Range::new(Bound::Incl(-MAX_CURVATURE), Bound::Incl(MAX_CURVATURE));

fn read_point_loads(n: &mut Node<'_>, length: Option<f64>) -> Option<Vec<PointLoad>> {
    let s_range = length.map_or(Range::NON_NEGATIVE, |l| {
        Range::new(Bound::Incl(0.0), Bound::Incl(l))
    });
    let loads: Vec<Option<PointLoad>> = n
        .tables("point_loads")
        .into_iter()
        .map(|mut p| {
            let s = p.required_f64("s", "arc length in metres", s_range);
            // a couple alone needs no force
            let torque = p.optional("torque", nalgebra::Vector3::zeros(), Node::vec3);
            let force = if p.has("force") || !p.has("torque") {
                p.required(
                    "force",
                    "[fx, fy, fz] in newtons, world coordinates (material frame with follows = true)",
                    Node::vec3,
                )
            } else {
                Some(nalgebra::Vector3::zeros())
            };
            let follows = super::reader::boolean(&mut p, "follows", false);
            if force.is_some_and(|f| f.norm() > MAX_POINT_LOAD) {
                p.error(
                    "force",
                    format!("must have a magnitude <= {MAX_POINT_LOAD:e} N"),
                );
            }
            if torque.is_some_and(|t| t.norm() > MAX_POINT_LOAD) {
                p.error(
                    "torque",
                    format!("must have a magnitude <= {MAX_POINT_LOAD:e} N·m"),
                );
            }
            p.finish();
            Some(PointLoad {
                s: s?,
                force: force?,
                follows: follows?,
                torque: torque?,
            })
        })
        .collect();
    loads.into_iter().collect()
}
