//! A session with one machine, a board on a serial port or the emulated one, and the
//! run of a job on it: upload, start, telemetry with heartbeats, setting changes at
//! given machine times or typed by the operator, until the job ends, faults or the
//! machine stops it.

use crate::link::{Heard, LinkError, MachineLink};
use crate::qemu::{self, Qemu, QemuError};
use crate::telemetry::{Entry, TelemetryLog};
use kerf::codec::link::{Event, JobKind, ModeCode, Refusal, Request, JOB_NOT_AT_REST};
use std::path::PathBuf;
use std::sync::mpsc::{Receiver, Sender};
use std::time::{Duration, Instant};

/// Where the machine is.
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// A board's serial port (a UART adapter or USB CDC) at `baud`.
    Port {
        /// The device, such as `/dev/ttyACM0`.
        device: String,
        /// Bits per second (ignored by USB CDC).
        baud: u32,
    },
    /// The emulated machine: this firmware image on QEMU.
    Qemu {
        /// The link image.
        image: PathBuf,
    },
}

/// Why a session failed.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The link.
    #[error(transparent)]
    Link(#[from] LinkError),
    /// The emulated machine did not start.
    #[error(transparent)]
    Qemu(#[from] QemuError),
    /// The serial port did not open.
    #[error("{device}: cannot open the machine's port: {message}")]
    Port {
        /// The device.
        device: String,
        /// Why.
        message: String,
    },
    /// The machine faulted during the run.
    #[error("the machine faulted: {0}")]
    Fault(String),
    /// The machine stopped the job because the host's heartbeats stopped.
    #[error("the machine lost the host and stopped the job")]
    HostLost,
    /// The machine went quiet during the run.
    #[error("the machine sent nothing for {0} s")]
    Quiet(u64),
    /// The machine stopped the job (an operator's stop).
    #[error("the job was stopped before its end")]
    Stopped,
    /// A change of the run's plan names a setting the machine does not have.
    #[error("{path}: the machine has no such setting (it has {known})")]
    UnknownSetting {
        /// The path asked for.
        path: String,
        /// The machine's settings.
        known: String,
    },
    /// The job ran to its end, but the machine refused a change of the run's plan
    /// (the first such, in words).
    #[error("the job ran to its end, but a planned change was refused: {0}")]
    ChangeRefused(String),
    /// A part of the job after the first could not be given to the machine.
    #[error("part {part} of {of}: {error}")]
    Part {
        /// Which part, from 1.
        part: usize,
        /// Of how many.
        of: usize,
        /// What the link or the machine said.
        error: LinkError,
    },
}

/// An open session; the emulated machine ends with it.
pub struct Session {
    /// The machine.
    pub machine: MachineLink,
    _qemu: Option<Qemu>,
}

/// Replies slower than this are lost (the emulated machine answers within a few of
/// its periods; a board within one supervisor tick).
const REPLY_TIMEOUT: Duration = Duration::from_secs(10);

impl Session {
    /// A session with a machine already connected over any byte stream (a test's
    /// socket pair, a machine simulated in the same process).
    pub fn over(machine: MachineLink) -> Self {
        Session {
            machine,
            _qemu: None,
        }
    }

    /// Connects to `target` and greets the machine.
    pub fn open(target: &Target) -> Result<Self, SessionError> {
        match target {
            Target::Qemu { image } => {
                let (q, stream) = qemu::start(image)?;
                let reader = stream.try_clone().map_err(LinkError::Io)?;
                let machine =
                    MachineLink::connect(Box::new(reader), Box::new(stream), REPLY_TIMEOUT)?;
                Ok(Session {
                    machine,
                    _qemu: Some(q),
                })
            }
            Target::Port { device, baud } => {
                let port_error = |e: serialport::Error| SessionError::Port {
                    device: device.clone(),
                    message: match e.kind {
                        serialport::ErrorKind::Io(kind) => {
                            crate::output::io_words(&std::io::Error::from(kind))
                        }
                        serialport::ErrorKind::NoDevice => "no such device".into(),
                        _ => e.description,
                    },
                };
                let port = serialport::new(device, *baud)
                    .timeout(Duration::from_millis(100))
                    .open()
                    .map_err(port_error)?;
                let reader = port.try_clone().map_err(port_error)?;
                let machine =
                    MachineLink::connect(Box::new(reader), Box::new(port), REPLY_TIMEOUT)?;
                Ok(Session {
                    machine,
                    _qemu: None,
                })
            }
        }
    }
}

/// A setting changed at a machine time of the run.
#[derive(Clone, Debug, PartialEq)]
pub struct TimedChange {
    /// Machine time after the start, s.
    pub at_s: f64,
    /// The setting's path.
    pub path: String,
    /// Its new value, JSON.
    pub value: String,
}

/// How a job is run.
#[derive(Clone, Debug, PartialEq)]
pub struct RunPlan {
    /// Telemetry samples per second of machine time.
    pub telemetry_hz: f64,
    /// Settings to change during the run, in time order.
    pub changes: Vec<TimedChange>,
    /// Seconds of silence after which the host gives up.
    pub quiet_s: u64,
}

/// What a run reports as it goes.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Progress<'a> {
    /// Bytes of the job the machine holds.
    Uploaded(u32),
    /// Machine time since the cut began, s, at a telemetry sample (the clock of
    /// [`RunPlan::changes`]), and the sample on the log's time axis.
    Sample(f64, &'a Entry),
    /// An event, a change or an operator's command, with the machine's time of the
    /// latest sample, s (the time axis of the run's plots; 0 before the first
    /// sample).
    Line(f64, &'a str),
}

/// Tries to give the machine the next part when it rests between parts (a commit the
/// machine finds busy is tried again; at rest it has a free buffer).
const START_TRIES: usize = 8;

/// Longest a start waits for the machine's axes to come to rest (carriages that slide
/// to their end stops after power-up take about 0.1 s).
const START_REST_WAIT: Duration = Duration::from_secs(5);

/// Longest a run waits for a machine that calibrates at power-up (the remote slave's
/// 0.8 s sweep takes about 40 s on the emulated MCU, which runs its 10 kHz period and
/// simulated delta well below real time).
const CALIBRATION_WAIT: Duration = Duration::from_secs(300);

/// Waits while the machine calibrates (the board's own task runs its calibration at
/// power-up), for at most [`CALIBRATION_WAIT`]; the mode it ends in. The task that
/// fits the calibration also answers the link, so a status may go unanswered while it
/// fits: asked again, until the wait is over.
fn wait_calibrated(
    m: &mut MachineLink,
    mut mode: ModeCode,
    progress: &mut dyn FnMut(Progress<'_>),
) -> Result<ModeCode, LinkError> {
    let since = Instant::now();
    if mode == ModeCode::Calibrating {
        progress(Progress::Line(0.0, "waiting for the machine's calibration"));
    }
    while mode == ModeCode::Calibrating && since.elapsed() < CALIBRATION_WAIT {
        m.next(Duration::from_millis(200))?;
        match m.status() {
            Ok(status) => mode = status.mode,
            Err(LinkError::Timeout { .. }) if since.elapsed() < CALIBRATION_WAIT => {}
            Err(e) => return Err(e),
        }
    }
    Ok(mode)
}

/// Starts the loaded job, again every 20 ms while the machine refuses because an axis
/// still moves (its first move starts from rest), for at most [`START_REST_WAIT`].
fn start_at_rest(
    m: &mut MachineLink,
    progress: &mut dyn FnMut(Progress<'_>),
) -> Result<(), LinkError> {
    let since = Instant::now();
    let mut told = false;
    loop {
        match m.command(Request::Start) {
            Err(LinkError::Refused {
                refusal: Refusal::Job(JOB_NOT_AT_REST),
                ..
            }) if since.elapsed() < START_REST_WAIT => {
                if !told {
                    progress(Progress::Line(0.0, "waiting for the axes to come to rest"));
                    told = true;
                }
                m.next(Duration::from_millis(20))?;
            }
            started => return started,
        }
    }
}

/// An operator's line for the machine during a run (`set PATH VALUE`, `get PATH`,
/// `stop`), and where its answer goes.
#[derive(Debug)]
pub struct Order {
    /// The line.
    pub line: String,
    /// Told what the machine answered, in words (`None`: the answer is only logged).
    pub answer: Option<Sender<Result<String, String>>>,
}

impl Order {
    /// A line whose answer is only logged (the terminal's).
    pub fn logged(line: String) -> Self {
        Order { line, answer: None }
    }
}

/// An operator's line during a run: `set PATH VALUE`, `get PATH` or `stop`; whether
/// the machine took a stop.
fn console(
    machine: &mut MachineLink,
    order: Order,
    t: f64,
    log: &mut TelemetryLog,
    progress: &mut dyn FnMut(Progress<'_>),
) -> bool {
    let line = order.line.as_str();
    let words: Vec<&str> = line.split_whitespace().collect();
    let outcome = match words.as_slice() {
        ["set", path, value] => machine
            .set(path, value)
            .map(|()| format!("set {path} = {value}")),
        ["get", path] => machine.get(path).map(|v| format!("{path} = {v}")),
        ["stop"] => machine.command(Request::Stop).map(|()| "stop".to_owned()),
        [] => return false,
        _ => {
            let text =
                format!("not understood during a run: {line:?} (set PATH VALUE, get PATH, stop)");
            if let Some(answer) = order.answer {
                let _ = answer.send(Err(text));
                return false;
            }
            Ok(text)
        }
    };
    let stopped = matches!(&outcome, Ok(s) if s == "stop");
    let outcome = outcome.map_err(|e| e.to_string());
    let text = match &outcome {
        Ok(s) | Err(s) => s.clone(),
    };
    if let Some(answer) = order.answer {
        // A client gone before the answer changes nothing on the machine.
        let _ = answer.send(outcome);
    }
    log.mark(&text);
    progress(Progress::Line(t, &text));
    stopped
}

/// The parts of a run: how many the machine has been given and has begun.
struct Parts<'j> {
    parts: &'j [(JobKind, &'j [u8])],
    /// Committed to the machine (loaded, or queued behind the running part).
    committed: usize,
    /// Begun (by `Start` or as the queued part, [`Event::NextJob`]).
    begun: usize,
    /// The next part is uploaded but its commit found the machine's buffers busy.
    commit_pending: bool,
}

impl Parts<'_> {
    /// Gives the machine the next part (committed, not begun) again as one that starts
    /// at rest, where it was to continue the part before at speed
    /// ([`crate::job::starting_at_rest`]).
    fn at_rest(&mut self, m: &mut MachineLink) -> Result<(), SessionError> {
        let Some(&(kind, bytes)) = self.parts.get(self.begun) else {
            return Ok(());
        };
        // It was read before it was sent: it reads.
        let fresh = crate::job::starting_at_rest(bytes).unwrap_or_else(|_| bytes.to_vec());
        if fresh.as_slice() == bytes {
            return Ok(());
        }
        m.upload(kind, &fresh, &mut |_| {})
            .map_err(|error| SessionError::Part {
                part: self.begun + 1,
                of: self.parts.len(),
                error,
            })
    }

    /// Gives the machine the next part if it has room for it (one part queued behind
    /// the running one at most); a commit the machine finds busy is tried again.
    fn feed(&mut self, m: &mut MachineLink) -> Result<(), SessionError> {
        let Some(&(kind, bytes)) = self.parts.get(self.committed) else {
            return Ok(());
        };
        if self.committed > self.begun {
            return Ok(());
        }
        let committed = if self.commit_pending {
            m.command(Request::JobCommit)
        } else {
            m.upload(kind, bytes, &mut |_| {})
        };
        match committed {
            Ok(()) => {
                self.committed += 1;
                self.commit_pending = false;
                Ok(())
            }
            Err(LinkError::Refused {
                refusal: Refusal::Busy,
                ..
            }) => {
                self.commit_pending = true;
                Ok(())
            }
            Err(e) => Err(SessionError::Part {
                part: self.committed + 1,
                of: self.parts.len(),
                error: e,
            }),
        }
    }
}

impl Session {
    /// Uploads `job`, starts it and follows it to its end ([`Session::run_parts`]
    /// with one part).
    pub fn run_job(
        &mut self,
        kind: JobKind,
        job: &[u8],
        plan: &RunPlan,
        log: &mut TelemetryLog,
        console_lines: Option<&Receiver<Order>>,
        progress: &mut dyn FnMut(Progress<'_>),
    ) -> Result<(), SessionError> {
        self.run_parts(&[(kind, job)], plan, log, console_lines, progress)
    }

    /// Uploads the first of `parts` (job files of their kinds), starts it and follows
    /// the run to the end of the last, changing settings as `plan` says and as the
    /// operator types on `console_lines`, telling `progress` as it goes. Each further
    /// part is uploaded while the one before runs and queued behind it, so the machine
    /// goes on to it without stopping (its approach, tool off, leads from where the
    /// part before ended); a part that ends before the next is queued, or whose start
    /// the machine refuses at that moment, is followed by a `Start` of the next. The
    /// telemetry goes into `log` whatever the end.
    ///
    /// Errors: the link; the machine refusing a part; a fault, a stop or a lost host
    /// before the end (the log holds what came until then).
    pub fn run_parts(
        &mut self,
        parts: &[(JobKind, &[u8])],
        plan: &RunPlan,
        log: &mut TelemetryLog,
        console_lines: Option<&Receiver<Order>>,
        progress: &mut dyn FnMut(Progress<'_>),
    ) -> Result<(), SessionError> {
        let m = &mut self.machine;
        let Some(&(kind, job)) = parts.first() else {
            return Ok(());
        };
        // A change of a setting the machine does not have fails before anything
        // is sent, not in the middle of the cut.
        let settings = &m.description().settings;
        if let Some(c) = plan
            .changes
            .iter()
            .find(|c| !settings.iter().any(|s| s.path == c.path))
        {
            return Err(SessionError::UnknownSetting {
                path: c.path.clone(),
                known: settings
                    .iter()
                    .map(|s| s.path.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        let mut refused_change: Option<String> = None;
        let status = m.status()?;
        let mode = wait_calibrated(m, status.mode, progress)?;
        if mode == ModeCode::Fault {
            m.command(Request::ResetFault)?;
            progress(Progress::Line(0.0, "fault reset before the job"));
        }
        m.upload(kind, job, &mut |n| progress(Progress::Uploaded(n)))?;
        m.telemetry(plan.telemetry_hz)?;
        start_at_rest(m, progress)?;
        let mut parts = Parts {
            parts,
            committed: 1,
            begun: 1,
            commit_pending: false,
        };
        let description = m.description().clone();
        let mut changes = plan.changes.iter().peekable();
        let mut last_heartbeat = Instant::now();
        let mut last_heard = Instant::now();
        let mut running = false;
        let mut stopped = false;
        loop {
            let heard = m.next(Duration::from_millis(50))?;
            match heard {
                Some(Heard::Telemetry(sample)) => {
                    last_heard = Instant::now();
                    log.push(sample);
                    // A heartbeat per sample keeps the machine's timeout counting its
                    // own periods, whatever the host's speed.
                    m.send(Request::Heartbeat)?;
                    last_heartbeat = Instant::now();
                    let now = log.since_cut_s();
                    if let Some(entry) = log.entries().last() {
                        progress(Progress::Sample(now, entry));
                    }
                    while let Some(c) = changes.next_if(|c| c.at_s <= now) {
                        let text = match m.set(&c.path, &c.value) {
                            Ok(()) => format!("set {} = {}", c.path, c.value),
                            Err(e) => {
                                let text = format!("set {} = {}: {e}", c.path, c.value);
                                refused_change.get_or_insert(text.clone());
                                text
                            }
                        };
                        log.mark(&text);
                        progress(Progress::Line(log.latest_s(), &text));
                    }
                }
                Some(Heard::Event(e)) => {
                    last_heard = Instant::now();
                    let now = log.latest_s();
                    let text = description.event_words(&e);
                    // Marked on the plots: faults and the like, not the mode changes
                    // and the parts of a program (they would crowd the plot's labels).
                    if !matches!(e, Event::Mode { .. } | Event::NextJob) {
                        log.mark(&text);
                    }
                    progress(Progress::Line(now, &text));
                    match e {
                        Event::Mode {
                            to: ModeCode::Running,
                            ..
                        } => running = true,
                        Event::Mode {
                            from: ModeCode::Running | ModeCode::Stopping,
                            to: ModeCode::Ready,
                        } if running => {
                            if stopped {
                                return Err(SessionError::Stopped);
                            }
                            if parts.begun == parts.parts.len() {
                                return match refused_change {
                                    Some(text) => Err(SessionError::ChangeRefused(text)),
                                    None => Ok(()),
                                };
                            }
                            // The machine rests between parts: the next one is given
                            // (if it was not yet) and started; one that was to go on
                            // from the part before at speed came too late, and starts
                            // at rest instead.
                            for _ in 0..START_TRIES {
                                if parts.committed > parts.begun {
                                    break;
                                }
                                parts.feed(m)?;
                            }
                            parts.at_rest(m)?;
                            start_at_rest(m, progress)?;
                            parts.begun += 1;
                            let text =
                                format!("part {} of {} started", parts.begun, parts.parts.len());
                            progress(Progress::Line(now, &text));
                        }
                        Event::NextJob => parts.begun += 1,
                        // The fault's reason follows its mode change: the run ends
                        // when it has come.
                        Event::Fault { code, detail } => {
                            return Err(SessionError::Fault(description.fault_words(code, detail)))
                        }
                        Event::HostLost => return Err(SessionError::HostLost),
                        _ => {}
                    }
                }
                Some(Heard::Reply(..)) => {}
                Some(Heard::OtherVersion(machine)) => {
                    return Err(SessionError::Link(LinkError::Version {
                        machine,
                        host: kerf::codec::link::VERSION,
                    }))
                }
                None => {
                    if last_heard.elapsed() > Duration::from_secs(plan.quiet_s) {
                        return Err(SessionError::Quiet(plan.quiet_s));
                    }
                }
            }
            if let Some(lines) = console_lines {
                while let Ok(order) = lines.try_recv() {
                    let now = log.latest_s();
                    stopped |= console(m, order, now, log, progress);
                }
            }
            if running && !stopped {
                parts.feed(m)?;
            }
            // Between samples (slow telemetry, a slow link), at least every 100 ms.
            if last_heartbeat.elapsed() > Duration::from_millis(100) {
                m.send(Request::Heartbeat)?;
                last_heartbeat = Instant::now();
            }
        }
    }
}
