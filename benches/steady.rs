//! Cost of the steady solver: one residual, one Jacobian, one Newton solve (from the natural
//! shape: the rest state, then the ramp in omega), for the representative helix at
//! N = 30, 60, 85 at omega = 0.3 rad/s (omegabar = 125), and a thinner rod (r0 = 0.4 mm) at
//! N = 100, 200, 300 at the same omegabar = 125 (at 0.3 rad/s itself the thin rod, 243 times
//! softer, would be 150 times past its buckling rate).
//!
//! Run: `cargo bench --bench steady`.

mod common;

use helixbif::analysis::solve::solve_at;
use helixbif::engine::newton::{NewtonSettings, System};
use helixbif::model::Model;
use helixbif::model::params::Physical;
use helixbif::model::steady::Steady;

fn model(r0: f64, nodes: usize) -> Model {
    let mut p = Physical::representative_lighthill();
    p.rod.r0 = r0;
    p.discretization.nodes = nodes;
    Model::new(&p).expect("valid benchmark model")
}

fn main() {
    helixbif::numerics::process::configure();
    println!("steady solver, {}", common::machine());
    println!(
        "{:>10} {:>5} {:>12} {:>12} {:>12} {:>10}",
        "rod", "N", "residual", "jacobian", "newton", "iterations"
    );
    for (label, r0, ladder) in [
        ("default", 1.58e-3, [30, 60, 85]),
        ("r0=0.4mm", 0.4e-3, [100, 200, 300]),
    ] {
        let mut rows = Vec::new();
        for n in ladder {
            let m = model(r0, n);
            let omegabar = model(1.58e-3, 30).scales.omega_to_bar(0.3);
            let problem = Steady::new(&m, omegabar);
            let u = problem.free_vector(&m.natural_config());
            let repeats = if n > 150 { 3 } else { 11 };
            let residual = common::median_seconds(repeats, || {
                problem.residual(&u).expect("residual");
            });
            let jacobian = common::median_seconds(repeats, || {
                problem.residual_and_jacobian(&u).expect("jacobian");
            });
            let mut iterations = 0;
            let newton = common::median_seconds(if n > 150 { 1 } else { 5 }, || {
                iterations = solve_at(&m, omegabar, &NewtonSettings::default())
                    .expect("solve")
                    .state
                    .report
                    .iterations;
            });
            println!(
                "{label:>10} {n:>5} {:>10.3}ms {:>10.3}ms {:>10.3}ms {iterations:>10}",
                residual * 1e3,
                jacobian * 1e3,
                newton * 1e3
            );
            rows.push((n, residual, jacobian, newton));
        }
        let g = |k: usize| {
            common::growth(
                &rows
                    .iter()
                    .map(|r| (r.0, [r.1, r.2, r.3][k]))
                    .collect::<Vec<_>>(),
            )
        };
        println!(
            "{label:>10} growth exponents in N: residual {:.2?}, jacobian {:.2?}, newton {:.2?}",
            g(0),
            g(1),
            g(2)
        );
    }
}
