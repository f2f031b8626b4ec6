//! Hall sensing helpers shared by the Hall test files.

use hal_mock::hall_sensor::{calibration_coast_m, HallSensor, HallSensorParams, COAST_PITCHES};
use kerf::sensing::hall::{HallCalibrator, HallConfig, SelfCalibration};

/// Magnetic pitch of the LM1247 presets, m.
pub const PITCH_M: f64 = 0.018;

/// Drawn sensor sets (`HallSensorParams::lm1247_drawn`) the Hall tests run beside the
/// model's worst preset.
pub const DRAWS: u64 = 12;

/// The noise at the model's limit for an ADC of `bits`, LSB RMS: 4 LSB at 16 bits
/// (the 16-bit goal), 1 LSB at 12 bits.
pub fn noise_limit_lsb(bits: u8) -> f64 {
    if bits >= 16 {
        4.0
    } else {
        1.0
    }
}

/// The sensor sets a Hall test covers at `bits`, noise at the model's limit: the worst
/// preset (`lm1247_worst`, harmonic phases within ±10° of the mounting) and [`DRAWS`]
/// drawn sets (harmonics of any amplitude up to their bounds and of any phase per
/// channel), each with its name.
pub fn sensor_sets(bits: u8) -> Vec<(String, HallSensorParams)> {
    let noise = noise_limit_lsb(bits);
    std::iter::once((
        "worst preset".to_string(),
        HallSensorParams::lm1247_worst(bits, noise),
    ))
    .chain((0..DRAWS).map(|seed| {
        (
            format!("draw {seed}"),
            HallSensorParams::lm1247_drawn(bits, noise, seed),
        )
    }))
    .collect()
}

/// Calibration as the module docs ask: two coasts (out and back) of 1.5 pitches, 256
/// samples each at a fixed rate, with the speed changing smoothly along each
/// ([`calibration_coast_m`]).
pub fn calibrate(config: &HallConfig, sensor: &mut HallSensor) -> SelfCalibration {
    let mut calibrator = HallCalibrator::<512>::new();
    for (start, direction) in [(0.0, 1.0), (COAST_PITCHES * PITCH_M, -1.0)] {
        calibrator.new_segment().expect("two segments fit");
        for x in calibration_coast_m(start, direction, PITCH_M, 256) {
            calibrator.push(sensor.sample(x)).expect("512 samples fit");
        }
    }
    calibrator
        .solve(&config.calibration)
        .expect("the sensors calibrate")
}
