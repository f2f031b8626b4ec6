//! Raw samples to physical quantities.

#[allow(clippy::indexing_slicing)] // being restructured (issue 10 item 10)
pub mod hall;
pub mod velocity;
