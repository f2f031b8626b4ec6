//! What to command: control laws, each a config (immutable) plus state.
//!
//! Signal ranges of the single-axis DOB+PD loop, with the [`Q31_32`](crate::scalar::Q31_32)
//! (Q31.32, ±2.1e9, resolution 2.3e-10) headroom they leave:
//!
//! | signal | unit | range used | headroom in Q31.32 |
//! |---|---|---|---|
//! | position, reference | m | ±0.1 | 2e10 |
//! | velocity | m/s | ±2 | 1e9 |
//! | acceleration command | m/s² | ±1e3 | 2e6 |
//! | force, disturbance estimate | N | ±1e2 | 2e7 |
//! | gains kp, kd, g·An | s⁻², s⁻¹, N·s/m | ≤ 1e5 | 2e4 |
//!
//! The scenario tests record every signal's peak and check these ranges.

pub mod adrc;
pub mod autofocus;
pub mod bilateral;
pub mod constraint;
pub mod contouring;
pub mod delay_observer;
pub mod dob;
pub mod hybrid_force;
pub mod identify;
pub mod laser;
pub mod pd;
pub mod pid;
pub mod preview;
pub mod redundant_pid;
