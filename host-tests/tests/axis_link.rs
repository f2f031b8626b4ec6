//! The single axis operated as a product: the simulated LM1247 axis behind its host
//! link (`kerf_sim::linked_axis`, f64) and the host tool's own session code
//! (`kerf_host::session`) on a socket pair. The host knows nothing of the axis but
//! what the machine describes: it uploads `data/axis_moves.gcode`, starts it, streams
//! telemetry, lowers the force limit mid-run and sees the force held to it, hears the
//! end; it stops a run part-way and asks the status; a broken Hall wire during a run
//! is heard as a fault in the machine's words.

use hal_mock::hall_sensor::ChannelFault;
use host_tests::link::{axis_machine as machine, run_plan, MachineThread};
use kerf::codec::job::write_gcode;
use kerf::codec::link::{JobKind, ModeCode, Request};
use kerf_host::link::{Heard, LinkError, MachineLink};
use kerf_host::session::{Progress, RunPlan, Session, SessionError};
use kerf_host::telemetry::TelemetryLog;
use kerf_sim::linked_axis::AXIS_MOVES_GCODE;
use kerf_sim::scenario::Scenario;
use std::os::unix::net::UnixStream;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The control period, s (the axis' 10 kHz).
const PERIOD_S: f64 = host_tests::link::AXIS_PERIOD_S;

fn moves_job() -> Vec<u8> {
    let mut out = vec![0u8; AXIS_MOVES_GCODE.len() + 64];
    let n = write_gcode(AXIS_MOVES_GCODE.as_bytes(), &mut out).unwrap();
    out.truncate(n);
    out
}

/// The moves' job file as scripts/smoke uploads it to the QEMU image (`kerf gcode`
/// checks programs with ARROW's loader): the committed bytes are the job writer's
/// from the G-code, rewritten with `KERF_WRITE_DATA=1`.
#[test]
fn the_committed_moves_job_is_its_gcode() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../data/axis_moves.krfj");
    if std::env::var_os("KERF_WRITE_DATA").is_some() {
        std::fs::write(path, moves_job()).unwrap();
    }
    assert_eq!(std::fs::read(path).unwrap(), moves_job());
}

struct Rig {
    /// First, so that the machine stops before the host's end closes.
    _machine: MachineThread,
    session: Session,
}

fn rig(scenario: Scenario) -> Rig {
    let (host, far) = UnixStream::pair().unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let thread = machine(scenario, far, Arc::clone(&stop));
    let link = MachineLink::connect(
        Box::new(host.try_clone().unwrap()),
        Box::new(host),
        Duration::from_secs(5),
    )
    .expect("the simulated axis answers");
    Rig {
        session: Session::over(link),
        _machine: MachineThread::new(stop, thread),
    }
}

fn plan(changes: &[(f64, &str, &str)]) -> RunPlan {
    run_plan(200.0, 30, changes)
}

/// The moves run with telemetry; `changes` made on the way. Returns the log and the
/// session's lines.
fn run(rig: &mut Rig, changes: &[(f64, &str, &str)]) -> (TelemetryLog, Vec<String>) {
    let channels = rig.session.machine.description().channels.clone();
    let mut log = TelemetryLog::new(PERIOD_S, &channels);
    let mut lines = Vec::new();
    rig.session
        .run_job(
            JobKind::Gcode,
            &moves_job(),
            &plan(changes),
            &mut log,
            None,
            &mut |p| {
                if let Progress::Line(t, text) = p {
                    lines.push(format!("{t:.3} {text}"));
                }
            },
        )
        .expect("the moves run to their end");
    (log, lines)
}

/// The largest |force| sampled while running at or after `from_s` of the run.
fn force_peak(log: &TelemetryLog, from_s: f64) -> f64 {
    let running: Vec<_> = log
        .entries()
        .iter()
        .filter(|e| e.sample.mode == ModeCode::Running)
        .collect();
    let start = running.first().map_or(0.0, |e| e.time_s);
    running
        .iter()
        .filter(|e| e.time_s - start >= from_s)
        .filter_map(|e| log.value(e, "force"))
        .fold(0.0, |w: f64, f| w.max(f.abs()))
}

#[test]
fn the_host_runs_the_moves_and_retunes_the_axis_mid_run() {
    let mut rig = rig(Scenario::TRACKING);
    let m = &rig.session.machine;
    assert_eq!(m.hello().machine, "single-axis");
    assert!((m.hello().period_s - PERIOD_S).abs() < 1e-12);
    let d = m.description().clone();
    assert_eq!(d.job_kinds, [JobKind::Gcode]);
    assert_eq!(d.settings.len(), 7);
    assert_eq!(d.channels.len(), 6);
    // The wrong kind of job is refused in the machine's words.
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
    // A bandwidth past its range: refused naming the range the machine announced.
    match rig.session.machine.set("/dob/bandwidth_hz", "5000") {
        Err(e @ LinkError::Refused { .. }) => {
            assert!(e.to_string().ends_with("takes > 0 and ≤ 3183 Hz"), "{e}")
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(
        rig.session.machine.get("/dob/bandwidth_hz").unwrap(),
        "150.0"
    );
    // The moves as programmed: the rapid back to X10 (40 mm in 0.15 s, 10 m/s²
    // peak on the 121 g slider and payload: 1.2 N) is the largest force.
    let (log, _) = run(&mut rig, &[]);
    let summary = log.summary();
    println!("axis link: {summary}");
    let free_peak = force_peak(&log, 3.0);
    println!("axis link: force peak after 3 s {free_peak:.3} N");
    assert!(free_peak > 1.0, "{free_peak}");
    // 4.9 s of moves at 200 samples a second.
    assert!(summary.cutting_samples > 900, "{summary:?}");
    // Again, with the force limit lowered to 0.6 N at 3 s: the rapid's force is
    // held to it; the run still ends (the carriage lags, then catches up).
    let (log, lines) = run(&mut rig, &[(3.0, "/dob/force_limit_n", "0.6")]);
    println!("axis link: {lines:?}");
    assert!(
        lines
            .iter()
            .any(|l| l.ends_with("set /dob/force_limit_n = 0.6")),
        "{lines:?}"
    );
    let held = force_peak(&log, 3.1);
    println!("axis link: force peak after the change {held:.3} N");
    assert!(held <= 0.6 + 1e-6 && held > 0.55, "{held}");
    assert_eq!(
        rig.session.machine.get("/dob/force_limit_n").unwrap(),
        "0.6"
    );
}

/// Started, then stopped part-way: the axis ramps to rest and the status says so.
#[test]
fn a_run_is_stopped_and_the_status_tells_it() {
    let mut rig = rig(Scenario::TRACKING);
    let m = &mut rig.session.machine;
    m.upload(JobKind::Gcode, &moves_job(), &mut |_| {}).unwrap();
    m.telemetry(100.0).unwrap();
    m.command(Request::Start).unwrap();
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut running = 0;
    while running < 50 && Instant::now() < deadline {
        if let Some(Heard::Telemetry(t)) = m.next(Duration::from_millis(100)).unwrap() {
            running += usize::from(t.mode == ModeCode::Running);
        }
    }
    assert_eq!(running, 50, "0.5 s of the run heard");
    m.command(Request::Stop).unwrap();
    let mut status = m.status().unwrap();
    while status.mode != ModeCode::Ready && Instant::now() < deadline {
        status = m.status().unwrap();
    }
    println!("axis link: status after the stop {status:?}");
    assert_eq!(status.mode, ModeCode::Ready);
    assert_eq!(status.last_fault, None);
}

/// A Hall wire that opens during the run is heard as the machine's fault, in its
/// words.
#[test]
fn a_broken_hall_wire_is_heard_as_the_machines_fault() {
    let mut scenario = Scenario::TRACKING;
    scenario.sensor_fault = Some((1.0, ChannelFault::OpenWire(0)));
    let mut rig = rig(scenario);
    let channels = rig.session.machine.description().channels.clone();
    let mut log = TelemetryLog::new(PERIOD_S, &channels);
    let ended = rig.session.run_job(
        JobKind::Gcode,
        &moves_job(),
        &plan(&[]),
        &mut log,
        None,
        &mut |_| {},
    );
    match ended {
        Err(SessionError::Fault(words)) => {
            assert!(words.contains("Hall sensors failed a check"), "{words}");
            println!("axis link: the run ended with a fault: {words}");
        }
        other => panic!("{other:?}"),
    }
    let status = rig.session.machine.status().unwrap();
    assert_eq!(status.mode, ModeCode::Fault);
    assert_eq!(status.last_fault, Some((1, 0)));
}
