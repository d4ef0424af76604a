//! Observables of a state (docs/model.md section 6): thrust, torque, efficiency and height, in
//! SI and normalized, for steady states and for moving ones.

use faer::Mat;
use faer::prelude::Solve;
use nalgebra::Vector3;
use serde::Serialize;

use crate::model::Model;
use crate::model::dofs::Layout;
use crate::model::rod::frame::Chart;
use crate::model::steady::{Steady, rotation_velocity};
use crate::{Error, Result};

/// Observables of a steady state (docs/model.md section 6), SI and normalized.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Observables {
    /// Rotation rate (rad/s) and `omegabar = omega mu ell^4 / EI`.
    pub omega: f64,
    pub omegabar: f64,
    /// Propulsive force `F_p = -e_z . sum_j F_j` (N) and `F_p ell^2 / EI`.
    #[serde(rename = "Fp")]
    pub fp: f64,
    #[serde(rename = "Fpbar")]
    pub fpbar: f64,
    /// Motor torque `T_p = e_z . sum_j x_j x F_j` (N m).
    #[serde(rename = "Tp")]
    pub tp: f64,
    /// Efficiency `F_p ell / T_p` (`None` at rest).
    pub eta: Option<f64>,
    /// Suspended height (m), its value at rest, and their ratio.
    pub h: f64,
    pub h0: f64,
    pub hbar: f64,
}

/// Propulsive force and motor torque (solver units) of the nodal forces `forces` at `x`.
pub(crate) fn thrust_and_torque(x: &[Vector3<f64>], forces: &[Vector3<f64>]) -> (f64, f64) {
    let fp = -forces.iter().map(|f| f.z).sum::<f64>();
    let tp = x.iter().zip(forces).map(|(p, f)| p.cross(f).z).sum();
    (fp, tp)
}

impl Model {
    /// Vertical distance from the clamp point to the lowest node (solver units): node 0, or the
    /// midpoint of the clamped edge when it is centred on the clamp
    /// ([`crate::model::params::ClampEdge`]).
    pub fn height(&self, x: &[Vector3<f64>]) -> f64 {
        let lowest = x.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
        self.physical.clamp_edge().clamp_point(x).z - lowest
    }

    /// Observables of the state `x` at `omegabar`, with `h0` the height at rest (solver units).
    pub fn observables(
        &self,
        omegabar: f64,
        x: &[Vector3<f64>],
        forces: &[Vector3<f64>],
        h0: f64,
    ) -> Observables {
        let s = &self.scales;
        let (fp, tp) = thrust_and_torque(x, forces);
        let h = self.height(x);
        Observables {
            omega: s.omega_from_bar(omegabar),
            omegabar,
            fp: fp * s.force,
            fpbar: fp,
            tp: tp * s.torque(),
            eta: (tp != 0.0).then(|| fp / tp),
            h: h * s.length,
            h0: h0 * s.length,
            hbar: h / h0,
        }
    }

    /// Observables of the steady state with nodes `x` at `omegabar` (the forces on the fluid
    /// those of the rigid rotation, [`Steady::drag`]), with `h0` the height at rest.
    pub(crate) fn steady_observables(
        &self,
        omegabar: f64,
        x: &[Vector3<f64>],
        h0: f64,
    ) -> Result<Observables> {
        let forces = match Steady::new(self, omegabar).drag(x)? {
            Some(d) => d.forces,
            None => vec![Vector3::zeros(); self.nodes()],
        };
        Ok(self.observables(omegabar, x, &forces, h0))
    }

    /// `F_p ell^2 / EI` of the natural shape held rigid and turned at `omegabar` (linear in it).
    pub fn rigid_thrust(&self, omegabar: f64) -> Result<f64> {
        let problem = Steady::new(self, omegabar);
        Ok(match problem.drag(&self.natural)? {
            Some(d) => thrust_and_torque(&self.natural, &d.forces).0,
            None => 0.0,
        })
    }
}

/// The forces on the fluid of a moving state `u` (twist measured in `chart`, e.g. a
/// an integrator sample's `u_chart` and `chart`) at rate `omegabar` (docs/model.md section 5).
pub fn moving_forces(
    model: &Model,
    u: &[f64],
    chart: &Chart,
    omegabar: f64,
) -> Result<Vec<Vector3<f64>>> {
    let steady = Steady::new(model, omegabar);
    let config = steady.config(u);
    let gradient = model.rod.gradient(&config, chart);
    let gravity = model.gravity(model.weight);
    let layout = model.rod.layout;
    let n = layout.nodes();
    let c = Layout::CLAMPED_NODES;
    let free: Vec<Vector3<f64>> = (c..n)
        .map(|i| Vector3::from_fn(|k, _| -gradient[layout.x(i, k)] + gravity[i][k]))
        .collect();
    let a = model.fluid.mobility(&config.x);
    let velocity = rotation_velocity(omegabar, &config.x);
    let nc = 3 * c;
    let a_cc = Mat::from_fn(nc, nc, |r, k| a[(r, k)]);
    let rhs = Mat::from_fn(nc, 1, |r, _| {
        velocity[r / 3][r % 3]
            - (0..3 * (n - c))
                .map(|k| a[(r, nc + k)] * free[k / 3][k % 3])
                .sum::<f64>()
    });
    let clamp = a_cc.partial_piv_lu().solve(&rhs);
    if !clamp.is_all_finite() {
        return Err(Error::Numerical(
            "singular clamp block of the mobility matrix".into(),
        ));
    }
    Ok((0..c)
        .map(|i| {
            Vector3::new(
                clamp[(3 * i, 0)],
                clamp[(3 * i + 1, 0)],
                clamp[(3 * i + 2, 0)],
            )
        })
        .chain(free)
        .collect())
}
