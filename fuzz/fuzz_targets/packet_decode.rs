//! Any byte string fed to the packet decoder must give `Ok` or a typed error, never a
//! panic. Input layout: one flag byte, two bytes that seed the decoder's last sequence
//! number (so the sequence check is exercised), then the packet. When bit 0 of the
//! flag byte is set, the packet's last two bytes are overwritten with its correct CRC
//! first, so that random mutations get past the CRC and reach the header and index-set
//! checks. An accepted packet is also turned into blocks of every supported N and
//! decoded, and every decoded sample must be finite and within `MAX_SAMPLE_ABS`.
//!
//! Run (nightly, `cargo install cargo-fuzz`):
//! `cd fuzz && cargo +nightly fuzz run packet_decode -- -max_total_time=660`
#![no_main]

use kerf::codec::packet::{parse, PacketDecoder, MAX_SAMPLE_ABS};
use kerf::codec::sdct::SdctDecoder;
use libfuzzer_sys::fuzz_target;

/// The packet CRC (CRC-16/IBM-3740), recomputed independently of kerf.
const CRC16: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_IBM_3740);

fn reconstruct<const N: usize>(packet: &kerf::codec::packet::Packet) {
    if let (Ok(block), Ok(dec)) = (packet.to_block::<N>(), SdctDecoder::<N>::new()) {
        let mut out = [0.0f32; N];
        dec.decode(&block, &mut out);
        assert_eq!(block.m(), usize::from(packet.m));
        // Every accepted packet decodes to finite samples inside the declared range.
        assert!(
            out.iter()
                .all(|x| x.is_finite() && x.abs() <= MAX_SAMPLE_ABS),
            "{out:?}"
        );
    }
}

fuzz_target!(|data: &[u8]| {
    let mut decoder = PacketDecoder::new();
    if let [flags, s0, s1, rest @ ..] = data {
        let mut patched = [0u8; 512];
        let rest = match patched.get_mut(..rest.len()) {
            Some(buf) if flags & 1 == 1 && rest.len() >= 2 => {
                buf.copy_from_slice(rest);
                let (body, crc) = buf.split_at_mut(rest.len() - 2);
                crc.copy_from_slice(&CRC16.checksum(body).to_le_bytes());
                &*buf
            }
            _ => rest,
        };
        // Prime the sequence state with a valid empty packet, then decode the rest.
        let mut primer = [0u8; 32];
        let block = kerf::codec::sdct::Block::<8>::from_parts(0, [0.0; 8]);
        if let Ok(len) =
            kerf::codec::packet::encode(&block, u16::from_le_bytes([*s0, *s1]), 0, &mut primer)
        {
            assert!(decoder.decode(&primer[..len]).is_ok());
        }
        let stateless = parse(rest);
        let stateful = decoder.decode(rest);
        if let Ok(received) = stateful {
            assert_eq!(stateless.as_ref().ok(), Some(&received.packet));
            let p = &received.packet;
            reconstruct::<8>(p);
            reconstruct::<16>(p);
            reconstruct::<32>(p);
            reconstruct::<64>(p);
        }
    }
});
