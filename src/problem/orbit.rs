//! The rod as an [`ImplicitDynamics`] for the generic shooting of [`crate::engine::periodic`]
//! (docs/model.md section 12): `Z_ff(x) dx_f/dt = R_x(x_f, theta)`, `R_theta = 0`, the free
//! positions differential and the twist algebraic, the rate `omegabar` the parameter. A step of
//! the shooting is the implicit step of the time integrator ([`ImplicitStep`]). Its twist angles
//! are measured in a chart carried from step to step through the period
//! ([`RodDynamics::centred_on`]), as the time integrator carries its own: the collapsed rod's
//! edges turn by up to 180 degrees within a period, where a fixed chart is singular. The size of
//! a displacement is its root mean square over the free nodes, `size(dx)^2 = |dx|^2 / (N - 2)`.

use crate::Result;
use crate::engine::newton::System;
use crate::engine::periodic::{ImplicitDynamics, StepLinearization, StepVelocity};
use crate::model::Model;
use crate::model::rod::frame::Chart;
use crate::model::steady::Steady;
use crate::problem::step::ImplicitStep;
use crate::problem::twist::slave_twist_in;

/// The rod's slaved-twist dynamics in the chart `chart`.
pub struct RodDynamics<'a> {
    pub model: &'a Model,
    pub chart: Chart,
}

impl RodDynamics<'_> {
    fn step(&self, p: f64, v: StepVelocity) -> ImplicitStep<'_> {
        ImplicitStep {
            steady: Steady {
                chart: self.chart.clone(),
                ..Steady::new(self.model, p)
            },
            c0: v.c0,
            offset: v.offset.to_vec(),
        }
    }
}

impl ImplicitDynamics for RodDynamics<'_> {
    fn dim(&self) -> usize {
        self.model.rod.layout.free_len()
    }
    fn differential(&self) -> usize {
        self.model.rod.layout.free_positions()
    }
    fn step_residual(&self, p: f64, v: StepVelocity, u: &[f64]) -> Result<Vec<f64>> {
        self.step(p, v).residual(u)
    }
    fn step_linearize(&self, p: f64, v: StepVelocity, u: &[f64]) -> Result<StepLinearization> {
        self.step(p, v).linearize_with_mass(u)
    }
    fn consistent(&self, _p: f64, u: &[f64]) -> Result<Vec<f64>> {
        slave_twist_in(self.model, &self.chart, u)
    }
    /// The chart transported to `u`'s edges (as the time integrator carries its chart): the
    /// twist angles of `u` are the same in it.
    fn centred_on(&self, u: &[f64]) -> Option<Self> {
        let x = Steady::new(self.model, 0.0).config(u).x;
        Some(RodDynamics {
            model: self.model,
            chart: self.chart.transported(&x),
        })
    }
    fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        Steady {
            chart: self.chart.clone(),
            ..Steady::new(self.model, 0.0)
        }
        .retract(u, du)
    }
    /// Root mean square node displacement: `|dx| / sqrt(N - 2)`.
    fn size(&self, dx: &[f64]) -> f64 {
        crate::engine::newton::norm(dx) / ((dx.len() / 3) as f64).sqrt()
    }
}

/// The mean square amplitude `2 |z|^2 size(q)^2` of an orbit whose normal-form radius is
/// `|z|` (for `q` the complex mode): the factor `2 size(q)^2`.
pub fn amplitude_factor(dynamics: &RodDynamics, mode: &(Vec<f64>, Vec<f64>)) -> f64 {
    2.0 * (dynamics.size(&mode.0).powi(2) + dynamics.size(&mode.1).powi(2))
}
