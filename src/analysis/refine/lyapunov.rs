//! The first Lyapunov coefficient's error in `N` (docs/model.md sections 10 and 12): `l1` of the
//! finest rung of a refinement against those of the two rungs before it, and the verdict only
//! where they settle its sign.
//!
//! `l1` converges in `N` as `omega_b` does not quite: on the representative helix (RPY line,
//! `l1` for a largest node displacement of `ell`) `N = 60, 119, 237, 473` give `0.48882,
//! 0.52862, 0.54159, 0.54503` (increments shrinking 3.1 and 3.8 times: observed orders 1.62
//! and 1.91), on a two-turn helix (`l = 0.1` m) `N = 27, 53, 105, 209, 417` give `0.37159,
//! 0.44052, 0.48809, 0.50210, 0.50566` (1.45, 3.4 and 3.9 times): no order the model fixes,
//! and coarse rungs before the range where any order holds. So `l1` is computed at the two
//! rungs before the finest as well, and where its increments over the three have one sign and
//! shrink at least as at first order (`|d_f| <= |d_p| (h_p - h_f) / (h_pp - h_p)`), the error of
//! the finest rung's `l1` is the first-order estimate
//!
//! ```text
//! e = |l1_f - l1_p| h_f / (h_p - h_f),                                                   (1)
//! ```
//!
//! which bounds it for any order at least 1 (at `N = 237` of the representative helix it
//! states `1.3e-2`, about three times the error against the second-order limit of the rungs 237
//! and 473, `0.5462`, which the precision of the finite differences alone, `6.0e-4`, would
//! understate almost eightfold). Elsewhere the error is not estimated, and the report says so.

use serde::Serialize;

use super::Solved;
use crate::analysis::locate::{Located, hopf_criticality};
use crate::engine::criticality::Verdict;
use crate::numerics::extrapolation::{Orders, first_order_error};

/// `l1` at one rung before the finest.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RungLyapunov {
    pub nodes: usize,
    /// `l1` and its precision (solver units, as the finest's).
    pub l1: f64,
    pub precision: f64,
}

/// `l1` at the rungs before the finest, and the estimated error in `N` of the finest's (1).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LyapunovError {
    /// The (at most two) rungs before the finest, coarsest first.
    pub rungs: Vec<RungLyapunov>,
    /// The finest rung's `l1`'s error in `N`, (1); `None` where it is not estimated (`failed`
    /// says why).
    pub error: Option<f64>,
    pub failed: Option<String>,
}

impl LyapunovError {
    /// `l1` at the two rungs `coarser` before `finest` (whose coefficient is computed;
    /// coarsest first), and the error (1) of the finest's, the spacings `h` those of `orders`;
    /// with one rung before, no `l1` there (it could give no error) and why; `None` where the
    /// finest has no coefficient or no rung before it.
    pub(super) fn measure(coarser: &[Solved], finest: &Located, orders: Orders) -> Option<Self> {
        let l1_f = finest.l1?;
        let unestimated = |rungs: Vec<RungLyapunov>, why: String| LyapunovError {
            rungs,
            error: None,
            failed: Some(why),
        };
        let (pp, p) = match coarser {
            [] => return None,
            // Not computed where it could give no error.
            [one] => {
                return Some(unestimated(
                    Vec::new(),
                    format!(
                        "two rungs (N = {} and {}) cannot show how l1 converges: a third is \
                         needed",
                        one.located.nodes, finest.nodes
                    ),
                ));
            }
            [.., pp, p] => (pp, p),
        };
        let pp = match coefficient(pp) {
            Ok(r) => r,
            Err(why) => return Some(unestimated(Vec::new(), why)),
        };
        let p = match coefficient(p) {
            Ok(r) => r,
            Err(why) => return Some(unestimated(vec![pp], why)),
        };
        let h = |n: usize| orders.spacing(n);
        let (hpp, hp, hf) = (h(pp.nodes), h(p.nodes), h(finest.nodes));
        let (d_p, d_f) = (p.l1 - pp.l1, l1_f - p.l1);
        let first_order = d_p * d_f >= 0.0 && d_f.abs() <= d_p.abs() * (hp - hf) / (hpp - hp);
        Some(if first_order {
            LyapunovError {
                error: Some(first_order_error(
                    orders,
                    (p.nodes, p.l1),
                    (finest.nodes, l1_f),
                )),
                rungs: vec![pp, p],
                failed: None,
            }
        } else {
            let why = format!(
                "its increments over N = {}, {}, {} ({d_p:+.2e}, {d_f:+.2e}) do not shrink as at \
                 first order or faster: the rungs are not yet where l1 converges",
                pp.nodes, p.nodes, finest.nodes
            );
            unestimated(vec![pp, p], why)
        })
    }

    /// The verdict of the finest rung's `l1` (precision `precision`) with this error in `N`: its
    /// sign where `|l1|` exceeds the error and the precision together and every rung before
    /// has the same sign; `undetermined` otherwise. Where the error is not estimated, the
    /// finest rung's own verdict `own` stands only if every rung before that has a coefficient
    /// has its sign (the report says its error in `N` is missing).
    pub fn verdict(&self, l1: f64, precision: f64, own: Verdict) -> Verdict {
        let one_sign = self.rungs.iter().all(|r| r.l1.signum() == l1.signum());
        let settled = match self.error {
            Some(error) => one_sign && l1.abs() > error + precision,
            None => one_sign && own != Verdict::Undetermined,
        };
        Verdict::of(l1, settled)
    }
}

/// `l1` at the Hopf point of a rung, or why it could not be computed.
fn coefficient(solved: &Solved) -> Result<RungLyapunov, String> {
    let nodes = solved.located.nodes;
    let critical = solved
        .critical
        .as_ref()
        .ok_or_else(|| format!("N = {nodes} has no Hopf point"))?;
    let at = hopf_criticality(&solved.model, &critical.event, &critical.chart)
        .map_err(|e| format!("l1 at N = {nodes} failed: {e}"))?;
    Ok(RungLyapunov {
        nodes,
        l1: at.l1,
        precision: at.precision,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn measured(l1: f64, error: f64) -> LyapunovError {
        let rung = |nodes, l1| RungLyapunov {
            nodes,
            l1,
            precision: 1e-4,
        };
        LyapunovError {
            rungs: vec![rung(60, l1 - error), rung(119, l1)],
            error: Some(error),
            failed: None,
        }
    }

    /// The sign is the verdict only where the error in `N` and the precision leave it, and the
    /// rungs before agree; a coefficient without its error in `N` keeps its own verdict only
    /// where the rungs before agree in sign.
    #[test]
    fn the_verdict_needs_the_sign_settled_in_n() {
        let own = Verdict::Subcritical;
        assert_eq!(
            measured(0.53, 0.013).verdict(0.54, 7.7e-4, own),
            Verdict::Subcritical
        );
        assert_eq!(
            measured(-0.2, 0.05).verdict(-0.3, 1e-3, Verdict::Supercritical),
            Verdict::Supercritical
        );
        // |l1| within the error in N, though far above its precision.
        assert_eq!(
            measured(0.01, 0.02).verdict(0.015, 1e-4, own),
            Verdict::Undetermined
        );
        // A rung before has the other sign.
        assert_eq!(
            measured(-0.01, 0.001).verdict(0.05, 1e-4, own),
            Verdict::Undetermined
        );
        // Without an error in N: the finest's own verdict where the rungs agree in sign.
        let unknown = |l1_before: f64| LyapunovError {
            error: None,
            failed: Some("the increments do not shrink".into()),
            ..measured(l1_before, 0.0)
        };
        assert_eq!(unknown(0.01).verdict(0.015, 1e-4, own), own);
        assert_eq!(
            unknown(-0.01).verdict(0.05, 1e-4, own),
            Verdict::Undetermined
        );
    }
}
