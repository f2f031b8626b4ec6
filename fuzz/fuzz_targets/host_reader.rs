//! `host_reader`: the harness [`kerf_fuzz::targets::host::host_reader`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS host_reader`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::host::host_reader(data);
});
