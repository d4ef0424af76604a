//! Generic numerics, free of the rod: dense LU with explicit parallelism, two-thread joins,
//! power-law fits and extrapolation, and the allocator's settings.

pub mod allocator;
pub mod fit;
pub mod lu;
pub mod parallel;
