//! Cost of `locate` (continuation from rest to the first loss of stability, pinned down to
//! 1e-8): on the representative helix at N = 30, 60, 85, and on a longer rod (l = 0.4 m, whose
//! admissible range reaches N = 150) at N = 100 and 150; with the share of the time spent in
//! residual/Jacobian evaluations, in the stability pair (twist elimination and Z_ff), and in the
//! engine (bordered solves, eigenvalues), and the number of points and corrector iterations;
//! then the representative helix on the RPY fluid at N = 60, 240 and 400 (docs/model.md section
//! 9). Each row also gives the time per accepted point as a multiple of one LU factorization of
//! a bordered matrix of the corrector's size, measured in the same run (`helixbif::numerics::lu::Lu`, as the
//! corrector makes it: on two threads from 600 rows).
//!
//! Run: `cargo bench --bench locate`.

mod common;

use std::cell::RefCell;
use std::time::Instant;

use faer::Mat;
use helixbif::Result;
use helixbif::analysis::solve::rest_state;
use helixbif::engine::arclength::{Limits, follow};
use helixbif::engine::newton::NewtonSettings;
use helixbif::engine::stop::Silent;
use helixbif::engine::{ContinuationSettings, Linearization, Problem};
use helixbif::model::Model;
use helixbif::model::fluid::FluidModel;
use helixbif::model::params::{Physical, ShapeParams};
use helixbif::numerics::lu::Lu;
use helixbif::problem::rod::{Parameter, RodProblem};

/// The rod problem with a stopwatch on each call.
struct Timed<'a> {
    inner: RodProblem<&'a Model>,
    linearize: RefCell<(usize, f64)>,
    residual: RefCell<(usize, f64)>,
    stability: RefCell<(usize, f64)>,
}

fn timed<T>(cell: &RefCell<(usize, f64)>, f: impl FnOnce() -> T) -> T {
    let t = Instant::now();
    let out = f();
    let mut c = cell.borrow_mut();
    c.0 += 1;
    c.1 += t.elapsed().as_secs_f64();
    out
}

impl Problem for Timed<'_> {
    fn dim(&self) -> usize {
        self.inner.dim()
    }
    fn residual(&self, u: &[f64], p: f64) -> Result<Vec<f64>> {
        timed(&self.residual, || self.inner.residual(u, p))
    }
    fn linearize(&self, u: &[f64], p: f64) -> Result<Linearization> {
        timed(&self.linearize, || self.inner.linearize(u, p))
    }
    fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        self.inner.retract(u, du)
    }
    fn stability_pair(
        &self,
        u: &[f64],
        p: f64,
        lin: &Linearization,
    ) -> Result<(Mat<f64>, Mat<f64>)> {
        timed(&self.stability, || self.inner.stability_pair(u, p, lin))
    }
    fn scales(&self) -> (f64, f64) {
        self.inner.scales()
    }
    fn rechart(&self, u: &[f64], tangent: &[f64]) -> Option<Vec<f64>> {
        self.inner.rechart(u, tangent)
    }
}

fn run(label: &str, physical: &Physical) {
    let model = Model::new(physical).expect("valid benchmark model");
    let start = Instant::now();
    let rest = rest_state(&model, &NewtonSettings::default()).expect("rest state");
    let omegabar_max = model.scales.omega_to_bar(2.0);
    let problem = Timed {
        inner: RodProblem::new(
            &model,
            Parameter::Omega,
            helixbif::problem::rod::omega_scale(omegabar_max),
        ),
        linearize: RefCell::new((0, 0.0)),
        residual: RefCell::new((0, 0.0)),
        stability: RefCell::new((0, 0.0)),
    };
    let u0 = problem.inner.steady(0.0).free_vector(&rest.config);
    let limits = Limits {
        p_min: -1.0,
        p_max: omegabar_max,
        stop_at_first_instability: true,
    };
    let branch = follow(
        &problem,
        u0,
        0.0,
        1.0,
        &ContinuationSettings::default(),
        &limits,
        &mut Silent,
    )
    .expect("locate");
    let total = start.elapsed().as_secs_f64();
    let (nl, tl) = *problem.linearize.borrow();
    let (ns, ts) = *problem.stability.borrow();
    let (nr, tr) = *problem.residual.borrow();
    let omega_b = branch
        .events
        .last()
        .map_or(f64::NAN, |e| model.scales.omega_from_bar(e.p));
    let iterations: usize = branch.points.iter().map(|p| p.iterations).sum();
    let engine = total - tl - ts - tr;
    // One LU factorization of a bordered matrix of this size (the corrector's), for scale.
    let n = problem.dim() + 1;
    let bordered = Mat::from_fn(n, n, |i, j| {
        if i == j {
            4.0
        } else {
            1.0 / (1.0 + (i as f64 - j as f64).abs())
        }
    });
    let lu = common::median_seconds(3, || {
        std::hint::black_box(Lu::new(bordered.as_ref()));
    });
    let per_point = total / branch.points.len() as f64;
    println!(
        "{label:>14} {:>4}  per point {:>8.2}ms = {:>5.1} LUs of the bordered matrix (n = {n}, one LU {:.2}ms)",
        model.nodes(),
        per_point * 1e3,
        per_point / lu,
        lu * 1e3
    );
    println!(
        "{label:>14} {:>4} {:>8.3}s  omega_b {omega_b:.6}  points {:>3} corrector its {:>4}  linearize {nl:>4} x {:>6.2}ms = {:>4.1}%  stability {ns:>3} x {:>6.2}ms = {:>4.1}%  residual {nr:>3} = {:>4.1}%  engine (LU, eigen) {:>4.1}%",
        model.nodes(),
        total,
        branch.points.len(),
        iterations,
        tl / nl.max(1) as f64 * 1e3,
        100.0 * tl / total,
        ts / ns.max(1) as f64 * 1e3,
        100.0 * ts / total,
        100.0 * tr / total,
        100.0 * engine / total
    );
}

fn main() {
    helixbif::numerics::process::configure();
    // `cargo bench --bench locate -- rpy` runs only the rows whose label contains "rpy".
    let filter = std::env::args()
        .skip(1)
        .find(|a| !a.starts_with('-'))
        .unwrap_or_default();
    println!("locate, {}", common::machine());
    let mut rows = Vec::new();
    for n in [30, 60, 85] {
        let mut p = Physical::representative_lighthill();
        p.discretization.nodes = n;
        rows.push(("default", p));
    }
    for n in [100, 150] {
        let mut p = Physical::representative_lighthill();
        if let ShapeParams::Helix { l, .. } = &mut p.shape {
            *l = 0.4;
        }
        p.discretization.nodes = n;
        rows.push(("l = 0.4 m", p));
    }
    for n in [60, 240, 400] {
        let mut p = Physical::representative_lighthill();
        p.fluid.model = FluidModel::Rpy;
        p.discretization.nodes = n;
        rows.push(("rpy", p));
    }
    for (label, p) in rows.iter().filter(|(label, _)| label.contains(&filter)) {
        run(label, p);
    }
}
