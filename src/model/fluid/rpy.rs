//! The Rotne–Prager–Yamakawa (RPY) regularised centreline (docs/model.md section 9): a line of blobs
//! of radius `a`, discretised in a symmetric Galerkin form that is positive definite for every
//! node count and every configuration.
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
//! Nodes `x_0 .. x_{N-1}`, edges `e_k = x_{k+1} - x_k` of length `l_k`, hat functions `phi_j`
//! (piecewise linear, `phi_j(x_i) = delta_ij`), Voronoi weights `w_j = ∫ phi_j ds`
//! (`(l_{j-1} + l_j)/2`, half an edge at the ends). The nodal force `F_j` is spread as the density
//! `f(s) = sum_j F_j phi_j(s) / w_j` (so `∫ f = sum_j F_j`, and `F_j = f w_j` for a uniform
//! density `f`), and the nodal velocity is the `phi_i`-average of the line velocity
//! `u(s) = ∫ M(x(s) - x(s')) f(s') ds'`:
//!
//! ```text
//! U_i = (1/w_i) ∫ phi_i u ds = sum_j A_ij F_j,
//! A_ij = (1/(w_i w_j)) ∫∫ phi_i(s) M(x(s) - x(s')) phi_j(s') ds ds'.
//! ```
//!
//! A uniform velocity `u` gives `U_i = u` (the `phi_i/w_i` have unit mass).
//!
//! **Quadrature.** Every edge carries the same `Q` Gauss–Legendre points `xi_q` in `(0, 1)` with
//! weights `g_q` (`sum g_q = 1`): point `p = (k, q)` at `y_p = (1 - xi_q) x_k + xi_q x_{k+1}` with
//! weight `c_p = g_q l_k`. One product rule for every pair of edges, the diagonal included, gives
//!
//! ```text
//! A = P^T M_pts P,   P_pj = c_p phi_j(y_p) / w_j,   M_pts = [M(y_p - y_q)]_pq,
//! ```
//!
//! (each entry times the `3 x 3` identity): `P` is sparse (point `p` on edge `k` has
//! `P_pk = c_p (1 - xi_q)/w_k`, `P_p,k+1 = c_p xi_q / w_{k+1}`). `A` is assembled edge pair by edge
//! pair, `O((N Q)^2)` kernel evaluations, without forming `M_pts`.
//!
//! **Why `A` is symmetric positive definite for every `N` and configuration.** `F^T A F =
//! G^T M_pts G` with the point forces `G = P F`. (i) `P` has full column rank when `Q >= 2`: on
//! edge `k`, `G_p = c_p [(1 - xi_q) F_k / w_k + xi_q F_{k+1} / w_{k+1}]` (`c_p > 0`) vanishes at two
//! distinct `xi_q` only if `F_k = F_{k+1} = 0`, so `F != 0` gives `G != 0` (with `Q = 1` the
//! alternating `F_k = (-1)^k w_k` would be lost). (ii) Gauss points are interior to their edges, so
//! two points coincide only where two edges of the polygon cross (or lie on top of each other)
//! exactly at Gauss points: a self-intersecting centreline. For any other polygon — near contact
//! and overlapping blobs included — the points are distinct, `M_pts` is positive definite and so is
//! `A`. If points do coincide, `M_pts` is only semi-definite and `F^T A F = 0` exactly when the
//! forces summed over each set of coincident points and the forces at the other points all
//! vanish. Two edges crossing at one common Gauss point keep `A` definite when `Q >= 3` (each
//! edge keeps two distinct points of its own, whose forces must vanish, so its node forces do);
//! two identical edges (a rod folded exactly onto itself) make `A` singular, as they should.
//! `A` is made exactly symmetric by averaging with its transpose.
//!
//! **Choice of `Q`.** The product rule is accurate while the point spacing `l/Q` resolves `a`;
//! `Q = max(2, ceil(POINTS_PER_BLOB * l / a))` ([`POINTS_PER_BLOB`]) keeps the spacing below
//! `a / POINTS_PER_BLOB` whatever `N`. `Q` is chosen once, from the longest edge of the natural
//! shape ([`Rpy::for_polygon`]), and held fixed for every configuration of the model so that
//! `A(X)` is a smooth function of the nodes.
//!
//! **Spectrum.** The line operator is of order `-2` (the `|r|` term of `M` at `r = 0`), coercive
//! in `H^{-1}`: its smallest eigenvalue falls like the node spacing `h` (measured in
//! `tests/rpy.rs`), positive at every `N`.
//!
//! # Shape derivative
//!
//! `B = ∂(A(X) y)/∂X` at fixed `y` ([`Rpy::mobility_derivative`]). With the point forces
//! `G_p = sum_j P_pj y_j` and point velocities `V_p = sum_q M(y_p - y_q) G_q`,
//! `(A y)_i = sum_p P_pi V_p`. Everything depends on `X` through the point positions (linear:
//! `∂y_p/∂x_k = 1 - xi_q`, `∂y_p/∂x_{k+1} = xi_q`) and the edge lengths (`c_p` proportional to
//! `l_k`, `w_j = (l_{j-1} + l_j)/2`, `∂l_k/∂x_{k+1} = -∂l_k/∂x_k = ê_k^T`):
//!
//! ```text
//! dP_pj = P_pj (dl_k(p)/l_k(p) - dw_j/w_j),
//! d(M(r) G)/dr =: D(r, G) = alpha' G rhat^T + beta' (rhat.G) rhat rhat^T
//!                          + (beta/r) [ rhat G^T + (rhat.G) I - 2 (rhat.G) rhat rhat^T ],
//! d(A y)_i = sum_pq P_pi D(y_p - y_q, G_q) (dy_p - dy_q)
//!          + sum_p P_pi V_p (dl_k(p)/l_k(p) - dw_i/w_i)
//!          + sum_pqj P_pi M_pq P_qj y_j (dl_k(q)/l_k(q) - dw_j/w_j).
//! ```
//!
//! At `r = 0` (a point with itself) the position term cancels (`dy_p - dy_p = 0`); coincident
//! distinct points, where `M` has a cone singularity, are given `D = 0`. The cost is `O((N Q)^2)`.

use super::Resistance;
use super::lanes::{LANES, Lanes};
use super::mobility::add_block;
use crate::error::ModelError;
use crate::{Error, Result};
use faer::Mat;
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;
use std::f64::consts::PI;

/// Quadrature points per blob radius: an edge of length `l` gets
/// `Q = max(2, ceil(POINTS_PER_BLOB * l / a))` Gauss points (spacing at most `a / 8`). The
/// product rule's error is second order in the spacing (the `|r|` cone of `M` on the diagonal):
/// with 8, the uniform-density drag of a straight rod is within 1e-4 of its closed form and the
/// rigid-helix thrust within about 0.03% of its limit in `Q` (measured at N = 60 and 240; with
/// 2 and 4 points per blob: 0.2-0.4% and 0.07-0.1%).
pub const POINTS_PER_BLOB: f64 = 8.0;

/// The blob radius `a = e^(3/2) r0 / 4` that reproduces the slender-body local drag of a
/// cylinder of radius `r0` (see the [module documentation](self)).
pub fn rpy_blob_radius(r0: f64) -> f64 {
    1.5f64.exp() * r0 / 4.0
}

/// Gauss–Legendre rule on `[0, 1]`: nodes `xi_q` and weights `g_q`, `sum g_q = 1`.
#[derive(Clone, Debug, PartialEq)]
struct GaussRule {
    xi: Vec<f64>,
    weight: Vec<f64>,
}

impl GaussRule {
    /// The `q`-point rule (exact for polynomials of degree `2q - 1`): the roots `t` of the
    /// Legendre polynomial `P_q` by Newton iteration from `cos(pi (i + 3/4) / (q + 1/2))`,
    /// `xi = (1 -+ t)/2`, `g = 1 / ((1 - t^2) P_q'(t)^2)`.
    fn new(q: usize) -> Self {
        let mut xi = vec![0.0; q];
        let mut weight = vec![0.0; q];
        let qf = q as f64;
        for i in 0..q.div_ceil(2) {
            let mut t = (PI * (i as f64 + 0.75) / (qf + 0.5)).cos();
            let mut derivative = 1.0;
            for _ in 0..100 {
                // P_q(t) and P_q'(t) by the three-term recurrence.
                let (mut p0, mut p1) = (1.0, t);
                for j in 2..=q {
                    let jf = j as f64;
                    let p2 = ((2.0 * jf - 1.0) * t * p1 - (jf - 1.0) * p0) / jf;
                    p0 = p1;
                    p1 = p2;
                }
                derivative = qf * (t * p1 - p0) / (t * t - 1.0);
                let step = p1 / derivative;
                t -= step;
                if step.abs() < 1e-16 {
                    break;
                }
            }
            let g = 1.0 / ((1.0 - t * t) * derivative * derivative);
            xi[i] = 0.5 * (1.0 - t);
            xi[q - 1 - i] = 0.5 * (1.0 + t);
            weight[i] = g;
            weight[q - 1 - i] = g;
        }
        Self { xi, weight }
    }
}

/// Whether the processor has AVX2 and FMA (detected at run time, once): the quadrature kernels
/// then run in a copy compiled for them, where the lane operations of [`Lanes`] are inlined and
/// carried out in one AVX register each (the baseline copy uses two SSE2 registers). The sums are
/// the same: no operation is fused (Rust contracts no `a * b + c` into an FMA by itself), so
/// both copies give the same bits (`tests::both_kernel_copies_give_the_same_bits`).
#[cfg(target_arch = "x86_64")]
fn wide_registers() -> bool {
    std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
}

/// `[f(0), f(1), f(2)]`, written out: in the kernels' inner loops `array::map` was left as a
/// call that copies its result (seen in profiles as `try_map` and `memmove`).
#[inline(always)]
fn components(f: impl Fn(usize) -> Lanes) -> [Lanes; 3] {
    [f(0), f(1), f(2)]
}

/// The quadrature points transposed for the kernels: entry `q * stride + k` belongs to point `q`
/// of edge `k`, so that one point of `LANES` consecutive edges is one contiguous read. The rows
/// are padded with `LANES - 1` weightless, forceless points at the origin, so any `LANES`
/// consecutive edges can be read; they contribute exact zeros.
struct PointLanes {
    stride: usize,
    /// Positions `y_p`, by component.
    pos: [Vec<f64>; 3],
    /// `[c_p (1 - xi_q), c_p xi_q]`, as [`Discretisation::pw`].
    pw: [Vec<f64>; 2],
}

impl PointLanes {
    /// `values(p)` of every point `p = k Q + q`, transposed and padded.
    fn transpose<const C: usize>(
        edges: usize,
        q: usize,
        values: impl Fn(usize) -> [f64; C],
    ) -> (usize, [Vec<f64>; C]) {
        let stride = edges + LANES - 1;
        let mut out: [Vec<f64>; C] = std::array::from_fn(|_| vec![0.0; q * stride]);
        for k in 0..edges {
            for i in 0..q {
                for (column, v) in out.iter_mut().zip(values(k * q + i)) {
                    column[i * stride + k] = v;
                }
            }
        }
        (stride, out)
    }
}

/// `alpha`, `beta`, `alpha'`, `beta'` and `beta / r` of `M(r) = alpha I + beta rhat rhat^T`, and
/// `1/r` (0 at `r = 0`), in each lane.
struct Radial {
    alpha: Lanes,
    beta: Lanes,
    dalpha: Lanes,
    dbeta: Lanes,
    beta_over_r: Lanes,
    inv: Lanes,
}

/// The RPY line mobility (see the [module documentation](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct Rpy {
    /// Dynamic viscosity `mu`.
    pub mu: f64,
    /// Blob radius `a`, normally [`rpy_blob_radius`]`(r0)`.
    pub blob_radius: f64,
    rule: GaussRule,
}

/// Geometry of one configuration: edges, Voronoi weights and the quadrature points.
struct Discretisation {
    /// Edge lengths `l_k`.
    len: Vec<f64>,
    /// Unit edge tangents `ê_k`.
    unit: Vec<Vector3<f64>>,
    /// Voronoi weights `w_j`.
    w: Vec<f64>,
    /// Point positions `y_p`, `p = k Q + q`.
    pos: Vec<Vector3<f64>>,
    /// `[c_p (1 - xi_q), c_p xi_q]`: the weights of the point's two nodes, before `1/w`.
    pw: Vec<[f64; 2]>,
    /// The points and weights transposed for the kernels.
    lanes: PointLanes,
}

/// What the points of one edge `k` contribute in [`Rpy::mobility_derivative`]: for the rows
/// `i = k, k + 1`, the blocks `B_ij` (all `j`), `partial` (all edges, both ends) and the
/// edge-length coefficient `C_ik`.
struct EdgeRows {
    b: [Vec<Matrix3<f64>>; 2],
    partial: [Vec<Vector3<f64>>; 2],
    coef: [Vector3<f64>; 2],
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

impl Rpy {
    /// RPY mobility with `points_per_edge` Gauss points on every edge.
    ///
    /// # Panics
    /// If `points_per_edge < 2` (`A` would lose positive definiteness) or the blob radius is not
    /// positive.
    pub fn new(mu: f64, blob_radius: f64, points_per_edge: usize) -> Self {
        assert!(
            points_per_edge >= 2,
            "RPY quadrature needs at least two points per edge, got {points_per_edge}"
        );
        assert!(
            blob_radius > 0.0,
            "RPY blob radius must be > 0, got {blob_radius}"
        );
        Self {
            mu,
            blob_radius,
            rule: GaussRule::new(points_per_edge),
        }
    }

    /// RPY mobility for configurations of the polygon `natural`, with
    /// `Q = max(2, ceil(per_blob * l_max / a))` points per edge from its longest edge
    /// (`per_blob`: [`POINTS_PER_BLOB`] by default).
    pub fn for_polygon(mu: f64, blob_radius: f64, per_blob: f64, natural: &[Vector3<f64>]) -> Self {
        let longest = natural
            .windows(2)
            .map(|e| (e[1] - e[0]).norm())
            .fold(0.0, f64::max);
        let q = ((per_blob * longest / blob_radius).ceil() as usize).max(2);
        Self::new(mu, blob_radius, q)
    }

    /// Gauss points per edge `Q`.
    pub fn points_per_edge(&self) -> usize {
        self.rule.xi.len()
    }

    /// `M(0) = I / (6 pi mu a)`: the self-mobility of a blob.
    fn self_mobility(&self) -> f64 {
        1.0 / (6.0 * PI * self.mu * self.blob_radius)
    }

    /// [`Radial`] at the distances `r`: both branches evaluated, each lane's chosen. At
    /// `r = 0` the near branch gives `M = I / (6 pi mu a)`, and `1/r` is set to 0 so that
    /// `rhat = 0`.
    #[inline(always)]
    fn radial(&self, r: Lanes) -> Radial {
        let a = self.blob_radius;
        let k = 1.0 / (8.0 * PI * self.mu);
        let m0 = self.self_mobility();
        let slope = 3.0 * m0 / (32.0 * a);
        let (k2_3, k2_1, k6_1) = (2.0 * a * a * k / 3.0, 2.0 * a * a * k, 6.0 * a * a * k);
        let zero = Lanes::ZERO;
        let inv = r.gt(zero).select(1.0 / r, zero);
        let inv2 = inv * inv;
        let far = r.ge(Lanes::splat(2.0 * a));
        let beta_over_r = inv2 * (k - k2_1 * inv2);
        Radial {
            alpha: far.select(inv * (k + k2_3 * inv2), m0 - 3.0 * slope * r),
            beta: far.select(beta_over_r * r, slope * r),
            dalpha: far.select(-inv2 * (k + k2_1 * inv2), Lanes::splat(-3.0 * slope)),
            dbeta: far.select(-inv2 * (k - k6_1 * inv2), Lanes::splat(slope)),
            beta_over_r: far.select(beta_over_r, Lanes::splat(slope)),
            inv,
        }
    }

    fn discretise(&self, x: &[Vector3<f64>]) -> Discretisation {
        let n = x.len();
        assert!(n >= 2, "RPY mobility needs at least two nodes, got {n}");
        let edges: Vec<Vector3<f64>> = x.windows(2).map(|e| e[1] - e[0]).collect();
        let len: Vec<f64> = edges.iter().map(|e| e.norm()).collect();
        let unit = edges.iter().zip(&len).map(|(e, l)| e / *l).collect();
        let w = (0..n)
            .map(|j| {
                let prev = if j > 0 { len[j - 1] } else { 0.0 };
                let next = if j + 1 < n { len[j] } else { 0.0 };
                0.5 * (prev + next)
            })
            .collect();
        let q = self.points_per_edge();
        let mut pos = Vec::with_capacity(q * (n - 1));
        let mut pw = Vec::with_capacity(q * (n - 1));
        for k in 0..n - 1 {
            for (xi, g) in self.rule.xi.iter().zip(&self.rule.weight) {
                pos.push(x[k] * (1.0 - xi) + x[k + 1] * *xi);
                let c = g * len[k];
                pw.push([c * (1.0 - xi), c * xi]);
            }
        }
        let (stride, [x, y, z]) = PointLanes::transpose(n - 1, q, |p| pos[p].into());
        let (_, weights) = PointLanes::transpose(n - 1, q, |p| pw[p]);
        Discretisation {
            len,
            unit,
            w,
            pos,
            pw,
            lanes: PointLanes {
                stride,
                pos: [x, y, z],
                pw: weights,
            },
        }
    }

    /// [`Rpy::edge_pairs_kernel`], compiled for AVX2 and FMA where the processor has them
    /// (see [`wide_registers`]).
    fn edge_pairs(&self, d: &Discretisation, k: usize) -> Vec<[[Matrix3<f64>; 2]; 2]> {
        #[cfg(target_arch = "x86_64")]
        if wide_registers() {
            // SAFETY: the processor has AVX2 and FMA, checked at run time.
            return unsafe { self.edge_pairs_avx2(d, k) };
        }
        self.edge_pairs_kernel(d, k)
    }

    /// [`Rpy::edge_pairs_kernel`] for processors with AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn edge_pairs_avx2(&self, d: &Discretisation, k: usize) -> Vec<[[Matrix3<f64>; 2]; 2]> {
        self.edge_pairs_kernel(d, k)
    }

    /// For edge `k` and every `k2 >= k`: `s[a][b] = sum_{p on k, p2 on k2} pw_a(p) M(y_p - y_p2)
    /// pw_b(p2)`, the contribution to the node blocks `(k + a, k2 + b)` before `1/(w w)`.
    /// [`LANES`] edges `k2` at a time, the sums kept per lane as a scalar times `I` plus a
    /// symmetric matrix (`[alpha sum, xx, xy, xz, yy, yz, zz]`), the form of
    /// `M = alpha I + (beta/r^2) r r^T`.
    #[inline(always)]
    fn edge_pairs_kernel(&self, d: &Discretisation, k: usize) -> Vec<[[Matrix3<f64>; 2]; 2]> {
        let q = self.points_per_edge();
        let edges = d.len.len();
        let lanes = &d.lanes;
        let mut out = Vec::with_capacity(edges - k);
        for k2 in (k..edges).step_by(LANES) {
            // s[a][b] per lane, in the same seven-number form.
            let mut s = [[[Lanes::ZERO; 7]; 2]; 2];
            for p in k * q..(k + 1) * q {
                let y = d.pos[p];
                let y = components(|c| Lanes::splat(y[c]));
                let mut sums = [[Lanes::ZERO; 7]; 2];
                for i in 0..q {
                    let at = i * lanes.stride + k2;
                    let r = components(|c| y[c] - Lanes::load(&lanes.pos[c], at));
                    let radial = self.radial((r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt());
                    let c = radial.beta_over_r * radial.inv;
                    let rr = [
                        r[0] * r[0],
                        r[0] * r[1],
                        r[0] * r[2],
                        r[1] * r[1],
                        r[1] * r[2],
                        r[2] * r[2],
                    ];
                    for (sum, pw) in sums.iter_mut().zip(&lanes.pw) {
                        let w = Lanes::load(pw, at);
                        sum[0] += w * radial.alpha;
                        let cw = c * w;
                        for (t, v) in sum[1..].iter_mut().zip(&rr) {
                            *t += cw * *v;
                        }
                    }
                }
                for (sa, weight) in s.iter_mut().zip(d.pw[p]) {
                    let weight = Lanes::splat(weight);
                    for (sab, sum) in sa.iter_mut().zip(&sums) {
                        for (t, v) in sab.iter_mut().zip(sum) {
                            *t += weight * *v;
                        }
                    }
                }
            }
            let s = s.map(|sa| sa.map(|sab| sab.map(|t| t.0)));
            for l in 0..LANES.min(edges - k2) {
                out.push(s.map(|sa| {
                    sa.map(|t| {
                        Matrix3::new(
                            t[0][l] + t[1][l],
                            t[2][l],
                            t[3][l],
                            t[2][l],
                            t[0][l] + t[4][l],
                            t[5][l],
                            t[3][l],
                            t[5][l],
                            t[0][l] + t[6][l],
                        )
                    })
                }));
            }
        }
        out
    }

    /// The mobility matrix `A(X) = P^T M_pts P` (`3N x 3N`, node-major, symmetric positive
    /// definite; see the [module documentation](self)).
    ///
    /// # Panics
    /// If `x` has fewer than two nodes.
    pub fn mobility(&self, x: &[Vector3<f64>]) -> Mat<f64> {
        let n = x.len();
        let d = self.discretise(x);
        let edges = n - 1;
        let mut a = Mat::zeros(3 * n, 3 * n);
        in_parallel_batches(
            edges,
            |k| self.edge_pairs(&d, k),
            |k, pairs| {
                for (k2, s) in (k..edges).zip(pairs) {
                    for (ia, sa) in s.iter().enumerate() {
                        for (jb, sab) in sa.iter().enumerate() {
                            let (i, j) = (k + ia, k2 + jb);
                            let block = sab / (d.w[i] * d.w[j]);
                            add_block(&mut a, i, j, &block);
                            if k2 != k {
                                add_block(&mut a, j, i, &block.transpose());
                            }
                        }
                    }
                }
            },
        );
        for c in 0..3 * n {
            for r in c + 1..3 * n {
                let mean = 0.5 * (a[(r, c)] + a[(c, r)]);
                a[(r, c)] = mean;
                a[(c, r)] = mean;
            }
        }
        a
    }

    /// The contributions of the points on edge `k` to the rows `k, k + 1` of `B`, of `partial`
    /// and of the edge-length coefficients of edge `k` (see [`Rpy::mobility_derivative`]), with
    /// `forces` the point forces split by node (`forces[3 c + i]`: component `i` of
    /// `P_p,k2+c y_{k2+c}`) in the layout of [`PointLanes`]. [`LANES`] edges `k2` at a time: per
    /// lane, the sums over the points `p2` of edge `k2` of `M G_p2` (split by node) and of
    /// `D(y_p - y_p2, G_p2)`, plain and weighted by `xi_q2`.
    #[inline(always)]
    fn edge_rows_kernel(&self, d: &Discretisation, forces: &[Vec<f64>; 6], k: usize) -> EdgeRows {
        let q = self.points_per_edge();
        let edges = d.len.len();
        let n = edges + 1;
        let lanes = &d.lanes;
        let mut out = EdgeRows {
            b: [vec![Matrix3::zeros(); n], vec![Matrix3::zeros(); n]],
            partial: [
                vec![Vector3::zeros(); 2 * edges],
                vec![Vector3::zeros(); 2 * edges],
            ],
            coef: [Vector3::zeros(); 2],
        };
        let points = k * q..(k + 1) * q;
        // P_pi of each point p of edge k for its rows i = k, k + 1.
        let p_nodes: Vec<[f64; 2]> = points
            .clone()
            .map(|p| [d.pw[p][0] / d.w[k], d.pw[p][1] / d.w[k + 1]])
            .collect();
        // Per point p, across all edges k2: sum of M G (the velocity of p) and of D, per lane.
        let mut velocity = vec![[Lanes::ZERO; 3]; q];
        let mut own = vec![[Lanes::ZERO; 9]; q];
        for k2 in (0..edges).step_by(LANES) {
            // Per row i = k + ia, across the points p: P_pi [s_0, s_1] and P_pi [D - xi D, xi D].
            let mut rows = [[Lanes::ZERO; 24]; 2];
            for (ip, p) in points.clone().enumerate() {
                let y = components(|c| Lanes::splat(d.pos[p][c]));
                let mut acc = [Lanes::ZERO; 24];
                for (i, &xi2) in self.rule.xi.iter().enumerate() {
                    let at = i * lanes.stride + k2;
                    let r = components(|j| y[j] - Lanes::load(&lanes.pos[j], at));
                    let c = self.radial((r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt());
                    let rhat = components(|j| r[j] * c.inv);
                    let g0 = components(|j| Lanes::load(&forces[j], at));
                    let g1 = components(|j| Lanes::load(&forces[3 + j], at));
                    let rg0 = rhat[0] * g0[0] + rhat[1] * g0[1] + rhat[2] * g0[2];
                    let rg1 = rhat[0] * g1[0] + rhat[1] * g1[1] + rhat[2] * g1[2];
                    let (bg0, bg1) = (c.beta * rg0, c.beta * rg1);
                    // D = u rhat^T + rhat v^T + (beta/r)(rhat.G) I, G = G_0 + G_1.
                    let rg = rg0 + rg1;
                    let diagonal = c.beta_over_r * rg;
                    let along = (c.dbeta - 2.0 * c.beta_over_r) * rg;
                    let mut u = [Lanes::ZERO; 3];
                    let mut v = [Lanes::ZERO; 3];
                    for j in 0..3 {
                        acc[j] += g0[j] * c.alpha + rhat[j] * bg0;
                        acc[3 + j] += g1[j] * c.alpha + rhat[j] * bg1;
                        let g = g0[j] + g1[j];
                        u[j] = g * c.dalpha;
                        v[j] = g * c.beta_over_r + rhat[j] * along;
                    }
                    let xi2 = Lanes::splat(xi2);
                    for a in 0..3 {
                        for b in 0..3 {
                            let mut dm = u[a] * rhat[b] + rhat[a] * v[b];
                            if a == b {
                                dm += diagonal;
                            }
                            acc[6 + 3 * a + b] += dm;
                            acc[15 + 3 * a + b] += dm * xi2;
                        }
                    }
                }
                for j in 0..3 {
                    velocity[ip][j] += acc[j] + acc[3 + j];
                }
                for j in 0..9 {
                    own[ip][j] += acc[6 + j];
                }
                for (row, &pi) in rows.iter_mut().zip(&p_nodes[ip]) {
                    let pi = Lanes::splat(pi);
                    for j in 0..6 {
                        row[j] += pi * acc[j];
                    }
                    for j in 0..9 {
                        row[6 + j] += pi * (acc[6 + j] - acc[15 + j]);
                        row[15 + j] += pi * acc[15 + j];
                    }
                }
            }
            let rows = rows.map(|row| row.map(|t| t.0));
            for l in 0..LANES.min(edges - k2) {
                let at = k2 + l;
                for (ia, row) in rows.iter().enumerate() {
                    out.partial[ia][2 * at] += Vector3::new(row[0][l], row[1][l], row[2][l]);
                    out.partial[ia][2 * at + 1] += Vector3::new(row[3][l], row[4][l], row[5][l]);
                    for jb in 0..2 {
                        out.b[ia][at + jb] -=
                            Matrix3::from_fn(|a, b| row[6 + 9 * jb + 3 * a + b][l]);
                    }
                }
            }
        }
        for ((p_node, &xi), (velocity, own)) in p_nodes
            .iter()
            .zip(&self.rule.xi)
            .zip(velocity.iter().zip(&own))
        {
            let velocity = Vector3::from_fn(|j, _| velocity[j].sum());
            let own = Matrix3::from_fn(|a, b| own[3 * a + b].sum());
            let phi = [1.0 - xi, xi];
            for (ia, &pi) in p_node.iter().enumerate() {
                for (jb, phib) in phi.iter().enumerate() {
                    out.b[ia][k + jb] += own * (pi * phib);
                }
                out.coef[ia] += velocity * (pi / d.len[k]);
            }
        }
        out
    }

    /// [`Rpy::edge_rows_kernel`], compiled for AVX2 and FMA where the processor has them (see
    /// [`wide_registers`]).
    fn edge_rows(&self, d: &Discretisation, forces: &[Vec<f64>; 6], k: usize) -> EdgeRows {
        #[cfg(target_arch = "x86_64")]
        if wide_registers() {
            // SAFETY: the processor has AVX2 and FMA, checked at run time.
            return unsafe { self.edge_rows_avx2(d, forces, k) };
        }
        self.edge_rows_kernel(d, forces, k)
    }

    /// [`Rpy::edge_rows_kernel`] for processors with AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn edge_rows_avx2(
        &self,
        d: &Discretisation,
        forces: &[Vec<f64>; 6],
        k: usize,
    ) -> EdgeRows {
        self.edge_rows_kernel(d, forces, k)
    }

    /// `B = ∂(A(X) y)/∂X` at fixed `y`: `B[(3i+a, 3j+b)] = ∂(A(X) y)_{3i+a} / ∂x_{j,b}`
    /// (`3N x 3N`, not symmetric). Analytic, `O((N Q)^2)`; equations in the
    /// [module documentation](self).
    ///
    /// # Panics
    /// If `x` has fewer than two nodes or `y.len() != x.len()`.
    pub fn mobility_derivative(&self, x: &[Vector3<f64>], y: &[Vector3<f64>]) -> Mat<f64> {
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
        // Point forces G_p split by the node they come from, [P_pk y_k, P_p,k+1 y_{k+1}], by
        // component, in the layout of the kernels.
        let (_, forces) = PointLanes::transpose(edges, q, |p| {
            let (k, pw) = (p / q, d.pw[p]);
            let (g0, g1) = (y[k] * (pw[0] / d.w[k]), y[k + 1] * (pw[1] / d.w[k + 1]));
            [g0.x, g0.y, g0.z, g1.x, g1.y, g1.z]
        });
        let mut b = Mat::zeros(3 * n, 3 * n);
        // partial[(i edges + k2) 2 + c] = sum_p P_pi sum_{p2 on k2} M(y_p - y_p2) forces[p2][c].
        let mut partial = vec![Vector3::zeros(); 2 * n * edges];
        // Coefficients of the edge-length derivatives: B_{i,k+1} += C_ik ê_k^T, B_ik -= C_ik ê_k^T.
        let mut coef = vec![Vector3::zeros(); n * edges];
        in_parallel_batches(
            edges,
            |k| self.edge_rows(&d, &forces, k),
            |k, rows| {
                for ia in 0..2 {
                    let i = k + ia;
                    for (j, block) in rows.b[ia].iter().enumerate() {
                        add_block(&mut b, i, j, block);
                    }
                    for (t, v) in partial[2 * i * edges..2 * (i + 1) * edges]
                        .iter_mut()
                        .zip(&rows.partial[ia])
                    {
                        *t += v;
                    }
                    coef[i * edges + k] += rows.coef[ia];
                }
            },
        );
        let mut a_y = vec![Vector3::zeros(); n];
        for i in 0..n {
            let row = &partial[2 * i * edges..2 * (i + 1) * edges];
            // a_y[j] = A_ij y_j.
            a_y.fill(Vector3::zeros());
            for (k2, pair) in row.chunks_exact(2).enumerate() {
                a_y[k2] += pair[0];
                a_y[k2 + 1] += pair[1];
            }
            let total: Vector3<f64> = a_y.iter().sum();
            for k2 in 0..edges {
                let c = &mut coef[i * edges + k2];
                *c += (row[2 * k2] + row[2 * k2 + 1]) / d.len[k2];
                *c -= 0.5 * (a_y[k2] / d.w[k2] + a_y[k2 + 1] / d.w[k2 + 1]);
                if k2 + 1 == i || k2 == i {
                    *c -= total * (0.5 / d.w[i]);
                }
                let block = *c * d.unit[k2].transpose();
                add_block(&mut b, i, k2 + 1, &block);
                add_block(&mut b, i, k2, &-block);
            }
        }
        b
    }

    /// The resistance `Z = A(x)^{-1}` as a Cholesky factorisation.
    ///
    /// # Errors
    /// [`Error::Numerical`] naming `context` if `A` has a non-finite entry (coincident nodes),
    /// [`Error::NotPositiveDefinite`] if it is not positive definite (only possible for a
    /// self-intersecting centreline, see the [module documentation](self)).
    pub fn resistance(&self, x: &[Vector3<f64>], context: &str) -> Result<Resistance> {
        Self::factorize(&self.mobility(x), context)
    }

    /// [`Rpy::resistance`] of the mobility `a`, already assembled.
    pub(crate) fn factorize(a: &Mat<f64>, context: &str) -> Result<Resistance> {
        Resistance::new(a, context).map_err(|e| match e {
            Error::Model(ModelError::NotPositiveDefinite { context, .. }) => {
                ModelError::NotPositiveDefinite {
                    context,
                    geometry: "quadrature points coincide: the centreline intersects itself".into(),
                }
                .into()
            }
            other => other,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::GaussRule;

    /// The kernels compiled for AVX2 and FMA give the same bits as the baseline ones, on a
    /// configuration with near and far pairs (a helix turned in on itself).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn both_kernel_copies_give_the_same_bits() {
        use nalgebra::Vector3;
        if !super::wide_registers() {
            return;
        }
        let x: Vec<Vector3<f64>> = (0..23)
            .map(|i| {
                let t = 0.4 * i as f64;
                Vector3::new(
                    0.1 * t.cos(),
                    0.1 * t.sin(),
                    -0.011 * i as f64 + 0.002 * t.sin(),
                )
            })
            .collect();
        let y: Vec<Vector3<f64>> = (0..x.len())
            .map(|i| Vector3::new(1.0, (i as f64).sin(), 0.3 - 0.01 * i as f64))
            .collect();
        let rpy = super::Rpy::for_polygon(1.0, 0.012, 8.0, &x);
        let d = rpy.discretise(&x);
        let q = rpy.points_per_edge();
        let (_, forces) = super::PointLanes::transpose(x.len() - 1, q, |p| {
            let (k, pw) = (p / q, d.pw[p]);
            let (g0, g1) = (y[k] * (pw[0] / d.w[k]), y[k + 1] * (pw[1] / d.w[k + 1]));
            [g0.x, g0.y, g0.z, g1.x, g1.y, g1.z]
        });
        for k in 0..x.len() - 1 {
            // SAFETY: the processor has AVX2 and FMA (checked above).
            let wide = unsafe { rpy.edge_pairs_avx2(&d, k) };
            assert_eq!(wide, rpy.edge_pairs_kernel(&d, k), "edge {k}");
            let wide = unsafe { rpy.edge_rows_avx2(&d, &forces, k) };
            let base = rpy.edge_rows_kernel(&d, &forces, k);
            assert_eq!(
                (wide.b, wide.partial, wide.coef),
                (base.b, base.partial, base.coef)
            );
        }
    }

    /// The `q`-point rule integrates `xi^d` over `[0, 1]` exactly (`1/(d + 1)`, to 1e-14) for
    /// `d <= 2q - 1`, with increasing nodes inside `(0, 1)` and positive weights.
    #[test]
    fn gauss_rule_is_exact_to_degree_2q_minus_1() {
        for q in 1..=64 {
            let rule = GaussRule::new(q);
            assert!(rule.xi.windows(2).all(|p| p[0] < p[1]));
            assert!(rule.xi[0] > 0.0 && rule.xi[q - 1] < 1.0);
            assert!(rule.weight.iter().all(|&g| g > 0.0));
            for d in 0..2 * q as i32 {
                let sum: f64 = rule
                    .xi
                    .iter()
                    .zip(&rule.weight)
                    .map(|(x, g)| g * x.powi(d))
                    .sum();
                let exact = 1.0 / (d + 1) as f64;
                assert!(
                    (sum - exact).abs() < 1e-14,
                    "q = {q}, degree {d}: {sum} vs {exact}"
                );
            }
        }
    }
}
