//! The host tool's link code (`kerf_host::link`) against the simulated Keops slave
//! behind its host link (`kerf_sim::linked`), over a socket pair with a line between
//! them that loses frames and adds garbage (the host's side):
//! a lost chunk resumed at the offset the machine reports, a damaged upload refused
//! at the commit with nothing loaded, garbage in both directions counted and
//! survived, a bad setting refused with its reason and nothing changed, and a machine
//! that stops answering seen as a typed timeout.

use hal_mock::hall_sensor::HallSensorParams;
use host_tests::link::octagon_job_file;
use kerf::codec::link::{JobKind, Refusal, Request};
use kerf_host::link::{LinkError, MachineLink, OwnedReply};
use kerf_sim::linked::with_linked_slave;
use kerf_sim::slave::SlaveScenario;
use std::io::{ErrorKind, Read, Write};
use std::os::unix::net::UnixStream;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

/// The host's side of the line: frames (one `write` each, as `MachineLink::send` makes
/// them) numbered from 0; those in `drop` are lost, and `garbage` goes out before
/// the frame numbered `garbage_before`.
struct Line {
    inner: UnixStream,
    frames: Arc<AtomicUsize>,
    drop: Arc<Mutex<Vec<usize>>>,
    garbage_before: Option<(usize, Vec<u8>)>,
}

impl Write for Line {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let k = self.frames.fetch_add(1, Ordering::Relaxed);
        if let Some((at, bytes)) = &self.garbage_before {
            if *at == k {
                self.inner.write_all(bytes)?;
            }
        }
        if self.drop.lock().unwrap().contains(&k) {
            return Ok(buf.len());
        }
        self.inner.write_all(buf)?;
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// The simulated slave on the other end of `socket`, stepping as fast as it can
/// until `stop` is set; while `mute` is set it reads and ignores the host. `noise`
/// is written to the host before the machine's first reply.
fn machine(
    socket: UnixStream,
    mute: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    noise: Vec<u8>,
) -> JoinHandle<()> {
    std::thread::spawn(move || {
        let mut socket = socket;
        // A read timeout, not non-blocking mode: the flag would be shared with the
        // writing clone below (one file description), the timeout is for reads only.
        socket
            .set_read_timeout(Some(Duration::from_millis(1)))
            .unwrap();
        let mut scenario = SlaveScenario::square();
        scenario.sensors = [HallSensorParams::LM1247_16BIT; 3];
        scenario.substeps = 1;
        let mut out = socket.try_clone().unwrap();
        out.write_all(&noise).unwrap();
        with_linked_slave::<f64, _>(&scenario, 1.0, |slave| {
            let mut buf = [0u8; 256];
            while !stop.load(Ordering::Relaxed) {
                let n = match socket.read(&mut buf) {
                    Ok(0) => return,
                    Ok(n) => n,
                    Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => 0,
                    Err(_) => return,
                };
                let input = if mute.load(Ordering::Relaxed) {
                    &[][..]
                } else {
                    &buf[..n]
                };
                let mut failed = false;
                slave
                    .period(input, &mut |frame| {
                        failed |= out.write_all(frame).is_err();
                        true
                    })
                    .expect("the idle slave steps");
                if failed {
                    return;
                }
            }
        })
        .expect("the scenario builds");
    })
}

struct Rig {
    machine: MachineLink,
    /// Frames the host has sent (its hello and the description's requests first).
    sent: Arc<AtomicUsize>,
    drop: Arc<Mutex<Vec<usize>>>,
    mute: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Drop for Rig {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            t.join().unwrap();
        }
    }
}

fn rig(garbage_to_machine: Option<(usize, Vec<u8>)>, noise_to_host: Vec<u8>) -> Rig {
    let (host, far) = UnixStream::pair().unwrap();
    let mute = Arc::new(AtomicBool::new(false));
    let stop = Arc::new(AtomicBool::new(false));
    let thread = machine(far, Arc::clone(&mute), Arc::clone(&stop), noise_to_host);
    let drop = Arc::new(Mutex::new(Vec::new()));
    let sent = Arc::new(AtomicUsize::new(0));
    let line = Line {
        inner: host.try_clone().unwrap(),
        frames: Arc::clone(&sent),
        drop: Arc::clone(&drop),
        garbage_before: garbage_to_machine,
    };
    let machine = MachineLink::connect(Box::new(host), Box::new(line), Duration::from_millis(300))
        .expect("the simulated slave answers hello");
    Rig {
        machine,
        sent,
        drop,
        mute,
        stop,
        thread: Some(thread),
    }
}

#[test]
fn a_lost_chunk_is_resumed_where_the_machine_says() {
    let mut rig = rig(None, Vec::new());
    assert_eq!(rig.machine.hello().machine, "keops-slave");
    let job = octagon_job_file();
    // Frames after the greeting: +0 begin, +1 chunk 0, +2 chunk 1 (lost), +3 status,
    // +4 chunk 1 again…
    let greeting = rig.sent.load(Ordering::Relaxed);
    assert!(
        greeting > 20,
        "hello and the description: {greeting} frames"
    );
    rig.drop.lock().unwrap().push(greeting + 2);
    let mut seen = Vec::new();
    rig.machine
        .upload(JobKind::Efd, &job, &mut |n| seen.push(n))
        .expect("the upload resumes and commits");
    assert_eq!(seen, [192, 384, 504]);
    // Begin, chunk 0, chunk 1 lost, status, chunk 1 again, chunk 2, commit.
    assert_eq!(rig.sent.load(Ordering::Relaxed) - greeting, 7);
    let status = rig.machine.status().unwrap();
    assert_eq!(status.upload_received, None, "committed: {status:?}");
    assert_eq!(status.bad_frames, 0);
}

#[test]
fn a_damaged_upload_is_refused_at_the_commit_and_nothing_is_loaded() {
    let mut rig = rig(None, Vec::new());
    let job = octagon_job_file();
    let mut damaged = job.clone();
    damaged[100] ^= 0x40;
    // The CRC announced is the good file's; the bytes sent are not.
    let seq_begin = rig
        .machine
        .ask(Request::JobBegin {
            kind: JobKind::Efd,
            total_bytes: job.len() as u32,
            crc32: kerf::codec::link::crc32(&job),
        })
        .unwrap();
    assert_eq!(seq_begin, OwnedReply::Ack);
    for (i, chunk) in damaged.chunks(192).enumerate() {
        let r = rig
            .machine
            .ask(Request::JobChunk {
                offset: (i * 192) as u32,
                data: chunk,
            })
            .unwrap();
        assert!(matches!(r, OwnedReply::JobProgress(_)), "{r:?}");
    }
    match rig.machine.command(Request::JobCommit) {
        Err(LinkError::Refused {
            refusal: Refusal::Incomplete,
            reason,
            ..
        }) => assert!(reason.contains("CRC"), "{reason}"),
        other => panic!("{other:?}"),
    }
    // Nothing loaded: a start has no job.
    match rig.machine.command(Request::Start) {
        Err(LinkError::Refused {
            refusal: Refusal::NoJob,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    // An upload past what the machine holds is refused at the begin.
    match rig
        .machine
        .upload(JobKind::Efd, &vec![0u8; 4096], &mut |_| {})
    {
        Err(LinkError::Refused {
            refusal: Refusal::TooLarge,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    // A job file the machine reads but does not cut (G-code) is refused with the
    // machine's own reason, and so is an open path too short for its speed ramps.
    let mut buf = [0u8; 256];
    let n = kerf::codec::job::write_gcode(b"G1 X1 F100\n", &mut buf).unwrap();
    match rig.machine.upload(JobKind::Gcode, &buf[..n], &mut |_| {}) {
        Err(LinkError::Refused { reason, .. }) => {
            assert!(reason.contains("contours only"), "{reason}")
        }
        other => panic!("{other:?}"),
    }
    let n =
        kerf::codec::job::write_points(&[[0.0, 0.0], [1e-4, 0.0], [1e-4, 1e-4]], &mut buf).unwrap();
    match rig.machine.upload(JobKind::Points, &buf[..n], &mut |_| {}) {
        Err(LinkError::Refused { reason, .. }) => {
            assert!(reason.contains("too short"), "{reason}")
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn garbage_both_ways_is_counted_and_the_conversation_goes_on() {
    // Garbage reaches the machine before the host's second frame, and the host
    // before the machine's first reply.
    let line_noise: Vec<u8> = (0..300u32).map(|i| (i * 89 % 253) as u8).collect();
    let mut rig = rig(Some((1, line_noise.clone())), line_noise);
    assert!(rig.machine.bad_frames() > 0);
    let status = rig.machine.status().unwrap();
    assert!(status.bad_frames > 0, "{status:?}");
    // Bad settings: refused with a reason, the value unchanged.
    let before = rig.machine.get("/slave/dob/bandwidth_hz").unwrap();
    match rig.machine.set("/slave/dob/bandwidth_hz", "\"fast\"") {
        Err(LinkError::Refused {
            refusal: Refusal::BadValue,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    match rig.machine.get("/slave/dob/no_such") {
        Err(LinkError::Refused {
            refusal: Refusal::UnknownPath,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    assert_eq!(rig.machine.get("/slave/dob/bandwidth_hz").unwrap(), before);
}

#[test]
fn a_machine_that_stops_answering_is_a_timeout() {
    let mut rig = rig(None, Vec::new());
    rig.mute.store(true, Ordering::Relaxed);
    match rig.machine.status() {
        Err(LinkError::Timeout { request, .. }) => assert_eq!(request, "status"),
        other => panic!("{other:?}"),
    }
}

/// Two requests out before any reply is read: waiting for the second skips the
/// first's reply as late and returns the second's, each matched by its number.
#[test]
fn reply_to_matches_the_request_number() {
    let mut rig = rig(None, Vec::new());
    let heartbeat = rig.machine.send(Request::Heartbeat).unwrap();
    let status = rig.machine.send(Request::Status).unwrap();
    assert_ne!(heartbeat, status);
    match rig.machine.reply_to(status, "status").unwrap() {
        OwnedReply::Status(s) => assert_eq!(s.bad_frames, 0, "{s:?}"),
        other => panic!("{other:?}"),
    }
    // The heartbeat's reply came first and was passed over: nothing is left for it.
    match rig.machine.reply_to(heartbeat, "heartbeat") {
        Err(LinkError::Timeout { request, .. }) => assert_eq!(request, "heartbeat"),
        other => panic!("{other:?}"),
    }
    let again = rig.machine.send(Request::Heartbeat).unwrap();
    assert!(matches!(
        rig.machine.reply_to(again, "heartbeat"),
        Ok(OwnedReply::Ack)
    ));
}

/// `kerf check` on the host says what the machine says after the upload: the same
/// jobs accepted, the same refused with the same code and words (a contour out of the
/// workspace, one too small for its ramps, an open path of 33 points, one with a
/// repeated point, G-code), and an accepted job's planned duration and cut are
/// those of the machine's presets.
#[test]
fn the_hosts_check_says_what_the_machine_says() {
    use kerf::codec::job::{write_gcode, write_points};
    use kerf_host::check::{check, CheckError, Machine};
    let efd_file = |scale: f64| {
        let points: Vec<[f64; 2]> = kerf::trajectory::shapes::octagon()
            .iter()
            .map(|p| [p[0] * scale, p[1] * scale])
            .collect();
        host_tests::link::efd_job_file(&points, 30)
    };
    let points_file = |points: &[[f64; 2]]| {
        let mut buf = [0u8; 1024];
        let n = write_points(points, &mut buf).unwrap();
        buf[..n].to_vec()
    };
    let letter = kerf::trajectory::shapes::letter_s();
    let mut repeated = letter.to_vec();
    repeated[3] = repeated[2];
    let long: Vec<[f64; 2]> = (0..33).map(|k| [1e-3 * k as f64, 0.0]).collect();
    let mut buf = [0u8; 64];
    let n = write_gcode(b"G1 X1 F100\n", &mut buf).unwrap();
    let gcode = buf[..n].to_vec();
    let jobs: [(&str, JobKind, Vec<u8>); 7] = [
        ("octagon ±10 mm", JobKind::Efd, efd_file(1.0)),
        ("octagon ±60 mm", JobKind::Efd, efd_file(6.0)),
        ("octagon ±0.02 mm", JobKind::Efd, efd_file(0.002)),
        ("letter s", JobKind::Points, points_file(&letter)),
        ("33 points", JobKind::Points, points_file(&long)),
        ("a repeated point", JobKind::Points, points_file(&repeated)),
        ("G-code", JobKind::Gcode, gcode),
    ];
    let mut rig = rig(None, Vec::new());
    let mut accepted = 0;
    for (what, kind, bytes) in &jobs {
        let here = check(bytes, Some(Machine::KeopsSlave));
        let there = rig.machine.upload(*kind, bytes, &mut |_| {});
        println!("{what}: here {here:?}, there {there:?}");
        match (&here, &there) {
            (Ok(checked), Ok(())) => {
                accepted += 1;
                // The preset's speed bounds the cut's time from below.
                assert!(checked.duration_s > checked.cut_length_m / 8e-3, "{what}");
            }
            (
                Err(CheckError::Refused { code, words, .. }),
                Err(LinkError::Refused { reason, .. }),
            ) => {
                let said = format!("job code {code:#06x}: {words}");
                assert!(
                    reason.contains(&said),
                    "{what}: here {said:?}, there {reason:?}"
                );
            }
            (Err(CheckError::Kind { .. }), Err(LinkError::Refused { reason, .. })) => {
                assert!(reason.contains("contours only"), "{what}: {reason}");
            }
            _ => panic!("{what}: the host says {here:?}, the machine {there:?}"),
        }
    }
    assert_eq!(accepted, 2);
}
