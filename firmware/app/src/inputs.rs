//! The benchmark images' inputs of the single-axis loop, shared by the Cortex-M4 and
//! Cortex-M3 images so that both time the same periods.

use core::f32::consts::PI;
use kerf::sensing::hall::HallConfig;
use kerf::trajectory::Reference;

/// Number of distinct inputs cycled through (a power of two).
pub const INPUTS: usize = 64;

/// Hall samples over one pitch: an axis moving 1/64 pitch per period.
pub fn hall_inputs() -> [[u16; 3]; INPUTS] {
    core::array::from_fn(|k| counts_at_phase(2.0 * PI * k as f32 / INPUTS as f32))
}

/// Counts of the nominal 16-bit sensor at electrical phase `phi` (rad).
pub fn counts_at_phase(phi: f32) -> [u16; 3] {
    let cfg = HallConfig::LM1247_16BIT;
    let mut counts = [0u16; 3];
    for (ch, shift) in [0.0, 2.0 * PI / 3.0, -2.0 * PI / 3.0]
        .into_iter()
        .enumerate()
    {
        counts[ch] = (cfg.calibration.offset_counts[ch]
            + cfg.amplitude_counts as f32 * libm::sinf(phi + shift)) as u16;
    }
    counts
}

/// References along a slow ramp, one per input.
pub fn references() -> [Reference<f32>; INPUTS] {
    core::array::from_fn(|k| Reference {
        position: 0.004 + 1e-5 * k as f32,
        velocity: 0.1,
        acceleration: 0.5,
    })
}
