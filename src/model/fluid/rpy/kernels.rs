//! The quadrature kernels of the RPY line (the [module documentation](super)): the kernel `M`
//! and its derivative at the quadrature points, summed edge pair by edge pair, in lanes of
//! [`LANES`] edges, in a baseline copy and copies compiled for AVX2 and FMA and for AVX-512.

use super::super::lanes::{LANES, Lanes};
use super::quadrature::{Edges, FAR_RATIO, FAR_RATIO_DEFORMED};
use super::{Discretisation, EdgeRows, PointSet, Rpy};
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::PI;
use std::sync::atomic::{AtomicU8, Ordering};

/// A copy of the quadrature kernels, by the registers it is compiled for: the lane operations of
/// [`Lanes`] are inlined and carried out in four SSE2 registers each (the baseline copy), two
/// AVX registers, or one AVX-512 register (eight `f64`). The widest copy the processor has runs
/// (detected at run time; the standard library caches the answer), or a narrower one where the
/// process asks for it ([`use_at_most`], the environment variable [`KERNELS_VARIABLE`]): every
/// copy gives the same bits, so the choice changes the time only. The sums are the same because
/// no operation is fused (Rust contracts no `a * b + c` into an FMA by itself;
/// `tests::every_kernel_copy_gives_the_same_bits`). `cargo bench --bench refine` ran the
/// default refinement in 3.9 and 4.8 s in the AVX2 and baseline copies on the 2-core AMD EPYC
/// (on an Intel Xeon, without the far field, the AVX-512 copy took 0.84 of the AVX2 copy's time).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum KernelCopy {
    Baseline,
    Avx2,
    Avx512,
}

/// The environment variable that caps the copy of the kernels: `baseline`, `avx2` or `avx512`
/// (the widest copy allowed; one the processor lacks is not used).
pub const KERNELS_VARIABLE: &str = "HELIXBIF_KERNELS";

impl KernelCopy {
    /// Its name, as [`KERNELS_VARIABLE`] takes it.
    pub fn name(self) -> &'static str {
        match self {
            KernelCopy::Baseline => "baseline",
            KernelCopy::Avx2 => "avx2",
            KernelCopy::Avx512 => "avx512",
        }
    }

    /// The copy named `name`, or an input error naming [`KERNELS_VARIABLE`].
    pub fn parse(name: &str) -> crate::Result<KernelCopy> {
        [KernelCopy::Baseline, KernelCopy::Avx2, KernelCopy::Avx512]
            .into_iter()
            .find(|c| c.name() == name)
            .ok_or_else(|| {
                crate::Error::input(
                    KERNELS_VARIABLE,
                    format!("`{name}` is not a copy of the kernels (baseline, avx2 or avx512)"),
                )
            })
    }

    /// The widest copy the processor can run.
    pub fn widest() -> KernelCopy {
        #[cfg(target_arch = "x86_64")]
        {
            use std::is_x86_feature_detected as has;
            if has!("avx512f")
                && has!("avx512vl")
                && has!("avx512dq")
                && has!("avx2")
                && has!("fma")
            {
                return KernelCopy::Avx512;
            }
            if has!("avx2") && has!("fma") {
                return KernelCopy::Avx2;
            }
        }
        KernelCopy::Baseline
    }

    /// The copy that runs: the widest the processor has, or the cap where that is narrower.
    pub fn in_use() -> KernelCopy {
        let cap = match CAP.load(Ordering::Relaxed) {
            UNCAPPED => KernelCopy::Avx512,
            c => COPIES[usize::from(c)],
        };
        KernelCopy::widest().min(cap)
    }
}

/// The copies in the order of [`KernelCopy`], indexed by the cap.
const COPIES: [KernelCopy; 3] = [KernelCopy::Baseline, KernelCopy::Avx2, KernelCopy::Avx512];

/// No cap set.
const UNCAPPED: u8 = u8::MAX;

/// The widest copy allowed (its index in [`COPIES`]), process-wide.
static CAP: AtomicU8 = AtomicU8::new(UNCAPPED);

/// Runs the kernels in no copy wider than `widest` from now on (in the whole process).
pub fn use_at_most(widest: KernelCopy) {
    CAP.store(widest as u8, Ordering::Relaxed);
}

/// The cap named by [`KERNELS_VARIABLE`], applied where it is set (and not empty); an input
/// error naming the variable where it holds something else than a copy's name. A front end
/// (the command line, the Python module) calls it at its start.
pub fn cap_from_environment() -> crate::Result<()> {
    match std::env::var(KERNELS_VARIABLE) {
        Ok(name) if !name.trim().is_empty() => {
            use_at_most(KernelCopy::parse(name.trim())?);
            Ok(())
        }
        Ok(_) | Err(std::env::VarError::NotPresent) => Ok(()),
        Err(std::env::VarError::NotUnicode(_)) => Err(crate::Error::input(
            KERNELS_VARIABLE,
            "is not valid Unicode (baseline, avx2 or avx512)",
        )),
    }
}

/// For a kernel `$kernel` of [`Rpy`]: its copies compiled for AVX2 and FMA (`$avx2`) and for
/// AVX-512 (`$avx512`), and `$name`, which runs the copy in use ([`KernelCopy::in_use`]).
macro_rules! wide_copies {
    ($name:ident, $kernel:ident, $avx2:ident, $avx512:ident, ($($arg:ident: $ty:ty),*) -> $ret:ty) => {
        #[doc = concat!("[`Rpy::", stringify!($kernel), "`] in the copy in use ([`KernelCopy::in_use`]).")]
        pub(super) fn $name(&self, $($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            match KernelCopy::in_use() {
                // SAFETY: the processor has AVX-512 (F, VL, DQ), AVX2 and FMA, checked at run time
                // ([`KernelCopy::widest`]).
                KernelCopy::Avx512 => return unsafe { self.$avx512($($arg),*) },
                // SAFETY: the processor has AVX2 and FMA, checked at run time.
                KernelCopy::Avx2 => return unsafe { self.$avx2($($arg),*) },
                KernelCopy::Baseline => {}
            }
            self.$kernel($($arg),*)
        }

        #[doc = concat!("[`Rpy::", stringify!($kernel), "`] for processors with AVX2 and FMA.")]
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma")]
        pub(super) unsafe fn $avx2(&self, $($arg: $ty),*) -> $ret {
            self.$kernel($($arg),*)
        }

        #[doc = concat!("[`Rpy::", stringify!($kernel), "`] for processors with AVX-512 (F, VL, DQ), AVX2 and FMA.")]
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx2,fma")]
        pub(super) unsafe fn $avx512(&self, $($arg: $ty),*) -> $ret {
            self.$kernel($($arg),*)
        }
    };
}

/// `[f(0), f(1), f(2)]`, written out: in the kernels' inner loops `array::map` was left as a
/// call that copies its result (seen in profiles as `try_map` and `memmove`).
#[inline(always)]
fn components(f: impl Fn(usize) -> Lanes) -> [Lanes; 3] {
    [f(0), f(1), f(2)]
}

/// The points of the rule (`xi`, `pw`) on the edges of `x`, `y_p = (1 - xi_q) x_k + xi_q x_{k+1}`.
fn point_set<'a>(x: &[Vector3<f64>], xi: &'a [f64], pw: &'a [[f64; 2]]) -> PointSet<'a> {
    let (edges, q) = (x.len() - 1, xi.len());
    let pos: Vec<Vector3<f64>> = x
        .windows(2)
        .flat_map(|e| xi.iter().map(|xi| e[0] * (1.0 - xi) + e[1] * *xi))
        .collect();
    let (stride, [px, py, pz]) = PointLanes::transpose(edges, q, |p| pos[p].into());
    let (_, weights) = PointLanes::transpose(edges, q, |p| pw[p]);
    PointSet {
        xi,
        pw,
        pos,
        lanes: PointLanes {
            stride,
            pos: [px, py, pz],
            pw: weights,
        },
    }
}

/// The quadrature points transposed for the kernels: entry `q * stride + k` belongs to point `q`
/// of edge `k`, so that one point of `LANES` consecutive edges is one contiguous read. The rows
/// are padded with `LANES - 1` weightless, forceless points at the origin, so any `LANES`
/// consecutive edges can be read; they contribute exact zeros.
pub(super) struct PointLanes {
    pub(super) stride: usize,
    /// Positions `y_p`, by component.
    pub(super) pos: [Vec<f64>; 3],
    /// The points' weights in the basis, as [`PointSet::pw`].
    pub(super) pw: [Vec<f64>; 2],
}

impl PointLanes {
    /// `values(p)` of every point `p = k Q + q`, transposed and padded.
    pub(super) fn transpose<const C: usize>(
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
pub(super) struct Radial {
    pub(super) alpha: Lanes,
    pub(super) beta: Lanes,
    pub(super) dalpha: Lanes,
    pub(super) dbeta: Lanes,
    pub(super) beta_over_r: Lanes,
    pub(super) inv: Lanes,
}

impl Rpy {
    /// `M(0) = I / (6 pi mu a)`: the self-mobility of a blob.
    pub(super) fn self_mobility(&self) -> f64 {
        1.0 / (6.0 * PI * self.mu * self.blob_radius)
    }

    /// [`Radial`] at the distances `r`: both branches evaluated, each lane's chosen. At
    /// `r = 0` the near branch gives `M = I / (6 pi mu a)`, and `1/r` is set to 0 so that
    /// `rhat = 0`.
    #[inline(always)]
    pub(super) fn radial(&self, r: Lanes) -> Radial {
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

    /// The quadrature points of the configuration `x`: the near rule's, the far rule's where
    /// the model has one, and which pairs of edges the far rule takes (once for every kernel
    /// pass over `x`).
    pub(super) fn discretise(&self, x: &[Vector3<f64>]) -> Discretisation<'_> {
        let n = x.len();
        assert_eq!(
            n,
            self.nodes(),
            "RPY mobility built for {} nodes, given {n}",
            self.nodes()
        );
        let edges = n - 1;
        // The far rule takes the edges `k` and `j` where in the natural polygon their midpoints
        // are at least FAR_RATIO times the longer edge apart, in `x` still at least
        // FAR_RATIO_DEFORMED times, and their points at least `2a` apart in both (so that `M` is
        // analytic over the pair; its only singularity, `r = 0`, is at least
        // `FAR_RATIO_DEFORMED - 1` edge lengths away). The natural polygon decides, so that the
        // partition, and with it `A(X)`, does not change with the configuration; the
        // configuration only takes a pair back to the near rule where the rod has folded far
        // from its natural shape.
        let far_pairs = match &self.far {
            Some(far) => {
                let (current, gap) = (Edges::of(x), 2.0 * self.blob_radius);
                (0..edges * edges)
                    .map(|i| {
                        let (k, j) = (i / edges, i % edges);
                        far.natural.apart(k, j, FAR_RATIO, gap)
                            && current.apart(k, j, FAR_RATIO_DEFORMED, gap)
                    })
                    .collect()
            }
            None => Vec::new(),
        };
        Discretisation {
            near: point_set(x, &self.rule.xi, &self.basis.pw),
            far: (self.far.as_ref()).map(|far| point_set(x, &far.rule.xi, &far.pw)),
            edges,
            far_pairs,
        }
    }

    /// Which of the [`LANES`] source edges from `k2` a pass over the edge `k` takes: 1 in the
    /// lanes of the edges it takes, 0 elsewhere (and in the padding past the last edge); `None`
    /// where it takes none. The near pass (`near`) takes the pairs that are not far apart
    /// ([`Discretisation::far_apart`]), the far pass the others; without a far rule the near pass takes
    /// every pair.
    pub(super) fn pass_mask(
        &self,
        d: &Discretisation,
        k: usize,
        k2: usize,
        near: bool,
    ) -> Option<Lanes> {
        let edges = d.edges;
        if d.far.is_none() {
            return near.then_some(Lanes::splat(1.0));
        }
        let mask = Lanes(std::array::from_fn(|l| {
            let j = k2 + l;
            f64::from(u8::from(j < edges && d.far_apart(k, j) != near))
        }));
        (mask.sum() > 0.0).then_some(mask)
    }

    /// `M(r)` at one separation, from [`Rpy::radial`]: the rows and columns of the point forces
    /// at the ends.
    pub(super) fn tensor(&self, r: Vector3<f64>) -> Matrix3<f64> {
        let c = self.radial(Lanes::splat(r.norm()));
        let rhat = r * c.inv.0[0];
        Matrix3::identity() * c.alpha.0[0] + rhat * rhat.transpose() * c.beta.0[0]
    }

    /// `D(r, g) = d(M(r) g)/dr` (0 at `r = 0`) at one separation, from [`Rpy::radial`]: the
    /// shape derivative's rows and columns of the point forces at the ends.
    pub(super) fn tensor_derivative(&self, r: Vector3<f64>, g: Vector3<f64>) -> Matrix3<f64> {
        let c = self.radial(Lanes::splat(r.norm()));
        let [dalpha, dbeta, beta_over_r, inv] =
            [c.dalpha, c.dbeta, c.beta_over_r, c.inv].map(|v| v.0[0]);
        let rhat = r * inv;
        let rr = rhat * rhat.transpose();
        let rg = rhat.dot(&g);
        g * rhat.transpose() * dalpha
            + rr * (dbeta * rg)
            + (rhat * g.transpose() + Matrix3::identity() * rg - rr * (2.0 * rg)) * beta_over_r
    }

    wide_copies!(edge_pairs, edge_pairs_kernel, edge_pairs_avx2, edge_pairs_avx512,
        (d: &Discretisation, set: &PointSet, near: bool, k: usize)
            -> Vec<[[Matrix3<f64>; 2]; 2]>);

    /// For edge `k` and every `k2 >= k`: `s[a][b] = sum_{p on k, p2 on k2} pw_a(p) M(y_p - y_p2)
    /// pw_b(p2)` over the points of `set`, the contribution to the node blocks `(k + a, k2 + b)`
    /// before `1/(w w)`, for the pairs of edges the pass takes ([`Rpy::pass_mask`]; zero for
    /// the others). [`LANES`] edges `k2` at a time, the sums kept per lane as a scalar times `I`
    /// plus a symmetric matrix (`[alpha sum, xx, xy, xz, yy, yz, zz]`), the form of
    /// `M = alpha I + (beta/r^2) r r^T`.
    #[inline(always)]
    pub(super) fn edge_pairs_kernel(
        &self,
        d: &Discretisation,
        set: &PointSet,
        near: bool,
        k: usize,
    ) -> Vec<[[Matrix3<f64>; 2]; 2]> {
        let q = set.per_edge();
        let edges = self.nodes() - 1;
        let lanes = &set.lanes;
        let mut out = Vec::with_capacity(edges - k);
        for k2 in (k..edges).step_by(LANES) {
            let Some(mask) = self.pass_mask(d, k, k2, near) else {
                out.extend(std::iter::repeat_n(
                    [[Matrix3::zeros(); 2]; 2],
                    LANES.min(edges - k2),
                ));
                continue;
            };
            // s[a][b] per lane, in the same seven-number form.
            let mut s = [[[Lanes::ZERO; 7]; 2]; 2];
            for p in k * q..(k + 1) * q {
                let y = set.pos[p];
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
                for (sa, weight) in s.iter_mut().zip(set.pw[p]) {
                    let weight = Lanes::splat(weight);
                    for (sab, sum) in sa.iter_mut().zip(&sums) {
                        for (t, v) in sab.iter_mut().zip(sum) {
                            *t += weight * *v;
                        }
                    }
                }
            }
            let s = s.map(|sa| sa.map(|sab| sab.map(|t| (t * mask).0)));
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

    /// The contributions of the points of `set` on edge `k` to the rows `k, k + 1` of `B_e`
    /// (see [`Rpy::mobility_derivative`]) from the pairs of edges the pass takes
    /// ([`Rpy::pass_mask`]), with `forces` the point forces `G` of `set` by component in the
    /// layout of [`PointLanes`]. [`LANES`] edges `k2` at a time: per lane, the sums over the
    /// points `p2` of edge `k2` of `D(y_p - y_p2, G_p2)`, plain and weighted by `xi_q2`.
    #[inline(always)]
    pub(super) fn edge_rows_kernel(
        &self,
        d: &Discretisation,
        set: &PointSet,
        near: bool,
        forces: &[Vec<f64>; 3],
        k: usize,
    ) -> EdgeRows {
        let q = set.per_edge();
        let n = self.nodes();
        let edges = n - 1;
        let lanes = &set.lanes;
        let w = &self.basis.w;
        let mut out = EdgeRows {
            b: [vec![Matrix3::zeros(); n], vec![Matrix3::zeros(); n]],
        };
        let points = k * q..(k + 1) * q;
        // P_pi of each point p of edge k for its rows i = k, k + 1.
        let p_nodes: Vec<[f64; 2]> = points
            .clone()
            .map(|p| [set.pw[p][0] / w[k], set.pw[p][1] / w[k + 1]])
            .collect();
        // Per point p, across all edges k2: the sum of D, per lane.
        let mut own = vec![[Lanes::ZERO; 9]; q];
        for k2 in (0..edges).step_by(LANES) {
            let Some(mask) = self.pass_mask(d, k, k2, near) else {
                continue;
            };
            // Per row i = k + ia, across the points p: P_pi [D - xi D, xi D].
            let mut rows = [[Lanes::ZERO; 18]; 2];
            for (ip, p) in points.clone().enumerate() {
                let y = components(|c| Lanes::splat(set.pos[p][c]));
                let mut acc = [Lanes::ZERO; 18];
                for (i, &xi2) in set.xi.iter().enumerate() {
                    let at = i * lanes.stride + k2;
                    let r = components(|j| y[j] - Lanes::load(&lanes.pos[j], at));
                    let c = self.radial((r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt());
                    let rhat = components(|j| r[j] * c.inv);
                    let g = components(|j| Lanes::load(&forces[j], at));
                    // D = u rhat^T + rhat v^T + (beta/r)(rhat.G) I.
                    let rg = rhat[0] * g[0] + rhat[1] * g[1] + rhat[2] * g[2];
                    let diagonal = c.beta_over_r * rg;
                    let along = (c.dbeta - 2.0 * c.beta_over_r) * rg;
                    let u = components(|j| g[j] * c.dalpha);
                    let v = components(|j| g[j] * c.beta_over_r + rhat[j] * along);
                    let xi2 = Lanes::splat(xi2);
                    for a in 0..3 {
                        for b in 0..3 {
                            let mut dm = u[a] * rhat[b] + rhat[a] * v[b];
                            if a == b {
                                dm += diagonal;
                            }
                            acc[3 * a + b] += dm;
                            acc[9 + 3 * a + b] += dm * xi2;
                        }
                    }
                }
                if mask != Lanes::splat(1.0) {
                    for a in &mut acc {
                        *a = *a * mask;
                    }
                }
                for j in 0..9 {
                    own[ip][j] += acc[j];
                }
                for (row, &pi) in rows.iter_mut().zip(&p_nodes[ip]) {
                    let pi = Lanes::splat(pi);
                    for j in 0..9 {
                        row[j] += pi * (acc[j] - acc[9 + j]);
                        row[9 + j] += pi * acc[9 + j];
                    }
                }
            }
            let rows = rows.map(|row| row.map(|t| t.0));
            for l in 0..LANES.min(edges - k2) {
                let at = k2 + l;
                for (ia, row) in rows.iter().enumerate() {
                    for jb in 0..2 {
                        out.b[ia][at + jb] -= Matrix3::from_fn(|a, b| row[9 * jb + 3 * a + b][l]);
                    }
                }
            }
        }
        for (p_node, (&xi, own)) in p_nodes.iter().zip(set.xi.iter().zip(&own)) {
            let own = Matrix3::from_fn(|a, b| own[3 * a + b].sum());
            let phi = [1.0 - xi, xi];
            for (ia, &pi) in p_node.iter().enumerate() {
                for (jb, phib) in phi.iter().enumerate() {
                    out.b[ia][k + jb] += own * (pi * phib);
                }
            }
        }
        out
    }

    wide_copies!(edge_rows, edge_rows_kernel, edge_rows_avx2, edge_rows_avx512,
        (d: &Discretisation, set: &PointSet, near: bool, forces: &[Vec<f64>; 3], k: usize)
            -> EdgeRows);

    /// The velocities `u_p = sum_p2 M(y_p - y_p2) G_p2` that the point forces of the points of
    /// `set` induce at its points `p` on edge `k` (the point forces at the ends aside), over the
    /// pairs of edges the pass takes ([`Rpy::pass_mask`]), for each set `forces[v]` (the point
    /// forces of `set` by component, in the layout of [`PointLanes`]): `q` points times the
    /// sets, point by point. Only the groups of [`LANES`] source edges whose first edge is in
    /// `sources` are visited (the others carry no force in any set). Each pair costs one kernel
    /// evaluation and, per set, `M G = alpha G + (beta/r^2) (r.G) r`.
    #[inline(always)]
    pub(super) fn edge_velocities_kernel(
        &self,
        d: &Discretisation,
        set: &PointSet,
        near: bool,
        forces: &[[Vec<f64>; 3]],
        sources: &[usize],
        k: usize,
    ) -> Vec<Vector3<f64>> {
        let q = set.per_edge();
        let lanes = &set.lanes;
        let masks: Vec<(usize, Lanes)> = sources
            .iter()
            .filter_map(|&k2| Some((k2, self.pass_mask(d, k, k2, near)?)))
            .collect();
        let mut out = Vec::with_capacity(q * forces.len());
        let mut sums = vec![[Lanes::ZERO; 3]; forces.len()];
        let mut group = vec![[Lanes::ZERO; 3]; forces.len()];
        for p in k * q..(k + 1) * q {
            let y = components(|c| Lanes::splat(set.pos[p][c]));
            sums.fill([Lanes::ZERO; 3]);
            for &(k2, mask) in &masks {
                // A group whose every lane the pass takes sums straight into `sums`.
                let whole = mask == Lanes::splat(1.0);
                let into = if whole {
                    &mut sums
                } else {
                    group.fill([Lanes::ZERO; 3]);
                    &mut group
                };
                for i in 0..q {
                    let at = i * lanes.stride + k2;
                    let r = components(|c| y[c] - Lanes::load(&lanes.pos[c], at));
                    let radial = self.radial((r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt());
                    let c = radial.beta_over_r * radial.inv;
                    for (sum, g) in into.iter_mut().zip(forces) {
                        let g = components(|j| Lanes::load(&g[j], at));
                        let along = c * (r[0] * g[0] + r[1] * g[1] + r[2] * g[2]);
                        for j in 0..3 {
                            sum[j] += radial.alpha * g[j] + along * r[j];
                        }
                    }
                }
                if !whole {
                    for (sum, g) in sums.iter_mut().zip(&group) {
                        for j in 0..3 {
                            sum[j] += g[j] * mask;
                        }
                    }
                }
            }
            out.extend(
                sums.iter()
                    .map(|s| Vector3::new(s[0].sum(), s[1].sum(), s[2].sum())),
            );
        }
        out
    }

    wide_copies!(edge_velocities, edge_velocities_kernel, edge_velocities_avx2,
        edge_velocities_avx512,
        (d: &Discretisation, set: &PointSet, near: bool, forces: &[[Vec<f64>; 3]],
            sources: &[usize], k: usize) -> Vec<Vector3<f64>>);

    /// The point forces `G_p = sum_j P_pj z_j` of the points of `set`, by component, in the
    /// layout of [`PointLanes`].
    pub(super) fn point_forces(&self, set: &PointSet, z: &[Vector3<f64>]) -> [Vec<f64>; 3] {
        let (q, w) = (set.per_edge(), &self.basis.w);
        let (_, forces) = PointLanes::transpose(self.nodes() - 1, q, |p| {
            let (k, pw) = (p / q, set.pw[p]);
            (z[k] * (pw[0] / w[k]) + z[k + 1] * (pw[1] / w[k + 1])).into()
        });
        forces
    }
}

#[cfg(test)]
mod tests {
    /// The kernels compiled for wider registers give the same bits as the baseline ones (each
    /// copy the processor has), in the near and the far pass, on a configuration with near and
    /// far pairs (a helix turned in on itself) and a number of edges that is no multiple of the
    /// lanes.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn every_kernel_copy_gives_the_same_bits() {
        use super::KernelCopy;
        use nalgebra::Vector3;
        let widest = KernelCopy::widest();
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
        let far = d
            .far
            .as_ref()
            .expect("this rule's 32 points per edge take a far rule");
        let sources: Vec<usize> = (0..x.len() - 1).step_by(super::LANES).collect();
        for (set, near) in [(&d.near, true), (far, false)] {
            let forces = rpy.point_forces(set, &y);
            let sets = [forces.clone()];
            for k in 0..x.len() - 1 {
                let pairs = rpy.edge_pairs_kernel(&d, set, near, k);
                let rows = rpy.edge_rows_kernel(&d, set, near, &forces, k).b;
                let velocities = rpy.edge_velocities_kernel(&d, set, near, &sets, &sources, k);
                if widest != KernelCopy::Baseline {
                    // SAFETY: the processor has AVX2 and FMA (AVX-512 implies them here).
                    unsafe {
                        assert_eq!(rpy.edge_pairs_avx2(&d, set, near, k), pairs, "edge {k}");
                        assert_eq!(rpy.edge_rows_avx2(&d, set, near, &forces, k).b, rows);
                        assert_eq!(
                            rpy.edge_velocities_avx2(&d, set, near, &sets, &sources, k),
                            velocities
                        );
                    }
                }
                if widest == KernelCopy::Avx512 {
                    // SAFETY: the processor has AVX-512 (F, VL, DQ), AVX2 and FMA.
                    unsafe {
                        assert_eq!(rpy.edge_pairs_avx512(&d, set, near, k), pairs, "edge {k}");
                        assert_eq!(rpy.edge_rows_avx512(&d, set, near, &forces, k).b, rows);
                        assert_eq!(
                            rpy.edge_velocities_avx512(&d, set, near, &sets, &sources, k),
                            velocities
                        );
                    }
                }
            }
        }
    }
}
