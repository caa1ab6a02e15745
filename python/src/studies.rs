//! `superhelix.study` and `superhelix.stress`: the studies of `superhelix study` and
//! `superhelix stress`, run by the same library functions (`superhelix-studies`), their
//! results returned as dicts and lists of plain values.
//!
//! - [`study`] returns what `superhelix study` writes to `DIR/study.json`
//!   ([`superhelix_studies::study::to_json`]), and with `out` writes the same files.
//! - [`stress`] returns one dict per case (what `superhelix stress --verbose` prints on a
//!   case's line, unrounded, and its failure), the counts and the report the command
//!   prints.

use crate::errors::input_error;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;
use superhelix_studies::stress::{self as hard_cases, CaseResult, StressOptions};
use superhelix_studies::study::{run_study, to_json, write_report, StudyOptions};
use superhelix_studies::{Error, FieldError};

/// A library error as a Python exception: a refused option as a `ValueError` naming the
/// keyword argument (`only`, `integrator`, `max_split_depth`, ...), a file that cannot be
/// written as an `OSError` naming the path, anything else as a `RuntimeError`.
fn option_error(e: Error) -> PyErr {
    match e {
        Error::Invalid(errors) => input_error(Error::Invalid(
            errors
                .into_iter()
                .map(|f| FieldError::new(keyword(&f.field), f.message))
                .collect(),
        )),
        e @ Error::Io { .. } => input_error(e),
        other => PyRuntimeError::new_err(other.to_string()),
    }
}

/// The keyword argument of a command-line option: `--max-split-depth` is
/// `max_split_depth`; other field names are kept.
fn keyword(option: &str) -> String {
    match option.strip_prefix("--") {
        Some(name) => name.replace('-', "_"),
        None => option.to_string(),
    }
}

/// A JSON value as plain Python values: objects as dicts (keys in the JSON's order),
/// arrays as lists, numbers as int or float, null as None.
fn json_to_py<'py>(py: Python<'py>, value: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    use serde_json::Value;
    Ok(match value {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any(),
        Value::Number(n) => match (n.as_u64(), n.as_i64(), n.as_f64()) {
            (Some(u), _, _) => u.into_pyobject(py)?.into_any(),
            (None, Some(i), _) => i.into_pyobject(py)?.into_any(),
            (None, None, Some(f)) => f.into_pyobject(py)?.into_any(),
            (None, None, None) => py.None().into_bound(py),
        },
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(json_to_py(py, item)?)?;
            }
            list.into_any()
        }
        Value::Object(map) => {
            let dict = PyDict::new(py);
            for (k, v) in map {
                dict.set_item(k, json_to_py(py, v)?)?;
            }
            dict.into_any()
        }
    })
}

/// study(only=None, quick=False, out=None) -> dict
///
/// What accuracy costs, as `superhelix study [--quick] [--only PROBLEM]` measures it:
/// `only` one problem (swing, curly, frequency, cantilever, floppy, rotary, tolerance;
/// without it every problem and the cost against N), `quick` the reduced grid. Returns
/// what the command writes to `study.json`: `command`, `quick`, `wall_seconds`,
/// `problems` (per problem its `key`, `title`, `static`, `points` — each setting's
/// `label`, `elements`, `dt`, `integrator`, `kernels`, `pareto` and its `error`,
/// `signed_error` and `cost_seconds`, or `failed` —, `spatial`, `convergence`,
/// `tolerance`, `rotary`) and `cost_by_elements`. Costs and `wall_seconds` are timings
/// and differ from run to run; the errors do not. With `out` (a folder) it also writes
/// the command's files there: `report.md`, the plots and `study.json`.
#[pyfunction]
#[pyo3(signature = (only=None, quick=false, out=None))]
pub fn study<'py>(
    py: Python<'py>,
    only: Option<String>,
    quick: bool,
    out: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    let q = if quick { "True" } else { "False" };
    let command = match &only {
        Some(o) => format!("superhelix.study(only={o:?}, quick={q})"),
        None => format!("superhelix.study(quick={q})"),
    };
    let options = StudyOptions {
        quick,
        only,
        command,
    };
    let json = py
        .detach(|| -> Result<serde_json::Value, Error> {
            let study = run_study(&options, superhelix_studies::kernel_factory())?;
            if let Some(dir) = &out {
                write_report(&study, dir)?;
            }
            Ok(to_json(&study))
        })
        .map_err(option_error)?;
    json_to_py(py, &json)
}

/// One case's result as a dict.
fn case_dict<'py>(py: Python<'py>, r: &CaseResult) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("name", &r.name)?;
    d.set_item("group", r.group)?;
    d.set_item("passed", r.passed())?;
    d.set_item("known_failure", hard_cases::is_known_failure(&r.name))?;
    match &r.failure {
        Some(f) => {
            let failure = PyDict::new(py);
            failure.set_item("strand", &f.strand)?;
            failure.set_item("time", f.time)?;
            failure.set_item("cause", &f.cause)?;
            d.set_item("failure", failure)?;
        }
        None => d.set_item("failure", py.None())?,
    }
    d.set_item("seconds", r.seconds)?;
    d.set_item("steps", r.steps)?;
    d.set_item("substeps", r.substeps)?;
    d.set_item("solves", r.solves)?;
    d.set_item("strand_steps", r.strand_steps)?;
    d.set_item("limited", r.limited)?;
    d.set_item("unbalanced", r.unbalanced)?;
    d.set_item("newton_fallbacks", r.newton_fallbacks)?;
    d.set_item("field_split", r.field_split)?;
    d.set_item("field_projected", r.field_projected)?;
    d.set_item("field_undamped", r.field_undamped)?;
    d.set_item("kinetic_peak", r.kinetic_peak)?;
    d.set_item("mean_kinetic", r.mean_kinetic.map(|m| m.to_vec()))?;
    d.set_item("energy_growth", r.energy_growth)?;
    d.set_item("energy_rise", r.energy_rise)?;
    d.set_item("conservative", r.conservative)?;
    d.set_item("stretch", r.stretch)?;
    d.set_item("frame_error", r.frame_error)?;
    d.set_item("penetration", r.penetration)?;
    Ok(d)
}

/// stress(quick=False, filter=None, integrator=None, field_stiffness=None, engine=None,
///        max_split_depth=None, tolerance=None) -> dict
///
/// The hard cases, as `superhelix stress` runs them with the same options (`quick` the
/// quick subset, `filter` the cases whose name contains it, and the variants applied to
/// every case). Returns `cases` (one dict per case, in the order of the cases: `name`,
/// `group`, `passed`, `known_failure`, `failure` — None or `strand`, `time`, `cause` —,
/// `seconds` (a timing), `steps`, `substeps`, `solves`, `strand_steps`, `limited`,
/// `unbalanced`, `newton_fallbacks`, `field_split`, `field_projected`, `field_undamped`,
/// `kinetic_peak` (T/B), `mean_kinetic` (None or the two halves' mean T/B),
/// `energy_growth` and `energy_rise` (per S, or None), `conservative`, `stretch`,
/// `frame_error`, `penetration`), `count`, `failed`, `wall_seconds` and `report` (the
/// text the command prints without --verbose).
#[pyfunction]
#[pyo3(signature = (quick=false, filter=None, integrator=None, field_stiffness=None, engine=None, max_split_depth=None, tolerance=None))]
#[allow(clippy::too_many_arguments)]
pub fn stress<'py>(
    py: Python<'py>,
    quick: bool,
    filter: Option<String>,
    integrator: Option<String>,
    field_stiffness: Option<String>,
    engine: Option<String>,
    max_split_depth: Option<usize>,
    tolerance: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let options = StressOptions {
        quick,
        filter,
        integrator,
        field_stiffness,
        engine,
        max_split_depth,
        tolerance,
    };
    let (results, wall) = py
        .detach(|| -> Result<_, Error> {
            let cases = hard_cases::select_cases(&options)?;
            let start = std::time::Instant::now();
            let results = hard_cases::run_cases(&cases);
            Ok((results, start.elapsed().as_secs_f64()))
        })
        .map_err(option_error)?;
    let cases = PyList::empty(py);
    for r in &results {
        cases.append(case_dict(py, r)?)?;
    }
    let d = PyDict::new(py);
    d.set_item("cases", cases)?;
    d.set_item("count", results.len())?;
    d.set_item("failed", results.iter().filter(|r| !r.passed()).count())?;
    d.set_item("wall_seconds", wall)?;
    d.set_item("report", hard_cases::render(&results, wall))?;
    Ok(d)
}
