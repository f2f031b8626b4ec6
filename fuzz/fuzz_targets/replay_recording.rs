//! `replay_recording`: the harness [`kerf_fuzz::targets::replay::replay_recording`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS replay_recording`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::replay::replay_recording(data);
});
