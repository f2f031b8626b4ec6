use super::*;
use crate::app::host_link::{describe, SettingText};
use crate::app::supervisor::{Machine, NonFiniteOutput};
use crate::codec::job::{write_efd, write_gcode};
use crate::codec::link::Description;
use crate::codec::spindle::SpindleError;
use crate::hal::LinkError;
use crate::sensing::force::BiasDrift;
use miniconf::json_core;
use std::format;
use std::string::String;
use std::vec::Vec;

type G = GrindingCell<f64>;

/// The cell's pass, as the image and the host tests run it.
const PASS_GCODE: &str = include_str!("../../../../../../data/grinding_pass.gcode");

fn job_file(gcode: &[u8]) -> Vec<u8> {
    let mut out = std::vec![0u8; gcode.len() + 64];
    let n = write_gcode(gcode, &mut out).unwrap();
    out.truncate(n);
    out
}

fn load(bytes: &[u8]) -> Result<GrindingJob, u16> {
    let file = JobFile::read(bytes).unwrap();
    let mut job = GrindingJob::default();
    <G as LinkMachine>::load_job(&mut super::super::product::PASS.clone(), &file, &mut job)
        .map(|()| job)
}

fn gcode(text: &str) -> Result<GrindingJob, u16> {
    load(&job_file(text.as_bytes()))
}

/// The cell's settings give back its configuration's laws.
#[test]
fn the_settings_of_the_cell_are_its_laws() {
    let s = GrindingSettings::CELL;
    assert_eq!(s.pid(), CONFIG.pid);
    assert_eq!(s.adrc(), CONFIG.adrc);
    let from_settings = G::coefficients(&s, CONFIG.period_s).unwrap();
    assert_eq!(from_settings, GrindingLaws::new(&CONFIG).unwrap());
}

/// Sets `path` to `value` in the cell's settings and validates them.
fn set(path: &str, value: &str) -> Result<GrindingLaws<f64>, ConfigError> {
    let mut s = GrindingSettings::CELL;
    json_core::set(&mut s, path, value.as_bytes()).unwrap();
    G::coefficients(&s, CONFIG.period_s)
}

/// The bounds the description announces are where validation refuses: the value at
/// a bound accepted, the next one past it refused and named by its law.
#[test]
fn the_announced_bounds_are_the_validations() {
    for (path, at, past, field) in [
        (
            "/pid/anti_windup",
            "1000",
            "1000.000001",
            "pid.anti_windup_per_s",
        ),
        ("/pid/anti_windup", "0", "-1e-9", "pid.anti_windup_per_s"),
        (
            "/pid/derivative_filter",
            "0",
            "-1e-9",
            "pid.derivative_filter_s",
        ),
        (
            "/pid/derivative_filter",
            "1e9",
            "1.000001e9",
            "pid.derivative_filter_s",
        ),
        (
            "/adrc/eso_bandwidth",
            "1000",
            "1000.000001",
            "adrc.eso_bandwidth_rad_s",
        ),
        ("/adrc/alpha", "1", "1.000001", "adrc.alpha"),
        ("/adrc/alpha", "0.01", "0.009999", "adrc.alpha"),
        ("/adrc/kp", "1e-9", "0", "adrc.kp"),
        ("/adrc/kd", "1e-9", "0", "adrc.kd"),
        ("/adrc/b0", "1e-9", "0", "adrc.b0"),
        ("/adrc/td_acceleration", "1e-3", "0", "adrc.td_acceleration"),
    ] {
        assert!(set(path, at).is_ok(), "{path} = {at}");
        let e = set(path, past).unwrap_err();
        assert_eq!(
            format!("{e}").split(':').next(),
            Some(field),
            "{path} = {past}"
        );
    }
    // The PID's gains take any finite sign (G's Ki is negative).
    for path in ["/pid/kp", "/pid/ki", "/pid/kd"] {
        assert!(set(path, "-3.5").is_ok(), "{path}");
    }
}

/// The pass's file loads into the cell's pass; other files are refused with the
/// code of their fault.
#[test]
fn a_gcode_pass_loads_and_bad_ones_are_refused_by_code() {
    let job = load(&job_file(PASS_GCODE.as_bytes())).unwrap();
    assert_eq!(job.law, super::super::ForceLawKind::Pid);
    assert_eq!(job.normal_force_n, 7.5);
    assert!((job.length_m - 0.5e-3).abs() < 1e-15, "{job:?}");
    // F6 mm/min.
    assert!((job.feed_m_s - 1e-4).abs() < 1e-16, "{job:?}");
    assert_eq!(job.spindle_rpm, 25_000.0);
    // Two moves add up; without M3 the tool rolls (spindle 0).
    let two = gcode("G91\nG1 X0.2 F6\nX0.3\n").unwrap();
    assert!((two.length_m - 0.5e-3).abs() < 1e-15);
    assert_eq!(two.spindle_rpm, 0.0);
    let mut efd = [0u8; 128];
    let n = write_efd([0.0, 0.0], &[[1e-3, 0.0, 0.0, 1e-3]], &mut efd).unwrap();
    assert_eq!(load(&efd[..n]).unwrap_err(), load_codes::KIND);
    for (text, code) in [
        ("G1 X0.1 Q3\n", load_codes::GCODE),
        ("G21\nM3 S100\n", load_codes::EMPTY),
        ("G0 X1\n", load_codes::RAPID),
        ("G1 X1 Y1 F6\n", load_codes::OFF_AXIS),
        ("G1 X1 A2 F6\n", load_codes::OFF_AXIS),
        ("G1 X-1 F6\n", load_codes::BACKWARD),
        ("G1 X1 F6\nG1 X1\n", load_codes::BACKWARD),
        ("G1 X1 F6\nG1 X2 F12\n", load_codes::FEED_CHANGES),
        (
            "M3 S1000\nG1 X1 F6\nS2000\nG1 X2\n",
            load_codes::SPINDLE_CHANGES,
        ),
        ("G1 X1 F6\nM3 S1000\nG1 X2\n", load_codes::SPINDLE_CHANGES),
    ] {
        assert_eq!(gcode(text).unwrap_err(), code, "{text:?}");
    }
}

/// A pass the loader takes but the cell's range does not is refused by the cell's
/// check, with the code of its field.
#[test]
fn a_pass_out_of_the_cells_range_is_refused_by_its_field() {
    let cell = G::new(&CONFIG).unwrap();
    // 2 m/s: past the cell's 1 m/s.
    let fast = gcode("G1 X1 F120000\n").unwrap();
    let e = cell.check_job(&fast).unwrap_err();
    assert_eq!(G::job_error_code(&e), 3);
    let e = cell
        .check_job(&gcode("M3 S200000\nG1 X1 F6\n").unwrap())
        .unwrap_err();
    assert_eq!(G::job_error_code(&e), 5);
    let e = cell
        .check_job(&gcode("G1 X20000 F6\n").unwrap())
        .unwrap_err();
    assert_eq!(G::job_error_code(&e), 4);
    assert!(cell.check_job(&gcode(PASS_GCODE).unwrap()).is_ok());
}

/// Every code the cell sends has its words, once; its refusals are not the link's.
#[test]
fn every_code_has_its_words() {
    let faults = [
        GrindingFault::Sensor(ForceError::Saturated { channel: 4 }),
        GrindingFault::ForceLimit,
        GrindingFault::Loop(crate::control::hybrid_force::HybridForceError::CommandNotFinite),
        GrindingFault::Hexapod(HexapodFault::Controller(7)),
        GrindingFault::Hexapod(HexapodFault::Reply(crate::codec::gcs::GcsError::Truncated)),
        GrindingFault::Hexapod(HexapodFault::Link(LinkError::Down)),
        GrindingFault::Hexapod(HexapodFault::Following { error_mm: 0.025 }),
        GrindingFault::Spindle(SpindleFault::Silent { ticks: 5 }),
        GrindingFault::Spindle(SpindleFault::Speed {
            commanded_rpm: 25_000,
            measured_rpm: 12_340,
        }),
        GrindingFault::Spindle(SpindleFault::Request(SpindleError::SpeedOutOfRange)),
        GrindingFault::Spindle(SpindleFault::Link(LinkError::Busy)),
        GrindingFault::BiasDrift(BiasDrift {
            component: 2,
            mean_n: 0.4,
            bound_n: 0.294,
        }),
        GrindingFault::Output(NonFiniteOutput { index: 1 }),
    ];
    let codes: Vec<u16> = faults.iter().map(|f| G::fault_code(f).0).collect();
    assert!(codes.iter().copied().eq(1..=13), "{codes:?}");
    assert!(FAULTS.iter().map(|f| f.code).eq(1..=13));
    // The device faults: the GCS code and the silent ticks in the detail.
    let (code, detail) = G::fault_code(&faults[3]);
    assert!(FAULTS[usize::from(code) - 1].words.contains("GCS error"));
    assert_eq!(detail, 7);
    let (code, detail) = G::fault_code(&faults[7]);
    assert!(FAULTS[usize::from(code) - 1]
        .words
        .contains("stopped answering"));
    assert_eq!(detail, 5);
    assert_eq!(G::fault_code(&faults[6]).1, 25);
    assert_eq!(G::fault_code(&faults[8]).1, 1234);
    assert_eq!(G::fault_code(&faults[0]).1, 4);
    for (e, code) in [
        (GrindingJobError::NotCalibrated, 1),
        (GrindingJobError::Field("normal_force_n"), 2),
        (GrindingJobError::Field("feed_m_s"), 3),
        (GrindingJobError::Field("length_m"), 4),
        (GrindingJobError::Field("spindle_rpm"), 5),
        (GrindingJobError::Field("law"), 6),
    ] {
        assert_eq!(G::job_error_code(&e), code);
        assert!(CodeWords::find(&JOB_REFUSALS, code).is_some());
    }
    crate::app::host_link::test_support::assert_code_tables(&FAULTS, &JOB_REFUSALS);
}

/// The description: nine channels, G-code jobs, eleven settings with their units.
#[test]
fn the_cell_describes_itself() {
    let (settings, count) =
        crate::app::host_link::test_support::described::<G>(&GrindingSettings::CELL);
    assert_eq!(settings.len(), 11, "{settings:?}");
    assert!(settings.contains(&String::from("/pid/kp [nm/N] finite")));
    assert!(settings.contains(&String::from("/pid/anti_windup [1/s] 0 to 1000")));
    assert!(settings.contains(&String::from("/adrc/eso_bandwidth [rad/s] > 0 and ≤ 1000")));
    assert_eq!(
        count,
        CHANNELS.len() + 1 + 11 + FAULTS.len() + JOB_REFUSALS.len()
    );
    let mut path = SettingText::default();
    assert_eq!(
        describe::<G>(CHANNELS.len() as u16, &GrindingSettings::CELL, &mut path),
        Some(Description::JobKind(JobKind::Gcode))
    );
}

/// A sample carries the forces, the piezo, the feed, the spindle, in the channels'
/// order.
#[test]
fn a_sample_has_a_value_per_channel() {
    use super::super::GrindingOutputs;
    use crate::sensing::force::LocalForces;
    let t = GrindingTelemetry::<f64> {
        forces: LocalForces {
            tangential_n: 2.5,
            normal_n: 7.25,
        },
        reference_n: 7.5,
        outputs: GrindingOutputs {
            piezo_m: 3e-6,
            hexapod_feed_m_s: 1e-4,
            spindle_rpm: 25_000.0,
        },
        piezo_velocity_m_s: -2e-6,
        feed_exceeded: true,
        fed_m: 4e-4,
    };
    let mut values = ChannelValues::new();
    G::sample(&t, &mut values);
    assert_eq!(values.len(), CHANNELS.len());
    let at = |name: &str| values[CHANNELS.iter().position(|c| c.name == name).unwrap()];
    assert_eq!(
        (
            at("normal_force"),
            at("force_reference"),
            at("tangential_force")
        ),
        (7.25, 7.5, 2.5)
    );
    assert_eq!((at("piezo"), at("piezo_velocity")), (3e-6, -2e-6));
    assert_eq!(
        (at("feed"), at("fed"), at("spindle")),
        (1e-4, 4e-4, 25_000.0)
    );
    assert_eq!(at("feed_exceeded"), 1.0);
}

/// A pass read from G-code takes its law and force from the pass it is given (here
/// not the cell's), its length, feed and spindle from the program; a refusal names
/// the 1-based line that caused it (0: the whole program).
#[test]
fn a_pass_takes_its_law_from_the_pass_and_a_refusal_names_its_line() {
    use super::super::product::{load_pass, PassError, PassErrorKind};
    use super::super::ForceLawKind;
    let pass = GrindingPass {
        law: ForceLawKind::Adrc,
        normal_force_n: 3.0,
    };
    // 0.2 + 0.3 mm at F12 mm/min (0.2 mm/s), the spindle at 1000 rpm.
    let job = load_pass(&pass, b"G91\nM3 S1000\nG1 X0.2 F12\nX0.3\nM5\n").unwrap();
    assert_eq!((job.law, job.normal_force_n), (ForceLawKind::Adrc, 3.0));
    assert!((job.length_m - 0.5e-3).abs() < 1e-15, "{job:?}");
    assert!((job.feed_m_s - 0.2e-3).abs() < 1e-16, "{job:?}");
    assert_eq!(job.spindle_rpm, 1000.0);
    let refused = |text: &str| load_pass(&pass, text.as_bytes()).unwrap_err();
    let at = |line, kind| PassError { line, kind };
    assert_eq!(
        refused("G1 X1 F6\nG1 X2\nG1 X3 Y1\n"),
        at(3, PassErrorKind::OffAxis)
    );
    assert_eq!(
        refused("G1 X1 F6\nG1 X0.5\n"),
        at(2, PassErrorKind::Backward)
    );
    assert_eq!(refused("G21\n\nG0 X1\n"), at(3, PassErrorKind::Rapid));
    assert_eq!(refused("G21\nM3 S100\n"), at(0, PassErrorKind::Empty));
    let e = refused("G1 X1 F6\nG1 X2 Q3\n");
    assert!(
        matches!(e, PassError { line: 2, kind: PassErrorKind::Gcode(g) } if g.line == 2),
        "{e:?}"
    );
}

/// The devices tick every whole number of control periods: G's 10 ms tick over the
/// cell's 1 ms period.
#[test]
fn the_device_tick_is_ten_control_periods() {
    use super::super::product::{device_tick_periods, DEVICES, PERIOD_S};
    let n = device_tick_periods();
    assert_eq!(n, 10);
    assert!((f64::from(n) * PERIOD_S - DEVICES.tick_s).abs() < 1e-15);
}
