//! The runs of a `Study`: each does what the command line's command does with the same
//! options (src/cli/commands.rs), with the GIL released, and returns the command's `--json`
//! (the same `serde_json::to_value` of the same result) with the tables the run wrote.

use std::path::{Path, PathBuf};

use pyo3::prelude::*;
use serde_json::Value;

use super::convert::{Array, Column, Columns};
use super::results::{
    Boundary, Branch, Frame, Located, Orbits, Record, Simulation, Solution, StudyRun,
};
use super::run::{bad_input, detached, numerical, output_dir, provenance, to_json, to_python};
use super::study::Study;
use crate::Error;
use crate::analysis::refine::{DEFAULT_ACCURACY, DEFAULT_MAX_NODES};
use crate::analysis::solve::{observable_errors, solve_at};
use crate::engine::periodic::branch::OrbitStop;
use crate::model::Model;
use crate::study::boundary::run_boundary;
use crate::study::branch::branch_report;
use crate::study::locate::{LocateResult, Resolution, locate_study};
use crate::study::orbits::{OrbitsOptions, branch_settings, run_orbits};
use crate::study::plan::{
    check_accuracy, check_max_nodes, check_refinement_room, point_accuracy, with_carry_spacing,
};
use crate::study::run::{incomplete, run_parts};
use crate::study::simulate::{
    OrbitOrigin, SimulateOptions, default_transient, run_simulate, simulation_provenance,
};

/// The JSON of a result about `study`, as the command line's `Titled` makes it: the study's
/// name beside the result's own fields.
fn titled(py: Python<'_>, study: &Study, result: &impl serde::Serialize) -> PyResult<Value> {
    let mut value = to_json(py, result)?;
    if let Value::Object(map) = &mut value {
        map.insert("study".into(), Value::String(study.study.name.clone()));
    }
    Ok(value)
}

/// What is known of a run that failed: the study and the output folder.
fn failed_run(study: &Study, dir: &Path) -> Value {
    serde_json::json!({ "study": study.study.name, "out": dir.display().to_string() })
}

/// A count given as an argument: a negative one is refused with the smallest count allowed.
fn count(field: &str, value: i64, min: usize) -> PyResult<usize> {
    usize::try_from(value).map_err(|_| bad_input(field, format!("must be >= {min}, got {value}")))
}

fn finite(field: &str, value: f64) -> PyResult<()> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(bad_input(
            field,
            format!("must be a finite number, got {value}"),
        ))
    }
}

/// The arguments of `Study.locate`.
pub(crate) struct LocateOptions {
    pub accuracy: Option<f64>,
    pub single: bool,
    pub max_nodes: Option<i64>,
    pub extrapolate: bool,
    pub nodes: Option<Vec<i64>>,
    pub tol: Option<f64>,
}

/// `helixbif locate`.
pub(crate) fn locate(py: Python<'_>, study: &Study, o: LocateOptions) -> PyResult<Py<PyAny>> {
    if o.single && o.extrapolate {
        return Err(bad_input(
            "single",
            "cannot be combined with extrapolate=True",
        ));
    }
    if o.single || o.extrapolate {
        let given = [
            ("accuracy", o.accuracy.is_some()),
            ("max_nodes", o.max_nodes.is_some()),
        ];
        if let Some((field, _)) = given.iter().find(|(_, g)| *g) {
            return Err(bad_input(
                field,
                "applies to the refinement only (not with single=True or extrapolate=True)",
            ));
        }
    }
    if o.nodes.is_some() && !o.extrapolate {
        return Err(bad_input("nodes", "needs extrapolate=True"));
    }
    let how = if o.extrapolate {
        let nodes = o.nodes.unwrap_or_default().into_iter();
        Resolution::Ladder(
            nodes
                .map(|n| count("nodes", n, 5))
                .collect::<PyResult<_>>()?,
        )
    } else if o.single {
        Resolution::Single
    } else {
        let accuracy = o.accuracy.unwrap_or(DEFAULT_ACCURACY);
        let max_nodes = match o.max_nodes {
            Some(m) => count("max_nodes", m, 5)?,
            None => DEFAULT_MAX_NODES,
        };
        check_accuracy("accuracy", accuracy).map_err(|e| to_python(py, e, None))?;
        check_max_nodes("max_nodes", max_nodes).map_err(|e| to_python(py, e, None))?;
        Resolution::Refine {
            accuracy,
            max_nodes,
        }
    };
    let tuned;
    let study = match o.tol {
        Some(t) if !(t > 0.0 && t < 1e-2) => {
            return Err(bad_input("tol", format!("must lie in (0, 0.01), got {t}")));
        }
        Some(t) => {
            tuned = study.with_items(py, vec![format!("continuation.event_tol={t:e}")])?;
            &tuned
        }
        None => study,
    };
    let file = &study.study;
    if let Resolution::Refine { max_nodes, .. } = how {
        check_refinement_room("max_nodes", max_nodes, &file.physical())
            .map_err(|e| to_python(py, e, None))?;
    }
    let result = detached(py, || locate_study(file, &how))?.map_err(|e| to_python(py, e, None))?;
    let shortfall = result.shortfall();
    let data = titled(py, study, &result)?;
    let (resolution, frame) = match &result {
        LocateResult::Single(_) => ("single", Frame::Scalars),
        LocateResult::Refined(_) => ("refine", Frame::Records("rungs")),
        LocateResult::Ladder(_) => (
            "ladder",
            Frame::Lists(&["nodes", "omega_b", "omegabar_b", "kinds"]),
        ),
    };
    let error = data.get("omega_b_error").cloned().unwrap_or(Value::Null);
    let mut record = Record::of(
        data,
        &[
            "study",
            "kind",
            "omega_b",
            "omega_b_extrapolated",
            "omegabar_b",
            "answer",
            "nodes",
            "criticality",
            "relative_error",
        ],
    );
    record.frame = frame;
    record.extra = vec![("resolution", resolution.into()), ("error", error)];
    let object = Located::object(py, record)?;
    // An accuracy asked for and not reached: the command line prints the report, then fails
    // (exit 1) with this line; here the report is the error's `partial`.
    match shortfall {
        Some(why) => Err(numerical(
            py,
            Error::Numerical(why).to_string(),
            Some(object),
        )),
        None => Ok(object),
    }
}

/// `helixbif branch --out`.
pub(crate) fn branch(
    py: Python<'_>,
    study: &Study,
    omega_max: Option<f64>,
    out: Option<PathBuf>,
) -> PyResult<Py<PyAny>> {
    let file = &study.study;
    let omega_max = omega_max.unwrap_or(file.branch.omega_max);
    if !(omega_max.is_finite() && omega_max != 0.0) {
        return Err(bad_input(
            "omega_max",
            format!("must be a finite nonzero number (rad/s), got {omega_max}"),
        ));
    }
    let dir = output_dir(py, out, "branch")?;
    let why = provenance(
        "branch",
        &[
            ("omega_max", omega_max.to_string()),
            ("out", dir.display().to_string()),
        ],
    );
    let (report, columns) = detached(py, || {
        let report = Model::new(&file.physical())
            .and_then(|model| branch_report(file, &model, omega_max, &dir, &why));
        (report, Columns::read(&dir.join("branch.csv")))
    })?;
    let columns = columns.map_err(|e| to_python(py, e, None))?;
    let summary: &[&str] = &["study", "nodes", "points", "omega_reached", "stop"];
    let record = |data: Value| Record {
        columns: columns.clone(),
        frame: Frame::Columns,
        ..Record::of(data, summary)
    };
    match report {
        Ok(report) => {
            let object = Branch::object(py, record(titled(py, study, &report)?))?;
            match report.stall() {
                Some(failure) => Err(to_python(py, failure, Some(object))),
                None => Ok(object),
            }
        }
        Err(e) => {
            let partial = Branch::object(py, record(failed_run(study, &dir)))?;
            Err(to_python(py, e, Some(partial)))
        }
    }
}

/// `helixbif solve`, with the node positions that `--shape` writes.
pub(crate) fn solve(py: Python<'_>, study: &Study, omega: f64) -> PyResult<Py<PyAny>> {
    finite("omega", omega)?;
    let file = &study.study;
    let solved = detached(py, || {
        let model = Model::new(&file.physical())?;
        let omegabar = model.scales.omega_to_bar(omega);
        let solution = solve_at(&model, omegabar, &file.newton)?;
        let ell = model.scales.length;
        let config = &solution.state.config;
        let positions: Vec<f64> = config
            .x
            .iter()
            .flat_map(|p| [p.x * ell, p.y * ell, p.z * ell])
            .collect();
        let errors = observable_errors(&file.physical(), &solution, &file.newton);
        let summary = solution.summary(&model, errors);
        Ok::<_, Error>((summary, positions, config.theta.clone()))
    })?;
    let (summary, positions, theta) = solved.map_err(|e| to_python(py, e, None))?;
    let nodes = positions.len() / 3;
    let mut record = Record::of(
        titled(py, study, &summary)?,
        &["study", "omega", "hbar", "Fp", "Tp", "eta", "nodes"],
    );
    record.arrays = vec![
        (
            "positions",
            Array {
                values: positions,
                shape: vec![nodes, 3],
            },
        ),
        (
            "theta",
            Array {
                shape: vec![theta.len()],
                values: theta,
            },
        ),
    ];
    Solution::object(py, record)
}

/// `helixbif boundary --vary --from --to [--accuracy --max-nodes --carry-spacing] --out`.
pub(crate) fn boundary(
    py: Python<'_>,
    study: &Study,
    vary: &str,
    (start, stop): (f64, f64),
    (accuracy, max_nodes, carry_spacing): (Option<f64>, Option<i64>, Option<f64>),
    out: Option<PathBuf>,
) -> PyResult<Py<PyAny>> {
    let file = &study.study;
    let max_nodes = max_nodes.map(|m| count("max_nodes", m, 5)).transpose()?;
    let refinement = point_accuracy(accuracy, max_nodes, ["accuracy", "max_nodes"])
        .and_then(|r| {
            let fields = ["accuracy", "carry_spacing"];
            with_carry_spacing(r, carry_spacing, (start, stop), fields)
        })
        .and_then(|r| {
            if let Some(r) = r {
                check_refinement_room("max_nodes", r.max_nodes, &file.physical())?;
            }
            Ok(r)
        })
        .map_err(|e| to_python(py, e, None))?;
    let dir = output_dir(py, out, "boundary")?;
    let mut arguments = vec![
        ("vary", vary.to_string()),
        ("start", start.to_string()),
        ("stop", stop.to_string()),
    ];
    if let Some(r) = refinement {
        arguments.push(("accuracy", r.accuracy.to_string()));
        arguments.push(("max_nodes", r.max_nodes.to_string()));
        if r.spacing > 0.0 {
            arguments.push(("carry_spacing", r.spacing.to_string()));
        }
    }
    arguments.push(("out", dir.display().to_string()));
    let why = provenance("boundary", &arguments);
    let (outcome, columns) = detached(py, || {
        let outcome = run_boundary(file, vary, (start, stop), refinement, &dir, &why);
        (outcome, Columns::read(&dir.join("boundary.csv")))
    })?;
    let (_, report) = outcome.map_err(|e| to_python(py, e, None))?;
    let columns = columns.map_err(|e| to_python(py, e, None))?;
    let summary: &[&str] = &["key", "from", "to", "nodes", "points", "segments"];
    let record = |data: Value| Record {
        columns: columns.clone(),
        frame: Frame::Columns,
        ..Record::of(data, summary)
    };
    match report {
        // The command line prints the report alone, without the study's name; an accuracy
        // not reached at some points fails after it (exit 1), here with the report as `partial`.
        Ok(report) => {
            let object = Boundary::object(py, record(to_json(py, &report)?))?;
            match report.shortfall() {
                Some(why) => Err(numerical(
                    py,
                    Error::Numerical(why).to_string(),
                    Some(object),
                )),
                None => Ok(object),
            }
        }
        Err(e) => {
            let partial = Boundary::object(py, record(failed_run(study, &dir)))?;
            Err(to_python(py, e, Some(partial)))
        }
    }
}

/// The arguments of `Study.simulate`.
pub(crate) struct SimulateArguments {
    pub omega: Option<f64>,
    pub t_end: f64,
    pub from_steady: bool,
    pub perturb: Option<f64>,
    pub from_orbit: Option<PathBuf>,
    pub ramp_time: f64,
    pub transient: Option<f64>,
    pub shape_every: i64,
    pub out: Option<PathBuf>,
    pub resume: bool,
}

/// The shapes of `shapes.csv` (rows `t, node, x, y, z`): an `(F, N, 3)` array and the `F`
/// times.
fn shapes(table: &Columns) -> (Array, Array) {
    let column = |name: &str| table.get(name).and_then(Column::floats).unwrap_or_default();
    let (t, node) = (column("t"), column("node"));
    let (x, y, z) = (column("x"), column("y"), column("z"));
    let nodes = node.iter().fold(0.0_f64, |m, &n| m.max(n + 1.0)) as usize;
    let frames = t.len().checked_div(nodes).unwrap_or(0);
    let rows = frames * nodes;
    let values = (0..rows).flat_map(|r| [x[r], y[r], z[r]]).collect();
    let times = (0..frames).map(|f| t[f * nodes]).collect();
    (
        Array {
            values,
            shape: vec![frames, nodes, 3],
        },
        Array {
            values: times,
            shape: vec![frames],
        },
    )
}

/// `helixbif simulate`.
pub(crate) fn simulate(py: Python<'_>, study: &Study, a: SimulateArguments) -> PyResult<Py<PyAny>> {
    if a.from_steady && a.from_orbit.is_some() {
        return Err(bad_input(
            "from_steady",
            "cannot be combined with from_orbit",
        ));
    }
    if a.perturb.is_some() && !a.from_steady {
        return Err(bad_input("perturb", "needs from_steady=True"));
    }
    if a.omega.is_none() && a.from_orbit.is_none() {
        return Err(bad_input("omega", "is needed unless from_orbit is given"));
    }
    let file = &study.study;
    let mut opts = SimulateOptions {
        omega: a.omega.unwrap_or(f64::NAN),
        t_end: a.t_end,
        from_steady: a.from_steady,
        perturb: a.perturb,
        from_orbit: None,
        ramp_time: a.ramp_time,
        transient: a.transient.unwrap_or_else(|| {
            let from_rest = !a.from_steady && a.from_orbit.is_none();
            default_transient(a.t_end, a.ramp_time, from_rest)
        }),
        shape_every: count("shape_every", a.shape_every, 0)?,
        newton: file.newton.clone(),
        resume: a.resume,
        provenance: simulation_provenance(file),
    };
    if let Some(path) = &a.from_orbit {
        let origin = OrbitOrigin::read(path).map_err(|e| to_python(py, e, None))?;
        opts.omega = a.omega.unwrap_or(origin.start.omega);
        opts.from_orbit = Some(origin);
    }
    let dir = output_dir(py, a.out, "simulate")?;
    let why = provenance(
        "simulate",
        &[
            ("omega", opts.omega.to_string()),
            ("t_end", a.t_end.to_string()),
            ("out", dir.display().to_string()),
        ],
    );
    let (report, tables) = detached(py, || {
        let report = Model::new(&file.physical()).and_then(|model| {
            let bar = crate::study::progress::bar("simulate");
            let settings = file.integrator.settings(&model.scales);
            run_simulate(file, &model, &settings, &opts, &dir, &bar, &why)
        });
        let tables = ["timeseries.csv", "shapes.csv", "cycles.csv"]
            .map(|name| Columns::read(&dir.join(name)));
        (report, tables)
    })?;
    let [series, shape_rows, cycles] = tables.map(|t| t.map_err(|e| to_python(py, e, None)));
    let (series, shape_rows, cycles) = (series?, shape_rows?, cycles?);
    let (shape_array, shape_times) = shapes(&shape_rows);
    let summary: &[&str] = &[
        "study",
        "omega",
        "t_end",
        "steps",
        "hbar_mean",
        "Fpbar_mean",
    ];
    let record = |data: Value| Record {
        columns: series.clone(),
        arrays: vec![
            ("shapes", shape_array.clone()),
            ("shape_times", shape_times.clone()),
        ],
        tables: vec![("cycles", cycles.clone())],
        frame: Frame::Columns,
        ..Record::of(data, summary)
    };
    match report {
        Ok(report) => Simulation::object(py, record(titled(py, study, &report)?)),
        Err(e) => {
            let partial = Simulation::object(py, record(failed_run(study, &dir)))?;
            Err(to_python(py, e, Some(partial)))
        }
    }
}

/// The arguments of `Study.orbits`.
pub(crate) struct OrbitsArguments {
    pub max_orbits: i64,
    pub steps: i64,
    pub amplitude: f64,
    pub omega_min: Option<f64>,
    pub omega_max: Option<f64>,
    pub out: Option<PathBuf>,
    pub resume: bool,
}

/// `helixbif orbits`.
pub(crate) fn orbits(py: Python<'_>, study: &Study, a: OrbitsArguments) -> PyResult<Py<PyAny>> {
    let file = &study.study;
    let opts = OrbitsOptions {
        settings: branch_settings(
            count("max_orbits", a.max_orbits, 2)?,
            count("steps", a.steps, 8)?,
            a.amplitude,
        ),
        omega_range: (
            a.omega_min.unwrap_or(0.0),
            a.omega_max.unwrap_or(file.branch.omega_max),
        ),
        resume: a.resume,
    };
    opts.validate_naming(str::to_string)
        .map_err(|e| to_python(py, e, None))?;
    let dir = output_dir(py, a.out, "orbits")?;
    let why = provenance(
        "orbits",
        &[
            ("max_orbits", a.max_orbits.to_string()),
            ("steps", a.steps.to_string()),
            ("amplitude", a.amplitude.to_string()),
            ("out", dir.display().to_string()),
        ],
    );
    let (report, tables) = detached(py, || {
        let report = Model::new(&file.physical())
            .and_then(|model| run_orbits(file, &model, &opts, &dir, &why));
        let tables = [
            dir.join("orbits.csv"),
            dir.join("branch").join("branch.csv"),
        ]
        .map(|path| Columns::read(&path));
        (report, tables)
    })?;
    let [rows, steady] = tables.map(|t| t.map_err(|e| to_python(py, e, None)));
    let (rows, steady) = (rows?, steady?);
    let summary: &[&str] = &["study", "omega_hopf", "l1", "criticality", "orbits"];
    let record = |data: Value| Record {
        columns: rows.clone(),
        tables: vec![("steady", steady.clone())],
        frame: Frame::Columns,
        ..Record::of(data, summary)
    };
    match report {
        Ok(report) => {
            let object = Orbits::object(py, record(titled(py, study, &report)?))?;
            match &report.stop {
                OrbitStop::StepTooSmall(reason) => {
                    let reached = report.last.as_ref().map_or(f64::NAN, |r| r.omega);
                    let message = Error::Numerical(format!(
                        "the orbit branch stalled at omega = {reached:.6e} rad/s after {} \
                         orbits ({reason}); the orbits found are in {}",
                        report.orbits, report.out
                    ));
                    Err(numerical(py, message.to_string(), Some(object)))
                }
                _ => Ok(object),
            }
        }
        Err(e) => {
            let partial = Orbits::object(py, record(failed_run(study, &dir)))?;
            Err(to_python(py, e, Some(partial)))
        }
    }
}

/// `helixbif run`: the study's plan (`[study]`; without one, `locate` refined to the default
/// accuracy) into `out`, with `resume` as `--resume`. The result is `helixbif run --json`
/// (`study`, `kind`, `seconds`, `out`, and the kind's `result`) with the table the run wrote at
/// the top of `out` ([`crate::study::run::StudyResult::table`]) as its columns. A study that
/// does not complete (a point short of its accuracy, a failed simulation, a stalled branch)
/// raises `NumericalError` after writing everything, with that result as `partial`; one that
/// fails before it has a result, with a `partial` whose `result` is None.
pub(crate) fn run(
    py: Python<'_>,
    study: &Study,
    out: Option<PathBuf>,
    resume: bool,
) -> PyResult<Py<PyAny>> {
    let file = &study.study;
    let kind = file.study.as_ref().map_or("locate", |p| p.kind());
    let dir = output_dir(py, out, "run")?;
    let mut arguments = vec![("out", dir.display().to_string())];
    if resume {
        arguments.push(("resume", "True".to_string()));
    }
    let why = provenance("run", &arguments);
    let started = std::time::Instant::now();
    let (outcome, table) = detached(py, || {
        let outcome = run_parts(file, &dir, resume, &why);
        let table = match &outcome {
            Ok((result, _)) => result.table().map(|name| Columns::read(&dir.join(name))),
            Err(_) => None,
        };
        (outcome, table)
    })?;
    let seconds = started.elapsed().as_secs_f64();
    let record = |result: Value, columns: Columns| Record {
        columns,
        frame: Frame::Columns,
        column_attributes: false,
        ..Record::of(
            serde_json::json!({
                "study": file.name,
                "kind": kind,
                "seconds": seconds,
                "out": dir.display().to_string(),
                "result": result,
            }),
            &["study", "kind", "seconds", "out"],
        )
    };
    let (result, failures) = match outcome {
        Ok(parts) => parts,
        Err(e) => {
            let partial = StudyRun::object(py, record(Value::Null, Columns::default()))?;
            return Err(to_python(py, e, Some(partial)));
        }
    };
    // The table of a study that did not complete may be missing or cut short: its failure is
    // the error to raise, with what could be read.
    let columns = match table.transpose() {
        Ok(columns) => columns.unwrap_or_default(),
        Err(_) if !failures.is_empty() => Columns::default(),
        Err(e) => return Err(to_python(py, e, None)),
    };
    let object = StudyRun::object(py, record(to_json(py, &result)?, columns))?;
    match incomplete(file, &failures, &dir) {
        Some(e) => Err(to_python(py, e, Some(object))),
        None => Ok(object),
    }
}
