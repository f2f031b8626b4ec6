//! `playout`: the harness [`kerf_fuzz::targets::replay::playout`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS playout`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::replay::playout(data);
});
