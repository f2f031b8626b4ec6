//! `gcode_parse`: the harness [`kerf_fuzz::targets::codec::gcode_parse`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS gcode_parse`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::codec::gcode_parse(data);
});
