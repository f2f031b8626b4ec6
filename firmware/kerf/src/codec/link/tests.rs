use super::*;
use std::vec::Vec;

/// CRC-32/ISO-HDLC bit by bit (reflected polynomial 0xEDB88320, init and xor-out all
/// ones): an independent route to the frame check.
fn crc32_bitwise(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

fn host_frames(chunk: &[u8]) -> Vec<HostFrame<'_>> {
    let requests = [
        Request::Hello,
        Request::Heartbeat,
        Request::JobBegin {
            kind: JobKind::Efd,
            total_bytes: 1234,
            crc32: 0xDEAD_BEEF,
        },
        Request::JobChunk {
            offset: 4096,
            data: chunk,
        },
        Request::JobStatus,
        Request::JobCommit,
        Request::Start,
        Request::Stop,
        Request::ResetFault,
        Request::Get {
            path: "/dob/bandwidth_hz",
        },
        Request::Set {
            path: "/pd/kp_per_s2",
            value: b"1.5e6",
        },
        Request::Telemetry { every_periods: 100 },
        Request::Status,
    ];
    requests
        .into_iter()
        .enumerate()
        .map(|(i, request)| HostFrame {
            seq: 65_530u16.wrapping_add(i as u16),
            request,
        })
        .collect()
}

#[test]
fn every_message_round_trips_and_frames_hold_no_zero_before_the_delimiter() {
    let chunk: Vec<u8> = (0..MAX_CHUNK).map(|i| i as u8).collect();
    for frame in host_frames(&chunk) {
        let mut out = [0u8; MAX_FRAME];
        let n = encode(&frame, &mut out).unwrap();
        assert!(n <= MAX_FRAME);
        assert_eq!((out[0], out[n - 1]), (0, 0));
        let body = &mut out[1..n - 1];
        assert!(body.iter().all(|&b| b != 0), "{frame:?}");
        let mut copy = body.to_vec();
        assert_eq!(decode::<HostFrame>(&mut copy).unwrap(), frame);
    }
    let replies = [
        MachineMessage::Reply {
            seq: 7,
            reply: Reply::Hello {
                version: VERSION,
                machine: "keops-slave",
                max_chunk: MAX_CHUNK as u16,
                period_ns: 100_000,
            },
        },
        MachineMessage::Reply {
            seq: 8,
            reply: Reply::Refused(Refusal::ChunkOffset { expected: 192 }),
        },
        MachineMessage::Reply {
            seq: 9,
            reply: Reply::Value { value: b"250.0" },
        },
        MachineMessage::Telemetry(TelemetrySample {
            period: u32::MAX,
            mode: ModeCode::Running,
            values: ChannelValues::from_slice(&[1e-3, -2e-3, 0.05, 3e-7, 1.0, -2.5, 9.0, 12.5])
                .unwrap(),
        }),
        MachineMessage::Reply {
            seq: 10,
            reply: Reply::Status(MachineStatus {
                mode: ModeCode::Fault,
                last_fault: Some((4, 0)),
                period: u64::MAX,
                upload_received: Some(192),
                bad_frames: 3,
                unsent: u32::MAX,
                settings: SettingsOrigin::FellBack {
                    sequence: u32::MAX,
                    skipped: 2,
                },
            }),
        },
        MachineMessage::Event(Event::Fault { code: 3, detail: 1 }),
        MachineMessage::Event(Event::Mode {
            from: ModeCode::Running,
            to: ModeCode::Fault,
        }),
    ];
    for message in replies {
        let mut out = [0u8; MAX_FRAME];
        let n = encode(&message, &mut out).unwrap();
        let mut body = out[1..n - 1].to_vec();
        assert_eq!(decode::<MachineMessage>(&mut body).unwrap(), message);
    }
}

#[test]
fn the_check_is_crc32_iso_hdlc() {
    // The catalogue's check value, and a frame's trailer against the bitwise route.
    assert_eq!(crc32_bitwise(b"123456789"), 0xCBF4_3926);
    let frame = HostFrame {
        seq: 3,
        request: Request::Start,
    };
    let mut out = [0u8; MAX_FRAME];
    let n = encode(&frame, &mut out).unwrap();
    let mut raw = out[1..n - 1].to_vec();
    let len = cobs::decode_in_place(&mut raw).unwrap();
    let (checked, crc) = raw[..len].split_at(len - 4);
    assert_eq!(checked[0], VERSION);
    assert_eq!(
        u32::from_le_bytes(crc.try_into().unwrap()),
        crc32_bitwise(checked)
    );
}

#[test]
fn damaged_frames_are_refused_by_kind() {
    let frame = HostFrame {
        seq: 1,
        request: Request::Get { path: "/a/b" },
    };
    let mut out = [0u8; MAX_FRAME];
    let n = encode(&frame, &mut out).unwrap();
    let good = out[1..n - 1].to_vec();
    // Every single-bit flip is caught (CRC-32 detects all of them); most show as a
    // CRC mismatch, some break the COBS structure first.
    for byte in 0..good.len() {
        for bit in 0..8 {
            let mut bad = good.clone();
            bad[byte] ^= 1 << bit;
            let e = decode::<HostFrame>(&mut bad).unwrap_err();
            assert!(
                matches!(e, FrameError::Crc | FrameError::Cobs | FrameError::TooShort),
                "{byte} {bit}: {e:?}"
            );
        }
    }
    // Truncated.
    let mut short = good[..good.len() - 3].to_vec();
    assert!(decode::<HostFrame>(&mut short).is_err());
    // Another version, with a correct CRC.
    let other = VERSION + 1;
    let mut payload = Vec::from([other]);
    let mut body = [0u8; 64];
    payload.extend_from_slice(postcard::to_slice(&frame, &mut body).unwrap());
    let crc = crc32_bitwise(&payload);
    payload.extend_from_slice(&crc.to_le_bytes());
    let mut encoded = [0u8; MAX_FRAME];
    let m = cobs::encode(&payload, &mut encoded);
    assert_eq!(
        decode::<HostFrame>(&mut encoded[..m]),
        Err(FrameError::Version(other))
    );
    // A well-framed message of the other direction, or with bytes left over.
    let message = MachineMessage::Event(Event::HostLost);
    let n = encode(&message, &mut out).unwrap();
    let mut body = out[1..n - 1].to_vec();
    assert_eq!(decode::<HostFrame>(&mut body), Err(FrameError::Message));
}

#[test]
fn the_reader_resynchronises_after_garbage_and_overlong_frames() {
    let frame = HostFrame {
        seq: 42,
        request: Request::Telemetry { every_periods: 10 },
    };
    let mut out = [0u8; MAX_FRAME];
    let n = encode(&frame, &mut out).unwrap();
    // Garbage (no zero), an overlong run, a lone delimiter pair, then the frame twice.
    let mut stream: Vec<u8> = (1..=200u8).collect();
    stream.push(0);
    stream.extend(core::iter::repeat_n(0x55, 600));
    stream.extend([0, 0]);
    stream.extend_from_slice(&out[..n]);
    stream.extend_from_slice(&out[..n]);
    let mut reader = FrameReader::<MAX_FRAME>::new();
    let mut results = Vec::new();
    for b in stream {
        if let Some(r) = reader.push(b) {
            results.push(r.and_then(|f| decode::<HostFrame>(f).map(|h| h == frame)));
        }
    }
    assert_eq!(results.len(), 4, "{results:?}");
    assert!(results[0].is_err(), "garbage");
    assert_eq!(results[1], Err(FrameError::TooLong));
    assert_eq!(results[2], Ok(true));
    assert_eq!(results[3], Ok(true));
}

#[test]
fn a_message_past_the_payload_is_refused_not_truncated() {
    // A setting's value has no range of its own: only the payload bounds it.
    let big = [b'1'; MAX_PAYLOAD];
    let frame = HostFrame {
        seq: 0,
        request: Request::Set {
            path: "/p",
            value: &big,
        },
    };
    let mut out = [0u8; 2 * MAX_FRAME];
    assert_eq!(encode(&frame, &mut out), Err(FrameError::NoRoom));
    let mut small = [0u8; 16];
    let ok = HostFrame {
        seq: 0,
        request: Request::Hello,
    };
    assert!(encode(&ok, &mut small).is_ok());
    let mut tiny = [0u8; 4];
    assert_eq!(encode(&ok, &mut tiny), Err(FrameError::NoRoom));
}

#[test]
fn board_fault_codes_are_named_and_no_other_code_is() {
    use super::board_fault::*;
    let causes = [
        HARD_FAULT,
        PANIC,
        MISSED_DEADLINE,
        WATCHDOG,
        SAMPLING,
        BREAK,
        STARTUP,
    ];
    let reasons: std::vec::Vec<_> = causes
        .iter()
        .map(|&c| reason(BOARD_FAULT | c).unwrap())
        .collect();
    for (k, r) in reasons.iter().enumerate() {
        assert_ne!(*r, "unknown board fault");
        assert!(reasons[k + 1..].iter().all(|other| other != r), "{r} twice");
    }
    assert!(reason(BOARD_FAULT | HARD_FAULT)
        .unwrap()
        .contains("HardFault"));
    assert_eq!(reason(BOARD_FAULT | 0xFF), Some("unknown board fault"));
    // The machines' own codes, and codes outside the board's range, are not the board's.
    for code in [0, 1, 6, 0x201, 0xA003, 0xB103, 0xFFFF] {
        assert_eq!(reason(code), None, "{code:#x}");
    }
}

proptest::proptest! {
    /// The fuzz target's property on random streams, in the test suite: frames or
    /// typed errors, never a panic; an accepted message encodes back to itself.
    #[test]
    fn random_streams_give_frames_or_typed_errors(data in proptest::collection::vec(proptest::num::u8::ANY, 0..600)) {
        let mut reader = FrameReader::<MAX_FRAME>::new();
        for byte in data {
            if let Some(Ok(frame)) = reader.push(byte) {
                if let Ok(message) = decode::<HostFrame>(frame) {
                    let mut out = [0u8; MAX_FRAME];
                    let n = encode(&message, &mut out).unwrap();
                    proptest::prop_assert_eq!(decode::<HostFrame>(&mut out[1..n - 1]).unwrap(), message);
                }
            }
        }
    }

    /// Random requests (a chunk of random bytes at a random offset, a random path
    /// and value) round-trip through a frame.
    #[test]
    fn random_requests_round_trip(seq: u16, offset: u32, data in proptest::collection::vec(proptest::num::u8::ANY, 0..MAX_CHUNK), path in "/[a-z_/]{0,40}") {
        let chunk = HostFrame { seq, request: Request::JobChunk { offset, data: &data } };
        let set = HostFrame { seq, request: Request::Set { path: &path, value: &data } };
        for frame in [chunk, set] {
            let mut out = [0u8; MAX_FRAME];
            let n = encode(&frame, &mut out).unwrap();
            proptest::prop_assert_eq!(decode::<HostFrame>(&mut out[1..n - 1]).unwrap(), frame);
        }
    }
}

/// A telemetry message of [`MAX_CHANNELS`] values with `value` at `field`, framed as
/// a sender that does not check would frame it.
fn telemetry_frame(field: usize, value: f32) -> Vec<u8> {
    let mut sample = TelemetrySample {
        period: 9,
        mode: ModeCode::Running,
        values: (0..MAX_CHANNELS).map(|i| 1e-3 * i as f32 - 2e-3).collect(),
    };
    sample.values[field] = value;
    framed_unchecked(&MachineMessage::Telemetry(sample))
}

/// Every telemetry value NaN or infinite in turn: the decoder refuses the frame with
/// its own error (its CRC is right), and the encoder refuses to write it; the largest
/// finite values pass both ways.
#[test]
fn non_finite_telemetry_is_refused_both_ways() {
    for field in 0..MAX_CHANNELS {
        for value in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut frame = telemetry_frame(field, value);
            assert_eq!(
                decode::<MachineMessage>(&mut frame),
                Err(FrameError::NotFinite),
                "field {field} = {value}"
            );
            let mut raw = telemetry_frame(field, value);
            let n = cobs::decode_in_place(&mut raw).unwrap();
            let message = postcard::from_bytes::<MachineMessage>(&raw[1..n - 4]).unwrap();
            let mut out = [0u8; MAX_FRAME];
            assert_eq!(encode(&message, &mut out), Err(FrameError::NotFinite));
        }
        for value in [f32::MAX, f32::MIN, f32::MIN_POSITIVE, -0.0] {
            let mut frame = telemetry_frame(field, value);
            let message = decode::<MachineMessage>(&mut frame).unwrap();
            let mut out = [0u8; MAX_FRAME];
            let n = encode(&message, &mut out).unwrap();
            assert_eq!(
                decode::<MachineMessage>(&mut out[1..n - 1]).unwrap(),
                message,
                "field {field} = {value}"
            );
        }
    }
}

/// `message` framed by hand (version, postcard, CRC-32, COBS), as a sender that does
/// not check would frame it.
fn framed_unchecked<M: Serialize>(message: &M) -> Vec<u8> {
    let mut payload = Vec::from([VERSION]);
    let mut body = [0u8; MAX_PAYLOAD];
    payload.extend_from_slice(postcard::to_slice(message, &mut body).unwrap());
    let crc = crc32_bitwise(&payload);
    payload.extend_from_slice(&crc.to_le_bytes());
    let mut encoded = [0u8; MAX_FRAME];
    let n = cobs::encode(&payload, &mut encoded);
    encoded[..n].to_vec()
}

/// Fields at and past the edges of their stated ranges: a chunk of MAX_CHUNK bytes
/// and a hello of 1 to MAX_CHUNK bytes with a positive period pass both ways; one
/// byte more, a zero largest chunk or a zero period are refused by the decoder (its
/// CRC is right) and by the encoder.
#[test]
fn fields_outside_their_stated_range_are_refused_both_ways() {
    let data = [0x5Au8; MAX_CHUNK + 1];
    let chunk = |len: usize| HostFrame {
        seq: 1,
        request: Request::JobChunk {
            offset: 0,
            data: &data[..len],
        },
    };
    let hello = |max_chunk: usize, period_ns: u32| MachineMessage::Reply {
        seq: 2,
        reply: Reply::Hello {
            version: VERSION,
            machine: "m",
            max_chunk: max_chunk as u16,
            period_ns,
        },
    };
    let mut out = [0u8; MAX_FRAME];
    for good in [chunk(0), chunk(MAX_CHUNK)] {
        let mut frame = framed_unchecked(&good);
        assert_eq!(decode::<HostFrame>(&mut frame), Ok(good));
        assert!(encode(&good, &mut out).is_ok());
    }
    let bad = chunk(MAX_CHUNK + 1);
    let mut frame = framed_unchecked(&bad);
    assert_eq!(decode::<HostFrame>(&mut frame), Err(FrameError::OutOfRange));
    assert_eq!(encode(&bad, &mut out), Err(FrameError::OutOfRange));
    for (max_chunk, period_ns, ok) in [
        (1, 1, true),
        (MAX_CHUNK, u32::MAX, true),
        (0, 100_000, false),
        (MAX_CHUNK + 1, 100_000, false),
        (MAX_CHUNK, 0, false),
    ] {
        let message = hello(max_chunk, period_ns);
        let mut frame = framed_unchecked(&message);
        let expected = if ok {
            Ok(message.clone())
        } else {
            Err(FrameError::OutOfRange)
        };
        assert_eq!(
            decode::<MachineMessage>(&mut frame),
            expected,
            "{message:?}"
        );
        assert_eq!(encode(&message, &mut out).map(|_| ()), expected.map(|_| ()));
    }
}

/// An entry written with `code_words`, as every machine's tables are, holds the code,
/// the words and the detail each in its own field; `find` finds it by its code only.
#[test]
fn a_table_written_with_code_words_is_found_by_code() {
    const TABLE: [CodeWords; 3] = [
        code_words(1, "the first", ""),
        code_words(7, "the seventh", "axis"),
        code_words(0x8000, "the last", "count"),
    ];
    let seventh = CodeWords::find(&TABLE, 7).unwrap();
    assert_eq!(
        (seventh.code, seventh.words, seventh.detail),
        (7, "the seventh", "axis")
    );
    assert_eq!(
        CodeWords::find(&TABLE, 0x8000),
        Some(&CodeWords {
            code: 0x8000,
            words: "the last",
            detail: "count",
        })
    );
    assert_eq!(CodeWords::find(&TABLE, 2), None);
}
