//! Cost of the periodic orbits (docs/model.md section 12) on the representative helix, Lighthill
//! at N = 20, 30, 60, 85 and the RPY line at N = 30, 60: one step linearization of the shooting
//! (`G_u`, `M`, `G_omega`), one residual of a step, the period map of 100 steps with and without
//! its sensitivities, and the first orbit from the Hopf point (shooting to convergence). The
//! period map with sensitivities is given as a multiple of 100 step linearizations, the orbit as
//! a multiple of one period map with sensitivities.
//!
//! Run: `cargo bench --bench orbits`.

mod common;

use helixbif::analysis::locate::hopf_criticality;
use helixbif::analysis::orbits::hopf_start;
use helixbif::engine::periodic::flow::{FlowSettings, period_map};
use helixbif::engine::periodic::orbit::{Condition, ShootingSettings, shoot};
use helixbif::engine::periodic::{ImplicitDynamics, StepVelocity};
use helixbif::model::Model;
use helixbif::study::Study;
use helixbif::study::locate::run_locate_critical;

fn main() {
    helixbif::numerics::process::configure();
    println!("periodic orbits, {}", common::machine());
    println!(
        "{:>10} {:>4} {:>11} {:>11} {:>11} {:>11} {:>8} {:>10} {:>8}",
        "fluid", "N", "step lin", "step res", "map", "map+sens", "/100 lin", "orbit", "/map+s"
    );
    for (fluid, ladder) in [("lighthill", vec![20, 30, 60, 85]), ("rpy", vec![30, 60])] {
        let mut rows = Vec::new();
        for n in ladder {
            let overrides = vec![
                format!("discretization.nodes={n}"),
                format!("fluid.model=\"{fluid}\""),
            ];
            let study = Study::from_path(None, &overrides).expect("valid study");
            let model = Model::new(&study.physical()).expect("valid model");
            let (_, critical) = run_locate_critical(&study, &model).expect("locate");
            let critical = critical.expect("a Hopf point");
            let lyapunov = hopf_criticality(&model, &critical.event, &critical.chart).expect("l1");
            let (dynamics, start) = hopf_start(&model, &critical, lyapunov.q.clone());
            let nx = dynamics.differential();
            let period = 2.0 * std::f64::consts::PI / start.frequency;
            let h = period / 100.0;
            let offset: Vec<f64> = start.u[..nx].iter().map(|x| -1.5 * x / h).collect();
            let velocity = StepVelocity {
                c0: 1.5 / h,
                offset: &offset,
            };
            let slow = fluid == "rpy" || n > 60;
            let repeats = if slow { 3 } else { 7 };
            let linearization = common::median_seconds(repeats, || {
                dynamics
                    .step_linearize(start.p, velocity, &start.u)
                    .expect("linearization");
            });
            let residual = common::median_seconds(repeats, || {
                dynamics
                    .step_residual(start.p, velocity, &start.u)
                    .expect("residual");
            });
            let mut guess = start.u.clone();
            for (g, q) in guess.iter_mut().zip(&start.mode.0) {
                *g += 2e-3 * q;
            }
            let flow = FlowSettings::default();
            let maps = if slow { 1 } else { 3 };
            let map = common::median_seconds(maps, || {
                period_map(&dynamics, start.p, &guess, period, &flow, false).expect("map");
            });
            let map_sens = common::median_seconds(maps, || {
                period_map(&dynamics, start.p, &guess, period, &flow, true).expect("map");
            });
            let re2: f64 = start.mode.0.iter().map(|v| v * v).sum();
            let centre: f64 = start.u[..nx]
                .iter()
                .zip(&start.mode.0)
                .map(|(x, q)| x * q)
                .sum::<f64>()
                / re2;
            let condition = Condition {
                c: start
                    .mode
                    .0
                    .iter()
                    .map(|q| q / re2)
                    .chain([0.0, 0.0])
                    .collect(),
                value: centre + 2e-3,
            };
            let mut iterations = 0;
            let orbit = common::median_seconds(1, || {
                iterations = shoot(
                    &dynamics,
                    &guess,
                    period,
                    start.p,
                    &condition,
                    &ShootingSettings::default(),
                )
                .expect("orbit")
                .iterations;
            });
            println!(
                "{fluid:>10} {n:>4} {:>9.2}ms {:>9.2}ms {:>10.3}s {:>10.3}s {:>8.2} {:>9.2}s {:>8.2}  ({iterations} Newton iterations)",
                linearization * 1e3,
                residual * 1e3,
                map,
                map_sens,
                map_sens / (100.0 * linearization),
                orbit,
                orbit / map_sens
            );
            rows.push((n, map_sens));
        }
        println!(
            "{fluid}: growth exponent of the period map with sensitivities in N: {:?}",
            common::growth(&rows)
                .iter()
                .map(|g| format!("{g:.2}"))
                .collect::<Vec<_>>()
        );
    }
}
