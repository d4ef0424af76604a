//! Reference frames of the discrete rod: parallel transport, the Bishop frame of the natural
//! shape, and the chart (reference directors and reference twist) in which twist angles are
//! measured.

use super::Config;
use nalgebra::{RealField, Vector3};

/// Parallel transport of `w` from the unit tangent `u` to the unit tangent `v`: the rotation
/// about `b = u x v` that takes `u` to `v` (Rodrigues' formula with `sin = |b|`, `cos = c = u.v`):
///
/// `P w = c w + b x w + b (b.w) / (1 + c)`.
///
/// Smooth in `u` and `v` except at `v = -u`.
pub fn transport<T: RealField + Copy>(
    u: &Vector3<T>,
    v: &Vector3<T>,
    w: &Vector3<T>,
) -> Vector3<T> {
    let b = u.cross(v);
    let c = u.dot(v);
    w * c + b.cross(w) + b * (b.dot(w) / (T::one() + c))
}

/// Signed angle from `a` to `b` about the axis `t` (all perpendicular to `t`), in `(-pi, pi]`.
pub fn signed_angle<T: RealField + Copy>(a: &Vector3<T>, b: &Vector3<T>, t: &Vector3<T>) -> T {
    a.cross(b).dot(t).atan2(a.dot(b))
}

/// Reference twist at the interior node between two edges: the signed angle about `t1` from the
/// parallel transport of `d0` (edge `i-1`) onto edge `i` to `d1` (edge `i`), plus `offset`, a
/// multiple of `2 pi` that keeps the value continuous along a path.
pub fn reference_twist<T: RealField + Copy>(
    t0: &Vector3<T>,
    d0: &Vector3<T>,
    t1: &Vector3<T>,
    d1: &Vector3<T>,
    offset: f64,
) -> T {
    let p = transport(t0, t1, d0);
    signed_angle(&p, d1, t1) + nalgebra::convert::<f64, T>(offset)
}

/// The multiple of `2 pi` to add to the principal `angle` to land nearest to `near`.
pub fn unwrap_offset(angle: f64, near: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    two_pi * ((near - angle) / two_pi).round()
}

/// The chart in which twist angles are measured: unit tangents `t^j` and first reference
/// directors `d1^j` of every edge, and the reference twist `mref_i` of every node (zero at the
/// two end nodes, which carry none).
///
/// The energy at another configuration is evaluated with the directors parallel-transported
/// from this chart onto the new edges, so that the energy is a smooth function of positions and
/// angles near the chart ("source frame").
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Chart {
    pub tangents: Vec<Vector3<f64>>,
    pub directors: Vec<Vector3<f64>>,
    pub ref_twist: Vec<f64>,
}

impl Chart {
    /// The Bishop (space-parallel) frame of a polygon: the first director is the coordinate
    /// axis least aligned with the first edge, made perpendicular to it, then parallel
    /// transported edge to edge. Its reference twist is zero by construction.
    pub fn bishop(x: &[Vector3<f64>]) -> Self {
        let tangents: Vec<Vector3<f64>> = x.windows(2).map(|p| (p[1] - p[0]).normalize()).collect();
        let t0 = tangents[0];
        let axis = (0..3)
            .map(|k| Vector3::ith(k, 1.0))
            .min_by(|a: &Vector3<f64>, b| a.dot(&t0).abs().total_cmp(&b.dot(&t0).abs()))
            .expect("three axes");
        let mut d = (axis - t0 * t0.dot(&axis)).normalize();
        let mut directors = vec![d];
        for pair in tangents.windows(2) {
            d = transport(&pair[0], &pair[1], &d);
            d = (d - pair[1] * pair[1].dot(&d)).normalize();
            directors.push(d);
        }
        let mut chart = Chart {
            tangents,
            directors,
            ref_twist: vec![0.0; x.len()],
        };
        chart.ref_twist = chart.twists_near(&chart.ref_twist);
        chart
    }

    /// The chart carried to the configuration `x`: each director parallel-transported from its
    /// old tangent to the new one, the reference twist recomputed and unwrapped near the old one.
    pub fn transported(&self, x: &[Vector3<f64>]) -> Self {
        let tangents: Vec<Vector3<f64>> = x.windows(2).map(|p| (p[1] - p[0]).normalize()).collect();
        let directors = self
            .tangents
            .iter()
            .zip(&tangents)
            .zip(&self.directors)
            .map(|((old, new), d)| {
                let d = transport(old, new, d);
                (d - new * new.dot(&d)).normalize()
            })
            .collect();
        let moved = Chart {
            tangents,
            directors,
            ref_twist: Vec::new(),
        };
        Chart {
            ref_twist: moved.twists_near(&self.ref_twist),
            ..moved
        }
    }

    /// This chart with the frame of the clamped edge 0 (tangent and director) taken from
    /// `clamp`, the reference twist at node 1 recomputed near its old value. With the clamp's
    /// angle `theta^0 = 0`, this sets the material frame at the clamp to `clamp`'s: how a
    /// state carried to another member of a family of rods (whose clamp turns with the second
    /// parameter) is held by that member's own clamp.
    pub fn with_clamp_of(&self, clamp: &Chart) -> Chart {
        let mut chart = self.clone();
        chart.tangents[0] = clamp.tangents[0];
        chart.directors[0] = clamp.directors[0];
        chart.ref_twist = chart.twists_near(&self.ref_twist);
        chart
    }

    /// Reference twists of this chart's directors, each unwrapped near `near[i]`.
    fn twists_near(&self, near: &[f64]) -> Vec<f64> {
        let n = self.tangents.len() + 1;
        let mut twist = vec![0.0; n];
        for i in 1..n - 1 {
            let raw = reference_twist(
                &self.tangents[i - 1],
                &self.directors[i - 1],
                &self.tangents[i],
                &self.directors[i],
                0.0,
            );
            twist[i] = raw + unwrap_offset(raw, near[i]);
        }
        twist
    }
}

/// `config` (twist measured in the chart `from`) with its twist re-expressed in the chart `to`:
/// the same positions and the same material frames and discrete twists, hence the same energy.
///
/// With `mref_from`, `mref_to` the reference twists of the two charts carried to `config.x`
/// ([`Chart::transported`], unwrapped as the energy unwraps them), the twists
/// `m_i = theta^i - theta^{i-1} + mref_i` agree (edge 0 is clamped, its director the same in
/// both) when `theta_to^j = theta^j + sum_{i <= j} (mref_from_i - mref_to_i)`; exact, including
/// the multiples of `2 pi`, as long as no edge of `config` points opposite to its tangent in
/// either chart (where the parallel transport is singular).
pub fn rechart(config: &Config, from: &Chart, to: &Chart) -> Config {
    let a = from.transported(&config.x);
    let b = to.transported(&config.x);
    let mut theta = config.theta.clone();
    let mut shift = 0.0;
    for (j, t) in theta.iter_mut().enumerate().skip(1) {
        shift += a.ref_twist[j] - b.ref_twist[j];
        *t += shift;
    }
    Config {
        x: config.x.clone(),
        theta,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transport_is_the_rotation_taking_u_to_v() {
        let u: Vector3<f64> = Vector3::new(1.0, 2.0, 0.5).normalize();
        let v: Vector3<f64> = Vector3::new(-0.3, 1.0, 2.0).normalize();
        let w: Vector3<f64> = Vector3::new(0.2, -1.0, 0.7);
        assert!((transport(&u, &v, &u) - v).norm() < 1e-14);
        let pw = transport(&u, &v, &w);
        assert!((pw.norm() - w.norm()).abs() < 1e-14);
        // The component along u x v is unchanged.
        let b = u.cross(&v).normalize();
        assert!((pw.dot(&b) - w.dot(&b)).abs() < 1e-14);
    }

    #[test]
    fn bishop_frame_of_a_helix_is_orthonormal_and_twist_free() {
        let x: Vec<Vector3<f64>> = (0..30)
            .map(|i| {
                let p = 0.4 * i as f64;
                Vector3::new(p.cos(), p.sin(), 0.3 * p)
            })
            .collect();
        let chart = Chart::bishop(&x);
        for (t, d) in chart.tangents.iter().zip(&chart.directors) {
            assert!(t.dot(d).abs() < 1e-14 && (d.norm() - 1.0).abs() < 1e-14);
        }
        assert!(chart.ref_twist.iter().all(|m| m.abs() < 1e-14));
    }
}
