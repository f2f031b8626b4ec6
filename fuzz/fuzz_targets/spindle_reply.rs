//! `spindle_reply`: the harness [`kerf_fuzz::targets::codec::spindle_reply`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS spindle_reply`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::codec::spindle_reply(data);
});
