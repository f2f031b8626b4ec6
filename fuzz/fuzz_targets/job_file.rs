//! `job_file`: the harness [`kerf_fuzz::targets::job::job_file`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS job_file`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::job::job_file(data);
});
