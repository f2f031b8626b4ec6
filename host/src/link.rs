//! The host's end of the machine link ([`kerf::codec::link`]): numbered requests,
//! replies matched to them, telemetry and events kept in arrival order, and typed
//! errors for everything that can go wrong on the way.
//!
//! The byte stream is a serial port (a board's UART or USB CDC) or a TCP socket (the
//! emulated machine's UART, [`crate::qemu`]). A reader thread turns bytes into
//! messages with the firmware's own [`FrameReader`] and decoder; frames that do not
//! decode (line noise, a machine that joined mid-frame) are counted and skipped, as
//! the machine does with the host's.

use crate::description::{Item, MachineDescription};
use kerf::codec::link::{
    decode, encode, Event, FrameError, FrameReader, HostFrame, JobKind, MachineMessage,
    MachineStatus, Refusal, Reply, Request, TelemetrySample, MAX_FRAME, VERSION,
};
use std::collections::VecDeque;
use std::io::{Read, Write};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// What went wrong talking to a machine.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// The port or socket failed.
    #[error("link: {0}")]
    Io(#[from] std::io::Error),
    /// The machine closed the link (QEMU ended, the cable came out).
    #[error("the machine closed the link")]
    Closed,
    /// No reply within the timeout.
    #[error("no reply to {request} within {timeout_s} s")]
    Timeout {
        /// The request.
        request: &'static str,
        /// How long the host waited, s.
        timeout_s: f64,
    },
    /// The machine speaks another version of the protocol.
    #[error("the machine speaks link version {machine}, this tool version {host}")]
    Version {
        /// The machine's.
        machine: u8,
        /// Ours ([`VERSION`]).
        host: u8,
    },
    /// The machine refused the request; nothing changed on it.
    #[error("{request} refused: {reason}")]
    Refused {
        /// The request.
        request: &'static str,
        /// The machine's refusal.
        refusal: Refusal,
        /// It, in words.
        reason: String,
    },
    /// A reply of the wrong kind (a machine that does not follow the protocol).
    #[error("{request}: unexpected reply {reply}")]
    Unexpected {
        /// The request.
        request: &'static str,
        /// What came, as text.
        reply: String,
    },
    /// An upload gave up after retrying.
    #[error("upload stalled at byte {received} of {total} after {attempts} attempts")]
    Stalled {
        /// Bytes the machine holds.
        received: u32,
        /// Bytes of the job.
        total: u32,
        /// Attempts made.
        attempts: u32,
    },
    /// A job larger than the protocol's sizes carry.
    #[error("a job of {0} bytes is larger than the link carries")]
    TooLarge(usize),
    /// A request that does not fit a frame (a settings path or value too long).
    #[error("{0}: the request does not fit a frame (a path or value too long)")]
    RequestTooLong(&'static str),
    /// The machine's description did not end (a machine that does not follow the
    /// protocol).
    #[error("the machine's description did not end after {0} items")]
    EndlessDescription(u16),
}

/// Most items a machine's description may have.
const MAX_DESCRIPTION_ITEMS: u16 = 1024;

/// A reply, owned.
#[derive(Clone, Debug, PartialEq)]
pub enum OwnedReply {
    /// The machine's name, version, largest chunk and control period.
    Hello(Hello),
    /// Done.
    Ack,
    /// Refused.
    Refused(Refusal),
    /// Upload progress, bytes.
    JobProgress(u32),
    /// A setting's value, JSON.
    Value(String),
    /// The machine's state.
    Status(MachineStatus),
    /// Item `index` of the machine's description, `None` past the last (the
    /// description is added to the machine's as it arrives).
    Description {
        /// The item asked for.
        index: u16,
        /// The item.
        item: Option<Item>,
    },
}

/// Who the machine is ([`Reply::Hello`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Hello {
    /// Link version.
    pub version: u8,
    /// The machine's name (`keops-slave`, …).
    pub machine: String,
    /// Largest job chunk it takes, bytes.
    pub max_chunk: usize,
    /// Its control period, s.
    pub period_s: f64,
}

/// Something the machine said.
#[derive(Clone, Debug, PartialEq)]
pub enum Heard {
    /// The answer to request `seq`.
    Reply(u16, OwnedReply),
    /// A telemetry sample.
    Telemetry(TelemetrySample),
    /// An event.
    Event(Event),
    /// A frame of another link version (the machine's).
    OtherVersion(u8),
}

impl Heard {
    fn of(message: MachineMessage<'_>) -> Self {
        match message {
            MachineMessage::Reply { seq, reply } => Heard::Reply(
                seq,
                match reply {
                    Reply::Hello {
                        version,
                        machine,
                        max_chunk,
                        period_ns,
                    } => OwnedReply::Hello(Hello {
                        version,
                        machine: machine.to_owned(),
                        max_chunk: usize::from(max_chunk),
                        period_s: f64::from(period_ns) * 1e-9,
                    }),
                    Reply::Ack => OwnedReply::Ack,
                    Reply::Refused(r) => OwnedReply::Refused(r),
                    Reply::JobProgress { received } => OwnedReply::JobProgress(received),
                    Reply::Value { value } => {
                        OwnedReply::Value(String::from_utf8_lossy(value).into_owned())
                    }
                    Reply::Status(s) => OwnedReply::Status(s),
                    Reply::Description { index, item } => OwnedReply::Description {
                        index,
                        item: item.as_ref().map(Item::of),
                    },
                },
            ),
            MachineMessage::Telemetry(t) => Heard::Telemetry(t),
            MachineMessage::Event(e) => Heard::Event(e),
        }
    }
}

/// A request's name in messages.
fn name(request: &Request<'_>) -> &'static str {
    match request {
        Request::Hello => "hello",
        Request::Heartbeat => "heartbeat",
        Request::JobBegin { .. } => "upload (begin)",
        Request::JobChunk { .. } => "upload (chunk)",
        Request::JobStatus => "upload (status)",
        Request::JobCommit => "upload (commit)",
        Request::Start => "start",
        Request::Stop => "stop",
        Request::ResetFault => "reset fault",
        Request::Get { .. } => "get",
        Request::Set { .. } => "set",
        Request::Telemetry { .. } => "telemetry",
        Request::Status => "status",
        Request::Describe { .. } => "describe",
        Request::Save => "save",
    }
}

/// Most attempts at one chunk before an upload gives up.
const UPLOAD_ATTEMPTS: u32 = 4;

/// The host's end of the link to one connected machine: its identity, the frames
/// sent to it and the replies and telemetry heard from it.
pub struct MachineLink {
    writer: Box<dyn Write + Send>,
    heard: Receiver<Option<Heard>>,
    bad_frames: Arc<AtomicU32>,
    backlog: VecDeque<Heard>,
    seq: u16,
    reply_timeout: Duration,
    hello: Hello,
    description: MachineDescription,
}

impl MachineLink {
    /// Connects over `reader`/`writer` (two handles of one port or socket) and asks
    /// who the machine is.
    ///
    /// Errors: the link, no answer within `reply_timeout`, another protocol version.
    pub fn connect(
        reader: Box<dyn Read + Send>,
        writer: Box<dyn Write + Send>,
        reply_timeout: Duration,
    ) -> Result<Self, LinkError> {
        let (tx, rx) = channel();
        let bad_frames = Arc::new(AtomicU32::new(0));
        let bad = Arc::clone(&bad_frames);
        std::thread::spawn(move || {
            let mut reader = reader;
            let mut frames = FrameReader::<MAX_FRAME>::new();
            let mut buf = [0u8; 512];
            loop {
                let n = match reader.read(&mut buf) {
                    Ok(0) => break,
                    Ok(n) => n,
                    Err(e) if e.kind() == std::io::ErrorKind::TimedOut => continue,
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                    Err(_) => break,
                };
                for &b in &buf[..n] {
                    let decoded = match frames.push(b) {
                        None => continue,
                        Some(Ok(frame)) => decode::<MachineMessage>(frame).map(Heard::of),
                        Some(Err(e)) => Err(e),
                    };
                    let heard = match decoded {
                        Ok(h) => h,
                        Err(FrameError::Version(v)) => Heard::OtherVersion(v),
                        Err(_) => {
                            bad.fetch_add(1, Ordering::Relaxed);
                            continue;
                        }
                    };
                    if tx.send(Some(heard)).is_err() {
                        return;
                    }
                }
            }
            let _ = tx.send(None);
        });
        let mut machine = MachineLink {
            writer,
            heard: rx,
            bad_frames,
            backlog: VecDeque::new(),
            seq: 0,
            reply_timeout,
            hello: Hello {
                version: 0,
                machine: String::new(),
                max_chunk: 0,
                period_s: 0.0,
            },
            description: MachineDescription::default(),
        };
        match machine.ask(Request::Hello)? {
            OwnedReply::Hello(h) if h.version == VERSION => machine.hello = h,
            OwnedReply::Hello(h) => {
                return Err(LinkError::Version {
                    machine: h.version,
                    host: VERSION,
                })
            }
            other => {
                return Err(LinkError::Unexpected {
                    request: "hello",
                    reply: format!("{other:?}"),
                })
            }
        }
        machine.description = machine.ask_description()?;
        Ok(machine)
    }

    /// Asks the machine's description item by item until it says there is no more.
    fn ask_description(&mut self) -> Result<MachineDescription, LinkError> {
        let mut description = MachineDescription::default();
        for index in 0..MAX_DESCRIPTION_ITEMS {
            match self.ask(Request::Describe { index })? {
                OwnedReply::Description { index: i, item } if i == index => match item {
                    Some(item) => description.add(&item),
                    None => return Ok(description),
                },
                other => {
                    return Err(LinkError::Unexpected {
                        request: "describe",
                        reply: format!("{other:?}"),
                    })
                }
            }
        }
        Err(LinkError::EndlessDescription(MAX_DESCRIPTION_ITEMS))
    }

    /// Who the machine said it is.
    pub fn hello(&self) -> &Hello {
        &self.hello
    }

    /// What the machine said of itself: channels, job kinds, settings, codes.
    pub fn description(&self) -> &MachineDescription {
        &self.description
    }

    /// Frames from the machine that did not decode so far.
    pub fn bad_frames(&self) -> u32 {
        self.bad_frames.load(Ordering::Relaxed)
    }

    /// Sends `request` without waiting; returns its number.
    pub fn send(&mut self, request: Request<'_>) -> Result<u16, LinkError> {
        self.seq = self.seq.wrapping_add(1);
        let mut out = [0u8; MAX_FRAME];
        let frame = HostFrame {
            seq: self.seq,
            request,
        };
        let what = name(&frame.request);
        let n = encode(&frame, &mut out).map_err(|_| LinkError::RequestTooLong(what))?;
        self.writer.write_all(&out[..n])?;
        self.writer.flush()?;
        Ok(self.seq)
    }

    /// The next message not yet taken, waiting at most `timeout`.
    pub fn next(&mut self, timeout: Duration) -> Result<Option<Heard>, LinkError> {
        if let Some(h) = self.backlog.pop_front() {
            return Ok(Some(h));
        }
        self.receive(timeout)
    }

    fn receive(&mut self, timeout: Duration) -> Result<Option<Heard>, LinkError> {
        match self.heard.recv_timeout(timeout) {
            Ok(Some(h)) => Ok(Some(h)),
            Ok(None) | Err(RecvTimeoutError::Disconnected) => Err(LinkError::Closed),
            Err(RecvTimeoutError::Timeout) => Ok(None),
        }
    }

    /// Sends `request` and waits for its reply; what else comes meanwhile is kept
    /// for [`MachineLink::next`].
    pub fn ask(&mut self, request: Request<'_>) -> Result<OwnedReply, LinkError> {
        let what = name(&request);
        let seq = self.send(request)?;
        self.reply_to(seq, what)
    }

    /// Waits for the reply to request `seq`.
    pub fn reply_to(&mut self, seq: u16, what: &'static str) -> Result<OwnedReply, LinkError> {
        let deadline = Instant::now() + self.reply_timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.receive(left)? {
                Some(Heard::Reply(s, reply)) if s == seq => return Ok(reply),
                Some(Heard::OtherVersion(machine)) => {
                    return Err(LinkError::Version {
                        machine,
                        host: VERSION,
                    })
                }
                // A late reply to an earlier request: already given up on.
                Some(Heard::Reply(..)) => {}
                Some(other) => self.backlog.push_back(other),
                None => {
                    return Err(LinkError::Timeout {
                        request: what,
                        timeout_s: self.reply_timeout.as_secs_f64(),
                    })
                }
            }
        }
    }

    /// Sends `request` and expects `Ack`.
    pub fn command(&mut self, request: Request<'_>) -> Result<(), LinkError> {
        let what = name(&request);
        match self.ask(request)? {
            OwnedReply::Ack => Ok(()),
            other => Err(self.not_ack(what, other)),
        }
    }

    fn not_ack(&self, request: &'static str, reply: OwnedReply) -> LinkError {
        self.not_ack_at(request, reply, None)
    }

    /// As [`MachineLink::not_ack`], for a request about the setting at `path`.
    fn not_ack_at(
        &self,
        request: &'static str,
        reply: OwnedReply,
        path: Option<&str>,
    ) -> LinkError {
        match reply {
            OwnedReply::Refused(refusal) => LinkError::Refused {
                request,
                reason: self.description.refusal_words(&refusal, path),
                refusal,
            },
            other => LinkError::Unexpected {
                request,
                reply: format!("{other:?}"),
            },
        }
    }

    /// A setting's value, JSON.
    pub fn get(&mut self, path: &str) -> Result<String, LinkError> {
        match self.ask(Request::Get { path })? {
            OwnedReply::Value(v) => Ok(v),
            other => Err(self.not_ack_at("get", other, Some(path))),
        }
    }

    /// Sets a setting (JSON value); the machine validates it as a configuration. A
    /// refusal names the range the machine announced for the setting.
    pub fn set(&mut self, path: &str, value: &str) -> Result<(), LinkError> {
        let request = Request::Set {
            path,
            value: value.as_bytes(),
        };
        match self.ask(request)? {
            OwnedReply::Ack => Ok(()),
            other => Err(self.not_ack_at("set", other, Some(path))),
        }
    }

    /// Asks for `rate_hz` telemetry samples per second of machine time (at most one
    /// per control period).
    pub fn telemetry(&mut self, rate_hz: f64) -> Result<(), LinkError> {
        let every = (1.0 / (rate_hz * self.hello.period_s))
            .round()
            .clamp(1.0, f64::from(u32::MAX)) as u32;
        self.command(Request::Telemetry {
            every_periods: every,
        })
    }

    /// The machine's state.
    pub fn status(&mut self) -> Result<MachineStatus, LinkError> {
        match self.ask(Request::Status)? {
            OwnedReply::Status(s) => Ok(s),
            other => Err(self.not_ack("status", other)),
        }
    }

    /// Uploads `job` (a job file of `kind`) in chunks and commits it; `progress` is
    /// told the bytes the machine holds after each chunk. A lost or refused chunk is
    /// resumed at the offset the machine reports; the machine checks the CRC and
    /// builds its job at the commit.
    pub fn upload(
        &mut self,
        kind: JobKind,
        job: &[u8],
        progress: &mut dyn FnMut(u32),
    ) -> Result<(), LinkError> {
        let total = u32::try_from(job.len()).map_err(|_| LinkError::TooLarge(job.len()))?;
        self.command(Request::JobBegin {
            kind,
            total_bytes: total,
            crc32: kerf::codec::link::crc32(job),
        })?;
        let chunk = self.hello.max_chunk.max(1);
        let mut received = 0u32;
        let mut attempts = 0;
        while received < total {
            let start = received as usize;
            let end = (start + chunk).min(job.len());
            let reply = self.ask(Request::JobChunk {
                offset: received,
                data: &job[start..end],
            });
            match reply {
                Ok(OwnedReply::JobProgress(n)) => {
                    received = n;
                    attempts = 0;
                    progress(n);
                    continue;
                }
                Ok(OwnedReply::Refused(Refusal::ChunkOffset { expected })) => {
                    received = expected;
                }
                Ok(other) => return Err(self.not_ack("upload (chunk)", other)),
                Err(LinkError::Timeout { .. }) => {
                    // The chunk or its reply was lost: ask where the machine is.
                    match self.ask(Request::JobStatus)? {
                        OwnedReply::JobProgress(n) => received = n,
                        other => return Err(self.not_ack("upload (status)", other)),
                    }
                }
                Err(e) => return Err(e),
            }
            attempts += 1;
            if attempts >= UPLOAD_ATTEMPTS {
                return Err(LinkError::Stalled {
                    received,
                    total,
                    attempts,
                });
            }
        }
        self.command(Request::JobCommit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kerf::codec::link::crc32;

    /// `message` framed as a machine of link version `version` would frame it.
    fn framed_as(version: u8, message: &MachineMessage<'_>) -> Vec<u8> {
        let mut out = [0u8; MAX_FRAME];
        let n = encode(message, &mut out).unwrap();
        let mut raw = out[1..n - 1].to_vec();
        let len = cobs::decode_in_place(&mut raw).unwrap();
        raw.truncate(len);
        raw[0] = version;
        let crc = crc32(&raw[..len - 4]).to_le_bytes();
        raw[len - 4..].copy_from_slice(&crc);
        let mut encoded = vec![0u8; MAX_FRAME];
        let m = cobs::encode(&raw, &mut encoded);
        [&[0u8][..], &encoded[..m], &[0u8]].concat()
    }

    /// A machine that answers in another version is named with both versions (not
    /// taken for a closed link or a silent machine).
    #[test]
    fn a_machine_of_another_version_is_refused_naming_both() {
        let hello = MachineMessage::Reply {
            seq: 1,
            reply: Reply::Hello {
                version: VERSION + 1,
                machine: "lathe",
                max_chunk: 64,
                period_ns: 1_000,
            },
        };
        let stream = framed_as(VERSION + 1, &hello);
        let reader = Box::new(std::io::Cursor::new(stream));
        let result =
            MachineLink::connect(reader, Box::new(std::io::sink()), Duration::from_secs(30));
        let Err(e) = result else {
            panic!("connected to a machine of another version")
        };
        assert_eq!(
            e.to_string(),
            format!(
                "the machine speaks link version {}, this tool version {VERSION}",
                VERSION + 1
            )
        );
    }
}
