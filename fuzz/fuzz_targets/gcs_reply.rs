//! Any byte string fed to the GCS reply parsers (and to the controller-side command
//! parser) must give `Ok` or a typed error, never a panic; every accepted reply
//! must carry finite values. Input layout: one selector byte, then the reply.
//! Accepted axis values are also written back and must parse to the same axes.
//!
//! Run (nightly, `cargo install cargo-fuzz`):
//! `cd fuzz && cargo +nightly fuzz run gcs_reply -- -max_total_time=660`
#![no_main]

use kerf::codec::gcs::{
    parse_axis_names, parse_axis_values, parse_error_code, parse_identification,
    parse_motion_status, parse_ready, parse_referenced, parse_value, reply, Command,
    MAX_REPLY_LEN,
};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((selector, bytes)) = data.split_first() else {
        return;
    };
    match selector % 9 {
        0 => {
            if let Ok(values) = parse_axis_values(bytes) {
                assert!(values.iter().all(|(_, v)| v.is_finite()));
                let mut buf = [0u8; MAX_REPLY_LEN];
                // Values beyond the writer's range are refused, not mangled.
                if let Ok(len) = reply::encode_axis_values(&values, &mut buf) {
                    if len > 0 {
                        let back = parse_axis_values(&buf[..len]).unwrap();
                        assert_eq!(back.axes(), values.axes());
                    }
                }
            }
        }
        1 => {
            if let Ok(v) = parse_value(bytes) {
                assert!(v.is_finite());
            }
        }
        2 => {
            let _ = parse_error_code(bytes);
        }
        3 => {
            if let Ok((all, referenced)) = parse_referenced(bytes) {
                assert!(referenced.iter().all(|a| all.contains(a)));
            }
        }
        4 => {
            let _ = parse_axis_names(bytes);
        }
        5 => {
            if let Ok(text) = parse_identification(bytes) {
                assert!(text.bytes().all(|b| (b' '..=b'~').contains(&b)));
            }
        }
        6 => {
            let _ = parse_motion_status(bytes);
        }
        7 => {
            let _ = parse_ready(bytes);
        }
        _ => {
            if let Ok(command) = Command::parse(bytes) {
                // Whatever the controller side accepts, the firmware side can write
                // (values of a parsed command are finite by construction).
                let mut buf = [0u8; 512];
                let _ = command.encode(&mut buf);
            }
        }
    }
});
