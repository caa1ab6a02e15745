//! `superhelix compare-kernels`: a candidate strand kernel (by default the generated
//! closed-form kernel for N elements) against the generic kernel with a high fixed
//! Gauss–Legendre order, on random configurations (issue #3, point 2).
//!
//! Each configuration draws a strand geometry (a preset's material, random element
//! lengths, root position and frame), generalized coordinates q whose elements have
//! |d|·l in [`WL_LIST`] or random, in one of the [`Shape`]s, random velocities q̇ and a
//! random [`BodyField`] (uniform, linear and velocity parts; some with a zero linear
//! part, some with an isotropic velocity part). Both kernels then give every output of
//! [`StrandKernel::evaluate`] with [`Terms::all`], the poses at the element ends, and
//! y(s), J(s) and c·∂²y(s)/∂q∂q at random arc lengths s (one on an element boundary).
//!
//! **Relative deviation** of a quantity in one configuration: the largest absolute
//! difference over its entries divided by the largest absolute entry of the reference,
//! `max_i |cand_i − ref_i| / max_i |ref_i|` (the plain `max |cand_i|` when the reference
//! is exactly zero; infinite when the candidate gives a NaN). The report gives, per
//! quantity, the worst value over all configurations and where it happened.

use crate::runtime::kernels::kernel::{
    BodyField, EvalInput, KernelFactory, StrandKernel, StrandTerms,
};
use crate::runtime::model::material::Preset;
use crate::runtime::model::quadrature::MAX_ORDER;
use crate::runtime::model::reconstruction::Pose;
use crate::runtime::model::strand::StrandGeometry;
use crate::runtime::{Error, GenericKernel, Matrix3, QuadratureRule, Result, Terms, Vector3};
use faer::Mat;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::fmt::Write as _;

/// The values of |d|·l every run covers (each configuration of even index has all its
/// elements at one of them; the others mix these with random values).
pub const WL_LIST: [f64; 8] = [0.0, 1e-12, 1e-8, 1e-4, 1e-2, 1.0, 30.0, 100.0];

/// Largest |d|·l drawn (the reference order is chosen to resolve it).
pub const MAX_WL: f64 = 100.0;

/// The kernel compared with the reference.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Candidate {
    /// The generated fixed-N kernel of [`crate::kernel_factory`] (the default; for the N
    /// it lists in `available()`).
    Generated,
    /// [`GenericKernel`] with its adaptive rule (`8 + ⌈1.5 |d| l⌉` points per element):
    /// for developing and testing the comparison before the generated kernels exist.
    GenericAdaptive,
    /// [`GenericKernel`] with n Gauss–Legendre points per element.
    GenericFixed(usize),
}

impl Candidate {
    /// Parse `generated`, `generic-adaptive` or `generic-<n>` (1 ≤ n ≤ 256).
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "generated" => Some(Candidate::Generated),
            "generic-adaptive" => Some(Candidate::GenericAdaptive),
            other => other
                .strip_prefix("generic-")
                .and_then(|n| n.parse().ok())
                .filter(|n| (1..=MAX_ORDER).contains(n))
                .map(Candidate::GenericFixed),
        }
    }

    /// The name `from_name` accepts.
    pub fn name(self) -> String {
        match self {
            Candidate::Generated => "generated".to_string(),
            Candidate::GenericAdaptive => "generic-adaptive".to_string(),
            Candidate::GenericFixed(n) => format!("generic-{n}"),
        }
    }
}

/// What `compare-kernels` runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CompareOptions {
    /// Elements per strand N.
    pub elements: usize,
    /// Number of random configurations K.
    pub samples: usize,
    /// Seed of the random configurations (ChaCha8).
    pub seed: u64,
    /// The kernel compared with the reference.
    pub candidate: Candidate,
}

impl Default for CompareOptions {
    fn default() -> Self {
        CompareOptions {
            elements: 5,
            samples: 1000,
            seed: 1,
            candidate: Candidate::Generated,
        }
    }
}

/// The shape of a configuration's elements.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// d in a random direction.
    General,
    /// Planar arc about n1: d = (0, κ, 0).
    Arc,
    /// Planar, untwisted: d = (0, κ1, κ2).
    Planar,
    /// Pure twist: d = (τ, 0, 0).
    Twist,
    /// Each element one of the above, at random.
    Mixed,
}

impl Shape {
    /// All shapes, in the order configurations cycle through them.
    pub const ALL: [Shape; 5] = [
        Shape::General,
        Shape::Arc,
        Shape::Planar,
        Shape::Twist,
        Shape::Mixed,
    ];

    /// Short name for the report.
    pub fn name(self) -> &'static str {
        match self {
            Shape::General => "general",
            Shape::Arc => "arc (0,k,0)",
            Shape::Planar => "planar (0,k1,k2)",
            Shape::Twist => "twist (t,0,0)",
            Shape::Mixed => "mixed",
        }
    }
}

/// One random configuration.
#[derive(Debug, Clone)]
pub struct Configuration {
    /// Strand geometry.
    pub geometry: StrandGeometry,
    /// Preset the material comes from.
    pub preset: Preset,
    /// Shape of the elements.
    pub shape: Shape,
    /// Generalized coordinates (3N).
    pub q: Vec<f64>,
    /// Generalized velocities (3N).
    pub v: Vec<f64>,
    /// External force per unit length.
    pub field: BodyField,
    /// Arc lengths where y, J and the Hessian are compared.
    pub points: Vec<f64>,
    /// The vector c of the compared Hessian c·∂²y/∂q∂q.
    pub hessian_weight: Vector3<f64>,
    /// |d|·l of each element.
    pub wl: Vec<f64>,
}

impl Configuration {
    /// Largest |d|·l of the elements.
    pub fn max_wl(&self) -> f64 {
        self.wl.iter().fold(0.0, |m, &x| m.max(x))
    }
}

/// Gauss–Legendre points per element of the reference for a largest |d|·l of `wl`:
/// `max(64, 16 + 2⌈wl⌉)`, at most 256. The integrands are trigonometric polynomials of
/// frequency up to 2|d| (4|d| for the rotary-inertia part) times low-degree polynomials;
/// n points integrate `e^{iωu}` over l to double precision once n is well past ωl/2,
/// and `compare-kernels --candidate generic-256` measures the margin (README).
pub fn reference_order(max_wl: f64) -> usize {
    (16 + 2 * max_wl.ceil() as usize).clamp(64, MAX_ORDER)
}

fn log_uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    10f64.powf(rng.random_range(lo.log10()..=hi.log10()))
}

fn random_vector(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    Vector3::new(
        rng.random_range(-1.0..=1.0),
        rng.random_range(-1.0..=1.0),
        rng.random_range(-1.0..=1.0),
    )
}

fn random_unit(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    loop {
        let v = random_vector(rng);
        let n = v.norm();
        if (0.1..=1.0).contains(&n) {
            return v / n;
        }
    }
}

fn random_matrix(rng: &mut ChaCha8Rng) -> Matrix3<f64> {
    Matrix3::from_fn(|_, _| rng.random_range(-1.0..=1.0))
}

/// A random rotation (Gram–Schmidt of two random directions).
fn random_rotation(rng: &mut ChaCha8Rng) -> Matrix3<f64> {
    let n0 = random_unit(rng);
    let n1 = loop {
        let b = random_unit(rng);
        let b = b - n0 * n0.dot(&b);
        if b.norm() > 0.1 {
            break b.normalize();
        }
    };
    Matrix3::from_columns(&[n0, n1, n0.cross(&n1)])
}

/// A unit Darboux direction of the given (non-mixed) shape.
fn direction(shape: Shape, rng: &mut ChaCha8Rng) -> Vector3<f64> {
    let sign = if rng.random_range(0..2) == 0 {
        1.0
    } else {
        -1.0
    };
    match shape {
        Shape::Arc => Vector3::new(0.0, sign, 0.0),
        Shape::Planar => {
            let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            Vector3::new(0.0, phi.cos(), phi.sin())
        }
        Shape::Twist => Vector3::new(sign, 0.0, 0.0),
        Shape::General | Shape::Mixed => random_unit(rng),
    }
}

/// Configuration number `index` of a run with N = `elements`, drawn from `rng`.
///
/// Even indices j = index/2 have every element at |d|·l = `WL_LIST[j % 8]` in shape
/// `Shape::ALL[(j / 8) % 5]`, so that K ≥ 80 covers every pair; odd indices mix, per
/// element, list values and log-uniform values in [1e-13, 100], in shape
/// `Shape::ALL[j % 5]`. Field kinds cycle over index % 4 (isotropic drag without linear
/// part; head-motion field; general velocity part without linear part; random matrices).
pub fn configuration(elements: usize, index: usize, rng: &mut ChaCha8Rng) -> Configuration {
    let n = elements;
    let preset = Preset::ALL[rng.random_range(0..Preset::ALL.len())];
    let material = preset.params().cross_section.material();
    let total = log_uniform(rng, 0.02, 0.5);
    let lengths: Vec<f64> = (0..n)
        .map(|_| total / n as f64 * rng.random_range(0.5..=1.5))
        .collect();
    let root = random_vector(rng) * 0.1;
    let frame = random_rotation(rng);
    let mut geometry = StrandGeometry::new(root, frame, lengths, &material);
    if rng.random_range(0..5) == 0 {
        // the paper's model exactly: no rotary inertia
        geometry.rotary_inertia = [0.0; 3];
    }

    let j = index / 2;
    let uniform_class = index % 2 == 0;
    let shape = if uniform_class {
        Shape::ALL[(j / WL_LIST.len()) % Shape::ALL.len()]
    } else {
        Shape::ALL[j % Shape::ALL.len()]
    };
    let mut q = vec![0.0; 3 * n];
    let mut wl = vec![0.0; n];
    for e in 0..n {
        let x = if uniform_class {
            WL_LIST[j % WL_LIST.len()]
        } else if rng.random_range(0..2) == 0 {
            WL_LIST[rng.random_range(0..WL_LIST.len())]
        } else {
            log_uniform(rng, 1e-13, MAX_WL)
        };
        let element_shape = if shape == Shape::Mixed {
            Shape::ALL[rng.random_range(0..4)]
        } else {
            shape
        };
        let d = direction(element_shape, rng) * (x / geometry.lengths[e]);
        q[3 * e..3 * e + 3].copy_from_slice(d.as_slice());
        wl[e] = d.norm() * geometry.lengths[e];
    }

    let v_scale = log_uniform(rng, 1e-3, 10.0);
    let v: Vec<f64> = (0..3 * n)
        .map(|k| rng.random_range(-1.0..=1.0) * v_scale / geometry.lengths[k / 3])
        .collect();

    let rho = material.mass_per_length;
    let nu = log_uniform(rng, 5e-6, 5e-5);
    let gravity = random_unit(rng) * 9.81;
    let head_acceleration = random_vector(rng) * 10.0;
    let head_velocity = random_vector(rng);
    let omega = random_unit(rng) * log_uniform(rng, 0.1, 20.0);
    let alpha = random_vector(rng) * 100.0;
    let w = omega.cross_matrix();
    let uniform = (gravity - head_acceleration) * rho - head_velocity * nu;
    let field = match index % 4 {
        0 => BodyField {
            uniform,
            linear: Matrix3::zeros(),
            velocity: -Matrix3::identity() * nu,
        },
        1 => BodyField {
            uniform,
            linear: -(alpha.cross_matrix() + w * w) * rho - w * nu,
            velocity: -w * (2.0 * rho) - Matrix3::identity() * nu,
        },
        2 => BodyField {
            uniform,
            linear: Matrix3::zeros(),
            velocity: -w * (2.0 * rho) - Matrix3::identity() * nu,
        },
        _ => BodyField {
            uniform,
            linear: random_matrix(rng) * (100.0 * rho),
            velocity: random_matrix(rng) * (10.0 * rho),
        },
    };

    let length = geometry.length();
    let mut points: Vec<f64> = (0..4).map(|_| rng.random_range(0.0..=length)).collect();
    if n > 1 {
        let boundary = rng.random_range(1..n);
        points.push(geometry.lengths[..boundary].iter().sum());
    }
    let hessian_weight = random_vector(rng) * (10.0 * rho);
    Configuration {
        geometry,
        preset,
        shape,
        q,
        v,
        field,
        points,
        hessian_weight,
        wl,
    }
}

/// The quantities compared, in the order of the report.
pub const QUANTITIES: [&str; 12] = [
    "mass M",
    "force (field - b)",
    "velocity term b",
    "stiffness",
    "damping",
    "velocity_term_jacobian",
    "first_moment",
    "positions at element ends",
    "frames at element ends",
    "positions y(s)",
    "J(s)",
    "c.d2y/dqdq(s)",
];

/// Largest |difference| and largest |reference| over the entries of one quantity.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Deviation {
    difference: f64,
    scale: f64,
    candidate: f64,
}

impl Deviation {
    pub(crate) fn add(&mut self, candidate: f64, reference: f64) {
        let d = (candidate - reference).abs();
        self.difference = self
            .difference
            .max(if d.is_nan() { f64::INFINITY } else { d });
        self.scale = self.scale.max(reference.abs());
        self.candidate = self.candidate.max(candidate.abs());
    }
    pub(crate) fn slices(&mut self, candidate: &[f64], reference: &[f64]) {
        for (c, r) in candidate.iter().zip(reference) {
            self.add(*c, *r);
        }
    }
    pub(crate) fn vectors(&mut self, candidate: &[Vector3<f64>], reference: &[Vector3<f64>]) {
        for (c, r) in candidate.iter().zip(reference) {
            self.slices(c.as_slice(), r.as_slice());
        }
    }
    pub(crate) fn mat(&mut self, candidate: &Mat<f64>, reference: &Mat<f64>) {
        for j in 0..reference.ncols() {
            for i in 0..reference.nrows() {
                self.add(candidate[(i, j)], reference[(i, j)]);
            }
        }
    }
    pub(crate) fn relative(&self) -> f64 {
        if self.difference.is_infinite() {
            f64::INFINITY
        } else if self.scale > 0.0 {
            self.difference / self.scale
        } else {
            self.candidate
        }
    }
}

/// Where the worst deviation of a quantity happened.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Worst {
    /// The relative deviation.
    pub deviation: f64,
    /// Largest |d|·l of the configuration's elements.
    pub wl: f64,
    /// Index of the configuration.
    pub configuration: usize,
    /// Its shape.
    pub shape: Shape,
    /// Its preset.
    pub preset: Preset,
}

/// Worst deviation over the configurations whose largest |d|·l is in one range.
#[derive(Debug, Clone, PartialEq)]
pub struct WlRange {
    /// The range, e.g. `(1e-4, 1e-2]`.
    pub label: String,
    /// Configurations in it.
    pub configurations: usize,
    /// Worst relative deviation over all quantities.
    pub deviation: f64,
}

/// Result of a comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct CompareReport {
    /// The options run.
    pub options: CompareOptions,
    /// Description of the candidate kernel.
    pub candidate: String,
    /// Description of the reference.
    pub reference: String,
    /// Per quantity (names in [`QUANTITIES`]), the worst deviation.
    pub quantities: Vec<(&'static str, Worst)>,
    /// Worst deviation per range of the configurations' largest |d|·l.
    pub by_wl: Vec<WlRange>,
    /// Largest of all relative deviations.
    pub max_relative_deviation: f64,
}

impl CompareReport {
    /// The report as printed by `compare-kernels` (Markdown tables), ending with the line
    /// `max_relative_deviation=<value>`.
    pub fn render(&self) -> String {
        let o = &self.options;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "compare-kernels: N = {}, {} random configurations, seed {}",
            o.elements, o.samples, o.seed
        );
        let _ = writeln!(s, "candidate: {}", self.candidate);
        let _ = writeln!(s, "reference: {}", self.reference);
        let _ = writeln!(
            s,
            "relative deviation = max|candidate - reference| / max|reference| over the entries \
             of one quantity in one configuration; worst over the configurations\n"
        );
        let _ = writeln!(
            s,
            "| quantity | worst relative deviation | at W·l (largest of the configuration) | configuration |"
        );
        let _ = writeln!(s, "|---|---|---|---|");
        for (name, w) in &self.quantities {
            if w.deviation == 0.0 {
                let _ = writeln!(s, "| {name} | 0 | - | - (identical everywhere) |");
                continue;
            }
            let _ = writeln!(
                s,
                "| {name} | {:.2e} | {} | #{} {}, {} |",
                w.deviation,
                wl_text(w.wl),
                w.configuration,
                w.shape.name(),
                w.preset.name()
            );
        }
        let _ = writeln!(
            s,
            "\n| largest W·l of the configuration | configurations | worst relative deviation (all quantities) |"
        );
        let _ = writeln!(s, "|---|---|---|");
        for r in &self.by_wl {
            let _ = writeln!(
                s,
                "| {} | {} | {} |",
                r.label,
                r.configurations,
                if r.configurations == 0 {
                    "-".to_string()
                } else {
                    format!("{:.2e}", r.deviation)
                }
            );
        }
        let _ = writeln!(
            s,
            "\nmax_relative_deviation={:.3e}",
            self.max_relative_deviation
        );
        s
    }
}

fn wl_text(wl: f64) -> String {
    if wl == 0.0 {
        "0".to_string()
    } else if (1e-3..1e3).contains(&wl) {
        format!("{:.4}", wl)
    } else {
        format!("{:.3e}", wl)
    }
}

fn check(o: &CompareOptions) -> Result<()> {
    let mut problems = Vec::new();
    if !(1..=200).contains(&o.elements) {
        problems.push(crate::FieldError::new("--elements", "must be in 1..=200"));
    }
    if !(1..=10_000_000).contains(&o.samples) {
        problems.push(crate::FieldError::new(
            "--samples",
            "must be in 1..=10000000",
        ));
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(Error::Invalid(problems))
    }
}

/// The candidate kernel for one geometry.
fn candidate_kernel(
    candidate: Candidate,
    geometry: &StrandGeometry,
    factory: Option<&dyn KernelFactory>,
) -> Result<Box<dyn StrandKernel>> {
    let n = geometry.elements();
    match candidate {
        Candidate::GenericAdaptive => Ok(Box::new(GenericKernel::new(
            geometry.clone(),
            QuadratureRule::Adaptive,
        ))),
        Candidate::GenericFixed(k) => Ok(Box::new(GenericKernel::new(
            geometry.clone(),
            QuadratureRule::Fixed(k),
        ))),
        Candidate::Generated => factory
            .filter(|f| f.available().contains(&n))
            .and_then(|f| f.create(geometry))
            .ok_or_else(|| {
                let available = factory.map(|f| f.available()).unwrap_or_default();
                Error::Kernel(format!(
                    "no generated kernel for N = {n} elements (this build has generated fixed-N \
                 kernels for N in {available:?}; SUPERHELIX_N={n} generates one at build time); \
                 compare one of those N, or a generic candidate with --candidate generic-adaptive"
                ))
            }),
    }
}

/// The relative deviations of every quantity in one configuration (order of
/// [`QUANTITIES`]).
fn compare_one(
    c: &Configuration,
    candidate: &mut dyn StrandKernel,
    reference: &mut dyn StrandKernel,
) -> [f64; 12] {
    let dofs = c.geometry.dofs();
    let n = c.geometry.elements();
    let input = EvalInput {
        q: &c.q,
        v: &c.v,
        field: c.field,
        terms: Terms::all(),
    };
    let mut a = StrandTerms::new(dofs);
    let mut b = StrandTerms::new(dofs);
    candidate.evaluate(&input, &mut a);
    reference.evaluate(&input, &mut b);
    let mut dev = [Deviation::default(); 12];
    dev[0].mat(&a.mass, &b.mass);
    dev[1].slices(&a.force, &b.force);
    dev[2].slices(&a.velocity_term, &b.velocity_term);
    dev[3].mat(&a.stiffness, &b.stiffness);
    dev[4].mat(&a.damping, &b.damping);
    dev[5].mat(&a.velocity_term_jacobian, &b.velocity_term_jacobian);
    dev[6].slices(a.first_moment.as_slice(), b.first_moment.as_slice());

    let mut ends_a = vec![Pose::default(); n + 1];
    let mut ends_b = vec![Pose::default(); n + 1];
    candidate.element_ends(&c.q, &mut ends_a);
    reference.element_ends(&c.q, &mut ends_b);
    for (pa, pb) in ends_a.iter().zip(&ends_b) {
        dev[7].slices(pa.position.as_slice(), pb.position.as_slice());
        dev[8].slices(pa.frame.as_slice(), pb.frame.as_slice());
    }

    let mut jac_a = vec![Vector3::zeros(); dofs];
    let mut jac_b = vec![Vector3::zeros(); dofs];
    for &s in &c.points {
        let mut h_a = Mat::zeros(dofs, dofs);
        let mut h_b = Mat::zeros(dofs, dofs);
        let ya = candidate.point(&c.q, s, &mut jac_a, Some((c.hessian_weight, &mut h_a)));
        let yb = reference.point(&c.q, s, &mut jac_b, Some((c.hessian_weight, &mut h_b)));
        dev[9].slices(ya.as_slice(), yb.as_slice());
        dev[10].vectors(&jac_a, &jac_b);
        dev[11].mat(&h_a, &h_b);
    }
    dev.map(|d| d.relative())
}

fn short(x: f64) -> String {
    if x == 0.0 || x >= 1.0 {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Upper ends of the |d|·l ranges of the report (the values of [`WL_LIST`]).
fn wl_range(wl: f64) -> usize {
    WL_LIST
        .iter()
        .position(|&edge| wl <= edge * (1.0 + 1e-9))
        .unwrap_or(WL_LIST.len())
}

fn wl_range_label(i: usize) -> String {
    match i {
        0 => "0".to_string(),
        i if i < WL_LIST.len() => format!("({}, {}]", short(WL_LIST[i - 1]), short(WL_LIST[i])),
        _ => format!("> {}", short(WL_LIST[WL_LIST.len() - 1])),
    }
}

/// Run the comparison. `factory` provides the generated kernels (pass
/// [`crate::kernel_factory()`]); it is needed only for [`Candidate::Generated`], and an
/// N it has no kernel for is an error naming N and the N it has.
pub fn compare_kernels(
    o: &CompareOptions,
    factory: Option<&dyn KernelFactory>,
) -> Result<CompareReport> {
    check(o)?;
    let mut rng = ChaCha8Rng::seed_from_u64(o.seed);
    let mut worst: Vec<Option<Worst>> = vec![None; QUANTITIES.len()];
    let mut ranges = vec![(0usize, 0.0f64); WL_LIST.len() + 1];
    let mut candidate_description = String::new();
    let (mut min_order, mut max_order) = (usize::MAX, 0);
    for index in 0..o.samples {
        let c = configuration(o.elements, index, &mut rng);
        let mut candidate = candidate_kernel(o.candidate, &c.geometry, factory)?;
        if candidate_description.is_empty() {
            candidate_description = candidate.description();
        }
        let order = reference_order(c.max_wl());
        min_order = min_order.min(order);
        max_order = max_order.max(order);
        let mut reference = GenericKernel::new(c.geometry.clone(), QuadratureRule::Fixed(order));
        let deviations = compare_one(&c, candidate.as_mut(), &mut reference);
        let wl = c.max_wl();
        let range = &mut ranges[wl_range(wl)];
        range.0 += 1;
        for (k, &d) in deviations.iter().enumerate() {
            range.1 = range.1.max(d);
            if worst[k].is_none_or(|w| d > w.deviation) {
                worst[k] = Some(Worst {
                    deviation: d,
                    wl,
                    configuration: index,
                    shape: c.shape,
                    preset: c.preset,
                });
            }
        }
    }
    let quantities: Vec<(&'static str, Worst)> = QUANTITIES
        .iter()
        .zip(worst)
        .filter_map(|(name, w)| w.map(|w| (*name, w)))
        .collect();
    let max_relative_deviation = quantities
        .iter()
        .fold(0.0, |m: f64, (_, w)| m.max(w.deviation));
    Ok(CompareReport {
        options: *o,
        candidate: candidate_description,
        reference: format!(
            "generic kernel, max(64, 16 + 2*ceil(largest W·l)) Gauss-Legendre points per element \
             ({min_order}..{max_order} in this run)"
        ),
        quantities,
        by_wl: ranges
            .iter()
            .enumerate()
            .map(|(i, &(count, dev))| WlRange {
                label: wl_range_label(i),
                configurations: count,
                deviation: dev,
            })
            .collect(),
        max_relative_deviation,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candidate_names_round_trip() {
        for c in [
            Candidate::Generated,
            Candidate::GenericAdaptive,
            Candidate::GenericFixed(12),
        ] {
            assert_eq!(Candidate::from_name(&c.name()), Some(c));
        }
        assert_eq!(Candidate::from_name("generic-0"), None);
        assert_eq!(Candidate::from_name("generic-257"), None);
        assert_eq!(Candidate::from_name("closed-form"), None);
    }

    #[test]
    fn configurations_cover_the_list_of_wl_and_every_shape() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let configs: Vec<Configuration> = (0..80).map(|i| configuration(3, i, &mut rng)).collect();
        for x in WL_LIST {
            assert!(
                configs
                    .iter()
                    .any(|c| c.wl.iter().all(|&w| (w - x).abs() <= 1e-12 * x.max(1e-300))),
                "W·l = {x}"
            );
        }
        for shape in Shape::ALL {
            assert!(configs.iter().any(|c| c.shape == shape), "{shape:?}");
        }
        for c in &configs {
            for e in 0..3 {
                let d = &c.q[3 * e..3 * e + 3];
                match c.shape {
                    Shape::Arc => assert!(d[0] == 0.0 && d[2] == 0.0),
                    Shape::Planar => assert_eq!(d[0], 0.0),
                    Shape::Twist => assert!(d[1] == 0.0 && d[2] == 0.0),
                    _ => {}
                }
            }
            assert!(c.max_wl() <= MAX_WL * (1.0 + 1e-12));
        }
        assert!(configs.iter().any(|c| !c.field.has_linear()));
        assert!(configs.iter().any(|c| c.field.has_linear()));
        assert!(configs
            .iter()
            .any(|c| c.field.isotropic_velocity().is_some()));
        assert!(configs
            .iter()
            .any(|c| c.field.isotropic_velocity().is_none()));
    }

    #[test]
    fn reference_order_is_enough_for_the_largest_wl() {
        assert_eq!(reference_order(0.0), 64);
        assert_eq!(reference_order(30.0), 76);
        assert_eq!(reference_order(100.0), 216);
        assert!(reference_order(MAX_WL) <= MAX_ORDER);
    }
}
