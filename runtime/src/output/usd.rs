//! `hair.usda`: a USD stage (text format) that usdview, Blender and Houdini open.
//!
//! ```text
//! #usda 1.0
//! ( upAxis = "Z", metersPerUnit = 1, timeCodesPerSecond = output_fps, ... )
//! def Xform "hair"
//!     def BasisCurves "<group>"     one per strand group, linear, one curve per strand
//!         int[] curveVertexCounts   points per strand
//!         point3f[] points          time-sampled: time code t · output_fps (k for frame k
//!                                   unless the scene gives `[output] times`)
//!         float3[] extent           time-sampled bounding box of the group
//!         float[] widths            2 x the strand's display radius, per vertex
//!         color3f[] primvars:displayColor   the group's preview colour
//!     def BasisCurves "render"      with `[render]`: the render strands, linear
//!         int[] curveVertexCounts   points per render strand (the guides' most)
//!         point3f[] points          time-sampled
//!         float3[] extent           time-sampled
//!         float[] widths            one width for all (constant): 2 × the guides' mean
//!                                   display radius
//!         color3f[] primvars:displayColor   per curve (uniform): the colour of the
//!                                   render strand's dominant guide's group
//! ```
//!
//! Group names become valid, unique USD identifiers (`[A-Za-z_][A-Za-z0-9_]*`; other
//! characters become `_`, clashes get `_2`, `_3`, ...). Numbers are float32 written with
//! the shortest decimal that reads back to the same float32. The stage is streamed, one
//! frame of one group at a time, into a temporary file that is renamed when complete.

use super::atomic::AtomicFile;

/// Each frame's time code, `t · fps`, written as the frame index when the frame is at its
/// nominal `k / fps` (every run without `[output] times`), else as `t · fps` to 10⁻⁹
/// (round-off removed).
fn time_codes(store: &dyn FrameStore, fps: f64) -> Vec<String> {
    (0..store.frame_count())
        .map(|k| {
            let code = store.time(k) * fps;
            if (code - k as f64).abs() <= 1e-9 * (k as f64).max(1.0) {
                k.to_string()
            } else {
                format!("{}", (code * 1e9).round() / 1e9)
            }
        })
        .collect()
}
use super::frames::FrameStore;
use super::preview::group_colour;
use super::render_strands::RenderFrames;
use super::scenery::Scenery;
use crate::error::{Error, Result};
use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

/// Name of the USD file in the output directory.
pub const USDA_FILE: &str = "hair.usda";

/// `x` as the shortest decimal that reads back to the same float32.
pub fn format_f32(x: f32) -> String {
    let a = x.abs();
    if x == 0.0 {
        "0".to_string()
    } else if (1e-4..1e7).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Valid, unique USD prim names for `names`, in order.
pub fn prim_names(names: &[&str]) -> Vec<String> {
    let mut out: Vec<String> = Vec::with_capacity(names.len());
    for name in names {
        let mut id: String = name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '_' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        if !id.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_') {
            id.insert(0, '_');
        }
        let mut unique = id.clone();
        let mut n = 2;
        while out.contains(&unique) {
            unique = format!("{id}_{n}");
            n += 1;
        }
        out.push(unique);
    }
    out
}

fn vec3(out: &mut String, p: [f64; 3]) {
    let _ = write!(
        out,
        "({}, {}, {})",
        format_f32(p[0] as f32),
        format_f32(p[1] as f32),
        format_f32(p[2] as f32)
    );
}

/// Write every frame of `store` as the USD stage `path` (see the module doc), with the
/// render strands of `render` (at the head poses of the scenery) as their own prim.
pub fn write_usda(
    path: &Path,
    store: &mut dyn FrameStore,
    render: Option<(&mut RenderFrames, &Scenery)>,
) -> Result<()> {
    let frames = store.frame_count();
    if frames == 0 {
        return Err(Error::invalid(
            "frames",
            "no frame to write: the run wrote none",
        ));
    }
    let (file, mut w) = AtomicFile::create(path)?;
    let io = |e: std::io::Error| file.error(e);
    let layout = store.layout().clone();
    let fps = layout.output_fps;
    let codes = time_codes(&*store, fps);
    let offsets = layout.point_offsets();
    let groups = layout.groups();
    let mut all_names = groups.clone();
    all_names.push("render");
    let mut names = prim_names(&all_names);
    let render_name = names.pop().unwrap_or_default();

    let mut text = String::new();
    let _ = write!(
        text,
        "#usda 1.0\n(\n    defaultPrim = \"hair\"\n    doc = \"Super-Helix hair: {} strands, {} frames\"\n    endTimeCode = {}\n    framesPerSecond = {fps}\n    metersPerUnit = 1\n    startTimeCode = 0\n    timeCodesPerSecond = {fps}\n    upAxis = \"Z\"\n)\n\ndef Xform \"hair\"\n{{\n",
        layout.strands.len(),
        frames,
        codes[frames - 1],
    );
    w.write_all(text.as_bytes()).map_err(io)?;

    let mut points = Vec::new();
    for (g, (group, prim)) in groups.iter().zip(&names).enumerate() {
        let members: Vec<usize> = (0..layout.strands.len())
            .filter(|&i| layout.strands[i].group == *group)
            .collect();
        text.clear();
        let counts: Vec<String> = members
            .iter()
            .map(|&i| layout.strands[i].points.to_string())
            .collect();
        let _ = write!(
            text,
            "    def BasisCurves \"{prim}\"\n    {{\n        uniform token type = \"linear\"\n        uniform token wrap = \"nonperiodic\"\n        int[] curveVertexCounts = [{}]\n        point3f[] points.timeSamples = {{\n",
            counts.join(", ")
        );
        w.write_all(text.as_bytes()).map_err(io)?;
        let mut extents = Vec::with_capacity(frames);
        for k in 0..frames {
            store.points(k, &mut points)?;
            text.clear();
            let _ = write!(text, "            {}: [", codes[k]);
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            let mut first = true;
            for &i in &members {
                for p in points.get(offsets[i]..offsets[i + 1]).unwrap_or(&[]) {
                    if !first {
                        text.push_str(", ");
                    }
                    first = false;
                    vec3(&mut text, *p);
                    for c in 0..3 {
                        let v = p[c] as f32 as f64;
                        lo[c] = lo[c].min(v);
                        hi[c] = hi[c].max(v);
                    }
                }
            }
            text.push_str("],\n");
            w.write_all(text.as_bytes()).map_err(io)?;
            extents.push((lo, hi));
        }
        text.clear();
        text.push_str("        }\n        float3[] extent.timeSamples = {\n");
        for (k, (lo, hi)) in extents.iter().enumerate() {
            let _ = write!(text, "            {}: [", codes[k]);
            vec3(&mut text, *lo);
            text.push_str(", ");
            vec3(&mut text, *hi);
            text.push_str("],\n");
        }
        text.push_str("        }\n        float[] widths = [");
        let mut first = true;
        for &i in &members {
            let width = format_f32((2.0 * layout.strands[i].radius) as f32);
            for _ in 0..layout.strands[i].points {
                if !first {
                    text.push_str(", ");
                }
                first = false;
                text.push_str(&width);
            }
        }
        let [r, gr, b] = group_colour(g);
        let _ = write!(
            text,
            "] (\n            interpolation = \"vertex\"\n        )\n        color3f[] primvars:displayColor = [({}, {}, {})] (\n            interpolation = \"constant\"\n        )\n    }}\n",
            format_f32(r as f32 / 255.0),
            format_f32(gr as f32 / 255.0),
            format_f32(b as f32 / 255.0)
        );
        if g + 1 < groups.len() || render.is_some() {
            text.push('\n');
        }
        w.write_all(text.as_bytes()).map_err(io)?;
    }
    if let Some((render, scenery)) = render {
        write_render_prim(&mut w, &io, &render_name, store, render, scenery, &codes)?;
    }
    w.write_all(b"}\n").map_err(io)?;
    file.commit(w)
}

/// The `BasisCurves` prim `name` of the render strands, every frame.
fn write_render_prim<W: Write>(
    w: &mut W,
    io: &dyn Fn(std::io::Error) -> Error,
    name: &str,
    store: &mut dyn FrameStore,
    render: &mut RenderFrames,
    scenery: &Scenery,
    codes: &[String],
) -> Result<()> {
    let frames = store.frame_count();
    let (count, m) = (render.strand_count(), render.points_per_strand());
    let mut text = String::new();
    let _ = write!(
        text,
        "    def BasisCurves \"{name}\"\n    {{\n        uniform token type = \"linear\"\n        uniform token wrap = \"nonperiodic\"\n        int[] curveVertexCounts = ["
    );
    for i in 0..count {
        if i > 0 {
            text.push_str(", ");
        }
        let _ = write!(text, "{m}");
    }
    text.push_str("]\n        point3f[] points.timeSamples = {\n");
    w.write_all(text.as_bytes()).map_err(io)?;
    let mut extents = Vec::with_capacity(frames);
    for k in 0..frames {
        let points = render.frame(store, k, scenery)?;
        text.clear();
        let _ = write!(text, "            {}: [", codes[k]);
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for (n, p) in points.iter().enumerate() {
            if n > 0 {
                text.push_str(", ");
            }
            let _ = write!(
                text,
                "({}, {}, {})",
                format_f32(p[0]),
                format_f32(p[1]),
                format_f32(p[2])
            );
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
            if text.len() > 1 << 20 {
                w.write_all(text.as_bytes()).map_err(io)?;
                text.clear();
            }
        }
        text.push_str("],\n");
        w.write_all(text.as_bytes()).map_err(io)?;
        extents.push((lo.map(f64::from), hi.map(f64::from)));
    }
    text.clear();
    text.push_str("        }\n        float3[] extent.timeSamples = {\n");
    for (k, (lo, hi)) in extents.iter().enumerate() {
        let _ = write!(text, "            {}: [", codes[k]);
        vec3(&mut text, *lo);
        text.push_str(", ");
        vec3(&mut text, *hi);
        text.push_str("],\n");
    }
    let _ = write!(
        text,
        "        }}\n        float[] widths = [{}] (\n            interpolation = \"constant\"\n        )\n        color3f[] primvars:displayColor = [",
        format_f32(render.width() as f32)
    );
    for (i, &g) in render.groups().iter().enumerate() {
        if i > 0 {
            text.push_str(", ");
        }
        let [r, gr, b] = group_colour(g as usize);
        let _ = write!(
            text,
            "({}, {}, {})",
            format_f32(r as f32 / 255.0),
            format_f32(gr as f32 / 255.0),
            format_f32(b as f32 / 255.0)
        );
    }
    text.push_str("] (\n            interpolation = \"uniform\"\n        )\n    }\n");
    w.write_all(text.as_bytes()).map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_read_back_exactly() {
        for x in [
            0.0f32,
            1.0,
            -0.1,
            1.0 / 3.0,
            3.4e-18,
            -2.5e-5,
            1e-4,
            123456.79,
            3.0e9,
        ] {
            let s = format_f32(x);
            assert_eq!(s.parse::<f32>().ok(), Some(x), "{s}");
        }
        assert_eq!(format_f32(-0.1), "-0.1");
        assert_eq!(format_f32(2.5e-5), "2.5e-5");
    }

    #[test]
    fn prim_names_are_valid_and_unique() {
        assert_eq!(
            prim_names(&["smooth", "2nd", "a b", "a-b", "a_b", ""]),
            ["smooth", "_2nd", "a_b", "a_b_2", "a_b_3", "_"]
        );
    }
}
