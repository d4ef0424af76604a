//! Numerical continuation and bifurcation detection, generic: this module never names a rod.
//!
//! A [`Problem`] is a smooth family `G(u, p) = 0` of `n` equations in `n` unknowns `u` and one
//! parameter `p`, with the linearized dynamics `M du/dt = K du` whose eigenvalues decide the
//! stability of a solution. [`arclength::follow`] traces a branch of solutions by
//! pseudo-arclength continuation, [`stability`] computes the leading eigenvalues at each point,
//! and [`events`] detects and pins down folds, branch points and Hopf points between points;
//! [`near_miss`] searches a mode that comes near the axis and falls back between two points for a
//! window of instability inside the step.
//! [`curve`] and [`event_curve`] follow a Hopf point, a fold or a branch point in a second
//! parameter, [`periodic`] the orbits born at a Hopf point, [`criticality`] gives the first
//! Lyapunov coefficient of a Hopf point. Every driver shares the step-size control ([`step`]),
//! the reasons a run ends and the observers that watch it ([`stop`]).
//! `reference` (with the feature `reference-problems`, which the tests and benchmarks turn on)
//! holds canonical problems with exact answers (fold, pitchfork, Hopf normal form, Brusselator)
//! shared by the tests and the benchmarks.
//!
//! Three kinds of events are kept apart, each with the names it has in files: the events of a
//! branch of equilibria ([`events::EventKind`]: `fold`, `branch_point`, `hopf`,
//! `mode_exchange`), the special points of a Hopf curve ([`curve::SpecialKind`]: `double_hopf`,
//! `zero_hopf`, `turning`, `bogdanov_takens`, `generalized_hopf`) and the events of a branch of
//! periodic orbits ([`periodic::branch::OrbitEventKind`]: `fold`, `cycle_fold`,
//! `period_doubling`, `torus`). They are different objects found by different tests: an
//! eigenvalue of an equilibrium crossing the imaginary axis between two points, a point of
//! codimension two on a curve of Hopf points, a Floquet multiplier crossing the unit circle
//! (bracketed by two orbits, not located); a fold of equilibria and a fold of orbits share a name
//! but not their meaning, and no event of one kind is ever compared with one of another.

pub mod arclength;
pub mod criticality;
pub mod crossing;
pub mod curve;
pub mod event_curve;
pub mod events;
pub mod krylov;
pub mod near_miss;
pub mod newton;
pub mod periodic;
#[cfg(feature = "reference-problems")]
pub mod reference;
pub mod stability;
pub mod step;
pub mod stop;

use faer::Mat;
use serde::{Deserialize, Serialize};

use crate::Result;
use crate::error::ensure_setting;

/// `G`, `G_u = dG/du` and `G_p = dG/dp` at one point.
pub struct Linearization {
    pub g: Vec<f64>,
    pub g_u: Mat<f64>,
    pub g_p: Vec<f64>,
}

/// The velocity field of a dynamics near one of its steady states, `y -> dy/dt`: shared by the
/// threads that evaluate it ([`Problem::dynamics`]).
pub type Field<'a> = Box<dyn Fn(&[f64]) -> Result<Vec<f64>> + Sync + 'a>;

/// A one-parameter family of square nonlinear systems `G(u, p) = 0`.
pub trait Problem {
    /// Number of unknowns `n`.
    fn dim(&self) -> usize;
    /// `G(u, p)`.
    fn residual(&self, u: &[f64], p: f64) -> Result<Vec<f64>>;
    /// `G`, `G_u` and `G_p` at `(u, p)`.
    fn linearize(&self, u: &[f64], p: f64) -> Result<Linearization>;
    /// The point reached from `u` along `du`; any map equal to `u + du` to first order (see
    /// [`newton::System::retract`]).
    fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        u.iter().zip(du).map(|(a, b)| a + b).collect()
    }
    /// The point a fraction `w` of the way from `u0` to `u1` (`w` outside `[0, 1]`
    /// extrapolates), two nearby solutions: a predictor between samples of a branch. Any map
    /// equal to `u0 + w (u1 - u0)` to first order in `u1 - u0`; the default is that.
    fn interpolate(&self, u0: &[f64], u1: &[f64], w: f64) -> Vec<f64> {
        u0.iter().zip(u1).map(|(a, b)| a + w * (b - a)).collect()
    }
    /// The stability pair `(K, M)` at a solution: the linearized dynamics `M dv/dt = K v`,
    /// eigenproblem `K v = s M v`, `M` symmetric positive definite. `lin` is the linearization
    /// at `(u, p)`, which the engine always has at hand when it asks.
    fn stability_pair(
        &self,
        u: &[f64],
        p: f64,
        lin: &Linearization,
    ) -> Result<(Mat<f64>, Mat<f64>)>;
    /// Typical sizes of a change of `u` (root mean square per unknown) and of `p`: the units of
    /// the arclength.
    fn scales(&self) -> (f64, f64) {
        (1.0, 1.0)
    }
    /// For a problem whose unknowns are coordinates in a chart of a manifold (the rod's twist
    /// angles are measured from reference frames transported from a chart, singular where an
    /// edge points against its chart tangent, and curved the more the farther the state is from
    /// it): moves the chart to the accepted solution `u`, keeping `u` the same state, and
    /// returns `tangent`, a vector of `u`'s coordinates there (the branch's tangent; empty when
    /// the caller has none), in the new coordinates; `None` when the chart stays. Every later
    /// point is measured in the new chart. The default never moves.
    fn rechart(&self, _u: &[f64], _tangent: &[f64]) -> Option<Vec<f64>> {
        None
    }
    /// The nonlinear dynamics whose linearization at the solution `(u, p)` is the stability
    /// pair, as a [`Field`]: `dy/dt` at the displacement `y` from the solution, in the
    /// coordinates of `K` (`y = 0` is the solution, and the derivative there is `M^{-1} K`).
    /// It serves the criticality of Hopf points ([`criticality`]), which evaluates it at many
    /// displacements at once (on every core). The default is `None`: a problem that does not
    /// define its dynamics gets no Lyapunov coefficient.
    fn dynamics(&self, _u: &[f64], _p: f64) -> Option<Result<Field<'_>>> {
        None
    }
    /// The size of a complex mode `re + i im` (in the coordinates of `K`) that the Lyapunov
    /// coefficient is normalized to: the critical mode is scaled to size 1. The default is the
    /// Euclidean norm (`<q, q> = 1`); a discretized continuum uses a size that does not depend
    /// on its resolution.
    fn mode_size(&self, re: &[f64], im: &[f64]) -> f64 {
        re.iter().chain(im).map(|v| v * v).sum::<f64>().sqrt()
    }
}

/// Settings of the continuation, in the units of the problem's parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ContinuationSettings {
    /// Initial, smallest and largest arclength step (in the units of [`Problem::scales`]).
    pub ds: f64,
    pub ds_min: f64,
    pub ds_max: f64,
    /// Largest number of accepted points.
    pub max_points: usize,
    /// Newton iterations allowed to the corrector before the step is halved.
    pub max_corrector: usize,
    /// Residual norm at which the corrector has converged.
    pub tol: f64,
    /// Relative precision of a located event in the parameter, `|dp| <= event_tol * |p|`.
    pub event_tol: f64,
    /// Number of leading eigenvalues kept per point.
    pub eigenvalues: usize,
    /// Largest change of the parameter in one step, as a fraction of the range followed. By
    /// default ([`None`]) 1/60 where the whole branch is wanted (its figures drawn point to
    /// point) and 1/4 where the run ends at the first loss of stability (where only the event
    /// matters, and the look-ahead of the eigenvalues keeps a stable window from being stepped
    /// over): [`ContinuationSettings::parameter_step`].
    pub max_parameter_step: Option<f64>,
    /// How the leading eigenvalues are computed at each point (see [`EigenMethod`]).
    pub eigen: EigenMethod,
}

/// The eigensolver of the stability problem (`continuation.eigen`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EigenMethod {
    /// The full spectrum, dense ([`stability::spectrum`]).
    Dense,
    /// The rightmost eigenvalues by shift-invert Krylov-Schur over one LU factorization, with
    /// a certified unstable count, falling back to dense where that fails ([`krylov`]).
    Krylov,
    /// Dense below [`stability::AUTO_KRYLOV_SIZE`] unknowns, Krylov from there on.
    #[default]
    Auto,
}

impl Default for ContinuationSettings {
    fn default() -> Self {
        ContinuationSettings {
            ds: 0.5,
            ds_min: 1e-6,
            ds_max: 4.0,
            max_points: 400,
            max_corrector: 8,
            tol: 1e-9,
            event_tol: 1e-8,
            eigenvalues: 6,
            max_parameter_step: None,
            eigen: EigenMethod::Auto,
        }
    }
}

impl ContinuationSettings {
    /// Checks ranges: `0 < ds_min <= ds <= ds_max`, `max_points >= 1`, `max_corrector >= 2`,
    /// `0 < tol < 1`, `0 < event_tol < 1e-2`, `eigenvalues >= 1`, `0 < max_parameter_step <= 1`
    /// where it is set; an error names the field ([`crate::error::EngineError::Setting`]).
    pub fn validate(&self) -> Result<()> {
        ensure_setting(
            self.ds_min > 0.0
                && self.ds_min <= self.ds
                && self.ds <= self.ds_max
                && self.ds_max.is_finite(),
            "ds",
            format!(
                "need 0 < ds_min <= ds <= ds_max < inf, got ds_min = {}, ds = {}, ds_max = {}",
                self.ds_min, self.ds, self.ds_max
            ),
        )?;
        ensure_setting(
            self.max_points >= 1,
            "max_points",
            format!("must be >= 1, got {}", self.max_points),
        )?;
        ensure_setting(
            self.max_corrector >= 2,
            "max_corrector",
            format!("must be >= 2, got {}", self.max_corrector),
        )?;
        ensure_setting(
            self.tol > 0.0 && self.tol < 1.0,
            "tol",
            format!("must lie in (0, 1), got {}", self.tol),
        )?;
        ensure_setting(
            self.event_tol > 0.0 && self.event_tol < 1e-2,
            "event_tol",
            format!("must lie in (0, 0.01), got {}", self.event_tol),
        )?;
        ensure_setting(
            self.eigenvalues >= 1,
            "eigenvalues",
            format!("must be >= 1, got {}", self.eigenvalues),
        )?;
        let fraction = self.max_parameter_step.unwrap_or(1.0);
        ensure_setting(
            fraction > 0.0 && fraction <= 1.0,
            "max_parameter_step",
            format!("must lie in (0, 1], got {fraction}"),
        )
    }

    /// The largest change of the parameter in one step as a fraction of the range followed:
    /// `max_parameter_step`, or by default 1/4 for a run that ends at the first loss of
    /// stability and 1/60 for one that draws the whole branch.
    pub fn parameter_step(&self, stop_at_first_instability: bool) -> f64 {
        self.max_parameter_step
            .unwrap_or(if stop_at_first_instability {
                0.25
            } else {
                1.0 / 60.0
            })
    }
}
