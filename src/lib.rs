//! helixbif: rigidly rotating steady states of an elastic rod turned in a viscous fluid
//! (Discrete Elastic Rods + Lighthill slender-body theory), their continuation, stability and
//! bifurcations.
//!
//! Layers, bottom up: [`params`] (SI input, validated) and [`model`] (dimensionless), [`shape`]
//! (natural shapes), [`rod`] (elastic energy), [`fluid`] (Lighthill mobility), [`steady`] (the
//! co-rotating steady problem), [`continuation`] (generic Newton and continuation), [`solve`]
//! (one steady state with its observables), [`study`] (study files).

pub mod allocator;
pub mod boundary;
pub mod branch;
pub mod continuation;
pub mod dofs;
pub mod dynamics;
pub mod error;
pub mod fit;
pub mod fluid;
pub mod lu;
pub mod model;
pub mod orbits;
pub mod output;
pub mod parallel;
pub mod params;
pub mod plot;
pub mod report;
pub mod rod;
pub mod shape;
pub mod solve;
pub mod steady;
pub mod study;

pub use error::{Error, Result};
