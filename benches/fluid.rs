//! Cost of the hydrodynamic pieces on the representative helix, `rpy` against `lighthill` at the
//! same `N` (docs/model.md section 9): one mobility assembly `A(X)`, one shape derivative
//! `B = d(A y)/dX`, one resistance factorisation (Cholesky of `A`) and one product `A Y` without
//! assembly (`Fluid::mobility_product`, for `Y` a dense column and the six unit columns of the
//! clamp: what one velocity of the dynamics needs), at N = 60 .. 480, with the ratios and the
//! growth exponents in `N`. For Lighthill's operator the product is the assembly times `Y`.
//!
//! Lighthill's `A` is indefinite past N = 87 on this rod (docs/model.md section 3), so its
//! factorisation is timed on the RPY matrix of the same size where its own fails: Cholesky costs
//! the same whatever the entries. Both fluids run on the same rayon pool (2 threads here).
//!
//! The RPY line is timed twice: as it runs (its far field summed by the 4-point rule) and with
//! the composite rule on every pair (`Rpy::without_far_field`), the baseline of the far field's
//! saving (row `far`: the first over the second).
//!
//! Run: `cargo bench --bench fluid`.

mod common;

use helixbif::model::Model;
use helixbif::model::fluid::{Fluid, FluidModel, Resistance};
use helixbif::model::params::Physical;
use nalgebra::Vector3;

fn model(fluid: FluidModel, nodes: usize) -> Model {
    let mut p = Physical::representative_lighthill();
    p.fluid.model = fluid;
    p.discretization.nodes = nodes;
    Model::new(&p).expect("valid benchmark model")
}

/// Median seconds of (mobility, derivative, factorisation, product) on the natural shape.
fn costs(m: &Model, fallback: Option<&Model>) -> [f64; 4] {
    let x = &m.natural;
    let y: Vec<Vector3<f64>> = (0..x.len())
        .map(|i| Vector3::new(1.0, (i as f64).sin(), 0.3))
        .collect();
    let repeats = if x.len() > 200 { 3 } else { 7 };
    let fluid: &Fluid = &m.fluid;
    let mobility = common::median_seconds(repeats, || {
        std::hint::black_box(fluid.mobility(x));
    });
    let derivative = common::median_seconds(repeats, || {
        std::hint::black_box(fluid.mobility_derivative(x, &y));
    });
    let a = match fluid.resistance(x, "benchmark") {
        Ok(_) => fluid.mobility(x),
        Err(_) => fallback
            .expect("an RPY model of the same size")
            .fluid
            .mobility(x),
    };
    let factor = common::median_seconds(repeats, || {
        std::hint::black_box(Resistance::new(&a, "benchmark").expect("positive definite"));
    });
    let columns = faer::Mat::from_fn(3 * x.len(), 7, |r, c| match c {
        0 => (r as f64).cos(),
        c => f64::from(u8::from(r == c - 1)),
    });
    let product = common::median_seconds(repeats, || {
        std::hint::black_box(fluid.mobility_product(x, columns.as_ref()));
    });
    [mobility, derivative, factor, product]
}

fn main() {
    helixbif::numerics::process::configure();
    println!(
        "hydrodynamics on the representative helix, {}",
        common::machine()
    );
    let rpy_q = match &model(FluidModel::Rpy, 60).fluid {
        Fluid::Rpy(r) => r.points_per_edge(),
        Fluid::Lighthill(_) => unreachable!("an RPY model"),
    };
    println!("(RPY Gauss points per edge at N = 60: {rpy_q})");
    println!(
        "{:>5} {:>7} {:>12} {:>12} {:>12} {:>12}",
        "N", "fluid", "mobility", "derivative", "cholesky", "product"
    );
    let ladder = [60, 120, 240, 480];
    let mut table: Vec<(usize, [f64; 4], [f64; 4])> = Vec::new();
    for n in ladder {
        let rpy = model(FluidModel::Rpy, n);
        let lighthill = model(FluidModel::Lighthill, n);
        let mut composite = model(FluidModel::Rpy, n);
        composite.fluid = match composite.fluid {
            Fluid::Rpy(r) => Fluid::Rpy(r.without_far_field()),
            lighthill => lighthill,
        };
        let r = costs(&rpy, None);
        let all = costs(&composite, None);
        let l = costs(&lighthill, Some(&rpy));
        for (name, c) in [("rpy", r), ("no-far", all), ("light", l)] {
            println!(
                "{n:>5} {name:>7} {:>10.3}ms {:>10.3}ms {:>10.3}ms {:>10.3}ms",
                c[0] * 1e3,
                c[1] * 1e3,
                c[2] * 1e3,
                c[3] * 1e3
            );
        }
        // rpy over its composite rule everywhere, and over Lighthill's operator.
        for (name, base) in [("far", all), ("ratio", l)] {
            println!(
                "{n:>5} {name:>7} {:>11.2}x {:>11.2}x {:>11.2}x {:>11.2}x",
                r[0] / base[0],
                r[1] / base[1],
                r[2] / base[2],
                r[3] / base[3]
            );
        }
        table.push((n, r, l));
    }
    println!("growth exponents d ln t / d ln N between successive N:");
    for (i, piece) in ["mobility", "derivative", "cholesky", "product"]
        .iter()
        .enumerate()
    {
        for (name, pick) in [("rpy", 0), ("light", 1)] {
            let points: Vec<(usize, f64)> = table
                .iter()
                .map(|(n, r, l)| (*n, if pick == 0 { r[i] } else { l[i] }))
                .collect();
            let slopes: Vec<String> = common::growth(&points)
                .iter()
                .map(|s| format!("{s:.2}"))
                .collect();
            println!("  {piece:>10} {name:>6}: {}", slopes.join(" "));
        }
    }
}
