//! The plots of `superhelix study`, as SVG: a title, axis titles with units, log–log
//! axes with labelled ticks, and a legend inside the picture.
//!
//! SVG because its text is SVG `<text>` drawn by the viewer: plotters' SVG backend needs
//! no font file, where a PNG would need a TrueType font compiled in. `report.md` embeds
//! the SVGs as images.
//!
//! Every series keeps one colour and marker in every plot: the colour is looked up in a
//! fixed table by the setting (integrator and kernels, [`series_style`]; friction for the
//! convergence plot), never by order of appearance.

use crate::runtime::{Error, IntegratorKind, Result};
use crate::study::{Kernels, ProblemResult, Setting};
use plotters::prelude::*;

/// Width and height of a plot, pixels.
pub const SIZE: (u32, u32) = (960, 640);

/// A marker shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    /// Filled circle: linearly implicit Euler, statics.
    Circle,
    /// Filled triangle: Newton implicit Euler.
    Triangle,
    /// Cross: BDF2.
    Cross,
    /// Square outline: RK4.
    Square,
}

/// Colour and marker of a series.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Style {
    /// Colour.
    pub colour: RGBColor,
    /// Marker.
    pub marker: Marker,
}

/// Marker of an integrator (statics: circle).
pub fn marker_of(integrator: Option<IntegratorKind>) -> Marker {
    match integrator {
        Some(IntegratorKind::NewtonImplicitEuler) => Marker::Triangle,
        Some(IntegratorKind::Bdf2) => Marker::Cross,
        Some(IntegratorKind::Rk4) => Marker::Square,
        _ => Marker::Circle,
    }
}

/// The fixed colour of a setting's series: generated kernels by integrator (linearly
/// implicit Euler blue, Newton implicit Euler orange, BDF2 green, RK4 red, statics
/// blue), generic kernels by rule (2 points purple, 4 brown, 8 pink, adaptive grey,
/// other orders olive).
pub fn series_style(setting: &Setting) -> Style {
    use crate::runtime::QuadratureRule::{Adaptive, Fixed};
    let colour = match setting.kernels {
        Kernels::Generated => match setting.integrator {
            Some(IntegratorKind::NewtonImplicitEuler) => RGBColor(255, 127, 14),
            Some(IntegratorKind::Bdf2) => RGBColor(44, 160, 44),
            Some(IntegratorKind::Rk4) => RGBColor(214, 39, 40),
            _ => RGBColor(31, 119, 180),
        },
        Kernels::Generic(Fixed(2)) => RGBColor(148, 103, 189),
        Kernels::Generic(Fixed(4)) => RGBColor(140, 86, 75),
        Kernels::Generic(Fixed(8)) => RGBColor(227, 119, 194),
        Kernels::Generic(Adaptive) => RGBColor(127, 127, 127),
        Kernels::Generic(Fixed(_)) => RGBColor(188, 189, 34),
    };
    Style {
        colour,
        marker: marker_of(setting.integrator),
    }
}

/// Colour of a convergence series: the integrator's colour, darker with friction.
pub fn convergence_style(integrator: IntegratorKind, friction: bool) -> Style {
    let base = series_style(&Setting {
        elements: 1,
        rate: Some(1),
        integrator: Some(integrator),
        kernels: Kernels::Generated,
    });
    let RGBColor(r, g, b) = base.colour;
    let colour = if friction {
        RGBColor(r / 2, g / 2, b / 2)
    } else {
        base.colour
    };
    Style { colour, ..base }
}

fn plot_error(e: impl std::fmt::Display) -> Error {
    Error::invalid("study.plot", e.to_string())
}

fn decades(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return (0.1, 1.0);
    }
    let (a, b) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    (10f64.powi(a), 10f64.powi(b.max(a + 1)))
}

/// Smallest error drawn (exact zeros are drawn here).
const ERROR_FLOOR: f64 = 1e-12;

/// One named series of points.
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Colour and marker.
    pub style: Style,
    /// (x, y) points.
    pub points: Vec<(f64, f64)>,
    /// Join the points with a line.
    pub line: bool,
}

/// A log–log plot as SVG text, the legend at `legend_at` inside the plotting area.
pub fn log_log_svg(
    title: &str,
    x_title: &str,
    y_title: &str,
    series: &[Series],
    extra_line: Option<(&str, Vec<(f64, f64)>)>,
    legend_at: SeriesLabelPosition,
) -> Result<String> {
    let (x0, x1) = decades(series.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
    let (y0, y1) = decades(series.iter().flat_map(|s| s.points.iter().map(|p| p.1)));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 24))
            .margin(15)
            .x_label_area_size(55)
            .y_label_area_size(85)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .x_desc(x_title)
            .y_desc(y_title)
            .x_label_formatter(&|x| format!("{x:.0e}"))
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .label_style(("sans-serif", 15))
            .axis_desc_style(("sans-serif", 18))
            .draw()
            .map_err(plot_error)?;
        if let Some((name, line)) = extra_line {
            chart
                .draw_series(LineSeries::new(line, BLACK.stroke_width(2)))
                .map_err(plot_error)?
                .label(name)
                .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK.stroke_width(2)));
        }
        for s in series {
            let colour = s.style.colour;
            if s.line {
                chart
                    .draw_series(LineSeries::new(s.points.clone(), colour.stroke_width(1)))
                    .map_err(plot_error)?;
            }
            let pts = s.points.clone();
            let anno = match s.style.marker {
                Marker::Circle => chart
                    .draw_series(pts.into_iter().map(|p| Circle::new(p, 5, colour.filled())))
                    .map_err(plot_error)?
                    .label(s.name.clone())
                    .legend(move |(x, y)| Circle::new((x + 10, y), 5, colour.filled())),
                Marker::Triangle => chart
                    .draw_series(
                        pts.into_iter()
                            .map(|p| TriangleMarker::new(p, 7, colour.filled())),
                    )
                    .map_err(plot_error)?
                    .label(s.name.clone())
                    .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 7, colour.filled())),
                Marker::Cross => chart
                    .draw_series(
                        pts.into_iter()
                            .map(|p| Cross::new(p, 6, colour.stroke_width(3))),
                    )
                    .map_err(plot_error)?
                    .label(s.name.clone())
                    .legend(move |(x, y)| Cross::new((x + 10, y), 6, colour.stroke_width(3))),
                Marker::Square => chart
                    .draw_series(pts.into_iter().map(|p| {
                        EmptyElement::at(p)
                            + Rectangle::new([(-5, -5), (5, 5)], colour.stroke_width(2))
                    }))
                    .map_err(plot_error)?
                    .label(s.name.clone())
                    .legend(move |(x, y)| {
                        Rectangle::new([(x + 5, y - 5), (x + 15, y + 5)], colour.stroke_width(2))
                    }),
            };
            let _ = anno;
        }
        chart
            .configure_series_labels()
            .position(legend_at)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(plot_error)?;
        root.present().map_err(plot_error)?;
    }
    Ok(svg)
}

/// Draw the error-against-cost plot of one problem: the SVG text.
pub fn plot(problem: &ProblemResult) -> Result<String> {
    let mut series: Vec<Series> = Vec::new();
    for p in &problem.points {
        let Ok(m) = &p.outcome else { continue };
        let name = p.setting.series();
        let point = (m.cost * 1e3, m.error.max(ERROR_FLOOR));
        match series.iter_mut().find(|s| s.name == name) {
            Some(s) => s.points.push(point),
            None => series.push(Series {
                name,
                style: series_style(&p.setting),
                points: vec![point],
                line: false,
            }),
        }
    }
    let mut front: Vec<(f64, f64)> = problem
        .points
        .iter()
        .filter(|p| p.pareto)
        .filter_map(|p| {
            p.outcome
                .as_ref()
                .ok()
                .map(|m| (m.cost * 1e3, m.error.max(ERROR_FLOOR)))
        })
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    let x_title = if problem.is_static {
        "cost: CPU time per static solve (ms)"
    } else {
        "cost: CPU time per strand per simulated second (ms)"
    };
    log_log_svg(
        &problem.title,
        x_title,
        &problem.error_title,
        &series,
        Some(("Pareto front", front)),
        SeriesLabelPosition::LowerLeft,
    )
}
