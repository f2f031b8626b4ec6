//! Unit tests of the Hall decoder and its calibration, compiled only under
//! `#[cfg(test)]` (see `mod tests` in `mod.rs`).

use super::CORRECTION_ENTRIES;
use super::*;
use core::f64::consts::PI;
use std::vec::Vec;

/// Imperfect channels: offset, amplitude, phase error and third harmonic per channel.
#[derive(Copy, Clone)]
struct Channels {
    offset: [f64; 3],
    amplitude: [f64; 3],
    phase_error: [f64; 3],
    harmonic3: [f64; 3],
}

impl Channels {
    fn ideal(cfg: &HallConfig) -> Self {
        Self {
            offset: [f64::from(cfg.calibration.offset_counts[0]); 3],
            amplitude: [cfg.amplitude_counts; 3],
            phase_error: [0.0; 3],
            harmonic3: [0.0; 3],
        }
    }

    fn sample(&self, phi: f64) -> [u16; 3] {
        let shift = [0.0, 2.0 * PI / 3.0, -2.0 * PI / 3.0];
        core::array::from_fn(|k| {
            let a = phi + shift[k] + self.phase_error[k];
            (self.offset[k] + self.amplitude[k] * (a.sin() + self.harmonic3[k] * (3.0 * a).sin()))
                .round() as u16
        })
    }
}

/// Phase error in turns, wrapped to (−0.5, 0.5].
fn wrapped_turns(phase: u32, phi: f64) -> f64 {
    let got = f64::from(phase) / 4_294_967_296.0;
    let mut d = got - phi / (2.0 * PI);
    d -= d.round();
    d
}

#[test]
fn integer_and_f32_paths_match_the_f64_angle_at_12_and_16_bits() {
    for cfg in [HallConfig::LM1247_16BIT, HallConfig::LM1247_12BIT] {
        let ch = Channels::ideal(&cfg);
        let mut f32_cfg = cfg;
        f32_cfg.arithmetic = HallArithmetic::F32;
        let int = HallDecoder::new(&cfg).unwrap();
        let flt = HallDecoder::new(&f32_cfg).unwrap();
        let (mut worst_int, mut worst_f32) = (0.0f64, 0.0f64);
        for k in 0..20_000 {
            let phi = 2.0 * PI * (k as f64 + 0.5) / 20_000.0;
            let raw = ch.sample(phi);
            // f64 reference of the same rounded counts: Clarke and atan2 in f64.
            let u: [f64; 3] = core::array::from_fn(|i| f64::from(raw[i]) - ch.offset[i]);
            let exact = (2.0 * u[0] - u[1] - u[2]).atan2(3f64.sqrt() * (u[1] - u[2]));
            worst_int = worst_int.max(wrapped_turns(int.raw_phase(raw).unwrap(), exact).abs());
            worst_f32 = worst_f32.max(wrapped_turns(flt.raw_phase(raw).unwrap(), exact).abs());
        }
        // Integer: atan2 budget 1e-7 turn, plus (s, c) rounded to integers at radius
        // R = 2^19 (0.5·√2/R rad = 2.1e-7 turn), plus coefficient rounding (2^-23
        // relative): below 4e-7 turn, 7 nm at 18 mm (the 16-bit ADC's LSB is 110 nm).
        assert!(
            worst_int < 4e-7,
            "{} bit integer: {worst_int} turn",
            cfg.adc_bits
        );
        // f32: atan2f and the sums round at ~1e-7 relative.
        assert!(
            worst_f32 < 1e-6,
            "{} bit f32: {worst_f32} turn",
            cfg.adc_bits
        );
    }
}

#[test]
fn position_unwraps_across_pitches_in_both_directions() {
    let cfg = HallConfig::LM1247_16BIT;
    let ch = Channels::ideal(&cfg);
    let (dec, mut dec_state) = (HallDecoder::new(&cfg).unwrap(), HallState::default());
    let start = 0.3;
    let mut path = heapless::Vec::<f64, 4096>::new();
    for k in 0..2000 {
        path.push(start + 5.0 * (k as f64) / 1999.0).unwrap();
    }
    for k in 0..40 {
        path.push(start + 5.0 - 0.124 * k as f64).unwrap();
    }
    for &turns in &path {
        let pos = dec
            .update(&mut dec_state, ch.sample(2.0 * PI * turns), 0)
            .unwrap();
        // ADC rounding of the ideal channels: 0.5 LSB / A rad = 3e-6 turn.
        assert!((pos.position_m::<f64>(1.0) - turns).abs() < 1e-5, "{turns}");
        assert_eq!(pos.pitch_count(), turns.floor() as i32);
    }
}

#[test]
fn prediction_unwraps_at_20_m_per_s_sampled_at_2_4_khz() {
    // 20 m/s at 2.4 kHz is 8.33 mm = 0.463 pitch per sample: beyond the quarter pitch
    // that a plain difference accepts, fine with the velocity prediction.
    let cfg = HallConfig::LM1247_16BIT;
    let ch = Channels::ideal(&cfg);
    let step_turns = 20.0 / 2400.0 / 0.018;
    for direction in [1.0, -1.0] {
        let (dec, mut dec_state) = (HallDecoder::new(&cfg).unwrap(), HallState::default());
        let predicted = (direction * step_turns * 4_294_967_296.0) as i64;
        let mut first = 0.0;
        for k in 0..500 {
            let turns = 0.1 + direction * step_turns * k as f64;
            let pos = dec
                .update(
                    &mut dec_state,
                    ch.sample(2.0 * PI * turns),
                    if k == 0 { 0 } else { predicted },
                )
                .unwrap();
            if k == 0 {
                first = pos.position_m::<f64>(1.0) - turns;
            }
            assert!(
                (pos.position_m::<f64>(1.0) - turns - first).abs() < 1e-5,
                "{k}"
            );
        }
        // Without the prediction the same samples are an implausible jump.
        let (plain, mut plain_state) = (HallDecoder::new(&cfg).unwrap(), HallState::default());
        plain.update(&mut plain_state, ch.sample(0.0), 0).unwrap();
        assert_eq!(
            plain.update(
                &mut plain_state,
                ch.sample(2.0 * PI * direction * step_turns),
                0
            ),
            Err(HallFault::ImplausibleJump)
        );
    }
}

#[test]
fn faults_are_named_and_hold_the_position() {
    let cfg = HallConfig::LM1247_16BIT;
    let ch = Channels::ideal(&cfg);
    let (dec, mut dec_state) = (HallDecoder::new(&cfg).unwrap(), HallState::default());
    // At φ = −30° channel 1 is at its peak, so freezing it at mid-scale is a large error.
    let phi = -PI / 6.0;
    let good = ch.sample(phi);
    let held = dec.update(&mut dec_state, good, 0).unwrap();
    assert_eq!(
        dec.update(&mut dec_state, [0, good[1], good[2]], 0),
        Err(HallFault::AdcRail(0))
    );
    assert_eq!(
        dec.update(&mut dec_state, [good[0], good[1], 65535], 0),
        Err(HallFault::AdcRail(2))
    );
    // A channel far off with no history of being frozen: the sum no longer vanishes.
    assert_eq!(
        dec.update(&mut dec_state, [good[0], 32768, good[2]], 0),
        Err(HallFault::ResidualOutOfBand)
    );
    // All channels scaled down by half: sum fine, magnitude out of band.
    let half = good.map(|c| ((i32::from(c) + 32768) / 2) as u16);
    assert_eq!(
        dec.update(&mut dec_state, half, 0),
        Err(HallFault::MagnitudeOutOfBand)
    );
    // Back to good data: the position did not move.
    assert_eq!(dec.update(&mut dec_state, good, 0), Ok(held));

    // Stuck channel: frozen at its value while the axis moves on.
    let (dec, mut dec_state) = (HallDecoder::new(&cfg).unwrap(), HallState::default());
    let frozen = ch.sample(0.0)[1];
    let mut first_fault = None;
    for k in 0..200 {
        let mut raw = ch.sample(2.0 * PI * k as f64 / 400.0);
        raw[1] = frozen;
        if let Err(fault) = dec.update(&mut dec_state, raw, 0) {
            first_fault = Some((k, fault));
            break;
        }
    }
    let (k, fault) = first_fault.unwrap();
    assert_eq!(fault, HallFault::StuckChannel(1));
    // Detected once the true signal is half an amplitude away (sum limit 0.5 A):
    // sin(φ + 120°) falls from 0.866 to 0.366 at φ = 38.5°, i.e. k = 42.8.
    assert!((42..=44).contains(&k), "{k}");
}

#[test]
fn bad_configs_are_rejected_by_name() {
    let ok = HallConfig::LM1247_16BIT;
    let with = |f: fn(&mut HallConfig)| {
        let mut c = ok;
        f(&mut c);
        HallDecoder::new(&c).err()
    };
    assert_eq!(
        with(|c| c.pitch_m = f64::NAN),
        Some(ConfigError::not_finite("pitch_m"))
    );
    assert_eq!(
        with(|c| c.pitch_m = 0.0),
        Some(ConfigError::not_positive("pitch_m"))
    );
    assert_eq!(
        with(|c| c.pitch_m = -0.018),
        Some(ConfigError::not_positive("pitch_m"))
    );
    assert_eq!(
        with(|c| c.adc_bits = 24),
        Some(ConfigError::out_of_range("adc_bits"))
    );
    assert_eq!(
        with(|c| c.amplitude_counts = 40000.0),
        Some(ConfigError::out_of_range("amplitude_counts"))
    );
    assert_eq!(
        with(|c| c.magnitude_band = (1.3, 0.7)),
        Some(ConfigError::out_of_range("magnitude_band"))
    );
    assert_eq!(
        with(|c| c.sum_limit = -1.0),
        Some(ConfigError::not_positive("sum_limit"))
    );
    assert_eq!(
        with(|c| c.calibration.sin_row[1] = f32::NAN),
        Some(ConfigError::not_finite("calibration.sin_row"))
    );
    assert_eq!(
        with(|c| c.calibration.cos_row[0] = 1.0),
        Some(ConfigError::out_of_range("calibration.cos_row"))
    );
    assert_eq!(
        with(|c| c.calibration.offset_counts[2] = 70000.0),
        Some(ConfigError::out_of_range("calibration.offset_counts"))
    );
    assert!(HallDecoder::new(&ok).is_ok());
    assert!(HallDecoder::new(&HallConfig::LM1247_12BIT).is_ok());
}

/// Noise-free channels that follow the model exactly (offset, gain, mounting phase
/// error, and a third harmonic that differs per channel in amplitude and turns with
/// the channel's mounting): after calibration with its model-derived table the decoded
/// phase is exact up to ADC rounding, at both resolutions.
#[test]
fn calibration_recovers_offset_gain_phase_and_harmonic() {
    for (cfg, limit_turns) in [
        (HallConfig::LM1247_16BIT, 2e-5),
        (HallConfig::LM1247_12BIT, 3e-4),
    ] {
        let a = cfg.amplitude_counts;
        let o = f64::from(cfg.calibration.offset_counts[0]);
        let ch = Channels {
            offset: [o + 0.03 * a, o - 0.02 * a, o + 0.01 * a],
            amplitude: [1.05 * a, 0.96 * a, 1.0 * a],
            phase_error: [0.0, 0.01, -0.015],
            harmonic3: [0.020, 0.022, 0.018],
        };
        let sample = |phi: f64| ch.sample(phi);
        let mut cal = HallCalibrator::<512>::new();
        for k in 0..512 {
            cal.push(sample(2.0 * PI * 1.3 * k as f64 / 512.0)).unwrap();
        }
        let fit = cal.solve(&cfg.calibration).unwrap();
        let models = fit.model.channels;
        assert!(
            (models[0].offset_counts - ch.offset[0]).abs() < 0.01 * a,
            "{models:?}"
        );
        assert!(
            (models[1].amplitude_counts / ch.amplitude[1] - 1.0).abs() < 0.01,
            "{models:?}"
        );
        // The health row leaves the harmonic (peak Σk hk Ak, phases within 3° of each
        // other); the healthy-residual table takes it out again, down to ADC rounding:
        // |w_eff · q| ≤ |w_eff|₂ · 0.5 √3 for rounding errors q of at most 0.5 LSB.
        let harmonic_sum: f64 = (0..3).map(|k| ch.harmonic3[k] * ch.amplitude[k]).sum();
        let table = fit.calibration.residual.unwrap();
        let rounding = f64::from(table.noise_gain) * 0.5 * 3f64.sqrt();
        assert!(
            fit.peak_sum_residual_counts
                <= rounding + f64::from(table.systematic_counts) + 0.01 * harmonic_sum,
            "{} bit: checked residual {} counts against a harmonic of {harmonic_sum}",
            cfg.adc_bits,
            fit.peak_sum_residual_counts,
        );
        let c2 = cfg.with_self_calibration(&fit);
        let before = HallDecoder::new(&cfg).unwrap();
        let after = HallDecoder::new(&c2).unwrap();
        let correction = fit.calibration.correction.unwrap();
        let (mut e_before, mut e_after) = (Vec::new(), Vec::new());
        for k in 0..4000 {
            let phi = 2.0 * PI * k as f64 / 4000.0;
            let raw = sample(phi);
            e_before.push(wrapped_turns(before.raw_phase(raw).unwrap(), phi));
            e_after.push(wrapped_turns(
                correction.apply(after.raw_phase(raw).unwrap()),
                phi,
            ));
        }
        let spread = |e: &[f64]| {
            let mean = e.iter().sum::<f64>() / e.len() as f64;
            e.iter().map(|x| (x - mean).abs()).fold(0.0, f64::max)
        };
        let (b, f) = (spread(&e_before), spread(&e_after));
        // ADC rounding alone: 0.5 LSB/A rad, 1.9e-5 rad at 16 bit (3e-6 turn),
        // 3e-4 rad at 12 bit (5e-5 turn); limits allow a few times that.
        assert!(
            f < limit_turns,
            "{} bit: after {f} turn, before {b}",
            cfg.adc_bits
        );
        assert!(
            b > 20.0 * f,
            "{} bit: calibration did not help: {b} vs {f}",
            cfg.adc_bits
        );
    }
}

#[test]
fn calibration_needs_a_whole_pitch_and_enough_samples() {
    let cfg = HallConfig::LM1247_16BIT;
    let ch = Channels::ideal(&cfg);
    let mut short = HallCalibrator::<512>::new();
    for k in 0..300 {
        short
            .push(ch.sample(2.0 * PI * 0.5 * k as f64 / 300.0))
            .unwrap();
    }
    assert_eq!(
        short.solve(&cfg.calibration).err(),
        Some(CalibrationError::NotEnoughMotion)
    );
    let mut few = HallCalibrator::<512>::new();
    for k in 0..10 {
        few.push(ch.sample(k as f64)).unwrap();
    }
    assert_eq!(
        few.solve(&cfg.calibration).err(),
        Some(CalibrationError::TooFewSamples)
    );
    let mut full = HallCalibrator::<4>::new();
    for _ in 0..4 {
        full.push(ch.sample(0.0)).unwrap();
    }
    assert_eq!(full.push(ch.sample(0.0)), Err(CalibrationError::Full));
}

#[test]
fn correction_table_removes_a_periodic_phase_error() {
    // A decoder error of 1e-4 turn · sin(2φ) + 5e-5 · cos(5φ), learnt against the
    // exact phase, is removed to the table's interpolation error.
    let error = |phi: f64| 1e-4 * (2.0 * phi).sin() + 5e-5 * (5.0 * phi).cos();
    let to_word = |turns: f64| (turns.rem_euclid(1.0) * 4_294_967_296.0) as u64 as u32;
    let mut learner = CorrectionLearner::default();
    for k in 0..20_000 {
        let phi = 2.0 * PI * k as f64 / 20_000.0;
        let truth = phi / (2.0 * PI);
        learner.add(to_word(truth + error(phi) + 0.37), to_word(truth));
    }
    let table = learner.finish().unwrap();
    let mut worst = 0.0f64;
    let mut worst_raw = 0.0f64;
    for k in 0..7919 {
        let phi = 2.0 * PI * k as f64 / 7919.0;
        let truth = phi / (2.0 * PI);
        let decoded = to_word(truth + error(phi) + 0.37);
        let corrected = table.apply(decoded);
        worst = worst.max(wrapped_turns(corrected, 2.0 * PI * (truth + 0.37)).abs());
        worst_raw = worst_raw.max(wrapped_turns(decoded, 2.0 * PI * (truth + 0.37)).abs());
    }
    // Interpolation error of 5e-5·cos 5φ on 256 entries: (2π·5/256)²/8 · 5e-5 = 2.4e-7
    // turn, plus the table indexed by the decoded rather than the true phase (error
    // slope × error, ~1e-7): below 1e-6 turn against 1.5e-4 before.
    assert!(worst < 1e-6, "{worst} (uncorrected {worst_raw})");
    assert!(worst_raw > 1e-4);
    assert_eq!(table.error_q32.len(), CORRECTION_ENTRIES);
    assert_eq!(
        CorrectionLearner::default().finish().err(),
        Some(CalibrationError::NotEnoughMotion)
    );
}

/// A preset asked for an impossible ADC width must not overflow its shift; the
/// decoder then names the field.
#[test]
fn adc_width_beyond_the_shift_is_a_config_error_not_an_overflow() {
    for bits in [32u8, 40, 64, 255] {
        let config = HallConfig::lm1247(bits);
        assert_eq!(
            HallDecoder::new(&config).err(),
            Some(ConfigError::out_of_range("adc_bits")),
            "{bits}"
        );
    }
}

/// Reference and decoded phases that differ by about half a pitch, either way: the
/// learner's sums, counts and mean removal must not overflow.
#[test]
fn correction_learner_survives_half_pitch_differences() {
    let mut learner = CorrectionLearner::default();
    // The first pair sets the offset (difference 0); then 129 entries at −½ pitch
    // and 127 at +½: the mean is about −0.006 pitch, and the largest entry minus the
    // mean is beyond i32.
    learner.add(0, 0);
    for entry in 0..256u32 {
        let decoded = entry << 24;
        let difference = if entry < 129 {
            0x8000_0000
        } else {
            0x7FFF_FFFF
        };
        learner.add(decoded, decoded.wrapping_sub(difference));
    }
    assert!(learner.finish().is_ok());
}

/// A prediction of a thousand pitches in one sample cannot be unwrapped (more than
/// half a pitch per sample): a typed fault, and the count does not move.
#[test]
fn a_prediction_beyond_half_a_pitch_per_sample_is_a_fault() {
    let config = HallConfig::LM1247_16BIT;
    let decoder = HallDecoder::new(&config).unwrap();
    let raw = Channels::ideal(&config).sample(0.3);
    let mut state = HallState::default();
    let first = decoder.update(&mut state, raw, 0).unwrap();
    for step in [1000i64 << 32, -(1000i64 << 32), 1 << 31, i64::MIN, i64::MAX] {
        assert_eq!(
            decoder.update(&mut state, raw, step),
            Err(HallFault::SpeedBeyondUnwrap),
            "{step}"
        );
    }
    // 0.45 pitch per sample, predicted, is still decoded: one pitch count further.
    let moved = Channels::ideal(&config).sample(0.3 + 0.45 * 2.0 * PI);
    let step = (0.45 * 4_294_967_296.0) as i64;
    let next = decoder.update(&mut state, moved, step).unwrap();
    let advance = (next.accumulator - first.accumulator) as f64 / 4_294_967_296.0;
    assert!((advance - 0.45).abs() < 1e-4, "{advance}");
}

/// Calibrated noise-free sensors with per-channel harmonics at `cfg`'s resolution.
fn calibrated(cfg: &HallConfig) -> (Channels, SelfCalibration) {
    let a = cfg.amplitude_counts;
    let o = f64::from(cfg.calibration.offset_counts[0]);
    let ch = Channels {
        offset: [o + 0.03 * a, o - 0.02 * a, o + 0.01 * a],
        amplitude: [1.05 * a, 0.96 * a, 1.0 * a],
        phase_error: [0.0, 0.01, -0.015],
        harmonic3: [0.030, 0.010, 0.022],
    };
    let mut cal = HallCalibrator::<512>::new();
    for k in 0..512 {
        cal.push(ch.sample(2.0 * PI * 1.3 * k as f64 / 512.0))
            .unwrap();
    }
    (ch, cal.solve(&cfg.calibration).unwrap())
}

/// Counts one LSB inside either rail are rail faults, for the nominal decoder (its
/// range is offset ± 1.15 A, plus the 5 % margin) and for a calibrated one (the fitted
/// range plus the margin); healthy samples over a pitch are not.
#[test]
fn counts_near_a_rail_are_rail_faults() {
    for cfg in [HallConfig::LM1247_16BIT, HallConfig::LM1247_12BIT] {
        let (ch, fit) = calibrated(&cfg);
        let full_scale = ((1u32 << cfg.adc_bits) - 1) as u16;
        for config in [cfg, cfg.with_self_calibration(&fit)] {
            let decoder = HallDecoder::new(&config).unwrap();
            let good = ch.sample(0.4);
            for k in 0..3 {
                for level in [0, 1, full_scale - 1, full_scale] {
                    let mut raw = good;
                    raw[k] = level;
                    assert_eq!(
                        decoder.raw_phase_checked(raw),
                        Err(HallFault::AdcRail(k as u8)),
                        "{} bit, channel {k} at {level}",
                        cfg.adc_bits
                    );
                }
            }
            for j in 0..1000 {
                let raw = ch.sample(2.0 * PI * j as f64 / 1000.0);
                assert!(decoder.raw_phase_checked(raw).is_ok(), "{j}: {raw:?}");
            }
            // The band is the healthy range plus 5 % of A, inside the rails.
            let band = decoder.rail_band_counts();
            assert!(band.iter().all(|&[lo, hi]| lo > 1 && hi < full_scale - 1));
        }
    }
}

/// The calibrated limit follows the budget: it grows with it, is half the budget's
/// own limit and at least the healthy band, and a budget whose own limit is below twice
/// the healthy band (0.1 µm; just below the smallest) is refused by name; without a
/// table the limit is `sum_limit · A`.
#[test]
fn the_residual_limit_follows_the_budget() {
    for cfg in [HallConfig::LM1247_16BIT, HallConfig::LM1247_12BIT] {
        let (_, fit) = calibrated(&cfg);
        let calibrated = cfg.with_self_calibration(&fit);
        let table = calibrated.calibration.residual.unwrap();
        let slope = residual::correction_slope(&calibrated.calibration);
        let mut last = 0.0;
        for budget_m in [20e-6, 40e-6, 80e-6] {
            let config = HallConfig {
                fault_error_budget_m: budget_m,
                ..calibrated
            };
            let limit = HallDecoder::new(&config).unwrap().residual_limit_counts();
            let own = table.budget_limit_counts(2.0 * PI * budget_m / cfg.pitch_m, slope);
            let healthy = table.healthy_band_counts();
            // Half the budget's own limit (the middle of [H, own − H]), to Q4 rounding,
            // and at least the healthy band.
            assert!((limit - 0.5 * own).abs() <= 1.0 / 32.0, "{limit}");
            assert!(limit >= healthy, "{limit} {healthy}");
            assert!(limit > last);
            last = limit;
        }
        let tiny = HallConfig {
            fault_error_budget_m: 0.1e-6,
            ..calibrated
        };
        assert_eq!(
            HallDecoder::new(&tiny).err(),
            Some(ConfigError::out_of_range("fault_error_budget_m"))
        );
        let smallest = calibrated.smallest_fault_error_budget_m().unwrap();
        let just = HallConfig {
            fault_error_budget_m: smallest * 1.001,
            ..calibrated
        };
        let below = HallConfig {
            fault_error_budget_m: smallest * 0.999,
            ..calibrated
        };
        assert!(HallDecoder::new(&just).is_ok());
        assert!(HallDecoder::new(&below).is_err());
        let nominal = HallDecoder::new(&cfg).unwrap().residual_limit_counts();
        assert!((nominal - 0.5 * cfg.amplitude_counts).abs() < 0.1);
    }
}

/// The healthy-residual table predicts the health row of noise-free calibrated
/// channels to within ADC rounding at every phase, while the row itself swings by the
/// harmonics: a channel moved by just over the limit is flagged, one moved by less is
/// not, at phases spread over the pitch.
#[test]
fn a_channel_off_by_the_limit_is_flagged_at_every_phase() {
    let cfg = HallConfig::LM1247_16BIT;
    let (ch, fit) = calibrated(&cfg);
    let config = cfg.with_self_calibration(&fit);
    let decoder = HallDecoder::new(&config).unwrap();
    let w = config.calibration.sum_row;
    let limit = decoder.residual_limit_counts();
    for j in 0..200 {
        let raw = ch.sample(2.0 * PI * j as f64 / 200.0);
        assert!(decoder.raw_phase_checked(raw).is_ok(), "{j}");
        for k in 0..3 {
            // The residual moves by w_k·e plus the table's shift (at most 25 % here).
            let big = (1.6 * limit / f64::from(w[k])) as i32;
            for sign in [-1, 1] {
                let mut bad = raw;
                bad[k] = (i32::from(raw[k]) + sign * big) as u16;
                assert_eq!(
                    decoder.raw_phase_checked(bad),
                    Err(HallFault::ResidualOutOfBand),
                    "{j}, channel {k}, {}",
                    sign * big
                );
            }
        }
    }
}

/// The offsets and the rounding folded into each row's constant (`HallDecoder::new`)
/// give the same integers as removing the offsets first, sample by sample: the
/// demodulated phase, and the health row's sum against the residual limit.
#[test]
fn folded_offsets_give_the_unfolded_integers() {
    let cfg = HallConfig::LM1247_16BIT;
    let a = cfg.amplitude_counts;
    let o = f64::from(cfg.calibration.offset_counts[0]);
    let ch = Channels {
        offset: [o + 0.03 * a, o - 0.02 * a, o + 0.01 * a],
        amplitude: [1.05 * a, 0.96 * a, 1.0 * a],
        phase_error: [0.0, 0.01, -0.015],
        harmonic3: [0.020, 0.022, 0.018],
    };
    let mut cal = HallCalibrator::<512>::new();
    for k in 0..512 {
        cal.push(ch.sample(2.0 * PI * 1.3 * k as f64 / 512.0))
            .unwrap();
    }
    let fit = cal.solve(&cfg.calibration).unwrap();
    let calibrated = cfg.with_self_calibration(&fit);
    for dec in [
        HallDecoder::new(&cfg).unwrap(),
        HallDecoder::new(&calibrated).unwrap(),
    ] {
        let offsets = dec_offsets_q4(&calibrated_or(&dec, &cfg, &calibrated));
        let mut residual_faults = 0;
        for k in 0..5000 {
            let phi = 2.0 * PI * (k as f64 + 0.25) / 5000.0;
            // Every fifth sample with one channel pushed off, so that both outcomes
            // of the residual check are compared.
            let mut raw = ch.sample(phi);
            if k % 5 == 0 {
                let push = 0.12 * a * (k % 7) as f64;
                raw[k % 3] = raw[k % 3].saturating_add(push as u16);
            }
            let u: [i64; 3] = core::array::from_fn(|i| {
                (i64::from(raw[i]) << COUNT_FRACTION_BITS) - i64::from(offsets[i])
            });
            let dot = |row: &[i32; 3]| -> i64 {
                row.iter().zip(&u).map(|(&w, &x)| i64::from(w) * x).sum()
            };
            let round = 1i64 << (COEFFICIENT_SHIFT - 1);
            let s = ((dot(&dec.sin_row_q) + round) >> COEFFICIENT_SHIFT) as i32;
            let c = ((dot(&dec.cos_row_q) + round) >> COEFFICIENT_SHIFT) as i32;
            let sum = dot(&dec.sum_row_q16) >> 16;
            let phase = atan::atan2_turns(s, c);
            let healthy = dec.residual.as_ref().map_or(0, |t| t.at(phase));
            let residual_fault =
                (sum - i64::from(healthy)).abs() > i64::from(dec.residual_limit_q4);
            let got = dec.raw_phase_checked(raw);
            if matches!(got, Err(HallFault::AdcRail(_))) {
                continue;
            }
            if residual_fault {
                residual_faults += 1;
                assert_eq!(got, Err(HallFault::ResidualOutOfBand), "{k}");
            } else if let Ok(got) = got {
                assert_eq!(got, phase, "{k}");
            }
        }
        assert!((100..=1000).contains(&residual_faults), "{residual_faults}");
    }
}

/// A healthy-residual table with an entry no channel sum can reach is refused by
/// name (the sample path keeps the difference in i32 on that bound).
#[test]
fn residual_entries_beyond_any_channel_sum_are_refused() {
    let cfg = HallConfig::LM1247_16BIT;
    let mut table = ResidualTable {
        value_q4: [0; RESIDUAL_ENTRIES],
        systematic_counts: 1.0,
        noise_gain: 1.0,
        noise_rms_counts: 1.0,
        sensitivity_counts_per_rad: [1e6; 3],
    };
    let with = |table: ResidualTable| {
        let mut c = cfg;
        c.calibration.residual = Some(table);
        HallDecoder::new(&c)
    };
    table.value_q4[5] = 1 << 26;
    assert!(with(table).is_ok());
    table.value_q4[5] = -(1 << 26) - 1;
    assert_eq!(
        with(table).err().map(|e| e.field()),
        Some("calibration.residual")
    );
}

/// The configuration a decoder of this test was made from.
fn calibrated_or(dec: &HallDecoder, nominal: &HallConfig, calibrated: &HallConfig) -> HallConfig {
    if dec.residual.is_some() {
        *calibrated
    } else {
        *nominal
    }
}

/// The offsets of `cfg` in Q4 counts, as the decoder rounds them.
fn dec_offsets_q4(cfg: &HallConfig) -> [i32; 3] {
    cfg.calibration
        .offset_counts
        .map(|o| libm::round(f64::from(o) * f64::from(1u32 << COUNT_FRACTION_BITS)) as i32)
}

impl HallDecoder {
    /// The checks of one sample without history or unwrapping.
    fn raw_phase_checked(&self, raw: [u16; 3]) -> Result<u32, HallFault> {
        self.phase(&mut [0; 3], raw)
    }
}
