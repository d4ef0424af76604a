//! Steady states against exact statements: linearity and mirror symmetry of the rigid-helix
//! thrust, quadratic convergence of Newton's method, and the `solve` pipeline on the default.

use helixbif::continuation::newton::NewtonSettings;
use helixbif::model::Model;
use helixbif::params::{Handedness, Physical, ShapeParams};
use helixbif::solve::solve_at;
use helixbif::steady::{self, height};

fn helix(handedness: Handedness, nodes: usize) -> Model {
    let mut p = Physical::representative();
    p.discretization.nodes = nodes;
    if let ShapeParams::Helix { handedness: h, .. } = &mut p.shape {
        *h = handedness;
    }
    Model::new(&p).unwrap()
}

#[test]
fn rigid_helix_thrust_is_linear_in_omega_and_flips_with_handedness() {
    let right = helix(Handedness::Right, 40);
    let left = helix(Handedness::Left, 40);
    let f1 = right.rigid_thrust(10.0).unwrap();
    let f2 = right.rigid_thrust(25.0).unwrap();
    let fm = right.rigid_thrust(-10.0).unwrap();
    // F = Z(X) Omega X with X fixed: exactly linear in omega (to round-off).
    assert!((f2 / f1 - 2.5).abs() < 1e-12, "{f1} {f2}");
    assert!((fm + f1).abs() < 1e-12 * f1.abs());
    // The left helix is the mirror image (y -> -y) of the right one; the mirror turns the
    // rotation the other way, so its thrust is exactly opposite.
    let fl = left.rigid_thrust(10.0).unwrap();
    assert!((fl + f1).abs() < 1e-10 * f1.abs(), "right {f1}, left {fl}");
    // The convention of docs/model.md section 6: the default (right-handed) helix pushes, F_p > 0.
    assert!(f1 > 0.0);
}

/// True when the tail of a residual history converges quadratically: each residual between
/// 1e-1 and 1e-8 is followed by one below `c r^2` (with the round-off floor allowed for).
fn quadratic_tail(history: &[f64], c: f64) -> bool {
    let floor = 1e-9;
    let pairs: Vec<(f64, f64)> = history
        .windows(2)
        .map(|w| (w[0], w[1]))
        .filter(|(r, _)| *r < 1e-1 && *r > 1e-8)
        .collect();
    !pairs.is_empty() && pairs.iter().all(|(r, next)| *next <= c * r * r + floor)
}

#[test]
fn newton_converges_quadratically() {
    let model = helix(Handedness::Right, 40);
    let settings = NewtonSettings::default();
    let rest = steady::solve(
        &model,
        0.0,
        model.weight,
        &model.natural_config(),
        &model.chart,
        &settings,
    )
    .unwrap();
    assert!(rest.report.residual_norm < 1e-9);
    assert!(
        quadratic_tail(&rest.report.history, 10.0),
        "{:?}",
        rest.report.history
    );
    // A rotating state reached from rest in small steps, then a step of omegabar 10.
    let mut state = rest;
    for omega in [5.0, 10.0, 20.0] {
        state = steady::solve(
            &model,
            omega,
            model.weight,
            &state.config,
            &state.chart,
            &settings,
        )
        .unwrap();
        assert!(
            quadratic_tail(&state.report.history, 10.0),
            "omegabar {omega}: {:?}",
            state.report.history
        );
        assert!(
            state.report.iterations <= 6,
            "omegabar {omega}: {} iterations",
            state.report.iterations
        );
    }
}

#[test]
fn solve_default_at_0_3_rad_per_s() {
    let model = Model::new(&Physical::representative()).unwrap();
    let omegabar = model.scales.omega_to_bar(0.3);
    let solution = solve_at(&model, omegabar, &NewtonSettings::default()).unwrap();
    let o = &solution.observables;
    assert!(solution.state.report.residual_norm < 1e-9);
    assert!(quadratic_tail(&solution.state.report.history, 10.0));
    assert!((o.omega - 0.3).abs() < 1e-15);
    // The flexible helix pushes, but less than the rigid one, and hangs lower as it turns.
    assert!(
        o.fpbar > 0.0 && o.fpbar < solution.fpbar_rigid,
        "{} vs rigid {}",
        o.fpbar,
        solution.fpbar_rigid
    );
    assert!(o.hbar > 1.0 && o.hbar < 1.2, "hbar {}", o.hbar);
    // SI and normalized values agree through the scales.
    assert!((o.fp - o.fpbar * model.scales.force).abs() < 1e-15);
    assert!((o.h0 - height(&solution.rest.config.x) * model.scales.length).abs() < 1e-15);
}

#[test]
fn rest_state_has_no_thrust_and_unit_height_ratio() {
    let model = helix(Handedness::Right, 30);
    let solution = solve_at(&model, 0.0, &NewtonSettings::default()).unwrap();
    assert_eq!(solution.observables.fp, 0.0);
    assert_eq!(solution.observables.hbar, 1.0);
    assert!(solution.observables.eta.is_none());
    // Gravity (net weight, rho_r > rho_f) stretches the hanging helix below its natural height.
    assert!(solution.observables.h0 > 0.2);
}
