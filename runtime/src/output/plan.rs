//! The output plan: which files a run writes ([`Formats`]), an estimate of each one's
//! size, the limit on their total, and the checks of the output directory made before
//! the simulation starts.
//!
//! Format names (scene `[output] formats = [...]`, `run --format`): `json`
//! (`frames.json`), `npy` (`frames.npy`, `frames.times.npy`, `frames.index.json`),
//! `usda` (`hair.usda`), `png` (`preview.png`, `preview_first.png`), `gif`
//! (`preview.gif`), `obj` (`last_frame.obj`), and `preview` (= png + gif). The default
//! is `["json", "usda", "preview"]`, where json is replaced by npy when the planned
//! `frames.json` would exceed [`JSON_TO_NPY_BYTES`]. A plan whose total exceeds the
//! limit ([`DEFAULT_MAX_BYTES`], or `[output] max_bytes`) is refused unless the run
//! allows large output.

use super::driver::display_radius;
use super::frame_times;
use super::frames::{FrameLayout, StrandInfo};
use crate::config::SimulationSetup;
use crate::error::{Error, Result};
use std::fmt;
use std::path::{Path, PathBuf};

pub use crate::config::formats::{Formats, OutputSettings, FORMAT_NAMES};

/// Default limit on a run's planned output, bytes (2 GB).
pub const DEFAULT_MAX_BYTES: u64 = 2_000_000_000;
/// Under the default formats, a `frames.json` planned larger than this (64 MB) is
/// replaced by `frames.npy`.
pub const JSON_TO_NPY_BYTES: u64 = 64_000_000;

/// Bytes `frames.json` spends per number: a shortest round-trip f64 of metres or rad/m
/// (about 19 characters with sign, digits and exponent) plus its separator, and the
/// brackets of each point spread over its three coordinates. Measured on the demo scene
/// (2.70 MB for 127,368 numbers: 21.2 bytes each).
pub const JSON_BYTES_PER_NUMBER: f64 = 21.5;
/// Bytes of a frame's fixed fields in `frames.json` (index, times, keys).
const JSON_BYTES_PER_FRAME: u64 = 100;
/// Bytes of an npy header (the writer pads it to a fixed size).
const NPY_HEADER_BYTES: u64 = 128;
/// Bytes `hair.usda` spends per float (a coordinate and its separators; the demo scene's
/// file has 14).
const USDA_BYTES_PER_FLOAT: f64 = 14.0;
/// Estimated size of one preview PNG (1200 × 600; the demo scene's are 75–80 kB).
const PNG_BYTES: u64 = 100_000;
/// Estimated bytes per frame of the preview GIF (the demo scene's: 15 kB).
const GIF_BYTES_PER_FRAME: u64 = 20_000;
/// Most frames the preview GIF holds (longer runs are subsampled).
const GIF_MAX_FRAMES: u64 = 200;
/// Bytes of `last_frame.obj` per point: a vertex line and its share of the line records.
const OBJ_BYTES_PER_POINT: u64 = 48;

/// One file of the plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedFile {
    /// File name in the output directory.
    pub name: &'static str,
    /// Estimated size, bytes.
    pub bytes: u64,
}

/// The files a run will write and their estimated sizes.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputPlan {
    /// Output directory.
    pub dir: PathBuf,
    /// The formats written (after the json → npy replacement).
    pub formats: Formats,
    /// The files, with estimated sizes.
    pub files: Vec<PlannedFile>,
    /// Frames planned.
    pub frames: usize,
    /// Why the formats differ from those asked for (the json → npy replacement).
    pub note: Option<String>,
    /// The limit on the total, bytes (`None` when large output is allowed).
    pub limit: Option<u64>,
    /// Where the limit comes from and how to lift it, for the refusal.
    limit_source: &'static str,
    /// Frames between two checkpoints (0: none): the scene's `checkpoint_every`, or
    /// [`super::checkpoint::DEFAULT_CHECKPOINT_EVERY`] for a run of more than one frame
    /// that writes `frames.npy` or `frames.json`.
    pub checkpoint_every: usize,
    /// The scene asks for checkpoints of a run that keeps its frames in neither
    /// `frames.npy` nor `frames.json` (a resumed run would lose the frames before it).
    checkpoint_without_frames: bool,
}

impl OutputPlan {
    /// The plan for frames of `layout` written to `dir`: `formats` (from `run --format`)
    /// replaces the scene's `settings.formats`; with neither, the default formats, with
    /// json replaced by npy when `frames.json` would exceed [`JSON_TO_NPY_BYTES`].
    /// `allow_large` lifts the size limit.
    pub fn new(
        layout: &FrameLayout,
        settings: &OutputSettings,
        formats: Option<Formats>,
        allow_large: bool,
        dir: &Path,
    ) -> Self {
        let mut note = None;
        let formats = match formats.or(settings.formats) {
            Some(f) => f,
            None => {
                let json = json_bytes(layout);
                if json > JSON_TO_NPY_BYTES {
                    note = Some(format!(
                        "frames.json would be {}, more than {}: writing frames.npy instead (ask for json with --format or [output] formats)",
                        Bytes(json),
                        Bytes(JSON_TO_NPY_BYTES)
                    ));
                    Formats {
                        json: false,
                        npy: true,
                        ..Formats::DEFAULT
                    }
                } else {
                    Formats::DEFAULT
                }
            }
        };
        let (limit, limit_source) = if allow_large {
            (None, "")
        } else if let Some(max) = settings.max_bytes {
            (Some(max), "the scene's [output] max_bytes")
        } else {
            (Some(DEFAULT_MAX_BYTES), "the default limit")
        };
        let keeps_frames = formats.npy || formats.json;
        let checkpoint_every = match settings.checkpoint_every {
            Some(k) => k,
            None if keeps_frames && layout.planned_frames > 1 => {
                super::checkpoint::DEFAULT_CHECKPOINT_EVERY
            }
            None => 0,
        };
        Self {
            checkpoint_every: if keeps_frames { checkpoint_every } else { 0 },
            checkpoint_without_frames: checkpoint_every > 0 && !keeps_frames,
            dir: dir.to_path_buf(),
            formats,
            files: planned_files(
                layout,
                formats,
                settings.render.map(|r| r.strands),
                settings.nodes,
            ),
            frames: layout.planned_frames,
            note,
            limit,
            limit_source,
        }
    }

    /// Estimated total, bytes.
    pub fn total_bytes(&self) -> u64 {
        self.files.iter().map(|f| f.bytes).sum()
    }

    /// An error naming the estimate, the limit and how to lift it when the total is
    /// over the limit.
    pub fn check_limit(&self) -> Result<()> {
        if self.checkpoint_without_frames {
            return Err(Error::invalid(
                "output.checkpoint_every",
                format!(
                    "checkpoints go on from the frames in frames.npy or frames.json, and the formats ({}) have neither: add \"npy\" to the formats, or set checkpoint_every = 0",
                    self.formats.names().join(", ")
                ),
            ));
        }
        match self.limit {
            Some(limit) if self.total_bytes() > limit => Err(Error::invalid(
                "output",
                format!(
                    "the run would write about {} in {} ({}), more than {} of {}; raise [output] max_bytes in the scene (bytes) or pass run --allow-large-output, or write fewer frames (output_fps), points (samples_per_element) or formats",
                    Bytes(self.total_bytes()),
                    self.dir.display(),
                    self.file_list(),
                    self.limit_source,
                    Bytes(limit),
                ),
            )),
            _ => Ok(()),
        }
    }

    fn file_list(&self) -> String {
        self.files
            .iter()
            .map(|f| format!("{} {}", f.name, Bytes(f.bytes)))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl fmt::Display for OutputPlan {
    /// `output: 2.6 MB in out/ (frames.json 2.4 MB, hair.usda ...)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "output: {} in {} ({})",
            Bytes(self.total_bytes()),
            self.dir.display(),
            self.file_list()
        )
    }
}

/// A byte count in decimal units: `512 B`, `2.6 kB`, `2.6 MB`, `1.5 GB`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bytes(pub u64);

impl fmt::Display for Bytes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let b = self.0 as f64;
        if self.0 < 1000 {
            write!(f, "{} B", self.0)
        } else if b < 1e6 {
            write!(f, "{:.1} kB", b / 1e3)
        } else if b < 1e9 {
            write!(f, "{:.1} MB", b / 1e6)
        } else {
            write!(f, "{:.1} GB", b / 1e9)
        }
    }
}

/// The layout of the frames a run of `setup` writes, from the setup alone (no
/// simulation is built): the same as [`super::frame_layout`] of its simulation.
pub fn setup_layout(setup: &SimulationSetup) -> FrameLayout {
    let strands = setup
        .strands
        .iter()
        .map(|s| StrandInfo {
            name: s.strand.name.clone(),
            group: s.group.clone(),
            radius: display_radius(&s.strand.material),
            points: 1 + setup.samples_per_element * s.strand.geometry.elements(),
            coordinates: s.q0.len(),
        })
        .collect();
    FrameLayout {
        strands,
        output_fps: setup.config.output_fps,
        planned_frames: frame_times(&setup.config).len(),
        held_tips: (0..setup.strands.len())
            .filter(|&i| setup.strands[i].tip.is_some())
            .collect(),
    }
}

/// Estimated size of `frames.json`, bytes.
pub fn json_bytes(layout: &FrameLayout) -> u64 {
    let numbers = (3 * layout.total_points() + layout.total_coordinates()) as f64;
    let header = 64 + 120 * layout.strands.len() as u64;
    let frame = (numbers * JSON_BYTES_PER_NUMBER).ceil() as u64 + JSON_BYTES_PER_FRAME;
    header.saturating_add(frame.saturating_mul(layout.planned_frames as u64))
}

/// Bytes of `hair.usda` per render strand besides its points: its vertex count and its
/// colour.
const USDA_BYTES_PER_RENDER_STRAND: u64 = 40;

/// The files of `formats` for frames of `layout`, with `render` render strands (of as
/// many points as the longest guide) in `hair.usda` and none elsewhere.
fn planned_files(
    layout: &FrameLayout,
    formats: Formats,
    render: Option<usize>,
    nodes: Option<usize>,
) -> Vec<PlannedFile> {
    let frames = layout.planned_frames as u64;
    let points = layout.total_points() as u64;
    let mut files = Vec::new();
    if let Some(k) = nodes {
        let per_frame = 3 * 8 * layout.strands.len() as u64;
        files.push(PlannedFile {
            name: super::nodes::NODES_FILE,
            bytes: NPY_HEADER_BYTES + frames * per_frame * k as u64,
        });
        files.push(PlannedFile {
            name: super::nodes::D1_FILE,
            bytes: NPY_HEADER_BYTES + frames * per_frame * (k as u64).saturating_sub(1),
        });
    }
    if formats.json {
        files.push(PlannedFile {
            name: "frames.json",
            bytes: json_bytes(layout),
        });
    }
    if formats.npy {
        files.push(PlannedFile {
            name: "frames.npy",
            bytes: NPY_HEADER_BYTES + frames * points * 3 * 4,
        });
        files.push(PlannedFile {
            name: "frames.times.npy",
            bytes: NPY_HEADER_BYTES + frames * 2 * 8,
        });
        let index = serde_json::to_string(layout).map_or(0, |s| s.len() as u64);
        files.push(PlannedFile {
            name: "frames.index.json",
            bytes: index,
        });
    }
    if formats.usda {
        let render = render.unwrap_or(0) as u64;
        let render_points =
            render * layout.strands.iter().map(|s| s.points).max().unwrap_or(0) as u64;
        let floats = (frames * (points + render_points) * 3) as f64;
        let per_strand = 200 * layout.strands.len() as u64 + USDA_BYTES_PER_RENDER_STRAND * render;
        files.push(PlannedFile {
            name: "hair.usda",
            bytes: 1000 + per_strand + (floats * USDA_BYTES_PER_FLOAT).ceil() as u64,
        });
    }
    if formats.png {
        files.push(PlannedFile {
            name: "preview.png",
            bytes: PNG_BYTES,
        });
        files.push(PlannedFile {
            name: "preview_first.png",
            bytes: PNG_BYTES,
        });
    }
    if formats.gif {
        files.push(PlannedFile {
            name: "preview.gif",
            bytes: 1000 + GIF_BYTES_PER_FRAME * frames.min(GIF_MAX_FRAMES),
        });
    }
    if formats.obj {
        files.push(PlannedFile {
            name: "last_frame.obj",
            bytes: 100 + OBJ_BYTES_PER_POINT * points,
        });
    }
    files
}

/// Make sure `dir` can receive the run's files before anything is simulated: created
/// (with its parents) if missing; a path that is a file, or a directory where a file
/// cannot be created (probed by creating and removing one), is refused with the path.
pub fn prepare_out_dir(dir: &Path) -> Result<()> {
    let refuse = |why: String| Error::invalid("--out", why);
    if dir.exists() && !dir.is_dir() {
        return Err(refuse(format!(
            "{} is a file, expected a directory",
            dir.display()
        )));
    }
    std::fs::create_dir_all(dir).map_err(|e| {
        refuse(format!(
            "cannot create the directory {}: {e}",
            dir.display()
        ))
    })?;
    let probe = dir.join(format!(".superhelix-write-probe-{}", std::process::id()));
    std::fs::File::create(&probe).map_err(|e| {
        refuse(format!(
            "{} is not writable: cannot create a file in it: {e}",
            dir.display()
        ))
    })?;
    std::fs::remove_file(&probe).map_err(|e| {
        refuse(format!(
            "{} is not writable: cannot remove {}: {e}",
            dir.display(),
            probe.display()
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn render_strands_are_counted_in_the_stage_only() {
        let strand = |points| StrandInfo {
            name: "s".into(),
            group: "g".into(),
            radius: 5e-5,
            points,
            coordinates: 3,
        };
        let layout = FrameLayout {
            strands: vec![strand(41), strand(21)],
            output_fps: 30.0,
            planned_frames: 10,
            held_tips: Vec::new(),
        };
        let bytes = |render: Option<usize>| planned_files(&layout, Formats::DEFAULT, render, None);
        let (plain, rendered) = (bytes(None), bytes(Some(1000)));
        let usda = |files: &[PlannedFile]| {
            files
                .iter()
                .find(|f| f.name == "hair.usda")
                .map(|f| f.bytes)
        };
        // 1000 strands of the longest guide's 41 points, 10 frames, 3 floats of 14 bytes
        let extra = 10 * 1000 * 41 * 3 * 14 + 1000 * USDA_BYTES_PER_RENDER_STRAND;
        assert_eq!(usda(&rendered), usda(&plain).map(|b| b + extra));
        let others = |files: &[PlannedFile]| -> Vec<PlannedFile> {
            files
                .iter()
                .filter(|f| f.name != "hair.usda")
                .cloned()
                .collect()
        };
        assert_eq!(others(&plain), others(&rendered));
    }
}
