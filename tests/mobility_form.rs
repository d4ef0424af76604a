//! The overdamped velocity in mobility form, `dx_f/dt = A_ff g_f + A_fc F_c - (Omega X)_f` with
//! the clamp reactions `F_c` (`Steady::free_velocity`, no factorization of `A`), against the
//! resistance form it replaces, `Z_ff^{-1} R_x` with `Z = A^{-1}` factorized, its free-free
//! block formed and factorized in turn: two routes through different linear algebra to one
//! vector, at random states away from equilibrium, on both fluids.

mod common;

use common::{perturbed_natural, relative_max_error};
use faer::Mat;
use faer::prelude::Solve;
use helixbif::continuation::newton::System;
use helixbif::fluid::FluidModel;
use helixbif::model::Model;
use helixbif::params::Physical;
use helixbif::steady::Steady;

/// Largest relative difference of the two velocities at a random state of amplitude `amp` edge
/// lengths about the natural shape.
fn difference(fluid: FluidModel, nodes: usize, omegabar: f64, amp: f64, seed: u64) -> f64 {
    let mut physical = Physical::representative();
    physical.fluid.model = fluid;
    physical.discretization.nodes = nodes;
    let model = Model::new(&physical).unwrap();
    let problem = Steady::new(&model, omegabar);
    let u = perturbed_natural(&model, amp, seed);
    let mobility_form = problem.free_velocity(&u).unwrap();

    let nx = model.rod.layout.free_positions();
    let r = problem.residual(&u).unwrap();
    let x = problem.config(&u).x;
    let n3 = 3 * x.len();
    let first = n3 - nx;
    let z = model
        .fluid
        .resistance(&x, "test")
        .unwrap()
        .solve(Mat::from_fn(n3, nx, |i, c| if i == first + c { 1.0 } else { 0.0 }).as_ref());
    let z_ff = Mat::from_fn(nx, nx, |i, j| z[(first + i, j)]);
    let v = z_ff
        .llt(faer::Side::Lower)
        .unwrap()
        .solve(Mat::from_fn(nx, 1, |i, _| r[i]));
    let resistance_form: Vec<f64> = (0..nx).map(|i| v[(i, 0)]).collect();
    assert_eq!(mobility_form.len(), nx);
    relative_max_error(&mobility_form, &resistance_form)
}

#[test]
fn the_mobility_form_velocity_equals_z_ff_inverse_times_the_residual() {
    for (fluid, nodes, omegabar, amp, seed) in [
        (FluidModel::Lighthill, 30, 150.0, 0.05, 1),
        (FluidModel::Lighthill, 60, 220.0, 0.02, 2),
        (FluidModel::Lighthill, 40, 0.0, 0.05, 3),
        (FluidModel::Rpy, 30, 150.0, 0.05, 4),
        (FluidModel::Rpy, 50, 220.0, 0.2, 5),
    ] {
        let e = difference(fluid, nodes, omegabar, amp, seed);
        println!("{fluid:?} N = {nodes} omegabar = {omegabar}: relative difference {e:.2e}");
        assert!(e < 1e-9, "{fluid:?} N = {nodes}: {e:.2e}");
    }
}
