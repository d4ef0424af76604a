//! `kind = "shapes"`: steady shapes at a few rates seen from two orthogonal sides (as two cameras
//! would see them), and the critical eigenmode at `omega_b`.

use std::path::Path;

use faer::c64;
use nalgebra::Vector3;
use serde::Serialize;

use super::Study;
use super::plan::Plan;
use crate::analysis::locate::{Loss, locate};
use crate::analysis::solve::solve_at;
use crate::engine::stability::mode;
use crate::engine::stop::Silent;
use crate::model::Model;
use crate::model::dofs::Layout;
use crate::plot::{Figure, Series, Style, write_panels};
use crate::study::figures::typeset;
use crate::study::output::CsvWriter;
use crate::{Error, Result};

/// One node of a shape in `shapes.csv` (SI).
#[derive(serde::Serialize)]
struct ShapeRow {
    omega: f64,
    i: usize,
    x: f64,
    y: f64,
    z: f64,
}

/// One node of the critical mode in `mode.csv`: the state at `omega_b` and the real and
/// imaginary parts of the mode's displacement (normalized to unit largest modulus).
#[derive(serde::Serialize)]
struct ModeRow {
    i: usize,
    x: f64,
    y: f64,
    z: f64,
    re_dx: f64,
    re_dy: f64,
    re_dz: f64,
    im_dx: f64,
    im_dy: f64,
    im_dz: f64,
}

/// Two side views (x–z and y–z, in cm, equal scales so the rod keeps its true proportions) of
/// a set of curves.
fn side_views(title: &str, curves: &[(String, Vec<Vector3<f64>>, Style)]) -> [Figure; 2] {
    let view = |name: &str, horizontal: usize, label: &str| Figure {
        title: format!("{title}, {name}"),
        equal_scale: true,
        x_label: format!("{label} (cm)"),
        y_label: "z (cm)".into(),
        series: curves
            .iter()
            .map(|(l, x, style)| Series {
                label: l.clone(),
                x: x.iter().map(|p| 100.0 * p[horizontal]).collect(),
                y: x.iter().map(|p| 100.0 * p.z).collect(),
                style: *style,
                stable: None,
                err: None,
            })
            .collect(),
        ..Figure::default()
    };
    // One legend for both views, on the second.
    [
        Figure {
            hide_legend: true,
            ..view("seen along y", 0, "x")
        },
        view("seen along x", 1, "y"),
    ]
}

/// An event's name as a title writes it: "Hopf point", "fold", "branch point".
fn event_in_words(name: &str) -> String {
    match name {
        "hopf" => "Hopf point".into(),
        other => other.replace('_', " "),
    }
}

/// Size of the two side views together: each panel taller than wide, as the rod hangs.
const SIDE_VIEWS_SIZE: (u32, u32) = (1000, 800);

/// Runs the study: `shapes.csv`, `mode.csv`, `shapes.svg`, `mode.svg`.
/// What the `shapes` study reports: the rates drawn and, where the branch loses stability, the
/// critical mode's rate, event and eigenvalue (1/s).
#[derive(Serialize)]
pub struct ShapesResult {
    pub omegas: Vec<f64>,
    #[serde(flatten)]
    pub critical: CriticalMode,
}

/// The critical mode of a shapes study, or `mode: null` where the branch stays stable.
#[derive(Serialize)]
#[serde(untagged)]
pub enum CriticalMode {
    None {
        mode: Option<()>,
    },
    Found {
        omega_b: f64,
        event: Loss,
        eigenvalue: [f64; 2],
    },
}

/// Runs the study: the steady shapes at its rates and the critical mode.
pub(crate) fn run_shapes(study: &Study, dir: &Path) -> Result<ShapesResult> {
    let Some(Plan::Shapes { omegas }) = &study.study else {
        return Err(Error::input("study.kind", "expected a shapes study"));
    };
    let model = Model::new(&study.physical())?;
    model.check_resolution()?;
    let ell = model.scales.length;
    let mut rows = CsvWriter::create(&dir.join("shapes.csv"))?;
    let mut curves = Vec::new();
    for &omega in omegas {
        let solution = solve_at(&model, model.scales.omega_to_bar(omega), &study.newton)?;
        let x: Vec<Vector3<f64>> = solution.state.config.x.iter().map(|p| p * ell).collect();
        for (i, p) in x.iter().enumerate() {
            rows.row(&ShapeRow {
                omega,
                i,
                x: p.x,
                y: p.y,
                z: p.z,
            })?;
        }
        curves.push((
            format!("ω = {} rad/s", typeset(&omega.to_string())),
            x,
            Style::Line,
        ));
    }
    write_panels(
        &side_views("Steady shapes", &curves),
        &dir.join("shapes.svg"),
        SIDE_VIEWS_SIZE,
    )?;

    // The critical mode at omega_b.
    let (located, critical) = locate(&model, &study.locate_settings(), &mut Silent)?;
    let Some(critical) = critical else {
        return Ok(ShapesResult {
            omegas: omegas.clone(),
            critical: CriticalMode::None { mode: None },
        });
    };
    let steady = critical.steady(&model);
    let event = &critical.event;
    let (k, m) = steady.stability_pair(&event.u)?;
    let (value, v) = mode(&k, &m, event.eigenvalue)?;
    let base = steady.config(&event.u).x;
    let displacement = |i: usize| -> (Vector3<f64>, Vector3<f64>) {
        if i < Layout::CLAMPED_NODES {
            return (Vector3::zeros(), Vector3::zeros());
        }
        let c = |k: usize| v[3 * (i - Layout::CLAMPED_NODES) + k];
        let d: [c64; 3] = [c(0), c(1), c(2)];
        (
            Vector3::new(d[0].re, d[1].re, d[2].re),
            Vector3::new(d[0].im, d[1].im, d[2].im),
        )
    };
    let mut mode_rows = CsvWriter::create(&dir.join("mode.csv"))?;
    for (i, p) in base.iter().enumerate() {
        let (re, im) = displacement(i);
        mode_rows.row(&ModeRow {
            i,
            x: p.x * ell,
            y: p.y * ell,
            z: p.z * ell,
            re_dx: re.x,
            re_dy: re.y,
            re_dz: re.z,
            im_dx: im.x,
            im_dy: im.y,
            im_dz: im.z,
        })?;
    }
    // Drawn with the largest displacement a tenth of the reference length.
    let amplitude = 0.1;
    let shifted = |sign: f64| -> Vec<Vector3<f64>> {
        base.iter()
            .enumerate()
            .map(|(i, p)| (p + displacement(i).0 * (sign * amplitude)) * ell)
            .collect()
    };
    let omega_b = located.omega_b.unwrap_or(f64::NAN);
    let mode_curves = vec![
        (
            format!("steady state at ω_b = {omega_b:.4} rad/s"),
            base.iter().map(|p| p * ell).collect(),
            Style::Line,
        ),
        (
            "plus the critical mode (real part)".to_string(),
            shifted(1.0),
            Style::Dashed,
        ),
        (
            "minus the critical mode (real part)".to_string(),
            shifted(-1.0),
            Style::Dashed,
        ),
    ];
    write_panels(
        &side_views(
            &format!(
                "Critical mode ({})",
                event_in_words(&located.kind.to_string())
            ),
            &mode_curves,
        ),
        &dir.join("mode.svg"),
        SIDE_VIEWS_SIZE,
    )?;
    Ok(ShapesResult {
        omegas: omegas.clone(),
        critical: CriticalMode::Found {
            omega_b,
            event: located.kind,
            eigenvalue: [value.re / model.scales.time, value.im / model.scales.time],
        },
    })
}
