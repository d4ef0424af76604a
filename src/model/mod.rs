//! The dimensionless model: the rod, the fluid and gravity in the solver's units, built once
//! from validated SI parameters.

pub mod dofs;
pub mod fluid;
pub mod observables;
pub mod params;
pub mod rod;
pub mod shape;
pub mod steady;

use nalgebra::Vector3;

use crate::model::fluid::Fluid;
use crate::model::params::{Physical, Scales};
use crate::model::rod::frame::Chart;
use crate::model::rod::{Config, Rod, Stiffness};
use crate::model::shape::rod_nodes;
use crate::numerics::process::available_memory;
use crate::{Error, Result};

/// Everything the solver needs, dimensionless (lengths by `ell`, forces by `EI/ell^2`, time by
/// `mu ell^4/EI`, so `EI = mu = 1`).
#[derive(Clone, Debug)]
pub struct Model {
    pub physical: Physical,
    pub scales: Scales,
    /// Natural node positions.
    pub natural: Vec<Vector3<f64>>,
    pub rod: Rod,
    /// The Bishop chart of the natural shape.
    pub chart: Chart,
    /// Net weight per unit length `q ell^3 / EI`.
    pub weight: f64,
    pub fluid: Fluid,
}

impl Model {
    /// Validates `physical` and builds the dimensionless model.
    pub fn new(physical: &Physical) -> Result<Self> {
        physical.validate()?;
        // Runs of a few hundred megabytes are not checked (the check reads system files); a
        // count outside Lighthill's admissible range is refused for that, more to the point
        // ([`Model::check_resolution`]).
        let nodes = physical.discretization.nodes;
        if memory_estimate(nodes) > 256 << 20
            && admissible_max_nodes(physical).is_none_or(|max| nodes <= max)
        {
            check_memory(nodes)?;
        }
        let scales = physical.scales();
        let ell = scales.length;
        let ei = physical.bending_stiffness();
        let clamp = physical.clamp_edge();
        let natural: Vec<Vector3<f64>> = rod_nodes(&physical.shape, nodes, clamp)
            .into_iter()
            .map(|p| p / ell)
            .collect();
        let stiffness = Stiffness {
            ea: physical.stretching_stiffness() * ell * ell / ei,
            ei: 1.0,
            gj: physical.twisting_stiffness() / ei,
        };
        let (rod, chart) = Rod::new(&natural, stiffness);
        Ok(Model {
            physical: physical.clone(),
            scales,
            rod,
            chart,
            weight: physical.weight_per_length() * ell.powi(3) / ei,
            fluid: Fluid::from_params(&physical.fluid, physical.rod.r0, ell, &natural, clamp),
            natural,
        })
    }

    /// Number of nodes `N`.
    pub fn nodes(&self) -> usize {
        self.natural.len()
    }

    /// Gravity on node `i`: `-q wbar_i e_z` with the natural Voronoi length `wbar_i` (the mass
    /// does not change when the rod stretches).
    pub(crate) fn gravity(&self, weight: f64) -> Vec<Vector3<f64>> {
        self.rod
            .weights
            .iter()
            .map(|w| Vector3::new(0.0, 0.0, -weight * w))
            .collect()
    }

    /// Checks that the node count lies in the admissible range (docs/model.md section 3) and
    /// that the mobility matrix of the natural shape is positive definite there; if not, the
    /// error (an input error: the node count is out of range) gives the range and the reason.
    /// A count above the range is refused without factorizing at that size. Nothing to check
    /// for a fluid model that is positive definite at every resolution (RPY).
    pub fn check_resolution(&self) -> Result<()> {
        let Some(delta) = self.fluid.resolution_cutoff() else {
            return Ok(());
        };
        let max = admissible_max_nodes(&self.physical).unwrap_or(usize::MAX);
        let n = self.nodes();
        if n <= max && natural_mobility_is_definite(&self.physical, n) {
            return Ok(());
        }
        let spacing = self.rod.rest_lengths[0] / delta;
        let range = if max >= 5 {
            format!("the admissible range 5..={max}")
        } else {
            "the admissible range, which is empty".to_owned()
        };
        Err(Error::input(
            "discretization.nodes",
            format!(
                "N = {n} is outside {range} for this rod: the node spacing ({spacing:.2} delta) \
                 is too close to the Lighthill cut-off delta = r0 sqrt(e)/2, where the discrete \
                 Lighthill operator is not positive definite (docs/model.md section 3)"
            ),
        ))
    }

    /// The natural configuration (`theta = 0`).
    pub fn natural_config(&self) -> Config {
        Config {
            x: self.natural.clone(),
            theta: vec![0.0; self.nodes() - 1],
        }
    }
}

/// The memory (bytes) a run at `nodes` nodes needs at its peak: the dense matrices of the order
/// of the unknowns, `n = 4N` (a Jacobian and its LU factors, the mobility and resistance, the
/// stability pair, the Krylov basis and the complex factorization of the spectrum), measured at
/// about 20 of them at the peak of `locate` (RPY, `N = 120..473`: 39, 140 and 572 MB), taken as
/// 24, plus 64 MB for the rest of the process.
pub fn memory_estimate(nodes: usize) -> u64 {
    let n = 4 * nodes as u64;
    24 * 8 * n * n + (64 << 20)
}

/// Refuses (as bad input) a node count whose run would need more memory than this process can
/// still allocate ([`available_memory`]), naming the estimate, the limit and the largest count
/// that fits.
fn check_memory(nodes: usize) -> Result<()> {
    let need = memory_estimate(nodes);
    let Some(available) = available_memory() else {
        return Ok(());
    };
    if need <= available.bytes {
        return Ok(());
    }
    let fits = (5..nodes)
        .rev()
        .find(|&n| memory_estimate(n) <= available.bytes)
        .map_or("no node count fits".to_string(), |n| {
            format!("N <= {n} fits")
        });
    let gb = |b: u64| b as f64 / 1e9;
    Err(Error::input(
        "discretization.nodes",
        format!(
            "N = {nodes} needs about {:.1} GB (dense matrices of order 4N), more than the {:.1} GB \
             this process may still allocate ({}); {fits}",
            gb(need),
            gb(available.bytes),
            available.source
        ),
    ))
}

/// True when the mobility matrix of the natural shape with `nodes` nodes is positive definite.
fn natural_mobility_is_definite(physical: &Physical, nodes: usize) -> bool {
    let ell = physical.shape.reference_length();
    let clamp = physical.clamp_edge();
    let x: Vec<Vector3<f64>> = rod_nodes(&physical.shape, nodes, clamp)
        .into_iter()
        .map(|p| p / ell)
        .collect();
    Fluid::from_params(&physical.fluid, physical.rod.r0, ell, &x, clamp)
        .resistance(&x, "")
        .is_ok()
}

/// The largest node count for which the natural shape's mobility matrix is positive definite
/// (4 when not even 5 nodes are); `None` when the fluid model is positive definite at every
/// resolution (RPY). The discrete Lighthill operator turns indefinite once the spacing falls to
/// about 3.9 delta (docs/model.md section 3), so the search starts from the estimate
/// `ds = 4 delta`, brackets the limit by steps that double, and bisects: a handful of
/// factorizations of the size of the limit, whatever node count is asked for. A model whose
/// matrix never fails (the original quadrature, factorized by LU) is capped at four times the
/// estimate. The natural mobility is positive definite for every `N` below the limit on the
/// shapes tested (`tests/fluid.rs`); [`Model::check_resolution`] still checks the `N` in use.
pub fn admissible_max_nodes(physical: &Physical) -> Option<usize> {
    let delta = physical.fluid.model.resolution_cutoff(physical.rod.r0)?;
    let contour = physical.shape.contour_length();
    let estimate = ((contour / (4.0 * delta)).floor() as usize + 1).max(5);
    let cap = (4 * estimate).max(64);
    let ok = |n: usize| natural_mobility_is_definite(physical, n);
    let mut step = (estimate / 8).max(1);
    // The bracket: `ok(good)` and `!ok(bad)`.
    let (mut good, mut bad) = if ok(estimate) {
        let mut good = estimate;
        loop {
            let next = (good + step).min(cap);
            if !ok(next) {
                break (good, next);
            }
            if next == cap {
                return Some(cap);
            }
            good = next;
            step *= 2;
        }
    } else {
        let mut bad = estimate;
        loop {
            let next = bad.saturating_sub(step).max(5);
            if ok(next) {
                break (next, bad);
            }
            if next == 5 {
                return Some(4);
            }
            bad = next;
            step *= 2;
        }
    };
    while bad - good > 1 {
        let mid = good + (bad - good) / 2;
        if ok(mid) {
            good = mid;
        } else {
            bad = mid;
        }
    }
    Some(good)
}
