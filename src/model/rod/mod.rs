//! Discrete Elastic Rods (Bergou et al. 2008, 2010): stretching, bending with natural curvature
//! and twisting with reference twist; energy, exact gradient and exact Hessian over the full
//! configuration vector of [`Layout`].
//!
//! Each energy term is a kernel over its few unknowns (an edge vector for stretching, two edges
//! and two angles for bending and twisting); [`Rod`] assembles them. The kernels see edge
//! vectors, so the map from edges to node positions (`e^i = x_{i+1} - x_i`) lives in one place,
//! [`Scatter`].

pub mod bend_twist;
pub mod frame;
pub mod stretch;

use faer::Mat;
use nalgebra::{SVector, Vector3};

use crate::model::dofs::Layout;
use crate::model::shape::voronoi_lengths;
use bend_twist::{BendTwist, STENCIL, strains, unknowns};
use frame::{Chart, unwrap_offset};

/// Elastic stiffnesses, in the solver's units (`EI = 1` there).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stiffness {
    pub ea: f64,
    pub ei: f64,
    pub gj: f64,
}

/// Positions of the nodes and twist angles of the edges.
#[derive(Clone, Debug, PartialEq)]
pub struct Config {
    pub x: Vec<Vector3<f64>>,
    pub theta: Vec<f64>,
}

/// The natural (stress-free) state of the rod and its stiffnesses.
#[derive(Clone, Debug)]
pub struct Rod {
    pub layout: Layout,
    pub stiffness: Stiffness,
    /// Natural edge lengths `|ebar^j|`.
    pub rest_lengths: Vec<f64>,
    /// Natural Voronoi lengths `wbar_i` (`lbar_i` at interior nodes, half-edges at the ends).
    pub weights: Vec<f64>,
    /// Natural material curvatures at every node (zero at the two ends).
    pub kappa_bar: Vec<[f64; 2]>,
    /// Natural twist at every node (zero at the two ends).
    pub twist_bar: Vec<f64>,
}

/// Where the unknowns of a kernel land in the full configuration vector: each local unknown is
/// a sum of at most two full unknowns with coefficients `+-1` (an edge component is
/// `x_{i+1,k} - x_{i,k}`).
struct Scatter<const M: usize> {
    terms: [[(usize, f64); 2]; M],
}

impl<const M: usize> Scatter<M> {
    fn add_gradient(&self, local: &SVector<f64, M>, full: &mut [f64]) {
        for (a, terms) in self.terms.iter().enumerate() {
            for &(p, c) in terms {
                full[p] += c * local[a];
            }
        }
    }

    fn add_hessian(&self, local: &nalgebra::SMatrix<f64, M, M>, full: &mut Mat<f64>) {
        for (a, ta) in self.terms.iter().enumerate() {
            for (b, tb) in self.terms.iter().enumerate() {
                let h = local[(a, b)];
                for &(p, cp) in ta {
                    for &(q, cq) in tb {
                        full[(p, q)] += cp * cq * h;
                    }
                }
            }
        }
    }
}

impl Rod {
    /// The rod whose natural shape is the polygon `natural`, and the Bishop chart of that shape.
    /// Natural curvatures and twist are those of the natural shape in its Bishop frame with
    /// `theta = 0`, so the natural shape is stress free.
    pub fn new(natural: &[Vector3<f64>], stiffness: Stiffness) -> (Self, Chart) {
        let layout = Layout::new(natural.len());
        let chart = Chart::bishop(natural);
        let mut rod = Rod {
            layout,
            stiffness,
            rest_lengths: natural.windows(2).map(|p| (p[1] - p[0]).norm()).collect(),
            weights: voronoi_lengths(natural),
            kappa_bar: vec![[0.0; 2]; natural.len()],
            twist_bar: vec![0.0; natural.len()],
        };
        let config = Config {
            x: natural.to_vec(),
            theta: vec![0.0; layout.edges()],
        };
        for i in 1..layout.nodes() - 1 {
            let (stencil, v) = rod.stencil(i, &config, &chart);
            let (k1, k2, m) = strains(&stencil, &v);
            rod.kappa_bar[i] = [k1, k2];
            rod.twist_bar[i] = m;
        }
        (rod, chart)
    }

    /// The edge vector `e^j = x_{j+1} - x_j`.
    fn edge_vector(config: &Config, j: usize) -> Vector3<f64> {
        config.x[j + 1] - config.x[j]
    }

    /// The bend-twist kernel of interior node `i` and its eight unknowns at `config`, with the
    /// reference directors transported from `chart`.
    fn stencil(
        &self,
        i: usize,
        config: &Config,
        chart: &Chart,
    ) -> (BendTwist, SVector<f64, STENCIL>) {
        let e0 = Self::edge_vector(config, i - 1);
        let e1 = Self::edge_vector(config, i);
        let v = unknowns(&e0, &e1, config.theta[i - 1], config.theta[i]);
        let mut stencil = BendTwist {
            source_t: [chart.tangents[i - 1], chart.tangents[i]],
            source_d: [chart.directors[i - 1], chart.directors[i]],
            twist_offset: 0.0,
            lbar: self.weights[i],
            kappa_bar: self.kappa_bar[i],
            twist_bar: self.twist_bar[i],
            ei: self.stiffness.ei,
            gj: self.stiffness.gj,
        };
        let (_, _, twist) = strains(&stencil, &v);
        let principal = twist - (v[7] - v[6]);
        stencil.twist_offset = unwrap_offset(principal, chart.ref_twist[i]);
        (stencil, v)
    }

    fn stencil_scatter(&self, i: usize) -> Scatter<STENCIL> {
        let l = &self.layout;
        let mut terms = [[(0, 0.0); 2]; STENCIL];
        for k in 0..3 {
            terms[k] = [(l.x(i, k), 1.0), (l.x(i - 1, k), -1.0)];
            terms[3 + k] = [(l.x(i + 1, k), 1.0), (l.x(i, k), -1.0)];
        }
        terms[6] = [(l.theta(i - 1), 1.0), (l.theta(i - 1), 0.0)];
        terms[7] = [(l.theta(i), 1.0), (l.theta(i), 0.0)];
        Scatter { terms }
    }

    fn edge_scatter(&self, j: usize) -> Scatter<3> {
        let l = &self.layout;
        Scatter {
            terms: std::array::from_fn(|k| [(l.x(j + 1, k), 1.0), (l.x(j, k), -1.0)]),
        }
    }

    /// Total elastic energy `E_s + E_b + E_t`.
    pub fn energy(&self, config: &Config, chart: &Chart) -> f64 {
        let stretch: f64 = (0..self.layout.edges())
            .map(|j| {
                let e = Self::edge_vector(config, j);
                stretch::stretch(self.stiffness.ea, self.rest_lengths[j], &e).0
            })
            .sum();
        let bend_twist: f64 = (1..self.layout.nodes() - 1)
            .map(|i| {
                let (s, v) = self.stencil(i, config, chart);
                s.energy(&v)
            })
            .sum();
        stretch + bend_twist
    }

    /// Gradient of the elastic energy over the full configuration vector.
    pub fn gradient(&self, config: &Config, chart: &Chart) -> Vec<f64> {
        let mut g = vec![0.0; self.layout.full_len()];
        for j in 0..self.layout.edges() {
            let e = Self::edge_vector(config, j);
            let (_, ge, _) = stretch::stretch(self.stiffness.ea, self.rest_lengths[j], &e);
            self.edge_scatter(j).add_gradient(&ge, &mut g);
        }
        for i in 1..self.layout.nodes() - 1 {
            let (s, v) = self.stencil(i, config, chart);
            let (_, gl) = s.gradient(&v);
            self.stencil_scatter(i).add_gradient(&gl, &mut g);
        }
        g
    }

    /// `dE/dtheta^j` for every edge `j` (stretching does not depend on the angles): the angle
    /// part of [`Rod::gradient`], at a fraction of its cost ([`BendTwist::twist_gradient`]).
    pub(crate) fn twist_gradient(&self, config: &Config, chart: &Chart) -> Vec<f64> {
        let mut g = vec![0.0; self.layout.edges()];
        for i in 1..self.layout.nodes() - 1 {
            let (s, v) = self.stencil(i, config, chart);
            let [g0, g1] = s.twist_gradient(&v);
            g[i - 1] += g0;
            g[i] += g1;
        }
        g
    }

    /// Gradient and Hessian (dense) of the elastic energy over the full configuration vector.
    pub fn hessian(&self, config: &Config, chart: &Chart) -> (Vec<f64>, Mat<f64>) {
        let n = self.layout.full_len();
        let mut g = vec![0.0; n];
        let mut h = Mat::zeros(n, n);
        for j in 0..self.layout.edges() {
            let e = Self::edge_vector(config, j);
            let (_, ge, he) = stretch::stretch(self.stiffness.ea, self.rest_lengths[j], &e);
            let scatter = self.edge_scatter(j);
            scatter.add_gradient(&ge, &mut g);
            scatter.add_hessian(&he, &mut h);
        }
        for i in 1..self.layout.nodes() - 1 {
            let (s, v) = self.stencil(i, config, chart);
            let (_, gl, hl) = s.hessian(&v);
            let scatter = self.stencil_scatter(i);
            scatter.add_gradient(&gl, &mut g);
            scatter.add_hessian(&hl, &mut h);
        }
        (g, h)
    }
}
