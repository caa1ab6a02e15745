//! The PNG plots of `superhelix study`: error against cost, log–log, one colour per
//! series (integrator and kernels), the Pareto front as a black line.
//!
//! plotters is built without a font backend (no system fonts are needed): the axes carry
//! decade grid lines and numeric tick labels drawn with a small built-in pixel font
//! ([`draw_text`]); the legend (which colour is which series) is written in report.md
//! ([`Legend::describe`]). The PNG is encoded here (uncompressed deflate blocks).

use crate::runtime::{Error, Result};
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
             Euler; black line: Pareto front.",
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
    let ok: Vec<(String, bool, f64, f64, bool)> = problem
        .points
        .iter()
        .filter_map(|p| {
            p.outcome.as_ref().ok().map(|m| {
                (
                    p.setting.series(),
                    p.setting.integrator
                        == Some(crate::runtime::IntegratorKind::NewtonImplicitEuler),
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
                if p.1 {
                    chart
                        .draw_series(std::iter::once(TriangleMarker::new(
                            (p.2, p.3),
                            7,
                            colour.filled(),
                        )))
                        .map_err(plot_error)?;
                } else {
                    chart
                        .draw_series(std::iter::once(Circle::new((p.2, p.3), 5, colour.filled())))
                        .map_err(plot_error)?;
                }
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
    Ok((encode_png(w, h, &buf), legend))
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

fn crc32(data: &[&[u8]]) -> u32 {
    let mut table = [0u32; 256];
    for (n, t) in table.iter_mut().enumerate() {
        let mut c = n as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
        *t = c;
    }
    let mut c = 0xFFFF_FFFFu32;
    for part in data {
        for &b in *part {
            c = table[((c ^ b as u32) & 0xFF) as usize] ^ (c >> 8);
        }
    }
    c ^ 0xFFFF_FFFF
}

fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_be_bytes());
    out.extend_from_slice(kind);
    out.extend_from_slice(data);
    out.extend_from_slice(&crc32(&[kind, data]).to_be_bytes());
}

/// An 8-bit RGB PNG of `rgb` (row-major, 3 bytes per pixel), zlib stream of stored
/// (uncompressed) deflate blocks.
pub fn encode_png(w: u32, h: u32, rgb: &[u8]) -> Vec<u8> {
    let row = (w * 3) as usize;
    let mut raw = Vec::with_capacity((row + 1) * h as usize);
    for y in 0..h as usize {
        raw.push(0); // filter: none
        raw.extend_from_slice(&rgb[y * row..(y + 1) * row]);
    }
    let mut z = vec![0x78, 0x01];
    let blocks: Vec<&[u8]> = raw.chunks(65_535).collect();
    for (i, b) in blocks.iter().enumerate() {
        z.push(u8::from(i + 1 == blocks.len()));
        let len = b.len() as u16;
        z.extend_from_slice(&len.to_le_bytes());
        z.extend_from_slice(&(!len).to_le_bytes());
        z.extend_from_slice(b);
    }
    let (mut a, mut b) = (1u32, 0u32);
    for &x in &raw {
        a = (a + x as u32) % 65_521;
        b = (b + a) % 65_521;
    }
    z.extend_from_slice(&((b << 16) | a).to_be_bytes());
    let mut out = vec![0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A];
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &ihdr);
    chunk(&mut out, b"IDAT", &z);
    chunk(&mut out, b"IEND", &[]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_of_iend_is_the_known_constant() {
        assert_eq!(crc32(&[b"IEND"]), 0xAE42_6082);
    }

    #[test]
    fn png_has_signature_and_chunks() {
        let png = encode_png(2, 1, &[255, 0, 0, 0, 0, 255]);
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(&png[12..16], b"IHDR");
        assert_eq!(&png[png.len() - 8..png.len() - 4], b"IEND");
    }
}
