//! ARROW's bad input: programs the machine must refuse at load,
//! naming the line, and encoder faults during a run that must end in `Fault` with zero
//! force and torque in the same period.

use host_tests::arrow::{job_from_gcode, run_job, ArrowRunConfig, Job, JobRun};
use kerf::app::supervisor::Mode;
use kerf::kinematics::arrow::{ArrowConfig, ArrowError, ArrowGeometry};
use kerf::machines::arrow::job::{ArrowJobConfig, ArrowJobErrorKind};
use kerf::machines::arrow::machine::ArrowFault;
use kerf::trajectory::gcode::{GcodeErrorKind, GcodePoint};
use kerf_sim::arrow::PYRAMID_GCODE;

const HEAD: &str = "G21 G90\nG0 X0 Y500 Z0 A0 B0\n";

fn refusal(body: &str) -> (u32, ArrowJobErrorKind) {
    let text = format!("{HEAD}{body}");
    let e = job_from_gcode(&text).expect_err(body);
    (e.line, e.kind)
}

#[test]
fn bad_programs_are_refused_at_load_naming_the_line() {
    // An unknown word, at its column.
    let (line, kind) = refusal("G1 X10 Y500 Z0 F600\nG1 X20 Q3\n");
    assert_eq!(line, 4);
    assert!(
        matches!(
            kind,
            ArrowJobErrorKind::Gcode {
                kind: GcodeErrorKind::UnknownWord(b'Q'),
                column: 8
            }
        ),
        "{kind:?}"
    );
    // A feed move before any feed.
    let (line, kind) = refusal("G1 X10 Y500 Z0\n");
    assert_eq!(line, 3);
    assert!(
        matches!(
            kind,
            ArrowJobErrorKind::Gcode {
                kind: GcodeErrorKind::MissingFeed,
                ..
            }
        ),
        "{kind:?}"
    );
    // y = 0.7 m: 0.2 m from the workspace centre, past eq. 25's 0.15 m.
    let (line, kind) = refusal("G1 X10 Y500 Z0 F600\nG1 X10 Y520 Z0\nG1 X10 Y700 Z0\n");
    assert_eq!(line, 5);
    assert_eq!(
        kind,
        ArrowJobErrorKind::Workspace(ArrowError::OutsideWorkspace(1))
    );
    // Only the start: no move.
    let (_, kind) = refusal("");
    assert_eq!(kind, ArrowJobErrorKind::Empty);
    // A start outside the workspace is refused on the start's line.
    let e = job_from_gcode("G0 X0 Y900 Z0\nG1 X1 F600\n").unwrap_err();
    assert_eq!(
        (e.line, e.kind),
        (
            1,
            ArrowJobErrorKind::Workspace(ArrowError::OutsideWorkspace(1))
        )
    );
    // A pure turn of the table with the tool point still: the spline measures the
    // tool point alone (ρ = 0), so the move has no length.
    let (line, kind) = refusal("G1 X0 Y500 Z0 A10 F600\n");
    assert_eq!(line, 3);
    assert!(matches!(kind, ArrowJobErrorKind::Spline(_)), "{kind:?}");
}

/// On a machine configured with a workspace wider than eq. 25's (y ± 0.2 m, z ± 0.4 m),
/// a path from the centre of y = 0.6 m up to z = 0.35 m comes to the plate
/// singularity of eq. 32 (sine 0.023 there): refused on that move's line, though
/// both its ends pass the workspace limits.
#[test]
fn a_path_into_a_singularity_is_refused_naming_its_line() {
    let mut wide = ArrowConfig::ARROW;
    wide.workspace.y_half_m = 0.2;
    wide.workspace.z_half_m = 0.4;
    let geometry = ArrowGeometry::<f64>::new(&wide).unwrap();
    let text = "G21 G90\nG0 X0 Y600 Z0\nG1 X0 Y600 Z100 F600\nG1 X0 Y600 Z350\n";
    let mut points: heapless::Vec<GcodePoint, 16> = heapless::Vec::new();
    let e = Job::from_gcode(
        text.as_bytes(),
        &mut points,
        &geometry,
        &ArrowJobConfig::ARROW,
    )
    .unwrap_err();
    assert_eq!((e.line, e.kind), (4, ArrowJobErrorKind::Singular));
    // The same path stopping short of the band loads.
    let text = "G21 G90\nG0 X0 Y600 Z0\nG1 X0 Y600 Z100 F600\nG1 X0 Y600 Z150\n";
    assert!(Job::from_gcode(
        text.as_bytes(),
        &mut points,
        &geometry,
        &ArrowJobConfig::ARROW
    )
    .is_ok());
}

fn config() -> ArrowRunConfig {
    ArrowRunConfig::published(true, true, 0)
}

/// Runs the pyramid for up to 1 s with `disturb` on the encoders.
fn faulted(disturb: &mut dyn FnMut(u64, &mut hal_mock::arrow::ArrowReading)) -> JobRun {
    let job = job_from_gcode(PYRAMID_GCODE).unwrap();
    run_job(&config(), &job, 5000, disturb).unwrap()
}

fn zero(run: &JobRun) -> bool {
    run.last_outputs.forces_n.amax() == 0.0 && run.last_outputs.torques_n_m == [0.0; 2]
}

#[test]
fn encoder_faults_stop_the_machine_with_zero_force_in_the_same_period() {
    // A NaN from actuator 2's encoder in period 2000.
    let run = faulted(&mut |k, r| {
        if k == 2000 {
            r.joints_m[2] = f64::NAN;
        }
    });
    assert_eq!(run.mode, Mode::Fault(ArrowFault::NotFinite));
    assert_eq!(
        run.samples.len(),
        2000,
        "faulted in the period that read it"
    );
    assert!(zero(&run));
    // A 2 mm jump of actuator 4 (a skipped count burst), kept from period 3000 on.
    let run = faulted(&mut |k, r| {
        if k >= 3000 {
            r.joints_m[4] += 2e-3;
        }
    });
    assert_eq!(run.mode, Mode::Fault(ArrowFault::EncoderJump(4)));
    assert_eq!(run.samples.len(), 3000);
    assert!(zero(&run));
    // Table motor 2's encoder jumps a quarter turn.
    let run = faulted(&mut |k, r| {
        if k >= 1000 {
            r.turntable_rad[1] += core::f64::consts::FRAC_PI_2;
        }
    });
    assert_eq!(run.mode, Mode::Fault(ArrowFault::EncoderJump(7)));
    assert!(zero(&run));
    // Actuator 0's encoder freezes from period 1000 (a cable pulled out: no jump):
    // its reference moves on with the path while the law, seeing the error through
    // Rm, moves the plate to spread it over all six joints, until one of them is
    // 2 mm off (joint 5, the first there) and the tracking limit trips.
    let mut frozen = None;
    let run = faulted(&mut |k, r| {
        if k == 1000 {
            frozen = Some(r.joints_m[0]);
        }
        if let Some(q) = frozen {
            r.joints_m[0] = q;
        }
    });
    assert!(
        matches!(run.mode, Mode::Fault(ArrowFault::TrackingError(_))),
        "{:?}",
        run.mode
    );
    assert!(run.samples.len() > 1000 && run.samples.len() < 5000);
    assert!(zero(&run));
    println!(
        "frozen encoder: tracking fault after {} periods",
        run.samples.len() - 1000
    );
}

/// A job read in place over another (as the link builds it in a job buffer that held
/// the job before) is the job read fresh: the earlier job's moves do not survive, in
/// count, plan or line; and a refused program leaves no job to mistake for a good one
/// (the next good one read over it is again the fresh one).
#[test]
fn a_job_read_over_another_is_the_job_read_fresh() {
    let short = format!("{HEAD}G1 X10 Y500 Z0 F600\n");
    let fresh = job_from_gcode(&short).unwrap();
    let geometry = ArrowGeometry::<f64>::new(&ArrowConfig::ARROW).unwrap();
    let mut points = Box::new(heapless::Vec::<GcodePoint, 256>::new());
    let mut reused = job_from_gcode(PYRAMID_GCODE).unwrap();
    assert_eq!(
        reused.moves().len(),
        3,
        "the pyramid: plunge, contour, retract"
    );
    for bad_first in [false, true] {
        if bad_first {
            let bad = format!("{HEAD}G1 X10 Q3\n");
            assert!(reused
                .read_gcode(
                    bad.as_bytes(),
                    &mut points,
                    &geometry,
                    &ArrowJobConfig::ARROW
                )
                .is_err());
        }
        reused
            .read_gcode(
                short.as_bytes(),
                &mut points,
                &geometry,
                &ArrowJobConfig::ARROW,
            )
            .unwrap();
        assert_eq!(reused.moves().len(), fresh.moves().len());
        assert_eq!(reused.periods(), fresh.periods());
        assert_eq!(reused.start(), fresh.start());
        for (a, b) in reused.moves().iter().zip(fresh.moves()) {
            assert_eq!((a.line, a.plan), (b.line, b.plan));
            assert_eq!(a.spline.points(), b.spline.points());
        }
    }
    // The same through the points the reader gave (`plan_points`).
    let mut again = job_from_gcode(PYRAMID_GCODE).unwrap();
    again
        .plan_points(&points, &geometry, &ArrowJobConfig::ARROW)
        .unwrap();
    assert_eq!(again.periods(), fresh.periods());
    assert_eq!(again.moves().len(), fresh.moves().len());
}
