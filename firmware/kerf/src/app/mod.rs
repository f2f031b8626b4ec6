//! Modes, supervision and the periodic step that ties sensing, control and the HAL.

pub mod axis;
pub mod calibrate;
