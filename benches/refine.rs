//! Cost of a converged `omega_b` (docs/model.md section 10), in one run on one machine:
//!
//! 1. the refinement of the built-in default (RPY line, `N = 60, 119, 237`, the answer the limit
//!    of the three) to the default accuracy `1e-3`, each rung's method and time, the Lyapunov
//!    coefficient at the finest rung, and the peak resident memory of the process after it; in
//!    the widest copy of the RPY kernels the processor has, and again in each narrower copy
//!    (AVX2, baseline), as a ratio to the first;
//! 2. one finer rung at `N = 473` by grid sequencing (from the `N = 237` rung's Hopf point,
//!    Newton on the carried state, the Hopf condition solved directly, the first-loss
//!    certificate) against a continuation from rest at `N = 473` (event search included), both
//!    without the Lyapunov coefficient, with the ratio and the difference of `omega_b`;
//! 3. the refinement to `1e-4` (at the default 8 quadrature points per blob radius, whose own
//!    error, 1.5e-4 relative, the refinement removes from its limit), with its peak memory.
//!
//! Run: `cargo bench --bench refine`.

mod common;

use std::time::Instant;

use helixbif::analysis::locate::{LocateSettings, locate};
use helixbif::analysis::refine::{Refinement, refine};
use helixbif::engine::ContinuationSettings;
use helixbif::engine::newton::NewtonSettings;
use helixbif::engine::stop::Silent;
use helixbif::model::Model;
use helixbif::model::fluid::rpy::{KernelCopy, use_at_most};
use helixbif::model::params::Physical;
use helixbif::study::Study;

/// Peak resident memory of this process so far (MB), from `/proc/self/status` (`VmHWM`).
fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

/// Prints a refinement's rungs and its answer.
fn print_refinement(label: &str, refinement: &Refinement, seconds: f64) {
    println!(
        "{label}: {seconds:.1} s wall, peak memory {:.0} MB",
        peak_rss_mb()
    );
    for r in &refinement.rungs {
        println!(
            "  N = {:4}  {:<12}  {:6.2} s  omega_b = {:.8} rad/s",
            r.nodes,
            r.method,
            r.seconds,
            r.omega_b.unwrap_or(f64::NAN)
        );
    }
    for q in [&refinement.quadrature, &refinement.quadrature_finer]
        .into_iter()
        .flatten()
    {
        println!(
            "  quadrature error at N = {}: {:+.2e} rad/s ({} against {} points per blob radius){}",
            q.nodes,
            q.error.unwrap_or(f64::NAN),
            q.points_per_blob,
            q.compared_with.unwrap_or(f64::NAN),
            q.failed
                .as_ref()
                .map_or(String::new(), |why| format!(": NOT measured, {why}"))
        );
    }
    if let Some(c) = &refinement.quadrature_correction {
        println!(
            "  removed from the limit: {:+.2e} rad/s, the correction's error {:.1e} rad/s",
            c.subtracted, c.error
        );
    }
    let rungs: f64 = refinement.rungs.iter().map(|r| r.seconds).sum();
    println!(
        "  omega_b = {:.7} +- {:.1e} rad/s ({:?}; {:.1e} relative, {}); the Lyapunov \
         coefficient, the quadrature's measurements and the rest: {:.1} s",
        refinement.finest.omega_b.unwrap_or(f64::NAN),
        refinement.omega_b_error.unwrap_or(f64::NAN),
        refinement.answer,
        refinement.relative_error.unwrap_or(f64::NAN),
        if refinement.reached {
            "reached"
        } else {
            "NOT reached"
        },
        seconds - rungs
    );
}

fn main() {
    helixbif::numerics::process::configure();
    println!("refinement of omega_b, {}", common::machine());
    let study = Study::load(None, &[]).unwrap();
    let physical = study.physical();
    let (newton, continuation) = (NewtonSettings::default(), ContinuationSettings::default());
    let with_l1 = LocateSettings {
        omega_max: study.branch.omega_max,
        newton: &newton,
        continuation: &continuation,
        criticality: true,
    };
    let quiet = LocateSettings {
        criticality: false,
        ..with_l1
    };

    // `physical` refined to `accuracy` (at most `max_nodes`), timed and printed; the seconds.
    let refined_to = |physical: &Physical, accuracy: f64, max_nodes: usize| {
        let started = Instant::now();
        let refinement = refine(physical, Some(accuracy), max_nodes, &with_l1, &mut Silent);
        let seconds = started.elapsed().as_secs_f64();
        print_refinement(
            &format!(
                "locate on the default, accuracy {accuracy:.0e}, {} kernels",
                KernelCopy::in_use().name()
            ),
            &refinement.unwrap(),
            seconds,
        );
        seconds
    };

    // 1. The default locate: refined to 1e-3, in the widest copy of the RPY kernels and again
    //    in each narrower one the processor has (the same bits, another time).
    let widest = KernelCopy::in_use();
    let seconds = refined_to(&physical, 1e-3, 500);
    for narrower in [KernelCopy::Avx2, KernelCopy::Baseline] {
        if narrower < widest {
            use_at_most(narrower);
            let t = refined_to(&physical, 1e-3, 500);
            println!(
                "  {:.2} times the time in the {} kernels",
                t / seconds,
                widest.name()
            );
        }
    }
    use_at_most(widest);

    // 2. One rung at N = 473: sequenced from N = 237 against a continuation from rest.
    let at = |nodes: usize| -> Physical {
        let mut p = physical.clone();
        p.discretization.nodes = nodes;
        p
    };
    let two = refine(&at(237), None, 473, &quiet, &mut Silent).unwrap();
    let Some(fine) = two.rungs.get(1) else {
        panic!(
            "the rung at N = 473 did not run: {}",
            two.stopped.as_deref().unwrap_or("no reason given")
        );
    };
    let started = Instant::now();
    let model = Model::new(&at(473)).unwrap();
    let (from_rest, _) = locate(&model, &quiet, &mut Silent).unwrap();
    let from_rest_seconds = started.elapsed().as_secs_f64();
    let (w_seq, w_rest) = (fine.omega_b.unwrap(), from_rest.omega_b.unwrap());
    println!(
        "one rung at N = 473: {} from N = 237 {:.2} s, continuation from rest {:.2} s: ratio \
         {:.3}; omega_b {:.10} and {:.10} rad/s (relative difference {:.1e})",
        fine.method,
        fine.seconds,
        from_rest_seconds,
        fine.seconds / from_rest_seconds,
        w_seq,
        w_rest,
        (w_seq - w_rest).abs() / w_rest
    );

    // 3. The refinement to 1e-4.
    refined_to(&physical, 1e-4, 500);
}
