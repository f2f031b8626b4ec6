//! The two ends of the remote machining link (T 7.2.3): what the master's and the
//! slave's images put on a [`FrameLink`] and take off it, each period.
//!
//! Master → slave: the slave's commands, one sample every `samples_per_command`
//! periods, in SDCT frames of N samples of the three acceleration channels
//! ([`StreamSender`]), behind an 8-byte header: the master's session (u16, a new
//! value at each power-up), the tick of the block's first sample (u32; sample j has
//! tick first + j · samples_per_command), and the beam's on/off per sample (u16 mask,
//! so N ≤ 16). Slave → master: the slave's effector position on the same sample
//! clock, in frames behind a 7-byte header: the tick of the command it was executing
//! at the block's last sample (u32), the master session it belongs to (u16), and a
//! flag byte (bit 0: the tick is valid, i.e. a command had played). Both headers are
//! under the stream frame's CRC-32 with the packets (`app::stream`), so one flipped
//! bit in a beam mask, a session or a tick refuses the frame instead of firing the
//! beam, restarting the playout or moving a block.
//!
//! A lossy link costs the slave the commands of every lost frame (16 ms of them: the
//! previous command holds meanwhile and the slave's model leaves the master's), so
//! the master can send every command frame more than once ([`MasterLink::with_copies`]):
//! byte for byte, `copies − 1` times again just before the next block's frame, a block
//! period after the original. A copy of a frame the slave has already taken is refused
//! by the stream's sequence check (counted apart as a repeat); a copy of a lost one
//! arrives in order, before the next block's frame, and plays as the original would
//! have if the slave's playout margin holds the extra block period (docs/control.md
//! §22). A block is then lost only when every copy is: with losses independent from
//! frame to frame, at p^copies for a frame loss p. (Copies spread over several later
//! blocks would not do better: the stream takes blocks in order, so a copy that
//! arrives after the next block's frame is refused.)
//!
//! Both ends can instead put every link sample in its own uncoded frame ([`raw`]): the
//! baseline without the blocks' latency.
//!
//! The slave end plays the commands out (`app::playout`) at a fixed latency. It keeps
//! the master session it has while that master is heard: a frame of another session
//! (a second master on the network) is dropped and counted, unless the session it has
//! has been silent for two block periods (32 ms at 16 samples of 1 kHz), when the new
//! one is a master that restarted; its first frame the stream takes then restarts the
//! playout, so the new master's ticks are not refused as stale. The master end passes the newest report to its
//! machine; a report of another session (the slave has not yet heard from this
//! master) can start the delay observer but never corrects it. Frames the stream
//! refuses (bad frame or packet CRC, cut, spliced, replayed, out of order) are dropped
//! and counted.

use crate::app::playout::{Playing, Playout, PlayoutRejected};
use crate::app::stream::{StreamError, StreamReceiver, StreamSender, FRAME_CRC_LEN, MAX_FRAME_LEN};
use crate::codec::link::crc32;
use crate::codec::packet::PacketError;
use crate::codec::sdct::SdctConfig;
use crate::error::{positive, ConfigError};
use crate::hal::{FrameLink, LinkBusy};
use heapless::Vec;

pub mod raw;

/// Link samples per SDCT block of the command and report streams, at both ends (at most
/// 16: the beam mask's bits hold a block).
pub const BLOCK: usize = 16;

/// What the master sends for one link sample.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct RemoteCommand {
    /// The slave's desired task acceleration ẍdes, m/s² (base frame).
    pub acceleration_m_s2: [f32; 3],
    /// The operator wants the beam on.
    pub laser_on: bool,
}

/// What the slave reports.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct SlaveReport {
    /// The master tick of the command it was executing when it measured (`None`: no
    /// command of this master's session had played).
    pub echo_tick: Option<u32>,
    /// Its effector, m.
    pub position_m: [f32; 3],
    /// Its effector's velocity, m/s (for the comparison case without the observer).
    pub velocity_m_s: [f32; 3],
}

/// Bytes of the master → slave header.
const COMMAND_HEADER: usize = 8;
/// Bytes of the slave → master header.
const REPORT_HEADER: usize = 7;

fn u16_at(bytes: &[u8], at: usize) -> u16 {
    let mut b = [0u8; 2];
    if let Some(s) = bytes.get(at..at + 2) {
        b.copy_from_slice(s);
    }
    u16::from_le_bytes(b)
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    let mut b = [0u8; 4];
    if let Some(s) = bytes.get(at..at + 4) {
        b.copy_from_slice(s);
    }
    u32::from_le_bytes(b)
}

fn put(bytes: &mut [u8], at: usize, value: &[u8]) {
    if let Some(s) = bytes.get_mut(at..at + value.len()) {
        s.copy_from_slice(value);
    }
}

/// Most times a command frame goes out ([`MasterLink::with_copies`]).
pub const MAX_COPIES: usize = 3;

/// A frame as it went out, for its copies.
type SentFrame = Vec<u8, MAX_FRAME_LEN>;

/// The link, keeping the frame it takes.
struct Keeping<'a, L> {
    link: &'a mut L,
    kept: Option<SentFrame>,
}

impl<L: FrameLink> FrameLink for Keeping<'_, L> {
    fn send(&mut self, frame: &[u8]) -> Result<(), LinkBusy> {
        self.link.send(frame)?;
        self.kept = Vec::from_slice(frame).ok();
        Ok(())
    }

    fn receive(&mut self, buf: &mut [u8]) -> Option<usize> {
        self.link.receive(buf)
    }
}

/// Blocks of N ≤ 16 samples (the beam mask is 16 bits).
fn check_block<const N: usize>() -> Result<(), ConfigError> {
    if N > 16 {
        return Err(ConfigError::out_of_range("block_samples"));
    }
    Ok(())
}

/// The master's end.
#[derive(Clone, Debug)]
pub struct MasterLink<const N: usize> {
    commands: StreamSender<3, N>,
    reports: StreamReceiver<3, N>,
    session: u16,
    filled: usize,
    first_tick: u32,
    laser_mask: u16,
    inv_sample_period: f32,
    refused: u32,
    /// Times each command frame goes out (1 to [`MAX_COPIES`]).
    copies: usize,
    /// The last frame sent, while copies are sent.
    last: Option<SentFrame>,
    /// Raw samples ([`raw`]): the newest report's position, for the velocity.
    raw: Option<Option<[f32; 3]>>,
}

impl<const N: usize> MasterLink<N> {
    /// The master's end for power-up `session`, coding `sdct.m` of N coefficients,
    /// one command sample every `sample_period_s`.
    pub fn new(sdct: &SdctConfig, session: u16, sample_period_s: f64) -> Result<Self, ConfigError> {
        check_block::<N>()?;
        Ok(Self {
            commands: StreamSender::new(sdct)?,
            reports: StreamReceiver::new()?,
            session,
            filled: 0,
            first_tick: 0,
            laser_mask: 0,
            inv_sample_period: crate::error::coefficient::<f32>(
                "sample_period_s",
                1.0 / positive("sample_period_s", sample_period_s)?,
            )?,
            refused: 0,
            copies: 1,
            last: None,
            raw: None,
        })
    }

    /// Every command in its own uncoded frame, and reports read the same way ([`raw`]);
    /// the slave's end must be raw too.
    pub fn with_raw_samples(mut self) -> Self {
        self.raw = Some(None);
        self
    }

    /// Sends every command frame `copies` times (1 to [`MAX_COPIES`]; 1, each once, is
    /// the default): `copies − 1` times again just before the next frame (module docs).
    /// The slave's playout margin must hold one more block period.
    pub fn with_copies(mut self, copies: usize) -> Result<Self, ConfigError> {
        if !(1..=MAX_COPIES).contains(&copies) {
            return Err(ConfigError::out_of_range("command_copies"));
        }
        self.copies = copies;
        Ok(self)
    }

    /// Queues this period's command (if the machine made one); a full block goes out.
    pub fn send(&mut self, command: Option<(u32, RemoteCommand)>, link: &mut impl FrameLink) {
        let Some((tick, c)) = command else { return };
        if self.raw.is_some() {
            self.send_copies(link);
            let frame = raw::command_frame(self.session, tick, &c);
            if link.send(&frame).is_ok() && self.copies > 1 {
                self.last = Vec::from_slice(&frame).ok();
            }
            return;
        }
        if self.filled == 0 {
            self.first_tick = tick;
            self.laser_mask = 0;
        }
        if c.laser_on {
            self.laser_mask |= 1 << self.filled;
        }
        self.filled = (self.filled + 1) % N.max(1);
        // The sender reads the header only with a block's last sample.
        let mut header = [0u8; COMMAND_HEADER];
        if self.filled == 0 {
            put(&mut header, 0, &self.session.to_le_bytes());
            put(&mut header, 2, &self.first_tick.to_le_bytes());
            put(&mut header, 6, &self.laser_mask.to_le_bytes());
        }
        if self.filled == 0 {
            self.send_copies(link);
        }
        // A busy link drops the block; the sender counts it and the slave sees the gap.
        let mut keeping = Keeping { link, kept: None };
        let _ = self
            .commands
            .push_frame(c.acceleration_m_s2, &header, &mut keeping);
        if self.copies > 1 && keeping.kept.is_some() {
            self.last = keeping.kept;
        }
    }

    /// The last frame's copies, before a new frame, so that the slave receives blocks
    /// in order whichever copy arrives. A busy link drops a copy.
    fn send_copies(&mut self, link: &mut impl FrameLink) {
        if let Some(frame) = self.last.take() {
            for _ in 1..self.copies {
                let _ = link.send(&frame);
            }
        }
    }

    /// The newest report that arrived (frames the stream refuses are counted).
    pub fn receive(&mut self, link: &mut impl FrameLink) -> Option<SlaveReport> {
        if let Some(previous) = &mut self.raw {
            return Self::receive_raw(
                link,
                self.session,
                self.inv_sample_period,
                previous,
                &mut self.refused,
            );
        }
        let mut newest = None;
        let mut header = [0u8; REPORT_HEADER];
        let mut block = [[0.0f32; N]; 3];
        while let Some(frame) = self.reports.poll_frame(link, &mut header, &mut block) {
            if frame.is_err() {
                self.refused = self.refused.saturating_add(1);
                continue;
            }
            let last = |i: usize| block.each_ref().map(|c| c.get(i).copied().unwrap_or(0.0));
            let (position, before) = (last(N.saturating_sub(1)), last(N.saturating_sub(2)));
            let valid =
                header.get(6).is_some_and(|f| f & 1 == 1) && u16_at(&header, 4) == self.session;
            newest = Some(SlaveReport {
                echo_tick: valid.then(|| u32_at(&header, 0)),
                position_m: position,
                velocity_m_s: [0, 1, 2].map(|k| {
                    (position.get(k).copied().unwrap_or(0.0)
                        - before.get(k).copied().unwrap_or(0.0))
                        * self.inv_sample_period
                }),
            });
        }
        newest
    }

    /// The newest raw report; the velocity from the previous one's position.
    fn receive_raw(
        link: &mut impl FrameLink,
        session: u16,
        inv_sample_period: f32,
        previous: &mut Option<[f32; 3]>,
        refused: &mut u32,
    ) -> Option<SlaveReport> {
        let mut newest = None;
        let mut buf = [0u8; raw::FRAME_LEN + 1];
        while let Some(len) = link.receive(&mut buf) {
            let Some((echo, from, position)) = buf.get(..len).and_then(raw::parse_report) else {
                *refused = refused.saturating_add(1);
                continue;
            };
            let before = previous.replace(position).unwrap_or(position);
            newest = Some(SlaveReport {
                echo_tick: echo.filter(|_| from == session),
                position_m: position,
                velocity_m_s: [0, 1, 2].map(|k| {
                    (position.get(k).copied().unwrap_or(0.0)
                        - before.get(k).copied().unwrap_or(0.0))
                        * inv_sample_period
                }),
            });
        }
        newest
    }

    /// Report frames refused so far.
    pub fn refused(&self) -> u32 {
        self.refused
    }

    /// Command blocks the link could not take.
    pub fn dropped(&self) -> u32 {
        self.commands.dropped()
    }
}

/// The slave's end.
#[derive(Clone, Debug)]
pub struct SlaveLink<const N: usize, const CAP: usize> {
    commands: StreamReceiver<3, N>,
    playout: Playout<RemoteCommand, CAP>,
    reports: StreamSender<3, N>,
    samples_per_command: u32,
    session: Option<u16>,
    executing: Option<u32>,
    phase: u32,
    refused: u32,
    repeats: u32,
    restarts: u32,
    foreign: u32,
    raw: bool,
    /// Local period of the newest frame of the session it has.
    last_heard: u32,
    /// Silence of that session after which another session is taken, periods.
    takeover_periods: u32,
}

impl<const N: usize, const CAP: usize> SlaveLink<N, CAP> {
    /// The slave's end: commands every `samples_per_command` periods, played
    /// `margin_periods` behind the first one's arrival; reports coded with `sdct.m`.
    pub fn new(
        sdct: &SdctConfig,
        samples_per_command: u32,
        margin_periods: u32,
    ) -> Result<Self, ConfigError> {
        check_block::<N>()?;
        if samples_per_command == 0 {
            return Err(ConfigError::out_of_range("samples_per_command"));
        }
        Ok(Self {
            commands: StreamReceiver::new()?,
            playout: Playout::new(margin_periods),
            reports: StreamSender::new(sdct)?,
            samples_per_command,
            session: None,
            executing: None,
            phase: 0,
            refused: 0,
            repeats: 0,
            restarts: 0,
            foreign: 0,
            raw: false,
            last_heard: 0,
            takeover_periods: 2u32
                .saturating_mul(N as u32)
                .saturating_mul(samples_per_command),
        })
    }

    /// Commands and reports in uncoded frames of one sample ([`raw`]); the master's end
    /// must be raw too.
    pub fn with_raw_samples(mut self) -> Self {
        self.raw = true;
        self
    }

    /// Whether a frame of `session` arriving at local period `now` may be taken: the
    /// session it has, or another once that one has been silent (module docs).
    fn may_take(&mut self, session: u16, now: u32) -> bool {
        let taken = match self.session {
            Some(s) if s != session => now.wrapping_sub(self.last_heard) >= self.takeover_periods,
            _ => true,
        };
        if !taken {
            self.foreign = self.foreign.saturating_add(1);
        }
        taken
    }

    /// A command frame of `session` was taken at `now`: a new session restarts the
    /// playout.
    fn session(&mut self, session: u16, now: u32) {
        self.last_heard = now;
        if self.session != Some(session) {
            if self.session.is_some() {
                self.restarts = self.restarts.saturating_add(1);
            }
            self.session = Some(session);
            self.playout.restart();
            self.executing = None;
        }
    }

    /// SDCT command frames into the playout.
    fn receive_blocks(&mut self, now: u32, link: &mut impl FrameLink) {
        let mut header = [0u8; COMMAND_HEADER];
        let mut block = [[0.0f32; N]; 3];
        let mut buf = [0u8; MAX_FRAME_LEN];
        while let Some(len) = link.receive(&mut buf) {
            let bytes = buf.get(..len).unwrap_or(&[]);
            // The session is read before the stream takes the frame (a second master's
            // frames would move the stream's sequence), once the frame's CRC holds.
            let intact = bytes
                .split_last_chunk::<FRAME_CRC_LEN>()
                .is_some_and(|(body, crc)| crc32(body) == u32::from_le_bytes(*crc));
            if !intact {
                self.refused = self.refused.saturating_add(1);
                continue;
            }
            if !self.may_take(u16_at(bytes, 0), now) {
                continue;
            }
            match self.commands.accept(bytes, &mut header, &mut block) {
                Ok(_) => {}
                Err(StreamError::Packet(PacketError::SequenceBackwards { .. })) => {
                    self.repeats = self.repeats.saturating_add(1);
                    continue;
                }
                Err(_) => {
                    self.refused = self.refused.saturating_add(1);
                    continue;
                }
            }
            self.session(u16_at(&header, 0), now);
            let (first, mask) = (u32_at(&header, 2), u16_at(&header, 6));
            let [x, y, z] = &block;
            for (j, ((x, y), z)) in x.iter().zip(y).zip(z).enumerate() {
                let tick = first.wrapping_add((j as u32).wrapping_mul(self.samples_per_command));
                let command = RemoteCommand {
                    acceleration_m_s2: [*x, *y, *z],
                    laser_on: mask >> j & 1 == 1,
                };
                // Stale (a replay, a duplicate) or no room: dropped, as the playout
                // counts its own.
                let _ = self.playout.push(now, tick, command);
            }
        }
    }

    /// Raw command frames into the playout.
    fn receive_raw(&mut self, now: u32, link: &mut impl FrameLink) {
        let mut buf = [0u8; raw::FRAME_LEN + 1];
        while let Some(len) = link.receive(&mut buf) {
            let Some((session, tick, command)) = buf.get(..len).and_then(raw::parse_command) else {
                self.refused = self.refused.saturating_add(1);
                continue;
            };
            if !self.may_take(session, now) {
                continue;
            }
            self.session(session, now);
            // A copy or a replay of a command already queued or played is stale.
            if self.playout.push(now, tick, command) == Err(PlayoutRejected::Stale) {
                self.repeats = self.repeats.saturating_add(1);
            }
        }
    }

    /// Takes what arrived into the playout; returns the command playing in local
    /// period `now` and whether it started this period.
    pub fn receive(
        &mut self,
        now: u32,
        link: &mut impl FrameLink,
    ) -> (Option<RemoteCommand>, bool) {
        if self.raw {
            self.receive_raw(now, link);
        } else {
            self.receive_blocks(now, link);
        }
        match self.playout.next(now) {
            Playing::Waiting => (None, false),
            Playing::Command {
                tick,
                value,
                held_periods,
            } => {
                self.executing = Some(tick);
                (Some(value), held_periods == 0)
            }
        }
    }

    /// Every `samples_per_command` periods, the slave's effector goes into the report
    /// stream (nothing while the position is unknown).
    pub fn report(&mut self, position_m: Option<[f32; 3]>, link: &mut impl FrameLink) {
        let due = self.phase == 0;
        self.phase = (self.phase + 1) % self.samples_per_command;
        let (true, Some(position)) = (due, position_m) else {
            return;
        };
        if self.raw {
            let frame = raw::report_frame(self.executing, self.session.unwrap_or(0), position);
            let _ = link.send(&frame);
            return;
        }
        let mut header = [0u8; REPORT_HEADER];
        put(&mut header, 0, &self.executing.unwrap_or(0).to_le_bytes());
        put(&mut header, 4, &self.session.unwrap_or(0).to_le_bytes());
        put(&mut header, 6, &[u8::from(self.executing.is_some())]);
        let _ = self.reports.push_frame(position, &header, link);
    }

    /// The master tick of the command playing (`None` before the first of this
    /// session).
    pub fn executing(&self) -> Option<u32> {
        self.executing
    }

    /// Command frames refused so far as bad (CRC, cut, spliced, not a frame).
    pub fn refused(&self) -> u32 {
        self.refused
    }

    /// Command frames of blocks already taken (the master's copies, a duplicate, a
    /// replay, a frame overtaken by a later one): dropped, never played.
    pub fn repeats(&self) -> u32 {
        self.repeats
    }

    /// Command frames of another master's session dropped while the one taken was
    /// heard.
    pub fn foreign(&self) -> u32 {
        self.foreign
    }

    /// Master restarts seen (a new session).
    pub fn restarts(&self) -> u32 {
        self.restarts
    }

    /// Commands that arrived after their play time.
    pub fn late(&self) -> u32 {
        self.playout.late()
    }

    /// The playout's latency behind the master's ticks, periods.
    pub fn latency_periods(&self) -> Option<u32> {
        self.playout.offset()
    }
}

#[cfg(test)]
mod tests;
