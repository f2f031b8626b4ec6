//! Raw samples to physical quantities.

pub mod hall;
pub mod velocity;
