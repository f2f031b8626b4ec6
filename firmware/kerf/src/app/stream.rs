//! A machine's signals sent over a [`FrameLink`] (docs/codec.md §30, T 7.2.3): blocks
//! of N samples of each of C channels sampled together, SDCT-coded, one frame per
//! block; the receiver validates the frame and its order and reconstructs.
//!
//! # Frame
//!
//! | bytes | field |
//! |---|---|
//! | h | the caller's header (0 to [`MAX_FRAME_HEADER`] bytes; both ends agree on h) |
//! | C × (13 to [`MAX_PACKET_LEN`]) | one packet per channel ([`packet`]: the block's sequence number, the index of its first sample, its own CRC-16) |
//! | 4 | CRC-32 (ISO-HDLC, [`crc32`]) of every byte before it, little-endian |
//!
//! The trailing CRC covers the caller's header, which no packet CRC does: the
//! receiver checks it before it reads anything else, so a frame with one flipped bit
//! anywhere (a beam mask, a session, a tick) is refused whole. CRC-32 detects every
//! error of up to three bits and every burst of up to 32 bits in frames of this size
//! (at most [`MAX_FRAME_LEN`] bytes).
//!
//! The master sends the slave its motion this way, a machine its telemetry to the
//! host. Both ends are sans-IO apart from the link, never block (a busy link drops
//! the block and counts it), and never allocate.
//!
//! ```
//! use kerf::app::stream::{SignalReceiver, SignalSender};
//! use kerf::codec::sdct::{SdctConfig, Selection};
//! use kerf::hal::{FrameLink, LinkBusy};
//!
//! /// A loopback: what is sent is received.
//! #[derive(Default)]
//! struct Loopback(Vec<Vec<u8>>);
//! impl FrameLink for Loopback {
//!     fn send(&mut self, frame: &[u8]) -> Result<(), LinkBusy> {
//!         self.0.push(frame.to_vec());
//!         Ok(())
//!     }
//!     fn receive(&mut self, buf: &mut [u8]) -> Option<usize> {
//!         let frame = (!self.0.is_empty()).then(|| self.0.remove(0))?;
//!         buf.get_mut(..frame.len())?.copy_from_slice(&frame);
//!         Some(frame.len())
//!     }
//! }
//!
//! let config = SdctConfig { m: 32, selection: Selection::Largest };
//! let mut sender = SignalSender::<32>::new(&config).unwrap();
//! let mut receiver = SignalReceiver::<32>::new().unwrap();
//! let mut link = Loopback::default();
//! for k in 0..64 {
//!     sender.push((k as f32 * 0.1).sin(), &mut link).unwrap();
//! }
//! let mut block = [0.0f32; 32];
//! let first = receiver.poll(&mut link, &mut block).unwrap().unwrap();
//! assert_eq!((first.sequence, first.first_sample, first.gap), (0, 0, 0));
//! // All 32 coefficients kept: the block comes back to the packet's Q15 precision.
//! assert!(block.iter().enumerate().all(|(k, y)| (y - (k as f32 * 0.1).sin()).abs() < 1e-3));
//! let second = receiver.poll(&mut link, &mut block).unwrap().unwrap();
//! assert_eq!((second.sequence, second.first_sample), (1, 32));
//! ```

use crate::codec::link::crc32;
use crate::codec::packet::{self, PacketDecoder, PacketError, MAX_PACKET_LEN};
use crate::codec::sdct::{Block, EncodeError, SdctConfig, SdctDecoder, SdctEncoder};
use crate::error::ConfigError;
use crate::hal::{FrameLink, LinkBusy};

/// Most channels a frame carries.
pub const MAX_CHANNELS: usize = 4;
/// Most bytes of the caller's header ahead of a frame's packets.
pub const MAX_FRAME_HEADER: usize = 8;
/// Bytes of the frame's trailing CRC-32.
pub const FRAME_CRC_LEN: usize = 4;
/// The longest frame: the header, [`MAX_CHANNELS`] packets of the largest size and
/// the CRC.
pub const MAX_FRAME_LEN: usize = MAX_FRAME_HEADER + MAX_CHANNELS * MAX_PACKET_LEN + FRAME_CRC_LEN;

/// Why a block was not sent, or a frame not accepted.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StreamError {
    /// A sample of the block was NaN or infinite: the block is dropped.
    Encode(EncodeError),
    /// A packet could not be built, or a received one was rejected.
    Packet(PacketError),
    /// The link was busy: the block is dropped.
    Busy(LinkBusy),
    /// A received frame's packets disagree (channel count, sequence number or
    /// timestamp), or it is shorter than its header and CRC.
    Frame,
    /// A received frame's CRC-32 does not match its bytes (header included).
    Crc,
}

impl From<PacketError> for StreamError {
    fn from(error: PacketError) -> Self {
        Self::Packet(error)
    }
}

/// The sending end of `C` signals sampled together: collects samples, and per block
/// of N sends one frame — the caller's header, then one packet per channel with the
/// same sequence number and first-sample index.
#[derive(Clone, Debug)]
pub struct StreamSender<const C: usize, const N: usize> {
    encoder: SdctEncoder<N>,
    block: [[f32; N]; C],
    filled: usize,
    sequence: u16,
    /// Index of the next block's first sample (64 bits: never wraps; the packet
    /// carries its low 32 bits).
    first_sample: u64,
    dropped: u32,
}

/// The sending end of one signal.
pub type SignalSender<const N: usize> = StreamSender<1, N>;

impl<const C: usize, const N: usize> StreamSender<C, N> {
    /// A sender keeping `config.m` of every N coefficients of each channel; 1 to
    /// [`MAX_CHANNELS`] channels.
    pub fn new(config: &SdctConfig) -> Result<Self, ConfigError> {
        if !(1..=MAX_CHANNELS).contains(&C) {
            return Err(ConfigError::out_of_range("channels"));
        }
        Ok(Self {
            encoder: SdctEncoder::new(config)?,
            block: [[0.0; N]; C],
            filled: 0,
            sequence: 0,
            first_sample: 0,
            dropped: 0,
        })
    }

    /// Adds one sample of every channel; the N-th of a block sends the block behind
    /// `header` (at most [`MAX_FRAME_HEADER`] bytes). A block that cannot be sent is
    /// dropped and counted, and its sequence number is used up, so the receiver sees
    /// the gap.
    pub fn push_frame(
        &mut self,
        samples: [f32; C],
        header: &[u8],
        link: &mut impl FrameLink,
    ) -> Result<(), StreamError> {
        for (channel, sample) in self.block.iter_mut().zip(samples) {
            if let Some(slot) = channel.get_mut(self.filled) {
                *slot = sample;
            }
        }
        self.filled += 1;
        if self.filled < N {
            return Ok(());
        }
        self.filled = 0;
        let (sequence, first_sample) = (self.sequence, self.first_sample);
        self.sequence = self.sequence.wrapping_add(1);
        self.first_sample = self.first_sample.wrapping_add(N as u64);
        let sent = self.send(sequence, first_sample, header, link);
        if sent.is_err() {
            self.dropped = self.dropped.saturating_add(1);
        }
        sent
    }

    fn send(
        &self,
        sequence: u16,
        first_sample: u64,
        header: &[u8],
        link: &mut impl FrameLink,
    ) -> Result<(), StreamError> {
        let mut frame = [0u8; MAX_FRAME_LEN];
        let mut len = header.len();
        frame
            .get_mut(..len)
            .filter(|_| len <= MAX_FRAME_HEADER)
            .ok_or(StreamError::Packet(PacketError::BufferTooSmall))?
            .copy_from_slice(header);
        for channel in &self.block {
            let block = self.encoder.encode(channel).map_err(StreamError::Encode)?;
            let out = frame.get_mut(len..).unwrap_or(&mut []);
            // The low 32 bits on the wire; the receiver unwraps them.
            len += packet::encode(&block, sequence, first_sample as u32, out)?;
        }
        let crc = crc32(frame.get(..len).unwrap_or(&[]));
        frame
            .get_mut(len..len + FRAME_CRC_LEN)
            .ok_or(StreamError::Packet(PacketError::BufferTooSmall))?
            .copy_from_slice(&crc.to_le_bytes());
        let frame = frame.get(..len + FRAME_CRC_LEN).unwrap_or(&[]);
        link.send(frame).map_err(StreamError::Busy)
    }

    /// A sender whose next block starts at sample `first_sample` (a sender that
    /// resumes a stream; also how the tests fast-forward across the 32-bit wrap).
    pub fn starting_at(config: &SdctConfig, first_sample: u64) -> Result<Self, ConfigError> {
        let mut sender = Self::new(config)?;
        sender.first_sample = first_sample;
        Ok(sender)
    }

    /// Blocks dropped so far.
    pub fn dropped(&self) -> u32 {
        self.dropped
    }
}

impl<const N: usize> StreamSender<1, N> {
    /// Adds one sample of the one signal (no header); see [`StreamSender::push_frame`].
    pub fn push(&mut self, sample: f32, link: &mut impl FrameLink) -> Result<(), StreamError> {
        self.push_frame([sample], &[], link)
    }
}

/// One block accepted by the receiver.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct ReceivedBlock {
    /// The packet's sequence number.
    pub sequence: u16,
    /// Index of the block's first sample at the sender, unwrapped: the packet carries
    /// it modulo 2^32 (5 days at 10 kHz), the receiver extends it to 64 bits against
    /// the previous block (restarting from the packet's value on a resynchronisation).
    pub first_sample: u64,
    /// Blocks skipped since the previous accepted one (lost, dropped, or late).
    pub gap: u16,
    /// The block starts a new sequence: the sender restarted (its sample index too).
    pub resynchronised: bool,
}

/// The receiving end of `C` signals: validates frames and their order, reconstructs
/// the blocks.
#[derive(Clone, Debug)]
pub struct StreamReceiver<const C: usize, const N: usize> {
    decoder: SdctDecoder<N>,
    packets: PacketDecoder,
    /// First sample of the last accepted block, 64 bits.
    last_first_sample: Option<u64>,
}

/// The receiving end of one signal.
pub type SignalReceiver<const N: usize> = StreamReceiver<1, N>;

impl<const C: usize, const N: usize> StreamReceiver<C, N> {
    /// A receiver for blocks of N (8, 16, 32 or 64) of 1 to [`MAX_CHANNELS`] channels.
    pub fn new() -> Result<Self, ConfigError> {
        if !(1..=MAX_CHANNELS).contains(&C) {
            return Err(ConfigError::out_of_range("channels"));
        }
        Ok(Self {
            decoder: SdctDecoder::new()?,
            packets: PacketDecoder::new(),
            last_first_sample: None,
        })
    }

    /// The next frame on `link`, if any: its header copied into `header` (whose length
    /// is the header's), every channel's block reconstructed into `out`; or why the
    /// frame was rejected (`header` and `out` untouched, the sequence state
    /// unchanged). The frame's CRC is checked first, then every packet, before any
    /// is accepted.
    pub fn poll_frame(
        &mut self,
        link: &mut impl FrameLink,
        header: &mut [u8],
        out: &mut [[f32; N]; C],
    ) -> Option<Result<ReceivedBlock, StreamError>> {
        let mut frame = [0u8; MAX_FRAME_LEN];
        let len = link.receive(&mut frame)?;
        let bytes = frame.get(..len)?;
        Some(self.accept_frame(bytes, header, out))
    }

    /// A frame the caller has received itself (to look at its header before the
    /// stream takes it), checked and reconstructed as [`StreamReceiver::poll_frame`]
    /// does.
    pub fn accept(
        &mut self,
        bytes: &[u8],
        header: &mut [u8],
        out: &mut [[f32; N]; C],
    ) -> Result<ReceivedBlock, StreamError> {
        self.accept_frame(bytes, header, out)
    }

    fn accept_frame(
        &mut self,
        bytes: &[u8],
        header: &mut [u8],
        out: &mut [[f32; N]; C],
    ) -> Result<ReceivedBlock, StreamError> {
        let (checked, crc) = bytes
            .split_last_chunk::<FRAME_CRC_LEN>()
            .filter(|(checked, _)| checked.len() >= header.len())
            .ok_or(StreamError::Frame)?;
        if crc32(checked) != u32::from_le_bytes(*crc) {
            return Err(StreamError::Crc);
        }
        let (head, mut rest) = checked
            .split_at_checked(header.len())
            .ok_or(StreamError::Frame)?;
        let mut blocks = [Block::<N>::from_parts(0, [0.0; N]); C];
        let mut first = None;
        for block in &mut blocks {
            let packet_bytes;
            (packet_bytes, rest) = rest
                .split_at_checked(packet::packet_len(rest)?)
                .ok_or(StreamError::Packet(PacketError::Truncated))?;
            let packet = packet::parse(packet_bytes)?;
            *block = packet.to_block::<N>()?;
            match &first {
                None => first = Some(packet),
                Some(p) if (p.sequence, p.timestamp) == (packet.sequence, packet.timestamp) => {}
                Some(_) => return Err(StreamError::Frame),
            }
        }
        if !rest.is_empty() {
            return Err(StreamError::Frame);
        }
        let received = self.packets.accept(first.ok_or(StreamError::Frame)?)?;
        header.copy_from_slice(head);
        for (block, out) in blocks.iter().zip(out.iter_mut()) {
            self.decoder.decode(block, out);
        }
        let wire = received.packet.timestamp;
        // Forward from the last block by the wrapping difference of the low 32 bits
        // (accepted blocks only move forward, by less than 2^31 samples).
        let first_sample = match (self.last_first_sample, received.resynchronised) {
            (Some(last), false) => last.wrapping_add(u64::from(wire.wrapping_sub(last as u32))),
            _ => u64::from(wire),
        };
        self.last_first_sample = Some(first_sample);
        Ok(ReceivedBlock {
            sequence: received.packet.sequence,
            first_sample,
            gap: received.gap,
            resynchronised: received.resynchronised,
        })
    }
}

impl<const N: usize> StreamReceiver<1, N> {
    /// The next frame of the one signal (no header) on `link`; see
    /// [`StreamReceiver::poll_frame`].
    pub fn poll(
        &mut self,
        link: &mut impl FrameLink,
        out: &mut [f32; N],
    ) -> Option<Result<ReceivedBlock, StreamError>> {
        let mut blocks = [*out];
        let result = self.poll_frame(link, &mut [], &mut blocks)?;
        if result.is_ok() {
            let [block] = blocks;
            *out = block;
        }
        Some(result)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::codec::sdct::Selection;
    use std::vec::Vec;

    /// A link that hands every frame straight over (the frames in flight are open to
    /// tests that cut or corrupt one).
    #[derive(Default)]
    pub(crate) struct Loopback(pub(crate) Vec<Vec<u8>>);

    impl FrameLink for Loopback {
        fn send(&mut self, frame: &[u8]) -> Result<(), LinkBusy> {
            self.0.push(frame.to_vec());
            Ok(())
        }
        fn receive(&mut self, buf: &mut [u8]) -> Option<usize> {
            let frame = (!self.0.is_empty()).then(|| self.0.remove(0))?;
            buf.get_mut(..frame.len())?.copy_from_slice(&frame);
            Some(frame.len())
        }
    }

    /// A stream fast-forwarded to just before the 32-bit sample index wraps (5 days at
    /// 10 kHz): the receiver's 64-bit index keeps counting through the wrap.
    #[test]
    fn sample_indices_survive_the_32_bit_wrap() {
        let config = SdctConfig {
            m: 8,
            selection: Selection::Largest,
        };
        let start = (1u64 << 32) - 3 * 32;
        let mut sender = SignalSender::<32>::starting_at(&config, start).unwrap();
        let mut receiver = SignalReceiver::<32>::new().unwrap();
        let mut link = Loopback::default();
        let mut out = [0.0f32; 32];
        let mut seen = Vec::new();
        for k in 0..(8 * 32) {
            sender.push(k as f32, &mut link).unwrap();
            while let Some(block) = receiver.poll(&mut link, &mut out) {
                seen.push(block.unwrap().first_sample);
            }
        }
        let expected: Vec<u64> = (0..8).map(|b| start + 32 * b).collect();
        assert_eq!(seen, expected);
        assert!(seen[3] > u64::from(u32::MAX));
    }

    /// Three channels in one frame behind a 4-byte header: each comes back to its own
    /// signal within the Q15 step, the header unchanged; a frame whose packets were
    /// cut, or spliced from two blocks, is rejected without moving the sequence state
    /// (by its CRC, and by the packets' checks when the CRC was sealed over the damage).
    #[test]
    fn three_channels_share_a_frame_and_a_sequence() {
        let config = SdctConfig {
            m: 16,
            selection: Selection::Largest,
        };
        let signal =
            |c: usize, k: usize| ((k as f32) * 0.05 * (c + 1) as f32).sin() * (c + 1) as f32;
        let mut sender = StreamSender::<3, 16>::new(&config).unwrap();
        let mut receiver = StreamReceiver::<3, 16>::new().unwrap();
        let mut link = Loopback::default();
        for k in 0..48 {
            let header = (k as u32 / 16).to_le_bytes();
            sender
                .push_frame([0, 1, 2].map(|c| signal(c, k)), &header, &mut link)
                .unwrap();
        }
        assert_eq!(link.0.len(), 3);
        // Splice: the first frame's header and packets 0–1 with the second frame's
        // packet 2 (its CRC as sent, then sealed again as a faulty sender would); the
        // first frame cut short by one byte, and its last packet cut with the CRC
        // sealed again.
        let seal = |mut body: Vec<u8>| {
            let crc = crc32(&body);
            body.extend_from_slice(&crc.to_le_bytes());
            body
        };
        let lens: Vec<usize> = {
            let f = &link.0[0];
            let a = packet::packet_len(&f[4..]).unwrap();
            let b = packet::packet_len(&f[4 + a..]).unwrap();
            std::vec![4 + a + b, f.len() - FRAME_CRC_LEN]
        };
        let mut spliced = link.0[0][..lens[0]].to_vec();
        spliced.extend_from_slice(&link.0[1][lens[0]..]);
        let resealed = seal(spliced[..spliced.len() - FRAME_CRC_LEN].to_vec());
        let mut cut = link.0[0].clone();
        cut.pop();
        let cut_packet = seal(link.0[0][..lens[1] - 1].to_vec());
        let mut bad = Loopback(std::vec![spliced, resealed, cut, cut_packet]);
        let mut header = [0u8; 4];
        let mut out = [[0.0f32; 16]; 3];
        for expected in [
            StreamError::Crc,
            StreamError::Frame,
            StreamError::Crc,
            StreamError::Packet(PacketError::Truncated),
        ] {
            assert_eq!(
                receiver.poll_frame(&mut bad, &mut header, &mut out),
                Some(Err(expected))
            );
        }
        assert_eq!(out, [[0.0; 16]; 3]);
        for b in 0..3u32 {
            let block = receiver
                .poll_frame(&mut link, &mut header, &mut out)
                .unwrap()
                .unwrap();
            assert_eq!(
                (block.sequence, block.first_sample, block.gap),
                (b as u16, 16 * u64::from(b), 0)
            );
            assert_eq!(header, b.to_le_bytes());
            for (c, channel) in out.iter().enumerate() {
                for (k, y) in channel.iter().enumerate() {
                    // All 16 coefficients kept: Q15 rounding of coefficients up to
                    // √16·3 = 12 gives steps of 2^(4−15); 16 of them add < 1e-3.
                    assert!((y - signal(c, 16 * b as usize + k)).abs() < 1e-3, "{c} {k}");
                }
            }
        }
    }

    /// Every bit of a frame flipped in turn, its caller's header included: each is
    /// refused with the header, the blocks and the sequence state untouched, and the
    /// intact frame is then accepted as the first block.
    #[test]
    fn a_frame_with_any_bit_flipped_is_refused() {
        let config = SdctConfig {
            m: 4,
            selection: Selection::Largest,
        };
        let mut sender = StreamSender::<2, 8>::new(&config).unwrap();
        let mut receiver = StreamReceiver::<2, 8>::new().unwrap();
        let mut link = Loopback::default();
        for k in 0..8 {
            let samples = [k as f32 * 0.25, 1.0 - k as f32 * 0.5];
            sender
                .push_frame(samples, &[0xA5, 0x00, 0xFF, 0x3C, 0x01], &mut link)
                .unwrap();
        }
        let frame = link.0.remove(0);
        for bit in 0..8 * frame.len() {
            let mut flipped = frame.clone();
            flipped[bit / 8] ^= 1 << (bit % 8);
            let (mut header, mut out) = ([0u8; 5], [[0.0f32; 8]; 2]);
            let result =
                receiver.poll_frame(&mut Loopback(std::vec![flipped]), &mut header, &mut out);
            assert!(matches!(result, Some(Err(_))), "bit {bit}: {result:?}");
            assert_eq!((header, out), ([0; 5], [[0.0; 8]; 2]), "bit {bit}");
        }
        let (mut header, mut out) = ([0u8; 5], [[0.0f32; 8]; 2]);
        let block = receiver
            .poll_frame(&mut Loopback(std::vec![frame]), &mut header, &mut out)
            .unwrap()
            .unwrap();
        assert_eq!(
            (block.sequence, block.gap, block.resynchronised),
            (0, 0, false)
        );
        assert_eq!(header, [0xA5, 0x00, 0xFF, 0x3C, 0x01]);
    }
}
