//! What a study asks `helixbif run` to do: the `[study]` table of a study file.
//!
//! ```toml
//! [study]
//! kind = "sweep"                       # branch | locate | sweep | phase | boundary | shapes | dynamics
//! cases = [{ label = "E", set = {} }]  # variants of the base model (overrides by dotted key)
//! vary = [{ key = "rod.E", range = { from = 0.8e6, to = 2e6, count = 5, log = true } }]
//! ```

use serde::{Deserialize, Serialize};

use crate::analysis::boundary::PointAccuracy;
use crate::analysis::refine::DEFAULT_MAX_NODES;
use crate::model::params::Physical;
use crate::model::{Model, admissible_max_nodes};
use crate::{Error, Result};

/// A variant of the study's model: a label and overrides (dotted keys, TOML values).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    pub label: String,
    #[serde(default)]
    pub set: toml::Table,
    /// The model field that a swept `factor` multiplies in this case (e.g. `rod.E`), so that
    /// each case can vary a different parameter about the base model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<String>,
}

/// Evenly spaced values (geometrically when `log`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Range {
    pub from: f64,
    pub to: f64,
    pub count: usize,
    #[serde(default)]
    pub log: bool,
}

/// A swept parameter: a model field by its dotted key (`rod.E`, `shape.l`, ...), one of the
/// dimensionless ratios `shape.lambda_over_l` (the pitch set to this times `l`, `l` and `R`
/// fixed) and `shape.R_over_lambda` (the radius set to this times the pitch), or `factor`, which
/// multiplies the field named by each case's `scale`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Vary {
    pub key: String,
    #[serde(default)]
    pub values: Vec<f64>,
    #[serde(default)]
    pub range: Option<Range>,
}

impl Vary {
    /// The listed values, or those of the range.
    pub fn points(&self) -> Vec<f64> {
        match &self.range {
            Some(r) if r.count == 1 => vec![r.from],
            Some(r) => (0..r.count)
                .map(|i| {
                    let t = i as f64 / (r.count - 1) as f64;
                    if r.log {
                        r.from * (r.to / r.from).powf(t)
                    } else {
                        r.from + (r.to - r.from) * t
                    }
                })
                .collect(),
            None => self.values.clone(),
        }
    }
}

/// How the results of a sweep are drawn and fitted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepFigure {
    /// Columns of `sweep.csv` on the axes.
    pub x: String,
    pub y: String,
    #[serde(default)]
    pub log_x: bool,
    #[serde(default)]
    pub log_y: bool,
    /// Column whose values separate the series (default: `case`).
    #[serde(default)]
    pub series: Option<String>,
    /// `through_origin` (a line `y = k x`), `power_law` (`y = C x^p`) or `common_power_law`
    /// (one exponent shared by the series, each with its own prefactor: the separable form
    /// `y = M(x) N(series)`, whose exponent is written to `fit.json`).
    #[serde(default)]
    pub fit: Option<FitKind>,
}

/// A fit drawn on a sweep figure.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FitKind {
    ThroughOrigin,
    PowerLaw,
    CommonPowerLaw,
}

/// The `[study]` table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Plan {
    /// Branches from rest to `branch.omega_max`, one per case, drawn together.
    Branch {
        #[serde(default)]
        cases: Vec<Case>,
    },
    /// `omega_b` refined in `N` until its estimated error is below `accuracy` (default
    /// [`crate::analysis::refine::DEFAULT_ACCURACY`], as `helixbif locate`; up to `max_nodes`);
    /// with `fixed_nodes`, at the study's `N` with its discretization error estimated from a
    /// coarser rung; or over a ladder of node counts extrapolated with the known orders.
    Locate {
        #[serde(default)]
        extrapolate: bool,
        #[serde(default)]
        fixed_nodes: bool,
        #[serde(default)]
        nodes: Vec<usize>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        accuracy: Option<f64>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max_nodes: Option<usize>,
    },
    /// `omega_b` over the product of the cases and the values of one or two parameters: each
    /// point at its own `N` with its discretization error estimated from `N/2 + 1` nodes, or,
    /// with `accuracy`, refined by `locate` to that relative accuracy, up to `max_nodes`
    /// (default [`crate::analysis::refine::DEFAULT_MAX_NODES`]).
    Sweep {
        #[serde(default)]
        cases: Vec<Case>,
        vary: Vec<Vary>,
        #[serde(default)]
        figures: Vec<SweepFigure>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        accuracy: Option<f64>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max_nodes: Option<usize>,
    },
    /// The propulsive force over (`lambda/l`, `omegabar (R/lambda)^m`): a branch per value of
    /// `lambda/l`, the stability boundary, and natural flagella placed on it.
    Phase {
        lambda_over_l: Vec<f64>,
        /// Keep `R/lambda` at this value (the radius follows the pitch); absent: `R` fixed.
        #[serde(default, rename = "R_over_lambda")]
        r_over_lambda: Option<f64>,
        /// The exponent `m`; when absent, read from the `fit.json` of `exponent_study`.
        #[serde(default)]
        m: Option<f64>,
        /// The study that fits `m` (a path relative to this study file). Its `fit.json` is read
        /// from beside the output folder (`<out>/../<its name>/fit.json`, the layout of
        /// `output/`); when it is not there, the exponent study is run into `<out>/<its name>/`.
        #[serde(default = "default_exponent_study")]
        exponent_study: String,
        /// Rows of the vertical axis of the map.
        #[serde(default = "default_rows")]
        rows: usize,
        /// Natural flagella (CSV: pitch_um, helix_radius_um, length_um, organism, ...), a path
        /// relative to this study file.
        #[serde(default)]
        bacteria: Option<String>,
        /// Each column's first loss of stability and every Hopf point of the boundary curve
        /// carried to this relative accuracy of `omega_b` (as `locate`), up to `max_nodes`
        /// (default [`crate::analysis::refine::DEFAULT_MAX_NODES`]); absent: each at its `N`
        /// with its discretization error estimated from `N/2 + 1` nodes.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        accuracy: Option<f64>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max_nodes: Option<usize>,
        /// With `accuracy`: the boundary curve's carry spacing in `ln(lambda/l)`
        /// ([`PointAccuracy::spacing`]; the columns are each refined); absent: every Hopf point
        /// of the curve refined.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        carry_spacing: Option<f64>,
    },
    /// The stability boundary `omega_b(q)` as a curve in the field `vary` from `from` to `to`,
    /// one curve per case (e.g. a `lambda/l` each), by two-parameter continuation of the Hopf
    /// point; the local exponent `m_loc` along each, its limit at the small end, and (with
    /// `fit`) a power law over `fit = [a, b]` for comparison.
    Boundary {
        vary: String,
        from: f64,
        to: f64,
        #[serde(default)]
        cases: Vec<Case>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        fit: Option<[f64; 2]>,
        /// Every Hopf point carried from the curve's `N` to this relative accuracy of `omega_b`
        /// (as `locate`), up to `max_nodes` (default
        /// [`crate::analysis::refine::DEFAULT_MAX_NODES`]); absent: the curve's `N`, each point
        /// with its discretization error estimated from `N/2 + 1` nodes.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        accuracy: Option<f64>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max_nodes: Option<usize>,
        /// With `accuracy`: refine only points at least this far apart in `ln q` and
        /// interpolate the correction between them ([`PointAccuracy::spacing`]); absent: every
        /// Hopf point refined.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        carry_spacing: Option<f64>,
    },
    /// Steady shapes at a few rates seen from two orthogonal sides, and the critical mode.
    Shapes { omegas: Vec<f64> },
    /// Simulations from rest at each rate (the motor spun up over `ramp_time` s, run to `t_end`
    /// s); the late-time mean and standard deviation of `hbar` and `Fpbar` (over
    /// `t >= transient` s) drawn over the continuation branch.
    Dynamics {
        omegas: Vec<f64>,
        t_end: f64,
        transient: f64,
        #[serde(default = "default_ramp_time")]
        ramp_time: f64,
        /// Also follow the periodic orbits born at the Hopf point (`orbits/`) and draw their
        /// period averages with the time averages.
        #[serde(default)]
        orbit_branch: bool,
        /// The orbit branch's settings (`[study.orbits]`; the orbit kind's defaults).
        #[serde(default)]
        orbits: OrbitPlan,
    },
    /// The branch of periodic orbits born at the Hopf point that `locate` finds.
    Orbits(OrbitPlan),
}

/// The branch of periodic orbits born at the Hopf point that `locate` finds: `max_orbits`
/// orbits of `steps` equal BDF2 steps per period, the first of normal-form radius `amplitude`
/// (reference lengths), while `omega` stays in `[omega_min, omega_max]` (rad/s; default
/// `[0, branch.omega_max]`, or the rates' range for a dynamics study). The fields of a
/// `kind = "orbits"` study, and the `[study.orbits]` table of a dynamics study.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OrbitPlan {
    #[serde(default = "default_max_orbits")]
    pub max_orbits: usize,
    #[serde(default = "default_orbit_steps")]
    pub steps: usize,
    #[serde(default = "default_orbit_amplitude")]
    pub amplitude: f64,
    #[serde(default)]
    pub omega_min: Option<f64>,
    #[serde(default)]
    pub omega_max: Option<f64>,
}

impl Default for OrbitPlan {
    fn default() -> Self {
        OrbitPlan {
            max_orbits: default_max_orbits(),
            steps: default_orbit_steps(),
            amplitude: default_orbit_amplitude(),
            omega_min: None,
            omega_max: None,
        }
    }
}

impl OrbitPlan {
    /// Checks the ranges, the fields named `study.<field>` (`prefix = "study"`) or
    /// `study.orbits.<field>`.
    fn validate(&self, prefix: &str) -> Result<()> {
        // Without omega_max the range ends where the study says, checked there.
        let lo = self.omega_min.unwrap_or(0.0);
        let upper = self.omega_max.unwrap_or(lo + 1.0);
        super::orbits::OrbitsOptions::of_plan(self, upper)
            .validate()
            .map_err(|e| match e {
                Error::Input { field, message } => Error::Input {
                    field: field.replace("orbits.", &format!("{prefix}.")),
                    message,
                },
                other => other,
            })
    }
}

fn default_max_orbits() -> usize {
    40
}

fn default_orbit_steps() -> usize {
    100
}

fn default_orbit_amplitude() -> f64 {
    1e-3
}

fn default_ramp_time() -> f64 {
    20.0
}

fn default_rows() -> usize {
    40
}

fn default_exponent_study() -> String {
    "exponent_m.toml".into()
}

impl Plan {
    /// The kind's name.
    pub fn kind(&self) -> &'static str {
        match self {
            Plan::Branch { .. } => "branch",
            Plan::Locate { .. } => "locate",
            Plan::Sweep { .. } => "sweep",
            Plan::Phase { .. } => "phase",
            Plan::Boundary { .. } => "boundary",
            Plan::Shapes { .. } => "shapes",
            Plan::Dynamics { .. } => "dynamics",
            Plan::Orbits(_) => "orbits",
        }
    }

    /// The file paths the plan names (relative ones resolve against the study file's folder).
    pub(crate) fn paths_mut(&mut self) -> Vec<&mut String> {
        match self {
            Plan::Phase {
                exponent_study,
                bacteria,
                ..
            } => std::iter::once(exponent_study)
                .chain(bacteria.as_mut())
                .collect(),
            _ => Vec::new(),
        }
    }

    /// Checks the ranges of the plan's own fields.
    pub fn validate(&self) -> Result<()> {
        match self {
            Plan::Sweep {
                vary,
                accuracy,
                max_nodes,
                ..
            } => {
                point_accuracy(*accuracy, *max_nodes, POINT_REFINEMENT)?;
                if vary.is_empty() || vary.len() > 2 {
                    return Err(Error::input(
                        "study.vary",
                        format!("sweep one or two parameters, got {}", vary.len()),
                    ));
                }
                for v in vary {
                    if let Some(r) = &v.range {
                        let ok = r.count >= 1
                            && r.from.is_finite()
                            && r.to.is_finite()
                            && (!r.log || (r.from > 0.0 && r.to > 0.0));
                        if !ok {
                            return Err(Error::input(
                                format!("study.vary.{}.range", v.key),
                                "needs count >= 1, finite ends, positive ends for log spacing",
                            ));
                        }
                    } else if v.values.is_empty() {
                        return Err(Error::input(
                            format!("study.vary.{}", v.key),
                            "give `values` or `range`",
                        ));
                    }
                    if v.points().iter().any(|x| !x.is_finite()) {
                        return Err(Error::input(
                            format!("study.vary.{}", v.key),
                            "values must be finite",
                        ));
                    }
                }
                Ok(())
            }
            Plan::Phase {
                lambda_over_l,
                r_over_lambda,
                m,
                rows,
                accuracy,
                max_nodes,
                carry_spacing,
                ..
            } => {
                let refinement = point_accuracy(*accuracy, *max_nodes, POINT_REFINEMENT)?;
                let mut sorted = lambda_over_l.clone();
                sorted.sort_by(f64::total_cmp);
                let distinct = sorted.windows(2).all(|w| w[0] < w[1]);
                if sorted.len() < 2
                    || !distinct
                    || sorted.iter().any(|v| !(v.is_finite() && *v > 0.0))
                {
                    return Err(Error::input(
                        "study.lambda_over_l",
                        "needs at least two distinct positive values",
                    ));
                }
                let range = (sorted[0], sorted[sorted.len() - 1]);
                with_carry_spacing(refinement, *carry_spacing, range, CARRY_SPACING)?;
                if r_over_lambda.is_some_and(|r| !(r.is_finite() && r > 0.0)) {
                    return Err(Error::input(
                        "study.R_over_lambda",
                        "must be a finite number > 0",
                    ));
                }
                if m.is_some_and(|m| !m.is_finite()) {
                    return Err(Error::input("study.m", "must be finite"));
                }
                if *rows < 2 {
                    return Err(Error::input(
                        "study.rows",
                        format!("must be >= 2, got {rows}"),
                    ));
                }
                Ok(())
            }
            Plan::Shapes { omegas } => {
                if omegas.is_empty() || omegas.iter().any(|w| !w.is_finite() || *w < 0.0) {
                    return Err(Error::input(
                        "study.omegas",
                        "needs at least one finite rate >= 0 (rad/s)",
                    ));
                }
                Ok(())
            }
            Plan::Dynamics {
                omegas,
                t_end,
                transient,
                ramp_time,
                orbits,
                ..
            } => {
                orbits.validate("study.orbits")?;
                if omegas.is_empty() || omegas.iter().any(|w| !w.is_finite() || *w <= 0.0) {
                    return Err(Error::input(
                        "study.omegas",
                        "needs at least one finite rate > 0 (rad/s)",
                    ));
                }
                if !(t_end.is_finite()
                    && *t_end > 0.0
                    && transient.is_finite()
                    && *transient >= 0.0
                    && transient < t_end)
                {
                    return Err(Error::input(
                        "study.t_end",
                        "needs 0 <= transient < t_end (s)",
                    ));
                }
                if !(ramp_time.is_finite() && *ramp_time >= 0.0) {
                    return Err(Error::input(
                        "study.ramp_time",
                        "must be a finite number >= 0 (s)",
                    ));
                }
                Ok(())
            }
            Plan::Orbits(orbits) => orbits.validate("study"),
            Plan::Locate {
                accuracy,
                max_nodes,
                extrapolate,
                fixed_nodes,
                nodes,
            } => {
                if let Some(a) = accuracy {
                    check_accuracy("study.accuracy", *a)?;
                }
                if let Some(m) = max_nodes {
                    check_max_nodes("study.max_nodes", *m)?;
                }
                if *extrapolate && accuracy.is_some() {
                    return Err(Error::input(
                        "study.accuracy",
                        "a refinement to an accuracy and an extrapolation over a ladder \
                         exclude each other: set one",
                    ));
                }
                let refines = accuracy.is_some() || max_nodes.is_some();
                if *fixed_nodes && (*extrapolate || refines || !nodes.is_empty()) {
                    return Err(Error::input(
                        "study.fixed_nodes",
                        "omega_b at the study's N excludes a refinement (accuracy, max_nodes) and \
                         an extrapolation (extrapolate, nodes): set one",
                    ));
                }
                Ok(())
            }
            Plan::Boundary {
                from,
                to,
                fit,
                accuracy,
                max_nodes,
                carry_spacing,
                ..
            } => {
                let refinement = point_accuracy(*accuracy, *max_nodes, POINT_REFINEMENT)?;
                with_carry_spacing(refinement, *carry_spacing, (*from, *to), CARRY_SPACING)?;
                if !(from.is_finite() && to.is_finite() && from != to) {
                    return Err(Error::input(
                        "study.from",
                        format!(
                            "`from` and `to` must be two different finite values, got {from} and {to}"
                        ),
                    ));
                }
                if fit.is_some_and(|[a, b]| !(a.is_finite() && b.is_finite() && 0.0 < a && a < b)) {
                    return Err(Error::input(
                        "study.fit",
                        "must be [a, b] with 0 < a < b (the range of the power-law fit)",
                    ));
                }
                Ok(())
            }
            Plan::Branch { .. } => Ok(()),
        }
    }
}

/// The fields of a boundary or sweep study's refinement of its points ([`point_accuracy`]).
pub const POINT_REFINEMENT: [&str; 2] = ["study.accuracy", "study.max_nodes"];

/// The refinement of a boundary's points ([`PointAccuracy`]): `accuracy` checked, with
/// `max_nodes` (default [`DEFAULT_MAX_NODES`]); none without an accuracy, and `max_nodes` alone
/// (it bounds the refinement) refused. `fields` name the two as the user gave them.
pub fn point_accuracy(
    accuracy: Option<f64>,
    max_nodes: Option<usize>,
    [accuracy_field, max_nodes_field]: [&str; 2],
) -> Result<Option<PointAccuracy>> {
    let Some(accuracy) = accuracy else {
        return match max_nodes {
            Some(_) => Err(Error::input(
                max_nodes_field,
                format!("bounds the refinement of the points, which needs {accuracy_field}"),
            )),
            None => Ok(None),
        };
    };
    check_accuracy(accuracy_field, accuracy)?;
    let max_nodes = max_nodes.unwrap_or(DEFAULT_MAX_NODES);
    check_max_nodes(max_nodes_field, max_nodes)?;
    Ok(Some(PointAccuracy {
        accuracy,
        max_nodes,
        spacing: 0.0,
    }))
}

/// The largest carry spacing of a curve, in `ln q` (refined points a factor `e` apart).
pub const CARRY_SPACING_MAX: f64 = 1.0;

/// The study keys of a boundary's carry spacing and the accuracy it needs.
pub const CARRY_SPACING: [&str; 2] = ["study.accuracy", "study.carry_spacing"];

/// `refinement` (of [`point_accuracy`]) with a curve's carry `spacing` in `ln q`
/// ([`PointAccuracy::spacing`]; absent: 0, every point refined), which must be in `[0,`
/// [`CARRY_SPACING_MAX`]`]`, needs an accuracy and, above 0, a range `from .. to` of the curve on
/// one side of 0 (the spacing is in `ln |q|`). `fields` name the two as the user gave them.
pub fn with_carry_spacing(
    refinement: Option<PointAccuracy>,
    spacing: Option<f64>,
    (from, to): (f64, f64),
    [accuracy_field, spacing_field]: [&str; 2],
) -> Result<Option<PointAccuracy>> {
    let Some(spacing) = spacing else {
        return Ok(refinement);
    };
    let Some(refinement) = refinement else {
        return Err(Error::input(
            spacing_field,
            format!("spaces the points refined to an accuracy, which needs {accuracy_field}"),
        ));
    };
    if !(0.0..=CARRY_SPACING_MAX).contains(&spacing) {
        return Err(Error::input(
            spacing_field,
            format!(
                "must be in [0, {CARRY_SPACING_MAX}] (a distance in ln of the varied value; 0 \
                 refines every point), got {spacing}"
            ),
        ));
    }
    if spacing > 0.0 && from * to <= 0.0 {
        return Err(Error::input(
            spacing_field,
            format!(
                "spaces the points in ln |q|, which needs the range on one side of 0, got {from} \
                 to {to}"
            ),
        ));
    }
    Ok(Some(PointAccuracy {
        spacing,
        ..refinement
    }))
}

/// Checks a relative accuracy of `omega_b` (`locate --accuracy`): in `(0, 0.1)`.
pub fn check_accuracy(field: &str, accuracy: f64) -> Result<()> {
    if accuracy > 0.0 && accuracy < 0.1 {
        Ok(())
    } else {
        Err(Error::input(
            field,
            format!("must lie in (0, 0.1) (a relative error of omega_b), got {accuracy}"),
        ))
    }
}

/// Checks that a refinement starting at the model's `N` has room below `max_nodes` for the
/// finer rung its error estimate needs: a cap at or below the start would run the start alone
/// and say only that the accuracy was not reached. An `N` outside the fluid model's admissible
/// range is refused first, with that range; an `N` at the end of that range (Lighthill's
/// operator) is not refused here: the refinement runs it and says that the range stops it.
pub fn check_refinement_room(field: &str, max_nodes: usize, physical: &Physical) -> Result<()> {
    let nodes = physical.discretization.nodes;
    if max_nodes > nodes {
        Ok(())
    } else {
        if admissible_max_nodes(physical).is_some_and(|a| a < nodes) {
            Model::new(physical)?.check_resolution()?;
        }
        Err(Error::input(
            field,
            format!(
                "must exceed discretization.nodes = {nodes}, where the refinement starts (its \
                 error estimate needs a finer rung), got {max_nodes}{}",
                if max_nodes == DEFAULT_MAX_NODES {
                    " (the default)"
                } else {
                    ""
                }
            ),
        ))
    }
}

/// Checks the largest node count of a refinement: at least 5.
pub fn check_max_nodes(field: &str, max_nodes: usize) -> Result<()> {
    if max_nodes >= 5 {
        Ok(())
    } else {
        Err(Error::input(
            field,
            format!("must be >= 5, got {max_nodes}"),
        ))
    }
}
