//! `helixbif run STUDY`: does what the study's `[study]` table declares and writes
//! `output/<study name>/` (CSV, `meta.json`, SVG figures).

use std::path::Path;

use serde_json::{Value, json};

use super::figures::{self, Case as FigureCase};
use super::orbits::OrbitsOptions;
use super::plan::Plan;
use super::runs::{
    DEFAULT_MAX_NODES, default_ladder, run_branch, run_ladder, run_locate, run_refinement,
};
use super::sweep::{cases, run_sweep, variant};
use super::{Study, sweep_figures};
use crate::engine::periodic::branch::OrbitStop;
use crate::model::Model;
use crate::model::params::ShapeParams;
use crate::study::output::{Meta, create_dir};
use crate::{Error, Result};

/// A folder-friendly form of a case label.
pub fn slug(label: &str) -> String {
    let s: String = label
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect();
    s.split('_')
        .filter(|part| !part.is_empty())
        .collect::<Vec<_>>()
        .join("_")
}

/// Runs the study into `dir`; returns a summary for the terminal. A branch that stalls or a sweep
/// point that fails makes it a numerical failure, after every result and figure is written.
/// With `resume`, the long kinds (`dynamics`, `orbits`) continue from their checkpoints in
/// `dir` (finished simulations are read back, not run again); the others run afresh.
pub fn run(study: &Study, dir: &Path, resume: bool) -> Result<Value> {
    create_dir(dir)?;
    let plan = study.study.clone().unwrap_or(Plan::Locate {
        extrapolate: false,
        nodes: Vec::new(),
        accuracy: None,
        max_nodes: None,
    });
    // What did not complete; reported as a numerical failure once everything is written.
    let mut failures: Vec<String> = Vec::new();
    let report = match &plan {
        Plan::Branch { cases: plan_cases } => {
            let cases = cases(plan_cases);
            let mut tables = Vec::new();
            let mut summaries = Vec::new();
            for case in &cases {
                let s = variant(study, case, &[], &[])?;
                let model = Model::new(&s.physical())?;
                let sub = if cases.len() == 1 {
                    dir.to_path_buf()
                } else {
                    dir.join(slug(&case.label))
                };
                let (report, t) = run_branch(&s, &model, s.branch.omega_max, &sub)?;
                summaries.push(json!({ "case": case.label, "report": report, "events": t.events.iter().map(|e| json!({"kind": e.kind, "omega": e.omega, "im": e.im})).collect::<Vec<_>>() }));
                tables.push((
                    case.label.clone(),
                    matches!(s.shape, ShapeParams::Helix { .. }),
                    t,
                ));
            }
            let fig_cases: Vec<FigureCase> = tables
                .iter()
                .map(|(label, rigid, t)| FigureCase {
                    label,
                    tables: t,
                    rigid: *rigid,
                })
                .collect();
            figures::branch_figures(dir, &study.name, &fig_cases)?;
            let stalled: Vec<String> = summaries
                .iter()
                .filter(|c| c["report"]["stalled"] == true)
                .map(|c| format!("{}: {}", c["case"], c["report"]["stop"]))
                .collect();
            failures.extend(stalled);
            json!({ "kind": "branch", "cases": summaries })
        }
        Plan::Locate {
            extrapolate,
            nodes,
            accuracy,
            max_nodes,
        } => {
            let value = if *extrapolate {
                let ladder = if nodes.is_empty() {
                    default_ladder(study)
                } else {
                    nodes.clone()
                };
                serde_json::to_value(run_ladder(study, &ladder)?)
            } else if let Some(eps) = accuracy {
                let max = max_nodes.unwrap_or(DEFAULT_MAX_NODES);
                serde_json::to_value(run_refinement(study, *eps, max)?)
            } else {
                let model = Model::new(&study.physical())?;
                serde_json::to_value(run_locate(study, &model)?)
            }
            .map_err(|e| Error::Numerical(e.to_string()))?;
            let path = dir.join("locate.json");
            std::fs::write(&path, format!("{value:#}\n"))
                .map_err(crate::study::output::io_error(&path))?;
            json!({ "kind": "locate", "result": value })
        }
        Plan::Sweep { .. } => {
            let summary = run_sweep(study, dir, None)?;
            if summary.failed > 0 {
                failures.push(format!(
                    "{} sweep points failed (status column of {})",
                    summary.failed, summary.file
                ));
            }
            let fits = sweep_figures(study, dir)?;
            json!({ "kind": "sweep", "summary": summary, "fits": fits })
        }
        Plan::Phase { .. } => super::phase::run_phase(study, dir)?,
        Plan::Boundary {
            vary,
            from,
            to,
            cases: plan_cases,
            fit,
        } => {
            let (value, failed) = super::boundary::run_study(
                study,
                vary,
                (*from, *to),
                &cases(plan_cases),
                *fit,
                dir,
            )?;
            failures.extend(failed);
            value
        }
        Plan::Shapes { .. } => super::shapes::run_shapes(study, dir)?,
        Plan::Dynamics { .. } => {
            let (rows, failed) = super::simulate::run_dynamics(study, dir, resume)?;
            if failed > 0 {
                failures.push(format!(
                    "{failed} simulations failed (status column of dynamics.csv)"
                ));
            }
            json!({ "kind": "dynamics", "rows": rows })
        }
        Plan::Orbits(orbits) => {
            let model = Model::new(&study.physical())?;
            let opts = OrbitsOptions {
                resume,
                ..OrbitsOptions::of_plan(orbits, study.branch.omega_max)
            };
            let report = super::orbits::run_orbits(study, &model, &opts, dir)?;
            if let OrbitStop::StepTooSmall(reason) = &report.stop {
                failures.push(format!("the orbit branch stalled: {reason}"));
            }
            json!({ "kind": "orbits", "report": report, "options": opts })
        }
    };
    let model = Model::new(&study.physical())?;
    Meta::new(study, model.scales, &report).write(&dir.join("meta.json"))?;
    if !failures.is_empty() {
        return Err(Error::Numerical(format!(
            "study `{}` incomplete ({}); what was computed is in {}",
            study.name,
            failures.join("; "),
            dir.display()
        )));
    }
    Ok(report)
}
