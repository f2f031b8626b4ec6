use super::super::product::{config, sample_contour, session, LINK_JOB_BYTES};
use super::super::RemoteMaster;
use super::*;
use crate::app::host_link::{describe, HostLink, HostLinkConfig, SettingText};
use crate::app::jobs::JobSlots;
use crate::app::supervisor::{Command, Machine};
use crate::codec::job::{write_gcode, write_points};
use crate::codec::link::{
    decode, encode, Description, HostFrame, MachineMessage, Refusal, Reply, Request,
    LINK_JOB_REFUSALS, MAX_FRAME,
};
use heapless::spsc::Queue;
use std::format;
use std::string::String;
use std::vec::Vec;

type M = Master<f64>;

/// The product's sample contour.
fn contour() -> Vec<[f64; 2]> {
    sample_contour().unwrap().to_vec()
}

fn points_file(points: &[[f64; 2]]) -> Vec<u8> {
    let mut out = std::vec![0u8; 16 + 8 * points.len()];
    let n = write_points(points, &mut out).unwrap();
    out.truncate(n);
    out
}

fn load(bytes: &[u8]) -> Result<FixtureJob<f64>, u16> {
    let file = JobFile::read(bytes).unwrap();
    let mut job = FixtureJob::default();
    <M as LinkMachine>::load_job(&mut session().unwrap(), &file, &mut job).map(|()| job)
}

/// The words of a refusal code: the machine's table, else the link's.
fn refusal_words(code: u16) -> &'static str {
    CodeWords::find(&JOB_REFUSALS, code)
        .or_else(|| CodeWords::find(&LINK_JOB_REFUSALS, code))
        .map_or("", |c| c.words)
}

/// The settings give back the product's fixture, and its coefficients.
#[test]
fn the_settings_of_the_master_are_its_fixture() {
    let s = MasterSettings::MASTER;
    assert_eq!(s.fixture(), FIXTURE);
    assert_eq!(config().unwrap().fixture, FIXTURE);
    let from_settings = M::coefficients(&s, PERIOD_S).unwrap();
    assert_eq!(from_settings, Fixture::new(&FIXTURE).unwrap());
}

/// The product's contour loads and the master takes it; a G-code job, too many or
/// too few points, a repeated point are refused with their codes, in words.
#[test]
fn a_contour_loads_and_the_wrong_kind_is_refused_in_words() {
    let points = contour();
    let job = load(&points_file(&points)).unwrap();
    let master = RemoteMaster::<f64>::new(&config().unwrap()).unwrap();
    assert!(master.check_job(&job).is_ok());

    let mut gcode = [0u8; 64];
    let n = write_gcode(b"G1 X1 F6\n", &mut gcode).unwrap();
    let code = load(&gcode[..n]).unwrap_err();
    assert_eq!(code, load_codes::KIND);
    assert_eq!(
        refusal_words(code),
        "this master takes contours as points only"
    );

    let mut many = points.clone();
    many.push([0.0, 0.0]);
    assert_eq!(load(&points_file(&many)).unwrap_err(), load_codes::TOO_MANY);
    assert_eq!(
        load(&points_file(&points[..10])).unwrap_err(),
        load_codes::TOO_FEW
    );
    let mut repeated = points.clone();
    repeated[5] = repeated[4];
    assert_eq!(
        load(&points_file(&repeated)).unwrap_err(),
        load_codes::REPEATED
    );
    // A closed contour written with its first point again at the end.
    let mut closed = points[..100].to_vec();
    closed.push(points[0]);
    assert_eq!(
        load(&points_file(&closed)).unwrap_err(),
        load_codes::REPEATED
    );
    // The empty default job, refused by the master's check.
    let e = master.check_job(&FixtureJob::default()).unwrap_err();
    assert_eq!(
        refusal_words(M::job_error_code(&e)),
        "the job has no contour"
    );
}

/// What the host got back at once for one request: the replies' debug forms (a
/// command queued is answered when the machine reports it carried out).
fn exchange(
    link: &mut HostLink<'_, M, LINK_JOB_BYTES>,
    commands: &mut heapless::spsc::Producer<'_, Command<M>>,
    request: Request<'_>,
) -> Vec<String> {
    let mut bytes = [0u8; MAX_FRAME];
    let n = encode(&HostFrame { seq: 9, request }, &mut bytes).unwrap();
    let mut replies = Vec::new();
    for &b in &bytes[..n] {
        link.receive(b, 0.0, commands, &mut |f| {
            let mut raw = f[1..f.len() - 1].to_vec();
            if let Ok(MachineMessage::Reply { reply, .. }) = decode::<MachineMessage>(&mut raw) {
                replies.push(format!("{reply:?}"));
            }
            true
        });
    }
    replies
}

/// An unknown path and a value out of the announced range are refused, and neither
/// changes the settings nor reaches the machine; a good value does both.
#[test]
fn a_bad_setting_is_refused_and_changes_nothing() {
    let jobs = JobSlots::default();
    let mut queue = Queue::<Command<M>, 4>::new();
    let (mut commands, mut machine) = queue.split();
    let config = HostLinkConfig {
        period_s: PERIOD_S,
        heartbeat_timeout_s: 0.5,
    };
    let mut link = HostLink::<M, LINK_JOB_BYTES>::new(
        &config,
        MasterSettings::MASTER,
        session().unwrap(),
        &jobs,
    )
    .unwrap();
    let refused = |r: Refusal| format!("{:?}", Reply::Refused(r));
    for (path, value, why) in [
        ("/fixture/normal/stiffness", "1", Refusal::UnknownPath),
        ("/fixture/lateral/reaching_rate", "1", Refusal::UnknownPath),
        ("/fixture/normal/reaching_rate", "0", Refusal::BadValue),
        ("/fixture/vertical/surface_slope", "-5", Refusal::BadValue),
        ("/fixture/normal/reaching_rate", "true", Refusal::BadValue),
    ] {
        let request = Request::Set {
            path,
            value: value.as_bytes(),
        };
        let got = exchange(&mut link, &mut commands, request);
        assert_eq!(got, [refused(why)], "{path} = {value}");
        assert_eq!(*link.settings(), MasterSettings::MASTER, "{path} = {value}");
        assert!(machine.dequeue().is_none(), "{path} = {value}");
    }
    let request = Request::Set {
        path: "/fixture/normal/reaching_rate",
        value: b"400",
    };
    assert!(exchange(&mut link, &mut commands, request).is_empty());
    assert_eq!(link.settings().fixture.normal.reaching_rate, 400.0);
    let Some(Command::ChangeSettings(fixture)) = machine.dequeue() else {
        panic!("no settings reached the machine");
    };
    let mut expected = FIXTURE;
    expected.normal.reaching_rate_per_s = 400.0;
    assert_eq!(fixture, Fixture::new(&expected).unwrap());
}

/// A rate whose product passes f32's range is refused in f32, named by its row.
#[test]
fn a_rate_the_scalar_cannot_carry_is_refused_by_its_row() {
    let mut s = MasterSettings::MASTER;
    s.fixture.vertical.reaching_rate = 1e37;
    assert!(M::coefficients(&s, PERIOD_S).is_ok());
    let e = <Master<f32> as LinkMachine>::coefficients(&s, PERIOD_S).unwrap_err();
    assert!(format!("{e}").starts_with("fixture.vertical"), "{e}");
}

/// Every fault the master has is sent with its code and detail, and has its words,
/// once; its refusals are not the link's.
#[test]
fn every_fault_is_told_in_words() {
    let faults = [
        RemoteMasterFault::Encoder {
            axis: 2,
            fault: EncoderFault::Jump { counts: 900 },
        },
        RemoteMasterFault::Encoder {
            axis: 1,
            fault: EncoderFault::OutOfRange,
        },
        RemoteMasterFault::Kinematics(crate::kinematics::delta::KinematicsError::NotFinite),
        RemoteMasterFault::Constraint(ContourError::FarFromContour),
        RemoteMasterFault::Fixture(crate::control::constraint::FixtureError::SingularConstraint),
        RemoteMasterFault::NotFinite,
    ];
    let codes: Vec<u16> = faults.iter().map(|f| M::fault_code(f).0).collect();
    assert!(codes.iter().copied().eq(1..=6), "{codes:?}");
    assert!(FAULTS.iter().map(|f| f.code).eq(1..=6));
    let (code, detail) = M::fault_code(&faults[0]);
    let told = CodeWords::find(&FAULTS, code).unwrap();
    assert_eq!(
        (told.words, told.detail, detail),
        (
            "an encoder count jumped farther than the carriage can move in a period",
            "carriage",
            2
        )
    );
    assert_eq!(M::fault_code(&faults[1]), (2, 1));
    for (e, code) in [
        (FixtureJobError::NoContour, 1),
        (FixtureJobError::NotFinite, 2),
    ] {
        assert_eq!(M::job_error_code(&e), code);
    }
    crate::app::host_link::test_support::assert_code_tables(&FAULTS, &JOB_REFUSALS);
}

/// The description: sixteen channels, points jobs, four settings with their units.
#[test]
fn the_master_describes_itself() {
    let (settings, count) =
        crate::app::host_link::test_support::described::<M>(&MasterSettings::MASTER);
    assert_eq!(
        settings,
        [
            "/fixture/normal/surface_slope [1/s] > 0",
            "/fixture/normal/reaching_rate [1/s] > 0",
            "/fixture/vertical/surface_slope [1/s] > 0",
            "/fixture/vertical/reaching_rate [1/s] > 0",
        ]
    );
    assert_eq!(
        count,
        CHANNELS.len() + 1 + 4 + FAULTS.len() + JOB_REFUSALS.len()
    );
    let mut path = SettingText::default();
    assert_eq!(
        describe::<M>(CHANNELS.len() as u16, &MasterSettings::MASTER, &mut path),
        Some(Description::JobKind(JobKind::Points))
    );
}

/// A sample carries the telemetry in the channels' order; the slave is NaN before
/// the first report.
#[test]
fn a_sample_has_a_value_per_channel() {
    let t = MasterTelemetry::<f64> {
        effector_m: [0.1, -0.02, 0.3],
        velocity_m_s: [0.003, 0.004, 0.0],
        constraint_m: [2e-6, -1e-6],
        force_n: [1.5, -0.25, 0.5],
        haptic_n: 0.75,
        slave_estimate_m: Some([0.01, 0.02, -0.2]),
        tracking_error_m: [3e-6, 0.0, 4e-6],
        laser_on: true,
        round_trip_periods: 400,
        rejected_reports: 0,
    };
    let mut values = ChannelValues::new();
    M::sample(&t, &mut values);
    assert_eq!(values.len(), CHANNELS.len());
    let at = |values: &ChannelValues, name: &str| {
        values[CHANNELS.iter().position(|c| c.name == name).unwrap()]
    };
    assert_eq!(
        (at(&values, "x"), at(&values, "y"), at(&values, "z")),
        (0.1, -0.02, 0.3)
    );
    assert_eq!(at(&values, "speed"), 0.005);
    assert_eq!(
        (at(&values, "error"), at(&values, "height_error")),
        (2e-6, -1e-6)
    );
    assert_eq!(
        (
            at(&values, "force1"),
            at(&values, "force2"),
            at(&values, "force3"),
            at(&values, "haptic")
        ),
        (1.5, -0.25, 0.5, 0.75)
    );
    assert_eq!(
        (
            at(&values, "slave_x"),
            at(&values, "slave_y"),
            at(&values, "slave_z")
        ),
        (0.01, 0.02, -0.2)
    );
    assert_eq!(at(&values, "tracking_error"), 5e-6);
    assert_eq!(at(&values, "beam"), 1.0);
    assert_eq!(at(&values, "round_trip"), 0.04);
    let unknown = MasterTelemetry {
        slave_estimate_m: None,
        ..t
    };
    M::sample(&unknown, &mut values);
    assert!(at(&values, "slave_x").is_nan());
}

/// The rest point is where the master's carriages at their homing stops put the
/// effector: the inverse kinematics of it gives back [`HOME_M`](super::super::product::HOME_M).
#[test]
fn the_rest_point_is_the_effector_at_home() {
    use super::super::product::{rest_point, HOME_M};
    use crate::kinematics::delta::{DeltaConfig, DeltaGeometry};
    use crate::kinematics::Vector3;
    let geometry = DeltaGeometry::<f64>::new(&DeltaConfig::MASTER_HORIZONTAL).unwrap();
    let q = geometry
        .inverse(&Vector3::from(rest_point().unwrap()))
        .unwrap();
    for (axis, (q, home)) in q.iter().zip(HOME_M).enumerate() {
        // The closed forms of both directions agree to rounding on 0.07 m.
        assert!((q - home).abs() < 1e-12, "carriage {axis}: {q} vs {home}");
    }
}

/// A fixture job takes its points from the file and its height, beam and windows from
/// the session (here not the product's); another kind of file, more points than the
/// master holds and a contour the fixture refuses are told apart.
#[test]
fn a_fixture_loads_from_points_and_the_session() {
    use super::super::product::{
        load_fixture, rest_point, FixtureLoadError, FixtureSession, SAMPLE_SEMI_AXES_M,
    };
    use crate::trajectory::constraint::ConstraintConfig;
    let session = FixtureSession {
        constraint: ConstraintConfig::closed_contour(),
        z_m: 0.0123,
        laser_on: false,
    };
    let read = |bytes: &[u8]| load_fixture::<f64>(&session, &JobFile::read(bytes).unwrap());
    let points = contour();
    let job = read(&points_file(&points)).unwrap();
    assert_eq!((job.z_m, job.laser_on), (0.0123, false));
    // The points are the sample ellipse's, evenly spaced in its angle from the rest
    // point (its rightmost): their centroid is the ellipse's centre, one semi-axis
    // left of the rest point. The file holds f32: each coordinate within half an
    // ulp of its value (< 1e-9 m below 32 mm), and so is their mean.
    let [x0, y0, _] = rest_point().unwrap();
    let origin = job.constraint.as_ref().unwrap().origin();
    assert!(
        (origin.x - (x0 - SAMPLE_SEMI_AXES_M[0])).abs() < 1e-9,
        "{origin}"
    );
    assert!((origin.y - y0).abs() < 1e-9, "{origin}");
    let mut gcode = [0u8; 64];
    let n = write_gcode(b"G1 X1 F6\n", &mut gcode).unwrap();
    assert!(matches!(read(&gcode[..n]), Err(FixtureLoadError::Kind)));
    let mut many = points.clone();
    many.push([0.0, 0.0]);
    assert!(matches!(
        read(&points_file(&many)),
        Err(FixtureLoadError::TooManyPoints)
    ));
    assert!(matches!(
        read(&points_file(&points[..10])),
        Err(FixtureLoadError::Contour(_))
    ));
}
