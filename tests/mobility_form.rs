//! The velocity form of the steady problem against the force balance it premultiplies by
//! `S = Z_ff^{-1}` (docs/model.md sections 4-5), each time through different linear algebra:
//! `Z = A^{-1}` factorized, its free-free block formed and factorized in turn.
//!
//! * The overdamped velocity in mobility form, `dx_f/dt = A_ff g_f + A_fc F_c - (Omega X)_f`
//!   with the clamp reactions `F_c` (`Steady::free_velocity`, no factorization of `A`), against
//!   `Z_ff^{-1} R_x`, at random states away from equilibrium, on both fluids.
//! * The Jacobian of the velocity form (`Steady::linearize_velocity`, eq. 5, built from `S`, `B`
//!   and the Hessian band by band) against `Z_ff^{-1}` times central differences of `R`, at
//!   random states; and against central differences of `V` itself at a steady state, where the
//!   two derivatives agree.
//! * The stability pair made from it against the pair of the force balance's Jacobian.

use crate::common;

use common::{perturbed_natural, relative_max_error};
use faer::Mat;
use faer::prelude::Solve;
use helixbif::model::Model;
use helixbif::model::fluid::FluidModel;
use helixbif::model::params::Physical;
use helixbif::model::steady::Steady;

fn model(fluid: FluidModel, nodes: usize) -> Model {
    let mut physical = Physical::representative_lighthill();
    physical.fluid.model = fluid;
    physical.discretization.nodes = nodes;
    Model::new(&physical).unwrap()
}

/// `Z_ff`, the free-free block of `Z = A^{-1}` at the state `u`, by solving with the free
/// columns of the identity.
fn z_ff(problem: &Steady, u: &[f64]) -> Mat<f64> {
    let nx = problem.model.rod.layout.free_positions();
    let x = problem.config(u).x;
    let n3 = 3 * x.len();
    let first = n3 - nx;
    let z = problem
        .model
        .fluid
        .resistance(&x, "test")
        .unwrap()
        .solve(Mat::from_fn(n3, nx, |i, c| if i == first + c { 1.0 } else { 0.0 }).as_ref());
    Mat::from_fn(nx, nx, |i, j| z[(first + i, j)])
}

/// Largest relative difference of the two velocities at a random state of amplitude `amp` edge
/// lengths about the natural shape.
fn difference(fluid: FluidModel, nodes: usize, omegabar: f64, amp: f64, seed: u64) -> f64 {
    let model = model(fluid, nodes);
    let problem = Steady::new(&model, omegabar);
    let u = perturbed_natural(&model, amp, seed);
    let mobility_form = problem.free_velocity(&u).unwrap();

    let nx = model.rod.layout.free_positions();
    let r = problem.residual(&u).unwrap();
    let v = z_ff(&problem, &u)
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

/// Central differences (step `h`) of `f` at `u`, column by column.
fn differences(u: &[f64], h: f64, f: impl Fn(&[f64]) -> Vec<f64>) -> Mat<f64> {
    let n = u.len();
    let mut out = Mat::zeros(f(u).len(), n);
    for c in 0..n {
        let (mut up, mut um) = (u.to_vec(), u.to_vec());
        up[c] += h;
        um[c] -= h;
        let (fp, fm) = (f(&up), f(&um));
        for r in 0..fp.len() {
            out[(r, c)] = (fp[r] - fm[r]) / (2.0 * h);
        }
    }
    out
}

/// `Z_ff^{-1}` applied to the position rows of `m`, the twist rows kept.
fn premultiplied(z_ff: &Mat<f64>, m: &Mat<f64>) -> Mat<f64> {
    let nx = z_ff.nrows();
    let top = z_ff
        .partial_piv_lu()
        .solve(m.submatrix(0, 0, nx, m.ncols()).to_owned());
    Mat::from_fn(m.nrows(), m.ncols(), |r, c| {
        if r < nx { top[(r, c)] } else { m[(r, c)] }
    })
}

fn entries(m: &Mat<f64>) -> Vec<f64> {
    (0..m.ncols())
        .flat_map(|c| (0..m.nrows()).map(move |r| (r, c)))
        .map(|(r, c)| m[(r, c)])
        .collect()
}

/// The velocity form's Newton Jacobian is `S R'` (eq. 5): against `Z_ff^{-1}` times central
/// differences of the force balance `R`, whole and in its viscous part (`J(omega) - J(0)`,
/// relative to its own largest entry: the stretching stiffness dwarfs it), at random states
/// away from equilibrium; its residual is `V`, as `Steady::velocity_residual` computes it by
/// eq. (4).
#[test]
fn the_velocity_jacobian_is_s_times_the_jacobian_of_the_force_balance() {
    for (fluid, nodes, omegabar, amp, seed) in [
        (FluidModel::Lighthill, 20, 125.0, 0.1, 11),
        (FluidModel::Lighthill, 24, 0.0, 0.2, 12),
        (FluidModel::Rpy, 16, 300.0, 0.3, 13),
    ] {
        let model = model(fluid, nodes);
        let (turning, still) = (Steady::new(&model, omegabar), Steady::new(&model, 0.0));
        let u = perturbed_natural(&model, amp, seed);
        let z = z_ff(&turning, &u);
        let h = 1e-7;
        let lin = turning.linearize_velocity(&u).unwrap();
        let fd = premultiplied(&z, &differences(&u, h, |v| turning.residual(v).unwrap()));
        let whole = relative_max_error(&entries(&lin.jacobian), &entries(&fd));
        let viscous = if omegabar == 0.0 {
            0.0
        } else {
            let lin0 = still.linearize_velocity(&u).unwrap();
            let fd0 = premultiplied(&z, &differences(&u, h, |v| still.residual(v).unwrap()));
            relative_max_error(
                &entries(&(&lin.jacobian - &lin0.jacobian)),
                &entries(&(&fd - &fd0)),
            )
        };
        let residual = relative_max_error(&lin.residual, &turning.velocity_residual(&u).unwrap());
        println!(
            "{fluid:?} N = {nodes} omegabar = {omegabar}: relative errors {whole:.1e} (all), \
             {viscous:.1e} (viscous), residual {residual:.1e}"
        );
        assert!(whole < 1e-6, "{fluid:?} N = {nodes}: {whole:.1e}");
        assert!(
            viscous < 1e-6,
            "{fluid:?} N = {nodes}: viscous {viscous:.1e}"
        );
        assert!(
            residual < 1e-9,
            "{fluid:?} N = {nodes}: residual {residual:.1e}"
        );
    }
}

/// At a steady state (`R = 0`) the Newton Jacobian is the derivative of `V` itself: against
/// central differences of `V` (eq. 4, through the clamp reactions), where away from equilibrium
/// they differ by the curvature of `S(X)` times the force residual.
#[test]
fn at_a_steady_state_the_velocity_jacobian_is_the_derivative_of_the_velocity() {
    use helixbif::engine::newton::NewtonSettings;
    for (fluid, nodes, omega) in [(FluidModel::Lighthill, 30, 0.4), (FluidModel::Rpy, 20, 0.4)] {
        let model = model(fluid, nodes);
        let omegabar = model.scales.omega_to_bar(omega);
        let solution =
            helixbif::analysis::solve::solve_at(&model, omegabar, &NewtonSettings::default())
                .unwrap()
                .state;
        let problem = Steady {
            model: &model,
            omega: omegabar,
            weight: solution.weight,
            chart: solution.chart.clone(),
        };
        let u = problem.free_vector(&solution.config);
        let lin = problem.linearize_velocity(&u).unwrap();
        let fd = differences(&u, 1e-7, |v| problem.velocity_residual(v).unwrap());
        let err = relative_max_error(&entries(&lin.jacobian), &entries(&fd));
        println!("{fluid:?} N = {nodes} at a steady state: relative error {err:.1e}");
        assert!(err < 1e-6, "{fluid:?} N = {nodes}: {err:.1e}");
    }
}

/// The stability pair from the velocity form's blocks (`M = S^{-1}`,
/// `K = -H_xx + H_xt H_tt^{-1} H_tx + M W`) against the one of the force balance: `K` with the
/// twist eliminated from `R'` ([`Steady::linearize`], eq. 3), `M = Z_ff` from the factorized `Z`,
/// at random states (the identity holds everywhere, not only at equilibria).
#[test]
fn the_stability_pair_from_the_velocity_form_is_that_of_the_force_balance() {
    for (fluid, nodes, omegabar, amp, seed) in [
        (FluidModel::Lighthill, 30, 200.0, 0.05, 21),
        (FluidModel::Rpy, 24, 200.0, 0.1, 22),
    ] {
        let model = model(fluid, nodes);
        let problem = Steady::new(&model, omegabar);
        let u = perturbed_natural(&model, amp, seed);
        let (k, m) = problem.stability_pair(&u).unwrap();
        let j = problem.linearize(&u).unwrap().jacobian;
        let nx = model.rod.layout.free_positions();
        let nt = j.nrows() - nx;
        let eliminated = j
            .submatrix(nx, nx, nt, nt)
            .partial_piv_lu()
            .solve(j.submatrix(nx, 0, nt, nx).to_owned());
        let k_force = j.submatrix(0, 0, nx, nx) - j.submatrix(0, nx, nx, nt) * &eliminated;
        let m_force = z_ff(&problem, &u);
        let (ek, em) = (
            relative_max_error(&entries(&k), &entries(&k_force)),
            relative_max_error(&entries(&m), &entries(&m_force)),
        );
        println!("{fluid:?} N = {nodes}: K {ek:.1e}, M {em:.1e}");
        assert!(
            ek < 1e-9 && em < 1e-9,
            "{fluid:?} N = {nodes}: K {ek:.1e}, M {em:.1e}"
        );
    }
}
