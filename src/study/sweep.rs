//! Sweeps: `omega_b` over a grid of model variants, run in parallel, resumable and shardable.
//!
//! Every point of the grid (case x values of one or two parameters) has a fixed index. Finished
//! points are appended to the CSV at once, each row in one `write` of a file opened for appending
//! and synced to disk, so a killed sweep loses only the points under way; a re-run reads the file
//! keyed by point index (a point recorded twice counts once), drops a final row cut short by the
//! kill, and skips the points already there. Whole files (the sorted CSV, the fingerprint) are
//! replaced atomically: written to a temporary file, synced, renamed over the old one. With
//! `--shard K/N` a run takes the points whose index is `K-1` modulo `N` and writes
//! `sweep.shard-K-of-N.csv`; `merge` joins the shards into `sweep.csv`, refusing files that come
//! from another study or that miss or repeat points. Beside each CSV a `.plan.json` records the
//! fingerprint of the study that produced it.

use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use super::plan::{Case, POINT_REFINEMENT, Plan, Vary, check_refinement_room, point_accuracy};
use super::progress;
use super::{LAMBDA_OVER_L, R_OVER_LAMBDA, Study, get_number, get_value, set_path, set_ratio};
use crate::analysis::boundary::PointAccuracy;
use crate::analysis::locate::LocateSettings;
use crate::analysis::refine::{Refinement, estimate_at_nodes, refine};
use crate::engine::stop::Silent;
use crate::error::caught;
use crate::model::params::Physical;
use crate::model::params::ShapeParams;
use crate::study::output::{create_dir, io_error, write_atomically};
use crate::{Error, Result};

/// One point of a sweep grid.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepPoint {
    pub index: usize,
    pub case: usize,
    pub values: Vec<f64>,
}

/// The cases of a plan (one unnamed case when none are given).
pub fn cases(cases: &[Case]) -> Vec<Case> {
    if cases.is_empty() {
        vec![Case {
            label: "base".into(),
            set: toml::Table::new(),
            scale: None,
        }]
    } else {
        cases.to_vec()
    }
}

/// The grid: every case with every combination of the swept values, in a fixed order.
pub(crate) fn grid(case_count: usize, vary: &[Vary]) -> Vec<SweepPoint> {
    let mut combos: Vec<Vec<f64>> = vec![Vec::new()];
    for v in vary {
        combos = combos
            .into_iter()
            .flat_map(|c| {
                v.points().into_iter().map(move |x| {
                    let mut next = c.clone();
                    next.push(x);
                    next
                })
            })
            .collect();
    }
    (0..case_count)
        .flat_map(|case| combos.iter().cloned().map(move |values| (case, values)))
        .enumerate()
        .map(|(index, (case, values))| SweepPoint {
            index,
            case,
            values,
        })
        .collect()
}

const FACTOR: &str = "factor";

/// The TOML value of a swept `x` for the field `key`: an integer where the field holds one
/// (`discretization.nodes`, `continuation.max_points`), refused unless `x` is a whole number.
fn swept_value(table: &toml::Table, key: &str, x: f64) -> Result<toml::Value> {
    let integer = get_value(table, key).is_some_and(|v| v.is_integer());
    if !integer {
        return Ok(toml::Value::Float(x));
    }
    if x.fract() == 0.0 && x.abs() < 9.0e15 {
        Ok(toml::Value::Integer(x as i64))
    } else {
        Err(Error::input(
            format!("study.vary.{key}"),
            format!("`{key}` takes whole numbers, got {x}"),
        ))
    }
}

/// The study of one point: the base with the case's overrides and the swept values (plain keys
/// first, then `lambda/l`, then `R/lambda`).
pub(crate) fn variant(base: &Study, case: &Case, vary: &[Vary], values: &[f64]) -> Result<Study> {
    let mut table = base.to_table()?;
    table.remove("study");
    for (key, value) in &case.set {
        match (
            key.as_str(),
            value.as_float().or(value.as_integer().map(|i| i as f64)),
        ) {
            (LAMBDA_OVER_L | R_OVER_LAMBDA, Some(x)) => set_ratio(&mut table, key, x)?,
            _ => set_path(&mut table, key, value.clone())?,
        }
    }
    let derived = [LAMBDA_OVER_L, R_OVER_LAMBDA, FACTOR];
    for (v, x) in vary
        .iter()
        .zip(values)
        .filter(|(v, _)| !derived.contains(&v.key.as_str()))
    {
        let value = swept_value(&table, &v.key, *x)?;
        set_path(&mut table, &v.key, value)?;
    }
    if let Some((_, x)) = vary.iter().zip(values).find(|(v, _)| v.key == FACTOR) {
        let key = case.scale.as_deref().ok_or_else(|| {
            Error::input(
                "study.cases.scale",
                format!("case `{}` sweeps `factor` but names no `scale`", case.label),
            )
        })?;
        let base_value = get_number(&table, key)
            .ok_or_else(|| Error::input(key, "the scaled field must be a number of the model"))?;
        set_path(&mut table, key, toml::Value::Float(x * base_value))?;
    }
    for key in [LAMBDA_OVER_L, R_OVER_LAMBDA] {
        if let Some((_, x)) = vary.iter().zip(values).find(|(v, _)| v.key == key) {
            set_ratio(&mut table, key, *x)?;
        }
    }
    Study::from_table(table)
}

/// The fixed columns of `sweep.csv` after the swept keys.
const RESULT_COLUMNS: [&str; 18] = [
    "E",
    "r0",
    "mu",
    "l",
    "lambda_over_l",
    "R_over_lambda",
    "EI",
    "E_r0_4_over_mu_l_4",
    "kind",
    "omega_b",
    "omega_b_error",
    "omegabar_b",
    "im",
    "Fpbar",
    "hbar",
    "nodes",
    "seconds",
    "status",
];

/// The column of a sweep whose points are carried to an accuracy: whether the point's
/// estimated relative error is below it (after `omega_b_error`).
const REACHED: &str = "reached";

/// The header of `sweep.csv` for a plan sweeping `vary`, with the column [`REACHED`] where the
/// points are `refined` to an accuracy.
pub fn header(vary: &[Vary], refined: bool) -> Vec<String> {
    let results = RESULT_COLUMNS.iter().flat_map(|&c| {
        let reached = (refined && c == "omega_b_error").then_some(REACHED);
        std::iter::once(c).chain(reached)
    });
    ["point", "case"]
        .iter()
        .map(|s| s.to_string())
        .chain(vary.iter().map(|v| v.key.clone()))
        .chain(results.map(String::from))
        .collect()
}

/// The prefix of the status of a point that failed (it runs again on a re-run).
const ERROR: &str = "error: ";

/// The prefix of the status of a point located with a warning: a near miss of one of its
/// branches from rest that the probes neither resolved nor excluded (docs/model.md section 5),
/// where a window of instability below its `omega_b` may have been stepped over. A result (a
/// re-run would find the same), left out of fits and figures with that reason.
const WARNING: &str = "ok; WARNING: ";

/// How a [`WARNING`] status ends (one cut short by a kill does not, and its point runs again).
const WARNING_END: &str = "may have been stepped over";

/// True for the status of a finished point: `ok`, `ok; WARNING: ...` ([`WARNING`]), or the whole
/// `unstable_at_rest (...)` of [`crate::analysis::locate::Located::status`]. Anything else (an
/// error, or a status cut short by a kill) runs again.
fn finished(status: &str) -> bool {
    status == "ok"
        || (status.starts_with(WARNING) && status.ends_with(WARNING_END))
        || (status.starts_with("unstable_at_rest (") && status.ends_with(')'))
}

/// How many of `rows` finished with a warning ([`WARNING`]).
fn warned(rows: &BTreeMap<usize, Vec<String>>) -> usize {
    rows.values()
        .filter(|row| row.last().is_some_and(|s| s.starts_with(WARNING)))
        .count()
}

/// The status of a located point: `located`'s ([`crate::analysis::locate::Located::status`]), or
/// where that is `ok` and a rung (`N`, why) left a near miss unresolved, the warning that says so
/// (on one line, without commas). Any rung's counts, not only the finest's: the finer rungs are
/// carried from the coarsest rung's point, and a window its branch may have stepped over lies
/// below theirs too.
fn point_status(located: String, unresolved: Option<(usize, &str)>) -> String {
    match unresolved {
        Some((nodes, why)) if located == "ok" => format!(
            "{WARNING}a near miss at N = {nodes} was not resolved ({why}): a window of \
             instability there {WARNING_END}"
        )
        .replace(['\n', ','], " "),
        _ => located,
    }
}

fn number(v: Option<f64>) -> String {
    v.map(|x| format!("{x:e}")).unwrap_or_default()
}

/// `omega_b` of one point of a sweep or of a phase map's column: carried to `accuracy` by
/// `locate`'s refinement from the point's `N` ([`refine`]) where one is asked for, else at the
/// point's `N` with its discretization error estimated from a coarser rung
/// ([`estimate_at_nodes`]).
pub(crate) fn located_point(
    physical: &Physical,
    settings: &LocateSettings,
    accuracy: Option<PointAccuracy>,
) -> Result<Refinement> {
    match accuracy {
        Some(a) => refine(
            physical,
            Some(a.accuracy),
            a.max_nodes,
            settings,
            &mut Silent,
        ),
        None => estimate_at_nodes(physical, settings, &mut Silent),
    }
}

/// Runs `locate` at one point ([`located_point`]) and formats its row; a failure is recorded
/// in the row, not raised.
fn run_point(
    base: &Study,
    (cases, vary): (&[Case], &[Vary]),
    accuracy: Option<PointAccuracy>,
    point: &SweepPoint,
) -> Vec<String> {
    let start = Instant::now();
    let case = &cases[point.case];
    let mut row = vec![point.index.to_string(), case.label.clone()];
    row.extend(point.values.iter().map(|x| format!("{x:e}")));
    // A panic (a bug) at this point is its failure, not the sweep's.
    let outcome = caught(|| {
        let study = variant(base, case, vary, &point.values)?;
        let refined = located_point(&study.physical(), &study.locate_settings(), accuracy)?;
        Ok((study, refined))
    });
    match outcome {
        Ok((study, refined)) => {
            let located = &refined.finest;
            let p = study.physical();
            let (lol, rol) = match p.shape {
                ShapeParams::Helix {
                    l, lambda, radius, ..
                } => (Some(lambda / l), Some(radius / lambda)),
                _ => (None, None),
            };
            let ell = p.shape.reference_length();
            row.extend([
                number(Some(p.rod.youngs_modulus)),
                number(Some(p.rod.r0)),
                number(Some(p.fluid.mu)),
                number(Some(ell)),
                number(lol),
                number(rol),
                number(Some(p.bending_stiffness())),
                number(Some(
                    p.rod.youngs_modulus * p.rod.r0.powi(4) / (p.fluid.mu * ell.powi(4)),
                )),
                located.kind.to_string(),
                number(located.omega_b),
                number(refined.omega_b_error),
            ]);
            // Whether the accuracy was reached, where some rung found an omega_b to refine (a
            // point unstable at rest or stable throughout at every rung is a result without
            // one; one that a finer rung lost did not reach it).
            if accuracy.is_some() {
                let refinable = refined.rungs.iter().any(|r| r.omega_b.is_some());
                row.push(if refinable {
                    refined.reached.to_string()
                } else {
                    String::new()
                });
            }
            row.extend([
                number(located.omegabar_b),
                number(located.im),
                number(located.fpbar),
                number(located.hbar),
                located.nodes.to_string(),
                format!("{:.3}", start.elapsed().as_secs_f64()),
                point_status(
                    located.status(),
                    refined
                        .rungs
                        .iter()
                        .find_map(|r| r.near_miss_unresolved.as_deref().map(|why| (r.nodes, why))),
                ),
            ]);
        }
        Err(e) => {
            row.extend((0..8).map(|_| String::new()));
            row.push("error".into());
            let empty = if accuracy.is_some() { 7 } else { 6 };
            row.extend((0..empty).map(|_| String::new()));
            row.push(base.discretization.nodes.to_string());
            row.push(format!("{:.3}", start.elapsed().as_secs_f64()));
            row.push(format!(
                "{ERROR}{}",
                e.to_string().replace(['\n', ','], " ")
            ));
        }
    }
    row
}

/// A fingerprint of everything that determines a sweep's results (the study without its name
/// and its figure specifications).
fn fingerprint(study: &Study) -> Result<String> {
    let mut s = study.clone();
    s.name = String::new();
    // How results are drawn does not change them.
    if let Some(Plan::Sweep { figures, .. }) = &mut s.study {
        figures.clear();
    }
    serde_json::to_string(&s).map_err(|e| Error::Numerical(e.to_string()))
}

/// The CSV file of a run: `sweep.csv`, or `sweep.shard-K-of-N.csv`.
fn csv_name(shard: Option<(usize, usize)>) -> String {
    match shard {
        Some((k, n)) => format!("sweep.shard-{k}-of-{n}.csv"),
        None => "sweep.csv".into(),
    }
}

fn plan_path(csv: &Path) -> PathBuf {
    csv.with_extension("plan.json")
}

/// Reads the rows of a sweep CSV, keyed by point index; checks its header.
fn read_points(path: &Path, header: &[String]) -> Result<BTreeMap<usize, Vec<String>>> {
    let mut reader = csv::Reader::from_path(path)
        .map_err(|e| Error::input("sweep", format!("{}: {e}", path.display())))?;
    let found: Vec<String> = reader
        .headers()
        .map_err(|e| Error::input("sweep", format!("{}: {e}", path.display())))?
        .iter()
        .map(String::from)
        .collect();
    if found != header {
        // A file written before each point stated its error has every column but that one.
        let older = header
            .iter()
            .filter(|h| *h != "omega_b_error")
            .eq(found.iter());
        let why = if older {
            "was written by an earlier helixbif, without the column omega_b_error"
        } else {
            "has the columns of another sweep"
        };
        return Err(Error::input(
            "sweep",
            format!(
                "{} {why}; delete it or choose another --out",
                path.display()
            ),
        ));
    }
    let mut rows = BTreeMap::new();
    for record in reader.records() {
        // A row cut short by a kill is dropped (its point runs again).
        let Ok(record) = record else { continue };
        let row: Vec<String> = record.iter().map(String::from).collect();
        if let Some(i) = row.first().and_then(|s| s.parse::<usize>().ok()) {
            rows.insert(i, row);
        }
    }
    Ok(rows)
}

/// One CSV record (with its line end) as bytes, so that it can be written in one call.
fn record_bytes(path: &Path, row: &[String]) -> Result<Vec<u8>> {
    let io = |message: String| Error::Io {
        path: path.display().to_string(),
        source: std::io::Error::other(message),
    };
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(row).map_err(|e| io(e.to_string()))?;
    w.into_inner().map_err(|e| io(e.to_string()))
}

fn write_rows(path: &Path, header: &[String], rows: &BTreeMap<usize, Vec<String>>) -> Result<()> {
    let mut bytes = record_bytes(path, header)?;
    for row in rows.values() {
        bytes.extend(record_bytes(path, row)?);
    }
    write_atomically(path, &bytes)
}

/// Checks (or writes) the fingerprint beside a sweep CSV.
fn check_plan(csv: &Path, study: &Study) -> Result<()> {
    let path = plan_path(csv);
    let mine = fingerprint(study)?;
    match std::fs::read_to_string(&path) {
        Ok(theirs) if theirs != mine => Err(Error::input(
            "sweep",
            format!(
                "{} was produced by a different study; delete it or choose another --out",
                csv.display()
            ),
        )),
        Ok(_) => Ok(()),
        Err(_) if csv.exists() => Err(Error::input(
            "sweep",
            format!(
                "{} has no fingerprint file {} beside it, so its study is unknown; delete it or choose another --out",
                csv.display(),
                path.display()
            ),
        )),
        Err(_) => write_atomically(&path, mine.as_bytes()),
    }
}

/// What a sweep run reports.
#[derive(Clone, Debug, Serialize)]
pub struct SweepSummary {
    pub file: String,
    pub points: usize,
    pub already_done: usize,
    pub computed: usize,
    pub failed: usize,
    /// Points of the file finished with a warning in their status ([`WARNING`]): fits and
    /// figures leave them out.
    pub warned: usize,
    /// The accuracy the points were carried to and how many reached it (absent without one).
    #[serde(flatten)]
    pub reach: Option<Reach>,
    pub seconds: f64,
}

impl SweepSummary {
    /// What the sweep fell short of: the accuracy, at the points that did not reach it.
    pub fn shortfall(&self) -> Option<String> {
        self.reach.as_ref()?.shortfall(&self.file)
    }
}

/// The relative accuracy of `omega_b` the points of a sweep file were carried to, how many of
/// its rows (resumed or merged ones included) have an `omega_b` refined to it, and at how many
/// of those it was not reached.
#[derive(Clone, Debug, Serialize)]
pub struct Reach {
    pub accuracy: f64,
    pub carried: usize,
    pub not_reached: usize,
}

impl Reach {
    /// The counts of the column [`REACHED`] of `rows` (of a sweep with `accuracy`; `None`
    /// without one).
    fn of(
        accuracy: Option<PointAccuracy>,
        header: &[String],
        rows: &BTreeMap<usize, Vec<String>>,
    ) -> Option<Reach> {
        let (accuracy, c) = (accuracy?, header.iter().position(|h| h == REACHED)?);
        Some(Reach {
            accuracy: accuracy.accuracy,
            carried: rows.values().filter(|r| !r[c].is_empty()).count(),
            not_reached: rows.values().filter(|r| r[c] == "false").count(),
        })
    }

    /// What the sweep file `file` fell short of: the accuracy, at the points that did not
    /// reach it.
    pub fn shortfall(&self, file: &str) -> Option<String> {
        (self.not_reached > 0).then(|| {
            format!(
                "accuracy {:e} not reached at {} of {} sweep points located (column {REACHED} \
                 of {file})",
                self.accuracy, self.not_reached, self.carried
            )
        })
    }
}

/// The cases and swept parameters of a sweep study and the refinement of its points (`None`:
/// each at its own `N`); `command` names the command for the error.
pub(super) fn sweep_plan<'a>(
    study: &'a Study,
    command: &str,
) -> Result<(&'a [Case], &'a [Vary], Option<PointAccuracy>)> {
    match &study.study {
        Some(Plan::Sweep {
            cases,
            vary,
            accuracy,
            max_nodes,
            ..
        }) => Ok((
            cases,
            vary,
            point_accuracy(*accuracy, *max_nodes, POINT_REFINEMENT)?,
        )),
        _ => Err(Error::input(
            "study.kind",
            format!("`{command}` needs a study whose [study] kind is \"sweep\""),
        )),
    }
}

/// Runs the sweep of `study` (its plan must be a sweep) into `dir`, skipping finished points.
pub fn run_sweep(study: &Study, dir: &Path, shard: Option<(usize, usize)>) -> Result<SweepSummary> {
    let (plan_cases, vary, accuracy) = sweep_plan(study, "sweep")?;
    if let Some((k, n)) = shard
        && (n == 0 || k == 0 || k > n)
    {
        return Err(Error::input(
            "--shard",
            format!("expected K/N with 1 <= K <= N, got {k}/{n}"),
        ));
    }
    let start = Instant::now();
    create_dir(dir)?;
    let cases = cases(plan_cases);
    let header = header(vary, accuracy.is_some());
    let all = grid(cases.len(), vary);
    let mine: Vec<SweepPoint> = all
        .into_iter()
        .filter(|p| shard.is_none_or(|(k, n)| shard_of(p.index, n) == k))
        .collect();
    // Bad input anywhere in the grid is refused before anything is computed.
    for point in &mine {
        let s = variant(study, &cases[point.case], vary, &point.values)?;
        if let Some(a) = accuracy {
            check_refinement_room("study.max_nodes", a.max_nodes, &s.physical())?;
        }
    }
    let path = dir.join(csv_name(shard));
    check_plan(&path, study)?;
    // Finished points are kept; failed ones run again.
    let mut done = if path.exists() {
        read_points(&path, &header)?
    } else {
        BTreeMap::new()
    };
    let indices: BTreeSet<usize> = mine.iter().map(|p| p.index).collect();
    done.retain(|i, row| indices.contains(i) && row.last().is_some_and(|s| finished(s)));
    // Rewrite what was kept (dropping any row cut short), then append as points finish.
    write_rows(&path, &header, &done)?;
    let todo: Vec<&SweepPoint> = mine
        .iter()
        .filter(|p| !done.contains_key(&p.index))
        .collect();
    let file = std::fs::OpenOptions::new()
        .append(true)
        .open(&path)
        .map_err(io_error(&path))?;
    let writer = Mutex::new(file);
    let bar = progress::points(todo.len());
    let failures = Mutex::new(0usize);
    let results: Vec<Result<()>> = todo
        .par_iter()
        .map(|point| {
            let row = run_point(study, (&cases, vary), accuracy, point);
            if row.last().is_some_and(|s| !finished(s)) {
                *failures.lock().expect("no panic while counting") += 1;
            }
            // One write of the whole row, then to disk: a kill leaves at most this row cut short.
            let bytes = record_bytes(&path, &row)?;
            let mut file = writer.lock().expect("no panic while writing");
            file.write_all(&bytes).map_err(io_error(&path))?;
            file.sync_data().map_err(io_error(&path))?;
            bar.inc(1);
            Ok(())
        })
        .collect();
    bar.finish_and_clear();
    results.into_iter().collect::<Result<Vec<()>>>()?;
    drop(writer);
    // Sort the finished file by point.
    let rows = read_points(&path, &header)?;
    write_rows(&path, &header, &rows)?;
    Ok(SweepSummary {
        file: path.display().to_string(),
        points: mine.len(),
        already_done: done.len(),
        computed: todo.len(),
        failed: failures.into_inner().expect("no panic while counting"),
        warned: warned(&rows),
        reach: Reach::of(accuracy, &header, &rows),
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The shard files `sweep.shard-K-of-N.csv` of `dir` as `(K, N, path)`, sorted.
pub(super) fn shard_files(dir: &Path) -> Result<Vec<(usize, usize, PathBuf)>> {
    let mut shards: Vec<(usize, usize, PathBuf)> = std::fs::read_dir(dir)
        .map_err(io_error(dir))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter_map(|p| {
            let name = p.file_name()?.to_str()?.to_string();
            let rest = name.strip_prefix("sweep.shard-")?.strip_suffix(".csv")?;
            let (k, n) = rest.split_once("-of-")?;
            Some((k.parse().ok()?, n.parse().ok()?, p))
        })
        .collect();
    shards.sort();
    Ok(shards)
}

/// The shard `K` (of `shards`) that runs point `index`: the points are dealt round-robin.
fn shard_of(index: usize, shards: usize) -> usize {
    index % shards + 1
}

/// What [`merge`] joined.
#[derive(Clone, Debug)]
pub struct Merged {
    pub points: usize,
    pub shards: usize,
    /// The points whose rows are not finished (an error status: a shard that failed them and
    /// was not run again), each with its shard `K` (of `shards`): kept in `sweep.csv` as they
    /// are, for the merge to fail on after writing.
    pub failed: Vec<(usize, usize)>,
    /// Points finished with a warning in their status ([`WARNING`]).
    pub warned: usize,
    /// With an accuracy, how many points reached it (the shards do not fail for it: the merge
    /// does).
    pub reach: Option<Reach>,
}

/// Joins the shard files of `dir` into `sweep.csv`; refuses shards of another study, different
/// shard counts, and missing or repeated points.
pub fn merge(study: &Study, dir: &Path) -> Result<Merged> {
    let (plan_cases, vary, accuracy) = sweep_plan(study, "merge")?;
    let header = header(vary, accuracy.is_some());
    let total = grid(cases(plan_cases).len(), vary).len();
    let mine = fingerprint(study)?;
    let shards = shard_files(dir)?;
    if shards.is_empty() {
        return Err(Error::input(
            "merge",
            format!("no sweep.shard-K-of-N.csv files in {}", dir.display()),
        ));
    }
    let n = shards[0].1;
    if shards.iter().any(|s| s.1 != n) || shards.len() != n {
        return Err(Error::input(
            "merge",
            format!(
                "expected the {n} shards of one split, found {:?}",
                shards.iter().map(|s| (s.0, s.1)).collect::<Vec<_>>()
            ),
        ));
    }
    let mut rows = BTreeMap::new();
    for (_, _, path) in &shards {
        let fingerprint_path = plan_path(path);
        let theirs = std::fs::read_to_string(&fingerprint_path).map_err(|_| {
            Error::input(
                "merge",
                format!(
                    "{} has no fingerprint file {}",
                    path.display(),
                    fingerprint_path.display()
                ),
            )
        })?;
        if theirs != mine {
            return Err(Error::input(
                "merge",
                format!("{} was produced by a different study", path.display()),
            ));
        }
        for (i, row) in read_points(path, &header)? {
            if rows.insert(i, row).is_some() {
                return Err(Error::input(
                    "merge",
                    format!("point {i} appears in two shards"),
                ));
            }
        }
    }
    if rows.len() != total {
        let missing: Vec<usize> = (0..total).filter(|i| !rows.contains_key(i)).collect();
        return Err(Error::input(
            "merge",
            format!("points missing (unfinished shards?): {missing:?}"),
        ));
    }
    let path = dir.join("sweep.csv");
    write_rows(&path, &header, &rows)?;
    write_atomically(&plan_path(&path), mine.as_bytes())?;
    Ok(Merged {
        points: rows.len(),
        shards: n,
        failed: rows
            .iter()
            .filter(|(_, r)| r.last().is_some_and(|s| !finished(s)))
            .map(|(&i, _)| (i, shard_of(i, n)))
            .collect(),
        warned: warned(&rows),
        reach: Reach::of(accuracy, &header, &rows),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point whose near miss was left unresolved is finished (a re-run would find the same) with
    /// a status other than `ok` (fits leave it out, saying why), on one line without commas; cut
    /// short by a kill it runs again. Without a near miss, or unstable at rest, the status is
    /// `located`'s own.
    #[test]
    fn a_near_miss_left_unresolved_is_a_finished_status_with_its_warning() {
        let why = "near omega = 1.5e-2 rad/s: 8 probes spent,\nand more";
        let warned = point_status("ok".into(), Some((61, why)));
        assert!(finished(&warned), "{warned}");
        assert_ne!(warned, "ok");
        assert!(warned.contains("N = 61") && warned.contains("8 probes spent"));
        assert!(!warned.contains(',') && !warned.contains('\n'), "{warned}");
        assert!(!finished(&warned[..warned.len() - 3]));
        assert_eq!(point_status("ok".into(), None), "ok");
        let rest = "unstable_at_rest (2 unstable eigenvalues at omega = 0)";
        assert_eq!(point_status(rest.into(), Some((61, why))), rest);
    }
}
