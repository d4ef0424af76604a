//! The figures of a traced branch: `hbar`, `Fpbar` (with the rigid-helix line), the efficiency
//! `eta`, and the leading `Re(s)` against `omega`; stable parts solid, unstable dashed, events
//! marked and named. Several branches (cases) share each figure.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::Result;
use crate::numerics::fit::{
    PowerLaw, Slope, common_power_law, local_exponents, power_law, through_origin,
};
use crate::plot::{Figure, Marker, MarkerShape, Scale, Series, Style, write_figure};
use crate::study::Study;
use crate::study::branch::BranchTables;
use crate::study::output::{LeftOut, Table, write_json};
use crate::study::plan::{FitKind, Plan};
use crate::study::progress;

/// One branch and its legend label.
pub(crate) struct DrawnBranch<'a> {
    pub label: &'a str,
    pub tables: &'a BranchTables,
    /// Draw the rigid-helix thrust line (helices only).
    pub rigid: bool,
}

fn line(
    label: &str,
    t: &BranchTables,
    y: impl Fn(&crate::study::branch::BranchRow) -> f64,
) -> Series {
    Series {
        label: label.to_string(),
        x: t.points.iter().map(|r| r.omega).collect(),
        y: t.points.iter().map(y).collect(),
        style: Style::Line,
        stable: Some(t.points.iter().map(|r| r.stable).collect()),
        err: None,
    }
}

fn events(
    cases: &[DrawnBranch],
    y: impl Fn(&crate::study::branch::EventRow) -> f64,
) -> Vec<Marker> {
    cases
        .iter()
        .flat_map(|c| c.tables.events.iter())
        .map(|e| Marker {
            label: e.kind.to_string(),
            x: e.omega,
            y: y(e),
        })
        .collect()
}

/// Writes `hbar.svg`, `Fpbar.svg`, `eta.svg` and `max_re.svg` into `dir`; returns their paths.
pub(crate) fn branch_figures(
    dir: &Path,
    title: &str,
    cases: &[DrawnBranch],
) -> Result<Vec<PathBuf>> {
    let label = |c: &DrawnBranch| {
        if cases.len() == 1 {
            String::from("steady branch")
        } else {
            c.label.to_string()
        }
    };
    let x_label = "omega (rad/s)".to_string();
    let mut written = Vec::new();

    let hbar = Figure {
        title: format!("{title}: suspended height"),
        x_label: x_label.clone(),
        y_label: "hbar = h/h0 (-)".into(),
        series: cases
            .iter()
            .map(|c| line(&label(c), c.tables, |r| r.hbar))
            .collect(),
        markers: events(cases, |e| e.hbar),
        ..Figure::default()
    };
    let mut thrust_series: Vec<Series> = cases
        .iter()
        .map(|c| line(&label(c), c.tables, |r| r.fpbar))
        .collect();
    for c in cases.iter().filter(|c| c.rigid) {
        let name = if cases.len() == 1 {
            "rigid helix".to_string()
        } else {
            format!("{} (rigid)", c.label)
        };
        thrust_series.push(Series {
            style: Style::Dashed,
            stable: None,
            ..line(&name, c.tables, |r| r.fpbar_rigid)
        });
    }
    let thrust = Figure {
        title: format!("{title}: propulsive force"),
        x_label: x_label.clone(),
        y_label: "Fpbar = Fp ell^2/EI (-)".into(),
        series: thrust_series,
        markers: events(cases, |e| e.fpbar),
        ..Figure::default()
    };
    let eta = Figure {
        title: format!("{title}: efficiency"),
        x_label: x_label.clone(),
        y_label: "eta = Fp ell/Tp (-)".into(),
        series: cases
            .iter()
            .map(|c| line(&label(c), c.tables, |r| r.eta.unwrap_or(f64::NAN)))
            .collect(),
        ..Figure::default()
    };
    let re = Figure {
        title: format!("{title}: leading eigenvalue"),
        x_label,
        y_label: "max Re(s) (1/s)".into(),
        series: cases
            .iter()
            .map(|c| line(&label(c), c.tables, |r| r.max_re))
            .collect(),
        markers: events(cases, |e| e.re),
        ..Figure::default()
    };
    for (name, fig) in [
        ("hbar.svg", hbar),
        ("Fpbar.svg", thrust),
        ("eta.svg", eta),
        ("max_re.svg", re),
    ] {
        let path = dir.join(name);
        write_figure(&fig, &path)?;
        written.push(path);
    }
    Ok(written)
}

/// The fit of one sweep figure, with the rows it left out.
#[derive(Serialize)]
pub struct SweepFit {
    pub figure: usize,
    #[serde(flatten)]
    pub fit: Fitted,
    pub left_out: Vec<LeftOut>,
}

/// A fit of a sweep figure, by its kind.
#[derive(Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Fitted {
    ThroughOrigin(Slope),
    PowerLaw(PowerLaw),
    CommonPowerLaw(CommonExponent),
}

/// One exponent `m` shared by the series, `y ~ N_k x^(-m)` (also the sweep's `fit.json`).
#[derive(Serialize)]
pub struct CommonExponent {
    pub m: f64,
    pub m_ci: [f64; 2],
    pub x: String,
    pub y: String,
    pub series: Option<String>,
    pub n: usize,
    pub r2: f64,
    pub prefactors: Vec<(String, f64)>,
    pub left_out: Vec<LeftOut>,
    /// Each series fitted alone.
    pub per_series_m: Vec<SeriesExponent>,
    /// The local exponent `m_loc = -d ln y / d ln x` between neighbouring points of each
    /// series: the power law's `m` is an average of these.
    pub local_m: Vec<LocalExponents>,
}

/// The exponent of one series fitted alone.
#[derive(Serialize)]
pub struct SeriesExponent {
    pub series: String,
    pub m: f64,
    pub m_ci: [f64; 2],
}

/// The local exponents of one series.
#[derive(Serialize)]
pub struct LocalExponents {
    pub series: String,
    pub intervals: Vec<LocalInterval>,
}

/// `m_loc` over one interval between neighbouring samples.
#[derive(Serialize)]
pub struct LocalInterval {
    pub x_lo: f64,
    pub x_hi: f64,
    pub x_mid: f64,
    pub m_loc: f64,
}

/// Draws the figures of a finished sweep (`sweep.csv` in `dir`) as its plan declares, with the
/// fits; a `common_power_law` fit also writes `fit.json` (the exponent `m = -p` of
/// `y ~ x^(-m)` with its interval) and a collapse figure. Returns the fits.
pub fn sweep_figures(study: &Study, dir: &Path) -> Result<Option<Vec<SweepFit>>> {
    let Some(Plan::Sweep { figures, .. }) = &study.study else {
        return Ok(None);
    };
    let table = Table::read(&dir.join("sweep.csv"))?;
    table.index("status")?;
    let mut fits = Vec::new();
    for (k, spec) in figures.iter().enumerate() {
        let (xc, yc) = (table.index(&spec.x)?, table.index(&spec.y)?);
        let sc = table.index(spec.series.as_deref().unwrap_or("case"))?;
        let positive = spec.log_x
            || spec.log_y
            || matches!(spec.fit, Some(FitKind::PowerLaw | FitKind::CommonPowerLaw));
        let (kept, left_out) = table.usable(xc, yc, positive);
        for l in &left_out {
            progress::note(&format!(
                "helixbif: figure {k} ({} against {}) leaves out {l}",
                spec.y, spec.x
            ));
        }
        // Groups in order of first appearance.
        let mut groups: Vec<(String, Vec<f64>, Vec<f64>)> = Vec::new();
        for (r, x, y) in kept {
            let g = table.text(r, sc).to_string();
            match groups.iter_mut().find(|e| e.0 == g) {
                Some(e) => {
                    e.1.push(x);
                    e.2.push(y);
                }
                None => groups.push((g, vec![x], vec![y])),
            }
        }
        let shapes = [
            MarkerShape::Circle,
            MarkerShape::Square,
            MarkerShape::Triangle,
            MarkerShape::Cross,
        ];
        let label = |g: &str| match &spec.series {
            Some(col) => format!(
                "{} = {}",
                short_name(col),
                g.parse::<f64>()
                    .map_or(g.to_string(), |v| format!("{v:.4}"))
            ),
            None => g.to_string(),
        };
        let mut series: Vec<Series> = groups
            .iter()
            .enumerate()
            .map(|(i, (g, x, y))| Series {
                label: label(g),
                x: x.clone(),
                y: y.clone(),
                style: Style::Markers(shapes[i % shapes.len()]),
                stable: None,
                err: None,
            })
            .collect();
        let all_x: Vec<f64> = groups.iter().flat_map(|g| g.1.iter().copied()).collect();
        let all_y: Vec<f64> = groups.iter().flat_map(|g| g.2.iter().copied()).collect();
        let (lo, hi) = all_x
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        let curve = |f: &dyn Fn(f64) -> f64, from: f64| -> (Vec<f64>, Vec<f64>) {
            let xs: Vec<f64> = (0..=60)
                .map(|i| {
                    let t = i as f64 / 60.0;
                    if spec.log_x {
                        from * (hi / from).powf(t)
                    } else {
                        from + (hi - from) * t
                    }
                })
                .collect();
            let ys = xs.iter().map(|x| f(*x)).collect();
            (xs, ys)
        };
        let mut annotation = None;
        let mut fit = None;
        match spec.fit {
            Some(FitKind::ThroughOrigin) => {
                let s = through_origin(&all_x, &all_y)?;
                let (x, y) = curve(&|x| s.slope * x, 0.0);
                series.push(dashed("fit through the origin", x, y));
                annotation = Some(format!(
                    "slope = {:.4e}\n95% CI [{:.4e}, {:.4e}]",
                    s.slope, s.slope_ci[0], s.slope_ci[1]
                ));
                fit = Some(Fitted::ThroughOrigin(s));
            }
            Some(FitKind::PowerLaw) => {
                let f = power_law(&all_x, &all_y)?;
                let (x, y) = curve(&|x| f.c * x.powf(f.p), lo);
                series.push(dashed("power-law fit", x, y));
                annotation = Some(format!(
                    "p = {:.4} [{:.4}, {:.4}] (95%)",
                    f.p, f.p_ci[0], f.p_ci[1]
                ));
                fit = Some(Fitted::PowerLaw(f));
            }
            Some(FitKind::CommonPowerLaw) => {
                let f = common_power_law(&groups)?;
                for (g, n) in &f.prefactors {
                    let (x, y) = curve(&|x| n * x.powf(f.p), lo);
                    series.push(dashed(&format!("fit, {}", label(g)), x, y));
                }
                let m = -f.p;
                let m_ci = [-f.p_ci[1], -f.p_ci[0]];
                annotation = Some(format!(
                    "m = {m:.4}, 95% CI [{:.4}, {:.4}]",
                    m_ci[0], m_ci[1]
                ));
                let local: Vec<_> = groups
                    .iter()
                    .map(|(_, x, y)| local_exponents(x, y))
                    .collect();
                let record = CommonExponent {
                    m,
                    m_ci,
                    x: spec.x.clone(),
                    y: spec.y.clone(),
                    series: spec.series.clone(),
                    n: f.n,
                    r2: f.r2,
                    prefactors: f.prefactors.clone(),
                    left_out: left_out.clone(),
                    per_series_m: f
                        .per_group
                        .iter()
                        .map(|(g, p, ci)| SeriesExponent {
                            series: g.clone(),
                            m: -p,
                            m_ci: [-ci[1], -ci[0]],
                        })
                        .collect(),
                    local_m: groups
                        .iter()
                        .zip(&local)
                        .map(|((g, _, _), l)| LocalExponents {
                            series: g.clone(),
                            intervals: l
                                .iter()
                                .map(|l| LocalInterval {
                                    x_lo: l.x_lo,
                                    x_hi: l.x_hi,
                                    x_mid: l.x_mid,
                                    m_loc: -l.p,
                                })
                                .collect(),
                        })
                        .collect(),
                };
                let local_series: Vec<Series> = groups
                    .iter()
                    .zip(&local)
                    .enumerate()
                    .map(|(i, ((g, _, _), l))| Series {
                        label: label(g),
                        x: l.iter().map(|l| l.x_mid).collect(),
                        y: l.iter().map(|l| -l.p).collect(),
                        style: Style::Markers(shapes[i % shapes.len()]),
                        stable: None,
                        err: None,
                    })
                    .chain(std::iter::once({
                        let (x, _) = curve(&|x| x, lo);
                        let y = vec![m; x.len()];
                        dashed(&format!("common fit, m = {m:.3}"), x, y)
                    }))
                    .collect();
                write_figure(
                    &Figure {
                        title: format!(
                            "{}: local exponent -d ln {} / d ln {}",
                            study.name,
                            short_name(&spec.y),
                            short_name(&spec.x)
                        ),
                        x_label: axis_label(&spec.x),
                        y_label: "m_loc (-)".into(),
                        x_scale: scale(spec.log_x),
                        series: local_series,
                        ..Figure::default()
                    },
                    &dir.join(format!("local_m_{k}.svg")),
                )?;
                write_json(&dir.join("fit.json"), &record)?;
                // The collapse: y / N_k against x falls on one curve if the form is separable.
                let collapsed: Vec<Series> = groups
                    .iter()
                    .zip(&f.prefactors)
                    .enumerate()
                    .map(|(i, ((g, x, y), (_, n)))| Series {
                        label: label(g),
                        x: x.clone(),
                        y: y.iter().map(|v| v / n).collect(),
                        style: Style::Markers(shapes[i % shapes.len()]),
                        stable: None,
                        err: None,
                    })
                    .chain(std::iter::once({
                        let (x, y) = curve(&|x| x.powf(f.p), lo);
                        dashed(&format!("x^(-m), m = {m:.3}"), x, y)
                    }))
                    .collect();
                write_figure(
                    &Figure {
                        title: format!("{}: collapse {} / N", study.name, short_name(&spec.y)),
                        x_label: axis_label(&spec.x),
                        y_label: format!(
                            "{} / N({}) (-)",
                            short_name(&spec.y),
                            short_name(spec.series.as_deref().unwrap_or("case"))
                        ),
                        x_scale: scale(spec.log_x),
                        y_scale: scale(spec.log_y),
                        series: collapsed,
                        annotation: annotation.clone(),
                        ..Figure::default()
                    },
                    &dir.join(format!("collapse_{k}.svg")),
                )?;
                fit = Some(Fitted::CommonPowerLaw(record));
            }
            None => {}
        }
        if let Some(fit) = fit {
            fits.push(SweepFit {
                figure: k,
                fit,
                left_out,
            });
        }
        write_figure(
            &Figure {
                title: format!(
                    "{}: {} against {}",
                    study.name,
                    short_name(&spec.y),
                    short_name(&spec.x)
                ),
                x_label: axis_label(&spec.x),
                y_label: axis_label(&spec.y),
                x_scale: scale(spec.log_x),
                y_scale: scale(spec.log_y),
                series,
                markers: Vec::new(),
                annotation,
            },
            &dir.join(format!("sweep_{k}.svg")),
        )?;
    }
    Ok(Some(fits))
}

fn dashed(label: &str, x: Vec<f64>, y: Vec<f64>) -> Series {
    Series {
        label: label.to_string(),
        x,
        y,
        style: Style::Dashed,
        stable: None,
        err: None,
    }
}

fn scale(log: bool) -> Scale {
    if log { Scale::Log } else { Scale::Linear }
}

/// An axis label with its unit, for the columns of `sweep.csv`.
fn axis_label(column: &str) -> String {
    let unit = match column {
        "omega_b" | "im" => "rad/s",
        "EI" => "N m^2",
        "E_r0_4_over_mu_l_4" => "1/s",
        "rod.E" => "Pa",
        "rod.r0" | "shape.l" | "shape.lambda" | "shape.R" | "shape.L" => "m",
        "fluid.mu" => "Pa s",
        _ => "-",
    };
    format!("{} ({unit})", short_name(column))
}

/// The readable name of a column of `sweep.csv`.
fn short_name(column: &str) -> &str {
    match column {
        "E_r0_4_over_mu_l_4" => "E r0^4/(mu l^4)",
        "lambda_over_l" | "shape.lambda_over_l" => "lambda/l",
        "R_over_lambda" | "shape.R_over_lambda" => "R/lambda",
        other => other,
    }
}
