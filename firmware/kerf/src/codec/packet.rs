//! Framed SDCT packets for the master/slave link (docs/codec.md §30, T 7.2.3).
//!
//! Wire format, version 1 (all multi-byte fields little-endian):
//!
//! | offset | bytes | field |
//! |---|---|---|
//! | 0 | 1 | version (= [`VERSION`]) |
//! | 1 | 1 | N, block length (8, 16, 32 or 64) |
//! | 2 | 1 | m, number of coefficients sent (0..=N) |
//! | 3 | 1 | index form: 0 = prefix, 1 = bit mask, 2 = packed list ([`IndexForm`]) |
//! | 4 | 1 | e, block-floating-point exponent (i8, [`MIN_EXPONENT`]..=[`MAX_EXPONENT`]) |
//! | 5 | 2 | sequence number (u16, wraps) |
//! | 7 | 4 | timestamp of the block's first sample, in sample periods (u32, wraps) |
//! | 11 | I | index set (I = 0, N/8 or ⌈m·log2 N / 8⌉ bytes, see [`IndexForm`]) |
//! | 11 + I | 2m | coefficients, Q15 mantissas (i16), in index-set order |
//! | 11 + I + 2m | 2 | CRC-16/IBM-3740 (CCITT-FALSE) of every byte before it |
//!
//! A coefficient is q · 2^(e − 15): block floating point with one exponent per packet,
//! chosen so that the largest kept |c| uses the full Q15 range. Orthonormal coefficients
//! of full-scale samples reach √N · full scale, so a fixed Q15 scale would clip them.
//!
//! The encoder picks the smallest index form: the prefix form (nothing sent, indices
//! 0..m) when the index set is the conventional DCT codec's, else whichever of the
//! N-bit mask and the list of m indices of log2 N bits each is shorter (mask on a tie).
//! A packed index of log2 N bits cannot name an index ≥ N and a mask has exactly N bits,
//! so out-of-range indices are unrepresentable on the wire; the encoder still rejects
//! an index set with bits at or above N.
//!
//! Legal ranges: e in −64..=64, so every coefficient is below 2^64 in magnitude and
//! every decoded sample below [`MAX_SAMPLE_ABS`] (2^68); a packed index list in
//! strictly ascending order (the values follow in that order). The encoder refuses a
//! block whose largest coefficient is 2^64 or more instead of clamping its exponent.
//!
//! The decoder checks, in this order: minimum length, version, N, m ≤ N, index form,
//! exponent range, exact length, CRC, index set (order, duplicates, count, zero
//! padding), and last the sequence number against the previous accepted packet.
//!
//! # Example
//!
//! A block of N = 8 keeping coefficients 0, 2 and 5 goes over the link and back; one
//! flipped bit is rejected by the CRC.
//!
//! ```
//! use kerf::codec::packet::{encode, PacketDecoder, PacketError, MAX_PACKET_LEN};
//! use kerf::codec::sdct::Block;
//!
//! let coefficients = [1.5, 0.0, -0.25, 0.0, 0.0, 0.125, 0.0, 0.0];
//! let block = Block::<8>::from_parts(0b10_0101, coefficients);
//! let mut buf = [0u8; MAX_PACKET_LEN];
//! let len = encode(&block, 7, 1_000, &mut buf).unwrap();
//!
//! let mut decoder = PacketDecoder::new();
//! let received = decoder.decode(&buf[..len]).unwrap();
//! assert_eq!(received.gap, 0);
//! assert_eq!((received.packet.sequence, received.packet.timestamp), (7, 1_000));
//! // These coefficients are multiples of the Q15 step 2^(e − 15) (e = 1 for the
//! // largest, 1.5), so the round trip is exact; in general each coefficient is within
//! // half a step.
//! assert_eq!(received.packet.to_block::<8>().unwrap(), block);
//!
//! // One flipped bit in the last coefficient: the CRC no longer matches, and the
//! // decoder's sequence state is unchanged.
//! let mut corrupted = buf;
//! corrupted[len - 3] ^= 0x01;
//! assert_eq!(decoder.decode(&corrupted[..len]), Err(PacketError::BadCrc));
//! assert_eq!(decoder.last_sequence(), Some(7));
//! ```

use crc::{Crc, CRC_16_IBM_3740};

use super::sdct::Block;
use super::{is_supported_n, prefix_mask, MAX_N};

/// The wire-format version this module writes and reads.
pub const VERSION: u8 = 1;
/// Bytes before the index set.
pub const HEADER_LEN: usize = 11;
/// Bytes of the trailing CRC.
pub const CRC_LEN: usize = 2;
/// Smallest block exponent a packet may carry.
pub const MIN_EXPONENT: i8 = -64;
/// Largest block exponent a packet may carry: every coefficient is below 2^64.
pub const MAX_EXPONENT: i8 = 64;
/// Bound on a decoded sample: an orthonormal inverse DCT of N coefficients below
/// 2^MAX_EXPONENT gives |x| ≤ √(2N) · 2^64 < 16 · 2^64 = 2^68 for N ≤ 64.
pub const MAX_SAMPLE_ABS: f32 = (1u128 << 68) as f32;
/// Largest packet: N = 64, m = 64 sent with a bit mask.
pub const MAX_PACKET_LEN: usize = HEADER_LEN + MAX_N / 8 + 2 * MAX_N + CRC_LEN;

/// CRC-16/IBM-3740: the 16-bit CCITT polynomial 0x1021, detects every burst of up to
/// 16 bits and all 1- to 3-bit errors in packets of this size.
const CRC16: Crc<u16> = Crc::<u16>::new(&CRC_16_IBM_3740);

/// How the index set of the kept coefficients is written.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum IndexForm {
    /// Indices 0..m (conventional DCT codec); nothing is sent.
    Prefix = 0,
    /// N-bit mask, bit k set when coefficient k is sent; N/8 bytes.
    Bitmask = 1,
    /// m indices of log2 N bits each, LSB first, zero-padded to whole bytes.
    List = 2,
}

impl IndexForm {
    fn from_byte(byte: u8) -> Option<Self> {
        match byte {
            0 => Some(Self::Prefix),
            1 => Some(Self::Bitmask),
            2 => Some(Self::List),
            _ => None,
        }
    }

    /// Bytes this form takes for `m` of `n` indices.
    pub const fn len(self, n: usize, m: usize) -> usize {
        match self {
            Self::Prefix => 0,
            Self::Bitmask => n / 8,
            Self::List => (m * index_bits(n) as usize).div_ceil(8),
        }
    }
}

/// Bits per packed index: log2 N.
const fn index_bits(n: usize) -> u32 {
    n.trailing_zeros()
}

/// Why a packet could not be written or was rejected.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PacketError {
    /// Fewer bytes than the header announces (or than a header).
    Truncated,
    /// More bytes than the header announces.
    LengthMismatch,
    /// The CRC does not match the bytes.
    BadCrc,
    /// The version byte is not [`VERSION`].
    UnknownVersion(u8),
    /// N is not one of [`SUPPORTED_N`](super::SUPPORTED_N), or not the N the caller expects.
    UnsupportedN(u8),
    /// m > N.
    TooManyCoefficients,
    /// The index-form byte is not an [`IndexForm`].
    UnknownIndexForm(u8),
    /// An index ≥ N (encoder side; unrepresentable on the wire, see the module docs).
    IndexOutOfRange(u8),
    /// The packed list names this index twice.
    DuplicateIndex(u8),
    /// The bit mask has a different number of bits set than m.
    IndexCountMismatch,
    /// Padding bits after the packed list are not zero.
    BadPadding,
    /// The sequence number is not after the last accepted one (a reordered or repeated
    /// packet); serial-number arithmetic, so wrapping from 65535 to 0 is forward.
    SequenceBackwards {
        /// Sequence number of the last accepted packet.
        last: u16,
        /// Sequence number of the rejected packet.
        got: u16,
    },
    /// The caller's buffer cannot hold the packet.
    BufferTooSmall,
    /// A coefficient to send is NaN or infinite.
    NotFinite,
    /// The block exponent is outside [`MIN_EXPONENT`]..=[`MAX_EXPONENT`] (on the wire),
    /// or a coefficient to send is 2^`MAX_EXPONENT` or larger (encoder side).
    ExponentOutOfRange(i8),
    /// The packed list names an index at or below the one before it (the values
    /// follow in ascending index order).
    UnsortedIndex(u8),
}

/// A validated packet: header fields and the coefficient mantissas at their indices.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Packet {
    /// Block length N.
    pub n: u8,
    /// Number of coefficients sent.
    pub m: u8,
    /// Block-floating-point exponent: coefficient = q · 2^(exponent − 15).
    pub exponent: i8,
    /// Sequence number.
    pub sequence: u16,
    /// Timestamp of the block's first sample, in sample periods.
    pub timestamp: u32,
    /// Index set: bit k set when coefficient k was sent.
    pub mask: u64,
    /// Q15 mantissas at their indices, zero where nothing was sent (entries ≥ N unused).
    pub mantissas: [i16; MAX_N],
}

impl Packet {
    /// Coefficient `k` in the units of the encoded samples (0.0 when not sent or k ≥ N).
    pub fn coefficient(&self, k: usize) -> f32 {
        let q = self.mantissas.get(k).copied().unwrap_or(0);
        libm::ldexpf(f32::from(q), i32::from(self.exponent) - 15)
    }

    /// The zero-filled coefficient block for an N-sample decoder; `UnsupportedN` when
    /// the packet was made for another block length.
    pub fn to_block<const N: usize>(&self) -> Result<Block<N>, PacketError> {
        if usize::from(self.n) != N {
            return Err(PacketError::UnsupportedN(self.n));
        }
        let mut coeffs = [0.0f32; N];
        for (k, c) in coeffs.iter_mut().enumerate() {
            *c = self.coefficient(k);
        }
        Ok(Block::from_parts(self.mask, coeffs))
    }
}

/// Writes `block` as one packet into `buf` and returns the number of bytes written.
///
/// The kept coefficients are quantized to Q15 mantissas with one exponent e such that
/// the largest |c| < 2^e; the error per coefficient is at most 2^(e − 16) (half a
/// mantissa step; a full step when rounding reaches +32768 and saturates).
pub fn encode<const N: usize>(
    block: &Block<N>,
    sequence: u16,
    timestamp: u32,
    buf: &mut [u8],
) -> Result<usize, PacketError> {
    encode_parts(block.mask(), block.coefficients(), sequence, timestamp, buf)
}

/// [`encode`] from an index mask and the N coefficients in natural order (entries
/// outside the mask are ignored). N = `coeffs.len()`.
pub fn encode_parts(
    mask: u64,
    coeffs: &[f32],
    sequence: u16,
    timestamp: u32,
    buf: &mut [u8],
) -> Result<usize, PacketError> {
    let n = coeffs.len();
    let n_byte = u8::try_from(n).unwrap_or(u8::MAX);
    if !is_supported_n(n) {
        return Err(PacketError::UnsupportedN(n_byte));
    }
    if mask & !prefix_mask(n) != 0 {
        // The highest set bit (mask ≠ 0 here), without a subtraction to check.
        return Err(PacketError::IndexOutOfRange(
            mask.checked_ilog2().unwrap_or(0) as u8,
        ));
    }
    // A bounded index range rather than `enumerate` (no counter overflow check).
    let kept = || {
        (0..n)
            .zip(coeffs.iter())
            .filter(move |&(k, _)| has_bit(mask, k))
    };
    let mut max_abs = 0.0f32;
    for (_, c) in kept() {
        if !c.is_finite() {
            return Err(PacketError::NotFinite);
        }
        max_abs = max_abs.max(c.abs());
    }
    let m = mask.count_ones() as usize;
    let form = choose_form(n, m, mask);
    let index_len = form.len(n, m);
    let total = HEADER_LEN + index_len + 2 * m + CRC_LEN;
    let out = buf.get_mut(..total).ok_or(PacketError::BufferTooSmall)?;

    // frexp: max_abs = f · 2^p with f in [0.5, 1), so max_abs < 2^p and the largest
    // mantissa lands in [16384, 32768). Zero blocks use e = 0.
    // Exponents below the range are raised to it (the block is then quantized in
    // steps of 2^(MIN_EXPONENT − 15), 8e-25: below any physical signal's resolution);
    // above it the block cannot be sent.
    let exponent = if max_abs > 0.0 {
        libm::frexpf(max_abs).1.max(i32::from(MIN_EXPONENT))
    } else {
        0
    };
    if exponent > i32::from(MAX_EXPONENT) {
        return Err(PacketError::ExponentOutOfRange(
            i8::try_from(exponent).unwrap_or(i8::MAX),
        ));
    }
    let (body, crc_bytes) = out.split_at_mut(total - CRC_LEN);
    let (header, rest) = body.split_at_mut(HEADER_LEN);
    header.copy_from_slice(&header_bytes(
        n_byte,
        m as u8,
        form,
        exponent as i8,
        sequence,
        timestamp,
    ));
    let (index_bytes, values) = rest.split_at_mut(index_len);
    write_index_set(form, n, mask, index_bytes);
    for ((_, &c), dst) in kept().zip(values.chunks_exact_mut(2)) {
        // exponent ∈ [MIN_EXPONENT, MAX_EXPONENT] (above): never saturates.
        let q = libm::roundf(libm::ldexpf(c, 15i32.saturating_sub(exponent)))
            .clamp(-32768.0, 32767.0) as i16;
        dst.copy_from_slice(&q.to_le_bytes());
    }
    crc_bytes.copy_from_slice(&CRC16.checksum(body).to_le_bytes());
    Ok(total)
}

fn header_bytes(
    n: u8,
    m: u8,
    form: IndexForm,
    exponent: i8,
    sequence: u16,
    timestamp: u32,
) -> [u8; HEADER_LEN] {
    let s = sequence.to_le_bytes();
    let t = timestamp.to_le_bytes();
    [
        VERSION,
        n,
        m,
        form as u8,
        exponent.to_le_bytes()[0],
        s[0],
        s[1],
        t[0],
        t[1],
        t[2],
        t[3],
    ]
}

/// The shortest form for this index set (see the module docs).
fn choose_form(n: usize, m: usize, mask: u64) -> IndexForm {
    if mask == prefix_mask(m) {
        IndexForm::Prefix
    } else if IndexForm::List.len(n, m) < IndexForm::Bitmask.len(n, m) {
        IndexForm::List
    } else {
        IndexForm::Bitmask
    }
}

fn write_index_set(form: IndexForm, n: usize, mask: u64, out: &mut [u8]) {
    match form {
        IndexForm::Prefix => {}
        IndexForm::Bitmask => out
            .iter_mut()
            .zip(mask.to_le_bytes())
            .for_each(|(dst, b)| *dst = b),
        IndexForm::List => {
            let width = index_bits(n);
            let mut bytes = out.iter_mut();
            let (mut acc, mut filled) = (0u32, 0u32);
            for k in (0..n).filter(|&k| has_bit(mask, k)) {
                acc |= (k as u32) << filled;
                filled += width;
                while filled >= 8 {
                    if let Some(dst) = bytes.next() {
                        *dst = acc as u8;
                    }
                    acc >>= 8;
                    filled -= 8;
                }
            }
            if let (true, Some(dst)) = (filled > 0, bytes.next()) {
                *dst = acc as u8;
            }
        }
    }
}

/// Whether bit `k` of `mask` is set; false past bit 63 (a shift the optimiser
/// cannot bound would otherwise keep an overflow check).
fn has_bit(mask: u64, k: usize) -> bool {
    u32::try_from(k)
        .ok()
        .and_then(|k| mask.checked_shr(k))
        .is_some_and(|m| m & 1 == 1)
}

/// Reads a packed index list; returns the mask or the first bad index.
fn read_index_list(n: usize, m: usize, bytes: &[u8]) -> Result<(u64, [u8; MAX_N]), PacketError> {
    let width = index_bits(n);
    let mut order = [0u8; MAX_N];
    let mut slots = order.iter_mut().take(m);
    let mut mask = 0u64;
    let (mut acc, mut filled, mut read) = (0u32, 0u32, 0usize);
    let mut input = bytes.iter();
    while read < m {
        while filled < width {
            let Some(&b) = input.next() else {
                return Err(PacketError::Truncated);
            };
            acc |= u32::from(b) << filled;
            filled += 8;
        }
        // The low `width` bits, then the rest (width = log2 N ≤ 6; a width of 32 or
        // more, which no supported N has, would take every bit).
        let index_mask = 1u32.checked_shl(width).unwrap_or(0).wrapping_sub(1);
        let k = (acc & index_mask) as u8;
        acc = acc.checked_shr(width).unwrap_or(0);
        filled -= width;
        read += 1;
        // A `width`-bit index is always < N; the check documents the invariant.
        if usize::from(k) >= n {
            return Err(PacketError::IndexOutOfRange(k));
        }
        if has_bit(mask, usize::from(k)) {
            return Err(PacketError::DuplicateIndex(k));
        }
        // Ascending: no set bit at or above k yet (k < n ≤ 64, checked above).
        if mask.checked_shr(u32::from(k)).unwrap_or(0) != 0 {
            return Err(PacketError::UnsortedIndex(k));
        }
        mask |= 1u64.checked_shl(u32::from(k)).unwrap_or(0);
        if let Some(slot) = slots.next() {
            *slot = k;
        }
    }
    if acc != 0 || input.any(|&b| b != 0) {
        return Err(PacketError::BadPadding);
    }
    Ok((mask, order))
}

/// A packet's header fields and the lengths they imply.
struct Header {
    n: u8,
    m: u8,
    form: IndexForm,
    exponent: i8,
    index_len: usize,
    total: usize,
    sequence: u16,
    timestamp: u32,
}

/// The header's checks, in the order of the module docs (up to the exponent).
fn read_header(bytes: &[u8]) -> Result<Header, PacketError> {
    let header: &[u8; HEADER_LEN] = bytes
        .get(..HEADER_LEN)
        .and_then(|h| h.try_into().ok())
        .ok_or(PacketError::Truncated)?;
    let [version, n_byte, m_byte, form_byte, e, s0, s1, t0, t1, t2, t3] = *header;
    if version != VERSION {
        return Err(PacketError::UnknownVersion(version));
    }
    let n = usize::from(n_byte);
    if !is_supported_n(n) {
        return Err(PacketError::UnsupportedN(n_byte));
    }
    let m = usize::from(m_byte);
    if m > n {
        return Err(PacketError::TooManyCoefficients);
    }
    let form = IndexForm::from_byte(form_byte).ok_or(PacketError::UnknownIndexForm(form_byte))?;
    let exponent = i8::from_le_bytes([e]);
    if !(MIN_EXPONENT..=MAX_EXPONENT).contains(&exponent) {
        return Err(PacketError::ExponentOutOfRange(exponent));
    }
    let index_len = form.len(n, m);
    let total = HEADER_LEN + index_len + 2 * m + CRC_LEN;
    Ok(Header {
        n: n_byte,
        m: m_byte,
        form,
        exponent,
        index_len,
        total,
        sequence: u16::from_le_bytes([s0, s1]),
        timestamp: u32::from_le_bytes([t0, t1, t2, t3]),
    })
}

/// The length of the packet that `bytes` starts with, from its header alone (version,
/// N, m, index form and exponent checked; nothing else): how a frame carrying several
/// packets back to back is split.
pub fn packet_len(bytes: &[u8]) -> Result<usize, PacketError> {
    read_header(bytes).map(|h| h.total)
}

/// Validates everything except the sequence number (see [`PacketDecoder`] for that).
pub fn parse(bytes: &[u8]) -> Result<Packet, PacketError> {
    let Header {
        n: n_byte,
        m: m_byte,
        form,
        exponent,
        index_len,
        total,
        sequence,
        timestamp,
    } = read_header(bytes)?;
    let (n, m) = (usize::from(n_byte), usize::from(m_byte));
    if bytes.len() < total {
        return Err(PacketError::Truncated);
    }
    if bytes.len() > total {
        return Err(PacketError::LengthMismatch);
    }
    let (body, crc_bytes) = bytes.split_at(total - CRC_LEN);
    let crc = crc_bytes
        .iter()
        .rev()
        .fold(0u16, |acc, &b| acc << 8 | u16::from(b));
    if CRC16.checksum(body) != crc {
        return Err(PacketError::BadCrc);
    }
    let rest = body.get(HEADER_LEN..).unwrap_or(&[]);
    let (index_bytes, values) = rest
        .split_at_checked(index_len)
        .ok_or(PacketError::Truncated)?;

    // Indices in the order their values follow.
    let mut order = [0u8; MAX_N];
    let mask = match form {
        IndexForm::Prefix => {
            order.iter_mut().zip(0..=u8::MAX).for_each(|(o, k)| *o = k);
            prefix_mask(m)
        }
        IndexForm::Bitmask => {
            let mut raw = [0u8; 8];
            raw.iter_mut().zip(index_bytes).for_each(|(d, &s)| *d = s);
            let mask = u64::from_le_bytes(raw);
            if mask.count_ones() as usize != m {
                return Err(PacketError::IndexCountMismatch);
            }
            let set = (0u8..64).filter(|&k| mask >> k & 1 == 1);
            order.iter_mut().zip(set).for_each(|(o, k)| *o = k);
            mask
        }
        IndexForm::List => {
            let (mask, list) = read_index_list(n, m, index_bytes)?;
            order = list;
            mask
        }
    };
    let mut mantissas = [0i16; MAX_N];
    for (&k, v) in order.iter().zip(values.chunks_exact(2)) {
        if let (Some(dst), [lo, hi]) = (mantissas.get_mut(usize::from(k)), v) {
            *dst = i16::from_le_bytes([*lo, *hi]);
        }
    }
    Ok(Packet {
        n: n_byte,
        m: m_byte,
        exponent,
        sequence,
        timestamp,
        mask,
        mantissas,
    })
}

/// A packet accepted by [`PacketDecoder::decode`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Received {
    /// The validated packet.
    pub packet: Packet,
    /// Sequence numbers skipped since the previous accepted packet (lost or still in
    /// flight); 0 for the first packet and for consecutive ones.
    pub gap: u16,
    /// This packet starts a new sequence (see [`PacketDecoder::decode`]): the sender
    /// restarted, or the link was out for longer than half the sequence space.
    pub resynchronised: bool,
}

/// How late (in sequence numbers) a genuine packet may arrive after a later one was
/// accepted, on a link that reorders: such packets are only ever rejected.
pub const REORDER_WINDOW: u16 = 16;
/// Consecutive packets further behind than [`REORDER_WINDOW`] after which the decoder
/// takes them as a new sequence (a restarted sender, an outage longer than half the
/// sequence space, or a forged packet that jumped the state ahead).
pub const RESYNC_PACKETS: u8 = 3;
/// A restarted sender's packets are accepted again by this one at the latest:
/// REORDER_WINDOW + RESYNC_PACKETS + 1.
pub const RESTART_ACCEPTED_WITHIN: usize = REORDER_WINDOW as usize + RESYNC_PACKETS as usize + 1;

/// Receiver state: validates packets and their order on the link.
#[derive(Clone, Debug, Default)]
pub struct PacketDecoder {
    last_sequence: Option<u16>,
    /// A run of consecutive packets further behind than the reorder window: its last
    /// sequence number and length.
    candidate: Option<(u16, u8)>,
}

impl PacketDecoder {
    /// A decoder that accepts any sequence number for its first packet.
    pub const fn new() -> Self {
        Self {
            last_sequence: None,
            candidate: None,
        }
    }

    /// Sequence number of the last accepted packet.
    pub const fn last_sequence(&self) -> Option<u16> {
        self.last_sequence
    }

    /// Validates `bytes` (see [`parse`]) and its sequence number.
    ///
    /// A packet after the last accepted one is accepted, a jump forward reported as
    /// [`Received::gap`]. A packet at most [`REORDER_WINDOW`] behind is late (or
    /// repeated) and rejected with [`PacketError::SequenceBackwards`]. Packets further
    /// behind are rejected the same way until [`RESYNC_PACKETS`] of them arrive with
    /// consecutive sequence numbers: the last of those is accepted as the start of a
    /// new sequence ([`Received::resynchronised`]). So a sender that restarts is
    /// accepted again within [`RESTART_ACCEPTED_WITHIN`] packets (the worst case is a
    /// restart just outside the window: its run is cut by the window, and it is
    /// accepted when it passes the old sequence), and one forged packet that jumped
    /// the state ahead costs RESYNC_PACKETS − 1 genuine ones. Rejected packets leave
    /// the accepted state unchanged.
    pub fn decode(&mut self, bytes: &[u8]) -> Result<Received, PacketError> {
        self.accept(parse(bytes)?)
    }

    /// The sequence check of [`PacketDecoder::decode`] on a packet already parsed
    /// (a frame's packets are parsed together before any is accepted).
    pub fn accept(&mut self, packet: Packet) -> Result<Received, PacketError> {
        let got = packet.sequence;
        let (gap, resynchronised) = match self.last_sequence {
            None => (0, false),
            Some(last) => {
                // Serial-number arithmetic (RFC 1982): forward when the wrapping
                // difference is in 1..=32767.
                let step = got.wrapping_sub(last) as i16;
                if step > 0 {
                    ((step - 1) as u16, false)
                } else if last.wrapping_sub(got) <= REORDER_WINDOW {
                    return Err(PacketError::SequenceBackwards { last, got });
                } else {
                    let run = match self.candidate {
                        // n < RESYNC_PACKETS (kept only below it): never saturates.
                        Some((previous, n)) if got == previous.wrapping_add(1) => {
                            n.saturating_add(1)
                        }
                        _ => 1,
                    };
                    if run < RESYNC_PACKETS {
                        self.candidate = Some((got, run));
                        return Err(PacketError::SequenceBackwards { last, got });
                    }
                    (0, true)
                }
            }
        };
        self.candidate = None;
        self.last_sequence = Some(got);
        Ok(Received {
            packet,
            gap,
            resynchronised,
        })
    }
}

#[cfg(test)]
mod tests;
