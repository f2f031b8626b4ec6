//! Any bytes as a reply to any spindle request: the decoder never panics, and every
//! accepted reply is a finite, non-negative reading.
#![no_main]

use kerf::codec::spindle::{SpindleReading, SpindleRequest};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&which, reply)) = data.split_first() else {
        return;
    };
    let request = match which % 7 {
        0 => SpindleRequest::SetSpeed { rpm: 25_000 },
        1 => SpindleRequest::Start,
        2 => SpindleRequest::DutyRpm,
        3 => SpindleRequest::ActualRpm,
        4 => SpindleRequest::SpindleRpm,
        5 => SpindleRequest::LoadPercent,
        _ => SpindleRequest::Current,
    };
    match request.decode(reply) {
        Ok(SpindleReading::LoadPercent(v)) | Ok(SpindleReading::CurrentA(v)) => {
            assert!(v.is_finite() && v >= 0.0)
        }
        Ok(_) => assert_eq!(reply.len(), 3),
        Err(_) => assert_ne!(reply.len(), 3),
    }
});
