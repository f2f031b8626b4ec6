//! ARROW operated as a product: the simulated machine behind its host link
//! (`kerf_sim::linked_arrow`, f64) and the host tool's own session code
//! (`kerf_host::session`) on a socket pair. The host knows nothing of ARROW but what
//! the machine describes: it uploads the pyramid's G-code file, starts it, streams
//! telemetry, changes a gain mid-run, and hears the end; a second run lowers the
//! force limit until a joint falls behind, heard as a fault with the machine's words.

use host_tests::link::{run_plan, serve, MachineThread, Pace};
use kerf::codec::job::write_gcode;
use kerf::codec::link::JobKind;
use kerf_host::link::{LinkError, MachineLink};
use kerf_host::session::{Progress, RunPlan, Session, SessionError};
use kerf_host::telemetry::TelemetryLog;
use kerf_sim::arrow::{ArrowScenario, PYRAMID_GCODE};
use kerf_sim::linked_arrow::with_linked_arrow;
use std::os::unix::net::UnixStream;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

/// The simulated ARROW on the far end of `socket`, a period per turn as fast as it
/// can, until `stop` is set or the host hangs up. Bytes from the host come through a
/// reader thread, so a period never waits for them.
fn machine(socket: UnixStream, stop: Arc<AtomicBool>) -> JoinHandle<()> {
    std::thread::spawn(move || {
        let mut scenario = ArrowScenario::smoke();
        scenario.plant.substeps = 1;
        // The simulation runs some fifty times faster than real time: the heartbeat
        // (tested with the link itself) must not take a busy host for a lost one.
        with_linked_arrow::<f64, _>(&scenario, 1e4, |arrow| {
            serve(socket, &stop, Pace::Free, |_, input, send| {
                arrow.period(input, send).is_ok()
            })
        })
        .expect("ARROW builds");
    })
}

fn pyramid_job() -> Vec<u8> {
    let mut out = vec![0u8; PYRAMID_GCODE.len() + 64];
    let n = write_gcode(PYRAMID_GCODE.as_bytes(), &mut out).unwrap();
    out.truncate(n);
    out
}

struct Rig {
    /// First, so that the machine stops before the host's end closes.
    _machine: MachineThread,
    session: Session,
}

fn rig() -> Rig {
    let (host, far) = UnixStream::pair().unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let thread = machine(far, Arc::clone(&stop));
    let link = MachineLink::connect(
        Box::new(host.try_clone().unwrap()),
        Box::new(host),
        Duration::from_secs(5),
    )
    .expect("the simulated ARROW answers");
    Rig {
        session: Session::over(link),
        _machine: MachineThread::new(stop, thread),
    }
}

fn plan(changes: &[(f64, &str, &str)]) -> RunPlan {
    run_plan(100.0, 30, changes)
}

#[test]
fn the_host_runs_the_pyramid_on_arrow_from_its_gcode_file() {
    let mut rig = rig();
    let m = &rig.session.machine;
    assert_eq!(m.hello().machine, "arrow");
    assert!((m.hello().period_s - 2e-4).abs() < 1e-12);
    let d = m.description().clone();
    assert_eq!(d.job_kinds, [JobKind::Gcode]);
    assert_eq!(d.settings.len(), 11);
    assert_eq!(d.channels.len(), 16);
    // The wrong kind of job is refused in the machine's words, nothing loaded.
    let mut efd = [0u8; 128];
    let n = kerf::codec::job::write_efd([0.0, 0.0], &[[1e-3, 0.0, 0.0, 1e-3]], &mut efd).unwrap();
    match rig
        .session
        .machine
        .upload(JobKind::Efd, &efd[..n], &mut |_| {})
    {
        Err(LinkError::Refused { reason, .. }) => {
            assert!(reason.contains("G-code jobs only"), "{reason}")
        }
        other => panic!("{other:?}"),
    }
    // A gain out of its range: refused naming the range the machine announced.
    match rig.session.machine.set("/parallel/kp", "-5") {
        Err(e @ LinkError::Refused { .. }) => {
            assert!(e.to_string().ends_with("takes > 0 N/m"), "{e}")
        }
        other => panic!("{other:?}"),
    }
    let mut log = TelemetryLog::new(2e-4, &d.channels);
    let mut lines = Vec::new();
    let ended = rig.session.run_job(
        JobKind::Gcode,
        &pyramid_job(),
        &plan(&[(10.0, "/parallel/kd", "9000")]),
        &mut log,
        None,
        &mut |p| {
            if let Progress::Line(t, text) = p {
                lines.push(format!("{t:.3} {text}"));
            }
        },
    );
    let summary = log.summary();
    println!("arrow link: {summary}");
    println!("arrow link: {lines:?}");
    ended.expect("the pyramid runs to its end");
    assert!(
        lines.iter().any(|l| l.ends_with("set /parallel/kd = 9000")),
        "{lines:?}"
    );
    assert_eq!(rig.session.machine.get("/parallel/kd").unwrap(), "9000.0");
    // 94 s of cutting at 100 samples a second.
    assert!(summary.cutting_samples > 9_000, "{summary:?}");
    // The largest joint error sampled (reference − encoder) is the assembled
    // machine's joint inconsistency, 0.1–0.3 mm (`ArrowPlantConfig::
    // with_geometric_error`), which the regularized law leaves alone, plus the
    // tracking error of A table 3's scale (µm): inside 0.35 mm, far inside the
    // machine's 2 mm tracking limit, and not a tracking error of its own.
    let joint_error: Vec<f64> = log
        .entries()
        .iter()
        .filter_map(|e| log.value(e, "joint_error"))
        .collect();
    let worst = joint_error.iter().fold(0.0f64, |w, e| w.max(*e));
    println!(
        "arrow link: largest joint error sampled {:.1} µm",
        worst * 1e6
    );
    assert!(worst > 0.05e-3 && worst < 0.35e-3, "{worst}");
    assert!(summary.to_string().contains("force peak"), "{summary}");
    assert!(!summary.to_string().contains("contour error"), "{summary}");
}

#[test]
fn a_force_limit_too_low_to_cut_is_heard_as_the_machines_fault() {
    let mut rig = rig();
    let channels = rig.session.machine.description().channels.clone();
    let mut log = TelemetryLog::new(2e-4, &channels);
    let ended = rig.session.run_job(
        JobKind::Gcode,
        &pyramid_job(),
        &plan(&[(0.5, "/parallel/force_limit", "1")]),
        &mut log,
        None,
        &mut |_| {},
    );
    match ended {
        Err(SessionError::Fault(words)) => {
            assert!(words.contains("tracking limit"), "{words}");
            println!("arrow link: the second run ended with a fault: {words}");
        }
        other => panic!("{other:?}"),
    }
}

/// A real mill program longer than ARROW holds (`data/gcode/cap.ngc`, turned onto its
/// tool axis and centred), given as the parts `kerf gcode` writes: the session loads
/// each part while the one before runs and the machine goes from part to part; its
/// reference ends on the program's last point and visits the program's whole box.
#[test]
fn a_mill_program_longer_than_arrow_holds_runs_as_parts() {
    let text = std::fs::read(
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/gcode/cap.ngc"),
    )
    .unwrap();
    let placement = kerf_host::arrow_parts::Placement {
        centre: true,
        mill: true,
    };
    let program = kerf_host::arrow_parts::parts(&text, placement).unwrap();
    let n = program.parts.len();
    assert!(n > 4, "{n}");
    let jobs: Vec<Vec<u8>> = program
        .parts
        .iter()
        .map(|p| {
            let mut out = vec![0u8; p.text.len() + 64];
            let len = write_gcode(&p.text, &mut out).unwrap();
            out.truncate(len);
            out
        })
        .collect();
    let given: Vec<(JobKind, &[u8])> = jobs.iter().map(|j| (JobKind::Gcode, &j[..])).collect();
    let mut rig = rig();
    let channels = rig.session.machine.description().channels.clone();
    let mut log = TelemetryLog::new(2e-4, &channels);
    let mut lines = Vec::new();
    let ended = rig
        .session
        .run_parts(&given, &plan(&[]), &mut log, None, &mut |p| {
            if let Progress::Line(t, text) = p {
                lines.push(format!("{t:.3} {text}"));
            }
        });
    println!("arrow parts: {}", log.summary());
    ended.unwrap_or_else(|e| panic!("{e}: {lines:?}"));
    // The references of the running machine (at rest it reports none).
    let reference: Vec<[f64; 3]> = log
        .entries()
        .iter()
        .filter(|e| e.sample.mode == kerf::codec::link::ModeCode::Running)
        .filter_map(|e| {
            let at = |c| log.value(e, c);
            Some([at("x_ref")?, at("y_ref")?, at("z_ref")?])
        })
        .collect();
    // The last sample's reference is the last part's end.
    let end = program.parts[n - 1].report.end;
    let last = reference.last().unwrap();
    for k in 0..3 {
        assert!((last[k] - end[k]).abs() < 1e-6, "{last:?} {end:?}");
    }
    // The reference spans the program's box (sampled at 100 Hz along moves of up to
    // the 100 mm/s rapids: within 1 mm of each face).
    for k in 0..3 {
        let points = program
            .parts
            .iter()
            .flat_map(|p| p.report.paths_m.iter().flatten());
        let lo = points.clone().map(|p| p[k]).fold(f64::INFINITY, f64::min);
        let hi = points.map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max);
        let r_lo = reference.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min);
        let r_hi = reference
            .iter()
            .map(|p| p[k])
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(
            (r_lo - lo).abs() < 1e-3 && (r_hi - hi).abs() < 1e-3,
            "{k}: {lo} {hi} {r_lo} {r_hi}"
        );
    }
    // As on the pyramid: the joints within the assembled machine's inconsistency.
    let worst = log
        .entries()
        .iter()
        .filter_map(|e| log.value(e, "joint_error"))
        .fold(0.0f64, f64::max);
    println!(
        "arrow parts: {n} parts, largest joint error sampled {:.1} µm",
        worst * 1e6
    );
    assert!(worst < 0.35e-3, "{worst}");
}

/// A planned change the run cannot make is not lost in the run's lines: one of a
/// setting the machine does not have fails before anything is sent; one the machine
/// refuses lets the job run to its end and then fails the run, in the machine's words.
#[test]
fn a_planned_change_that_cannot_be_made_fails_the_run() {
    let mut rig = rig();
    let channels = rig.session.machine.description().channels.clone();
    let mut log = TelemetryLog::new(2e-4, &channels);
    let mut uploaded = 0;
    let ended = rig.session.run_job(
        JobKind::Gcode,
        &pyramid_job(),
        &plan(&[(0.1, "/parallel/kp_typo", "1")]),
        &mut log,
        None,
        &mut |p| {
            if let Progress::Uploaded(n) = p {
                uploaded = n;
            }
        },
    );
    match ended {
        Err(e @ SessionError::UnknownSetting { .. }) => {
            let words = e.to_string();
            assert!(
                words.starts_with("/parallel/kp_typo: the machine has no such setting"),
                "{words}"
            );
            assert!(words.contains("/parallel/kp,"), "{words}");
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(uploaded, 0);
    assert!(log.entries().is_empty());
    // The machine's range refuses a negative gain: the job still runs to its end.
    let job = kerf_host::arrow_parts::parts(
        b"G21 G90\nG0 X13.333 Y464.604 Z-13.333 A-15 B15\nG1 X20 F600\n",
        Default::default(),
    )
    .unwrap();
    let part = &job.parts[0].text;
    let mut bytes = vec![0u8; part.len() + 64];
    let n = write_gcode(part, &mut bytes).unwrap();
    bytes.truncate(n);
    let mut lines = Vec::new();
    let ended = rig.session.run_job(
        JobKind::Gcode,
        &bytes,
        &plan(&[(0.1, "/parallel/kp", "-5")]),
        &mut log,
        None,
        &mut |p| {
            if let Progress::Line(_, text) = p {
                lines.push(text.to_owned());
            }
        },
    );
    match ended {
        Err(SessionError::ChangeRefused(words)) => {
            assert!(words.starts_with("set /parallel/kp = -5: "), "{words}");
            assert!(words.ends_with("takes > 0 N/m"), "{words}");
        }
        other => panic!("{other:?}: {lines:?}"),
    }
    assert!(
        lines.iter().any(|l| l == "mode running -> ready"),
        "{lines:?}"
    );
}
