//! The grinding cell operated as a product: the simulated cell behind its host link
//! (`kerf_sim::linked_grinding`, f64, with its hexapod and spindle on their protocols)
//! and the host tool's own session code (`kerf_host::session`) on a socket pair. The
//! host knows nothing of the cell but what it describes: it uploads a pass as a G-code
//! job file, starts it, streams the forces, changes a gain mid-pass and hears the end;
//! then a device broken mid-pass (a command the hexapod's controller refuses, a
//! converter that stops answering) is heard as a fault in the cell's words, and the
//! simulation's device link latched the fault of the device broken.

use host_tests::link::{run_plan, serve, MachineThread, Pace};
use kerf::codec::gcs::code;
use kerf::codec::job::write_gcode;
use kerf::codec::link::JobKind;
use kerf::machines::grinding::{DeviceFault, HexapodFault, SpindleFault};
use kerf_host::link::{LinkError, MachineLink};
use kerf_host::session::{Progress, RunPlan, Session, SessionError};
use kerf_host::telemetry::TelemetryLog;
use kerf_sim::linked_grinding::{with_linked_grinding, PASS_GCODE};
use std::os::unix::net::UnixStream;
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

/// A device to break: none, the hexapod's controller, the spindle's converter.
const BREAK_NONE: u8 = 0;
const BREAK_HEXAPOD: u8 = 1;
const BREAK_SPINDLE: u8 = 2;

/// Machine time per host second the simulated cell is held to, at most: unpaced, the
/// cell's cheap periods would end a 5 s pass before a busy host's mid-pass change
/// arrives. Only a bound on speed: a slower machine changes nothing.
const PACE: f64 = 2.0;

/// The heartbeat timeout of the simulated cell, s of machine time: long, so that a
/// busy host is not taken for a lost one (the heartbeat is tested with the link).
const HEARTBEAT_TIMEOUT_S: f64 = 1e4;

/// The device link's fault as the simulation latched it: in the period a device was
/// broken (before the break), and the first one after it.
type DeviceFaults = Arc<Mutex<(Option<DeviceFault>, Option<DeviceFault>)>>;

/// The simulated cell on the far end of `socket`, a period per turn at [`PACE`],
/// until `stop` is set or the host hangs up; `breaks` names a device to break
/// (once), `faults` gets the device link's fault around it. Bytes from the host come
/// through a reader thread, so a period never waits for them.
fn machine(
    socket: UnixStream,
    stop: Arc<AtomicBool>,
    breaks: Arc<AtomicU8>,
    faults: DeviceFaults,
) -> JoinHandle<()> {
    std::thread::spawn(move || {
        with_linked_grinding::<f64, _>(HEARTBEAT_TIMEOUT_S, |cell| {
            let pace = Pace::Scaled {
                period_s: 1e-3,
                speedup: PACE,
            };
            let mut broken = false;
            serve(socket, &stop, pace, |_, input, send| {
                let device = breaks.swap(BREAK_NONE, Ordering::Relaxed);
                if device != BREAK_NONE {
                    faults.lock().unwrap().0 = cell.device_fault();
                    broken = true;
                }
                match device {
                    // VLS beyond the H-824's 1 mm/s: the controller sets error 8,
                    // which the device link's next ERR? reads.
                    BREAK_HEXAPOD => {
                        let mut reply = [0u8; 64];
                        cell.hexapod_mut().handle(b"VLS 50\n", &mut reply);
                    }
                    BREAK_SPINDLE => cell.spindle_mut().answering = false,
                    _ => {}
                }
                cell.period(input, send);
                let mut faults = faults.lock().unwrap();
                if broken && faults.1.is_none() {
                    faults.1 = cell.device_fault();
                }
                true
            })
        })
        .expect("the cell builds and calibrates");
    })
}

/// The pass's job file as scripts/smoke uploads it to the QEMU image (`kerf gcode`
/// checks programs with ARROW's loader, which a pass along X at the origin is not):
/// the committed bytes are the job writer's from the G-code, rewritten with
/// `KERF_WRITE_DATA=1`.
#[test]
fn the_committed_pass_job_is_its_gcode() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../data/grinding_pass.krfj");
    if std::env::var_os("KERF_WRITE_DATA").is_some() {
        std::fs::write(path, pass_job()).unwrap();
    }
    assert_eq!(std::fs::read(path).unwrap(), pass_job());
}

fn pass_job() -> Vec<u8> {
    let mut out = vec![0u8; PASS_GCODE.len() + 64];
    let n = write_gcode(PASS_GCODE.as_bytes(), &mut out).unwrap();
    out.truncate(n);
    out
}

struct Rig {
    /// First, so that the machine stops before the host's end closes.
    _machine: MachineThread,
    session: Session,
    breaks: Arc<AtomicU8>,
    faults: DeviceFaults,
}

fn rig() -> Rig {
    let (host, far) = UnixStream::pair().unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let breaks = Arc::new(AtomicU8::new(BREAK_NONE));
    let faults = DeviceFaults::default();
    let thread = machine(
        far,
        Arc::clone(&stop),
        Arc::clone(&breaks),
        Arc::clone(&faults),
    );
    let link = MachineLink::connect(
        Box::new(host.try_clone().unwrap()),
        Box::new(host),
        Duration::from_secs(5),
    )
    .expect("the simulated cell answers");
    Rig {
        session: Session::over(link),
        breaks,
        faults,
        _machine: MachineThread::new(stop, thread),
    }
}

fn plan(changes: &[(f64, &str, &str)]) -> RunPlan {
    run_plan(100.0, 30, changes)
}

/// The pass (0.5 mm at 0.1 mm/s: 5 s, the first 2 s of it the piezo's approach) runs
/// to its end with the PID's Kp changed from 8.42 to 8 nm/N at 3.5 s, acknowledged.
/// The force follows the cell's 7.5 N: over the samples from the first contact plus
/// 1 s, the mean measured normal force is within 1.5 N of it. The PID's command is the
/// piezo's increment, so following the surface's slope leaves an error of the slope's
/// rate over Kp per second: G's sinusoid (50 µm, 4 mm) rises at up to
/// 7.8 µm/s under a 0.1 mm/s feed, against 8.4 µm/s per N, about 0.9 N; the noise
/// (σ 0.9 N) averages to 0.06 N over 200 samples. The cell fed the pass's 0.5 mm.
#[test]
fn the_host_grinds_a_pass_from_its_gcode_file() {
    let mut rig = rig();
    let m = &rig.session.machine;
    assert_eq!(m.hello().machine, "grinding");
    assert!((m.hello().period_s - 1e-3).abs() < 1e-12);
    let d = m.description().clone();
    assert_eq!(d.job_kinds, [JobKind::Gcode]);
    assert_eq!(d.settings.len(), 11);
    assert_eq!(d.channels.len(), 9);
    // The wrong kind of job is refused in the cell's words, nothing loaded.
    let mut efd = [0u8; 128];
    let n = kerf::codec::job::write_efd([0.0, 0.0], &[[1e-3, 0.0, 0.0, 1e-3]], &mut efd).unwrap();
    match rig
        .session
        .machine
        .upload(JobKind::Efd, &efd[..n], &mut |_| {})
    {
        Err(LinkError::Refused { reason, .. }) => {
            assert!(reason.contains("G-code passes only"), "{reason}")
        }
        other => panic!("{other:?}"),
    }
    // A gain past its bound: refused naming the range the cell announced.
    match rig.session.machine.set("/pid/anti_windup", "1001") {
        Err(e @ LinkError::Refused { .. }) => {
            assert!(e.to_string().ends_with("takes 0 to 1000 1/s"), "{e}")
        }
        other => panic!("{other:?}"),
    }
    let mut log = TelemetryLog::new(1e-3, &d.channels);
    let mut lines = Vec::new();
    let ended = rig.session.run_job(
        JobKind::Gcode,
        &pass_job(),
        &plan(&[(3.5, "/pid/kp", "8")]),
        &mut log,
        None,
        &mut |p| {
            if let Progress::Line(t, text) = p {
                lines.push(format!("{t:.3} {text}"));
            }
        },
    );
    let summary = log.summary();
    println!("grinding link: {summary}");
    println!("grinding link: {lines:?}");
    ended.expect("the pass runs to its end");
    assert!(
        lines.iter().any(|l| l.ends_with("set /pid/kp = 8")),
        "{lines:?}"
    );
    assert_eq!(rig.session.machine.get("/pid/kp").unwrap(), "8.0");
    let series = |name: &str| -> Vec<(f64, f64)> {
        log.entries()
            .iter()
            .filter_map(|e| Some((e.time_s, log.value(e, name)?)))
            .collect()
    };
    let force = series("normal_force");
    let contact = force
        .iter()
        .find(|(_, f)| *f > 3.0)
        .map(|(t, _)| *t)
        .expect("the tool touches the workpiece");
    let steady: Vec<f64> = force
        .iter()
        .filter(|(t, _)| *t > contact + 1.0)
        .map(|(_, f)| *f)
        .collect();
    let mean = steady.iter().sum::<f64>() / steady.len() as f64;
    let rms = (steady.iter().map(|f| (f - 7.5).powi(2)).sum::<f64>() / steady.len() as f64).sqrt();
    let fed = series("fed").last().map_or(0.0, |(_, v)| *v);
    println!(
        "grinding link: {} samples, contact at {contact:.2} s, {} steady: mean normal force {mean:.2} N, RMS error {rms:.2} N; fed {:.3} mm",
        force.len(),
        steady.len(),
        fed * 1e3
    );
    assert!(steady.len() > 200, "{}", steady.len());
    assert!((mean - 7.5).abs() < 1.5, "{mean}");
    assert!(series("force_reference").iter().any(|(_, r)| *r == 7.5));
    assert!(fed > 0.49e-3, "{fed}");
    assert!(summary.to_string().contains("force peak"), "{summary}");
}

/// Runs the pass and breaks `device` 1 s into it: the run ends in a fault, in words;
/// with them, the device link's fault before the break and after it, as the
/// simulation latched it.
fn broken_pass(device: u8) -> (String, (Option<DeviceFault>, Option<DeviceFault>)) {
    let mut rig = rig();
    let channels = rig.session.machine.description().channels.clone();
    let mut log = TelemetryLog::new(1e-3, &channels);
    let breaks = Arc::clone(&rig.breaks);
    let mut broken = false;
    let ended = rig.session.run_job(
        JobKind::Gcode,
        &pass_job(),
        &plan(&[]),
        &mut log,
        None,
        &mut |p| {
            if let Progress::Sample(t, _) = p {
                if t > 1.0 && !broken {
                    breaks.store(device, Ordering::Relaxed);
                    broken = true;
                }
            }
        },
    );
    let faults = Arc::clone(&rig.faults);
    // The machine thread stops and is joined: its last period's fault is recorded.
    drop(rig);
    let faults = *faults.lock().unwrap();
    match ended {
        Err(SessionError::Fault(words)) => (words, faults),
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_gcs_error_of_the_hexapod_is_heard_in_the_cells_words() {
    let (words, faults) = broken_pass(BREAK_HEXAPOD);
    println!("grinding link: the hexapod's fault: {words}");
    assert_eq!(
        words,
        "the hexapod's controller reported a GCS error (code 8)"
    );
    // Healthy until the break; then the error the VLS set: velocity out of limits.
    assert_eq!(
        faults,
        (
            None,
            Some(DeviceFault::Hexapod(HexapodFault::Controller(
                code::VEL_OUT_OF_LIMITS
            )))
        )
    );
}

#[test]
fn a_silent_spindle_is_heard_in_the_cells_words() {
    let (words, faults) = broken_pass(BREAK_SPINDLE);
    println!("grinding link: the spindle's fault: {words}");
    assert_eq!(
        words,
        "the spindle's converter stopped answering (silent ticks in a row 5)"
    );
    assert_eq!(
        faults,
        (
            None,
            Some(DeviceFault::Spindle(SpindleFault::Silent { ticks: 5 }))
        )
    );
}
