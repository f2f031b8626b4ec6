use super::*;
use crate::app::host_link::{describe, HostLink, HostLinkConfig, SettingText};
use crate::app::jobs::JobSlots;
use crate::app::supervisor::{Command, Machine, Mode, NonFiniteOutput, Report, Supervisor};
use crate::codec::job::{write_gcode, write_recording};
use crate::codec::link::{
    decode, encode, Description, Event, HostFrame, MachineMessage, Request, MAX_FRAME,
};
use crate::machines::delta_slave::remote::product::{LINK_JOB_BYTES, PERIOD_S};
use heapless::spsc::Queue;
use miniconf::json_core;
use std::boxed::Box;
use std::format;
use std::string::String;
use std::vec::Vec;

type S = SessionSlave<f64>;

/// The recorded master session the QEMU replay plays (4 s, 24 KB of frames).
const RECORDING: &[u8] = include_bytes!("../../../../../../../data/remote_commands.krfr");

/// The first `periods` of the recording as a session job file.
fn session_file(periods: u32) -> Vec<u8> {
    let recording = Recording::parse(RECORDING).unwrap();
    let mut session = std::vec![0u8; RECORDING.len()];
    let n = recording.write_session(periods, &mut session).unwrap();
    let mut out = std::vec![0u8; n + 64];
    let n = write_recording(&session[..n], &mut out).unwrap();
    out.truncate(n);
    out
}

fn load(bytes: &[u8]) -> Result<Box<SessionJob>, u16> {
    let file = JobFile::read(bytes).unwrap();
    let mut job = Box::<SessionJob>::default();
    <S as LinkMachine>::load_job(&mut (), &file, &mut job).map(|()| job)
}

fn refusal_words(code: u16) -> &'static str {
    CodeWords::find(&JOB_REFUSALS, code).unwrap().words
}

/// The first 2 s load: the recorded header, the frames that arrived before 2 s; the
/// whole 4 s do not fit and are refused in the slave's words; a job of another kind
/// is refused as such.
#[test]
fn a_session_loads_and_other_jobs_are_refused_in_words() {
    let job = load(&session_file(20_000)).unwrap();
    let recording = Recording::parse(RECORDING).unwrap();
    assert_eq!(job.header.periods, 20_000);
    assert_eq!(job.header.start_m, recording.header.start_m);
    assert_eq!(job.header.margin_periods, recording.header.margin_periods);
    assert!(job.frames.len() <= SESSION_FRAME_BYTES);
    // Every frame kept arrived before 2 s; the next one of the recording did not.
    let mut at = 0;
    let mut last = 0;
    while let Some((arrival, _, next)) =
        crate::machines::delta_slave::remote::recording::frame_at(&job.frames, at)
    {
        (at, last) = (next, arrival);
    }
    assert_eq!(at, job.frames.len());
    assert!(last < 20_000);
    let (following, _, _) =
        crate::machines::delta_slave::remote::recording::frame_at(recording.frames(), at).unwrap();
    assert!(following >= 20_000, "{following}");
    // The 4 s do not fit.
    let code = load(&session_file(40_000)).unwrap_err();
    assert!(refusal_words(code).contains("12 KiB"), "{code}");
    // G-code is not a session.
    let mut gcode = [0u8; 64];
    let n = write_gcode(b"G1 X1 F100\n", &mut gcode).unwrap();
    let code = load(&gcode[..n]).unwrap_err();
    assert_eq!(code, load_codes::KIND);
    assert_eq!(
        refusal_words(code),
        "this slave plays recorded master sessions only"
    );
    // A damaged recording: its words say so.
    let mut session = std::vec![0u8; RECORDING.len()];
    let n = recording.write_session(20_000, &mut session).unwrap();
    let mut out = std::vec![0u8; n + 64];
    let cut = write_recording(&session[..n - 1], &mut out).unwrap();
    let code = load(&out[..cut]).unwrap_err();
    assert!(refusal_words(code).contains("damaged"), "{code}");
    // The empty job is refused by the slave's check.
    let slave = S::new(&CONFIG).unwrap();
    let e = slave.check_job(&SessionJob::default()).unwrap_err();
    assert!(refusal_words(S::job_error_code(&e)).contains("no frame"));
}

/// The description: the channels in the order of a sample, the recording kind, the
/// settings with units and ranges, the words of every code.
#[test]
fn the_slave_describes_itself() {
    let mut items = Vec::new();
    for index in 0.. {
        let mut text = SettingText::default();
        match describe::<S>(index, &RemoteSlaveSettings::of_product(), &mut text) {
            Some(Description::Setting {
                path, unit, range, ..
            }) => items.push(format!("setting {path} [{unit}] {range}")),
            Some(item) => items.push(format!("{item:?}")),
            None => break,
        }
    }
    let settings: Vec<&String> = items.iter().filter(|i| i.starts_with("setting")).collect();
    assert_eq!(settings.len(), 9, "{settings:?}");
    for expected in [
        "setting /slave/dob/bandwidth_hz [Hz] > 0 and ≤ 3183",
        "setting /model_following/bandwidth_hz [Hz] > 0",
        "setting /link/hold_after_s [s] > 0",
        "setting /link/give_up_after_s [s] > hold_after_s, in whole periods",
    ] {
        assert!(items.contains(&expected.into()), "{expected}: {settings:?}");
    }
    assert_eq!(
        items.len(),
        CHANNELS.len() + 1 + 9 + FAULTS.len() + JOB_REFUSALS.len()
    );
    assert_eq!(items[CHANNELS.len()], "JobKind(Recording)");
    crate::app::host_link::test_support::assert_code_tables(&FAULTS, &JOB_REFUSALS);
}

/// The product's settings give back its configuration; the announced ranges are
/// where validation refuses.
#[test]
fn the_settings_are_the_configurations_and_their_ranges_hold() {
    let settings = RemoteSlaveSettings::of_product();
    let back = settings.model_following();
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-14 * b.abs();
    assert!(close(back.kp_per_s2, CONFIG.model_following.kp_per_s2));
    assert!(close(back.kd_per_s, CONFIG.model_following.kd_per_s));
    assert!(S::coefficients(&settings, PERIOD_S).is_ok());
    let set = |path: &str, value: &str| {
        let mut s = settings;
        json_core::set(&mut s, path, value.as_bytes()).unwrap();
        S::coefficients(&s, PERIOD_S).map(|_| ())
    };
    // The give-up must be more whole periods than the hold (0.05 s: 500 periods).
    assert!(set("/link/give_up_after_s", "0.0501").is_ok());
    let e = set("/link/give_up_after_s", "0.05").unwrap_err();
    assert_eq!(e.field(), "give_up_after_s");
    assert_eq!(
        set("/link/hold_after_s", "0").unwrap_err().field(),
        "hold_after_s"
    );
    let e = set("/model_following/bandwidth_hz", "-1").unwrap_err();
    assert!(format!("{e}").starts_with("model_following."), "{e}");
    assert!(set("/slave/dob/bandwidth_hz", "3183").is_ok());
    assert!(set("/slave/dob/bandwidth_hz", "3184").is_err());
}

/// Every fault has its words; a link loss and a carriage's fault say which.
#[test]
fn every_fault_has_its_words() {
    use crate::app::axis::AxisFault;
    use crate::app::joints::JointFault;
    let faults = [
        RemoteSlaveFault::Slave(DeltaFault::Joint(JointFault {
            axis: 2,
            fault: AxisFault::NotFinite,
        })),
        RemoteSlaveFault::Slave(DeltaFault::Kinematics(
            crate::kinematics::delta::KinematicsError::SingularJ2,
        )),
        RemoteSlaveFault::Slave(DeltaFault::Saturated),
        RemoteSlaveFault::Slave(DeltaFault::Output(NonFiniteOutput { index: 3 })),
        RemoteSlaveFault::LinkLost,
    ];
    let codes: Vec<(u16, u16)> = faults.iter().map(S::fault_code).collect();
    assert_eq!(codes, [(1, 2), (2, 0), (3, 0), (4, 3), (5, 0)]);
    assert!(FAULTS.iter().map(|f| f.code).eq(1..=5));
    let lost = CodeWords::find(&FAULTS, 5).unwrap();
    assert!(lost.words.contains("fell silent"), "{}", lost.words);
}

/// What the host got.
fn messages(sent: &[Vec<u8>]) -> Vec<String> {
    sent.iter()
        .map(|frame| {
            let mut raw = frame[1..frame.len() - 1].to_vec();
            format!("{:?}", decode::<MachineMessage>(&mut raw).unwrap())
        })
        .collect()
}

fn frame(seq: u16, request: Request<'_>) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    let n = encode(&HostFrame { seq, request }, &mut out).unwrap();
    out[..n].to_vec()
}

/// The slave behind its link, its Hall counts `hall` every period: a setting past
/// its range or at an unknown path is refused and changes nothing; Hall counts that
/// fail the carriages' checks fault the slave, and the host hears the fault in the
/// slave's words.
#[test]
fn bad_settings_change_nothing_and_a_fault_is_heard_in_words() {
    let jobs = JobSlots::default();
    let mut commands = Queue::<Command<S>, 2>::new();
    let mut reports = Queue::<Report<S>, 16>::new();
    let (mut to_machine, from_sender) = commands.split();
    let (to_link, mut from_machine) = reports.split();
    let mut supervisor = Supervisor::new(S::new(&CONFIG).unwrap(), from_sender, to_link, &jobs);
    supervisor.set_telemetry_decimation(0);
    let config = HostLinkConfig {
        period_s: PERIOD_S,
        heartbeat_timeout_s: 1.0,
    };
    let settings = RemoteSlaveSettings::of_product();
    let mut link =
        Box::new(HostLink::<S, LINK_JOB_BYTES>::new(&config, settings, (), &jobs).unwrap());
    let mut sent = Vec::new();
    for (seq, path, value, answer) in [
        (
            1,
            "/link/give_up_after_s",
            &b"0.01"[..],
            "Refused(BadValue)",
        ),
        (
            2,
            "/model_following/bandwidth_hz",
            b"0",
            "Refused(BadValue)",
        ),
        (3, "/link/nope", b"1", "Refused(UnknownPath)"),
        (4, "/slave/dob", b"1", "Refused(UnknownPath)"),
    ] {
        let before = sent.len();
        for &b in &frame(seq, Request::Set { path, value }) {
            link.receive(b, 0.0, &mut to_machine, &mut |f| {
                sent.push(f.to_vec());
                true
            });
        }
        let got = messages(&sent[before..]);
        assert_eq!(got.len(), 1, "{got:?}");
        assert!(got[0].contains(answer), "{path}: {got:?}");
        assert_eq!(*link.settings(), settings);
        assert!(to_machine.ready(), "nothing queued for {path}");
    }
    // Every Hall count at zero: no carriage's sensors read so.
    for _ in 0..3 {
        supervisor.step(&[[0u16; 3]; 3]);
        while let Some(r) = from_machine.dequeue() {
            link.report(&r, &mut |f| {
                sent.push(f.to_vec());
                true
            });
        }
    }
    assert!(
        matches!(supervisor.mode(), Mode::Fault(_)),
        "{:?}",
        supervisor.mode()
    );
    let mut raw: Vec<u8> = sent.last().unwrap().clone();
    let n = raw.len();
    let event = decode::<MachineMessage>(&mut raw[1..n - 1]).unwrap();
    let MachineMessage::Event(Event::Fault { code, detail }) = event else {
        panic!("{event:?}")
    };
    let words = CodeWords::find(&FAULTS, code).unwrap();
    assert!(
        words.words.starts_with("a carriage faulted"),
        "{}",
        words.words
    );
    assert_eq!(words.detail, "carriage");
    assert_eq!(detail, 0);
}
