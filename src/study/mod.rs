//! Study files: TOML descriptions of a run, kept in version control.
//!
//! A study holds the physical parameters (SI) and the numerical settings. Any field can be
//! overridden from the command line with `--set key=value` (dotted path, TOML value syntax, e.g.
//! `--set rod.E=2e6`, `--set shape.handedness=right`). Unknown keys are refused, naming the key.

pub mod figures;
pub mod phase;
pub mod plan;
pub mod run;
pub mod runs;
pub mod shapes;
pub mod simulate;
pub mod sweep;

pub use figures::sweep_figures;
pub use plan::Plan;

use serde::{Deserialize, Serialize};

use crate::continuation::ContinuationSettings;
use crate::continuation::newton::NewtonSettings;
use crate::params::{Discretization, FluidParams, Physical, RodParams, ShapeParams};
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
    /// Largest rotation rate followed (rad/s).
    pub omega_max: f64,
}

impl Default for BranchRange {
    fn default() -> Self {
        BranchRange { omega_max: 2.0 }
    }
}

impl Study {
    /// The built-in default: the representative helix of MODEL.md section 7.
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
            study: None,
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
                    e.into_inner().message().to_string(),
                )
            })?;
        let mut study = study;
        study.physical().validate()?;
        study.resolve_per_turn()?;
        study.newton.validate()?;
        study.continuation.validate()?;
        if !(study.branch.omega_max.is_finite() && study.branch.omega_max > 0.0) {
            return Err(Error::input(
                "branch.omega_max",
                format!(
                    "must be a finite number > 0 (rad/s), got {}",
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
                Study::load(Some(&text), overrides)
            }
        }
    }
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
    set_path(table, key.trim(), value)
}

/// Sets the value at a dotted path of a TOML table, creating intermediate tables.
pub fn set_path(table: &mut toml::Table, key: &str, value: toml::Value) -> Result<()> {
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

/// The number at a dotted path of a TOML table (integers read as floats).
pub fn get_number(table: &toml::Table, key: &str) -> Option<f64> {
    let mut parts = key.split('.').peekable();
    let mut current = table;
    while let Some(part) = parts.next() {
        let value = current.get(part)?;
        if parts.peek().is_none() {
            return value
                .as_float()
                .or_else(|| value.as_integer().map(|i| i as f64));
        }
        current = value.as_table()?;
    }
    None
}
