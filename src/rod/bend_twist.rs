//! Bending and twisting at one interior node of the discrete rod (Bergou et al. 2008, 2010).
//!
//! The stencil of node `i` holds the two adjacent edges `e0 = e^{i-1}`, `e1 = e^i` and their twist
//! angles `theta0`, `theta1`: eight unknowns. With `t = e/|e|`, reference directors `a` carried by
//! parallel transport from the chart onto the current edges, `b = t x a`, and material directors
//! `m1 = cos(theta) a + sin(theta) b`, `m2 = -sin(theta) a + cos(theta) b`:
//!
//! * curvature binormal `kb = 2 e0 x e1 / (|e0||e1| + e0.e1)`,
//! * material curvatures `kappa1 = 1/2 (m2_0 + m2_1).kb`, `kappa2 = -1/2 (m1_0 + m1_1).kb`,
//! * twist `m = theta1 - theta0 + mref` (`mref`: angle from the transport of `a_0` onto edge `i` to `a_1`),
//! * `E = EI/(2 lbar) [(kappa1 - kappa1bar)^2 + (kappa2 - kappa2bar)^2] + GJ/(2 lbar) (m - mbar)^2`.
//!
//! The energy is written once, generic over the scalar; its exact gradient and Hessian come from
//! forward-mode automatic differentiation (`num-dual`): the chain rule carried out to machine
//! precision, through the transport of the reference frame, so no term (such as the finite
//! transport term missing from the printed Hessian of Bergou et al. 2010) can be forgotten.

use nalgebra::{RealField, SMatrix, SVector, Vector3, convert};
use num_dual::{gradient, hessian};

use super::frame::{reference_twist, transport};

/// Number of unknowns of a stencil: `(e0, e1, theta0, theta1)`.
pub const STENCIL: usize = 8;

/// Everything a bend-twist stencil needs besides its unknowns.
#[derive(Clone, Copy, Debug)]
pub struct BendTwist {
    /// Chart tangents and directors of the two edges (the source of the parallel transport).
    pub source_t: [Vector3<f64>; 2],
    pub source_d: [Vector3<f64>; 2],
    /// Multiple of `2 pi` added to the principal reference twist.
    pub twist_offset: f64,
    /// Natural Voronoi length `lbar_i`.
    pub lbar: f64,
    /// Natural material curvatures and twist.
    pub kappa_bar: [f64; 2],
    pub twist_bar: f64,
    pub ei: f64,
    pub gj: f64,
}

/// Material curvatures `(kappa1, kappa2)` and twist `m` of a stencil.
pub fn strains<T: RealField + Copy>(s: &BendTwist, v: &SVector<T, STENCIL>) -> (T, T, T) {
    let c = |a: &Vector3<f64>| a.map(convert::<f64, T>);
    let e0 = Vector3::new(v[0], v[1], v[2]);
    let e1 = Vector3::new(v[3], v[4], v[5]);
    let (l0, l1) = (e0.norm(), e1.norm());
    let (t0, t1) = (e0 / l0, e1 / l1);
    let a0 = transport(&c(&s.source_t[0]), &t0, &c(&s.source_d[0]));
    let a1 = transport(&c(&s.source_t[1]), &t1, &c(&s.source_d[1]));
    let material = |t: &Vector3<T>, a: &Vector3<T>, theta: T| {
        let b = t.cross(a);
        let (sin, cos) = theta.sin_cos();
        (a * cos + b * sin, b * cos - a * sin)
    };
    let (m1_0, m2_0) = material(&t0, &a0, v[6]);
    let (m1_1, m2_1) = material(&t1, &a1, v[7]);
    let two: T = convert(2.0);
    let half: T = convert(0.5);
    let kb = e0.cross(&e1) * (two / (l0 * l1 + e0.dot(&e1)));
    let kappa1 = (m2_0 + m2_1).dot(&kb) * half;
    let kappa2 = -(m1_0 + m1_1).dot(&kb) * half;
    let mref = reference_twist(&t0, &a0, &t1, &a1, s.twist_offset);
    (kappa1, kappa2, v[7] - v[6] + mref)
}

impl BendTwist {
    /// Bending plus twisting energy of the stencil.
    pub fn energy<T: RealField + Copy>(&self, v: &SVector<T, STENCIL>) -> T {
        let (k1, k2, m) = strains(self, v);
        let d1 = k1 - convert(self.kappa_bar[0]);
        let d2 = k2 - convert(self.kappa_bar[1]);
        let dm = m - convert(self.twist_bar);
        let scale: T = convert(0.5 / self.lbar);
        (d1 * d1 * convert(self.ei) + d2 * d2 * convert(self.ei) + dm * dm * convert(self.gj))
            * scale
    }

    /// Energy and exact gradient.
    pub fn gradient(&self, v: &SVector<f64, STENCIL>) -> (f64, SVector<f64, STENCIL>) {
        gradient(|w| self.energy(&w), v)
    }

    /// Energy, exact gradient and exact Hessian.
    pub fn hessian(
        &self,
        v: &SVector<f64, STENCIL>,
    ) -> (f64, SVector<f64, STENCIL>, SMatrix<f64, STENCIL, STENCIL>) {
        hessian(|w| self.energy(&w), v)
    }
}
