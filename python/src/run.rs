//! `scene.run()`: the run driver of `superhelix run` (`run_streaming`: the same steps,
//! frame times and centrelines) with every frame kept in memory, as numpy arrays.

use crate::arrays::{f64_array, i64_array};
use crate::energy::EnergyMeter;
use crate::errors::run_error;
use crate::scene::{engine_name, Scene};
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};
use superhelix_runtime::forces::internal_loads::{InternalLoads, Momenta};
use superhelix_runtime::output::nodes::NodeSampler;
use superhelix_runtime::output::{
    frame_layout, run_streaming, ErrorControlSummary, FrameLayout, FrameSink, FrameSteps,
    FrameView, RunSummary, StopReason, StrandSteps,
};
use superhelix_runtime::{FrameSource, Result, Simulation, SimulationSetup, StepStats};

/// How often a run looks for Ctrl-C (it takes the GIL for it).
pub const SIGNAL_CHECK: Duration = Duration::from_millis(100);

/// What `scene.run` was asked besides the scene.
pub struct RunOptions {
    /// Measure each frame's energies after the run.
    pub energies: bool,
    /// Record each frame's directors, velocities and internal loads.
    pub mechanics: bool,
}

/// One strand at one frame: its directors and velocities at the frame's points (flat)
/// and its internal loads.
type StrandMechanics = (Vec<f64>, Vec<f64>, InternalLoads);

/// What `scene.run(mechanics=True)` records per frame, and the momenta it keeps for the
/// inertia of the internal loads.
struct Mechanics {
    /// Points per element (the frames' `samples_per_element`).
    per: usize,
    /// Per strand, the momenta before the last two steps.
    earlier: Vec<Vec<Momenta>>,
    /// Per frame: per strand its directors, velocities and internal loads.
    frames: Vec<Vec<StrandMechanics>>,
    /// The first refusal of the internal loads.
    error: Option<superhelix_runtime::Error>,
}

impl Mechanics {
    fn keep_momenta(&mut self, sim: &Simulation) {
        sim.keep_momenta(&mut self.earlier);
    }

    fn record(&mut self, sim: &Simulation) {
        let mut frame = Vec::new();
        for i in 0..FrameSource::strand_count(sim) {
            let arcs = sim.centreline_arcs(i, self.per);
            let directors = crate::simulation::directors_at(sim, i, &arcs);
            let velocities = crate::simulation::velocities_at(sim, i, &arcs);
            let earlier = self.earlier.get(i).map_or(&[][..], Vec::as_slice);
            match sim.internal_loads(i, earlier) {
                Ok(loads) => frame.push((directors, velocities, loads)),
                Err(e) => {
                    self.error.get_or_insert(e);
                    return;
                }
            }
        }
        self.frames.push(frame);
    }
}

/// The simulation as the driver sees it, recording q̇ with every frame written.
///
/// The driver builds a frame from the centrelines and q of every strand and then asks
/// `frame_steps` exactly once per frame written (`FrameSource::frame_steps`), so q̇ is
/// taken there: from the state the frame records.
struct Recording<'a> {
    sim: &'a mut Simulation,
    qdot: Vec<f64>,
    mechanics: Option<Mechanics>,
}

impl FrameSource for Recording<'_> {
    fn time(&self) -> f64 {
        FrameSource::time(&*self.sim)
    }
    fn strand_count(&self) -> usize {
        FrameSource::strand_count(&*self.sim)
    }
    fn strand_name(&self, i: usize) -> &str {
        FrameSource::strand_name(&*self.sim, i)
    }
    fn strand_group(&self, i: usize) -> &str {
        FrameSource::strand_group(&*self.sim, i)
    }
    fn strand_radius(&self, i: usize) -> f64 {
        FrameSource::strand_radius(&*self.sim, i)
    }
    fn q(&self, i: usize) -> &[f64] {
        FrameSource::q(&*self.sim, i)
    }
    fn v(&self, i: usize) -> &[f64] {
        FrameSource::v(&*self.sim, i)
    }
    fn centreline_world(&mut self, i: usize, samples_per_element: usize) -> Vec<[f64; 3]> {
        FrameSource::centreline_world(self.sim, i, samples_per_element)
    }
    fn step(&mut self) -> Result<()> {
        if let Some(m) = self.mechanics.as_mut() {
            m.keep_momenta(self.sim);
        }
        FrameSource::step(self.sim)
    }
    fn step_by(&mut self, h: f64) -> Result<()> {
        if let Some(m) = self.mechanics.as_mut() {
            m.keep_momenta(self.sim);
        }
        FrameSource::step_by(self.sim, h)
    }
    fn speed(&self, i: usize) -> f64 {
        FrameSource::speed(&*self.sim, i)
    }
    fn has_held_tip(&self, i: usize) -> bool {
        FrameSource::has_held_tip(&*self.sim, i)
    }
    fn held_ends(&mut self, out: &mut Vec<superhelix_runtime::output::HeldEndFrame>) {
        FrameSource::held_ends(self.sim, out)
    }
    fn solve_static(&mut self) -> Result<()> {
        FrameSource::solve_static(self.sim)
    }
    fn deepest_inside(&mut self) -> Option<f64> {
        FrameSource::deepest_inside(self.sim)
    }
    fn error_control(&self) -> Option<ErrorControlSummary> {
        FrameSource::error_control(&*self.sim)
    }
    fn coulomb_updates(&self) -> Option<superhelix_runtime::output::CoulombUpdates> {
        FrameSource::coulomb_updates(&*self.sim)
    }
    fn frame_steps(&mut self) -> Option<FrameSteps> {
        for i in 0..FrameSource::strand_count(&*self.sim) {
            self.qdot.extend_from_slice(FrameSource::v(&*self.sim, i));
        }
        if let Some(m) = self.mechanics.as_mut() {
            m.record(self.sim);
        }
        FrameSource::frame_steps(self.sim)
    }
    fn strand_steps(&self) -> Option<Vec<StrandSteps>> {
        FrameSource::strand_steps(&*self.sim)
    }
}

/// Every frame handed over, flat.
#[derive(Default)]
struct Collect {
    times: Vec<f64>,
    state_times: Vec<f64>,
    points: Vec<f64>,
    q: Vec<f64>,
    steps: Vec<Option<FrameSteps>>,
    /// Per held tip: drift, force, torque (7 numbers), frame-major.
    held: Vec<f64>,
    /// With `[output] nodes`: the sampler, and its nodes and directors, frame-major.
    sampler: Option<NodeSampler>,
    arc_nodes: Vec<f64>,
    d1: Vec<f64>,
}

impl FrameSink for Collect {
    fn write_frame(&mut self, frame: &FrameView<'_>) -> Result<()> {
        self.times.push(frame.time);
        self.state_times.push(frame.state_time);
        self.points.extend(frame.points.iter().flatten());
        self.q.extend_from_slice(frame.q);
        self.steps.push(frame.steps);
        for h in frame.held {
            self.held.push(h.drift);
            self.held.extend_from_slice(&h.reaction);
        }
        if let Some(sampler) = self.sampler.as_mut() {
            sampler.sample(frame, &mut self.arc_nodes, &mut self.d1)?;
        }
        Ok(())
    }
    fn finish(&mut self) -> Result<()> {
        Ok(())
    }
}

/// Each frame's (kinetic, potential) energies per strand, or why they could not be had.
type Measured = std::result::Result<(Vec<f64>, Vec<f64>), String>;

/// What a run produced, before it becomes Python objects.
struct Produced {
    layout: FrameLayout,
    frames: Collect,
    qdot: Vec<f64>,
    summary: RunSummary,
    planned_frames: usize,
    time: f64,
    stop: StopReason,
    stats: StepStats,
    strand_steps: Option<Vec<StrandSteps>>,
    energies: Option<Measured>,
    engine: &'static str,
    mechanics: Option<Mechanics>,
}

/// Hands every field of [`RunResult`] to the macro `$m` (pickle writes and reads them
/// by these names).
macro_rules! run_result_fields {
    ($m:ident) => {
        $m!(
            times,
            state_times,
            points,
            offsets,
            nodes,
            q,
            qdot,
            kinetic_energy,
            potential_energy,
            energy,
            strand_names,
            groups,
            radii,
            stats,
            summary,
            summary_line,
            frame_steps,
            strand_steps,
            held,
            held_tips,
            arc_nodes,
            d1,
            mechanics,
            engine,
            completed
        )
    };
}

/// The result of `scene.run()`: every frame of the run as numpy arrays (SI units), and
/// what the steps did.
///
/// Arrays by frame k (frame times k / output_fps), strand i (scene order), centreline
/// point j (the root, then samples_per_element points per element) and coordinate c
/// ((τ, κ1, κ2) per element from the root):
///
/// - points: (frames, total points, 3), every strand's centreline concatenated, world
///   coordinates, m: what frames.npy holds (in float32 there); strand i is
///   points[:, offsets[i]:offsets[i + 1]]
/// - nodes: (frames, strands, points, 3) when every strand has as many points, else a
///   list of (frames, points_i, 3) arrays
/// - q, qdot: (frames, strands, 3N) when every strand has the same N, else lists of
///   (frames, 3N_i) arrays; rad/m and rad/(m s)
/// - times: nominal frame times (s); state_times: the simulated time of each state
/// - kinetic_energy, potential_energy, energy: (frames, strands), J (None when run with
///   energies=False)
#[pyclass(module = "superhelix", frozen, get_all)]
pub struct RunResult {
    /// Nominal frame times k / output_fps, s: shape (frames,).
    times: Py<PyAny>,
    /// Simulated time of the state each frame records, s: shape (frames,).
    state_times: Py<PyAny>,
    /// Every strand's centreline, concatenated in strand order, world coordinates, m:
    /// shape (frames, total points, 3) (frames.npy holds these in float32).
    points: Py<PyAny>,
    /// Where each strand's points start in `points` (and ends): shape (strands + 1,).
    offsets: Py<PyAny>,
    /// The centrelines by strand: (frames, strands, points, 3) when all strands have as
    /// many points, else a list of (frames, points_i, 3) arrays.
    nodes: Py<PyAny>,
    /// Generalized coordinates (τ, κ1, κ2 per element, rad/m): (frames, strands, 3N) when
    /// all strands share N, else a list of (frames, 3N_i) arrays.
    q: Py<PyAny>,
    /// Generalized velocities, rad/(m s), laid out as `q`.
    qdot: Py<PyAny>,
    /// Kinetic energy ½ q̇ᵀ M q̇ relative to the head of each strand at each frame, J:
    /// (frames, strands); None when run with energies=False.
    kinetic_energy: Py<PyAny>,
    /// Potential energy of each strand at each frame, J: elastic plus gravity plus point
    /// loads (contacts and electrostatics excluded): (frames, strands); None when run
    /// with energies=False.
    potential_energy: Py<PyAny>,
    /// kinetic_energy + potential_energy, J: (frames, strands); None when run with
    /// energies=False. Conserved up to damping only with a still head.
    energy: Py<PyAny>,
    /// Strand names, in scene order.
    strand_names: Vec<String>,
    /// Strand groups (a patch's name, else the strand's group), in scene order.
    groups: Vec<String>,
    /// Display radius of each strand, m (as in frames.index.json).
    radii: Py<PyAny>,
    /// The solver's counters summed over strands and steps (the runtime's StepStats):
    /// attempts (implicit solves), substeps (steps split), energy_rejected,
    /// energy_limited, energy_unbalanced, energy_pulled_back, rotation_limited, stiffness_dropped,
    /// newton_iterations, newton_unconverged, contacts_predicted, error_steps,
    /// error_rejected, pairs_indefinite, pairs_unresolved (hair–hair pairs of
    /// `coupling = "pair"` left without force: indefinite compliance, unresolved sweeps).
    stats: Py<PyAny>,
    /// The run's summary (the runtime's RunSummary): mode, steps, strands, frames,
    /// planned_frames, wall_time (s, stepping only), strand_steps_per_second, max_speed,
    /// deepest_inside (m, None without contacts), time (s reached), engine, completed,
    /// error_control (with a tolerance: tolerance, largest_error, smallest_step,
    /// smallest_step_strand, steps, rejected; else None), coulomb (with
    /// `[electrostatics]`: updates, seconds of the Coulomb forces' evaluations; else None).
    summary: Py<PyAny>,
    /// The summary line `superhelix run` prints.
    summary_line: String,
    /// With a tolerance: per frame, the error-controlled steps since the previous frame,
    /// shape (frames, 5): largest error / L, steps, rejected, smallest step (s), largest
    /// step (s), as frames.steps.npy. None with fixed steps.
    frame_steps: Py<PyAny>,
    /// With a tolerance: per strand over the run, shape (strands, 5): steps, rejected,
    /// largest error / L, smallest step (s), largest step (s), as strand_steps.npy. None
    /// with fixed steps.
    strand_steps: Py<PyAny>,
    /// With held tips (`[strands.ends.tip]`): per frame and held tip, shape (frames, held
    /// tips, 7): the largest drift of the tip from its holder since the previous frame (over
    /// L, or radians for frames), then the holder's force (N) and torque (N m) on the tip,
    /// world coordinates, as frames.held.npy. None without held tips.
    held: Py<PyAny>,
    /// The strands whose tip is held (indices in scene order): the rows of `held`.
    held_tips: Vec<usize>,
    /// With `[output] nodes = K`: every strand at K evenly spaced arc lengths, root to tip,
    /// world coordinates, m: shape (frames, strands, K, 3), as frames.nodes.npy. None
    /// otherwise.
    arc_nodes: Py<PyAny>,
    /// With `[output] nodes = K`: each strand's d1 director at the middle of each of the
    /// K − 1 segments between its nodes, world coordinates: shape (frames, strands, K − 1,
    /// 3), as frames.d1.npy. None otherwise.
    d1: Py<PyAny>,
    /// With `scene.run(mechanics=True)`: per frame, a dict of `directors` and
    /// `velocities` at the points of `nodes` (as `Simulation.directors()` and
    /// `velocities()` give them) and `internal_loads` (a dict per strand, as
    /// `Simulation.internal_loads()`, the inertia counted from the steps before the
    /// frame). None otherwise.
    mechanics: Py<PyAny>,
    /// The engine that stepped the strands: "embedded" or "runtime".
    engine: String,
    /// Whether every planned frame was computed (False on the `result` of a
    /// SimulationError or KeyboardInterrupt).
    completed: bool,
}

#[pymethods]
impl RunResult {
    /// Number of frames.
    #[getter]
    fn frame_count(&self, py: Python<'_>) -> PyResult<usize> {
        self.times.bind(py).len()
    }

    /// pickle: every field, by name (`RunResult._from_fields` builds it again).
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyDict>,))> {
        let d = PyDict::new(py);
        macro_rules! put {
            ($($f:ident),*) => { $( d.set_item(stringify!($f), &self.$f)?; )* };
        }
        run_result_fields!(put);
        let from_fields = py.get_type::<RunResult>().getattr("_from_fields")?;
        Ok((from_fields, (d,)))
    }

    /// RunResult._from_fields(d): the result whose fields `d` holds (pickle's inverse of
    /// `__reduce__`; a missing field raises KeyError naming it).
    #[staticmethod]
    fn _from_fields(d: &Bound<'_, PyDict>) -> PyResult<RunResult> {
        let get = |key: &str| -> PyResult<Bound<'_, PyAny>> {
            d.get_item(key)?
                .ok_or_else(|| pyo3::exceptions::PyKeyError::new_err(key.to_string()))
        };
        macro_rules! build {
            ($($f:ident),*) => { RunResult { $( $f: get(stringify!($f))?.extract()?, )* } };
        }
        Ok(run_result_fields!(build))
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        let frames = self.times.bind(py).len().unwrap_or(0);
        format!(
            "<superhelix.RunResult: {} strand{}, {frames} frames{}>",
            self.strand_names.len(),
            if self.strand_names.len() == 1 {
                ""
            } else {
                "s"
            },
            if self.completed {
                ""
            } else {
                " (stopped early)"
            }
        )
    }
}

/// Steps `setup` as `superhelix run` does, every frame kept; raises as documented on
/// `Scene.run`.
pub fn run_scene(
    py: Python<'_>,
    setup: SimulationSetup,
    options: &RunOptions,
) -> PyResult<RunResult> {
    let config = setup.config.clone();
    let samples = setup.samples_per_element;
    let mut sim = Scene::build(py, setup.clone())?;
    if options.mechanics && FrameSource::strand_count(&sim) > 0 {
        // refused before the run: a scene whose forces the balance cannot place
        sim.internal_loads(0, &[])
            .map_err(crate::errors::input_error)?;
    }
    let stop = AtomicBool::new(false);
    let interrupt: Mutex<Option<PyErr>> = Mutex::new(None);
    let produced = py.detach(|| {
        let engine = engine_name(sim.engine());
        let layout = frame_layout(&sim, &config, samples);
        let mut frames = Collect::default();
        if let Some(count) = setup.output.nodes {
            let strands: Vec<_> = setup.strands.iter().map(|s| &s.strand).collect();
            // (the scene's check allows the count)
            frames.sampler = NodeSampler::new(&strands, &setup.head, count).ok();
        }
        let mut source = Recording {
            sim: &mut sim,
            qdot: Vec::new(),
            mechanics: options.mechanics.then(|| Mechanics {
                per: samples,
                earlier: Vec::new(),
                frames: Vec::new(),
                error: None,
            }),
        };
        let mut checked = Instant::now();
        let outcome = run_streaming(
            &mut source,
            &config,
            samples,
            &mut [&mut frames],
            &stop,
            |_, _| {
                if checked.elapsed() < SIGNAL_CHECK {
                    return;
                }
                checked = Instant::now();
                Python::attach(|py| {
                    if let Err(e) = py.check_signals() {
                        if let Ok(mut slot) = interrupt.lock() {
                            slot.get_or_insert(e);
                        }
                        stop.store(true, Ordering::SeqCst);
                    }
                });
            },
        );
        let qdot = std::mem::take(&mut source.qdot);
        let mechanics = source.mechanics.take();
        let stats = sim.stats();
        let strand_steps = FrameSource::strand_steps(&sim);
        let energies = options.energies.then(|| {
            let mut meter = EnergyMeter::new(&setup);
            measure_energies(&mut sim, &mut meter, &layout, &frames.q, &qdot)
        });
        Produced {
            layout,
            frames,
            qdot,
            summary: outcome.summary,
            planned_frames: outcome.planned_frames,
            time: outcome.time,
            stop: outcome.stop,
            stats,
            strand_steps,
            energies,
            engine,
            mechanics,
        }
    });
    let mut produced = produced;
    let interrupted = interrupt.into_inner().ok().flatten();
    let stop = std::mem::replace(&mut produced.stop, StopReason::Completed);
    let completed = matches!(stop, StopReason::Completed);
    let result = to_python(py, produced, completed)?;
    let err = match stop {
        StopReason::Completed => return Ok(result),
        // the frames are in memory: the only failures are the steps'
        StopReason::Failed(e) => run_error(e),
        StopReason::Interrupted => {
            interrupted.unwrap_or_else(|| PyKeyboardInterrupt::new_err("the run was stopped"))
        }
    };
    let result = Py::new(py, result)?;
    let _ = err.value(py).setattr("result", result);
    Err(err)
}

/// Each frame's (kinetic, potential) energy per strand, frame-major, from the recorded
/// states (see [`EnergyMeter`]; the run is over: `sim` may be set to each state).
fn measure_energies(
    sim: &mut Simulation,
    meter: &mut EnergyMeter,
    layout: &FrameLayout,
    q: &[f64],
    qdot: &[f64],
) -> Measured {
    let offsets = layout.coordinate_offsets();
    let total = layout.total_coordinates();
    let strands = layout.strands.len();
    let frames = match (q.len().checked_div(total), qdot.len().checked_div(total)) {
        (Some(a), Some(b)) => a.min(b),
        _ => 0,
    };
    let mut kinetic = Vec::with_capacity(frames * strands);
    let mut potential = Vec::with_capacity(frames * strands);
    for k in 0..frames {
        for i in 0..strands {
            let range = k * total + offsets[i]..k * total + offsets[i + 1];
            let (t, v) = meter.measure(sim, i, Some((&q[range.clone()], &qdot[range])))?;
            kinetic.push(t);
            potential.push(v);
        }
    }
    Ok((kinetic, potential))
}

fn to_python(py: Python<'_>, p: Produced, completed: bool) -> PyResult<RunResult> {
    let frames = p.frames.times.len();
    let layout = &p.layout;
    let strands = layout.strands.len();
    let total_points = layout.total_points();
    let point_offsets = layout.point_offsets();
    let q_offsets = layout.coordinate_offsets();
    let total_q = layout.total_coordinates();
    let points_per: Vec<usize> = layout.strands.iter().map(|s| s.points).collect();
    let q_per: Vec<usize> = layout.strands.iter().map(|s| s.coordinates).collect();
    let shared = |v: &[usize]| v.first().filter(|&&n| v.iter().all(|&m| m == n)).copied();

    let nodes = match shared(&points_per) {
        Some(n) => f64_array(py, &[frames, strands, n, 3], p.frames.points.clone())?,
        None => per_strand(
            py,
            &p.frames.points,
            frames,
            total_points * 3,
            &point_offsets,
            3,
        )?,
    };
    let by_strand = |values: &[f64]| -> PyResult<Py<PyAny>> {
        match shared(&q_per) {
            Some(n) => f64_array(py, &[frames, strands, n], values.to_vec()),
            None => per_strand(py, values, frames, total_q, &q_offsets, 1),
        }
    };
    let q = by_strand(&p.frames.q)?;
    let qdot = by_strand(&p.qdot[..p.qdot.len().min(frames * total_q)])?;
    let points = f64_array(py, &[frames, total_points, 3], p.frames.points)?;
    let offsets = i64_array(
        py,
        &[strands + 1],
        point_offsets.iter().map(|&o| o as i64).collect(),
    )?;
    let (kinetic_energy, potential_energy, energy) = match p.energies.transpose() {
        Err(e) => return Err(PyRuntimeError::new_err(e)),
        Ok(Some((kinetic, potential))) => {
            let sum: Vec<f64> = kinetic.iter().zip(&potential).map(|(a, b)| a + b).collect();
            let rows = kinetic.len() / strands.max(1);
            (
                f64_array(py, &[rows, strands], kinetic)?,
                f64_array(py, &[rows, strands], potential)?,
                f64_array(py, &[rows, strands], sum)?,
            )
        }
        Ok(None) => (py.None(), py.None(), py.None()),
    };
    let frame_steps = if p.frames.steps.iter().any(Option::is_some) {
        let rows: Vec<f64> = p
            .frames
            .steps
            .iter()
            .flat_map(|s| {
                let s = s.unwrap_or_default();
                [
                    s.largest_error,
                    s.steps as f64,
                    s.rejected as f64,
                    s.smallest_step,
                    s.largest_step,
                ]
            })
            .collect();
        f64_array(py, &[frames, 5], rows)?
    } else {
        py.None()
    };
    let strand_steps = match &p.strand_steps {
        Some(rows) => f64_array(
            py,
            &[rows.len(), 5],
            rows.iter()
                .flat_map(|s| {
                    [
                        s.steps as f64,
                        s.rejected as f64,
                        s.largest_error,
                        s.smallest_step,
                        s.largest_step,
                    ]
                })
                .collect(),
        )?,
        None => py.None(),
    };
    let held_count = layout.held_tips.len();
    let held = if held_count > 0 {
        let rows = p.frames.held.len() / (7 * held_count);
        f64_array(py, &[rows, held_count, 7], p.frames.held)?
    } else {
        py.None()
    };
    let (arc_nodes, d1) = match &p.frames.sampler {
        Some(sampler) => {
            let k = sampler.count();
            (
                f64_array(py, &[frames, strands, k, 3], p.frames.arc_nodes)?,
                f64_array(py, &[frames, strands, k - 1, 3], p.frames.d1)?,
            )
        }
        None => (py.None(), py.None()),
    };
    let summary = summary_dict(
        py,
        &p.summary,
        p.planned_frames,
        p.time,
        p.engine,
        completed,
    )?;
    let mechanics = match p.mechanics {
        None => py.None(),
        Some(m) => {
            if let Some(e) = m.error {
                return Err(crate::errors::input_error(e));
            }
            let list = PyList::empty(py);
            for frame in m.frames {
                let (mut directors, mut velocities, loads) =
                    (Vec::new(), Vec::new(), PyList::empty(py));
                for (d, v, l) in frame {
                    directors.push(d);
                    velocities.push(v);
                    loads.append(crate::simulation::loads_dict(py, &l)?)?;
                }
                let d = PyDict::new(py);
                d.set_item(
                    "directors",
                    crate::simulation::stacked(py, directors, &[3, 3])?,
                )?;
                d.set_item(
                    "velocities",
                    crate::simulation::stacked(py, velocities, &[3])?,
                )?;
                d.set_item("internal_loads", loads)?;
                list.append(d)?;
            }
            list.into_any().unbind()
        }
    };
    Ok(RunResult {
        times: f64_array(py, &[frames], p.frames.times)?,
        state_times: f64_array(py, &[frames], p.frames.state_times)?,
        points,
        offsets,
        nodes,
        q,
        qdot,
        kinetic_energy,
        potential_energy,
        energy,
        strand_names: layout.strands.iter().map(|s| s.name.clone()).collect(),
        groups: layout.strands.iter().map(|s| s.group.clone()).collect(),
        radii: f64_array(
            py,
            &[strands],
            layout.strands.iter().map(|s| s.radius).collect(),
        )?,
        stats: stats_dict(py, &p.stats)?.into_any().unbind(),
        summary: summary.into_any().unbind(),
        summary_line: p.summary.to_string(),
        frame_steps,
        strand_steps,
        held,
        held_tips: layout.held_tips.clone(),
        arc_nodes,
        d1,
        mechanics,
        engine: p.engine.to_string(),
        completed,
    })
}

/// A list of per-strand arrays (frames, width_i) or (frames, width_i / 3, 3) from
/// frame-major rows of `row` values, strand i at `offsets[i] * unit..offsets[i + 1] * unit`.
fn per_strand(
    py: Python<'_>,
    values: &[f64],
    frames: usize,
    row: usize,
    offsets: &[usize],
    unit: usize,
) -> PyResult<Py<PyAny>> {
    let list = PyList::empty(py);
    for w in offsets.windows(2) {
        let (a, b) = (w[0] * unit, w[1] * unit);
        let mut data = Vec::with_capacity(frames * (b - a));
        for k in 0..frames {
            data.extend_from_slice(&values[k * row + a..k * row + b]);
        }
        let shape = if unit == 3 {
            vec![frames, w[1] - w[0], 3]
        } else {
            vec![frames, b - a]
        };
        list.append(f64_array(py, &shape, data)?)?;
    }
    Ok(list.into_any().unbind())
}

/// The runtime's StepStats as a dict.
pub fn stats_dict<'py>(py: Python<'py>, s: &StepStats) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("attempts", s.attempts)?;
    d.set_item("substeps", s.substeps)?;
    d.set_item("energy_rejected", s.energy_rejected)?;
    d.set_item("energy_limited", s.energy_limited)?;
    d.set_item("energy_unbalanced", s.energy_unbalanced)?;
    d.set_item("energy_pulled_back", s.energy_pulled_back)?;
    d.set_item("rotation_limited", s.rotation_limited)?;
    d.set_item("stiffness_dropped", s.stiffness_dropped)?;
    d.set_item("newton_iterations", s.newton_iterations)?;
    d.set_item("newton_unconverged", s.newton_unconverged)?;
    d.set_item("contacts_predicted", s.contacts_predicted)?;
    d.set_item("error_steps", s.error_steps)?;
    d.set_item("error_rejected", s.error_rejected)?;
    d.set_item("pairs_indefinite", s.pairs_indefinite)?;
    d.set_item("pairs_unresolved", s.pairs_unresolved)?;
    Ok(d)
}

/// The error-controlled step's summary as a dict.
pub fn error_control_dict<'py>(
    py: Python<'py>,
    e: &ErrorControlSummary,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("tolerance", e.tolerance)?;
    d.set_item("largest_error", e.largest_error)?;
    d.set_item("smallest_step", e.smallest_step)?;
    d.set_item("smallest_step_strand", e.smallest_step_strand)?;
    d.set_item("steps", e.steps)?;
    d.set_item("rejected", e.rejected)?;
    d.set_item("rejected_deep", e.rejected_deep)?;
    Ok(d)
}

fn summary_dict<'py>(
    py: Python<'py>,
    s: &RunSummary,
    planned_frames: usize,
    time: f64,
    engine: &str,
    completed: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let mode = match s.mode {
        superhelix_runtime::Mode::Static => "static",
        superhelix_runtime::Mode::Dynamic => "dynamic",
    };
    d.set_item("mode", mode)?;
    d.set_item("steps", s.steps)?;
    d.set_item("strands", s.strands)?;
    d.set_item("frames", s.frames)?;
    d.set_item("planned_frames", planned_frames)?;
    d.set_item("wall_time", s.wall_time.as_secs_f64())?;
    d.set_item("strand_steps_per_second", s.strand_steps_per_second())?;
    d.set_item("max_speed", s.max_speed)?;
    d.set_item("deepest_inside", s.deepest_inside)?;
    d.set_item("time", time)?;
    d.set_item("engine", engine)?;
    d.set_item("completed", completed)?;
    match &s.error_control {
        Some(e) => d.set_item("error_control", error_control_dict(py, e)?)?,
        None => d.set_item("error_control", py.None())?,
    }
    match &s.coulomb {
        Some(c) => {
            let e = PyDict::new(py);
            e.set_item("updates", c.updates)?;
            e.set_item("seconds", c.seconds)?;
            d.set_item("coulomb", e)?;
        }
        None => d.set_item("coulomb", py.None())?,
    }
    Ok(d)
}
