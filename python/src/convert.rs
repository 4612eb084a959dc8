//! Python values ↔ TOML values: a scene given as a dict becomes the TOML
//! text a file would hold (so dicts and files load through one parser,
//! with one set of messages), and TOML text becomes the dict
//! `tomllib.load` would give.

use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

use crate::SceneError;

/// The TOML text of a scene given as a dict (what `tomllib.load` returns
/// for a scene file). Numbers, strings, booleans, lists, tuples, dicts and
/// anything with `tolist()` (numpy arrays and scalars) or `__fspath__`
/// (paths) are written; anything else is a SceneError naming its key.
#[pyfunction]
pub fn to_toml(value: &Bound<'_, PyAny>) -> PyResult<String> {
    match to_value(value, "")? {
        toml::Value::Table(t) => Ok(toml::to_string(&t)
            .map_err(|e| SceneError::new_err(format!("<dict>: cannot be written as TOML: {e}")))?),
        _ => Err(PyTypeError::new_err("a scene is a dict of tables")),
    }
}

/// The dict of TOML text (tables are dicts, arrays lists).
#[pyfunction]
pub fn parse_toml<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    let table: toml::Table =
        toml::from_str(text).map_err(|e| SceneError::new_err(format!("<scene text>: {e}")))?;
    to_python(py, &toml::Value::Table(table))
}

/// The TOML value of a Python value; errors name `key`.
pub fn to_value(v: &Bound<'_, PyAny>, key: &str) -> PyResult<toml::Value> {
    let at = |what: &str| {
        SceneError::new_err(format!(
            "<dict>: `{}`: {what}",
            if key.is_empty() { "(top)" } else { key }
        ))
    };
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        let i: i64 = v.extract().map_err(|_| at("an integer beyond 64 bits"))?;
        return Ok(toml::Value::Integer(i));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(v.extract()?));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, item) in d.iter() {
            let name: String = k
                .extract()
                .map_err(|_| at("dict keys in a scene are strings"))?;
            let sub = if key.is_empty() {
                name.clone()
            } else {
                format!("{key}.{name}")
            };
            if item.is_none() {
                // None means "not given", as a missing key.
                continue;
            }
            t.insert(name, to_value(&item, &sub)?);
        }
        return Ok(toml::Value::Table(t));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let mut a = Vec::new();
        for (i, item) in v.try_iter()?.enumerate() {
            a.push(to_value(&item?, &format!("{key}[{i}]"))?);
        }
        return Ok(toml::Value::Array(a));
    }
    if v.hasattr("__fspath__")? {
        let p = v.call_method0("__fspath__")?;
        return to_value(&p, key);
    }
    if v.hasattr("tolist")? {
        let l = v.call_method0("tolist")?;
        return to_value(&l, key);
    }
    Err(at(&format!(
        "a {} has no TOML form (numbers, strings, booleans, lists, dicts, numpy arrays)",
        v.get_type().name()?
    )))
}

fn to_python<'py>(py: Python<'py>, v: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        toml::Value::String(s) => s.into_pyobject(py)?.into_any(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        toml::Value::Float(f) => f.into_pyobject(py)?.into_any(),
        toml::Value::Boolean(b) => b.into_pyobject(py)?.to_owned().into_any(),
        toml::Value::Datetime(d) => d.to_string().into_pyobject(py)?.into_any(),
        toml::Value::Array(a) => {
            let items: PyResult<Vec<_>> = a.iter().map(|x| to_python(py, x)).collect();
            PyList::new(py, items?)?.into_any()
        }
        toml::Value::Table(t) => {
            let d = PyDict::new(py);
            for (k, x) in t {
                d.set_item(k, to_python(py, x)?)?;
            }
            d.into_any()
        }
    })
}
