//! `helixbif run STUDY`: does what the study's `[study]` table declares and writes
//! `output/<study name>/` (CSV, `meta.json`, SVG figures).

use std::path::Path;

use serde::Serialize;

use super::boundary::{BoundaryStudy, Curves, run_study as run_boundaries};
use super::branch::{BranchEvent, BranchReport, run_branch};
use super::dynamics::AverageRow;
use super::figures::{self, DrawnBranch, SweepFit};
use super::locate::{LocateResult, Resolution, locate_study};
use super::orbits::{OrbitsOptions, OrbitsReport};
use super::output::{Meta, Provenance, create_dir, write_json};
use super::phase::PhaseResult;
use super::plan::{
    CARRY_SPACING, POINT_REFINEMENT, Plan, check_refinement_room, point_accuracy,
    with_carry_spacing,
};
use super::shapes::ShapesResult;
use super::sweep::{SweepSummary, cases, run_sweep, variant};
use super::{Study, sweep_figures};
use crate::analysis::refine::{DEFAULT_ACCURACY, DEFAULT_MAX_NODES};
use crate::engine::periodic::branch::OrbitStop;
use crate::model::Model;
use crate::model::params::ShapeParams;
use crate::{Error, Result};

/// What a study run found, by the study's kind (its JSON: `kind` and the kind's own fields).
#[derive(Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum StudyResult {
    Branch {
        cases: Vec<BranchCase>,
    },
    Locate {
        result: LocateResult,
    },
    Sweep {
        summary: SweepSummary,
        fits: Option<Vec<SweepFit>>,
    },
    Phase(PhaseResult),
    Boundary(BoundaryStudy),
    Shapes(ShapesResult),
    Dynamics {
        rows: Vec<AverageRow>,
    },
    Orbits {
        report: OrbitsReport,
        options: OrbitsOptions,
    },
}

impl StudyResult {
    /// The table the run wrote at the top of its folder: the kind's main CSV file (`sweep.csv`,
    /// ...); `None` for `locate` (its result is `locate.json`) and for a branch or boundary study
    /// of several cases, whose tables are in their cases' subfolders.
    pub fn table(&self) -> Option<&'static str> {
        match self {
            StudyResult::Branch { cases } => (cases.len() == 1).then_some("branch.csv"),
            StudyResult::Locate { .. } => None,
            StudyResult::Sweep { .. } => Some("sweep.csv"),
            StudyResult::Phase(_) => Some("phase.csv"),
            StudyResult::Boundary(b) => (b.curves.len() == 1).then_some("boundary.csv"),
            StudyResult::Shapes(_) => Some("shapes.csv"),
            StudyResult::Dynamics { .. } => Some("dynamics.csv"),
            StudyResult::Orbits { .. } => Some("orbits.csv"),
        }
    }
}

/// One case of a branch study: its label, its report and its events.
#[derive(Serialize)]
pub struct BranchCase {
    pub case: String,
    pub report: BranchReport,
    pub events: Vec<BranchEvent>,
}

/// A folder-friendly form of a case label.
pub(crate) fn slug(label: &str) -> String {
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

/// The [`Resolution`] a `locate` plan asks for.
fn resolution(plan: &Plan) -> Resolution {
    match plan {
        Plan::Locate {
            extrapolate: true,
            nodes,
            ..
        } => Resolution::Ladder(nodes.clone()),
        // A study that fixes N keeps it, with its estimated discretization error.
        Plan::Locate {
            fixed_nodes: true, ..
        } => Resolution::Fixed,
        Plan::Locate {
            accuracy,
            max_nodes,
            ..
        } => Resolution::Refine {
            accuracy: accuracy.unwrap_or(DEFAULT_ACCURACY),
            max_nodes: max_nodes.unwrap_or(DEFAULT_MAX_NODES),
        },
        _ => Resolution::Fixed,
    }
}

/// Runs the study into `dir`. A branch that stalls or a sweep point that fails makes it a
/// numerical failure, after every result and figure is written. With `resume`, the long kinds
/// (`dynamics`, `orbits`) continue from their checkpoints in `dir` (finished simulations are
/// read back, not run again), a `boundary` study reads back the curves an earlier run finished
/// (and follows the others); the others run afresh. `provenance` goes into `meta.json`.
pub fn run(
    study: &Study,
    dir: &Path,
    resume: bool,
    provenance: &Provenance,
) -> Result<StudyResult> {
    let (result, failures) = run_parts(study, dir, resume, provenance)?;
    match incomplete(study, &failures, dir) {
        Some(error) => Err(error),
        None => Ok(result),
    }
}

/// The numerical failure of a study that did not complete (`failures`: what did not), naming
/// the folder that holds what was computed; `None` where nothing failed.
pub fn incomplete(study: &Study, failures: &[String], dir: &Path) -> Option<Error> {
    (!failures.is_empty()).then(|| {
        Error::Numerical(format!(
            "study `{}` incomplete ({}); what was computed is in {}",
            study.name,
            failures.join("; "),
            dir.display()
        ))
    })
}

/// [`run`], returning the study's result with what did not complete (empty where everything
/// did) instead of failing on it: every result, figure and `meta.json` are written either way.
/// For a front end that hands back the result of an incomplete study with its failure.
pub fn run_parts(
    study: &Study,
    dir: &Path,
    resume: bool,
    provenance: &Provenance,
) -> Result<(StudyResult, Vec<String>)> {
    let plan = study.study.clone().unwrap_or(Plan::Locate {
        extrapolate: false,
        fixed_nodes: false,
        nodes: Vec::new(),
        accuracy: None,
        max_nodes: None,
    });
    if let Resolution::Refine { max_nodes, .. } = resolution(&plan) {
        check_refinement_room("study.max_nodes", max_nodes, &study.physical())?;
    }
    create_dir(dir)?;
    // What did not complete; reported as a numerical failure once everything is written.
    let mut failures: Vec<String> = Vec::new();
    let result = match &plan {
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
                let (report, t) = run_branch(&s, &model, s.branch.omega_max, &sub, provenance)?;
                if report.stalled {
                    failures.push(format!("{}: {}", case.label, report.stop));
                }
                summaries.push(BranchCase {
                    case: case.label.clone(),
                    events: t.events.iter().map(BranchEvent::of).collect(),
                    report,
                });
                tables.push((
                    case.label.clone(),
                    matches!(s.shape, ShapeParams::Helix { .. }),
                    t,
                ));
            }
            let fig_cases: Vec<DrawnBranch> = tables
                .iter()
                .map(|(label, rigid, t)| DrawnBranch {
                    label,
                    tables: t,
                    rigid: *rigid,
                })
                .collect();
            figures::branch_figures(dir, &fig_cases)?;
            StudyResult::Branch { cases: summaries }
        }
        Plan::Locate { .. } => {
            let result = locate_study(study, &resolution(&plan))?;
            write_json(&dir.join("locate.json"), &result)?;
            failures.extend(result.shortfall());
            StudyResult::Locate { result }
        }
        Plan::Sweep { .. } => {
            let summary = run_sweep(study, dir, None)?;
            if summary.failed > 0 {
                failures.push(format!(
                    "{} sweep points failed (status column of {})",
                    summary.failed, summary.file
                ));
            }
            failures.extend(summary.shortfall());
            let fits = sweep_figures(study, dir)?;
            StudyResult::Sweep { summary, fits }
        }
        Plan::Phase { .. } => {
            let phase = super::phase::run_phase(study, dir, provenance)?;
            failures.extend(phase.shortfall());
            StudyResult::Phase(phase)
        }
        Plan::Boundary {
            vary,
            from,
            to,
            cases: plan_cases,
            fit,
            accuracy,
            max_nodes,
            carry_spacing,
        } => {
            let curves = Curves {
                key: vary,
                from: *from,
                to: *to,
                accuracy: with_carry_spacing(
                    point_accuracy(*accuracy, *max_nodes, POINT_REFINEMENT)?,
                    *carry_spacing,
                    (*from, *to),
                    CARRY_SPACING,
                )?,
            };
            let (value, failed) = run_boundaries(
                study,
                &curves,
                &cases(plan_cases),
                (*fit, resume),
                dir,
                provenance,
            )?;
            failures.extend(failed);
            StudyResult::Boundary(value)
        }
        Plan::Shapes { .. } => StudyResult::Shapes(super::shapes::run_shapes(study, dir)?),
        Plan::Dynamics { .. } => {
            let (rows, failed) = super::dynamics::run_dynamics(study, dir, resume, provenance)?;
            if failed > 0 {
                failures.push(format!(
                    "{failed} simulations failed (status column of dynamics.csv)"
                ));
            }
            StudyResult::Dynamics { rows }
        }
        Plan::Orbits(orbits) => {
            let model = Model::new(&study.physical())?;
            let options = OrbitsOptions {
                resume,
                ..OrbitsOptions::of_plan(orbits, study.branch.omega_max)
            };
            let report = super::orbits::run_orbits(study, &model, &options, dir, provenance)?;
            if let OrbitStop::StepTooSmall(reason) = &report.stop {
                failures.push(format!("the orbit branch stalled: {reason}"));
            }
            StudyResult::Orbits { report, options }
        }
    };
    let model = Model::new(&study.physical())?;
    // The run's record in meta.json has its keys in alphabetical order, as every JSON file.
    let record = serde_json::to_value(&result).map_err(|e| Error::Numerical(e.to_string()))?;
    Meta::new(study, model.scales, &record, provenance).write(&dir.join("meta.json"))?;
    Ok((result, failures))
}
