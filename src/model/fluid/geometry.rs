//! Per-node geometry of the discretisation: Voronoi weight `w_i`, node tangent `t_i`, the
//! own-segment logarithm `L_i`, and the derivatives of `w_i` and `t_i` with respect to the
//! (at most three) nodes they depend on.
//!
//! Derivatives used (edge `e`, unit tangent `ê = e/|e|`):
//!
//! ```text
//! ∂|e|/∂e = ê^T,        ∂ê/∂e = (I - ê ê^T)/|e| =: P(e),
//! t = s/|s|  =>  ∂t/∂s = (I - t t^T)/|s|.
//! ```

use super::{Lighthill, Quadrature};
use nalgebra::{Matrix3, Vector3};

/// Dependence of `w_i` and `t_i` on one node `x_k`.
#[derive(Clone, Copy, Debug)]
pub(super) struct NodeDependence {
    /// The node `k`.
    pub node: usize,
    /// `∂w_i/∂x_k` (the gradient, a row vector stored as a column).
    pub dw: Vector3<f64>,
    /// `∂t_i/∂x_k`.
    pub dt: Matrix3<f64>,
}

/// Geometry of node `i` entering the diagonal block `A_ii`.
#[derive(Clone, Copy, Debug)]
pub(super) struct NodeGeometry {
    /// Voronoi weight `w_i`.
    pub w: f64,
    /// Unit tangent `t_i`.
    pub t: Vector3<f64>,
    /// Own-segment logarithm `L_i` (0 for [`Quadrature::Original`] and below the cut-off).
    pub log: f64,
    /// `dL_i/dw_i` (0 where `L_i` is held at 0).
    pub dlog_dw: f64,
    deps: [NodeDependence; 3],
    ndeps: usize,
}

impl NodeGeometry {
    /// The nodes `w_i`, `t_i` depend on, with the derivatives.
    pub(crate) fn dependences(&self) -> &[NodeDependence] {
        &self.deps[..self.ndeps]
    }
}

/// Edge `e = b - a` with its length, unit tangent and `P(e) = (I - ê ê^T)/|e|`.
struct Edge {
    len: f64,
    unit: Vector3<f64>,
    proj: Matrix3<f64>,
}

impl Edge {
    fn new(a: &Vector3<f64>, b: &Vector3<f64>) -> Self {
        let e = b - a;
        let len = e.norm();
        let unit = e / len;
        Self {
            len,
            unit,
            proj: (Matrix3::identity() - unit * unit.transpose()) / len,
        }
    }
}

impl Lighthill {
    /// Geometry of node `i` of the polygon `x` (`x.len() >= 2`).
    ///
    /// * End nodes: `w = |e|/2`, `t = ê` with `e` the end edge; `∂w/∂x = ∓ê/2`, `∂t/∂x = ∓P(e)`
    ///   for the first/second node of the edge.
    /// * Interior nodes: `w = (|e^{i-1}| + |e^i|)/2`, so `∂w/∂x_{i-1} = -ê^{i-1}/2`,
    ///   `∂w/∂x_i = (ê^{i-1} - ê^i)/2`, `∂w/∂x_{i+1} = ê^i/2`.
    ///   - `Reference`: `t = s/|s|`, `s = ê^{i-1} + ê^i`, `T = (I - t t^T)/|s|`:
    ///     `∂t/∂x_{i-1} = -T P(e^{i-1})`, `∂t/∂x_i = T (P(e^{i-1}) - P(e^i))`,
    ///     `∂t/∂x_{i+1} = T P(e^i)`.
    ///   - `Original`: `t = d/|d|`, `d = x_{i+1} - x_{i-1}`: `∂t/∂x_{i∓1} = ∓P(d)`,
    ///     `∂t/∂x_i = 0`.
    pub(super) fn node_geometry(&self, x: &[Vector3<f64>], i: usize) -> NodeGeometry {
        let n = x.len();
        let zero = NodeDependence {
            node: i,
            dw: Vector3::zeros(),
            dt: Matrix3::zeros(),
        };
        let (w, t, deps, ndeps, interior) = if i == 0 || i == n - 1 {
            let a = if i == 0 { 0 } else { n - 2 };
            let e = Edge::new(&x[a], &x[a + 1]);
            let deps = [
                NodeDependence {
                    node: a,
                    dw: -0.5 * e.unit,
                    dt: -e.proj,
                },
                NodeDependence {
                    node: a + 1,
                    dw: 0.5 * e.unit,
                    dt: e.proj,
                },
                zero,
            ];
            (0.5 * e.len, e.unit, deps, 2, false)
        } else {
            let prev = Edge::new(&x[i - 1], &x[i]);
            let next = Edge::new(&x[i], &x[i + 1]);
            let (t, dt) = match self.quadrature {
                Quadrature::Reference => {
                    let s = prev.unit + next.unit;
                    let s_len = s.norm();
                    let t = s / s_len;
                    let tp = (Matrix3::identity() - t * t.transpose()) / s_len;
                    (
                        t,
                        [
                            -tp * prev.proj,
                            tp * (prev.proj - next.proj),
                            tp * next.proj,
                        ],
                    )
                }
                Quadrature::Original => {
                    let d = Edge::new(&x[i - 1], &x[i + 1]);
                    (d.unit, [-d.proj, Matrix3::zeros(), d.proj])
                }
            };
            let dw = [
                -0.5 * prev.unit,
                0.5 * (prev.unit - next.unit),
                0.5 * next.unit,
            ];
            let deps = [0, 1, 2].map(|k| NodeDependence {
                node: i - 1 + k,
                dw: dw[k],
                dt: dt[k],
            });
            (0.5 * (prev.len + next.len), t, deps, 3, true)
        };
        let (log, dlog_dw) = match self.quadrature {
            Quadrature::Original => (0.0, 0.0),
            Quadrature::Reference if interior && w > 2.0 * self.delta => {
                ((w / (2.0 * self.delta)).ln(), 1.0 / w)
            }
            Quadrature::Reference if !interior && w > self.delta => {
                (0.5 * (w / self.delta).ln(), 0.5 / w)
            }
            Quadrature::Reference => (0.0, 0.0),
        };
        NodeGeometry {
            w,
            t,
            log,
            dlog_dw,
            deps,
            ndeps,
        }
    }
}
