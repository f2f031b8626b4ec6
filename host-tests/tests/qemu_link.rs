//! The host link end to end against the emulated MCU: the
//! QEMU image `link` (the Keops slave in f32 with its simulated delta,
//! `kerf_sim::linked`) speaks the protocol on its UART, which QEMU connects to a TCP
//! socket of this test. The host is the `kerf` tool's own session code
//! (`kerf_host::session`): it uploads the octagon as an EFD job file, runs it with a
//! heartbeat per telemetry sample, retunes the DOB during the cut; then cuts again
//! and lowers the force limit until the machine faults, and hears the fault as an
//! event with its reason; bad settings are refused with typed errors and change
//! nothing.
//!
//! Needs the image built first, so it is run by `scripts/smoke`
//! (`cargo test -p host-tests --test qemu_link -- --ignored`) after
//! `cargo build … --bin link`; `KERF_LINK_ELF` names the image.

use host_tests::link::octagon_job_file;
use kerf::codec::link::{JobKind, ModeCode, Refusal, Request};
use kerf_host::link::LinkError;
use kerf_host::session::{RunPlan, Session, SessionError, Target, TimedChange};
use kerf_host::telemetry::TelemetryLog;
use std::path::PathBuf;

fn plan(changes: &[(f64, &str, &str)]) -> RunPlan {
    RunPlan {
        telemetry_hz: 100.0,
        changes: changes
            .iter()
            .map(|&(at_s, path, value)| TimedChange {
                at_s,
                path: path.into(),
                value: value.into(),
            })
            .collect(),
        quiet_s: 60,
    }
}

#[test]
#[ignore = "needs the QEMU link image: scripts/smoke builds it and runs this test"]
fn a_host_cuts_retunes_and_hears_a_fault_over_the_emulated_serial_port() {
    let image = PathBuf::from(
        std::env::var_os("KERF_LINK_ELF")
            .expect("KERF_LINK_ELF: the link image (scripts/smoke builds it)"),
    );
    let mut session = Session::open(&Target::Qemu { image }).expect("the emulated machine");
    let hello = session.machine.hello().clone();
    assert_eq!(hello.machine, "keops-slave");
    assert!((hello.period_s - 1e-4).abs() < 1e-12, "{hello:?}");
    let job = octagon_job_file();

    // A whole cut, the DOB retuned half a second in.
    let mut log = TelemetryLog::new(hello.period_s, &session.machine.description().channels);
    let mut lines = Vec::new();
    let mut uploaded = 0;
    session
        .run_job(
            JobKind::Efd,
            &job,
            &plan(&[(0.5, "/slave/dob/bandwidth_hz", "120")]),
            &mut log,
            None,
            &mut |p| match p {
                kerf_host::session::Progress::Uploaded(n) => uploaded = n,
                kerf_host::session::Progress::Line(t, s) => lines.push(format!("{t:.3} {s}")),
                kerf_host::session::Progress::Sample(..) => {}
            },
        )
        .expect("the cut runs to its end");
    let summary = log.summary();
    println!("qemu link: {summary}");
    println!("qemu link: {lines:?}");
    assert_eq!(uploaded as usize, job.len());
    assert!(
        lines
            .iter()
            .any(|l| l.ends_with("set /slave/dob/bandwidth_hz = 120")),
        "{lines:?}"
    );
    assert_eq!(
        session.machine.get("/slave/dob/bandwidth_hz").unwrap(),
        "120.0"
    );
    // 100 samples a second over the octagon's cut (several seconds of machine time).
    assert!(summary.cutting_samples > 100, "{summary}");
    assert!(summary.error_max_m < 5e-6, "{summary}");

    // Bad settings: refused with their reason, nothing changed.
    match session.machine.set("/slave/dob/no_such_gain", "1") {
        Err(LinkError::Refused {
            refusal: Refusal::UnknownPath,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    match session.machine.set("/slave/dob/bandwidth_hz", "-5") {
        Err(LinkError::Refused {
            refusal: Refusal::BadValue,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    assert_eq!(
        session.machine.get("/slave/dob/bandwidth_hz").unwrap(),
        "120.0"
    );

    // Again, and the force limit lowered until the carriages cannot hold the cut.
    let mut log = TelemetryLog::new(hello.period_s, &session.machine.description().channels);
    let ended = session.run_job(
        JobKind::Efd,
        &job,
        &plan(&[(0.1, "/slave/dob/force_limit_n", "0.05")]),
        &mut log,
        None,
        &mut |_| {},
    );
    println!("qemu link: the second cut ended with {ended:?}");
    match ended {
        Err(SessionError::Fault(why)) => assert!(why.contains("contour-error limit"), "{why}"),
        other => panic!("{other:?}"),
    }
    assert!(log.marks().iter().any(|(_, m)| m.starts_with("fault 4")));
    let status = session.machine.status().unwrap();
    assert_eq!(status.mode, ModeCode::Fault);
    assert_eq!(status.last_fault, Some((4, 0)));
    session.machine.command(Request::ResetFault).unwrap();
    let status = session.machine.status().unwrap();
    assert_eq!(
        (status.mode, status.last_fault),
        (ModeCode::Idle, Some((4, 0)))
    );
    assert_eq!(status.bad_frames, 0);
}
