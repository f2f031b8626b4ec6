//! kerf: control firmware for precision machining robots.
//!
//! Sans-IO and allocation-free: every algorithm is a config struct validated by
//! `new()` plus a state struct stepped once per control period. Modules follow the data
//! flow of a period: [`sensing`] → [`kinematics`] → [`trajectory`] → [`control`] →
//! [`codec`], with [`hal`] the board boundary and [`app`] the periodic step and
//! supervision. Laws are generic over [`scalar::Real`] (f32, f64, fixed point).
#![no_std]
#![forbid(unsafe_code)]
// Panic-free control path: no unwrap/expect/panic and no unchecked indexing outside
// tests (fixed-size patterns, iterators and `get` instead). The link check image
// (`firmware/panic-check`, run by `scripts/panic-check`) proves the result for the
// entry points.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

#[cfg(test)]
extern crate std;

pub mod app;
pub mod codec;
pub mod control;
pub mod error;
pub mod hal;
pub mod kinematics;
pub mod machines;
pub mod scalar;
pub mod sensing;
pub mod trajectory;

pub use error::{ConfigContext, ConfigError, ConfigErrorKind};
pub use scalar::{Float, Gain, Real, Q31_32, Q6_25};
