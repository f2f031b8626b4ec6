//! Hall sensing helpers shared by the Hall test files.

use hal_mock::hall_sensor::{calibration_coast_m, HallSensor, COAST_PITCHES};
use kerf::sensing::hall::{HallCalibrator, HallConfig, SelfCalibration};

/// Magnetic pitch of the LM1247 presets, m.
pub const PITCH_M: f64 = 0.018;

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
