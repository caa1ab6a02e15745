//! Outputs: the `frames.json` file and the driver that runs a simulation to it.
//!
//! `frames.json` is `{ "frame_times": [...], "state_times": [...], "strands": [ { "name":
//! ..., "points": [frame][point][3], "q": [frame][3N] } ] }`, all SI: `frame_times[k] =
//! k / output_fps` for `k = 0..=floor(duration · output_fps)`; `state_times[k]` is the
//! simulated time of the state written as frame k; `points` are world coordinates in
//! metres, root first, then `samples_per_element` points per element; `q` are the
//! generalized coordinates (τ, κ1, κ2 per element, rad/m). Static mode writes one frame
//! at time 0. No non-finite number is ever written.
//!
//! The driver ([`run_to_frames`]) reaches the simulation only through [`FrameSource`].

use crate::error::{Error, Result};
use crate::simulation::{Mode, SimulationConfig};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;
use std::time::{Duration, Instant};

pub mod frames;
pub mod npy;
pub mod obj;
pub mod plan;
pub mod preview;
pub mod products;
pub mod usd;

/// What the driver needs of a running simulation. Strand indices run over
/// `0..strand_count()`.
pub trait FrameSource {
    /// Current simulated time, seconds (0 before the first step).
    fn time(&self) -> f64;
    /// Number of strands.
    fn strand_count(&self) -> usize;
    /// Name of strand `i`.
    fn strand_name(&self, i: usize) -> &str;
    /// Generalized coordinates of strand `i` (3N).
    fn q(&self, i: usize) -> &[f64];
    /// Generalized velocities q̇ of strand `i` (3N).
    fn v(&self, i: usize) -> &[f64];
    /// Centreline of strand `i` in world coordinates at the current time: the root, then
    /// `samples_per_element` points per element (the last one at the element's end).
    fn centreline_world(&mut self, i: usize, samples_per_element: usize) -> Vec<[f64; 3]>;
    /// Advance by one time step.
    fn step(&mut self) -> Result<()>;
    /// Replace the state by the static equilibrium.
    fn solve_static(&mut self) -> Result<()>;
}

/// The contents of `frames.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Frames {
    /// Nominal frame times `k / output_fps`, seconds.
    pub frame_times: Vec<f64>,
    /// Simulated time of the state written for each frame, seconds.
    pub state_times: Vec<f64>,
    /// One entry per strand, in scene order.
    pub strands: Vec<StrandFrames>,
}

/// One strand's frames.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StrandFrames {
    /// Strand name.
    pub name: String,
    /// `points[frame][point]`: centreline in world coordinates, metres, root first.
    pub points: Vec<Vec<[f64; 3]>>,
    /// `q[frame]`: generalized coordinates (3N), rad/m.
    pub q: Vec<Vec<f64>>,
}

/// What a run did, for the one-line report.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSummary {
    /// Dynamic or static.
    pub mode: Mode,
    /// Time steps taken (0 in static mode).
    pub steps: usize,
    /// Number of strands.
    pub strands: usize,
    /// Frames written.
    pub frames: usize,
    /// Wall-clock time of the run (without writing the file).
    pub wall_time: Duration,
    /// Largest Euclidean norm of a strand's q̇ over all strands and steps, rad/(m·s).
    pub max_speed: f64,
}

impl RunSummary {
    /// Strand-steps per wall-clock second (0 when nothing was stepped).
    pub fn strand_steps_per_second(&self) -> f64 {
        let secs = self.wall_time.as_secs_f64();
        if secs > 0.0 {
            (self.steps * self.strands) as f64 / secs
        } else {
            0.0
        }
    }
}

impl fmt::Display for RunSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let wall = self.wall_time.as_secs_f64();
        match self.mode {
            Mode::Static => write!(f, "static: {} strands solved in {wall:.3} s", self.strands),
            Mode::Dynamic => write!(
                f,
                "{} steps x {} strands in {wall:.3} s: {:.0} strand-steps/s, max |q̇| = {:.4e} rad/(m s), {} frames",
                self.steps,
                self.strands,
                self.strand_steps_per_second(),
                self.max_speed,
                self.frames
            ),
        }
    }
}

/// Number of time steps of a dynamic run: `ceil(duration / dt)` (up to rounding of the
/// ratio), so that the last state is at or after `duration`. 0 in static mode.
pub fn total_steps(config: &SimulationConfig) -> usize {
    let ratio = config.duration / config.dt;
    if config.mode == Mode::Static || !ratio.is_finite() || ratio <= 0.0 {
        return 0;
    }
    (ratio - 1e-9 * ratio.max(1.0)).ceil().max(0.0) as usize
}

/// Nominal frame times `k / output_fps` for `k = 0..=floor(duration · output_fps)`;
/// `[0]` in static mode.
pub fn frame_times(config: &SimulationConfig) -> Vec<f64> {
    let product = config.duration * config.output_fps;
    if config.mode == Mode::Static || !product.is_finite() || product <= 0.0 {
        return vec![0.0];
    }
    let last = (product + 1e-9 * product.max(1.0)).floor().max(0.0) as usize;
    (0..=last).map(|k| k as f64 / config.output_fps).collect()
}

/// Run `source` as `config` says and collect the frames.
///
/// Dynamic mode takes [`total_steps`] fixed steps. Frame k (nominal time `t_k = k /
/// output_fps`) records the state at the first step time `t ≥ t_k − dt/2`, i.e. the
/// state nearest to `t_k` (when `output_fps > 1/dt` consecutive frames may repeat a
/// state). Any frame still unrecorded after the last step gets the final state.
/// `progress(step, total_steps)` is called after every step. Static mode solves for the
/// equilibrium and records one frame.
///
/// Every recorded number and every velocity is checked: a non-finite value stops the run
/// with [`Error::Diverged`], naming the strand and the time.
pub fn run_to_frames<S: FrameSource + ?Sized>(
    source: &mut S,
    config: &SimulationConfig,
    samples_per_element: usize,
    mut progress: impl FnMut(usize, usize),
) -> Result<(Frames, RunSummary)> {
    let started = Instant::now();
    let mut recorder = Recorder::new(source, frame_times(config), samples_per_element);
    let mut max_speed = check_state(source)?;
    let steps = total_steps(config);
    if config.mode == Mode::Static {
        source.solve_static()?;
        check_state(source)?;
        progress(1, 1);
    } else {
        recorder.record_due(source, source.time() + 0.5 * config.dt)?;
        for step in 1..=steps {
            source.step()?;
            max_speed = max_speed.max(check_state(source)?);
            recorder.record_due(source, source.time() + 0.5 * config.dt)?;
            progress(step, steps);
        }
    }
    recorder.record_due(source, f64::INFINITY)?;
    let frames = recorder.frames;
    let summary = RunSummary {
        mode: config.mode,
        steps,
        strands: source.strand_count(),
        frames: frames.frame_times.len(),
        wall_time: started.elapsed(),
        max_speed,
    };
    Ok((frames, summary))
}

/// Write `frames` as JSON to `path`, creating the parent directory if needed.
pub fn write_frames(path: &Path, frames: &Frames) -> Result<()> {
    let io_error = |source: std::io::Error| Error::Io {
        path: path.display().to_string(),
        source,
    };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io_error)?;
    }
    let file = std::fs::File::create(path).map_err(io_error)?;
    let mut writer = std::io::BufWriter::new(file);
    serde_json::to_writer(&mut writer, frames).map_err(|e| io_error(e.into()))?;
    std::io::Write::flush(&mut writer).map_err(io_error)
}

/// Collects frames as the run goes.
struct Recorder {
    frames: Frames,
    nominal: Vec<f64>,
    samples_per_element: usize,
}

impl Recorder {
    fn new<S: FrameSource + ?Sized>(
        source: &S,
        nominal: Vec<f64>,
        samples_per_element: usize,
    ) -> Self {
        let strands = (0..source.strand_count())
            .map(|i| StrandFrames {
                name: source.strand_name(i).to_string(),
                points: Vec::new(),
                q: Vec::new(),
            })
            .collect();
        let frames = Frames {
            frame_times: Vec::new(),
            state_times: Vec::new(),
            strands,
        };
        Self {
            frames,
            nominal,
            samples_per_element,
        }
    }

    /// Record the current state for every pending frame whose nominal time is `<= until`.
    fn record_due<S: FrameSource + ?Sized>(&mut self, source: &mut S, until: f64) -> Result<()> {
        while let Some(&t) = self.nominal.get(self.frames.frame_times.len()) {
            if t > until {
                break;
            }
            self.record(source, t)?;
        }
        Ok(())
    }

    fn record<S: FrameSource + ?Sized>(&mut self, source: &mut S, nominal: f64) -> Result<()> {
        let time = source.time();
        for (i, strand) in self.frames.strands.iter_mut().enumerate() {
            let q = source.q(i).to_vec();
            let points = source.centreline_world(i, self.samples_per_element);
            ensure_finite(
                source,
                i,
                points.iter().flatten().copied(),
                "non-finite centreline point",
            )?;
            strand.q.push(q);
            strand.points.push(points);
        }
        self.frames.frame_times.push(nominal);
        self.frames.state_times.push(time);
        Ok(())
    }
}

/// Largest |q̇| over the strands; [`Error::Diverged`] if a coordinate or velocity is
/// not finite.
fn check_state<S: FrameSource + ?Sized>(source: &S) -> Result<f64> {
    let mut max_speed = 0.0_f64;
    for i in 0..source.strand_count() {
        ensure_finite(
            source,
            i,
            source.q(i).iter().copied(),
            "non-finite generalized coordinates",
        )?;
        let v = source.v(i);
        ensure_finite(
            source,
            i,
            v.iter().copied(),
            "non-finite generalized velocity",
        )?;
        max_speed = max_speed.max(v.iter().map(|x| x * x).sum::<f64>().sqrt());
    }
    Ok(max_speed)
}

fn ensure_finite<S: FrameSource + ?Sized>(
    source: &S,
    i: usize,
    mut values: impl Iterator<Item = f64>,
    cause: &str,
) -> Result<()> {
    if values.all(f64::is_finite) {
        return Ok(());
    }
    Err(Error::Diverged {
        strand: source.strand_name(i).to_string(),
        index: i,
        time: source.time(),
        cause: cause.to_string(),
    })
}

#[cfg(test)]
mod tests;
