//! Joint space ↔ task space.
//!
//! Kinematics work on small fixed-size vectors and matrices, so this module uses
//! nalgebra's [`Vector3`] / [`Matrix3`] (re-exported so callers need no direct
//! dependency) and is generic over nalgebra's `RealField` (`f32` on the MCU, `f64` as
//! the host reference).

pub mod arrow;
pub mod contour_frame;
pub mod delta;
pub mod tool;

pub use nalgebra::{Matrix3, Vector3};
