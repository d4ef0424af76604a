//! Step-size control, one for every driver of the engine (the arclength run, the Hopf and event
//! curves, the orbit branch): the step grows after an easy step, shrinks after a hard one, is
//! halved after a failure, and stays within `[ds_min, ds_max]`; a failure that would take it
//! below `ds_min` is reported ([`TooSmall`]), and the run ends there.
//!
//! The rules are the same everywhere (factors 1.5, 0.7 and 0.5; an easy step takes at most 3
//! iterations, a hard one at least 6); what differs is what a driver knows of a step's effort:
//! the arclength corrector and the Hopf curve count iterations ([`StepControl::adapt`]), the
//! orbit branch grows after an easy shooting but never shrinks after a hard one
//! ([`StepControl::never_shrinking`]), and an event curve, whose points are whole runs, grows
//! after every success ([`StepControl::grow`]).

/// Factor of the step after an easy step.
const GROW: f64 = 1.5;
/// Factor of the step after a hard step.
const SHRINK: f64 = 0.7;
/// Factor of the step after a failure.
const HALVE: f64 = 0.5;
/// A step of at most this many iterations is easy.
const EASY: usize = 3;
/// A step of at least this many iterations is hard.
const HARD: usize = 6;

/// The step of a run and its bounds.
#[derive(Clone, Debug, PartialEq)]
pub struct StepControl {
    ds: f64,
    ds_min: f64,
    ds_max: f64,
    /// Whether a hard step shrinks the next one.
    shrinks: bool,
}

/// A failure halved the step below `ds_min`: the run cannot go on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TooSmall;

impl StepControl {
    /// A step starting at `ds`, kept within `[ds_min, ds_max]` by the rules above.
    pub fn new(ds: f64, ds_min: f64, ds_max: f64) -> Self {
        StepControl {
            ds,
            ds_min,
            ds_max,
            shrinks: true,
        }
    }

    /// The same control, except that a hard step leaves the step as it is.
    pub fn never_shrinking(self) -> Self {
        StepControl {
            shrinks: false,
            ..self
        }
    }

    /// The current step.
    pub fn ds(&self) -> f64 {
        self.ds
    }

    /// After a step accepted with `iterations` corrector iterations: 1.5 times longer (at most
    /// `ds_max`) after an easy one, 0.7 times shorter (at least `ds_min`) after a hard one.
    pub fn adapt(&mut self, iterations: usize) {
        if iterations <= EASY {
            self.grow();
        } else if iterations >= HARD && self.shrinks {
            self.ds = (self.ds * SHRINK).max(self.ds_min);
        }
    }

    /// 1.5 times longer, at most `ds_max`: after a success whose effort is not counted.
    pub fn grow(&mut self) {
        self.ds = (self.ds * GROW).min(self.ds_max);
    }

    /// After a failure: the step halved, or [`TooSmall`] when that is below `ds_min`.
    pub fn failed(&mut self) -> Result<(), TooSmall> {
        self.ds *= HALVE;
        if self.ds < self.ds_min {
            Err(TooSmall)
        } else {
            Ok(())
        }
    }

    /// Halves the step if that keeps it at least `ds_min` (a step shortened by choice, not after a
    /// failure); `false`, the step unchanged, otherwise.
    pub fn shorten(&mut self) -> bool {
        let shorter = self.ds * HALVE;
        if shorter >= self.ds_min {
            self.ds = shorter;
            true
        } else {
            false
        }
    }

    /// The step at most `at_most`, at least `ds_min`.
    pub fn limit(&mut self, at_most: f64) {
        self.ds = self.ds.min(at_most).max(self.ds_min);
    }

    /// The step `ds`, at least `ds_min`.
    pub fn set(&mut self, ds: f64) {
        self.ds = ds.max(self.ds_min);
    }
}
