//! `remote_link`: the harness [`kerf_fuzz::targets::stream::remote_link`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS remote_link`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::stream::remote_link(data);
});
