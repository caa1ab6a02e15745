//! The run loop: steps a [`FrameSource`] and streams every frame to a list of
//! [`FrameSink`]s as soon as it is computed.
//!
//! Frame timing: dynamic mode takes [`total_steps`] fixed steps. Frame k (nominal time
//! `t_k = k / output_fps`) records the state at the first step time `t ≥ t_k − dt/2`,
//! i.e. the state nearest to `t_k` (when `output_fps > 1/dt` consecutive frames may
//! repeat a state). Any frame still unrecorded after the last step gets the final state.
//! With `[output] times` the frames are at those times exactly: a step of `dt` inside
//! which a frame's time falls is split there ([`FrameSource::step_by`]), the state written,
//! and the step finished, so the steps keep their grid `k dt` (times within
//! [`EXACT_FRACTION`] of a step's end count as that end); the summary then counts the
//! steps taken. Static mode solves for the equilibrium and records one frame at time 0.
//!
//! The run stops early when the stop flag is raised (checked between steps), when a
//! coordinate, velocity or centreline point is not finite, or a point is beyond the
//! float32 range the centrelines are written in ([`Error::Diverged`], naming the strand,
//! the time and the cause: no non-finite number is ever written), when a step
//! fails, or when a sink cannot write. In every case every sink is finished, so every
//! frame written stays readable, and the [`RunOutcome`] says how many frames were
//! written and why the run stopped.

use super::frames::{FrameLayout, FrameSink, FrameView, StrandInfo};
use super::{frame_times, total_steps, FrameSource, RunSummary};
use crate::config::{Mode, SimulationConfig};
use crate::error::{Error, Result};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Why a run stopped.
#[derive(Debug)]
pub enum StopReason {
    /// Every planned frame was written.
    Completed,
    /// The stop flag was raised (Ctrl-C).
    Interrupted,
    /// A step failed, a value became non-finite or a sink could not write.
    Failed(Error),
}

/// What a run did: its summary (whose `frames` counts the frames written), why it
/// stopped, and the simulated time it reached.
#[derive(Debug)]
pub struct RunOutcome {
    /// Steps, frames written, wall-clock time, largest speed.
    pub summary: RunSummary,
    /// Frames the run planned to write.
    pub planned_frames: usize,
    /// Why the run stopped.
    pub stop: StopReason,
    /// Simulated time when the run stopped, s.
    pub time: f64,
}

impl RunOutcome {
    /// Frames written to every sink.
    pub fn frames_written(&self) -> usize {
        self.summary.frames
    }
}

/// Display radius of a strand from its material: for an elliptic cross-section of
/// semi-axes a, b the rotary inertias per length are ρI1 = ρπab³/4 and ρI2 = ρπa³b/4
/// and the mass per length ρπab, so b = 2·sqrt(ρI1/ρS) and a = 2·sqrt(ρI2/ρS); the
/// radius is (a + b)/2. Strands without rotary inertia get [`DEFAULT_DISPLAY_RADIUS`].
pub fn display_radius(material: &crate::model::material::Material) -> f64 {
    let m = material.mass_per_length;
    let [_, i1, i2] = material.rotary_inertia;
    let radius = (i1 / m).sqrt() + (i2 / m).sqrt();
    if radius.is_finite() && radius > 0.0 {
        radius
    } else {
        DEFAULT_DISPLAY_RADIUS
    }
}

/// Display radius of a strand whose cross-section is unknown, m (a typical hair).
pub const DEFAULT_DISPLAY_RADIUS: f64 = 5e-5;

/// The layout of the frames a run of `source` under `config` writes.
pub fn frame_layout<S: FrameSource + ?Sized>(
    source: &S,
    config: &SimulationConfig,
    samples_per_element: usize,
) -> FrameLayout {
    let strands = (0..source.strand_count())
        .map(|i| {
            let coordinates = source.q(i).len();
            StrandInfo {
                name: source.strand_name(i).to_string(),
                group: source.strand_group(i).to_string(),
                radius: source.strand_radius(i),
                points: 1 + samples_per_element * source.strand_elements(i),
                coordinates,
            }
        })
        .collect();
    FrameLayout {
        strands,
        output_fps: config.output_fps,
        planned_frames: frame_times(config).len(),
        held_tips: (0..source.strand_count())
            .filter(|&i| source.has_held_tip(i))
            .collect(),
    }
}

/// Run `source` as `config` says, handing every frame to every sink in `sinks` as it is
/// computed (see the module documentation for the frame timing and early stops).
/// `stop` is checked between steps; `progress(step, total_steps)` is called after every
/// step. Every sink is finished before this returns, whatever the outcome.
pub fn run_streaming<S: FrameSource + ?Sized>(
    source: &mut S,
    config: &SimulationConfig,
    samples_per_element: usize,
    sinks: &mut [&mut dyn FrameSink],
    stop: &AtomicBool,
    progress: impl FnMut(usize, usize),
) -> RunOutcome {
    run_checkpointed(
        source,
        config,
        samples_per_element,
        sinks,
        stop,
        progress,
        None,
    )
}

/// Checkpoints of a run: how often, where, of what, and where a resumed run starts.
#[derive(Debug, Clone)]
pub struct Checkpoints {
    /// Frames between two checkpoints (0: none; a Ctrl-C still writes one).
    pub every: usize,
    /// The output directory (the checkpoint goes next to the frames).
    pub dir: std::path::PathBuf,
    /// The scene and options the checkpoint is of.
    pub identity: super::checkpoint::SceneIdentity,
    /// Where a resumed run starts (its source already restored to the checkpoint's
    /// state and its sinks cut back to the checkpoint's marks); `None`: from t = 0.
    pub resume: Option<super::checkpoint::RunPoint>,
    /// Checkpoints written by this run.
    pub written: usize,
}

/// [`run_streaming`] with checkpoints: every `checkpoints.every` frames (after the step
/// that wrote them), and when the stop flag ends the run, the sinks are marked and the
/// source's state written ([`super::checkpoint`]); a run with `checkpoints.resume` goes
/// on from there, its frames numbered after those written.
pub fn run_checkpointed<S: FrameSource + ?Sized>(
    source: &mut S,
    config: &SimulationConfig,
    samples_per_element: usize,
    sinks: &mut [&mut dyn FrameSink],
    stop: &AtomicBool,
    mut progress: impl FnMut(usize, usize),
    checkpoints: Option<&mut Checkpoints>,
) -> RunOutcome {
    let started = Instant::now();
    let nominal = frame_times(config);
    let planned_frames = nominal.len();
    let steps = total_steps(config);
    let from = checkpoints
        .as_ref()
        .and_then(|c| c.resume)
        .unwrap_or_default();
    let mut streamer = Streamer {
        nominal,
        samples_per_element,
        written: from.frames,
        points: Vec::new(),
        q: Vec::new(),
        held: Vec::new(),
        held_drift: from.held_drift,
        sinks,
    };
    let resumed = checkpoints.as_ref().is_some_and(|c| c.resume.is_some());
    let mut max_speed = from.max_speed;
    let mut deepest = match resumed {
        true => from.deepest,
        false => source.deepest_inside(),
    };
    let mut taken = from.taken;
    let result = run_loop(
        source,
        config,
        steps,
        &mut streamer,
        stop,
        (&mut max_speed, &mut deepest, &mut taken),
        &mut progress,
        (checkpoints, from.step, resumed),
    );
    let mut stop_reason = match result {
        Ok(true) => StopReason::Completed,
        Ok(false) => StopReason::Interrupted,
        Err(e) => StopReason::Failed(e),
    };
    for sink in streamer.sinks.iter_mut() {
        if let Err(e) = sink.finish() {
            if !matches!(stop_reason, StopReason::Failed(_)) {
                stop_reason = StopReason::Failed(e);
            }
        }
    }
    let summary = RunSummary {
        mode: config.mode,
        // the steps planned, and those that ended on a frame's time under [output] times
        // (a resumed run: those of this run)
        steps: if config.output_times.is_some() {
            taken - from.taken
        } else {
            steps - from.step
        },
        strands: source.strand_count(),
        frames: streamer.written,
        wall_time: started.elapsed(),
        max_speed,
        deepest_inside: deepest,
        error_control: source.error_control(),
        coulomb: source.coulomb_updates(),
        held_drift: streamer.held_drift,
    };
    RunOutcome {
        summary,
        planned_frames,
        stop: stop_reason,
        time: source.time(),
    }
}

/// The steps and frames of a run; `Ok(false)` when the stop flag ended it.
#[allow(clippy::too_many_arguments)]
fn run_loop<S: FrameSource + ?Sized>(
    source: &mut S,
    config: &SimulationConfig,
    steps: usize,
    streamer: &mut Streamer<'_, '_>,
    stop: &AtomicBool,
    (max_speed, deepest, taken): (&mut f64, &mut Option<f64>, &mut usize),
    progress: &mut impl FnMut(usize, usize),
    (mut checkpoints, first, resumed): (Option<&mut Checkpoints>, usize, bool),
) -> Result<bool> {
    *max_speed = max_speed.max(check_state(source)?);
    // the frames written when the last checkpoint was taken
    let mut checkpointed = streamer.written;
    if config.mode == Mode::Static {
        if stop.load(Ordering::Relaxed) {
            return Ok(false);
        }
        source.solve_static()?;
        check_state(source)?;
        progress(1, 1);
    } else {
        // frames at given times land exactly on them: a step that would pass one is split
        // there; otherwise a frame takes the state nearest its time
        let exact = config.output_times.is_some();
        let reach = if exact {
            EXACT_FRACTION * config.dt
        } else {
            0.5 * config.dt
        };
        if !resumed {
            streamer.write_due(source, source.time() + reach)?;
        }
        for step in first + 1..=steps {
            if stop.load(Ordering::Relaxed) {
                // (a Ctrl-C keeps where the run was, to go on from there)
                if step > first + 1 || !resumed {
                    write_checkpoint(
                        source,
                        streamer,
                        step - 1,
                        (*max_speed, *deepest, *taken),
                        checkpoints.as_deref_mut(),
                    )?;
                }
                return Ok(false);
            }
            let end = source.time() + config.dt;
            let mut split = false;
            while let Some(t) = streamer
                .next_time()
                .filter(|&t| exact && t > source.time() + reach && t < end - reach)
            {
                source.step_by(t - source.time())?;
                after_step(source, streamer, reach, (&mut *max_speed, &mut *deepest))?;
                *taken += 1;
                split = true;
            }
            if split {
                source.step_by(end - source.time())?;
            } else {
                source.step()?;
            }
            after_step(source, streamer, reach, (&mut *max_speed, &mut *deepest))?;
            *taken += 1;
            let every = checkpoints.as_ref().map_or(0, |c| c.every);
            if every > 0 && streamer.written >= checkpointed + every && step < steps {
                write_checkpoint(
                    source,
                    streamer,
                    step,
                    (*max_speed, *deepest, *taken),
                    checkpoints.as_deref_mut(),
                )?;
                checkpointed = streamer.written;
            }
            super::test_hooks::after_frames(streamer.written);
            progress(step, steps);
        }
    }
    streamer.write_due(source, f64::INFINITY)?;
    Ok(true)
}

/// Mark every sink and write the source's state as a checkpoint of the run at `step`
/// (nothing without `checkpoints`).
fn write_checkpoint<S: FrameSource + ?Sized>(
    source: &S,
    streamer: &mut Streamer<'_, '_>,
    step: usize,
    (max_speed, deepest, taken): (f64, Option<f64>, usize),
    checkpoints: Option<&mut Checkpoints>,
) -> Result<()> {
    let Some(c) = checkpoints else {
        return Ok(());
    };
    let marks = streamer
        .sinks
        .iter_mut()
        .map(|sink| sink.mark())
        .collect::<Result<Vec<_>>>()?;
    let Some(state) = source.state().transpose()? else {
        return Err(Error::invalid(
            "output.checkpoint_every",
            "this simulation cannot be checkpointed: set checkpoint_every = 0",
        ));
    };
    let checkpoint = super::checkpoint::Checkpoint {
        version: super::checkpoint::VERSION,
        identity: c.identity.clone(),
        point: super::checkpoint::RunPoint {
            step,
            time: source.time(),
            frames: streamer.written,
            taken,
            max_speed,
            deepest,
            held_drift: streamer.held_drift,
        },
        sinks: marks,
        state,
    };
    super::checkpoint::write(&c.dir, &checkpoint)?;
    c.written += 1;
    Ok(())
}

/// After a step: the state checked, the deepest point inside a body, the frames due.
fn after_step<S: FrameSource + ?Sized>(
    source: &mut S,
    streamer: &mut Streamer<'_, '_>,
    reach: f64,
    (max_speed, deepest): (&mut f64, &mut Option<f64>),
) -> Result<()> {
    *max_speed = max_speed.max(check_state(source)?);
    if let (Some(d), Some(now)) = (deepest.as_mut(), source.deepest_inside()) {
        *d = d.max(now);
    }
    streamer.write_due(source, source.time() + reach)
}

/// How close to a step's end (in steps) a frame's time counts as that step's end under
/// `[output] times`: round-off, not a shorter step.
pub const EXACT_FRACTION: f64 = 1e-9;

/// Builds each frame once and hands it to every sink.
struct Streamer<'s, 'k> {
    nominal: Vec<f64>,
    samples_per_element: usize,
    written: usize,
    points: Vec<[f64; 3]>,
    q: Vec<f64>,
    held: Vec<super::HeldEndFrame>,
    /// The largest held-tip drift of the frames written.
    held_drift: Option<f64>,
    sinks: &'s mut [&'k mut dyn FrameSink],
}

impl Streamer<'_, '_> {
    /// The time of the next frame to write.
    fn next_time(&self) -> Option<f64> {
        self.nominal.get(self.written).copied()
    }

    /// Write the current state for every pending frame whose nominal time is `<= until`.
    fn write_due<S: FrameSource + ?Sized>(&mut self, source: &mut S, until: f64) -> Result<()> {
        while let Some(&t) = self.nominal.get(self.written) {
            if t > until {
                break;
            }
            self.write(source, t)?;
        }
        Ok(())
    }

    fn write<S: FrameSource + ?Sized>(&mut self, source: &mut S, nominal: f64) -> Result<()> {
        self.points.clear();
        self.q.clear();
        for i in 0..source.strand_count() {
            let points = source.centreline_world(i, self.samples_per_element);
            ensure_finite(
                source,
                i,
                points.iter().flatten().copied(),
                "non-finite centreline point",
            )?;
            // the centrelines are written as float32 (frames.npy, USD, OBJ): a point
            // beyond its range would be written as infinite
            ensure_finite(
                source,
                i,
                points.iter().flatten().map(|&c| c as f32 as f64),
                "centreline point beyond the float32 range of the outputs (|x| > 3.4e38 m)",
            )?;
            self.points.extend_from_slice(&points);
            self.q.extend_from_slice(source.q(i));
        }
        source.held_ends(&mut self.held);
        for h in &self.held {
            self.held_drift = Some(self.held_drift.unwrap_or(0.0).max(h.drift));
        }
        let frame = FrameView {
            index: self.written,
            time: nominal,
            state_time: source.time(),
            points: &self.points,
            q: &self.q,
            steps: source.frame_steps(),
            held: &self.held,
        };
        for sink in self.sinks.iter_mut() {
            sink.write_frame(&frame)?;
        }
        self.written += 1;
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
        max_speed = max_speed.max(source.speed(i));
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
