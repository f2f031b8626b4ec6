//! `host_job`: the harness [`kerf_fuzz::targets::job::host_job`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS host_job`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::job::host_job(data);
});
