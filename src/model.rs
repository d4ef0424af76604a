//! The dimensionless model: the rod, the fluid and gravity in the solver's units, built once
//! from validated SI parameters.

use nalgebra::Vector3;

use crate::fluid::Fluid;
use crate::params::{Physical, Scales};
use crate::rod::frame::Chart;
use crate::rod::{Rod, Stiffness};
use crate::shape::natural_nodes;
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
        let scales = physical.scales();
        let ell = scales.length;
        let ei = physical.bending_stiffness();
        let natural: Vec<Vector3<f64>> =
            natural_nodes(&physical.shape, physical.discretization.nodes)
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
            fluid: Fluid::from_params(&physical.fluid, physical.rod.r0, ell, &natural),
            natural,
        })
    }

    /// Number of nodes `N`.
    pub fn nodes(&self) -> usize {
        self.natural.len()
    }

    /// Gravity on node `i`: `-q wbar_i e_z` with the natural Voronoi length `wbar_i` (the mass
    /// does not change when the rod stretches).
    pub fn gravity(&self, weight: f64) -> Vec<Vector3<f64>> {
        self.rod
            .weights
            .iter()
            .map(|w| Vector3::new(0.0, 0.0, -weight * w))
            .collect()
    }

    /// Checks that the mobility matrix of the natural shape is positive definite at this node
    /// count; if not, the error (an input error: the node count is out of range) gives the
    /// admissible range and the reason. Nothing to check for a fluid model that is positive
    /// definite at every resolution (RPY).
    pub fn check_resolution(&self) -> Result<()> {
        let Some(delta) = self.fluid.resolution_cutoff() else {
            return Ok(());
        };
        if natural_mobility_is_definite(&self.physical, self.nodes()) {
            return Ok(());
        }
        let max = admissible_max_nodes(&self.physical).unwrap_or(self.nodes());
        let spacing = self.rod.rest_lengths[0] / delta;
        Err(Error::input(
            "discretization.nodes",
            format!(
                "N = {} is outside the admissible range 5..={max} for this rod: the node spacing \
                 ({spacing:.2} delta) is too close to the Lighthill cut-off delta = r0 sqrt(e)/2, where \
                 the discrete Lighthill operator is not positive definite (MODEL.md section 3)",
                self.nodes()
            ),
        ))
    }
}

/// True when the mobility matrix of the natural shape with `nodes` nodes is positive definite.
fn natural_mobility_is_definite(physical: &Physical, nodes: usize) -> bool {
    let ell = physical.shape.reference_length();
    let x: Vec<Vector3<f64>> = natural_nodes(&physical.shape, nodes)
        .into_iter()
        .map(|p| p / ell)
        .collect();
    Fluid::from_params(&physical.fluid, physical.rod.r0, ell, &x)
        .resistance(&x, "")
        .is_ok()
}

/// The largest node count for which the natural shape's mobility matrix is positive definite,
/// searched by single steps from the estimate `ds = 4 delta` (MODEL.md section 3: the discrete
/// operator turns indefinite once the spacing falls to about 3.9 delta). `None` when the fluid
/// model is positive definite at every resolution (RPY): no cap beyond the validated 5000.
pub fn admissible_max_nodes(physical: &Physical) -> Option<usize> {
    let delta = physical.fluid.model.resolution_cutoff(physical.rod.r0)?;
    let contour = physical.shape.contour_length();
    let estimate = ((contour / (4.0 * delta)).floor() as usize + 1).max(5);
    let ok = |n: usize| natural_mobility_is_definite(physical, n);
    let mut n = estimate;
    if ok(n) {
        while n < 5000 && ok(n + 1) {
            n += 1;
        }
    } else {
        while n > 5 && !ok(n) {
            n -= 1;
        }
    }
    Some(n)
}
