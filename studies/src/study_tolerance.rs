//! The study's `tolerance` problem: what a tolerance (`[simulation] tolerance`, the
//! error-controlled step) delivers and costs, measured against references of other
//! schemes, and set against the best fixed step at the same error.
//!
//! Five cases, each run at every tolerance of the grid with frames every 1/30 s (the
//! error-controlled step chooses its own steps within them):
//!
//! - `swing` (frictionless): the study's `swing` strand at N = 20 (the N of the study's
//!   reference: with the same N the difference is time error alone), 0.5 s.
//! - `curly` (friction, drag, a shaking head): the study's `curly` strand at N = 20.
//! - `floppy`, frictionless and with friction: the study's floppy N = 3 strand, 1 s.
//! - `helix` (frictionless): a curly N = 3 helix hanging at rest in its natural shape,
//!   released under gravity with nothing to damp it, 1 s.
//!
//! **References** ([`ReferenceScheme`]), each checked by its own refinement: the
//! frictionless N = 3 strands against explicit RK4 (fourth order: its error is a
//! fifteenth of its distance from the run at half the rate); the others against BDF2 at
//! two small steps combined by second-order Richardson extrapolation (4 x(h/2) − x(h))/3,
//! checked against the same extrapolation one halving coarser (their distance bounds the
//! finer one's error: its leading term is third order, an eighth of the coarser one's).
//!
//! **Fixed steps**: each case is also run at fixed steps, linearly implicit Euler and
//! BDF2 at 30 · 2^k steps a second, measured in the same way. At each tolerance's
//! measured error, the cost of the best fixed step is read off the fixed runs' Pareto
//! front (log–log interpolation between its two points that bracket the error), in
//! implicit solves (exact) and in CPU time: [`ToleranceCase::fixed_cost_at`].
//!
//! Error: max over the frames (every 1/30 s) of |tip − tip_ref| / L. Cost: CPU time of
//! the steps per simulated second, as for the other problems.

use crate::runtime::config::{IntegratorKind, SimulationSetup};
use crate::runtime::kernels::kernel::KernelFactory;
use crate::runtime::{HeadMotion, Result, Vector3};
use crate::study::integrator_label;
use crate::study::{
    curly_setup, floppy_strand, helix_strand, max_distance, setup_of, swing_setup, tip_run, Grid,
    Kernels, ProblemResult, Setting, CURLY_LENGTH, FLOPPY_DURATION, FLOPPY_LENGTH, FLOPPY_N,
    HELIX_DURATION, HELIX_LENGTH, HELIX_N, REFERENCE_N, SWING_LENGTH,
};
use crate::study_plot::{log_log_svg, Marker, Series, Style};
use plotters::prelude::{RGBColor, SeriesLabelPosition};
use rayon::prelude::*;
use std::fmt::Write as _;

/// The tolerances of the full study.
pub const TOLERANCES: [f64; 6] = [1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6];

/// The tolerances of `--quick`.
pub const QUICK_TOLERANCES: [f64; 4] = [1e-1, 1e-2, 1e-3, 1e-4];

/// Frames per second of the runs (the scene's dt).
pub const FRAME_RATE: u32 = 30;

/// File name of the cost-against-error plot.
pub const COST_PLOT: &str = "tolerance_cost.svg";

/// How a case's reference is computed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceScheme {
    /// The integrator (fixed steps).
    pub integrator: IntegratorKind,
    /// The coarsest rate, steps a second: RK4 runs at it and twice it (the reference is
    /// the finer run); BDF2 at it, twice and four times it (the reference is the
    /// extrapolation of the two finer runs).
    pub rate: u32,
}

impl ReferenceScheme {
    /// True for a Richardson-extrapolated pair (any second-order integrator).
    fn richardson(&self) -> bool {
        self.integrator != IntegratorKind::Rk4
    }
    /// The rates run.
    fn rates(&self) -> Vec<u32> {
        if self.richardson() {
            vec![self.rate, 2 * self.rate, 4 * self.rate]
        } else {
            vec![self.rate, 2 * self.rate]
        }
    }
    /// What the report says of it.
    fn describe(&self) -> String {
        if self.richardson() {
            format!(
                "BDF2 at dt = 1/{} and 1/{} s, Richardson-extrapolated (4 x(dt/2) − x(dt))/3",
                2 * self.rate,
                4 * self.rate
            )
        } else {
            format!("RK4 at dt = 1/{} s", 2 * self.rate)
        }
    }
}

/// What one run at one tolerance measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToleranceMeasured {
    /// Max over the frames of |tip − tip_ref| / L.
    pub error: f64,
    /// CPU seconds per simulated second.
    pub cost: f64,
    /// Steps accepted.
    pub steps: usize,
    /// Steps rejected.
    pub rejected: usize,
    /// Implicit solves (accepted steps, rejected ones, and the first step's three).
    pub solves: usize,
}

/// One tolerance's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct TolerancePoint {
    /// The tolerance asked for.
    pub tolerance: f64,
    /// What it measured, or why the run failed.
    pub outcome: std::result::Result<ToleranceMeasured, String>,
}

/// One fixed-step run of a case.
#[derive(Debug, Clone, PartialEq)]
pub struct FixedPoint {
    /// Linearly implicit Euler or BDF2.
    pub integrator: IntegratorKind,
    /// Steps a second.
    pub rate: u32,
    /// What it measured, or why it failed.
    pub outcome: std::result::Result<FixedMeasured, String>,
}

/// What one fixed-step run measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedMeasured {
    /// Max over the frames of |tip − tip_ref| / L.
    pub error: f64,
    /// CPU seconds per simulated second.
    pub cost: f64,
    /// Implicit solves (the steps, and their splits).
    pub solves: usize,
}

/// What the cost comparison counts: CPU time (noisy: two runs share the machine) or
/// implicit solves (exact: a solve costs the same on either path, `superhelix bench`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CostMeasure {
    /// CPU seconds per simulated second.
    Cpu,
    /// Implicit solves over the run.
    Solves,
}

impl CostMeasure {
    fn of_fixed(self, m: &FixedMeasured) -> f64 {
        match self {
            CostMeasure::Cpu => m.cost,
            CostMeasure::Solves => m.solves as f64,
        }
    }
}

/// One case: a strand against its reference at every tolerance, and at fixed steps.
#[derive(Debug, Clone, PartialEq)]
pub struct ToleranceCase {
    /// `swing`, `curly`, `floppy`, `helix`.
    pub problem: &'static str,
    /// With internal friction (and drag where the problem has it).
    pub friction: bool,
    /// Elements N.
    pub elements: usize,
    /// The reference.
    pub reference: ReferenceScheme,
    /// The reference's estimated error (max over frames, / L), from its refinement.
    pub reference_error: f64,
    /// The points, in [`Grid::tolerances`] order.
    pub points: Vec<TolerancePoint>,
    /// The fixed-step runs.
    pub fixed: Vec<FixedPoint>,
}

impl ToleranceCase {
    /// `swing, N = 20, frictionless`.
    pub fn label(&self) -> String {
        format!(
            "{}, N = {}, {}",
            self.problem,
            self.elements,
            friction_label(self.friction)
        )
    }

    /// The smallest error / tolerance over the successful points, and the largest.
    pub fn ratio_range(&self) -> (f64, f64) {
        self.points
            .iter()
            .filter_map(|p| p.outcome.as_ref().ok().map(|m| m.error / p.tolerance))
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), r| {
                (lo.min(r), hi.max(r))
            })
    }

    /// The fixed runs' Pareto front as (cost, error), by increasing cost and decreasing
    /// error: no fixed run is both cheaper and at least as accurate as a point of it.
    pub fn fixed_front(&self, measure: CostMeasure) -> Vec<(f64, f64)> {
        let mut points: Vec<(f64, f64)> = self
            .fixed
            .iter()
            .filter_map(|f| {
                f.outcome
                    .as_ref()
                    .ok()
                    .map(|m| (measure.of_fixed(m), m.error))
            })
            .collect();
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut front: Vec<(f64, f64)> = Vec::new();
        for p in points {
            if front.last().is_none_or(|l| p.1 < l.1) {
                front.push(p);
            }
        }
        front
    }

    /// The cost of the best fixed step whose error is `error`: on the fixed Pareto
    /// front, log–log interpolated between the two points that bracket it. An error
    /// larger than the cheapest fixed run's is that run's cost (no fixed step is longer
    /// than a frame); `None` below the most accurate fixed run.
    pub fn fixed_cost_at(&self, error: f64, measure: CostMeasure) -> Option<f64> {
        let front = self.fixed_front(measure);
        let first = front.first()?;
        if error >= first.1 {
            return Some(first.0);
        }
        front.windows(2).find_map(|w| {
            let ((c0, e0), (c1, e1)) = (w[0], w[1]);
            (error <= e0 && error >= e1).then(|| {
                let s = (error.ln() - e0.ln()) / (e1.ln() - e0.ln());
                (c0.ln() + s * (c1.ln() - c0.ln())).exp()
            })
        })
    }
}

/// `friction` or `frictionless`.
fn friction_label(friction: bool) -> &'static str {
    if friction {
        "friction"
    } else {
        "frictionless"
    }
}

/// One case's input.
struct CaseInput<'a> {
    problem: &'static str,
    friction: bool,
    elements: usize,
    make: Box<dyn Fn(&Setting) -> SimulationSetup + Sync + 'a>,
    reference: ReferenceScheme,
    length: f64,
    duration: f64,
}

/// One run of the problem.
#[derive(Clone, Copy)]
enum Job {
    /// Case, the reference's rate index.
    Reference(usize, usize),
    /// Case, tolerance.
    Tolerance(usize, f64),
    /// Case, integrator, rate.
    Fixed(usize, IntegratorKind, u32),
}

/// What one run gave.
#[derive(Clone)]
struct Run {
    /// The tip at every frame, world coordinates.
    tips: Vec<Vector3<f64>>,
    /// CPU seconds per simulated second.
    cost: f64,
    /// Steps the error control accepted and rejected (0 at fixed steps).
    steps: usize,
    rejected: usize,
    /// Implicit solves.
    solves: usize,
}

/// A run, or why it failed.
type FrameRun = std::result::Result<Run, String>;

fn run_job(inputs: &[CaseInput<'_>], job: Job, factory: Option<&dyn KernelFactory>) -> FrameRun {
    let (c, integrator, rate, tolerance) = match job {
        Job::Reference(c, k) => {
            let r = inputs[c].reference;
            (c, r.integrator, r.rates()[k], None)
        }
        Job::Tolerance(c, t) => (
            c,
            IntegratorKind::LinearlyImplicitEuler,
            FRAME_RATE,
            Some(t),
        ),
        Job::Fixed(c, integrator, rate) => (c, integrator, rate, None),
    };
    let input = &inputs[c];
    let setting = Setting {
        elements: input.elements,
        rate: Some(rate),
        integrator: Some(integrator),
        kernels: Kernels::Generated,
    };
    let mut setup = (input.make)(&setting);
    setup.config.tolerance = tolerance;
    let steps = (input.duration * rate as f64).round() as usize;
    let (tips, cpu, stats) = tip_run(setup, factory, steps)?;
    let stride = (rate / FRAME_RATE) as usize;
    Ok(Run {
        tips: tips.iter().step_by(stride).copied().collect(),
        cost: cpu / input.duration,
        steps: stats.error_steps,
        rejected: stats.error_rejected,
        solves: stats.attempts,
    })
}

/// A rough cost of a job, to start the longest first.
fn job_weight(inputs: &[CaseInput<'_>], job: Job) -> f64 {
    let per_step = |c: usize| (inputs[c].elements as f64) * inputs[c].duration;
    match job {
        Job::Reference(c, k) => per_step(c) * inputs[c].reference.rates()[k] as f64,
        Job::Tolerance(c, t) => per_step(c) * 3.0 * t.powf(-0.5),
        Job::Fixed(c, _, rate) => per_step(c) * rate as f64,
    }
}

/// The reference at every frame and its estimated error (/ L), from its runs.
fn combine(
    input: &CaseInput<'_>,
    runs: &[Vec<Vector3<f64>>],
) -> std::result::Result<(Vec<Vector3<f64>>, f64), String> {
    if input.reference.richardson() {
        let [r0, r1, r2] = runs else {
            return Err("the reference needs three runs".into());
        };
        let rich = |a: &[Vector3<f64>], b: &[Vector3<f64>]| -> Vec<Vector3<f64>> {
            a.iter().zip(b).map(|(x, y)| (4.0 * y - x) / 3.0).collect()
        };
        let (coarse, fine) = (rich(r0, r1), rich(r1, r2));
        let own = max_distance(&coarse, &fine, 1) / input.length;
        Ok((fine, own))
    } else {
        let [r0, r1] = runs else {
            return Err("the reference needs two runs".into());
        };
        let own = max_distance(r0, r1, 1) / input.length / 15.0;
        Ok((r1.clone(), own))
    }
}

/// Run the `tolerance` problem.
pub(crate) fn tolerance_problem(grid: &Grid, factory: Option<&dyn KernelFactory>) -> ProblemResult {
    let bdf2 = |rate| ReferenceScheme {
        integrator: IntegratorKind::Bdf2,
        rate,
    };
    let rk4 = |rate| ReferenceScheme {
        integrator: IntegratorKind::Rk4,
        rate,
    };
    let mut inputs = vec![
        CaseInput {
            problem: "swing",
            friction: false,
            elements: REFERENCE_N,
            make: Box::new(|s| swing_setup(s, grid.swing_duration)),
            reference: bdf2(grid.tolerance_swing_reference_rate),
            length: SWING_LENGTH,
            duration: grid.swing_duration,
        },
        CaseInput {
            problem: "curly",
            friction: true,
            elements: REFERENCE_N,
            make: Box::new(|s| curly_setup(s, grid.duration)),
            reference: bdf2(grid.tolerance_curly_reference_rate),
            length: CURLY_LENGTH,
            duration: grid.duration,
        },
    ];
    for friction in [false, true] {
        inputs.push(CaseInput {
            problem: "floppy",
            friction,
            elements: FLOPPY_N,
            make: Box::new(move |s| {
                setup_of(
                    floppy_strand(friction),
                    s,
                    FLOPPY_DURATION,
                    true,
                    HeadMotion::Still,
                )
            }),
            reference: if friction { bdf2(15000) } else { rk4(60000) },
            length: FLOPPY_LENGTH,
            duration: FLOPPY_DURATION,
        });
    }
    inputs.push(CaseInput {
        problem: "helix",
        friction: false,
        elements: HELIX_N,
        make: Box::new(|s| setup_of(helix_strand(), s, HELIX_DURATION, true, HeadMotion::Still)),
        reference: rk4(30000),
        length: HELIX_LENGTH,
        duration: HELIX_DURATION,
    });

    let mut jobs: Vec<Job> = Vec::new();
    for (c, input) in inputs.iter().enumerate() {
        jobs.extend((0..input.reference.rates().len()).map(|k| Job::Reference(c, k)));
        jobs.extend(grid.tolerances.iter().map(|&t| Job::Tolerance(c, t)));
        for integrator in [IntegratorKind::LinearlyImplicitEuler, IntegratorKind::Bdf2] {
            jobs.extend(
                grid.tolerance_fixed_rates
                    .iter()
                    .map(|&r| Job::Fixed(c, integrator, r)),
            );
        }
    }
    let mut order: Vec<usize> = (0..jobs.len()).collect();
    order.sort_by(|&a, &b| job_weight(&inputs, jobs[b]).total_cmp(&job_weight(&inputs, jobs[a])));
    let mut runs: Vec<(usize, FrameRun)> = order
        .par_iter()
        .map(|&j| (j, run_job(&inputs, jobs[j], factory)))
        .collect();
    runs.sort_by_key(|r| r.0);
    // each case's runs, by kind
    let mut references: Vec<Vec<FrameRun>> = vec![Vec::new(); inputs.len()];
    let mut points: Vec<Vec<(f64, FrameRun)>> = vec![Vec::new(); inputs.len()];
    let mut fixed: Vec<Vec<(IntegratorKind, u32, FrameRun)>> = vec![Vec::new(); inputs.len()];
    for (job, (_, run)) in jobs.iter().zip(runs) {
        match *job {
            Job::Reference(c, _) => references[c].push(run),
            Job::Tolerance(c, t) => points[c].push((t, run)),
            Job::Fixed(c, integrator, rate) => fixed[c].push((integrator, rate, run)),
        }
    }

    let mut notes = String::new();
    let cases: Vec<ToleranceCase> = inputs
        .iter()
        .zip(references.into_iter().zip(points).zip(fixed))
        .map(|(input, ((references, points), fixed))| {
            let label = format!("{}, {}", input.problem, friction_label(input.friction));
            let reference = references
                .into_iter()
                .map(|r| r.map(|r| r.tips))
                .collect::<std::result::Result<Vec<_>, String>>()
                .and_then(|runs| combine(input, &runs));
            let (reference_tips, reference_error) = match reference {
                Ok((tips, own)) => {
                    let _ = write!(
                        notes,
                        "Reference of `{label}`: {}; its error, estimated from its refinement (max \
                         over frames, / L): {own:.1e}. ",
                        input.reference.describe()
                    );
                    (Some(tips), own)
                }
                Err(e) => {
                    let _ = write!(notes, "The reference of `{label}` failed: {e}. ");
                    (None, f64::NAN)
                }
            };
            let error_of = |run: &Run| -> std::result::Result<f64, String> {
                let reference = reference_tips.as_ref().ok_or("no reference")?;
                Ok(max_distance(&run.tips, reference, 1) / input.length)
            };
            ToleranceCase {
                problem: input.problem,
                friction: input.friction,
                elements: input.elements,
                reference: input.reference,
                reference_error,
                points: points
                    .into_iter()
                    .map(|(tolerance, run)| TolerancePoint {
                        tolerance,
                        outcome: run.and_then(|r| {
                            Ok(ToleranceMeasured {
                                error: error_of(&r)?,
                                cost: r.cost,
                                steps: r.steps,
                                rejected: r.rejected,
                                solves: r.solves,
                            })
                        }),
                    })
                    .collect(),
                fixed: fixed
                    .into_iter()
                    .map(|(integrator, rate, run)| FixedPoint {
                        integrator,
                        rate,
                        outcome: run.and_then(|r| {
                            Ok(FixedMeasured {
                                error: error_of(&r)?,
                                cost: r.cost,
                                solves: r.solves,
                            })
                        }),
                    })
                    .collect(),
            }
        })
        .collect();
    let rates = &grid.tolerance_fixed_rates;
    ProblemResult {
        key: "tolerance",
        title: "What a tolerance delivers and costs".into(),
        description: format!(
            "The error-controlled step (`[simulation] tolerance`) on the strands of `swing` and \
             `curly` at N = {REFERENCE_N} (so that the difference from their references is time \
             error alone), on the floppy N = {FLOPPY_N} strand of `floppy`, frictionless and with \
             friction, and on a frictionless curly N = {HELIX_N} helix hanging at rest in its \
             natural shape, released under gravity; frames every 1/{FRAME_RATE} s. Error: max \
             over the frames of |tip − tip_ref| / L; the tolerance bounds each step's estimated \
             local error. Cost: implicit solves, and CPU time of the steps per simulated second. \
             Each case also runs \
             at fixed steps (linearly implicit Euler and BDF2, {} to {} steps a second, doubling); \
             the cost of the best fixed step at a tolerance's measured error is read off their \
             Pareto front, log–log interpolated.",
            rates.first().copied().unwrap_or(0),
            rates.last().copied().unwrap_or(0),
        ),
        is_static: false,
        points: Vec::new(),
        notes: notes.trim_end().to_string(),
        spatial: Vec::new(),
        error_title: "error: max over frames of |tip − tip_ref| / L".into(),
        convergence: Vec::new(),
        rotary: Vec::new(),
        tolerance: cases,
    }
}

/// A table with a row per tolerance and a column per case, each cell `cell(case, point)`.
fn table_by_tolerance(
    s: &mut String,
    cases: &[ToleranceCase],
    cell: impl Fn(&ToleranceCase, &TolerancePoint) -> String,
) {
    let names: Vec<String> = cases.iter().map(ToleranceCase::label).collect();
    let _ = writeln!(s, "| tolerance | {} |", names.join(" | "));
    let _ = writeln!(s, "|---|{}", "---|".repeat(names.len()));
    let rows = cases.first().map_or(0, |c| c.points.len());
    for i in 0..rows {
        let cells: Vec<String> = cases
            .iter()
            .map(|c| c.points.get(i).map_or("-".into(), |p| cell(c, p)))
            .collect();
        let t = cases[0].points[i].tolerance;
        let _ = writeln!(s, "| {t:.0e} | {} |", cells.join(" | "));
    }
}

/// The report's table: per tolerance and case, the error (and error / tolerance), the
/// cost and the steps; then the cost comparison ([`render_cost_table`]).
pub fn render_table(s: &mut String, cases: &[ToleranceCase]) {
    let _ = writeln!(s, "Error / L (error / tolerance) and cost (ms of CPU per simulated s, steps accepted / rejected):\n");
    table_by_tolerance(s, cases, |_, p| match &p.outcome {
        Ok(m) => format!(
            "{:.2e} ({:.2}); {:.3} ms, {}/{}",
            m.error,
            m.error / p.tolerance,
            m.cost * 1e3,
            m.steps,
            m.rejected
        ),
        Err(e) => format!("failed: {}", e.replace('|', "/")),
    });
    let ranges: Vec<String> = cases
        .iter()
        .map(|c| {
            let (lo, hi) = c.ratio_range();
            format!("{} {lo:.2}–{hi:.2}", c.label())
        })
        .collect();
    let _ = writeln!(
        s,
        "\nError / tolerance over the range: {}.\n",
        ranges.join("; ")
    );
    render_cost_table(s, cases);
}

/// The cost-against-error table: per tolerance and case, the tolerance's solves and
/// CPU time against the best fixed step's at the same measured error.
pub fn render_cost_table(s: &mut String, cases: &[ToleranceCase]) {
    let _ = writeln!(
        s,
        "Cost at equal error, the tolerance against the best fixed step at the error the \
         tolerance measured: implicit solves (exact; a solve costs about the same on either path), \
         then CPU time (two runs share the machine, so it spreads by some 15 %); each as \
         tolerance / fixed = ratio. \"beyond\": no fixed run of the ladder is that accurate.\n"
    );
    table_by_tolerance(s, cases, |c, p| match &p.outcome {
        Ok(m) => match (
            c.fixed_cost_at(m.error, CostMeasure::Solves),
            c.fixed_cost_at(m.error, CostMeasure::Cpu),
        ) {
            (Some(n), Some(f)) => format!(
                "solves {} / {:.0} = **{:.2}**; CPU {:.3} / {:.3} ms = {:.2}",
                m.solves,
                n,
                m.solves as f64 / n,
                m.cost * 1e3,
                f * 1e3,
                m.cost / f
            ),
            _ => format!("beyond (solves {}, {:.3} ms)", m.solves, m.cost * 1e3),
        },
        Err(_) => "-".into(),
    });
    let fronts: Vec<String> = cases
        .iter()
        .map(|c| {
            let front = c.fixed_front(CostMeasure::Solves);
            let runs: Vec<String> = c
                .fixed
                .iter()
                .filter_map(|f| {
                    let m = f.outcome.as_ref().ok()?;
                    front.contains(&(m.solves as f64, m.error)).then(|| {
                        format!(
                            "{} 1/{}: {:.1e}, {} solves",
                            integrator_label(f.integrator),
                            f.rate,
                            m.error,
                            m.solves
                        )
                    })
                })
                .collect();
            format!("{}: {}", c.label(), runs.join("; "))
        })
        .collect();
    let _ = writeln!(
        s,
        "\nThe fixed steps' Pareto front in solves (integrator dt: error, solves): {}.\n",
        fronts.join(". ")
    );
}

/// The fixed colour and marker of a case.
fn style(case: &ToleranceCase) -> Style {
    let (colour, marker) = match (case.problem, case.friction) {
        ("swing", _) => (RGBColor(31, 119, 180), Marker::Circle),
        ("curly", _) => (RGBColor(214, 39, 40), Marker::Triangle),
        ("helix", _) => (RGBColor(148, 103, 189), Marker::Circle),
        (_, false) => (RGBColor(44, 160, 44), Marker::Cross),
        (_, true) => (RGBColor(22, 80, 22), Marker::Square),
    };
    Style { colour, marker }
}

/// Error against tolerance, with the line error = tolerance.
pub fn plot(problem: &ProblemResult) -> Result<String> {
    let series: Vec<Series> = problem
        .tolerance
        .iter()
        .map(|c| Series {
            name: c.label(),
            style: style(c),
            points: c
                .points
                .iter()
                .filter_map(|p| p.outcome.as_ref().ok().map(|m| (p.tolerance, m.error)))
                .collect(),
            line: true,
        })
        .collect();
    let tolerances: Vec<f64> = problem
        .tolerance
        .first()
        .map(|c| c.points.iter().map(|p| p.tolerance).collect())
        .unwrap_or_default();
    log_log_svg(
        &problem.title,
        "tolerance asked for (local error per step / L)",
        &problem.error_title,
        &series,
        Some((
            "error = tolerance",
            tolerances.iter().map(|&t| (t, t)).collect(),
        )),
        SeriesLabelPosition::UpperLeft,
    )
}

/// Cost (implicit solves) against error: per case, the tolerances (joined, circles) and
/// the fixed steps' Pareto front (joined, crosses), in the case's colour.
pub fn cost_plot(problem: &ProblemResult) -> Result<String> {
    let mut series: Vec<Series> = Vec::new();
    for c in &problem.tolerance {
        let colour = style(c).colour;
        series.push(Series {
            name: format!("{}: tolerance", c.label()),
            style: Style {
                colour,
                marker: Marker::Circle,
            },
            points: c
                .points
                .iter()
                .filter_map(|p| p.outcome.as_ref().ok().map(|m| (m.solves as f64, m.error)))
                .collect(),
            line: true,
        });
        series.push(Series {
            name: format!("{}: best fixed step", c.label()),
            style: Style {
                colour,
                marker: Marker::Cross,
            },
            points: c
                .fixed_front(CostMeasure::Solves)
                .iter()
                .map(|&(solves, e)| (solves, e))
                .collect(),
            line: true,
        });
    }
    log_log_svg(
        "What a tolerance costs against the best fixed step",
        "cost: implicit solves over the run",
        &problem.error_title,
        &series,
        None,
        SeriesLabelPosition::LowerLeft,
    )
}

/// The cases as JSON (`study.json`).
pub fn to_json(cases: &[ToleranceCase]) -> serde_json::Value {
    use serde_json::json;
    cases
        .iter()
        .map(|c| {
            json!({
                "problem": c.problem,
                "friction": c.friction,
                "elements": c.elements,
                "reference": c.reference.describe(),
                "reference_error": c.reference_error,
                "points": c.points.iter().map(|p| match &p.outcome {
                    Ok(m) => json!({"tolerance": p.tolerance, "error": m.error, "cost_seconds": m.cost, "steps": m.steps, "rejected": m.rejected, "solves": m.solves, "fixed_solves_at_error": c.fixed_cost_at(m.error, CostMeasure::Solves), "fixed_cost_seconds_at_error": c.fixed_cost_at(m.error, CostMeasure::Cpu)}),
                    Err(e) => json!({"tolerance": p.tolerance, "failed": e}),
                }).collect::<Vec<_>>(),
                "fixed": c.fixed.iter().map(|f| match &f.outcome {
                    Ok(m) => json!({"integrator": f.integrator.name(), "rate": f.rate, "error": m.error, "cost_seconds": m.cost, "solves": m.solves}),
                    Err(err) => json!({"integrator": f.integrator.name(), "rate": f.rate, "failed": err}),
                }).collect::<Vec<_>>(),
            })
        })
        .collect()
}
