//! `frames.json`: every frame of a run, streamed frame-major as the run goes.
//!
//! ```text
//! {"format": "superhelix-frames", "version": 2,
//!  "layout": {"strands": [{"name": ..., "group": ..., "radius": ..., "points": P_i,
//!                          "coordinates": C_i}, ...],
//!             "output_fps": ..., "planned_frames": ...},
//!  "frames": [
//!   {"index": 0, "time": ..., "state_time": ..., "points": [[x, y, z], ...], "q": [...]},
//!   ...
//!  ]}
//! ```
//!
//! All SI. `layout.strands` lists the strands in scene order: `group` is the patch name
//! for strands of a `[[patches]]` entry and the `group` field (default: the strand's own
//! name) for a `[[strands]]` entry; `radius` is the display radius (m, the mean semi-axis
//! of the cross-section); `points` = 1 + samples_per_element · N centreline points and
//! `coordinates` = 3N generalized coordinates per frame. Frame k has `index` k
//! (consecutive from 0), the nominal `time` k / output_fps, the simulated time of the
//! state written (`state_time`), every strand's centreline in world coordinates (m),
//! concatenated in strand order (root first, then `samples_per_element` points per
//! element), and every strand's generalized coordinates (τ, κ1, κ2 per element, rad/m),
//! concatenated the same way. `planned_frames` is the number of frames of a complete
//! run; a run that stops early (interrupted, diverged) writes fewer and still closes the
//! file. Static mode writes one frame at time 0. No non-finite number is ever written.
//! A run with a tolerance gives every frame an `"error_control"` object: what the
//! error-controlled step did since the previous frame (`largest_error` over L, `steps`,
//! `rejected`, `smallest_step` and `largest_step` in s; all 0 for frame 0).
//! A scene with held tips (`[strands.ends.tip]`) lists them in `layout.held_tips` and
//! gives every frame a `"held"` list, one entry per held tip: `strand` (its index),
//! `drift` (the largest distance of the tip from its holder after any step since the
//! previous frame, over L for positions and in radians for frames) and `reaction` (the
//! holder's force on the tip, N, then its torque, N·m, world coordinates).
//!
//! The file is written as `frames.json.partial`, one frame per line, flushed after each
//! frame, and renamed to `frames.json` when the run finishes or stops: a previous
//! `frames.json` is replaced only by a complete, readable file. [`JsonFrameStore`] reads
//! both, and also a file cut off by a hard kill (it keeps the complete frames).

use super::frames::{FrameLayout, FrameSink, FrameStore, FrameView};
use super::{FrameSteps, HeldEndFrame};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// Value of the `format` field.
pub const FORMAT: &str = "superhelix-frames";
/// Value of the `version` field.
pub const VERSION: u64 = 2;
/// Suffix of the file streamed to before the rename.
pub const PARTIAL_SUFFIX: &str = ".partial";

/// One frame as written.
#[derive(Serialize)]
struct FrameOut<'a> {
    index: usize,
    time: f64,
    state_time: f64,
    points: &'a [[f64; 3]],
    q: &'a [f64],
    #[serde(skip_serializing_if = "Option::is_none")]
    error_control: Option<FrameSteps>,
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    held: &'a [HeldEndFrame],
}

/// One frame as read back.
#[derive(Debug, Clone, Deserialize)]
struct FrameIn {
    index: usize,
    time: f64,
    state_time: f64,
    points: Vec<[f64; 3]>,
    q: Vec<f64>,
    #[serde(default)]
    error_control: Option<FrameSteps>,
    #[serde(default)]
    held: Vec<HeldEndFrame>,
}

/// The streamed `frames.json` writer (see the module documentation).
pub struct JsonFrameSink {
    path: PathBuf,
    partial: PathBuf,
    writer: Option<BufWriter<File>>,
    frames: usize,
}

impl JsonFrameSink {
    /// Start `path` (streamed to `path.partial` until [`FrameSink::finish`]) and write
    /// the header with `layout`.
    pub fn create(path: &Path, layout: &FrameLayout) -> Result<Self> {
        let mut partial = path.as_os_str().to_owned();
        partial.push(PARTIAL_SUFFIX);
        let partial = PathBuf::from(partial);
        let file = File::create(&partial).map_err(|e| io_error(&partial, e))?;
        let mut writer = BufWriter::new(file);
        let header = serde_json::to_string(layout).map_err(|e| io_error(&partial, e.into()))?;
        write!(
            writer,
            "{{\"format\":\"{FORMAT}\",\"version\":{VERSION},\"layout\":{header},\"frames\":["
        )
        .and_then(|()| writer.flush())
        .map_err(|e| io_error(&partial, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            partial,
            writer: Some(writer),
            frames: 0,
        })
    }

    /// Go on writing `path` after a checkpoint: the file (`path.partial`, or `path` when the
    /// run that wrote it finished) is cut back to where `mark` ([`FrameSink::mark`]) says
    /// it ended, and the next frame follows.
    pub fn resume(path: &Path, mark: &[u64]) -> Result<Self> {
        let mut partial = path.as_os_str().to_owned();
        partial.push(PARTIAL_SUFFIX);
        let partial = PathBuf::from(partial);
        let &[bytes, frames] = mark else {
            return Err(resume_error(
                &partial,
                "the checkpoint does not say where it ended",
            ));
        };
        if !partial.exists() {
            // (a finished file: its closing bracket goes with the cut)
            std::fs::rename(path, &partial).map_err(|e| io_error(path, e))?;
        }
        let mut file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&partial)
            .map_err(|e| io_error(&partial, e))?;
        let len = file.metadata().map_err(|e| io_error(&partial, e))?.len();
        if len < bytes {
            return Err(resume_error(
                &partial,
                &format!("{len} bytes, the checkpoint's frames end at byte {bytes}"),
            ));
        }
        file.set_len(bytes)
            .and_then(|()| file.seek(SeekFrom::Start(bytes)).map(|_| ()))
            .map_err(|e| io_error(&partial, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            partial,
            writer: Some(BufWriter::new(file)),
            frames: frames as usize,
        })
    }

    /// The final path (`frames.json`).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The path written to until the file is finished.
    pub fn partial_path(&self) -> &Path {
        &self.partial
    }
}

impl FrameSink for JsonFrameSink {
    fn write_frame(&mut self, frame: &FrameView<'_>) -> Result<()> {
        let Some(writer) = self.writer.as_mut() else {
            return Err(Error::invalid(
                "frames.json",
                "a frame was written after the file was finished",
            ));
        };
        let out = FrameOut {
            index: frame.index,
            time: frame.time,
            state_time: frame.state_time,
            points: frame.points,
            q: frame.q,
            error_control: frame.steps,
            held: frame.held,
        };
        let separator: &[u8] = if self.frames == 0 { b"\n" } else { b",\n" };
        let result = writer
            .write_all(separator)
            .and_then(|()| serde_json::to_writer(&mut *writer, &out).map_err(Into::into))
            .and_then(|()| writer.flush());
        result.map_err(|e| io_error(&self.partial, e))?;
        self.frames += 1;
        Ok(())
    }

    fn mark(&mut self) -> Result<Vec<u64>> {
        let Some(writer) = self.writer.as_mut() else {
            return Err(Error::invalid(
                "frames.json",
                "a checkpoint was asked after the file was finished",
            ));
        };
        writer.flush().map_err(|e| io_error(&self.partial, e))?;
        let file = writer.get_mut();
        let at = file
            .sync_data()
            .and_then(|()| file.stream_position())
            .map_err(|e| io_error(&self.partial, e))?;
        Ok(vec![at, self.frames as u64])
    }

    fn finish(&mut self) -> Result<()> {
        let Some(mut writer) = self.writer.take() else {
            return Ok(());
        };
        writer
            .write_all(b"\n]}\n")
            .and_then(|()| writer.flush())
            .map_err(|e| io_error(&self.partial, e))?;
        let file = writer
            .into_inner()
            .map_err(|e| io_error(&self.partial, e.into_error()))?;
        file.sync_all().map_err(|e| io_error(&self.partial, e))?;
        drop(file);
        std::fs::rename(&self.partial, &self.path).map_err(|e| io_error(&self.path, e))
    }
}

/// A frame file that cannot be resumed, naming it and why.
pub(crate) fn resume_error(path: &Path, why: &str) -> Error {
    Error::invalid(
        "--resume",
        format!(
            "{} does not hold the frames its checkpoint names ({why}): remove checkpoint.bin to start again from t = 0",
            path.display()
        ),
    )
}

/// Frames read back from a `frames.json` (or a `frames.json.partial`, or a file cut off
/// mid-frame: the complete frames are read).
#[derive(Debug, Clone)]
pub struct JsonFrameStore {
    layout: FrameLayout,
    frames: Vec<FrameIn>,
    complete: bool,
}

impl JsonFrameStore {
    /// Read `path`.
    pub fn open(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).map_err(|e| io_error(path, e))?;
        Self::from_bytes(&bytes).map_err(|message| {
            io_error(
                path,
                std::io::Error::new(std::io::ErrorKind::InvalidData, message),
            )
        })
    }

    /// Read a `frames.json` held in memory; the error says what is wrong and where.
    pub fn from_bytes(bytes: &[u8]) -> std::result::Result<Self, String> {
        let mut parser = Parser { bytes, pos: 0 };
        parser.expect(b'{')?;
        let mut format = None;
        let mut version = None;
        let mut layout: Option<FrameLayout> = None;
        let mut frames = Vec::new();
        let mut complete = false;
        loop {
            match parser.peek() {
                Some(b'}') => break,
                None => break,
                _ => {}
            }
            let key: String = parser.value()?;
            parser.expect(b':')?;
            match key.as_str() {
                "format" => format = Some(parser.value::<String>()?),
                "version" => version = Some(parser.value::<u64>()?),
                "layout" => layout = Some(parser.value()?),
                "frames" => {
                    let layout = layout
                        .as_ref()
                        .ok_or("\"frames\" comes before \"layout\"")?;
                    complete = parser.frames(layout, &mut frames)?;
                    if !complete {
                        break;
                    }
                }
                _ => {
                    parser.value::<serde::de::IgnoredAny>()?;
                }
            }
            if parser.peek() == Some(b',') {
                parser.pos += 1;
            }
        }
        if format.as_deref() != Some(FORMAT) {
            return Err(format!(
                "not a {FORMAT} file (format = {format:?}, expected \"{FORMAT}\")"
            ));
        }
        if version != Some(VERSION) {
            return Err(format!(
                "version {version:?} of {FORMAT}, expected {VERSION}"
            ));
        }
        let layout = layout.ok_or("no \"layout\"")?;
        Ok(Self {
            layout,
            frames,
            complete,
        })
    }

    /// Whether the file was complete (its frame list closed): false for a file cut off
    /// by a hard kill.
    pub fn is_complete(&self) -> bool {
        self.complete
    }

    /// Simulated time of the state of frame k, s.
    pub fn state_time(&self, k: usize) -> f64 {
        self.frames.get(k).map_or(f64::NAN, |f| f.state_time)
    }

    /// Generalized coordinates of frame k (all strands), or `None` past the last frame.
    pub fn q(&self, k: usize) -> Option<&[f64]> {
        self.frames.get(k).map(|f| f.q.as_slice())
    }

    /// What the error-controlled step did before frame k (`None`: fixed steps, or no
    /// such frame).
    pub fn steps(&self, k: usize) -> Option<FrameSteps> {
        self.frames.get(k).and_then(|f| f.error_control)
    }

    /// The held-tip report of frame k (empty: none, or no such frame).
    pub fn held(&self, k: usize) -> &[HeldEndFrame] {
        self.frames.get(k).map_or(&[], |f| &f.held)
    }

    /// Points of frame k (all strands), or `None` past the last frame.
    pub fn frame_points(&self, k: usize) -> Option<&[[f64; 3]]> {
        self.frames.get(k).map(|f| f.points.as_slice())
    }
}

impl FrameStore for JsonFrameStore {
    fn layout(&self) -> &FrameLayout {
        &self.layout
    }

    fn frame_count(&self) -> usize {
        self.frames.len()
    }

    fn state_time(&self, k: usize) -> f64 {
        JsonFrameStore::state_time(self, k)
    }

    fn time(&self, k: usize) -> f64 {
        self.frames.get(k).map_or(f64::NAN, |f| f.time)
    }

    fn points(&mut self, k: usize, out: &mut Vec<[f64; 3]>) -> Result<()> {
        let points = self.frame_points(k).ok_or_else(|| {
            Error::invalid(
                "frame",
                format!(
                    "frame {k} does not exist: frames.json holds {}",
                    self.frames.len()
                ),
            )
        })?;
        out.clear();
        out.extend_from_slice(points);
        Ok(())
    }
}

/// A small reader of the top level of `frames.json` that parses one value at a time, so
/// that a file cut off inside the frame list still yields its complete frames.
struct Parser<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl Parser<'_> {
    fn peek(&mut self) -> Option<u8> {
        while let Some(&b) = self.bytes.get(self.pos) {
            if b.is_ascii_whitespace() {
                self.pos += 1;
            } else {
                return Some(b);
            }
        }
        None
    }

    fn expect(&mut self, byte: u8) -> std::result::Result<(), String> {
        match self.peek() {
            Some(b) if b == byte => {
                self.pos += 1;
                Ok(())
            }
            found => Err(format!(
                "expected '{}' at byte {}, found {}",
                byte as char,
                self.pos,
                found.map_or("the end of the file".to_string(), |b| format!(
                    "'{}'",
                    b as char
                ))
            )),
        }
    }

    /// The next value, or a parse error (EOF included).
    fn try_value<T: serde::de::DeserializeOwned>(
        &mut self,
    ) -> std::result::Result<T, serde_json::Error> {
        self.peek();
        let mut stream =
            serde_json::Deserializer::from_slice(&self.bytes[self.pos..]).into_iter::<T>();
        match stream.next() {
            Some(Ok(value)) => {
                self.pos += stream.byte_offset();
                Ok(value)
            }
            Some(Err(e)) => Err(e),
            None => Err(serde::de::Error::custom("EOF while parsing a value")),
        }
    }

    fn value<T: serde::de::DeserializeOwned>(&mut self) -> std::result::Result<T, String> {
        let at = self.pos;
        self.try_value().map_err(|e| format!("at byte {at}: {e}"))
    }

    /// The frame list; `Ok(false)` when the file ends inside it.
    fn frames(
        &mut self,
        layout: &FrameLayout,
        frames: &mut Vec<FrameIn>,
    ) -> std::result::Result<bool, String> {
        if self.peek().is_none() {
            return Ok(false);
        }
        self.expect(b'[')?;
        let (points, coordinates) = (layout.total_points(), layout.total_coordinates());
        loop {
            match self.peek() {
                None => return Ok(false),
                Some(b']') => {
                    self.pos += 1;
                    return Ok(true);
                }
                Some(b',') if !frames.is_empty() => self.pos += 1,
                _ => {}
            }
            if self.peek().is_none() {
                return Ok(false);
            }
            let at = self.pos;
            let frame: FrameIn = match self.try_value() {
                Ok(frame) => frame,
                Err(e) if e.is_eof() => return Ok(false),
                Err(e) => return Err(format!("frame {} at byte {at}: {e}", frames.len())),
            };
            let k = frames.len();
            if frame.index != k || frame.points.len() != points || frame.q.len() != coordinates {
                return Err(format!(
                    "frame {k} at byte {at} has index {}, {} points and {} coordinates; the layout says index {k}, {points} points and {coordinates} coordinates",
                    frame.index,
                    frame.points.len(),
                    frame.q.len()
                ));
            }
            frames.push(frame);
        }
    }
}

fn io_error(path: &Path, source: std::io::Error) -> Error {
    Error::Io {
        path: path.display().to_string(),
        source,
    }
}
