//! Outputs: the run driver that streams frames to files as they are computed, the
//! `frames.json` format, the output plan.
//!
//! - [`frames`]: the layout of a run's frames, one frame ([`FrameView`]), the
//!   [`FrameSink`] (a file written while the run goes) and [`FrameStore`] (read access
//!   to the frames written) traits.
//! - [`driver`]: the run loop ([`run_streaming`]), its stop flag and early stops.
//! - [`json`]: `frames.json`, streamed frame-major.
//! - [`memory`]: frames in memory.
//! - [`nodes`]: `frames.nodes.npy` and `frames.d1.npy`, each strand at evenly spaced arc
//!   length (`[output] nodes`).
//! - [`npy`]: `frames.npy`, `frames.times.npy`, `frames.index.json`, streamed.
//! - [`plan`]: which files a run writes ([`Formats`]), their estimated sizes, the size
//!   limit and the checks of the output directory.
//! - [`atomic`]: files written whole or not at all (a temporary file, synced, and a
//!   rename); [`test_hooks`]: where tests make a run abort.
//! - [`products`]: the files written after the run from the frames written
//!   (`hair.usda` by [`usd`], the previews by [`preview`], `last_frame.obj` by [`obj`]),
//!   with the head motion, bodies and render strands of the run's [`scenery`]; the
//!   render strands of each frame by [`render_strands`].
//!
//! The driver reaches the simulation only through [`FrameSource`].

pub mod atomic;
pub mod checkpoint;
pub mod driver;
pub mod frames;
pub mod json;
pub mod memory;
pub mod nodes;
pub mod npy;
pub mod obj;
pub mod plan;
pub mod preview;
pub mod products;
pub mod render_strands;
pub mod scenery;
pub mod test_hooks;
pub mod usd;

pub use driver::{frame_layout, run_streaming, RunOutcome, StopReason};
pub use frames::{FrameLayout, FrameSink, FrameStore, FrameView, StrandInfo};
pub use json::{JsonFrameSink, JsonFrameStore};
pub use memory::MemoryFrames;
pub use plan::{Formats, OutputPlan, OutputSettings};

pub use crate::config::{frame_times, total_steps};
use crate::config::{Mode, SimulationConfig};
use crate::error::Result;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

/// What the driver needs of a running simulation. Strand indices run over
/// `0..strand_count()`.
pub trait FrameSource {
    /// Current simulated time, seconds (0 before the first step).
    fn time(&self) -> f64;
    /// Number of strands.
    fn strand_count(&self) -> usize;
    /// Name of strand `i`.
    fn strand_name(&self, i: usize) -> &str;
    /// Group of strand `i` (see [`StrandInfo::group`]); by default its name.
    fn strand_group(&self, i: usize) -> &str {
        self.strand_name(i)
    }
    /// Display radius of strand `i`, m (see [`StrandInfo::radius`]); by default
    /// [`driver::DEFAULT_DISPLAY_RADIUS`].
    fn strand_radius(&self, _i: usize) -> f64 {
        driver::DEFAULT_DISPLAY_RADIUS
    }
    /// Number of elements of strand `i` (its centreline has `samples_per_element` points
    /// per element after the root): by default a third of its coordinates (a source with
    /// coordinates beyond the elements', as a free root's translation, says how many).
    fn strand_elements(&self, i: usize) -> usize {
        self.q(i).len() / 3
    }
    /// Generalized coordinates of strand `i` (3N).
    fn q(&self, i: usize) -> &[f64];
    /// Generalized velocities q̇ of strand `i` (3N).
    fn v(&self, i: usize) -> &[f64];
    /// The size of strand `i`'s velocity reported as the run's largest speed: |q̇| by
    /// default (a source whose coordinates have other scales, as a pinned root's joint,
    /// says how it measures).
    fn speed(&self, i: usize) -> f64 {
        self.v(i).iter().map(|x| x * x).sum::<f64>().sqrt()
    }
    /// Centreline of strand `i` in world coordinates at the current time: the root, then
    /// `samples_per_element` points per element (the last one at the element's end).
    fn centreline_world(&mut self, i: usize, samples_per_element: usize) -> Vec<[f64; 3]>;
    /// Advance by one time step.
    fn step(&mut self) -> Result<()>;
    /// Advance by a step of `h` seconds (what `[output] times` uses to end a step on a
    /// frame's time); by default refused: the source takes its own steps only.
    fn step_by(&mut self, h: f64) -> Result<()> {
        Err(crate::error::Error::invalid(
            "output.times",
            format!("a step of {h} s was asked of a source that takes fixed steps only"),
        ))
    }
    /// Replace the state by the static equilibrium.
    fn solve_static(&mut self) -> Result<()>;
    /// The deepest point of any centreline inside a body at the current state, m (0: none
    /// inside; `None`: no contacts, the default).
    fn deepest_inside(&mut self) -> Option<f64> {
        None
    }
    /// What the error-controlled step did so far (`None`: fixed steps, the default).
    fn error_control(&self) -> Option<ErrorControlSummary> {
        None
    }
    /// How often the Coulomb forces were recomputed so far in this run (`None`: no
    /// `[electrostatics]`, the default).
    fn coulomb_updates(&self) -> Option<CoulombUpdates> {
        None
    }
    /// What the error-controlled step did since the last call (`None`: fixed steps, the
    /// default); called once per frame written.
    fn frame_steps(&mut self) -> Option<FrameSteps> {
        None
    }
    /// What the error-controlled step did so far, per strand in scene order (`None`: fixed
    /// steps, the default).
    fn strand_steps(&self) -> Option<Vec<StrandSteps>> {
        None
    }
    /// Whether strand `i`'s tip is held (`[strands.ends.tip]`); by default no strand's.
    fn has_held_tip(&self, _i: usize) -> bool {
        false
    }
    /// Every held tip's drift since the last call and its reaction at the current state,
    /// in strand order, appended to `out` (which is cleared first); called once per frame
    /// written. By default no strand has a held tip.
    fn held_ends(&mut self, out: &mut Vec<HeldEndFrame>) {
        out.clear();
    }
    /// Everything the source needs to go on from where it is, encoded (what a checkpoint
    /// writes); `None` (the default): the source cannot be checkpointed.
    fn state(&self) -> Option<Result<Vec<u8>>> {
        None
    }
    /// Continue from `state` as [`Self::state`] encoded it; by default refused.
    fn restore(&mut self, _state: &[u8]) -> Result<()> {
        Err(crate::error::Error::invalid(
            "--resume",
            "this source cannot continue from a checkpoint",
        ))
    }
}

/// One held tip (`[strands.ends.tip]`) at one frame: written per frame in `frames.json`
/// (`"held"`) and `frames.held.npy`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct HeldEndFrame {
    /// The strand's index in scene order.
    pub strand: usize,
    /// The largest distance of the tip from its holder after any step since the previous
    /// frame: position off relative to the strand's length, frame off in radians (the
    /// larger of the two; a step fails beyond 1e-9).
    pub drift: f64,
    /// The holder's reaction on the tip at the frame's state, world coordinates: force
    /// (N), then torque (N·m; zero unless the tip is clamped).
    pub reaction: [f64; 6],
}

/// What the error-controlled step (`[simulation] tolerance`) did for one strand over a
/// run: a row of `strand_steps.npy`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct StrandSteps {
    /// Steps accepted.
    pub steps: usize,
    /// Steps rejected and retried shorter.
    pub rejected: usize,
    /// The largest estimated error of an accepted step, relative to the strand's length.
    pub largest_error: f64,
    /// The smallest step, s (0: none).
    pub smallest_step: f64,
    /// The largest step, s.
    pub largest_step: f64,
}

/// What the error-controlled step (`[simulation] tolerance`) did between two frames: the
/// steps that ended after the previous frame's state and at or before this frame's (frame
/// 0: none). Written per frame in `frames.json` and `frames.index.json`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameSteps {
    /// The largest estimated error of an accepted step, relative to its strand's length
    /// (0: no step).
    pub largest_error: f64,
    /// Steps accepted, all strands.
    pub steps: usize,
    /// Steps rejected and retried shorter, all strands.
    pub rejected: usize,
    /// The smallest step any strand took, s (0: no step).
    pub smallest_step: f64,
    /// The largest step any strand took, s (0: no step).
    pub largest_step: f64,
}

pub use crate::forces::electrostatics::force_coulomb::CoulombUpdates;

/// What the error-controlled step (`[simulation] tolerance`) did over a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorControlSummary {
    /// The tolerance.
    pub tolerance: f64,
    /// The largest estimated error of an accepted step, relative to its strand's length.
    pub largest_error: f64,
    /// The smallest step any strand took, s.
    pub smallest_step: f64,
    /// The strand that took it (its index in scene order; `None`: no step).
    pub smallest_step_strand: Option<usize>,
    /// Steps accepted, all strands.
    pub steps: usize,
    /// Steps rejected and retried shorter, all strands.
    pub rejected: usize,
    /// Of those, the steps rejected by the contacts' depth check (a sample taken deeper
    /// than the split depth beyond its depth at the step's start), whatever their
    /// estimated error.
    pub rejected_deep: usize,
}

/// Every frame of a run, strand-major (what [`run_to_frames`] returns).
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
    /// Largest Euclidean norm of a strand's q̇ over all strands and steps, rad/(m·s) (a
    /// pinned root's joint counted as the root frame's angular velocity θ̇ = l₀ ḋ₀, rad/s).
    pub max_speed: f64,
    /// Deepest point of a centreline inside a body after any step, m (`None`: a scene
    /// without contacts).
    pub deepest_inside: Option<f64>,
    /// What the error-controlled step did (`None`: fixed steps).
    pub error_control: Option<ErrorControlSummary>,
    /// How often the Coulomb forces were recomputed (`None`: no `[electrostatics]`).
    pub coulomb: Option<CoulombUpdates>,
    /// The largest drift of a held tip from its holder over the frames written (see
    /// [`HeldEndFrame::drift`]; `None`: no strand has a held tip).
    pub held_drift: Option<f64>,
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
        let strands = match self.strands {
            1 => "1 strand".to_string(),
            n => format!("{n} strands"),
        };
        match self.mode {
            Mode::Static => {
                write!(f, "static: {strands} solved in {wall:.3} s")?;
                match self.held_drift {
                    Some(d) => write!(f, ", held tips at most {d:.1e} L off their holders"),
                    None => Ok(()),
                }
            }
            Mode::Dynamic => {
                write!(
                    f,
                    "{} steps x {strands} in {wall:.3} s: {:.0} strand-steps/s, max |q̇| = {:.4e} rad/(m s), {} frames",
                    self.steps,
                    self.strand_steps_per_second(),
                    self.max_speed,
                    self.frames
                )?;
                if let Some(d) = self.deepest_inside {
                    write!(f, ", deepest centreline point {d:.3e} m inside a body")?;
                }
                if let Some(d) = self.held_drift {
                    write!(f, ", held tips at most {d:.1e} L off their holders")?;
                }
                if let Some(c) = self.coulomb {
                    let times = match c.updates {
                        1 => "once".to_string(),
                        n => format!("{n} times"),
                    };
                    write!(
                        f,
                        ", Coulomb forces recomputed {times} in {:.3} s",
                        c.seconds
                    )?;
                }
                match self.error_control {
                    Some(e) => {
                        write!(
                            f,
                            "; tolerance {:.1e}: largest estimated error {:.2e} L, {} steps taken, {} rejected ({} by the contacts' depth check), smallest step {:.3e} s",
                            e.tolerance,
                            e.largest_error,
                            e.steps,
                            e.rejected,
                            e.rejected_deep,
                            e.smallest_step
                        )?;
                        match e.smallest_step_strand {
                            Some(i) => {
                                write!(f, " (strand {i}; every strand's in strand_steps.npy)")
                            }
                            None => Ok(()),
                        }
                    }
                    None => Ok(()),
                }
            }
        }
    }
}

/// Run `source` as `config` says and collect the frames in memory, strand-major.
///
/// The frame timing is [`run_streaming`]'s. `progress(step, total_steps)` is called
/// after every step. A non-finite coordinate, velocity or point stops the run with
/// [`crate::Error::Diverged`], naming the strand and the time (the frames of a stopped run are
/// kept by [`run_streaming`] with a [`MemoryFrames`] sink).
pub fn run_to_frames<S: FrameSource + ?Sized>(
    source: &mut S,
    config: &SimulationConfig,
    samples_per_element: usize,
    progress: impl FnMut(usize, usize),
) -> Result<(Frames, RunSummary)> {
    let mut memory = MemoryFrames::new(frame_layout(source, config, samples_per_element));
    let never = AtomicBool::new(false);
    let outcome = run_streaming(
        source,
        config,
        samples_per_element,
        &mut [&mut memory],
        &never,
        progress,
    );
    match outcome.stop {
        StopReason::Failed(e) => Err(e),
        StopReason::Completed | StopReason::Interrupted => {
            Ok((memory.to_frames(), outcome.summary))
        }
    }
}

#[cfg(test)]
mod tests;
