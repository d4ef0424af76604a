//! How a run of the engine ends, and who watches it go.
//!
//! [`Stop`] says why a run ended, for the arclength run ([`super::arclength`]) and the curves of
//! two-parameter continuation ([`super::curve`], [`super::event_curve`]). The reasons that mean
//! the same for all of them are its variants: the parameter followed reached the end of its range,
//! the largest number of points was reached, the step ran out, the observer ended the run. A
//! driver's own reasons are a type of its own, [`Stop::Own`], so that a caller matches exactly the
//! reasons its driver can give: [`super::arclength::BranchStop`] (the first loss of stability,
//! the stop rules), [`super::curve::CurveEnd`] (a family without a member ahead, a Hopf curve that
//! ends); an event curve has none.
//!
//! An [`Observer`] sees the points and events of a run as they come and may end it
//! (`ControlFlow::Break`, the run's stop then [`Stop::Observer`]), in the manner of argmin's
//! observers and BifurcationKit's callbacks: `Observer<Point, Event>` for the arclength run,
//! `Observer<CurvePoint, Special>` for a Hopf curve (whose events are its special points).
//! [`Silent`] sees nothing and never ends a run.
//!
//! The orbit branch ([`super::periodic::branch`]) keeps its own reasons, `OrbitStop`: they are
//! the same ideas, but `OrbitStop` is the `stop` of the `orbits` report, whose names
//! (`max_orbits`, ...) are part of that report, and its `MaxOrbits` counts the orbits of the whole
//! branch, those of the runs before a resumed checkpoint included, where [`Stop::MaxPoints`]
//! counts the points of one run. Its observer follows the same pattern (`ControlFlow::Break`
//! ends the run, [`Stop::Observer`]'s counterpart) as a closure of the orbit's index, the orbit
//! and the checkpoint after it, which borrow from the run's state.

use std::convert::Infallible;
use std::ops::ControlFlow;

/// Why a run ended: the reasons every driver shares, and `Own`, those of the driver's own.
#[derive(Clone, Debug, PartialEq)]
pub enum Stop<Own = Infallible> {
    /// The parameter followed reached the end of its range: an arclength run's point left
    /// `[p_min, p_max]` (the point is kept), a curve's last point lies on the end of its range of
    /// `q`.
    ParameterLimit,
    /// The largest number of points was reached.
    MaxPoints,
    /// The step fell below its smallest value; the reason of the last failure (in an arclength
    /// run, a state the problem refused when any attempt met one:
    /// [`crate::Error::is_refused_state`]).
    StepTooSmall(String),
    /// The [`Observer`] ended the run (on a curve at a special point, its last point).
    Observer,
    /// A reason of the driver's own.
    Own(Own),
}

/// Sees the points `P` and events `E` of a run as they are found (writers, progress bars,
/// searches), and may end the run with [`Stop::Observer`]: `ControlFlow::Break` ends it after
/// the point, or after the event (a branch at the point that closes the event's step, unless a
/// stop rule ends it there too, whose reason is kept; a Hopf curve at the special point, its last
/// point).
pub trait Observer<P, E> {
    /// An accepted point.
    fn point(&mut self, _point: &P) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }
    /// An event, told before the point that ends its step.
    fn event(&mut self, _event: &E) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }
}

/// An observer that ignores everything.
pub struct Silent;
impl<P, E> Observer<P, E> for Silent {}
