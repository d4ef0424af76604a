//! The result classes: each holds the JSON of the command line's `--json` for the same run
//! (`to_dict()`), the tables the run wrote as typed columns (`columns`, numpy arrays), and arrays
//! of more dimensions (node positions, shapes). Attributes are the columns first, then the
//! arrays, the tables, a few values of the Python API's own, and the JSON's keys; `result[key]`
//! is the JSON's value only.

use numpy::{AllowTypeChange, PyArrayLike1};
use pyo3::exceptions::{PyAttributeError, PyImportError, PyKeyError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::convert::{Array, Columns, json_to_py};
use super::run::{detached, to_json, to_python};
use crate::numerics::fit::power_law;

/// What `to_pandas()` makes of a result.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Frame {
    /// A DataFrame of the columns.
    Columns,
    /// A DataFrame of the JSON's list of objects under this key (e.g. `rungs`).
    Records(&'static str),
    /// A DataFrame of the JSON's lists under these keys, side by side (a ladder).
    Lists(&'static [&'static str]),
    /// A Series of the JSON's scalar values.
    Scalars,
}

/// What every result holds (see the module's doc).
#[derive(Clone, Debug)]
pub(crate) struct Record {
    pub data: serde_json::Value,
    pub columns: Columns,
    pub tables: Vec<(&'static str, Columns)>,
    pub arrays: Vec<(&'static str, Array)>,
    pub extra: Vec<(&'static str, serde_json::Value)>,
    pub frame: Frame,
    /// Whether each column is also an attribute (`branch.omega`); not where the columns are
    /// those of a table of the caller's choosing (`StudyRun`, whose names vary with the study).
    pub column_attributes: bool,
    /// The JSON's keys that `repr` shows, in order.
    pub summary: &'static [&'static str],
}

impl Record {
    /// A record of `data` alone.
    pub(crate) fn of(data: serde_json::Value, summary: &'static [&'static str]) -> Record {
        Record {
            data,
            columns: Columns::default(),
            tables: Vec::new(),
            arrays: Vec::new(),
            extra: Vec::new(),
            frame: Frame::Scalars,
            column_attributes: true,
            summary,
        }
    }

    fn data_keys(&self) -> Vec<String> {
        self.data
            .as_object()
            .map(|m| m.keys().cloned().collect())
            .unwrap_or_default()
    }

    fn lookup<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Option<Bound<'py, PyAny>>> {
        if let Some(column) = self.columns.get(name).filter(|_| self.column_attributes) {
            return column.to_py(py).map(Some);
        }
        if let Some((_, array)) = self.arrays.iter().find(|(n, _)| *n == name) {
            return array.to_py(py).map(Some);
        }
        if let Some((_, table)) = self.tables.iter().find(|(n, _)| *n == name) {
            return Ok(Some(table.to_py(py)?.into_any()));
        }
        if let Some((_, value)) = self.extra.iter().find(|(n, _)| *n == name) {
            return json_to_py(py, value).map(Some);
        }
        match self.data.get(name) {
            Some(value) => json_to_py(py, value).map(Some),
            None => Ok(None),
        }
    }

    fn attribute<'py>(
        &self,
        py: Python<'py>,
        class: &str,
        name: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.lookup(py, name)?.ok_or_else(|| {
            PyAttributeError::new_err(format!("'{class}' object has no attribute '{name}'"))
        })
    }

    fn item<'py>(&self, py: Python<'py>, key: &str) -> PyResult<Bound<'py, PyAny>> {
        match self.data.get(key) {
            Some(value) => json_to_py(py, value),
            None => Err(PyKeyError::new_err(key.to_string())),
        }
    }

    /// Every name an attribute answers to.
    fn names(&self) -> Vec<String> {
        let mut names = if self.column_attributes {
            self.columns.names()
        } else {
            Vec::new()
        };
        names.extend(self.arrays.iter().map(|(n, _)| n.to_string()));
        names.extend(self.tables.iter().map(|(n, _)| n.to_string()));
        names.extend(self.extra.iter().map(|(n, _)| n.to_string()));
        names.extend(self.data_keys());
        names.sort();
        names.dedup();
        names
    }

    fn repr(&self, class: &str) -> String {
        let mut parts: Vec<String> = self
            .summary
            .iter()
            .filter_map(|k| match self.data.get(*k) {
                None | Some(serde_json::Value::Null) => None,
                Some(serde_json::Value::String(s)) => Some(format!("{k}='{s}'")),
                Some(v @ (serde_json::Value::Number(_) | serde_json::Value::Bool(_))) => {
                    Some(format!("{k}={v}"))
                }
                Some(serde_json::Value::Array(a)) => Some(format!("{k}=[{} items]", a.len())),
                Some(serde_json::Value::Object(_)) => Some(format!("{k}={{...}}")),
            })
            .collect();
        if !self.columns.0.is_empty() {
            let rows = match self.columns.0.first().map(|(_, c)| c) {
                Some(super::convert::Column::Float(v)) => v.len(),
                Some(super::convert::Column::Int(v)) => v.len(),
                Some(super::convert::Column::Bool(v)) => v.len(),
                Some(super::convert::Column::Text(v)) => v.len(),
                None => 0,
            };
            parts.push(format!(
                "columns=[{}] x {rows} rows",
                self.columns.names().join(", ")
            ));
        }
        format!("{class}({})", parts.join(", "))
    }

    fn to_pandas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let pandas = py.import("pandas").map_err(|_| {
            PyImportError::new_err(
                "to_pandas() needs pandas, which is not installed (pip install pandas)",
            )
        })?;
        let frame = pandas.getattr("DataFrame")?;
        match self.frame {
            Frame::Columns => frame.call1((self.columns.to_py(py)?,)),
            Frame::Records(key) => frame.call1((self.item(py, key)?,)),
            Frame::Lists(keys) => {
                let dict = PyDict::new(py);
                for key in keys {
                    dict.set_item(key, self.item(py, key)?)?;
                }
                frame.call1((dict,))
            }
            Frame::Scalars => {
                let dict = PyDict::new(py);
                if let Some(map) = self.data.as_object() {
                    for (k, v) in map {
                        if !(v.is_array() || v.is_object()) {
                            dict.set_item(k, json_to_py(py, v)?)?;
                        }
                    }
                }
                pandas.getattr("Series")?.call1((dict,))
            }
        }
    }
}

macro_rules! result_class {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[pyclass(module = "helixbif", frozen)]
        pub struct $name {
            pub(crate) record: Record,
        }

        impl $name {
            /// The Python object of `record`.
            pub(crate) fn object(py: Python<'_>, record: Record) -> PyResult<Py<PyAny>> {
                Ok(Py::new(py, $name { record })?.into_any())
            }
        }

        #[pymethods]
        impl $name {
            /// The result as the command line's `--json` prints it: a fresh dict of plain
            /// Python values (keys sorted; None where the JSON has null).
            fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
                json_to_py(py, &self.record.data)
            }

            /// The main table as a dict of numpy arrays, one per column (empty where the
            /// result has no table).
            #[getter]
            fn columns<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
                self.record.columns.to_py(py)
            }

            /// The result as a pandas object (pandas must be installed; it is not a
            /// dependency of helixbif).
            fn to_pandas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
                self.record.to_pandas(py)
            }

            /// The keys of `to_dict()`.
            fn keys(&self) -> Vec<String> {
                self.record.data_keys()
            }

            fn __getattr__<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
                self.record.attribute(py, stringify!($name), name)
            }

            fn __getitem__<'py>(&self, py: Python<'py>, key: &str) -> PyResult<Bound<'py, PyAny>> {
                self.record.item(py, key)
            }

            fn __contains__(&self, key: &str) -> bool {
                self.record.data.get(key).is_some()
            }

            fn __dir__(slf: &Bound<'_, Self>) -> PyResult<Vec<String>> {
                let object = slf.py().import("builtins")?.getattr("object")?;
                let mut names: Vec<String> =
                    object.getattr("__dir__")?.call1((slf,))?.extract()?;
                names.extend(slf.get().record.names());
                Ok(names)
            }

            fn __repr__(&self) -> String {
                self.record.repr(stringify!($name))
            }
        }
    };
}

result_class! {
    /// What `Study.locate()` finds: the first loss of stability of the branch from rest
    /// (`kind`, `omega_b` in rad/s, `omegabar_b`, `im`, `l1`, `criticality`, ...), with
    /// `rungs`, `omega_b_error` and `relative_error` when refined, or the ladder's lists when
    /// extrapolated. `resolution` says which (`single`, `refine`, `ladder`); `error` is
    /// `omega_b_error` (rad/s, None without an estimate). `to_dict()` is `helixbif locate
    /// --json`.
    Located
}

result_class! {
    /// The branch from rest of `Study.branch()`: the columns of `branch.csv` as numpy arrays
    /// (`omega` rad/s, `omegabar`, `Fp` N, `Fpbar`, `Fpbar_rigid`, `Tp` N m, `eta`, `h` m,
    /// `hbar`, `max_re` 1/s, `n_unstable`, `stable`, `probe`, `s`), the `events` (a list of
    /// dicts, the rows of `events.csv`) and the report (`points`, `omega_reached`, `stop`,
    /// `stalled`, `probes`, `windows_between`, `near_miss_unresolved`, `out`, ...). `to_dict()`
    /// is `helixbif branch --json`.
    Branch
}

result_class! {
    /// One steady state of `Study.solve()`: the observables (`omega`, `omegabar`, `Fp`,
    /// `Fpbar`, `Tp`, `eta`, `h`, `h0`, `hbar`, `Fp_rigid`, `Fpbar_rigid`), Newton's report,
    /// `positions` (the nodes, an (N, 3) float64 array in m) and `theta` (the twist angle of
    /// each edge, (N - 1,), rad). `to_dict()` is `helixbif solve --json`.
    Solution
}

result_class! {
    /// The stability boundary of `Study.boundary()`: the columns of `boundary.csv` (`q`,
    /// `omega_b` rad/s, `omegabar_b`, `kind`, `w`, `m_loc`, `l1`, `criticality`, `segment`,
    /// ...), the `special` points and the report (`points`, `segments`, `check_omega_b`, ...).
    /// `to_dict()` is `helixbif boundary --json`; its `criticality` (counts of Hopf points)
    /// is `result["criticality"]`, the attribute is the column.
    Boundary
}

result_class! {
    /// A simulation of `Study.simulate()`: the columns of `timeseries.csv` (`t` s, `omega`
    /// rad/s, `hbar`, `Fp` N, `Fpbar`, `Tp` N m, `eta`), `shapes` (an (F, N, 3) float64 array,
    /// m) at `shape_times` (s), and the report (`hbar_mean`, `hbar_std`, `Fpbar_mean`, `steps`,
    /// ...). `to_dict()` is `helixbif simulate --json`; its scalar `omega` is
    /// `result["omega"]`, the attribute is the column.
    Simulation
}

result_class! {
    /// The periodic orbits of `Study.orbits()`: the columns of `orbits.csv` (`omega` rad/s,
    /// `period` s, `amplitude` m, `hbar_mean`, `Fpbar_mean`, `max_multiplier`, `stable`,
    /// `verdict`, ...), the steady branch underneath (`steady`, a dict of arrays) and the
    /// report (`omega_hopf`, `frequency`, `l1`, `criticality`, `stop`, `events`, ...).
    /// `to_dict()` is `helixbif orbits --json`.
    Orbits
}

result_class! {
    /// A study's plan run into a folder by `Study.run()`: `study`, `kind` (the plan's: `branch`,
    /// `locate`, `sweep`, `phase`, `boundary`, `shapes`, `dynamics`, `orbits`), `seconds`,
    /// `out` and the kind's `result` (a dict); `columns` (not attributes: their names vary with
    /// the study) and `to_pandas()` are the table the kind writes at the top of `out`
    /// (`sweep.csv`, `boundary.csv`, ...; none for `locate` and for studies of several cases,
    /// whose tables are in their subfolders). `to_dict()` is `helixbif run --json`.
    StudyRun
}

result_class! {
    /// A power law `y = C x^p` fitted by least squares in logarithms: `C`, `p`, their 95%
    /// intervals `C_ci`, `p_ci`, `n`, `r2`, and `residuals` (a float64 array of
    /// `ln y - ln C - p ln x`). `to_dict()` is the fit's part of `helixbif fit --json`.
    PowerLaw
}

/// Fits the power law `y = C x^p` by least squares in logarithms, `ln y = ln C + p ln x` (errors
/// taken as relative), with 95% confidence intervals from the log-scale residuals (Student t),
/// as `helixbif fit` does.
///
/// x, y: sequences or arrays of the same length (at least 3), finite and positive, with at
/// least two distinct x. Raises ValueError otherwise.
#[pyfunction]
pub(crate) fn fit_power_law(
    py: Python<'_>,
    x: PyArrayLike1<'_, f64, AllowTypeChange>,
    y: PyArrayLike1<'_, f64, AllowTypeChange>,
) -> PyResult<Py<PyAny>> {
    let (x, y) = (x.as_array().to_vec(), y.as_array().to_vec());
    let fit = detached(py, || power_law(&x, &y))?.map_err(|e| to_python(py, e, None))?;
    let data = to_json(py, &fit)?;
    let mut record = Record::of(data, &["C", "p", "n", "r2"]);
    record.arrays.push((
        "residuals",
        Array {
            shape: vec![fit.residuals.len()],
            values: fit.residuals,
        },
    ));
    PowerLaw::object(py, record)
}
