//! The machine's side of the host link: the slower task that reads the
//! host's frames ([`crate::codec::link`]), turns them into supervisor commands,
//! answers, and forwards telemetry and events. It never touches the control period:
//! it talks to the supervisor only through its command and report queues, and does
//! everything expensive (assembling and checking an uploaded job, validating a
//! setting into coefficients) before a command is queued.
//!
//! - **Jobs** arrive in chunks into a buffer of `J` bytes: `JobBegin` (kind, size,
//!   CRC), `JobChunk`s at the offset reached so far (any other offset is refused with
//!   the offset expected, so the host resumes there after a lost reply), `JobCommit`:
//!   size and CRC checked, the job file read ([`crate::codec::job`]) and built into
//!   the machine's job ([`LinkMachine::load_job`]), then `LoadJob` queued. Nothing of a
//!   refused upload reaches the machine.
//! - **Settings** are the machine's [`LinkMachine::Settings`] tree, addressed by path
//!   (miniconf, JSON values: `/dob/bandwidth_hz`). A `Set` is applied to a copy, the
//!   copy validated into coefficients as a configuration is, and only then kept and
//!   sent (`ChangeSettings`, bumpless); a bad path or value changes nothing.
//! - **Commands** (`Start`, `Stop`, `ResetFault`, `LoadJob`, `ChangeSettings`) are
//!   answered when the supervisor reports them carried out or refused.
//! - **Telemetry** goes out every `every_periods` control periods as the host asked;
//!   mode changes and faults go out as events.
//! - **Saved settings** ([`HostLink::attach_store`]): on `Save` the settings as they
//!   are go to the machine's store ([`crate::app::settings_store`]) as text, a
//!   `path=value` line per leaf; at power-up the saved copy is read back as `Set`s
//!   would be, sent to the supervisor at the first tick, and `Status` says where the
//!   settings came from.
//! - **Heartbeat**: while a job runs, a host silent for longer than
//!   [`HostLinkConfig::heartbeat_timeout_s`] (no frame at all) stops the job, and the
//!   host is told [`Event::HostLost`] should it come back.

use crate::app::jobs::JobSlots;
use crate::app::settings_store::{Loaded, NoCopy, SettingsPersist};
use crate::app::supervisor::{Command, CommandError, CommandKind, Machine, Mode, Report};
use crate::codec::job::JobFile;
use crate::codec::link::{
    crc32, decode, encode, Channel, ChannelValues, CodeWords, Description, Event, FrameError,
    FrameReader, HostFrame, JobKind, MachineMessage, MachineStatus, ModeCode, Refusal, Reply,
    Request, SettingsOrigin, TelemetrySample, JOB_FILE_UNREADABLE, JOB_KIND_MISMATCH, MAX_CHUNK,
    MAX_FRAME, VERSION,
};
use crate::error::{positive, ConfigError};
use heapless::spsc::Producer;
use heapless::Deque;
use miniconf::{json_core, ConstPath, NodeIter, TreeDeserialize, TreeSchema, TreeSerialize};

mod persist;
pub use persist::SAVED_BYTES;

/// Deepest setting path a machine describes (a leaf deeper is not announced; a test
/// of each machine checks its tree).
pub const SETTINGS_DEPTH: usize = 6;

/// Longest setting path a machine describes, bytes.
pub const SETTINGS_PATH_BYTES: usize = 64;

/// A setting path as the description writes it.
pub type SettingPath = ConstPath<heapless::String<SETTINGS_PATH_BYTES>, '/'>;

/// A machine the host link can drive: its settings tree, how a job file becomes its
/// job, and how its telemetry and faults go on the wire — everything a host needs to
/// know of it, which the link announces ([`Request::Describe`]).
pub trait LinkMachine: Machine {
    /// The settings tree (miniconf): what `Get`/`Set` address. A leaf's `unit` and
    /// `range` metadata (`#[tree(meta(unit = "Hz", range = "…"))]`) are announced.
    type Settings: TreeSchema + TreeSerialize + for<'de> TreeDeserialize<'de> + Copy;
    /// What turns a job file into a job beyond the file (the machine's configuration,
    /// the motion a contour is cut with).
    type JobContext;
    /// The machine's name in `Hello`.
    const NAME: &'static str;
    /// Its telemetry channels, in the order [`LinkMachine::sample`] writes them (at
    /// most [`crate::codec::link::MAX_CHANNELS`]).
    const CHANNELS: &'static [Channel];
    /// The job kinds it takes.
    const JOB_KINDS: &'static [JobKind];
    /// Its fault codes ([`LinkMachine::fault_code`]) in words.
    const FAULTS: &'static [CodeWords];
    /// Its job refusal codes ([`LinkMachine::load_job`], [`LinkMachine::job_error_code`])
    /// in words.
    const JOB_REFUSALS: &'static [CodeWords];
    /// Validates settings into coefficients, as a configuration is.
    fn coefficients(
        settings: &Self::Settings,
        period_s: f64,
    ) -> Result<Self::Coefficients, ConfigError>;
    /// Builds the machine's job from a job file, in place; a code for the refusal. The
    /// context may keep what the next job needs of this one (where a program cut as
    /// several parts goes on).
    fn load_job(
        context: &mut Self::JobContext,
        file: &JobFile<'_>,
        job: &mut Self::Job,
    ) -> Result<(), u16>;
    /// The wire form of a job error.
    fn job_error_code(error: &Self::JobError) -> u16;
    /// The wire form of a fault: (what, where).
    fn fault_code(fault: &Self::Fault) -> (u16, u16);
    /// The telemetry's values, one per channel of [`LinkMachine::CHANNELS`].
    fn sample(telemetry: &Self::Telemetry, values: &mut ChannelValues);
}

/// Longest value of a setting as text, bytes (as [`Request::Get`] answers).
const VALUE_BYTES: usize = 64;

/// Room for the text of a setting's description: its path and its preset value.
#[derive(Clone, Debug)]
pub struct SettingText {
    path: SettingPath,
    preset: [u8; VALUE_BYTES],
}

impl Default for SettingText {
    fn default() -> Self {
        Self {
            path: SettingPath::default(),
            preset: [0; VALUE_BYTES],
        }
    }
}

/// Item `index` of `M`'s description: its channels, job kinds, settings (their path
/// and their value in `presets` written into `text`), fault codes and job refusal
/// codes, in that order; `None` past the last.
pub fn describe<'a, M: LinkMachine>(
    index: u16,
    presets: &M::Settings,
    text: &'a mut SettingText,
) -> Option<Description<'a>> {
    let mut i = usize::from(index);
    if let Some(c) = M::CHANNELS.get(i) {
        return Some(Description::Channel {
            name: c.name,
            unit: c.unit,
        });
    }
    i -= M::CHANNELS.len();
    if let Some(kind) = M::JOB_KINDS.get(i) {
        return Some(Description::JobKind(*kind));
    }
    i -= M::JOB_KINDS.len();
    // The leaves walked without the schema's shape (its computation unwraps).
    let leaves = || NodeIter::<SettingPath, SETTINGS_DEPTH>::new(M::Settings::SCHEMA);
    let count = leaves().count();
    if i < count {
        text.path = leaves().nth(i)?.ok()?;
        let SettingText { path, preset } = text;
        let n = json_core::get(presets, path.as_ref(), preset).ok()?;
        let preset = core::str::from_utf8(preset.get(..n)?).ok()?;
        let path: &'a SettingPath = path;
        let (edge, _) = M::Settings::SCHEMA.get_meta(path.as_ref()).ok()?;
        let meta = |key| edge.and_then(|m| m.get(key)).unwrap_or("");
        return Some(Description::Setting {
            path: path.as_ref(),
            unit: meta("unit"),
            range: meta("range"),
            preset,
        });
    }
    i -= count;
    if let Some(f) = M::FAULTS.get(i) {
        return Some(Description::Fault {
            code: f.code,
            words: f.words,
            detail: f.detail,
        });
    }
    i -= M::FAULTS.len();
    M::JOB_REFUSALS.get(i).map(|r| Description::JobRefusal {
        code: r.code,
        words: r.words,
    })
}

/// How the link behaves.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HostLinkConfig {
    /// The machine's control period, s (for the settings' coefficients).
    pub period_s: f64,
    /// Silence of the host after which a running job is stopped, s.
    pub heartbeat_timeout_s: f64,
}

impl HostLinkConfig {
    /// A host that sends a heartbeat every 100 ms is given 0.5 s: five lost in a row.
    pub const DEFAULT_TIMEOUT_S: f64 = 0.5;
}

/// An upload in progress.
#[derive(Clone, Debug)]
struct Upload<const J: usize> {
    kind: JobKind,
    total: u32,
    crc32: u32,
    bytes: heapless::Vec<u8, J>,
}

/// Frames the link could not read (for the status): counted, never answered.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Default)]
pub struct LinkCounters {
    /// Frames dropped: bad COBS, CRC, version, message, or too long.
    pub bad_frames: u32,
    /// Replies or samples the host was not sent (the sender refused them).
    pub unsent: u32,
}

/// A settings store attached to the link, and how the link writes its settings into
/// it. The writer is taken where a store is attached: an image without one (a board
/// today) links no code to save settings.
struct Attached<'q, M: LinkMachine> {
    store: &'q mut (dyn SettingsPersist + Send),
    write: persist::WriteText<M::Settings>,
    restore: persist::Restore<M>,
}

/// The host link of one machine with an upload buffer of `J` bytes, building jobs in
/// the machine's job buffers.
pub struct HostLink<'q, M: LinkMachine, const J: usize> {
    config: HostLinkConfig,
    jobs: &'q JobSlots<M::Job>,
    /// The control period as `Hello` carries it.
    period_ns: u32,
    context: M::JobContext,
    reader: FrameReader<MAX_FRAME>,
    upload: Option<Upload<J>>,
    settings: M::Settings,
    /// The settings as flashed, before any saved copy.
    presets: M::Settings,
    pending: Deque<(u16, CommandKind), 4>,
    telemetry_every: u32,
    last_sample_period: Option<u64>,
    last_report_period: u64,
    mode: ModeCode,
    last_fault: Option<(u16, u16)>,
    last_heard_s: Option<f64>,
    host_lost: bool,
    counters: LinkCounters,
    store: Option<Attached<'q, M>>,
    origin: SettingsOrigin,
    /// Settings read from the store, not yet sent to the supervisor.
    restored: bool,
}

/// A period in s as `Hello` carries it, whole ns rounded; `None` when that is 0 or
/// past `u32::MAX` ns (4.29 s), which the link refuses ([`FrameError::OutOfRange`]
/// for a zero) or cannot hold.
///
/// [`FrameError::OutOfRange`]: crate::codec::link::FrameError::OutOfRange
fn period_ns(period_s: f64) -> Option<u32> {
    let ns = libm::round(period_s * 1e9);
    (1.0..=f64::from(u32::MAX))
        .contains(&ns)
        .then_some(ns as u32)
}

/// The wire form of a supervisor mode.
pub fn mode_code<F>(mode: &Mode<F>) -> ModeCode {
    match mode {
        Mode::Idle => ModeCode::Idle,
        Mode::Calibrating => ModeCode::Calibrating,
        Mode::Ready => ModeCode::Ready,
        Mode::Running => ModeCode::Running,
        Mode::Stopping => ModeCode::Stopping,
        Mode::Fault(_) => ModeCode::Fault,
    }
}

impl<'q, M: LinkMachine, const J: usize> HostLink<'q, M, J> {
    /// A link whose settings start at `settings` (the ones the machine runs), building
    /// jobs in `context`, in the buffer of `jobs` the supervisor does not hold.
    ///
    /// Errors: a period or timeout not finite and positive; a period `Hello` cannot
    /// carry (below 0.5 ns or past 4.29 s).
    pub fn new(
        config: &HostLinkConfig,
        settings: M::Settings,
        context: M::JobContext,
        jobs: &'q JobSlots<M::Job>,
    ) -> Result<Self, ConfigError> {
        let period_ns = period_ns(positive("period_s", config.period_s)?)
            .ok_or(ConfigError::out_of_range("period_s"))?;
        positive("heartbeat_timeout_s", config.heartbeat_timeout_s)?;
        Ok(Self {
            config: *config,
            jobs,
            period_ns,
            context,
            reader: FrameReader::new(),
            upload: None,
            settings,
            presets: settings,
            pending: Deque::new(),
            telemetry_every: 0,
            last_sample_period: None,
            last_report_period: 0,
            mode: ModeCode::Idle,
            last_fault: None,
            last_heard_s: None,
            host_lost: false,
            counters: LinkCounters::default(),
            store: None,
            origin: SettingsOrigin::NoStore,
            restored: false,
        })
    }

    /// Keeps the settings in `store` from now on and starts from the copy saved in it
    /// (module docs); where they came from, as `Status` will report it. Call it before
    /// the first [`HostLink::tick`], which sends them to the supervisor.
    pub fn attach_store(&mut self, store: &'q mut (dyn SettingsPersist + Send)) -> SettingsOrigin {
        let mut text = [0u8; SAVED_BYTES];
        let loaded = store.load(&mut text);
        let mut restore = |len: usize| {
            let lines = text.get(..len).unwrap_or(&[]);
            self.restored = true;
            persist::read_text::<M>(&mut self.settings, lines, self.config.period_s)
        };
        self.origin = match loaded {
            Some(Loaded::Saved { sequence, len }) => SettingsOrigin::Saved {
                sequence,
                skipped: restore(len),
            },
            Some(Loaded::FellBack { sequence, len }) => SettingsOrigin::FellBack {
                sequence,
                skipped: restore(len),
            },
            Some(Loaded::Defaults(NoCopy::NeverSaved)) => SettingsOrigin::Presets,
            Some(Loaded::Defaults(NoCopy::Damaged)) | None => SettingsOrigin::Damaged,
        };
        self.store = Some(Attached {
            store,
            write: persist::write_text::<M>,
            restore: persist::restore::<M>,
        });
        self.origin
    }

    /// The settings as the link holds them.
    pub fn settings(&self) -> &M::Settings {
        &self.settings
    }

    /// Frames dropped and messages not sent so far.
    pub fn counters(&self) -> LinkCounters {
        self.counters
    }

    /// A fault the board found outside the machine (its own fault path, or the cause
    /// of the last reset read at start-up; codes of [`crate::codec::link::board_fault`]):
    /// sent as [`Event::Fault`] and kept as the last fault that [`Request::Status`]
    /// reports, as the machine's own faults are, so that a host that connects later
    /// still reads it.
    pub fn board_fault(&mut self, code: u16, detail: u16, send: &mut dyn FnMut(&[u8]) -> bool) {
        self.last_fault = Some((code, detail));
        self.send(&MachineMessage::Event(Event::Fault { code, detail }), send);
    }

    /// Encodes and sends one message through `send`.
    fn send(&mut self, message: &MachineMessage<'_>, send: &mut dyn FnMut(&[u8]) -> bool) {
        let mut out = [0u8; MAX_FRAME];
        let sent = match encode(message, &mut out) {
            Ok(n) => out.get(..n).is_some_and(send),
            Err(_) => false,
        };
        if !sent {
            self.counters.unsent = self.counters.unsent.saturating_add(1);
        }
    }

    fn reply(&mut self, seq: u16, reply: Reply<'_>, send: &mut dyn FnMut(&[u8]) -> bool) {
        self.send(&MachineMessage::Reply { seq, reply }, send);
    }

    /// Queues `command` for the supervisor; its answer comes with the report. False
    /// (and `Busy` answered) when a queue is full.
    fn command(
        &mut self,
        seq: u16,
        command: Command<M>,
        commands: &mut Producer<'_, Command<M>>,
        send: &mut dyn FnMut(&[u8]) -> bool,
    ) -> bool {
        let kind = command.kind();
        if !self.pending.is_full() && commands.enqueue(command).is_ok() {
            // Room was checked above.
            let _ = self.pending.push_back((seq, kind));
            return true;
        }
        self.reply(seq, Reply::Refused(Refusal::Busy), send);
        false
    }

    /// Takes one byte from the host at time `now_s` (any monotonic seconds).
    pub fn receive(
        &mut self,
        byte: u8,
        now_s: f64,
        commands: &mut Producer<'_, Command<M>>,
        send: &mut dyn FnMut(&[u8]) -> bool,
    ) {
        let mut frame = [0u8; MAX_FRAME];
        let len = match self.reader.push(byte) {
            None => return,
            Some(Err(_)) => {
                self.counters.bad_frames = self.counters.bad_frames.saturating_add(1);
                return;
            }
            Some(Ok(raw)) => {
                let Some(copy) = frame.get_mut(..raw.len()) else {
                    return;
                };
                copy.copy_from_slice(raw);
                raw.len()
            }
        };
        let Some(raw) = frame.get_mut(..len) else {
            return;
        };
        match decode::<HostFrame>(raw) {
            Ok(HostFrame { seq, request }) => {
                self.last_heard_s = Some(now_s);
                self.host_lost = false;
                self.handle(seq, request, commands, send);
            }
            Err(e) => {
                self.counters.bad_frames = self.counters.bad_frames.saturating_add(1);
                if let FrameError::Version(version) = e {
                    let refused = Event::VersionRefused { version };
                    self.send(&MachineMessage::Event(refused), send);
                }
            }
        }
    }

    fn handle(
        &mut self,
        seq: u16,
        request: Request<'_>,
        commands: &mut Producer<'_, Command<M>>,
        send: &mut dyn FnMut(&[u8]) -> bool,
    ) {
        let refuse = |r| Reply::Refused(r);
        match request {
            Request::Hello => self.reply(
                seq,
                Reply::Hello {
                    version: VERSION,
                    machine: M::NAME,
                    max_chunk: MAX_CHUNK as u16,
                    period_ns: self.period_ns,
                },
                send,
            ),
            Request::Heartbeat => self.reply(seq, Reply::Ack, send),
            Request::Describe { index } => {
                let mut text = SettingText::default();
                let item = describe::<M>(index, &self.presets, &mut text);
                self.reply(seq, Reply::Description { index, item }, send);
            }
            Request::Status => {
                let status = MachineStatus {
                    mode: self.mode,
                    last_fault: self.last_fault,
                    period: self.last_report_period,
                    upload_received: self.upload.as_ref().map(|up| up.bytes.len() as u32),
                    bad_frames: self.counters.bad_frames,
                    unsent: self.counters.unsent,
                    settings: self.origin,
                };
                self.reply(seq, Reply::Status(status), send);
            }
            Request::Telemetry { every_periods } => {
                self.telemetry_every = every_periods;
                self.reply(seq, Reply::Ack, send);
            }
            Request::JobBegin {
                kind,
                total_bytes,
                crc32,
            } => {
                let reply = if usize::try_from(total_bytes).map_or(true, |n| n > J) {
                    refuse(Refusal::TooLarge)
                } else {
                    self.upload = Some(Upload {
                        kind,
                        total: total_bytes,
                        crc32,
                        bytes: heapless::Vec::new(),
                    });
                    Reply::Ack
                };
                self.reply(seq, reply, send);
            }
            Request::JobChunk { offset, data } => {
                let reply = match self.upload.as_mut() {
                    None => refuse(Refusal::NoJob),
                    Some(up) => {
                        let received = up.bytes.len() as u32;
                        let end = u64::from(offset) + data.len() as u64;
                        if offset != received || end > u64::from(up.total) {
                            refuse(Refusal::ChunkOffset { expected: received })
                        } else if up.bytes.extend_from_slice(data).is_err() {
                            refuse(Refusal::TooLarge)
                        } else {
                            Reply::JobProgress {
                                received: up.bytes.len() as u32,
                            }
                        }
                    }
                };
                self.reply(seq, reply, send);
            }
            Request::JobStatus => {
                let reply = match &self.upload {
                    Some(up) => Reply::JobProgress {
                        received: up.bytes.len() as u32,
                    },
                    None => refuse(Refusal::NoJob),
                };
                self.reply(seq, reply, send);
            }
            Request::JobCommit => self.commit(seq, commands, send),
            Request::Start => {
                self.command(seq, Command::Start, commands, send);
            }
            Request::Stop => {
                self.command(seq, Command::Stop, commands, send);
            }
            Request::ResetFault => {
                self.command(seq, Command::ResetFault, commands, send);
            }
            Request::Save => {
                let moving = matches!(
                    self.mode,
                    ModeCode::Running | ModeCode::Calibrating | ModeCode::Stopping
                );
                let reply = match self.store.as_mut() {
                    None => refuse(Refusal::NoStore),
                    Some(attached) if moving && attached.store.restarts() => {
                        refuse(Refusal::InvalidInMode)
                    }
                    Some(attached) => {
                        let mut text = heapless::Vec::new();
                        match (attached.write)(&self.settings, &mut text)
                            .and_then(|()| attached.store.save(&text))
                        {
                            Some(_) => Reply::Ack,
                            None => refuse(Refusal::StoreFailed),
                        }
                    }
                };
                self.reply(seq, reply, send);
            }
            Request::Get { path } => {
                let mut value = [0u8; VALUE_BYTES];
                match json_core::get(&self.settings, path, &mut value) {
                    Ok(n) => {
                        let v = value.get(..n).unwrap_or(&[]);
                        let message = MachineMessage::Reply {
                            seq,
                            reply: Reply::Value { value: v },
                        };
                        self.send(&message, send);
                    }
                    Err(_) => self.reply(seq, refuse(Refusal::UnknownPath), send),
                }
            }
            Request::Set { path, value } => {
                let mut candidate = self.settings;
                let parsed = json_core::set(&mut candidate, path, value);
                let coefficients = match parsed {
                    Err(miniconf::SerdeError::Value(_)) => Err(Refusal::UnknownPath),
                    Err(_) => Err(Refusal::BadValue),
                    Ok(_) => M::coefficients(&candidate, self.config.period_s)
                        .map_err(|_| Refusal::BadValue),
                };
                match coefficients {
                    Ok(c) => {
                        if self.command(seq, Command::ChangeSettings(c), commands, send) {
                            self.settings = candidate;
                        }
                    }
                    Err(r) => self.reply(seq, refuse(r), send),
                }
            }
        }
    }

    /// Checks the upload and queues the job it holds.
    fn commit(
        &mut self,
        seq: u16,
        commands: &mut Producer<'_, Command<M>>,
        send: &mut dyn FnMut(&[u8]) -> bool,
    ) {
        let Some(up) = self.upload.take() else {
            return self.reply(seq, Reply::Refused(Refusal::NoJob), send);
        };
        let complete = up.bytes.len() as u64 == u64::from(up.total) && crc32(&up.bytes) == up.crc32;
        if !complete {
            // Kept: the host may resume it.
            self.upload = Some(up);
            return self.reply(seq, Reply::Refused(Refusal::Incomplete), send);
        }
        // One job on its way at a time: the buffer of a job queued but not yet taken
        // is free to `take_free`, and must not be built over.
        let loading = self.pending.iter().any(|&(_, k)| k == CommandKind::LoadJob);
        let free = if loading { None } else { self.jobs.take_free() };
        let Some((slot, mut job)) = free else {
            self.upload = Some(up);
            return self.reply(seq, Reply::Refused(Refusal::Busy), send);
        };
        let built = JobFile::read(&up.bytes)
            .map_err(|_| JOB_FILE_UNREADABLE)
            .and_then(|file| {
                if file.kind() != up.kind {
                    return Err(JOB_KIND_MISMATCH);
                }
                M::load_job(&mut self.context, &file, &mut job)
            });
        // Released before the supervisor is asked to take it.
        drop(job);
        match built {
            Ok(()) => {
                self.command(seq, Command::LoadJob(slot), commands, send);
            }
            Err(code) => self.reply(seq, Reply::Refused(Refusal::Job(code)), send),
        }
    }

    /// Takes one report of the supervisor: answers a pending command, forwards
    /// telemetry (decimated) and events.
    pub fn report(&mut self, report: &Report<M>, send: &mut dyn FnMut(&[u8]) -> bool) {
        match report {
            Report::ModeChanged { mode, .. } => {
                let to = mode_code(mode);
                let from = self.mode;
                self.mode = to;
                self.send(&MachineMessage::Event(Event::Mode { from, to }), send);
                if let Mode::Fault(f) = mode {
                    let (code, detail) = M::fault_code(f);
                    self.last_fault = Some((code, detail));
                    self.send(&MachineMessage::Event(Event::Fault { code, detail }), send);
                }
            }
            Report::Accepted(kind) => {
                if let Some(seq) = self.answered(*kind) {
                    self.reply(seq, Reply::Ack, send);
                }
            }
            Report::Refused { command, error } => {
                let refusal = match error {
                    CommandError::InvalidInMode => Refusal::InvalidInMode,
                    CommandError::NoJob => Refusal::NoJob,
                    CommandError::JobBufferBusy => Refusal::Busy,
                    CommandError::Job(e) => Refusal::Job(M::job_error_code(e)),
                };
                if let Some(seq) = self.answered(*command) {
                    self.reply(seq, Reply::Refused(refusal), send);
                }
            }
            Report::Telemetry {
                period,
                mode,
                telemetry,
            } => {
                self.last_report_period = *period;
                let due = self.telemetry_every > 0
                    && self.last_sample_period.is_none_or(|last| {
                        period.saturating_sub(last) >= u64::from(self.telemetry_every)
                    });
                if due {
                    self.last_sample_period = Some(*period);
                    let mut sample = TelemetrySample {
                        period: *period as u32,
                        mode: mode_code(mode),
                        values: ChannelValues::new(),
                    };
                    M::sample(telemetry, &mut sample.values);
                    self.send(&MachineMessage::Telemetry(sample), send);
                }
            }
            Report::NextJob => self.send(&MachineMessage::Event(Event::NextJob), send),
            Report::CalibrationSample { .. } | Report::SweepDone => {}
        }
    }

    /// The pending request a report answers (commands are carried out in order).
    fn answered(&mut self, kind: CommandKind) -> Option<u16> {
        match self.pending.front() {
            Some((_, k)) if *k == kind => self.pending.pop_front().map(|(seq, _)| seq),
            // A command the link did not send (the board's own task): not ours.
            _ => None,
        }
    }

    /// Checks the host's heartbeat at `now_s`: a running job whose host has been
    /// silent past the timeout is stopped (once) and [`Event::HostLost`] sent.
    pub fn tick(
        &mut self,
        now_s: f64,
        commands: &mut Producer<'_, Command<M>>,
        send: &mut dyn FnMut(&[u8]) -> bool,
    ) {
        // The saved settings, once, before any command of the host: the report of
        // this command answers no request (`answered`).
        if let Some(attached) = self.store.as_ref().filter(|_| self.restored) {
            if self.pending.is_empty() {
                self.restored = !(attached.restore)(&self.settings, self.config.period_s, commands);
            }
        }
        if self.mode != ModeCode::Running || self.host_lost {
            return;
        }
        let silent = self
            .last_heard_s
            .is_none_or(|t| now_s - t > self.config.heartbeat_timeout_s);
        if silent && commands.enqueue(Command::Stop).is_ok() {
            self.host_lost = true;
            self.send(&MachineMessage::Event(Event::HostLost), send);
        }
    }
}

#[cfg(test)]
pub(crate) mod test_support;
#[cfg(test)]
mod tests;
