//! What the application needs from a board: sample inputs, write outputs, the period.
//!
//! Implemented per board (and by `hal-mock` for simulated machines). Only `app` and
//! the binaries use these traits; every algorithm stays sans-IO.

/// Three analog Hall channels per axis, raw ADC counts (offset-binary).
pub trait HallInput {
    /// Latest simultaneous sample of axis `axis`: `[u1, u2, u3]`.
    fn hall_counts(&mut self, axis: usize) -> [u16; 3];
}

/// Per-axis force (current) command.
pub trait ForceOutput {
    /// Commands `force_n` newtons on axis `axis` (the driver converts with its force
    /// constant). Must accept 0.0 at any time: that is the safe state.
    fn set_force(&mut self, axis: usize, force_n: f32);
}

/// The fixed control period.
pub trait ControlClock {
    /// Period of the control interrupt in seconds.
    fn period_s(&self) -> f32;
}
