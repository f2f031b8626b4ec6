//! `telemetry_log`: the harness [`kerf_fuzz::targets::host::telemetry_log`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS telemetry_log`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::host::telemetry_log(data);
});
