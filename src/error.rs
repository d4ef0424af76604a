//! Error values of the library, layered as the library is: the engine's failures
//! ([`EngineError`]) and the physical model's ([`ModelError`]) are variants of their own, wrapped
//! into the crate's [`Error`], so that a caller can tell what failed by its type, never by its
//! message.
//!
//! Bad input (exit code 2 at the command line) is kept apart from numerical failure (exit code 1):
//! [`Error::is_input`] tells which is which. The engine names its own settings
//! ([`EngineError::Setting`]); a front end that took them from a study table or from options
//! renames them with [`Error::naming_setting`].

use faer::c64;
use thiserror::Error;

/// Everything that can go wrong in `helixbif`.
#[derive(Debug, Error)]
pub enum Error {
    /// A user-supplied value is out of its allowed range, or a study file cannot be read.
    #[error("invalid input: {field}: {message}")]
    Input { field: String, message: String },

    /// A failure of the generic engine (Newton, continuation, spectra, curves, orbits).
    #[error(transparent)]
    Engine(#[from] EngineError),

    /// A failure of the physical model (the fluid's operator).
    #[error(transparent)]
    Model(#[from] ModelError),

    /// A numerical failure of an analysis (what it was doing, where and why).
    #[error("numerical failure: {0}")]
    Numerical(String),

    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },

    /// A bug: the code panicked (the message of the panic; where it happened is on stderr,
    /// printed by the panic hook). Caught by [`caught`] so that one point of a sweep, or one
    /// curve of a study, does not end the others, and the command line still ends with one
    /// line and exit code 1.
    #[error(
        "internal error (a bug in helixbif; please report it with the command line and the \
         panic message above): {0}"
    )]
    Internal(String),
}

/// A failure of the generic engine.
#[derive(Debug, Error)]
pub enum EngineError {
    /// Newton's method did not converge.
    #[error(
        "Newton failed {context}: {reason} after {iterations} iterations (residual {residual:.3e})"
    )]
    NewtonFailed {
        context: String,
        reason: String,
        iterations: usize,
        residual: f64,
    },

    /// One of the engine's own settings is out of range; `setting` is the engine's name for it
    /// (the front ends say where it comes from: a study key, an option).
    #[error("invalid input: {setting}: {message}")]
    Setting { setting: String, message: String },

    /// A two-parameter family has no member at the value of its second parameter asked for
    /// (why, in the member's words): a curve that meets this comes as near that end of the
    /// family as its smallest step allows and stops there. A numerical failure, so worded.
    #[error("numerical failure: no member of the family there: {0}")]
    NoMember(Box<Error>),

    /// The complex pair a Hopf curve tracks has met on the real axis: the curve ends at a
    /// Bogdanov-Takens point near there. A numerical failure, so worded.
    #[error(
        "numerical failure: the tracked pair has become real: {track} (a Bogdanov-Takens point \
         is near)"
    )]
    PairBecameReal { track: c64 },
}

/// A failure of the physical model.
#[derive(Debug, Error)]
pub enum ModelError {
    /// The mobility matrix is not symmetric positive definite (Cholesky failed): `context` says
    /// where (which state), `geometry` why (the smallest node spacing and the closest approach
    /// of two parts of the rod, against the cut-off).
    #[error("mobility matrix not positive definite ({context}): {geometry}")]
    NotPositiveDefinite { context: String, geometry: String },
}

impl Error {
    /// Shorthand for an input error naming the offending field.
    pub fn input(field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Input {
            field: field.into(),
            message: message.into(),
        }
    }

    /// An engine setting out of range ([`EngineError::Setting`]), named as the engine names it.
    pub fn setting(setting: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Engine(EngineError::Setting {
            setting: setting.into(),
            message: message.into(),
        })
    }

    /// True where the problem refused the state it was asked about: it has no admissible state
    /// there (the rod's mobility is not positive definite, parts of it too close). The engine
    /// takes this for where the problem ends, not for a numerical difficulty: Newton's line
    /// search gives it as its reason when every trial point met it, and a continuation that
    /// runs out of step names it as the reason it stopped.
    pub fn is_refused_state(&self) -> bool {
        matches!(self, Error::Model(ModelError::NotPositiveDefinite { .. }))
    }

    /// True for errors caused by bad user input (exit code 2), false for numerical or I/O
    /// failures (exit code 1).
    pub fn is_input(&self) -> bool {
        matches!(
            self,
            Error::Input { .. } | Error::Engine(EngineError::Setting { .. })
        )
    }

    /// An input error about an engine setting, its name given by `name(setting)` (the study key
    /// or the command-line option it came from); any other error unchanged.
    pub fn naming_setting(self, name: impl FnOnce(&str) -> String) -> Self {
        match self {
            Error::Engine(EngineError::Setting { setting, message }) => Error::Input {
                field: name(&setting),
                message,
            },
            other => other,
        }
    }
}

/// `work()`, with a panic inside it (a bug) turned into [`Error::Internal`] with the panic's
/// message. Everything `work` wrote to disk before it panicked stays there.
pub fn caught<T>(work: impl FnOnce() -> Result<T>) -> Result<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(work)).unwrap_or_else(|payload| {
        let message = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic without a message".into());
        Err(Error::Internal(message))
    })
}

/// `Ok` when `condition` holds, else an input error naming `field` with `message`.
pub(crate) fn ensure(condition: bool, field: &str, message: String) -> Result<()> {
    if condition {
        Ok(())
    } else {
        Err(Error::input(field, message))
    }
}

/// `Ok` when `condition` holds, else an engine setting error naming `setting` with `message`.
pub fn ensure_setting(condition: bool, setting: &str, message: String) -> Result<()> {
    if condition {
        Ok(())
    } else {
        Err(Error::setting(setting, message))
    }
}

/// Result alias used throughout the library.
pub type Result<T> = std::result::Result<T, Error>;

#[cfg(test)]
mod tests {
    use super::*;

    /// A panic inside `caught` comes back as an internal error with the panic's message (a
    /// literal or a formatted one), not an input error (exit code 1, not 2); a result without
    /// a panic passes through unchanged.
    #[test]
    fn a_panic_becomes_an_internal_error() {
        let literal = caught(|| -> Result<()> { panic!("the len is 121") }).unwrap_err();
        assert!(matches!(&literal, Error::Internal(m) if m == "the len is 121"));
        assert!(!literal.is_input());
        let index = 121;
        let formatted =
            caught(|| -> Result<()> { panic!("but the index is {index}") }).unwrap_err();
        assert_eq!(
            formatted.to_string(),
            "internal error (a bug in helixbif; please report it with the command line and the \
             panic message above): but the index is 121"
        );
        assert_eq!(caught(|| Ok(7)).unwrap(), 7);
        let refused = caught(|| -> Result<()> { Err(Error::input("shape.l", "must be > 0")) });
        assert!(refused.unwrap_err().is_input());
    }
}
