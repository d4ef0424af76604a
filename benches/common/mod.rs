#![allow(dead_code)] // shared by several benchmarks, each using a part
//! Timing helpers shared by the benchmarks (no external harness: each benchmark prints a table).

use std::time::Instant;

/// Median wall time (seconds) of `f` over `repeats` runs, after one warm-up run.
pub fn median_seconds(repeats: usize, mut f: impl FnMut()) -> f64 {
    f();
    let mut times: Vec<f64> = (0..repeats)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// Log-log slope between consecutive (n, t) pairs: the apparent growth exponent in `n`.
pub fn growth(points: &[(usize, f64)]) -> Vec<f64> {
    points
        .windows(2)
        .map(|w| (w[1].1 / w[0].1).ln() / (w[1].0 as f64 / w[0].0 as f64).ln())
        .collect()
}

/// A line describing the machine, for the record.
pub fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!(
        "{cpu}, {cores} cores (dense LU, its solves and the RPY kernels on two threads, the rest \
         of faer on one; the RPY kernels' {} copy)",
        helixbif::model::fluid::rpy::KernelCopy::in_use().name()
    )
}
