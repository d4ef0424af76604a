//! Values between the library and Python: JSON (the results, as `--json` prints them) to Python
//! objects, Python values to TOML (the values of `with_`), the CSV tables a run wrote to typed
//! columns, and columns and arrays to numpy.

use std::path::Path;

use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

use crate::Result;
use crate::study::output::Table;

/// A JSON value as Python objects: null `None`, numbers `int` (integers) or `float`, arrays
/// lists, objects dicts (keys in the JSON's order: sorted).
pub(crate) fn json_to_py<'py>(
    py: Python<'py>,
    value: &serde_json::Value,
) -> PyResult<Bound<'py, PyAny>> {
    use serde_json::Value;
    Ok(match value {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        Value::Number(n) => {
            if let Some(u) = n.as_u64() {
                u.into_pyobject(py)?.into_any()
            } else if let Some(i) = n.as_i64() {
                i.into_pyobject(py)?.into_any()
            } else {
                PyFloat::new(py, n.as_f64().unwrap_or(f64::NAN)).into_any()
            }
        }
        Value::String(s) => PyString::new(py, s).into_any(),
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

/// A Python value as a TOML value, for an override `key=value`: `bool`, `int` (and numpy
/// integers), `float` (and numpy floats), `str`, lists and tuples (arrays), dicts with string
/// keys (inline tables); anything else is bad input naming `key`.
pub(crate) fn py_to_toml(key: &str, value: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    let refuse = || {
        let kind = value
            .get_type()
            .name()
            .map_or_else(|_| "?".to_string(), |n| n.to_string());
        super::run::bad_input(
            key,
            format!("cannot be set from a Python value of type {kind}"),
        )
    };
    if value.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(value.extract()?));
    }
    if value.is_instance_of::<PyInt>() {
        let i: i64 = value
            .extract()
            .map_err(|_| super::run::bad_input(key, format!("integer out of range: {value}")))?;
        return Ok(toml::Value::Integer(i));
    }
    if value.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(value.extract()?));
    }
    if let Ok(s) = value.cast::<PyString>() {
        return Ok(toml::Value::String(s.to_str()?.to_string()));
    }
    if let Ok(d) = value.cast::<PyDict>() {
        let mut table = toml::Table::new();
        for (k, v) in d.iter() {
            let k: String = k.extract().map_err(|_| refuse())?;
            let inner = format!("{key}.{k}");
            table.insert(k, py_to_toml(&inner, &v)?);
        }
        return Ok(toml::Value::Table(table));
    }
    if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
        let items: Vec<Bound<'_, PyAny>> = value.extract()?;
        let array = items
            .iter()
            .map(|v| py_to_toml(key, v))
            .collect::<PyResult<Vec<_>>>()?;
        return Ok(toml::Value::Array(array));
    }
    // numpy scalars: integers by `__index__`, floats by `__float__`.
    if value.hasattr("__index__")?
        && let Ok(i) = value.extract::<i64>()
    {
        return Ok(toml::Value::Integer(i));
    }
    if value.hasattr("dtype")?
        && let Ok(x) = value.extract::<f64>()
    {
        return Ok(toml::Value::Float(x));
    }
    Err(refuse())
}

/// The override `key=value` that `--set` reads, for a Python value.
pub(crate) fn override_item(key: &str, value: &Bound<'_, PyAny>) -> PyResult<String> {
    if key.contains('=') {
        return Err(PyValueError::new_err(format!(
            "invalid input: {key}: a key cannot contain `=`"
        )));
    }
    Ok(format!("{key}={}", py_to_toml(key, value)?))
}

/// One column of a table, typed by what all its cells hold.
#[derive(Clone, Debug)]
pub(crate) enum Column {
    /// Numbers (empty cells `NaN`).
    Float(Vec<f64>),
    /// Integers (counts, indices).
    Int(Vec<i64>),
    /// `true`/`false`.
    Bool(Vec<bool>),
    /// Anything else (names, verdicts; empty cells empty strings).
    Text(Vec<String>),
}

/// The columns of a table, in the file's order.
#[derive(Clone, Debug, Default)]
pub(crate) struct Columns(pub Vec<(String, Column)>);

impl Columns {
    /// The columns of the CSV file at `path` as the library wrote it (numbers in their shortest
    /// round-trip form, so read back bit for bit); a file that does not exist has none.
    pub(crate) fn read(path: &Path) -> Result<Columns> {
        if !path.exists() {
            return Ok(Columns::default());
        }
        let table = Table::read(path)?;
        let columns = (0..table.header.len())
            .map(|c| {
                let cells: Vec<&str> = (0..table.rows.len()).map(|r| table.text(r, c)).collect();
                (table.header[c].clone(), Column::of(&cells))
            })
            .collect();
        Ok(Columns(columns))
    }

    pub(crate) fn names(&self) -> Vec<String> {
        self.0.iter().map(|(n, _)| n.clone()).collect()
    }

    pub(crate) fn get(&self, name: &str) -> Option<&Column> {
        self.0.iter().find(|(n, _)| n == name).map(|(_, c)| c)
    }

    /// The columns as a dict of numpy arrays.
    pub(crate) fn to_py<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let dict = PyDict::new(py);
        for (name, column) in &self.0 {
            dict.set_item(name, column.to_py(py)?)?;
        }
        Ok(dict)
    }
}

impl Column {
    /// The column of the cells' texts: booleans, integers, numbers (empty cells `NaN`), or text.
    fn of(cells: &[&str]) -> Column {
        let nonempty = || cells.iter().filter(|c| !c.is_empty());
        if cells.is_empty() {
            return Column::Float(Vec::new());
        }
        if cells.iter().all(|c| *c == "true" || *c == "false") {
            return Column::Bool(cells.iter().map(|c| *c == "true").collect());
        }
        if cells.iter().all(|c| c.parse::<i64>().is_ok()) {
            return Column::Int(cells.iter().map(|c| c.parse().unwrap_or(0)).collect());
        }
        if nonempty().all(|c| c.parse::<f64>().is_ok()) {
            return Column::Float(
                cells
                    .iter()
                    .map(|c| c.parse().unwrap_or(f64::NAN))
                    .collect(),
            );
        }
        Column::Text(cells.iter().map(|c| c.to_string()).collect())
    }

    /// Its numbers, where it has numbers.
    pub(crate) fn floats(&self) -> Option<Vec<f64>> {
        match self {
            Column::Float(v) => Some(v.clone()),
            Column::Int(v) => Some(v.iter().map(|&i| i as f64).collect()),
            _ => None,
        }
    }

    /// A numpy array: `float64`, `int64`, `bool`, or `str` (numpy's unicode type).
    pub(crate) fn to_py<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        Ok(match self {
            Column::Float(v) => PyArray1::from_vec(py, v.clone()).into_any(),
            Column::Int(v) => PyArray1::from_vec(py, v.clone()).into_any(),
            Column::Bool(v) => PyArray1::from_vec(py, v.clone()).into_any(),
            Column::Text(v) => {
                let list = PyList::new(py, v)?;
                py.import("numpy")?
                    .getattr("asarray")?
                    .call1((list, "str"))?
            }
        })
    }
}

/// An array of `float64` of the given shape (row-major `values`).
#[derive(Clone, Debug)]
pub(crate) struct Array {
    pub values: Vec<f64>,
    pub shape: Vec<usize>,
}

impl Array {
    pub(crate) fn to_py<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let flat = PyArray1::from_vec(py, self.values.clone());
        Ok(flat.reshape(self.shape.clone())?.into_any())
    }
}
