//! Statics against a classic: a horizontal cantilever bending under its own weight (large
//! deflection), compared with the elastica computed independently here by a shooting method.
//!
//! Elastica (arclength `s` in units of `L`, angle `theta` below the horizontal,
//! `w = q L^3 / EI`): `theta'' = -w (1 - s) cos(theta)`, `theta(0) = 0`, `theta'(1) = 0`
//! (no moment at the free end). Tip drop `int_0^1 sin(theta) ds`, reach `int_0^1 cos(theta) ds`.

use crate::common;

use common::straight_rod;
use helixbif::engine::newton::NewtonSettings;
use helixbif::model::Model;
use helixbif::problem::steady;

/// Integrates the elastica by RK4 from `theta'(0) = k`; returns `(theta'(1), drop, reach)`.
fn integrate(w: f64, k: f64, steps: usize) -> (f64, f64, f64) {
    let h = 1.0 / steps as f64;
    // State: theta, theta', drop, reach.
    let f = |s: f64, y: [f64; 4]| [y[1], -w * (1.0 - s) * y[0].cos(), y[0].sin(), y[0].cos()];
    let mut y = [0.0, k, 0.0, 0.0];
    for i in 0..steps {
        let s = i as f64 * h;
        let add = |a: [f64; 4], b: [f64; 4], c: f64| {
            std::array::from_fn::<f64, 4, _>(|j| a[j] + c * b[j])
        };
        let k1 = f(s, y);
        let k2 = f(s + h / 2.0, add(y, k1, h / 2.0));
        let k3 = f(s + h / 2.0, add(y, k2, h / 2.0));
        let k4 = f(s + h, add(y, k3, h));
        y = std::array::from_fn(|j| y[j] + h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]));
    }
    (y[1], y[2], y[3])
}

/// Tip drop and reach of the elastica, by secant iteration on `theta'(0)`.
fn elastica(w: f64) -> (f64, f64) {
    let steps = 4000;
    let (mut k0, mut k1) = (0.5 * w, 0.4 * w);
    let (mut r0, _, _) = integrate(w, k0, steps);
    for _ in 0..50 {
        let (r1, drop, reach) = integrate(w, k1, steps);
        if r1.abs() < 1e-13 {
            return (drop, reach);
        }
        let k2 = k1 - r1 * (k1 - k0) / (r1 - r0);
        (k0, r0, k1) = (k1, r1, k2);
    }
    panic!("shooting did not converge");
}

/// Relative errors of the discrete tip drop and reach at `nodes` nodes.
fn discrete_errors(w: f64, nodes: usize, reference: (f64, f64)) -> (f64, f64) {
    let physical = straight_rod(0.1, 1e-4, 90.0, nodes);
    let model = Model::new(&physical).unwrap();
    // Load ramp in the weight (large deflection from a straight start).
    let settings = NewtonSettings::default();
    let mut state = steady::solve(
        &model,
        0.0,
        0.0,
        &model.natural_config(),
        &model.chart,
        &settings,
    )
    .unwrap();
    for k in 1..=8 {
        let weight = w * k as f64 / 8.0;
        state = steady::solve(&model, 0.0, weight, &state.config, &state.chart, &settings).unwrap();
    }
    let tip = state.config.x[nodes - 1];
    let (drop, reach) = (-tip.z, tip.x);
    (
        (drop - reference.0).abs() / reference.0,
        (reach - reference.1).abs() / reference.1,
    )
}

#[test]
fn cantilever_under_own_weight_matches_the_elastica() {
    let w = 5.0;
    let reference = elastica(w);
    // Sanity of the reference: the small-deflection limit w/8 and a large-deflection drop.
    let small = elastica(0.01);
    assert!((small.0 - 0.01 / 8.0).abs() < 1e-4 * 0.01 / 8.0);
    assert!(reference.0 > 0.45 && reference.0 < 0.55, "{reference:?}");
    let errors: Vec<(f64, f64)> = [50, 100, 200]
        .iter()
        .map(|&n| discrete_errors(w, n, reference))
        .collect();
    println!(
        "elastica w = {w}: drop {:.6}, reach {:.6}; relative errors (drop, reach) at N = 50, 100, 200: {errors:.3?}",
        reference.0, reference.1
    );
    // Within 1% at N = 200.
    assert!(errors[2].0 < 0.01 && errors[2].1 < 0.01, "{errors:?}");
    // First order or better: halving the spacing at least roughly halves the error.
    for pair in errors.windows(2) {
        assert!(pair[1].0 < 0.6 * pair[0].0, "{errors:?}");
    }
}
