//! Generic numerics, free of the rod: dense LU with explicit parallelism, two-thread joins,
//! scaling-law fits, the extrapolation in the node count, statistics of sampled signals, and the
//! process-wide settings (allocator, faer's default parallelism, the memory available).

pub mod extrapolation;
pub mod fit;
pub mod lu;
pub mod parallel;
pub mod process;
pub mod statistics;
