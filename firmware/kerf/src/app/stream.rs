//! A machine's signal sent over a [`FrameLink`] (SPEC `codec::sdct`, T 7.2.3): blocks
//! of N samples, SDCT-coded, each in one packet with its sequence number and the
//! index of its first sample; the receiver validates the order and reconstructs.
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

use crate::codec::packet::{self, PacketDecoder, PacketError, MAX_PACKET_LEN};
use crate::codec::sdct::{EncodeError, SdctConfig, SdctDecoder, SdctEncoder};
use crate::error::ConfigError;
use crate::hal::{FrameLink, LinkBusy};

/// Why a block was not sent.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StreamError {
    /// A sample of the block was NaN or infinite: the block is dropped.
    Encode(EncodeError),
    /// The packet could not be built.
    Packet(PacketError),
    /// The link was busy: the block is dropped.
    Busy(LinkBusy),
}

/// The sending end: collects samples, sends a packet per block of N.
#[derive(Clone, Debug)]
pub struct SignalSender<const N: usize> {
    encoder: SdctEncoder<N>,
    block: [f32; N],
    filled: usize,
    sequence: u16,
    /// Index of the next block's first sample (64 bits: never wraps; the packet
    /// carries its low 32 bits).
    first_sample: u64,
    dropped: u32,
}

impl<const N: usize> SignalSender<N> {
    /// A sender keeping `config.m` of every N coefficients.
    pub fn new(config: &SdctConfig) -> Result<Self, ConfigError> {
        Ok(Self {
            encoder: SdctEncoder::new(config)?,
            block: [0.0; N],
            filled: 0,
            sequence: 0,
            first_sample: 0,
            dropped: 0,
        })
    }

    /// Adds one sample; the N-th of a block sends the block. A block that cannot be
    /// sent is dropped and counted, and its sequence number is used up, so the
    /// receiver sees the gap.
    pub fn push(&mut self, sample: f32, link: &mut impl FrameLink) -> Result<(), StreamError> {
        if let Some(slot) = self.block.get_mut(self.filled) {
            *slot = sample;
        }
        self.filled += 1;
        if self.filled < N {
            return Ok(());
        }
        self.filled = 0;
        let (sequence, first_sample) = (self.sequence, self.first_sample);
        self.sequence = self.sequence.wrapping_add(1);
        self.first_sample = self.first_sample.wrapping_add(N as u64);
        let sent = self.send(sequence, first_sample, link);
        if sent.is_err() {
            self.dropped = self.dropped.saturating_add(1);
        }
        sent
    }

    fn send(
        &self,
        sequence: u16,
        first_sample: u64,
        link: &mut impl FrameLink,
    ) -> Result<(), StreamError> {
        let block = self
            .encoder
            .encode(&self.block)
            .map_err(StreamError::Encode)?;
        let mut frame = [0u8; MAX_PACKET_LEN];
        // The low 32 bits on the wire; the receiver unwraps them.
        let len = packet::encode(&block, sequence, first_sample as u32, &mut frame)
            .map_err(StreamError::Packet)?;
        let frame = frame
            .get(..len)
            .ok_or(StreamError::Packet(PacketError::Truncated))?;
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

/// The receiving end: validates packets and their order, reconstructs blocks.
#[derive(Clone, Debug)]
pub struct SignalReceiver<const N: usize> {
    decoder: SdctDecoder<N>,
    packets: PacketDecoder,
    /// First sample of the last accepted block, 64 bits.
    last_first_sample: Option<u64>,
}

impl<const N: usize> SignalReceiver<N> {
    /// A receiver for blocks of N (8, 16, 32 or 64).
    pub fn new() -> Result<Self, ConfigError> {
        Ok(Self {
            decoder: SdctDecoder::new()?,
            packets: PacketDecoder::new(),
            last_first_sample: None,
        })
    }

    /// The next frame on `link`, if any: its block reconstructed into `out`, or why
    /// the frame was rejected (`out` untouched).
    pub fn poll(
        &mut self,
        link: &mut impl FrameLink,
        out: &mut [f32; N],
    ) -> Option<Result<ReceivedBlock, PacketError>> {
        let mut frame = [0u8; MAX_PACKET_LEN];
        let len = link.receive(&mut frame)?;
        let bytes = frame.get(..len)?;
        Some(self.packets.decode(bytes).and_then(|received| {
            let block = received.packet.to_block::<N>()?;
            self.decoder.decode(&block, out);
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
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::sdct::Selection;
    use std::vec::Vec;

    /// A link that hands every frame straight over.
    #[derive(Default)]
    struct Loopback(Vec<Vec<u8>>);

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
}
