//! The rod as the engine's problems: the steady problem as a Newton system, the continuation
//! problem in one parameter ([`rod::RodProblem`]) and in two ([`family::RodFamily`]), the implicit
//! time step, the twist slaved to the positions, and the rod's dynamics for periodic orbits.

pub mod carry;
pub mod family;
pub mod orbit;
pub mod rod;
pub mod steady;
pub mod step;
pub mod twist;
