//! Any byte string fed to the G-code reader must give `Ok` or a typed error naming a
//! line inside the input, never a panic, and every accepted point must be finite with
//! a feed that is finite and not negative. The same bytes are also read line by line
//! through `Parser::parse_line`, which must agree with `parse` on the points.
//!
//! Run (nightly, `cargo install cargo-fuzz`):
//! `cd fuzz && cargo +nightly fuzz run gcode_parse -- -max_total_time=660`
#![no_main]

use heapless::Vec;
use kerf::trajectory::gcode::{parse, GcodePoint, Parser};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut points: Vec<GcodePoint, 64> = Vec::new();
    let lines = data.split(|&b| b == b'\n').count();
    match parse(data, &mut points) {
        Ok(program) => {
            assert!(program.lines as usize <= lines);
            for p in &points {
                assert!(
                    p.position_m.iter().chain(&p.angles_rad).all(|v| v.is_finite()),
                    "{p:?}"
                );
                assert!(p.feed_m_s.is_finite() && p.feed_m_s >= 0.0, "{p:?}");
                assert!(p.line >= 1 && p.line as usize <= lines);
            }
        }
        Err(e) => assert!(e.line >= 1 && e.line as usize <= lines, "{e:?}"),
    }
    // Line by line, up to the first refusal: the same points.
    let mut parser = Parser::new();
    let mut k = 0;
    for line in data.split(|&b| b == b'\n') {
        match parser.parse_line(line) {
            Ok(Some(p)) => {
                if let Some(q) = points.get(k) {
                    assert_eq!(p, *q);
                }
                k += 1;
            }
            Ok(None) => {}
            Err(_) => break,
        }
    }
});
