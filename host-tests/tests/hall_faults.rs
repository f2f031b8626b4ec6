//! Issue 10 item 6: Hall faults are flagged before they cost accuracy.
//!
//! The worst sensors of the model (`lm1247_worst`) at 16 bits with 4 LSB and 12 bits
//! with 1 LSB noise, calibrated through the real self-calibration path; every
//! single-channel failure on every channel, at onsets spread over a pitch, at 1 to
//! 500 mm/s sampled at 10 kHz. The error a fault causes is measured against a healthy
//! twin: a second sensor with the same noise seed sampled at the same positions and
//! decoded by a second decoder, so that the figure is the fault's own error (the
//! healthy calibrated error and the noise cancel). The total error (decoded − true,
//! less the constant homing offset) is reported beside it.

use hal_mock::hall_sensor::{ChannelFault, HallSensor, HallSensorParams};
use host_tests::hall::{calibrate, PITCH_M};
use kerf::error::ConfigErrorKind;
use kerf::sensing::hall::{HallConfig, HallDecoder, HallFault, HallState};

/// Sample period, s (10 kHz).
const TS_S: f64 = 1e-4;
/// The goal: a fault is flagged before its error exceeds this, m.
const BUDGET_M: f64 = 20e-6;
/// (ADC bits, noise LSB RMS): the two worst cases of the calibration tests.
const CASES: [(u8, f64); 2] = [(16, 4.0), (12, 1.0)];
/// Speeds of the detection table, m/s.
const SPEEDS_M_S: [f64; 4] = [0.001, 0.01, 0.1, 0.5];
/// Evenly spaced onset phases per pitch (the channel's peaks and zero crossings are
/// added to them).
const ONSETS: usize = 32;
const Q32: f64 = 4_294_967_296.0;

/// A failure kind of the table: its name and the fault it injects on channel `k`
/// of an ADC with full scale `full_scale`.
struct Kind {
    name: &'static str,
    fault: fn(usize, f64) -> ChannelFault,
}

fn kinds() -> Vec<Kind> {
    vec![
        Kind {
            name: "frozen at last value",
            fault: |k, _| ChannelFault::Frozen(k),
        },
        Kind {
            name: "stuck 1 LSB above 0",
            fault: |k, _| ChannelFault::Stuck(k, 1),
        },
        Kind {
            name: "stuck at 1/4 scale",
            fault: |k, fs| ChannelFault::Stuck(k, (0.25 * fs) as u16),
        },
        Kind {
            name: "stuck at mid-scale",
            fault: |k, fs| ChannelFault::Stuck(k, (0.5 * fs) as u16),
        },
        Kind {
            name: "stuck at 3/4 scale",
            fault: |k, fs| ChannelFault::Stuck(k, (0.75 * fs) as u16),
        },
        Kind {
            name: "stuck 1 LSB below full scale",
            fault: |k, fs| ChannelFault::Stuck(k, (fs - 2.0) as u16),
        },
        Kind {
            name: "open wire to 0",
            fault: |k, _| ChannelFault::OpenWire(k),
        },
        Kind {
            name: "open wire floating at mid-scale (noisy)",
            fault: |k, fs| ChannelFault::Floating(k, 0.5 * fs),
        },
        Kind {
            name: "gain collapse to 0.9",
            fault: |k, _| ChannelFault::Gain(k, 0.9),
        },
        Kind {
            name: "gain collapse to 0.5",
            fault: |k, _| ChannelFault::Gain(k, 0.5),
        },
        Kind {
            name: "gain collapse to 0",
            fault: |k, _| ChannelFault::Gain(k, 0.0),
        },
    ]
}

/// One calibrated worst-case sensor set.
struct Setup {
    params: HallSensorParams,
    config: HallConfig,
    decoder: HallDecoder,
}

fn setup(bits: u8, noise_lsb: f64) -> Setup {
    let params = HallSensorParams::lm1247_worst(bits, noise_lsb);
    let nominal = HallConfig::lm1247(bits);
    let fit = calibrate(&nominal, &mut HallSensor::new(params, 23));
    let config = nominal.with_self_calibration(&fit);
    // 20 µm where the sensors allow it; otherwise the smallest budget the decoder
    // accepts (reported by the tests: the goal is missed there, not loosened quietly).
    let budget_m = config
        .smallest_fault_error_budget_m()
        .expect("a calibrated table")
        .max(BUDGET_M / (1.0 + 1e-9))
        * (1.0 + 1e-9);
    let config = HallConfig {
        fault_error_budget_m: budget_m,
        ..config
    };
    let decoder = HallDecoder::new(&config).expect("the smallest accepted budget");
    Setup {
        params,
        config,
        decoder,
    }
}

/// Position of a decoded sample, m, wrapped into the pitch around `x_m`.
fn decoded_error_m(accumulator: i64, x_m: f64) -> f64 {
    let mut e = accumulator as f64 / Q32 - x_m / PITCH_M;
    e -= e.round();
    e * PITCH_M
}

/// What one trial saw.
struct Trial {
    /// Samples from onset to the first flagged one (1: flagged in the onset sample).
    samples: Option<u64>,
    fault: Option<HallFault>,
    /// Largest |faulty − healthy twin| over the accepted samples after onset, m.
    fault_error_m: f64,
    /// Largest |decoded − true − homing offset| over the same samples, m.
    total_error_m: f64,
    /// Faults of the healthy twin (false alarms).
    twin_faults: u64,
}

/// Runs one trial: 50 healthy samples, then the fault from the sample at phase
/// `onset_rad` on, until flagged (or two pitches of travel, a failure).
fn trial(
    s: &Setup,
    speed: f64,
    fault: ChannelFault,
    onset_rad: f64,
    seed: u64,
    homing_m: f64,
) -> Trial {
    let mut healthy = HallSensor::new(s.params, seed);
    let mut faulty = HallSensor::new(s.params, seed);
    let (mut healthy_state, mut faulty_state) = (HallState::default(), HallState::default());
    let step_m = speed * TS_S;
    let step = (step_m / PITCH_M * Q32) as i64;
    let onset_x = onset_rad / (2.0 * std::f64::consts::PI) * PITCH_M;
    let warmup = 50u64;
    let limit = warmup + (2.0 * PITCH_M / step_m) as u64;
    let mut t = Trial {
        samples: None,
        fault: None,
        fault_error_m: 0.0,
        total_error_m: 0.0,
        twin_faults: 0,
    };
    for n in 0..limit {
        let x = onset_x + (n as f64 - warmup as f64) * step_m;
        if n == warmup {
            faulty.fault = Some(fault);
        }
        let predicted = if n == 0 { 0 } else { step };
        let reference = s
            .decoder
            .update(&mut healthy_state, healthy.sample(x), predicted);
        let decoded = s
            .decoder
            .update(&mut faulty_state, faulty.sample(x), predicted);
        let reference = match reference {
            Ok(p) => p,
            Err(_) => {
                t.twin_faults += 1;
                continue;
            }
        };
        match decoded {
            Ok(p) if n >= warmup => {
                let own = (p.accumulator - reference.accumulator) as f64 / Q32 * PITCH_M;
                t.fault_error_m = t.fault_error_m.max(own.abs());
                let total = decoded_error_m(p.accumulator, x) - homing_m;
                t.total_error_m = t.total_error_m.max(total.abs());
            }
            Ok(_) => {}
            Err(f) if n >= warmup => {
                t.samples = Some(n - warmup + 1);
                t.fault = Some(f);
                break;
            }
            Err(f) => panic!("healthy warm-up flagged {f:?}"),
        }
    }
    t
}

/// The constant offset of the calibrated decode (the common rotation a fit leaves,
/// which homing removes): mean of decoded − true over a pitch.
fn homing_offset_m(s: &Setup) -> f64 {
    let mut sensor = HallSensor::new(s.params, 99);
    let n = 4096;
    let sum: f64 = (0..n)
        .map(|k| {
            let x = PITCH_M * (k as f64 + 0.5) / n as f64;
            let phase = s.decoder.raw_phase(sensor.sample(x)).expect("healthy");
            let phase = s
                .config
                .calibration
                .correction
                .map_or(phase, |c| c.apply(phase));
            decoded_error_m(i64::from(phase), x)
        })
        .sum();
    sum / n as f64
}

/// Worst case of one failure kind at one resolution.
#[derive(Default, Clone)]
struct Worst {
    distance_m: f64,
    samples_at_1_mm_s: u64,
    fault_error_m: f64,
    total_error_m: f64,
    trials: u64,
    case: String,
}

#[test]
fn every_single_channel_failure_is_flagged_within_20_um() {
    println!("| ADC | noise | failure | worst detection distance µm | worst time at 1 mm/s (periods / ms) | worst fault error before flag µm | worst total error µm | trials |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut reached = Vec::new();
    for (bits, noise_lsb) in CASES {
        let mut overall = Worst::default();
        let s = setup(bits, noise_lsb);
        println!(
            "| {bits} bit | {noise_lsb} LSB | budget installed: {:.2} µm | | | | | |",
            s.config.fault_error_budget_m * 1e6
        );
        if bits == 16 {
            assert!(s.config.fault_error_budget_m <= BUDGET_M * (1.0 + 1e-6));
        }
        let homing_m = homing_offset_m(&s);
        let full_scale = f64::from((1u32 << bits) - 1);
        for kind in kinds() {
            let mut worst = Worst::default();
            for k in 0..3 {
                // The channel's peaks and zero crossings (its phase is the preset's),
                // and evenly spaced onsets.
                let p = s.params.phase_rad[k];
                let special = [0.0, 0.5, 1.0, 1.5].map(|q| q * std::f64::consts::PI - p);
                let even =
                    (0..ONSETS).map(|j| 2.0 * std::f64::consts::PI * j as f64 / ONSETS as f64);
                for (j, onset) in special.into_iter().chain(even).enumerate() {
                    for (i, &speed) in SPEEDS_M_S.iter().enumerate() {
                        let seed = 1000 * k as u64 + 10 * j as u64 + i as u64;
                        let fault = (kind.fault)(k, full_scale);
                        let t = trial(&s, speed, fault, onset, seed, homing_m);
                        let what = format!(
                            "{bits} bit, {}, channel {k}, onset {onset:.3} rad, {} mm/s",
                            kind.name,
                            speed * 1e3
                        );
                        assert_eq!(t.twin_faults, 0, "false alarm on the healthy twin: {what}");
                        let n = t.samples.unwrap_or_else(|| panic!("never flagged: {what}"));
                        if t.fault_error_m > worst.fault_error_m {
                            worst.case = format!(
                                "{what}: {:.1} µm before {:?} after {n} samples",
                                t.fault_error_m * 1e6,
                                t.fault
                            );
                        }
                        worst.distance_m = worst.distance_m.max(n as f64 * speed * TS_S);
                        if i == 0 {
                            worst.samples_at_1_mm_s = worst.samples_at_1_mm_s.max(n);
                        }
                        worst.fault_error_m = worst.fault_error_m.max(t.fault_error_m);
                        worst.total_error_m = worst.total_error_m.max(t.total_error_m);
                        worst.trials += 1;
                    }
                }
            }
            if worst.fault_error_m > overall.fault_error_m {
                overall = worst.clone();
            }
            println!(
                "| {bits} bit | {noise_lsb} LSB | {} | {:.0} | {} / {:.1} | {:.1} | {:.1} | {} |",
                kind.name,
                worst.distance_m * 1e6,
                worst.samples_at_1_mm_s,
                worst.samples_at_1_mm_s as f64 * TS_S * 1e3,
                worst.fault_error_m * 1e6,
                worst.total_error_m * 1e6,
                worst.trials
            );
        }
        println!(
            "| {bits} bit | residual limit {:.1} counts ({:.3} % of A) | | | | | | |",
            s.decoder.residual_limit_counts(),
            100.0 * s.decoder.residual_limit_counts() / s.config.amplitude_counts
        );
        println!("{bits} bit worst case: {}", overall.case);
        reached.push((bits, overall.fault_error_m));
    }
    for (bits, worst_m) in reached {
        // 16 bits, 4 LSB: the goal. 12 bits, 1 LSB: the goal is out of reach of a
        // per-sample check (20 µm of error shows 6.1 standard deviations of the checked
        // residual's noise, and 10⁷ healthy samples need 6σ plus the table error, see
        // `residual`): the decoder refuses 20 µm there and accepts 21.6 µm; with the
        // limit at that edge, noise lets a fast fault pass a sample more. The figure
        // reached is asserted so that it cannot grow unnoticed.
        let bound = if bits == 16 { BUDGET_M } else { 23e-6 };
        assert!(worst_m <= bound, "{bits} bit: {:.1} µm", worst_m * 1e6);
    }
}

/// 10⁷ healthy samples per resolution on the worst sensors: ten runs with their own
/// noise seeds at speeds from 0.3 to 300 mm/s, forwards and backwards, each over at
/// least five pitches (every phase many times); not one fault.
#[test]
fn no_false_alarm_in_10_million_healthy_samples() {
    let runs = 10u64;
    let per_run = 1_000_000u64;
    let speeds = [
        0.0011, 0.0031, 0.009, -0.02, 0.047, -0.1, 0.15, -0.21, 0.3, 0.0017,
    ];
    for (bits, noise_lsb) in CASES {
        let s = setup(bits, noise_lsb);
        let mut faults = 0u64;
        let mut first = None;
        for (run, &speed) in (0..runs).zip(&speeds) {
            let mut sensor = HallSensor::new(s.params, 7_000 + run);
            let mut state = HallState::default();
            let step_m = speed * TS_S;
            let step = (step_m / PITCH_M * Q32) as i64;
            // At least five pitches: slow runs repeat a short stretch back and forth.
            let stretch = (per_run as f64 * step_m.abs()).max(5.0 * PITCH_M);
            for n in 0..per_run {
                let travel = (n as f64 * step_m.abs()) % (2.0 * stretch);
                let (x, sign) = if travel < stretch {
                    (travel, 1.0)
                } else {
                    (2.0 * stretch - travel, -1.0)
                };
                let x = 0.003 * run as f64 + speed.signum() * x;
                let predicted = if n == 0 {
                    0
                } else {
                    (sign * speed.signum()) as i64 * step.abs()
                };
                if let Err(f) = s.decoder.update(&mut state, sensor.sample(x), predicted) {
                    faults += 1;
                    first.get_or_insert((run, n, f));
                }
            }
        }
        println!(
            "{bits} bit, {noise_lsb} LSB: {faults} faults in {} healthy samples (limit {:.1} counts)",
            runs * per_run,
            s.decoder.residual_limit_counts()
        );
        assert_eq!(faults, 0, "{bits} bit: first {first:?}");
    }
}

/// The limit follows the budget: a larger budget gives a larger limit, the 20 µm
/// default sits between the healthy band and the budget's own limit, and a budget the
/// healthy noise does not fit under (0.1 µm at 12 bits) is refused by name.
#[test]
fn the_residual_limit_follows_the_error_budget() {
    println!("| ADC | noise | budget µm | limit counts | limit % of A | healthy band counts |");
    println!("|---|---|---|---|---|---|");
    // The smallest budget each case allows (20 µm is met where it is at most 20).
    for (bits, noise_lsb) in CASES {
        let s = setup(bits, noise_lsb);
        let table = s.config.calibration.residual.expect("a calibrated table");
        println!(
            "| {bits} bit | {noise_lsb} LSB | smallest accepted {:.2} | | | |",
            s.config.smallest_fault_error_budget_m().unwrap() * 1e6
        );
        let healthy = table.healthy_band_counts();
        let mut last = 0.0;
        let least = s.config.fault_error_budget_m;
        for budget in [least, 2.0 * least, 5.0 * least] {
            let config = HallConfig {
                fault_error_budget_m: budget,
                ..s.config
            };
            let limit = HallDecoder::new(&config).unwrap().residual_limit_counts();
            println!(
                "| {bits} bit | {noise_lsb} LSB | {:.0} | {limit:.1} | {:.3} | {healthy:.1} |",
                budget * 1e6,
                100.0 * limit / s.config.amplitude_counts
            );
            assert!(
                limit > last && limit > healthy,
                "{budget}: {limit} vs {last}"
            );
            last = limit;
        }
    }
    let s = setup(12, 1.0);
    let impossible = HallConfig {
        fault_error_budget_m: 0.1e-6,
        ..s.config
    };
    let error = HallDecoder::new(&impossible).unwrap_err();
    assert_eq!(
        (error.kind, error.field()),
        (ConfigErrorKind::OutOfRange, "fault_error_budget_m")
    );
}
