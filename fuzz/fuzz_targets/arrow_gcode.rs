//! `arrow_gcode`: the harness [`kerf_fuzz::targets::job::arrow_gcode`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS arrow_gcode`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::job::arrow_gcode(data);
});
