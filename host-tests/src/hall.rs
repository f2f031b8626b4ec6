//! Hall sensing helpers shared by the Hall test files.

use hal_mock::hall_sensor::HallSensor;
use kerf::sensing::hall::{HallCalibrator, HallConfig, SelfCalibration};

/// Magnetic pitch of the LM1247 presets, m.
pub const PITCH_M: f64 = 0.018;

/// Calibration as the module docs ask: two coasts (out and back) of 1.5 pitches, 256
/// samples each at a fixed rate, with the speed changing smoothly along each (a coast
/// under constant force and viscous friction: x(t) = v∞ t + (v0 − v∞) T (1 − e^(−t/T))).
pub fn calibrate(config: &HallConfig, sensor: &mut HallSensor) -> SelfCalibration {
    let mut calibrator = HallCalibrator::<512>::new();
    for (start, direction) in [(0.0, 1.0), (1.5 * PITCH_M, -1.0)] {
        calibrator.new_segment().expect("two segments fit");
        // 0.25 s coast, v from 0.12 to about 0.1 m/s (T = 0.24 s): 1.5 pitches.
        let (v0, v_end, tau) = (0.12, 0.1, 0.24);
        let x = |t: f64| v_end * t + (v0 - v_end) * tau * (1.0 - (-t / tau).exp());
        let scale = 1.5 * PITCH_M / x(0.25);
        for k in 0..256 {
            let t = 0.25 * k as f64 / 255.0;
            calibrator
                .push(sensor.sample(start + direction * scale * x(t)))
                .expect("512 samples fit");
        }
    }
    calibrator
        .solve(&config.calibration)
        .expect("the sensors calibrate")
}
