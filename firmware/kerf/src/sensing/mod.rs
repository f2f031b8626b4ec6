//! Raw samples to physical quantities.

pub mod encoder;
pub mod force;
pub mod hall;
pub mod sharpness;
pub mod velocity;
