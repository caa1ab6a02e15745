//! `superhelix study`: what accuracy costs. A documented set of reference problems is run
//! over a grid of settings (elements N, time step dt, integrator, kernels), and each
//! setting's error against a reference is set against its cost; the report names the
//! Pareto-best setting for common budgets.
//!
//! The problems ([`PROBLEMS`]):
//!
//! 1. `swing`: a straight 20 cm strand of the smooth preset released horizontal under
//!    gravity, no drag, no internal friction. Error: largest distance, over the
//!    setting's time steps in the first `duration` seconds, between its tip and the
//!    tip of a converged reference, divided by the length L.
//! 2. `curly`: a 20 cm curly-preset strand (its drag and friction) on a head shaking at
//!    2 Hz by ±30° about the vertical, gravity. Error as for `swing` (world positions).
//! 3. `frequency`: a straight 5 cm fibre (smooth-preset cross-section), no gravity, no
//!    damping, started in the first bending mode of its discrete model at small
//!    amplitude; the angular frequency measured from the tip's zero crossings (two full
//!    periods) against Euler–Bernoulli ω1 = 1.8751² √(EI/(ρS L⁴)). Error |ω/ω1 − 1|.
//! 4. `cantilever`: a straight 10 cm fibre, a tip load F giving δ = F L³/(3EI) = 1e-4 L,
//!    static solve. Error |δ_N/δ − 1| (the model's value is exactly 1/(4N²)).
//! 5. `floppy`: convergence in dt. A floppy N = 3 strand with nearly straight elements
//!    released under gravity, frictionless and with the preset's internal friction;
//!    linearly implicit Euler and BDF2 over a range of dt, tip error over 1 s against
//!    BDF2 at a very small step with second-order Richardson extrapolation
//!    ((4 x(h/2) − x(h))/3, checked one halving finer), and the measured orders.
//!    Frictionless, linearly implicit Euler damps the stiff twist modes and barely
//!    converges; BDF2 converges at second order: the integrator for accuracy.
//! 6. `rotary`: what the cross-sections' rotary inertia changes, against the paper's
//!    kinetic energy (5b) without it: the twist, bending and centreline of two curved
//!    N = 3 strands (one twisted, one planar) over 0.2 s.
//!
//! 7. `tolerance`: the error-controlled step at tolerances 1e-1 … 1e-6 on the strands
//!    of `swing`, `curly` and `floppy` and on a frictionless helix, against references
//!    of other schemes, and its cost against the best fixed step's at the same error
//!    ([`crate::study_tolerance`]).
//!
//! The reference of `swing` and `curly` is N = 20 with generated kernels and the
//! linearly implicit Euler integrator at two small steps h and h/2, combined by
//! Richardson extrapolation (2 x(h/2) − x(h)); the report gives how far it is from
//! its two ingredients, from BDF2 at h/2 (an independent second-order result: a bound
//! on its time error) and from N = 15 at h/2, which bound what errors are resolved.
//!
//! Cost: on-CPU time of the stepping thread ([`Clock`]), per strand per simulated
//! second (dynamic problems) or per static solve (the cantilever).

use crate::quadrature_table::Clock;
use crate::runtime::config::{
    IntegratorKind, KernelChoice, Mode, SimulationConfig, SimulationSetup, StrandSetup,
};
use crate::runtime::kernels::kernel::{
    BodyField, EvalInput, KernelFactory, StrandKernel, StrandTerms, Terms,
};
use crate::runtime::model::material::{helix_curvature, CrossSection, HelixForm, Preset};
use crate::runtime::model::strand::{PointLoad, Strand, StrandGeometry};
use crate::runtime::{
    Environment, Error, GenericKernel, HeadMotion, Matrix3, QuadratureRule, Result, Simulation,
    StepStats, Vector3,
};
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The problems, by key, in report order.
pub const PROBLEMS: [&str; 7] = [
    "swing",
    "curly",
    "frequency",
    "cantilever",
    "floppy",
    "rotary",
    "tolerance",
];

/// Budgets of the dynamic problems, seconds of CPU per strand per simulated second.
pub const DYNAMIC_BUDGETS: [f64; 5] = [1e-4, 1e-3, 1e-2, 1e-1, 1.0];

/// Budgets of the static problem, seconds of CPU per solve.
pub const STATIC_BUDGETS: [f64; 4] = [1e-5, 1e-4, 1e-3, 1e-2];

/// Which strand kernels a setting uses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kernels {
    /// The generated closed-form kernel for N.
    Generated,
    /// The generic kernel with this quadrature rule.
    Generic(QuadratureRule),
}

impl Kernels {
    /// `generated`, `generic-4`, `generic-adaptive`.
    pub fn label(self) -> String {
        match self {
            Kernels::Generated => "generated".into(),
            Kernels::Generic(QuadratureRule::Fixed(n)) => format!("generic-{n}"),
            Kernels::Generic(QuadratureRule::Adaptive) => "generic-adaptive".into(),
        }
    }
    fn config(self) -> (KernelChoice, QuadratureRule) {
        match self {
            Kernels::Generated => (KernelChoice::Generated, QuadratureRule::Adaptive),
            Kernels::Generic(rule) => (KernelChoice::Generic, rule),
        }
    }
}

/// Short name of an integrator in tables.
pub fn integrator_label(kind: IntegratorKind) -> &'static str {
    match kind {
        IntegratorKind::LinearlyImplicitEuler => "LIE",
        IntegratorKind::NewtonImplicitEuler => "NIE",
        IntegratorKind::Bdf2 => "BDF2",
        IntegratorKind::Rk4 => "RK4",
    }
}

/// Long name of an integrator in the report.
pub fn integrator_description(kind: IntegratorKind) -> &'static str {
    match kind {
        IntegratorKind::LinearlyImplicitEuler => "linearly implicit Euler",
        IntegratorKind::NewtonImplicitEuler => "Newton implicit Euler",
        IntegratorKind::Bdf2 => "linearised BDF2",
        IntegratorKind::Rk4 => "explicit Runge–Kutta 4",
    }
}

/// One point of the grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setting {
    /// Elements N.
    pub elements: usize,
    /// Steps per simulated second (dt = 1/rate); `None` for the static problem.
    pub rate: Option<u32>,
    /// Integrator; `None` for the static problem.
    pub integrator: Option<IntegratorKind>,
    /// Kernels.
    pub kernels: Kernels,
}

impl Setting {
    /// `N=5 dt=1/120 LIE generated`.
    pub fn label(&self) -> String {
        let mut s = format!("N={}", self.elements);
        if let Some(r) = self.rate {
            let _ = write!(s, " dt=1/{r}");
        }
        if let Some(i) = self.integrator {
            let _ = write!(s, " {}", integrator_label(i));
        }
        let _ = write!(s, " {}", self.kernels.label());
        s
    }
    /// The plot series: integrator and kernels.
    pub fn series(&self) -> String {
        match self.integrator {
            Some(i) => format!("{} {}", integrator_label(i), self.kernels.label()),
            None => self.kernels.label(),
        }
    }
    fn dt(&self) -> f64 {
        1.0 / self.rate.unwrap_or(1) as f64
    }
}

/// Error and cost of one setting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    /// The problem's error measure (dimensionless, ≥ 0).
    pub error: f64,
    /// The error with its sign where it has one (frequency: ω/ω1 − 1; cantilever:
    /// δ_N/δ − 1); equal to `error` for the trajectory problems.
    pub signed: f64,
    /// CPU seconds per strand per simulated second, or per solve (statics).
    pub cost: f64,
}

/// One setting's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct Point {
    /// The setting.
    pub setting: Setting,
    /// Error and cost, or why the run failed.
    pub outcome: std::result::Result<Measured, String>,
    /// On the Pareto front (no other point is both cheaper and more accurate).
    pub pareto: bool,
}

/// One problem's results.
#[derive(Debug, Clone, PartialEq)]
pub struct ProblemResult {
    /// Key (`swing`, …), also the plot file's name.
    pub key: &'static str,
    /// Title.
    pub title: String,
    /// Markdown paragraph: setup, error measure, reference.
    pub description: String,
    /// True for the static problem (cost per solve).
    pub is_static: bool,
    /// The points, sorted by cost.
    pub points: Vec<Point>,
    /// Extra markdown (reference checks, spatial-only table).
    pub notes: String,
    /// Frequency problem: (N, ω of the discrete model, ω/ω1 − 1) without time stepping,
    /// for every N of the full grid.
    pub spatial: Vec<(usize, f64, f64)>,
    /// Title of the error axis of the plot, with its unit.
    pub error_title: String,
    /// Convergence problems (`floppy`): error against dt per integrator and friction;
    /// when not empty the plot is error against dt.
    pub convergence: Vec<Convergence>,
    /// Rotary-inertia problem: the measured relative changes.
    pub rotary: Vec<RotaryChange>,
    /// Tolerance problem: asked tolerance against measured error and cost, per case.
    pub tolerance: Vec<crate::study_tolerance::ToleranceCase>,
}

/// Error against dt of one integrator on one strand (`floppy`).
#[derive(Debug, Clone, PartialEq)]
pub struct Convergence {
    /// Integrator.
    pub integrator: IntegratorKind,
    /// With the preset's internal friction (false: frictionless).
    pub friction: bool,
    /// (dt in s, error / L), dt decreasing.
    pub points: Vec<(f64, f64)>,
    /// Least-squares slope of log error against log dt over the smallest three dt.
    pub order: f64,
}

impl Convergence {
    /// `BDF2, frictionless`.
    pub fn label(&self) -> String {
        format!(
            "{}, {}",
            integrator_label(self.integrator),
            if self.friction {
                "internal friction"
            } else {
                "frictionless"
            }
        )
    }
}

/// What rotary inertia changes on one strand (`rotary`).
#[derive(Debug, Clone, PartialEq)]
pub struct RotaryChange {
    /// Which strand.
    pub case: String,
    /// max over t of |τ_with − τ_without| / max over t of |τ_without(t) − τ_without(0)|
    /// (N-vectors of twist): the change relative to the twist's motion; `None` when the
    /// twist does not move.
    pub twist: Option<f64>,
    /// The same for the bending coordinates (κ1, κ2).
    pub bending: Option<f64>,
    /// max over t and centreline points of |x_with − x_without| / L.
    pub centreline: f64,
}

impl ProblemResult {
    /// The budgets of this problem, seconds.
    pub fn budgets(&self) -> &'static [f64] {
        if self.is_static {
            &STATIC_BUDGETS
        } else {
            &DYNAMIC_BUDGETS
        }
    }
    /// The most accurate successful point costing at most `budget` seconds.
    pub fn best_within(&self, budget: f64) -> Option<&Point> {
        self.points
            .iter()
            .filter(|p| matches!(p.outcome, Ok(m) if m.cost <= budget))
            .min_by(|a, b| error_of(a).total_cmp(&error_of(b)))
    }
    /// The successful point of a setting.
    pub fn find(&self, setting: &Setting) -> Option<Measured> {
        self.points
            .iter()
            .find(|p| p.setting == *setting)
            .and_then(|p| p.outcome.clone().ok())
    }
}

fn error_of(p: &Point) -> f64 {
    p.outcome.as_ref().map_or(f64::INFINITY, |m| m.error)
}

/// The grid of a study.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Elements N of the main sweep (generated kernels).
    pub elements: Vec<usize>,
    /// Steps per second of the main sweep.
    pub rates: Vec<u32>,
    /// Integrators of the main sweep.
    pub integrators: Vec<IntegratorKind>,
    /// Generic rules compared with the generated kernels.
    pub generic_rules: Vec<QuadratureRule>,
    /// N of the kernel sweep.
    pub kernel_elements: Vec<usize>,
    /// Steps per second of the kernel sweep (linearly implicit Euler).
    pub kernel_rates: Vec<u32>,
    /// Simulated seconds of `curly`.
    pub duration: f64,
    /// Simulated seconds of `swing`: its first swing down. After it the 20 cm smooth
    /// strand (ρS g L³/EI ≈ 160) whips, and over 1 s the reference does not converge
    /// (N = 15 and N = 20 differ by 0.2 L, dt/2 moves it by 0.1 L).
    pub swing_duration: f64,
    /// Steps per second of the coarser reference run (the finer one has twice as many);
    /// a multiple of every rate.
    pub reference_rate: u32,
    /// Timed repetitions of a static solve (the fastest counts).
    pub static_repeats: usize,
    /// Steps per second of `floppy`'s convergence sweep.
    pub floppy_rates: Vec<u32>,
    /// Steps per second of `floppy`'s coarser reference run (BDF2; the finer has twice
    /// as many); a multiple of every floppy rate.
    pub floppy_reference_rate: u32,
    /// Steps per second of the two runs of `rotary` (BDF2).
    pub rotary_rate: u32,
    /// Tolerances of `tolerance`.
    pub tolerances: Vec<f64>,
    /// Steps per second of `tolerance`'s fixed-step runs (each a multiple of the frame
    /// rate, 30).
    pub tolerance_fixed_rates: Vec<u32>,
    /// The coarsest rate of the swing's reference in `tolerance` (BDF2 at twice and four
    /// times it, Richardson-extrapolated).
    pub tolerance_swing_reference_rate: u32,
    /// The same for `curly`.
    pub tolerance_curly_reference_rate: u32,
}

impl Grid {
    /// The full study of issue #4.
    pub fn full() -> Self {
        Grid {
            elements: vec![1, 2, 3, 5, 8, 10, 15, 20],
            rates: vec![24, 30, 60, 120, 240, 1000],
            integrators: vec![
                IntegratorKind::LinearlyImplicitEuler,
                IntegratorKind::NewtonImplicitEuler,
                IntegratorKind::Bdf2,
            ],
            generic_rules: vec![
                QuadratureRule::Fixed(2),
                QuadratureRule::Fixed(4),
                QuadratureRule::Fixed(8),
                QuadratureRule::Adaptive,
            ],
            kernel_elements: vec![5, 10, 20],
            kernel_rates: vec![30, 240],
            duration: 1.0,
            swing_duration: 0.5,
            reference_rate: 6000,
            static_repeats: 5,
            floppy_rates: vec![30, 100, 300, 1000, 3000],
            floppy_reference_rate: 60000,
            rotary_rate: 100000,
            tolerances: crate::study_tolerance::TOLERANCES.to_vec(),
            tolerance_fixed_rates: (0..=10).map(|k| 30 << k).collect(),
            tolerance_swing_reference_rate: 48000,
            tolerance_curly_reference_rate: 6000,
        }
    }
    /// The reduced grid of `--quick` (CI).
    pub fn quick() -> Self {
        Grid {
            elements: vec![2, 5, 10, 20],
            rates: vec![30, 120, 240],
            integrators: vec![
                IntegratorKind::LinearlyImplicitEuler,
                IntegratorKind::NewtonImplicitEuler,
                IntegratorKind::Bdf2,
            ],
            generic_rules: vec![
                QuadratureRule::Fixed(2),
                QuadratureRule::Fixed(4),
                QuadratureRule::Adaptive,
            ],
            kernel_elements: vec![5],
            kernel_rates: vec![120],
            duration: 0.5,
            swing_duration: 0.5,
            reference_rate: 2400,
            static_repeats: 3,
            floppy_rates: vec![30, 100, 300, 1000],
            floppy_reference_rate: 30000,
            rotary_rate: 100000,
            tolerances: crate::study_tolerance::QUICK_TOLERANCES.to_vec(),
            tolerance_fixed_rates: (0..=6).map(|k| 30 << k).collect(),
            tolerance_swing_reference_rate: 12000,
            tolerance_curly_reference_rate: 1500,
        }
    }

    /// The dynamic settings: the main sweep with generated kernels, then the kernel
    /// sweep with the generic rules.
    pub fn dynamic_settings(&self) -> Vec<Setting> {
        let mut out = Vec::new();
        for &integrator in &self.integrators {
            for &elements in &self.elements {
                for &rate in &self.rates {
                    out.push(Setting {
                        elements,
                        rate: Some(rate),
                        integrator: Some(integrator),
                        kernels: Kernels::Generated,
                    });
                }
            }
        }
        for &rule in &self.generic_rules {
            for &elements in &self.kernel_elements {
                for &rate in &self.kernel_rates {
                    out.push(Setting {
                        elements,
                        rate: Some(rate),
                        integrator: Some(IntegratorKind::LinearlyImplicitEuler),
                        kernels: Kernels::Generic(rule),
                    });
                }
            }
        }
        // the kernel sweep's generated points, when the main sweep lacks them
        for &elements in &self.kernel_elements {
            for &rate in &self.kernel_rates {
                let s = Setting {
                    elements,
                    rate: Some(rate),
                    integrator: Some(IntegratorKind::LinearlyImplicitEuler),
                    kernels: Kernels::Generated,
                };
                if !out.contains(&s) {
                    out.push(s);
                }
            }
        }
        out
    }

    /// The static settings: every N, generated and generic kernels.
    pub fn static_settings(&self) -> Vec<Setting> {
        let mut out = Vec::new();
        for kernels in std::iter::once(Kernels::Generated)
            .chain(self.generic_rules.iter().map(|&r| Kernels::Generic(r)))
        {
            for &elements in &self.elements {
                out.push(Setting {
                    elements,
                    rate: None,
                    integrator: None,
                    kernels,
                });
            }
        }
        out
    }
}

/// What `study` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyOptions {
    /// The reduced grid.
    pub quick: bool,
    /// Only this problem (a key of [`PROBLEMS`]); all of them when `None`.
    pub only: Option<String>,
    /// The command line, quoted in the report.
    pub command: String,
}

/// A finished study.
#[derive(Debug, Clone, PartialEq)]
pub struct Study {
    /// Options run.
    pub options: StudyOptions,
    /// The grid.
    pub grid: Grid,
    /// Results, in [`PROBLEMS`] order.
    pub problems: Vec<ProblemResult>,
    /// Wall time of the whole study, s.
    pub wall_seconds: f64,
    /// How costs were measured.
    pub clock: Clock,
    /// Cost of one strand-step against N for each path ([`crate::study_cost`]).
    pub cost: Vec<crate::study_cost::CostPoint>,
}

// ---------------------------------------------------------------- problem set-ups

/// The smooth preset's cross-section (r = 50 µm, e = 1, E = 1 GPa).
fn round_fibre() -> CrossSection {
    Preset::Smooth.params().cross_section
}

/// A strand of N equal elements, root at `root`, tangent `direction`, uniform natural
/// (τ, κ1, κ2).
#[allow(clippy::too_many_arguments)]
fn strand(
    cs: CrossSection,
    n: usize,
    length: f64,
    root: Vector3<f64>,
    direction: Vector3<f64>,
    natural: [f64; 3],
    gamma: f64,
    nu: f64,
) -> Strand {
    let material = cs.material();
    let n0 = direction.normalize();
    let n2 = if n0.z.abs() < 0.9 {
        Vector3::z()
    } else {
        Vector3::x()
    };
    let n2 = (n2 - n0 * n0.dot(&n2)).normalize();
    let n1 = n2.cross(&n0);
    Strand {
        name: format!("n{n}"),
        geometry: StrandGeometry::new(
            root,
            Matrix3::from_columns(&[n0, n1, n2]),
            vec![length / n as f64; n],
            &material,
        ),
        material,
        natural: (0..n).flat_map(|_| natural).collect(),
        internal_friction: gamma,
        air_drag: nu,
        point_loads: Vec::new(),
        ends: Default::default(),
    }
}

pub(crate) fn setup_of(
    strand: Strand,
    setting: &Setting,
    duration: f64,
    gravity: bool,
    head: HeadMotion,
) -> SimulationSetup {
    let (kernels, quadrature) = setting.kernels.config();
    SimulationSetup {
        electrostatics: None,
        contacts: None,
        config: SimulationConfig {
            mode: if setting.rate.is_some() {
                Mode::Dynamic
            } else {
                Mode::Static
            },
            dt: setting.dt(),
            duration,
            integrator: setting
                .integrator
                .unwrap_or(IntegratorKind::LinearlyImplicitEuler),
            kernels,
            quadrature,
            ..SimulationConfig::default()
        },
        environment: Environment {
            gravity: gravity.then(|| Vector3::new(0.0, 0.0, -9.81)),
        },
        head,
        strands: vec![StrandSetup {
            charge_per_length: None,
            tip: None,
            q0: strand.natural.clone(),
            group: strand.name.clone(),
            strand,
        }],
        bodies: Vec::new(),
        samples_per_element: 1,
        output: Default::default(),
    }
}

pub(crate) const SWING_LENGTH: f64 = 0.2;
pub(crate) const CURLY_LENGTH: f64 = 0.2;
const FREQUENCY_LENGTH: f64 = 0.05;
const CANTILEVER_LENGTH: f64 = 0.1;

pub(crate) fn swing_setup(setting: &Setting, duration: f64) -> SimulationSetup {
    let s = strand(
        round_fibre(),
        setting.elements,
        SWING_LENGTH,
        Vector3::zeros(),
        Vector3::x(),
        [0.0; 3],
        0.0,
        0.0,
    );
    setup_of(s, setting, duration, true, HeadMotion::Still)
}

fn shaking_head() -> HeadMotion {
    HeadMotion::Oscillate {
        axis: Vector3::z(),
        amplitude: 30f64.to_radians(),
        frequency_hz: 2.0,
        center: Vector3::zeros(),
    }
}

pub(crate) fn curly_setup(setting: &Setting, duration: f64) -> SimulationSetup {
    let p = Preset::Curly.params();
    let s = strand(
        p.cross_section,
        setting.elements,
        CURLY_LENGTH,
        Vector3::new(0.1, 0.0, 0.0),
        Vector3::x(),
        helix_curvature(p.helix_radius, p.helix_step, HelixForm::Exact),
        p.internal_friction,
        p.air_drag,
    );
    setup_of(s, setting, duration, true, shaking_head())
}

// ---------------------------------------------------------------- timing

/// Run `steps` steps, recording the tip (world) before the first and after every
/// step; returns the trajectory and the CPU seconds of the steps alone.
fn tip_trajectory(
    setup: SimulationSetup,
    factory: Option<&dyn KernelFactory>,
    steps: usize,
) -> TipRun {
    tip_run(setup, factory, steps).map(|(tips, cpu, _)| (tips, cpu))
}

/// [`tip_trajectory`] with the run's step statistics.
pub(crate) fn tip_run(
    setup: SimulationSetup,
    factory: Option<&dyn KernelFactory>,
    steps: usize,
) -> std::result::Result<(Vec<Vector3<f64>>, f64, StepStats), String> {
    let mut sim = Simulation::new(setup, factory).map_err(|e| e.to_string())?;
    let per = 1;
    let tip = |sim: &mut Simulation| {
        let p = *sim.centreline_world(0, per).last().expect("a root point");
        Vector3::new(p[0], p[1], p[2])
    };
    let mut out = Vec::with_capacity(steps + 1);
    out.push(tip(&mut sim));
    let mut cpu = 0.0;
    for _ in 0..steps {
        let t0 = now();
        sim.step().map_err(|e| e.to_string())?;
        cpu += now() - t0;
        out.push(tip(&mut sim));
    }
    Ok((out, cpu, sim.stats()))
}

/// A tip trajectory and the CPU seconds of its steps, or why the run failed.
type TipRun = std::result::Result<(Vec<Vector3<f64>>, f64), String>;

thread_local! {
    static START: Instant = Instant::now();
}

fn now() -> f64 {
    crate::cpu_time::thread_seconds().unwrap_or_else(|| START.with(|s| s.elapsed().as_secs_f64()))
}

// ---------------------------------------------------------------- trajectory problems

/// A converged tip trajectory on the reference grid (`reference_rate` steps per
/// second) and how it was checked.
pub(crate) struct Reference {
    /// The reference tip, world coordinates, at every step of the reference grid.
    pub tips: Vec<Vector3<f64>>,
    /// Steps per second of the reference grid.
    pub rate: u32,
    notes: String,
}

pub(crate) fn max_distance(a: &[Vector3<f64>], b: &[Vector3<f64>], stride_b: usize) -> f64 {
    a.iter()
        .enumerate()
        .map(|(k, x)| (x - b[k * stride_b]).norm())
        .fold(0.0, f64::max)
}

pub(crate) const REFERENCE_N: usize = 20;
const CHECK_N: usize = 15;

fn reference(
    make: &(dyn Fn(&Setting, f64) -> SimulationSetup + Sync),
    grid: &Grid,
    duration: f64,
    length: f64,
    factory: Option<&dyn KernelFactory>,
) -> Result<Reference> {
    let rate = grid.reference_rate;
    let lie = IntegratorKind::LinearlyImplicitEuler;
    let runs: Vec<(usize, u32, IntegratorKind)> = vec![
        (REFERENCE_N, rate, lie),
        (REFERENCE_N, 2 * rate, lie),
        (CHECK_N, 2 * rate, lie),
        (REFERENCE_N, 2 * rate, IntegratorKind::Bdf2),
    ];
    let results: Vec<TipRun> = runs
        .par_iter()
        .map(|&(elements, r, integrator)| {
            let setting = Setting {
                elements,
                rate: Some(r),
                integrator: Some(integrator),
                kernels: Kernels::Generated,
            };
            let steps = (duration * r as f64).round() as usize;
            tip_trajectory(make(&setting, duration), factory, steps)
        })
        .collect();
    let mut trajectories = Vec::new();
    for (r, (n, rate, integrator)) in results.into_iter().zip(&runs) {
        trajectories.push(r.map_err(|e| {
            Error::invalid(
                "study.reference",
                format!(
                    "reference run N = {n}, dt = 1/{rate}, {} failed: {e}",
                    integrator_label(*integrator)
                ),
            )
        })?);
    }
    let coarse = &trajectories[0].0;
    let fine = &trajectories[1].0;
    let check = &trajectories[2].0;
    let second_order = &trajectories[3].0;
    let tips: Vec<Vector3<f64>> = coarse
        .iter()
        .enumerate()
        .map(|(j, c)| 2.0 * fine[2 * j] - c)
        .collect();
    let d_coarse = max_distance(&tips, coarse, 1) / length;
    let d_fine = max_distance(&tips, fine, 2) / length;
    let d_n = max_distance(&tips, check, 2) / length;
    let d_bdf2 = max_distance(&tips, second_order, 2) / length;
    let notes = format!(
        "Reference: N = {REFERENCE_N}, generated kernels, linearly implicit Euler at dt = 1/{rate} \
         and 1/{} s combined by Richardson extrapolation 2 x(dt/2) − x(dt). Its distance (max over \
         time, / L) from the run at 1/{rate}: {d_coarse:.2e}; from the run at 1/{}: {d_fine:.2e} \
         (the first-order error of that run); from BDF2 at 1/{}: {d_bdf2:.2e} (two independent \
         second-order results: a bound on the reference's own time error, and the floor below \
         which N = {REFERENCE_N} errors are not resolved); from N = {CHECK_N} at 1/{}: {d_n:.2e}, an \
         estimate of N = {REFERENCE_N}'s own spatial error: errors of coarser N below about {:.0e} \
         are not resolved, while N = {REFERENCE_N} settings share the reference's discretisation and \
         measure time error alone.",
        2 * rate,
        2 * rate,
        2 * rate,
        2 * rate,
        d_n.max(d_bdf2),
    );
    Ok(Reference { tips, rate, notes })
}

#[allow(clippy::too_many_arguments)]
fn trajectory_problem(
    key: &'static str,
    title: &str,
    description: String,
    make: &(dyn Fn(&Setting, f64) -> SimulationSetup + Sync),
    length: f64,
    grid: &Grid,
    duration: f64,
    factory: Option<&dyn KernelFactory>,
) -> Result<ProblemResult> {
    let reference = reference(make, grid, duration, length, factory)?;
    let settings = grid.dynamic_settings();
    let points: Vec<Point> = settings
        .par_iter()
        .map(|setting| {
            let rate = setting.rate.unwrap_or(1);
            let steps = (duration * rate as f64).round() as usize;
            let stride = (reference.rate / rate) as usize;
            let outcome =
                tip_trajectory(make(setting, duration), factory, steps).map(|(tips, cpu)| {
                    let error = max_distance(&tips, &reference.tips, stride) / length;
                    Measured {
                        error,
                        signed: error,
                        cost: cpu / duration,
                    }
                });
            Point {
                setting: *setting,
                outcome,
                pareto: false,
            }
        })
        .collect();
    Ok(finish(ProblemResult {
        key,
        title: title.into(),
        description,
        is_static: false,
        points,
        notes: reference.notes.clone(),
        spatial: Vec::new(),
        error_title: "error: max over time of |tip − tip_ref| / L".into(),
        convergence: Vec::new(),
        rotary: Vec::new(),
        tolerance: Vec::new(),
    }))
}

// ---------------------------------------------------------------- frequency

/// Euler–Bernoulli first bending angular frequency of a clamped-free beam.
pub fn euler_bernoulli_omega(ei: f64, mass_per_length: f64, length: f64) -> f64 {
    1.8751_f64.powi(2) * (ei / (mass_per_length * length.powi(4))).sqrt()
}

/// First eigenpair of K x = λ M x at q = 0 (mass by the adaptive generic kernel).
fn first_mode(strand: &Strand) -> (f64, Vec<f64>) {
    use nalgebra::{DMatrix, DVector};
    let n = strand.geometry.dofs();
    let mut kernel = GenericKernel::new(strand.geometry.clone(), QuadratureRule::Adaptive);
    let mut out = StrandTerms::new(n);
    let zero = vec![0.0; n];
    kernel.evaluate(
        &EvalInput {
            q: &zero,
            v: &zero,
            field: BodyField::zero(),
            terms: Terms {
                mass: true,
                ..Default::default()
            },
        },
        &mut out,
    );
    let m = DMatrix::from_fn(n, n, |i, j| out.mass[(i, j)]);
    let k = DVector::from_vec(strand.stiffness_diagonal());
    let l = m.cholesky().expect("M is positive definite").l();
    let linv = l.try_inverse().expect("L is invertible");
    let c = &linv * DMatrix::from_diagonal(&k) * linv.transpose();
    let eig = c.symmetric_eigen();
    let i = (0..n)
        .min_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]))
        .unwrap_or(0);
    let x = linv.transpose() * eig.eigenvectors.column(i);
    (eig.eigenvalues[i].sqrt(), x.iter().copied().collect())
}

fn frequency_strand(n: usize) -> Strand {
    strand(
        round_fibre(),
        n,
        FREQUENCY_LENGTH,
        Vector3::zeros(),
        Vector3::x(),
        [0.0; 3],
        0.0,
        0.0,
    )
}

/// Angular frequency measured from 5 zero crossings (two periods) of the tip's
/// displacement along its initial direction, and the CPU seconds per simulated second.
fn measured_frequency(
    setting: &Setting,
    omega_eb: f64,
    factory: Option<&dyn KernelFactory>,
) -> std::result::Result<Measured, String> {
    let s = frequency_strand(setting.elements);
    let n = s.geometry.dofs();
    let (omega_discrete, mode) = first_mode(&s);
    let scale = 1e-3 / mode.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let q0: Vec<f64> = mode.iter().map(|x| x * scale).collect();
    let mut sim = Simulation::new(setup_of(s, setting, 1.0, false, HeadMotion::Still), factory)
        .map_err(|e| e.to_string())?;
    sim.set_state(0, &q0, &vec![0.0; n]);
    let rest = Vector3::new(FREQUENCY_LENGTH, 0.0, 0.0);
    let start = sim.position_at(0, FREQUENCY_LENGTH) - rest;
    let u = start.normalize();
    let dt = setting.dt();
    let period = 2.0 * std::f64::consts::PI / omega_eb;
    let mut prev = start.dot(&u);
    let mut crossings = Vec::new();
    let mut cpu = 0.0;
    while crossings.len() < 5 {
        if sim.time() > 4.0 * period {
            return Err("fewer than 5 zero crossings in 4 periods".into());
        }
        let t0 = now();
        sim.step().map_err(|e| e.to_string())?;
        cpu += now() - t0;
        let z = (sim.position_at(0, FREQUENCY_LENGTH) - rest).dot(&u);
        if prev.signum() != z.signum() {
            crossings.push(sim.time() - dt * z / (z - prev));
        }
        prev = z;
    }
    let omega = 2.0 * std::f64::consts::PI / ((crossings[4] - crossings[0]) / 2.0);
    Ok(Measured {
        error: (omega_discrete / omega_eb - 1.0).abs() + (omega / omega_discrete - 1.0).abs(),
        signed: omega / omega_eb - 1.0,
        cost: cpu / sim.time(),
    })
}

fn frequency_problem(grid: &Grid, factory: Option<&dyn KernelFactory>) -> ProblemResult {
    let m = round_fibre().material();
    let omega_eb = euler_bernoulli_omega(m.stiffness[1], m.mass_per_length, FREQUENCY_LENGTH);
    let settings = grid.dynamic_settings();
    let points: Vec<Point> = settings
        .par_iter()
        .map(|setting| Point {
            setting: *setting,
            outcome: measured_frequency(setting, omega_eb, factory),
            pareto: false,
        })
        .collect();
    let mut notes = String::from(
        "Spatial error alone (eigenvalue of the linearised discrete model, K x = ω² M x at q = 0, \
         no time stepping), every N of the full grid:\n\n| N | ω of the discrete model, rad/s | ω/ω1 − 1 |\n|---|---|---|\n",
    );
    let spatial: Vec<(usize, f64, f64)> = Grid::full()
        .elements
        .iter()
        .map(|&n| {
            let (omega, _) = first_mode(&frequency_strand(n));
            (n, omega, omega / omega_eb - 1.0)
        })
        .collect();
    for (n, omega, e) in &spatial {
        let _ = writeln!(notes, "| {n} | {omega:.4} | {e:+.3e} |");
    }

    let description = format!(
        "A straight {} cm fibre of the smooth preset's cross-section (r = 50 µm, E = 1 GPa), no \
         gravity, no drag or friction, started at rest in the first bending mode of its discrete \
         model (largest curvature 1e-3 rad/m). The angular frequency is measured from the tip's \
         zero crossings over two full periods and compared with Euler–Bernoulli ω1 = 1.8751² \
         √(EI/(ρS L⁴)) = {omega_eb:.4} rad/s. Error: |ω_N/ω1 − 1| + |ω/ω_N − 1|, with ω_N the \
         discrete model's eigenvalue: the spatial error (second order in 1/N, the model is \
         stiffer) and the time stepping's error (implicit Euler lengthens the period by \
         ≈ (ω dt)²/3, and so does BDF2) added in magnitude, because with signs they cancel (N = 3 at dt = \
         1/120 s lands within 6e-4 of ω1 by luck); the signed ω/ω1 − 1 is in the table. \
         Cost: CPU time per strand per simulated second.",
        FREQUENCY_LENGTH * 100.0
    );
    finish(ProblemResult {
        key: "frequency",
        title: "First bending frequency against Euler–Bernoulli".into(),
        description,
        is_static: false,
        points,
        notes,
        spatial,
        error_title: "error: |ω_N/ω1 − 1| + |ω/ω_N − 1|".into(),
        convergence: Vec::new(),
        rotary: Vec::new(),
        tolerance: Vec::new(),
    })
}

// ---------------------------------------------------------------- cantilever

fn cantilever_point(
    setting: &Setting,
    repeats: usize,
    factory: Option<&dyn KernelFactory>,
) -> std::result::Result<Measured, String> {
    let cs = round_fibre();
    let ei = cs.material().stiffness[1];
    let delta = 1e-4 * CANTILEVER_LENGTH;
    let force = 3.0 * ei * delta / CANTILEVER_LENGTH.powi(3);
    let mut s = strand(
        cs,
        setting.elements,
        CANTILEVER_LENGTH,
        Vector3::zeros(),
        Vector3::x(),
        [0.0; 3],
        0.0,
        0.0,
    );
    s.point_loads.push(PointLoad {
        s: CANTILEVER_LENGTH,
        force: Vector3::new(0.0, 0.0, -force),
        follows: false,
        torque: nalgebra::Vector3::zeros(),
    });
    let setup = setup_of(s, setting, 0.0, false, HeadMotion::Still);
    let mut best = f64::INFINITY;
    let mut signed = f64::NAN;
    for _ in 0..repeats.max(1) {
        let mut sim = Simulation::new(setup.clone(), factory).map_err(|e| e.to_string())?;
        let t0 = now();
        let report = sim.solve_static().map_err(|e| e.to_string())?[0];
        best = best.min(now() - t0);
        if !report.converged {
            return Err(format!("static solve did not converge: {report:?}"));
        }
        let tip = sim.position_at(0, CANTILEVER_LENGTH);
        signed = -tip.z / delta - 1.0;
    }
    Ok(Measured {
        error: signed.abs(),
        signed,
        cost: best,
    })
}

fn cantilever_problem(grid: &Grid, factory: Option<&dyn KernelFactory>) -> ProblemResult {
    let points: Vec<Point> = grid
        .static_settings()
        .par_iter()
        .map(|setting| Point {
            setting: *setting,
            outcome: cantilever_point(setting, grid.static_repeats, factory),
            pareto: false,
        })
        .collect();
    finish(ProblemResult {
        key: "cantilever",
        title: "Static cantilever against F L³/(3EI)".into(),
        description: format!(
            "A straight {} cm fibre (smooth preset's cross-section), clamped horizontal, a tip \
             load F such that F L³/(3EI) = 1e-4 L (linear regime), no gravity; static solve \
             (Newton with line search to a relative residual of 1e-11). Error: |δ_N / (F L³/(3EI)) − 1|; \
             the model's piecewise-constant curvature gives exactly 1/(4N²). Cost: CPU time of \
             one static solve (best of {}).",
            CANTILEVER_LENGTH * 100.0,
            grid.static_repeats
        ),
        is_static: true,
        points,
        notes: String::new(),
        spatial: Vec::new(),
        error_title: "error: |δ_N / (F L³/(3EI)) − 1|".into(),
        convergence: Vec::new(),
        rotary: Vec::new(),
        tolerance: Vec::new(),
    })
}

// ---------------------------------------------------------------- floppy

pub(crate) const FLOPPY_LENGTH: f64 = 0.2;
pub(crate) const FLOPPY_N: usize = 3;
pub(crate) const FLOPPY_DURATION: f64 = 1.0;
/// Natural (τ, κ1, κ2) of the floppy strand, rad/m: each 6.7 cm element turns by
/// 0.13 rad, nearly straight, so its twist has little inertia and is stiff.
const FLOPPY_NATURAL: [f64; 3] = [0.2, 2.0, 0.0];
/// Natural (τ, κ1, κ2) of the helical strand of `rotary`, rad/m (nearly straight
/// elements, out-of-plane curvature: gravity excites the twist).
const ROTARY_NATURAL: [f64; 3] = [0.5, 1.0, 0.5];

/// The floppy strand: curly preset, N = 3, 20 cm, natural helix, root horizontal,
/// released from rest under gravity (off equilibrium), no drag; internal friction of
/// the preset or none.
pub(crate) fn floppy_strand(friction: bool) -> Strand {
    let p = Preset::Curly.params();
    strand(
        p.cross_section,
        FLOPPY_N,
        FLOPPY_LENGTH,
        Vector3::zeros(),
        Vector3::x(),
        FLOPPY_NATURAL,
        if friction { p.internal_friction } else { 0.0 },
        0.0,
    )
}

/// The frictionless helix of the `tolerance` problem: the curly preset's cross-section
/// and natural helix (radius 6 mm, step 5 mm, the exact form), N = 3, 20 cm, hanging from
/// its root, released at rest in its natural shape under gravity, no internal friction
/// and no drag: nothing damps the errors its steps make.
pub(crate) fn helix_strand() -> Strand {
    let p = Preset::Curly.params();
    strand(
        p.cross_section,
        HELIX_N,
        HELIX_LENGTH,
        Vector3::zeros(),
        -Vector3::z(),
        helix_curvature(p.helix_radius, p.helix_step, HelixForm::Exact),
        0.0,
        0.0,
    )
}

/// The helix's elements, length (m) and duration (s).
pub(crate) const HELIX_N: usize = 3;
/// See [`HELIX_N`].
pub(crate) const HELIX_LENGTH: f64 = 0.2;
/// See [`HELIX_N`].
pub(crate) const HELIX_DURATION: f64 = 1.0;

fn floppy_run(
    friction: bool,
    integrator: IntegratorKind,
    rate: u32,
    factory: Option<&dyn KernelFactory>,
) -> TipRun {
    let setting = Setting {
        elements: FLOPPY_N,
        rate: Some(rate),
        integrator: Some(integrator),
        kernels: Kernels::Generated,
    };
    let setup = setup_of(
        floppy_strand(friction),
        &setting,
        FLOPPY_DURATION,
        true,
        HeadMotion::Still,
    );
    let steps = (FLOPPY_DURATION * rate as f64).round() as usize;
    tip_trajectory(setup, factory, steps)
}

/// Least-squares slope of log y against log x.
fn log_slope(points: &[(f64, f64)]) -> f64 {
    let logs: Vec<(f64, f64)> = points.iter().map(|&(x, y)| (x.ln(), y.ln())).collect();
    let n = logs.len() as f64;
    let (mx, my) = logs
        .iter()
        .fold((0.0, 0.0), |(a, b), &(x, y)| (a + x / n, b + y / n));
    let (sxy, sxx) = logs.iter().fold((0.0, 0.0), |(a, b), &(x, y)| {
        (a + (x - mx) * (y - my), b + (x - mx) * (x - mx))
    });
    sxy / sxx
}

/// The floppy problem.
fn floppy_problem(grid: &Grid, factory: Option<&dyn KernelFactory>) -> Result<ProblemResult> {
    let r = grid.floppy_reference_rate;
    let mut notes = String::new();
    let mut convergence = Vec::new();
    for friction in [false, true] {
        let runs: Vec<TipRun> = [r, 2 * r, 4 * r]
            .par_iter()
            .map(|&rate| floppy_run(friction, IntegratorKind::Bdf2, rate, factory))
            .collect();
        let mut tips = Vec::new();
        for (run, rate) in runs.into_iter().zip([r, 2 * r, 4 * r]) {
            tips.push(
                run.map_err(|e| {
                    Error::invalid(
                        "study.floppy",
                        format!("reference run BDF2 dt = 1/{rate} failed: {e}"),
                    )
                })?
                .0,
            );
        }
        // second-order Richardson (4 x(h/2) − x(h)) / 3, on the grid of h
        let richardson = |coarse: &[Vector3<f64>], fine: &[Vector3<f64>]| -> Vec<Vector3<f64>> {
            coarse
                .iter()
                .enumerate()
                .map(|(j, c)| (4.0 * fine[2 * j] - c) / 3.0)
                .collect()
        };
        let reference = richardson(&tips[0], &tips[1]);
        let finer = richardson(&tips[1], &tips[2]);
        let d_fine = max_distance(&reference, &tips[1], 2) / FLOPPY_LENGTH;
        let d_next = max_distance(&reference, &finer, 2) / FLOPPY_LENGTH;
        let _ = writeln!(
            notes,
            "Reference ({}): BDF2 at dt = 1/{r} and 1/{} s combined by second-order Richardson \
             extrapolation (4 x(dt/2) − x(dt))/3. Its distance (max over time, / L) from BDF2 at \
             1/{}: {d_fine:.2e}; from the same extrapolation one halving finer (1/{} and 1/{}): \
             {d_next:.2e}, its own error, below every error it measures here.\n",
            if friction {
                "internal friction"
            } else {
                "frictionless"
            },
            2 * r,
            2 * r,
            2 * r,
            4 * r
        );
        for integrator in [IntegratorKind::LinearlyImplicitEuler, IntegratorKind::Bdf2] {
            let results: Vec<(u32, TipRun)> = grid
                .floppy_rates
                .par_iter()
                .map(|&rate| (rate, floppy_run(friction, integrator, rate, factory)))
                .collect();
            let mut points = Vec::new();
            for (rate, run) in results {
                let (run_tips, _) = run.map_err(|e| {
                    Error::invalid(
                        "study.floppy",
                        format!("{} dt = 1/{rate} failed: {e}", integrator_label(integrator)),
                    )
                })?;
                let stride = (r / rate) as usize;
                let error = max_distance(&run_tips, &reference, stride) / FLOPPY_LENGTH;
                points.push((1.0 / rate as f64, error));
            }
            let tail = &points[points.len().saturating_sub(3)..];
            convergence.push(Convergence {
                integrator,
                friction,
                order: log_slope(tail),
                points,
            });
        }
    }
    let p = Preset::Curly.params();
    Ok(ProblemResult {
        key: "floppy",
        title: "Convergence in dt of a floppy strand, frictionless and with friction".into(),
        description: format!(
            "A floppy {} cm strand of the curly preset's cross-section and friction, natural \
             (τ, κ1, κ2) = ({}, {}, {}) rad/m (nearly straight elements), N = {FLOPPY_N}, \
             generated kernels, root clamped horizontal, released from rest in its natural shape \
             under gravity, no drag, for {FLOPPY_DURATION} s: once frictionless, once with the \
             preset's internal friction γ = {:e} kg·m³/s. Error: max over the setting's time \
             steps of |tip − tip_ref| / L, for linearly implicit Euler (LIE) and BDF2. The \
             order is the least-squares slope of log error against log dt over the three \
             smallest dt. Without friction, the stiff twist modes of the nearly straight \
             elements are not resolved by any of these steps: linearly implicit Euler damps \
             them, which changes the motion, and converges slowly; BDF2 converges at second \
             order. A user who needs accuracy picks BDF2.",
            FLOPPY_LENGTH * 100.0,
            FLOPPY_NATURAL[0],
            FLOPPY_NATURAL[1],
            FLOPPY_NATURAL[2],
            p.internal_friction
        ),
        is_static: false,
        points: Vec::new(),
        notes,
        spatial: Vec::new(),
        error_title: "error: max over time of |tip − tip_ref| / L".into(),
        convergence,
        rotary: Vec::new(),
        tolerance: Vec::new(),
    })
}

// ---------------------------------------------------------------- rotary

const ROTARY_DURATION: f64 = 0.2;

/// Generalized coordinates and centreline (world) of a strand at one time.
type State = (Vec<f64>, Vec<[f64; 3]>);

/// q and the centreline after every step (and at the start) of a BDF2 run.
fn state_trajectory(
    setup: SimulationSetup,
    factory: Option<&dyn KernelFactory>,
    steps: usize,
) -> std::result::Result<Vec<State>, String> {
    let mut sim = Simulation::new(setup, factory).map_err(|e| e.to_string())?;
    let mut out = Vec::with_capacity(steps + 1);
    out.push((sim.q(0).to_vec(), sim.centreline_world(0, 4)));
    for _ in 0..steps {
        sim.step().map_err(|e| e.to_string())?;
        out.push((sim.q(0).to_vec(), sim.centreline_world(0, 4)));
    }
    Ok(out)
}

/// max over t of |a_sel(t) − b_sel(t)| / max over t of |b_sel(t) − b_sel(0)|: the
/// change relative to the motion of the coordinates k of q with `select(k)`; `None`
/// when they do not move (beyond 1e-9 rad/m).
fn relative_change(a: &[State], b: &[State], select: impl Fn(usize) -> bool) -> Option<f64> {
    let norm = |x: &mut dyn Iterator<Item = f64>| x.map(|v| v * v).sum::<f64>().sqrt();
    let start = &b.first()?.0;
    let (mut diff, mut motion) = (0.0f64, 0.0f64);
    for (x, y) in a.iter().zip(b) {
        let n = x.0.len();
        diff = diff.max(norm(
            &mut (0..n).filter(|&k| select(k)).map(|k| x.0[k] - y.0[k]),
        ));
        motion = motion.max(norm(
            &mut (0..n).filter(|&k| select(k)).map(|k| y.0[k] - start[k]),
        ));
    }
    (motion > 1e-9).then(|| diff / motion)
}

fn rotary_problem(grid: &Grid, factory: Option<&dyn KernelFactory>) -> Result<ProblemResult> {
    let p = Preset::Curly.params();
    let cases: [(&str, [f64; 3]); 2] = [
        ("twisted: (τ, κ1, κ2) = (0.5, 1, 0.5) rad/m", ROTARY_NATURAL),
        (
            "planar: (0, 1, 0) rad/m, bending in the plane of gravity only",
            [0.0, ROTARY_NATURAL[1], 0.0],
        ),
    ];
    let rate = grid.rotary_rate;
    let setting = Setting {
        elements: FLOPPY_N,
        rate: Some(rate),
        integrator: Some(IntegratorKind::Bdf2),
        kernels: Kernels::Generated,
    };
    let measure = |natural: [f64; 3], case: &str, rate: u32| -> Result<RotaryChange> {
        let steps = (ROTARY_DURATION * rate as f64).round() as usize;
        let setting = Setting {
            rate: Some(rate),
            ..setting
        };
        let runs: Vec<_> = [true, false]
            .par_iter()
            .map(|&with_rotary| {
                let mut s = strand(
                    p.cross_section,
                    FLOPPY_N,
                    FLOPPY_LENGTH,
                    Vector3::zeros(),
                    Vector3::x(),
                    natural,
                    0.0,
                    0.0,
                );
                if !with_rotary {
                    s.geometry.rotary_inertia = [0.0; 3];
                }
                let setup = setup_of(s, &setting, ROTARY_DURATION, true, HeadMotion::Still);
                state_trajectory(setup, factory, steps)
            })
            .collect();
        let fail = |e: String| Error::invalid("study.rotary", format!("{case}: {e}"));
        let mut runs = runs.into_iter();
        let with = runs
            .next()
            .unwrap_or_else(|| Err("no run".into()))
            .map_err(fail)?;
        let without = runs
            .next()
            .unwrap_or_else(|| Err("no run".into()))
            .map_err(fail)?;
        let centreline = with
            .iter()
            .zip(&without)
            .flat_map(|(x, y)| {
                x.1.iter().zip(&y.1).map(|(a, b)| {
                    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
                })
            })
            .fold(0.0, f64::max)
            / FLOPPY_LENGTH;
        Ok(RotaryChange {
            case: case.to_string(),
            twist: relative_change(&with, &without, |k| k % 3 == 0),
            bending: relative_change(&with, &without, |k| k % 3 != 0),
            centreline,
        })
    };
    let mut rotary = Vec::new();
    for (case, natural) in cases {
        rotary.push(measure(natural, case, rate)?);
    }
    let half = measure(cases[0].1, cases[0].0, rate / 2)?;
    let show = |x: Option<f64>| x.map_or("-".into(), |v| format!("{v:.3e}"));
    let notes = format!(
        "Converged in dt: at dt = 2/{rate} s the twisted strand's changes are {} (twist), {} \
         (bending), {:.3e} (centreline), against {}, {}, {:.3e} at 1/{rate} s.",
        show(half.twist),
        show(half.bending),
        half.centreline,
        show(rotary[0].twist),
        show(rotary[0].bending),
        rotary[0].centreline
    );
    Ok(ProblemResult {
        key: "rotary",
        title: "What the cross-sections' rotary inertia changes".into(),
        description: format!(
            "The model adds the cross-sections' rotary inertia, ½∫Ωᵀ diag(ρI) Ω ds, to the \
             paper's kinetic energy (5b); `StrandGeometry::rotary_inertia = [0; 3]` gives the \
             paper's model exactly (whose mass matrix is singular where an element is \
             straight, so both strands here are curved, if slightly). Two frictionless {} cm \
             strands of the curly preset's cross-section, N = {FLOPPY_N}, no drag, root horizontal, released \
             from rest under gravity, each run with and without rotary inertia by BDF2 at \
             dt = 1/{rate} s for {ROTARY_DURATION} s. Twist (τ) and bending (κ1, κ2): max over \
             time of |q_with − q_without| over those coordinates / max over time of \
             |q_without(t) − q_without(0)| (the change relative to their motion); centreline: max over time and points of the distance / L. For \
             bending alone (the planar strand, whose twist stays zero) rotary inertia is \
             ~1e-6 of the centreline terms and changes nothing visible; for the twist of a \
             nearly straight element it is nearly the only inertia, and it changes the \
             twist's motion by percents.",
            FLOPPY_LENGTH * 100.0
        ),
        is_static: false,
        points: Vec::new(),
        notes,
        spatial: Vec::new(),
        error_title: String::new(),
        convergence: Vec::new(),
        rotary,
        tolerance: Vec::new(),
    })
}

// ---------------------------------------------------------------- Pareto, study

/// Sort by cost and mark the Pareto front.
fn finish(mut p: ProblemResult) -> ProblemResult {
    p.points.sort_by(|a, b| {
        let cost = |x: &Point| x.outcome.as_ref().map_or(f64::INFINITY, |m| m.cost);
        cost(a).total_cmp(&cost(b))
    });
    let mut best = f64::INFINITY;
    for point in &mut p.points {
        if let Ok(m) = point.outcome {
            if m.error < best {
                best = m.error;
                point.pareto = true;
            }
        }
    }
    p
}

/// Run the study (no files written; see [`write_report`]).
pub fn run_study(options: &StudyOptions, factory: Option<&dyn KernelFactory>) -> Result<Study> {
    let grid = if options.quick {
        Grid::quick()
    } else {
        Grid::full()
    };
    for &r in grid.rates.iter().chain(&grid.kernel_rates) {
        if grid.reference_rate % r != 0 {
            return Err(Error::invalid(
                "study.grid",
                format!(
                    "reference rate {} is not a multiple of {r}",
                    grid.reference_rate
                ),
            ));
        }
    }
    if let Some(only) = &options.only {
        if !PROBLEMS.contains(&only.as_str()) {
            return Err(Error::invalid(
                "--only",
                format!(
                    "`{only}` is not a problem; the problems are {}",
                    PROBLEMS.join(", ")
                ),
            ));
        }
    }
    let wanted = |key: &str| options.only.as_deref().is_none_or(|o| o == key);
    let wall = Instant::now();
    let mut problems = Vec::new();
    if wanted("swing") {
        problems.push(trajectory_problem(
            "swing",
            "Straight strand swinging under gravity",
            format!(
                "A straight {} cm strand of the smooth preset (r = 50 µm, E = 1 GPa), root \
                     clamped horizontal, released from rest under gravity, no drag, no internal \
                     friction, for {} s (the first swing down; later the tip whips and no \
                     reference converges). Error: max over the setting's time steps of \
                     |tip − tip_ref| / L.",
                SWING_LENGTH * 100.0,
                grid.swing_duration
            ),
            &swing_setup,
            SWING_LENGTH,
            &grid,
            grid.swing_duration,
            factory,
        )?);
    }
    if wanted("curly") {
        problems.push(trajectory_problem(
            "curly",
            "Curly strand on a shaking head",
            format!(
                "A {} cm strand of the curly preset (helix radius 6 mm, step 5 mm, its drag \
                     and internal friction) leaving a 10 cm head horizontally, gravity, the head \
                     turning about the vertical at 2 Hz by ±30°, for {} s. Error: max over the \
                     setting's time steps of |tip − tip_ref| / L, world positions.",
                CURLY_LENGTH * 100.0,
                grid.duration
            ),
            &curly_setup,
            CURLY_LENGTH,
            &grid,
            grid.duration,
            factory,
        )?);
    }
    if wanted("frequency") {
        problems.push(frequency_problem(&grid, factory));
    }
    if wanted("cantilever") {
        problems.push(cantilever_problem(&grid, factory));
    }
    if wanted("floppy") {
        problems.push(floppy_problem(&grid, factory)?);
    }
    if wanted("rotary") {
        problems.push(rotary_problem(&grid, factory)?);
    }
    if wanted("tolerance") {
        problems.push(crate::study_tolerance::tolerance_problem(&grid, factory));
    }
    // the cost against N belongs to the whole study, not to one problem
    let cost = if options.only.is_some() {
        Vec::new()
    } else if options.quick {
        crate::study_cost::cost_by_elements(&[1, 5, 10], 10, 5)?
    } else {
        crate::study_cost::cost_by_elements(&crate::study_cost::ELEMENTS, 20, 30)?
    };
    Ok(Study {
        options: options.clone(),
        grid,
        problems,
        wall_seconds: wall.elapsed().as_secs_f64(),
        clock: Clock::current(),
        cost,
    })
}

// ---------------------------------------------------------------- report

fn ms(seconds: f64) -> String {
    let v = seconds * 1e3;
    if v >= 100.0 {
        format!("{v:.0}")
    } else if v >= 1.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.3}")
    }
}

fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("{cores} cores available ({cpu})")
}

/// The report's markdown.
pub fn render_report(study: &Study, plots: &[Option<String>]) -> String {
    let g = &study.grid;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# What accuracy costs ({})\n",
        if study.options.quick {
            "quick study"
        } else {
            "full study"
        }
    );
    let _ = writeln!(
        s,
        "Command: `{}`. Machine: {}. Study wall time: {:.1} s.\n",
        study.options.command,
        machine(),
        study.wall_seconds
    );
    let rates: Vec<String> = g.rates.iter().map(|r| format!("1/{r}")).collect();
    let rules: Vec<String> = g
        .generic_rules
        .iter()
        .map(|&r| Kernels::Generic(r).label())
        .collect();
    let _ = writeln!(
        s,
        "Grid: N ∈ {:?}, dt ∈ {{{}}} s, integrators {}, generated kernels; kernel sweep: {} \
         against generated at N ∈ {:?}, dt ∈ {{{}}} s with LIE (the cantilever: every N with \
         every kernel).\n",
        g.elements,
        rates.join(", "),
        g.integrators
            .iter()
            .map(|&i| format!("{} ({})", integrator_description(i), integrator_label(i)))
            .collect::<Vec<_>>()
            .join(", "),
        rules.join(", "),
        g.kernel_elements,
        g.kernel_rates
            .iter()
            .map(|r| format!("1/{r}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let _ = writeln!(
        s,
        "Cost: {}, of the time steps (or the static solve) only, one strand per run; runs \
         execute two at a time on the two cores, so the figures include some contention. \
         Costs are in ms of CPU per strand per simulated second (the cantilever: ms per \
         solve). A setting is on the Pareto front when no cheaper setting is as accurate.\n",
        study.clock.describe()
    );
    for (problem, plot) in study.problems.iter().zip(plots) {
        let _ = writeln!(s, "## {} (`{}`)\n", problem.title, problem.key);
        let _ = writeln!(s, "{}\n", problem.description);
        if !problem.notes.is_empty() {
            let _ = writeln!(s, "{}\n", problem.notes);
        }
        if let Some(file) = plot {
            let _ = writeln!(s, "![{}]({file})\n", problem.title);
        }
        if !problem.convergence.is_empty() {
            render_convergence(&mut s, &problem.convergence);
            continue;
        }
        if !problem.tolerance.is_empty() {
            crate::study_tolerance::render_table(&mut s, &problem.tolerance);
            let _ = writeln!(
                s,
                "![Cost against error]({})\n",
                crate::study_tolerance::COST_PLOT
            );
            continue;
        }
        if !problem.rotary.is_empty() {
            let _ = writeln!(
                s,
                "| strand | twist τ, relative change | bending κ1, κ2, relative change | centreline, / L |"
            );
            let _ = writeln!(s, "|---|---|---|---|");
            for r in &problem.rotary {
                let show =
                    |x: Option<f64>| x.map_or("does not move".into(), |v| format!("{v:.2e}"));
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {:.2e} |",
                    r.case,
                    show(r.twist),
                    show(r.bending),
                    r.centreline
                );
            }
            let _ = writeln!(s);
            continue;
        }
        let unit = if problem.is_static {
            "ms per solve"
        } else {
            "ms per strand per simulated s"
        };
        let _ = writeln!(s, "Pareto-best setting for a budget:\n");
        let _ = writeln!(s, "| budget ({unit}) | best setting | error | cost |");
        let _ = writeln!(s, "|---|---|---|---|");
        for &b in problem.budgets() {
            match problem.best_within(b) {
                Some(p) => {
                    let m = p.outcome.as_ref().expect("successful point");
                    let _ = writeln!(
                        s,
                        "| {} | {} | {:.2e} | {} |",
                        ms(b),
                        p.setting.label(),
                        m.error,
                        ms(m.cost)
                    );
                }
                None => {
                    let _ = writeln!(s, "| {} | none fits | - | - |", ms(b));
                }
            }
        }
        let _ = writeln!(s);
        let signed = !problem.spatial.is_empty() || problem.is_static;
        if signed {
            let _ = writeln!(
                s,
                "| # | setting | error | signed | cost ({unit}) | Pareto |"
            );
            let _ = writeln!(s, "|---|---|---|---|---|---|");
        } else {
            let _ = writeln!(s, "| # | setting | error | cost ({unit}) | Pareto |");
            let _ = writeln!(s, "|---|---|---|---|---|");
        }
        for (i, p) in problem.points.iter().enumerate() {
            match &p.outcome {
                Ok(m) => {
                    let sign = if signed {
                        format!(" {:+.2e} |", m.signed)
                    } else {
                        String::new()
                    };
                    let _ = writeln!(
                        s,
                        "| {} | {} | {:.2e} |{sign} {} | {} |",
                        i + 1,
                        p.setting.label(),
                        m.error,
                        ms(m.cost),
                        if p.pareto { "yes" } else { "" }
                    );
                }
                Err(e) => {
                    let _ = writeln!(
                        s,
                        "| {} | {} | failed: {} |{} - | |",
                        i + 1,
                        p.setting.label(),
                        e.replace('|', "/"),
                        if signed { " - |" } else { "" }
                    );
                }
            }
        }
        let _ = writeln!(s);
    }
    if study.cost.is_empty() {
        return s;
    }
    let _ = writeln!(
        s,
        "## Cost of one strand-step against N (`cost`)\n\n\
         The bench's strands (wavy preset, 20 cm, gravity, air drag, internal friction, \
         dt = 1/30 s; `superhelix bench`), CPU time of the process per strand-step, for the \
         generic runtime-N kernel (Gauss–Legendre quadrature), the moment assembly on the \
         generated closed forms (any N), the generated fixed-N kernel in the runtime engine, \
         and the embedded engine (the fixed-N step an engine embeds: \
         arrays of literal size, one workspace per thread). All three take the same steps, \
         checked and split by the same rules (`kernels = \"generic\"`, `\"moment\"`, \
         `\"generated\"`; `engine = \"embedded\"`).\n\n![cost against N]({})\n",
        COST_PLOT
    );
    let _ = writeln!(s, "{}", crate::study_cost::cost_table(&study.cost));
    s
}

/// The convergence table of `floppy`: error / L per dt and series, and the orders.
fn render_convergence(s: &mut String, series: &[Convergence]) {
    let names: Vec<String> = series.iter().map(Convergence::label).collect();
    let _ = writeln!(s, "| dt (s) | {} |", names.join(" | "));
    let _ = writeln!(s, "|---|{}", "---|".repeat(names.len()));
    let rows = series.first().map_or(0, |c| c.points.len());
    for i in 0..rows {
        let dt = series[0].points[i].0;
        let cells: Vec<String> = series
            .iter()
            .map(|c| {
                c.points
                    .get(i)
                    .map_or("-".into(), |p| format!("{:.2e}", p.1))
            })
            .collect();
        let _ = writeln!(s, "| 1/{:.0} | {} |", 1.0 / dt, cells.join(" | "));
    }
    let orders: Vec<String> = series
        .iter()
        .map(|c| format!("{} {:.2}", c.label(), c.order))
        .collect();
    let _ = writeln!(
        s,
        "\nMeasured orders (slope over the three smallest dt): {}.\n",
        orders.join("; ")
    );
}

/// The plot of a problem as SVG, if it has one.
fn problem_plot(problem: &ProblemResult) -> Result<Option<String>> {
    use crate::study_plot::{convergence_style, log_log_svg, plot, Series};
    if !problem.convergence.is_empty() {
        let series: Vec<Series> = problem
            .convergence
            .iter()
            .map(|c| Series {
                name: format!("{} (order {:.2})", c.label(), c.order),
                style: convergence_style(c.integrator, c.friction),
                points: c.points.clone(),
                line: true,
            })
            .collect();
        return log_log_svg(
            &problem.title,
            "time step dt (s)",
            &problem.error_title,
            &series,
            None,
            plotters::chart::SeriesLabelPosition::LowerRight,
        )
        .map(Some);
    }
    if !problem.tolerance.is_empty() {
        return crate::study_tolerance::plot(problem).map(Some);
    }
    if problem.points.is_empty() {
        return Ok(None);
    }
    plot(problem).map(Some)
}

/// Write `dir/report.md`, one SVG plot per problem that has one (`dir/<key>.svg`) and
/// `dir/study.json`; returns the files.
pub fn write_report(study: &Study, dir: &Path) -> Result<Vec<PathBuf>> {
    let io = |path: &Path, source: std::io::Error| Error::Io {
        path: path.display().to_string(),
        source,
    };
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    let mut files = Vec::new();
    let mut plots = Vec::new();
    for problem in &study.problems {
        match problem_plot(problem)? {
            Some(svg) => {
                let name = format!("{}.svg", problem.key);
                let path = dir.join(&name);
                std::fs::write(&path, svg).map_err(|e| io(&path, e))?;
                files.push(path);
                plots.push(Some(name));
            }
            None => plots.push(None),
        }
    }
    if let Some(problem) = study.problems.iter().find(|p| !p.tolerance.is_empty()) {
        let path = dir.join(crate::study_tolerance::COST_PLOT);
        std::fs::write(&path, crate::study_tolerance::cost_plot(problem)?)
            .map_err(|e| io(&path, e))?;
        files.push(path);
    }
    if !study.cost.is_empty() {
        let cost_svg = crate::study_cost::cost_plot(&study.cost)?;
        let path = dir.join(COST_PLOT);
        std::fs::write(&path, cost_svg).map_err(|e| io(&path, e))?;
        files.push(path);
    }
    let path = dir.join("report.md");
    std::fs::write(&path, render_report(study, &plots)).map_err(|e| io(&path, e))?;
    files.push(path);
    let path = dir.join("study.json");
    let text = serde_json::to_string_pretty(&to_json(study)).unwrap_or_default();
    std::fs::write(&path, text).map_err(|e| io(&path, e))?;
    files.push(path);
    Ok(files)
}

/// File name of the cost-against-N plot.
pub const COST_PLOT: &str = "cost_by_elements.svg";

/// The results as JSON (`study.json`): per problem, every point's setting, error,
/// signed error, cost (s) and Pareto flag, or its failure.
pub fn to_json(study: &Study) -> serde_json::Value {
    use serde_json::json;
    let problems: Vec<serde_json::Value> = study
        .problems
        .iter()
        .map(|p| {
            let points: Vec<serde_json::Value> = p
                .points
                .iter()
                .map(|pt| {
                    let s = &pt.setting;
                    let mut v = json!({
                        "label": s.label(),
                        "elements": s.elements,
                        "dt": s.rate.map(|r| 1.0 / r as f64),
                        "integrator": s.integrator.map(|i| i.name()),
                        "kernels": s.kernels.label(),
                        "pareto": pt.pareto,
                    });
                    match &pt.outcome {
                        Ok(m) => {
                            v["error"] = json!(m.error);
                            v["signed_error"] = json!(m.signed);
                            v["cost_seconds"] = json!(m.cost);
                        }
                        Err(e) => v["failed"] = json!(e),
                    }
                    v
                })
                .collect();
            json!({
                "key": p.key,
                "title": p.title,
                "static": p.is_static,
                "points": points,
                "spatial": p.spatial.iter().map(|(n, w, e)| json!({"elements": n, "omega": w, "signed_error": e})).collect::<Vec<_>>(),
                "convergence": p.convergence.iter().map(|c| json!({"integrator": c.integrator.name(), "friction": c.friction, "order": c.order, "dt_error": c.points})).collect::<Vec<_>>(),
                "tolerance": crate::study_tolerance::to_json(&p.tolerance),
                "rotary": p.rotary.iter().map(|r| json!({"case": r.case, "twist": r.twist, "bending": r.bending, "centreline": r.centreline})).collect::<Vec<_>>(),
            })
        })
        .collect();
    json!({
        "command": study.options.command,
        "quick": study.options.quick,
        "wall_seconds": study.wall_seconds,
        "problems": problems,
        "cost_by_elements": study.cost.iter().map(|c| json!({"path": c.path, "elements": c.n, "us_per_strand_step": c.us_per_strand_step, "substeps": c.substeps})).collect::<Vec<_>>(),
    })
}
