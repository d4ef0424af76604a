//! Generic numerical continuation machinery; it never names a rod.

pub mod newton;
