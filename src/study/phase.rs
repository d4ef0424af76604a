//! `kind = "phase"`: the propulsive force over the plane (`lambda/l`, `omegabar (R/lambda)^m`),
//! with the stability boundary and natural bacterial flagella placed on it.
//!
//! One branch per value of `lambda/l` (the pitch varied at fixed `l` and `R`, so `R/lambda`
//! changes with it); the vertical coordinate `omegabar (R/lambda)^m` removes the dependence on
//! `R/lambda` found by the exponent study, and is drawn in `log10` so that the flagella's wide
//! ranges (two decades of `EI`, 300 to 700 rev/s) fit beside the computed branches.

use std::path::Path;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::plan::{
    CARRY_SPACING, Case, POINT_REFINEMENT, Plan, Vary, check_refinement_room, point_accuracy,
    with_carry_spacing,
};
use super::sweep::{located_point, variant};
use super::{LAMBDA_OVER_L, Study};
use crate::analysis::boundary::{BoundaryPoint, PointAccuracy};
use crate::analysis::branch::{observables_at, probe_windows, trace_charted};
use crate::analysis::locate::{LocateSettings, Loss};
use crate::analysis::solve::rest_state;
use crate::engine::events::Event;
use crate::engine::stop::Silent;
use crate::model::Model;
use crate::model::params::Field;
use crate::model::params::ShapeParams;
use crate::plot::{Heatmap, MarkerShape, Series, Style, write_heatmap};
use crate::study::boundary::{Kept, family, run_family};
use crate::study::figures::{FPBAR_LABEL, typeset};
use crate::study::output::{CsvWriter, Provenance, Table};
use crate::study::progress;
use crate::{Error, Result};

/// A row of `phase.csv`: a point of a branch, with `y = omegabar (R/lambda)^m`.
#[derive(serde::Serialize)]
struct PhaseRow {
    lambda_over_l: f64,
    #[serde(rename = "R_over_lambda")]
    r_over_lambda: f64,
    omegabar: f64,
    y: f64,
    #[serde(rename = "Fpbar")]
    fpbar: f64,
    stable: bool,
}

/// A row of the phase study's `boundary.csv`: the first loss of stability of a column, at the
/// finest `N` of its refinement (`nodes`); `reached` only where the study asks for an accuracy.
#[derive(serde::Serialize)]
struct ColumnLossRow {
    lambda_over_l: f64,
    #[serde(rename = "R_over_lambda")]
    r_over_lambda: f64,
    omegabar_b: f64,
    omegabar_b_error: Option<f64>,
    y_b: f64,
    y_b_error: Option<f64>,
    kind: Loss,
    nodes: usize,
    reached: Option<bool>,
}

/// What the `phase` study reports.
#[derive(Serialize)]
pub struct PhaseResult {
    /// The exponent of the vertical coordinate `omegabar (R/lambda)^m`.
    pub m: f64,
    /// The relative accuracy of `omega_b` the columns' first losses and the curve's Hopf points
    /// were carried to (`None`: each at its own `N` with its estimated error).
    pub accuracy: Option<f64>,
    pub columns: Vec<ColumnSummary>,
    /// The flagella of the data file left off the map, and why.
    pub skipped_flagella: Vec<String>,
    pub boundary_curve: CurveOutcome,
}

impl PhaseResult {
    /// What the map fell short of: the accuracy, at the columns and on the curve that did not
    /// reach it.
    pub fn shortfall(&self) -> Vec<String> {
        let Some(accuracy) = self.accuracy else {
            return Vec::new();
        };
        let missed: Vec<String> = self
            .columns
            .iter()
            .filter(|c| c.reached == Some(false))
            .map(|c| format!("{}", c.lambda_over_l))
            .collect();
        let columns = (!missed.is_empty()).then(|| {
            format!(
                "accuracy {accuracy:e} not reached at the first loss of stability of the \
                 column(s) lambda/l = {} (column reached of boundary.csv)",
                missed.join(", ")
            )
        });
        let curve = match &self.boundary_curve {
            CurveOutcome::Written {
                shortfall: Some(s), ..
            } => Some(format!("boundary curve: {s}")),
            _ => None,
        };
        columns.into_iter().chain(curve).collect()
    }
}

/// One column of the map: its ratios, its first loss of stability and its branch's size.
#[derive(Serialize)]
pub struct ColumnSummary {
    pub lambda_over_l: f64,
    #[serde(rename = "R_over_lambda")]
    pub r_over_lambda: f64,
    pub omegabar_b: Option<f64>,
    /// The estimated discretization error of `omegabar_b` ([`ColumnLoss`]), or why it has none.
    pub omegabar_b_error: Option<f64>,
    pub error_missing: Option<String>,
    pub kind: Option<Loss>,
    /// The node count `omegabar_b` is at (the finest rung of its refinement).
    pub nodes: Option<usize>,
    /// Whether `omegabar_b` reached the study's accuracy (absent without one).
    pub reached: Option<bool>,
    /// A near miss that its probes neither resolved nor excluded (docs/model.md section 5), of
    /// a rung's branch from rest (a window of instability below `omegabar_b` may have been
    /// stepped over) or else of the column's own branch (a window may be missing from the
    /// map): the `N` and why.
    pub near_miss_unresolved: Option<String>,
    /// The column's rows of `phase.csv`: the branch's points from rest up to its first fold and
    /// the probes of its near misses among them.
    pub points: usize,
}

/// Where the boundary curve of the map was written, or why it could not be followed.
#[derive(Serialize)]
#[serde(untagged)]
pub enum CurveOutcome {
    /// Written to `out`; `shortfall` where points fell short of the study's accuracy.
    Written {
        out: String,
        #[serde(skip_serializing_if = "Option::is_none")]
        shortfall: Option<String>,
    },
    Failed {
        error: String,
    },
}

/// The exponent `m` in a `fit.json` (of a boundary or a sweep study).
#[derive(Deserialize)]
struct ExponentFile {
    m: f64,
}

/// The branch of one column of the map.
struct Column {
    lambda_over_l: f64,
    r_over_lambda: f64,
    /// `(omegabar, Fpbar, stable)` from rest up to the first fold (or the end), with the probes
    /// of its near misses among them.
    points: Vec<(f64, f64, bool)>,
    /// First loss of stability at the column's `N`.
    boundary: Option<ColumnLoss>,
    /// The first near miss of the column's branch that its probes neither resolved nor excluded
    /// (a window there may be missing from the map), and why.
    near_miss_unresolved: Option<String>,
}

/// A column's first loss of stability ([`located_point`]): at its `N` with the estimated
/// discretization error of `omegabar_b` (from a coarser rung at `N/2 + 1` nodes, the
/// quadrature's error included), or carried to the study's accuracy by `locate`'s refinement
/// (`reached` says whether it got there), or why it has no error; `nodes` the `N` of
/// `omegabar_b`.
struct ColumnLoss {
    omegabar_b: f64,
    error: std::result::Result<f64, String>,
    kind: Loss,
    nodes: usize,
    reached: Option<bool>,
    /// The first rung's near miss left unresolved ([`ColumnSummary::near_miss_unresolved`]).
    near_miss_unresolved: Option<String>,
}

/// The study of the column `lambda/l` (with `R/lambda` held where the plan holds it).
fn column_study(study: &Study, lambda_over_l: f64, r_over_lambda: Option<f64>) -> Result<Study> {
    let base = Case {
        label: "base".into(),
        set: toml::Table::new(),
        scale: None,
    };
    let ratio = |key: &str, value: f64| Vary {
        key: key.into(),
        values: vec![value],
        range: None,
    };
    let mut vary = vec![ratio("shape.lambda_over_l", lambda_over_l)];
    let mut values = vec![lambda_over_l];
    if let Some(r) = r_over_lambda {
        vary.push(ratio("shape.R_over_lambda", r));
        values.push(r);
    }
    variant(study, &base, &vary, &values)
}

fn column(
    study: &Study,
    lambda_over_l: f64,
    r_over_lambda: Option<f64>,
    accuracy: Option<PointAccuracy>,
) -> Result<Column> {
    let s = column_study(study, lambda_over_l, r_over_lambda)?;
    let ShapeParams::Helix { lambda, radius, .. } = s.shape else {
        return Err(Error::input("shape.kind", "a phase diagram needs a helix"));
    };
    let model = Model::new(&s.physical())?;
    let rest = rest_state(&model, &s.newton)?;
    let omegabar_max = model.scales.omega_to_bar(s.branch.omega_max);
    let traced = trace_charted(
        &model,
        &rest,
        omegabar_max,
        &s.continuation,
        false,
        &mut Silent,
    )?;
    // A window of instability inside one step changes no unstable count between the points:
    // the probes of the near misses find it (as `branch` does, docs/model.md section 5), and
    // take their place among the points.
    let misses = probe_windows(&model, &traced, omegabar_max, &s.newton, &s.continuation)?;
    let branch = &traced.branch;
    let rising = branch
        .points
        .iter()
        .take_while(|p| p.tangent_p > 0.0)
        .count();
    let mut points = Vec::new();
    for p in &branch.points[..rising] {
        let o = observables_at(&model, &rest, &p.u, p.p)?;
        points.push((p.p, o.fpbar, p.spectrum.unstable == 0));
    }
    let probed = (misses.stable.iter())
        .chain(misses.windows.iter().map(|w| &w.probe))
        .filter(|q| q.after + 1 < rising);
    for q in probed {
        let o = observables_at(&model, &rest, &q.u, q.p)?;
        points.push((q.p, o.fpbar, q.spectrum.unstable == 0));
    }
    // Below the first fold `omegabar` rises along the branch, and orders it.
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The first loss of stability again with a coarser rung beside it, for its error (the
    // branch above keeps every point for the map; its Lyapunov coefficient is not drawn).
    // The branch's own first loss: an event, or a window's loss if that lies in an earlier step.
    let event = (branch.events.iter()).find(|e| e.unstable_before == 0 && e.unstable_after > 0);
    let window = misses
        .windows
        .first()
        .filter(|w| event.is_none_or(|e| branch.points[w.probe.after].s < e.s));
    let first = window.map(|w| &w.loss.event).or(event);
    let boundary = first.map(|e| column_loss(&s, e, accuracy)).transpose()?;
    let near_miss_unresolved = (misses.unresolved_described(&model).next())
        .map(|why| format!("at N = {}, {why}", model.nodes()));
    Ok(Column {
        lambda_over_l,
        r_over_lambda: radius / lambda,
        points,
        boundary,
        near_miss_unresolved,
    })
}

/// The first loss of stability of the column study `s` whose branch loses its stability first at
/// `first` (an event of the branch or a window's loss), with its error: the answer of
/// [`located_point`] (two rungs at the column's `N`, or with `accuracy` refined from it, as a
/// sweep point's), or where that finds no `omega_b` or fails (a numerical failure; bad input
/// stays an error), `first` without an error, saying why.
fn column_loss(s: &Study, first: &Event, accuracy: Option<PointAccuracy>) -> Result<ColumnLoss> {
    let settings = LocateSettings {
        criticality: false,
        ..s.locate_settings()
    };
    // The branch's own loss, without an error (`why`).
    let unestimated = |why: String, near_miss_unresolved: Option<String>| ColumnLoss {
        omegabar_b: first.p,
        error: Err(why),
        kind: Loss::Event(first.kind),
        nodes: s.discretization.nodes,
        reached: accuracy.map(|_| false),
        near_miss_unresolved,
    };
    let refined = match located_point(&s.physical(), &settings, accuracy) {
        Ok(r) => r,
        Err(e) if !e.is_input() => {
            return Ok(unestimated(
                format!("locate at the column's N failed: {e}"),
                None,
            ));
        }
        Err(e) => return Err(e),
    };
    let answer = &refined.finest;
    let near_miss_unresolved = refined.rungs.iter().find_map(|r| {
        r.near_miss_unresolved
            .as_ref()
            .map(|why| format!("at N = {}, {why}", r.nodes))
    });
    if let (Some(omegabar_b), Some(omega_b)) = (answer.omegabar_b, answer.omega_b) {
        let why = || {
            refined
                .stopped
                .clone()
                .unwrap_or_else(|| "no coarser rung to compare".into())
        };
        return Ok(ColumnLoss {
            omegabar_b,
            error: refined
                .omega_b_error
                .map(|e| e * omegabar_b / omega_b)
                .ok_or_else(why),
            kind: answer.kind,
            nodes: answer.nodes,
            reached: accuracy.map(|_| refined.reached),
            near_miss_unresolved,
        });
    }
    Ok(unestimated(
        format!(
            "locate at the column's N found no omega_b ({}) to estimate its error from",
            answer.kind
        ),
        near_miss_unresolved,
    ))
}

/// Linear interpolation of `Fpbar` at `omegabar` along a column (NaN outside it).
fn interpolate(points: &[(f64, f64, bool)], omegabar: f64) -> f64 {
    // A rate within rounding of a branch's end (the map's first and last rows are at the ends
    // of the branches' range, through log10 and back) still lies on the branch.
    let tol = 1e-9 * omegabar.abs();
    points
        .windows(2)
        .find(|w| w[0].0 - tol <= omegabar && omegabar <= w[1].0 + tol)
        .map_or(f64::NAN, |w| {
            let t = ((omegabar - w[0].0) / (w[1].0 - w[0].0)).clamp(0.0, 1.0);
            w[0].1 + t * (w[1].1 - w[0].1)
        })
}

/// The exponent `m`: from the plan, else from the `fit.json` of the exponent study beside the
/// output folder `dir` (`dir/../<name>/fit.json`), else by running that study into
/// `dir/<name>/` (nothing is written outside `dir`).
fn exponent(
    m: Option<f64>,
    exponent_study: &str,
    dir: &Path,
    provenance: &Provenance,
) -> Result<f64> {
    if let Some(m) = m {
        return Ok(m);
    }
    let source = Study::from_path(Some(Path::new(exponent_study)), &[]).map_err(|e| {
        Error::input(
            "study.exponent_study",
            format!("give m, or a readable exponent study: {e}"),
        )
    })?;
    let beside = dir.parent().map(|p| p.join(&source.name).join("fit.json"));
    let path = match beside.filter(|p| p.is_file()) {
        Some(path) => path,
        None => {
            let own = dir.join(&source.name);
            progress::note(&format!(
                "helixbif: no fit.json of `{}` beside {}: running {exponent_study} into {}",
                source.name,
                dir.display(),
                own.display()
            ));
            super::run::run(&source, &own, false, provenance)?;
            own.join("fit.json")
        }
    };
    let text = std::fs::read_to_string(&path).map_err(crate::study::output::io_error(&path))?;
    let file: ExponentFile = serde_json::from_str(&text)
        .map_err(|e| Error::input("study.m", format!("{}: {e}", path.display())))?;
    Ok(file.m)
}

/// A flagellum placed on the map: its `lambda/l` and the range of `log10(omegabar (R/lambda)^m)`
/// for `EI` in [1e-24, 1e-22] N m^2 and 300 to 700 rev/s in water (`mu = 1e-3` Pa s); the central
/// value for 500 rev/s and `EI = 3.5e-24` N m^2 (measured for E. coli).
struct Flagellum {
    label: String,
    lambda_over_l: f64,
    low: f64,
    central: f64,
    high: f64,
}

fn flagella(path: &str, m: f64) -> Result<(Vec<Flagellum>, Vec<String>)> {
    let table = Table::read(Path::new(path))?;
    let (org, form) = (table.index("organism")?, table.index("form")?);
    let (pc, rc, lc) = (
        table.index("pitch_um")?,
        table.index("helix_radius_um")?,
        table.index("length_um")?,
    );
    let mu = 1e-3;
    let mut placed = Vec::new();
    let mut skipped = Vec::new();
    for r in 0..table.rows.len() {
        let label = format!("{} ({})", table.text(r, org), table.text(r, form));
        let (Some(pitch), Some(radius), Some(length)) = (
            table.number(r, pc),
            table.number(r, rc),
            table.number(r, lc),
        ) else {
            skipped.push(format!("{label}: length unknown, not placed"));
            continue;
        };
        let l = length * 1e-6;
        let shape = (radius / pitch).powf(m);
        let y = |rev_per_s: f64, ei: f64| {
            (2.0 * std::f64::consts::PI * rev_per_s * mu * l.powi(4) / ei * shape).log10()
        };
        placed.push(Flagellum {
            label,
            lambda_over_l: pitch / length,
            low: y(300.0, 1e-22),
            central: y(500.0, 3.5e-24),
            high: y(700.0, 1e-24),
        });
    }
    Ok((placed, skipped))
}

/// Runs the study: `phase.csv`, `boundary.csv`, `phase.svg`.
pub(crate) fn run_phase(study: &Study, dir: &Path, provenance: &Provenance) -> Result<PhaseResult> {
    let Some(Plan::Phase {
        lambda_over_l,
        r_over_lambda,
        m,
        exponent_study,
        rows,
        bacteria,
        accuracy,
        max_nodes,
        carry_spacing,
    }) = &study.study
    else {
        return Err(Error::input("study.kind", "expected a phase study"));
    };
    let accuracy = point_accuracy(*accuracy, *max_nodes, POINT_REFINEMENT)?;
    let mut values = lambda_over_l.clone();
    values.sort_by(f64::total_cmp);
    // The curve's points, refined at its carry spacing; the columns each.
    let range = (values[0], values[values.len() - 1]);
    let curve_accuracy = with_carry_spacing(accuracy, *carry_spacing, range, CARRY_SPACING)?;
    // Every column's N, and the curve's, leave the refinement room; checked before anything
    // runs.
    if let Some(a) = accuracy {
        check_refinement_room("study.max_nodes", a.max_nodes, &study.physical())?;
        for &v in &values {
            let s = column_study(study, v, *r_over_lambda)?;
            check_refinement_room("study.max_nodes", a.max_nodes, &s.physical())?;
        }
    }
    let m = exponent(*m, exponent_study, dir, provenance)?;
    let columns = values
        .par_iter()
        .map(|&v| column(study, v, *r_over_lambda, accuracy))
        .collect::<Result<Vec<Column>>>()?;
    let mut table = CsvWriter::create(&dir.join("phase.csv"))?;
    let mut bounds = CsvWriter::create(&dir.join("boundary.csv"))?;
    for c in &columns {
        let shape = c.r_over_lambda.powf(m);
        for &(omegabar, fpbar, stable) in &c.points {
            table.row(&PhaseRow {
                lambda_over_l: c.lambda_over_l,
                r_over_lambda: c.r_over_lambda,
                omegabar,
                y: omegabar * shape,
                fpbar,
                stable,
            })?;
        }
        if let Some(loss) = &c.boundary {
            bounds.row(&ColumnLossRow {
                lambda_over_l: c.lambda_over_l,
                r_over_lambda: c.r_over_lambda,
                omegabar_b: loss.omegabar_b,
                omegabar_b_error: loss.error.as_ref().ok().copied(),
                y_b: loss.omegabar_b * shape,
                y_b_error: loss.error.as_ref().ok().map(|e| e * shape),
                kind: loss.kind,
                nodes: loss.nodes,
                reached: loss.reached,
            })?;
        }
    }
    // The vertical grid in log10(omegabar (R/lambda)^m), over what the branches cover.
    let logs: Vec<f64> = columns
        .iter()
        .flat_map(|c| {
            c.points
                .iter()
                .filter(|p| p.0 > 0.0)
                .map(move |p| (p.0 * c.r_over_lambda.powf(m)).log10())
        })
        .collect();
    let (lo, hi) = logs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    // The top row at the highest rate every column reaches: the branches all stop just past
    // `omega_max`, each a little further, and a row above the lowest of these ends would be
    // blank in every column but one.
    let hi = columns
        .iter()
        .filter_map(|c| {
            c.points
                .iter()
                .filter(|p| p.0 > 0.0)
                .map(|p| (p.0 * c.r_over_lambda.powf(m)).log10())
                .reduce(f64::max)
        })
        .fold(hi, f64::min)
        .max(lo);
    let ys: Vec<f64> = (0..*rows)
        .map(|i| lo + (hi - lo) * i as f64 / (*rows - 1) as f64)
        .collect();
    let z: Vec<Vec<f64>> = ys
        .iter()
        .map(|y| {
            columns
                .iter()
                .map(|c| interpolate(&c.points, 10f64.powf(*y) / c.r_over_lambda.powf(m)))
                .collect()
        })
        .collect();
    // The columns' first losses at `log10 y_b`, each with a symmetric bar that covers both
    // ends of `omegabar_b (1 +- r)`, `r` the relative error: `-log10(1 - r)` decades (`r` taken
    // at most 0.99; none where the error could not be estimated).
    let marked: Vec<(f64, f64, f64)> = columns
        .iter()
        .filter_map(|c| {
            c.boundary.as_ref().map(|loss| {
                let y = (loss.omegabar_b * c.r_over_lambda.powf(m)).log10();
                let bar = loss
                    .error
                    .as_ref()
                    .map_or(0.0, |e| -(1.0f64 - (e / loss.omegabar_b).min(0.99)).log10());
                (c.lambda_over_l, y, bar)
            })
        })
        .collect();
    let bx: Vec<f64> = marked.iter().map(|t| t.0).collect();
    let by: Vec<f64> = marked.iter().map(|t| t.1).collect();
    let bars: Vec<f64> = marked.iter().map(|t| t.2).collect();
    // The stability boundary as a curve in lambda/l (two-parameter continuation of the Hopf
    // point, `R/lambda` held where the study holds it), the columns' own first losses of
    // stability marked on it; the columns joined by a line where the curve cannot be followed.
    let curve = boundary_curve(
        study,
        (&values, *r_over_lambda),
        m,
        curve_accuracy,
        &dir.join("boundary_curve"),
        provenance,
    );
    let mut overlays = match &curve {
        Ok((lines, _)) => lines.clone(),
        Err(_) => vec![Series {
            label: "stability boundary (first loss in each column)".into(),
            x: bx.clone(),
            y: by.clone(),
            style: Style::Line,
            stable: None,
            err: None,
        }],
    };
    overlays.push(Series {
        label: "first loss of stability (own N, estimated error)".into(),
        x: bx,
        y: by,
        style: Style::Markers(MarkerShape::Circle),
        stable: None,
        err: Some(bars),
    });
    let mut skipped = Vec::new();
    if let Some(path) = bacteria {
        let (placed, missing) = flagella(path, m)?;
        skipped = missing;
        for f in placed {
            // The exact range as a vertical segment, the central value as a marker on it.
            overlays.push(Series {
                label: format!("{} (range)", typeset(&f.label)),
                x: vec![f.lambda_over_l, f.lambda_over_l],
                y: vec![f.low, f.high],
                style: Style::Line,
                stable: None,
                err: None,
            });
            overlays.push(Series {
                label: String::new(),
                x: vec![f.lambda_over_l],
                y: vec![f.central],
                style: Style::Markers(MarkerShape::Square),
                stable: None,
                err: None,
            });
        }
    }
    write_heatmap(
        &Heatmap {
            title: format!("Propulsive force over the phase plane (m = {m:.3})"),
            x_label: "λ/ℓ (–)".into(),
            y_label: "log₁₀(ω̄ (R/λ)ᵐ) (–)".into(),
            colorbar_label: FPBAR_LABEL.into(),
            x: values.clone(),
            y: ys,
            z,
            overlays,
            // Rows are samples of each column's branch, fine in y; columns are the study's few
            // values of lambda/l, kept apart.
            smooth_y: true,
        },
        &dir.join("phase.svg"),
    )?;
    Ok(PhaseResult {
        m,
        accuracy: accuracy.map(|a| a.accuracy),
        columns: columns
            .iter()
            .map(|c| ColumnSummary {
                lambda_over_l: c.lambda_over_l,
                r_over_lambda: c.r_over_lambda,
                omegabar_b: c.boundary.as_ref().map(|b| b.omegabar_b),
                omegabar_b_error: c.boundary.as_ref().and_then(|b| b.error.clone().ok()),
                error_missing: c.boundary.as_ref().and_then(|b| b.error.clone().err()),
                kind: c.boundary.as_ref().map(|b| b.kind),
                nodes: c.boundary.as_ref().map(|b| b.nodes),
                reached: c.boundary.as_ref().and_then(|b| b.reached),
                near_miss_unresolved: (c.boundary.as_ref())
                    .and_then(|b| b.near_miss_unresolved.clone())
                    .or_else(|| c.near_miss_unresolved.clone()),
                points: c.points.len(),
            })
            .collect(),
        skipped_flagella: skipped,
        boundary_curve: match &curve {
            Ok((_, shortfall)) => CurveOutcome::Written {
                out: dir.join("boundary_curve").display().to_string(),
                shortfall: shortfall.clone(),
            },
            Err(e) => CurveOutcome::Failed {
                error: e.to_string(),
            },
        },
    })
}

/// The boundary curve from the smallest to the largest `lambda/l` of the columns `values`
/// (`R/lambda` held where given), as lines of `log10(omegabar_b (R/lambda)^m)` (one per segment
/// of the curve), written to `dir`; with `accuracy`, every Hopf point carried to it, and what
/// the curve fell short of.
fn boundary_curve(
    study: &Study,
    (values, r_over_lambda): (&[f64], Option<f64>),
    m: f64,
    accuracy: Option<PointAccuracy>,
    dir: &Path,
    provenance: &Provenance,
) -> Result<(Vec<Series>, Option<String>)> {
    let ShapeParams::Helix { l, radius, .. } = study.shape else {
        return Err(Error::input("shape.kind", "a phase diagram needs a helix"));
    };
    let mut family = family(study, LAMBDA_OVER_L)?;
    if let Some(r) = r_over_lambda {
        family = family.holding(Field::ROverLambda, r);
    }
    let (from, to) = (values[0], values[values.len() - 1]);
    let mut kept = Kept::default();
    let outcome = run_family(
        study,
        &family,
        (from, to),
        (accuracy, dir, provenance),
        &mut kept,
    )?;
    let shortfall = outcome?.shortfall();
    let rows = kept.rows;
    let segments = rows.last().map_or(0, |r| r.segment + 1);
    let lines = (0..segments)
        .map(|k| {
            let on: Vec<&BoundaryPoint> = rows.iter().filter(|r| r.segment == k).collect();
            let shape = |q: f64| r_over_lambda.unwrap_or(radius / (q * l)).powf(m);
            Series {
                label: if k == 0 {
                    "stability boundary (curve)".into()
                } else {
                    String::new()
                },
                x: on.iter().map(|r| r.q).collect(),
                y: on
                    .iter()
                    .map(|r| (r.omegabar_b * shape(r.q)).log10())
                    .collect(),
                style: Style::Line,
                stable: None,
                err: None,
            }
        })
        .collect();
    Ok((lines, shortfall))
}

#[cfg(test)]
mod tests {
    use super::{Study, column, interpolate};
    use crate::analysis::branch::trace;
    use crate::analysis::solve::rest_state;
    use crate::engine::ContinuationSettings;
    use crate::engine::events::EventKind;
    use crate::engine::stop::Silent;
    use crate::model::Model;

    /// A column whose only loss of stability is a window inside one step of its branch:
    /// `exponent_m.toml`'s `lambda/l = 0.25` rod on the RPY line (15 nodes per turn, `N = 61`)
    /// at `R/lambda = 0.3725`, followed towards 30 rad/s for 14 points, to 0.01678 rad/s: a mode
    /// rises through the axis at 0.01452 rad/s and falls back at 0.01528, inside the step from
    /// 0.01192 to 0.01570 (the next loss, 0.01732, lies past the last point). The column's first
    /// loss must be that window's, as an independent continuation with short steps (up to 0.018
    /// rad/s, steps of at most 0.0005 rad/s) finds it as its first Hopf point, to `1e-7`
    /// relative; its map must mark a rate inside the window unstable, and those below it stable.
    /// Without the probes the column had no loss and its map no unstable row.
    #[test]
    fn a_column_whose_only_loss_is_a_window_inside_one_step_has_that_loss() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/studies/fig4d_phase.toml");
        let overrides: Vec<String> = [
            "fluid.model=\"rpy\"",
            "discretization.per_turn=15",
            "branch.omega_max=30",
            "continuation.max_points=14",
            "study.m=2.5",
        ]
        .map(String::from)
        .to_vec();
        let study = Study::from_path(Some(path.as_ref()), &overrides).unwrap();
        let c = column(&study, 0.25, Some(0.3725), None).unwrap();
        let loss = c
            .boundary
            .expect("the window's loss is the column's first loss");
        assert_eq!(loss.nodes, 61);

        // The independent reference: the same rod followed with short steps.
        let s = super::column_study(&study, 0.25, Some(0.3725)).unwrap();
        let model = Model::new(&s.physical()).unwrap();
        let rest = rest_state(&model, &s.newton).unwrap();
        let omegabar_max = model.scales.omega_to_bar(0.018);
        let short = ContinuationSettings {
            max_points: ContinuationSettings::default().max_points,
            max_parameter_step: Some(0.0005 / 0.018),
            ..s.continuation.clone()
        };
        let branch = trace(&model, &rest, omegabar_max, &short, false, &mut Silent);
        let hopf: Vec<_> = (branch.unwrap().events.into_iter())
            .filter(|e| e.kind == EventKind::Hopf)
            .collect();
        assert!(hopf.len() >= 2 && hopf[0].loses_stability() && !hopf[1].loses_stability());
        let (first, regained) = (hopf[0].p, hopf[1].p);
        assert!(
            (loss.omegabar_b - first).abs() < 1e-7 * first,
            "column {}, short steps {first}",
            loss.omegabar_b
        );
        // The map: stable below the window, an unstable probe inside it.
        assert!((c.points.iter()).filter(|p| p.0 < first).all(|p| p.2));
        assert!(
            (c.points.iter()).any(|p| p.0 > first && p.0 < regained && !p.2),
            "{:?}",
            c.points
        );
        assert!(c.points.windows(2).all(|w| w[0].0 < w[1].0));
        assert!(c.near_miss_unresolved.is_none());
    }

    #[test]
    fn a_rate_within_rounding_of_a_branch_end_lies_on_the_branch() {
        let points = [(0.0, 0.0, true), (10.0, 2.0, true), (997.5, 28.8, true)];
        // The last row of the map: the largest rate through log10 and back, a few ulps off.
        assert_eq!(interpolate(&points, 997.5 * (1.0 + 1e-12)), 28.8);
        assert!((interpolate(&points, 5.0) - 1.0).abs() < 1e-12);
        assert!(interpolate(&points, 997.5 * (1.0 + 1e-6)).is_nan());
    }
}
