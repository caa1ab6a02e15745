//! `superhelix.Batch`: strands of one N stepped by the embedded fixed-N step of
//! `superhelix-kernels`, the head pose given per step: what the C ABI's `ShBatch` does
//! (`capi/`), from Python.
//!
//! The semantics are the C library's (docs/embedding.md): each call steps every strand
//! by dt in a time of its own [0, dt], the head given as its state at the end of the step
//! and the substeps following the motion extrapolated back from it; a strand whose step
//! fails keeps the state it had; the checked step by default, the plain linearly
//! implicit step on request, or error-controlled steps at a tolerance.

use crate::arrays::{f64_array, shape_text, to_f64, vector};
use crate::errors::StepError as PyStepError;
use crate::scene::Scene;
use nalgebra::{Matrix3, Vector3};
use pyo3::exceptions::{PyIndexError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::{Mutex, MutexGuard};
use superhelix_generated::{visit_size, ClosedForm, SizeVisitor};
use superhelix_kernels::fixed::batch::{
    step_batch_strand, BatchOutcome, BatchSettings, BatchStrandSpec,
};
use superhelix_kernels::fixed::{
    self, Effects, FixedStrand, FixedWorkspace, ParamsError, StepHistory, StepInput,
    ToleranceReport, MAX_TOLERANCE, MIN_TOLERANCE,
};
use superhelix_kernels::head::HeadState;
use superhelix_kernels::material::section_terms;
use superhelix_kernels::pose::Pose;
use superhelix_runtime::solver::embedded::fixed_params;
use superhelix_runtime::Strand;

/// Most strands of one batch (the C library's cap).
const MAX_STRANDS: usize = 10_000_000;

/// The strands of a batch behind a trait, so that Python need not know N.
trait Group: Send {
    fn elements(&self) -> usize;
    fn len(&self) -> usize;
    fn strand_bytes(&self) -> usize;
    fn workspace_bytes(&self) -> usize;
    fn step(&mut self, settings: &BatchSettings, dt: f64) -> BatchOutcome;
    fn forget_energy(&mut self);
    fn keep_histories(&mut self);
    /// The N + 1 element ends of strand i in world coordinates, appended to `out`.
    fn centreline(&self, i: usize, head: &HeadState, out: &mut Vec<f64>);
    fn q(&self, i: usize) -> &[f64];
    fn v(&self, i: usize) -> &[f64];
    fn set_state(&mut self, i: usize, q: &[f64], v: &[f64]);
    /// (kinetic, elastic, potential) of strand i in the world of `settings`.
    fn energy(&mut self, i: usize, settings: &BatchSettings) -> (f64, f64, f64);
}

struct Strands<const N: usize, const D: usize, const E: usize, const B: usize> {
    strands: Vec<FixedStrand<N, D, B>>,
    /// The error-controlled step's history per strand (empty until a tolerance is set).
    histories: Vec<StepHistory<D>>,
    ws: Box<FixedWorkspace<N, D, E>>,
}

impl<const N: usize, const D: usize, const E: usize, const B: usize> Group for Strands<N, D, E, B> {
    fn elements(&self) -> usize {
        N
    }
    fn len(&self) -> usize {
        self.strands.len()
    }
    fn strand_bytes(&self) -> usize {
        FixedStrand::<N, D, B>::BYTES
    }
    fn workspace_bytes(&self) -> usize {
        FixedWorkspace::<N, D, E>::BYTES
    }
    fn step(&mut self, settings: &BatchSettings, dt: f64) -> BatchOutcome {
        let mut outcome = BatchOutcome::default();
        let mut histories = self.histories.iter_mut();
        for (i, strand) in self.strands.iter_mut().enumerate() {
            let mut report = ToleranceReport::default();
            let r = step_batch_strand(
                &ClosedForm,
                strand,
                histories.next(),
                settings,
                dt,
                &mut self.ws,
                &mut outcome.counts,
                &mut report,
            );
            outcome.record(i, r, &report);
        }
        outcome
    }
    fn forget_energy(&mut self) {
        for s in &mut self.strands {
            s.last_energy = None;
        }
    }
    fn keep_histories(&mut self) {
        self.histories
            .resize_with(self.strands.len(), StepHistory::default);
    }
    fn centreline(&self, i: usize, head: &HeadState, out: &mut Vec<f64>) {
        let mut ends = [Pose::default(); E];
        fixed::centreline(&ClosedForm, &self.strands[i], &mut ends);
        for end in &ends {
            out.extend_from_slice(head.to_world(&end.position).as_slice());
        }
    }
    fn q(&self, i: usize) -> &[f64] {
        &self.strands[i].q
    }
    fn v(&self, i: usize) -> &[f64] {
        &self.strands[i].v
    }
    fn set_state(&mut self, i: usize, q: &[f64], v: &[f64]) {
        let (mut qq, mut vv) = ([0.0; D], [0.0; D]);
        qq.copy_from_slice(&q[..D]);
        vv.copy_from_slice(&v[..D]);
        self.strands[i].set_state(&qq, &vv);
        if let Some(h) = self.histories.get_mut(i) {
            h.forget();
        }
    }
    fn energy(&mut self, i: usize, settings: &BatchSettings) -> (f64, f64, f64) {
        let effects = Effects {
            gravity: settings.input.gravity,
            head_moves: false,
        };
        let e = fixed::energy(
            &ClosedForm,
            &self.strands[i],
            &effects,
            &settings.input.head,
            0.0,
            &mut self.ws,
        );
        (e.kinetic, e.elastic, e.potential)
    }
}

/// Builds the strands of a batch from parameters.
struct FromSpecs<'a> {
    specs: &'a [BatchStrandSpec<'a>],
}

impl SizeVisitor for FromSpecs<'_> {
    type Output = Result<Box<dyn Group>, (usize, ParamsError)>;
    fn visit<const N: usize, const D: usize, const E: usize, const B: usize>(self) -> Self::Output {
        let mut strands = Vec::with_capacity(self.specs.len());
        for (i, s) in self.specs.iter().enumerate() {
            let params = s.params::<N, D>().map_err(|e| (i, e))?;
            strands.push(FixedStrand::at_rest(params));
        }
        Ok(Box::new(Strands::<N, D, E, B> {
            strands,
            histories: Vec::new(),
            ws: Box::new(FixedWorkspace::new()),
        }))
    }
}

/// Builds the strands of a batch from a scene's strands and initial states.
struct FromScene<'a> {
    strands: &'a [(&'a Strand, &'a [f64])],
}

impl SizeVisitor for FromScene<'_> {
    type Output = Option<Box<dyn Group>>;
    fn visit<const N: usize, const D: usize, const E: usize, const B: usize>(self) -> Self::Output {
        let mut strands = Vec::with_capacity(self.strands.len());
        for (strand, q0) in self.strands {
            let mut s = FixedStrand::<N, D, B>::at_rest(fixed_params::<N, D>(strand)?);
            if q0.len() != D {
                return None;
            }
            s.q.copy_from_slice(q0);
            strands.push(s);
        }
        Some(Box::new(Strands::<N, D, E, B> {
            strands,
            histories: Vec::new(),
            ws: Box::new(FixedWorkspace::new()),
        }))
    }
}

/// What one `Batch.step` did (the C library's `ShStepReport`).
#[pyclass(module = "superhelix", frozen, get_all)]
#[derive(Debug, Clone, Copy)]
pub struct StepReport {
    /// Strands stepped (those whose step failed included).
    stepped: usize,
    /// Strands whose step failed (each kept its state).
    failed: usize,
    /// Index of the first strand whose step failed, or None.
    first_failed: Option<usize>,
    /// Largest rotation a step put into one element, rad (l_Q |Δd_Q|); with the plain
    /// step keep it below ~0.2 by the choice of dt.
    max_element_rotation: f64,
    /// Linear solves of the checked or error-controlled steps, accepted or not.
    attempts: usize,
    /// Checked step: steps split into halves (each split counts once).
    substeps: usize,
    /// Checked step: steps split because they created energy.
    energy_rejected: usize,
    /// Steps whose excess energy was removed from the velocities.
    energy_limited: usize,
    /// Checked step: deepest substeps accepted although their energy exceeded the bound.
    energy_unbalanced: usize,
    /// Error-controlled step: steps accepted, all strands (0 with fixed steps).
    steps: usize,
    /// Error-controlled step: steps rejected and retried shorter.
    rejected: usize,
    /// Error-controlled step: largest estimated local error of an accepted step, / L.
    largest_error: f64,
    /// Error-controlled step: the smallest step any strand took, s (0: none).
    smallest_step: f64,
    /// Error-controlled step: the largest step any strand took, s.
    largest_step: f64,
}

impl StepReport {
    fn of(stepped: usize, o: &BatchOutcome) -> StepReport {
        StepReport {
            stepped,
            failed: o.failed,
            first_failed: o.first.map(|(i, _)| i),
            max_element_rotation: o.max_element_rotation,
            attempts: o.counts.attempts + o.tolerance.solves,
            substeps: o.counts.substeps,
            energy_rejected: o.counts.energy_rejected,
            energy_limited: o.counts.energy_limited + o.tolerance.energy_limited,
            energy_unbalanced: o.counts.energy_unbalanced,
            steps: o.tolerance.steps,
            rejected: o.tolerance.rejected,
            largest_error: o.tolerance.largest_error,
            smallest_step: o.tolerance.smallest_step,
            largest_step: o.tolerance.largest_step,
        }
    }
}

#[pymethods]
impl StepReport {
    /// The report as a dict.
    fn as_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("stepped", self.stepped)?;
        d.set_item("failed", self.failed)?;
        d.set_item("first_failed", self.first_failed)?;
        d.set_item("max_element_rotation", self.max_element_rotation)?;
        d.set_item("attempts", self.attempts)?;
        d.set_item("substeps", self.substeps)?;
        d.set_item("energy_rejected", self.energy_rejected)?;
        d.set_item("energy_limited", self.energy_limited)?;
        d.set_item("energy_unbalanced", self.energy_unbalanced)?;
        d.set_item("steps", self.steps)?;
        d.set_item("rejected", self.rejected)?;
        d.set_item("largest_error", self.largest_error)?;
        d.set_item("smallest_step", self.smallest_step)?;
        d.set_item("largest_step", self.largest_step)?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let first = self
            .first_failed
            .map_or("None".to_string(), |i| i.to_string());
        format!(
            "StepReport(stepped={}, failed={}, first_failed={first}, max_element_rotation={:e}, \
             attempts={}, substeps={}, energy_rejected={}, energy_limited={}, \
             energy_unbalanced={}, steps={}, rejected={}, largest_error={:e}, \
             smallest_step={:e}, largest_step={:e})",
            self.stepped,
            self.failed,
            self.max_element_rotation,
            self.attempts,
            self.substeps,
            self.energy_rejected,
            self.energy_limited,
            self.energy_unbalanced,
            self.steps,
            self.rejected,
            self.largest_error,
            self.smallest_step,
            self.largest_step
        )
    }
}

struct Inner {
    group: Box<dyn Group>,
    settings: BatchSettings,
    last: Option<StepReport>,
}

/// A batch of strands with the same number of elements N, stepped by the embedded
/// fixed-N step (the step a game engine embeds, docs/embedding.md), the head pose given
/// per step: the C library's ShBatch, from Python.
///
/// Batch(elements, count=1, *, length=0.2, element_lengths=None, root_position=(0, 0, 0),
///       root_frame=None, radius=50e-6, ellipticity=1.0, youngs_modulus=1.5e9,
///       poisson_ratio=0.48, density=1300.0, natural=(0, 0, 0), internal_friction=5e-11,
///       air_drag=5e-6, gravity=None)
///
/// Every strand starts at rest in its natural shape (q = natural, qdot = 0), the head at
/// rest at the origin. Per-strand values may be given per strand (a leading axis of
/// length count) or once for all: element_lengths (N,) or (count, N) (default: length /
/// N each); root_position (3,) or (count, 3), head coordinates, m; root_frame (3, 3) or
/// (count, 3, 3), a rotation whose columns are n0 (the tangent at the root), n1, n2
/// (default: n0 = (0, 0, -1), n1 = (1, 0, 0), n2 = (0, -1, 0), hanging down); natural (3,)
/// for every element, (3N,) or (count, 3N), rad/m (τ, κ1, κ2 per element). The cross-
/// section (radius m, ellipticity, Young's modulus Pa, Poisson ratio, density kg/m³),
/// internal friction γ (kg m³/s) and air drag ν (kg/(m s)) are shared; the defaults
/// are the C example's fibre. gravity: (3,) world m/s², or None. A value out of range
/// raises ValueError naming the strand and the parameter.
#[pyclass(module = "superhelix", frozen)]
pub struct Batch {
    inner: Mutex<Inner>,
}

/// `value` as `count` rows of `width` values: given once (shape `once`) or per strand
/// (shape (count, *once)).
fn per_strand_rows(
    value: &Bound<'_, PyAny>,
    name: &str,
    count: usize,
    once: &[usize],
) -> PyResult<Vec<Vec<f64>>> {
    let (shape, values) = to_f64(value, name)?;
    let width: usize = once.iter().product();
    if shape == once {
        return Ok(vec![values; count]);
    }
    let mut per = vec![count];
    per.extend_from_slice(once);
    if shape == per {
        return Ok(values.chunks(width).map(<[f64]>::to_vec).collect());
    }
    Err(PyValueError::new_err(format!(
        "{name}: expected shape {} or {}, got {}",
        shape_text(once),
        shape_text(&per),
        shape_text(&shape)
    )))
}

fn head_state(
    position: &Bound<'_, PyAny>,
    rotation: &Bound<'_, PyAny>,
    derivatives: [Option<&Bound<'_, PyAny>>; 4],
) -> PyResult<(HeadState, bool)> {
    let x = vector(position, "head_position", 3)?;
    let (shape, r) = to_f64(rotation, "head_rotation")?;
    if shape != [3, 3] {
        return Err(PyValueError::new_err(format!(
            "head_rotation: expected shape (3, 3), got {}",
            shape_text(&shape)
        )));
    }
    let names = [
        "velocity",
        "acceleration",
        "angular_velocity",
        "angular_acceleration",
    ];
    let moves = derivatives.iter().any(Option::is_some);
    let mut d = [Vector3::zeros(); 4];
    for ((slot, value), name) in d.iter_mut().zip(derivatives).zip(names) {
        if let Some(value) = value {
            let v = vector(value, name, 3)?;
            *slot = Vector3::new(v[0], v[1], v[2]);
        }
    }
    let all = x.iter().chain(&r).chain(d.iter().flat_map(|v| v.iter()));
    if !all.into_iter().all(|v| v.is_finite()) {
        return Err(PyValueError::new_err("head: every value must be finite"));
    }
    let rotation = Matrix3::from_row_slice(&r);
    if (rotation.transpose() * rotation - Matrix3::identity()).amax() > 1e-6
        || rotation.determinant() <= 0.0
    {
        return Err(PyValueError::new_err(
            "head_rotation: must be a rotation (orthonormal within 1e-6, det > 0)",
        ));
    }
    Ok((
        HeadState {
            position: Vector3::new(x[0], x[1], x[2]),
            rotation,
            velocity: d[0],
            acceleration: d[1],
            omega: d[2],
            alpha: d[3],
        },
        moves,
    ))
}

fn gravity_of(g: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Vector3<f64>>> {
    match g {
        None => Ok(None),
        Some(g) if g.is_none() => Ok(None),
        Some(g) => {
            let v = vector(g, "gravity", 3)?;
            if !v.iter().all(|x| x.is_finite()) {
                return Err(PyValueError::new_err("gravity: must be finite"));
            }
            Ok(Some(Vector3::new(v[0], v[1], v[2])))
        }
    }
}

impl Batch {
    fn lock(&self) -> PyResult<MutexGuard<'_, Inner>> {
        self.inner.lock().map_err(|_| {
            PyRuntimeError::new_err("this batch was poisoned by an earlier internal error")
        })
    }

    fn with_group(group: Box<dyn Group>, gravity: Option<Vector3<f64>>, head: HeadState) -> Batch {
        Batch {
            inner: Mutex::new(Inner {
                group,
                settings: BatchSettings {
                    input: StepInput {
                        head,
                        gravity,
                        head_moves: false,
                    },
                    checked: true,
                    tolerance: None,
                },
                last: None,
            }),
        }
    }
}

fn supported(n: usize) -> bool {
    superhelix_generated::fixed::SIZES.contains(&n)
}

/// How to get the fixed-N code for `n` elements, for the message refusing it.
fn how_to_add(n: usize) -> String {
    if (1..=superhelix_runtime::scene::MAX_ELEMENTS).contains(&n) {
        format!(": build the module with it (`SUPERHELIX_N={n} pip install ./python`), or step the scene with `Scene.simulation()`, which takes any N")
    } else {
        String::new()
    }
}

#[pymethods]
impl Batch {
    #[new]
    #[pyo3(signature = (
        elements, count = 1, *, length = 0.2, element_lengths = None,
        root_position = None, root_frame = None, radius = 50e-6, ellipticity = 1.0,
        youngs_modulus = 1.5e9, poisson_ratio = 0.48, density = 1300.0, natural = None,
        internal_friction = 5e-11, air_drag = 5e-6, gravity = None
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        elements: usize,
        count: usize,
        length: f64,
        element_lengths: Option<&Bound<'_, PyAny>>,
        root_position: Option<&Bound<'_, PyAny>>,
        root_frame: Option<&Bound<'_, PyAny>>,
        radius: f64,
        ellipticity: f64,
        youngs_modulus: f64,
        poisson_ratio: f64,
        density: f64,
        natural: Option<&Bound<'_, PyAny>>,
        internal_friction: f64,
        air_drag: f64,
        gravity: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Batch> {
        let n = elements;
        if !supported(n) {
            return Err(PyValueError::new_err(format!(
                "elements: no generated fixed-N code for N = {n} in this build (sizes: {:?}){}",
                superhelix_generated::fixed::SIZES,
                how_to_add(n)
            )));
        }
        if count == 0 || count > MAX_STRANDS {
            return Err(PyValueError::new_err(format!(
                "count: must be in 1..={MAX_STRANDS}, got {count}"
            )));
        }
        // the cross-section's checks, as the C library makes them
        let positive = |x: f64| x.is_finite() && x > 0.0;
        let section_problem = if !positive(radius) {
            Some("radius: must be finite and > 0")
        } else if !(ellipticity.is_finite() && ellipticity >= 1.0) {
            Some("ellipticity: must be finite and >= 1")
        } else if !positive(youngs_modulus) {
            Some("youngs_modulus: must be finite and > 0")
        } else if !(poisson_ratio > -1.0 && poisson_ratio <= 0.5) {
            Some("poisson_ratio: must be in (-1, 0.5]")
        } else if !positive(density) {
            Some("density: must be finite and > 0")
        } else {
            None
        };
        if let Some(p) = section_problem {
            return Err(PyValueError::new_err(p));
        }
        let lengths = match element_lengths {
            Some(v) => per_strand_rows(v, "element_lengths", count, &[n])?,
            None => vec![vec![length / n as f64; n]; count],
        };
        let roots = match root_position {
            Some(v) => per_strand_rows(v, "root_position", count, &[3])?,
            None => vec![vec![0.0; 3]; count],
        };
        let frames = match root_frame {
            Some(v) => per_strand_rows(v, "root_frame", count, &[3, 3])?,
            // n0 down, n1 along x, n2 = n0 × n1 (rows of the matrix with these columns)
            None => vec![vec![0.0, 1.0, 0.0, 0.0, 0.0, -1.0, -1.0, 0.0, 0.0]; count],
        };
        let naturals = match natural {
            None => vec![vec![0.0; 3 * n]; count],
            Some(v) => {
                let (shape, _) = to_f64(v, "natural")?;
                if shape == [3] {
                    per_strand_rows(v, "natural", count, &[3])?
                        .into_iter()
                        .map(|k| k.iter().copied().cycle().take(3 * n).collect())
                        .collect()
                } else {
                    per_strand_rows(v, "natural", count, &[3 * n])?
                }
            }
        };
        let gravity = gravity_of(gravity)?;
        let section = section_terms(radius, ellipticity, youngs_modulus, poisson_ratio, density);
        let specs: Vec<BatchStrandSpec<'_>> = (0..count)
            .map(|i| {
                let f = &frames[i];
                BatchStrandSpec {
                    root_position: [roots[i][0], roots[i][1], roots[i][2]],
                    // columns of the (row-major) matrix: root_frame[c][r] = M[r][c]
                    root_frame: [[f[0], f[3], f[6]], [f[1], f[4], f[7]], [f[2], f[5], f[8]]],
                    lengths: &lengths[i],
                    section,
                    natural: &naturals[i],
                    internal_friction,
                    air_drag,
                }
            })
            .collect();
        let built = py.detach(|| visit_size(n, FromSpecs { specs: &specs }));
        match built {
            Some(Ok(group)) => Ok(Batch::with_group(group, gravity, HeadState::rest())),
            Some(Err((i, e))) => Err(PyValueError::new_err(format!("strand {i}: {e}"))),
            None => Err(PyValueError::new_err(format!(
                "elements: no generated fixed-N code for N = {n}{}",
                how_to_add(n)
            ))),
        }
    }

    /// Batch.from_scene(scene) -> Batch
    ///
    /// The strands of a scene (all with the same N, with this build's fixed-N code; no
    /// point loads) as the embedded engine keeps them: their parameters, their initial
    /// states, the scene's gravity, the head still at its pose of t = 0. Stepped by the
    /// scene's dt with that head, they take the steps `scene.run()` takes under the
    /// embedded engine, to round-off.
    #[staticmethod]
    fn from_scene(scene: &Scene) -> PyResult<Batch> {
        let setup = scene.setup();
        let n = setup
            .strands
            .first()
            .map(|s| s.strand.geometry.elements())
            .unwrap_or(0);
        if let Some((i, s)) = setup
            .strands
            .iter()
            .enumerate()
            .find(|(_, s)| s.strand.geometry.elements() != n)
        {
            return Err(PyValueError::new_err(format!(
                "strands[{i}]: strand '{}' has N = {} where the first has {n} (one N per batch)",
                s.strand.name,
                s.strand.geometry.elements()
            )));
        }
        if let Some((i, _)) = setup
            .strands
            .iter()
            .enumerate()
            .find(|(_, s)| !s.strand.point_loads.is_empty())
        {
            return Err(PyValueError::new_err(format!(
                "strands[{i}].point_loads: the embedded step has no point loads"
            )));
        }
        if !supported(n) {
            return Err(PyValueError::new_err(format!(
                "elements: no generated fixed-N code for N = {n} in this build (sizes: {:?}){}",
                superhelix_generated::fixed::SIZES,
                how_to_add(n)
            )));
        }
        let strands: Vec<(&Strand, &[f64])> = setup
            .strands
            .iter()
            .map(|s| (&s.strand, s.q0.as_slice()))
            .collect();
        let group = visit_size(n, FromScene { strands: &strands })
            .flatten()
            .ok_or_else(|| {
                PyValueError::new_err("the scene's strands do not fit the fixed-N step")
            })?;
        let head = setup.head.state(0.0);
        let head = HeadState {
            velocity: Vector3::zeros(),
            acceleration: Vector3::zeros(),
            omega: Vector3::zeros(),
            alpha: Vector3::zeros(),
            ..head
        };
        Ok(Batch::with_group(group, setup.environment.gravity, head))
    }

    /// batch.step(dt, head_position=None, head_rotation=None, *, velocity=None,
    ///            acceleration=None, angular_velocity=None, angular_acceleration=None)
    ///            -> StepReport
    ///
    /// Step every strand by dt (s, finite and > 0), with the GIL released. The head pose
    /// (position (3,), world m; rotation (3, 3), head to world), when given, is the
    /// head's state at the end of this step and stays for the next ones (as
    /// set_head). Given any of its derivatives (world velocity and acceleration, angular
    /// velocity and acceleration in head coordinates), the head moves: their fictitious
    /// forces act and the substeps follow the motion extrapolated back from the end of
    /// the step; without them the head is still. Every strand is stepped; one whose step
    /// fails keeps its state, and StepError (with .report) names the first.
    #[pyo3(signature = (
        dt, head_position = None, head_rotation = None, *, velocity = None,
        acceleration = None, angular_velocity = None, angular_acceleration = None
    ))]
    #[allow(clippy::too_many_arguments)]
    fn step(
        &self,
        py: Python<'_>,
        dt: f64,
        head_position: Option<&Bound<'_, PyAny>>,
        head_rotation: Option<&Bound<'_, PyAny>>,
        velocity: Option<&Bound<'_, PyAny>>,
        acceleration: Option<&Bound<'_, PyAny>>,
        angular_velocity: Option<&Bound<'_, PyAny>>,
        angular_acceleration: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<StepReport> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(PyValueError::new_err(format!(
                "dt: must be finite and > 0, got {dt}"
            )));
        }
        let derivatives = [
            velocity,
            acceleration,
            angular_velocity,
            angular_acceleration,
        ];
        let head = match (head_position, head_rotation) {
            (None, None) if derivatives.iter().all(Option::is_none) => None,
            (Some(p), Some(r)) => Some(head_state(p, r, derivatives)?),
            _ => {
                return Err(PyValueError::new_err(
                    "head_position, head_rotation: give both (derivatives need them too)",
                ))
            }
        };
        let (report, outcome) = py.detach(|| -> PyResult<(StepReport, BatchOutcome)> {
            let mut guard = self.inner.lock().map_err(|_| {
                PyRuntimeError::new_err("this batch was poisoned by an earlier internal error")
            })?;
            let inner = &mut *guard;
            if let Some((state, moves)) = head {
                set_head(inner, state, moves);
            }
            let outcome = inner.group.step(&inner.settings, dt);
            let report = StepReport::of(inner.group.len(), &outcome);
            inner.last = Some(report);
            Ok((report, outcome))
        })?;
        match outcome.first {
            None => Ok(report),
            Some((i, e)) => {
                let more = match outcome.failed {
                    1 => String::new(),
                    f => format!(" ({} more strands failed)", f - 1),
                };
                let err = PyStepError::new_err(format!("strand {i}: {e}; it kept its state{more}"));
                let _ = err.value(py).setattr("report", Py::new(py, report)?);
                Err(err)
            }
        }
    }

    /// batch.set_head(position, rotation, *, velocity=None, acceleration=None,
    ///                angular_velocity=None, angular_acceleration=None) -> None
    ///
    /// The head state the next steps end at (it stays until set again), and the frame
    /// centrelines() maps to world coordinates with; see step().
    #[pyo3(signature = (
        position, rotation, *, velocity = None, acceleration = None,
        angular_velocity = None, angular_acceleration = None
    ))]
    fn set_head(
        &self,
        position: &Bound<'_, PyAny>,
        rotation: &Bound<'_, PyAny>,
        velocity: Option<&Bound<'_, PyAny>>,
        acceleration: Option<&Bound<'_, PyAny>>,
        angular_velocity: Option<&Bound<'_, PyAny>>,
        angular_acceleration: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let (state, moves) = head_state(
            position,
            rotation,
            [
                velocity,
                acceleration,
                angular_velocity,
                angular_acceleration,
            ],
        )?;
        set_head(&mut *self.lock()?, state, moves);
        Ok(())
    }

    /// batch.set_gravity(g) -> None
    ///
    /// Gravity for the next steps: (3,) world m/s², or None for none.
    #[pyo3(signature = (g))]
    fn set_gravity(&self, g: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
        let g = gravity_of(g)?;
        let mut inner = self.lock()?;
        if g != inner.settings.input.gravity {
            // the strands' potential energies change with gravity
            inner.group.forget_energy();
        }
        inner.settings.input.gravity = g;
        Ok(())
    }

    /// batch.set_checked(checked) -> None
    ///
    /// True (the default): the checked step, the runtime's (split when it rotates an
    /// element by more than 0.2 rad or creates energy). False: the plain linearly
    /// implicit step, cheaper, unchecked (keep StepReport.max_element_rotation below
    /// ~0.2 by the choice of dt).
    fn set_checked(&self, checked: bool) -> PyResult<()> {
        self.lock()?.settings.checked = checked;
        Ok(())
    }

    /// batch.set_tolerance(tau) -> None
    ///
    /// Error-controlled steps: within every dt each strand takes steps of its own so that
    /// each one's estimated local error stays below tau (relative to its length; 1e-8 to
    /// 0.5). 0 returns to fixed steps. Anything else raises ValueError and changes
    /// nothing.
    fn set_tolerance(&self, tau: f64) -> PyResult<()> {
        let mut inner = self.lock()?;
        if tau == 0.0 {
            inner.settings.tolerance = None;
            return Ok(());
        }
        if !(MIN_TOLERANCE..=MAX_TOLERANCE).contains(&tau) {
            return Err(PyValueError::new_err(format!(
                "tolerance: {tau:e} is neither 0 nor within [1e-8, 0.5]"
            )));
        }
        inner.group.keep_histories();
        inner.settings.tolerance = Some(tau);
        Ok(())
    }

    /// The tolerance of the error-controlled steps, or None (fixed steps).
    #[getter]
    fn tolerance(&self) -> PyResult<Option<f64>> {
        Ok(self.lock()?.settings.tolerance)
    }

    /// Whether the checked step is taken (see set_checked).
    #[getter]
    fn checked(&self) -> PyResult<bool> {
        Ok(self.lock()?.settings.checked)
    }

    /// Number of strands.
    #[getter]
    fn count(&self) -> PyResult<usize> {
        Ok(self.lock()?.group.len())
    }

    /// Number of elements N of every strand.
    #[getter]
    fn elements(&self) -> PyResult<usize> {
        Ok(self.lock()?.group.elements())
    }

    /// Bytes one strand keeps (FixedStrand::BYTES; sh_strand_bytes in C).
    #[getter]
    fn strand_bytes(&self) -> PyResult<usize> {
        Ok(self.lock()?.group.strand_bytes())
    }

    /// Bytes of the batch's workspace (sh_workspace_bytes in C).
    #[getter]
    fn workspace_bytes(&self) -> PyResult<usize> {
        Ok(self.lock()?.group.workspace_bytes())
    }

    /// The report of the last step (None before the first).
    #[getter]
    fn last_step(&self) -> PyResult<Option<StepReport>> {
        Ok(self.lock()?.last)
    }

    /// Generalized coordinates of every strand, rad/m: (count, 3N). A copy.
    #[getter]
    fn q(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let inner = self.lock()?;
        let (c, d) = (inner.group.len(), 3 * inner.group.elements());
        let data = (0..c).flat_map(|i| inner.group.q(i).to_vec()).collect();
        drop(inner);
        f64_array(py, &[c, d], data)
    }

    /// Generalized velocities of every strand, rad/(m s): (count, 3N). A copy.
    #[getter]
    fn qdot(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let inner = self.lock()?;
        let (c, d) = (inner.group.len(), 3 * inner.group.elements());
        let data = (0..c).flat_map(|i| inner.group.v(i).to_vec()).collect();
        drop(inner);
        f64_array(py, &[c, d], data)
    }

    /// batch.set_state(i, q, qdot=None) -> None
    ///
    /// Replace strand i's state (3N values each; qdot zero when None). The strand
    /// forgets its kept basis, energy and error-control history.
    #[pyo3(signature = (i, q, qdot = None))]
    fn set_state(
        &self,
        i: usize,
        q: &Bound<'_, PyAny>,
        qdot: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let mut inner = self.lock()?;
        let (count, d) = (inner.group.len(), 3 * inner.group.elements());
        if i >= count {
            return Err(PyIndexError::new_err(format!(
                "strand {i}: the batch has {count} strand(s)"
            )));
        }
        let q = vector(q, "q", d)?;
        let v = match qdot {
            Some(v) => vector(v, "qdot", d)?,
            None => vec![0.0; d],
        };
        if !q.iter().chain(&v).all(|x| x.is_finite()) {
            return Err(PyValueError::new_err("q, qdot: every value must be finite"));
        }
        inner.group.set_state(i, &q, &v);
        Ok(())
    }

    /// batch.centrelines() -> array
    ///
    /// The N + 1 element ends of every strand in world coordinates (the head last set),
    /// m: (count, N + 1, 3).
    fn centrelines(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let inner = self.lock()?;
        let (c, n) = (inner.group.len(), inner.group.elements());
        let mut data = Vec::with_capacity(c * (n + 1) * 3);
        for i in 0..c {
            inner
                .group
                .centreline(i, &inner.settings.input.head, &mut data);
        }
        drop(inner);
        f64_array(py, &[c, n + 1, 3], data)
    }

    /// batch.energies() -> dict
    ///
    /// Each strand's energy in its state, J, arrays of shape (count,): kinetic (relative
    /// to the head), elastic (½ Σ K (q − q_n)²), gravity (with the head last set),
    /// potential (elastic plus gravity, as `Simulation.energies()` and a run's
    /// `potential_energy` count it) and total, as the checked step measures them.
    fn energies<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let mut inner = self.lock()?;
        let settings = inner.settings;
        let c = inner.group.len();
        let (mut t, mut u, mut v) = (vec![], vec![], vec![]);
        for i in 0..c {
            let (k, e, p) = inner.group.energy(i, &settings);
            t.push(k);
            u.push(e);
            v.push(p);
        }
        drop(inner);
        let total: Vec<f64> = (0..c).map(|i| t[i] + u[i] + v[i]).collect();
        let d = PyDict::new(py);
        d.set_item("kinetic", f64_array(py, &[c], t)?)?;
        let potential: Vec<f64> = (0..c).map(|i| u[i] + v[i]).collect();
        d.set_item("elastic", f64_array(py, &[c], u)?)?;
        d.set_item("gravity", f64_array(py, &[c], v)?)?;
        d.set_item("potential", f64_array(py, &[c], potential)?)?;
        d.set_item("total", f64_array(py, &[c], total)?)?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        match self.inner.lock() {
            Ok(inner) => format!(
                "<superhelix.Batch: {} strand{} of N = {}, {}>",
                inner.group.len(),
                if inner.group.len() == 1 { "" } else { "s" },
                inner.group.elements(),
                match (inner.settings.tolerance, inner.settings.checked) {
                    (Some(t), _) => format!("error-controlled steps at {t:e}"),
                    (None, true) => "checked steps".to_string(),
                    (None, false) => "plain steps".to_string(),
                }
            ),
            Err(_) => "<superhelix.Batch (poisoned)>".to_string(),
        }
    }
}

/// Sets the head of the next steps (the kept energies forgotten when whether the head
/// moves changes: they were measured in the other field).
fn set_head(inner: &mut Inner, state: HeadState, moves: bool) {
    if moves != inner.settings.input.head_moves {
        inner.group.forget_energy();
    }
    inner.settings.input.head = state;
    inner.settings.input.head_moves = moves;
}

/// The numbers of elements N this build has fixed-N code for.
pub fn supported_elements() -> Vec<usize> {
    superhelix_generated::fixed::SIZES.to_vec()
}
