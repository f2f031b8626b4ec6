//! The autofocus stage operated as a product: the simulated zoom camera on its focus
//! axis behind the stage's host link (`kerf_sim::linked_autofocus`, f64) and the host
//! tool's own session code (`kerf_host::session`) on a socket pair. The host knows
//! nothing of the stage but what it describes: it uploads the zoom schedule of
//! `data/autofocus_zoom.krfj`, starts it, streams telemetry, lowers the law's largest
//! speed mid-run and sees the velocity reference held to it, hears the end; it stops
//! a run part-way and asks the status; a camera that stops sending frames, and a
//! scene the law finds too plain once its least sharpness is raised, are heard as
//! faults in the stage's words.

use hal_mock::focus::CameraParams;
use host_tests::link::{run_plan, serve, MachineThread, Pace};
use kerf::codec::job::write_schedule;
use kerf::codec::link::{JobKind, ModeCode, Request};
use kerf::machines::autofocus::product::PERIOD_S;
use kerf_host::link::{Heard, LinkError, MachineLink};
use kerf_host::session::{Progress, Session, SessionError};
use kerf_host::telemetry::{Entry, TelemetryLog};
use kerf_sim::linked_autofocus::{with_linked_autofocus, CameraState, CAMERA_SEED, ZOOM_SCHEDULE};
use std::os::unix::net::UnixStream;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The simulated stage on the far end of `socket`, a period per turn as fast as it
/// can, until `stop` is set or the host hangs up; its camera falls silent after
/// `silent_after` periods of a running job, if given. Bytes from the host come
/// through a reader thread, so a period never waits for them.
fn machine(socket: UnixStream, stop: Arc<AtomicBool>, silent_after: Option<u32>) -> JoinHandle<()> {
    std::thread::spawn(move || {
        let mut running = 0u32;
        // The simulation runs faster than real time: the heartbeat (tested with the
        // link itself) must not take a busy host for a lost one.
        with_linked_autofocus::<f64, _>(CAMERA_SEED, 1e4, |stage| {
            serve(socket, &stop, Pace::Free, |_, input, send| {
                stage.period(input, send);
                if stage.supervisor().mode() == kerf::app::supervisor::Mode::Running {
                    running += 1;
                    if silent_after == Some(running) {
                        stage.set_camera(CameraState::Silent);
                    }
                }
                true
            })
        })
        .expect("the stage builds");
    })
}

fn schedule_job() -> Vec<u8> {
    let mut out = vec![0u8; 16 + 8 * ZOOM_SCHEDULE.len()];
    let n = write_schedule(&ZOOM_SCHEDULE, &mut out).unwrap();
    out.truncate(n);
    out
}

/// The schedule's job file as scripts/smoke uploads it to the QEMU image: the
/// committed bytes are the job writer's from `ZOOM_SCHEDULE`, rewritten with
/// `KERF_WRITE_DATA=1`.
#[test]
fn the_committed_schedule_job_is_its_steps() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../data/autofocus_zoom.krfj");
    if std::env::var_os("KERF_WRITE_DATA").is_some() {
        std::fs::write(path, schedule_job()).unwrap();
    }
    assert_eq!(std::fs::read(path).unwrap(), schedule_job());
}

struct Rig {
    /// First, so that the machine stops before the host's end closes.
    _machine: MachineThread,
    session: Session,
}

fn rig(silent_after: Option<u32>) -> Rig {
    let (host, far) = UnixStream::pair().unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let thread = machine(far, Arc::clone(&stop), silent_after);
    let link = MachineLink::connect(
        Box::new(host.try_clone().unwrap()),
        Box::new(host),
        Duration::from_secs(5),
    )
    .expect("the simulated stage answers");
    Rig {
        session: Session::over(link),
        _machine: MachineThread::new(stop, thread),
    }
}

/// The schedule run with telemetry at 100 Hz, `changes` made on the way: the log,
/// the session's lines, and how it ended.
fn run(
    rig: &mut Rig,
    changes: &[(f64, &str, &str)],
) -> (TelemetryLog, Vec<String>, Result<(), SessionError>) {
    let channels = rig.session.machine.description().channels.clone();
    let mut log = TelemetryLog::new(PERIOD_S, &channels);
    let mut lines = Vec::new();
    let ended = rig.session.run_job(
        JobKind::Schedule,
        &schedule_job(),
        &run_plan(100.0, 30, changes),
        &mut log,
        None,
        &mut |p| {
            if let Progress::Line(t, text) = p {
                lines.push(format!("{t:.3} {text}"));
            }
        },
    );
    (log, lines, ended)
}

/// The running samples with their time from the run's start.
fn running(log: &TelemetryLog) -> Vec<(f64, &Entry)> {
    let entries: Vec<&Entry> = log
        .entries()
        .iter()
        .filter(|e| e.sample.mode == ModeCode::Running)
        .collect();
    let start = entries.first().map_or(0.0, |e| e.time_s);
    entries.iter().map(|e| (e.time_s - start, *e)).collect()
}

/// At the last sample of each step: the distance from the position to the camera's
/// focus at the sampled magnification, in units of its depth of field w.
fn focus_errors(log: &TelemetryLog) -> Vec<(f64, f64, f64)> {
    let camera = CameraParams::ZOOM_INSPECTION;
    let samples = running(log);
    let value = |e: &Entry, name| log.value(e, name).unwrap();
    let mut ends = Vec::new();
    for (k, (_, e)) in samples.iter().enumerate() {
        let step = value(e, "step");
        let last = samples
            .get(k + 1)
            .is_none_or(|(_, next)| value(next, "step") != step);
        if last && (step as usize) < ZOOM_SCHEDULE.len() {
            let (q, m) = (value(e, "position"), value(e, "magnification"));
            let error = q - camera.focus_m(m);
            ends.push((m, error, error.abs() / camera.depth_of_field_m(m)));
        }
    }
    ends
}

/// The largest |velocity reference| sampled from `from_s` of the run on.
fn speed_peak(log: &TelemetryLog, from_s: f64) -> f64 {
    running(log)
        .iter()
        .filter(|(t, _)| *t >= from_s)
        .filter_map(|(_, e)| log.value(e, "velocity_reference"))
        .fold(0.0, |w: f64, v| w.max(v.abs()))
}

/// The schedule in focus at the end of each step. The residual is noise-limited: the
/// gradient's zero is found to about 0.2 w (one standard deviation, at m = 1; the
/// host scenario `autofocus` derives it), and where in the camera's noise a run
/// starts depends on the host's timing, so the residual at a step's end varies from
/// run to run (0.09–0.45 w at m = 1 over twelve runs): the bound is 0.75 w, 3.75
/// standard deviations, still inside the depth of field (a zoom change missed would
/// leave 15 w); with μ0 lowered to 2 mm/s just after the zoom to
/// m = 2 starts, the velocity reference keeps to it while the focus moves 3 mm, and
/// the step still ends in focus. The change reaches the machine when the host sends
/// it, some periods after the sample at 5.2 s (the simulation runs faster than real
/// time, so a busy host's milliseconds are a larger part of a second of machine
/// time); the reference is checked from 5.7 s, while the 3 mm refocus at 2 mm/s still
/// runs (until 6.5 s at the earliest).
#[test]
fn the_host_runs_the_zoom_schedule_and_retunes_the_law_mid_run() {
    let mut rig = rig(None);
    let m = &rig.session.machine;
    assert_eq!(m.hello().machine, "autofocus");
    assert!((m.hello().period_s - PERIOD_S).abs() < 1e-12);
    let d = m.description().clone();
    assert_eq!(d.job_kinds, [JobKind::Schedule]);
    assert_eq!(d.settings.len(), 9);
    assert_eq!(d.channels.len(), 9);
    // The wrong kind of job is refused in the stage's words.
    let mut gcode = [0u8; 64];
    let n = kerf::codec::job::write_gcode(b"G0 X10\n", &mut gcode).unwrap();
    match rig
        .session
        .machine
        .upload(JobKind::Gcode, &gcode[..n], &mut |_| {})
    {
        Err(LinkError::Refused { reason, .. }) => {
            assert!(reason.contains("schedule jobs only"), "{reason}")
        }
        other => panic!("{other:?}"),
    }
    // A bandwidth past its range: refused naming the range the stage announced.
    match rig.session.machine.set("/velocity/bandwidth_hz", "400") {
        Err(e @ LinkError::Refused { .. }) => {
            assert!(e.to_string().ends_with("takes > 0 and ≤ 318 Hz"), "{e}")
        }
        other => panic!("{other:?}"),
    }
    let (log, lines, ended) = run(&mut rig, &[(5.2, "/law/max_speed_m_s", "0.002")]);
    println!("autofocus link: {lines:?}");
    ended.expect("the schedule runs to its end");
    let samples = running(&log).len();
    let errors = focus_errors(&log);
    for (m, error, in_w) in &errors {
        println!(
            "autofocus link: m {m:.2}: {:+.1} um from focus ({in_w:.3} w)",
            error * 1e6
        );
    }
    let before = speed_peak(&log, 0.0);
    let after = speed_peak(&log, 5.7);
    println!(
        "autofocus link: {samples} samples; velocity reference peak {:.3} mm/s before the \
         change, {:.3} mm/s after",
        before * 1e3,
        after * 1e3
    );
    assert!(
        lines
            .iter()
            .any(|l| l.ends_with("set /law/max_speed_m_s = 0.002")),
        "{lines:?}"
    );
    assert_eq!(errors.len(), ZOOM_SCHEDULE.len(), "{errors:?}");
    assert!(errors.iter().all(|(_, _, w)| *w < 0.75), "{errors:?}");
    // 11 s at 100 samples a second.
    assert!(samples > 1000, "{samples}");
    assert!(before > 3e-3, "{before}");
    // The reference ramps to μ0 over a frame from below it: never past it (f32).
    assert!(after <= 2e-3 * (1.0 + 1e-6) && after > 1.5e-3, "{after}");
    assert_eq!(
        rig.session.machine.get("/law/max_speed_m_s").unwrap(),
        "0.002"
    );
}

/// Started, then stopped part-way: the axis ramps to rest and the status says so.
#[test]
fn a_run_is_stopped_and_the_status_tells_it() {
    let mut rig = rig(None);
    let m = &mut rig.session.machine;
    m.upload(JobKind::Schedule, &schedule_job(), &mut |_| {})
        .unwrap();
    m.telemetry(100.0).unwrap();
    m.command(Request::Start).unwrap();
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut running = 0;
    while running < 100 && Instant::now() < deadline {
        if let Some(Heard::Telemetry(t)) = m.next(Duration::from_millis(100)).unwrap() {
            running += usize::from(t.mode == ModeCode::Running);
        }
    }
    assert_eq!(running, 100, "1 s of the run heard");
    m.command(Request::Stop).unwrap();
    let mut status = m.status().unwrap();
    while status.mode != ModeCode::Ready && Instant::now() < deadline {
        status = m.status().unwrap();
    }
    println!("autofocus link: status after the stop {status:?}");
    assert_eq!(status.mode, ModeCode::Ready);
    assert_eq!(status.last_fault, None);
}

/// A camera that stops sending frames 2 s into the run, and (another run) a least
/// sharpness raised above the scene's: each heard as the stage's fault, in its words.
#[test]
fn a_silent_camera_and_a_plain_scene_are_heard_as_the_stages_faults() {
    let mut silent = rig(Some(2000));
    let (_, _, ended) = run(&mut silent, &[]);
    match ended {
        Err(SessionError::Fault(words)) => {
            assert!(words.contains("no camera frame for longer"), "{words}");
            println!("autofocus link: the run ended with a fault: {words}");
        }
        other => panic!("{other:?}"),
    }
    let status = silent.session.machine.status().unwrap();
    assert_eq!(status.mode, ModeCode::Fault);
    assert_eq!(status.last_fault, Some((1, 0)));
    let mut plain = rig(None);
    let (_, _, ended) = run(&mut plain, &[(1.0, "/law/min_sharpness", "1000")]);
    match ended {
        Err(SessionError::Fault(words)) => {
            assert!(words.contains("too little texture"), "{words}");
            println!("autofocus link: the run ended with a fault: {words}");
        }
        other => panic!("{other:?}"),
    }
}
