//! `packet_decode`: the harness [`kerf_fuzz::targets::codec::packet_decode`] (its docs say what it
//! asserts). Run with `scripts/fuzz SECONDS packet_decode`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    kerf_fuzz::targets::codec::packet_decode(data);
});
