//! The class `Study`: a validated study (the command line's study file with its `--set`
//! overrides), immutable; `with_` derives a variant with the dotted keys and the code of
//! `--set`, and the runs are the command line's commands ([`super::runs`]).

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString, PyTuple};

use super::convert::{json_to_py, override_item};
use super::run::{bad_input, to_json, to_python};
use super::runs;
use crate::study::Study as StudyFile;

/// A study: the physical parameters (SI units) and numerical settings of a rod in a viscous
/// fluid, as a study file holds them (docs/model.md, docs/studies.md), validated.
/// Immutable: `with_()` returns a changed copy.
///
/// Make one with `Study.default()` (the representative helix), `Study.from_file(path)` or
/// `Study.from_toml(text)`; run it with `locate`, `branch`, `solve`, `boundary`, `simulate`,
/// `orbits` (the command line's commands, with the same results). Numbers in SI units: rates
/// in rad/s, lengths in m, forces in N, times in s.
#[pyclass(module = "helixbif", frozen)]
pub struct Study {
    pub(crate) study: StudyFile,
    /// The overrides applied since the study was read, as `--set` reads them.
    pub(crate) overrides: Vec<String>,
}

impl Study {
    fn loaded(py: Python<'_>, loaded: crate::Result<StudyFile>) -> PyResult<Study> {
        Ok(Study {
            study: loaded.map_err(|e| to_python(py, e, None))?,
            overrides: Vec::new(),
        })
    }

    /// This study with the overrides `items` (`key=value`, as `--set` reads them) applied.
    pub(crate) fn with_items(&self, py: Python<'_>, items: Vec<String>) -> PyResult<Study> {
        let text = self.toml(py)?;
        let study = StudyFile::load(Some(&text), &items).map_err(|e| to_python(py, e, None))?;
        let mut overrides = self.overrides.clone();
        overrides.extend(items);
        Ok(Study { study, overrides })
    }

    fn toml(&self, py: Python<'_>) -> PyResult<String> {
        let table = self.study.to_table().map_err(|e| to_python(py, e, None))?;
        Ok(table.to_string())
    }
}

#[pymethods]
impl Study {
    /// The built-in representative helix (docs/model.md section 7; the command line's study
    /// without a file).
    #[staticmethod]
    fn default(py: Python<'_>) -> PyResult<Study> {
        Study::loaded(py, StudyFile::load(None, &[]))
    }

    /// The study file at `path` (TOML, SI units); relative paths inside it resolve against its
    /// folder. Raises ValueError when it cannot be read or is not a valid study.
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<Study> {
        Study::loaded(py, StudyFile::from_path(Some(&path), &[]))
    }

    /// The study of the TOML text `text` (a study file's contents); relative paths inside it
    /// resolve against the working folder. Raises ValueError when it is not a valid study.
    #[staticmethod]
    fn from_toml(py: Python<'_>, text: &str) -> PyResult<Study> {
        Study::loaded(py, StudyFile::load(Some(text), &[]))
    }

    /// A copy with fields overridden by their dotted keys, as `--set key=value` does:
    /// `study.with_(**{"rod.E": 2e6, "discretization.nodes": 80})`, or
    /// `study.with_({"shape.R_over_lambda": 0.2})`, or `study.with_("shape.handedness=left")`
    /// (a string is read exactly as `--set` reads its argument). Values are Python numbers,
    /// booleans, strings, lists or dicts (a dict replaces a whole table, e.g.
    /// `{"shape": {"kind": "straight", "L": 0.12, "alpha_deg": 15}}`). The keys
    /// `shape.R_over_lambda` and `shape.lambda_over_l` set the helix's radius and pitch by
    /// their ratio. The study itself is unchanged. Raises ValueError (the command line's
    /// message) on an unknown key or a value out of range.
    #[pyo3(signature = (*sets, **overrides))]
    fn with_(
        &self,
        py: Python<'_>,
        sets: &Bound<'_, PyTuple>,
        overrides: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Study> {
        fn add(items: &mut Vec<String>, map: &Bound<'_, PyDict>) -> PyResult<()> {
            for (key, value) in map.iter() {
                let key: String = key
                    .extract()
                    .map_err(|_| bad_input("--set", "keys are dotted strings"))?;
                items.push(override_item(&key, &value)?);
            }
            Ok(())
        }
        let mut items = Vec::new();
        for set in sets.iter() {
            if let Ok(text) = set.cast::<PyString>() {
                items.push(text.to_str()?.to_string());
            } else if let Ok(map) = set.cast::<PyDict>() {
                add(&mut items, map)?;
            } else {
                return Err(bad_input(
                    "--set",
                    "positional arguments are `key=value` strings or dicts",
                ));
            }
        }
        if let Some(map) = overrides {
            add(&mut items, map)?;
        }
        self.with_items(py, items)
    }

    /// The study as a study file's TOML text (`Study.from_toml(study.to_toml())` is the same
    /// study).
    fn to_toml(&self, py: Python<'_>) -> PyResult<String> {
        self.toml(py)
    }

    /// The study as a dict of plain Python values (its tables as dicts).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &to_json(py, &self.study)?)
    }

    /// The value of a dotted key, `study["rod.E"]`; KeyError when the study has no such field.
    fn __getitem__<'py>(&self, py: Python<'py>, key: &str) -> PyResult<Bound<'py, PyAny>> {
        let json = to_json(py, &self.study)?;
        let mut value = &json;
        for part in key.split('.') {
            value = value
                .get(part)
                .ok_or_else(|| pyo3::exceptions::PyKeyError::new_err(key.to_string()))?;
        }
        json_to_py(py, value)
    }

    /// The study's name (the command line's output folder `output/<name>/`).
    #[getter]
    fn name(&self) -> String {
        self.study.name.clone()
    }

    /// The node count N (after `discretization.per_turn`, when set).
    #[getter]
    fn nodes(&self) -> usize {
        self.study.discretization.nodes
    }

    /// The overrides applied by `with_()` since the study was read, as `--set` arguments.
    #[getter]
    fn overrides(&self) -> Vec<String> {
        self.overrides.clone()
    }

    fn __repr__(&self) -> String {
        if self.overrides.is_empty() {
            format!("Study('{}')", self.study.name)
        } else {
            format!(
                "Study('{}', overrides={:?})",
                self.study.name, self.overrides
            )
        }
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Study>()
            .is_ok_and(|o| o.get().study == self.study)
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let from_toml = slf.get_type().getattr("from_toml")?;
        Ok((from_toml, (slf.get().toml(slf.py())?,)))
    }

    /// The critical rate omega_b (rad/s): the first loss of stability of the branch from rest
    /// (`helixbif locate`). By default N is refined (spacing halved) until the estimated
    /// relative error of omega_b (in N and, on the RPY line, of the quadrature) is below
    /// `accuracy` (default 1e-3) or `max_nodes` (default 500, above the study's N) or the
    /// model's admissible range
    /// stops it; `single=True` locates at the study's N only; `extrapolate=True` runs a ladder
    /// of node counts `nodes` (default: N, 2N - 1, 4N - 3 on the RPY line, five inside the
    /// admissible range on Lighthill's operator) and extrapolates. `tol` is the relative
    /// precision of omega_b (default the study's continuation.event_tol, 1e-8). Returns a
    /// `Located`. Raises ValueError on bad input, NumericalError when the continuation fails
    /// or the refinement stops short of `accuracy` (the `Located` in its `partial`).
    #[pyo3(signature = (accuracy=None, *, single=false, max_nodes=None, extrapolate=false, nodes=None, tol=None))]
    #[allow(clippy::too_many_arguments)]
    fn locate(
        &self,
        py: Python<'_>,
        accuracy: Option<f64>,
        single: bool,
        max_nodes: Option<i64>,
        extrapolate: bool,
        nodes: Option<Vec<i64>>,
        tol: Option<f64>,
    ) -> PyResult<Py<PyAny>> {
        let options = runs::LocateOptions {
            accuracy,
            single,
            max_nodes,
            extrapolate,
            nodes,
            tol,
        };
        runs::locate(py, self, options)
    }

    /// The branch from rest up to `omega_max` rad/s (default the study's branch.omega_max;
    /// negative: the motor turning clockwise seen from above), with stability at every point
    /// (`helixbif branch`). Writes branch.csv, events.csv, meta.json and figures into `out`
    /// (default: a fresh temporary folder, kept; `result.out` names it). Returns a `Branch`.
    /// Raises NumericalError (with the points found in `partial`) when the continuation
    /// stalls before `omega_max`.
    #[pyo3(signature = (omega_max=None, *, out=None))]
    fn branch(
        &self,
        py: Python<'_>,
        omega_max: Option<f64>,
        out: Option<PathBuf>,
    ) -> PyResult<Py<PyAny>> {
        runs::branch(py, self, omega_max, out)
    }

    /// One steady state at the rate `omega` rad/s (`helixbif solve`): the observables with their
    /// estimated errors (`errors`), Newton's report and the node positions. Returns a
    /// `Solution`. Raises NumericalError when Newton's
    /// method fails.
    fn solve(&self, py: Python<'_>, omega: f64) -> PyResult<Py<PyAny>> {
        runs::solve(py, self, omega)
    }

    /// The stability boundary omega_b(q) as the study field `vary` (a dotted key of a number,
    /// or `shape.R_over_lambda`, `shape.lambda_over_l`) goes from `start` to `stop`
    /// (`helixbif boundary --vary --from --to`). Writes boundary.csv, points.csv, meta.json and
    /// figures into `out` (default a fresh temporary folder). With `accuracy`, every Hopf point
    /// is carried to that relative accuracy of omega_b (up to `max_nodes`, default 500, above
    /// the study's N), as
    /// `locate` refines it (`--accuracy`, `--max-nodes`); with `carry_spacing` as well, only
    /// points that far apart in ln q are refined and the others take the correction
    /// interpolated, more refined where its error is above `accuracy`
    /// (`--carry-spacing`). Returns a `Boundary`. Raises NumericalError (the
    /// curve found so far in `partial`) when the curve cannot be finished or a point falls
    /// short of `accuracy`.
    #[pyo3(signature = (vary, start, stop, *, accuracy=None, max_nodes=None, carry_spacing=None, out=None))]
    #[allow(clippy::too_many_arguments)]
    fn boundary(
        &self,
        py: Python<'_>,
        vary: &str,
        start: f64,
        stop: f64,
        accuracy: Option<f64>,
        max_nodes: Option<i64>,
        carry_spacing: Option<f64>,
        out: Option<PathBuf>,
    ) -> PyResult<Py<PyAny>> {
        let refinement = (accuracy, max_nodes, carry_spacing);
        runs::boundary(py, self, vary, (start, stop), refinement, out)
    }

    /// The rod stepped through time for `t_end` s at `omega` rad/s (`helixbif simulate`): from
    /// rest with the motor spun up over `ramp_time` s (default 20), or `from_steady` (displaced
    /// along the least stable mode by `perturb` reference lengths), or from a periodic orbit's
    /// file `from_orbit` (states/orbit_K.json of `orbits`; `omega` then defaults to the
    /// orbit's). Statistics over t >= `transient` s (default the second half, after the
    /// spin-up); the shape every `shape_every` steps (0: never). `resume=True` continues from
    /// the checkpoint in `out`. Returns a `Simulation`. Raises NumericalError (the samples so
    /// far in `partial`) when a step fails.
    #[pyo3(signature = (omega=None, *, t_end, from_steady=false, perturb=None, from_orbit=None, ramp_time=20.0, transient=None, shape_every=50, out=None, resume=false))]
    #[allow(clippy::too_many_arguments)]
    fn simulate(
        &self,
        py: Python<'_>,
        omega: Option<f64>,
        t_end: f64,
        from_steady: bool,
        perturb: Option<f64>,
        from_orbit: Option<PathBuf>,
        ramp_time: f64,
        transient: Option<f64>,
        shape_every: i64,
        out: Option<PathBuf>,
        resume: bool,
    ) -> PyResult<Py<PyAny>> {
        let options = runs::SimulateArguments {
            omega,
            t_end,
            from_steady,
            perturb,
            from_orbit,
            ramp_time,
            transient,
            shape_every,
            out,
            resume,
        };
        runs::simulate(py, self, options)
    }

    /// The study's plan (`[study]`; without one, `locate` refined to the default accuracy) run
    /// into `out` (default a new temporary folder), as `helixbif run` does: every table, figure
    /// and `meta.json` written there. `resume=True` continues an interrupted run in `out`
    /// (`--resume`: finished simulations and boundary curves read back, orbit branches from
    /// their checkpoints). Raises NumericalError with `partial` when the study does not
    /// complete.
    #[pyo3(signature = (*, out=None, resume=false))]
    fn run(&self, py: Python<'_>, out: Option<PathBuf>, resume: bool) -> PyResult<Py<PyAny>> {
        runs::run(py, self, out, resume)
    }

    /// The periodic orbits born at the Hopf point that `locate(single=True)` finds
    /// (`helixbif orbits`): at most `max_orbits` orbits, `steps` time steps per period, the
    /// first of normal-form radius `amplitude` reference lengths, while omega stays in
    /// [`omega_min`, `omega_max`] rad/s (default [0, branch.omega_max]). `resume=True` goes on
    /// from the checkpoint in `out` (one of another rod, fluid, shape or discretization, or of
    /// other options but `max_orbits` and the range, is refused). Returns an `Orbits`. Raises
    /// NumericalError (the orbits so far in `partial`) when the branch stalls.
    #[pyo3(signature = (*, max_orbits=40, steps=100, amplitude=1e-3, omega_min=None, omega_max=None, out=None, resume=false))]
    #[allow(clippy::too_many_arguments)]
    fn orbits(
        &self,
        py: Python<'_>,
        max_orbits: i64,
        steps: i64,
        amplitude: f64,
        omega_min: Option<f64>,
        omega_max: Option<f64>,
        out: Option<PathBuf>,
        resume: bool,
    ) -> PyResult<Py<PyAny>> {
        let options = runs::OrbitsArguments {
            max_orbits,
            steps,
            amplitude,
            omega_min,
            omega_max,
            out,
            resume,
        };
        runs::orbits(py, self, options)
    }
}
