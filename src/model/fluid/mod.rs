//! Hydrodynamics of a polygonal centreline: the mobility `A(X)` (nodal forces on the fluid to
//! nodal velocities), its shape derivative `B = ∂(A(X) y)/∂X` and the resistance `Z = A^{-1}`,
//! behind one interface, [`Fluid`], with two models ([`FluidModel`]):
//!
//! * [`Lighthill`] (the reference, documented below): Lighthill's slender-body theory with a
//!   point quadrature, positive definite only while the node spacing exceeds about `4 delta`;
//! * [`Rpy`] (module [`rpy`]): the Rotne–Prager–Yamakawa regularised line in a symmetric
//!   Galerkin form, positive definite at every resolution.
//!
//! # Lighthill (1976) slender-body theory
//!
//! ## Continuous theory
//!
//! A slender filament of radius `r0` and centreline `x(s)` pushes on a viscous fluid (viscosity
//! `mu`) with force per unit length `f(s)`. Lighthill's slender-body theory gives the centreline
//! velocity
//!
//! ```text
//! u(s) = (I - t t^T) f(s) / (4 pi mu)  +  ∫_{|x(s') - x(s)| > delta} J(x(s) - x(s')) f(s') ds'
//! ```
//!
//! with the Oseen tensor (Stokeslet) `J(r) = (I/|r| + r r^T/|r|^3) / (8 pi mu)` and the
//! cut-off `delta = r0 sqrt(e) / 2` ([`lighthill_cutoff`]).
//!
//! ## Discretisation
//!
//! Nodes `x_0 .. x_{N-1}`, edges `e^i = x_{i+1} - x_i`, unit edge tangents `ê^i = e^i/|e^i|`.
//! The force `F_j` (exerted by the rod on the fluid) is lumped at node `j`, i.e.
//! `f ≈ F_j / w_j` on the Voronoi segment of node `j`, whose length is
//!
//! ```text
//! w_0 = |e^0|/2,   w_i = (|e^{i-1}| + |e^i|)/2 (0 < i < N-1),   w_{N-1} = |e^{N-2}|/2.
//! ```
//!
//! The nodal velocities are `U = A(X) F` with the symmetric `3N x 3N` mobility matrix `A`
//! (node-major: row/column `3 i + k`, `k = 0, 1, 2` for `x, y, z`), assembled by one of two
//! [`Quadrature`]s:
//!
//! * [`Quadrature::Reference`]: the node tangent is the normalised sum of the adjacent unit edge
//!   tangents, `t_i = s_i/|s_i|`, `s_i = ê^{i-1} + ê^i` (the edge tangent at the two ends);
//!   off-diagonal blocks `A_ij = J(x_i - x_j)` if `|x_i - x_j| > delta`, else `0`; diagonal blocks
//!   hold the local term plus the Stokeslet integral over the node's own (straight) segment
//!   outside the cut-off:
//!
//!   ```text
//!   A_ii = [ (I - t_i t_i^T) + (I + t_i t_i^T) L_i ] / (4 pi mu w_i),
//!   L_i = ln(w_i / (2 delta))    if w_i > 2 delta, else 0   (interior nodes),
//!   L_i = (1/2) ln(w_i / delta)  if w_i > delta,   else 0   (end nodes),
//!   ```
//!
//!   i.e. `(I + t t^T)/(8 pi mu) ∫ ds/|s| (F_i/w_i)` over the straight own segment outside the
//!   cut-off: `2 ∫_delta^{w/2} ds/s` for an interior node, `∫_delta^{w} ds/s` (one-sided) at an
//!   end.
//!
//!   Two properties (checked in `tests/fluid.rs`): for a straight rod with spacing `h` the axial
//!   part of `A` is Toeplitz with symbol `[2 ln(h/(2 delta)) - 2 ln|2 sin(theta/2)|]/(4 pi mu h)`,
//!   so `A` is positive definite only while `h > 4 delta` (about the same on a helix); and the
//!   point Stokeslets replace `∫ ds/s` beyond the own segment by a harmonic sum that falls short
//!   by `ln 2 - gamma ≈ 0.116` per side whatever `h`, so the discrete operator behaves like
//!   Lighthill's with `ln(L/r0)` lowered by that amount (an `O(1/ln(L/r0))` relative excess of
//!   the drag, 1.5–2.6% for aspect ratios 1000–100).
//!
//! * [`Quadrature::Original`] (the variant of a published code): central-difference tangent
//!   `t_i = (x_{i+1} - x_{i-1}) / |x_{i+1} - x_{i-1}|` (edge tangent at the ends),
//!   `A_ii = (I - t_i t_i^T) / (4 pi mu w_i)` (no own-segment term) and all off-diagonal blocks
//!   `A_ij = J(x_i - x_j)` (no cut-off). Note that `A_ii t_i = 0`, so the quadratic form vanishes
//!   on a tangential force at a single node while the Stokeslets couple it to the other nodes:
//!   this `A` is never positive definite (use an LU solve, not [`Resistance`]).
//!
//! Both quadratures share the diagonal-block form
//! `A_ii = [ (1 + L_i) I + (L_i - 1) t_i t_i^T ] / (4 pi mu w_i)` (with `L_i = 0` for `Original`).
//!
//! [`Lighthill::mobility_derivative`] gives the shape derivative `B = ∂(A(X) y)/∂X` at fixed `y`
//! (equations in its documentation), and [`Resistance`] holds `Z = A^{-1}` as a Cholesky
//! factorisation.

mod derivative;
mod geometry;
mod lanes;
mod mobility;
mod resistance;
pub mod rpy;

pub use resistance::Resistance;
pub use rpy::{Rpy, rpy_blob_radius};

use crate::Result;
use crate::error::ModelError;
use crate::model::params::{ClampEdge, FluidParams};
use faer::Mat;
use nalgebra::Vector3;

/// Which hydrodynamic model a study uses (`fluid.model`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FluidModel {
    /// Lighthill's slender-body theory ([`Lighthill`]) as published: the paper's operator, kept
    /// for comparison; its node range is capped, so its discretization error is not controlled.
    Lighthill,
    /// The RPY-regularised centreline ([`Rpy`]), well posed at every `N`: the default.
    #[default]
    Rpy,
}

impl FluidModel {
    /// For a rod of radius `r0`, the length below which the node spacing makes the model's `A`
    /// indefinite, so that studies have an admissible node range: Lighthill's cut-off `delta`
    /// (definite while the spacing exceeds about `4 delta`); `None` for RPY, definite at every
    /// resolution.
    pub fn resolution_cutoff(self, r0: f64) -> Option<f64> {
        match self {
            FluidModel::Lighthill => Some(lighthill_cutoff(r0)),
            FluidModel::Rpy => None,
        }
    }
}

/// The hydrodynamic model of a study: the one interface the solver uses.
#[derive(Clone, Debug)]
pub enum Fluid {
    Lighthill(Lighthill),
    Rpy(Rpy),
}

impl Fluid {
    /// The dimensionless fluid (`mu = 1`, lengths in units of `ell`) of a rod of radius `r0`
    /// (SI, as `ell`) whose natural node positions (dimensionless) are `natural`, clamped as
    /// `clamp` says: the RPY quadrature is chosen from the natural edges ([`Rpy::for_rod`]).
    /// (Lighthill's line is used with [`ClampEdge::First`] only, see
    /// [`crate::model::params::Physical::validate`].)
    pub(crate) fn from_params(
        params: &FluidParams,
        r0: f64,
        ell: f64,
        natural: &[Vector3<f64>],
        clamp: ClampEdge,
    ) -> Self {
        match params.model {
            FluidModel::Lighthill => Fluid::Lighthill(Lighthill {
                mu: 1.0,
                delta: lighthill_cutoff(r0) / ell,
                quadrature: params.quadrature,
            }),
            FluidModel::Rpy => {
                let a = params.blob_radius.unwrap_or_else(|| rpy_blob_radius(r0));
                let per_blob = params.points_per_blob.unwrap_or(rpy::POINTS_PER_BLOB);
                Fluid::Rpy(Rpy::for_rod(1.0, a / ell, per_blob, natural, clamp))
            }
        }
    }

    /// The mobility matrix `A(x)` (`3N x 3N`, node-major, symmetric).
    pub fn mobility(&self, x: &[Vector3<f64>]) -> Mat<f64> {
        match self {
            Fluid::Lighthill(f) => f.mobility(x),
            Fluid::Rpy(f) => f.mobility(x),
        }
    }

    /// `A(x) Y` for the columns of `Y`: without assembling `A` on the RPY line
    /// ([`Rpy::mobility_product`]), as the assembled matrix times `Y` for Lighthill's operator.
    pub fn mobility_product(&self, x: &[Vector3<f64>], y: faer::MatRef<'_, f64>) -> Mat<f64> {
        match self {
            Fluid::Lighthill(f) => f.mobility(x) * y,
            Fluid::Rpy(f) => f.mobility_product(x, y),
        }
    }

    /// The shape derivative `B = ∂(A(X) y)/∂X` at fixed `y`.
    pub fn mobility_derivative(&self, x: &[Vector3<f64>], y: &[Vector3<f64>]) -> Mat<f64> {
        match self {
            Fluid::Lighthill(f) => f.mobility_derivative(x, y),
            Fluid::Rpy(f) => f.mobility_derivative(x, y),
        }
    }

    /// The resistance `Z = A(x)^{-1}`; errors name `context`.
    pub fn resistance(&self, x: &[Vector3<f64>], context: &str) -> Result<Resistance> {
        self.factorize(&self.mobility(x), x, context)
    }

    /// The resistance of the mobility `a`, already assembled at `x`; errors name `context`
    /// and, where `a` is not positive definite, say why the configuration may defeat it.
    pub(crate) fn factorize(
        &self,
        a: &Mat<f64>,
        x: &[Vector3<f64>],
        context: &str,
    ) -> Result<Resistance> {
        match self {
            Fluid::Lighthill(f) => f.factorize(a, x, context),
            Fluid::Rpy(_) => Rpy::factorize(a, context),
        }
    }

    /// Whether `A` is positive definite, so that `Z_ff` can serve as the mass matrix of the
    /// stability problem (false for Lighthill's original quadrature, where `A_ii t_i = 0`).
    pub fn is_mass_matrix(&self) -> bool {
        !matches!(
            self,
            Fluid::Lighthill(Lighthill {
                quadrature: Quadrature::Original,
                ..
            })
        )
    }

    /// Whether `A` is taken as symmetric positive definite without a check: the RPY line, short
    /// of a self-intersecting centreline (by construction with one quadrature rule for every pair
    /// of edges; its far field changes the smallest eigenvalue by its quadrature error, measured
    /// at most `4.1e-6` relative: [`Rpy`]'s documentation). Lighthill's is only within its
    /// admissible resolution and must be checked by a factorization.
    pub(crate) fn definite_by_construction(&self) -> bool {
        matches!(self, Fluid::Rpy(_))
    }

    /// The RPY line's quadrature points per edge; `None` for Lighthill's operator.
    pub fn points_per_edge(&self) -> Option<usize> {
        match self {
            Fluid::Lighthill(_) => None,
            Fluid::Rpy(f) => Some(f.points_per_edge()),
        }
    }

    /// The dimensionless [`FluidModel::resolution_cutoff`] of this fluid.
    pub fn resolution_cutoff(&self) -> Option<f64> {
        match self {
            Fluid::Lighthill(f) => Some(f.delta),
            Fluid::Rpy(_) => None,
        }
    }
}

/// How the slender-body integral is discretised (see the [module documentation](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Quadrature {
    /// Own-segment logarithm on the diagonal, cut-off `delta` on the off-diagonal Stokeslets,
    /// node tangent from the normalised sum of the adjacent unit edge tangents.
    #[default]
    Reference,
    /// Local term only on the diagonal, no cut-off, central-difference node tangent.
    Original,
}

/// Lighthill slender-body mobility of a polygonal filament.
#[derive(Clone, Copy, Debug)]
pub struct Lighthill {
    /// Dynamic viscosity `mu`.
    pub mu: f64,
    /// Cut-off length `delta`, normally [`lighthill_cutoff`]`(r0)`.
    pub delta: f64,
    /// Discretisation of the slender-body integral.
    pub quadrature: Quadrature,
}

impl Lighthill {
    /// Lighthill model for a rod of radius `r0` in a fluid of viscosity `mu`, with the cut-off
    /// `delta = r0 sqrt(e) / 2`.
    pub fn from_radius(mu: f64, r0: f64, quadrature: Quadrature) -> Self {
        Self {
            mu,
            delta: lighthill_cutoff(r0),
            quadrature,
        }
    }

    /// The resistance `Z = A(x)^{-1}` at the configuration `x`: a Cholesky factorization for the
    /// reference quadrature (failing with [`crate::Error::NotPositiveDefinite`], naming
    /// `context`, when `A` is not positive definite), an LU factorization for the original one.
    pub fn resistance(&self, x: &[Vector3<f64>], context: &str) -> crate::Result<Resistance> {
        self.factorize(&self.mobility(x), x, context)
    }

    /// [`Lighthill::resistance`] of the mobility `a`, already assembled at `x`.
    pub(crate) fn factorize(
        &self,
        a: &Mat<f64>,
        x: &[Vector3<f64>],
        context: &str,
    ) -> crate::Result<Resistance> {
        match self.quadrature {
            Quadrature::Reference => Resistance::new(a, context).map_err(|e| match e {
                crate::Error::Model(ModelError::NotPositiveDefinite { context, .. }) => {
                    ModelError::NotPositiveDefinite {
                        context,
                        geometry: self.diagnose(x),
                    }
                    .into()
                }
                e => e,
            }),
            Quadrature::Original => Resistance::general(a, context),
        }
    }

    /// Why a configuration may defeat the positivity of the discrete operator (docs/model.md
    /// section 3): its smallest node spacing and the closest approach of two nodes at least
    /// three apart along the rod, both in units of the cut-off `delta`.
    fn diagnose(&self, x: &[Vector3<f64>]) -> String {
        let d = self.delta;
        let spacing = x
            .windows(2)
            .enumerate()
            .map(|(i, w)| (i, (w[1] - w[0]).norm()))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let approach = (0..x.len())
            .flat_map(|i| (i + 3..x.len()).map(move |j| (i, j)))
            .map(|(i, j)| (i, j, (x[i] - x[j]).norm()))
            .min_by(|a, b| a.2.total_cmp(&b.2));
        let mut text = match spacing {
            Some((i, h)) => format!("smallest node spacing {:.2} delta (edge {i})", h / d),
            None => "no edges".to_owned(),
        };
        if let Some((i, j, r)) = approach {
            text += &format!(
                ", closest approach of non-adjacent nodes {:.2} delta (nodes {i} and {j})",
                r / d
            );
        }
        text + "; the discrete Lighthill operator stays positive only while the spacing exceeds \
                about 4 delta and parts of the rod stay several delta apart (docs/model.md \
                section 3): use fewer nodes, or a configuration farther from contact"
    }
}

/// Lighthill's cut-off length `delta = r0 sqrt(e) / 2` for a rod of radius `r0`.
///
/// With this choice the local expansion of the slender-body integral reproduces the
/// flow around a circular cylinder of radius `r0` (Lighthill 1976).
pub fn lighthill_cutoff(r0: f64) -> f64 {
    0.5 * r0 * std::f64::consts::E.sqrt()
}

/// Packs nodal 3-vectors node-major into a `3N x 1` column.
pub fn stack_vectors(v: &[Vector3<f64>]) -> faer::Mat<f64> {
    faer::Mat::from_fn(3 * v.len(), 1, |r, _| v[r / 3][r % 3])
}

/// Unpacks a node-major `3N x 1` column (column `col` of `m`) into nodal 3-vectors.
pub fn unstack_vectors(m: faer::MatRef<'_, f64>, col: usize) -> Vec<Vector3<f64>> {
    (0..m.nrows() / 3)
        .map(|i| Vector3::new(m[(3 * i, col)], m[(3 * i + 1, col)], m[(3 * i + 2, col)]))
        .collect()
}
