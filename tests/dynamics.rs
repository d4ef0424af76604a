//! Time integration of the overdamped rod (`helixbif::analysis::dynamics`) against the linear stability
//! analysis and the steady solver, on the representative helix at a small node count:
//!
//! 1. the Jacobian of one implicit step against finite differences (and its mass-matrix part,
//!    and the shape derivative of `Z_ff` on its own);
//! 2. a small perturbation along the least stable mode decays (below `omega_b`) or grows (above)
//!    at `Re s` and turns at `Im s`;
//! 3. a spin-up from rest settles on the steady state of `solve_at`;
//! 4. BDF2 converges at second order with fixed steps, the clamp staying exact;
//! 5. `bisect` brackets the Hopf point found by `locate`.

use crate::common;

use std::f64::consts::PI;
use std::ops::ControlFlow;

use common::{Rng, relative_max_error};
use faer::c64;
use helixbif::analysis::branch::observables_at;
use helixbif::analysis::dynamics::{
    BisectSettings, Checkpoints, DynamicsSettings, IntegratorState, Rate, Start, bisect, integrate,
    integrate_from, least_stable_mode, perturb,
};
use helixbif::analysis::locate::{LocateSettings, locate};
use helixbif::analysis::solve::rest_state;
use helixbif::analysis::solve::solve_at;
use helixbif::engine::ContinuationSettings;
use helixbif::engine::events::EventKind;
use helixbif::engine::newton::{NewtonSettings, System, norm};
use helixbif::engine::stability::spectrum;
use helixbif::engine::stop::Silent;
use helixbif::model::Model;
use helixbif::model::params::Physical;
use helixbif::model::rod::frame::Chart;
use helixbif::model::rod::frame::rechart;
use helixbif::model::steady::Steady;
use helixbif::problem::step::ImplicitStep;
use helixbif::problem::twist::{natural_chart_unknowns, slave_twist_in};
use helixbif::study::IntegratorTable;

/// The representative helix with `nodes` nodes, in the process configuration of the command-line
/// tool (no threads inside a small factorization).
fn helix(nodes: usize) -> Model {
    helixbif::numerics::process::configure();
    let mut physical = Physical::representative_lighthill();
    physical.discretization.nodes = nodes;
    Model::new(&physical).unwrap()
}

/// `omegabar_b` of the model, checked to be a Hopf point.
fn hopf(model: &Model) -> f64 {
    let (located, event) = locate(
        model,
        &LocateSettings {
            omega_max: 2.0,
            newton: &NewtonSettings::default(),
            continuation: &ContinuationSettings::default(),
            criticality: true,
        },
        &mut Silent,
    )
    .unwrap();
    let event = event.unwrap().event;
    assert_eq!(event.kind, EventKind::Hopf, "{located:?}");
    event.p
}

/// Central finite differences of `f` over the first `columns` unknowns of `u`, row-major
/// `rows x columns`.
fn finite_differences(
    u: &[f64],
    columns: usize,
    f: impl Fn(&[f64]) -> Vec<f64>,
) -> (usize, Vec<f64>) {
    let h = 1e-7;
    let mut cols = Vec::new();
    for c in 0..columns {
        let (mut up, mut um) = (u.to_vec(), u.to_vec());
        up[c] += h;
        um[c] -= h;
        let (fp, fm) = (f(&up), f(&um));
        cols.push(
            fp.iter()
                .zip(&fm)
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect::<Vec<_>>(),
        );
    }
    let rows = cols[0].len();
    let mut out = Vec::with_capacity(rows * columns);
    for r in 0..rows {
        for col in &cols {
            out.push(col[r]);
        }
    }
    (rows, out)
}

fn entries(m: &faer::Mat<f64>) -> Vec<f64> {
    (0..m.nrows())
        .flat_map(|r| (0..m.ncols()).map(move |c| m[(r, c)]))
        .collect()
}

#[test]
fn step_jacobian_matches_finite_differences() {
    let model = helix(20);
    let omega = 300.0;
    let steady = Steady::new(&model, omega);
    let nx = model.rod.layout.free_positions();
    let ds = model.rod.rest_lengths[0];
    let mut rng = Rng::new(7);
    // A non-equilibrium state and a previous one, as in a step of size dt.
    let base = steady.free_vector(&model.natural_config());
    let u: Vec<f64> = base.iter().map(|v| v + 0.1 * ds * rng.uniform()).collect();
    let previous: Vec<f64> = u[..nx]
        .iter()
        .map(|v| v + 0.01 * ds * rng.uniform())
        .collect();
    let dt = 1e-3;
    let step = ImplicitStep {
        steady: steady.clone(),
        c0: 1.0 / dt,
        offset: previous.iter().map(|x| -x / dt).collect(),
    };

    // The whole step Jacobian.
    let (_, jac) = step.residual_and_jacobian(&u).unwrap();
    let (_, fd) = finite_differences(&u, u.len(), |v| step.residual(v).unwrap());
    let whole = relative_max_error(&entries(&jac), &fd);

    // Its mass-matrix part d[Z_ff(x) v(x)]/dx = c0 Z_ff + d(Z_ff)[v], on its own.
    let mass = step.motion_jacobian(&u).unwrap();
    let (_, fd_mass) = finite_differences(&u, nx, |v| step.motion_force(v).unwrap());
    let mass_err = relative_max_error(&entries(&mass), &fd_mass);

    // The shape derivative of Z_ff alone, -[Z B(X; Z V)]_ff: velocity held fixed (c0 = 0).
    let velocity: Vec<f64> = u[..nx]
        .iter()
        .zip(&previous)
        .map(|(a, b)| (a - b) / dt)
        .collect();
    let frozen = ImplicitStep {
        steady: steady.clone(),
        c0: 0.0,
        offset: velocity,
    };
    let shape = frozen.motion_jacobian(&u).unwrap();
    let (_, fd_shape) = finite_differences(&u, nx, |v| frozen.motion_force(v).unwrap());
    let shape_err = relative_max_error(&entries(&shape), &fd_shape);
    let size = |m: &faer::Mat<f64>| entries(m).iter().fold(0.0f64, |a, b| a.max(b.abs()));
    println!(
        "relative errors: step Jacobian {whole:.2e} (largest entry {:.2e}), mass part {mass_err:.2e} \
         (largest {:.2e}), shape derivative of Z_ff {shape_err:.2e} (largest {:.2e})",
        size(&jac),
        size(&mass),
        size(&shape)
    );
    assert!(whole < 1e-6, "step Jacobian: {whole:e}");
    assert!(mass_err < 1e-6, "mass-matrix part: {mass_err:e}");
    assert!(shape_err < 1e-6, "shape derivative of Z_ff: {shape_err:e}");
}

/// Integrates a perturbation of amplitude `1e-4` (in `ell`) along the least stable mode at
/// `fraction * omega_b` and fits `ln a(t)` (the complex modal amplitude) against `t`: returns
/// (fitted `s`, predicted `s`).
fn modal_rate(fraction: f64, t_end: f64) -> (c64, c64) {
    let model = helix(20);
    let omega = fraction * hopf(&model);
    let solution = solve_at(&model, omega, &NewtonSettings::default()).unwrap();
    let us = natural_chart_unknowns(&model, &solution.state.config, &solution.state.chart).unwrap();
    let steady = Steady::new(&model, omega);
    let residual = norm(&steady.residual(&us).unwrap());
    assert!(
        residual < 1e-8,
        "steady state in the natural chart: {residual:e}"
    );
    let mode = least_stable_mode(&model, omega, &us).unwrap();
    assert!(mode.is_complex(), "{:?}", mode.eigenvalue);
    // The same eigenvalue as the stability module's.
    let (k, m) = steady.stability_pair(&us).unwrap();
    let leading = spectrum(&k, &m, 4).unwrap().leading[0];
    assert!((leading.re - mode.eigenvalue.re).abs() < 1e-8 * leading.norm());
    assert!((leading.im.abs() - mode.eigenvalue.im).abs() < 1e-8 * leading.norm());

    let amplitude = 1e-4;
    let u0 = perturb(&model, &us, &mode, amplitude, 0.0).unwrap();
    let nx = model.rod.layout.free_positions();
    let a0 = mode.amplitude(
        &u0[..nx]
            .iter()
            .zip(&us)
            .map(|(a, b)| a - b)
            .collect::<Vec<_>>(),
    );
    assert!(
        (a0 - c64::new(amplitude, 0.0)).norm() < 1e-2 * amplitude,
        "{a0:?}"
    );
    let settings = DynamicsSettings {
        rtol: 0.0,
        atol: 1e-11,
        ..DynamicsSettings::default()
    };
    let mut record = Vec::new();
    let run = integrate(&model, Rate::Fixed(omega), u0, t_end, &settings, |s| {
        let dx: Vec<f64> = (0..nx).map(|i| s.u[i] - us[i]).collect();
        record.push((s.t, mode.amplitude(&dx)));
        ControlFlow::Continue(())
    })
    .unwrap();
    println!(
        "omega = {fraction} omega_b: {} steps, {} rejected, {} Newton iterations",
        run.steps, run.rejected, run.newton_iterations
    );
    // Least squares on t >= t_end/10 (after the other modes, excited at second order by the
    // finite amplitude and the twist, have decayed), the phase unwrapped.
    let mut phase_offset = 0.0;
    let mut previous = record[0].1.arg();
    let mut points = Vec::new();
    for &(t, a) in &record {
        let mut jump = a.arg() - previous;
        while jump > PI {
            jump -= 2.0 * PI;
            phase_offset -= 2.0 * PI;
        }
        while jump < -PI {
            jump += 2.0 * PI;
            phase_offset += 2.0 * PI;
        }
        previous = a.arg();
        if t >= 0.1 * t_end {
            points.push((t, a.norm().ln(), a.arg() + phase_offset));
        }
    }
    let slope = |y: &dyn Fn(&(f64, f64, f64)) -> f64| {
        let n = points.len() as f64;
        let mt = points.iter().map(|p| p.0).sum::<f64>() / n;
        let my = points.iter().map(y).sum::<f64>() / n;
        let sxy: f64 = points.iter().map(|p| (p.0 - mt) * (y(p) - my)).sum();
        let sxx: f64 = points.iter().map(|p| (p.0 - mt).powi(2)).sum();
        sxy / sxx
    };
    let fitted = c64::new(slope(&|p| p.1), slope(&|p| p.2));
    // Still linear: the amplitude stayed small.
    let largest = record.iter().map(|r| r.1.norm()).fold(0.0, f64::max);
    assert!(largest < 3.0 * amplitude, "amplitude grew to {largest:e}");
    (fitted, mode.eigenvalue)
}

#[test]
fn perturbation_decays_at_the_predicted_rate_below_omega_b() {
    let (fitted, predicted) = modal_rate(0.8, 0.04);
    println!("0.8 omega_b: fitted s = {fitted}, predicted s = {predicted}");
    assert!(predicted.re < 0.0);
    assert!((fitted.re / predicted.re - 1.0).abs() < 0.05);
    assert!((fitted.im / predicted.im - 1.0).abs() < 0.05);
}

#[test]
fn perturbation_grows_at_the_predicted_rate_above_omega_b() {
    let (fitted, predicted) = modal_rate(1.1, 0.04);
    println!("1.1 omega_b: fitted s = {fitted}, predicted s = {predicted}");
    assert!(predicted.re > 0.0);
    assert!((fitted.re / predicted.re - 1.0).abs() < 0.05);
    assert!((fitted.im / predicted.im - 1.0).abs() < 0.05);
}

#[test]
fn spin_up_from_rest_settles_on_the_steady_state() {
    let model = helix(20);
    let omega = 0.8 * hopf(&model);
    let newton = NewtonSettings::default();
    let rest = rest_state(&model, &newton).unwrap();
    let solved = solve_at(&model, omega, &newton).unwrap().observables;
    let u0 = Steady::new(&model, 0.0).free_vector(&rest.config);
    // A loose tolerance: the steady state is an exact fixed point of BDF2, only the transient
    // is approximated.
    let settings = DynamicsSettings {
        rtol: 1e-4,
        atol: 1e-4,
        ..DynamicsSettings::default()
    };
    let rate = Rate::Ramp {
        target: omega,
        ramp_time: 0.1,
    };
    let run = integrate(&model, rate, u0, 10.0, &settings, |_| {
        ControlFlow::Continue(())
    })
    .unwrap();
    let simulated = observables_at(&model, &rest, &run.last.u, omega).unwrap();
    println!(
        "{} steps, {} rejected, {} Newton iterations; simulated {simulated:?}; solve_at {solved:?}",
        run.steps, run.rejected, run.newton_iterations
    );
    for (name, a, b) in [
        ("Fp", simulated.fp, solved.fp),
        ("Tp", simulated.tp, solved.tp),
        ("hbar", simulated.hbar, solved.hbar),
    ] {
        let err = (a / b - 1.0).abs();
        println!("{name}: relative difference {err:.2e}");
        assert!(err < 1e-6, "{name}: {a} vs {b}");
    }
}

#[test]
fn bdf2_converges_at_second_order_and_keeps_the_clamp() {
    let model = helix(20);
    let omega = 0.8 * hopf(&model);
    let rest = rest_state(&model, &NewtonSettings::default()).unwrap();
    let steady = Steady::new(&model, 0.0);
    let u0 = steady.free_vector(&rest.config);
    let t_end = 0.01;
    let rate = Rate::Ramp {
        target: omega,
        ramp_time: t_end,
    };
    let nx = model.rod.layout.free_positions();
    let final_positions = |steps: usize| {
        let settings = DynamicsSettings {
            adaptive: false,
            dt0: t_end / steps as f64,
            dt_min: 1e-9,
            ..DynamicsSettings::default()
        };
        let mut clamp_exact = true;
        let run = integrate(&model, rate, u0.clone(), t_end, &settings, |s| {
            let x = steady.config(&s.u).x;
            clamp_exact &= x[0] == model.natural[0] && x[1] == model.natural[1];
            ControlFlow::Continue(())
        })
        .unwrap();
        assert!(clamp_exact, "the clamp moved");
        assert_eq!(run.steps, steps);
        assert_eq!(run.last.t, t_end);
        run.last.u[..nx].to_vec()
    };
    let reference = final_positions(1280);
    let counts = [20, 40, 80, 160];
    let errors: Vec<f64> = counts
        .iter()
        .map(|&n| {
            final_positions(n)
                .iter()
                .zip(&reference)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
        })
        .collect();
    let ratios: Vec<f64> = errors.windows(2).map(|w| w[0] / w[1]).collect();
    println!("steps {counts:?}: max position errors {errors:?}, ratios {ratios:?}");
    // Second order: the error falls by 4 per halving (3.3, 3.7, 3.9 measured: the coarsest
    // step, |s| h ~ 0.2 for the fast shape modes, is not yet asymptotic).
    for r in &ratios {
        assert!(
            *r > 3.0 && *r < 5.0,
            "second order expected: ratios {ratios:?}"
        );
    }
    let last = ratios[ratios.len() - 1];
    assert!((last / 4.0 - 1.0).abs() < 0.1, "ratios {ratios:?}");
}

#[test]
fn bisect_brackets_the_hopf_point() {
    let model = helix(20);
    let omega_b = hopf(&model);
    // Coarse settings to keep the test short: a 15% bracket, a short hold, 30 steps per period
    // (BDF2 damping then shifts the boundary by about 1%).
    let settings = BisectSettings {
        precision: 0.15,
        ramp_time: 0.15,
        hold_time: 0.5,
        window: 0.12,
        steps_per_period: 30.0,
        dynamics: DynamicsSettings {
            rtol: 1e-4,
            atol: 1e-7,
            ..BisectSettings::default().dynamics
        },
        ..BisectSettings::default()
    };
    let result = bisect(&model, 0.8 * omega_b, 1.3 * omega_b, &settings).unwrap();
    for t in &result.trials {
        println!("{}", t.summary(omega_b));
    }
    println!(
        "bracket {:?} (omega_b = {omega_b}), {} steps, {} Newton iterations, {} Jacobians",
        result.bracket, result.steps, result.newton_iterations, result.jacobians
    );
    let (a, b) = result.bracket;
    assert!(
        a < omega_b && omega_b < b,
        "{:?} vs {omega_b}",
        result.bracket
    );
    assert!(b - a <= 0.15 * b);
    for t in &result.trials {
        assert_eq!(t.stable, t.omega < omega_b, "{t:?}");
    }
}

/// Past `omega_b` the rod buckles into a large motion in which edges turn far from their
/// natural direction (beyond the reach of the natural chart of the twist): the integrator
/// carries its chart along, and the twist it carries stays consistent with the positions.
#[test]
fn post_buckling_motion_far_from_the_natural_chart() {
    let model = helix(20);
    let omega = 1.15 * hopf(&model);
    let newton = NewtonSettings::default();
    let rest = rest_state(&model, &newton).unwrap();
    let u0 = Steady::new(&model, 0.0).free_vector(&rest.config);
    let natural = model.chart.tangents.clone();
    let settings = DynamicsSettings {
        rtol: 1e-3,
        atol: 1e-4,
        ..DynamicsSettings::default()
    };
    let rate = Rate::Ramp {
        target: omega,
        ramp_time: 0.1,
    };
    let steady = Steady::new(&model, 0.0);
    let mut largest = 0.0f64;
    let mut turned_at = None;
    let t_end = 150.0;
    let run = integrate(&model, rate, u0, t_end, &settings, |s| {
        let x = steady.config(&s.u_chart).x;
        let angle = x
            .windows(2)
            .zip(&natural)
            .map(|(p, t)| (p[1] - p[0]).normalize().dot(t).clamp(-1.0, 1.0).acos())
            .fold(0.0f64, f64::max);
        largest = largest.max(angle);
        if largest > 150f64.to_radians() && turned_at.is_none() {
            turned_at = Some(s.t);
        }
        ControlFlow::Continue(())
    })
    .unwrap();
    println!(
        "{} steps, {} rejected, {} Newton iterations; largest turn of an edge {:.1} deg \
         (150 deg first at t = {turned_at:?}), hbar at the end {:.3}",
        run.steps,
        run.rejected,
        run.newton_iterations,
        largest.to_degrees(),
        steady.model.height(&steady.config(&run.last.u_chart).x)
            / steady.model.height(&rest.config.x)
    );
    assert_eq!(run.last.t, t_end);
    assert!(largest > 120f64.to_radians(), "{}", largest.to_degrees());

    // The carried twist is slaved in its chart, and re-solving it in a fresh chart (the Bishop
    // frame of the final polygon), from a start 0.2 rad off, gives the same forces on the
    // positions.
    let last = &run.last;
    let nx = model.rod.layout.free_positions();
    let carried = Steady {
        chart: last.chart.clone(),
        ..Steady::new(&model, omega)
    };
    let r_carried = carried.residual(&last.u_chart).unwrap();
    let r_theta = norm(&r_carried[nx..]);
    let x = carried.config(&last.u_chart).x;
    let fresh_chart = Chart::bishop(&x);
    let converted = rechart(&carried.config(&last.u_chart), &last.chart, &fresh_chart);
    let mut start = Steady::new(&model, 0.0).free_vector(&converted);
    for (j, t) in start[nx..].iter_mut().enumerate() {
        *t += 0.2 * (j as f64).sin();
    }
    let fresh_u = slave_twist_in(&model, &fresh_chart, &start).unwrap();
    let fresh = Steady {
        chart: fresh_chart.clone(),
        ..Steady::new(&model, omega)
    };
    let r_fresh = fresh.residual(&fresh_u).unwrap();
    let diff: Vec<f64> = (0..nx).map(|i| r_fresh[i] - r_carried[i]).collect();
    let scale = norm(&r_carried[..nx]);
    // The twists agree too: the carried one converted to the fresh chart is the re-solved one.
    let twist_diff = converted
        .theta
        .iter()
        .zip(&fresh.config(&fresh_u).theta)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    println!(
        "R_theta in the carried chart {r_theta:.2e}; position residual {scale:.3e}, difference \
         with the twist re-solved in a fresh chart {:.2e}; twist difference {twist_diff:.2e}",
        norm(&diff)
    );
    assert!(r_theta < 1e-6, "{r_theta:e}");
    assert!(norm(&diff) < 1e-6 * scale.max(1.0), "{:e}", norm(&diff));
    assert!(twist_diff < 1e-6, "{twist_diff:e}");
}
/// At a steady state the rod does not move in the co-rotating frame, so the forces on the fluid
/// obtained from force balance and the clamp's mobility equal the steady drag `Z Omega X`.
#[test]
fn moving_forces_at_a_steady_state_equal_the_steady_drag() {
    let mut physical = Physical::representative_lighthill();
    physical.discretization.nodes = 24;
    let model = Model::new(&physical).unwrap();
    let omegabar = 150.0;
    let solution =
        helixbif::analysis::solve::solve_at(&model, omegabar, &NewtonSettings::default()).unwrap();
    let u = helixbif::problem::twist::natural_chart_unknowns(
        &model,
        &solution.state.config,
        &solution.state.chart,
    )
    .unwrap();
    let moving =
        helixbif::model::observables::moving_forces(&model, &u, &model.chart, omegabar).unwrap();
    let steady = helixbif::model::steady::Steady::new(&model, omegabar);
    let drag = steady.drag(&steady.config(&u).x).unwrap().unwrap().forces;
    let scale = drag.iter().map(|f| f.norm()).fold(0.0, f64::max);
    for (a, b) in moving.iter().zip(&drag) {
        assert!((a - b).norm() < 1e-7 * scale, "{a} vs {b}");
    }
}

/// The integrator's table defaults: the chord, and Newton ending on an update below
/// `newton_kappa` in the error test's weighted norm.
fn table_settings(model: &Model) -> DynamicsSettings {
    IntegratorTable::default().settings(&model.scales)
}

/// A run interrupted after any checkpoint and resumed from the saved state continues bit for
/// bit as the uninterrupted run (the buckled motion past `omega_b`, the chord in use): the same
/// later states, the same counts, the same last sample.
#[test]
fn a_resumed_integration_equals_the_uninterrupted_one() {
    let model = helix(20);
    let omega = 1.15 * hopf(&model);
    let rest = rest_state(&model, &NewtonSettings::default()).unwrap();
    let u0 = Steady::new(&model, 0.0).free_vector(&rest.config);
    let settings = table_settings(&model);
    let rate = Rate::Ramp {
        target: omega,
        ramp_time: 0.02,
    };
    let t_end = 0.3;
    let run_from = |start: Start| {
        let mut saved: Vec<IntegratorState> = Vec::new();
        let mut save = |s: &IntegratorState| {
            saved.push(s.clone());
            Ok(())
        };
        let run = integrate_from(
            &model,
            rate,
            start,
            t_end,
            &settings,
            |_| ControlFlow::Continue(()),
            Some(Checkpoints {
                every: 7,
                save: &mut save,
            }),
        )
        .unwrap();
        (run, saved)
    };
    let (whole, saved) = run_from(Start::Initial(u0));
    println!(
        "{} steps, {} rejected, {} iterations, {} Jacobians, {} checkpoints",
        whole.steps,
        whole.rejected,
        whole.newton_iterations,
        whole.jacobians,
        saved.len()
    );
    assert!(saved.len() >= 4, "{} checkpoints", saved.len());
    let last = saved.last().unwrap();
    assert_eq!(last.t, t_end);
    let k = saved.len() / 2;
    let (resumed, saved_after) = run_from(Start::Resume(Box::new(saved[k].clone())));
    assert_eq!(saved_after, saved[k + 1..].to_vec());
    assert_eq!(resumed.last, whole.last);
    assert_eq!(
        (resumed.steps, resumed.rejected, resumed.newton_iterations),
        (whole.steps, whole.rejected, whole.newton_iterations)
    );
    // The state survives its file: JSON written and read back is the same state.
    let text = serde_json::to_string(&saved[k]).unwrap();
    let back: IntegratorState = serde_json::from_str(&text).unwrap();
    assert_eq!(back, saved[k]);
}

/// Newton ending on a small weighted update (`newton_kappa`) errs, per step, by about `kappa`
/// in the error test's norm (at most `kappa / (1 - 1/3)`: the chord contracts by 3 or is
/// rebuilt): steps from the states of a run solved to the residual tolerance, taken again with
/// `kappa`, land within that of the full solve's next state, with fewer iterations.
#[test]
fn newton_ended_on_a_small_update_errs_by_about_kappa_per_step() {
    let model = helix(20);
    let omega = 1.15 * hopf(&model);
    let rest = rest_state(&model, &NewtonSettings::default()).unwrap();
    let u0 = Steady::new(&model, 0.0).free_vector(&rest.config);
    let table = table_settings(&model);
    let rate = Rate::Ramp {
        target: omega,
        ramp_time: 0.01,
    };
    let t_end = 0.04;
    let tight = DynamicsSettings {
        newton_kappa: 0.0,
        newton_tol: 1e-10,
        max_newton: 30,
        ..table.clone()
    };
    let mut states: Vec<IntegratorState> = Vec::new();
    let mut save = |s: &IntegratorState| {
        states.push(s.clone());
        Ok(())
    };
    integrate_from(
        &model,
        rate,
        Start::Initial(u0),
        t_end,
        &tight,
        |_| ControlFlow::Continue(()),
        Some(Checkpoints {
            every: 1,
            save: &mut save,
        }),
    )
    .unwrap();
    assert!(states.len() > 40, "{} steps", states.len());
    let nx = model.rod.layout.free_positions();
    let (mut worst, mut iterations, mut tight_iterations) = (0.0f64, 0, 0);
    for k in (5..states.len() - 1).step_by(5) {
        let mut next = None;
        let run = integrate_from(
            &model,
            rate,
            Start::Resume(Box::new(states[k].clone())),
            t_end,
            &table,
            |s| {
                next = Some(s.u_chart.clone());
                ControlFlow::Break(())
            },
            None,
        )
        .unwrap();
        let next = next.unwrap();
        let exact = &states[k + 1].points[0].1;
        assert_eq!(states[k + 1].points[0].0, run.last.t, "the same step");
        let sum: f64 = (0..nx)
            .map(|i| {
                let w = table.atol + table.rtol * exact[i].abs();
                ((next[i] - exact[i]) / w).powi(2)
            })
            .sum();
        worst = worst.max((sum / nx as f64).sqrt());
        iterations += run.newton_iterations - states[k].newton_iterations;
        tight_iterations += states[k + 1].newton_iterations - states[k].newton_iterations;
    }
    println!(
        "kappa {}: largest weighted one-step difference {worst:.3e}; iterations {iterations} \
         against {tight_iterations}",
        table.newton_kappa
    );
    assert!(table.newton_kappa > 0.0);
    assert!(worst <= 1.5 * table.newton_kappa, "{worst:e}");
    assert!(iterations < tight_iterations);
}
