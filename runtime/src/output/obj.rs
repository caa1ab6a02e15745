//! `last_frame.obj`: the last frame's centrelines as Wavefront OBJ polylines.
//!
//! One object per strand: `o <strand name>`, its points `v x y z` (m, world coordinates,
//! Z up), then one line element `l i j k ...` through them (1-based indices counted over
//! the whole file). Written to a temporary file and renamed.

use super::atomic::write_atomically;
use super::frames::FrameStore;
use super::usd::format_f32;
use crate::error::{Error, Result};
use std::fmt::Write as _;
use std::path::Path;

/// Name of the OBJ file in the output directory.
pub const OBJ_FILE: &str = "last_frame.obj";

/// The OBJ text of frame `frame` of `store`.
pub fn obj_text(store: &mut dyn FrameStore, frame: usize) -> Result<String> {
    let mut points = Vec::new();
    store.points(frame, &mut points)?;
    let layout = store.layout();
    let offsets = layout.point_offsets();
    let mut text = String::new();
    let _ = writeln!(
        text,
        "# Super-Helix hair: frame {frame} (t = {} s), {} strands, metres, Z up",
        store.time(frame),
        layout.strands.len()
    );
    for (i, strand) in layout.strands.iter().enumerate() {
        // OBJ names end at the line: keep them on one line
        let name: String = strand
            .name
            .chars()
            .map(|c| if c.is_whitespace() { '_' } else { c })
            .collect();
        let _ = writeln!(text, "o {name}");
        let range = offsets[i]..offsets[i + 1];
        for p in points.get(range.clone()).unwrap_or(&[]) {
            let _ = writeln!(
                text,
                "v {} {} {}",
                format_f32(p[0] as f32),
                format_f32(p[1] as f32),
                format_f32(p[2] as f32)
            );
        }
        if range.len() >= 2 {
            text.push('l');
            for j in range {
                let _ = write!(text, " {}", j + 1);
            }
            text.push('\n');
        }
    }
    Ok(text)
}

/// Write the last frame of `store` as `path`.
pub fn write_obj(path: &Path, store: &mut dyn FrameStore) -> Result<()> {
    let frames = store.frame_count();
    if frames == 0 {
        return Err(Error::invalid(
            "frames",
            "no frame to write: the run wrote none",
        ));
    }
    let text = obj_text(store, frames - 1)?;
    write_atomically(path, text.as_bytes())
}
