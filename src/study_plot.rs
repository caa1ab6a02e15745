//! The PNG plots of `superhelix study`: error against cost, log–log, one colour per
//! series (integrator and kernels), the Pareto front as a black line.
//!
//! plotters is built without a font backend: its text needs a TrueType font from the
//! system or shipped with us, and neither is available offline, so the axes carry decade
//! grid lines and numeric tick labels drawn with a small built-in pixel font
//! ([`draw_text`], digits and 'e' only); the legend (which colour is which series) is
//! written in report.md ([`Legend::describe`]). plotters renders into an RGB buffer and
//! tiny-skia encodes it as PNG.

use crate::runtime::{Error, IntegratorKind, Result};
use crate::study::ProblemResult;
use plotters::prelude::*;
use std::fmt::Write as _;

/// Width and height of a plot, pixels.
pub const SIZE: (u32, u32) = (960, 640);

/// Named colours of the series, in order.
pub const PALETTE: [(&str, RGBColor); 10] = [
    ("blue", RGBColor(31, 119, 180)),
    ("orange", RGBColor(255, 127, 14)),
    ("green", RGBColor(44, 160, 44)),
    ("red", RGBColor(214, 39, 40)),
    ("purple", RGBColor(148, 103, 189)),
    ("brown", RGBColor(140, 86, 75)),
    ("pink", RGBColor(227, 119, 194)),
    ("grey", RGBColor(127, 127, 127)),
    ("olive", RGBColor(188, 189, 34)),
    ("cyan", RGBColor(23, 190, 207)),
];

/// What a plot shows, for the report.
#[derive(Debug, Clone, PartialEq)]
pub struct Legend {
    /// Series name and colour name.
    pub series: Vec<(String, &'static str)>,
    /// Decades of the x axis (cost in ms), 10^a..10^b.
    pub x_decades: (i32, i32),
    /// Decades of the y axis (error), 10^a..10^b.
    pub y_decades: (i32, i32),
}

impl Legend {
    /// One markdown sentence: axes and series colours.
    pub fn describe(&self, x: &str, unit: &str, y: &str) -> String {
        let mut s = format!(
            "x = {x} ({unit}, log scale, 1e{} to 1e{}), y = {y} (log scale, 1e{} to 1e{}); grey \
             lines at every decade, labelled with the exponent; colours: ",
            self.x_decades.0, self.x_decades.1, self.y_decades.0, self.y_decades.1
        );
        let parts: Vec<String> = self
            .series
            .iter()
            .map(|(name, colour)| format!("{name} = {colour}"))
            .collect();
        let _ = write!(
            s,
            "{}; filled circles: linearly implicit Euler or statics, triangles: Newton implicit \
             Euler, crosses: BDF2; black line: Pareto front.",
            parts.join(", ")
        );
        s
    }
}

fn plot_error(e: impl std::fmt::Display) -> Error {
    Error::invalid("study.plot", e.to_string())
}

fn decades(values: impl Iterator<Item = f64>) -> (i32, i32) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return (-1, 0);
    }
    let (a, b) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    (a, b.max(a + 1))
}

/// Smallest error drawn (exact zeros are drawn here).
const ERROR_FLOOR: f64 = 1e-12;

/// Draw the plot of one problem; returns the PNG bytes and the legend.
pub fn plot(problem: &ProblemResult) -> Result<(Vec<u8>, Legend)> {
    let ok: Vec<(String, Option<IntegratorKind>, f64, f64, bool)> = problem
        .points
        .iter()
        .filter_map(|p| {
            p.outcome.as_ref().ok().map(|m| {
                (
                    p.setting.series(),
                    p.setting.integrator,
                    m.cost * 1e3,
                    m.error.max(ERROR_FLOOR),
                    p.pareto,
                )
            })
        })
        .collect();
    let mut names: Vec<String> = Vec::new();
    for (name, ..) in &ok {
        if !names.contains(name) {
            names.push(name.clone());
        }
    }
    let x_decades = decades(ok.iter().map(|p| p.2));
    let y_decades = decades(ok.iter().map(|p| p.3));
    let (w, h) = SIZE;
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let (left, bottom, right, top) = (90i32, 50i32, 30i32, 30i32);
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let area = root.margin(top as u32, bottom as u32, left as u32, right as u32);
        let (x0, x1) = (10f64.powi(x_decades.0), 10f64.powi(x_decades.1));
        let (y0, y1) = (10f64.powi(y_decades.0), 10f64.powi(y_decades.1));
        let mut chart = ChartBuilder::on(&area)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(plot_error)?;
        let grey = RGBColor(210, 210, 210);
        for e in x_decades.0..=x_decades.1 {
            let x = 10f64.powi(e);
            chart
                .draw_series(LineSeries::new([(x, y0), (x, y1)], grey))
                .map_err(plot_error)?;
        }
        for e in y_decades.0..=y_decades.1 {
            let y = 10f64.powi(e);
            chart
                .draw_series(LineSeries::new([(x0, y), (x1, y)], grey))
                .map_err(plot_error)?;
        }
        let mut front: Vec<(f64, f64)> = ok.iter().filter(|p| p.4).map(|p| (p.2, p.3)).collect();
        front.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(front, BLACK.stroke_width(2)))
            .map_err(plot_error)?;
        for (i, name) in names.iter().enumerate() {
            let colour = PALETTE[i % PALETTE.len()].1;
            for p in ok.iter().filter(|p| &p.0 == name) {
                match p.1 {
                    Some(IntegratorKind::NewtonImplicitEuler) => chart
                        .draw_series(std::iter::once(TriangleMarker::new(
                            (p.2, p.3),
                            7,
                            colour.filled(),
                        )))
                        .map_err(plot_error)?,
                    Some(IntegratorKind::Bdf2) => chart
                        .draw_series(std::iter::once(Cross::new(
                            (p.2, p.3),
                            6,
                            colour.stroke_width(3),
                        )))
                        .map_err(plot_error)?,
                    _ => chart
                        .draw_series(std::iter::once(Circle::new((p.2, p.3), 5, colour.filled())))
                        .map_err(plot_error)?,
                };
            }
        }
        // frame and decade exponents (pixel font)
        let (pw, ph) = (w as i32 - left - right, h as i32 - top - bottom);
        root.draw(&Rectangle::new(
            [(left, top), (left + pw, top + ph)],
            BLACK.stroke_width(1),
        ))
        .map_err(plot_error)?;
        let nx = (x_decades.1 - x_decades.0) as f64;
        for e in x_decades.0..=x_decades.1 {
            let px = left + ((e - x_decades.0) as f64 / nx * pw as f64).round() as i32;
            let label = format!("1e{e}");
            let tw = text_width(&label, 3);
            draw_text(&root, &label, (px - tw / 2, top + ph + 10), 3).map_err(plot_error)?;
        }
        let ny = (y_decades.1 - y_decades.0) as f64;
        for e in y_decades.0..=y_decades.1 {
            let py = top + ph - ((e - y_decades.0) as f64 / ny * ph as f64).round() as i32;
            let label = format!("1e{e}");
            let tw = text_width(&label, 3);
            draw_text(&root, &label, (left - tw - 8, py - 7), 3).map_err(plot_error)?;
        }
        root.present().map_err(plot_error)?;
    }
    let legend = Legend {
        series: names
            .iter()
            .enumerate()
            .map(|(i, n)| (n.clone(), PALETTE[i % PALETTE.len()].0))
            .collect(),
        x_decades,
        y_decades,
    };
    Ok((encode_png(w, h, &buf)?, legend))
}

/// 3x5 pixel glyphs of the characters of tick labels, rows top to bottom, 3 bits each.
fn glyph(c: char) -> Option<[u8; 5]> {
    Some(match c {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 2, 2, 2],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        'e' => [0, 7, 7, 4, 7],
        '-' => [0, 0, 7, 0, 0],
        '.' => [0, 0, 0, 0, 2],
        _ => return None,
    })
}

fn text_width(text: &str, scale: i32) -> i32 {
    text.chars().count() as i32 * 4 * scale
}

/// Draw `text` (digits, `e`, `-`, `.`) with its top-left corner at `at`, each font
/// pixel a `scale`×`scale` square.
pub fn draw_text<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    text: &str,
    at: (i32, i32),
    scale: i32,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    for (i, c) in text.chars().enumerate() {
        let Some(rows) = glyph(c) else { continue };
        let x0 = at.0 + i as i32 * 4 * scale;
        for (r, bits) in rows.iter().enumerate() {
            for col in 0..3 {
                if bits & (4 >> col) != 0 {
                    let x = x0 + col * scale;
                    let y = at.1 + r as i32 * scale;
                    area.draw(&Rectangle::new(
                        [(x, y), (x + scale - 1, y + scale - 1)],
                        BLACK.filled(),
                    ))?;
                }
            }
        }
    }
    Ok(())
}

/// A PNG of `rgb` (row-major, 3 bytes per pixel) through tiny-skia's encoder.
pub fn encode_png(w: u32, h: u32, rgb: &[u8]) -> Result<Vec<u8>> {
    let mut pixmap = tiny_skia::Pixmap::new(w, h)
        .ok_or_else(|| plot_error(format!("cannot make a {w} x {h} image")))?;
    for (px, c) in pixmap
        .data_mut()
        .chunks_exact_mut(4)
        .zip(rgb.chunks_exact(3))
    {
        px.copy_from_slice(&[c[0], c[1], c[2], 255]);
    }
    pixmap.encode_png().map_err(plot_error)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_has_signature_and_chunks() {
        let png = encode_png(2, 1, &[255, 0, 0, 0, 0, 255]).expect("encodes");
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(&png[12..16], b"IHDR");
        assert_eq!(&png[png.len() - 8..png.len() - 4], b"IEND");
    }
}
