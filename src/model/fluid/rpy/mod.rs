//! The Rotne–Prager–Yamakawa (RPY) regularised centreline (docs/model.md section 9): a line of blobs
//! of radius `a`, discretised in a symmetric Galerkin form that is positive definite for every
//! node count and every configuration (by construction with one quadrature rule for every pair
//! of edges; the far field perturbs it by the quadrature's error, below).
//!
//! # Kernel
//!
//! With `r = |r|`, `rhat = r / r`, the RPY tensor of two blobs of radius `a` is
//! `M(r) = alpha(r) I + beta(r) rhat rhat^T`:
//!
//! ```text
//! r >= 2a:  alpha = (1 + 2a^2/(3 r^2)) / (8 pi mu r),   beta = (1 - 2a^2/r^2) / (8 pi mu r),
//! r <  2a:  alpha = (1 - 9 r/(32 a)) / (6 pi mu a),      beta = (3 r/(32 a)) / (6 pi mu a),
//! r  = 0 :  M = I / (6 pi mu a).
//! ```
//!
//! `alpha`, `beta` and their first derivatives are continuous at `r = 2a`. `M` is a positive
//! definite kernel: `M(r)` is the average of the Oseen tensor over the surfaces of two spheres of
//! radius `a` a distance `r` apart, whose Fourier symbol `(I - k k^T/k^2) sinc^2(k a)/(mu k^2)` is
//! positive semi-definite with only the longitudinal direction in its null space, so
//! `sum_pq G_p . M(y_p - y_q) G_q > 0` for forces `G != 0` on *distinct* points `y_p`, however
//! close (Rotne & Prager 1969; overlapping blobs: Wajnryb, Mizerski, Zuk & Szymczak 2013).
//! [`rpy_blob_radius`] gives the default `a = e^(3/2) r0 / 4`, for which the local (one-sided,
//! per unit force density) integral of `M` along a straight line equals Lighthill's:
//! `∫_0^X M_tt ds = (ln(X/(2a)) + 1)/(4 pi mu) = ln(X/delta)/(4 pi mu)` and
//! `2 ∫_0^X M_nn ds = (2 ln(X/(2a)) + 4)/(8 pi mu) = (2 ln(X/delta) + 2)/(8 pi mu)` (including
//! Lighthill's local term `1/(4 pi mu)`), both with `delta = 2a/e = r0 sqrt(e)/2`.
//!
//! # Galerkin discretisation
//!
//! Nodes `x_0 .. x_{N-1}`, edges `e_k = x_{k+1} - x_k`. Everything is written in the *material*
//! arclength `sigma` of the natural polygon (natural edge lengths `lbar_k`): the force on the
//! fluid per unit natural length `g(sigma)` (so `∫ g dsigma` is the total force, and
//! `∫∫ g M g dsigma dsigma'` is the same double integral as over the current centreline, by
//! `f ds = g dsigma`), and the velocity of the line `u(sigma) = sum_j phi_j(sigma) U_j`, the
//! piecewise-linear interpolation of the node velocities (hat functions `phi_j`) — exactly the
//! motion of the polygon, so a rigid motion of the nodes is a rigid motion of the line.
//!
//! **The ends carry point forces.** The line operator is of order `-2` (the `|r|` cone of `M` at
//! `r = 0`, below), like the kernel `|s - s'|` in one dimension, and a first-kind equation with
//! such a kernel has, on an interval, a solution with a *point force at each end* besides a smooth
//! density (for `∫|s - s'| g(s') ds' = u(s)`: `g = u''/2` plus `alpha delta_0 + beta delta_L`,
//! which fit the linear part that `u''` does not see). Measured on the rigid representative helix
//! with plain hat functions: the end node's force stays near `0.0124` as the spacing falls from
//! `a` to `a/8`, while interior node forces fall with the spacing; a hat function cannot hold a
//! point force, and the error left is of first order in the spacing (the drag and the thrust
//! converged at observed orders near 1, and `omega_b` with them). So the basis of the force
//! density is
//!
//! ```text
//! g(sigma) = F_0 delta(sigma) + sum_{0<j<N-1} F_j psi_j(sigma) / w_j + F_{N-1} delta(sigma - Lbar),
//! ```
//!
//! `psi_j` the hat function of interior node `j`, except that on an end edge it is `1` (the
//! interior node next to an end takes that edge whole: with the point force at the end the basis
//! still reproduces a uniform density, `F_j = g w_j`), `w_j = ∫ psi_j` (`w = 1` for a point
//! force: `F_0`, `F_{N-1}` are forces). The velocity is tested with the same functions,
//! `V_i = (1/w_i) ∫ psi_i u dsigma`, each by the one-point rule at the centroid of `psi_i` (exact
//! for a velocity linear along the rod; a point force's centroid is its end):
//!
//! ```text
//! A_e F = C U,    (A_e)_ij = (1/(w_i w_j)) ∫∫ psi_i(sigma) M(x(sigma) - x(sigma')) psi_j(sigma') dsigma dsigma',
//! C_ij = phi_j(centroid of psi_i)    (tridiagonal, constant; rows sum to 1).
//! ```
//!
//! At an interior node between equal edges the centroid is the node (`C_ii = 1`: the velocity
//! "collocated" at the node, as the hat functions alone had it); the hat of the node next to an
//! end, whole on the end edge, has its centroid `2h/9` towards the end (`C = [2/9, 7/9]`):
//! collocating there instead is an error of first order in `h` next to a node force of order
//! one. The force the fluid puts on node `i` in the balance of the rod, the virtual power of `g`
//! on a velocity of node `i` alone by the same rule, is `Q_i = (C^T F)_i`, and the mobility that
//! the rest of the program uses (node loads to node velocities) is
//!
//! ```text
//! U = A Q,    A = C^{-1} A_e C^{-T},
//! ```
//!
//! symmetric positive definite whenever `A_e` is (a congruence: `C` is strictly diagonally
//! dominant, hence invertible). Measured on the rigid representative helix (N = 60 .. 1889,
//! spacing `4.3 a .. 0.13 a`): thrust and torque converge at observed orders 1.9 .. 2.0, against
//! increments that changed sign and orders near 1 with hat functions; with the point forces
//! but `C = I` the node next to an end kept a force of order one at every spacing and the
//! torque's order wandered (3.1 .. 3.8 per halving). The Galerkin test itself
//! (`C_ij = (1/w_i) ∫ psi_i phi_j`, the consistent mass) gives the same order with a constant
//! four times larger on `omega_b`. A uniform velocity gives `U_i = u`.
//!
//! **Quadrature.** Every edge is cut into `m` equal cells with the two-point Gauss rule in each:
//! the same `Q = 2m` points `xi_q` in `(0, 1)` with weights `g_q` (`sum g_q = 1`) on every edge,
//! point `p = (k, q)` at `y_p = (1 - xi_q) x_k + xi_q x_{k+1}` with weight `c_p = g_q lbar_k`;
//! the point forces are two more points, `y = x_0` and `x_{N-1}`, of weight 1. One product rule
//! for every pair, the diagonal included, gives
//!
//! ```text
//! A_e = P^T M_pts P,   P_pj = c_p psi_j(y_p) / w_j,   M_pts = [M(y_p - y_q)]_pq,
//! ```
//!
//! (each entry times the `3 x 3` identity): `P` is sparse and constant (the material measure).
//! `A_e` is assembled edge pair by edge pair, `O((N Q)^2)` kernel evaluations (fewer with the far
//! field, below), without forming
//! `M_pts`, and the rows and columns of the point forces, `O(N Q)`, beside.
//!
//! **Why `A` is symmetric positive definite for every `N` and configuration** (with one rule for
//! every pair, as where `Q <= 4`; the far field below perturbs it by the quadrature's error). `F^T A_e F =
//! G^T M_pts G` with the point forces `G = P F`. (i) `P` has full column rank: a point force is a
//! point of its own; on an interior edge `k`, `G_p = c_p [(1 - xi_q) F_k / w_k + xi_q F_{k+1} /
//! w_{k+1}]` (`c_p > 0`) vanishes at two distinct `xi_q` only if `F_k = F_{k+1} = 0`, and on an
//! end edge `G_p = c_p F_j / w_j` of its interior node `j`. (ii) Gauss points are interior to
//! their edges and distinct from the nodes, so two points coincide only where two edges of the
//! polygon cross (or lie on top of each other) exactly at Gauss points: a self-intersecting
//! centreline. For any other polygon — near contact and overlapping blobs included — the points
//! are distinct, `M_pts` is positive definite and so are `A_e` and `A`. If points do coincide,
//! `M_pts` is only semi-definite and `F^T A_e F = 0` exactly when the forces summed over each set
//! of coincident points and the forces at the other points all vanish: two edges crossing at one
//! common Gauss point keep `A` definite (each keeps other points of its own, whose forces must
//! vanish), two identical edges (a rod folded exactly onto itself) make `A` singular, as they
//! should. `A` is made exactly symmetric by averaging with its transpose.
//!
//! **Far field.** Between two edges far apart `M` is analytic over the pair, and the composite
//! rule's `Q` points per edge buy nothing there. The pairs of edges whose midpoints are at least
//! `FAR_RATIO = 3` times the longer edge apart in the natural polygon, still at least
//! `FAR_RATIO_DEFORMED = 2` times in the configuration at hand, and whose points are at least
//! `2a` apart in both (so that every pair of points is on the analytic far branch of `M`), are
//! summed by the `FAR_POINTS = 4`-point Gauss rule on each edge instead, wherever the composite
//! rule has more points than that (`Q >= 8`): `A_e = P^T M_pts P` over the near pairs plus
//! `P_far^T M_far P_far` over the far ones, with `P_far` the same basis at the far rule's
//! points. On such a pair `r = 0` is at least one edge length from either edge (two in the
//! natural shape), and the far rule's error is of the order `rho^(-8)` of the pair's sum, `rho`
//! the ellipse with foci at the edge's ends that reaches it: `rho = 5 + sqrt(24)`,
//! `rho^(-8) = 1.1e-8`, in the natural shape, `rho = 3 + sqrt(8)`, `rho^(-8) = 7.5e-7`, at the
//! deformed threshold (measured on a helix: at most `2.6e-8` natural and `3.0e-7` coiled twice
//! as tight, and at most 1.6e-2 and 6.3e-2 of the error of the composite rule of 8 points it
//! replaces there; `tests::the_far_rule_is_more_accurate_than_the_composite_rule_it_replaces`).
//! The kernel passes take the near pairs by the near rule and the far pairs by the far rule,
//! per pair of edges, in the mobility, its product and its shape derivative alike, so the three
//! are the same operator and `B` its exact derivative. The natural polygon sorts the pairs, so
//! `A(X)` stays smooth in `X`; only where the rod folds far from its natural shape (a pair
//! comes within twice the longer edge) does a pair go back to the near rule, and `A(X)` steps
//! there by the difference of the two rules on that pair (mostly the composite rule's own
//! error). What it gives up: `A` is no congruence by construction; it differs from the
//! composite rule's congruence by that rule's error on the far pairs, which moved the smallest
//! eigenvalue by at most `4.1e-6` relative in `tests/rpy.rs` (the helix at `N = 100, 200`, two
//! hairpins). It is factorized by Cholesky wherever a resistance is made (every linearization
//! of the steady problem), which would report a loss of definiteness; the matrix-free velocity
//! (the dynamics, the Lyapunov coefficient) takes it as positive definite. The cost of one `A`
//! or `B` falls from `(N Q)^2` kernel evaluations to about `(4 N)^2` plus the near pairs'
//! `O(N Q^2)` (the kernels take a few groups of eight source edges around each edge by the near
//! rule).
//!
//! **Choice of `m`: the same points at every rung.** The product rule's error is second order in
//! the point spacing, and for *any* positive-weight rule it is of one sign: the point sum sees
//! the kernel's cone at `r = 0` through every point's interaction with itself, which a finer
//! rule shrinks but never cancels. What a convergence study in `N` needs is that this error be
//! the same at every rung. With a rule chosen per edge (`Q` Gauss points, `Q` rounded up from the
//! edge length) the point pattern, and with it the error, jumped from one `N` to the next (by up
//! to `2e-4` of `omega_b`, the size of the discretisation increments). Here `m` is the power of
//! two nearest to `per_blob * lbar / (2 a)` (at least 1), from the longest natural edge: halving
//! the edges (`N -> 2N - 1`) halves `m`, and the points of the natural polygon keep their
//! spacing as long as `m >= 2` before the halving (the refinement in `N` stops before a rung
//! whose spacing differs, `crate::analysis::refine`).
//! `m` is held fixed for every configuration of the model so that `A(X)` is smooth in `X`.
//!
//! **Spectrum.** The line operator is of order `-2` (the `|r|` term of `M` at `r = 0`), coercive
//! in `H^{-1}`: its smallest eigenvalue falls like the node spacing `h` (measured in
//! `tests/rpy.rs`), positive at every `N`.
//!
//! # Shape derivative
//!
//! `B = ∂(A(X) y)/∂X` at fixed `y` ([`Rpy::mobility_derivative`]). `C` and `P` are constant, so
//! with `z = C^{-T} y`, `B = C^{-1} B_e` and `B_e = ∂(A_e(X) z)/∂X`. With the point forces
//! `G_p = sum_j P_pj z_j`, `(A_e z)_i = sum_pq P_pi M(y_p - y_q) G_q`, and everything depends on
//! `X` through the point positions alone (linear: `∂y_p/∂x_k = 1 - xi_q`, `∂y_p/∂x_{k+1} = xi_q`;
//! a point force's `y` is its node):
//!
//! ```text
//! d(M(r) G)/dr =: D(r, G) = alpha' G rhat^T + beta' (rhat.G) rhat rhat^T
//!                          + (beta/r) [ rhat G^T + (rhat.G) I - 2 (rhat.G) rhat rhat^T ],
//! d(A_e z)_i = sum_pq P_pi D(y_p - y_q, G_q) (dy_p - dy_q).
//! ```
//!
//! At `r = 0` (a point with itself) the term cancels (`dy_p - dy_p = 0`); coincident distinct
//! points, where `M` has a cone singularity, are given `D = 0`. The cost is that of `A`.

mod basis;
mod kernels;
mod quadrature;

pub use kernels::{KERNELS_VARIABLE, KernelCopy, cap_from_environment, use_at_most};

use super::Resistance;
use super::lanes::LANES;
use super::mobility::add_block;
use super::unstack_vectors;
use crate::error::ModelError;
use crate::model::params::ClampEdge;
use crate::{Error, Result};
use basis::Basis;
use faer::{Mat, MatRef};
use kernels::PointLanes;
use nalgebra::{Matrix3, Vector3};
use quadrature::{Edges, FAR_POINTS, GaussRule, cells_per_edge};
use rayon::prelude::*;

/// Quadrature points per blob radius, about: an edge of natural length `lbar` is cut into `m`
/// cells of two Gauss points each, `m` the power of two nearest to
/// `POINTS_PER_BLOB * lbar / (2 a)` (at least 1), so the points are between `a / 11` and
/// `a / 5.7` apart (see the [module documentation](self) for why a power of two). The product
/// rule's error is second order in the spacing (the `|r|` cone of `M` on the diagonal) and of one
/// sign; see docs/model.md section 9 for what it costs `omega_b`.
pub const POINTS_PER_BLOB: f64 = 8.0;

/// The points per blob radius a model takes (`fluid.points_per_blob`; the near pairs' kernels
/// cost its square).
pub const POINTS_PER_BLOB_RANGE: std::ops::RangeInclusive<f64> = 2.0..=64.0;

/// The blob radius `a = e^(3/2) r0 / 4` that reproduces the slender-body local drag of a
/// cylinder of radius `r0` (see the [module documentation](self)).
pub fn rpy_blob_radius(r0: f64) -> f64 {
    1.5f64.exp() * r0 / 4.0
}

/// The RPY line mobility (see the [module documentation](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct Rpy {
    /// Dynamic viscosity `mu`.
    pub mu: f64,
    /// Blob radius `a`, normally [`rpy_blob_radius`]`(r0)`.
    pub blob_radius: f64,
    rule: GaussRule,
    /// The basis in the material measure of the natural polygon (constant; boxed, so that
    /// [`super::Fluid`] stays small).
    basis: Box<Basis>,
    /// The far field's rule, where the edges hold more points than it (boxed, as `basis`).
    far: Option<Box<FarRule>>,
    /// The clamped edge is centred on the clamp point ([`ClampEdge::Centred`]): the line starts
    /// at the clamp point, the midpoint of `x_0` and `x_1`.
    centred_clamp: bool,
}

/// The rule of the far field: [`FAR_POINTS`] Gauss points on every edge, the weights
/// `[c_p psi_k(y_p), c_p psi_{k+1}(y_p)]` of its points in the basis (as [`Basis::pw`]), and the
/// edges of the natural polygon, which say which pairs it may take.
#[derive(Clone, Debug, PartialEq)]
struct FarRule {
    rule: GaussRule,
    pw: Vec<[f64; 2]>,
    natural: Edges,
}

/// One rule's quadrature points on the edges of one configuration.
struct PointSet<'a> {
    /// The points' parameters `xi_q` along their edge (`Q` of them, the same on every edge).
    xi: &'a [f64],
    /// The points' weights in the basis, `[c_p psi_k(y_p), c_p psi_{k+1}(y_p)]`, `p = k Q + q`.
    pw: &'a [[f64; 2]],
    /// Point positions `y_p`.
    pos: Vec<Vector3<f64>>,
    /// The points and weights transposed for the kernels.
    lanes: PointLanes,
}

impl PointSet<'_> {
    /// Points per edge `Q`.
    fn per_edge(&self) -> usize {
        self.xi.len()
    }
}

/// Geometry of one configuration: the quadrature points of the near rule and of the far rule
/// (where there is one), and which pairs of edges the far rule takes ([`Rpy::discretise`]).
struct Discretisation<'a> {
    near: PointSet<'a>,
    far: Option<PointSet<'a>>,
    /// Number of edges.
    edges: usize,
    /// Whether the far rule takes the edges `k` and `j`, at `k * edges + j` (empty without a
    /// far rule).
    far_pairs: Vec<bool>,
}

impl Discretisation<'_> {
    /// Whether the far rule takes the edges `k` and `j`.
    fn far_apart(&self, k: usize, j: usize) -> bool {
        self.far_pairs
            .get(k * self.edges + j)
            .copied()
            .unwrap_or(false)
    }
}

/// Columns of [`Rpy::mobility_product`] whose point forces sit on the same groups of source
/// edges: they go through the kernel together, sharing its evaluations.
struct SourceGroup {
    /// The first edge of each group of [`LANES`] edges with a force in any of the columns.
    sources: Vec<usize>,
    /// The columns.
    columns: Vec<usize>,
    /// Their point forces by component ([`kernels::PointLanes`] layout) at the near rule's
    /// points.
    forces: Vec<[Vec<f64>; 3]>,
    /// The same at the far rule's points (empty without one).
    far_forces: Vec<[Vec<f64>; 3]>,
}

/// What the points of one edge `k` contribute in [`Rpy::mobility_derivative`]: for the rows
/// `i = k, k + 1`, the blocks `B_ij` (all `j`).
struct EdgeRows {
    b: [Vec<Matrix3<f64>>; 2],
}

/// Runs `task(k)` for `k = 0 .. count` on the rayon pool, 32 tasks per thread at a time, and
/// hands the results to `merge` in the order of `k`: the sums are the same whatever the number
/// of threads. A batch is merged while the next one is computed (the merge, which writes into
/// one matrix, runs on one thread: by `perf` at RPY `N = 400`, about 40% of the kernels' time in
/// the mobility and a sixth in its shape derivative), so two batches of results are held at
/// once.
fn in_parallel_batches<T: Send>(
    count: usize,
    task: impl Fn(usize) -> T + Sync,
    mut merge: impl FnMut(usize, T) + Send,
) {
    let batch = 32 * rayon::current_num_threads();
    let mut merged = |start: usize, results: Vec<T>| {
        for (k, result) in (start..).zip(results) {
            merge(k, result);
        }
    };
    let mut pending: Option<(usize, Vec<T>)> = None;
    for start in (0..count).step_by(batch) {
        let end = (start + batch).min(count);
        let (results, ()) = rayon::join(
            || (start..end).into_par_iter().map(&task).collect(),
            || {
                if let Some((before, results)) = pending.take() {
                    merged(before, results);
                }
            },
        );
        pending = Some((start, results));
    }
    if let Some((before, results)) = pending {
        merged(before, results);
    }
}

/// The longest edge of the polygon `natural`, which sets the quadrature's cells per edge
/// ([`Rpy::for_polygon`]).
pub fn longest_edge(natural: &[Vector3<f64>]) -> f64 {
    natural
        .windows(2)
        .map(|e| (e[1] - e[0]).norm())
        .fold(0.0, f64::max)
}

impl Rpy {
    /// RPY mobility for configurations of the polygon `natural` (`N >= 2` nodes; its edge
    /// lengths are the material measure, see the [module documentation](self)), with `cells`
    /// cells of two Gauss points on every edge.
    ///
    /// # Panics
    /// If `cells == 0`, the blob radius is not positive or `natural` has fewer than two nodes or
    /// an edge of zero length.
    pub fn new(mu: f64, blob_radius: f64, cells: usize, natural: &[Vector3<f64>]) -> Self {
        assert!(
            cells >= 1,
            "RPY quadrature needs at least one cell per edge"
        );
        assert!(
            blob_radius > 0.0,
            "RPY blob radius must be > 0, got {blob_radius}"
        );
        assert!(
            natural.len() >= 2,
            "RPY mobility needs at least two nodes, got {}",
            natural.len()
        );
        let lbar: Vec<f64> = natural.windows(2).map(|e| (e[1] - e[0]).norm()).collect();
        assert!(
            lbar.iter().all(|&l| l > 0.0),
            "RPY mobility needs edges of positive length"
        );
        let rule = GaussRule::composite(cells);
        let far = (rule.xi.len() > FAR_POINTS).then(|| {
            let rule = GaussRule::new(FAR_POINTS);
            let pw = Basis::new(&lbar, &rule).pw;
            let natural = Edges::of(natural);
            Box::new(FarRule { rule, pw, natural })
        });
        Self {
            mu,
            blob_radius,
            basis: Box::new(Basis::new(&lbar, &rule)),
            rule,
            far,
            centred_clamp: false,
        }
    }

    /// RPY mobility of a rod whose natural nodes are `natural`, clamped as `clamp` says: with
    /// [`ClampEdge::First`] the line is the polygon ([`Rpy::for_polygon`]); with
    /// [`ClampEdge::Centred`] the half edge above the clamp is no part of the rod, and the line
    /// is the polygon `x_f = T x` whose first node is the clamp point, `(x_0 + x_1)/2`. The
    /// mobility of the rod's nodes is then `T^{-1} A(x_f) T^{-T}` (the force on the line's first
    /// node shared equally by `x_0` and `x_1`, whose motion is the mean of theirs: a congruence,
    /// so still symmetric positive definite). Both nodes are clamped, so only the clamp
    /// reactions are shared.
    pub fn for_rod(
        mu: f64,
        blob_radius: f64,
        per_blob: f64,
        natural: &[Vector3<f64>],
        clamp: ClampEdge,
    ) -> Self {
        let centred_clamp = clamp == ClampEdge::Centred;
        let line = if centred_clamp {
            let mut line = natural.to_vec();
            line[0] = clamp.clamp_point(natural);
            line
        } else {
            natural.to_vec()
        };
        Self {
            centred_clamp,
            ..Self::for_polygon(mu, blob_radius, per_blob, &line)
        }
    }

    /// The nodes of the line for the rod's nodes `x` (see [`Rpy::for_rod`]).
    fn line_nodes<'a>(&self, x: &'a [Vector3<f64>]) -> std::borrow::Cow<'a, [Vector3<f64>]> {
        if self.centred_clamp {
            let mut line = x.to_vec();
            line[0] = ClampEdge::Centred.clamp_point(x);
            std::borrow::Cow::Owned(line)
        } else {
            std::borrow::Cow::Borrowed(x)
        }
    }

    /// RPY mobility for configurations of the polygon `natural` with `m` cells of two Gauss
    /// points on every edge, `m` the power of two nearest to `per_blob * l_max / (2 a)` (at
    /// least 1), `l_max` its longest edge (`per_blob`: [`POINTS_PER_BLOB`] by default). Halving
    /// the edges halves `m` and keeps the points where they were (see the
    /// [module documentation](self)).
    pub fn for_polygon(mu: f64, blob_radius: f64, per_blob: f64, natural: &[Vector3<f64>]) -> Self {
        let longest = longest_edge(natural);
        Self::new(
            mu,
            blob_radius,
            cells_per_edge(per_blob * longest / (2.0 * blob_radius)),
            natural,
        )
    }

    /// The same model with the composite rule on every pair of edges, far apart or not (see
    /// *Far field* in the [module documentation](self)): the baseline the far field is measured
    /// against (`benches/fluid.rs`, the module's tests).
    pub fn without_far_field(mut self) -> Self {
        self.far = None;
        self
    }

    /// Gauss points per edge `Q` (two per cell).
    pub fn points_per_edge(&self) -> usize {
        self.rule.xi.len()
    }

    /// Number of nodes `N` of the polygon the model was built for.
    pub fn nodes(&self) -> usize {
        self.basis.w.len()
    }

    /// The mobility matrix `A(X) = C^{-1} A_e(X) C^{-T}`, `A_e = P^T M_pts P` over the near
    /// pairs plus the far field's sum over the far ones (`3N x 3N`, node-major, symmetric
    /// positive definite; see the [module documentation](self)), of the rod's nodes
    /// ([`Rpy::for_rod`]).
    ///
    /// # Panics
    /// If `x` has another number of nodes than the polygon of the model.
    pub fn mobility(&self, x: &[Vector3<f64>]) -> Mat<f64> {
        let mut a = self.line_mobility(&self.line_nodes(x));
        if self.centred_clamp {
            // T^{-1} A T^{-T}: node 0's row and column become 2 (0) - (1).
            for c in 0..a.ncols() {
                for k in 0..3 {
                    a[(k, c)] = 2.0 * a[(k, c)] - a[(3 + k, c)];
                }
            }
            for r in 0..a.nrows() {
                for k in 0..3 {
                    a[(r, k)] = 2.0 * a[(r, k)] - a[(r, 3 + k)];
                }
            }
        }
        a
    }

    /// [`Rpy::mobility`] of the line's own nodes.
    fn line_mobility(&self, x: &[Vector3<f64>]) -> Mat<f64> {
        let n = x.len();
        let d = self.discretise(x);
        let w = &self.basis.w;
        let edges = n - 1;
        let mut a = Mat::zeros(3 * n, 3 * n);
        in_parallel_batches(
            edges,
            |k| {
                let mut pairs = self.edge_pairs(&d, &d.near, true, k);
                if let Some(far) = &d.far {
                    let far_pairs = self.edge_pairs(&d, far, false, k);
                    for (s, f) in pairs.iter_mut().zip(far_pairs) {
                        for (sa, fa) in s.iter_mut().zip(f) {
                            for (sab, fab) in sa.iter_mut().zip(fa) {
                                *sab += fab;
                            }
                        }
                    }
                }
                pairs
            },
            |k, pairs| {
                for (k2, s) in (k..edges).zip(pairs) {
                    for (ia, sa) in s.iter().enumerate() {
                        for (jb, sab) in sa.iter().enumerate() {
                            // (Zero where i or j is a point force: no weight on the edges.)
                            let (i, j) = (k + ia, k2 + jb);
                            let block = sab / (w[i] * w[j]);
                            add_block(&mut a, i, j, &block);
                            if k2 != k {
                                add_block(&mut a, j, i, &block.transpose());
                            }
                        }
                    }
                }
            },
        );
        // The point forces at the ends: with each other and with every point of the edges (by
        // the near rule).
        let q = self.points_per_edge();
        let ends = [0, n - 1];
        for (ie, &e) in ends.iter().enumerate() {
            for &e2 in &ends[ie..] {
                let m = self.tensor(x[e] - x[e2]);
                add_block(&mut a, e, e2, &m);
                if e2 != e {
                    add_block(&mut a, e2, e, &m);
                }
            }
            for (p, y) in d.near.pos.iter().enumerate() {
                let m = self.tensor(x[e] - y);
                let k = p / q;
                for (c, pw) in d.near.pw[p].iter().enumerate() {
                    if *pw != 0.0 {
                        let block = m * (pw / w[k + c]);
                        add_block(&mut a, e, k + c, &block);
                        add_block(&mut a, k + c, e, &block);
                    }
                }
            }
        }
        // A = C^{-1} A_e C^{-T}, as C^{-1} (C^{-1} A_e)^T (A_e is symmetric), made exactly
        // symmetric.
        let consistent = &self.basis.consistent;
        consistent.solve_columns(&mut a, false);
        let mut a = a.transpose().to_owned();
        consistent.solve_columns(&mut a, false);
        for c in 0..3 * n {
            for r in c + 1..3 * n {
                let mean = 0.5 * (a[(r, c)] + a[(c, r)]);
                a[(r, c)] = mean;
                a[(c, r)] = mean;
            }
        }
        a
    }

    /// `A(X) Y` for the columns of `Y` (node-major `3N` vectors), without assembling `A`:
    /// `A y = C^{-1} P^T M_pts P C^{-T} y` of the rod's nodes (for [`ClampEdge::Centred`]
    /// `T^{-1} A(T x) T^{-T} y`, see [`Rpy::for_rod`]). The point forces `G = P C^{-T} y` go
    /// through the kernel once per pair of points (of the near rule or the far rule), as in the
    /// assembly but with none
    /// of its `O(N^2)` dense work (the eliminations of `C^{-1}` on `3N` columns, the transpose
    /// and the symmetrization), and a source edge whose points carry no force in any column is
    /// skipped: columns localized near one end (the clamp's) cost `O(N Q)`. Same values as
    /// [`Rpy::mobility`] times `Y` to round-off.
    ///
    /// # Panics
    /// If `x` has another number of nodes than the polygon of the model, or `Y` another number
    /// of rows than `3N`.
    pub fn mobility_product(&self, x: &[Vector3<f64>], y: MatRef<'_, f64>) -> Mat<f64> {
        assert_eq!(
            y.nrows(),
            3 * x.len(),
            "mobility_product: {} rows for {} nodes",
            y.nrows(),
            x.len()
        );
        assert_eq!(x.len(), self.nodes(), "mobility_product: {} nodes", x.len());
        if y.ncols() == 0 {
            return Mat::zeros(y.nrows(), 0);
        }
        let columns: Vec<Vec<Vector3<f64>>> = (0..y.ncols())
            .map(|c| {
                let mut v = unstack_vectors(y, c);
                if self.centred_clamp {
                    // T^{-T} y.
                    let v0 = v[0];
                    v[1] -= v0;
                    v[0] = 2.0 * v0;
                }
                v
            })
            .collect();
        let mut products = self.line_product(&self.line_nodes(x), &columns);
        let mut out = Mat::zeros(y.nrows(), y.ncols());
        for (c, v) in products.iter_mut().enumerate() {
            if self.centred_clamp {
                // T^{-1} r.
                v[0] = 2.0 * v[0] - v[1];
            }
            for (i, vi) in v.iter().enumerate() {
                for k in 0..3 {
                    out[(3 * i + k, c)] = vi[k];
                }
            }
        }
        out
    }

    /// [`Rpy::mobility_product`] of the line's own nodes, for the node vectors `columns`.
    fn line_product(
        &self,
        x: &[Vector3<f64>],
        columns: &[Vec<Vector3<f64>>],
    ) -> Vec<Vec<Vector3<f64>>> {
        let n = x.len();
        let d = self.discretise(x);
        let q = self.points_per_edge();
        let edges = n - 1;
        let w = &self.basis.w;
        let consistent = &self.basis.consistent;
        let z: Vec<Vec<Vector3<f64>>> = columns
            .iter()
            .map(|y| consistent.solve_vectors(y, true))
            .collect();
        let forces: Vec<[Vec<f64>; 3]> = z.iter().map(|z| self.point_forces(&d.near, z)).collect();
        let mut far_forces = (d.far.as_ref())
            .into_iter()
            .flat_map(|far| z.iter().map(|z| self.point_forces(far, z)));
        // The groups of LANES source edges that carry a force, per column.
        let active = |g: &[Vec<f64>; 3], k2: usize| {
            g.iter().any(|g| {
                (0..q).any(|i| {
                    let at = i * d.near.lanes.stride + k2;
                    g[at..at + LANES].iter().any(|&v| v != 0.0)
                })
            })
        };
        let mut together: Vec<SourceGroup> = Vec::new();
        for (c, g) in forces.iter().enumerate() {
            let sources: Vec<usize> = (0..edges)
                .step_by(LANES)
                .filter(|&k2| active(g, k2))
                .collect();
            let group = match together.iter().position(|group| group.sources == sources) {
                Some(at) => &mut together[at],
                None => {
                    together.push(SourceGroup {
                        sources,
                        columns: Vec::new(),
                        forces: Vec::new(),
                        far_forces: Vec::new(),
                    });
                    together.last_mut().expect("just pushed")
                }
            };
            group.columns.push(c);
            group.forces.push(g.clone());
            // (The far rule's forces vanish on the same edges: on either rule's points of an
            // edge they are the same linear function of the edge's two coefficients.)
            if let Some(g) = far_forces.next() {
                group.far_forces.push(g);
            }
        }
        let ends = [0, n - 1];
        // Per edge k, per column: the rows k, k + 1 of A_e z from the velocities at its points.
        let rows: Vec<Vec<[Vector3<f64>; 2]>> = (0..edges)
            .into_par_iter()
            .map(|k| {
                // The velocities at the points of `set` on edge k, point by point, a column
                // each, from the pairs of edges its pass takes.
                let velocities = |set: &PointSet, near: bool| {
                    let mut u = vec![Vector3::zeros(); set.per_edge() * z.len()];
                    for group in &together {
                        let forces = if near {
                            &group.forces
                        } else {
                            &group.far_forces
                        };
                        let v = self.edge_velocities(&d, set, near, forces, &group.sources, k);
                        for (i, v) in v.chunks_exact(group.columns.len()).enumerate() {
                            for (&c, v) in group.columns.iter().zip(v) {
                                u[i * z.len() + c] = *v;
                            }
                        }
                    }
                    u
                };
                let mut rows = vec![[Vector3::zeros(); 2]; z.len()];
                let passes =
                    std::iter::once((&d.near, true)).chain(d.far.as_ref().map(|far| (far, false)));
                for (set, near) in passes {
                    for (i, u) in velocities(set, near).chunks_exact(z.len()).enumerate() {
                        let p = k * set.per_edge() + i;
                        // The point forces at the ends, by the near rule.
                        let m = near.then(|| ends.map(|e| self.tensor(set.pos[p] - x[e])));
                        for ((row, u), z) in rows.iter_mut().zip(u).zip(&z) {
                            let u = match m {
                                Some(m) => u + m[0] * z[ends[0]] + m[1] * z[ends[1]],
                                None => *u,
                            };
                            for (c, pw) in set.pw[p].iter().enumerate() {
                                row[c] += u * (pw / w[k + c]);
                            }
                        }
                    }
                }
                rows
            })
            .collect();
        let mut products = vec![vec![Vector3::zeros(); n]; z.len()];
        for (k, rows) in rows.iter().enumerate() {
            for (product, row) in products.iter_mut().zip(rows) {
                product[k] += row[0];
                product[k + 1] += row[1];
            }
        }
        // The rows of the point forces at the ends: from each other and every point of the edges.
        for &e in &ends {
            for &e2 in &ends {
                let m = self.tensor(x[e] - x[e2]);
                for (product, z) in products.iter_mut().zip(&z) {
                    product[e] += m * z[e2];
                }
            }
            for (p, y) in d.near.pos.iter().enumerate() {
                let m = self.tensor(x[e] - y);
                let at = (p % q) * d.near.lanes.stride + p / q;
                for (product, g) in products.iter_mut().zip(&forces) {
                    product[e] += m * Vector3::new(g[0][at], g[1][at], g[2][at]);
                }
            }
        }
        products
            .iter()
            .map(|v| consistent.solve_vectors(v, false))
            .collect()
    }

    /// `B = ∂(A(X) y)/∂X` at fixed `y`: `B[(3i+a, 3j+b)] = ∂(A(X) y)_{3i+a} / ∂x_{j,b}`
    /// (`3N x 3N`, not symmetric). Analytic, the cost of the assembly; equations in the
    /// [module documentation](self).
    ///
    /// # Panics
    /// If `x` has another number of nodes than the polygon of the model, or `y.len() != x.len()`.
    pub fn mobility_derivative(&self, x: &[Vector3<f64>], y: &[Vector3<f64>]) -> Mat<f64> {
        if !self.centred_clamp {
            return self.line_derivative(x, y);
        }
        // d(T^{-1} A(T x) T^{-T} y) = T^{-1} B_line(T x, T^{-T} y) T dx.
        let mut y_line = y.to_vec();
        y_line[0] = 2.0 * y[0];
        y_line[1] = y[1] - y[0];
        let mut b = self.line_derivative(&self.line_nodes(x), &y_line);
        for r in 0..b.nrows() {
            for k in 0..3 {
                let half = 0.5 * b[(r, k)];
                b[(r, k)] = half;
                b[(r, 3 + k)] += half;
            }
        }
        for c in 0..b.ncols() {
            for k in 0..3 {
                b[(k, c)] = 2.0 * b[(k, c)] - b[(3 + k, c)];
            }
        }
        b
    }

    /// [`Rpy::mobility_derivative`] of the line's own nodes.
    fn line_derivative(&self, x: &[Vector3<f64>], y: &[Vector3<f64>]) -> Mat<f64> {
        let n = x.len();
        assert_eq!(
            y.len(),
            n,
            "mobility_derivative: y has {} nodes, x has {n}",
            y.len()
        );
        let d = self.discretise(x);
        let q = self.points_per_edge();
        let edges = n - 1;
        let w = &self.basis.w;
        let z = self.basis.consistent.solve_vectors(y, true);
        let forces = self.point_forces(&d.near, &z);
        let far_forces = d.far.as_ref().map(|far| self.point_forces(far, &z));
        let mut b = Mat::zeros(3 * n, 3 * n);
        in_parallel_batches(
            edges,
            |k| {
                let mut rows = self.edge_rows(&d, &d.near, true, &forces, k);
                if let (Some(far), Some(far_forces)) = (&d.far, &far_forces) {
                    let far_rows = self.edge_rows(&d, far, false, far_forces, k);
                    for (row, far_row) in rows.b.iter_mut().zip(&far_rows.b) {
                        for (block, far_block) in row.iter_mut().zip(far_row) {
                            *block += far_block;
                        }
                    }
                }
                rows
            },
            |k, rows| {
                for ia in 0..2 {
                    for (j, block) in rows.b[ia].iter().enumerate() {
                        add_block(&mut b, k + ia, j, block);
                    }
                }
            },
        );
        // The point forces at the ends: their rows (their position and that of every other
        // point), and their velocity at the edges' points.
        let ends = [0, n - 1];
        for &e in &ends {
            for &e2 in &ends {
                if e2 != e {
                    let dm = self.tensor_derivative(x[e] - x[e2], z[e2]);
                    add_block(&mut b, e, e, &dm);
                    add_block(&mut b, e, e2, &-dm);
                }
            }
            for (p, y) in d.near.pos.iter().enumerate() {
                let (k, xi) = (p / q, self.rule.xi[p % q]);
                let g = Vector3::from_fn(|c, _| forces[c][(p % q) * d.near.lanes.stride + k]);
                let dm = self.tensor_derivative(x[e] - y, g);
                add_block(&mut b, e, e, &dm);
                add_block(&mut b, e, k, &(dm * -(1.0 - xi)));
                add_block(&mut b, e, k + 1, &(dm * -xi));
                let dm = self.tensor_derivative(y - x[e], z[e]);
                for (c, pw) in d.near.pw[p].iter().enumerate() {
                    if *pw != 0.0 {
                        let pi = pw / w[k + c];
                        add_block(&mut b, k + c, k, &(dm * (pi * (1.0 - xi))));
                        add_block(&mut b, k + c, k + 1, &(dm * (pi * xi)));
                        add_block(&mut b, k + c, e, &(dm * -pi));
                    }
                }
            }
        }
        self.basis.consistent.solve_columns(&mut b, false);
        b
    }

    /// The resistance `Z = A(x)^{-1}` as a Cholesky factorisation.
    ///
    /// # Errors
    /// [`Error::Numerical`] naming `context` if `A` has a non-finite entry (coincident nodes),
    /// [`Error::NotPositiveDefinite`] if it is not positive definite (for a self-intersecting
    /// centreline, or a far field whose error outweighs the smallest eigenvalue; see the
    /// [module documentation](self)).
    pub fn resistance(&self, x: &[Vector3<f64>], context: &str) -> Result<Resistance> {
        Self::factorize(&self.mobility(x), context)
    }

    /// [`Rpy::resistance`] of the mobility `a`, already assembled.
    pub(crate) fn factorize(a: &Mat<f64>, context: &str) -> Result<Resistance> {
        Resistance::new(a, context).map_err(|e| match e {
            Error::Model(ModelError::NotPositiveDefinite { context, .. }) => {
                ModelError::NotPositiveDefinite {
                    context,
                    geometry: "the centreline intersects itself (quadrature points coincide), or \
                               it folds so that the far field's quadrature error outweighs the \
                               smallest eigenvalue"
                        .into(),
                }
                .into()
            }
            other => other,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::Rpy;
    use nalgebra::Vector3;

    /// `sqrt(sum |s_ab|^2)` over the four `3 x 3` blocks of an edge pair.
    fn norm(s: &[[nalgebra::Matrix3<f64>; 2]; 2]) -> f64 {
        s.iter()
            .flatten()
            .map(|m| m.norm_squared())
            .sum::<f64>()
            .sqrt()
    }

    /// The far rule on every pair of edges it takes against the same pair summed by a composite
    /// rule 16 times finer (128 points per edge; for a kernel analytic over the pair its error
    /// falls as the fourth power of the cell: the far rule's error moves by 1e-2 of itself from
    /// 64 to 128 points), on a helix turned in on itself (pairs far apart across the turns and
    /// along the line) in its natural shape and coiled twice as tight (its turns a third of an
    /// edge apart, so that many pairs far apart in the natural shape are within twice the longer
    /// edge and go back to the near rule). In the natural shape the far rule's error is below `1e-7` of
    /// the pair's sum (measured `2.6e-8`; the scale is `rho^(-2 Q_far)` of a Gauss rule on an
    /// integrand analytic inside the ellipse with foci at the edge's ends that reaches the
    /// nearest singularity, `r = 0`, at least two edge lengths away: `rho = 5 + sqrt(24)`,
    /// `rho^(-8) = 1.1e-8`); coiled, below `1e-6` (pairs down to twice the longer edge apart:
    /// `rho = 3 + sqrt(8)`, `rho^(-8) = 7.5e-7`). In both, the far rule's error is below that of
    /// the composite rule of 8 points per edge that it replaces on each of those pairs, and the
    /// near pass leaves exactly zero on the pairs the far rule takes.
    #[test]
    fn the_far_rule_is_more_accurate_than_the_composite_rule_it_replaces() {
        let natural: Vec<Vector3<f64>> = (0..41)
            .map(|i| {
                let t = 0.4 * i as f64;
                Vector3::new(0.1 * t.cos(), 0.1 * t.sin(), -0.006 * i as f64)
            })
            .collect();
        // Coiled twice as tight, with edges of nearly the same length (0.0389 against 0.0404).
        let coiled: Vec<Vector3<f64>> = (0..41)
            .map(|i| {
                let t = 0.8 * i as f64;
                Vector3::new(0.05 * t.cos(), 0.05 * t.sin(), -0.0015 * i as f64)
            })
            .collect();
        let a = 0.004;
        let with_far = Rpy::new(1.0, a, 4, &natural);
        let composite = Rpy::new(1.0, a, 4, &natural).without_far_field();
        let reference = Rpy::new(1.0, a, 64, &natural).without_far_field();
        let mut counts = Vec::new();
        for (name, x, bound) in [("natural", &natural, 1e-7), ("coiled", &coiled, 1e-6)] {
            let (d, dc, dr) = (
                with_far.discretise(x),
                composite.discretise(x),
                reference.discretise(x),
            );
            let far = d.far.as_ref().expect("8 points per edge take a far rule");
            let (mut pairs, mut worst_far, mut worst_ratio) = (0, 0.0_f64, 0.0_f64);
            for k in 0..x.len() - 1 {
                let by_far = with_far.edge_pairs(&d, far, false, k);
                let by_near = with_far.edge_pairs(&d, &d.near, true, k);
                let by_composite = composite.edge_pairs(&dc, &dc.near, true, k);
                let exact = reference.edge_pairs(&dr, &dr.near, true, k);
                let rows = by_far.iter().zip(&by_near).zip(&by_composite).zip(&exact);
                for (j, (((f, near), c), e)) in (k..).zip(rows) {
                    if !d.far_apart(k, j) {
                        assert_eq!(norm(f), 0.0, "{name}: pair ({k}, {j}) is near: no far sum");
                        continue;
                    }
                    assert_eq!(
                        norm(near),
                        0.0,
                        "{name}: pair ({k}, {j}) is far: no near sum"
                    );
                    let difference = |s: &[[nalgebra::Matrix3<f64>; 2]; 2]| {
                        let mut out = *s;
                        for (o, e) in out.iter_mut().flatten().zip(e.iter().flatten()) {
                            *o -= e;
                        }
                        norm(&out) / norm(e)
                    };
                    let (error_far, error_composite) = (difference(f), difference(c));
                    pairs += 1;
                    worst_far = worst_far.max(error_far);
                    worst_ratio = worst_ratio.max(error_far / error_composite);
                }
            }
            println!(
                "{name}: {pairs} pairs by the far rule: its error at most {worst_far:.2e} of the \
                 pair's sum, at most {worst_ratio:.2e} of the composite rule's"
            );
            assert!(worst_far < bound, "{name}: {worst_far:e}");
            assert!(worst_ratio < 1.0, "{name}: {worst_ratio:e}");
            counts.push(pairs);
        }
        // Measured: 568 and 283 (the coil sends 285 pairs back to the near rule).
        assert!(
            counts[0] > 500 && counts[1] > 100 && counts[1] < counts[0],
            "{counts:?}"
        );
    }
}
