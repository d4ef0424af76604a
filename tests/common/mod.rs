//! Shared helpers of the integration tests.
#![allow(dead_code)]

use nalgebra::Vector3;

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
