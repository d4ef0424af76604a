//! The figures of a traced branch: `hbar`, `Fpbar` (with the rigid-helix line), the efficiency
//! `eta`, and the leading `Re(s)` against `omega`; stable parts solid, unstable dashed, events
//! marked and named. Several branches (cases) share each figure.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::Result;
use crate::model::fluid::FluidModel;
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

/// Writes `hbar.svg`, `Fpbar.svg`, `eta.svg` and `max_re.svg` into `dir` (each with its PNG);
/// returns the SVGs' paths.
pub(crate) fn branch_figures(dir: &Path, cases: &[DrawnBranch]) -> Result<Vec<PathBuf>> {
    let label = |c: &DrawnBranch| {
        if cases.len() == 1 {
            String::from("steady branch")
        } else {
            typeset(c.label)
        }
    };
    let x_label = OMEGA_LABEL.to_string();
    let mut written = Vec::new();

    let hbar = Figure {
        title: "Suspended height of the steady rod".into(),
        x_label: x_label.clone(),
        y_label: HBAR_LABEL.into(),
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
            format!("{} (rigid)", typeset(c.label))
        };
        thrust_series.push(Series {
            style: Style::Dashed,
            stable: None,
            ..line(&name, c.tables, |r| r.fpbar_rigid)
        });
    }
    let thrust = Figure {
        title: "Propulsive force of the steady rod".into(),
        x_label: x_label.clone(),
        y_label: FPBAR_LABEL.into(),
        series: thrust_series,
        markers: events(cases, |e| e.fpbar),
        ..Figure::default()
    };
    let eta = Figure {
        title: "Efficiency of the steady rod".into(),
        x_label: x_label.clone(),
        y_label: ETA_LABEL.into(),
        series: cases
            .iter()
            .map(|c| line(&label(c), c.tables, |r| r.eta.unwrap_or(f64::NAN)))
            .collect(),
        ..Figure::default()
    };
    let re = Figure {
        title: "Leading eigenvalue of the steady rod".into(),
        x_label,
        y_label: MAX_RE_LABEL.into(),
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

/// The estimated discretization error of the value `y` of column `column` at row `r` of a
/// sweep table: `omega_b_error` for `omega_b`, the same relative error for `omegabar_b`
/// (`omegabar_b` is `omega_b` times a constant of the point); `None` for another column, or
/// where the table has no error there.
fn discretization_error_of(table: &Table, r: usize, column: &str, y: f64) -> Option<f64> {
    let error = table.number(r, table.index("omega_b_error").ok()?)?;
    match column {
        "omega_b" => Some(error),
        "omegabar_b" => {
            let omega_b = table.number(r, table.index("omega_b").ok()?)?;
            Some(error / omega_b.abs() * y.abs())
        }
        _ => None,
    }
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
        // Groups in order of first appearance, with each point's discretization error where
        // the y column is omega_b or omegabar_b.
        let mut groups: Vec<(String, Vec<f64>, Vec<f64>)> = Vec::new();
        let mut errors: Vec<Vec<Option<f64>>> = Vec::new();
        for (r, x, y) in kept {
            let g = table.text(r, sc).to_string();
            let e = discretization_error_of(&table, r, &spec.y, y);
            match groups.iter().position(|entry| entry.0 == g) {
                Some(i) => {
                    groups[i].1.push(x);
                    groups[i].2.push(y);
                    errors[i].push(e);
                }
                None => {
                    groups.push((g, vec![x], vec![y]));
                    errors.push(vec![e]);
                }
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
                    .map_or(typeset(g), |v| minus(&v.to_string()))
            ),
            None => typeset(g),
        };
        let mut series: Vec<Series> = groups
            .iter()
            .zip(&errors)
            .enumerate()
            .map(|(i, ((g, x, y), e))| Series {
                label: label(g),
                x: x.clone(),
                y: y.clone(),
                style: Style::Markers(shapes[i % shapes.len()]),
                stable: None,
                // A point without an error (none estimated, or an older sweep.csv) has no bar.
                err: e
                    .iter()
                    .any(Option::is_some)
                    .then(|| e.iter().map(|e| e.unwrap_or(f64::NAN)).collect()),
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
                    "slope = {}\n95 % CI [{}, {}]",
                    sci(s.slope),
                    sci(s.slope_ci[0]),
                    sci(s.slope_ci[1])
                ));
                fit = Some(Fitted::ThroughOrigin(s));
            }
            Some(FitKind::PowerLaw) => {
                let f = power_law(&all_x, &all_y)?;
                let (x, y) = curve(&|x| f.c * x.powf(f.p), lo);
                series.push(dashed("power-law fit", x, y));
                annotation = Some(format!(
                    "p = {}, 95 % CI [{}, {}]",
                    minus(&format!("{:.4}", f.p)),
                    minus(&format!("{:.4}", f.p_ci[0])),
                    minus(&format!("{:.4}", f.p_ci[1]))
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
                    "m = {m:.3}, 95 % CI [{:.3}, {:.3}]",
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
                            "Local exponent −d ln {} / d ln {}",
                            short_name(&spec.y),
                            short_name(&spec.x)
                        ),
                        x_label: axis_label(&spec.x),
                        y_label: "m_loc (–)".into(),
                        x_scale: scale(spec.log_x),
                        series: local_series,
                        ..Figure::default()
                    },
                    &dir.join(format!("local_m_{k}.svg")),
                )?;
                write_json(&dir.join("fit.json"), &record)?;
                // The collapse: y / C_k against x falls on one curve if the form is separable
                // (C_k the fitted prefactor of series k; not N, which is the node count).
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
                        dashed(&format!("({})⁻ᵐ, m = {m:.3}", short_name(&spec.x)), x, y)
                    }))
                    .collect();
                write_figure(
                    &Figure {
                        title: format!(
                            "Collapse of {} on one power law of {}",
                            short_name(&spec.y),
                            short_name(&spec.x)
                        ),
                        x_label: axis_label(&spec.x),
                        y_label: format!(
                            "{} / C({}) (–)",
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
        // The title says what the bars are and how large they are relative to the values
        // (bars of a tenth of a per cent hide under the markers).
        let relative: Vec<f64> = series
            .iter()
            .filter_map(|s| Some(s.err.as_ref()?.iter().zip(&s.y).map(|(e, y)| e / y.abs())))
            .flatten()
            .filter(|r| r.is_finite())
            .collect();
        // `omega_b_error` of a refinement: on the RPY line the error in `N` plus the size of
        // the quadrature's own error (docs/model.md section 10).
        let what = match study.fluid.model {
            FluidModel::Rpy => "estimated error, discretization and quadrature",
            FluidModel::Lighthill => "estimated discretization error",
        };
        let bars = error_range("bars", what, &relative);
        write_figure(
            &Figure {
                title: format!(
                    "{} against {}{bars}",
                    short_name(&spec.y),
                    short_name(&spec.x)
                ),
                x_label: axis_label(&spec.x),
                y_label: axis_label(&spec.y),
                x_scale: scale(spec.log_x),
                y_scale: scale(spec.log_y),
                series,
                annotation,
                ..Figure::default()
            },
            &dir.join(format!("sweep_{k}.svg")),
        )?;
    }
    Ok(Some(fits))
}

/// What the error bars (or band: `drawn`) of a figure show (`what`) and their range, for its
/// title: ` (bars: estimated discretization error, 0.05 to 0.2 %)` over the finite `relative`
/// errors; empty where there are none.
pub(crate) fn error_range(drawn: &str, what: &str, relative: &[f64]) -> String {
    finite_range(relative).map_or(String::new(), |(lo, hi)| {
        format!(" ({drawn}: {what}, {} to {} %)", percent(lo), percent(hi))
    })
}

/// As [`error_range`], for errors in the units of the quantity drawn (two significant digits):
/// ` (band: its error, 0.0012 to 0.35)`.
pub(crate) fn absolute_error_range(drawn: &str, what: &str, errors: &[f64]) -> String {
    finite_range(errors).map_or(String::new(), |(lo, hi)| {
        format!(
            " ({drawn}: {what}, {} to {})",
            significant(lo),
            significant(hi)
        )
    })
}

/// The smallest and largest finite `values`; `None` where there are none.
fn finite_range(values: &[f64]) -> Option<(f64, f64)> {
    let mut finite = values.iter().copied().filter(|r| r.is_finite());
    let first = finite.next()?;
    Some(finite.fold((first, first), |(lo, hi), r| (lo.min(r), hi.max(r))))
}

/// A number with two significant digits, without an exponent (`0.0012`, `3.5`, `120`).
fn significant(x: f64) -> String {
    let decimals = (1.0 - x.abs().log10().floor()).clamp(0.0, 6.0) as usize;
    format!("{x:.decimals$}")
}

/// A fraction as a percentage with two significant digits (`0.0012` -> `0.12`).
fn percent(fraction: f64) -> String {
    significant(100.0 * fraction)
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

/// An axis label with its unit, for the columns of `sweep.csv` and the keys of a study.
pub(crate) fn axis_label(column: &str) -> String {
    let unit = match column {
        "omega_b" | "im" => "rad/s",
        "EI" => "N m²",
        "E_r0_4_over_mu_l_4" => "1/s",
        "rod.E" => "Pa",
        "rod.r0" | "shape.l" | "shape.lambda" | "shape.R" | "shape.L" => "m",
        "fluid.mu" => "Pa s",
        _ => "–",
    };
    format!("{} ({unit})", short_name(column))
}

/// The readable name of a column of `sweep.csv` or a key of a study, in the figures' Unicode
/// math.
pub(crate) fn short_name(column: &str) -> String {
    match column {
        "E_r0_4_over_mu_l_4" => "E r₀⁴/(μ ℓ⁴)".into(),
        "lambda_over_l" | "shape.lambda_over_l" => "λ/ℓ".into(),
        "R_over_lambda" | "shape.R_over_lambda" => "R/λ".into(),
        "omegabar_b" => "ω̄_b".into(),
        "omega_b" => "ω_b".into(),
        "rod.r0" => "r₀".into(),
        "fluid.mu" => "μ".into(),
        "shape.lambda" => "λ".into(),
        "shape.l" => "ℓ".into(),
        "im" => "Im s".into(),
        other => typeset(other),
    }
}

/// The axis label of the rotation rate.
pub(crate) const OMEGA_LABEL: &str = "ω (rad/s)";
/// The axis labels of the observables, each with the formula the code computes
/// (`model::observables`): the suspended height, the propulsive force, the efficiency.
pub(crate) const HBAR_LABEL: &str = "h̄ = h/h₀ (–)";
pub(crate) const FPBAR_LABEL: &str = "F̄ₚ = Fₚℓ²/EI (–)";
pub(crate) const ETA_LABEL: &str = "η = Fₚℓ/Tₚ (–)";
pub(crate) const MAX_RE_LABEL: &str = "max Re s (1/s)";

/// `label` (a case's label, a column's name) with the ASCII names of the quantities written as
/// the figures write them: `lambda/l` as λ/ℓ, `omega` as ω, `omegabar` as ω̄, `mu` as μ, `+-` as
/// ±, a hyphen before a digit as a minus sign. Whole words only, so `lambda_l_0_125` or a file
/// name stays as it is.
pub(crate) fn typeset(label: &str) -> String {
    let words: [(&str, &str); 9] = [
        ("lambda/l", "λ/ℓ"),
        ("R/lambda", "R/λ"),
        ("omegabar_b", "ω̄_b"),
        ("omegabar", "ω̄"),
        ("omega_b", "ω_b"),
        ("omega", "ω"),
        ("lambda", "λ"),
        ("mu", "μ"),
        ("eta", "η"),
    ];
    let is_word = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut out = String::new();
    let mut rest = label;
    'outer: while let Some(c) = rest.chars().next() {
        let at_start = out.chars().last().is_none_or(|p| !is_word(p));
        if at_start {
            for (ascii, math) in words {
                if let Some(after) = rest.strip_prefix(ascii)
                    && !after.chars().next().is_some_and(is_word)
                {
                    out.push_str(math);
                    rest = after;
                    continue 'outer;
                }
            }
        }
        if let Some(after) = rest.strip_prefix("+-") {
            out.push('±');
            rest = after;
            continue;
        }
        if c == '-' && at_start && rest[1..].starts_with(|d: char| d.is_ascii_digit()) {
            out.push('−');
        } else {
            out.push(c);
        }
        rest = &rest[c.len_utf8()..];
    }
    out
}

/// A number in scientific notation as the axes write it: "1.234×10⁻³".
fn sci(v: f64) -> String {
    let s = format!("{v:.4e}");
    let Some((mantissa, exp)) = s.split_once('e') else {
        return s;
    };
    let sup: String = exp
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            d => "⁰¹²³⁴⁵⁶⁷⁸⁹"
                .chars()
                .nth(d.to_digit(10).unwrap_or(0) as usize)
                .unwrap_or(d),
        })
        .collect();
    minus(&format!("{mantissa}×10{sup}"))
}

/// `s` with hyphen-minus signs as real minus signs.
fn minus(s: &str) -> String {
    s.replace('-', "−")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_are_typeset_in_whole_words() {
        assert_eq!(typeset("lambda/l = 0.125"), "λ/ℓ = 0.125");
        assert_eq!(typeset("omega = -0.5 rad/s"), "ω = −0.5 rad/s");
        assert_eq!(typeset("lambda_l_0_125"), "lambda_l_0_125");
        assert_eq!(typeset("mean +- std"), "mean ± std");
        assert_eq!(typeset("sometimes"), "sometimes");
        assert_eq!(sci(-1.5e-3), "−1.5000×10⁻³");
    }
}
