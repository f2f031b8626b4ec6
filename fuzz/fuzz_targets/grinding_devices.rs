//! `grinding_devices`: the harness [`kerf_fuzz::targets::devices::grinding_devices`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS grinding_devices`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::devices::grinding_devices(data);
});
