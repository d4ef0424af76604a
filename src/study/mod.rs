//! Study files: TOML descriptions of a run, kept in version control.
//!
//! A study holds the physical parameters (SI) and the numerical settings. Any field can be
//! overridden from the command line with `--set key=value` (dotted path, TOML value syntax, e.g.
//! `--set rod.E=2e6`, `--set shape.handedness=right`). Unknown keys are refused, naming the key.

pub mod boundary;
pub mod branch;
pub mod cycles;
pub mod dynamics;
pub mod figures;
pub mod interrupt;
pub mod locate;
pub mod orbits;
pub mod output;
pub mod phase;
pub mod plan;
pub mod progress;
pub mod run;
pub mod shapes;
pub mod simulate;
pub mod slurm;
pub mod sweep;

pub use figures::sweep_figures;
pub use plan::Plan;

use serde::{Deserialize, Serialize};

use crate::analysis::dynamics::DynamicsSettings;
use crate::analysis::locate::LocateSettings;
use crate::engine::ContinuationSettings;
use crate::engine::newton::NewtonSettings;
use crate::model::params::{Discretization, FluidParams, Physical, RodParams, ShapeParams};
use crate::{Error, Result};

/// One study file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Study {
    /// Name of the study (the output folder `output/<name>/`).
    #[serde(default = "default_name")]
    pub name: String,
    pub rod: RodParams,
    pub fluid: FluidParams,
    pub shape: ShapeParams,
    pub discretization: Discretization,
    #[serde(default)]
    pub newton: NewtonSettings,
    #[serde(default)]
    pub continuation: ContinuationSettings,
    #[serde(default)]
    pub branch: BranchRange,
    /// The time stepper of `simulate` and the `dynamics` study.
    #[serde(default)]
    pub integrator: IntegratorTable,
    /// What `helixbif run` does with this study (absent: `locate`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub study: Option<Plan>,
}

fn default_name() -> String {
    "study".into()
}

/// How far a branch is followed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BranchRange {
    /// Largest rotation rate followed (rad/s); negative to follow the branch towards negative
    /// rates (the motor turning clockwise seen from above).
    pub omega_max: f64,
}

impl Default for BranchRange {
    fn default() -> Self {
        BranchRange { omega_max: 2.0 }
    }
}

impl Study {
    /// The built-in default: the representative helix of docs/model.md section 7.
    pub fn representative() -> Self {
        let p = Physical::representative();
        Study {
            name: "representative".into(),
            rod: p.rod,
            fluid: p.fluid,
            shape: p.shape,
            discretization: p.discretization,
            newton: NewtonSettings::default(),
            continuation: ContinuationSettings::default(),
            branch: BranchRange::default(),
            integrator: Default::default(),
            study: None,
        }
    }

    /// The range and the numerical settings of `locate` on this study.
    pub(crate) fn locate_settings(&self) -> LocateSettings<'_> {
        LocateSettings {
            omega_max: self.branch.omega_max,
            newton: &self.newton,
            continuation: &self.continuation,
            criticality: true,
        }
    }

    /// The physical part of the study.
    pub fn physical(&self) -> Physical {
        Physical {
            rod: self.rod.clone(),
            fluid: self.fluid.clone(),
            shape: self.shape.clone(),
            discretization: self.discretization.clone(),
        }
    }

    /// Reads a study from TOML text (`None`: the built-in default), applies the `key=value`
    /// overrides, and validates every field.
    pub fn load(text: Option<&str>, overrides: &[String]) -> Result<Self> {
        let mut table = match text {
            Some(t) => t.parse().map_err(|e: toml::de::Error| {
                Error::input("study file", e.message().replace('\n', " "))
            })?,
            None => Study::representative().to_table()?,
        };
        for item in overrides {
            apply_override(&mut table, item)?;
        }
        Study::from_table(table)
    }

    /// The study as a TOML table, from which variants are derived.
    pub fn to_table(&self) -> Result<toml::Table> {
        toml::Table::try_from(self).map_err(|e| Error::input("study", e.to_string()))
    }

    /// Deserializes and validates a study from a TOML table; errors name the offending field.
    pub fn from_table(table: toml::Table) -> Result<Self> {
        let study: Study =
            serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(|e| {
                let path = e.path().to_string();
                Error::input(
                    if path == "." {
                        "study".to_string()
                    } else {
                        path
                    },
                    in_words(e.into_inner().message()),
                )
            })?;
        let mut study = study;
        study.physical().validate()?;
        study.resolve_per_turn()?;
        study
            .newton
            .validate()
            .map_err(|e| e.naming_setting(|s| format!("newton.{s}")))?;
        study
            .continuation
            .validate()
            .map_err(|e| e.naming_setting(|s| format!("continuation.{s}")))?;
        study.integrator.validate()?;
        if !(study.branch.omega_max.is_finite() && study.branch.omega_max != 0.0) {
            return Err(Error::input(
                "branch.omega_max",
                format!(
                    "must be a finite nonzero number (rad/s; negative: the motor turning \
                     clockwise seen from above), got {}",
                    study.branch.omega_max
                ),
            ));
        }
        if let Some(plan) = &study.study {
            plan.validate()?;
        }
        Ok(study)
    }

    /// Replaces `discretization.nodes` by the count that `discretization.per_turn` asks for.
    fn resolve_per_turn(&mut self) -> Result<()> {
        let Some(per_turn) = self.discretization.per_turn else {
            return Ok(());
        };
        let ShapeParams::Helix { l, lambda, .. } = self.shape else {
            return Err(Error::input(
                "discretization.per_turn",
                "applies to helices only",
            ));
        };
        if !(per_turn.is_finite() && per_turn >= 2.0) {
            return Err(Error::input(
                "discretization.per_turn",
                format!("must be >= 2, got {per_turn}"),
            ));
        }
        let wanted = (per_turn * l / lambda).round() as usize + 1;
        let max = crate::model::admissible_max_nodes(&self.physical())
            .map_or(usize::MAX, |max| max.saturating_sub(2));
        self.discretization.nodes = wanted.min(max).max(5);
        Ok(())
    }

    /// Reads a study file (or the default when `path` is `None`) with overrides.
    pub fn from_path(path: Option<&std::path::Path>, overrides: &[String]) -> Result<Self> {
        match path {
            None => Study::load(None, overrides),
            Some(p) => {
                let text = std::fs::read_to_string(p).map_err(|e| {
                    Error::input("study file", format!("cannot read {}: {e}", p.display()))
                })?;
                let mut study = Study::load(Some(&text), overrides)?;
                study.resolve_paths(p.parent().unwrap_or(std::path::Path::new("")));
                Ok(study)
            }
        }
    }

    /// Makes the relative paths a study names (data files, other studies) relative to `base`,
    /// the folder of the study file, so that a study means the same from any working directory.
    fn resolve_paths(&mut self, base: &std::path::Path) {
        if let Some(plan) = &mut self.study {
            for path in plan.paths_mut() {
                if std::path::Path::new(path.as_str()).is_relative() {
                    *path = base.join(path.as_str()).display().to_string();
                }
            }
        }
    }
}

/// A deserialization message with the Rust types it names in the user's words: the range of
/// values a field of that type takes (`-3` for a node count: `expected an integer >= 0`, the
/// field's own bounds checked once it is one). The study's fields are `usize`, `f64` and
/// `bool` (besides strings, tables and arrays of them).
fn in_words(message: &str) -> String {
    [
        ("expected usize", "expected an integer >= 0"),
        ("expected f64", "expected a number"),
        ("expected a boolean", "expected true or false"),
    ]
    .iter()
    .fold(message.to_string(), |m, (rust, words)| {
        m.replace(rust, words)
    })
}

/// Applies one `dotted.key=value` override to a TOML table. The value is read as a TOML value
/// (number, boolean, string in quotes, array); a bare word that is not one is taken as a string.
fn apply_override(table: &mut toml::Table, item: &str) -> Result<()> {
    let (key, raw) = item
        .split_once('=')
        .ok_or_else(|| Error::input("--set", format!("expected key=value, got `{item}`")))?;
    let value = format!("v = {}", raw.trim())
        .parse::<toml::Table>()
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| toml::Value::String(raw.trim().to_string()));
    let key = key.trim();
    if [LAMBDA_OVER_L, R_OVER_LAMBDA].contains(&key) {
        let x = value
            .as_float()
            .or_else(|| value.as_integer().map(|i| i as f64))
            .ok_or_else(|| Error::input(key, format!("must be a number, got `{}`", raw.trim())))?;
        return set_ratio(table, key, x);
    }
    set_path(table, key, value)
}

/// The dimensionless helix ratios that can be set or swept: `shape.lambda_over_l` sets the
/// pitch to the value times `l` (with `l` and `R` fixed), `shape.R_over_lambda` the radius to
/// the value times the pitch.
pub(crate) const LAMBDA_OVER_L: &str = "shape.lambda_over_l";
pub(crate) const R_OVER_LAMBDA: &str = "shape.R_over_lambda";

/// Sets one of the ratios [`LAMBDA_OVER_L`], [`R_OVER_LAMBDA`] to `x` on a helix study table.
pub fn set_ratio(table: &mut toml::Table, key: &str, x: f64) -> Result<()> {
    let (target, from) = match key {
        LAMBDA_OVER_L => ("shape.lambda", "shape.l"),
        R_OVER_LAMBDA => ("shape.R", "shape.lambda"),
        _ => return Err(Error::input(key, "not a helix ratio")),
    };
    let reference = get_number(table, from)
        .ok_or_else(|| Error::input(key, format!("needs a helix with a numeric `{from}`")))?;
    set_path(table, target, toml::Value::Float(x * reference))
}

/// Sets the value at a dotted path of a TOML table, creating intermediate tables.
pub(crate) fn set_path(table: &mut toml::Table, key: &str, value: toml::Value) -> Result<()> {
    let parts: Vec<&str> = key.split('.').collect();
    if parts.iter().any(|p| p.is_empty()) {
        return Err(Error::input("--set", format!("malformed key `{key}`")));
    }
    let (last, parents) = parts.split_last().expect("split yields one part");
    let mut current = table;
    for part in parents {
        current = current
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()))
            .as_table_mut()
            .ok_or_else(|| Error::input(key, format!("`{part}` is not a table")))?;
    }
    current.insert(last.to_string(), value);
    Ok(())
}

/// The value at a dotted path of a TOML table.
pub(crate) fn get_value<'a>(table: &'a toml::Table, key: &str) -> Option<&'a toml::Value> {
    let mut parts = key.split('.').peekable();
    let mut current = table;
    while let Some(part) = parts.next() {
        let value = current.get(part)?;
        if parts.peek().is_none() {
            return Some(value);
        }
        current = value.as_table()?;
    }
    None
}

/// The number at a dotted path of a TOML table (integers read as floats).
pub(crate) fn get_number(table: &toml::Table, key: &str) -> Option<f64> {
    let value = get_value(table, key)?;
    value
        .as_float()
        .or_else(|| value.as_integer().map(|i| i as f64))
}

/// The default output folder of a study run: `output/<name>/`, or, when `--set` overrides
/// change the study, `output/<name>.set-<overrides>/` (so that a variant never overwrites the
/// committed results of the study itself). Long override lists are shortened, with a hash of
/// the whole list so that different lists give different folders.
pub fn default_output(name: &str, overrides: &[String]) -> std::path::PathBuf {
    let root = std::path::Path::new("output");
    if overrides.is_empty() {
        return root.join(name);
    }
    let joined = overrides.join(" ");
    let mut slug: String = joined
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '.' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if slug.len() > 60 {
        // FNV-1a: stable across runs and platforms (unlike the standard hasher).
        let hash = joined.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
        });
        slug.truncate(40);
        slug = format!("{slug}-{:08x}", hash as u32);
    }
    root.join(format!("{name}.set-{slug}"))
}

/// The study's `[integrator]` table: the time stepper of `helixbif simulate` and the `dynamics`
/// study, in SI units (converted to the solver's by [`IntegratorTable::settings`]).
///
/// The defaults aim at time averages of a buckled rod to three digits: a local error of `1e-4`
/// relative and 1 um absolute on node positions per step, and the factorized step Jacobian
/// reused while it converges (a chord method). Tighten `rtol`, `atol` to resolve the growth of
/// a small perturbation of a steady state.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IntegratorTable {
    /// Relative local error tolerance on node positions (-), in `(0, 0.1]`.
    pub rtol: f64,
    /// Absolute local error tolerance on node positions (m), `> 0`.
    pub atol: f64,
    /// Largest time step (s), `> 0`.
    pub dt_max: f64,
    /// `"chord"`: keep the factorized step Jacobian over iterations and steps while Newton
    /// converges fast; `"newton"`: a fresh exact Jacobian at every iteration.
    pub jacobian: JacobianUse,
}

/// How the implicit steps use the Jacobian (see [`IntegratorTable::jacobian`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JacobianUse {
    Chord,
    Newton,
}

impl Default for IntegratorTable {
    fn default() -> Self {
        IntegratorTable {
            rtol: 1e-4,
            atol: 1e-6,
            dt_max: 2.0,
            jacobian: JacobianUse::Chord,
        }
    }
}

/// The update at which a step's Newton iteration ends, in the error test's weighted norm
/// ([`DynamicsSettings::newton_kappa`]; DASSL's choice is about 0.3, a tenth of it is safe).
const NEWTON_KAPPA: f64 = 0.03;

impl IntegratorTable {
    /// Checks every field against its range; errors name the field.
    pub fn validate(&self) -> Result<()> {
        let checks = [
            (
                "integrator.rtol",
                self.rtol,
                self.rtol > 0.0 && self.rtol <= 0.1,
                "(0, 0.1]",
            ),
            (
                "integrator.atol",
                self.atol,
                self.atol > 0.0 && self.atol.is_finite(),
                "> 0 (m)",
            ),
            (
                "integrator.dt_max",
                self.dt_max,
                self.dt_max > 0.0 && self.dt_max.is_finite(),
                "> 0 (s)",
            ),
        ];
        for (field, value, ok, range) in checks {
            if !ok {
                return Err(Error::input(
                    field,
                    format!("must lie in {range}, got {value}"),
                ));
            }
        }
        Ok(())
    }

    /// The integrator's settings in solver units (lengths in `ell`, times in `mu ell^4/EI`).
    pub fn settings(&self, scales: &crate::model::params::Scales) -> DynamicsSettings {
        let defaults = DynamicsSettings::default();
        DynamicsSettings {
            rtol: self.rtol,
            atol: self.atol / scales.length,
            dt_max: self.dt_max / scales.time,
            dt0: defaults.dt0.min(self.dt_max / scales.time),
            reuse_jacobian: self.jacobian == JacobianUse::Chord,
            newton_kappa: NEWTON_KAPPA,
            ..defaults
        }
    }
}
