//! The remaining public functions no other test called: parsers' small helpers,
//! conversions into the target scalar, a job's start and period, the scenarios'
//! figures; each against what its documentation says, computed here another way.

use host_tests::arrow::job_from_gcode;
use kerf::codec::gcs::{parse_number, Axis, GcsError, MAX_NUMBER_LEN};
use kerf::codec::{is_supported_n, SUPPORTED_N};
use kerf::kinematics::arrow::{ArrowConfig, ArrowGeometry, Pose};
use kerf::machines::arrow::job::{split_pose, ArrowJobConfig};
use kerf::trajectory::efd::Efd;
use kerf::trajectory::open_path::OpenPath;
use kerf::trajectory::task_spline::{KnotSpacing, TaskSpline, TaskSplineConfig};
use kerf_sim::contour::ContourMeter;
use kerf_sim::remote::{Recording, RecordingHeader, RecordingWriter};
use kerf_sim::slave::SlaveScenario;

#[test]
fn axis_letters_name_their_axes_in_either_case() {
    for (i, letter) in [b'X', b'Y', b'Z', b'U', b'V', b'W'].into_iter().enumerate() {
        for byte in [letter, letter.to_ascii_lowercase()] {
            let axis = Axis::from_name(byte).unwrap();
            assert_eq!((axis.index(), axis.name()), (i, letter));
        }
    }
    for byte in [b'A', b'x' + 3, b'1', b' ', 0xff] {
        assert_eq!(Axis::from_name(byte), Err(GcsError::UnknownAxis(byte)));
    }
}

/// Every form the grammar admits parses to Rust's own reading of the text; every
/// other form, an overflow or an over-long token is refused with its reason.
#[test]
fn gcs_numbers_parse_as_written_and_nothing_else() {
    for text in [
        "0",
        "-0",
        "+12",
        "3.",
        ".5",
        "-.5",
        "1.25e3",
        "1E-3",
        "2e+2",
        "123456789.123456789",
    ] {
        let expected: f64 = text.parse().unwrap();
        assert_eq!(parse_number(text.as_bytes()), Ok(expected), "{text}");
    }
    for text in [
        "", "+", ".", "1..2", "1e", "1e+", "e5", "1.2.3", "0x10", "1,5", "nan", "inf", " 1", "--1",
    ] {
        assert_eq!(
            parse_number(text.as_bytes()),
            Err(GcsError::MalformedNumber),
            "{text}"
        );
    }
    assert_eq!(parse_number(b"1e400"), Err(GcsError::NotFinite));
    let long = "1".repeat(MAX_NUMBER_LEN + 1);
    assert_eq!(parse_number(long.as_bytes()), Err(GcsError::TooLong));
    let longest = "1".repeat(MAX_NUMBER_LEN);
    assert!(parse_number(longest.as_bytes()).is_ok());
}

#[test]
fn supported_block_lengths_are_exactly_the_listed_ones() {
    for n in 0..=256 {
        assert_eq!(is_supported_n(n), SUPPORTED_N.contains(&n), "{n}");
    }
}

/// A task point (x, y, z, A = θx, B = θz) splits into the plate pose (x, y, z, θz)
/// and the table angle θx; a job's start is the IK of its first point and its period
/// the configured one.
#[test]
fn an_arrow_job_starts_where_its_program_does() {
    let p = kerf::trajectory::task_spline::Pose::<f64>::from([1.0, 2.0, 3.0, 0.4, 0.5]);
    assert_eq!(split_pose(&p), (Pose::new(1.0, 2.0, 3.0, 0.5), 0.4));
    let job = job_from_gcode("G21 G90\nG0 X10 Y520 Z5 A0.1 B2\nG1 X20 Y500 Z0 F600\n").unwrap();
    let geometry = ArrowGeometry::<f64>::new(&ArrowConfig::ARROW).unwrap();
    let (start, theta_x) = job.start();
    let b = 2f64.to_radians();
    assert!(
        (start - Pose::new(0.010, 0.520, 0.005, b)).amax() < 1e-12,
        "{start:?}"
    );
    assert!((theta_x - 0.1f64.to_radians()).abs() < 1e-12);
    let joints = geometry.inverse(&start).unwrap();
    assert!((job.start_joints_m() - joints).amax() < 1e-12);
    assert_eq!(job.period_s(), ArrowJobConfig::ARROW.period_s);
}

#[test]
fn a_task_spline_keeps_its_knot_spacing() {
    let points = [
        [0.0, 0.5, 0.0, 0.0, 0.0],
        [0.01, 0.5, 0.0, 0.0, 0.0],
        [0.01, 0.51, 0.002, 0.0, 0.1],
    ]
    .map(kerf::trajectory::task_spline::Pose::<f64>::from);
    for spacing in [KnotSpacing::Centripetal, KnotSpacing::ChordLength] {
        let config = TaskSplineConfig {
            knots: spacing,
            angle_length_m_per_rad: 0.01,
        };
        let spline = TaskSpline::<f64, 8>::through(&points, &config).unwrap();
        assert_eq!(spline.spacing(), spacing);
    }
}

/// The conversion into f32 in place: every coefficient and the centre rounded once
/// (what `as f32` gives), the harmonics kept; a value f32 cannot hold is refused.
#[test]
fn curves_convert_into_the_target_scalar_in_place() {
    let square = [[0.0, 0.0], [0.01, 0.0], [0.01, 0.008], [0.0, 0.008]];
    let efd = Efd::<f64, 8>::from_polygon(&square, 6).unwrap();
    let mut f32_efd = Efd::<f32, 8>::empty();
    assert_eq!((f32_efd.harmonics(), f32_efd.centre().x), (0, 0.0));
    assert!(f32_efd.coefficients().iter().all(|c| *c == [0.0; 4]));
    f32_efd.assign_f64(&efd).unwrap();
    assert_eq!(f32_efd.harmonics(), efd.harmonics());
    assert_eq!(f32_efd.centre().x, efd.centre().x as f32);
    assert_eq!(f32_efd.centre().y, efd.centre().y as f32);
    for (a, b) in f32_efd.coefficients().iter().zip(efd.coefficients()) {
        assert_eq!(*a, b.map(|v| v as f32));
    }
    let huge = [[0.0, 0.0], [1e39, 0.0], [1e39, 1e39], [0.0, 1e39]];
    let far = Efd::<f64, 8>::from_polygon(&huge, 2).unwrap();
    assert!(f32_efd.assign_f64(&far).is_err());

    let path =
        OpenPath::<f64, 8>::from_points(&[[0.0, 0.0], [0.004, 0.001], [0.009, -0.002]]).unwrap();
    let mut f32_path = OpenPath::<f32, 8>::empty();
    assert_eq!(f32_path.points(), 0);
    f32_path.assign_f64(&path).unwrap();
    assert_eq!(f32_path.points(), 3);
    assert_eq!(f32_path.centre().x, path.centre().x as f32);
    assert_eq!(f32_path.centre().y, path.centre().y as f32);
    let ratio = f64::from(f32_path.chord_length_m()) / path.chord_length_m();
    assert!((ratio - 1.0).abs() < 1e-6, "{ratio}");
    let far = OpenPath::<f64, 8>::from_points(&[[0.0, 0.0], [1e39, 0.0], [1e39, 1e39]]).unwrap();
    assert!(f32_path.assign_f64(&far).is_err());
}

/// The meter's RMS over the periods it measured: with the reference on the x axis
/// and the effector beside it, each measured period's contour error is the effector's
/// |y| (the window's middle sample), so the RMS is that of the measured samples' y.
#[test]
fn contour_meter_rms_is_the_rms_of_the_normal_offsets() {
    const W: usize = 5;
    let mut meter = ContourMeter::<W>::new();
    assert_eq!(meter.rms_m(), 0.0);
    let offset = |k: usize| 1e-6 * ((k as f64) * 0.9).sin();
    let n = 40;
    for k in 0..n {
        let x = k as f64 * 1e-4;
        meter.push([x, 0.0], [x, offset(k)]);
    }
    // Full from the W-th sample on: samples W/2 .. n − 1 − W/2 are measured.
    let measured: Vec<f64> = (W / 2..n - W / 2).map(offset).collect();
    let expected = (measured.iter().map(|y| y * y).sum::<f64>() / measured.len() as f64).sqrt();
    assert!(
        (meter.rms_m() - expected).abs() < 1e-12 * expected,
        "{} {expected}",
        meter.rms_m()
    );
}

/// Each recorded tick finds its position; a tick between, before or after them none.
#[test]
fn a_recording_finds_each_reference_by_its_tick() {
    let header = RecordingHeader {
        m: 8,
        samples_per_command: 10,
        margin_periods: 20,
        start_m: [0.0, 0.0, 0.2],
        laser_power_w: 1.0,
        approach_s: 0.3,
        periods: 100,
        measure_from: 10,
    };
    let mut writer = RecordingWriter::new(header);
    let ticks: Vec<u32> = (0..37).map(|i| 5 + 3 * i).collect();
    for &t in &ticks {
        assert!(writer.reference(t, [t as f32, -(t as f32), 0.5]));
    }
    let bytes = writer.finish();
    let recording = Recording::parse(&bytes).unwrap();
    for t in 0..ticks.last().unwrap() + 5 {
        let expected = ticks.contains(&t).then(|| [t as f32, -(t as f32), 0.5]);
        assert_eq!(recording.reference_m(t), expected, "{t}");
    }
}

/// The square job lasts its approach and four sides.
#[test]
fn the_square_lasts_its_approach_and_four_sides() {
    let square = SlaveScenario::square();
    assert!((square.job_s() - (square.approach_s + 4.0 * square.side_s)).abs() < 1e-15);
    let longer = SlaveScenario {
        side_s: 1.25,
        approach_s: 0.5,
        ..square
    };
    assert!((longer.job_s() - 5.5).abs() < 1e-15);
}

/// A run is called hung only past what it has to do: the calibration sweep (its own
/// period count, from the machine's pitch and period) and the job's periods, for
/// every preset, with and without calibration, and for a job of a single period too
/// (where no multiple of the job's length alone leaves room for the sweep).
#[test]
fn the_period_limit_leaves_room_for_the_calibration_and_the_job() {
    use kerf::app::calibrate::CalibrationSweep;
    use kerf_sim::scenario::{Scenario, START_M};
    for preset in [Scenario::TRACKING, Scenario::keops_joint()] {
        let machine = &preset.machine;
        let sweep =
            CalibrationSweep::<f64, 1>::new([START_M], machine.hall[0].pitch_m, machine.period_s)
                .unwrap();
        for (calibrate, periods) in [(true, preset.periods), (false, preset.periods), (true, 1)] {
            let s = Scenario {
                calibrate,
                periods,
                ..preset
            };
            let needed = sweep.periods() + periods;
            assert!(
                s.period_limit() > needed,
                "{} against {needed}",
                s.period_limit()
            );
        }
    }
}

/// The octagon job carries the law it was asked for and starts where the module docs
/// put it: at the cutting height, on the ±6 mm octagon (within 0.1 mm of its first
/// vertex, where the 30-harmonic fit's θ = 0 lies, Gibbs-rounded at the corner);
/// more harmonics than a contour holds are a contour error, not a panic.
#[test]
fn the_octagon_job_is_the_octagon_under_the_law_asked() {
    use kerf::machines::delta_slave::product::CUT_HEIGHT_M;
    use kerf::machines::delta_slave::{
        ContourLaw, DeltaJobError, DeltaSlaveConfig, CONTOUR_HARMONICS,
    };
    use kerf::trajectory::shapes::octagon;
    use kerf_sim::contour::octagon_job;
    let machine = DeltaSlaveConfig::KEOPS;
    let vertex = octagon()[0].map(|c| 0.6 * c);
    for law in [ContourLaw::Contouring, ContourLaw::Preview] {
        let job = octagon_job(&machine, 1.0, 30, law).unwrap();
        assert_eq!(job.contour_law(), Some(law));
        let start = job.start_m();
        assert_eq!(start[2], CUT_HEIGHT_M);
        let off = (start[0] - vertex[0]).hypot(start[1] - vertex[1]);
        assert!(off < 1e-4, "{start:?} against {vertex:?}");
    }
    assert!(matches!(
        octagon_job(&machine, 1.0, CONTOUR_HARMONICS + 1, ContourLaw::Contouring),
        Err(DeltaJobError::Contour(_))
    ));
}

/// Unpowered, every carriage of the slave slides down its rail onto its lower end
/// stop (the plant's: [`END_STOP_INSET_M`] inside the travel's lower end) and stays;
/// given a single period it is still moving: a timeout.
#[test]
fn unpowered_carriages_come_to_rest_on_their_lower_end_stops() {
    use hal_mock::delta_plant::END_STOP_INSET_M;
    use kerf_sim::slave::{rest_unpowered, SlaveError};
    let scenario = SlaveScenario::square();
    let rest = rest_unpowered(&scenario, 1.0).unwrap();
    for (q, actuator) in rest.iter().zip(scenario.machine.delta.actuators) {
        assert!(
            (q - (actuator.travel_min_m + END_STOP_INSET_M)).abs() < 1e-12,
            "{rest:?}"
        );
    }
    let period = scenario.machine.joints.period_s;
    assert!(matches!(
        rest_unpowered(&scenario, period),
        Err(SlaveError::Timeout)
    ));
}
