//! Simulated hardware for kerf: the same plants run in host tests and inside the QEMU
//! image, so this crate is `no_std` (libm) and deterministic (seeded noise).
#![no_std]
#![forbid(unsafe_code)]

#[cfg(feature = "std")]
extern crate std;

pub mod arrow;
pub mod axis;
pub mod cia402;
pub mod delta;
pub mod delta_plant;
pub mod drive;
pub mod focus;
pub mod grinding;
pub mod grinding_cell;
pub mod hall_sensor;
pub mod hexapod;
pub mod linear_motor;
pub mod link;
pub mod master;
pub mod noise;
pub mod spindle;
