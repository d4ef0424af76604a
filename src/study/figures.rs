//! The figures of a traced branch: `hbar`, `Fpbar` (with the rigid-helix line), the efficiency
//! `eta`, and the leading `Re(s)` against `omega`; stable parts solid, unstable dashed, events
//! marked and named. Several branches (cases) share each figure.

use std::path::{Path, PathBuf};

use crate::Result;
use crate::plot::{Figure, Marker, Series, Style, write_figure};
use crate::study::runs::BranchTables;

/// One branch and its legend label.
pub struct Case<'a> {
    pub label: &'a str,
    pub tables: &'a BranchTables,
    /// Draw the rigid-helix thrust line (helices only).
    pub rigid: bool,
}

fn line(
    label: &str,
    t: &BranchTables,
    y: impl Fn(&crate::study::runs::BranchRow) -> f64,
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

fn events(cases: &[Case], y: impl Fn(&crate::study::runs::EventRow) -> f64) -> Vec<Marker> {
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
pub fn branch_figures(dir: &Path, title: &str, cases: &[Case]) -> Result<Vec<PathBuf>> {
    let label = |c: &Case| {
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
