//! Analyses of the rod: steady states, the first loss of stability and its refinement in `N`,
//! stability boundaries, periodic orbits and the dynamics. Each takes its inputs typed and returns
//! typed results; none prints or writes files.

pub mod boundary;
pub mod branch;
pub mod dynamics;
pub mod locate;
pub mod near_miss;
pub mod orbits;
pub mod refine;
pub mod solve;
