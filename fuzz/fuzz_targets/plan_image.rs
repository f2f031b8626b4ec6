//! `plan_image`: the harness [`kerf_fuzz::targets::host::plan_image`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS plan_image`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::host::plan_image(data);
});
