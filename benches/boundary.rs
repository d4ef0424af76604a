//! Cost of a stability boundary drawn as a curve against the sweep of independent `locate` runs
//! at the same points, in one run on one machine: the `exponent_m` rod at `lambda/l = 0.1875`
//! (10 nodes per turn, `N = 54`), `R/lambda` from 0.4 down to 0.1, and the default helix at
//! `N = 60` from `R/lambda = 0.32` down to 0.25. Prints, per curve, the points, the steady
//! solves, both times, their ratio and the largest relative difference of `omega_b`, and where
//! the curve's time went (the report's `time`).
//!
//! Run: `cargo bench --bench boundary`.

mod common;

use std::time::Instant;

use helixbif::model::Model;
use helixbif::study::Study;
use helixbif::study::boundary::run_boundary;
use helixbif::study::locate::run_locate;
use helixbif::study::output::Provenance;

fn main() {
    helixbif::numerics::process::configure();
    println!(
        "boundary curve against locate at the same points, {}",
        common::machine()
    );
    let exponent = concat!(env!("CARGO_MANIFEST_DIR"), "/studies/exponent_m.toml");
    // (label, study file, overrides, first and last R/lambda)
    type Case<'a> = (&'a str, Option<&'a str>, Vec<String>, f64, f64);
    let cases: [Case; 2] = [
        (
            "exponent_m, lambda/l = 0.1875",
            Some(exponent),
            vec!["shape.lambda_over_l=0.1875".into()],
            0.4,
            0.1,
        ),
        (
            "default helix",
            None,
            vec!["discretization.nodes=60".into()],
            0.32,
            0.25,
        ),
    ];
    println!(
        "{:>30} {:>4} {:>7} {:>7} {:>10} {:>10} {:>7} {:>10}",
        "curve", "N", "points", "solves", "curve (s)", "locate (s)", "ratio", "max diff"
    );
    for (label, path, overrides, from, to) in cases {
        let text = path.map(|p| std::fs::read_to_string(p).expect("the study file"));
        let mut study = Study::load(text.as_deref(), &overrides).expect("a valid study");
        study.study = None;
        let dir =
            std::env::temp_dir().join(format!("helixbif-bench-boundary-{}", std::process::id()));
        let started = Instant::now();
        let (rows, report) = run_boundary(
            &study,
            "shape.R_over_lambda",
            (from, to),
            None,
            &dir,
            &Provenance::default(),
        )
        .expect("a curve");
        let report = report.expect("a curve");
        let curve = started.elapsed().as_secs_f64();
        let started = Instant::now();
        let mut worst: f64 = 0.0;
        for row in &rows {
            let mut at = study.clone();
            at.discretization.per_turn = None;
            at.discretization.nodes = report.nodes;
            at.branch.omega_max = 2.0 * row.omega_b;
            let mut table = at.to_table().expect("a table");
            helixbif::study::set_ratio(&mut table, "shape.R_over_lambda", row.q).expect("a helix");
            let at = Study::from_table(table).expect("a valid study");
            let model = Model::new(&at.physical()).expect("a model");
            let located = run_locate(&at, &model).expect("locate");
            let omega_b = located.omega_b.expect("an instability");
            worst = worst.max((omega_b - row.omega_b).abs() / omega_b);
        }
        let sweep = started.elapsed().as_secs_f64();
        println!(
            "{label:>30} {:>4} {:>7} {:>7} {curve:>10.2} {sweep:>10.2} {:>7.1} {worst:>10.1e}",
            report.nodes,
            rows.len(),
            report.evaluations,
            sweep / curve
        );
        let t = report.time;
        println!(
            "{:>30} the curve's time: following it {:.2} s, window checks {:.2} s, the points' \
             errors {:.2} s, the check at the end {:.2} s",
            "", t.curve, t.window_checks, t.rows, t.end_check
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
