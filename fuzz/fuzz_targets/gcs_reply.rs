//! `gcs_reply`: the harness [`kerf_fuzz::targets::codec::gcs_reply`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS gcs_reply`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::codec::gcs_reply(data);
});
