//! Hall sensing against the simulated imperfect LM1247 sensors: error over a pitch
//! before and after calibration, with the learnt correction table, at 16 and 12 bits;
//! and the velocity estimate against a finite difference.

use hal_mock::hall_sensor::{HallSensor, HallSensorParams};
use kerf::sensing::hall::{
    CorrectionLearner, HallCalibrator, HallConfig, HallCorrection, HallDecoder, HallState,
    SelfCalibration,
};
use kerf::sensing::velocity::{TrackingObserver, TrackingObserverConfig, TrackingObserverState};

const PITCH_M: f64 = 0.018;

/// Peak and RMS of (decoded − true) over positions spread across two pitches, after
/// removing the mean (a constant offset is homing, not error). Positions are
/// decoded without unwrapping history, so only the phase within the pitch matters.
fn error_over_pitch(
    config: &HallConfig,
    correction: Option<HallCorrection>,
    sensor: &mut HallSensor,
) -> (f64, f64) {
    let mut decoder = HallDecoder::new(config).unwrap();
    decoder.set_correction(correction);
    let n = 20_000;
    let mut errors = Vec::with_capacity(n);
    for k in 0..n {
        let x = 2.0 * PITCH_M * (k as f64 + 0.5) / n as f64;
        let phase = decoder.raw_phase(sensor.sample(x)).expect("healthy sensor");
        let phase = correction.map_or(phase, |c| c.apply(phase));
        let decoded_turns = f64::from(phase) / 4_294_967_296.0;
        let mut e = decoded_turns - x / PITCH_M;
        e -= e.round();
        errors.push(e * PITCH_M);
    }
    // Errors are small against the pitch, so the wrapped values have a common offset.
    let mean = errors.iter().sum::<f64>() / n as f64;
    let peak = errors.iter().map(|e| (e - mean).abs()).fold(0.0, f64::max);
    let rms = (errors.iter().map(|e| (e - mean) * (e - mean)).sum::<f64>() / n as f64).sqrt();
    (peak, rms)
}

/// Calibration move: 1.5 pitches, 512 samples.
fn calibrate(config: &HallConfig, sensor: &mut HallSensor) -> SelfCalibration {
    let mut calibrator = HallCalibrator::<512>::new();
    for k in 0..512 {
        calibrator
            .push(sensor.sample(1.5 * PITCH_M * k as f64 / 512.0))
            .unwrap();
    }
    calibrator.solve(&config.calibration).unwrap()
}

/// Correction learnt against the master's 0.5 µm encoder over 10 pitches of slow
/// motion (100 samples per table entry average the noise down by 10).
fn learn_correction(config: &HallConfig, sensor: &mut HallSensor) -> HallCorrection {
    let decoder = HallDecoder::new(config).unwrap();
    let mut learner = CorrectionLearner::default();
    let n = 256_000;
    for k in 0..n {
        let x = 10.0 * PITCH_M * k as f64 / n as f64;
        let encoder_m = (x / 0.5e-6).round() * 0.5e-6;
        let reference_phase =
            ((encoder_m / PITCH_M).rem_euclid(1.0) * 4_294_967_296.0) as u64 as u32;
        if let Some(phase) = decoder.raw_phase(sensor.sample(x)) {
            learner.add(phase, reference_phase);
        }
    }
    learner.finish().unwrap()
}

#[test]
fn calibration_report_at_16_and_12_bits() {
    println!("| ADC | noise | stage | peak µm (noisy) | RMS µm (noisy) | peak µm (noise-free) | RMS µm (noise-free) |");
    println!("|---|---|---|---|---|---|---|");
    for (bits, noise_lsb) in [(16u8, 4.0), (12, 1.0)] {
        let params = HallSensorParams::lm1247_imperfect(bits, noise_lsb);
        let mut quiet = params;
        quiet.noise_lsb = 0.0;
        let mut sensor = HallSensor::new(params, 11);
        let mut quiet_sensor = HallSensor::new(quiet, 11);
        let nominal = HallConfig::lm1247(bits);
        let fit = calibrate(&nominal, &mut sensor);
        let mut calibrated = nominal;
        calibrated.calibration = fit.calibration;
        let learnt = learn_correction(&calibrated, &mut sensor);
        let mut rows = Vec::new();
        for (stage, config, table) in [
            ("nominal", nominal, None),
            ("self-calibrated, linear only", calibrated, None),
            (
                "self-calibrated with model table",
                calibrated,
                Some(fit.correction),
            ),
            (
                "table learnt against 0.5 um encoder",
                calibrated,
                Some(learnt),
            ),
        ] {
            let noisy = error_over_pitch(&config, table, &mut sensor);
            let clean = error_over_pitch(&config, table, &mut quiet_sensor);
            println!(
                "| {bits} bit | {noise_lsb} LSB | {stage} | {:.2} | {:.2} | {:.2} | {:.2} |",
                noisy.0 * 1e6,
                noisy.1 * 1e6,
                clean.0 * 1e6,
                clean.1 * 1e6
            );
            rows.push((noisy, clean));
        }
        let (nominal_err, calibrated_err, corrected_err) = (rows[0], rows[2], rows[3]);
        assert!(
            calibrated_err.0 .0 < nominal_err.0 .0 / 5.0,
            "calibration must help a lot"
        );
        if bits == 16 {
            // Goals of the 16-bit, 4 LSB case.
            assert!(calibrated_err.0 .0 <= 10e-6, "{calibrated_err:?}");
            assert!(calibrated_err.0 .1 <= 3e-6, "{calibrated_err:?}");
            // The systematic error left by the correction table (noise-free sensor).
            assert!(corrected_err.1 .0 <= 1e-6, "{corrected_err:?}");
        }
    }
}

/// The tracking observer (2π·600 rad/s, as in the axis loop) against the finite
/// difference of the same decoded positions at constant speed, 10 kHz, 16 bit, 4 LSB.
#[test]
fn velocity_estimate_noise_against_finite_difference() {
    let params = HallSensorParams::lm1247_imperfect(16, 4.0);
    let mut sensor = HallSensor::new(params, 5);
    let mut config = HallConfig::LM1247_16BIT;
    let fit = calibrate(&config, &mut sensor);
    config.calibration = fit.calibration;
    let (mut decoder, mut decoder_state) =
        (HallDecoder::new(&config).unwrap(), HallState::default());
    decoder.set_correction(Some(fit.correction));
    let ts = 1e-4;
    let bandwidth = 2.0 * std::f64::consts::PI * 600.0;
    let observer = TrackingObserver::<f64>::new(
        &TrackingObserverConfig {
            bandwidth_rad_s: bandwidth,
        },
        ts,
    )
    .unwrap();
    let mut observer_state = TrackingObserverState::at_rest(0.0);
    let speed = 0.1;
    let (mut sum_obs, mut sum_fd, mut n) = (0.0, 0.0, 0);
    let mut last = None;
    for k in 0..20_000 {
        let x = 0.001 + speed * ts * k as f64;
        let step =
            (observer.predicted_step(&observer_state, 0.0) / PITCH_M * 4_294_967_296.0) as i64;
        let position = decoder
            .update(&mut decoder_state, sensor.sample(x), step)
            .unwrap()
            .position_m(PITCH_M);
        if k == 0 {
            observer_state = TrackingObserverState::at_rest(position);
        }
        let v = observer.update(&mut observer_state, position, 0.0);
        if let Some(previous) = last {
            if k > 2000 {
                let fd = (position - previous) / ts;
                sum_obs += (v - speed) * (v - speed);
                sum_fd += (fd - speed) * (fd - speed);
                n += 1;
            }
        }
        last = Some(position);
    }
    let (rms_obs, rms_fd) = ((sum_obs / n as f64).sqrt(), (sum_fd / n as f64).sqrt());
    println!(
        "velocity at 0.1 m/s: observer (bandwidth {:.0} Hz) RMS error {:.2} mm/s, finite difference {:.2} mm/s",
        bandwidth / (2.0 * std::f64::consts::PI),
        rms_obs * 1e3,
        rms_fd * 1e3
    );
    // White position noise σ: the difference has √2·σ/Ts; the observer passes about
    // √(ω Ts) of it (noise bandwidth of the double pole), 0.6 here, plus the residual
    // calibration ripple at 5.6 Hz·... the ratio must be clearly below 1.
    assert!(rms_obs < 0.7 * rms_fd, "{rms_obs} vs {rms_fd}");
}
