//! Natural (stress-free) shapes and their discretization.
//!
//! Conventions of MODEL.md section 2: helix nodes at equal steps of the helix angle `phi` (all
//! natural edges are equal chords), arc and straight nodes at equal steps of arclength. Node 0 is
//! the clamp; the rotation axis is the `z` axis through the origin.

use nalgebra::Vector3;
use std::f64::consts::PI;

use crate::params::ShapeParams;

/// Node positions of the natural shape, in SI units (m).
///
/// * helix: `X(phi) = (R cos phi, -h R sin phi, -lambda phi / (2 pi))`, `phi_i = i 2 pi (l/lambda) / (N-1)`;
///   its axis is the rotation axis and the clamp sits at `X(0) = (R, 0, 0)`;
/// * arc: `X(s) = (R (1 - cos(s/R)), 0, -R sin(s/R))`, tangent `-e_z` at the clamp (the origin);
/// * straight: `X(s) = s (sin alpha, 0, -cos alpha)` from the clamp at the origin.
pub fn natural_nodes(shape: &ShapeParams, nodes: usize) -> Vec<Vector3<f64>> {
    let steps = (nodes - 1) as f64;
    (0..nodes)
        .map(|i| {
            let u = i as f64 / steps;
            match *shape {
                ShapeParams::Helix {
                    l,
                    lambda,
                    radius,
                    handedness,
                } => {
                    let phi = u * 2.0 * PI * l / lambda;
                    Vector3::new(
                        radius * phi.cos(),
                        -handedness.sign() * radius * phi.sin(),
                        -lambda * phi / (2.0 * PI),
                    )
                }
                ShapeParams::Arc { length, radius } => {
                    let a = u * length / radius;
                    Vector3::new(radius * (1.0 - a.cos()), 0.0, -radius * a.sin())
                }
                ShapeParams::Straight { length, alpha_deg } => {
                    let a = alpha_deg.to_radians();
                    u * length * Vector3::new(a.sin(), 0.0, -a.cos())
                }
            }
        })
        .collect()
}

/// Voronoi lengths of the nodes of a polygon: half the adjacent edges (one half-edge at each end).
pub fn voronoi_lengths(x: &[Vector3<f64>]) -> Vec<f64> {
    let n = x.len();
    let mut w = vec![0.0; n];
    for i in 0..n - 1 {
        let half = 0.5 * (x[i + 1] - x[i]).norm();
        w[i] += half;
        w[i + 1] += half;
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Handedness;

    #[test]
    fn helix_has_equal_chords_and_is_shorter_than_the_curve() {
        let shape = ShapeParams::Helix {
            l: 0.2,
            lambda: 0.05,
            radius: 0.0159,
            handedness: Handedness::Right,
        };
        let x = natural_nodes(&shape, 41);
        let chords: Vec<f64> = x.windows(2).map(|p| (p[1] - p[0]).norm()).collect();
        let c0 = chords[0];
        assert!(chords.iter().all(|c| (c - c0).abs() < 1e-14));
        let polygon: f64 = chords.iter().sum();
        let contour = shape.contour_length();
        assert!(polygon < contour && polygon > 0.98 * contour);
        assert!((x[40].z + 0.2).abs() < 1e-14);
        let w = voronoi_lengths(&x);
        assert!((w.iter().sum::<f64>() - polygon).abs() < 1e-14);
    }

    #[test]
    fn arc_and_straight_clamp_tangents() {
        let arc = natural_nodes(
            &ShapeParams::Arc {
                length: 0.12,
                radius: 0.0672,
            },
            50,
        );
        let t = (arc[1] - arc[0]).normalize();
        assert!(t.x.abs() < 0.05 && t.z < -0.99);
        let rod = natural_nodes(
            &ShapeParams::Straight {
                length: 0.12,
                alpha_deg: 15.0,
            },
            13,
        );
        let t = (rod[1] - rod[0]).normalize();
        assert!((t.z + 15f64.to_radians().cos()).abs() < 1e-14);
        assert!((rod[12].norm() - 0.12).abs() < 1e-14);
    }
}
