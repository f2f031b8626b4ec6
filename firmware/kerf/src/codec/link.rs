//! The host link: messages between the operator's host tool and any kerf machine over
//! a byte stream (a UART, USB CDC), and their framing.
//!
//! # Frame
//!
//! | bytes | field |
//! |---|---|
//! | 1 | version (= [`VERSION`]) |
//! | n | the message, postcard-encoded ([`HostFrame`] to the machine, [`MachineFrame`] from it) |
//! | 4 | CRC-32 (ISO-HDLC, as Ethernet and zlib) of the version and the message, little-endian |
//!
//! The whole is COBS-encoded between two 0x00 delimiters, so a receiver that joins
//! mid-stream, or sees garbage, resynchronises at the next zero byte: the leading
//! delimiter ends whatever garbage came before, and the frame itself is not lost. A frame carries at most [`MAX_PAYLOAD`] bytes before
//! COBS; job data travels in chunks of at most [`MAX_CHUNK`] bytes. Past the CRC the
//! message's values are checked ([`LinkMessage::check`]: telemetry is finite, a chunk
//! and a hello within their stated ranges), by the
//! encoder as by the decoder, so nothing written is refused when read.
//!
//! # Conversation
//!
//! The host numbers its requests ([`HostFrame::seq`]); the machine answers each with a
//! [`MachineMessage::Reply`] carrying the same number: [`Reply::Ack`], a typed
//! [`Reply::Refused`], a value or the upload's progress. Telemetry and events come
//! unasked. A job is uploaded as [`Request::JobBegin`] (kind, size, CRC of the whole),
//! [`Request::JobChunk`]s at increasing offsets and [`Request::JobCommit`]; after a
//! lost reply the host asks [`Request::JobStatus`] and resumes at the offset the
//! machine reports.
//!
//! # A machine describes itself
//!
//! The link knows no machine. After [`Request::Hello`] a host asks
//! [`Request::Describe`] for item 0, 1, 2, … until the machine answers `None`: the
//! items ([`Description`]) are the telemetry channels in the order a
//! [`TelemetrySample`] carries their values (name and unit), the job kinds the machine
//! takes, its settings (path, unit, range), and the words for its fault and job
//! refusal codes. A host with no code of its own for a machine then logs, plots, sets
//! and explains it.
//!
//! # Versions
//!
//! The first byte of every frame is the link's [`VERSION`]. A frame of another
//! version is not read; a machine that receives one (CRC intact) answers with
//! [`Event::VersionRefused`] in its own version, so a host of either version names
//! both: the one it speaks and the one it was sent.

use serde::{Deserialize, Serialize};

/// Version of the frame and the messages in it (2: `Hello` carries the control
/// period, `Status`; 3: the machine describes itself, telemetry carries its own
/// channels; 4: a job loaded while one runs is queued behind it, [`Event::NextJob`];
/// 5: settings saved across resets, [`Request::Save`], [`MachineStatus::settings`];
/// 6: a setting's description carries its preset).
pub const VERSION: u8 = 6;

/// Most values a telemetry sample carries.
pub const MAX_CHANNELS: usize = 16;

/// The values of a telemetry sample, in the order of the machine's channels.
pub type ChannelValues = heapless::Vec<f32, MAX_CHANNELS>;

/// Most bytes of a frame before COBS: version, message and CRC.
pub const MAX_PAYLOAD: usize = 256;

/// Most bytes of an encoded frame: COBS adds one byte per 254 and one more, and the
/// two delimiters.
pub const MAX_FRAME: usize = MAX_PAYLOAD + MAX_PAYLOAD / 254 + 3;

/// Most job bytes in one [`Request::JobChunk`] (the rest of the payload holds the
/// message's own fields).
pub const MAX_CHUNK: usize = 192;

/// The frame check (also the settings store's, [`crate::app::settings_store`]).
pub(crate) const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// CRC-32 (ISO-HDLC, as Ethernet and zlib) of `bytes`: the check of frames, of job
/// files, and of a whole upload ([`Request::JobBegin`]).
pub fn crc32(bytes: &[u8]) -> u32 {
    CRC32.checksum(bytes)
}

/// What an uploaded job holds.
#[derive(Serialize, Deserialize, Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum JobKind {
    /// Elliptic Fourier coefficients of a closed contour.
    Efd,
    /// A point list of an open contour.
    Points,
    /// G-code text.
    Gcode,
    /// A recorded master session: the command frames that reached a remote slave,
    /// each with its arrival period (`machines::delta_slave::remote::recording`).
    Recording,
    /// A schedule: setpoints, each held for a duration (the autofocus stage's zoom
    /// schedule, `machines::autofocus::product`).
    Schedule,
    /// A program of straight moves, each with its feed: a part cut with sharp corners.
    Moves,
}

/// A request of the host.
#[derive(Serialize, Deserialize, Copy, Clone, Debug, PartialEq)]
pub enum Request<'a> {
    /// Who are you: the machine answers [`Reply::Hello`].
    Hello,
    /// The host is still there (the machine stops a running job when they cease).
    Heartbeat,
    /// An upload begins: `total_bytes` of `kind`, whose CRC-32 is `crc32`.
    JobBegin {
        /// What the job holds.
        kind: JobKind,
        /// Its size, bytes.
        total_bytes: u32,
        /// CRC-32 (ISO-HDLC) of all its bytes.
        crc32: u32,
    },
    /// Job bytes at `offset`.
    JobChunk {
        /// Where they go.
        offset: u32,
        /// At most [`MAX_CHUNK`] bytes.
        #[serde(borrow)]
        data: &'a [u8],
    },
    /// How far the upload got: [`Reply::JobProgress`].
    JobStatus,
    /// The upload is complete: check and load it.
    JobCommit,
    /// Start the loaded job.
    Start,
    /// Stop (a controlled ramp to rest).
    Stop,
    /// Leave a fault.
    ResetFault,
    /// A setting's value, as JSON: [`Reply::Value`].
    Get {
        /// Its path in the settings tree, such as `/dob/bandwidth_hz`.
        #[serde(borrow)]
        path: &'a str,
    },
    /// Sets a setting from JSON; validated as a configuration, applied bumplessly.
    Set {
        /// Its path.
        #[serde(borrow)]
        path: &'a str,
        /// The value, JSON.
        #[serde(borrow)]
        value: &'a [u8],
    },
    /// Telemetry every `every_periods` control periods (0: none).
    Telemetry {
        /// Decimation.
        every_periods: u32,
    },
    /// The machine's state: [`Reply::Status`].
    Status,
    /// Item `index` of the machine's description: [`Reply::Description`].
    Describe {
        /// From 0; the machine answers `None` past its last item.
        index: u16,
    },
    /// Keep the settings as they are now across resets ([`Reply::Ack`] once they are
    /// written; [`Refusal::NoStore`] on a machine that keeps none).
    Save,
}

/// A request with its number.
#[derive(Serialize, Deserialize, Copy, Clone, Debug, PartialEq)]
pub struct HostFrame<'a> {
    /// The host's request number, echoed in the reply.
    pub seq: u16,
    /// The request.
    #[serde(borrow)]
    pub request: Request<'a>,
}

/// Why a request was refused.
#[derive(Serialize, Deserialize, Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Refusal {
    /// A chunk not at the offset the upload has reached (`expected`), or past the
    /// announced size.
    ChunkOffset {
        /// The offset the machine expects next.
        expected: u32,
    },
    /// The job is larger than the machine holds.
    TooLarge,
    /// The uploaded bytes do not match the announced CRC, or fall short of its size.
    Incomplete,
    /// No upload in progress, or no job loaded.
    NoJob,
    /// The job does not fit the machine: a code per machine, or
    /// [`JOB_FILE_UNREADABLE`] / [`JOB_KIND_MISMATCH`] for any machine.
    Job(u16),
    /// Not in this mode.
    InvalidInMode,
    /// No setting at that path.
    UnknownPath,
    /// The value does not parse, or fails the configuration's validation.
    BadValue,
    /// The machine's command queue is full; try again.
    Busy,
    /// The machine keeps no settings across resets.
    NoStore,
    /// The settings could not be written (the store's flash failed, or they do not
    /// fit it); the copy saved before is kept.
    StoreFailed,
}

/// Fault codes of the board itself, the same for every machine (the machines' own
/// codes are small numbers): `BOARD_FAULT | cause`, with the cause one of
/// [`board_fault`]'s. Sent as [`Event::Fault`] and kept as [`MachineStatus::last_fault`].
pub const BOARD_FAULT: u16 = 0xB000;

/// Board fault causes ([`BOARD_FAULT`] `| cause`) and what their detail holds.
pub mod board_fault {
    /// A HardFault; detail: the low 16 bits of the faulting program counter.
    pub const HARD_FAULT: u16 = 3;
    /// A panic; detail: the source line.
    pub const PANIC: u16 = 4;
    /// A control period ended after the next period's trigger; detail: its cycles / 16.
    pub const MISSED_DEADLINE: u16 = 5;
    /// The independent watchdog reset the board.
    pub const WATCHDOG: u16 = 6;
    /// A period's samples did not arrive together (or a DMA transfer error).
    pub const SAMPLING: u16 = 7;
    /// The break input (driver fault, E-stop) holds the outputs off until a reset.
    pub const BREAK: u16 = 8;
    /// Start-up failed; detail: the step.
    pub const STARTUP: u16 = 9;

    /// What a board fault code (`BOARD_FAULT | cause`) means; `None` for any other code.
    pub fn reason(code: u16) -> Option<&'static str> {
        if code & 0xFF00 != super::BOARD_FAULT {
            return None;
        }
        Some(match code & 0xFF {
            HARD_FAULT => "the board's processor faulted (HardFault) and reset",
            PANIC => "the board's firmware panicked and reset",
            MISSED_DEADLINE => "a control period missed its deadline; the board reset",
            WATCHDOG => "the board's watchdog expired and reset it",
            SAMPLING => "the Hall samples of a period did not arrive together; the board reset",
            BREAK => "the break input (driver fault or E-stop) switched the outputs off",
            STARTUP => "the board's start-up failed",
            _ => "unknown board fault",
        })
    }

    /// What the detail of a board fault code is, where it carries one.
    pub fn detail(code: u16) -> Option<&'static str> {
        if code & 0xFF00 != super::BOARD_FAULT {
            return None;
        }
        match code & 0xFF {
            HARD_FAULT => Some("program counter, low 16 bits"),
            PANIC => Some("source line"),
            MISSED_DEADLINE => Some("cycles / 16"),
            STARTUP => Some("step"),
            _ => None,
        }
    }
}

/// A telemetry channel of a machine: its name and unit ([`Description::Channel`]).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Channel {
    /// Name (`x`, `force1`).
    pub name: &'static str,
    /// Unit (`m`, `N`, `W`; `1` for a plain number).
    pub unit: &'static str,
}

/// A code of a machine and its words ([`Description::Fault`],
/// [`Description::JobRefusal`]).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct CodeWords {
    /// The code.
    pub code: u16,
    /// What it means.
    pub words: &'static str,
    /// What its detail holds, for a fault (empty: nothing).
    pub detail: &'static str,
}

/// A code and its words, as a machine's tables write them.
pub const fn code_words(code: u16, words: &'static str, detail: &'static str) -> CodeWords {
    CodeWords {
        code,
        words,
        detail,
    }
}

impl CodeWords {
    /// The entry of `code` in `table`.
    pub fn find(table: &[CodeWords], code: u16) -> Option<&CodeWords> {
        table.iter().find(|c| c.code == code)
    }
}

/// The job refusals of the link itself, the same for every machine.
pub const LINK_JOB_REFUSALS: [CodeWords; 3] = [
    CodeWords {
        code: JOB_FILE_UNREADABLE,
        words: "not a job file the firmware reads (magic, version, CRC)",
        detail: "",
    },
    CodeWords {
        code: JOB_KIND_MISMATCH,
        words: "the job file's kind differs from the announced one",
        detail: "",
    },
    CodeWords {
        code: JOB_NOT_AT_REST,
        words: "an axis still moves; the job starts from rest",
        detail: "",
    },
];

/// [`Refusal::Job`]: the committed bytes are not a job file the firmware reads.
pub const JOB_FILE_UNREADABLE: u16 = 0xFFFF;

/// [`Refusal::Job`]: the job file's kind differs from the one [`Request::JobBegin`]
/// announced.
pub const JOB_KIND_MISMATCH: u16 = 0xFFFE;

/// [`Refusal::Job`] of [`Request::Start`]: an axis still moves, and the job's first
/// move starts from rest; a host starts again once the axes rest.
pub const JOB_NOT_AT_REST: u16 = 0xFFFD;

/// The answer to a request.
#[derive(Serialize, Deserialize, Copy, Clone, Debug, PartialEq)]
pub enum Reply<'a> {
    /// The machine: link version, name, largest chunk.
    Hello {
        /// [`VERSION`].
        version: u8,
        /// The machine's name.
        #[serde(borrow)]
        machine: &'a str,
        /// Largest [`Request::JobChunk`] it takes, bytes.
        max_chunk: u16,
        /// Its control period, ns (the time base of [`TelemetrySample::period`]).
        period_ns: u32,
    },
    /// Done.
    Ack,
    /// Refused, nothing changed.
    Refused(Refusal),
    /// Bytes of the upload received so far, in order.
    JobProgress {
        /// Bytes.
        received: u32,
    },
    /// A setting's value, JSON.
    Value {
        /// The value.
        #[serde(borrow)]
        value: &'a [u8],
    },
    /// The machine's state, for a host that joins.
    Status(MachineStatus),
    /// Item `index` of the machine's description, `None` past the last.
    Description {
        /// The item asked for.
        index: u16,
        /// The item.
        #[serde(borrow)]
        item: Option<Description<'a>>,
    },
}

/// One item of a machine's description ([`Request::Describe`]).
#[derive(Serialize, Deserialize, Copy, Clone, Debug, PartialEq, Eq)]
pub enum Description<'a> {
    /// A telemetry channel: the values of [`TelemetrySample::values`] are in the order
    /// of these items.
    Channel {
        /// Its name (`x`, `force1`, …).
        name: &'a str,
        /// Its unit (`m`, `N`, `W`, `rad`, `1` for a plain number).
        unit: &'a str,
    },
    /// A job kind the machine takes.
    JobKind(JobKind),
    /// A setting ([`Request::Get`], [`Request::Set`]).
    Setting {
        /// Its path.
        path: &'a str,
        /// Its unit (empty for a switch).
        unit: &'a str,
        /// The values the machine takes, in words (`0 < value ≤ 3183`; empty: any
        /// value of its type).
        range: &'a str,
        /// The value the machine starts with when nothing is saved (as flashed), as
        /// [`Request::Get`] answers.
        preset: &'a str,
    },
    /// What a fault code of [`Event::Fault`] means.
    Fault {
        /// The code.
        code: u16,
        /// What happened, in words.
        words: &'a str,
        /// What the fault's detail holds (empty: nothing).
        detail: &'a str,
    },
    /// What a job refusal code of [`Refusal::Job`] means.
    JobRefusal {
        /// The code.
        code: u16,
        /// Why, in words.
        words: &'a str,
    },
}

/// The machine's state as [`Request::Status`] reports it.
#[derive(Serialize, Deserialize, Copy, Clone, Debug, PartialEq, Eq, Default)]
pub struct MachineStatus {
    /// The supervisor's mode.
    pub mode: ModeCode,
    /// The last fault (code, detail) as [`Event::Fault`] carried it, kept after it is
    /// reset.
    pub last_fault: Option<(u16, u16)>,
    /// The control period of the latest telemetry report (0 before any).
    pub period: u64,
    /// Bytes of an upload in progress (`None`: none).
    pub upload_received: Option<u32>,
    /// Frames dropped since power-up: bad COBS, CRC, version or message.
    pub bad_frames: u32,
    /// Replies, samples or events the link could not send since power-up.
    pub unsent: u32,
    /// Where the settings the machine started with came from.
    pub settings: SettingsOrigin,
}

/// Where the settings a machine runs with came from at power-up
/// ([`crate::app::settings_store`]).
#[derive(Serialize, Deserialize, Copy, Clone, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SettingsOrigin {
    /// The machine keeps no settings: its presets at every power-up.
    #[default]
    NoStore,
    /// Never saved: its presets.
    Presets,
    /// The copy last saved; `skipped` of its values the machine no longer takes were
    /// left at their presets.
    Saved {
        /// The copy's sequence number.
        sequence: u32,
        /// Values left at their presets.
        skipped: u16,
    },
    /// The copy before the last save, which was cut short (or damaged since).
    FellBack {
        /// The copy's sequence number.
        sequence: u32,
        /// Values left at their presets.
        skipped: u16,
    },
    /// Every saved copy is damaged (or the store could not be read): the presets.
    Damaged,
}

/// A decimated telemetry sample.
///
/// `period` is the low 32 bits of the machine's period count: it wraps (after 5.0
/// days at 10 kHz), so a host extends it by the forward difference of each sample to
/// the previous.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq, Default)]
pub struct TelemetrySample {
    /// Control period count.
    pub period: u32,
    /// Supervisor mode ([`ModeCode`]).
    pub mode: ModeCode,
    /// One value per channel of the machine ([`Description::Channel`]), in their order.
    pub values: ChannelValues,
}

/// The supervisor's mode on the wire.
#[derive(Serialize, Deserialize, Copy, Clone, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModeCode {
    /// Idle.
    #[default]
    Idle,
    /// Calibrating.
    Calibrating,
    /// Ready.
    Ready,
    /// Running a job.
    Running,
    /// Ramping to rest.
    Stopping,
    /// Faulted.
    Fault,
}

/// Something that happened on the machine.
#[derive(Serialize, Deserialize, Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Event {
    /// The mode changed.
    Mode {
        /// From.
        from: ModeCode,
        /// To.
        to: ModeCode,
    },
    /// The machine faulted: a code per machine (its fault enum's order) and its
    /// detail (an axis or a line).
    Fault {
        /// What.
        code: u16,
        /// Where.
        detail: u16,
    },
    /// The host's heartbeats stopped while a job ran: the machine stopped it.
    HostLost,
    /// The job queued behind the running one has begun: the one before ended (a
    /// program of several parts runs on without leaving `Running`).
    NextJob,
    /// The machine received a frame of link version `version`, which it does not
    /// read (it speaks [`VERSION`]).
    VersionRefused {
        /// The version of the refused frame.
        version: u8,
    },
}

/// What the machine sends.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub enum MachineMessage<'a> {
    /// The answer to request `seq`.
    Reply {
        /// The request's number.
        seq: u16,
        /// The answer.
        #[serde(borrow)]
        reply: Reply<'a>,
    },
    /// A telemetry sample.
    Telemetry(TelemetrySample),
    /// An event.
    Event(Event),
}

/// A machine message (the frame's name for symmetry with [`HostFrame`]).
pub type MachineFrame<'a> = MachineMessage<'a>;

/// Why bytes are not a message.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// The frame outgrew the receive buffer (the rest up to the next delimiter is
    /// dropped).
    TooLong,
    /// Not valid COBS.
    Cobs,
    /// Shorter than a version and a CRC.
    TooShort,
    /// Another link version.
    Version(u8),
    /// The CRC does not match.
    Crc,
    /// The message does not decode (or has bytes left over).
    Message,
    /// The message carries a NaN or infinite value (telemetry): a machine's reading is
    /// a number or a fault, never a NaN on the wire.
    NotFinite,
    /// A field is outside its stated range: a [`Request::JobChunk`] of more than
    /// [`MAX_CHUNK`] bytes, a [`Reply::Hello`] with a zero period or a largest chunk of
    /// 0 or more than [`MAX_CHUNK`].
    OutOfRange,
    /// The output buffer is too small for the frame.
    NoRoom,
}

/// A message of this link: what [`encode`] and [`decode`] check beyond the framing, so
/// that the encoder writes nothing the decoder refuses.
pub trait LinkMessage {
    /// Every value in its stated range: [`FrameError::NotFinite`] for a NaN or an
    /// infinity, [`FrameError::OutOfRange`] for a field outside its documented range.
    fn check(&self) -> Result<(), FrameError>;
}

impl LinkMessage for HostFrame<'_> {
    /// A chunk holds at most [`MAX_CHUNK`] bytes; the other requests' fields take any
    /// value of their type (a setting's value is JSON text, checked as a
    /// configuration when it is applied).
    fn check(&self) -> Result<(), FrameError> {
        match self.request {
            Request::JobChunk { data, .. } if data.len() > MAX_CHUNK => Err(FrameError::OutOfRange),
            _ => Ok(()),
        }
    }
}

impl LinkMessage for MachineMessage<'_> {
    /// Telemetry is checked ([`TelemetrySample::check`]); a hello's period is
    /// positive and its largest chunk 1 to [`MAX_CHUNK`] bytes; the other replies'
    /// and the events' fields take any value of their type.
    fn check(&self) -> Result<(), FrameError> {
        match self {
            Self::Telemetry(sample) => sample.check(),
            Self::Reply {
                reply:
                    Reply::Hello {
                        max_chunk,
                        period_ns,
                        ..
                    },
                ..
            } => {
                let chunk_ok = (1..=MAX_CHUNK).contains(&usize::from(*max_chunk));
                if chunk_ok && *period_ns > 0 {
                    Ok(())
                } else {
                    Err(FrameError::OutOfRange)
                }
            }
            Self::Reply { .. } | Self::Event(_) => Ok(()),
        }
    }
}

impl TelemetrySample {
    /// Every value finite, else [`FrameError::NotFinite`].
    pub fn check(&self) -> Result<(), FrameError> {
        if self.values.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(FrameError::NotFinite)
        }
    }
}

/// Encodes `message` into `out` as one frame between delimiters; returns its length.
///
/// Errors: [`FrameError::NotFinite`] for a message its decoder would refuse
/// ([`LinkMessage::check`]); [`FrameError::NoRoom`] when the message exceeds
/// [`MAX_PAYLOAD`] or `out` holds less than the encoded frame.
pub fn encode<M: Serialize + LinkMessage>(
    message: &M,
    out: &mut [u8],
) -> Result<usize, FrameError> {
    message.check()?;
    let mut payload = [0u8; MAX_PAYLOAD];
    let (version, rest) = payload.split_first_mut().ok_or(FrameError::NoRoom)?;
    *version = VERSION;
    let body = rest.len().saturating_sub(4);
    let used = postcard::to_slice(message, rest.get_mut(..body).ok_or(FrameError::NoRoom)?)
        .map_err(|_| FrameError::NoRoom)?
        .len();
    let checked = 1 + used;
    let crc = CRC32.checksum(payload.get(..checked).ok_or(FrameError::NoRoom)?);
    payload
        .get_mut(checked..checked + 4)
        .ok_or(FrameError::NoRoom)?
        .copy_from_slice(&crc.to_le_bytes());
    let frame = payload.get(..checked + 4).ok_or(FrameError::NoRoom)?;
    let (lead, rest) = out.split_first_mut().ok_or(FrameError::NoRoom)?;
    *lead = 0;
    let n = cobs::try_encode(frame, rest).map_err(|_| FrameError::NoRoom)?;
    *rest.get_mut(n).ok_or(FrameError::NoRoom)? = 0;
    Ok(n + 2)
}

/// Decodes one frame (its COBS bytes, without the delimiter) in place and reads the
/// message, which may borrow from `frame`.
///
/// Errors: bad COBS, too short, another version, a CRC mismatch, a message that does
/// not decode or leaves bytes over, a value out of range ([`LinkMessage::check`]).
pub fn decode<'a, M: Deserialize<'a> + LinkMessage>(frame: &'a mut [u8]) -> Result<M, FrameError> {
    let n = cobs::decode_in_place(frame).map_err(|_| FrameError::Cobs)?;
    let frame: &'a [u8] = frame.get(..n).ok_or(FrameError::Cobs)?;
    if n < 5 {
        return Err(FrameError::TooShort);
    }
    let (checked, crc) = frame.split_at(n - 4);
    let mut crc_bytes = [0u8; 4];
    crc_bytes.copy_from_slice(crc);
    if CRC32.checksum(checked) != u32::from_le_bytes(crc_bytes) {
        return Err(FrameError::Crc);
    }
    let (version, body) = checked.split_first().ok_or(FrameError::TooShort)?;
    if *version != VERSION {
        return Err(FrameError::Version(*version));
    }
    match postcard::take_from_bytes::<M>(body) {
        Ok((message, [])) => message.check().map(|()| message),
        _ => Err(FrameError::Message),
    }
}

/// Collects a byte stream into frames: bytes up to each 0x00 delimiter, in a buffer of
/// `N` bytes. Allocation-free; one byte at a time, as a UART delivers them.
#[derive(Clone, Debug)]
pub struct FrameReader<const N: usize> {
    buf: [u8; N],
    len: usize,
    overflowed: bool,
}

impl<const N: usize> Default for FrameReader<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> FrameReader<N> {
    /// An empty reader.
    pub const fn new() -> Self {
        Self {
            buf: [0; N],
            len: 0,
            overflowed: false,
        }
    }

    /// Takes one byte. At a delimiter returns the frame collected since the last one
    /// (its COBS bytes, for [`decode`]), or [`FrameError::TooLong`] when it did not
    /// fit; empty frames (two delimiters in a row) are skipped.
    pub fn push(&mut self, byte: u8) -> Option<Result<&mut [u8], FrameError>> {
        if byte != 0 {
            match self.buf.get_mut(self.len) {
                Some(slot) if !self.overflowed => {
                    *slot = byte;
                    self.len += 1;
                }
                _ => self.overflowed = true,
            }
            return None;
        }
        let (len, overflowed) = (self.len, self.overflowed);
        self.len = 0;
        self.overflowed = false;
        if overflowed {
            return Some(Err(FrameError::TooLong));
        }
        if len == 0 {
            return None;
        }
        self.buf.get_mut(..len).map(Ok)
    }
}

#[cfg(test)]
mod tests;
