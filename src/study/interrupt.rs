//! A front end's way to end a long run early: one check per process ([`set_check`]), asked by
//! the study layer's observers between steps (the points of a continuation, the points of a
//! boundary, the orbits of an orbit branch, the time steps of a simulation). The Python module
//! installs one that runs Python's signal handlers, so that Ctrl-C (`KeyboardInterrupt`) ends a
//! run between two steps; the command line installs none (the default signal handler ends the
//! process).
//!
//! A run that its check ends stops as its observer's `ControlFlow::Break` or error makes it
//! stop (what was written so far stays on disk); the front end that asked says what that means.

use std::ops::ControlFlow;
use std::sync::OnceLock;

use crate::{Error, Result};

static CHECK: OnceLock<fn() -> bool> = OnceLock::new();

/// Installs `check`, asked between the steps of every run of the study layer: `true` ends the
/// run. The first check installed stays; returns whether this one was installed.
pub fn set_check(check: fn() -> bool) -> bool {
    CHECK.set(check).is_ok()
}

/// Whether the installed check asks to end the run (never without one).
pub fn requested() -> bool {
    CHECK.get().is_some_and(|check| check())
}

/// `Break` when the installed check asks to end the run: what an observer returns.
pub(crate) fn flow() -> ControlFlow<()> {
    if requested() {
        ControlFlow::Break(())
    } else {
        ControlFlow::Continue(())
    }
}

/// An error when the installed check asks to end the run: for observers that end a run by an
/// error.
pub(crate) fn check() -> Result<()> {
    if requested() {
        Err(Error::Numerical("interrupted".into()))
    } else {
        Ok(())
    }
}
