//! `stream_frame`: the harness [`kerf_fuzz::targets::stream::stream_frame`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS stream_frame`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::stream::stream_frame(data);
});
