//! helixbif: rigidly rotating steady states of an elastic rod turned in a viscous fluid
//! (Discrete Elastic Rods + Lighthill slender-body theory), their continuation, stability and
//! bifurcations.
//!
//! Layers, bottom up: [`params`] (SI input, validated) and [`model`] (dimensionless), [`shape`]
//! (natural shapes), [`rod`] (elastic energy), [`fluid`] (Lighthill mobility), [`steady`] (the
//! co-rotating steady problem), [`continuation`] (generic Newton and continuation), [`solve`]
//! (one steady state with its observables), [`study`] (study files).

pub mod analysis;
pub mod engine;
pub mod error;
pub mod model;
pub mod numerics;
pub mod plot;
pub mod problem;
#[cfg(feature = "python")]
pub mod python;
pub mod study;

pub use error::{Error, Result};
