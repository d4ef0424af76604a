//! Stretching of one edge: `E_s = 1/2 EA (|e|/|ebar| - 1)^2 |ebar|`.

use nalgebra::{Matrix3, Vector3};

/// Energy, gradient and Hessian of the stretching energy of an edge with respect to the edge
/// vector `e` (`t = e/|e|`, `eps = |e|/|ebar| - 1`):
///
/// * `E = 1/2 EA eps^2 |ebar|`,
/// * `dE/de = EA eps t`,
/// * `d2E/de2 = EA/|ebar| t t^T + EA eps/|e| (I - t t^T)`.
pub(crate) fn stretch(ea: f64, rest: f64, e: &Vector3<f64>) -> (f64, Vector3<f64>, Matrix3<f64>) {
    let len = e.norm();
    let t = e / len;
    let eps = len / rest - 1.0;
    let tt = t * t.transpose();
    let hess = tt * (ea / rest) + (Matrix3::identity() - tt) * (ea * eps / len);
    (0.5 * ea * eps * eps * rest, t * (ea * eps), hess)
}
