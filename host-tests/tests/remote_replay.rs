//! The slave side of remote machining fed by recorded master frames (the QEMU
//! image replays them). The host's closed-loop scenario records what reached its slave
//! (`kerf_sim::remote::Recording`); the recording is kept in the repository, because
//! the QEMU image includes it, and must equal what the scenario records today. The
//! replay runs here in f64 and in the image in f32; `scripts/smoke` compares the two.
//!
//! Regenerate the recording after a change to the master, the link or the scenario:
//! `KERF_RECORD_REMOTE=1 cargo test -p host-tests --test remote_replay`.

use host_tests::remote::{run, RemoteCase, TS};
use kerf_sim::remote::{
    replay, Recording, RecordingError, RemoteSimError, REPLAY_BOUNDS_M, REPLAY_F32_TOLERANCE_M,
};
use std::path::PathBuf;

/// The recorded case: the nominal scenario (20 ± 10 ms, observer on, scale 0.5),
/// shortened to what the emulated CPU replays in under a minute.
fn recorded_case() -> RemoteCase {
    RemoteCase {
        seconds: 4.0,
        ..RemoteCase::nominal()
    }
}

fn recording_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/remote_commands.krfr")
}

fn stored() -> Vec<u8> {
    std::fs::read(recording_path())
        .unwrap_or_else(|e| panic!("{}: {e}", recording_path().display()))
}

#[test]
fn the_stored_recording_is_what_the_scenario_records_and_replays_like_it() {
    let case = recorded_case();
    let closed = run(&case).unwrap_or_else(|e| panic!("{e:?}"));
    if std::env::var_os("KERF_RECORD_REMOTE").is_some() {
        std::fs::write(recording_path(), &closed.recording).expect("write the recording");
    }
    let bytes = stored();
    assert!(
        bytes == closed.recording,
        "{} is stale: regenerate it with KERF_RECORD_REMOTE=1 cargo test -p host-tests --test remote_replay",
        recording_path().display()
    );
    let recording = Recording::parse(&bytes).expect("the stored recording parses");
    let (closed_max, closed_rms) = closed
        .tracking_m(f64::from(recording.header.measure_from) * TS)
        .expect("the closed loop followed");
    let r = replay::<f64>(&bytes).unwrap_or_else(|e| panic!("{e:?}"));
    // The line scripts/smoke compares with the QEMU image's (nanometres).
    println!(
        "host remote replay (f64): {} periods, {} frames, tracking max {} rms {} (nm)",
        r.periods,
        r.frames,
        (r.max_m * 1e9).round(),
        (r.rms_m * 1e9).round()
    );
    println!(
        "closed loop: tracking max {:.1} rms {:.1} µm; replay {:.1} / {:.1} µm; {} bytes, {} frames",
        closed_max * 1e6,
        closed_rms * 1e6,
        r.max_m * 1e6,
        r.rms_m * 1e6,
        bytes.len(),
        recording.frame_count()
    );
    assert_eq!(r.fault, None);
    assert_eq!(r.frames, recording.frame_count(), "every frame delivered");
    assert_eq!((r.refused, r.late), (0, 0));
    let measured = recording.header.periods - recording.header.measure_from;
    assert!(
        r.periods + 10 * 16 >= measured,
        "{} of {measured} periods measured",
        r.periods
    );
    assert!(
        r.max_m < REPLAY_BOUNDS_M.0 && r.rms_m < REPLAY_BOUNDS_M.1,
        "{r:?}"
    );
    // The replayed slave's inputs are the recorded slave's, so in f64 it repeats that
    // slave: the figures differ only by the references' rounding to f32 (ulp of
    // 60 mm = 3.7 nm).
    for (replayed, closed) in [(r.max_m, closed_max), (r.rms_m, closed_rms)] {
        assert!(
            (replayed - closed).abs() < 10e-9,
            "replay {replayed} m against closed loop {closed} m"
        );
    }
}

#[test]
fn bad_recordings_get_typed_errors() {
    let bytes = stored();
    let header_len = kerf_sim::remote::RECORDING_HEADER_LEN;
    let error = |b: &[u8]| match replay::<f32>(b) {
        Err(RemoteSimError::Recording(e)) => e,
        other => panic!("{other:?}"),
    };
    assert_eq!(error(&[]), RecordingError::Magic);
    assert_eq!(error(b"KRFX\x01\x00"), RecordingError::Magic);
    let mut version = bytes.clone();
    version[4] = 9;
    assert_eq!(error(&version), RecordingError::Version(9));
    let mut block = bytes.clone();
    block[7] = 8;
    assert_eq!(error(&block), RecordingError::Block(8));
    assert_eq!(
        error(&bytes[..header_len - 1]),
        RecordingError::Truncated(0)
    );
    // Cut inside the last frame, and one byte too many.
    let frames = Recording::parse(&bytes).unwrap().frame_count();
    assert_eq!(
        error(&bytes[..bytes.len() - 1]),
        RecordingError::Truncated(frames - 1)
    );
    let mut longer = bytes.clone();
    longer.push(0);
    assert_eq!(error(&longer), RecordingError::TrailingBytes);
    // The first frame's arrival moved past the second's.
    let ticks = u32::from_le_bytes(bytes[42..46].try_into().unwrap()) as usize;
    let first = header_len + 16 * ticks;
    let mut order = bytes.clone();
    order[first..first + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    assert_eq!(error(&order), RecordingError::OutOfOrder(1));
    // A frame's length beyond what a frame can be.
    let mut long = bytes.clone();
    long[first + 4..first + 6].copy_from_slice(&u16::MAX.to_le_bytes());
    assert!(matches!(
        error(&long),
        RecordingError::FrameTooLong(0) | RecordingError::Truncated(0)
    ));
}

#[test]
fn a_corrupt_recorded_frame_is_refused_and_the_slave_follows_on() {
    // A byte flipped inside a frame's payload: the link refuses the frame (its CRC),
    // the slave holds the last command through the block it lost and follows on, no
    // fault. Open loop nothing corrects the block's 16 lost commands, so its tracking
    // error grows (printed); closed, the master's observer takes the difference up
    // (remote_machining's 1 % loss case).
    let mut bytes = stored();
    let frames = Recording::parse(&bytes).unwrap().frame_count();
    let ticks = u32::from_le_bytes(bytes[42..46].try_into().unwrap()) as usize;
    let mut at = kerf_sim::remote::RECORDING_HEADER_LEN + 16 * ticks;
    // The 100th frame, past the start.
    for _ in 0..100 {
        let len = u16::from_le_bytes(bytes[at + 4..at + 6].try_into().unwrap()) as usize;
        at += 6 + len;
    }
    let len = u16::from_le_bytes(bytes[at + 4..at + 6].try_into().unwrap()) as usize;
    bytes[at + 6 + len / 2] ^= 0x5a;
    let r = replay::<f64>(&bytes).unwrap_or_else(|e| panic!("{e:?}"));
    assert_eq!(r.frames, frames);
    assert_eq!(r.refused, 1, "{r:?}");
    assert_eq!(r.fault, None, "{r:?}");
    println!(
        "one corrupt frame: refused {}, tracking max {:.1} rms {:.1} µm",
        r.refused,
        r.max_m * 1e6,
        r.rms_m * 1e6
    );
}

#[test]
fn the_f32_slave_replays_within_its_tolerance_of_the_f64_one() {
    // What scripts/smoke checks against the emulated MCU, here on the host's f32.
    let bytes = stored();
    let (wide, narrow) = (
        replay::<f64>(&bytes).unwrap_or_else(|e| panic!("{e:?}")),
        replay::<f32>(&bytes).unwrap_or_else(|e| panic!("{e:?}")),
    );
    println!(
        "f32 against f64: max {:.1} against {:.1} nm, RMS {:.1} against {:.1} nm",
        narrow.max_m * 1e9,
        wide.max_m * 1e9,
        narrow.rms_m * 1e9,
        wide.rms_m * 1e9
    );
    assert_eq!(
        (narrow.fault, narrow.frames, narrow.refused),
        (None, wide.frames, 0)
    );
    assert!((narrow.max_m - wide.max_m).abs() < REPLAY_F32_TOLERANCE_M);
    assert!((narrow.rms_m - wide.rms_m).abs() < REPLAY_F32_TOLERANCE_M);
}
