//! The rotating rod as the engine's continuation problem: the velocity form of the steady
//! problem in the parameter `omegabar` or the weight `q`, its twist measured in a chart that
//! follows the branch, its stability pair and its dynamics (for the Lyapunov coefficient).

use std::borrow::Borrow;
use std::cell::{OnceCell, RefCell};
use std::sync::Arc;

use faer::Mat;

use crate::Result;
use crate::engine::{Field, Linearization, Problem};
use crate::model::Model;
use crate::model::rod::frame::Chart;
use crate::model::rod::frame::rechart;
use crate::model::steady::{MobilityBlocks, Steady};
use crate::numerics::lu::Lu;
use crate::problem::twist::slave_twist_chord;

/// The continuation parameter of the rod.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Parameter {
    /// The rotation rate `omegabar` (weight fixed at the model's).
    Omega,
    /// The weight per length `q ell^3 / EI` (no rotation): statics, e.g. Greenhill's column.
    Weight,
}

/// Typical change of a position unknown (solver units: a twentieth of the reference length):
/// with the parameter's scale, the units of the arclength.
const POSITION_SCALE: f64 = 5e-2;
/// The smallest scale of `omegabar` in the arclength, and the typical weight `q ell^3/EI`.
pub(crate) const OMEGA_SCALE: f64 = 10.0;
pub const WEIGHT_SCALE: f64 = 1.0;

/// The scale of `omegabar` in the arclength for a branch followed up to `omegabar_max`: a
/// hundredth of the range (at least [`OMEGA_SCALE`]), so that the largest step
/// (`continuation.ds_max`) covers a fixed fraction of the range where the branch is straight,
/// and the number of points does not grow with the rate that the instability needs (a thin or
/// tight helix buckles at `omegabar` in the tens of thousands).
pub fn omega_scale(omegabar_max: f64) -> f64 {
    (0.01 * omegabar_max.abs()).max(OMEGA_SCALE)
}

/// The steady rod problem `G(u; p) = 0` with `p` the chosen [`Parameter`], its twist angles
/// measured in a chart that starts as the natural one and follows the branch
/// ([`Problem::rechart`]).
pub struct RodProblem<M: Borrow<Model>> {
    /// The model, borrowed (a branch of one study) or owned (a member of a two-parameter
    /// family, [`crate::boundary::RodFamily`]).
    pub model: M,
    pub parameter: Parameter,
    /// The typical change of `p` (the parameter's unit in the arclength): [`omega_scale`] or
    /// [`WEIGHT_SCALE`].
    pub parameter_scale: f64,
    chart: RefCell<Chart>,
    /// The mobility blocks of the latest linearization and the unknowns it was made at: the
    /// stability pair at the point just corrected reuses them.
    blocks: RefCell<Option<(Vec<f64>, MobilityBlocks)>>,
    /// The unit of the velocity rows, [`Steady::typical_mobility`] of the natural shape, made
    /// at the first evaluation.
    velocity_unit: OnceCell<f64>,
    /// The twist blocks of the Jacobian at the state `(u, p)` the dynamics ([`Problem::dynamics`])
    /// was last asked about.
    twist: RefCell<Option<Arc<TwistMap>>>,
}

/// The twist rows of the steady Jacobian at a state: `J_tt = dR_theta/dtheta` (factorized) and
/// `J_tx = dR_theta/dx`, whose `-J_tt^{-1} J_tx` is the derivative of the slaved twist.
struct TwistMap {
    /// The state `(u, p)`.
    u: Vec<f64>,
    p: f64,
    j_tt: Lu<f64>,
    j_tx: Mat<f64>,
}

impl<M: Borrow<Model>> RodProblem<M> {
    /// The problem in the model's natural chart.
    pub fn new(model: M, parameter: Parameter, parameter_scale: f64) -> Self {
        let chart = RefCell::new(model.borrow().chart.clone());
        RodProblem {
            model,
            parameter,
            parameter_scale,
            chart,
            blocks: RefCell::new(None),
            velocity_unit: OnceCell::new(),
            twist: RefCell::new(None),
        }
    }

    /// The twist blocks of the Jacobian at `(u, p)`, made once per state.
    fn twist_map(&self, u: &[f64], p: f64) -> Arc<TwistMap> {
        if let Some(map) = self.twist.borrow().as_ref()
            && map.u == u
            && map.p == p
        {
            return map.clone();
        }
        // The twist rows of the Jacobian are those of -dE/dtheta: -H.
        let h = self.steady(p).free_hessian(u);
        let nx = self.model.borrow().rod.layout.free_positions();
        let nt = h.nrows() - nx;
        let map = Arc::new(TwistMap {
            u: u.to_vec(),
            p,
            j_tt: Lu::of(Mat::from_fn(nt, nt, |r, c| -h[(nx + r, nx + c)])),
            j_tx: Mat::from_fn(nt, nx, |r, c| -h[(nx + r, c)]),
        });
        *self.twist.borrow_mut() = Some(map.clone());
        map
    }

    /// The steady problem at parameter value `p`, twist measured in the current chart.
    pub fn steady(&self, p: f64) -> Steady<'_> {
        let mut s = Steady::new(self.model.borrow(), 0.0);
        s.chart = self.chart.borrow().clone();
        match self.parameter {
            Parameter::Omega => s.omega = p,
            Parameter::Weight => s.weight = p,
        }
        s
    }

    /// The chart the twist angles are measured in now (that of the latest points and events).
    pub fn chart(&self) -> Chart {
        self.chart.borrow().clone()
    }

    /// Measures the twist angles in `chart` from now on.
    pub(crate) fn set_chart(&self, chart: Chart) {
        *self.chart.borrow_mut() = chart;
    }

    /// The unit of the velocity rows ([`Steady::typical_mobility`] of the natural shape).
    fn velocity_unit(&self) -> Result<f64> {
        if let Some(unit) = self.velocity_unit.get() {
            return Ok(*unit);
        }
        let model = self.model.borrow();
        let unit = self.steady(0.0).typical_mobility(&model.natural)?;
        Ok(*self.velocity_unit.get_or_init(|| unit))
    }

    /// Divides the velocity rows (the free positions') of `g` by [`Self::velocity_unit`], which
    /// it returns.
    fn in_force_units(&self, g: &mut [f64]) -> Result<f64> {
        let unit = self.velocity_unit()?;
        let nx = self.model.borrow().rod.layout.free_positions();
        for v in &mut g[..nx] {
            *v /= unit;
        }
        Ok(unit)
    }
}

impl<M: Borrow<Model>> Problem for RodProblem<M> {
    fn dim(&self) -> usize {
        self.model.borrow().rod.layout.free_len()
    }

    /// The velocity form `V` ([`Steady::velocity_residual`]), its position rows divided by the
    /// typical mobility of the natural shape (the corrector's `tol` then measures a force, as in
    /// the force balance, whose round-off `S` would otherwise enlarge some twentyfold on a fine
    /// rod): the same solutions as the force balance, and Newton's matrix needs no solve with
    /// the resistance.
    fn residual(&self, u: &[f64], p: f64) -> Result<Vec<f64>> {
        let mut g = self.steady(p).velocity_residual(u)?;
        self.in_force_units(&mut g)?;
        Ok(g)
    }

    fn linearize(&self, u: &[f64], p: f64) -> Result<Linearization> {
        let steady = self.steady(p);
        let mut lin = steady.linearize_velocity(u)?;
        let mut g_p = match self.parameter {
            Parameter::Omega => steady.velocity_rate_derivative(&lin, u),
            Parameter::Weight => steady.velocity_weight_derivative(&lin),
        };
        let unit = self.in_force_units(&mut lin.residual)?;
        self.in_force_units(&mut g_p)?;
        let nx = lin.blocks.schur.nrows();
        for c in 0..lin.jacobian.ncols() {
            for r in 0..nx {
                lin.jacobian[(r, c)] /= unit;
            }
        }
        *self.blocks.borrow_mut() = Some((u.to_vec(), lin.blocks));
        Ok(Linearization {
            g: lin.residual,
            g_u: lin.jacobian,
            g_p,
        })
    }

    fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        self.steady(0.0).retract(u, du)
    }

    fn interpolate(&self, u0: &[f64], u1: &[f64], w: f64) -> Vec<f64> {
        self.steady(0.0).interpolate(u0, u1, w)
    }

    fn stability_pair(
        &self,
        u: &[f64],
        p: f64,
        _lin: &Linearization,
    ) -> Result<(Mat<f64>, Mat<f64>)> {
        let cached = self.blocks.borrow();
        let blocks = cached.as_ref().filter(|(at, _)| at == u).map(|(_, b)| b);
        self.steady(p).stability_pair_from(u, blocks)
    }

    fn scales(&self) -> (f64, f64) {
        (POSITION_SCALE, self.parameter_scale)
    }

    /// `dx_f/dt = Z_ff^{-1} R_x(x_f, theta*(x_f))` at the free positions of `u` displaced by `y`,
    /// the twist slaved (docs/model.md section 5; [`crate::analysis::dynamics`] eq. (1)), started from the
    /// twist of `u` and converged to round-off: the differences of the Lyapunov coefficient
    /// divide this by `h^3`. The velocity is taken in mobility form
    /// ([`Steady::free_velocity`]), without `Z`. The field holds the twist blocks of the
    /// Jacobian at `u` and the chart of now.
    fn dynamics(&self, u: &[f64], p: f64) -> Option<Result<Field<'_>>> {
        let twist = self.twist_map(u, p);
        let steady = self.steady(p);
        let u = u.to_vec();
        Some(Ok(Box::new(move |y: &[f64]| {
            let nx = y.len();
            // The twist predicted to first order, theta* - J_tt^{-1} J_tx y, then slaved by the
            // chord method on J_tt (gradients only).
            let j_tx_y = &twist.j_tx * Mat::from_fn(nx, 1, |i, _| y[i]);
            let dtheta = twist.j_tt.solve(j_tx_y.as_ref());
            let mut moved = u.clone();
            for (x, d) in moved.iter_mut().zip(y) {
                *x += d;
            }
            for (k, t) in moved[nx..].iter_mut().enumerate() {
                *t -= dtheta[(k, 0)];
            }
            let slaved =
                slave_twist_chord(steady.model, &steady.chart, &moved, 1e-15, &twist.j_tt)?;
            steady.free_velocity(&slaved)
        })))
    }

    /// The largest node displacement of the mode, `max_i |q_i|` over the free nodes: a size
    /// that does not depend on the node count (unlike `<q, q>`, which grows with it for the same
    /// physical shape), so that `l1` converges with `N`.
    fn mode_size(&self, re: &[f64], im: &[f64]) -> f64 {
        re.chunks_exact(3)
            .zip(im.chunks_exact(3))
            .map(|(a, b)| a.iter().chain(b).map(|v| v * v).sum::<f64>())
            .fold(0.0, f64::max)
            .sqrt()
    }

    /// Moves the chart to `u` (directors transported onto its edges, reference twist unwrapped
    /// near the old one, so that the energy and the angles at `u` are unchanged), at every call:
    /// the angles are then coordinates centred on the last point of a branch, where they are
    /// nearly flat, and the tangent predicts well; in a chart a few steps old the transport
    /// makes them curved, and the corrector needed 4-5 Newton steps where it now needs 3. The
    /// chart never comes near its singular set, an edge pointing against its chart tangent
    /// (which stalled fig2's tight arc at 0.947 rad/s before the chart moved).
    ///
    /// The tangent in the new coordinates is the derivative of the change of coordinates along
    /// it: positions are unchanged, and the angles shift by the partial sums of the difference of
    /// the two charts' reference twists at the configuration ([`crate::analysis::dynamics::rechart`]),
    /// a smooth function of the positions, differentiated by central differences (step
    /// `1e-5` of the tangent's largest component; truncation and round-off near `1e-10` of the
    /// tangent, which only predicts).
    fn rechart(&self, u: &[f64], tangent: &[f64]) -> Option<Vec<f64>> {
        let steady = self.steady(0.0);
        let old = self.chart.borrow().clone();
        let moved = old.transported(&steady.config(u).x);
        let converted = if tangent.is_empty() {
            Vec::new()
        } else {
            let largest = tangent.iter().fold(0.0, |m: f64, v| m.max(v.abs()));
            let h = 1e-5 / largest.max(f64::MIN_POSITIVE);
            let at = |s: f64| {
                let y: Vec<f64> = u.iter().zip(tangent).map(|(a, t)| a + s * t).collect();
                steady.free_vector(&rechart(&steady.config(&y), &old, &moved))
            };
            let (plus, minus) = (at(h), at(-h));
            plus.iter()
                .zip(&minus)
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect()
        };
        *self.chart.borrow_mut() = moved;
        Some(converted)
    }
}
