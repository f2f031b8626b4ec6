use super::*;
use crate::app::host_link::{describe, SettingText};
use crate::codec::job::{write_efd, write_gcode};
use crate::codec::link::Description;
use miniconf::json_core;
use std::format;
use std::string::String;
use std::vec::Vec;

type A = Arrow<f64>;

/// The pyramid of A fig. 26–27, as the image and the host tests run it.
const PYRAMID: &str = include_str!("../../../../../../data/pyramid.gcode");

fn job_file(gcode: &[u8]) -> Vec<u8> {
    let mut out = std::vec![0u8; gcode.len() + 64];
    let n = write_gcode(gcode, &mut out).unwrap();
    out.truncate(n);
    out
}

fn load(bytes: &[u8]) -> Result<std::boxed::Box<Job<f64>>, u16> {
    let file = JobFile::read(bytes).unwrap();
    let mut job = std::boxed::Box::<Job<f64>>::default();
    <A as LinkMachine>::load_job(&mut (), &file, &mut job).map(|()| job)
}

/// The presets' settings give back the presets, and their law is the product's.
#[test]
fn the_settings_of_the_presets_are_the_presets() {
    let s = ArrowSettings::ARROW;
    assert_eq!(s.parallel(), RedundantPidConfig::ARROW_PARALLEL);
    assert_eq!(s.turntable(), RedundantPidConfig::ARROW_TURNTABLE);
    let from_settings = A::coefficients(&s, 2e-4).unwrap();
    let preset = law::<f64>(
        &RedundantPidConfig::ARROW_PARALLEL,
        &RedundantPidConfig::ARROW_TURNTABLE,
        true,
        2e-4,
    )
    .unwrap();
    assert_eq!(from_settings, preset);
}

/// A setting is validated as the law is and named by its part.
#[test]
fn a_bad_gain_is_refused_by_its_path() {
    let mut s = ArrowSettings::ARROW;
    json_core::set(&mut s, "/turntable/kd", b"-1").unwrap();
    let e = A::coefficients(&s, 2e-4).unwrap_err();
    assert_eq!(format!("{e}").split(':').next(), Some("turntable.kd"));
    let mut s = ArrowSettings::ARROW;
    json_core::set(&mut s, "/parallel/kp", b"0").unwrap();
    assert_eq!(A::coefficients(&s, 2e-4).unwrap_err().field(), "kp");
    // In f32, a gain whose K_D/Ts passes f32's range is refused, not carried as inf.
    let mut s = ArrowSettings::ARROW;
    s.parallel.kd = 1e36;
    assert!(A::coefficients(&s, 2e-4).is_ok());
    assert!(<Arrow<f32> as LinkMachine>::coefficients(&s, 2e-4).is_err());
}

/// The pyramid's file loads into its three moves; other files are refused with the
/// code of their fault.
#[test]
fn a_gcode_job_loads_and_bad_ones_are_refused_by_code() {
    let job = load(&job_file(PYRAMID.as_bytes())).unwrap();
    assert_eq!(job.moves().len(), 3);
    let mut efd = [0u8; 128];
    let n = write_efd([0.0, 0.0], &[[1e-3, 0.0, 0.0, 1e-3]], &mut efd).unwrap();
    assert_eq!(load(&efd[..n]).unwrap_err(), load_codes::KIND);
    assert_eq!(
        load(&job_file(b"G1 X0.1 Q3\n")).unwrap_err(),
        load_codes::GCODE
    );
    assert_eq!(load(&job_file(b"G21\n")).unwrap_err(), load_codes::EMPTY);
    // Ten metres away: outside every arm's reach.
    let far = b"G21 G90\nG0 X0 Y500 Z0\nG1 X10000 Y500 Z0 F1500\n";
    assert_eq!(load(&job_file(far)).unwrap_err(), load_codes::WORKSPACE);
}

/// Every code the machine sends has its words, once; its refusals are not the link's.
#[test]
fn every_code_has_its_words() {
    let faults = [
        ArrowFault::NotFinite,
        ArrowFault::EncoderJump(7),
        ArrowFault::TrackingError(2),
        ArrowFault::Path,
        ArrowFault::Output(crate::app::supervisor::NonFiniteOutput { index: 6 }),
        ArrowFault::Drive(crate::app::drive_set::DriveFault::Silent {
            drive: 4,
            periods: 2,
        }),
    ];
    for f in &faults {
        assert!(
            CodeWords::find(&FAULTS, A::fault_code(f).0).is_some(),
            "{f:?}"
        );
    }
    assert!(FAULTS.iter().map(|f| f.code).eq(1..=7));
    let (code, detail) = A::fault_code(&ArrowFault::TrackingError(2));
    let entry = CodeWords::find(&FAULTS, code).unwrap();
    assert!(entry.words.contains("tracking limit"));
    assert_eq!((entry.detail, detail), (ENCODER, 2));
    for r in [
        ArrowJobRefusal::Empty,
        ArrowJobRefusal::WrongPeriod,
        ArrowJobRefusal::NotAtStart(1),
        ArrowJobRefusal::NoReading,
    ] {
        assert!(CodeWords::find(&JOB_REFUSALS, A::job_error_code(&r)).is_some());
    }
    crate::app::host_link::test_support::assert_code_tables(&FAULTS, &JOB_REFUSALS);
}

/// The description: sixteen channels, G-code jobs, eleven settings with their units.
#[test]
fn arrow_describes_itself() {
    let (settings, count) =
        crate::app::host_link::test_support::described::<A>(&ArrowSettings::ARROW);
    assert_eq!(settings.len(), 11, "{settings:?}");
    assert!(settings.contains(&String::from("/turntable/kp [N·m/rad] > 0")));
    assert!(settings.contains(&String::from("/feedforward [] true or false")));
    assert_eq!(
        count,
        CHANNELS.len() + 1 + 11 + FAULTS.len() + JOB_REFUSALS.len()
    );
    let mut path = SettingText::default();
    assert_eq!(
        describe::<A>(CHANNELS.len() as u16, &ArrowSettings::ARROW, &mut path),
        Some(Description::JobKind(JobKind::Gcode))
    );
}

/// A sample carries the desired pose, the largest joint error by magnitude, the
/// commands and the move, in the channels' order.
#[test]
fn a_sample_has_a_value_per_channel() {
    use crate::kinematics::arrow::{ActuatorVector, Pose};
    use crate::machines::arrow::machine::ArrowOutputs;
    let t = ArrowTelemetry::<f64> {
        move_index: 2,
        desired: Pose::new(0.1, 0.5, -0.02, 0.3),
        theta_x_rad: 0.25,
        joint_error_m: ActuatorVector::from_column_slice(&[1e-6, -4e-6, 2e-6, 0.0, 0.0, 3e-6]),
        table_error_rad: -1e-4,
        outputs: ArrowOutputs {
            forces_n: ActuatorVector::from_column_slice(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
            torques_n_m: [7.0, 8.0],
        },
        saturated: false,
    };
    let mut values = ChannelValues::new();
    A::sample(&t, &mut values);
    assert_eq!(values.len(), CHANNELS.len());
    let at = |name: &str| values[CHANNELS.iter().position(|c| c.name == name).unwrap()];
    assert_eq!(
        (at("y_ref"), at("theta_z_ref"), at("theta_x_ref")),
        (0.5, 0.3, 0.25)
    );
    assert_eq!(at("joint_error"), 4e-6);
    assert_eq!((at("force6"), at("torque2"), at("move")), (6.0, 8.0, 2.0));
}
