//! Python values to TOML: a scene given as a dict becomes the TOML text the runtime reads.
//!
//! dict → table (string keys), list and tuple → array, bool → boolean, int → integer
//! (64-bit), float → float, str → string; anything with a `tolist()` method (numpy arrays
//! and numpy scalars) is converted through it. `None` and other types have no TOML value:
//! a `TypeError` names the key path (`strands[0].root`), as the scene's errors do.

use pyo3::exceptions::{PyOverflowError, PyTypeError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use toml::{Table, Value};

/// Deepest nesting followed (a self-referencing list would otherwise never end).
const MAX_DEPTH: usize = 64;

/// The TOML text of a scene given as a dict.
pub fn dict_to_toml(d: &Bound<'_, PyDict>) -> PyResult<String> {
    let table = table(d, "", 0)?;
    toml::to_string(&table).map_err(|e| PyTypeError::new_err(format!("scene: {e}")))
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

fn table(d: &Bound<'_, PyDict>, path: &str, depth: usize) -> PyResult<Table> {
    let mut t = Table::new();
    for (k, v) in d.iter() {
        let key: String = match k.cast::<PyString>() {
            Ok(s) => s.to_cow()?.into_owned(),
            Err(_) => {
                return Err(PyTypeError::new_err(format!(
                    "{}: keys must be strings, got {}",
                    if path.is_empty() { "scene" } else { path },
                    type_name(&k)
                )))
            }
        };
        let field = join(path, &key);
        let value = value(&v, &field, depth + 1)?;
        t.insert(key, value);
    }
    Ok(t)
}

fn type_name(v: &Bound<'_, PyAny>) -> String {
    v.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "an unknown type".to_string())
}

fn value(v: &Bound<'_, PyAny>, path: &str, depth: usize) -> PyResult<Value> {
    if depth > MAX_DEPTH {
        return Err(PyTypeError::new_err(format!(
            "{path}: nested more than {MAX_DEPTH} levels deep"
        )));
    }
    // bool before int: a Python bool is an int
    if let Ok(b) = v.cast::<PyBool>() {
        return Ok(Value::Boolean(b.is_true()));
    }
    if v.is_instance_of::<PyInt>() {
        return match v.extract::<i64>() {
            Ok(i) => Ok(Value::Integer(i)),
            Err(_) => Err(PyOverflowError::new_err(format!(
                "{path}: {} does not fit a 64-bit TOML integer",
                v.str().map(|s| s.to_string()).unwrap_or_default()
            ))),
        };
    }
    if let Ok(f) = v.cast::<PyFloat>() {
        return Ok(Value::Float(f.value()));
    }
    if let Ok(s) = v.cast::<PyString>() {
        return Ok(Value::String(s.to_cow()?.into_owned()));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        return Ok(Value::Table(table(d, path, depth)?));
    }
    if let Ok(l) = v.cast::<PyList>() {
        return array(l.iter(), path, depth);
    }
    if let Ok(t) = v.cast::<PyTuple>() {
        return array(t.iter(), path, depth);
    }
    if v.is_none() {
        return Err(PyTypeError::new_err(format!(
            "{path}: None has no TOML value (leave the key out for its default)"
        )));
    }
    // numpy arrays and scalars
    if v.hasattr("tolist").unwrap_or(false) {
        if let Ok(converted) = v.call_method0("tolist") {
            // a numpy scalar's tolist() is a Python scalar; an array's a list
            if !converted.is(v) {
                return value(&converted, path, depth + 1);
            }
        }
    }
    Err(PyTypeError::new_err(format!(
        "{path}: a {} has no TOML value (use dict, list, tuple, bool, int, float or str)",
        type_name(v)
    )))
}

fn array<'py>(
    items: impl Iterator<Item = Bound<'py, PyAny>>,
    path: &str,
    depth: usize,
) -> PyResult<Value> {
    let mut out = Vec::new();
    for (i, item) in items.enumerate() {
        out.push(value(&item, &format!("{path}[{i}]"), depth + 1)?);
    }
    Ok(Value::Array(out))
}
