//! Tests of the RPY-regularised centreline (`helixbif::fluid::rpy`, MODEL.md section 9).
//!
//! Run with `cargo test --release --test rpy -- --nocapture` to see the measured numbers.

use faer::{Mat, Side};
use helixbif::fluid::{
    Fluid, FluidModel, Lighthill, Quadrature, Resistance, Rpy, lighthill_cutoff, rpy_blob_radius,
    stack_vectors,
};
use helixbif::params::Physical;
use helixbif::shape::natural_nodes;
use nalgebra::Vector3;
use std::f64::consts::PI;

/// The representative helix (MODEL.md section 7) with `n` nodes, in units of its axial length
/// `l`, and its rod radius `r0 / l`.
fn helix(n: usize) -> (Vec<Vector3<f64>>, f64) {
    let p = Physical::representative();
    let l = p.shape.reference_length();
    let x = natural_nodes(&p.shape, n)
        .into_iter()
        .map(|v| v / l)
        .collect();
    (x, p.rod.r0 / l)
}

/// Straight rod of length `l` along z with `n` equally spaced nodes.
fn straight_rod(n: usize, l: f64) -> Vec<Vector3<f64>> {
    (0..n)
        .map(|k| Vector3::new(0.0, 0.0, l * k as f64 / (n - 1) as f64))
        .collect()
}

/// A hairpin: two parallel legs of length 1 along x (spacing `h`), `gap` apart in y, joined by a
/// semicircle of diameter `gap` (`arc_nodes` interior nodes). The return leg's nodes are shifted
/// by `shift` along x, so that its quadrature points need not face the first leg's.
fn hairpin(legs: usize, gap: f64, arc_nodes: usize, shift: f64) -> Vec<Vector3<f64>> {
    let h = 1.0 / (legs - 1) as f64;
    let mut x: Vec<Vector3<f64>> = (0..legs)
        .map(|k| Vector3::new(k as f64 * h, 0.0, 0.0))
        .collect();
    for k in 1..=arc_nodes {
        let t = PI * k as f64 / (arc_nodes + 1) as f64;
        x.push(Vector3::new(
            1.0 + 0.5 * gap * t.sin(),
            0.5 * gap * (1.0 - t.cos()),
            0.0,
        ));
    }
    x.extend((0..legs).map(|k| Vector3::new(1.0 - shift - k as f64 * h, gap, 0.0)));
    x
}

/// SplitMix64: a small deterministic pseudo-random generator.
struct SplitMix64(u64);

impl SplitMix64 {
    /// Uniform in `[-1, 1)`.
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        2.0 * (z >> 11) as f64 / (1u64 << 53) as f64 - 1.0
    }

    fn vector(&mut self) -> Vector3<f64> {
        Vector3::new(self.uniform(), self.uniform(), self.uniform())
    }
}

fn max_abs(m: &Mat<f64>) -> f64 {
    let mut out: f64 = 0.0;
    for c in 0..m.ncols() {
        for r in 0..m.nrows() {
            out = out.max(m[(r, c)].abs());
        }
    }
    out
}

fn arc_length(x: &[Vector3<f64>]) -> f64 {
    x.windows(2).map(|e| (e[1] - e[0]).norm()).sum()
}

fn smallest_eigenvalue(a: &Mat<f64>) -> f64 {
    a.self_adjoint_eigenvalues(Side::Lower).unwrap()[0]
}

/// Test 1: `A` symmetric positive definite.
#[test]
fn mobility_is_symmetric_positive_definite_at_every_resolution() {
    for n in [100, 200, 400] {
        let (x, r0) = helix(n);
        let a_blob = rpy_blob_radius(r0);
        let model = Rpy::for_polygon(1.0, a_blob, &x);
        let a = model.mobility(&x);
        Resistance::new(&a, "helix").unwrap();
        let lambda = smallest_eigenvalue(&a);
        let length = arc_length(&x);
        let h = length / (n - 1) as f64;
        println!(
            "helix N = {n}, Q = {}: lambda_min mu L = {:.4e}, lambda_min mu a^2 / h = {:.4e}, h/a = {:.3}",
            model.points_per_edge(),
            lambda * length,
            lambda * a_blob * a_blob / h,
            h / a_blob
        );
    }
    let r0 = 0.005;
    for (gap, shift) in [(0.5 * r0, 0.0), (0.05 * r0, 0.3 / 40.0)] {
        let x = hairpin(41, gap, 3, shift);
        let model = Rpy::for_polygon(1.0, rpy_blob_radius(r0), &x);
        let a = model.mobility(&x);
        Resistance::new(&a, "hairpin").unwrap();
        println!(
            "hairpin gap {:.3} r0: Q = {}, lambda_min mu L = {:.4e}",
            gap / r0,
            model.points_per_edge(),
            smallest_eigenvalue(&a) * arc_length(&x)
        );
    }
}

/// Central finite differences of `X -> A(X) y`.
fn finite_difference_derivative(
    model: &Rpy,
    x: &[Vector3<f64>],
    y: &[Vector3<f64>],
    h: f64,
) -> Mat<f64> {
    let n = x.len();
    let ys = stack_vectors(y);
    let mut b = Mat::zeros(3 * n, 3 * n);
    for j in 0..n {
        for k in 0..3 {
            let mut xp = x.to_vec();
            let mut xm = x.to_vec();
            xp[j][k] += h;
            xm[j][k] -= h;
            let dp = model.mobility(&xp) * &ys - model.mobility(&xm) * &ys;
            for r in 0..3 * n {
                b[(r, 3 * j + k)] = dp[(r, 0)] / (2.0 * h);
            }
        }
    }
    b
}

#[test]
fn derivative_matches_finite_differences() {
    let mut rng = SplitMix64(20261201);
    let r0 = 0.005;
    let (hx, hr0) = helix(16);
    let cases: Vec<(&str, Vec<Vector3<f64>>, f64)> = vec![
        ("helix", hx, hr0),
        ("two nodes", straight_rod(2, 0.1), r0),
        ("hairpin gap 0.5 r0", hairpin(8, 0.5 * r0, 2, 0.0), r0),
        ("hairpin gap 1.5 r0", hairpin(8, 1.5 * r0, 2, 0.05), r0),
        ("folded gap 0.05 r0", hairpin(8, 0.05 * r0, 1, 0.07), r0),
    ];
    for (name, x0, r0) in cases {
        let amplitude = 0.1 * arc_length(&x0) / (x0.len() - 1) as f64;
        let amplitude = amplitude.min(0.1 * r0);
        let x: Vec<Vector3<f64>> = x0.iter().map(|p| p + amplitude * rng.vector()).collect();
        let model = Rpy::for_polygon(1.0, rpy_blob_radius(r0), &x);
        let y: Vec<Vector3<f64>> = (0..x.len()).map(|_| rng.vector()).collect();
        let b = model.mobility_derivative(&x, &y);
        let b_fd = finite_difference_derivative(&model, &x, &y, 1e-7);
        let err = max_abs(&(&b - &b_fd)) / max_abs(&b);
        println!(
            "{name}: N = {}, Q = {}, max |B - B_fd| / max |B| = {err:.2e}",
            x.len(),
            model.points_per_edge()
        );
        assert!(err < 1e-6, "{name}: {err:.2e}");
    }
}

fn total_drag(z: &Resistance, n: usize, u: Vector3<f64>) -> Vector3<f64> {
    z.solve_vectors(&vec![u; n]).iter().sum()
}

#[test]
fn straight_rod_drag() {
    let l: f64 = 1.0;
    for aspect in [100.0, 1000.0] {
        let r0 = l / (2.0 * aspect);
        let log = (l / r0).ln() + 2f64.ln();
        let cyl = (2.0 * PI * l / (log - 1.5), 4.0 * PI * l / (log - 0.5));
        for intervals in [25, 50, 100, 200, 400] {
            let n = intervals + 1;
            let x = straight_rod(n, l);
            let model = Rpy::for_polygon(1.0, rpy_blob_radius(r0), &x);
            let t = std::time::Instant::now();
            let z = model.resistance(&x, "rod").unwrap();
            let ax = total_drag(&z, n, Vector3::z()).z;
            let tr = total_drag(&z, n, Vector3::x()).x;
            println!(
                "aspect {aspect}, N = {n}, Q = {}: axial {ax:.6} ({:.5}), transverse {tr:.6} ({:.5}) [{:.2}s]",
                model.points_per_edge(),
                ax / cyl.0,
                tr / cyl.1,
                t.elapsed().as_secs_f64()
            );
        }
    }
}

#[test]
fn rigid_helix_thrust() {
    for n in [60, 85] {
        let (x, r0) = helix(n);
        let u: Vec<Vector3<f64>> = x.iter().map(|p| Vector3::new(-p.y, p.x, 0.0)).collect();
        let l = Lighthill::from_radius(1.0, r0, Quadrature::Reference);
        let fl: Vector3<f64> = l.resistance(&x, "").unwrap().solve_vectors(&u).iter().sum();
        for m in [n, 2 * n, 4 * n] {
            let (xm, _) = helix(m);
            let um: Vec<Vector3<f64>> = xm.iter().map(|p| Vector3::new(-p.y, p.x, 0.0)).collect();
            let r = Rpy::for_polygon(1.0, rpy_blob_radius(r0), &xm);
            let fr: Vector3<f64> = r.resistance(&xm, "").unwrap().solve_vectors(&um).iter().sum();
            println!(
                "lighthill N = {n}: thrust {:.6}; rpy N = {m}: {:.6}, ratio {:.5}",
                fl.z,
                fr.z,
                fr.z / fl.z
            );
        }
    }
    let _ = (lighthill_cutoff(1.0), FluidModel::Rpy, std::any::type_name::<Fluid>());
}

#[test]
#[ignore]
fn explore_quadrature() {
    let l: f64 = 1.0;
    let r0 = l / 200.0;
    let a = rpy_blob_radius(r0);
    for intervals in [25usize, 50, 100, 200, 400, 800] {
        let n = intervals + 1;
        let x = straight_rod(n, l);
        let mut line = format!("N = {n}:");
        for q in [2usize, 4, 8, 16, 32, 64] {
            if (q as f64) * a * intervals as f64 > 40.0 || (q as f64) < 1.0 / (a * intervals as f64) {
                continue;
            }
            let model = Rpy::new(1.0, a, q);
            let z = model.resistance(&x, "rod").unwrap();
            let f = z.solve_vectors(&vec![Vector3::z(); n]);
            let ax: f64 = f.iter().map(|v| v.z).sum();
            line += &format!(" Q={q}: {ax:.7} (end {:.4})", f[0].z / ax);
        }
        println!("{line}");
    }
}

#[test]
#[ignore]
fn explore_timing() {
    for n in [60usize, 120, 240, 480] {
        let (x, r0) = helix(n);
        let a = rpy_blob_radius(r0);
        let h = arc_length(&x) / (n - 1) as f64;
        let y: Vec<Vector3<f64>> = x.iter().map(|p| Vector3::new(-p.y, p.x, 0.0)).collect();
        let t = std::time::Instant::now();
        let lh = Lighthill::from_radius(1.0, r0, Quadrature::Reference);
        let _ = lh.mobility(&x);
        let tl = t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        let _ = lh.mobility_derivative(&x, &y);
        let tld = t.elapsed().as_secs_f64();
        let mut line = format!("N = {n}: lighthill A {tl:.4}s B {tld:.4}s;");
        for c in [2.0, 4.0, 8.0] {
            let q = ((c * h / a).ceil() as usize).max(2);
            let model = Rpy::new(1.0, a, q);
            let t = std::time::Instant::now();
            let am = model.mobility(&x);
            let ta = t.elapsed().as_secs_f64();
            let t = std::time::Instant::now();
            let _ = model.mobility_derivative(&x, &y);
            let tb = t.elapsed().as_secs_f64();
            let t = std::time::Instant::now();
            let z = Resistance::new(&am, "").unwrap();
            let tz = t.elapsed().as_secs_f64();
            let f: Vector3<f64> = z.solve_vectors(&y).iter().sum();
            line += &format!(" c={c} Q={q}: A {ta:.4}s B {tb:.4}s chol {tz:.4}s thrust {:.7};", f.z);
        }
        println!("{line}");
    }
}
