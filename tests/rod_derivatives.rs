//! Discrete Elastic Rods: the exact gradient and Hessian against central finite differences,
//! invariance of the energy under rigid motions, and a stress-free natural shape.

use crate::common;

use common::{Rng, helix, relative_max_error};
use helixbif::model::rod::frame::Chart;
use helixbif::model::rod::{Config, Rod, Stiffness};
use nalgebra::{Rotation3, Vector3};

const STIFFNESS: Stiffness = Stiffness {
    ea: 4.0e3,
    ei: 1.0,
    gj: 2.0 / 3.0,
};

/// The representative helix (radius 0.0795, pitch 0.25, units of l) and a random perturbation
/// of its nodes and angles of relative size `amp`.
fn perturbed(nodes: usize, amp: f64, seed: u64) -> (Rod, Chart, Config) {
    let natural = helix(nodes, 0.0795, 0.25, -1.0);
    let (rod, chart) = Rod::new(&natural, STIFFNESS);
    let mut rng = Rng::new(seed);
    let ds = rod.rest_lengths[0];
    let config = Config {
        x: natural
            .iter()
            .map(|p| p + rng.vector() * amp * ds)
            .collect(),
        theta: (0..nodes - 1).map(|_| rng.uniform() * amp).collect(),
    };
    (rod, chart, config)
}

/// Reads and writes entry `p` of the full configuration vector.
fn set(config: &mut Config, rod: &Rod, p: usize, value: f64) {
    let n = rod.layout.nodes();
    if p < 3 * n {
        config.x[p / 3][p % 3] = value;
    } else {
        config.theta[p - 3 * n] = value;
    }
}

fn get(config: &Config, rod: &Rod, p: usize) -> f64 {
    let n = rod.layout.nodes();
    if p < 3 * n {
        config.x[p / 3][p % 3]
    } else {
        config.theta[p - 3 * n]
    }
}

fn fd_gradient(rod: &Rod, config: &Config, chart: &Chart, h: f64) -> Vec<f64> {
    (0..rod.layout.full_len())
        .map(|p| {
            let mut c = config.clone();
            let v = get(config, rod, p);
            set(&mut c, rod, p, v + h);
            let ep = rod.energy(&c, chart);
            set(&mut c, rod, p, v - h);
            let em = rod.energy(&c, chart);
            (ep - em) / (2.0 * h)
        })
        .collect()
}

#[test]
fn gradient_matches_finite_differences_on_perturbed_helices() {
    for (seed, amp) in [(1, 0.05), (2, 0.2), (3, 0.4)] {
        let (rod, chart, config) = perturbed(24, amp, seed);
        let g = rod.gradient(&config, &chart);
        let fd = fd_gradient(&rod, &config, &chart, 1e-6);
        let err = relative_max_error(&g, &fd);
        assert!(err < 1e-6, "seed {seed}: gradient relative error {err:e}");
    }
}

#[test]
fn hessian_matches_finite_differences_of_the_gradient() {
    // Non-equilibrium states; the chart is the natural one (source frame != current frame) in
    // the first case and the perturbed configuration's own transported chart in the second.
    for (seed, amp, own_chart) in [(4, 0.1, false), (5, 0.3, true), (6, 0.3, false)] {
        let (rod, natural_chart, config) = perturbed(20, amp, seed);
        let chart = if own_chart {
            natural_chart.transported(&config.x)
        } else {
            natural_chart
        };
        let (g, h) = rod.hessian(&config, &chart);
        let g_only = rod.gradient(&config, &chart);
        assert!(relative_max_error(&g, &g_only) < 1e-14);
        let n = rod.layout.full_len();
        let step = 1e-6;
        let mut analytic = Vec::with_capacity(n * n);
        let mut numeric = Vec::with_capacity(n * n);
        for q in 0..n {
            let mut c = config.clone();
            let v = get(&config, &rod, q);
            set(&mut c, &rod, q, v + step);
            let gp = rod.gradient(&c, &chart);
            set(&mut c, &rod, q, v - step);
            let gm = rod.gradient(&c, &chart);
            for p in 0..n {
                analytic.push(h[(p, q)]);
                numeric.push((gp[p] - gm[p]) / (2.0 * step));
            }
        }
        let err = relative_max_error(&analytic, &numeric);
        assert!(err < 1e-6, "seed {seed}: Hessian relative error {err:e}");
        // Symmetry.
        let asym = (0..n)
            .flat_map(|p| (0..n).map(move |q| (p, q)))
            .fold(0.0f64, |m, (p, q)| m.max((h[(p, q)] - h[(q, p)]).abs()));
        assert!(asym < 1e-9, "Hessian asymmetry {asym:e}");
    }
}

#[test]
fn energy_is_invariant_under_rigid_motions() {
    let (rod, chart, config) = perturbed(30, 0.3, 7);
    let e = rod.energy(&config, &chart);
    let rotation = Rotation3::from_axis_angle(
        &nalgebra::Unit::new_normalize(Vector3::new(0.3, -1.0, 0.4)),
        1.1,
    );
    let shift = Vector3::new(0.7, -0.2, 1.5);
    let moved: Vec<Vector3<f64>> = config.x.iter().map(|p| rotation * p + shift).collect();
    // The chart moves with the rod (directors rotated with it), angles unchanged.
    let moved_chart = Chart {
        tangents: chart.tangents.iter().map(|t| rotation * t).collect(),
        directors: chart.directors.iter().map(|d| rotation * d).collect(),
        ref_twist: chart.ref_twist.clone(),
    };
    let moved_config = Config {
        x: moved,
        theta: config.theta.clone(),
    };
    let e_moved = rod.energy(&moved_config, &moved_chart);
    assert!((e - e_moved).abs() < 1e-12 * e, "{e} vs {e_moved}");
    // Translation alone with the unchanged chart.
    let shifted = Config {
        x: config.x.iter().map(|p| p + shift).collect(),
        theta: config.theta.clone(),
    };
    assert!((rod.energy(&shifted, &chart) - e).abs() < 1e-12 * e);
}

#[test]
fn natural_shape_is_stress_free() {
    for nodes in [10, 40, 80] {
        let natural = helix(nodes, 0.0795, 0.25, 1.0);
        let (rod, chart) = Rod::new(&natural, STIFFNESS);
        let config = Config {
            x: natural,
            theta: vec![0.0; nodes - 1],
        };
        assert!(rod.energy(&config, &chart).abs() < 1e-20);
        let g = rod.gradient(&config, &chart);
        let max = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(max < 1e-10, "nodes {nodes}: elastic force {max:e}");
        // The integrated discrete curvature |kb| is 2 tan(psi/2), psi the turning angle
        // between chords.
        let i = nodes / 2;
        let (e0, e1) = (config.x[i] - config.x[i - 1], config.x[i + 1] - config.x[i]);
        let psi = e0.angle(&e1);
        let k = rod.kappa_bar[i];
        let discrete = (k[0] * k[0] + k[1] * k[1]).sqrt();
        let expected = 2.0 * (psi / 2.0).tan();
        assert!((discrete - expected).abs() < 1e-12 * expected);
        assert!(rod.twist_bar.iter().all(|m| m.abs() < 1e-12));
    }
}

#[test]
fn natural_curvature_converges_to_the_helix_curvature_at_second_order() {
    // Continuous helix: kappa = R / (R^2 + c^2), c = pitch / (2 pi).
    let c = 0.25 / (2.0 * std::f64::consts::PI);
    let kappa = 0.0795 / (0.0795 * 0.0795 + c * c);
    let error = |nodes: usize| {
        let (rod, _) = Rod::new(&helix(nodes, 0.0795, 0.25, 1.0), STIFFNESS);
        let k = rod.kappa_bar[nodes / 2];
        let curvature = (k[0] * k[0] + k[1] * k[1]).sqrt() / rod.weights[nodes / 2];
        (curvature - kappa).abs() / kappa
    };
    let (e1, e2) = (error(41), error(81));
    // Halving the spacing divides the error by about 4 (second order).
    assert!(e1 < 0.05 && (e1 / e2 - 4.0).abs() < 0.4, "{e1} {e2}");
}
