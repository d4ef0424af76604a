//! Shared helpers of the integration tests.
#![allow(dead_code)]

use helixbif::model::params::{Discretization, FluidParams, Physical, RodParams, ShapeParams};
use nalgebra::Vector3;

/// The `helixbif` binary as a command, its progress lines in a log (stderr is no terminal here)
/// held back for a day (`HELIXBIF_PROGRESS_SECONDS`): a run slowed down by the tests beside it
/// writes no line on stderr that its test does not expect.
pub fn command() -> std::process::Command {
    let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_helixbif"));
    command.env("HELIXBIF_PROGRESS_SECONDS", "86400");
    command
}

/// Runs the `helixbif` binary: exit code, stdout, stderr.
pub fn helixbif(args: &[&str]) -> (i32, String, String) {
    let out = command().args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

/// `helixbif run STUDY --out OUT`: the exit code, stdout and stderr.
pub fn run_into(study: &std::path::Path, out: &std::path::Path) -> (i32, String, String) {
    helixbif(&[
        "run",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ])
}

/// A straight, thin rubber rod (`E = 1 MPa`, `rho = 1000 kg/m^3`) of length `length` and radius
/// `r0`, clamped at `alpha_deg` from the downward vertical, in a weightless unit-viscosity fluid
/// (the weight comes from the rod alone, `q = rho g pi r0^2`).
pub fn straight_rod(length: f64, r0: f64, alpha_deg: f64, nodes: usize) -> Physical {
    Physical {
        rod: RodParams {
            youngs_modulus: 1e6,
            r0,
            rho: 1000.0,
            nu: 0.5,
        },
        fluid: FluidParams {
            mu: 1.0,
            rho: 0.0,
            g: 9.81,
            quadrature: Default::default(),
            model: helixbif::model::fluid::FluidModel::Lighthill,
            blob_radius: None,
            points_per_blob: None,
        },
        shape: ShapeParams::Straight { length, alpha_deg },
        discretization: Discretization {
            nodes,
            per_turn: None,
            clamp_edge: Default::default(),
        },
    }
}

/// A small deterministic pseudo-random generator (xorshift64*), so tests need no `rand` crate.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    /// Uniform in `[-1, 1)`.
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let bits = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11;
        2.0 * (bits as f64 / (1u64 << 53) as f64) - 1.0
    }
    pub fn vector(&mut self) -> Vector3<f64> {
        Vector3::new(self.uniform(), self.uniform(), self.uniform())
    }
}

/// Helix in units of its axial length: `X(phi) = (R cos phi, -h R sin phi, -pitch phi / 2 pi)`,
/// nodes at equal steps of `phi`.
pub fn helix(nodes: usize, radius: f64, pitch: f64, handedness: f64) -> Vec<Vector3<f64>> {
    let turns = 1.0 / pitch;
    (0..nodes)
        .map(|i| {
            let phi = 2.0 * std::f64::consts::PI * turns * i as f64 / (nodes - 1) as f64;
            Vector3::new(
                radius * phi.cos(),
                -handedness * radius * phi.sin(),
                -pitch * phi / (2.0 * std::f64::consts::PI),
            )
        })
        .collect()
}

/// Largest absolute difference between two slices, relative to the largest entry of `reference`.
pub fn relative_max_error(value: &[f64], reference: &[f64]) -> f64 {
    let scale = reference.iter().fold(0.0f64, |m, r| m.max(r.abs()));
    let err = value
        .iter()
        .zip(reference)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    err / scale
}

/// An empty temporary folder for one test (`helixbif-<name>-<pid>`), made anew.
pub fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("helixbif-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A small sweep study file in `dir`: 8 points (`lambda/l` from 0.2 to 0.34), 16 nodes.
pub fn small_sweep(dir: &std::path::Path) -> std::path::PathBuf {
    let path = dir.join("small.toml");
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/fig4b_pitch.toml"),
    )
    .unwrap()
    .replace("per_turn = 15.0", "")
    .replace("nodes = 60", "nodes = 16")
    .replace(
        "values = [0.15, 0.2, 0.25, 0.3, 0.35]",
        "values = [0.2, 0.22, 0.24, 0.26, 0.28, 0.3, 0.32, 0.34]",
    );
    std::fs::write(&path, text).unwrap();
    path
}

/// SplitMix64: a small deterministic pseudo-random generator (no `rand` dependency), for the
/// fluid tests' perturbed configurations.
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// Uniform in `[-1, 1)`.
    pub fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        2.0 * (z >> 11) as f64 / (1u64 << 53) as f64 - 1.0
    }

    pub fn vector(&mut self) -> Vector3<f64> {
        Vector3::new(self.uniform(), self.uniform(), self.uniform())
    }
}

/// Central finite differences of `X -> A(X) y` for a mobility `A`, step `h` on every coordinate:
/// column `3 j + k` is `(A(X + h e_jk) y - A(X - h e_jk) y) / (2 h)`.
pub fn finite_difference_derivative(
    mobility: impl Fn(&[Vector3<f64>]) -> faer::Mat<f64>,
    x: &[Vector3<f64>],
    y: &[Vector3<f64>],
    h: f64,
) -> faer::Mat<f64> {
    let n = x.len();
    let ys = helixbif::model::fluid::stack_vectors(y);
    let mut b = faer::Mat::zeros(3 * n, 3 * n);
    for j in 0..n {
        for k in 0..3 {
            let mut xp = x.to_vec();
            let mut xm = x.to_vec();
            xp[j][k] += h;
            xm[j][k] -= h;
            let dp = mobility(&xp) * &ys - mobility(&xm) * &ys;
            for r in 0..3 * n {
                b[(r, 3 * j + k)] = dp[(r, 0)] / (2.0 * h);
            }
        }
    }
    b
}

/// The free unknowns of the natural shape of `model`, each moved by `amp` natural edge lengths
/// times a uniform random number (seeded): a state away from equilibrium.
pub fn perturbed_natural(model: &helixbif::model::Model, amp: f64, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    let ds = model.rod.rest_lengths[0];
    helixbif::model::steady::Steady::new(model, 0.0)
        .free_vector(&model.natural_config())
        .iter()
        .map(|v| v + amp * ds * rng.uniform())
        .collect()
}
