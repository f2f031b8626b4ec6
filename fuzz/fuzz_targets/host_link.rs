//! `host_link`: the harness [`kerf_fuzz::targets::link::host_link`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS host_link`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::link::host_link(data);
});
