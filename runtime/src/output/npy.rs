//! `frames.npy`, `frames.times.npy` and `frames.index.json`: the compact binary frames for
//! large scenes, readable by numpy without custom code.
//!
//! - `frames.npy`: float32, C order, shape `[frames, points, 3]`: every strand's
//!   centreline (world coordinates, m) concatenated in strand order, as in
//!   [`FrameView::points`]. Strand `i` is `[:, offsets[i]:offsets[i + 1], :]` with the
//!   offsets of [`FrameLayout::point_offsets`].
//! - `frames.times.npy`: float64, shape `[frames, 2]`: nominal time `k / output_fps` and
//!   simulated time of the state written, s.
//! - `frames.index.json`: the [`FrameLayout`] (strand names, groups, display radii, points
//!   and coordinates per strand, output fps, planned frames), written at the start.
//! - `frames.steps.npy` (scenes with a tolerance only): float64, shape `[frames, 5]`, what
//!   the error-controlled step did since the previous frame ([`super::FrameSteps`]): the
//!   largest estimated error over L, steps accepted, steps rejected, the smallest and the
//!   largest step (s); all 0 for frame 0. The index then names the file and its columns
//!   (`"error_control": {"file": "frames.steps.npy", "columns": [...], "strands_file":
//!   "strand_steps.npy", "strands_columns": [...]}`), rewritten once at the first frame.
//! - `frames.held.npy` (scenes with held tips, `[strands.ends.tip]`, only): float64, shape
//!   `[frames, held tips, 7]`, one row per strand of the layout's `held_tips`
//!   ([`super::HeldEndFrame`]): the largest drift of the tip from its holder after any
//!   step since the previous frame (over L for positions, radians for frames), then the
//!   holder's reaction on the tip at the frame's state: force (N) and torque (N·m), world
//!   coordinates. The index names the file and its columns (`"held_ends": {"file":
//!   "frames.held.npy", "columns": [...]}`).
//! - `strand_steps.npy` (scenes with a tolerance only, whatever the formats): float64,
//!   shape `[strands, 5]`, what the error-controlled step did for each strand over the
//!   run ([`super::StrandSteps`]): steps accepted, steps rejected, the largest estimated
//!   error over L, the smallest and the largest step (s). Written when the run ends
//!   (also when it stops early), by [`write_strand_steps`].
//!
//! ```python
//! import json, numpy as np
//! points = np.load("out/frames.npy")          # [frames, points, 3]
//! index = json.load(open("out/frames.index.json"))
//! ```
//!
//! Both `.npy` files use format version 1.0 of `numpy.lib.format`: the magic `\x93NUMPY`,
//! the version bytes `1 0`, a little-endian u16 header length, and a Python dict literal
//! `{'descr': ..., 'fortran_order': False, 'shape': (...), }` padded with spaces and ended
//! by `\n` so that the data starts at a multiple of 64 bytes. After every frame the data
//! is appended and then the header is rewritten in place with the new frame count; the
//! header is padded for the largest count, so it never moves. A run that is killed
//! therefore leaves files numpy opens with exactly the frames whose header was written
//! (numpy ignores trailing bytes of a partly written frame).
//!
//! The format is written by hand: the npy crates (`npyz`, `ndarray-npy`) write the
//! shape once, either before the data or when the writer is finished, so a run stopped
//! in between would leave a header that does not match the data. Reading back handles
//! only what this module writes (little-endian float32 `[n, points, 3]` and float64
//! `[n, 2]`), a few dozen lines.

use super::atomic::{io_error, write_atomically};
use super::frames::{FrameLayout, FrameSink, FrameStore, FrameView};
use crate::error::{Error, Result};
pub use crate::input::npy::read_f64;
use crate::input::npy::{bad_file, read_header, rows_present, MAGIC, PREAMBLE};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// Name of the points file.
pub const NPY_FILE: &str = "frames.npy";
/// Name of the times file.
pub const TIMES_FILE: &str = "frames.times.npy";
/// Name of the layout file.
pub const INDEX_FILE: &str = "frames.index.json";
/// Name of the per-frame report of the error-controlled step (scenes with a tolerance).
pub const STEPS_FILE: &str = "frames.steps.npy";
/// Columns of [`STEPS_FILE`], as named in the index.
pub const STEPS_COLUMNS: [&str; 5] = [
    "largest_error",
    "steps",
    "rejected",
    "smallest_step",
    "largest_step",
];

/// Name of the per-frame report of the held tips (scenes with `[strands.ends.tip]`).
pub const HELD_FILE: &str = "frames.held.npy";
/// Columns of [`HELD_FILE`], as named in the index.
pub const HELD_COLUMNS: [&str; 7] = ["drift", "fx", "fy", "fz", "tx", "ty", "tz"];

/// Name of the per-strand report of the error-controlled step (scenes with a tolerance).
pub const STRAND_STEPS_FILE: &str = "strand_steps.npy";
/// Columns of [`STRAND_STEPS_FILE`], as named in the index.
pub const STRAND_STEPS_COLUMNS: [&str; 5] = [
    "steps",
    "rejected",
    "largest_error",
    "smallest_step",
    "largest_step",
];

/// Write [`STRAND_STEPS_FILE`] into `dir` (atomically): one row per strand, the columns of
/// [`STRAND_STEPS_COLUMNS`]. Returns its path.
pub fn write_strand_steps(dir: &Path, rows: &[super::StrandSteps]) -> Result<PathBuf> {
    let path = dir.join(STRAND_STEPS_FILE);
    let shape = [rows.len() as u64, 5];
    let mut bytes = header_bytes("<f8", &shape, header_len_for("<f8", &[5]));
    for r in rows {
        for x in [
            r.steps as f64,
            r.rejected as f64,
            r.largest_error,
            r.smallest_step,
            r.largest_step,
        ] {
            bytes.extend_from_slice(&x.to_le_bytes());
        }
    }
    write_atomically(&path, &bytes)?;
    Ok(path)
}

/// Write a whole little-endian float64 array of `rows` rows of shape `tail` to `path`
/// (atomically), with the header a growing file of the same rows has: what
/// `superhelix merge` writes the per-strand files ([`super::nodes`], [`STRAND_STEPS_FILE`])
/// with.
pub fn write_f64_rows(path: &Path, tail: &[u64], rows: u64, values: &[f64]) -> Result<()> {
    let mut shape = vec![rows];
    shape.extend_from_slice(tail);
    let mut bytes = header_bytes("<f8", &shape, header_len_for("<f8", tail));
    for x in values {
        bytes.extend_from_slice(&x.to_le_bytes());
    }
    write_atomically(path, &bytes)
}

/// `frames.index.json`: the layout, where the per-frame step report is (runs with a
/// tolerance, from the first frame on) and where the held-end report is (scenes with held
/// tips).
#[derive(serde::Serialize)]
struct Index<'a> {
    #[serde(flatten)]
    layout: &'a FrameLayout,
    #[serde(skip_serializing_if = "Option::is_none")]
    error_control: Option<StepsIndex>,
    #[serde(skip_serializing_if = "Option::is_none")]
    held_ends: Option<HeldIndex>,
}

/// Where the per-frame step report is and what its columns are.
#[derive(serde::Serialize)]
struct StepsIndex {
    file: &'static str,
    columns: [&'static str; 5],
    strands_file: &'static str,
    strands_columns: [&'static str; 5],
}

/// Where the held-end report is and what its columns are.
#[derive(serde::Serialize)]
struct HeldIndex {
    file: &'static str,
    columns: [&'static str; 7],
}

/// Alignment of the data start required by the format.
const ALIGN: usize = 64;

/// The header dict of an array of type `descr` (`<f4`, `<f8`) and shape `shape`.
fn header_dict(descr: &str, shape: &[u64]) -> String {
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let tuple = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {tuple}, }}")
}

/// Total header length (preamble included) that holds `descr` with any row count and the
/// given trailing dimensions, rounded up to [`ALIGN`].
fn header_len_for(descr: &str, tail: &[u64]) -> usize {
    let mut widest = vec![u64::MAX];
    widest.extend_from_slice(tail);
    let needed = PREAMBLE + header_dict(descr, &widest).len() + 1;
    needed.div_ceil(ALIGN) * ALIGN
}

/// The full header (preamble, dict, space padding, `\n`) of length `total`.
fn header_bytes(descr: &str, shape: &[u64], total: usize) -> Vec<u8> {
    let dict = header_dict(descr, shape);
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&[1, 0]);
    // header_len_for keeps totals far below u16::MAX (a few hundred bytes)
    let len = (total - PREAMBLE) as u16;
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out.resize(total - 1, b' ');
    out.push(b'\n');
    out
}

/// One growing `.npy` file: the header is rewritten after every row.
pub(crate) struct GrowingNpy {
    file: File,
    path: PathBuf,
    descr: &'static str,
    tail: Vec<u64>,
    header_len: usize,
    row_bytes: u64,
    rows: u64,
}

impl GrowingNpy {
    pub(crate) fn create(
        path: PathBuf,
        descr: &'static str,
        item_bytes: u64,
        tail: Vec<u64>,
    ) -> Result<Self> {
        Self::open(path, descr, item_bytes, tail, None)
    }

    /// The file at `path`: created with no rows (`resume` `None`), or, as [`Self::create`]
    /// made it, gone on with after its first `resume` rows, what follows them cut away.
    pub(crate) fn open(
        path: PathBuf,
        descr: &'static str,
        item_bytes: u64,
        tail: Vec<u64>,
        resume: Option<u64>,
    ) -> Result<Self> {
        let file = match resume {
            None => File::create(&path),
            Some(_) => std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .open(&path),
        }
        .map_err(|e| io_error(&path, e))?;
        let header_len = header_len_for(descr, &tail);
        let row_bytes = item_bytes * tail.iter().product::<u64>();
        let rows = resume.unwrap_or(0);
        let end = header_len as u64 + rows * row_bytes;
        if resume.is_some() {
            let len = file.metadata().map_err(|e| io_error(&path, e))?.len();
            if len < end {
                return Err(super::json::resume_error(
                    &path,
                    &format!("{len} bytes, the checkpoint's {rows} rows end at byte {end}"),
                ));
            }
        }
        let mut npy = Self {
            file,
            path,
            descr,
            tail,
            header_len,
            row_bytes,
            rows,
        };
        // the header first: a kill between the two leaves a file longer than its header
        // says, which every reader reads
        npy.write_header()?;
        if resume.is_some() {
            npy.file.set_len(end).map_err(|e| io_error(&npy.path, e))?;
        }
        Ok(npy)
    }

    /// Rows written.
    pub(crate) fn rows(&self) -> u64 {
        self.rows
    }

    /// Sync every row written to disk.
    pub(crate) fn sync(&mut self) -> Result<()> {
        self.file.sync_data().map_err(|e| io_error(&self.path, e))
    }

    fn write_header(&mut self) -> Result<()> {
        let mut shape = vec![self.rows];
        shape.extend_from_slice(&self.tail);
        let bytes = header_bytes(self.descr, &shape, self.header_len);
        self.file
            .seek(SeekFrom::Start(0))
            .and_then(|_| self.file.write_all(&bytes))
            .map_err(|e| io_error(&self.path, e))
    }

    /// Append one row (exactly `row_bytes` long), then publish it in the header.
    pub(crate) fn append(&mut self, row: &[u8]) -> Result<()> {
        let at = self.header_len as u64 + self.rows * self.row_bytes;
        self.file
            .seek(SeekFrom::Start(at))
            .and_then(|_| self.file.write_all(row))
            .map_err(|e| io_error(&self.path, e))?;
        self.rows += 1;
        self.write_header()
    }

    pub(crate) fn finish(&mut self) -> Result<()> {
        self.file
            .flush()
            .and_then(|_| self.file.sync_all())
            .map_err(|e| io_error(&self.path, e))
    }
}

/// Writes `frames.npy`, `frames.times.npy` and `frames.index.json` as the run goes.
pub struct NpyFrameSink {
    points: GrowingNpy,
    times: GrowingNpy,
    /// The per-frame step report, created at the first frame that has one.
    steps: Option<GrowingNpy>,
    /// The per-frame held-end report (scenes with held tips).
    held: Option<GrowingNpy>,
    dir: PathBuf,
    layout: FrameLayout,
    total_points: usize,
    row: Vec<u8>,
}

impl NpyFrameSink {
    /// Create the three files in `dir` (created if needed): the index with `layout`, and
    /// both arrays with zero frames.
    pub fn create(dir: &Path, layout: &FrameLayout) -> Result<Self> {
        std::fs::create_dir_all(dir).map_err(|e| io_error(dir, e))?;
        Self::open(dir, layout, None)
    }

    /// Go on writing the files in `dir` after a checkpoint: each is cut back to the rows
    /// `mark` ([`FrameSink::mark`]) gives, and the next frame follows.
    pub fn resume(dir: &Path, layout: &FrameLayout, mark: &[u64]) -> Result<Self> {
        let &[frames, steps, held] = mark else {
            return Err(super::json::resume_error(
                &dir.join(NPY_FILE),
                "the checkpoint does not say where it ended",
            ));
        };
        Self::open(dir, layout, Some([frames, steps, held]))
    }

    /// The files, created (`rows` `None`) or cut back to `rows` (frames, step-report
    /// rows, held-report rows; a step report of no rows is created at its first frame).
    fn open(dir: &Path, layout: &FrameLayout, rows: Option<[u64; 3]>) -> Result<Self> {
        let file = |name: &str, descr, item, tail: Vec<u64>, k: usize| {
            GrowingNpy::open(dir.join(name), descr, item, tail, rows.map(|r| r[k]))
        };
        let total_points = layout.total_points();
        let points = file(NPY_FILE, "<f4", 4, vec![total_points as u64, 3], 0)?;
        let times = file(TIMES_FILE, "<f8", 8, vec![2], 0)?;
        let steps = match rows {
            Some([_, steps, _]) if steps > 0 => Some(file(STEPS_FILE, "<f8", 8, vec![5], 1)?),
            _ => None,
        };
        let held = if layout.held_tips.is_empty() {
            None
        } else {
            let shape = vec![layout.held_tips.len() as u64, HELD_COLUMNS.len() as u64];
            Some(file(HELD_FILE, "<f8", 8, shape, 2)?)
        };
        write_index(dir, layout, steps.is_some())?;
        Ok(Self {
            points,
            times,
            steps,
            held,
            dir: dir.to_path_buf(),
            layout: layout.clone(),
            total_points,
            row: Vec::with_capacity(12 * total_points),
        })
    }

    /// Create [`STEPS_FILE`] and name it in the index.
    fn start_steps(&mut self) -> Result<()> {
        let file = GrowingNpy::create(self.dir.join(STEPS_FILE), "<f8", 8, vec![5])?;
        write_index(&self.dir, &self.layout, true)?;
        self.steps = Some(file);
        Ok(())
    }

    /// Frames written so far.
    pub fn frames_written(&self) -> usize {
        self.points.rows as usize
    }
}

impl FrameSink for NpyFrameSink {
    fn write_frame(&mut self, frame: &FrameView<'_>) -> Result<()> {
        if frame.points.len() != self.total_points {
            return Err(Error::invalid(
                "frame.points",
                format!(
                    "frame {} has {} points, the layout has {}",
                    frame.index,
                    frame.points.len(),
                    self.total_points
                ),
            ));
        }
        self.row.clear();
        for p in frame.points {
            for &c in p {
                self.row.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
        let mut times = [0u8; 16];
        times[..8].copy_from_slice(&frame.time.to_le_bytes());
        times[8..].copy_from_slice(&frame.state_time.to_le_bytes());
        if let Some(s) = frame.steps {
            if self.steps.is_none() {
                self.start_steps()?;
            }
            let row = [
                s.largest_error,
                s.steps as f64,
                s.rejected as f64,
                s.smallest_step,
                s.largest_step,
            ];
            let bytes: Vec<u8> = row.iter().flat_map(|x| x.to_le_bytes()).collect();
            if let Some(file) = self.steps.as_mut() {
                file.append(&bytes)?;
            }
        }
        if let Some(file) = self.held.as_mut() {
            if frame.held.len() != self.layout.held_tips.len() {
                return Err(Error::invalid(
                    "frame.held",
                    format!(
                        "frame {} reports {} held tips, the layout has {}",
                        frame.index,
                        frame.held.len(),
                        self.layout.held_tips.len()
                    ),
                ));
            }
            let bytes: Vec<u8> = frame
                .held
                .iter()
                .flat_map(|h| std::iter::once(h.drift).chain(h.reaction))
                .flat_map(f64::to_le_bytes)
                .collect();
            file.append(&bytes)?;
        }
        // the times first: a frame counts once its points header is written
        self.times.append(&times)?;
        self.points.append(&self.row)
    }

    fn mark(&mut self) -> Result<Vec<u64>> {
        let mut rows = [self.points.rows(), 0, 0];
        for (k, file) in [self.steps.as_mut(), self.held.as_mut()]
            .into_iter()
            .enumerate()
        {
            if let Some(f) = file {
                f.sync()?;
                rows[k + 1] = f.rows();
            }
        }
        self.times.sync()?;
        self.points.sync()?;
        Ok(rows.to_vec())
    }

    fn finish(&mut self) -> Result<()> {
        if let Some(s) = self.steps.as_mut() {
            s.finish()?;
        }
        if let Some(s) = self.held.as_mut() {
            s.finish()?;
        }
        self.times.finish()?;
        self.points.finish()
    }
}

/// Write `frames.index.json` into `dir` (atomically): the layout, the held-end report's
/// file when the layout has held tips, the step report's when `steps`.
fn write_index(dir: &Path, layout: &FrameLayout, steps: bool) -> Result<()> {
    let index = dir.join(INDEX_FILE);
    let with = Index {
        layout,
        error_control: steps.then_some(StepsIndex {
            file: STEPS_FILE,
            columns: STEPS_COLUMNS,
            strands_file: STRAND_STEPS_FILE,
            strands_columns: STRAND_STEPS_COLUMNS,
        }),
        held_ends: (!layout.held_tips.is_empty()).then_some(HeldIndex {
            file: HELD_FILE,
            columns: HELD_COLUMNS,
        }),
    };
    let json = serde_json::to_vec_pretty(&with).map_err(|e| io_error(&index, e.into()))?;
    write_atomically(&index, &json)
}

/// Reads frames written by [`NpyFrameSink`] (or by a run that was stopped).
pub struct NpyFrameStore {
    layout: FrameLayout,
    file: File,
    path: PathBuf,
    data_start: u64,
    times: Vec<[f64; 2]>,
    frames: usize,
    buf: Vec<u8>,
}

impl NpyFrameStore {
    /// Open `frames.npy` (or the directory holding it) with its `frames.times.npy` and
    /// `frames.index.json`: a file `X.npy` goes with `X.times.npy` and `X.index.json`.
    /// The frames available are those all files hold whole.
    pub fn open(path: &Path) -> Result<Self> {
        let npy = if path.is_dir() {
            path.join(NPY_FILE)
        } else {
            path.to_path_buf()
        };
        let stem = npy
            .file_name()
            .and_then(|n| n.to_str())
            .and_then(|n| n.strip_suffix(".npy"))
            .ok_or_else(|| {
                bad_file(
                    &npy,
                    "expected a .npy file or a directory holding frames.npy",
                )
            })?
            .to_string();
        let times_path = npy.with_file_name(format!("{stem}.times.npy"));
        let index_path = npy.with_file_name(format!("{stem}.index.json"));

        let index = std::fs::read(&index_path).map_err(|e| io_error(&index_path, e))?;
        let layout: FrameLayout = serde_json::from_slice(&index)
            .map_err(|e| bad_file(&index_path, format!("not a frame index: {e}")))?;
        if !(layout.output_fps.is_finite() && layout.output_fps > 0.0) {
            return Err(bad_file(&index_path, "output_fps must be finite and > 0"));
        }
        let total_points = layout.total_points() as u64;

        let mut file = File::open(&npy).map_err(|e| io_error(&npy, e))?;
        let header = read_header(&mut file, &npy)?;
        if header.descr != "<f4" || header.fortran_order {
            return Err(bad_file(
                &npy,
                format!(
                    "expected little-endian float32 in C order ('<f4'), found '{}'",
                    header.descr
                ),
            ));
        }
        if header.shape.len() != 3 || header.shape[1] != total_points || header.shape[2] != 3 {
            return Err(bad_file(
                &npy,
                format!(
                    "shape {:?} does not match [frames, {total_points}, 3] of {}",
                    header.shape,
                    index_path.display()
                ),
            ));
        }
        let len = file.metadata().map_err(|e| io_error(&npy, e))?.len();
        let point_frames = rows_present(&header, len, 12 * total_points);

        let mut tfile = File::open(&times_path).map_err(|e| io_error(&times_path, e))?;
        let theader = read_header(&mut tfile, &times_path)?;
        if theader.descr != "<f8"
            || theader.fortran_order
            || theader.shape.len() != 2
            || theader.shape[1] != 2
        {
            return Err(bad_file(
                &times_path,
                "expected little-endian float64 of shape [frames, 2]",
            ));
        }
        let tlen = tfile
            .metadata()
            .map_err(|e| io_error(&times_path, e))?
            .len();
        let time_frames = rows_present(&theader, tlen, 16);
        let frames = point_frames.min(time_frames);
        let mut bytes = vec![0u8; 16 * frames];
        tfile
            .seek(SeekFrom::Start(theader.data_start))
            .and_then(|_| tfile.read_exact(&mut bytes))
            .map_err(|e| io_error(&times_path, e))?;
        let times = bytes
            .chunks_exact(16)
            .map(|c| {
                let mut a = [0u8; 8];
                let mut b = [0u8; 8];
                a.copy_from_slice(&c[..8]);
                b.copy_from_slice(&c[8..]);
                [f64::from_le_bytes(a), f64::from_le_bytes(b)]
            })
            .collect();
        Ok(Self {
            layout,
            file,
            path: npy,
            data_start: header.data_start,
            times,
            frames,
            buf: Vec::new(),
        })
    }

    /// Simulated time of the state written as frame k, s.
    pub fn state_time(&self, k: usize) -> f64 {
        self.times.get(k).map_or(f64::NAN, |t| t[1])
    }
}

impl FrameStore for NpyFrameStore {
    fn layout(&self) -> &FrameLayout {
        &self.layout
    }

    fn frame_count(&self) -> usize {
        self.frames
    }

    fn state_time(&self, k: usize) -> f64 {
        NpyFrameStore::state_time(self, k)
    }

    fn time(&self, k: usize) -> f64 {
        self.times
            .get(k)
            .map_or(k as f64 / self.layout.output_fps, |t| t[0])
    }

    fn points(&mut self, k: usize, out: &mut Vec<[f64; 3]>) -> Result<()> {
        if k >= self.frames {
            return Err(Error::invalid(
                "frame",
                format!(
                    "frame {k} does not exist: {} holds frames 0..{}",
                    self.path.display(),
                    self.frames
                ),
            ));
        }
        let n = self.layout.total_points();
        self.buf.resize(12 * n, 0);
        let at = self.data_start + (k * 12 * n) as u64;
        self.file
            .seek(SeekFrom::Start(at))
            .and_then(|_| self.file.read_exact(&mut self.buf))
            .map_err(|e| io_error(&self.path, e))?;
        out.clear();
        out.extend(self.buf.chunks_exact(12).map(|c| {
            let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]) as f64;
            [f(0), f(4), f(8)]
        }));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::frames::StrandInfo;

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("superhelix-npy-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    fn layout() -> FrameLayout {
        let strand = |name: &str, points| StrandInfo {
            name: name.into(),
            group: "g".into(),
            radius: 5e-5,
            points,
            coordinates: 3 * (points - 1) / 4,
        };
        FrameLayout {
            strands: vec![strand("a", 5), strand("b", 9)],
            output_fps: 30.0,
            planned_frames: 10,
            held_tips: Vec::new(),
        }
    }

    /// Frame k's points: distinct, non-representable in f32 exactly.
    fn frame_points(k: usize, n: usize) -> Vec<[f64; 3]> {
        (0..n)
            .map(|i| {
                let t = (k * 100 + i) as f64;
                [0.1 * t + 1.0 / 3.0, -0.01 * t, (t * 0.7).sin()]
            })
            .collect()
    }

    fn write(dir: &Path, frames: usize) -> NpyFrameSink {
        let layout = layout();
        let mut sink = match NpyFrameSink::create(dir, &layout) {
            Ok(s) => s,
            Err(e) => panic!("{e}"),
        };
        for k in 0..frames {
            let points = frame_points(k, layout.total_points());
            let view = FrameView {
                index: k,
                time: k as f64 / 30.0,
                state_time: k as f64 / 30.0 + 1e-3,
                points: &points,
                q: &[],
                steps: None,
                held: &[],
            };
            if let Err(e) = sink.write_frame(&view) {
                panic!("{e}");
            }
        }
        sink
    }

    fn header_of(path: &Path) -> crate::input::npy::NpyHeader {
        let mut f = File::open(path).unwrap_or_else(|e| panic!("{e}"));
        read_header(&mut f, path).unwrap_or_else(|e| panic!("{e}"))
    }

    fn open(dir: &Path) -> NpyFrameStore {
        NpyFrameStore::open(dir).unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn frames_round_trip_to_float32_precision() {
        let dir = scratch("round-trip");
        let mut sink = write(&dir, 4);
        sink.finish().unwrap_or_else(|e| panic!("{e}"));
        let mut store = open(&dir.join(NPY_FILE));
        assert_eq!(store.layout(), &layout());
        assert_eq!(store.frame_count(), 4);
        let mut out = Vec::new();
        for k in 0..4 {
            store.points(k, &mut out).unwrap_or_else(|e| panic!("{e}"));
            let expected = frame_points(k, 14);
            assert_eq!(out.len(), 14);
            for (p, e) in out.iter().zip(&expected) {
                for c in 0..3 {
                    // exactly the float32 nearest to the value written
                    assert_eq!(p[c], e[c] as f32 as f64, "frame {k}");
                }
            }
            assert_eq!(store.time(k), k as f64 / 30.0);
            assert_eq!(store.state_time(k), k as f64 / 30.0 + 1e-3);
        }
        assert!(store.points(4, &mut out).is_err());
    }

    #[test]
    fn the_header_holds_the_frame_count_after_every_frame() {
        for frames in [0, 1, 7] {
            let dir = scratch(&format!("count-{frames}"));
            let _sink = write(&dir, frames);
            // read while the sink is still open: as a killed run leaves it
            let h = header_of(&dir.join(NPY_FILE));
            assert_eq!(h.shape, vec![frames as u64, 14, 3]);
            assert_eq!(h.descr, "<f4");
            assert!(!h.fortran_order);
            let len = std::fs::metadata(dir.join(NPY_FILE))
                .map(|m| m.len())
                .unwrap_or(0);
            assert_eq!(len, h.data_start + (frames * 14 * 12) as u64);
            let t = header_of(&dir.join(TIMES_FILE));
            assert_eq!(t.shape, vec![frames as u64, 2]);
            assert_eq!(t.descr, "<f8");
            assert_eq!(open(&dir).frame_count(), frames);
        }
    }

    #[test]
    fn a_frame_cut_short_is_not_counted() {
        let dir = scratch("truncated");
        drop(write(&dir, 3));
        let path = dir.join(NPY_FILE);
        let start = header_of(&path).data_start;
        // two and a half frames of data, the header still claiming three
        let file = std::fs::OpenOptions::new()
            .write(true)
            .open(&path)
            .unwrap_or_else(|e| panic!("{e}"));
        file.set_len(start + (14 * 12 * 5 / 2) as u64)
            .unwrap_or_else(|e| panic!("{e}"));
        drop(file);
        let mut store = open(&dir);
        assert_eq!(store.frame_count(), 2);
        let mut out = Vec::new();
        store.points(1, &mut out).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(out[13][0], frame_points(1, 14)[13][0] as f32 as f64);
        assert!(store.points(2, &mut out).is_err());
    }

    #[test]
    fn headers_follow_the_npy_format_1_0() {
        let dir = scratch("spec");
        drop(write(&dir, 2));
        for (name, descr, shape) in [
            (NPY_FILE, "<f4", "(2, 14, 3)"),
            (TIMES_FILE, "<f8", "(2, 2)"),
        ] {
            let bytes = std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(&bytes[..6], b"\x93NUMPY", "{name}: magic");
            assert_eq!(&bytes[6..8], &[1, 0], "{name}: version 1.0");
            let len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
            assert_eq!((10 + len) % 64, 0, "{name}: data aligned to 64 bytes");
            let header =
                std::str::from_utf8(&bytes[10..10 + len]).unwrap_or_else(|e| panic!("{e}"));
            assert!(header.is_ascii());
            assert!(header.ends_with('\n'), "{name}: header ends with a newline");
            assert_eq!(
                header.trim_end(),
                format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}"),
                "{name}: dict with the keys descr, fortran_order, shape"
            );
        }
    }

    #[test]
    fn a_frame_of_the_wrong_size_is_refused() {
        let dir = scratch("wrong-size");
        let mut sink = write(&dir, 1);
        let points = frame_points(1, 3);
        let view = FrameView {
            index: 1,
            time: 0.0,
            state_time: 0.0,
            points: &points,
            q: &[],
            steps: None,
            held: &[],
        };
        assert!(matches!(sink.write_frame(&view), Err(Error::Invalid(_))));
        assert_eq!(sink.frames_written(), 1);
    }

    #[test]
    fn a_file_that_is_not_npy_is_refused_with_its_path() {
        let dir = scratch("not-npy");
        drop(write(&dir, 1));
        std::fs::write(dir.join(NPY_FILE), b"hello").unwrap_or_else(|e| panic!("{e}"));
        match NpyFrameStore::open(&dir) {
            Err(e) => assert!(
                e.to_string().contains("frames.npy") && e.to_string().contains("not an .npy"),
                "{e}"
            ),
            Ok(_) => panic!("opened a file that is not npy"),
        }
    }
}
