//! Natural (stress-free) shapes and their discretization.
//!
//! Conventions of docs/model.md section 2: helix nodes at equal steps of the helix angle `phi` (all
//! natural edges are equal chords), arc and straight nodes at equal steps of arclength. Node 0 is
//! the clamp; the rotation axis is the `z` axis through the origin.

use nalgebra::Vector3;
use std::f64::consts::PI;

use crate::model::params::{ClampEdge, HelixClamp, ShapeParams};

/// Node positions of the natural shape, in SI units (m), node 0 at the clamp point.
///
/// * helix: `X(phi) = (R cos phi, -h R sin phi, -lambda phi / (2 pi))`, `phi_i = i 2 pi (l/lambda) / (N-1)`;
///   its axis is the rotation axis and the clamp sits at `X(0) = (R, 0, 0)`; with the axis clamp
///   ([`HelixClamp::Axis`]) see [`axis_clamped_helix`];
/// * arc: `X(s) = (R (1 - cos(s/R)), 0, -R sin(s/R))`, tangent `-e_z` at the clamp (the origin);
/// * straight: `X(s) = s (sin alpha, 0, -cos alpha)` from the clamp at the origin.
pub fn natural_nodes(shape: &ShapeParams, nodes: usize) -> Vec<Vector3<f64>> {
    if let ShapeParams::Helix {
        clamp: HelixClamp::Axis,
        ..
    } = shape
    {
        return axis_clamped_helix(shape, nodes);
    }
    let steps = (nodes - 1) as f64;
    (0..nodes)
        .map(|i| curve_point(shape, i as f64 / steps))
        .collect()
}

/// The natural nodes for the clamp discretization `clamp` ([`ClampEdge`]): [`natural_nodes`],
/// or with the clamped first edge centred on the clamp point, nodes at the fractions
/// `u_i = (i - 1/2)/(N - 3/2)` of the shape's parameter (`phi` for a helix, `s` otherwise), so
/// that the last node is the free end and the midpoint of the clamped edge lies at `u = 0`
/// (exactly for the straight rod, to `O(h^2)` on a curve: `X` continued above the clamp).
///
/// # Panics
/// For [`ClampEdge::Centred`] with the axis clamp (refused by [`crate::model::params::Physical::validate`]).
pub fn rod_nodes(shape: &ShapeParams, nodes: usize, clamp: ClampEdge) -> Vec<Vector3<f64>> {
    match clamp {
        ClampEdge::First => natural_nodes(shape, nodes),
        ClampEdge::Centred => {
            assert!(
                !matches!(
                    shape,
                    ShapeParams::Helix {
                        clamp: HelixClamp::Axis,
                        ..
                    }
                ),
                "a centred clamped edge is not defined for the axis clamp"
            );
            let steps = (nodes - 1) as f64 - 0.5;
            (0..nodes)
                .map(|i| curve_point(shape, (i as f64 - 0.5) / steps))
                .collect()
        }
    }
}

/// The point at the fraction `u` of the natural curve (the helix, arc or straight rod from its
/// clamp at `u = 0` to its free end at `u = 1`).
fn curve_point(shape: &ShapeParams, u: f64) -> Vector3<f64> {
    match *shape {
        ShapeParams::Helix {
            l,
            lambda,
            radius,
            handedness,
            ..
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
}

/// A helix held on the rotation axis: node 0 above the origin and node 1 at the origin (the
/// clamped first edge on the axis, pointing down, one helix chord long), a straight radial
/// connector from the origin to the helix's end `X(0) = (R, 0, 0)` in edges of about that chord,
/// then the helix at equal steps of `phi` with the remaining nodes.
fn axis_clamped_helix(shape: &ShapeParams, nodes: usize) -> Vec<Vector3<f64>> {
    let ShapeParams::Helix {
        l,
        lambda,
        radius,
        handedness,
        ..
    } = *shape
    else {
        unreachable!("called for helices only");
    };
    let own = ShapeParams::Helix {
        l,
        lambda,
        radius,
        handedness,
        clamp: HelixClamp::Helix,
    };
    let guess = own.contour_length() / (nodes - 1) as f64;
    let connector = ((radius / guess).round() as usize).clamp(1, nodes.saturating_sub(6).max(1));
    let helix = natural_nodes(&own, nodes - 1 - connector);
    let chord = (helix[1] - helix[0]).norm();
    let mut x = vec![Vector3::new(0.0, 0.0, chord), Vector3::zeros()];
    x.extend((1..connector).map(|k| Vector3::new(radius * k as f64 / connector as f64, 0.0, 0.0)));
    x.extend(helix);
    x
}

/// Voronoi lengths of the nodes of a polygon: half the adjacent edges (one half-edge at each end).
pub(crate) fn voronoi_lengths(x: &[Vector3<f64>]) -> Vec<f64> {
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
    use crate::model::params::Handedness;

    #[test]
    fn helix_has_equal_chords_and_is_shorter_than_the_curve() {
        let shape = ShapeParams::Helix {
            l: 0.2,
            lambda: 0.05,
            radius: 0.0159,
            handedness: Handedness::Right,
            clamp: HelixClamp::Helix,
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
    fn centred_clamp_puts_the_clamped_edge_across_the_clamp_point() {
        let shape = ShapeParams::Helix {
            l: 0.2,
            lambda: 0.05,
            radius: 0.0159,
            handedness: Handedness::Right,
            clamp: HelixClamp::Helix,
        };
        let x = rod_nodes(&shape, 41, ClampEdge::Centred);
        assert_eq!(x.len(), 41);
        let chords: Vec<f64> = x.windows(2).map(|p| (p[1] - p[0]).norm()).collect();
        assert!(chords.iter().all(|c| (c - chords[0]).abs() < 1e-14));
        // Node 0 above the clamp, the free end at the helix's end, the clamp point between
        // nodes 0 and 1 (to O(h^2): the chord's midpoint lies inside the helix).
        assert!(x[0].z > 0.0 && (x[40].z + 0.2).abs() < 1e-14);
        let clamp = ClampEdge::Centred.clamp_point(&x);
        assert!((clamp - Vector3::new(0.0159, 0.0, 0.0)).norm() < 0.1 * chords[0]);
        assert_eq!(
            rod_nodes(&shape, 41, ClampEdge::First),
            natural_nodes(&shape, 41)
        );
        let rod = rod_nodes(
            &ShapeParams::Straight {
                length: 0.12,
                alpha_deg: 15.0,
            },
            13,
            ClampEdge::Centred,
        );
        assert!(ClampEdge::Centred.clamp_point(&rod).norm() < 1e-16);
        assert!((rod[12].norm() - 0.12).abs() < 1e-14);
    }

    #[test]
    fn axis_clamp_starts_on_the_axis_and_joins_the_helix() {
        let shape = ShapeParams::Helix {
            l: 0.2,
            lambda: 0.05,
            radius: 0.0159,
            handedness: Handedness::Right,
            clamp: HelixClamp::Axis,
        };
        let x = natural_nodes(&shape, 60);
        assert_eq!(x.len(), 60);
        assert!(x[0].x == 0.0 && x[0].y == 0.0 && x[0].z > 0.0 && x[1].norm() == 0.0);
        // The helix part ends at the helix's far end.
        assert!((x[59].z + 0.2).abs() < 1e-14);
        let first_helix = x
            .iter()
            .position(|p| (p - Vector3::new(0.0159, 0.0, 0.0)).norm() < 1e-15)
            .unwrap();
        assert!(first_helix >= 3);
        // Connector edges are close to the helix chord.
        let chord = (x[first_helix + 1] - x[first_helix]).norm();
        let connector = (x[2] - x[1]).norm();
        assert!((connector / chord - 1.0).abs() < 0.5);
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
