//! Unit tests of the packet format, compiled only under `#[cfg(test)]`.

use super::*;
use proptest::prelude::*;
extern crate std;

fn block64(mask: u64) -> Block<64> {
    Block::from_parts(mask, core::array::from_fn(|k| (k as f32 - 20.0) * 0.37))
}

fn encoded(mask: u64, sequence: u16) -> ([u8; MAX_PACKET_LEN], usize) {
    let mut buf = [0u8; MAX_PACKET_LEN];
    let len = encode(&block64(mask), sequence, 1234, &mut buf).unwrap();
    (buf, len)
}

/// Rewrites the CRC after a deliberate edit, so the check under test is reached.
fn fix_crc(bytes: &mut [u8]) {
    let n = bytes.len() - CRC_LEN;
    let crc = CRC16.checksum(&bytes[..n]);
    bytes[n..].copy_from_slice(&crc.to_le_bytes());
}

#[test]
fn index_form_is_the_smallest() {
    // N = 64: list of 6-bit indices beats the 8-byte mask up to m = 10.
    let sparse = 1 << 3 | 1 << 40 | 1 << 63;
    let (buf, len) = encoded(sparse, 0);
    assert_eq!(buf[3], IndexForm::List as u8);
    assert_eq!(len, HEADER_LEN + 3 + 2 * 3 + CRC_LEN); // 18 bits → 3 bytes
    let dense = 0x5555_5555_5555_5555;
    let (buf, len) = encoded(dense, 0);
    assert_eq!(buf[3], IndexForm::Bitmask as u8);
    assert_eq!(len, HEADER_LEN + 8 + 2 * 32 + CRC_LEN);
    let (buf, len) = encoded(0xFF, 0);
    assert_eq!(buf[3], IndexForm::Prefix as u8);
    assert_eq!(len, HEADER_LEN + 2 * 8 + CRC_LEN);
    assert_eq!(encoded(u64::MAX, 0).1, MAX_PACKET_LEN - 8); // full prefix
}

#[test]
fn every_malformation_has_its_error() {
    let (buf, len) = encoded(1 << 3 | 1 << 40 | 1 << 63, 7);
    let good = &buf[..len];
    assert!(parse(good).is_ok());
    assert_eq!(parse(&good[..5]), Err(PacketError::Truncated));
    assert_eq!(parse(&good[..len - 1]), Err(PacketError::Truncated));
    let mut long = [0u8; MAX_PACKET_LEN];
    long[..len].copy_from_slice(good);
    assert_eq!(parse(&long[..len + 1]), Err(PacketError::LengthMismatch));

    let mut bad = buf;
    bad[HEADER_LEN + 4] ^= 0x10;
    assert_eq!(parse(&bad[..len]), Err(PacketError::BadCrc));

    let edit = |offset: usize, value: u8| {
        let mut b = buf;
        b[offset] = value;
        fix_crc(&mut b[..len]);
        parse(&b[..len])
    };
    assert_eq!(edit(0, 2), Err(PacketError::UnknownVersion(2)));
    assert_eq!(edit(1, 48), Err(PacketError::UnsupportedN(48)));
    assert_eq!(edit(2, 65), Err(PacketError::TooManyCoefficients));
    assert_eq!(edit(3, 9), Err(PacketError::UnknownIndexForm(9)));
    // Same length with a 4th index would not fit: m = 4 needs 3 bytes of list and
    // 8 bytes of values, so the length check fires.
    assert_eq!(edit(2, 4), Err(PacketError::Truncated));

    // Duplicate: indices 3, 40, 63 → 3, 3, 63 (first 6-bit field copied over the
    // second one: bits 6..12 of the list).
    let mut dup = buf;
    let list = u32::from_le_bytes([dup[11], dup[12], dup[13], 0]);
    let list = (list & !(0x3F << 6)) | 3 << 6;
    dup[11..14].copy_from_slice(&list.to_le_bytes()[..3]);
    fix_crc(&mut dup[..len]);
    assert_eq!(parse(&dup[..len]), Err(PacketError::DuplicateIndex(3)));

    // Padding: 3 × 6 bits leave 6 zero bits in the last list byte.
    let mut pad = buf;
    pad[13] |= 0x80;
    fix_crc(&mut pad[..len]);
    assert_eq!(parse(&pad[..len]), Err(PacketError::BadPadding));

    // Bit mask whose popcount disagrees with m.
    let (mbuf, mlen) = encoded(0x5555_5555_5555_5555, 0);
    let mut cnt = mbuf;
    cnt[HEADER_LEN] |= 0x02;
    fix_crc(&mut cnt[..mlen]);
    assert_eq!(parse(&cnt[..mlen]), Err(PacketError::IndexCountMismatch));

    // Encoder-side errors.
    let mut small = [0u8; 10];
    assert_eq!(
        encode(&block64(1), 0, 0, &mut small),
        Err(PacketError::BufferTooSmall)
    );
    let mut big = [0u8; MAX_PACKET_LEN];
    assert_eq!(
        encode_parts(1 << 9, &[1.0; 8], 0, 0, &mut big),
        Err(PacketError::IndexOutOfRange(9))
    );
    assert_eq!(
        encode_parts(1, &[1.0; 12], 0, 0, &mut big),
        Err(PacketError::UnsupportedN(12))
    );
    assert_eq!(
        encode_parts(1, &[f32::NAN; 8], 0, 0, &mut big),
        Err(PacketError::NotFinite)
    );
}

#[test]
fn sequence_must_move_forward_and_gaps_are_reported() {
    let mut dec = PacketDecoder::new();
    let mut feed = |seq: u16| {
        let (buf, len) = encoded(0b1011, seq);
        dec.decode(&buf[..len]).map(|r| r.gap)
    };
    assert_eq!(feed(65530), Ok(0));
    assert_eq!(feed(65531), Ok(0));
    assert_eq!(feed(2), Ok(6)); // wraps forward past 65535, 6 numbers skipped
    assert_eq!(
        feed(2),
        Err(PacketError::SequenceBackwards { last: 2, got: 2 })
    );
    assert_eq!(
        feed(65535),
        Err(PacketError::SequenceBackwards {
            last: 2,
            got: 65535
        })
    );
    assert_eq!(feed(3), Ok(0)); // rejected packets left the state alone
}

#[test]
fn packet_for_another_n_is_not_a_block() {
    let (buf, len) = encoded(0b11, 0);
    let packet = parse(&buf[..len]).unwrap();
    assert_eq!(packet.to_block::<32>(), Err(PacketError::UnsupportedN(64)));
    assert!(packet.to_block::<64>().is_ok());
}

proptest! {
    /// Stable-toolchain companion of the cargo-fuzz target: arbitrary bytes give
    /// `Ok` or a typed error.
    #[test]
    fn arbitrary_bytes_never_panic(
        bytes in proptest::collection::vec(any::<u8>(), 0..200),
        last in any::<u16>(),
    ) {
        let mut dec = PacketDecoder { last_sequence: Some(last), candidate: None };
        let _ = dec.decode(&bytes);
    }

    /// Well-formed headers with random index and value bytes of about the right
    /// length and a correct CRC, so the index-set checks are reached often.
    #[test]
    fn random_bodies_behind_valid_headers_never_panic(
        n in proptest::sample::select(&[8u8, 16, 32, 64][..]),
        m_extra in 0u8..=66,
        form in 0u8..4,
        body in proptest::collection::vec(any::<u8>(), 140),
        len_delta in -1i32..=1,
    ) {
        let m = m_extra.min(n + 1);
        let index_len = IndexForm::from_byte(form).map_or(0, |f| f.len(n.into(), m.into()));
        let exact = HEADER_LEN + index_len + 2 * usize::from(m) + CRC_LEN;
        let len = (exact as i32 + len_delta) as usize;
        let mut bytes = std::vec::Vec::from(header_bytes(n, m, IndexForm::Prefix, 0, 9, 0));
        bytes[3] = form;
        bytes.extend(body.iter().cycle().take(len - HEADER_LEN));
        let packet = &mut bytes[..];
        fix_crc(packet);
        if let Ok(p) = parse(packet) {
            prop_assert_eq!(p.mask.count_ones(), u32::from(p.m));
            prop_assert!(p.mask & !prefix_mask(usize::from(p.n)) == 0);
            prop_assert_eq!(len, exact);
        }
    }

    #[test]
    fn encode_then_decode_round_trips(
        values in proptest::array::uniform32(-1.0e4f32..1.0e4),
        mask in any::<u32>(),
        sequence in any::<u16>(),
        timestamp in any::<u32>(),
        scale_exp in -40i32..40,
    ) {
        let coeffs = values.map(|v| libm::ldexpf(v, scale_exp));
        let block = Block::<32>::from_parts(u64::from(mask), coeffs);
        let mut buf = [0u8; MAX_PACKET_LEN];
        let len = encode(&block, sequence, timestamp, &mut buf).unwrap();
        let m = mask.count_ones() as usize;
        let form = choose_form(32, m, u64::from(mask));
        prop_assert_eq!(len, HEADER_LEN + form.len(32, m) + 2 * m + CRC_LEN);
        let received = PacketDecoder::new().decode(&buf[..len]).unwrap();
        let p = &received.packet;
        prop_assert_eq!((p.n, usize::from(p.m)), (32, m));
        prop_assert_eq!((p.sequence, p.timestamp, p.mask), (sequence, timestamp, u64::from(mask)));
        let decoded = p.to_block::<32>().unwrap();
        // Half a mantissa step 2^(e−16), a full step when rounding saturates.
        let step = libm::ldexpf(1.0, i32::from(p.exponent) - 15);
        let max_abs = coeffs.iter().enumerate()
            .filter(|&(k, _)| mask >> k & 1 == 1)
            .fold(0.0f32, |a, (_, c)| a.max(c.abs()));
        // The exponent uses the mantissa range: 2^(e−1) ≤ max |c| < 2^e.
        let top = libm::ldexpf(1.0, i32::from(p.exponent));
        prop_assert!(m == 0 || (max_abs < top && max_abs >= 0.5 * top));
        for (k, (&a, &b)) in block.coefficients().iter().zip(decoded.coefficients()).enumerate() {
            prop_assert!((a - b).abs() <= step, "k {} {} vs {}", k, a, b);
        }
    }
}

/// A valid-CRC packet at the largest i8 exponent with full-scale mantissas: every
/// coefficient is about 2^127, and the inverse DCT's sum of 64 of them is +inf in
/// f32. The exponent is outside the declared range and must be refused.
#[test]
fn an_exponent_outside_the_declared_range_is_refused() {
    let block = Block::<64>::from_parts(u64::MAX, [0.75; 64]);
    let mut buf = [0u8; MAX_PACKET_LEN];
    let len = encode(&block, 0, 0, &mut buf).unwrap();
    for e in [127i8, MAX_EXPONENT + 1, MIN_EXPONENT - 1, -128] {
        buf[4] = e.to_le_bytes()[0];
        fix_crc(&mut buf[..len]);
        assert_eq!(
            parse(&buf[..len]),
            Err(PacketError::ExponentOutOfRange(e)),
            "{e}"
        );
    }
    for e in [MIN_EXPONENT, 0, MAX_EXPONENT] {
        buf[4] = e.to_le_bytes()[0];
        fix_crc(&mut buf[..len]);
        let block = parse(&buf[..len]).unwrap().to_block::<64>().unwrap();
        let mut y = [0.0f32; 64];
        crate::codec::sdct::SdctDecoder::<64>::new()
            .unwrap()
            .decode(&block, &mut y);
        assert!(
            y.iter().all(|v| v.is_finite() && v.abs() <= MAX_SAMPLE_ABS),
            "{e}"
        );
    }
}

/// A coefficient beyond 2^MAX_EXPONENT is an error, not a silently clamped
/// exponent that brings a full-scale value back 50 % off.
#[test]
fn the_encoder_refuses_coefficients_beyond_the_range() {
    let mut buf = [0u8; MAX_PACKET_LEN];
    for big in [
        3.0e38f32,
        1.0e30,
        libm::ldexpf(1.0, i32::from(MAX_EXPONENT)),
    ] {
        let block = Block::<8>::from_parts(0b11, [1.0, big, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert!(
            matches!(
                encode(&block, 0, 0, &mut buf),
                Err(PacketError::ExponentOutOfRange(_))
            ),
            "{big}"
        );
    }
    // Just inside: comes back to Q15 precision.
    let inside = libm::ldexpf(0.99, i32::from(MAX_EXPONENT));
    let block = Block::<8>::from_parts(0b1, [inside, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let len = encode(&block, 0, 0, &mut buf).unwrap();
    let back = parse(&buf[..len]).unwrap().coefficient(0);
    assert!((back / inside - 1.0).abs() < 1e-4, "{back} vs {inside}");
}

/// A packed list must name its indices in ascending order (the order the values
/// follow); a list out of order would put values at the wrong coefficients.
#[test]
fn an_unsorted_index_list_is_refused() {
    // N = 64, indices 3, 40, 63: a 3 × 6-bit list. Swap the first two.
    let (buf, len) = encoded(1 << 3 | 1 << 40 | 1 << 63, 0);
    assert_eq!(buf[3], IndexForm::List as u8);
    let mut swapped = buf;
    let list = u32::from_le_bytes([buf[11], buf[12], buf[13], 0]);
    let (a, b) = (list & 0x3F, list >> 6 & 0x3F);
    let list = (list & !0xFFF) | b | a << 6;
    swapped[11..14].copy_from_slice(&list.to_le_bytes()[..3]);
    fix_crc(&mut swapped[..len]);
    assert_eq!(parse(&swapped[..len]), Err(PacketError::UnsortedIndex(3)));
}

fn feed(
    decoder: &mut PacketDecoder,
    sequences: impl IntoIterator<Item = u16>,
) -> std::vec::Vec<bool> {
    sequences
        .into_iter()
        .map(|seq| {
            decoder
                .decode(&encoded(0b1, seq).0[..encoded(0b1, seq).1])
                .is_ok()
        })
        .collect()
}

/// A sender that restarts at 0 after 500 packets: accepted again at its
/// RESYNC_PACKETS-th packet, and in order from there.
#[test]
fn a_restarted_sender_is_accepted_within_the_resync_count() {
    let mut decoder = PacketDecoder::new();
    assert!(feed(&mut decoder, 0..500).iter().all(|&ok| ok));
    let accepted = feed(&mut decoder, 0..10);
    let first = accepted.iter().position(|&ok| ok).unwrap();
    assert_eq!(first + 1, usize::from(RESYNC_PACKETS), "{accepted:?}");
    assert!(accepted[first..].iter().all(|&ok| ok));
    assert_eq!(decoder.last_sequence(), Some(9));
}

/// The worst case over every restart point up to 40 behind the last accepted
/// packet: a restart just outside the reorder window starts a run that the window
/// then interrupts, and the sender is accepted when it passes the old sequence.
#[test]
fn the_worst_restart_costs_the_stated_bound() {
    let packets_until_accepted = |behind: u16| {
        let mut decoder = PacketDecoder::new();
        feed(&mut decoder, 0..=1000);
        let accepted = feed(&mut decoder, 1000 - behind..1100);
        accepted.iter().position(|&ok| ok).unwrap() + 1
    };
    let worst = (0..=40).map(packets_until_accepted).max().unwrap();
    assert_eq!(
        worst,
        usize::from(REORDER_WINDOW) + usize::from(RESYNC_PACKETS) + 1
    );
    assert_eq!(worst, RESTART_ACCEPTED_WITHIN);
    // Far behind: the resync count.
    assert_eq!(packets_until_accepted(40), usize::from(RESYNC_PACKETS));
}

/// An outage longer than half the sequence space makes genuine packets look old.
#[test]
fn a_gap_beyond_half_the_sequence_space_resynchronises() {
    let mut decoder = PacketDecoder::new();
    feed(&mut decoder, 0..=10);
    let resumed = 10u16.wrapping_add(40_000);
    let accepted = feed(&mut decoder, (0..5).map(|k| resumed.wrapping_add(k)));
    assert_eq!(accepted, [false, false, true, true, true]);
}

/// One forged packet far ahead (valid CRC) blocks genuine traffic for only
/// RESYNC_PACKETS − 1 packets.
#[test]
fn a_forged_packet_far_ahead_blocks_only_briefly() {
    let mut decoder = PacketDecoder::new();
    feed(&mut decoder, 0..=10);
    assert_eq!(feed(&mut decoder, [30_010]), [true]);
    let accepted = feed(&mut decoder, 11..20);
    assert_eq!(
        accepted.iter().filter(|&&ok| !ok).count(),
        usize::from(RESYNC_PACKETS) - 1
    );
    assert!(accepted[usize::from(RESYNC_PACKETS) - 1..]
        .iter()
        .all(|&ok| ok));
}

/// Late packets inside the reorder window are never used, even in a consecutive
/// run: resynchronising on them would deliver old data.
#[test]
fn late_packets_inside_the_window_never_resynchronise() {
    let mut decoder = PacketDecoder::new();
    feed(&mut decoder, [100]);
    let late = 100 - REORDER_WINDOW..100;
    assert!(feed(&mut decoder, late).iter().all(|&ok| !ok));
    assert_eq!(decoder.last_sequence(), Some(100));
}
