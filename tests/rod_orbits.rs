//! Periodic orbits of the rod (`helixbif::analysis::orbits`) near its Hopf point: the period map's
//! monodromy against finite differences, the map and the forces the same whether the twist
//! chart is carried through the period or held fixed, the orbits' Floquet multiplier and amplitude against
//! the first Lyapunov coefficient (two independent routes), and an orbit against the adaptive
//! time integrator (in the library, and through `simulate --from-orbit`: the orbit's period and
//! period averages converge at second order in its steps).

use std::ops::ControlFlow;

use crate::common;

use helixbif::analysis::dynamics::{DynamicsSettings, Rate, integrate};
use helixbif::analysis::locate::hopf_criticality;
use helixbif::analysis::orbits::hopf_start;
use helixbif::engine::periodic::branch::{
    HopfStart, OrbitBranch, OrbitBranchSettings, follow_orbits,
};
use helixbif::engine::periodic::flow::{FlowSettings, carried, period_map};
use helixbif::engine::periodic::{ImplicitDynamics, StepLinearization, StepVelocity};
use helixbif::model::Model;
use helixbif::model::steady::Steady;
use helixbif::problem::orbit::{RodDynamics, amplitude_factor};
use helixbif::problem::twist::natural_chart_unknowns;
use helixbif::study::Study;
use helixbif::study::locate::run_locate_critical;

fn located(
    nodes: usize,
) -> (
    Model,
    helixbif::analysis::locate::Critical,
    helixbif::engine::criticality::Lyapunov,
) {
    let study = Study::from_path(
        None,
        &[
            "fluid.model=\"lighthill\"".to_string(),
            format!("discretization.nodes={nodes}"),
        ],
    )
    .unwrap();
    let model = Model::new(&study.physical()).unwrap();
    let (located, critical) = run_locate_critical(&study, &model).unwrap();
    assert_eq!(located.kind.name(), "hopf");
    let critical = critical.unwrap();
    let lyapunov = hopf_criticality(&model, &critical.event, &critical.chart).unwrap();
    (model, critical, lyapunov)
}

/// The first `max_orbits` orbits from the Hopf point, the first of radius `amplitude`, with
/// `steps` per period.
fn orbits_from(
    dynamics: &RodDynamics,
    start: &HopfStart,
    amplitude: f64,
    max_orbits: usize,
    steps: usize,
) -> OrbitBranch {
    let mut settings = OrbitBranchSettings {
        amplitude,
        max_orbits,
        ..OrbitBranchSettings::default()
    };
    settings.shooting.flow.steps = steps;
    follow_orbits(
        dynamics,
        start,
        &settings,
        (0.0, 2.0 * start.p),
        |_, _, _| ControlFlow::Continue(()),
    )
    .unwrap()
}

/// Period maps of 24 steps.
fn flow_of_24_steps() -> FlowSettings {
    FlowSettings {
        steps: 24,
        ..FlowSettings::default()
    }
}

/// The Hopf state displaced by `size` (reference lengths) along the real part of the critical
/// mode, and the Hopf period.
fn displaced(start: &HopfStart, size: f64) -> (Vec<f64>, f64) {
    let mut u = start.u.clone();
    for (x, q) in u.iter_mut().zip(&start.mode.0) {
        *x += size * q;
    }
    (u, 2.0 * std::f64::consts::PI / start.frequency)
}

/// The rod's dynamics with the twist chart held fixed through the period (no
/// [`ImplicitDynamics::centred_on`]).
struct FixedChart<'a>(RodDynamics<'a>);

impl ImplicitDynamics for FixedChart<'_> {
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn differential(&self) -> usize {
        self.0.differential()
    }
    fn step_residual(&self, p: f64, v: StepVelocity, u: &[f64]) -> helixbif::Result<Vec<f64>> {
        self.0.step_residual(p, v, u)
    }
    fn step_linearize(
        &self,
        p: f64,
        v: StepVelocity,
        u: &[f64],
    ) -> helixbif::Result<StepLinearization> {
        self.0.step_linearize(p, v, u)
    }
    fn consistent(&self, p: f64, u: &[f64]) -> helixbif::Result<Vec<f64>> {
        self.0.consistent(p, u)
    }
    fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        self.0.retract(u, du)
    }
}

/// A large motion (the Hopf state displaced by 0.05 reference lengths along the mode, one Hopf
/// period of 24 steps; larger ones bring Lighthill's operator to its limit at `N = 12`): the
/// chart carried from step to step turns away from the fixed one, and the twist coordinates
/// differ, yet the positions, their sensitivities and the forces on the fluid agree.
#[test]
fn the_period_map_does_not_depend_on_the_chart_the_twist_is_measured_in() {
    let (model, critical, lyapunov) = located(12);
    let (dynamics, start) = hopf_start(&model, &critical, lyapunov.q.clone());
    let fixed = FixedChart(RodDynamics {
        model: &model,
        chart: critical.chart.clone(),
    });
    let nx = dynamics.differential();
    let settings = flow_of_24_steps();
    let (u, period) = displaced(&start, 0.05);
    let a = period_map(&dynamics, start.p, &u, period, &settings, true).unwrap();
    let b = period_map(&fixed, start.p, &u, period, &settings, true).unwrap();
    // How far the carried chart turned: the largest angle between its tangents at the end and
    // the fixed chart's.
    let frames = carried(&dynamics, &a.states);
    let end_chart = &frames.last().unwrap().as_ref().unwrap().chart;
    let turned = end_chart
        .tangents
        .iter()
        .zip(&critical.chart.tangents)
        .map(|(s, t)| s.dot(t).clamp(-1.0, 1.0).acos().to_degrees())
        .fold(0.0, f64::max);
    assert!(turned > 5.0, "the chart turned by {turned} degrees only");
    let twist = a.states.last().unwrap()[nx..]
        .iter()
        .zip(&b.states.last().unwrap()[nx..])
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    assert!(
        twist > 1e-4,
        "the twist coordinates differ by {twist:e} only"
    );
    let scale = a.end(nx).iter().map(|v| v.abs()).fold(0.0, f64::max);
    let positions = a
        .end(nx)
        .iter()
        .zip(b.end(nx))
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    let (sa, sb) = (a.sensitivity.unwrap(), b.sensitivity.unwrap());
    let sensitivity = (&sa.x0 - &sb.x0).norm_max() / sb.x0.norm_max();
    let forces = |u: &[f64], chart| {
        helixbif::model::observables::moving_forces(&model, u, chart, start.p).unwrap()
    };
    let (fa, fb) = (
        forces(a.states.last().unwrap(), end_chart),
        forces(b.states.last().unwrap(), &critical.chart),
    );
    let force_scale = fb.iter().map(|f| f.norm()).fold(0.0, f64::max);
    let force = fa
        .iter()
        .zip(&fb)
        .map(|(x, y)| (x - y).norm())
        .fold(0.0, f64::max)
        / force_scale;
    eprintln!(
        "chart turned {turned:.1} degrees, twist coordinates by {twist:.2e}; positions {:.2e}, \
         monodromy {sensitivity:.2e}, forces {force:.2e}",
        positions / scale
    );
    assert!(positions <= 1e-9 * scale, "{positions:e}");
    assert!(sensitivity <= 1e-7, "{sensitivity:e}");
    assert!(force <= 1e-7, "{force:e}");
}

#[test]
fn the_rod_monodromy_matches_finite_differences_of_the_period_map() {
    let (model, critical, lyapunov) = located(12);
    let (dynamics, start) = hopf_start(&model, &critical, lyapunov.q.clone());
    let nx = dynamics.differential();
    let settings = flow_of_24_steps();
    // A state off the orbit.
    let (u, period) = displaced(&start, 2e-3);
    let map = period_map(&dynamics, start.p, &u, period, &settings, true).unwrap();
    let sens = map.sensitivity.unwrap();
    let end = |u: &[f64], t: f64, p: f64| {
        period_map(&dynamics, p, u, t, &settings, false)
            .unwrap()
            .end(nx)
            .to_vec()
    };
    // Directions: the two parts of the critical mode, a smooth bend of the whole rod (the
    // shooting corrects along such shapes; a single coordinate excites the stretching, where
    // finite differences are dominated by curvature or by the steps' Newton precision), then
    // the period and the rate.
    let bend: Vec<f64> = (0..nx)
        .map(|i| {
            let node = (i / 3) as f64 / (nx / 3) as f64;
            if i % 3 == 0 { node * node } else { 0.0 }
        })
        .collect();
    let directions = [start.mode.0.clone(), start.mode.1.clone(), bend];
    let mut worst: f64 = 0.0;
    for case in 0..directions.len() + 2 {
        let (h, exact): (f64, Vec<f64>) = if case < directions.len() {
            let d = &directions[case];
            (
                1e-5,
                (0..nx)
                    .map(|r| (0..nx).map(|c| sens.x0[(r, c)] * d[c]).sum())
                    .collect(),
            )
        } else if case == directions.len() {
            (1e-6 * period, sens.period.clone())
        } else {
            (1e-6 * start.p, sens.parameter.clone())
        };
        let shifted = |s: f64| {
            let mut v = u.clone();
            let (mut t, mut p) = (period, start.p);
            if case < directions.len() {
                for (x, d) in v.iter_mut().zip(&directions[case]) {
                    *x += s * d;
                }
            } else if case == directions.len() {
                t += s;
            } else {
                p += s;
            }
            end(&v, t, p)
        };
        let (plus, minus) = (shifted(h), shifted(-h));
        let scale = exact.iter().map(|v| v.abs()).fold(0.0, f64::max);
        let error = (0..nx)
            .map(|r| ((plus[r] - minus[r]) / (2.0 * h) - exact[r]).abs() / scale)
            .fold(0.0, f64::max);
        eprintln!("direction {case}: {error:.2e} of the largest entry {scale:.3e}");
        worst = worst.max(error);
    }
    eprintln!(
        "rod monodromy (N = 12): worst difference from finite differences {worst:.2e} of the column's largest entry"
    );
    assert!(worst < 1e-5, "{worst:e}");
}

/// Near a Hopf point the normal form `r' = mu r + w l1 r^3` gives the orbit `r^2 = -mu/(w l1)`
/// whose nontrivial multiplier is `exp(-2 mu T) = exp(2 w l1 r^2 T)`; the mean square amplitude
/// is `2 r^2 size(q)^2`. So `ln |multiplier| / T = 2 w l1 A^2 / (2 size(q)^2)` ties the
/// shooting's multipliers and amplitudes to the Lyapunov coefficient, whatever the small shift
/// of the discrete Hopf point.
#[test]
fn small_rod_orbits_have_the_multiplier_the_lyapunov_coefficient_predicts() {
    let (model, critical, lyapunov) = located(20);
    let (dynamics, start) = hopf_start(&model, &critical, lyapunov.q.clone());
    let factor = amplitude_factor(&dynamics, &lyapunov.q);
    let branch = orbits_from(&dynamics, &start, 5e-4, 4, 200);
    let w = start.frequency;
    let mut errors = Vec::new();
    for o in &branch.orbits {
        let a2 = o.amplitude(&dynamics, None).powi(2);
        let measured = o.max_multiplier().ln() / o.period;
        let predicted = w * lyapunov.l1 * a2 / (0.5 * factor);
        let error = (measured / predicted - 1.0).abs();
        eprintln!(
            "omegabar {:.6}: A^2 {a2:.4e}, ln|mu|/T {measured:.5e}, predicted {predicted:.5e} \
             (relative difference {error:.2e}); trivial multiplier off 1 by {:.1e}",
            o.p,
            (o.trivial - faer::c64::new(1.0, 0.0)).norm()
        );
        errors.push(error);
        // Subcritical: the orbits are unstable and lie below the Hopf rate.
        assert!(lyapunov.l1 > 0.0);
        assert_eq!(o.unstable, 1);
    }
    assert!(branch.orbits.last().unwrap().p < branch.orbits[0].p);
    // The multiplier is 1 + 1e-6 .. 1e-5 here, so its discretization error weighs most on the
    // smallest orbit (0.7% at 200 steps per period, 1.8% at 100).
    assert!(errors.iter().all(|&e| e < 0.02), "{errors:?}");
}

/// The orbit found by shooting closes under the adaptive BDF2 integrator (a different step
/// sequence, error-controlled): after one period the state returns to within a small fraction
/// of the orbit's amplitude.
#[test]
fn a_rod_orbit_closes_under_the_adaptive_integrator() {
    let (model, critical, lyapunov) = located(20);
    let (dynamics, start) = hopf_start(&model, &critical, lyapunov.q.clone());
    let branch = orbits_from(&dynamics, &start, 2e-3, 3, 100);
    let orbit = branch.orbits.last().unwrap();
    let nx = dynamics.differential();
    let amplitude = orbit.amplitude(&dynamics, None);
    let integrator = DynamicsSettings {
        rtol: 1e-9,
        atol: 1e-11,
        dt0: orbit.period * 1e-4,
        dt_max: orbit.period / 200.0,
        ..DynamicsSettings::default()
    };
    // The integrator takes its start in the natural chart.
    let config = Steady::new(&model, orbit.p).config(&orbit.states[0]);
    let u0 = natural_chart_unknowns(&model, &config, &dynamics.chart).unwrap();
    let trajectory = integrate(
        &model,
        Rate::Fixed(orbit.p),
        u0,
        orbit.period,
        &integrator,
        |_| ControlFlow::Continue(()),
    )
    .unwrap();
    let end = &trajectory.last.u[..nx];
    let gap: Vec<f64> = (0..nx).map(|i| end[i] - orbit.states[0][i]).collect();
    let closure = dynamics.size(&gap) / amplitude;
    eprintln!(
        "orbit at omegabar {:.6}, amplitude {amplitude:.3e}: after one period the adaptive \
         integrator ({} steps) is {closure:.2e} amplitudes from the start",
        orbit.p, trajectory.steps
    );
    assert!(closure < 2e-2, "{closure:e}");
}

/// The period and period averages of an orbit (`helixbif orbits`, `steps` BDF2 steps a period)
/// and of the simulation started on it (`simulate --from-orbit`, adaptive steps at `rtol =
/// 1e-9`), both at `N = 20`: `(orbit period, simulated period, orbit hbar and Fpbar averages,
/// simulated ones over the first period)`.
fn orbit_and_simulation(steps: usize) -> [f64; 6] {
    let dir = common::temp_dir(&format!("orbit-vs-simulation-{steps}"));
    let (orbits, sim) = (dir.join("orbits"), dir.join("sim"));
    let nodes = "discretization.nodes=20";
    let steps = steps.to_string();
    let (code, _, stderr) = common::helixbif(&[
        "orbits",
        "--set",
        "fluid.model=lighthill",
        "--set",
        nodes,
        "--max-orbits",
        "3",
        "--steps",
        &steps,
        "--out",
        orbits.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let start = orbits.join("states").join("orbit_0002.json");
    let (code, stdout, stderr) = common::helixbif(&[
        "simulate",
        "--set",
        "fluid.model=lighthill",
        "--set",
        nodes,
        "--set",
        "integrator.rtol=1e-9",
        "--set",
        "integrator.atol=1e-12",
        "--from-orbit",
        start.to_str().unwrap(),
        "--t-end",
        "19.5",
        "--shape-every",
        "0",
        "--out",
        sim.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    let o = &v["orbit"];
    let cycles = o["cycles"].as_array().unwrap();
    // Three whole periods of about 6.4 s; the first has no earlier crossing to time it from.
    assert_eq!(cycles.len(), 3, "{v}");
    let f = |x: &serde_json::Value| x.as_f64().unwrap();
    std::fs::remove_dir_all(&dir).ok();
    [
        f(&o["period"]),
        f(&cycles[2]["period"]),
        f(&o["hbar_mean"]),
        f(&cycles[0]["hbar_mean"]),
        f(&o["Fpbar_mean"]),
        f(&cycles[0]["Fpbar_mean"]),
    ]
}

#[test]
fn an_orbit_and_the_simulation_started_on_it_agree_to_the_orbits_second_order_error() {
    // The simulation at rtol 1e-9 is the reference: its period moves by 6e-6 relative from
    // rtol 1e-9 to 1e-10, against orbit errors of 3e-4 and more.
    let coarse = orbit_and_simulation(100);
    let fine = orbit_and_simulation(200);
    let error = |r: &[f64; 6], k: usize| (r[k] - r[k + 1]) / r[k + 1];
    // BDF2's period is long by about 1.3e-3 at 100 steps a period, a quarter of that at 200.
    let (e100, e200) = (error(&coarse, 0), error(&fine, 0));
    assert!(e100 > 0.0 && e100 < 2e-3, "{coarse:?}");
    assert!((3.6..4.4).contains(&(e100 / e200)), "{e100} {e200}");
    // The period averages of hbar (1e-6 relative at 100 steps) and Fpbar (1e-5), the same order.
    for (k, bound) in [(2, 2e-6), (4, 2e-5)] {
        let (c, f) = (error(&coarse, k), error(&fine, k));
        assert!(c.abs() < bound, "{k}: {coarse:?}");
        assert!((3.5..4.5).contains(&(c / f)), "{k}: {c} {f}");
    }
}
