//! Generic numerics, free of the rod: dense LU with explicit parallelism, two-thread joins,
//! power-law fits and extrapolation, and the process-wide settings of the allocator and of faer.

pub mod fit;
pub mod lu;
pub mod parallel;
pub mod process;
pub mod statistics;
