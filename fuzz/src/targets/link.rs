//! The host link's frames: the codec on both sides (`link_frame`) and the machine's
//! request handling behind it (`host_link`: uploads, commits, job files, settings
//! through serde-json-core and miniconf, commands and the heartbeat).
//!
//! Seeds are frames of the link's own encoder ([`kerf::codec::link::encode`]), so
//! they pass the frame CRC; `host_link` also takes bare messages that the harness
//! frames itself (version, CRC-32, COBS as `codec::link` documents), so that every
//! mutation of a message reaches the message decoder and the handler.

use crate::input::{Input, Seed};
use heapless::spsc::Queue;
use kerf::app::host_link::{HostLink, HostLinkConfig, LinkMachine};
use kerf::app::supervisor::{Command, Mode, Report};
use kerf::codec::job::write_efd;
use kerf::codec::link::{
    crc32, decode, encode, FrameReader, HostFrame, JobKind, MachineMessage, Reply, Request,
    MAX_CHUNK, MAX_FRAME, VERSION,
};
use kerf::machines::delta_slave::link::SlaveSettings;
use kerf::machines::delta_slave::product::{contour_defaults, LINK_JOB_BYTES};
use kerf::machines::delta_slave::{DeltaFault, DeltaSlave, DeltaSlaveConfig};
use kerf_sim::contour::octagon_efd;

/// Encodes `$message`, decodes it as `$type`, encodes it again: the two frames are
/// the same bytes (floats compared as bits, so a NaN does not fail the comparison).
macro_rules! round_trips {
    ($message:expr, $type:ty) => {{
        let mut first = [0u8; MAX_FRAME];
        let n = encode($message, &mut first).expect("a decoded message fits a frame");
        let mut copy = first;
        let again = decode::<$type>(&mut copy[1..n - 1]).expect("an encoded message decodes");
        let mut second = [0u8; MAX_FRAME];
        let m = encode(&again, &mut second).expect("it still fits");
        assert_eq!(first[..n], second[..m]);
    }};
}

/// `link_frame`: any byte stream through the frame reader and the decoder of both
/// directions gives frames or typed errors; every message decoded encodes again into
/// a frame that decodes to the same message. Returns the messages decoded.
pub fn link_frame(data: &[u8]) -> usize {
    let mut reader = FrameReader::<MAX_FRAME>::new();
    let mut decoded = 0;
    for &byte in data {
        let Some(Ok(frame)) = reader.push(byte) else {
            continue;
        };
        assert!(frame.len() <= MAX_FRAME);
        let mut copy = [0u8; MAX_FRAME];
        let copy = &mut copy[..frame.len()];
        copy.copy_from_slice(frame);
        if let Ok(message) = decode::<HostFrame>(frame) {
            decoded += 1;
            round_trips!(&message, HostFrame);
            let mut frame = [0u8; MAX_FRAME];
            let n = encode(&message, &mut frame).unwrap();
            assert_eq!(decode::<HostFrame>(&mut frame[1..n - 1]), Ok(message));
        }
        if let Ok(message) = decode::<MachineMessage>(copy) {
            decoded += 1;
            round_trips!(&message, MachineMessage);
        }
    }
    decoded
}

/// A message body framed as the link frames it: version, body, CRC-32, COBS, between
/// delimiters.
pub fn frame_body(body: &[u8]) -> Vec<u8> {
    let mut payload = Vec::with_capacity(body.len() + 5);
    payload.push(VERSION);
    payload.extend_from_slice(body);
    let crc = crc32(&payload);
    payload.extend_from_slice(&crc.to_le_bytes());
    let mut out = vec![0u8; payload.len() + payload.len() / 254 + 3];
    let n = cobs::try_encode(&payload, &mut out[1..]).expect("room for COBS");
    out.truncate(n + 2);
    *out.last_mut().unwrap() = 0;
    out
}

/// The body of one encoded frame (what [`frame_body`] frames).
fn body_of(frame: &[u8]) -> Vec<u8> {
    let mut cobs_bytes = frame[1..frame.len() - 1].to_vec();
    let n = cobs::decode_in_place(&mut cobs_bytes).expect("a frame of the encoder");
    cobs_bytes[1..n - 4].to_vec()
}

type Slave = DeltaSlave<f32>;

/// The step kinds of a `host_link` input.
mod step {
    /// Bytes as the host sent them.
    pub const RAW: u8 = 0;
    /// A message body, framed by the harness.
    pub const BODY: u8 = 1;
    /// Time passes (the record's first byte, ms) and the heartbeat is checked.
    pub const TICK: u8 = 2;
    /// The supervisor answers the queued commands (accepted, or refused when the
    /// record's first byte is odd).
    pub const ANSWER: u8 = 3;
    /// The supervisor reports a mode change (the record's first byte picks it).
    pub const MODE: u8 = 4;
}

/// A settings value as the link answers it: JSON for a number or a bool of the
/// slave's settings (every number finite: the tree holds validated settings).
fn check_value(value: &[u8]) {
    let text = core::str::from_utf8(value).expect("JSON is UTF-8");
    if text != "true" && text != "false" {
        let v: f64 = text
            .parse()
            .unwrap_or_else(|_| panic!("not a number: {text}"));
        assert!(v.is_finite(), "{text}");
    }
}

/// `host_link`: the Keops slave's link (`DeltaSlave<f32>`, the job buffer of the
/// simulated and emulated slave) fed steps of [`step`]'s kinds, each a kind byte and
/// a record. Every frame the link sends decodes; progress and status never report
/// more than the buffer holds; a value is a finite number or a bool; the settings
/// the link keeps always validate into coefficients. Returns the replies sent (each
/// is a request that passed the CRC and decoded).
pub fn host_link(data: &[u8]) -> usize {
    let machine = DeltaSlaveConfig::KEOPS;
    let period_s = machine.joints.period_s;
    let config = HostLinkConfig {
        period_s,
        heartbeat_timeout_s: 0.05,
    };
    let settings = SlaveSettings::of(&machine.joints.axis);
    let context = contour_defaults(&machine, 1.0);
    let jobs = kerf::app::jobs::JobSlots::default();
    let mut link = HostLink::<Slave, LINK_JOB_BYTES>::new(&config, settings, context.into(), &jobs)
        .expect("the slave's link configuration");
    let mut commands = Queue::<Command<Slave>, 4>::new();
    let (mut to_machine, mut from_link) = commands.split();
    let sent = core::cell::RefCell::new(Vec::<Vec<u8>>::new());
    let mut send = |frame: &[u8]| {
        sent.borrow_mut().push(frame.to_vec());
        true
    };
    let (mut input, mut now_s, mut replies) = (Input::new(data), 0.0, 0);
    while let (Some(kind), Some(record)) = (input.u8(), input.record()) {
        let first = record.first().copied().unwrap_or(0);
        match kind % 5 {
            step::RAW => {
                for &b in record {
                    link.receive(b, now_s, &mut to_machine, &mut send);
                }
            }
            step::BODY => {
                for b in frame_body(record) {
                    link.receive(b, now_s, &mut to_machine, &mut send);
                }
            }
            step::TICK => {
                now_s += f64::from(first) * 1e-3;
                link.tick(now_s, &mut to_machine, &mut send);
            }
            step::ANSWER => {
                while let Some(command) = from_link.dequeue() {
                    let report = if first & 1 == 1 {
                        Report::Refused {
                            command: command.kind(),
                            error: kerf::app::supervisor::CommandError::InvalidInMode,
                        }
                    } else {
                        Report::Accepted(command.kind())
                    };
                    link.report(&report, &mut send);
                }
            }
            _ => {
                let mode = match first % 6 {
                    0 => Mode::Idle,
                    1 => Mode::Calibrating,
                    2 => Mode::Ready,
                    3 => Mode::Running,
                    4 => Mode::Stopping,
                    _ => Mode::Fault(DeltaFault::FollowingError { axis: first / 6 }),
                };
                let period = u64::from(first);
                link.report(&Report::ModeChanged { period, mode }, &mut send);
            }
        }
        assert!(
            <Slave as LinkMachine>::coefficients(link.settings(), period_s).is_ok(),
            "the link keeps settings that do not validate: {:?}",
            link.settings()
        );
        for mut frame in sent.take() {
            let n = frame.len();
            assert!(n <= MAX_FRAME && frame[0] == 0 && frame[n - 1] == 0);
            let message = decode::<MachineMessage>(&mut frame[1..n - 1])
                .expect("every frame the link sends decodes");
            let MachineMessage::Reply { reply, .. } = message else {
                continue;
            };
            replies += 1;
            match reply {
                Reply::JobProgress { received } => assert!(received as usize <= LINK_JOB_BYTES),
                Reply::Status(s) => {
                    assert!(s
                        .upload_received
                        .is_none_or(|r| r as usize <= LINK_JOB_BYTES));
                }
                Reply::Value { value } => check_value(value),
                Reply::Hello { max_chunk, .. } => assert_eq!(usize::from(max_chunk), MAX_CHUNK),
                _ => {}
            }
        }
    }
    replies
}

/// The ±6 mm octagon as a 12-harmonic EFD job file (the contour the slave's tests
/// cut).
pub fn octagon_job() -> Vec<u8> {
    let efd = octagon_efd(12).expect("the octagon fits");
    let centre = efd.centre();
    let coefficients: Vec<[f64; 4]> = efd.coefficients()[..efd.harmonics()].to_vec();
    let mut out = vec![0u8; 1024];
    let n = write_efd([centre.x, centre.y], &coefficients, &mut out).expect("room");
    out.truncate(n);
    out
}

/// A host's session: hello, status, settings read and written (one refused) and
/// saved, the
/// octagon uploaded in chunks and committed, started, heartbeats, stopped.
fn session() -> Vec<(u8, Vec<u8>)> {
    let job = octagon_job();
    let mut steps = Vec::new();
    let mut seq = 0u16;
    let mut ask = |steps: &mut Vec<(u8, Vec<u8>)>, request: Request<'_>| {
        seq += 1;
        let mut out = [0u8; MAX_FRAME];
        let n = encode(&HostFrame { seq, request }, &mut out).expect("a request fits");
        steps.push((step::RAW, out[..n].to_vec()));
    };
    ask(&mut steps, Request::Hello);
    for index in [0, 11, 12, 17, 18, 40, u16::MAX] {
        ask(&mut steps, Request::Describe { index });
    }
    ask(&mut steps, Request::Status);
    ask(&mut steps, Request::Telemetry { every_periods: 100 });
    let path = "/slave/dob/bandwidth_hz";
    ask(&mut steps, Request::Get { path });
    ask(
        &mut steps,
        Request::Set {
            path,
            value: b"120",
        },
    );
    ask(&mut steps, Request::Set { path, value: b"-1" });
    // The fuzzed link has no store: refused.
    ask(&mut steps, Request::Save);
    ask(
        &mut steps,
        Request::Set {
            path: "/slave/dob/compensate",
            value: b"true",
        },
    );
    steps.push((step::ANSWER, vec![0]));
    let total_bytes = job.len() as u32;
    let crc32 = crc32(&job);
    ask(
        &mut steps,
        Request::JobBegin {
            kind: JobKind::Efd,
            total_bytes,
            crc32,
        },
    );
    for (k, data) in job.chunks(MAX_CHUNK).enumerate() {
        let offset = (k * MAX_CHUNK) as u32;
        ask(&mut steps, Request::JobChunk { offset, data });
    }
    ask(&mut steps, Request::JobStatus);
    ask(&mut steps, Request::JobCommit);
    steps.push((step::ANSWER, vec![0]));
    ask(&mut steps, Request::Start);
    steps.push((step::ANSWER, vec![0]));
    steps.push((step::MODE, vec![3]));
    ask(&mut steps, Request::Heartbeat);
    steps.push((step::TICK, vec![20]));
    steps.push((step::TICK, vec![80]));
    ask(&mut steps, Request::Stop);
    steps.push((step::ANSWER, vec![1]));
    steps.push((step::MODE, vec![5]));
    ask(&mut steps, Request::ResetFault);
    steps.push((step::ANSWER, vec![0]));
    steps
}

/// Seeds of [`host_link`]: the session as frames, and as bodies the harness frames.
pub fn host_link_seeds() -> Vec<Vec<u8>> {
    let steps = session();
    let as_frames = steps
        .iter()
        .fold(Seed::new(), |s, (k, r)| s.u8(*k).record(r));
    let as_bodies = steps.iter().fold(Seed::new(), |s, (k, r)| match *k {
        step::RAW => s.u8(step::BODY).record(&body_of(r)),
        _ => s.u8(*k).record(r),
    });
    vec![as_frames.0, as_bodies.0]
}

/// Seeds of [`link_frame`]: every request of the session, and the slave's answers to
/// it (replies, events and a telemetry sample), as one stream each.
pub fn link_frame_seeds() -> Vec<Vec<u8>> {
    let requests: Vec<u8> = session()
        .into_iter()
        .filter(|(k, _)| *k == step::RAW)
        .flat_map(|(_, r)| r)
        .collect();
    let mut answers = Vec::new();
    let seed = host_link_seeds().remove(0);
    replay_answers(&seed, &mut answers);
    let sample = kerf::codec::link::TelemetrySample {
        period: 12_345,
        values: [
            1e-3, -2e-3, 0.25, 0.0, 0.0, 0.25, 3e-7, 0.5, -1.0, 1.5, 10.0,
        ]
        .into_iter()
        .collect(),
        ..Default::default()
    };
    let mut out = [0u8; MAX_FRAME];
    let n = encode(&MachineMessage::Telemetry(sample), &mut out).unwrap();
    answers.extend_from_slice(&out[..n]);
    vec![requests, answers]
}

/// Runs a `host_link` input and collects every frame the link sends.
fn replay_answers(data: &[u8], out: &mut Vec<u8>) {
    let machine = DeltaSlaveConfig::KEOPS;
    let config = HostLinkConfig {
        period_s: machine.joints.period_s,
        heartbeat_timeout_s: 0.05,
    };
    let settings = SlaveSettings::of(&machine.joints.axis);
    let jobs = kerf::app::jobs::JobSlots::default();
    let context = contour_defaults(&machine, 1.0);
    let mut link =
        HostLink::<Slave, LINK_JOB_BYTES>::new(&config, settings, context.into(), &jobs).unwrap();
    let mut commands = Queue::<Command<Slave>, 4>::new();
    let (mut to_machine, mut from_link) = commands.split();
    let mut send = |frame: &[u8]| {
        out.extend_from_slice(frame);
        true
    };
    let mut input = Input::new(data);
    while let (Some(kind), Some(record)) = (input.u8(), input.record()) {
        match kind {
            step::RAW => {
                for &b in record {
                    link.receive(b, 0.0, &mut to_machine, &mut send);
                }
            }
            step::ANSWER => {
                while let Some(command) = from_link.dequeue() {
                    link.report(&Report::Accepted(command.kind()), &mut send);
                }
            }
            _ => {}
        }
    }
}
