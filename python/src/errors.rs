//! The runtime's errors as Python exceptions.
//!
//! - [`SceneError`] (a `ValueError`): a scene the runtime refuses. Its message is the list
//!   of problems exactly as `superhelix validate` prints them on stderr, one per line
//!   (`field: message`), and its `problems` attribute holds them as `(field, message)`
//!   pairs.
//! - [`SimulationError`] (a `RuntimeError`): a step failed (a strand diverged or a solve
//!   failed); the message is the runtime's, naming the strand, the time and the cause.
//! - [`StepError`] (a `RuntimeError`): a strand of a [`crate::batch::Batch`] failed its
//!   step (it kept its state); `report` holds the step's report.
//! - An unreadable file is an `OSError` (`FileNotFoundError`, `PermissionError`, ...)
//!   naming the path.

use pyo3::exceptions::PyValueError;
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyPermissionError, PyRuntimeError};
use pyo3::prelude::*;
use pyo3::types::PyList;
use superhelix_runtime::{Error, FieldError};

pyo3::create_exception!(
    superhelix,
    SceneError,
    PyValueError,
    "A scene the runtime refuses. str(e) is the list of problems exactly as `superhelix validate` prints them (one `field: message` per line); e.problems holds them as (field, message) pairs."
);

pyo3::create_exception!(
    superhelix,
    SimulationError,
    PyRuntimeError,
    "A step of a simulation failed: a strand's state became non-finite or a solve failed. The message names the strand, the time and the cause; e.result (when set) holds the frames computed before the failure."
);

pyo3::create_exception!(
    superhelix,
    StepError,
    PyRuntimeError,
    "A strand of a Batch failed its step and kept the state it had; the other strands stepped. The message names the first failing strand; e.report holds the step's StepReport."
);

/// The problems a scene error lists, as `superhelix validate` lists them: a syntax error
/// and any other error are one problem of the field `<toml>`.
pub fn problems(e: Error) -> Vec<FieldError> {
    match e {
        Error::Invalid(errors) => errors,
        Error::Parse(message) => vec![FieldError::new("<toml>", message)],
        other => vec![FieldError::new("<toml>", other.to_string())],
    }
}

/// A [`SceneError`] listing `problems` (its message: one `field: message` per line).
pub fn scene_error(py: Python<'_>, problems: &[FieldError]) -> PyErr {
    let message = problems
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join("\n");
    let err = SceneError::new_err(message);
    let pairs: Vec<(String, String)> = problems
        .iter()
        .map(|p| (p.field.clone(), p.message.clone()))
        .collect();
    // attaching the list cannot fail short of memory; the message carries it anyway
    if let Ok(list) = PyList::new(py, pairs) {
        let _ = err.value(py).setattr("problems", list);
    }
    err
}

/// A runtime error met while reading a scene or building its simulation: every problem
/// as a [`SceneError`], a file that cannot be read as an `OSError`.
pub fn build_error(py: Python<'_>, e: Error) -> PyErr {
    match e {
        Error::Io { path, source } => io_error(&path, &source),
        other => scene_error(py, &problems(other)),
    }
}

/// A runtime error met while stepping: a [`SimulationError`] (an `OSError` for files).
pub fn run_error(e: Error) -> PyErr {
    match e {
        Error::Io { path, source } => io_error(&path, &source),
        other => SimulationError::new_err(other.to_string()),
    }
}

/// An `OSError` of the kind of `source`, naming `path`.
/// A file or value refused (`Simulation.load`, `save`): `ValueError` naming each field,
/// an I/O error as [`io_error`].
pub fn input_error(e: Error) -> PyErr {
    match e {
        Error::Io { path, source } => io_error(&path, &source),
        Error::Invalid(errors) => PyValueError::new_err(
            errors
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join("\n"),
        ),
        other => SimulationError::new_err(other.to_string()),
    }
}

pub fn io_error(path: &str, source: &std::io::Error) -> PyErr {
    let message = format!("{path}: {source}");
    match source.kind() {
        std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
        std::io::ErrorKind::PermissionDenied => PyPermissionError::new_err(message),
        _ => PyOSError::new_err(message),
    }
}
