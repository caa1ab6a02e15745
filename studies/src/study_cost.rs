//! The study's cost of one strand-step against the number of elements N, for each way a
//! strand's terms can be computed: the generic runtime-N kernel (Gauss–Legendre
//! quadrature), the moment assembly on the generated closed forms (runtime N), the
//! generated fixed-N kernel in the runtime engine, and the embedded engine (the fixed-N step of `superhelix-kernels` on arrays of literal size, one
//! workspace per thread). The bench's strands (wavy preset, 20 cm, gravity, drag,
//! internal friction, dt = 1/30 s), CPU time of the process per strand-step.

use crate::bench::{bench, BenchOptions, EffectSet};
use crate::study_plot::{log_log_svg, Marker, Series, Style};
use plotters::prelude::{RGBColor, SeriesLabelPosition};
use superhelix_runtime::config::{Engine, KernelChoice};
use superhelix_runtime::Result;

/// One measured cost.
#[derive(Debug, Clone, PartialEq)]
pub struct CostPoint {
    /// The path's label.
    pub path: &'static str,
    /// Elements per strand.
    pub n: usize,
    /// CPU time per strand-step, µs (wall time where the platform has no CPU clock).
    pub us_per_strand_step: f64,
    /// Steps split by the checks, over all strands.
    pub substeps: usize,
}

/// The paths compared: label, kernels, engine, colour.
pub const PATHS: [(&str, KernelChoice, Engine, RGBColor); 4] = [
    (
        "generic (quadrature, runtime N)",
        KernelChoice::Generic,
        Engine::Runtime,
        RGBColor(127, 127, 127),
    ),
    (
        "moment (closed forms, runtime N)",
        KernelChoice::Moment,
        Engine::Runtime,
        RGBColor(44, 160, 44),
    ),
    (
        "generated fixed-N (runtime engine)",
        KernelChoice::Generated,
        Engine::Runtime,
        RGBColor(31, 119, 180),
    ),
    (
        "embedded fixed-N step",
        KernelChoice::Generated,
        Engine::Embedded,
        RGBColor(214, 39, 40),
    ),
];

/// The numbers of elements of the study's cost curve.
pub const ELEMENTS: [usize; 8] = [1, 2, 3, 5, 8, 10, 15, 20];

/// Cost per strand-step of every path at every N of `elements`: `strands` strands for
/// `steps` steps each.
pub fn cost_by_elements(
    elements: &[usize],
    strands: usize,
    steps: usize,
) -> Result<Vec<CostPoint>> {
    let mut points = Vec::new();
    for &(path, kernels, engine, _) in &PATHS {
        for &n in elements {
            let report = bench(&BenchOptions {
                elements: n,
                strands,
                steps,
                kernels,
                engine,
                effects: EffectSet::default_bench(),
                ..BenchOptions::default()
            })?;
            let seconds = report.cpu_seconds.unwrap_or(report.seconds);
            points.push(CostPoint {
                path,
                n,
                us_per_strand_step: 1e6 * seconds / report.strand_steps.max(1) as f64,
                substeps: report.substeps,
            });
        }
    }
    Ok(points)
}

/// The cost curve as an SVG plot (log–log: N against µs per strand-step).
pub fn cost_plot(points: &[CostPoint]) -> Result<String> {
    let series: Vec<Series> = PATHS
        .iter()
        .map(|&(path, _, _, colour)| Series {
            name: path.to_string(),
            style: Style {
                colour,
                marker: Marker::Circle,
            },
            points: points
                .iter()
                .filter(|p| p.path == path)
                .map(|p| (p.n as f64, p.us_per_strand_step))
                .collect(),
            line: true,
        })
        .collect();
    log_log_svg(
        "Cost of one strand-step against N",
        "elements per strand N",
        "CPU time per strand-step (µs)",
        &series,
        None,
        SeriesLabelPosition::UpperLeft,
    )
}

/// The cost curve as a markdown table: one row per N, one column per path.
pub fn cost_table(points: &[CostPoint]) -> String {
    let mut s = String::from("| N |");
    for (path, ..) in PATHS {
        s.push_str(&format!(" {path} (µs) |"));
    }
    s.push_str(" generic ÷ embedded |\n|---|");
    for _ in PATHS {
        s.push_str("---|");
    }
    s.push_str("---|\n");
    let mut ns: Vec<usize> = points.iter().map(|p| p.n).collect();
    ns.sort_unstable();
    ns.dedup();
    for n in ns {
        let cost = |path: &str| {
            points
                .iter()
                .find(|p| p.n == n && p.path == path)
                .map(|p| p.us_per_strand_step)
        };
        s.push_str(&format!("| {n} |"));
        for (path, ..) in PATHS {
            match cost(path) {
                Some(c) => s.push_str(&format!(" {c:.1} |")),
                None => s.push_str(" — |"),
            }
        }
        match (cost(PATHS[0].0), cost(PATHS[3].0)) {
            (Some(a), Some(b)) if b > 0.0 => s.push_str(&format!(" {:.1}× |\n", a / b)),
            _ => s.push_str(" — |\n"),
        }
    }
    s
}
