//! Wall time of `omega_b` by bisection on simulations from rest (`dynamics::bisect`, relative
//! precision 1e-2 and 1e-3, where each halving of the bracket costs one more simulation)
//! against continuation (`branch::locate`, relative precision 1e-8) on the representative helix
//! at N = 30 and N = 60, in one run.
//!
//! Run with `cargo bench --bench bisect_vs_locate` (add `-- 30` to do one node count only).
//! The bisection bracket is `[0.6, 1.5] omega_b` around the value `locate` found (a guess a
//! simulation study could make from a coarser run); both run single-threaded, as the command
//! line tool does.

use std::time::Instant;

use helixbif::analysis::dynamics::{BisectSettings, bisect};
use helixbif::analysis::locate::{LocateSettings, locate};
use helixbif::engine::ContinuationSettings;
use helixbif::engine::newton::NewtonSettings;
use helixbif::engine::stop::Silent;
use helixbif::model::Model;
use helixbif::model::params::Physical;

fn main() {
    helixbif::numerics::process::configure();
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let nodes = if args.is_empty() { vec![30, 60] } else { args };
    println!(
        "| N | locate (1e-8) | omegabar_b | bisect precision | bisect | bracket / omegabar_b | trials | steps | Newton it. | Jacobians | ratio |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for n in nodes {
        let mut physical = Physical::representative_lighthill();
        physical.discretization.nodes = n;
        let model = Model::new(&physical).expect("a valid model");

        let start = Instant::now();
        let (_, event) = locate(
            &model,
            &LocateSettings {
                omega_max: 2.0,
                newton: &NewtonSettings::default(),
                continuation: &ContinuationSettings::default(),
                criticality: true,
            },
            &mut Silent,
        )
        .expect("locate");
        let t_locate = start.elapsed().as_secs_f64();
        let event = event.expect("an instability below 2 rad/s").event;
        let omega_b = event.p;

        for precision in [1e-2, 1e-3] {
            let settings = BisectSettings {
                precision,
                ..BisectSettings::default()
            };
            let start = Instant::now();
            let result = bisect(&model, 0.6 * omega_b, 1.5 * omega_b, &settings).expect("bisect");
            let t_bisect = start.elapsed().as_secs_f64();
            for t in &result.trials {
                eprintln!("N = {n}, precision {precision:e}: {}", t.summary(omega_b));
            }
            println!(
                "| {n} | {t_locate:.2} s | {omega_b:.4} | {precision:.0e} | {t_bisect:.1} s | [{:.4}, {:.4}] | {} | {} | {} | {} | {:.0} |",
                result.bracket.0 / omega_b,
                result.bracket.1 / omega_b,
                result.trials.len(),
                result.steps,
                result.newton_iterations,
                result.jacobians,
                t_bisect / t_locate
            );
        }
    }
}
