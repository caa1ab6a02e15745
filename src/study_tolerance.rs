//! The study's `tolerance` problem: what a tolerance (`[simulation] tolerance`, the
//! error-controlled step) delivers and costs, measured against the study's own
//! references.
//!
//! Four cases, each run at every tolerance of [`TOLERANCES`] with frames every 1/30 s
//! (the error-controlled step chooses its own steps within them):
//!
//! - `swing` (frictionless): the study's `swing` at the reference's N = 20, against its
//!   reference (the Richardson-extrapolated N = 20 run): with the same N, the difference
//!   is time error alone.
//! - `curly` (friction, drag, a shaking head): the study's `curly` at N = 20, against its
//!   reference.
//! - `floppy`, frictionless and with friction: the study's floppy N = 3 strand against
//!   its BDF2 references.
//! - `helix` (frictionless): a curly N = 3 helix hanging at rest in its natural shape,
//!   released under gravity with nothing to damp it, against explicit RK4 at
//!   [`HELIX_REFERENCE_RATE`] steps a second (another scheme, no error control), its own
//!   error estimated from the run at half that rate.
//!
//! Error: max over the frames (every 1/30 s) of |tip − tip_ref| / L. Cost: CPU time of
//! the steps per simulated second, as for the other problems.

use crate::runtime::config::{IntegratorKind, SimulationSetup};
use crate::runtime::kernels::kernel::KernelFactory;
use crate::runtime::{HeadMotion, Result, Vector3};
use crate::study::{
    curly_setup, floppy_strand, helix_strand, max_distance, setup_of, swing_setup, tip_run, Grid,
    Kernels, ProblemResult, Reference, Setting, CURLY_LENGTH, FLOPPY_DURATION, FLOPPY_LENGTH,
    FLOPPY_N, HELIX_DURATION, HELIX_LENGTH, HELIX_N, REFERENCE_N, SWING_LENGTH,
};
use crate::study_plot::{log_log_svg, Marker, Series, Style};
use plotters::prelude::{RGBColor, SeriesLabelPosition};
use rayon::prelude::*;
use std::fmt::Write as _;

/// The tolerances asked for.
pub const TOLERANCES: [f64; 5] = [1e-1, 1e-2, 1e-3, 1e-4, 1e-5];

/// Frames per second of the runs (the scene's dt).
const FRAME_RATE: u32 = 30;

/// Steps per second of the helix's RK4 reference (its own error, estimated as a
/// sixteenth of its distance from the run at half the rate, is in the report's notes).
pub const HELIX_REFERENCE_RATE: u32 = 240_000;

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
}

/// One tolerance's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct TolerancePoint {
    /// The tolerance asked for.
    pub tolerance: f64,
    /// What it measured, or why the run failed.
    pub outcome: std::result::Result<ToleranceMeasured, String>,
}

/// One case: a strand against its reference at every tolerance.
#[derive(Debug, Clone, PartialEq)]
pub struct ToleranceCase {
    /// `swing`, `curly`, `floppy`, `helix`.
    pub problem: &'static str,
    /// With internal friction (and drag where the problem has it).
    pub friction: bool,
    /// Elements N.
    pub elements: usize,
    /// The points, in [`Grid::tolerances`] order.
    pub points: Vec<TolerancePoint>,
}

impl ToleranceCase {
    /// `swing, frictionless`.
    pub fn label(&self) -> String {
        format!(
            "{}, N = {}, {}",
            self.problem,
            self.elements,
            if self.friction {
                "friction"
            } else {
                "frictionless"
            }
        )
    }

    /// The largest error / tolerance over the successful points, and the smallest.
    pub fn ratio_range(&self) -> (f64, f64) {
        self.points
            .iter()
            .filter_map(|p| p.outcome.as_ref().ok().map(|m| m.error / p.tolerance))
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), r| {
                (lo.min(r), hi.max(r))
            })
    }
}

/// The references the cases are measured against (computed by the other problems).
pub(crate) struct References<'a> {
    /// `swing`'s.
    pub swing: &'a Reference,
    /// `curly`'s.
    pub curly: &'a Reference,
    /// `floppy`'s, frictionless and with friction, at `Grid::floppy_reference_rate`.
    pub floppy: &'a [Vec<Vector3<f64>>],
}

/// One case's input: a set-up for a tolerance, the reference, its rate, L, duration.
struct CaseInput<'a> {
    problem: &'static str,
    friction: bool,
    elements: usize,
    make: Box<dyn Fn() -> SimulationSetup + Sync + 'a>,
    reference: &'a [Vector3<f64>],
    reference_rate: u32,
    length: f64,
    duration: f64,
}

fn frame_setting(elements: usize) -> Setting {
    Setting {
        elements,
        rate: Some(FRAME_RATE),
        integrator: Some(IntegratorKind::LinearlyImplicitEuler),
        kernels: Kernels::Generated,
    }
}

/// Run the `tolerance` problem.
pub(crate) fn tolerance_problem(
    grid: &Grid,
    factory: Option<&dyn KernelFactory>,
    references: &References<'_>,
) -> ProblemResult {
    let (swing_reference, swing_rate, mut notes) = match swing_reference(grid, factory) {
        Ok(r) => r,
        Err(e) => (references.swing.tips.clone(), references.swing.rate, e),
    };
    let helix = helix_reference(factory);
    match &helix {
        Ok((_, note)) => notes.push_str(&format!(" {note}")),
        Err(e) => notes.push_str(&format!(" {e}")),
    }
    let mut inputs = vec![
        CaseInput {
            problem: "swing",
            friction: false,
            elements: REFERENCE_N,
            make: Box::new(|| swing_setup(&frame_setting(REFERENCE_N), grid.swing_duration)),
            reference: &swing_reference,
            reference_rate: swing_rate,
            length: SWING_LENGTH,
            duration: grid.swing_duration,
        },
        CaseInput {
            problem: "curly",
            friction: true,
            elements: REFERENCE_N,
            make: Box::new(|| curly_setup(&frame_setting(REFERENCE_N), grid.duration)),
            reference: &references.curly.tips,
            reference_rate: references.curly.rate,
            length: CURLY_LENGTH,
            duration: grid.duration,
        },
    ];
    for (friction, reference) in [false, true].into_iter().zip(references.floppy) {
        inputs.push(CaseInput {
            problem: "floppy",
            friction,
            elements: FLOPPY_N,
            make: Box::new(move || {
                setup_of(
                    floppy_strand(friction),
                    &frame_setting(FLOPPY_N),
                    FLOPPY_DURATION,
                    true,
                    HeadMotion::Still,
                )
            }),
            reference,
            reference_rate: grid.floppy_reference_rate,
            length: FLOPPY_LENGTH,
            duration: FLOPPY_DURATION,
        });
    }
    if let Ok((reference, _)) = &helix {
        inputs.push(CaseInput {
            problem: "helix",
            friction: false,
            elements: HELIX_N,
            make: Box::new(|| {
                setup_of(
                    helix_strand(),
                    &frame_setting(HELIX_N),
                    HELIX_DURATION,
                    true,
                    HeadMotion::Still,
                )
            }),
            reference,
            reference_rate: HELIX_REFERENCE_RATE,
            length: HELIX_LENGTH,
            duration: HELIX_DURATION,
        });
    }
    let jobs: Vec<(usize, f64)> = (0..inputs.len())
        .flat_map(|c| grid.tolerances.iter().map(move |&t| (c, t)))
        .collect();
    let outcomes: Vec<TolerancePoint> = jobs
        .par_iter()
        .map(|&(c, tolerance)| TolerancePoint {
            tolerance,
            outcome: measure(&inputs[c], tolerance, factory),
        })
        .collect();
    let mut outcomes = outcomes.into_iter();
    let cases: Vec<ToleranceCase> = inputs
        .iter()
        .map(|input| ToleranceCase {
            problem: input.problem,
            friction: input.friction,
            elements: input.elements,
            points: outcomes.by_ref().take(grid.tolerances.len()).collect(),
        })
        .collect();
    ProblemResult {
        key: "tolerance",
        title: "What a tolerance delivers and costs".into(),
        description: format!(
            "The error-controlled step (`[simulation] tolerance`) on the strands of `swing` and \
             `curly` at N = {REFERENCE_N} (the N of their references, so that the difference is \
             time error alone) and on the floppy N = {FLOPPY_N} strand of `floppy`, frictionless \
             and with friction, and on a frictionless curly N = {HELIX_N} helix hanging at rest in \
             its natural shape, released under gravity (against RK4 at 1/{HELIX_REFERENCE_RATE} \
             s), frames every 1/{FRAME_RATE} s. Error: max over the frames of \
             |tip − tip_ref| / L against the problem's reference; the tolerance bounds each \
             step's estimated local error on the centreline, over L. Cost: CPU time of the \
             steps per simulated second."
        ),
        is_static: false,
        points: Vec::new(),
        notes,
        spatial: Vec::new(),
        error_title: "error: max over frames of |tip − tip_ref| / L".into(),
        convergence: Vec::new(),
        rotary: Vec::new(),
        tolerance: cases,
    }
}

/// `swing`'s reference for this problem, finer than the `swing` problem's (whose own
/// error, about 3.6e-4 L, is what it measures at the smallest tolerances): BDF2 at N = 20
/// at 4 and 8 times the study's reference rate, combined by second-order Richardson
/// extrapolation (4 x(h/2) − x(h))/3; with the report's note on its distance from its
/// finer ingredient.
fn swing_reference(
    grid: &Grid,
    factory: Option<&dyn KernelFactory>,
) -> std::result::Result<(Vec<Vector3<f64>>, u32, String), String> {
    let rate = 4 * grid.reference_rate;
    let tips = runs_at(
        [rate, 2 * rate],
        (IntegratorKind::Bdf2, REFERENCE_N, grid.swing_duration),
        &|setting| swing_setup(setting, grid.swing_duration),
        factory,
    )
    .map_err(|e| {
        format!("The swing's reference run failed ({e}); the `swing` problem's reference is used.")
    })?;
    let reference: Vec<Vector3<f64>> = tips[0]
        .iter()
        .enumerate()
        .map(|(j, c)| (4.0 * tips[1][2 * j] - c) / 3.0)
        .collect();
    let d_fine = max_distance(&reference, &tips[1], 2) / SWING_LENGTH;
    let notes = format!(
        "Reference of `swing` here: BDF2 at N = {REFERENCE_N}, dt = 1/{rate} and 1/{} s, combined by \
         second-order Richardson extrapolation (4 x(dt/2) − x(dt))/3; its distance (max over time, \
         / L) from BDF2 at 1/{}: {d_fine:.2e}. `curly` and `floppy` use their problems' references.",
        2 * rate,
        2 * rate
    );
    Ok((reference, rate, notes))
}

/// The helix's reference: RK4 at [`HELIX_REFERENCE_RATE`] and at half that rate, its own
/// error estimated as a sixteenth of their distance (fourth order), with the report's note.
fn helix_reference(
    factory: Option<&dyn KernelFactory>,
) -> std::result::Result<(Vec<Vector3<f64>>, String), String> {
    let mut tips = runs_at(
        [HELIX_REFERENCE_RATE / 2, HELIX_REFERENCE_RATE],
        (IntegratorKind::Rk4, HELIX_N, HELIX_DURATION),
        &|setting| {
            setup_of(
                helix_strand(),
                setting,
                HELIX_DURATION,
                true,
                HeadMotion::Still,
            )
        },
        factory,
    )
    .map_err(|e| format!("The helix's reference run failed ({e}): no `helix` case."))?;
    let own = max_distance(&tips[0], &tips[1], 2) / HELIX_LENGTH / 15.0;
    let note = format!(
        "Reference of `helix`: RK4 at dt = 1/{HELIX_REFERENCE_RATE} s, its error estimated as \
         its distance from RK4 at 1/{} s over 15 (max over time, / L): {own:.2e}.",
        HELIX_REFERENCE_RATE / 2
    );
    let fine = tips.pop().unwrap_or_default();
    Ok((fine, note))
}

/// The tips at every step of the runs of `setup` (given its setting) at each of `rates`
/// steps a second, in parallel, with `integrator` and the generated kernels at `elements`
/// over `duration` s; the first failure's message.
fn runs_at(
    rates: [u32; 2],
    (integrator, elements, duration): (IntegratorKind, usize, f64),
    setup: &(dyn Fn(&Setting) -> SimulationSetup + Sync),
    factory: Option<&dyn KernelFactory>,
) -> std::result::Result<Vec<Vec<Vector3<f64>>>, String> {
    rates
        .par_iter()
        .map(|&rate| {
            let setting = Setting {
                elements,
                rate: Some(rate),
                integrator: Some(integrator),
                kernels: Kernels::Generated,
            };
            let steps = (duration * rate as f64).round() as usize;
            tip_run(setup(&setting), factory, steps).map(|r| r.0)
        })
        .collect()
}

fn measure(
    input: &CaseInput<'_>,
    tolerance: f64,
    factory: Option<&dyn KernelFactory>,
) -> std::result::Result<ToleranceMeasured, String> {
    let mut setup = (input.make)();
    setup.config.tolerance = Some(tolerance);
    let frames = (input.duration * FRAME_RATE as f64).round() as usize;
    let (tips, cpu, stats) = tip_run(setup, factory, frames)?;
    let stride = (input.reference_rate / FRAME_RATE) as usize;
    Ok(ToleranceMeasured {
        error: max_distance(&tips, input.reference, stride) / input.length,
        cost: cpu / input.duration,
        steps: stats.error_steps,
        rejected: stats.error_rejected,
    })
}

/// The report's table: per tolerance and case, the error (and error / tolerance), the
/// cost and the steps.
pub fn render_table(s: &mut String, cases: &[ToleranceCase]) {
    let names: Vec<String> = cases.iter().map(ToleranceCase::label).collect();
    let _ = writeln!(s, "Error / L (error / tolerance) and cost (ms of CPU per simulated s, steps accepted / rejected):\n");
    let _ = writeln!(s, "| tolerance | {} |", names.join(" | "));
    let _ = writeln!(s, "|---|{}", "---|".repeat(names.len()));
    let rows = cases.first().map_or(0, |c| c.points.len());
    for i in 0..rows {
        let cells: Vec<String> = cases
            .iter()
            .map(
                |c| match c.points.get(i).map(|p| (p.tolerance, &p.outcome)) {
                    Some((t, Ok(m))) => format!(
                        "{:.2e} ({:.2}); {:.3} ms, {}/{}",
                        m.error,
                        m.error / t,
                        m.cost * 1e3,
                        m.steps,
                        m.rejected
                    ),
                    Some((_, Err(e))) => format!("failed: {}", e.replace('|', "/")),
                    None => "-".into(),
                },
            )
            .collect();
        let t = cases[0].points[i].tolerance;
        let _ = writeln!(s, "| {t:.0e} | {} |", cells.join(" | "));
    }
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
                "points": c.points.iter().map(|p| match &p.outcome {
                    Ok(m) => json!({"tolerance": p.tolerance, "error": m.error, "cost_seconds": m.cost, "steps": m.steps, "rejected": m.rejected}),
                    Err(e) => json!({"tolerance": p.tolerance, "failed": e}),
                }).collect::<Vec<_>>(),
            })
        })
        .collect()
}
