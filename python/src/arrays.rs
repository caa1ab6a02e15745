//! numpy arrays to and from Rust vectors, with shapes checked and named in errors.

use numpy::ndarray::{ArrayD, IxDyn};
use numpy::{IntoPyArray, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

/// A float64 array of `shape` holding `data` (C order).
pub fn f64_array(py: Python<'_>, shape: &[usize], data: Vec<f64>) -> PyResult<Py<PyAny>> {
    let a = ArrayD::from_shape_vec(IxDyn(shape), data).map_err(|e| {
        PyRuntimeError::new_err(format!("internal error: array of shape {shape:?}: {e}"))
    })?;
    Ok(a.into_pyarray(py).into_any().unbind())
}

/// An int64 array of `shape` holding `data` (C order).
pub fn i64_array(py: Python<'_>, shape: &[usize], data: Vec<i64>) -> PyResult<Py<PyAny>> {
    let a = ArrayD::from_shape_vec(IxDyn(shape), data).map_err(|e| {
        PyRuntimeError::new_err(format!("internal error: array of shape {shape:?}: {e}"))
    })?;
    Ok(a.into_pyarray(py).into_any().unbind())
}

/// `value` as float64 values (any array-like numpy converts) with its shape; `name`
/// names the argument in errors.
pub fn to_f64(value: &Bound<'_, PyAny>, name: &str) -> PyResult<(Vec<usize>, Vec<f64>)> {
    let py = value.py();
    let np = py.import("numpy")?;
    let converted = np
        .call_method1("asarray", (value, "float64"))
        .map_err(|e| PyValueError::new_err(format!("{name}: expected numbers ({e})")))?;
    let array = converted
        .cast_into::<PyArrayDyn<f64>>()
        .map_err(|e| PyValueError::new_err(format!("{name}: expected a float array ({e})")))?;
    let shape = array.shape().to_vec();
    let values = array.readonly().as_array().iter().copied().collect();
    Ok((shape, values))
}

/// `value` as exactly `n` float64 values (shape `(n,)`), named `name` in errors.
pub fn vector(value: &Bound<'_, PyAny>, name: &str, n: usize) -> PyResult<Vec<f64>> {
    let (shape, values) = to_f64(value, name)?;
    if shape != [n] {
        return Err(PyValueError::new_err(format!(
            "{name}: expected {n} values (shape ({n},)), got shape {}",
            shape_text(&shape)
        )));
    }
    Ok(values)
}

/// A shape as Python writes it: `(3,)`, `(2, 3)`.
pub fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}
