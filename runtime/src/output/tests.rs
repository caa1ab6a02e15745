use super::*;
use crate::error::Error;

mod streaming;

/// A fake simulation: strand i is a straight line along x from (0, i, 0) whose tip bends
/// in z as q = sin(t); it can be told to produce a NaN at a given step.
struct Fake {
    time: f64,
    dt: f64,
    steps: usize,
    q: Vec<Vec<f64>>,
    v: Vec<Vec<f64>>,
    nan_at_step: Option<usize>,
    /// At this step q becomes 1e39: finite in f64, beyond float32's range.
    huge_at_step: Option<usize>,
    solved: bool,
}

impl Fake {
    fn new(strands: usize, dt: f64) -> Self {
        Self {
            time: 0.0,
            dt,
            steps: 0,
            q: vec![vec![0.0; 6]; strands],
            v: vec![vec![0.0; 6]; strands],
            nan_at_step: None,
            huge_at_step: None,
            solved: false,
        }
    }
}

const NAMES: [&str; 3] = ["a", "b", "c"];

impl FrameSource for Fake {
    fn time(&self) -> f64 {
        self.time
    }
    fn strand_count(&self) -> usize {
        self.q.len()
    }
    fn strand_name(&self, i: usize) -> &str {
        NAMES[i]
    }
    fn q(&self, i: usize) -> &[f64] {
        &self.q[i]
    }
    fn v(&self, i: usize) -> &[f64] {
        &self.v[i]
    }
    fn centreline_world(&mut self, i: usize, samples_per_element: usize) -> Vec<[f64; 3]> {
        let n = 2 * samples_per_element;
        (0..=n)
            .map(|k| [k as f64 * 0.01, i as f64, self.q[i][0] * k as f64])
            .collect()
    }
    fn step(&mut self) -> Result<()> {
        self.steps += 1;
        self.time = self.steps as f64 * self.dt;
        let bad = self.nan_at_step == Some(self.steps);
        let huge = self.huge_at_step == Some(self.steps);
        for (q, v) in self.q.iter_mut().zip(&mut self.v) {
            q[0] = if bad {
                f64::NAN
            } else if huge {
                1e39
            } else {
                self.time.sin()
            };
            v[0] = self.time.cos();
        }
        Ok(())
    }
    fn solve_static(&mut self) -> Result<()> {
        self.solved = true;
        Ok(())
    }
}

fn config(dt: f64, duration: f64, fps: f64) -> SimulationConfig {
    SimulationConfig {
        dt,
        duration,
        output_fps: fps,
        ..SimulationConfig::default()
    }
}

#[test]
fn frames_at_every_output_time_with_the_nearest_state() {
    let cfg = config(1.0 / 30.0, 2.0, 30.0);
    let mut fake = Fake::new(2, cfg.dt);
    let mut calls = Vec::new();
    let (frames, summary) =
        run_to_frames(&mut fake, &cfg, 3, |s, n| calls.push((s, n))).expect("runs");
    assert_eq!(summary.steps, 60);
    assert_eq!(calls.len(), 60);
    assert_eq!(calls.last(), Some(&(60, 60)));
    assert_eq!(frames.frame_times.len(), 61);
    assert_eq!(frames.strands.len(), 2);
    for (nominal, state) in frames.frame_times.iter().zip(&frames.state_times) {
        assert!((nominal - state).abs() <= 0.5 * cfg.dt + 1e-12);
    }
    let b = &frames.strands[1];
    assert_eq!(b.name, "b");
    assert_eq!(b.points.len(), 61);
    assert_eq!(b.points[0].len(), 7);
    assert_eq!(b.points[0][0], [0.0, 1.0, 0.0]);
    assert!((b.q[30][0] - 1.0_f64.sin()).abs() < 1e-12);
    assert!((summary.max_speed - 1.0).abs() < 1e-3);
}

#[test]
fn coarse_output_takes_every_nth_state_and_fine_output_repeats_states() {
    let cfg = config(0.01, 1.0, 10.0);
    let (frames, summary) =
        run_to_frames(&mut Fake::new(1, 0.01), &cfg, 1, |_, _| {}).expect("runs");
    assert_eq!(summary.steps, 100);
    assert_eq!(frames.frame_times.len(), 11);
    assert!((frames.state_times[3] - 0.3).abs() < 1e-12);
    let cfg = config(0.1, 1.0, 20.0);
    let (frames, _) = run_to_frames(&mut Fake::new(1, 0.1), &cfg, 1, |_, _| {}).expect("runs");
    assert_eq!(frames.frame_times.len(), 21);
    assert!(frames
        .state_times
        .iter()
        .zip(&frames.frame_times)
        .all(|(s, t)| (s - t).abs() <= 0.05 + 1e-12));
}

#[test]
fn a_nan_stops_the_run_with_the_strand_and_time() {
    let cfg = config(0.1, 1.0, 2.0); // no frame is due at the failing step
    let mut fake = Fake::new(3, 0.1);
    fake.nan_at_step = Some(4);
    match run_to_frames(&mut fake, &cfg, 2, |_, _| {}) {
        Err(Error::Diverged {
            strand,
            index,
            time,
            ..
        }) => {
            assert_eq!((strand.as_str(), index), ("a", 0));
            assert!((time - 0.4).abs() < 1e-12);
        }
        other => panic!("expected Diverged, got {other:?}"),
    }
}

#[test]
fn a_point_beyond_float32_stops_the_run_before_it_is_written() {
    // the centreline is written as float32: 1e39 (finite in f64) would be written as
    // infinite; the run stops at the frame that would hold it, keeping those before
    let cfg = config(0.1, 1.0, 10.0);
    let mut fake = Fake::new(2, 0.1);
    fake.huge_at_step = Some(3);
    match run_to_frames(&mut fake, &cfg, 2, |_, _| {}) {
        Err(Error::Diverged {
            strand,
            time,
            cause,
            ..
        }) => {
            assert_eq!(strand, "a");
            assert!((time - 0.3).abs() < 1e-12);
            assert!(cause.contains("float32"), "{cause}");
        }
        other => panic!("expected Diverged, got {other:?}"),
    }
}

#[test]
fn static_mode_solves_and_writes_one_frame() {
    let cfg = SimulationConfig {
        mode: Mode::Static,
        ..config(0.1, 1.0, 10.0)
    };
    let mut fake = Fake::new(1, 0.1);
    let (frames, summary) = run_to_frames(&mut fake, &cfg, 2, |_, _| {}).expect("runs");
    assert!(fake.solved);
    assert_eq!(frames.frame_times, vec![0.0]);
    assert_eq!((summary.steps, summary.frames), (0, 1));
}

#[test]
fn zero_duration_writes_the_initial_state() {
    let cfg = config(0.1, 0.0, 10.0);
    let (frames, summary) =
        run_to_frames(&mut Fake::new(1, 0.1), &cfg, 2, |_, _| {}).expect("runs");
    assert_eq!((summary.steps, frames.frame_times.len()), (0, 1));
}

#[test]
fn step_and_frame_counts_survive_rounding() {
    assert_eq!(total_steps(&config(1.0 / 30.0, 2.0, 30.0)), 60);
    assert_eq!(total_steps(&config(0.1, 0.3, 30.0)), 3);
    assert_eq!(total_steps(&config(0.1, 0.25, 30.0)), 3);
    assert_eq!(frame_times(&config(0.1, 0.3, 10.0)).len(), 4);
    assert_eq!(frame_times(&config(0.1, 0.29, 10.0)).len(), 3);
}
