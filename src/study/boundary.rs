//! The boundary runs of `helixbif boundary` and of the `boundary` study kind: the curve of
//! [`crate::analysis::boundary`] streamed to `boundary.csv` and `points.csv` (rewritten after
//! every point, so that a failure keeps everything found), its figures, and for a study one
//! curve per case with the local exponent and a power law shared by the curves.

use std::path::Path;
use std::time::Instant;

use indicatif::ProgressBar;
use serde::Serialize;

use crate::analysis::boundary::{
    Boundary, BoundaryObserver, BoundaryPoint, Criticality, SpecialPoint, check_end,
    follow_boundary,
};
use crate::model::Model;
use crate::model::params::Field;
use crate::numerics::fit::{CommonPowerLaw, PowerLaw, common_power_law, line_intercept, power_law};
use crate::plot::{Figure, Marker, Scale, Series, Style, write_figure};
use crate::problem::family::RodFamily;
use crate::study::Study;
use crate::study::figures::{axis_label, error_range, short_name, typeset};
use crate::study::output::{CsvWriter, Meta, Provenance, create_dir, write_json};
use crate::study::plan::Case;
use crate::study::progress;
use crate::study::run::slug;
use crate::study::sweep::variant;
use crate::{Error, Result};

/// What `helixbif boundary` reports.
#[derive(Debug, Serialize)]
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
    /// mode opening there.
    pub window_checks: usize,
    pub seconds: f64,
    /// `omega_b` of an independent `locate` at the end of the range, and its relative
    /// difference from the curve's last point.
    pub check_omega_b: Option<f64>,
    pub check_difference: Option<f64>,
    /// How many Hopf points of the curve are supercritical, subcritical, undetermined, and
    /// without a coefficient (it could not be computed).
    pub criticality: Criticality,
    pub out: String,
}

/// What `meta.json` records of a boundary run: its report, or why it stopped short.
#[derive(Serialize)]
#[serde(untagged)]
enum BoundaryRun<'a> {
    Finished(&'a BoundaryReport),
    Stopped { error: String },
}

/// Writes the boundary to `boundary.csv` and `points.csv` in `dir` as it grows, and draws a
/// progress bar over the range.
struct BoundaryWriter<'a> {
    dir: &'a Path,
    bar: ProgressBar,
    range: (f64, f64),
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

/// Follows the boundary of `study` in `key` from `from` to `to` and writes `boundary.csv`,
/// `points.csv` and the figures to `dir`: the boundary found, and the report or why it did not
/// reach the end of the range (what was found is on disk either way).
pub fn run_boundary(
    study: &Study,
    key: &str,
    (from, to): (f64, f64),
    dir: &Path,
    provenance: &Provenance,
) -> Result<(Vec<BoundaryPoint>, Result<BoundaryReport>)> {
    run_family(study, &family(study, key)?, (from, to), dir, provenance)
}

/// [`run_boundary`] over the members of `family`.
pub(crate) fn run_family(
    study: &Study,
    family: &RodFamily,
    (from, to): (f64, f64),
    dir: &Path,
    provenance: &Provenance,
) -> Result<(Vec<BoundaryPoint>, Result<BoundaryReport>)> {
    let key = family.field().key();
    crate::analysis::boundary::check_range(family, from, to)?;
    let started = Instant::now();
    create_dir(dir)?;
    let bar = progress::bar(&format!("boundary in {key}"));
    let mut writer = BoundaryWriter {
        dir,
        bar,
        range: (from, to),
    };
    let settings = study.locate_settings();
    let (boundary, outcome) = follow_boundary(family, &settings, from, to, &mut writer);
    writer.bar.finish_and_clear();
    // What was found is kept (tables and figures) even when the curve could not be finished.
    let written = writer.write(&boundary).and_then(|()| {
        let special: Vec<(String, SpecialPoint)> = boundary
            .special
            .iter()
            .map(|p| (String::new(), p.clone()))
            .collect();
        curve_figures(
            dir,
            key,
            &[(String::new(), boundary.points.clone())],
            &special,
        )
    });
    let report = outcome.and(written).map(|()| {
        let last = boundary.points.last().expect("a finished curve has points");
        let check_omega_b = check_end(family, &settings, last);
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
            seconds: started.elapsed().as_secs_f64(),
            check_difference: check_omega_b.map(|w| (w - last.omega_b).abs() / last.omega_b.abs()),
            check_omega_b,
            criticality: boundary.criticality(),
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
    Ok((boundary.points, report))
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
    pub report: Option<BoundaryReport>,
    /// Why the curve did not reach the end of the range (its points so far are on disk).
    pub error: Option<String>,
    /// `m_loc` at the smallest `q` of the curve.
    pub m_loc_smallest: Option<[f64; 2]>,
    /// `m_loc` extrapolated to `q = 0` by a straight line through the lowest fifth of the
    /// curve's range of `q`.
    pub m_loc_limit: Option<f64>,
    /// `omegabar_b = C q^p` over the stated range, `m = -p`.
    pub fit: Option<PowerLaw>,
}

/// The exponents of a curve's rows: `m_loc` at the smallest `q`, its limit at `q = 0`, and the
/// power law over `fit`.
fn exponents(
    rows: &[BoundaryPoint],
    fit: Option<[f64; 2]>,
) -> (Option<[f64; 2]>, Option<f64>, Option<PowerLaw>) {
    let with_m: Vec<(f64, f64)> = rows
        .iter()
        .filter_map(|r| r.m_loc.filter(|_| r.q > 0.0).map(|m| (r.q, m)))
        .collect();
    let smallest = with_m
        .iter()
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|&(q, m)| [q, m]);
    let lo = with_m.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let hi = with_m.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
    let low: Vec<(f64, f64)> = with_m
        .iter()
        .copied()
        .filter(|p| p.0 <= lo + 0.2 * (hi - lo))
        .collect();
    let limit = line_intercept(&low);
    let power = fit.and_then(|[a, b]| {
        let inside: Vec<&BoundaryPoint> = rows.iter().filter(|r| r.q >= a && r.q <= b).collect();
        let x: Vec<f64> = inside.iter().map(|r| r.q).collect();
        let y: Vec<f64> = inside.iter().map(|r| r.omegabar_b).collect();
        power_law(&x, &y).ok()
    });
    (smallest, limit, power)
}

/// A boundary study: a curve per case in `key` over `range`, each in its own folder (the
/// study's own when there is one case), the curves drawn together (`boundary.svg`,
/// `m_loc.svg`), and with `fit`, one power law shared by the curves over that range
/// (`fit.json`: `m`, its interval, the range; the exponent the phase study reads). Returns the
/// summary and the curves that did not finish.
pub fn run_study(
    study: &Study,
    key: &str,
    (from, to): (f64, f64),
    cases: &[Case],
    fit: Option<[f64; 2]>,
    dir: &Path,
    provenance: &Provenance,
) -> Result<(BoundaryStudy, Vec<String>)> {
    let mut summaries = Vec::new();
    let mut failures = Vec::new();
    let mut all_rows = Vec::new();
    let mut all_special = Vec::new();
    for case in cases {
        let s = variant(study, case, &[], &[])?;
        let sub = if cases.len() == 1 {
            dir.to_path_buf()
        } else {
            dir.join(slug(&case.label))
        };
        let (rows, outcome) = run_boundary(&s, key, (from, to), &sub, provenance)?;
        let (report, error) = match outcome {
            Ok(r) => (Some(r), None),
            Err(e) if e.is_input() => return Err(e),
            Err(e) => {
                failures.push(format!("{}: {e}", case.label));
                (None, Some(e.to_string()))
            }
        };
        let (m_loc_smallest, m_loc_limit, power) = exponents(&rows, fit);
        if let Some(r) = &report {
            all_special.extend(r.special.iter().map(|p| (case.label.clone(), p.clone())));
        }
        all_rows.push((case.label.clone(), rows));
        summaries.push(CurveSummary {
            label: case.label.clone(),
            report,
            error,
            m_loc_smallest,
            m_loc_limit,
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
/// axes; `m_loc.svg`: `m_loc` against `q`), a line per curve and segment, labelled by the curve's
/// label (none for a lone unlabelled curve), the special points marked.
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
    let series = |y: &dyn Fn(&[&BoundaryPoint], usize) -> f64, band: bool| -> Vec<Series> {
        curves
            .iter()
            .flat_map(|(label, rows)| {
                let segments = rows.last().map_or(0, |r| r.segment + 1);
                (0..segments).map(move |k| {
                    let on: Vec<&BoundaryPoint> = rows.iter().filter(|r| r.segment == k).collect();
                    Series {
                        label: if segments > 1 {
                            format!("{} (curve {})", typeset(label), k + 1)
                        } else {
                            typeset(label)
                        },
                        x: on.iter().map(|r| r.q).collect(),
                        y: (0..on.len()).map(|i| y(&on, i)).collect(),
                        style: Style::Line,
                        stable: None,
                        err: band.then(|| on.iter().map(|r| error(r)).collect()),
                    }
                })
            })
            .collect()
    };
    let markers: Vec<Marker> = special
        .iter()
        .map(|(_, p)| Marker {
            label: p.kind.name().replace('_', " "),
            x: p.q,
            y: p.omegabar,
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
        series: series(&|on, i| on[i].omegabar_b, true),
        markers,
        ..Figure::default()
    };
    write_figure(&omega, &dir.join("boundary.svg"))?;
    // m_loc diverges at a turning point of a curve in q (the tangent of ln ω̄_b against ln q is
    // vertical there and its sign flips across it), and a difference whose samples straddle one
    // can take any value (−192 at R/λ ≈ 0.377 in exponent_m, where the turning point located
    // last is stored after a sample already past it). Such values say only "turning point
    // here". So a sample whose neighbours reverse the direction of q or of ω̄_b is left out
    // (the line breaks there), and the y axis spans Tukey's far-out fences (quartiles ∓ 3
    // interquartile ranges) of the values: every sample of a smooth stretch lies inside them,
    // and a curve that diverges is drawn up to the frame instead of setting the scale.
    let m_loc = series(
        &|on, i| {
            let turns = |f: fn(&BoundaryPoint) -> f64| {
                i > 0 && i + 1 < on.len() && {
                    let (a, b) = (f(on[i]) - f(on[i - 1]), f(on[i + 1]) - f(on[i]));
                    a * b < 0.0
                }
            };
            if turns(|r| r.q) || turns(|r| r.omegabar_b) {
                f64::NAN
            } else {
                on[i].m_loc.unwrap_or(f64::NAN)
            }
        },
        false,
    );
    let values: Vec<f64> = m_loc.iter().flat_map(|s| s.y.iter().copied()).collect();
    let exponent = Figure {
        title: "Local exponent of the stability boundaries".into(),
        x_label: axis_label(key),
        y_label: format!("m_loc = −d ln ω̄_b / d ln {} (–)", short_name(key)),
        series: m_loc,
        y_range: far_out_fences(&values),
        ..Figure::default()
    };
    write_figure(&exponent, &dir.join("m_loc.svg"))
}
