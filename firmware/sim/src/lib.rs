//! Scenarios: a kerf machine app put together with simulated hardware from `hal-mock`.
//! The host tests and the QEMU image both run them from here, so both check the same
//! thing against the same bounds; `hal-mock` itself holds hardware only.
#![no_std]
#![forbid(unsafe_code)]

#[cfg(feature = "std")]
extern crate std;

pub mod arrow;
pub mod arrow_drives;
pub mod contour;
pub mod linked;
pub mod linked_arrow;
pub mod linked_autofocus;
pub mod linked_axis;
pub mod linked_grinding;
pub mod linked_master;
pub mod linked_remote_slave;
pub mod operator;
pub mod remote;
pub mod scenario;
pub mod slave;
#[cfg(feature = "std")]
pub mod trace;
