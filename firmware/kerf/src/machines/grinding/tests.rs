use super::*;
use crate::app::jobs::JobSlots;
use crate::app::supervisor::{Command, Mode, Report, Supervisor};
use heapless::spsc::Queue;
use nalgebra::{Matrix6, Vector6};
use std::vec::Vec;

/// Gauge voltages that the sensor's calibration turns into `wrench` ([Fx, Fy, Fz, Mx,
/// My, Mz]) over `bias`: the calibration matrix inverted in f64 here.
fn raw_for(wrench: [f64; 6], bias: [f64; 6]) -> [f64; 6] {
    let cal = Matrix6::from_fn(|r, c| FtSensorConfig::ATI_GAMMA_IP60.calibration[r][c]);
    let raw = cal.try_inverse().unwrap() * Vector6::from(wrench);
    core::array::from_fn(|k| raw[k] + bias[k])
}

const BIAS: [f64; 6] = [0.3, -0.2, 0.1, 0.05, -0.4, 0.25];

/// The normal force a wrench of pure Fy gives with no eccentricity and no tangential
/// moment: |Fy|.
fn pressing(fn_n: f64) -> GrindingInputs<f64> {
    GrindingInputs {
        ft_raw_v: raw_for([0.0, fn_n, 0.0, 0.0, 0.0, 0.0], BIAS),
        device_fault: None,
    }
}

fn job(law: ForceLawKind) -> GrindingJob {
    GrindingJob {
        law,
        normal_force_n: 7.5,
        feed_m_s: 1e-4,
        length_m: 5e-4,
        spindle_rpm: 25_000.0,
    }
}

type Reports = Vec<Report<GrindingCell<f64>>>;

/// Runs `f` with a calibrated cell's supervisor (bias captured from `BIAS`, Ready).
fn with_ready_cell(
    f: impl FnOnce(
        &mut Supervisor<'_, GrindingCell<f64>>,
        &mut dyn FnMut(Command<GrindingCell<f64>>),
        &JobSlots<GrindingJob>,
        &mut dyn FnMut() -> Reports,
    ),
) {
    let jobs = JobSlots::default();
    let mut commands = Queue::<Command<GrindingCell<f64>>, 4>::new();
    let mut reports = Queue::<Report<GrindingCell<f64>>, 64>::new();
    let (mut to, from) = commands.split();
    let (report_to, mut report_from) = reports.split();
    let cell = GrindingCell::<f64>::new(&GrindingConfig::PUBLISHED).unwrap();
    let mut s = Supervisor::new(cell, from, report_to, &jobs);
    s.set_telemetry_decimation(0);
    let mut send = |c| assert!(to.enqueue(c).is_ok());
    let mut drain = || core::iter::from_fn(|| report_from.dequeue()).collect::<Vec<_>>();
    send(Command::Calibrate);
    for _ in 0..GrindingConfig::PUBLISHED.bias.samples {
        s.step(&pressing(0.0));
    }
    send(Command::FinishCalibration(GrindingCalibration {
        eccentricity: Eccentricity {
            dx_m: 0.0,
            dy_m: 0.0,
        },
    }));
    s.step(&pressing(0.0));
    assert_eq!(s.mode(), Mode::Ready);
    let bias = s.machine().bias().unwrap().raw_v;
    for (b, e) in bias.iter().zip(BIAS) {
        assert!((b - e).abs() < 1e-12);
    }
    drain();
    f(&mut s, &mut send, &jobs, &mut drain);
}

/// A job before the bias is captured is refused with its reason; bad fields are named.
#[test]
fn jobs_are_checked() {
    let cell = GrindingCell::<f64>::new(&GrindingConfig::PUBLISHED).unwrap();
    let mut c = cell.clone();
    assert_eq!(
        c.begin_job(&job(ForceLawKind::Pid)),
        Err(GrindingJobError::NotCalibrated)
    );
    for (mut bad, field) in [
        (job(ForceLawKind::Pid), "normal_force_n"),
        (job(ForceLawKind::Adrc), "feed_m_s"),
        (job(ForceLawKind::Pid), "length_m"),
        (job(ForceLawKind::Pid), "spindle_rpm"),
    ] {
        match field {
            "normal_force_n" => bad.normal_force_n = 25.0,
            "feed_m_s" => bad.feed_m_s = f64::NAN,
            "length_m" => bad.length_m = -1.0,
            _ => bad.spindle_rpm = f64::INFINITY,
        }
        assert_eq!(cell.check_job(&bad), Err(GrindingJobError::Field(field)));
    }
}

/// A pass presses toward the surface until the force is there, feeds the set length
/// and ends Ready; a stop retracts at the rate limit with the feed at zero.
#[test]
fn a_pass_runs_and_a_stop_retracts() {
    for law in [ForceLawKind::Pid, ForceLawKind::Adrc] {
        with_ready_cell(|s, send, jobs, _| {
            send(Command::LoadJob(jobs.place(job(law)).unwrap()));
            send(Command::Start);
            // Out of contact: the piezo moves toward the surface, the hexapod feeds what
            // the piezo leaves of the set feed: V_hex = √(F_R² − V_pzo²).
            let out = s.step(&pressing(0.0));
            assert_eq!(s.mode(), Mode::Running);
            assert!(out.piezo_m > 0.0 && out.spindle_rpm == 25_000.0);
            let v_pzo = out.piezo_m / 1e-3;
            let v_hex = (1e-8 - v_pzo * v_pzo).sqrt();
            assert!((out.hexapod_feed_m_s - v_hex).abs() < 1e-12, "{out:?}");
            let mut periods = 1;
            // A stiff contact 2 µm away: 5 N/µm beyond it (G's gains act in
            // 10 pm per unit: a force time constant of 0.24 s here).
            let mut piezo_m = out.piezo_m;
            while s.mode() == Mode::Running && periods < 20_000 {
                let force = 5e6 * (piezo_m - 2e-6).max(0.0);
                piezo_m = s.step(&pressing(force)).piezo_m;
                periods += 1;
            }
            // The PID holds the reference and the pass ends after 0.5 mm at 0.1 mm/s:
            // five seconds and what the piezo took of the feed. G's ADRC gains
            // (b0 0.543 against this contact's 5 N/µm in 10 pm units) keep the piezo
            // moving near its rate limit, which takes the whole feed (V_hex → 0): the
            // force stays bounded, the pass is stopped below.
            let force = s.machine().telemetry().forces.normal_n;
            match law {
                ForceLawKind::Pid => {
                    assert!((force - 7.5).abs() < 0.1, "{force}");
                    assert_eq!(s.mode(), Mode::Ready);
                    assert!((5000..7000).contains(&periods), "{periods}");
                }
                ForceLawKind::Adrc => {
                    assert!(force > 1.0 && force < 15.0, "{force}");
                    send(Command::Stop);
                    while s.mode() != Mode::Ready && periods < 40_000 {
                        s.step(&pressing(0.0));
                        periods += 1;
                    }
                    assert_eq!(s.mode(), Mode::Ready);
                }
            }
            send(Command::LoadJob(jobs.place(job(law)).unwrap()));
            send(Command::Start);
            for _ in 0..200 {
                s.step(&pressing(0.0));
            }
            let pressed = s.machine().telemetry().outputs.piezo_m;
            send(Command::Stop);
            let out = s.step(&pressing(0.0));
            assert_eq!(s.mode(), Mode::Stopping);
            assert!(out.piezo_m < pressed && out.hexapod_feed_m_s == 0.0 && out.spindle_rpm == 0.0);
            let mut periods = 0;
            while s.mode() == Mode::Stopping && periods < 10_000 {
                s.step(&pressing(0.0));
                periods += 1;
            }
            assert_eq!(s.mode(), Mode::Ready);
        });
    }
}

/// Bad input during a pass: NaN, a clipped channel, a crash force, Ft beyond the
/// resultant: a fault with its reason and safe outputs in the same period.
#[test]
fn bad_readings_fault_with_safe_outputs() {
    let nan = GrindingInputs {
        ft_raw_v: [0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0],
        device_fault: None,
    };
    let clipped = GrindingInputs {
        ft_raw_v: [0.0, 0.0, 0.0, 9.99, 0.0, 0.0],
        device_fault: None,
    };
    // Mz alone: a tangential force with no resultant in the plane.
    let inconsistent = GrindingInputs {
        ft_raw_v: raw_for([0.5, 0.0, 0.0, 0.0, 0.0, 0.02], BIAS),
        device_fault: None,
    };
    let cases = [
        (
            nan,
            GrindingFault::Sensor(ForceError::NotFinite { channel: 1 }),
        ),
        (
            clipped,
            GrindingFault::Sensor(ForceError::Saturated { channel: 3 }),
        ),
        (pressing(45.0), GrindingFault::ForceLimit),
        (
            GrindingInputs {
                device_fault: Some(DeviceFault::Hexapod(HexapodFault::Controller(7))),
                ..pressing(5.0)
            },
            GrindingFault::Hexapod(HexapodFault::Controller(7)),
        ),
        (
            GrindingInputs {
                device_fault: Some(DeviceFault::Spindle(SpindleFault::Silent { ticks: 5 })),
                ..pressing(5.0)
            },
            GrindingFault::Spindle(SpindleFault::Silent { ticks: 5 }),
        ),
    ];
    for (input, fault) in cases {
        with_ready_cell(|s, send, jobs, _| {
            send(Command::LoadJob(
                jobs.place(job(ForceLawKind::Pid)).unwrap(),
            ));
            send(Command::Start);
            for _ in 0..50 {
                s.step(&pressing(5.0));
            }
            let out = s.step(&input);
            assert_eq!(s.mode(), Mode::Fault(fault));
            assert_eq!(out, s.machine().safe_outputs());
            assert_eq!(
                (out.piezo_m, out.hexapod_feed_m_s, out.spindle_rpm),
                (0.0, 0.0, 0.0)
            );
        });
    }
    with_ready_cell(|s, send, jobs, _| {
        send(Command::LoadJob(
            jobs.place(job(ForceLawKind::Adrc)).unwrap(),
        ));
        send(Command::Start);
        s.step(&pressing(5.0));
        s.step(&inconsistent);
        assert!(matches!(
            s.mode(),
            Mode::Fault(GrindingFault::Sensor(ForceError::NegativeRadicand { .. }))
        ));
    });
}

/// A sensor that moves during the bias capture (a force of 10 N appears halfway)
/// faults the calibration instead of capturing a wrong bias.
#[test]
fn a_disturbed_bias_capture_faults() {
    let mut commands = Queue::<Command<GrindingCell<f64>>, 4>::new();
    let mut reports = Queue::<Report<GrindingCell<f64>>, 64>::new();
    let (mut to, from) = commands.split();
    let (report_to, _report_from) = reports.split();
    let cell = GrindingCell::<f64>::new(&GrindingConfig::PUBLISHED).unwrap();
    let jobs = JobSlots::default();
    let mut s = Supervisor::new(cell, from, report_to, &jobs);
    s.set_telemetry_decimation(0);
    assert!(to.enqueue(Command::Calibrate).is_ok());
    for k in 0..GrindingConfig::PUBLISHED.bias.samples {
        s.step(&pressing(if k > 200 { 10.0 } else { 0.0 }));
    }
    assert!(matches!(
        s.mode(),
        Mode::Fault(GrindingFault::Sensor(ForceError::NotAtRest { .. }))
    ));
}

/// At rest after calibration the drift watch sees the compensated force: 0.29 N on
/// Fy (inside G's 0.294 N bound) for 3 s raises nothing; 0.30 N faults
/// `BiasDrift` on Fy at the end of the first window, in the 1500th period at rest
/// (500 settling, 1000 averaged); a device fault at rest faults too.
#[test]
fn a_drift_at_rest_faults_at_the_end_of_a_window() {
    with_ready_cell(|s, _, _, _| {
        for _ in 0..3000 {
            s.step(&pressing(0.29));
        }
        assert_eq!(s.mode(), Mode::Ready);
    });
    with_ready_cell(|s, _, _, _| {
        // The first period at rest was the one that took the calibration's fit.
        let mut periods = 1;
        while s.mode() == Mode::Ready && periods < 5000 {
            s.step(&pressing(0.30));
            periods += 1;
        }
        assert_eq!(periods, 500 + 1000);
        match s.mode() {
            Mode::Fault(GrindingFault::BiasDrift(d)) => {
                assert_eq!(d.component, 1);
                assert!((d.mean_n - 0.30).abs() < 1e-6, "{d:?}");
            }
            other => panic!("{other:?}"),
        }
    });
    with_ready_cell(|s, _, _, _| {
        s.step(&GrindingInputs {
            device_fault: Some(DeviceFault::Spindle(SpindleFault::Silent { ticks: 5 })),
            ..pressing(0.0)
        });
        assert_eq!(
            s.mode(),
            Mode::Fault(GrindingFault::Spindle(SpindleFault::Silent { ticks: 5 }))
        );
    });
}
