//! The boundary runs of `helixbif boundary` and of the `boundary` study kind: the curve of
//! [`crate::analysis::boundary`] streamed to `boundary.csv` and `points.csv` (rewritten after
//! every point, so that a failure keeps everything found), its figures, and for a study one
//! curve per case with the local exponent and a power law shared by the curves.

use std::path::Path;
use std::time::Instant;

use indicatif::ProgressBar;
use serde::{Deserialize, Serialize};

use crate::analysis::boundary::{
    Answer, Boundary, BoundaryObserver, BoundaryPoint, Criticality, PointAccuracy, SpecialPoint,
    TimeSpent, check_end, follow_boundary,
};
use crate::error::caught;
use crate::model::Model;
use crate::model::params::Field;
use crate::numerics::fit::{CommonPowerLaw, PowerLaw, common_power_law, line_intercept, power_law};
use crate::plot::{Figure, Marker, Scale, Series, Style, write_figure};
use crate::problem::family::RodFamily;
use crate::study::Study;
use crate::study::figures::{absolute_error_range, axis_label, error_range, short_name, typeset};
use crate::study::output::{
    CsvWriter, Meta, Provenance, create_dir, read_rows, resumed_checkpoint, write_json,
    write_json_atomically,
};
use crate::study::plan::{Case, check_refinement_room};
use crate::study::progress;
use crate::study::run::slug;
use crate::study::sweep::variant;
use crate::{Error, Result};

/// What `helixbif boundary` reports (kept in `curve.json`, read back by a resumed study).
#[derive(Debug, Serialize, Deserialize)]
pub struct BoundaryReport {
    pub key: String,
    pub from: f64,
    pub to: f64,
    pub nodes: usize,
    pub points: usize,
    pub segments: usize,
    pub special: Vec<SpecialPoint>,
    /// Steady solves (Newton from a close guess, with a spectrum) over the whole curve.
    pub evaluations: usize,
    /// Independent `locate` runs from rest below the curve, watching for a window of another
    /// mode opening there (a point carried to an accuracy is checked by one, then refined).
    pub window_checks: usize,
    pub seconds: f64,
    /// Where the seconds went.
    pub time: TimeSpent,
    /// `omega_b` of an independent `locate` at the end of the range, and its relative
    /// difference from the curve's last point.
    pub check_omega_b: Option<f64>,
    pub check_difference: Option<f64>,
    /// How many Hopf points of the curve are supercritical, subcritical, undetermined, and
    /// without a coefficient (it could not be computed).
    pub criticality: Criticality,
    /// The relative accuracy of `omega_b` every Hopf point was carried to (`--accuracy`), how
    /// many points were (the Hopf points), and how many did not reach it (their `reached`
    /// column false); absent without one.
    pub accuracy: Option<f64>,
    pub carried: Option<usize>,
    pub not_reached: Option<usize>,
    /// Of the points carried, how many took the interpolated correction of refined ones (a
    /// carry spacing); absent without an accuracy.
    pub interpolated: Option<usize>,
    /// The largest estimated relative error of `omega_b` over the points that state one, and
    /// where (`q`).
    pub relative_error_max: Option<[f64; 2]>,
    /// Where the first point fell short of the accuracy, and why its refinement stopped.
    pub first_shortfall: Option<String>,
    /// The first window check whose branch had a near miss neither resolved nor excluded
    /// (docs/model.md section 5).
    pub first_unresolved_near_miss: Option<String>,
    /// The largest node count of a point's `omega_b` (`nodes` is the curve's).
    pub nodes_max: usize,
    pub out: String,
}

impl BoundaryReport {
    /// What the boundary fell short of: the accuracy, at the points that did not reach it.
    pub fn shortfall(&self) -> Option<String> {
        let (accuracy, missed) = (self.accuracy?, self.not_reached.filter(|&k| k > 0)?);
        let worst = self.relative_error_max.map_or(String::new(), |[e, q]| {
            format!(
                " (the largest estimated relative error {e:.1e}, at {} = {q})",
                self.key
            )
        });
        let first = self
            .first_shortfall
            .as_ref()
            .map_or(String::new(), |f| format!("; the first {f}"));
        Some(format!(
            "accuracy {accuracy:e} not reached at {missed} of {} points carried to it (column \
             `reached`){worst}{first}",
            self.carried.unwrap_or(self.points)
        ))
    }
}

/// What `meta.json` records of a boundary run: its report, or why it stopped short.
#[derive(Serialize)]
#[serde(untagged)]
enum BoundaryRun<'a> {
    Finished(&'a BoundaryReport),
    Stopped { error: String },
}

/// What a curve has found: its rows and special points as written to disk after its last point
/// (and at its end). A boundary study draws them in its combined figures for every curve, one
/// that ended in a panic (a bug) included, whose rows would otherwise be on disk only.
#[derive(Default)]
pub(crate) struct Kept {
    pub(crate) rows: Vec<BoundaryPoint>,
    pub(crate) special: Vec<SpecialPoint>,
}

impl Kept {
    /// Holds a copy of `boundary`'s rows and special points.
    fn hold(&mut self, boundary: &Boundary) {
        self.rows.clone_from(&boundary.points);
        self.special.clone_from(&boundary.special);
    }
}

/// Writes the boundary to `boundary.csv` and `points.csv` in `dir` as it grows (a copy of what
/// it wrote in `kept`), and draws a progress bar over the range.
struct BoundaryWriter<'a> {
    dir: &'a Path,
    bar: ProgressBar,
    range: (f64, f64),
    kept: &'a mut Kept,
}

impl BoundaryWriter<'_> {
    fn write(&self, boundary: &Boundary) -> Result<()> {
        let mut csv = CsvWriter::create(&self.dir.join("boundary.csv"))?;
        for row in &boundary.points {
            csv.row(row)?;
        }
        let mut csv = CsvWriter::create(&self.dir.join("points.csv"))?;
        for row in &boundary.special {
            csv.row(row)?;
        }
        Ok(())
    }
}

impl BoundaryObserver for BoundaryWriter<'_> {
    fn grown(&mut self, boundary: &Boundary) -> Result<()> {
        let Some(point) = boundary.points.last() else {
            return Ok(());
        };
        progress::set_fraction(&self.bar, point.q, self.range);
        self.bar.set_message(format!(
            "q = {:.5}, omega_b = {:.5} rad/s",
            point.q, point.omega_b
        ));
        self.write(boundary)?;
        self.kept.hold(boundary);
        crate::study::interrupt::check()
    }
}

/// The family of `study` in the field named `key` (a number of the physical model, or a helix
/// ratio).
pub fn family(study: &Study, key: &str) -> Result<RodFamily> {
    let field = Field::of_key(key).ok_or_else(|| {
        Error::input(
            "--vary",
            format!(
                "`{key}` is not a numeric field of the study (or {}, {})",
                Field::LambdaOverL.key(),
                Field::ROverLambda.key()
            ),
        )
    })?;
    RodFamily::new(&study.physical(), field, study.branch.omega_max)
}

/// Follows the boundary of `study` in `key` from `from` to `to` (with `accuracy`, every Hopf
/// point carried to it) and writes `boundary.csv`, `points.csv` and the figures to `dir`: the
/// boundary found, and the report or why it did not reach the end of the range (what was found
/// is on disk either way).
pub fn run_boundary(
    study: &Study,
    key: &str,
    (from, to): (f64, f64),
    accuracy: Option<PointAccuracy>,
    dir: &Path,
    provenance: &Provenance,
) -> Result<(Vec<BoundaryPoint>, Result<BoundaryReport>)> {
    let mut kept = Kept::default();
    let outcome = keeping(
        study,
        key,
        (from, to),
        (accuracy, dir, provenance),
        &mut kept,
    )?;
    Ok((kept.rows, outcome))
}

/// [`run_boundary`], with what the curve found held in `kept` as it grows (and at its end).
fn keeping(
    study: &Study,
    key: &str,
    range: (f64, f64),
    (accuracy, dir, provenance): (Option<PointAccuracy>, &Path, &Provenance),
    kept: &mut Kept,
) -> Result<Result<BoundaryReport>> {
    let family = family(study, key)?;
    run_family(study, &family, range, (accuracy, dir, provenance), kept)
}

/// [`run_boundary`] over the members of `family`, what it found held in `kept`.
pub(crate) fn run_family(
    study: &Study,
    family: &RodFamily,
    (from, to): (f64, f64),
    (accuracy, dir, provenance): (Option<PointAccuracy>, &Path, &Provenance),
    kept: &mut Kept,
) -> Result<Result<BoundaryReport>> {
    let key = family.field().key();
    crate::analysis::boundary::check_range(family, from, to)?;
    let started = Instant::now();
    create_dir(dir)?;
    // The record of a curve finished here before goes: the folder is being written afresh.
    let record = dir.join("curve.json");
    if record.exists() {
        std::fs::remove_file(&record)
            .map_err(|e| Error::Numerical(format!("{}: {e}", record.display())))?;
    }
    let bar = progress::bar(&format!("boundary in {key}"));
    let mut writer = BoundaryWriter {
        dir,
        bar,
        range: (from, to),
        kept,
    };
    let settings = study.locate_settings();
    let (boundary, outcome) = follow_boundary(family, (&settings, accuracy), from, to, &mut writer);
    writer.bar.finish_and_clear();
    // What was found is kept (tables and figures) even when the curve could not be finished.
    let written = writer
        .write(&boundary)
        .and_then(|()| one_curve_figures(dir, key, &boundary.points, &boundary.special));
    writer.kept.hold(&boundary);
    let report = outcome.and(written).map(|()| {
        let last = boundary.points.last().expect("a finished curve has points");
        let checked = Instant::now();
        let check_omega_b = check_end(family, &settings, last);
        let seconds = started.elapsed().as_secs_f64();
        let mut time = TimeSpent {
            end_check: checked.elapsed().as_secs_f64(),
            ..boundary.time
        };
        time.curve = seconds - time.window_checks - time.rows - time.end_check;
        BoundaryReport {
            key: key.to_string(),
            from,
            to,
            nodes: study.discretization.nodes,
            points: boundary.points.len(),
            segments: boundary.segments,
            special: boundary.special.clone(),
            evaluations: boundary.evaluations,
            window_checks: boundary.window_checks,
            seconds,
            time,
            check_difference: check_omega_b
                .map(|w| (w - last.curve_omega_b).abs() / last.curve_omega_b.abs()),
            check_omega_b,
            criticality: boundary.criticality(),
            accuracy: accuracy.map(|a| a.accuracy),
            carried: accuracy.map(|_| {
                boundary
                    .points
                    .iter()
                    .filter(|r| r.reached.is_some())
                    .count()
            }),
            interpolated: accuracy.map(|_| {
                boundary
                    .points
                    .iter()
                    .filter(|r| r.answer == Answer::Interpolated)
                    .count()
            }),
            not_reached: accuracy.map(|_| {
                boundary
                    .points
                    .iter()
                    .filter(|r| r.reached == Some(false))
                    .count()
            }),
            relative_error_max: boundary
                .points
                .iter()
                .filter_map(|r| r.omega_b_error.map(|e| [e / r.omega_b.abs(), r.q]))
                .max_by(|a, b| a[0].total_cmp(&b[0])),
            first_shortfall: boundary.first_shortfall.clone(),
            first_unresolved_near_miss: boundary.first_unresolved_near_miss.clone(),
            nodes_max: boundary.points.iter().map(|r| r.nodes).max().unwrap_or(0),
            out: dir.display().to_string(),
        }
    });
    let scales = Model::new(&family.physical(from)?)?.scales;
    let run = match &report {
        Ok(r) => BoundaryRun::Finished(r),
        Err(e) => BoundaryRun::Stopped {
            error: e.to_string(),
        },
    };
    Meta::new(study, scales, run, provenance).write(&dir.join("meta.json"))?;
    if let Ok(report) = &report {
        let record = CurveRecord {
            settings: curve_settings(study, key, (from, to), accuracy)?,
            command_line: provenance.command_line.clone(),
            report,
        };
        write_json_atomically(&dir.join("curve.json"), &record)?;
    }
    Ok(report)
}

/// The figures of one curve (unlabelled) in its folder `dir`.
fn one_curve_figures(
    dir: &Path,
    key: &str,
    rows: &[BoundaryPoint],
    special: &[SpecialPoint],
) -> Result<()> {
    let special: Vec<(String, SpecialPoint)> =
        special.iter().map(|p| (String::new(), p.clone())).collect();
    curve_figures(dir, key, &[(String::new(), rows.to_vec())], &special)
}

/// The folder of `case`'s curve, one of `cases` in the study folder `dir` (the study's own when
/// there is one case).
fn case_folder(dir: &Path, case: &Case, cases: usize) -> std::path::PathBuf {
    if cases == 1 {
        dir.to_path_buf()
    } else {
        dir.join(slug(&case.label))
    }
}

/// What a curve was followed for: the study (a case's own), the field, the range and the
/// accuracy (with its node cap and carry spacing). A resumed study reads a curve back only
/// where these are its own.
fn curve_settings(
    study: &Study,
    key: &str,
    (from, to): (f64, f64),
    accuracy: Option<PointAccuracy>,
) -> Result<serde_json::Value> {
    let key = Field::of_key(key).map_or(key, |f| f.key());
    let accuracy = accuracy.map(|a| {
        serde_json::json!({
            "accuracy": a.accuracy,
            "max_nodes": a.max_nodes,
            "carry_spacing": a.spacing,
        })
    });
    let study = serde_json::to_value(study).map_err(|e| Error::Numerical(e.to_string()))?;
    Ok(serde_json::json!({
        "study": study,
        "vary": key,
        "range": [from, to],
        "accuracy": accuracy,
    }))
}

/// The record of a finished curve, `curve.json` in its folder: written (atomically) once the
/// curve is done, removed when a run starts following it, so that it exists only beside a
/// whole curve. What it was followed for ([`curve_settings`]), by which command, and its report.
#[derive(Serialize, Deserialize)]
struct CurveRecord<R> {
    settings: serde_json::Value,
    command_line: Vec<String>,
    report: R,
}

/// The curve a run of the same study finished in `dir` (its rows, special points and report),
/// read back by a resumed study instead of following it again; `None` where no run finished
/// it there (none ran, or it stopped short or was killed: no `curve.json`). A curve followed
/// for other `settings` ([`curve_settings`]), a record this version cannot read
/// ([`resumed_checkpoint`]), or one whose table holds another count of points, is refused.
fn finished_curve(
    settings: &serde_json::Value,
    dir: &Path,
) -> Result<Option<(Kept, BoundaryReport)>> {
    let path = dir.join("curve.json");
    let Some(record) =
        resumed_checkpoint(&path, true, settings, |r: &CurveRecord<BoundaryReport>| {
            Some(&r.settings)
        })?
    else {
        return Ok(None);
    };
    let kept = Kept {
        rows: read_rows(&dir.join("boundary.csv"), true)?,
        special: read_rows(&dir.join("points.csv"), true)?,
    };
    if kept.rows.len() != record.report.points {
        return Err(Error::input(
            "--resume",
            format!(
                "{}: its table holds {} points, its record {}; run without --resume to follow \
                 the curve afresh",
                path.display(),
                kept.rows.len(),
                record.report.points
            ),
        ));
    }
    Ok(Some((kept, record.report)))
}

/// What a boundary study reports: each curve, and the power law they share over the fit range.
#[derive(Debug, Serialize)]
pub struct BoundaryStudy {
    pub curves: Vec<CurveSummary>,
    pub common_fit: Option<CommonPowerLaw>,
}

/// The exponent `m` of `omegabar_b ~ q^(-m)` shared by a study's curves over `range`
/// (`fit.json`, the exponent a phase study reads).
#[derive(Serialize)]
struct ExponentFit {
    m: f64,
    m_ci: [f64; 2],
    range: [f64; 2],
    source: &'static str,
}

/// What a boundary study says of one curve: where it ran, its local exponent near the small end
/// of the range and, over the stated range, a power law.
#[derive(Debug, Serialize)]
pub struct CurveSummary {
    pub label: String,
    /// Whether the curve was read back from the record of an earlier run that finished it
    /// (`run --resume`, [`finished_curve`]) instead of followed by this run.
    pub resumed: bool,
    pub report: Option<BoundaryReport>,
    /// Why the curve did not reach the end of the range (its points so far are on disk).
    pub error: Option<String>,
    /// `m_loc` at the smallest `q` of the curve (`[q, m_loc]`), and its error estimated from
    /// the points' errors (`m_loc_error` of that row).
    pub m_loc_smallest: Option<[f64; 2]>,
    pub m_loc_smallest_error: Option<f64>,
    /// `m_loc` extrapolated to `q = 0` by a straight line through the lowest fifth of the
    /// curve's range of `q`, and its error: the half-width of the intercept's 95% interval
    /// (the scatter about the line) plus the largest `m_loc_error` of the points fitted (errors
    /// of one sign, smooth in `q`, move the line about as a whole; a trend in them would move
    /// its end at `q = 0` further); absent where a point fitted has no error (a number with
    /// half its error would pass for a precise one).
    pub m_loc_limit: Option<f64>,
    pub m_loc_limit_error: Option<f64>,
    /// `omegabar_b = C q^p` over the stated range, `m = -p`.
    pub fit: Option<PowerLaw>,
}

/// The exponents of a curve's rows: `m_loc` at the smallest `q` and its limit at `q = 0`, each
/// with its error ([`CurveSummary`]), and the power law over `fit`.
fn exponents(rows: &[BoundaryPoint], fit: Option<[f64; 2]>) -> (Exponents, Option<PowerLaw>) {
    let with_m: Vec<&BoundaryPoint> = rows
        .iter()
        .filter(|r| r.m_loc.is_some() && r.q > 0.0)
        .collect();
    let smallest = with_m.iter().min_by(|a, b| a.q.total_cmp(&b.q));
    let lo = with_m.iter().map(|r| r.q).fold(f64::INFINITY, f64::min);
    let hi = with_m.iter().map(|r| r.q).fold(f64::NEG_INFINITY, f64::max);
    let low: Vec<&BoundaryPoint> = with_m
        .iter()
        .copied()
        .filter(|r| r.q <= lo + 0.2 * (hi - lo))
        .collect();
    let line: Vec<(f64, f64)> = low
        .iter()
        .map(|r| (r.q, r.m_loc.unwrap_or(f64::NAN)))
        .collect();
    let limit = line_intercept(&line);
    // The points' own errors: the largest, where every point fitted has one.
    let shift = low
        .iter()
        .map(|r| r.m_loc_error)
        .collect::<Option<Vec<f64>>>()
        .map(|e| e.into_iter().fold(0.0, f64::max));
    let exponents = Exponents {
        smallest: smallest.map(|r| [r.q, r.m_loc.unwrap_or(f64::NAN)]),
        smallest_error: smallest.and_then(|r| r.m_loc_error),
        limit: limit.map(|[m, _]| m),
        limit_error: limit.zip(shift).map(|([_, width], shift)| width + shift),
    };
    let power = fit.and_then(|[a, b]| {
        let inside: Vec<&BoundaryPoint> = rows.iter().filter(|r| r.q >= a && r.q <= b).collect();
        let x: Vec<f64> = inside.iter().map(|r| r.q).collect();
        let y: Vec<f64> = inside.iter().map(|r| r.omegabar_b).collect();
        power_law(&x, &y).ok()
    });
    (exponents, power)
}

/// `m_loc` at a curve's smallest `q` and its limit at `q = 0`, with their errors.
struct Exponents {
    smallest: Option<[f64; 2]>,
    smallest_error: Option<f64>,
    limit: Option<f64>,
    limit_error: Option<f64>,
}

/// The curves of a boundary study: the study field `key` from `from` to `to`, every Hopf point
/// carried to `accuracy` where one is asked for.
pub struct Curves<'a> {
    pub key: &'a str,
    pub from: f64,
    pub to: f64,
    pub accuracy: Option<PointAccuracy>,
}

/// A boundary study: a curve per case ([`Curves`]), each in its own folder (the study's own
/// when there is one case), the curves drawn together (`boundary.svg`, `m_loc.svg`), and with
/// `fit`, one power law shared by the curves over that range (`fit.json`: `m`, its interval,
/// the range; the exponent the phase study reads). With `resume`, a curve an earlier run of the
/// same study finished is read back from its folder ([`finished_curve`]) and its figures drawn
/// again, not followed again. Returns the summary and the curves that did not finish or fell
/// short of the accuracy.
pub fn run_study(
    study: &Study,
    curves: &Curves,
    cases: &[Case],
    (fit, resume): (Option<[f64; 2]>, bool),
    dir: &Path,
    provenance: &Provenance,
) -> Result<(BoundaryStudy, Vec<String>)> {
    let Curves {
        key,
        from,
        to,
        accuracy,
    } = *curves;
    // Each case's study and folder, and with `resume` the curve a run finished there: every
    // case's N checked for the refinement room and every folder read (or refused) before any
    // curve is followed.
    let mut members = Vec::new();
    for case in cases {
        let s = variant(study, case, &[], &[])?;
        if let Some(a) = accuracy {
            check_refinement_room("study.max_nodes", a.max_nodes, &s.physical())?;
        }
        let sub = case_folder(dir, case, cases.len());
        let finished = if resume {
            finished_curve(&curve_settings(&s, key, (from, to), accuracy)?, &sub)?
        } else {
            None
        };
        members.push((case, s, sub, finished));
    }
    let mut summaries = Vec::new();
    let mut failures = Vec::new();
    let mut all_rows = Vec::new();
    let mut all_special = Vec::new();
    for (case, s, sub, finished) in members {
        let resumed = finished.is_some();
        let (kept, outcome) = if let Some((read, report)) = finished {
            one_curve_figures(&sub, key, &read.rows, &read.special)?;
            (read, Ok(report))
        } else {
            // A panic (a bug) ends this curve, not the others; its rows so far are on disk and
            // in `kept`.
            let mut kept = Kept::default();
            let outcome = match caught(|| {
                keeping(&s, key, (from, to), (accuracy, &sub, provenance), &mut kept)
            }) {
                Err(e @ Error::Internal(_)) => Err(e),
                other => other?,
            };
            (kept, outcome)
        };
        let Kept { rows, special } = kept;
        let (report, error) = match outcome {
            Ok(r) => {
                failures.extend(r.shortfall().map(|f| format!("{}: {f}", case.label)));
                (Some(r), None)
            }
            Err(e) if e.is_input() => return Err(e),
            Err(e) => {
                failures.push(format!("{}: {e}", case.label));
                (None, Some(e.to_string()))
            }
        };
        let (m, power) = exponents(&rows, fit);
        all_special.extend(special.into_iter().map(|p| (case.label.clone(), p)));
        all_rows.push((case.label.clone(), rows));
        summaries.push(CurveSummary {
            label: case.label.clone(),
            resumed,
            report,
            error,
            m_loc_smallest: m.smallest,
            m_loc_smallest_error: m.smallest_error,
            m_loc_limit: m.limit,
            m_loc_limit_error: m.limit_error,
            fit: power,
        });
    }
    let common = fit.and_then(|[a, b]| {
        let groups: Vec<(String, Vec<f64>, Vec<f64>)> = all_rows
            .iter()
            .map(|(label, rows)| {
                let inside: Vec<&BoundaryPoint> =
                    rows.iter().filter(|r| r.q >= a && r.q <= b).collect();
                (
                    label.clone(),
                    inside.iter().map(|r| r.q).collect(),
                    inside.iter().map(|r| r.omegabar_b).collect(),
                )
            })
            .collect();
        common_power_law(&groups).ok()
    });
    if let (Some(c), Some(range)) = (&common, fit) {
        let exponent = ExponentFit {
            m: -c.p,
            m_ci: [-c.p_ci[1], -c.p_ci[0]],
            range,
            source: "boundary curves (one power law shared by the curves over the range)",
        };
        write_json(&dir.join("fit.json"), &exponent)?;
    }
    curve_figures(dir, key, &all_rows, &all_special)?;
    Ok((
        BoundaryStudy {
            curves: summaries,
            common_fit: common,
        },
        failures,
    ))
}

/// The range inside Tukey's far-out fences (first quartile − 3 IQR, third quartile + 3 IQR) of
/// the finite `values`, shrunk to the values inside it and padded by 5 % on each side; `None`
/// when that leaves out nothing (the axis is then fitted as usual) or there are too few values.
fn far_out_fences(values: &[f64]) -> Option<(f64, f64)> {
    let mut v: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if v.len() < 4 {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let quantile = |p: f64| {
        let t = p * (v.len() - 1) as f64;
        let (i, f) = (t.floor() as usize, t.fract());
        v[i] + f * (v[(i + 1).min(v.len() - 1)] - v[i])
    };
    let (q1, q3) = (quantile(0.25), quantile(0.75));
    let (lo, hi) = (q1 - 3.0 * (q3 - q1), q3 + 3.0 * (q3 - q1));
    let inside: Vec<f64> = v
        .iter()
        .copied()
        .filter(|x| (lo..=hi).contains(x))
        .collect();
    let (first, last) = (*inside.first()?, *inside.last()?);
    if inside.len() == v.len() || last <= first {
        return None;
    }
    let pad = 0.05 * (last - first);
    Some((first - pad, last + pad))
}

/// Boundary curves drawn together (`boundary.svg`: `omegabar_b` against `q` on logarithmic
/// axes; `m_loc.svg`: `m_loc` against `q`), a line per curve in one colour, broken where the
/// boundary switches or jumps to another segment, labelled by the curve's label (none for a lone
/// unlabelled curve), the special points marked.
fn curve_figures(
    dir: &Path,
    key: &str,
    curves: &[(String, Vec<BoundaryPoint>)],
    special: &[(String, SpecialPoint)],
) -> Result<()> {
    // Each point's omegabar_b and its estimated error (the relative error of omega_b).
    let error = |r: &BoundaryPoint| {
        r.omega_b_error
            .map_or(f64::NAN, |e| e / r.omega_b.abs() * r.omegabar_b.abs())
    };
    type Band<'b> = Option<&'b dyn Fn(&BoundaryPoint) -> f64>;
    // One series per curve: its segments one after the other, a gap (a point that cannot be
    // drawn) between two, `y` of each segment's `i`-th point given the segment.
    let series = |y: &dyn Fn(&[&BoundaryPoint], usize) -> f64, band: Band| -> Vec<Series> {
        curves
            .iter()
            .map(|(label, rows)| {
                let segments = rows.last().map_or(0, |r| r.segment + 1);
                let (mut xs, mut ys, mut errs) = (Vec::new(), Vec::new(), Vec::new());
                for k in 0..segments {
                    let on: Vec<&BoundaryPoint> = rows.iter().filter(|r| r.segment == k).collect();
                    if k > 0 {
                        xs.push(f64::NAN);
                        ys.push(f64::NAN);
                        errs.push(f64::NAN);
                    }
                    xs.extend(on.iter().map(|r| r.q));
                    ys.extend((0..on.len()).map(|i| y(&on, i)));
                    errs.extend(on.iter().map(|r| band.map_or(f64::NAN, |e| e(r))));
                }
                Series {
                    label: typeset(label),
                    x: xs,
                    y: ys,
                    style: Style::Line,
                    stable: None,
                    err: band.map(|_| errs),
                }
            })
            .collect()
    };
    // A special point stays where the curve found it, at the curve's N; where the points were
    // carried to an accuracy, its marker is moved onto the drawn line by the correction
    // (`omega_b / curve_omega_b`) of the nearest point of its curve.
    let markers: Vec<Marker> = special
        .iter()
        .map(|(label, p)| {
            let nearest = curves
                .iter()
                .filter(|(l, _)| l == label)
                .flat_map(|(_, rows)| rows.iter())
                .min_by(|a, b| (a.q - p.q).abs().total_cmp(&(b.q - p.q).abs()));
            Marker {
                label: p.kind.name().replace('_', " "),
                x: p.q,
                y: p.omegabar * nearest.map_or(1.0, |r| r.omega_b / r.curve_omega_b),
            }
        })
        .collect();
    let relative: Vec<f64> = curves
        .iter()
        .flat_map(|(_, rows)| rows.iter().map(|r| error(r) / r.omegabar_b.abs()))
        .collect();
    let omega = Figure {
        title: format!(
            "Stability boundaries{}",
            error_range("band", "estimated discretization error in N", &relative)
        ),
        x_label: axis_label(key),
        y_label: "ω̄_b = ω_b μℓ⁴/EI (–)".into(),
        x_scale: Scale::Log,
        y_scale: Scale::Log,
        series: series(&|on, i| on[i].omegabar_b, Some(&error)),
        markers,
        ..Figure::default()
    };
    write_figure(&omega, &dir.join("boundary.svg"))?;
    // m_loc diverges at a turning point of a curve in q (the tangent of ln ω̄_b against ln q is
    // vertical there and its sign flips across it), and a difference whose samples straddle one
    // can take any value (−192 at R/λ ≈ 0.377 in exponent_m, where the turning point located
    // last is stored after a sample already past it; 1.3e4 on a segment of two points, the
    // stretch between a turning point and the window the boundary jumps to, a few 1e-5 apart
    // in ln q). Such values say only "turning point here". So a sample is drawn where the
    // curve is seen to go one way through it: in a segment of at least three points, and not
    // where its neighbours reverse the direction of q or of ω̄_b (the line breaks there). The y
    // axis spans Tukey's far-out fences (quartiles ∓ 3 interquartile ranges) of the values:
    // every sample of a smooth stretch lies inside them, and a curve that diverges is drawn up
    // to the frame instead of setting the scale.
    let m_loc = series(
        &|on, i| {
            let turns = |f: fn(&BoundaryPoint) -> f64| {
                i > 0 && i + 1 < on.len() && {
                    let (a, b) = (f(on[i]) - f(on[i - 1]), f(on[i + 1]) - f(on[i]));
                    a * b < 0.0
                }
            };
            if on.len() < 3 || turns(|r| r.q) || turns(|r| r.omegabar_b) {
                f64::NAN
            } else {
                on[i].m_loc.unwrap_or(f64::NAN)
            }
        },
        Some(&|r: &BoundaryPoint| r.m_loc_error.unwrap_or(f64::NAN)),
    );
    let values: Vec<f64> = m_loc.iter().flat_map(|s| s.y.iter().copied()).collect();
    let y_range = far_out_fences(&values);
    // The errors of the samples drawn inside the frame (not of those left out at a turning
    // point, nor of those beyond the fences).
    let inside = |y: f64| y_range.map_or(y.is_finite(), |(lo, hi)| (lo..=hi).contains(&y));
    let m_loc_errors: Vec<f64> = m_loc
        .iter()
        .flat_map(|s| {
            let err = s.err.as_deref().unwrap_or_default();
            s.y.iter()
                .zip(err)
                .filter(|(y, _)| inside(**y))
                .map(|(_, e)| *e)
        })
        .collect();
    let exponent = Figure {
        title: format!(
            "Local exponent{}",
            absolute_error_range("band", "its estimated error", &m_loc_errors)
        ),
        x_label: axis_label(key),
        y_label: format!("m_loc = −d ln ω̄_b / d ln {} (–)", short_name(key)),
        series: m_loc,
        y_range,
        ..Figure::default()
    };
    write_figure(&exponent, &dir.join("m_loc.svg"))
}
