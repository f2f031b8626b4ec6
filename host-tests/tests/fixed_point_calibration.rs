//! Self-calibration of the single axis in the fixed-point scalars, Q6.25 included:
//! the sweep's time k·Ts is formed from its period count without passing k through
//! the signal range (1500 periods pass Q6.25's ±64: the reference froze at rest and
//! the loop saturated the force), and the settle's force sum, far past ±64, is kept
//! in 64-bit integers. A Q6.25 machine calibrates on the imperfect sensors and tracks
//! the profile within the same bounds as the `f32` one.

use hal_mock::hall_sensor::HallSensorParams;
use kerf::sensing::hall::SelfCalibration;
use kerf::{Real, Q31_32, Q6_25};
use kerf_sim::scenario::{
    run_with, Outcome, Scenario, ScenarioError, MAX_ERROR_BOUND_M, RMS_ERROR_BOUND_M,
};

/// The imperfect sensors of the firmware's own calibration test (offsets ±3 % FS,
/// gains ±5 %, mounting errors to 1.5°, 2 % third harmonic, 4 LSB noise), calibrated
/// by the machine, then the 1 s tracking profile.
fn calibrated<T: Real>() -> Result<(Outcome, SelfCalibration), ScenarioError> {
    let mut s = Scenario::TRACKING;
    s.sensor = HallSensorParams::lm1247_imperfect(16, 4.0);
    s.calibrate = true;
    let (outcome, fit) = run_with::<T>(
        &s,
        Outcome::with_window(f64::INFINITY, f64::INFINITY),
        |_| {},
    )?;
    Ok((
        outcome,
        fit.unwrap_or_else(|| panic!("{}: no fit: {outcome:?}", core::any::type_name::<T>())),
    ))
}

#[test]
fn a_fixed_point_machine_calibrates_and_tracks() {
    let (reference, reference_fit) = calibrated::<f32>().unwrap();
    for (name, result) in [
        ("Q31_32", calibrated::<Q31_32>()),
        ("Q6_25", calibrated::<Q6_25>()),
    ] {
        let (tracked, fit) = result.unwrap_or_else(|e| panic!("{name}: {e:?}"));
        println!(
            "{name:>6}: rms {:.3} um max {:.3} um; fit residual rms {:.2} counts (f32 {:.2})",
            tracked.rms_error_m * 1e6,
            tracked.max_error_m * 1e6,
            fit.residual_rms_counts,
            reference_fit.residual_rms_counts,
        );
        assert!(tracked.fault_period.is_none(), "{name}: {tracked:?}");
        assert!(
            tracked.rms_error_m < RMS_ERROR_BOUND_M,
            "{name}: {tracked:?}"
        );
        assert!(
            tracked.max_error_m < MAX_ERROR_BOUND_M,
            "{name}: {tracked:?}"
        );
    }
    assert!(reference.fault_period.is_none());
}
