//! A recorded master session: what reached a remote slave over the delayed link, each
//! command frame as it arrived (after the network's delay and loss) with its arrival
//! period counted from the master's start, and, for a tracking summary, the scaled
//! master position of command ticks. The host's remote scenario writes it; the QEMU
//! replay and the host link's session job ([`super::session`]) play it back.
//!
//! Format, version 1, little-endian:
//!
//! ```text
//! "KRFR" version:u16 m:u8 block:u8 samples_per_command:u16 margin_periods:u32
//! start_m:[f32;3] laser_power_w:f32 approach_s:f32 periods:u32 measure_from:u32
//! ticks:u32 frames:u32
//! ticks × (tick:u32 [f32;3])           scaled master position per command tick, ticks rising, m
//! frames × (arrival:u32 len:u16 bytes) in arrival order
//! ```

use crate::app::remote_link::BLOCK;
use crate::app::stream::MAX_FRAME_LEN;
use crate::hal::{FrameLink, LinkBusy};

/// Magic of a recording.
pub const RECORDING_MAGIC: [u8; 4] = *b"KRFR";
/// The format version this module writes and reads.
pub const RECORDING_VERSION: u16 = 1;
/// Bytes of a recording's header.
pub const RECORDING_HEADER_LEN: usize = 50;
/// Bytes of one reference: the tick and the position.
pub const REFERENCE_LEN: usize = 16;
/// Bytes before a frame's own: its arrival and length.
pub const FRAME_PREFIX_LEN: usize = 6;

/// Why a recording was not read.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RecordingError {
    /// It does not start with [`RECORDING_MAGIC`].
    Magic,
    /// Another format version.
    Version(u16),
    /// A block length other than [`BLOCK`].
    Block(u8),
    /// It ends inside the header, the references or frame `.0`.
    Truncated(u32),
    /// Frame `.0` is longer than a stream frame can be.
    FrameTooLong(u32),
    /// Frame `.0` arrived before the one before it.
    OutOfOrder(u32),
    /// Bytes follow the last frame.
    TrailingBytes,
    /// A reference's tick is not above the one before it.
    TicksNotRising,
}

/// What a recording's header says.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct RecordingHeader {
    /// SDCT coefficients kept per block (the report stream's coding).
    pub m: u8,
    /// Control periods per link sample.
    pub samples_per_command: u16,
    /// The playout's margin, periods.
    pub margin_periods: u32,
    /// Where the slave waits for the master (the master's start, scaled), m.
    pub start_m: [f32; 3],
    /// The beam's constant power, W.
    pub laser_power_w: f32,
    /// The slave's approach to `start_m`, s.
    pub approach_s: f32,
    /// Control periods recorded from the master's start.
    pub periods: u32,
    /// The period from which the tracking summary counts.
    pub measure_from: u32,
}

/// The `N` bytes at `at`, if the slice holds them (an offset near `usize::MAX` is
/// past the end, not a wrap: these run in the control period).
fn bytes_at<const N: usize>(bytes: &[u8], at: usize) -> Option<[u8; N]> {
    bytes.get(at..at.checked_add(N)?)?.try_into().ok()
}

fn u16_at(bytes: &[u8], at: usize) -> Option<u16> {
    bytes_at(bytes, at).map(u16::from_le_bytes)
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    bytes_at(bytes, at).map(u32::from_le_bytes)
}

fn f32_at(bytes: &[u8], at: usize) -> Option<f32> {
    u32_at(bytes, at).map(f32::from_bits)
}

fn vector_at(bytes: &[u8], at: usize) -> Option<[f32; 3]> {
    Some([
        f32_at(bytes, at)?,
        f32_at(bytes, at.checked_add(4)?)?,
        f32_at(bytes, at.checked_add(8)?)?,
    ])
}

/// The frame at byte `at` of a frame section: (arrival, bytes, next offset).
pub fn frame_at(frames: &[u8], at: usize) -> Option<(u32, &[u8], usize)> {
    let arrival = u32_at(frames, at)?;
    let len = usize::from(u16_at(frames, at.checked_add(4)?)?);
    let start = at.checked_add(FRAME_PREFIX_LEN)?;
    let end = start.checked_add(len)?;
    let frame = frames.get(start..end)?;
    Some((arrival, frame, end))
}

/// The header's bytes for `header` with `ticks` references and `frames` frames.
pub fn header_bytes(
    header: &RecordingHeader,
    ticks: u32,
    frames: u32,
) -> [u8; RECORDING_HEADER_LEN] {
    let mut out = [0u8; RECORDING_HEADER_LEN];
    let h = header;
    let mut fields = out.iter_mut();
    let mut put = |bytes: &[u8]| {
        // The bytes first: zip stops on them without taking a field.
        for (from, to) in bytes.iter().zip(fields.by_ref()) {
            *to = *from;
        }
    };
    put(&RECORDING_MAGIC);
    put(&RECORDING_VERSION.to_le_bytes());
    put(&[h.m, BLOCK as u8]);
    put(&h.samples_per_command.to_le_bytes());
    put(&h.margin_periods.to_le_bytes());
    for c in h.start_m {
        put(&c.to_le_bytes());
    }
    for v in [h.laser_power_w, h.approach_s] {
        put(&v.to_le_bytes());
    }
    for v in [h.periods, h.measure_from, ticks, frames] {
        put(&v.to_le_bytes());
    }
    out
}

/// A validated recording, read in place.
#[derive(Copy, Clone, Debug)]
pub struct Recording<'a> {
    /// The header.
    pub header: RecordingHeader,
    references: &'a [u8],
    frames: &'a [u8],
    frame_count: u32,
}

impl<'a> Recording<'a> {
    /// Checks the header and walks every frame once.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, RecordingError> {
        let truncated = RecordingError::Truncated(0);
        if bytes.get(..4) != Some(&RECORDING_MAGIC[..]) {
            return Err(RecordingError::Magic);
        }
        let version = u16_at(bytes, 4).ok_or(truncated)?;
        if version != RECORDING_VERSION {
            return Err(RecordingError::Version(version));
        }
        let field = |at| u32_at(bytes, at).ok_or(truncated);
        let block = *bytes.get(7).ok_or(truncated)?;
        if usize::from(block) != BLOCK {
            return Err(RecordingError::Block(block));
        }
        let header = RecordingHeader {
            m: *bytes.get(6).ok_or(truncated)?,
            samples_per_command: u16_at(bytes, 8).ok_or(truncated)?,
            margin_periods: field(10)?,
            start_m: vector_at(bytes, 14).ok_or(truncated)?,
            laser_power_w: f32_at(bytes, 26).ok_or(truncated)?,
            approach_s: f32_at(bytes, 30).ok_or(truncated)?,
            periods: field(34)?,
            measure_from: field(38)?,
        };
        let (ticks, frame_count) = (field(42)?, field(46)?);
        let body = bytes.get(RECORDING_HEADER_LEN..).ok_or(truncated)?;
        let references_len = (ticks as usize)
            .checked_mul(REFERENCE_LEN)
            .ok_or(truncated)?;
        let (references, frames) = body.split_at_checked(references_len).ok_or(truncated)?;
        let recording = Self {
            header,
            references,
            frames,
            frame_count,
        };
        // The ticks rise (the lookup is a binary search).
        let mut previous = None;
        for tick in references
            .chunks_exact(REFERENCE_LEN)
            .filter_map(|r| u32_at(r, 0))
        {
            if previous.is_some_and(|p| tick <= p) {
                return Err(RecordingError::TicksNotRising);
            }
            previous = Some(tick);
        }
        // Every frame complete, in arrival order, nothing after the last.
        let mut cursor = 0;
        let mut last_arrival = 0;
        for i in 0..frame_count {
            let (arrival, frame, next) =
                frame_at(frames, cursor).ok_or(RecordingError::Truncated(i))?;
            if frame.len() > MAX_FRAME_LEN {
                return Err(RecordingError::FrameTooLong(i));
            }
            if arrival < last_arrival {
                return Err(RecordingError::OutOfOrder(i));
            }
            last_arrival = arrival;
            cursor = next;
        }
        if cursor != frames.len() {
            return Err(RecordingError::TrailingBytes);
        }
        Ok(recording)
    }

    /// The scaled master position of master tick `tick`, m (a binary search: the
    /// ticks rise).
    pub fn reference_m(&self, tick: u32) -> Option<[f32; 3]> {
        let (mut low, mut high) = (0, self.references.len() / REFERENCE_LEN);
        while low < high {
            let middle = low + (high - low) / 2;
            let at = middle * REFERENCE_LEN;
            match u32_at(self.references, at)?.cmp(&tick) {
                core::cmp::Ordering::Less => low = middle + 1,
                core::cmp::Ordering::Greater => high = middle,
                core::cmp::Ordering::Equal => return vector_at(self.references, at + 4),
            }
        }
        None
    }

    /// Command frames recorded.
    pub fn frame_count(&self) -> u32 {
        self.frame_count
    }

    /// The frame section: every frame with its arrival and length, in arrival order.
    pub fn frames(&self) -> &'a [u8] {
        self.frames
    }

    /// Writes the session of this recording's first `periods` into `out`: the header
    /// (its periods and `measure_from` cut to `periods`), no master references (a
    /// slave plays a session without them), the frames that arrived before `periods`.
    /// Returns its length; `None` when `out` is too small.
    pub fn write_session(&self, periods: u32, out: &mut [u8]) -> Option<usize> {
        let mut header = self.header;
        header.periods = header.periods.min(periods);
        header.measure_from = header.measure_from.min(header.periods);
        let (mut end, mut count) = (0, 0u32);
        while let Some((arrival, _, next)) = frame_at(self.frames, end) {
            if arrival >= header.periods {
                break;
            }
            (end, count) = (next, count + 1);
        }
        let frames = self.frames.get(..end)?;
        let len = RECORDING_HEADER_LEN + frames.len();
        let (head, body) = out.get_mut(..len)?.split_at_mut(RECORDING_HEADER_LEN);
        head.copy_from_slice(&header_bytes(&header, 0, count));
        body.copy_from_slice(frames);
        Some(len)
    }
}

/// Where a playback of a frame section is: the next frame's offset and how many were
/// delivered.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct FrameCursor {
    at: usize,
    delivered: u32,
}

impl FrameCursor {
    /// Copies the next frame of `frames` into `buf` if it arrived by period `now`;
    /// its length.
    pub fn next(&mut self, frames: &[u8], now: u32, buf: &mut [u8]) -> Option<usize> {
        let (arrival, frame, next) = frame_at(frames, self.at)?;
        if arrival > now {
            return None;
        }
        self.at = next;
        self.delivered = self.delivered.saturating_add(1);
        let into = buf.get_mut(..frame.len())?;
        into.copy_from_slice(frame);
        Some(frame.len())
    }

    /// Frames delivered.
    pub fn delivered(&self) -> u32 {
        self.delivered
    }
}

/// A frame section as the slave's link: each frame arrives at its recorded period;
/// nothing can be sent back.
pub struct ReplayLink<'a> {
    frames: &'a [u8],
    cursor: FrameCursor,
    /// Control periods since the master's start.
    pub now: u32,
}

impl<'a> ReplayLink<'a> {
    /// The link at the master's start.
    pub fn new(recording: Recording<'a>) -> Self {
        Self::resume(recording.frames(), FrameCursor::default(), 0)
    }

    /// The link over `frames` at `cursor`, in period `now`.
    pub fn resume(frames: &'a [u8], cursor: FrameCursor, now: u32) -> Self {
        Self {
            frames,
            cursor,
            now,
        }
    }

    /// Where the playback is.
    pub fn cursor(&self) -> FrameCursor {
        self.cursor
    }

    /// Frames delivered.
    pub fn delivered(&self) -> u32 {
        self.cursor.delivered()
    }
}

impl FrameLink for ReplayLink<'_> {
    fn send(&mut self, _frame: &[u8]) -> Result<(), LinkBusy> {
        Err(LinkBusy)
    }

    fn receive(&mut self, buf: &mut [u8]) -> Option<usize> {
        self.cursor.next(self.frames, self.now, buf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An offset at the end of the address range is past the end of any section, never
    /// a wrap (a panic with overflow checks, a wrong frame without): every reader of
    /// the frame section says `None` there, as the control period relies on.
    #[test]
    fn offsets_near_the_top_are_past_the_end() {
        let frames = [0u8; 32];
        for at in [usize::MAX, usize::MAX - 1, usize::MAX - 3, usize::MAX - 5] {
            assert_eq!(frame_at(&frames, at), None, "{at}");
            assert_eq!(vector_at(&frames, at), None, "{at}");
        }
        // Inside the section the same readers read: a frame of 2 bytes arriving at 7.
        let mut frames = [0u8; FRAME_PREFIX_LEN + 2];
        frames[..4].copy_from_slice(&7u32.to_le_bytes());
        frames[4..6].copy_from_slice(&2u16.to_le_bytes());
        let (arrival, frame, next) = frame_at(&frames, 0).unwrap();
        assert_eq!((arrival, frame.len(), next), (7, 2, FRAME_PREFIX_LEN + 2));
    }

    /// A frame section of `(arrival, bytes)` frames, written byte by byte as the
    /// module docs lay it out.
    fn section(frames: &[(u32, &[u8])]) -> std::vec::Vec<u8> {
        let mut out = std::vec::Vec::new();
        for (arrival, bytes) in frames {
            out.extend_from_slice(&arrival.to_le_bytes());
            out.extend_from_slice(&(bytes.len() as u16).to_le_bytes());
            out.extend_from_slice(bytes);
        }
        out
    }

    /// A playback delivers each frame at its arrival, not before, and counts it; a
    /// link resumed at its cursor in a later period goes on from the next frame (the
    /// session does so each period), and nothing is sent back.
    #[test]
    fn a_resumed_playback_goes_on_where_it_stopped() {
        let frames = section(&[(0, &[1, 2]), (5, &[3]), (5, &[4, 5, 6]), (9, &[7])]);
        let mut buf = [0u8; MAX_FRAME_LEN];
        let mut link = ReplayLink::resume(&frames, FrameCursor::default(), 0);
        assert_eq!(link.receive(&mut buf), Some(2));
        assert_eq!(buf[..2], [1, 2]);
        // The next arrives at 5.
        assert_eq!(link.receive(&mut buf), None);
        assert_eq!(link.delivered(), 1);
        assert_eq!(link.send(&[0]), Err(LinkBusy));
        let cursor = link.cursor();
        assert_eq!(cursor.delivered(), 1);
        let mut link = ReplayLink::resume(&frames, cursor, 5);
        assert_eq!(link.receive(&mut buf), Some(1));
        assert_eq!(buf[0], 3);
        assert_eq!(link.receive(&mut buf), Some(3));
        assert_eq!(buf[..3], [4, 5, 6]);
        assert_eq!(link.receive(&mut buf), None);
        assert_eq!(link.delivered(), 3);
        let mut link = ReplayLink::resume(&frames, link.cursor(), 9);
        assert_eq!(link.receive(&mut buf), Some(1));
        assert_eq!(buf[0], 7);
        assert_eq!(link.receive(&mut buf), None);
        assert_eq!(link.cursor().delivered(), 4);
    }
}
