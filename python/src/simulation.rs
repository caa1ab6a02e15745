//! `superhelix.Simulation`: a scene's simulation stepped by hand.

use crate::arrays::{f64_array, vector};
use crate::energy::EnergyMeter;
use crate::errors::run_error;
use crate::run::{error_control_dict, stats_dict, SIGNAL_CHECK};
use crate::scene::{engine_name, Scene};
use pyo3::exceptions::{PyIndexError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::sync::{Mutex, MutexGuard};
use std::time::Instant;
use superhelix_runtime::forces::internal_loads::Momenta;
use superhelix_runtime::{Simulation as Runtime, SimulationSetup};

/// What a simulation was built from: the scene's text and folder and the overrides of
/// `scene.simulation(...)` (what `save` writes and `load` builds again).
#[derive(Clone)]
pub struct Origin {
    pub text: String,
    pub dir: std::path::PathBuf,
    pub dt: Option<f64>,
    pub tolerance: Option<f64>,
}

struct Inner {
    sim: Runtime,
    setup: SimulationSetup,
    origin: Origin,
    /// Measures energies without touching `sim` ([`EnergyMeter`]).
    meter: EnergyMeter,
    /// Whether `step` keeps the momenta for the inertia of `internal_loads`.
    track_inertia: bool,
    /// Per strand, the momenta before the last two steps, oldest first.
    earlier: Vec<Vec<Momenta>>,
}

impl Inner {
    /// Keep every strand's momenta now, dropping all but the last two.
    fn keep_momenta(&mut self) {
        self.sim.keep_momenta(&mut self.earlier);
    }
}

/// A running simulation of a scene (`scene.simulation()`), advanced by `step()`.
///
/// Each step advances every strand by the simulation's dt (the scene's `[simulation] dt`,
/// or the `dt` given to `scene.simulation`) with the scene's head motion, gravity,
/// bodies and contacts: the steps `scene.run()` takes. q, qdot and nodes() read the
/// state; set_state() replaces a strand's.
#[pyclass(module = "superhelix", frozen)]
pub struct Simulation {
    inner: Mutex<Inner>,
}

impl Simulation {
    pub fn new(py: Python<'_>, setup: SimulationSetup, origin: Origin) -> PyResult<Simulation> {
        let sim = Scene::build(py, setup.clone())?;
        Ok(Simulation {
            inner: Mutex::new(Inner {
                sim,
                origin,
                meter: EnergyMeter::new(&setup),
                setup,
                track_inertia: false,
                earlier: Vec::new(),
            }),
        })
    }

    /// Steps `range` of a call of `steps` steps, without the GIL: the momenta kept before
    /// the call's last two steps when `track_inertia` is on, Ctrl-C checked every 0.1 s.
    fn advance(&self, range: std::ops::Range<usize>, steps: usize) -> PyResult<()> {
        let mut inner = self.lock()?;
        let mut checked = Instant::now();
        for k in range {
            if inner.track_inertia && k + 2 >= steps {
                inner.keep_momenta();
            }
            inner.sim.step().map_err(run_error)?;
            // Ctrl-C between two steps (the GIL taken for it at most every 0.1 s)
            if checked.elapsed() >= SIGNAL_CHECK {
                checked = Instant::now();
                Python::attach(|py| py.check_signals())?;
            }
        }
        Ok(())
    }

    fn lock(&self) -> PyResult<MutexGuard<'_, Inner>> {
        self.inner.lock().map_err(|_| {
            PyRuntimeError::new_err("this simulation was poisoned by an earlier internal error")
        })
    }
}

/// Per-strand rows as one (strands, width) array when every strand has the same width,
/// else a list of 1-D arrays.
fn rows(py: Python<'_>, rows: Vec<Vec<f64>>) -> PyResult<Py<PyAny>> {
    let width = rows.first().map_or(0, Vec::len);
    if rows.iter().all(|r| r.len() == width) {
        let n = rows.len();
        f64_array(py, &[n, width], rows.into_iter().flatten().collect())
    } else {
        let list = PyList::empty(py);
        for r in rows {
            let n = r.len();
            list.append(f64_array(py, &[n], r)?)?;
        }
        Ok(list.into_any().unbind())
    }
}

/// One strand's internal loads as `sim.internal_loads()` gives them (a dict of arrays).
pub fn loads_dict<'py>(
    py: Python<'py>,
    l: &superhelix_runtime::forces::internal_loads::InternalLoads,
) -> PyResult<Bound<'py, PyDict>> {
    let flat3 = |v: &[nalgebra::Vector3<f64>]| -> Vec<f64> {
        v.iter()
            .flat_map(|x| x.iter().copied().collect::<Vec<_>>())
            .collect()
    };
    let d = PyDict::new(py);
    let ends = l.arcs.len();
    let elements = l.element_moment.len();
    d.set_item("arc", f64_array(py, &[ends], l.arcs.clone())?)?;
    d.set_item("position", f64_array(py, &[ends, 3], flat3(&l.positions))?)?;
    d.set_item("force", f64_array(py, &[ends, 3], flat3(&l.force))?)?;
    d.set_item("moment", f64_array(py, &[ends, 3], flat3(&l.moment))?)?;
    d.set_item(
        "element_moment",
        f64_array(py, &[elements, 3], flat3(&l.element_moment))?,
    )?;
    d.set_item(
        "element_moment_world",
        f64_array(py, &[elements, 3], flat3(&l.element_moment_world))?,
    )?;
    let six = |r: Option<nalgebra::Vector6<f64>>| {
        r.map(|r| f64_array(py, &[6], r.iter().copied().collect()))
            .transpose()
    };
    d.set_item("root_reaction", six(l.root_reaction)?)?;
    d.set_item("tip_reaction", six(l.tip_reaction)?)?;
    d.set_item("inertia", l.inertia)?;
    Ok(d)
}

/// Strand i's material frames at `arcs` as `directors()` lays them out (3 × 3 per point,
/// row j the director d_j).
pub fn directors_at(sim: &Runtime, i: usize, arcs: &[f64]) -> Vec<f64> {
    sim.poses_world(i, arcs)
        .iter()
        .flat_map(|p| p.frame.iter().copied().collect::<Vec<_>>())
        .collect()
}

/// Strand i's world velocities at `arcs` as `velocities()` lays them out (3 per point).
pub fn velocities_at(sim: &Runtime, i: usize, arcs: &[f64]) -> Vec<f64> {
    sim.velocities_world(i, arcs)
        .iter()
        .flat_map(|v| v.iter().copied().collect::<Vec<_>>())
        .collect()
}

/// `samples_per_element` of `nodes()` and its kin: the scene's `[output]
/// samples_per_element` when None, else checked to be in [1, 64].
fn node_samples(sim: &Runtime, samples_per_element: Option<usize>) -> PyResult<usize> {
    let per = samples_per_element.unwrap_or(sim.samples_per_element());
    if (1..=64).contains(&per) {
        Ok(per)
    } else {
        Err(PyValueError::new_err(format!(
            "samples_per_element: must be in [1, 64], got {per}"
        )))
    }
}

/// Per-strand values of `tail` shape per point as one (strands, points, *tail) array
/// when every strand has as many points, else a list of (points_i, *tail) arrays.
pub fn stacked(py: Python<'_>, per_strand: Vec<Vec<f64>>, tail: &[usize]) -> PyResult<Py<PyAny>> {
    let width: usize = tail.iter().product();
    let points = per_strand.first().map_or(0, |v| v.len() / width);
    let shape_of =
        |p: usize| -> Vec<usize> { std::iter::once(p).chain(tail.iter().copied()).collect() };
    if per_strand.iter().all(|v| v.len() == points * width) {
        let n = per_strand.len();
        let mut shape = vec![n];
        shape.extend(shape_of(points));
        f64_array(py, &shape, per_strand.into_iter().flatten().collect())
    } else {
        let list = PyList::empty(py);
        for v in per_strand {
            let p = v.len() / width;
            list.append(f64_array(py, &shape_of(p), v)?)?;
        }
        Ok(list.into_any().unbind())
    }
}

fn check_index(i: usize, count: usize) -> PyResult<()> {
    if i < count {
        Ok(())
    } else {
        Err(PyIndexError::new_err(format!(
            "strand {i}: the simulation has {count} strand(s)"
        )))
    }
}

#[pymethods]
impl Simulation {
    /// sim.step(dt=None, steps=1, callback=None, every=1) -> None
    ///
    /// Advance every strand by `steps` time steps of the simulation's dt, with the GIL
    /// released. The runtime steps by the dt the simulation was built with: a `dt` given
    /// here must equal it (build with `scene.simulation(dt=...)` for another). The head
    /// follows the scene's motion (a head pose per step is the embedded Batch's).
    ///
    /// `callback(sim)` is called before every `every`-th step (steps 0, every, 2 every,
    /// ...) with the simulation at that state: it may read it and change the loads
    /// (`set_point_loads`, `set_gravity`) for the steps that follow, a user force
    /// recomputed every step with `every=1`. Its cost is one Python call (with the GIL)
    /// and what it reads, per call; without it the steps run without the GIL. An
    /// exception it raises stops the steps and is raised here.
    ///
    /// Raises SimulationError when a strand fails (the others keep their last good
    /// state), and KeyboardInterrupt on Ctrl-C (after the step under way).
    #[pyo3(signature = (dt = None, steps = 1, callback = None, every = 1))]
    fn step(
        slf: &Bound<'_, Self>,
        dt: Option<f64>,
        steps: usize,
        callback: Option<Bound<'_, PyAny>>,
        every: usize,
    ) -> PyResult<()> {
        let py = slf.py();
        let this = slf.get();
        let h = this.lock()?.sim.config().dt;
        if let Some(dt) = dt {
            if dt != h {
                return Err(PyValueError::new_err(format!(
                    "dt: this simulation steps by dt = {h} s (the runtime's step length is fixed when it is built); use scene.simulation(dt={dt}) to step by {dt} s"
                )));
            }
        }
        if every == 0 {
            return Err(PyValueError::new_err("every: must be at least 1, got 0"));
        }
        let Some(callback) = callback else {
            return py.detach(|| this.advance(0..steps, steps));
        };
        if !callback.is_callable() {
            return Err(PyValueError::new_err(
                "callback: must be callable (sim) -> None",
            ));
        }
        let mut k = 0;
        while k < steps {
            callback.call1((slf,))?;
            let end = (k + every).min(steps);
            py.detach(|| this.advance(k..end, steps))?;
            k = end;
        }
        Ok(())
    }

    /// Simulated time, s.
    #[getter]
    fn time(&self) -> PyResult<f64> {
        Ok(self.lock()?.sim.time())
    }

    /// The time step, s.
    #[getter]
    fn dt(&self) -> PyResult<f64> {
        Ok(self.lock()?.sim.config().dt)
    }

    /// Steps taken.
    #[getter]
    fn steps_taken(&self) -> PyResult<usize> {
        Ok(self.lock()?.sim.steps())
    }

    /// Number of strands.
    #[getter]
    fn strand_count(&self) -> PyResult<usize> {
        Ok(self.lock()?.sim.strand_count())
    }

    /// Strand names, in scene order.
    #[getter]
    fn strand_names(&self) -> PyResult<Vec<String>> {
        let inner = self.lock()?;
        Ok((0..inner.sim.strand_count())
            .map(|i| inner.sim.strand(i).name.clone())
            .collect())
    }

    /// The engine stepping the strands: "embedded" or "runtime".
    #[getter]
    fn engine(&self) -> PyResult<&'static str> {
        Ok(engine_name(self.lock()?.sim.engine()))
    }

    /// Generalized coordinates (τ, κ1, κ2 per element, rad/m): (strands, 3N) when every
    /// strand has the same N, else a list of (3N_i,) arrays. A copy.
    #[getter]
    fn q(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let inner = self.lock()?;
        let q = (0..inner.sim.strand_count())
            .map(|i| inner.sim.q(i).to_vec())
            .collect();
        drop(inner);
        rows(py, q)
    }

    /// Generalized velocities, rad/(m s), laid out as `q`. A copy.
    #[getter]
    fn qdot(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let inner = self.lock()?;
        let v = (0..inner.sim.strand_count())
            .map(|i| inner.sim.v(i).to_vec())
            .collect();
        drop(inner);
        rows(py, v)
    }

    /// sim.nodes(samples_per_element=None) -> array
    ///
    /// Every strand's centreline in world coordinates at the current time, m: the root,
    /// then `samples_per_element` points per element (default: the scene's
    /// `[output] samples_per_element`, as in the frames). (strands, points, 3) when all
    /// strands have as many points, else a list of (points_i, 3) arrays.
    #[pyo3(signature = (samples_per_element = None))]
    fn nodes(&self, py: Python<'_>, samples_per_element: Option<usize>) -> PyResult<Py<PyAny>> {
        let mut inner = self.lock()?;
        let per = node_samples(&inner.sim, samples_per_element)?;
        let n = inner.sim.strand_count();
        let lines: Vec<Vec<[f64; 3]>> =
            (0..n).map(|i| inner.sim.centreline_world(i, per)).collect();
        drop(inner);
        let points = lines.first().map_or(0, Vec::len);
        if lines.iter().all(|l| l.len() == points) {
            let data = lines.into_iter().flatten().flatten().collect();
            f64_array(py, &[n, points, 3], data)
        } else {
            let list = PyList::empty(py);
            for l in lines {
                let p = l.len();
                list.append(f64_array(py, &[p, 3], l.into_iter().flatten().collect())?)?;
            }
            Ok(list.into_any().unbind())
        }
    }

    /// sim.directors(samples_per_element=None) -> array
    ///
    /// The material frame at the points of `nodes()` (the same arguments), world
    /// coordinates: shape (strands, points, 3, 3), `[i, p, j]` the director d_j, with d0
    /// the tangent and d1, d2 the frame's normals (the axes of the κ1 and κ2 bending;
    /// section 3.1 of the Super-Helix paper). Unit vectors, orthonormal, right-handed.
    /// A list of (points_i, 3, 3) arrays when the strands have different point counts.
    #[pyo3(signature = (samples_per_element = None))]
    fn directors(&self, py: Python<'_>, samples_per_element: Option<usize>) -> PyResult<Py<PyAny>> {
        let inner = self.lock()?;
        let per = node_samples(&inner.sim, samples_per_element)?;
        let per_strand: Vec<Vec<f64>> = (0..inner.sim.strand_count())
            .map(|i| directors_at(&inner.sim, i, &inner.sim.centreline_arcs(i, per)))
            .collect();
        drop(inner);
        stacked(py, per_strand, &[3, 3])
    }

    /// sim.velocities(samples_per_element=None) -> array
    ///
    /// The world velocity of the points of `nodes()` (the same arguments), m/s: the
    /// strand's motion relative to the head (J(s) q̇) plus the head's own
    /// (Ẋ + ω × (x − X)). Shape (strands, points, 3), or a list as `nodes()`.
    #[pyo3(signature = (samples_per_element = None))]
    fn velocities(
        &self,
        py: Python<'_>,
        samples_per_element: Option<usize>,
    ) -> PyResult<Py<PyAny>> {
        let inner = self.lock()?;
        let per = node_samples(&inner.sim, samples_per_element)?;
        let per_strand: Vec<Vec<f64>> = (0..inner.sim.strand_count())
            .map(|i| velocities_at(&inner.sim, i, &inner.sim.centreline_arcs(i, per)))
            .collect();
        drop(inner);
        stacked(py, per_strand, &[3])
    }

    /// Whether `step()` keeps the momenta `internal_loads()` needs for the inertia
    /// (default False). Set it before the steps whose end you will measure: each
    /// `step()` call then measures every strand's momenta before its last two steps
    /// (about three reconstructions of the strand each, a fraction of one implicit
    /// step's cost).
    #[getter]
    fn track_inertia(&self) -> PyResult<bool> {
        Ok(self.lock()?.track_inertia)
    }

    #[setter]
    fn set_track_inertia(&self, on: bool) -> PyResult<()> {
        let mut inner = self.lock()?;
        inner.track_inertia = on;
        if !on {
            inner.earlier.clear();
        }
        Ok(())
    }

    /// sim.internal_loads(inertia=None) -> list[dict]
    ///
    /// What each strand carries inside and what holds it, at the current state (world
    /// coordinates; arc length from the root): a dict per strand with
    ///
    /// - `arc` (N+1,): the element ends, m; `position` (N+1, 3) there, m;
    /// - `force` (N+1, 3), N, and `moment` (N+1, 3), N·m about the centreline point: what
    ///   the part beyond each end exerts on the part before it, from the balance of that
    ///   part (gravity, the head's motion, air drag, point loads, a held tip, inertia);
    /// - `element_moment` (N, 3): each element's moment from its curvatures and twist,
    ///   along its material frame (twist, bending about d1, about d2), N·m, with
    ///   internal friction's; `element_moment_world` (N, 3) the same at the element's
    ///   middle in world coordinates;
    /// - `root_reaction`, `tip_reaction`: (6,) force then moment (about the end) the
    ///   holder applies, or None (a free root, a tip not held);
    /// - `inertia`: whether the momenta's change was counted.
    ///
    /// `inertia=None` counts the inertia from the momenta `step()` kept
    /// (`track_inertia`), and raises ValueError when a strand moves and none were kept;
    /// False leaves it out (a static state). Raises ValueError for a scene with contacts
    /// or electrostatics, whose forces the balance cannot place along the strand.
    #[pyo3(signature = (inertia = None))]
    fn internal_loads<'py>(
        &self,
        py: Python<'py>,
        inertia: Option<bool>,
    ) -> PyResult<Bound<'py, PyList>> {
        let inner = self.lock()?;
        let n = inner.sim.strand_count();
        let mut all = Vec::with_capacity(n);
        for i in 0..n {
            let earlier: &[Momenta] = match inertia {
                Some(false) => &[],
                _ => inner.earlier.get(i).map_or(&[], Vec::as_slice),
            };
            let loads = inner
                .sim
                .internal_loads(i, earlier)
                .map_err(crate::errors::input_error)?;
            if inertia.is_none() && !loads.inertia && inner.sim.v(i).iter().any(|&v| v != 0.0) {
                return Err(PyValueError::new_err(format!(
                    "internal_loads: strand {i} moves and no momenta were kept for its inertia: set sim.track_inertia = True before stepping (or pass inertia=False to leave the inertia out)"
                )));
            }
            all.push(loads);
        }
        drop(inner);
        let list = PyList::empty(py);
        for l in &all {
            list.append(loads_dict(py, l)?)?;
        }
        Ok(list)
    }

    /// sim.point_loads(i) -> list[dict]
    ///
    /// Strand i's own point loads now: dicts of `s` (arc length, m), `force` (N, world
    /// coordinates, or along the material frame when `follows`) and `follows`.
    fn point_loads<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Bound<'py, PyList>> {
        let inner = self.lock()?;
        check_index(i, inner.sim.strand_count())?;
        let list = PyList::empty(py);
        for l in inner.sim.point_loads(i) {
            let d = PyDict::new(py);
            d.set_item("s", l.s)?;
            d.set_item(
                "force",
                f64_array(py, &[3], l.force.iter().copied().collect())?,
            )?;
            d.set_item("follows", l.follows)?;
            d.set_item(
                "torque",
                f64_array(py, &[3], l.torque.iter().copied().collect())?,
            )?;
            list.append(d)?;
        }
        Ok(list)
    }

    /// sim.set_point_loads(i, loads) -> None
    ///
    /// Replace strand i's own point loads from the next step on (and for
    /// `solve_static()`): an iterable of dicts with `s` (m, in [0, L]), `force` (3
    /// values, N, at most 1e6 N), optionally `follows` (False: the force is in world
    /// coordinates; True: along the material frame at s, runtime engine only) and
    /// `torque` (a couple at s, 3 values, N·m, world coordinates, runtime engine only; a
    /// couple alone needs no `force`), as a scene's `[[strands.point_loads]]`. The clock,
    /// the head's phase and the integrator's history are kept: a load set before every
    /// step (`step(callback=...)`) is stepped exactly as the same load given in the
    /// scene. Costs nothing per step beyond the loads' own terms.
    fn set_point_loads(&self, i: usize, loads: &Bound<'_, PyAny>) -> PyResult<()> {
        let mut parsed = Vec::new();
        for (k, item) in loads.try_iter()?.enumerate() {
            let item = item?;
            let d = item.cast::<PyDict>().map_err(|_| {
                PyValueError::new_err(format!(
                    "point_loads[{k}]: must be a dict with s, force and optionally follows, torque"
                ))
            })?;
            for key in d.keys() {
                let key: String = key.extract()?;
                if !["s", "force", "follows", "torque"].contains(&key.as_str()) {
                    return Err(PyValueError::new_err(format!(
                        "point_loads[{k}].{key}: unknown key (s, force, follows, torque)"
                    )));
                }
            }
            let s: f64 = d
                .get_item("s")?
                .ok_or_else(|| PyValueError::new_err(format!("point_loads[{k}].s: required")))?
                .extract()
                .map_err(|_| {
                    PyValueError::new_err(format!("point_loads[{k}].s: must be a number"))
                })?;
            let torque = match d.get_item("torque")? {
                Some(t) => vector(&t, &format!("point_loads[{k}].torque"), 3)?,
                None => vec![0.0; 3],
            };
            let force = match d.get_item("force")? {
                Some(f) => vector(&f, &format!("point_loads[{k}].force"), 3)?,
                // a couple alone needs no force
                None if d.get_item("torque")?.is_some() => vec![0.0; 3],
                None => {
                    return Err(PyValueError::new_err(format!(
                        "point_loads[{k}].force: required"
                    )))
                }
            };
            let follows = match d.get_item("follows")? {
                Some(f) => f.extract::<bool>().map_err(|_| {
                    PyValueError::new_err(format!(
                        "point_loads[{k}].follows: must be True or False"
                    ))
                })?,
                None => false,
            };
            parsed.push(superhelix_runtime::model::strand::PointLoad {
                s,
                force: nalgebra::Vector3::new(force[0], force[1], force[2]),
                follows,
                torque: nalgebra::Vector3::new(torque[0], torque[1], torque[2]),
            });
        }
        let mut inner = self.lock()?;
        check_index(i, inner.sim.strand_count())?;
        inner
            .sim
            .set_point_loads(i, parsed)
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// sim.holder(i) -> dict | None
    ///
    /// Where strand i's held tip is held: `position` (3,) and `frame` (3, 3), rows the
    /// held directors n0, n1, n2, in the holder's motion frame (the world for a still
    /// holder); None when its tip is not held.
    fn holder<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Option<Bound<'py, PyDict>>> {
        let inner = self.lock()?;
        check_index(i, inner.sim.strand_count())?;
        let Some((p, f)) = inner.sim.holder(i) else {
            return Ok(None);
        };
        drop(inner);
        let d = PyDict::new(py);
        d.set_item(
            "position",
            f64_array(py, &[3], p.iter().copied().collect())?,
        )?;
        d.set_item(
            "frame",
            f64_array(py, &[3, 3], f.iter().copied().collect())?,
        )?;
        Ok(Some(d))
    }

    /// sim.set_holder(i, position, frame=None) -> None
    ///
    /// Hold strand i's tip at `position` (3 values, m) from now on, and a clamped tip in
    /// `frame` (3×3, rows the directors n0, n1, n2: a rotation) when given, in the
    /// holder's motion frame: a holder moved between steps or between static solves,
    /// the parameter of a displacement-controlled study. Refused (ValueError, the holder
    /// left where it was) for a strand without a held tip, a point out of the rod's
    /// reach or a frame that is not a rotation. The strand's energy balance starts
    /// afresh (the holder did work on it).
    #[pyo3(signature = (i, position, frame = None))]
    fn set_holder(
        &self,
        i: usize,
        position: &Bound<'_, PyAny>,
        frame: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let p = vector(position, "position", 3)?;
        let frame = match frame {
            Some(f) if !f.is_none() => {
                let (shape, values) = crate::arrays::to_f64(f, "frame")?;
                if shape != [3, 3] {
                    return Err(PyValueError::new_err(format!(
                        "frame: expected shape (3, 3), got {}",
                        crate::arrays::shape_text(&shape)
                    )));
                }
                // rows of the array are the directors: the columns of the frame
                Some(nalgebra::Matrix3::from_column_slice(&values))
            }
            _ => None,
        };
        let mut inner = self.lock()?;
        check_index(i, inner.sim.strand_count())?;
        inner
            .sim
            .set_holder(i, nalgebra::Vector3::new(p[0], p[1], p[2]), frame)
            .map_err(crate::errors::input_error)
    }

    /// sim.save(path) -> None
    ///
    /// Write the simulation to the file `path` in the checkpoint format of
    /// `superhelix run` (`checkpoint.bin`: magic, length, CRC-32, body): the scene's
    /// text and folder, the overrides of `scene.simulation(...)`, a digest of what the
    /// scene builds, and the whole state (every strand's q, qdot and integrator history,
    /// the contacts' anchors, held tips, the clock, gravity and point loads as
    /// `set_gravity` and `set_point_loads` left them). Written atomically; an existing
    /// file is replaced only when it is itself a saved simulation or checkpoint.
    /// `Simulation.load(path)` goes on from it: the steps that follow are those this
    /// simulation would take, to the bit. The momenta kept for `track_inertia` are not
    /// saved.
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        use superhelix_runtime::output::checkpoint;
        if path.exists() && !checkpoint::is_checkpoint(&path) {
            return Err(PyValueError::new_err(format!(
                "path: {} exists and is not a saved simulation: choose another path or remove it",
                path.display()
            )));
        }
        let inner = self.lock()?;
        let state = inner.sim.state().encode().map_err(run_error)?;
        let origin = &inner.origin;
        let saved = checkpoint::Checkpoint {
            version: checkpoint::VERSION,
            identity: checkpoint::SceneIdentity {
                scene: origin.text.clone(),
                tolerance: origin.tolerance,
                formats: Vec::new(),
                part: None,
                digest: checkpoint::setup_digest(&inner.setup),
                dt: origin.dt,
                folder: Some(origin.dir.to_string_lossy().into_owned()),
            },
            point: checkpoint::RunPoint {
                step: inner.sim.steps(),
                time: inner.sim.time(),
                ..Default::default()
            },
            sinks: Vec::new(),
            state,
        };
        drop(inner);
        py.detach(|| checkpoint::write_file(&path, &saved))
            .map_err(run_error)
    }

    /// Simulation.load(path, folder=None) -> Simulation
    ///
    /// The simulation `sim.save(path)` wrote, going on from where it was. The scene is
    /// read again from the saved text, its relative paths from the saved folder (or
    /// `folder`); a scene whose files changed since (a mesh, a groom's curves) is
    /// refused, as `superhelix run --resume` refuses it.
    #[staticmethod]
    #[pyo3(signature = (path, folder = None))]
    fn load(
        py: Python<'_>,
        path: std::path::PathBuf,
        folder: Option<std::path::PathBuf>,
    ) -> PyResult<Simulation> {
        use superhelix_runtime::output::checkpoint;
        let saved = py
            .detach(|| checkpoint::read_file(&path, "path"))
            .map_err(crate::errors::input_error)?
            .ok_or_else(|| {
                pyo3::exceptions::PyFileNotFoundError::new_err(format!(
                    "path: {} does not exist",
                    path.display()
                ))
            })?;
        let identity = saved.identity;
        let Some(saved_folder) = identity.folder.clone() else {
            return Err(PyValueError::new_err(format!(
                "path: {} is a run's checkpoint, not a saved simulation: continue it with `superhelix run SCENE --resume DIR`",
                path.display()
            )));
        };
        let dir = folder.unwrap_or_else(|| std::path::PathBuf::from(saved_folder));
        let scene = Scene::parse(py, identity.scene.clone(), dir.clone())?;
        let setup = scene.setup_with(&crate::scene::Overrides {
            dt: identity.dt,
            tolerance: identity.tolerance,
            ..Default::default()
        })?;
        if checkpoint::setup_digest(&setup) != identity.digest {
            return Err(PyValueError::new_err(format!(
                "path: a file the scene reads (a mesh, a groom's curves) under {} has changed since {} was saved",
                dir.display(),
                path.display()
            )));
        }
        let state = superhelix_runtime::simulation::SimulationState::decode(&saved.state)
            .map_err(crate::errors::input_error)?;
        let origin = Origin {
            text: identity.scene,
            dir,
            dt: identity.dt,
            tolerance: identity.tolerance,
        };
        let sim = Simulation::new(py, setup, origin)?;
        sim.lock()?
            .sim
            .restore(state)
            .map_err(crate::errors::input_error)?;
        Ok(sim)
    }

    /// sim.set_state(i, q, qdot=None) -> None
    ///
    /// Replace strand i's state: q and qdot (zero when None), 3N values each.
    #[pyo3(signature = (i, q, qdot = None))]
    fn set_state(
        &self,
        i: usize,
        q: &Bound<'_, PyAny>,
        qdot: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let mut inner = self.lock()?;
        check_index(i, inner.sim.strand_count())?;
        let n = inner.sim.q(i).len();
        let q = vector(q, "q", n)?;
        let v = match qdot {
            Some(v) => vector(v, "qdot", n)?,
            None => vec![0.0; n],
        };
        if !q.iter().chain(&v).all(|x| x.is_finite()) {
            return Err(PyValueError::new_err("q, qdot: every value must be finite"));
        }
        inner.sim.set_state(i, &q, &v);
        if let Some(kept) = inner.earlier.get_mut(i) {
            kept.clear();
        }
        Ok(())
    }

    /// sim.energies() -> dict
    ///
    /// Each strand's energy in its current state, J, as arrays of shape (strands,):
    /// kinetic (½ q̇ᵀ M q̇ relative to the head), elastic (½ (q − q_n)ᵀ K (q − q_n)),
    /// potential (elastic plus gravity plus point loads; contacts and electrostatics not
    /// counted) and total: the names and meanings of `Batch.energies()` and of a run's
    /// `potential_energy`. The stepping
    /// simulation is not changed: the runtime engine's strands are measured on a second
    /// simulation of the scene without contacts, set to this state (built on first use).
    fn energies<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let (kinetic, potential, elastic) =
            py.detach(|| -> PyResult<(Vec<f64>, Vec<f64>, Vec<f64>)> {
                let mut guard = self.inner.lock().map_err(|_| {
                    PyRuntimeError::new_err(
                        "this simulation was poisoned by an earlier internal error",
                    )
                })?;
                let inner = &mut *guard;
                let n = inner.sim.strand_count();
                let (mut kinetic, mut potential) = (Vec::with_capacity(n), Vec::with_capacity(n));
                for i in 0..n {
                    let (t, v) = inner
                        .meter
                        .measure(&mut inner.sim, i, None)
                        .map_err(PyRuntimeError::new_err)?;
                    kinetic.push(t);
                    potential.push(v);
                }
                let elastic = (0..n)
                    .map(|i| inner.sim.strand(i).elastic_energy(inner.sim.q(i)))
                    .collect();
                Ok((kinetic, potential, elastic))
            })?;
        let n = kinetic.len();
        let total: Vec<f64> = kinetic.iter().zip(&potential).map(|(a, b)| a + b).collect();
        let d = PyDict::new(py);
        d.set_item("kinetic", f64_array(py, &[n], kinetic)?)?;
        d.set_item("elastic", f64_array(py, &[n], elastic)?)?;
        d.set_item("potential", f64_array(py, &[n], potential)?)?;
        d.set_item("total", f64_array(py, &[n], total)?)?;
        Ok(d)
    }

    /// sim.stats() -> dict
    ///
    /// The solver's counters summed over strands since the start (the runtime's
    /// StepStats; keys as RunResult.stats).
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.lock()?.sim.stats();
        stats_dict(py, &s)
    }

    /// Gravity now, world coordinates, m/s²: shape (3,), or None without gravity.
    #[getter]
    fn gravity(&self, py: Python<'_>) -> PyResult<Option<Py<PyAny>>> {
        let g = self.lock()?.sim.gravity();
        g.map(|g| f64_array(py, &[3], g.iter().copied().collect()))
            .transpose()
    }

    /// sim.set_gravity(g)
    ///
    /// Gravity from now on for every strand, world coordinates, m/s² (3 finite values,
    /// each within ±1000 m/s², as the scene's), or None for none: a load turned or ramped
    /// between steps, the clock and the head's phase kept. The steps and `solve_static()`
    /// take it; the potential changes at once, so each strand's energy balance starts
    /// afresh from its state (no work done). Costs nothing per step.
    fn set_gravity(&self, g: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
        let g = match g {
            None => None,
            Some(v) if v.is_none() => None,
            Some(v) => {
                let g = vector(v, "gravity", 3)?;
                let max = superhelix_runtime::scene::MAX_GRAVITY;
                if let Some(x) = g.iter().find(|x| !x.is_finite() || x.abs() > max) {
                    return Err(PyValueError::new_err(format!(
                        "gravity: each component must be finite and within ±{max} m/s² (as [environment] gravity), got {x}"
                    )));
                }
                Some(nalgebra::Vector3::new(g[0], g[1], g[2]))
            }
        };
        self.lock()?.sim.set_gravity(g);
        Ok(())
    }

    /// sim.solve_static() -> list[dict]
    ///
    /// Every strand's static equilibrium under the present gravity and point loads (head
    /// at rest), by Newton's method from its present q: set a strand's q first
    /// (`set_state`, any `result.q` of the same strand) to start from a guess, or to
    /// follow one branch by small changes of a load. Per strand: iterations, residual
    /// (max |F|, N·m), force_scale and converged. The velocities are left as they were.
    /// Raises SimulationError when a strand's solve fails (non-finite or diverged), and
    /// ValueError for a load without a potential (a follower load, a couple).
    fn solve_static<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let reports = py.detach(|| -> PyResult<_> {
            let mut inner = self.inner.lock().map_err(|_| {
                PyRuntimeError::new_err("this simulation was poisoned by an earlier internal error")
            })?;
            inner.sim.solve_static().map_err(crate::errors::input_error)
        })?;
        let list = PyList::empty(py);
        for r in reports {
            let d = PyDict::new(py);
            d.set_item("iterations", r.iterations)?;
            d.set_item("residual", r.residual)?;
            d.set_item("force_scale", r.force_scale)?;
            d.set_item("converged", r.converged)?;
            list.append(d)?;
        }
        Ok(list)
    }

    /// sim.follow_branch(i, stop, parameter="load", start=None, direction=None,
    ///                   step=0.02, max_step=None, max_points=1000) -> dict
    ///
    /// Follow strand i's static equilibria (head at rest) as a parameter a goes from
    /// `start` toward `stop`, by pseudo-arclength continuation: the branch is followed
    /// through folds of a and onto its unstable part, where load-stepped static solves
    /// jump to another branch. The first point is the static equilibrium at `start` from
    /// the strand's present q as a guess (`set_state` picks the branch).
    ///
    /// `parameter="load"`: a scales the strand's point loads as they are now (`start`
    /// 1 by default). `parameter="holder"`: a moves its held tip's holder from where it
    /// is now along the unit vector `direction`, m (`start` 0 by default).
    /// `step` is the first arclength step in the norm `sqrt(Σ (l_e Δq)² + (Δa/σ)²)`
    /// (radians of bend per element; σ = 1 for a load scale, the strand's length for a
    /// holder), `max_step` the largest (10 × step by default).
    ///
    /// Returns a dict: `parameter` (k,), `q` (k, 3N), `tip` (k, 3) in m, `reaction`
    /// (k, 6): the holder's force and torque on the tip (zero without a held tip),
    /// `unstable` (k,): the directions in which the energy decreases (0: stable),
    /// `energy` (k,) in J, `folds`: a list of dicts (`after`: the index of the point
    /// before it, and the same keys for the fold itself), `branch_points`: the indices
    /// of the points after which the count of unstable directions changed without a
    /// fold (steps refined to 1e-3 of `step` first), `end`: "reached",
    /// "max_points" or "stalled", and `start`: the first static solve's report. The
    /// simulation's state, loads and holder are left as they were. Refused (ValueError,
    /// the field named) with contacts or electrostatics, for a holder parameter on a
    /// tip not held, or settings out of range.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (i, stop, parameter = "load", start = None, direction = None, step = 0.02, max_step = None, max_points = 1000))]
    fn follow_branch<'py>(
        &self,
        py: Python<'py>,
        i: usize,
        stop: f64,
        parameter: &str,
        start: Option<f64>,
        direction: Option<&Bound<'_, PyAny>>,
        step: f64,
        max_step: Option<f64>,
        max_points: usize,
    ) -> PyResult<Bound<'py, PyDict>> {
        use superhelix_runtime::solver::continuation::{
            BranchEnd, BranchParameter, BranchPoint, ContinuationSettings,
        };
        let direction = match direction {
            Some(d) if !d.is_none() => Some(vector(d, "direction", 3)?),
            _ => None,
        };
        let (parameter, default_start) = match (parameter, direction) {
            ("load", None) => (BranchParameter::LoadScale, 1.0),
            ("load", Some(_)) => {
                return Err(PyValueError::new_err(
                    "direction: only for parameter=\"holder\"",
                ))
            }
            ("holder", Some(d)) => {
                let v = nalgebra::Vector3::new(d[0], d[1], d[2]);
                let norm = v.norm();
                if !(norm.is_finite() && norm > 0.0) {
                    return Err(PyValueError::new_err(
                        "direction: must be a non-zero finite vector",
                    ));
                }
                (
                    BranchParameter::Holder {
                        direction: v / norm,
                    },
                    0.0,
                )
            }
            ("holder", None) => {
                return Err(PyValueError::new_err(
                    "direction: required for parameter=\"holder\" (3 values)",
                ))
            }
            (other, _) => {
                return Err(PyValueError::new_err(format!(
                    "parameter: expected \"load\" or \"holder\", got {other:?}"
                )))
            }
        };
        let settings = ContinuationSettings {
            parameter,
            start: start.unwrap_or(default_start),
            stop,
            step,
            max_step: max_step.unwrap_or(10.0 * step),
            max_points,
        };
        let branch = py.detach(|| -> PyResult<_> {
            let inner = self.inner.lock().map_err(|_| {
                PyRuntimeError::new_err("this simulation was poisoned by an earlier internal error")
            })?;
            check_index(i, inner.sim.strand_count())?;
            inner
                .sim
                .follow_branch(i, &settings)
                .map_err(crate::errors::input_error)
        })?;
        let n = branch.points.first().map_or(0, |p| p.q.len());
        let k = branch.points.len();
        let gather = |f: &dyn Fn(&BranchPoint) -> Vec<f64>| -> Vec<f64> {
            branch.points.iter().flat_map(f).collect()
        };
        let d = PyDict::new(py);
        d.set_item(
            "parameter",
            f64_array(py, &[k], gather(&|p| vec![p.parameter]))?,
        )?;
        d.set_item("q", f64_array(py, &[k, n], gather(&|p| p.q.clone()))?)?;
        d.set_item(
            "tip",
            f64_array(py, &[k, 3], gather(&|p| p.tip.as_slice().to_vec()))?,
        )?;
        d.set_item(
            "reaction",
            f64_array(py, &[k, 6], gather(&|p| p.reaction.as_slice().to_vec()))?,
        )?;
        d.set_item(
            "unstable",
            crate::arrays::i64_array(
                py,
                &[k],
                branch.points.iter().map(|p| p.unstable as i64).collect(),
            )?,
        )?;
        d.set_item("energy", f64_array(py, &[k], gather(&|p| vec![p.energy]))?)?;
        let folds = PyList::empty(py);
        for f in &branch.folds {
            let p = &f.point;
            let fd = PyDict::new(py);
            fd.set_item("after", f.after)?;
            fd.set_item("parameter", p.parameter)?;
            fd.set_item("q", f64_array(py, &[n], p.q.clone())?)?;
            fd.set_item("tip", f64_array(py, &[3], p.tip.as_slice().to_vec())?)?;
            fd.set_item(
                "reaction",
                f64_array(py, &[6], p.reaction.as_slice().to_vec())?,
            )?;
            fd.set_item("unstable", p.unstable)?;
            fd.set_item("energy", p.energy)?;
            folds.append(fd)?;
        }
        d.set_item("folds", folds)?;
        d.set_item("branch_points", branch.branch_points.clone())?;
        d.set_item(
            "end",
            match branch.end {
                BranchEnd::Reached => "reached",
                BranchEnd::MaxPoints => "max_points",
                BranchEnd::Stalled { .. } => "stalled",
            },
        )?;
        let r = PyDict::new(py);
        r.set_item("iterations", branch.start.iterations)?;
        r.set_item("residual", branch.start.residual)?;
        r.set_item("force_scale", branch.start.force_scale)?;
        r.set_item("converged", branch.start.converged)?;
        d.set_item("start", r)?;
        Ok(d)
    }

    /// sim.error_control() -> dict | None
    ///
    /// With a tolerance, what the error-controlled steps did so far (tolerance,
    /// largest_error, smallest_step, smallest_step_strand, steps, rejected); else None.
    fn error_control<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let e = self.lock()?.sim.error_control();
        e.map(|e| error_control_dict(py, &e)).transpose()
    }

    /// sim.head_pose() -> (position, rotation)
    ///
    /// The head's pose at the current time, by the scene's motion or as `set_head` drives
    /// it: its world position X (3,) and rotation R (3, 3), head to world (a head point y
    /// is at X + R y).
    fn head_pose(&self, py: Python<'_>) -> PyResult<(Py<PyAny>, Py<PyAny>)> {
        let inner = self.lock()?;
        let state = inner.sim.head_state();
        drop(inner);
        crate::scene::pose(py, &state)
    }

    /// sim.set_head(position, rotation=None, velocity=None, acceleration=None,
    ///              omega=None, alpha=None, time=None) -> None
    ///
    /// Drive the head from Python from now on, in place of the scene's `[head] motion`:
    /// its world position X (3 values, m) and rotation R (3×3, head to world; identity
    /// if None) at `time` (default: now), with its velocity and acceleration (world,
    /// m/s, m/s²) and ω and α (head coordinates, rad/s, rad/s²; zero if None). The head
    /// moves on from that state with constant acceleration and angular acceleration
    /// until the next call, as the embedded `Batch`'s head: a pose given before each
    /// step as an engine gives its character's (with `time = sim.time + sim.dt`, the
    /// state at the step's end, which the implicit steps take). The strands' coordinates
    /// are the head's, so a pose that jumps carries them with it; the rates make the
    /// fictitious forces. Refused (ValueError, the field named) for a rotation that is
    /// not one (to 1e-9), values out of range, or a scene with a held tip. Each strand's
    /// energy balance starts afresh; the integrators' histories are kept; `save` keeps
    /// the driven head.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (position, rotation = None, velocity = None, acceleration = None, omega = None, alpha = None, time = None))]
    fn set_head(
        &self,
        position: &Bound<'_, PyAny>,
        rotation: Option<&Bound<'_, PyAny>>,
        velocity: Option<&Bound<'_, PyAny>>,
        acceleration: Option<&Bound<'_, PyAny>>,
        omega: Option<&Bound<'_, PyAny>>,
        alpha: Option<&Bound<'_, PyAny>>,
        time: Option<f64>,
    ) -> PyResult<()> {
        let v3 =
            |value: Option<&Bound<'_, PyAny>>, name: &str| -> PyResult<nalgebra::Vector3<f64>> {
                match value {
                    Some(v) if !v.is_none() => {
                        let v = vector(v, name, 3)?;
                        Ok(nalgebra::Vector3::new(v[0], v[1], v[2]))
                    }
                    _ => Ok(nalgebra::Vector3::zeros()),
                }
            };
        let rotation = match rotation {
            Some(r) if !r.is_none() => {
                let (shape, values) = crate::arrays::to_f64(r, "rotation")?;
                if shape != [3, 3] {
                    return Err(PyValueError::new_err(format!(
                        "rotation: expected shape (3, 3), got {}",
                        crate::arrays::shape_text(&shape)
                    )));
                }
                // numpy's rows are R's rows
                nalgebra::Matrix3::from_row_slice(&values)
            }
            _ => nalgebra::Matrix3::identity(),
        };
        let state = superhelix_runtime::HeadState {
            position: v3(Some(position), "position")?,
            rotation,
            velocity: v3(velocity, "velocity")?,
            acceleration: v3(acceleration, "acceleration")?,
            omega: v3(omega, "omega")?,
            alpha: v3(alpha, "alpha")?,
        };
        self.lock()?
            .sim
            .set_head(state, time)
            .map_err(crate::errors::input_error)
    }

    fn __repr__(&self) -> String {
        match self.inner.lock() {
            Ok(inner) => format!(
                "<superhelix.Simulation: {} strands at t = {} s, dt = {} s, engine {}>",
                inner.sim.strand_count(),
                inner.sim.time(),
                inner.sim.config().dt,
                engine_name(inner.sim.engine())
            ),
            Err(_) => "<superhelix.Simulation (poisoned)>".to_string(),
        }
    }
}
