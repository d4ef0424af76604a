//! Cost of the stability spectrum: the dense solver (Cholesky reduction and the full
//! eigendecomposition) against the Krylov path (shift-invert Krylov-Schur over one LU with its
//! certificate, src/continuation/krylov.rs), on the stability pair `(K, Z_ff)` of the
//! representative helix at 0.4 rad/s, at N = 30, 45, 60 (Lighthill) and 120, 240 (RPY: the
//! Lighthill operator is indefinite beyond N = 87); each as a multiple of one LU factorization
//! of a matrix of the same size (`helixbif::numerics::lu::Lu`, as the Krylov path makes it). The Krylov shift is seeded, as along a branch, from a leading
//! spectrum of the same state. Then `locate` at N = 60 (Lighthill) with each
//! `continuation.eigen`, with the number of Krylov results, dense solves and fallbacks among the
//! spectra of the branch's points and events.
//!
//! Run: `cargo bench --bench eigen`.

mod common;

use faer::Mat;
use helixbif::analysis::locate::{LocateSettings, locate};
use helixbif::analysis::solve::solve_at;
use helixbif::engine::krylov::shift_after;
use helixbif::engine::newton::NewtonSettings;
use helixbif::engine::stability::{EigenCounts, leading, spectrum};
use helixbif::engine::stop::Silent;
use helixbif::engine::{ContinuationSettings, EigenMethod};
use helixbif::model::Model;
use helixbif::model::fluid::FluidModel;
use helixbif::model::params::Physical;
use helixbif::model::steady::Steady;
use helixbif::numerics::lu::Lu;

fn model(nodes: usize) -> Model {
    let mut p = Physical::representative_lighthill();
    p.discretization.nodes = nodes;
    if nodes > 87 {
        p.fluid.model = FluidModel::Rpy;
    }
    Model::new(&p).expect("valid benchmark model")
}

/// The stability pair at `omega` rad/s.
fn pair(nodes: usize, omega: f64) -> (Mat<f64>, Mat<f64>) {
    let m = model(nodes);
    let omegabar = m.scales.omega_to_bar(omega);
    let solution = solve_at(&m, omegabar, &NewtonSettings::default()).expect("steady state");
    let steady = Steady {
        model: &m,
        omega: omegabar,
        weight: solution.state.weight,
        chart: solution.state.chart.clone(),
    };
    steady
        .stability_pair(&steady.free_vector(&solution.state.config))
        .expect("stability pair")
}

fn main() {
    helixbif::numerics::process::configure();
    println!("stability spectrum, {}", common::machine());
    println!(
        "{:>5} {:>5} {:>6} {:>10} {:>10} {:>10} {:>8} {:>8} {:>8} {:>9} {:>9}",
        "N",
        "fluid",
        "n",
        "LU s",
        "dense s",
        "krylov s",
        "dense/LU",
        "kryl/LU",
        "dns/kryl",
        "fallbacks",
        "agreement"
    );
    let mut dense_growth = Vec::new();
    let mut krylov_growth = Vec::new();
    for nodes in [30, 45, 60, 120, 240] {
        let (k, m) = pair(nodes, 0.4);
        let n = k.nrows();
        let repeats = if n > 400 { 3 } else { 7 };
        let prior = spectrum(&k, &m, 6).expect("dense spectrum");
        let sigma = shift_after(&prior);
        let shifted = Mat::from_fn(n, n, |i, j| k[(i, j)] - sigma * m[(i, j)]);
        let lu = common::median_seconds(repeats, || {
            std::hint::black_box(Lu::new(shifted.as_ref()));
        });
        let dense = common::median_seconds(repeats, || {
            std::hint::black_box(spectrum(&k, &m, 6).unwrap());
        });
        let mut counts = EigenCounts::default();
        let krylov = common::median_seconds(repeats, || {
            counts.add(&std::hint::black_box(
                leading(&k, &m, 6, EigenMethod::Krylov, Some(&prior)).unwrap(),
            ));
        });
        let found = leading(&k, &m, 6, EigenMethod::Krylov, Some(&prior)).unwrap();
        let agreement = found
            .leading
            .iter()
            .zip(&prior.leading)
            .map(|(a, b)| (a - b).norm() / b.norm())
            .fold(0.0, f64::max);
        let agreement = if found.unstable == prior.unstable {
            agreement
        } else {
            f64::INFINITY
        };
        println!(
            "{nodes:>5} {:>5} {n:>6} {lu:>10.5} {dense:>10.5} {krylov:>10.5} {:>8.1} {:>8.1} {:>8.2} {:>9} {agreement:>9.1e}",
            if nodes > 87 { "rpy" } else { "lh" },
            dense / lu,
            krylov / lu,
            dense / krylov,
            format!("{}/{}", counts.fallbacks, counts.krylov + counts.fallbacks),
        );
        dense_growth.push((n, dense));
        krylov_growth.push((n, krylov));
    }
    println!(
        "growth exponents in n: dense {:.2?}, krylov {:.2?}",
        common::growth(&dense_growth),
        common::growth(&krylov_growth)
    );

    println!("\nlocate, representative helix, N = 60 (Lighthill)");
    println!(
        "{:>7} {:>10} {:>16} {:>7} {:>6} {:>9}",
        "eigen", "seconds", "omega_b rad/s", "krylov", "dense", "fallbacks"
    );
    let m = model(60);
    let mut reference = None;
    for eigen in [EigenMethod::Dense, EigenMethod::Krylov, EigenMethod::Auto] {
        let settings = ContinuationSettings {
            eigen,
            ..ContinuationSettings::default()
        };
        let run = || {
            locate(
                &m,
                &LocateSettings {
                    omega_max: 2.0,
                    newton: &NewtonSettings::default(),
                    continuation: &settings,
                    criticality: true,
                },
                &mut Silent,
            )
        };
        let seconds = common::median_seconds(3, || {
            std::hint::black_box(run().unwrap());
        });
        let mut counts = EigenCounts::default();
        let omega_b = locate(
            &m,
            &LocateSettings {
                omega_max: 2.0,
                newton: &NewtonSettings::default(),
                continuation: &settings,
                criticality: true,
            },
            &mut counts,
        )
        .unwrap()
        .0
        .omega_b
        .unwrap();
        let dense_seconds = *reference.get_or_insert(seconds);
        println!(
            "{:>7} {seconds:>10.4} {omega_b:>16.12} {:>7} {:>6} {:>9}   ({:.2}x dense)",
            format!("{eigen:?}").to_lowercase(),
            counts.krylov,
            counts.dense,
            counts.fallbacks,
            dense_seconds / seconds
        );
    }
}
