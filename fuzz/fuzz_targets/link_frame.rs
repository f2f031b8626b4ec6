//! Any byte stream fed to the host link's frame reader and decoder must give frames
//! or typed errors, never a panic, in both directions; every message accepted is
//! encoded again and must decode to itself.
//!
//! Run (nightly, `cargo install cargo-fuzz`):
//! `cd fuzz && cargo +nightly fuzz run link_frame -- -max_total_time=660`
#![no_main]

use kerf::codec::link::{decode, encode, FrameReader, HostFrame, MachineMessage, MAX_FRAME};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut reader = FrameReader::<MAX_FRAME>::new();
    for &byte in data {
        let Some(Ok(frame)) = reader.push(byte) else {
            continue;
        };
        let mut copy = [0u8; MAX_FRAME];
        let Some(copy) = copy.get_mut(..frame.len()) else {
            continue;
        };
        copy.copy_from_slice(frame);
        if let Ok(message) = decode::<HostFrame>(frame) {
            let mut out = [0u8; MAX_FRAME];
            let n = encode(&message, &mut out).unwrap();
            assert_eq!(decode::<HostFrame>(&mut out[1..n - 1]).unwrap(), message);
        }
        if let Ok(message) = decode::<MachineMessage>(copy) {
            let mut out = [0u8; MAX_FRAME];
            let n = encode(&message, &mut out).unwrap();
            assert_eq!(decode::<MachineMessage>(&mut out[1..n - 1]).unwrap(), message);
        }
    }
});
