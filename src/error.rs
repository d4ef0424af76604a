//! Error values of the library.
//!
//! Bad input (exit code 2 at the command line) is kept apart from numerical failure (exit code 1):
//! [`Error::is_input`] tells which is which.

use thiserror::Error;

/// Everything that can go wrong in `helixbif`.
#[derive(Debug, Error)]
pub enum Error {
    /// A user-supplied value is out of its allowed range, or a study file cannot be read.
    #[error("invalid input: {field}: {message}")]
    Input { field: String, message: String },

    /// The mobility matrix is not symmetric positive definite (Cholesky failed): `context` says
    /// where (which state), `geometry` why (the smallest node spacing and the closest approach
    /// of two parts of the rod, against the cut-off).
    #[error("mobility matrix not positive definite ({context}): {geometry}")]
    NotPositiveDefinite { context: String, geometry: String },

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

    /// A numerical failure that is not a Newton stall (singular matrix, NaN, ...).
    #[error("numerical failure: {0}")]
    Numerical(String),

    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
}

impl Error {
    /// Shorthand for an input error naming the offending field.
    pub fn input(field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Input {
            field: field.into(),
            message: message.into(),
        }
    }

    /// True for errors caused by bad user input (exit code 2), false for numerical or I/O
    /// failures (exit code 1).
    pub fn is_input(&self) -> bool {
        matches!(self, Error::Input { .. })
    }
}

/// `Ok` when `condition` holds, else an input error naming `field` with `message`.
pub fn ensure(condition: bool, field: &str, message: String) -> Result<()> {
    if condition {
        Ok(())
    } else {
        Err(Error::input(field, message))
    }
}

/// Result alias used throughout the library.
pub type Result<T> = std::result::Result<T, Error>;
