//! The analytic Jacobian of the co-rotating steady residual (elastic Hessian, gravity and the
//! viscous part `Z (Omega - B)`) against central finite differences of the residual.
//!
//! The elastic entries (stretching, `EA/EI ~ 6e4`) dwarf the viscous ones, so the viscous block
//! is also checked on its own: `J(omega) - J(0)` against finite differences of
//! `G(omega) - G(0)`, relative to its own largest entry.

use crate::common;

use common::{Rng, perturbed_natural, relative_max_error};
use helixbif::engine::newton::System;
use helixbif::model::Model;
use helixbif::model::fluid::FluidModel;
use helixbif::model::params::Physical;
use helixbif::model::steady::Steady;

/// Relative errors of the whole Jacobian, of its viscous part, and of its twist-twist block (each
/// relative to its own largest entry) at a random state.
fn check(fluid: FluidModel, nodes: usize, omegabar: f64, amp: f64, seed: u64) -> (f64, f64, f64) {
    let mut physical = Physical::representative_lighthill();
    physical.fluid.model = fluid;
    physical.discretization.nodes = nodes;
    let model = Model::new(&physical).unwrap();
    let problem = Steady::new(&model, omegabar);
    let still = Steady::new(&model, 0.0);
    let u = perturbed_natural(&model, amp, seed);
    let (_, jac) = problem.residual_and_jacobian(&u).unwrap();
    let (_, jac0) = still.residual_and_jacobian(&u).unwrap();
    let h = 1e-7;
    let (mut analytic, mut numeric) = (Vec::new(), Vec::new());
    let (mut viscous, mut viscous_fd) = (Vec::new(), Vec::new());
    let (mut twist, mut twist_fd) = (Vec::new(), Vec::new());
    let first_angle = model.rod.layout.free_positions();
    for c in 0..u.len() {
        let mut up = u.clone();
        up[c] += h;
        let mut um = u.clone();
        um[c] -= h;
        let (gp, gm) = (
            problem.residual(&up).unwrap(),
            problem.residual(&um).unwrap(),
        );
        let (gp0, gm0) = (still.residual(&up).unwrap(), still.residual(&um).unwrap());
        for r in 0..u.len() {
            analytic.push(jac[(r, c)]);
            numeric.push((gp[r] - gm[r]) / (2.0 * h));
            viscous.push(jac[(r, c)] - jac0[(r, c)]);
            viscous_fd.push((gp[r] - gm[r] - gp0[r] + gm0[r]) / (2.0 * h));
            if r >= first_angle && c >= first_angle {
                twist.push(jac[(r, c)]);
                twist_fd.push((gp[r] - gm[r]) / (2.0 * h));
            }
        }
    }
    let visc_err = if omegabar == 0.0 {
        0.0
    } else {
        relative_max_error(&viscous, &viscous_fd)
    };
    (
        relative_max_error(&analytic, &numeric),
        visc_err,
        relative_max_error(&twist, &twist_fd),
    )
}

fn assert_jacobian(fluid: FluidModel, cases: &[(usize, f64, f64, u64)]) {
    for &(nodes, omegabar, amp, seed) in cases {
        let (err, visc, twist) = check(fluid, nodes, omegabar, amp, seed);
        println!(
            "{fluid:?}, N = {nodes}, omegabar = {omegabar}: relative errors {err:.1e} (all), \
             {visc:.1e} (viscous), {twist:.1e} (twist)"
        );
        assert!(
            twist < 1e-6,
            "N = {nodes}, omegabar = {omegabar}: twist block relative error {twist:e}"
        );
        assert!(
            err < 1e-6,
            "N = {nodes}, omegabar = {omegabar}: relative error {err:e}"
        );
        assert!(
            visc < 1e-6,
            "N = {nodes}, omegabar = {omegabar}: viscous block relative error {visc:e}"
        );
    }
}

#[test]
fn jacobian_matches_finite_differences_with_rotation() {
    assert_jacobian(
        FluidModel::Lighthill,
        &[(20, 125.0, 0.1, 1), (30, 300.0, 0.3, 2), (24, 0.0, 0.2, 3)],
    );
}

/// The same check on the RPY fluid (its `B` enters `Z (Omega - B)`).
#[test]
fn jacobian_matches_finite_differences_on_rpy() {
    assert_jacobian(FluidModel::Rpy, &[(16, 300.0, 0.3, 4)]);
}

/// `G_p = dG/dp` of the rod problem (the parameter column of the bordered system) against
/// central differences of the residual in `p`, at random non-equilibrium states: in the rate
/// `omegabar` (at rest, where the drag is assembled on purpose, and turning) and in the weight.
#[test]
fn parameter_derivatives_match_finite_differences() {
    use helixbif::engine::Problem;
    use helixbif::problem::rod::{Parameter, RodProblem, WEIGHT_SCALE, omega_scale};
    let mut physical = Physical::representative_lighthill();
    physical.discretization.nodes = 24;
    let model = Model::new(&physical).unwrap();
    let mut rng = Rng::new(7);
    let ds = model.rod.rest_lengths[0];
    let cases = [
        (Parameter::Omega, omega_scale(800.0), 0.0, 1e-3),
        (Parameter::Omega, omega_scale(800.0), 150.0, 1e-3),
        // G is linear in the weight: a wide step has no truncation error.
        (Parameter::Weight, WEIGHT_SCALE, 2.0, 0.1),
    ];
    for (parameter, parameter_scale, p, h) in cases {
        let problem = RodProblem::new(&model, parameter, parameter_scale);
        let u: Vec<f64> = problem
            .steady(0.0)
            .free_vector(&model.natural_config())
            .iter()
            .map(|v| v + 0.1 * ds * rng.uniform())
            .collect();
        let analytic = problem.linearize(&u, p).unwrap().g_p;
        let (gp, gm) = (
            problem.residual(&u, p + h).unwrap(),
            problem.residual(&u, p - h).unwrap(),
        );
        let numeric: Vec<f64> = gp
            .iter()
            .zip(&gm)
            .map(|(a, b)| (a - b) / (2.0 * h))
            .collect();
        let err = relative_max_error(&analytic, &numeric);
        assert!(
            err < 1e-7,
            "{parameter:?} at p = {p}: relative error {err:e}"
        );
        // The derivative is not trivially zero.
        assert!(analytic.iter().any(|v| v.abs() > 1e-6), "{parameter:?}");
    }
}
