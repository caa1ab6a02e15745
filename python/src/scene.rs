//! `superhelix.Scene`: a scene read from TOML text, a file or a dict, checked as the
//! command line checks it, and run or stepped.

use crate::convert::dict_to_toml;
use crate::errors::{build_error, io_error, scene_error};
use crate::run::{run_scene, RunOptions, RunResult};
use crate::simulation::Simulation as PySimulation;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};
use superhelix_runtime::config::{Engine, Mode};
use superhelix_runtime::groom::GroomReport;
use superhelix_runtime::output::plan::setup_layout;
use superhelix_runtime::output::{frame_times, total_steps, OutputPlan};
use superhelix_runtime::scene::{MAX_DT, MAX_FRAMES, MAX_STEPS};
use superhelix_runtime::{
    engine_for, parse_scene_reporting, validate_scene_at, KernelFactory, Simulation,
    SimulationSetup,
};

/// The scene `superhelix run` simulates without a scene file (`src/default_scene.toml`).
const DEFAULT_SCENE: &str = include_str!("../../src/default_scene.toml");

/// The generated kernels of this build, as the command line uses them.
pub fn kernels() -> Option<&'static dyn KernelFactory> {
    Some(superhelix_runtime::kernels::closed_form::kernel_factory())
}

/// A Super-Helix scene: strands, head motion, environment, bodies, contacts and run
/// settings, read and checked as `superhelix run` reads them (docs/scene-format.md).
///
/// Make one with `Scene.from_toml(text)`, `Scene.from_file(path)`, `Scene.from_dict(d)`
/// or `Scene.default()`; a scene the runtime refuses raises `SceneError`. Then
/// `scene.validate()` (the checks of `superhelix validate`), `scene.run()` (every frame
/// as numpy arrays) or `scene.simulation()` (step it yourself).
#[pyclass(module = "superhelix", frozen)]
pub struct Scene {
    text: String,
    dir: PathBuf,
    setup: SimulationSetup,
    grooms: Vec<GroomReport>,
}

impl Scene {
    /// Parse `text` with relative file paths resolved against `dir`; a refused scene
    /// lists every problem `superhelix validate` would (the same text).
    pub(crate) fn parse(py: Python<'_>, text: String, dir: PathBuf) -> PyResult<Scene> {
        let parsed = py.detach(|| match parse_scene_reporting(&text, &dir) {
            Ok(parsed) => Ok(parsed),
            // the failure path lists every problem, as `superhelix validate` does
            Err(e) => Err((e, validate_scene_at(&text, &dir, kernels()))),
        });
        match parsed {
            Ok((setup, grooms)) => Ok(Scene {
                text,
                dir,
                setup,
                grooms,
            }),
            Err((e, problems)) if problems.is_empty() => Err(build_error(py, e)),
            Err((_, problems)) => Err(scene_error(py, &problems)),
        }
    }

    /// The parsed setup.
    pub fn setup(&self) -> &SimulationSetup {
        &self.setup
    }

    /// The setup with the run's overrides applied and checked.
    pub(crate) fn setup_with(&self, o: &Overrides) -> PyResult<SimulationSetup> {
        let mut setup = self.setup.clone();
        let c = &mut setup.config;
        if let Some(dt) = o.dt {
            if !(dt.is_finite() && dt > 0.0 && dt <= MAX_DT) {
                return Err(PyValueError::new_err(format!(
                    "dt: must be in (0, {MAX_DT}] s, got {dt}"
                )));
            }
            c.dt = dt;
        }
        if let Some(duration) = o.duration {
            if !(duration.is_finite() && duration >= 0.0) {
                return Err(PyValueError::new_err(format!(
                    "duration: must be finite and >= 0 s, got {duration}"
                )));
            }
            c.duration = duration;
        }
        if let Some(frames) = o.frames {
            if frames == 0 || frames as f64 > MAX_FRAMES {
                return Err(PyValueError::new_err(format!(
                    "frames: must be in [1, {MAX_FRAMES:.0}], got {frames}"
                )));
            }
            // frame k is at k / output_fps: F frames end at (F - 1) / output_fps
            c.duration = (frames - 1) as f64 / c.output_fps;
        }
        if let Some(tolerance) = o.tolerance {
            // 0 turns a scene's tolerance off, as for Batch.set_tolerance
            c.tolerance = (tolerance != 0.0).then_some(tolerance);
        }
        if c.mode == Mode::Dynamic && c.duration / c.dt > MAX_STEPS {
            return Err(PyValueError::new_err(format!(
                "duration / dt = {:.0} steps, more than the cap of {MAX_STEPS:.0}",
                c.duration / c.dt
            )));
        }
        if c.mode == Mode::Dynamic && c.duration * c.output_fps > MAX_FRAMES {
            return Err(PyValueError::new_err(format!(
                "duration * output_fps = {:.0} frames, more than the cap of {MAX_FRAMES:.0}",
                c.duration * c.output_fps
            )));
        }
        Ok(setup)
    }

    /// A simulation of `setup` with this build's kernels; a refusal is a `SceneError`.
    pub fn build(py: Python<'_>, setup: SimulationSetup) -> PyResult<Simulation> {
        py.detach(|| Simulation::new(setup, kernels()))
            .map_err(|e| build_error(py, e))
    }
}

/// What `run` and `simulation` may change of a scene's `[simulation]`.
#[derive(Debug, Clone, Copy, Default)]
pub struct Overrides {
    pub dt: Option<f64>,
    pub duration: Option<f64>,
    pub frames: Option<usize>,
    pub tolerance: Option<f64>,
}

fn folder(base_dir: Option<PathBuf>) -> PathBuf {
    base_dir.unwrap_or_default()
}

#[pymethods]
impl Scene {
    /// Scene.from_toml(text, base_dir=None) -> Scene
    ///
    /// A scene from TOML text (docs/scene-format.md). Relative file paths in it (a mesh
    /// body's `path`, a groom's curves) are resolved against `base_dir` (default: the
    /// working directory). Raises SceneError listing every problem, as
    /// `superhelix validate` prints them.
    #[staticmethod]
    #[pyo3(signature = (text, base_dir = None))]
    fn from_toml(py: Python<'_>, text: String, base_dir: Option<PathBuf>) -> PyResult<Scene> {
        Scene::parse(py, text, folder(base_dir))
    }

    /// Scene.from_file(path) -> Scene
    ///
    /// A scene from a TOML file; relative file paths in it are resolved against the
    /// file's folder, as `superhelix run SCENE` does. Raises OSError when the file cannot
    /// be read and SceneError listing every problem of the scene.
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<Scene> {
        let text = std::fs::read_to_string(&path)
            .map_err(|e| io_error(&path.display().to_string(), &e))?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Scene::parse(py, text, dir)
    }

    /// Scene.from_dict(d, base_dir=None) -> Scene
    ///
    /// A scene from a dict laid out as the TOML file is (tables as dicts, arrays of
    /// tables as lists of dicts, e.g. {"simulation": {"dt": 1/30}, "strands": [{"length":
    /// 0.2}]}). The dict is written as TOML text (`scene.toml`) and read as
    /// `Scene.from_toml` reads it. Values: dict, list, tuple, bool, int, float, str and
    /// numpy arrays or scalars; None (or anything else) raises TypeError naming the key.
    #[staticmethod]
    #[pyo3(signature = (d, base_dir = None))]
    fn from_dict(
        py: Python<'_>,
        d: &Bound<'_, PyDict>,
        base_dir: Option<PathBuf>,
    ) -> PyResult<Scene> {
        let text = dict_to_toml(d)?;
        Scene::parse(py, text, folder(base_dir))
    }

    /// Scene.rod(*, length, radius, youngs_modulus, density, poisson, elements=10, ...) -> Scene
    ///
    /// A scene of one rod with mechanical defaults, for rod-mechanics studies: the
    /// material is given, never taken from a hair preset (length, radius, Young's
    /// modulus, density and Poisson's ratio are required; the cross-section is round
    /// unless `ellipticity` says otherwise); no internal friction, no air drag and no
    /// gravity unless given; straight at rest unless `natural` gives a (τ, κ1, κ2) for
    /// every element. The rod starts at `root` (default the origin) along `direction`
    /// (default +x) with `normal` its first director (default: the world axis least
    /// aligned with it); `root_end` is "clamped", "pinned" or "free", `tip` a dict as
    /// the scene's `[strands.ends.tip]` (e.g. {"kind": "pinned"}), `point_loads` a list
    /// of dicts as `[[strands.point_loads]]`. `dt`, `duration`, `integrator` and
    /// `engine` are the `[simulation]`'s. The text it builds is `scene.toml`; every other setting is the
    /// scene format's (docs/scene-format.md).
    #[staticmethod]
    #[pyo3(signature = (
        *, length, radius, youngs_modulus, density, poisson, elements = 10,
        ellipticity = 1.0, root = None, direction = None, normal = None, natural = None,
        root_end = "clamped", tip = None, point_loads = None, gravity = None,
        internal_friction = 0.0, air_drag = 0.0, dt = 1e-3, duration = 1.0,
        integrator = None, engine = None, name = "rod"
    ))]
    #[allow(clippy::too_many_arguments)]
    fn rod(
        py: Python<'_>,
        length: f64,
        radius: f64,
        youngs_modulus: f64,
        density: f64,
        poisson: f64,
        elements: usize,
        ellipticity: f64,
        root: Option<Bound<'_, PyAny>>,
        direction: Option<Bound<'_, PyAny>>,
        normal: Option<Bound<'_, PyAny>>,
        natural: Option<Bound<'_, PyAny>>,
        root_end: &str,
        tip: Option<Bound<'_, PyAny>>,
        point_loads: Option<Bound<'_, PyAny>>,
        gravity: Option<Bound<'_, PyAny>>,
        internal_friction: f64,
        air_drag: f64,
        dt: f64,
        duration: f64,
        integrator: Option<&str>,
        engine: Option<&str>,
        name: &str,
    ) -> PyResult<Scene> {
        let strand = PyDict::new(py);
        strand.set_item("name", name)?;
        strand.set_item("length", length)?;
        strand.set_item("elements", elements)?;
        strand.set_item("radius", radius)?;
        strand.set_item("ellipticity", ellipticity)?;
        strand.set_item("youngs_modulus", youngs_modulus)?;
        strand.set_item("density", density)?;
        strand.set_item("poisson", poisson)?;
        strand.set_item("internal_friction", internal_friction)?;
        strand.set_item("air_drag", air_drag)?;
        strand.set_item("initial", "natural")?;
        match natural {
            Some(n) => strand.set_item("natural", n)?,
            None => strand.set_item("natural", [0.0, 0.0, 0.0])?,
        }
        match root {
            Some(r) => strand.set_item("root", r)?,
            None => strand.set_item("root", [0.0, 0.0, 0.0])?,
        }
        match direction {
            Some(d) => strand.set_item("direction", d)?,
            None => strand.set_item("direction", [1.0, 0.0, 0.0])?,
        }
        if let Some(n) = normal {
            strand.set_item("normal", n)?;
        }
        if let Some(loads) = point_loads {
            strand.set_item("point_loads", loads)?;
        }
        let ends = PyDict::new(py);
        ends.set_item("root", root_end)?;
        if let Some(tip) = tip {
            ends.set_item("tip", tip)?;
        }
        strand.set_item("ends", ends)?;
        let simulation = PyDict::new(py);
        simulation.set_item("dt", dt)?;
        simulation.set_item("duration", duration)?;
        if let Some(integrator) = integrator {
            simulation.set_item("integrator", integrator)?;
        }
        if let Some(engine) = engine {
            simulation.set_item("engine", engine)?;
        }
        let environment = PyDict::new(py);
        match gravity {
            Some(g) if !g.is_none() => environment.set_item("gravity", g)?,
            _ => environment.set_item("gravity", "none")?,
        }
        let scene = PyDict::new(py);
        scene.set_item("simulation", simulation)?;
        scene.set_item("environment", environment)?;
        scene.set_item("strands", vec![strand])?;
        let text = dict_to_toml(&scene)?;
        Scene::parse(py, text, PathBuf::new())
    }

    /// Scene.default() -> Scene
    ///
    /// The scene `superhelix run` simulates without a scene file: a full head of 100 wavy
    /// guides (N = 6) groomed over an ellipsoidal head and started sag-free, touching the
    /// head, the neck, the shoulders and each other; still for 1 s, then a 45° turn each
    /// way, 3 s at dt = 1/30 s.
    #[staticmethod]
    fn default(py: Python<'_>) -> PyResult<Scene> {
        Scene::parse(py, DEFAULT_SCENE.to_string(), PathBuf::new())
    }

    /// The scene's TOML text (for a scene from a dict, the text it was written as).
    #[getter]
    fn toml(&self) -> &str {
        &self.text
    }

    /// pickle: a scene is its TOML text and the folder its relative paths are resolved
    /// against; unpickling reads them again (`Scene.from_toml(text, base_dir)`), as a
    /// process pool's worker would.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String, PathBuf))> {
        let from_toml = py.get_type::<Scene>().getattr("from_toml")?;
        Ok((from_toml, (self.text.clone(), self.dir.clone())))
    }

    /// Folder relative file paths of the scene are resolved against.
    #[getter]
    fn base_dir(&self) -> PathBuf {
        self.dir.clone()
    }

    /// Number of strands.
    #[getter]
    fn strand_count(&self) -> usize {
        self.setup.strands.len()
    }

    /// Strand names, in scene order.
    #[getter]
    fn strand_names(&self) -> Vec<String> {
        self.setup
            .strands
            .iter()
            .map(|s| s.strand.name.clone())
            .collect()
    }

    /// Number of elements N of each strand, in scene order.
    #[getter]
    fn elements(&self) -> Vec<usize> {
        self.setup
            .strands
            .iter()
            .map(|s| s.strand.geometry.elements())
            .collect()
    }

    /// The time step `[simulation] dt`, s.
    #[getter]
    fn dt(&self) -> f64 {
        self.setup.config.dt
    }

    /// The run's duration `[simulation] duration`, s.
    #[getter]
    fn duration(&self) -> f64 {
        self.setup.config.duration
    }

    /// Frames per second of the output `[simulation] output_fps`.
    #[getter]
    fn output_fps(&self) -> f64 {
        self.setup.config.output_fps
    }

    /// The error-controlled step's tolerance `[simulation] tolerance` (None: fixed steps).
    #[getter]
    fn tolerance(&self) -> Option<f64> {
        self.setup.config.tolerance
    }

    /// Centreline points per element in the frames `[output] samples_per_element`.
    #[getter]
    fn samples_per_element(&self) -> usize {
        self.setup.samples_per_element
    }

    /// Time steps a run takes (0 in static mode).
    #[getter]
    fn steps(&self) -> usize {
        total_steps(&self.setup.config)
    }

    /// Frames a run writes.
    #[getter]
    fn frame_count(&self) -> usize {
        frame_times(&self.setup.config).len()
    }

    /// The engine `run` steps the scene with: "embedded" (the fixed-N step) or "runtime"
    /// (what `engine = "auto"` resolves to; `validate()` says why).
    #[getter]
    fn engine(&self) -> &'static str {
        engine_name(engine_for(&self.setup).0)
    }

    /// What each `[[grooms]]` entry reports (fit errors, roots' spread, sag-free change),
    /// as `superhelix validate` and `run` print them.
    #[getter]
    fn groom_reports(&self) -> Vec<String> {
        self.grooms.iter().map(ToString::to_string).collect()
    }

    /// scene.validate() -> dict
    ///
    /// The checks of `superhelix validate SCENE`: the scene is read, its simulation built
    /// with this build's kernels (bodies, initial states, engine) and its output plan
    /// checked against the size limit. Raises SceneError with every problem (the same
    /// text `validate` prints on stderr, one `field: message` per line). On success a
    /// dict: strands, steps, engine ("embedded" or "runtime"), engine_reason (why not the
    /// embedded engine under engine = "auto", else None), output (the plan line `run`
    /// prints for --out out), grooms (the groom reports).
    fn validate<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let setup = self.setup.clone();
        let (dir, text) = (&self.dir, &self.text);
        let built = py.detach(|| match Simulation::new(setup, kernels()) {
            Ok(_) => Ok(()),
            Err(_) => Err(validate_scene_at(text, dir, kernels())),
        });
        if let Err(problems) = built {
            return Err(scene_error(py, &problems));
        }
        let plan = OutputPlan::new(
            &setup_layout(&self.setup),
            &self.setup.output,
            None,
            false,
            Path::new("out"),
        );
        if let Err(e) = plan.check_limit() {
            return Err(build_error(py, e));
        }
        let (engine, reason) = engine_for(&self.setup);
        let d = PyDict::new(py);
        d.set_item("strands", self.setup.strands.len())?;
        d.set_item("steps", total_steps(&self.setup.config))?;
        d.set_item("engine", engine_name(engine))?;
        d.set_item("engine_reason", reason.map(|r| r.to_string()))?;
        d.set_item("output", plan.to_string())?;
        d.set_item("grooms", self.groom_reports())?;
        Ok(d)
    }

    /// scene.run(*, duration=None, frames=None, tolerance=None, energies=True,
    ///           max_bytes=4e9) -> RunResult
    ///
    /// Simulate the scene as `superhelix run` does (the same steps, frame times and
    /// centrelines: `frames.npy` holds `result.points` rounded to float32) and return every
    /// frame as numpy arrays. `duration` (s) or `frames` (the run ends at frame
    /// frames - 1) replace `[simulation] duration`; `tolerance` replaces `[simulation]
    /// tolerance` as `run --tolerance` does (0: fixed steps). With `energies` each frame's
    /// kinetic and potential energy per strand is measured after the run. The GIL is
    /// released while it runs; Ctrl-C stops it between two steps (KeyboardInterrupt).
    /// The frames are kept in memory: a run whose arrays would take more than `max_bytes`
    /// (bytes, estimated before it starts) is refused with ValueError; raise it, or ask
    /// for fewer frames, or write files with `superhelix run`. Raises SceneError when the
    /// scene cannot be built and SimulationError when a step fails (its `result`
    /// attribute holds the frames computed before).
    ///
    /// With `mechanics=True` every frame also records each strand's directors and
    /// velocities at the points of `nodes` and its internal loads and reactions
    /// (`result.mechanics`, as `Simulation.directors()`, `velocities()` and
    /// `internal_loads()` give them), the inertia from the momenta kept before each step
    /// (about three reconstructions of each strand per step); refused (ValueError) for a
    /// scene with contacts or electrostatics.
    #[pyo3(signature = (
        *, duration = None, frames = None, tolerance = None, energies = true,
        max_bytes = 4e9, mechanics = false
    ))]
    #[allow(clippy::too_many_arguments)]
    fn run(
        &self,
        py: Python<'_>,
        duration: Option<f64>,
        frames: Option<usize>,
        tolerance: Option<f64>,
        energies: bool,
        max_bytes: f64,
        mechanics: bool,
    ) -> PyResult<RunResult> {
        if duration.is_some() && frames.is_some() {
            return Err(PyValueError::new_err(
                "duration, frames: give one of them (frames sets duration = (frames - 1) / output_fps)",
            ));
        }
        let setup = self.setup_with(&Overrides {
            duration,
            frames,
            tolerance,
            ..Default::default()
        })?;
        let bytes = memory_estimate(&setup, energies, mechanics);
        if max_bytes.is_nan() || bytes > max_bytes {
            return Err(PyValueError::new_err(format!(
                "max_bytes: the run's arrays would take about {:.3e} bytes in memory, more than max_bytes = {max_bytes:.3e}; pass a larger max_bytes, fewer frames (frames=, duration=, [simulation] output_fps, [output] samples_per_element) or write files with `superhelix run`",
                bytes
            )));
        }
        run_scene(
            py,
            setup,
            &RunOptions {
                energies,
                mechanics,
            },
        )
    }

    /// scene.simulation(*, dt=None, tolerance=None) -> Simulation
    ///
    /// The scene's simulation at t = 0, to step by hand (`sim.step()`). `dt` replaces
    /// `[simulation] dt` (every step of this simulation is that long), `tolerance` the
    /// scene's tolerance (0: fixed steps). Raises SceneError when it cannot be built.
    #[pyo3(signature = (*, dt = None, tolerance = None))]
    fn simulation(
        &self,
        py: Python<'_>,
        dt: Option<f64>,
        tolerance: Option<f64>,
    ) -> PyResult<PySimulation> {
        let setup = self.setup_with(&Overrides {
            dt,
            tolerance,
            ..Default::default()
        })?;
        let origin = crate::simulation::Origin {
            text: self.text.clone(),
            dir: self.dir.clone(),
            dt,
            tolerance,
        };
        PySimulation::new(py, setup, origin)
    }

    /// scene.head_pose(t) -> (position, rotation)
    ///
    /// The head's pose at time t (s) by the scene's `[head] motion`: its world position X
    /// (3,) and rotation R (3, 3), head to world (a head point y is at X + R y): where
    /// the bodies attached to the head are in a frame of time t.
    fn head_pose(&self, py: Python<'_>, t: f64) -> PyResult<(Py<PyAny>, Py<PyAny>)> {
        if !t.is_finite() {
            return Err(PyValueError::new_err(format!("t: must be finite, got {t}")));
        }
        pose(py, &self.setup.head.state(t))
    }

    fn __repr__(&self) -> String {
        format!(
            "<superhelix.Scene: {} strand{}, {} steps of {} s, {} frames, engine {}>",
            self.setup.strands.len(),
            if self.setup.strands.len() == 1 {
                ""
            } else {
                "s"
            },
            total_steps(&self.setup.config),
            self.setup.config.dt,
            frame_times(&self.setup.config).len(),
            self.engine()
        )
    }
}

/// Bytes the arrays of a run of `setup` take in memory (f64): every frame's points, q
/// and q̇ (held twice while they become numpy arrays), and the energies.
fn memory_estimate(setup: &SimulationSetup, energies: bool, mechanics: bool) -> f64 {
    let frames = frame_times(&setup.config).len() as f64;
    let strands = setup.strands.len() as f64;
    let (mut points, mut coordinates, mut elements) = (0.0, 0.0, 0.0);
    for s in &setup.strands {
        let n = s.strand.geometry.elements() as f64;
        points += 1.0 + setup.samples_per_element as f64 * n;
        coordinates += 3.0 * n;
        elements += n;
    }
    let per_frame = 3.0 * points + 2.0 * coordinates + if energies { 3.0 * strands } else { 0.0 };
    // with mechanics: 12 numbers per point (directors, velocity), and per strand 10 per
    // element end (arc, position, force, moment), 6 per element and two reactions
    let mechanics = if mechanics {
        12.0 * points + 10.0 * (elements + strands) + 6.0 * elements + 12.0 * strands
    } else {
        0.0
    };
    2.0 * 8.0 * frames * (per_frame + mechanics)
}

/// The name of a resolved engine.
pub fn engine_name(e: Engine) -> &'static str {
    match e {
        Engine::Embedded => "embedded",
        _ => "runtime",
    }
}

/// A head state's pose as numpy arrays: position (3,) and rotation (3, 3).
pub fn pose(
    py: Python<'_>,
    state: &superhelix_runtime::HeadState,
) -> PyResult<(Py<PyAny>, Py<PyAny>)> {
    let x = state.position;
    let r = state.rotation;
    let rows: Vec<f64> = (0..3)
        .flat_map(|i| (0..3).map(move |j| r[(i, j)]))
        .collect();
    Ok((
        crate::arrays::f64_array(py, &[3], vec![x[0], x[1], x[2]])?,
        crate::arrays::f64_array(py, &[3, 3], rows)?,
    ))
}
