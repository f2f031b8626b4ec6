//! The link against the real supervisor running a toy machine: a simulated host
//! sends frames byte by byte and reads what comes back.

use super::*;
use crate::app::jobs::JobSlots;
use crate::app::supervisor::{Step, Supervisor};
use crate::codec::job::{write_gcode, write_points};
use crate::codec::link::JobKind;
use heapless::spsc::Queue;
use miniconf::Tree;
use std::vec::Vec;

#[derive(Tree, Copy, Clone, Debug, PartialEq)]
struct Limits {
    speed_m_s: f32,
}

#[derive(Tree, Copy, Clone, Debug, PartialEq)]
struct ToySettings {
    gain: f32,
    limits: Limits,
}

const SETTINGS: ToySettings = ToySettings {
    gain: 2.0,
    limits: Limits { speed_m_s: 0.01 },
};

/// Runs jobs of `n` periods (the point count); faults on a broken sensor.
#[derive(Default)]
struct Toy {
    left: u32,
    gain: f32,
}

impl From<crate::app::supervisor::NonFiniteOutput> for u8 {
    fn from(output: crate::app::supervisor::NonFiniteOutput) -> Self {
        output.index
    }
}

impl Machine for Toy {
    type Inputs = bool;
    type Outputs = u8;
    type Job = u32;
    type JobError = u8;
    type Coefficients = f32;
    type SweepSample = crate::app::supervisor::NoSweep;
    type Calibration = ();
    type Fault = u8;
    type Telemetry = u32;
    fn safe_outputs(&self) -> u8 {
        0
    }
    fn monitor(&mut self, ok: &bool) -> Result<(), u8> {
        if *ok {
            Ok(())
        } else {
            Err(7)
        }
    }
    fn begin_calibration(&mut self) {}
    fn calibrate(
        &mut self,
        ok: &bool,
        _: &mut dyn FnMut(crate::app::supervisor::NoSweep),
    ) -> Result<Step<u8>, u8> {
        self.monitor(ok)?;
        Ok(Step::Done(0))
    }
    fn finish_calibration(&mut self, _: &()) {}
    fn check_job(&self, job: &u32) -> Result<(), u8> {
        if *job > 200 {
            Err(3)
        } else {
            Ok(())
        }
    }
    fn begin_job(&mut self, job: &u32) -> Result<(), u8> {
        self.left = *job;
        Ok(())
    }
    fn run(&mut self, _: &u32, ok: &bool) -> Result<Step<u8>, u8> {
        self.monitor(ok)?;
        self.left = self.left.saturating_sub(1);
        Ok(if self.left == 0 {
            Step::Done(1)
        } else {
            Step::Continue(1)
        })
    }
    fn begin_stop(&mut self) {}
    fn stop(&mut self, _: &u32, ok: &bool) -> Result<Step<u8>, u8> {
        self.monitor(ok)?;
        Ok(Step::Done(0))
    }
    fn set_coefficients(&mut self, gain: &f32) {
        self.gain = *gain;
    }
    fn reset(&mut self) {}
    fn telemetry(&self) -> u32 {
        self.left
    }
}

impl LinkMachine for Toy {
    type Settings = ToySettings;
    type JobContext = ();
    const NAME: &'static str = "toy";
    const CHANNELS: &'static [Channel] = &[Channel {
        name: "left",
        unit: "1",
    }];
    const JOB_KINDS: &'static [JobKind] = &[JobKind::Points];
    const FAULTS: &'static [CodeWords] = &[CodeWords {
        code: 1,
        words: "the toy broke",
        detail: "",
    }];
    const JOB_REFUSALS: &'static [CodeWords] = &[CodeWords {
        code: 1,
        words: "not a point job",
        detail: "",
    }];
    fn coefficients(s: &ToySettings, _period_s: f64) -> Result<f32, ConfigError> {
        positive("gain", f64::from(s.gain))?;
        positive("limits.speed_m_s", f64::from(s.limits.speed_m_s))?;
        Ok(s.gain)
    }
    fn load_job(_: &mut (), file: &JobFile<'_>, job: &mut u32) -> Result<(), u16> {
        match file {
            JobFile::Points { .. } if file.count() > 0 => {
                *job = file.count() as u32;
                Ok(())
            }
            _ => Err(1),
        }
    }
    fn job_error_code(e: &u8) -> u16 {
        u16::from(*e)
    }
    fn fault_code(f: &u8) -> (u16, u16) {
        (u16::from(*f), 0)
    }
    fn sample(t: &u32, values: &mut ChannelValues) {
        values.clear();
        let _ = values.push(*t as f32);
    }
}

/// What the host got: owned copies of the decoded messages.
#[derive(Clone, Debug, PartialEq)]
enum Got {
    Reply(u16, std::string::String),
    Telemetry(TelemetrySample),
    Event(Event),
}

fn got(frame: &[u8]) -> Got {
    let mut raw = frame[1..frame.len() - 1].to_vec();
    match decode::<MachineMessage>(&mut raw).unwrap() {
        MachineMessage::Reply { seq, reply } => Got::Reply(seq, std::format!("{reply:?}")),
        MachineMessage::Telemetry(t) => Got::Telemetry(t),
        MachineMessage::Event(e) => Got::Event(e),
    }
}

fn frame(seq: u16, request: Request<'_>) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    let n = encode(&HostFrame { seq, request }, &mut out).unwrap();
    out[..n].to_vec()
}

/// Runs the toy through the supervisor with the link in front of it.
struct Rig<'q> {
    supervisor: Supervisor<'q, Toy>,
    link: HostLink<'q, Toy, 2048>,
    to_machine: Producer<'q, Command<Toy>>,
    from_machine: heapless::spsc::Consumer<'q, Report<Toy>>,
    sent: Vec<Vec<u8>>,
    now_s: f64,
    periods_run: u64,
    sensor_ok: bool,
}

impl Rig<'_> {
    /// The host sends `bytes`; then `periods` control periods pass (1 ms each), the
    /// link reading the reports after each.
    fn exchange(&mut self, bytes: &[u8], periods: u32) -> Vec<Got> {
        let mut sent = Vec::new();
        for &b in bytes {
            self.link
                .receive(b, self.now_s, &mut self.to_machine, &mut |f| {
                    sent.push(f.to_vec());
                    true
                });
        }
        for _ in 0..periods {
            self.supervisor.step(&self.sensor_ok);
            self.periods_run += 1;
            self.now_s += 1e-3;
            while let Some(r) = self.from_machine.dequeue() {
                self.link.report(&r, &mut |f| {
                    sent.push(f.to_vec());
                    true
                });
            }
            self.link.tick(self.now_s, &mut self.to_machine, &mut |f| {
                sent.push(f.to_vec());
                true
            });
        }
        self.sent.extend(sent.iter().cloned());
        sent.iter().map(|f| got(f)).collect()
    }
}

impl Rig<'_> {
    /// The period of the last telemetry report the link read (the toy reports every
    /// period; the supervisor counts from 0).
    fn supervisor_period(&self) -> u64 {
        self.periods_run - 1
    }
}

fn with_rig(test: impl FnOnce(&mut Rig<'_>)) {
    let jobs = JobSlots::default();
    let mut commands: Queue<Command<Toy>, 4> = Queue::new();
    let mut reports: Queue<Report<Toy>, 64> = Queue::new();
    let (to_machine, from_sender) = commands.split();
    let (to_sender, from_machine) = reports.split();
    let mut supervisor = Supervisor::new(Toy::default(), from_sender, to_sender, &jobs);
    supervisor.set_telemetry_decimation(1);
    let config = HostLinkConfig {
        period_s: 1e-3,
        heartbeat_timeout_s: 0.05,
    };
    let mut rig = Rig {
        supervisor,
        link: HostLink::new(&config, SETTINGS, (), &jobs).unwrap(),
        to_machine,
        from_machine,
        sent: Vec::new(),
        now_s: 0.0,
        periods_run: 0,
        sensor_ok: true,
    };
    // Calibrated and ready, as the board's own task leaves it.
    rig.to_machine.enqueue(Command::Calibrate).ok();
    rig.exchange(&[], 2);
    rig.to_machine.enqueue(Command::FinishCalibration(())).ok();
    rig.exchange(&[], 2);
    assert_eq!(rig.supervisor.mode(), Mode::Ready);
    test(&mut rig);
}

fn reply(seq: u16, text: &str) -> Got {
    Got::Reply(seq, text.into())
}

fn points_job(n: usize) -> Vec<u8> {
    let points: Vec<[f64; 2]> = (0..n).map(|i| [i as f64 * 1e-4, 0.0]).collect();
    let mut buf = [0u8; 4096];
    let len = write_points(&points, &mut buf).unwrap();
    buf[..len].to_vec()
}

fn upload(rig: &mut Rig<'_>, job: &[u8], seq0: u16) -> Vec<Got> {
    let crc = crc32(job);
    let mut out = rig.exchange(
        &frame(
            seq0,
            Request::JobBegin {
                kind: JobKind::Points,
                total_bytes: job.len() as u32,
                crc32: crc,
            },
        ),
        0,
    );
    for (i, chunk) in job.chunks(40).enumerate() {
        out.extend(rig.exchange(
            &frame(
                seq0 + 1 + i as u16,
                Request::JobChunk {
                    offset: (i * 40) as u32,
                    data: chunk,
                },
            ),
            0,
        ));
    }
    out
}

#[test]
fn hello_and_a_job_uploaded_in_chunks_runs_with_telemetry_and_events() {
    with_rig(|rig| {
        let hello = rig.exchange(&frame(1, Request::Hello), 0);
        assert_eq!(
            hello,
            [reply(
                1,
                &std::format!(
                    "Hello {{ version: {}, machine: \"toy\", max_chunk: 192, period_ns: 1000000 }}",
                    crate::codec::link::VERSION
                )
            )]
        );
        let job = points_job(20); // 12 + 160 + 4 = 176 bytes: five chunks
        let progress = upload(rig, &job, 10);
        assert_eq!(progress[0], reply(10, "Ack"));
        assert_eq!(
            progress.last(),
            Some(&reply(15, "JobProgress { received: 176 }"))
        );
        // The commit is answered when the supervisor has loaded the job.
        assert!(rig.exchange(&frame(16, Request::JobCommit), 0).is_empty());
        assert_eq!(rig.exchange(&[], 1), [reply(16, "Ack")]);
        rig.exchange(&frame(17, Request::Telemetry { every_periods: 5 }), 0);
        let run = rig.exchange(&frame(18, Request::Start), 25);
        assert!(run.contains(&reply(18, "Ack")), "{run:?}");
        assert!(run.contains(&Got::Event(Event::Mode {
            from: ModeCode::Ready,
            to: ModeCode::Running
        })));
        let samples: Vec<&TelemetrySample> = run
            .iter()
            .filter_map(|g| match g {
                Got::Telemetry(t) => Some(t),
                _ => None,
            })
            .collect();
        // 20 periods of job at one sample per 5 periods; each 5 apart.
        assert!(samples.len() >= 4, "{run:?}");
        assert!(samples.windows(2).all(|w| w[1].period - w[0].period == 5));
        assert!(run.contains(&Got::Event(Event::Mode {
            from: ModeCode::Running,
            to: ModeCode::Ready
        })));
    });
}

#[test]
fn a_lost_reply_resumes_at_the_offset_the_machine_reports() {
    with_rig(|rig| {
        let job = points_job(20);
        let crc = crc32(&job);
        let begin = Request::JobBegin {
            kind: JobKind::Points,
            total_bytes: job.len() as u32,
            crc32: crc,
        };
        rig.exchange(&frame(1, begin), 0);
        rig.exchange(
            &frame(
                2,
                Request::JobChunk {
                    offset: 0,
                    data: &job[..40],
                },
            ),
            0,
        );
        // The host lost that reply and sends the chunk again: refused with the offset
        // the machine expects; a chunk beyond it too.
        let again = rig.exchange(
            &frame(
                3,
                Request::JobChunk {
                    offset: 0,
                    data: &job[..40],
                },
            ),
            0,
        );
        assert_eq!(again, [reply(3, "Refused(ChunkOffset { expected: 40 })")]);
        let ahead = rig.exchange(
            &frame(
                4,
                Request::JobChunk {
                    offset: 80,
                    data: &job[80..120],
                },
            ),
            0,
        );
        assert_eq!(ahead, [reply(4, "Refused(ChunkOffset { expected: 40 })")]);
        assert_eq!(
            rig.exchange(&frame(5, Request::JobStatus), 0),
            [reply(5, "JobProgress { received: 40 }")]
        );
        // A commit now is refused and keeps the upload; the rest completes it.
        assert_eq!(
            rig.exchange(&frame(6, Request::JobCommit), 0),
            [reply(6, "Refused(Incomplete)")]
        );
        rig.exchange(
            &frame(
                7,
                Request::JobChunk {
                    offset: 40,
                    data: &job[40..],
                },
            ),
            0,
        );
        rig.exchange(&frame(8, Request::JobCommit), 0);
        assert_eq!(rig.exchange(&[], 1), [reply(8, "Ack")]);
    });
}

#[test]
fn bad_uploads_are_refused_and_nothing_reaches_the_machine() {
    with_rig(|rig| {
        // Announced larger than the buffer.
        let big = Request::JobBegin {
            kind: JobKind::Points,
            total_bytes: 2049,
            crc32: 0,
        };
        assert_eq!(
            rig.exchange(&frame(1, big), 0),
            [reply(1, "Refused(TooLarge)")]
        );
        // A chunk with no upload.
        let chunk = Request::JobChunk {
            offset: 0,
            data: &[1, 2, 3],
        };
        assert_eq!(
            rig.exchange(&frame(2, chunk), 0),
            [reply(2, "Refused(NoJob)")]
        );
        // Uploaded whole but with a wrong CRC announced.
        let job = points_job(4);
        let wrong = Request::JobBegin {
            kind: JobKind::Points,
            total_bytes: job.len() as u32,
            crc32: crc32(&job) ^ 1,
        };
        rig.exchange(&frame(3, wrong), 0);
        rig.exchange(
            &frame(
                4,
                Request::JobChunk {
                    offset: 0,
                    data: &job,
                },
            ),
            0,
        );
        assert_eq!(
            rig.exchange(&frame(5, Request::JobCommit), 0),
            [reply(5, "Refused(Incomplete)")]
        );
        // A G-code file announced as points: the kinds differ.
        let mut buf = [0u8; 64];
        let n = write_gcode(b"G1 X1 F1\n", &mut buf).unwrap();
        let gcode = &buf[..n];
        let as_points = Request::JobBegin {
            kind: JobKind::Points,
            total_bytes: n as u32,
            crc32: crc32(gcode),
        };
        rig.exchange(&frame(6, as_points), 0);
        rig.exchange(
            &frame(
                7,
                Request::JobChunk {
                    offset: 0,
                    data: gcode,
                },
            ),
            0,
        );
        assert_eq!(
            rig.exchange(&frame(8, Request::JobCommit), 0),
            [reply(8, "Refused(Job(65534))")]
        );
        // A job the machine refuses (201 points, past its 200): the supervisor's code.
        upload(rig, &points_job(201), 20);
        rig.exchange(&frame(90, Request::JobCommit), 0);
        assert_eq!(rig.exchange(&[], 1), [reply(90, "Refused(Job(3))")]);
        // Nothing was loaded: a start is refused.
        assert_eq!(
            rig.exchange(&frame(91, Request::Start), 1),
            [reply(91, "Refused(NoJob)")]
        );
        assert_eq!(rig.supervisor.mode(), Mode::Ready);
    });
}

#[test]
fn settings_by_path_are_validated_before_anything_changes() {
    with_rig(|rig| {
        assert_eq!(
            rig.exchange(
                &frame(
                    1,
                    Request::Get {
                        path: "/limits/speed_m_s"
                    }
                ),
                0
            ),
            [reply(1, "Value { value: [48, 46, 48, 49] }")] // "0.01"
        );
        for (seq, path, value, answer) in [
            (2, "/gain/x", &b"1.0"[..], "Refused(UnknownPath)"),
            (3, "/nope", b"1.0", "Refused(UnknownPath)"),
            (4, "/gain", b"\"fast\"", "Refused(BadValue)"),
            (5, "/gain", b"-1.0", "Refused(BadValue)"),
            (6, "/limits/speed_m_s", b"0", "Refused(BadValue)"),
        ] {
            let r = rig.exchange(&frame(seq, Request::Set { path, value }), 1);
            assert_eq!(r, [reply(seq, answer)], "{path}");
            assert_eq!(*rig.link.settings(), SETTINGS);
        }
        assert!(rig
            .exchange(
                &frame(
                    7,
                    Request::Set {
                        path: "/gain",
                        value: b"3.5"
                    }
                ),
                0
            )
            .is_empty());
        assert_eq!(rig.exchange(&[], 1), [reply(7, "Ack")]);
        assert_eq!(rig.link.settings().gain, 3.5);
        assert_eq!(rig.supervisor.machine().gain, 3.5);
    });
}

#[test]
fn garbage_is_counted_and_a_silent_host_stops_the_job() {
    with_rig(|rig| {
        let noise: Vec<u8> = (0..500u32).map(|i| (i * 37 % 251) as u8).collect();
        assert!(rig.exchange(&noise, 0).is_empty());
        assert!(rig.link.counters().bad_frames > 0);
        // Still understood after the noise.
        assert_eq!(
            rig.exchange(&frame(1, Request::Heartbeat), 0),
            [reply(1, "Ack")]
        );
        // A job of 150 periods; the host present for 20, then silent past the 50 ms.
        upload(rig, &points_job(150), 40);
        rig.exchange(&frame(100, Request::JobCommit), 1);
        let run = rig.exchange(&frame(101, Request::Start), 5);
        assert!(run.contains(&reply(101, "Ack")), "{run:?}");
        // Heartbeats keep it running.
        for k in 0..3 {
            rig.exchange(&frame(102 + k, Request::Heartbeat), 5);
        }
        assert_eq!(rig.supervisor.mode(), Mode::Running);
        let silent = rig.exchange(&[], 60);
        assert!(silent.contains(&Got::Event(Event::HostLost)), "{silent:?}");
        assert_eq!(rig.supervisor.mode(), Mode::Ready);
        // Stopped early: the job had periods left.
        assert!(rig.supervisor.machine().left > 0);
    });
}

#[test]
fn a_fault_reaches_the_host_as_an_event_with_its_code() {
    with_rig(|rig| {
        upload(rig, &points_job(20), 1);
        rig.exchange(&frame(10, Request::JobCommit), 1);
        rig.exchange(&frame(11, Request::Start), 3);
        rig.sensor_ok = false;
        let out = rig.exchange(&frame(12, Request::Heartbeat), 1);
        assert!(
            out.contains(&Got::Event(Event::Fault { code: 7, detail: 0 })),
            "{out:?}"
        );
        rig.sensor_ok = true;
        let reset = rig.exchange(&frame(13, Request::ResetFault), 1);
        assert!(reset.contains(&reply(13, "Ack")), "{reset:?}");
        assert_eq!(rig.supervisor.mode(), Mode::Idle);
        // A host that joins now reads the mode and the fault that was reset; a bad
        // frame and a half upload show too.
        rig.exchange(&[0, 1, 2, 3, 0], 0);
        rig.exchange(
            &frame(
                14,
                Request::JobBegin {
                    kind: JobKind::Points,
                    total_bytes: 100,
                    crc32: 0,
                },
            ),
            0,
        );
        let period = rig.supervisor_period();
        let status = rig.exchange(&frame(15, Request::Status), 0);
        let want = MachineStatus {
            mode: ModeCode::Idle,
            last_fault: Some((7, 0)),
            period,
            upload_received: Some(0),
            bad_frames: 1,
            unsent: 0,
            settings: SettingsOrigin::NoStore,
        };
        assert_eq!(
            status,
            [reply(15, &std::format!("{:?}", Reply::Status(want)))]
        );
    });
}

#[test]
fn a_board_fault_is_sent_and_kept_for_a_host_that_asks_later() {
    use crate::codec::link::{board_fault, BOARD_FAULT};
    with_rig(|rig| {
        let code = BOARD_FAULT | board_fault::WATCHDOG;
        let mut sent = Vec::new();
        rig.link.board_fault(code, 0, &mut |f| {
            sent.push(f.to_vec());
            true
        });
        let events: Vec<Got> = sent.iter().map(|f| got(f)).collect();
        assert_eq!(events, [Got::Event(Event::Fault { code, detail: 0 })]);
        // The machine goes on (the board's fault is not the supervisor's), and a host
        // that joins reads the board's fault as the last one.
        rig.exchange(&[], 2);
        assert_eq!(rig.supervisor.mode(), Mode::Ready);
        let period = rig.supervisor_period();
        let status = rig.exchange(&frame(1, Request::Status), 0);
        let want = MachineStatus {
            mode: ModeCode::Ready,
            last_fault: Some((code, 0)),
            period,
            upload_received: None,
            bad_frames: 0,
            unsent: 0,
            settings: SettingsOrigin::NoStore,
        };
        assert_eq!(
            status,
            [reply(1, &std::format!("{:?}", Reply::Status(want)))]
        );
    });
}

/// The control period as `Hello` carries it (whole ns in a u32): periods that round
/// to 0 ns or past u32::MAX ns (4.29 s) are refused at construction, not sent as 0 or
/// saturated; the edges that fit pass.
#[test]
fn a_period_the_hello_cannot_carry_is_refused() {
    let new = |period_s: f64| {
        let config = HostLinkConfig {
            period_s,
            heartbeat_timeout_s: 0.05,
        };
        HostLink::<Toy, 64>::new(&config, SETTINGS, (), &JobSlots::default()).map(|_| ())
    };
    for period_s in [1e-12, 0.49e-9, 4.3, 10.0] {
        assert_eq!(
            new(period_s),
            Err(ConfigError::out_of_range("period_s")),
            "{period_s}"
        );
    }
    for period_s in [0.6e-9, 1e-4, 4.29] {
        assert_eq!(new(period_s), Ok(()), "{period_s}");
    }
}

/// Each corrupted frame is one bad frame (counted once, no reply), a good frame is
/// not counted, and every message the sender refuses is one unsent message; the
/// status reply carries both counts.
#[test]
fn bad_frames_and_unsent_messages_are_counted_once_each() {
    with_rig(|rig| {
        assert_eq!(rig.link.counters(), LinkCounters::default());
        for k in 1..=3u32 {
            let mut bad = frame(10 + k as u16, Request::Heartbeat);
            // A payload byte changed, never to the delimiter.
            let b = &mut bad[3];
            *b = if *b == 0xff { 0xfe } else { *b + 1 };
            assert!(rig.exchange(&bad, 0).is_empty());
            assert_eq!(rig.link.counters().bad_frames, k);
        }
        assert_eq!(
            rig.exchange(&frame(20, Request::Heartbeat), 0),
            [reply(20, "Ack")]
        );
        assert_eq!(rig.link.counters().bad_frames, 3);
        // The sender refuses: each reply not sent is counted.
        for k in 1..=2u32 {
            for &b in &frame(30, Request::Heartbeat) {
                rig.link
                    .receive(b, rig.now_s, &mut rig.to_machine, &mut |_| false);
            }
            assert_eq!(rig.link.counters().unsent, k);
        }
        let status = rig.exchange(&frame(40, Request::Status), 0);
        let [Got::Reply(40, text)] = &status[..] else {
            panic!("{status:?}")
        };
        assert!(text.contains("bad_frames: 3, unsent: 2"), "{text}");
        assert_eq!(
            rig.link.counters(),
            LinkCounters {
                bad_frames: 3,
                unsent: 2
            }
        );
    });
}

/// A host asks item after item: the machine's channel, job kind, settings (nested
/// paths, each with its preset: the value as flashed, not as set since), fault and
/// refusal words, then `None`.
#[test]
fn the_machine_describes_itself_item_by_item() {
    with_rig(|rig| {
        let set = Request::Set {
            path: "/gain",
            value: b"3.5",
        };
        assert!(rig.exchange(&frame(39, set), 0).is_empty());
        assert_eq!(rig.exchange(&[], 1), [reply(39, "Ack")]);
        let mut items = Vec::new();
        for index in 0..8u16 {
            let got = rig.exchange(&frame(40 + index, Request::Describe { index }), 0);
            assert_eq!(got.len(), 1, "{got:?}");
            items.push(got[0].clone());
        }
        let expected = [
            r#"Description { index: 0, item: Some(Channel { name: "left", unit: "1" }) }"#,
            "Description { index: 1, item: Some(JobKind(Points)) }",
            r#"Description { index: 2, item: Some(Setting { path: "/gain", unit: "", range: "", preset: "2.0" }) }"#,
            r#"Description { index: 3, item: Some(Setting { path: "/limits/speed_m_s", unit: "", range: "", preset: "0.01" }) }"#,
            r#"Description { index: 4, item: Some(Fault { code: 1, words: "the toy broke", detail: "" }) }"#,
            r#"Description { index: 5, item: Some(JobRefusal { code: 1, words: "not a point job" }) }"#,
            "Description { index: 6, item: None }",
            "Description { index: 7, item: None }",
        ];
        for (i, (got, want)) in items.iter().zip(expected).enumerate() {
            assert_eq!(*got, reply(40 + i as u16, want));
        }
    });
}

/// A frame of another link version is not read; the machine says which version it
/// refused, in its own.
#[test]
fn a_frame_of_another_version_is_answered_with_both_versions() {
    with_rig(|rig| {
        let mut other = frame(1, Request::Status);
        let n = other.len();
        let mut raw = other[1..n - 1].to_vec();
        let len = cobs::decode_in_place(&mut raw).unwrap();
        raw.truncate(len);
        raw[0] = VERSION - 1;
        let crc = crc32(&raw[..len - 4]).to_le_bytes();
        raw[len - 4..].copy_from_slice(&crc);
        let mut encoded = std::vec![0u8; MAX_FRAME];
        let m = cobs::encode(&raw, &mut encoded);
        other = [&[0u8][..], &encoded[..m], &[0u8]].concat();
        let got = rig.exchange(&other, 0);
        assert_eq!(
            got,
            [Got::Event(Event::VersionRefused {
                version: VERSION - 1
            })]
        );
        assert_eq!(rig.link.counters().bad_frames, 1);
    });
}

mod store;
