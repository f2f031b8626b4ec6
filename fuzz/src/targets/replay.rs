//! The slave's playout of the master's commands (`playout`) and the recording of a
//! remote run that the QEMU image replays (`replay_recording`, `KRFR`).

use crate::input::{same_bits, Input, Seed};
use crate::targets::stream::master_frames;
use kerf::app::playout::{Playing, Playout, PlayoutRejected, TICK_WINDOW};
use kerf::app::stream::MAX_FRAME_LEN;
use kerf::hal::FrameLink;
use kerf_sim::remote::{
    Recording, RecordingHeader, RecordingWriter, ReplayLink, RECORDING_HEADER_LEN,
};
use std::collections::HashMap;

/// The playout's queue in the harness: small, so that it fills.
const CAP: usize = 8;

/// Wrapping order of ticks, as the playout documents it.
fn after(a: u32, b: u32) -> bool {
    a.wrapping_sub(b).wrapping_sub(1) < 1 << 31
}

/// `playout`: a `Playout` of capacity 8 fed operations (one byte each, then its
/// fields): push a command of a tick, play the next period, let periods pass, restart.
/// What plays is a command that was pushed and accepted with that tick; a command
/// that starts is after the one before it (wrapping order: the playout never goes
/// back); a held command is the one before, held one period longer; the late count
/// never falls. Returns the commands that started.
pub fn playout(data: &[u8]) -> usize {
    let mut input = Input::new(data);
    let Some(margin) = input.u16() else {
        return 0;
    };
    let mut playout = Playout::<u32, CAP>::new(u32::from(margin));
    let mut accepted: HashMap<u32, u32> = HashMap::new();
    let (mut now, mut value, mut started) = (0u32, 0u32, 0);
    let mut playing: Option<(u32, u32)> = None;
    while let Some(op) = input.u8() {
        match op % 4 {
            0 => {
                let Some(tick) = input.u32() else { break };
                value += 1;
                let late = playout.late();
                match playout.push(now, tick, value) {
                    Ok(()) => {
                        accepted.insert(tick, value);
                        assert!(playout.offset().is_some());
                    }
                    Err(PlayoutRejected::Stale) => {
                        assert!(
                            playing.is_some_and(|(p, _)| !after(tick, p))
                                || accepted.contains_key(&tick)
                        );
                    }
                    Err(PlayoutRejected::Full) => {}
                    Err(PlayoutRejected::OutOfWindow) => {
                        let far =
                            |t: u32| t.wrapping_sub(tick).min(tick.wrapping_sub(t)) > TICK_WINDOW;
                        assert!(accepted.keys().any(|t| far(*t)));
                    }
                }
                assert!(playout.late() >= late);
            }
            1 => match playout.next(now) {
                Playing::Waiting => assert!(playing.is_none()),
                Playing::Command {
                    tick,
                    value,
                    held_periods,
                } => {
                    assert_eq!(
                        accepted.get(&tick),
                        Some(&value),
                        "tick {tick} never accepted so"
                    );
                    if held_periods == 0 {
                        if let Some((p, _)) = playing {
                            assert!(after(tick, p), "{tick} started after {p}");
                        }
                        playing = Some((tick, 0));
                        started += 1;
                    } else {
                        let (p, held) = playing.expect("something played before");
                        assert_eq!((tick, held_periods), (p, held + 1));
                        playing = Some((tick, held_periods));
                    }
                }
            },
            2 => {
                let Some(periods) = input.u16() else { break };
                now = now.wrapping_add(u32::from(periods));
                // The hold count runs on with every period played, not with time.
            }
            _ => {
                playout.restart();
                accepted.clear();
                playing = None;
            }
        }
    }
    started
}

/// Seeds of [`playout`]: a command a period with jitter, one lost, one late, one
/// duplicated, played as they come; then a restart.
pub fn playout_seeds() -> Vec<Vec<u8>> {
    let mut s = Seed::new().u16(3);
    let arrivals = [0u32, 1, 2, 4, 3, 5, 7, 7, 9, 12, 10, 11, 14];
    for (k, &tick) in arrivals.iter().enumerate() {
        s = s.u8(0).u32(tick + 1000).u8(1).u8(2).u16(1);
        if k % 4 == 3 {
            s = s.u8(1).u8(1);
        }
    }
    let across_wrap = Seed::new()
        .u16(1)
        .u8(0)
        .u32(u32::MAX - 1)
        .u8(0)
        .u32(u32::MAX)
        .u8(0)
        .u32(0)
        .u8(2)
        .u16(2)
        .u8(1)
        .u8(2)
        .u16(1)
        .u8(1)
        .u8(2)
        .u16(1)
        .u8(1)
        .u8(3)
        .u8(0)
        .u32(5)
        .u8(1);
    vec![s.0, across_wrap.0]
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap())
}

/// `replay_recording`: `Recording::parse`. A recording read gives every reference
/// back by its tick (bit for bit) and none for a tick it does not hold, delivers its
/// frames in arrival order, each no longer than a stream frame, and writing its
/// header, references and frames again gives the same bytes. Returns 1 and the
/// frames.
pub fn replay_recording(data: &[u8]) -> usize {
    let Ok(recording) = Recording::parse(data) else {
        return 0;
    };
    let mut writer = RecordingWriter::new(recording.header);
    let ticks = u32_at(data, 42) as usize;
    let references = &data[RECORDING_HEADER_LEN..RECORDING_HEADER_LEN + 16 * ticks];
    for r in references.chunks_exact(16) {
        let tick = u32_at(r, 0);
        let position: [f32; 3] = core::array::from_fn(|i| f32::from_bits(u32_at(r, 4 + 4 * i)));
        let found = recording
            .reference_m(tick)
            .expect("every reference is found");
        assert!(same_bits(&found, &position));
        assert!(writer.reference(tick, position), "ticks rise");
        if let Some(next) = tick.checked_add(1) {
            let held = references.chunks_exact(16).any(|q| u32_at(q, 0) == next);
            assert_eq!(recording.reference_m(next).is_some(), held);
        }
    }
    // The frames as the replay delivers them, each at its arrival period.
    let mut cursor = RECORDING_HEADER_LEN + 16 * ticks;
    let mut link = ReplayLink::new(recording);
    let mut buf = [0u8; MAX_FRAME_LEN];
    for _ in 0..recording.frame_count() {
        let arrival = u32_at(data, cursor);
        let len = usize::from(u16::from_le_bytes([data[cursor + 4], data[cursor + 5]]));
        assert!(len <= MAX_FRAME_LEN);
        link.now = arrival;
        let got = link
            .receive(&mut buf)
            .expect("the frame arrives at its period");
        assert_eq!(&buf[..got], &data[cursor + 6..cursor + 6 + len]);
        writer.frame(arrival, &buf[..got]);
        cursor += 6 + len;
    }
    link.now = u32::MAX;
    assert_eq!(link.receive(&mut buf), None, "no frame past the count");
    assert_eq!(writer.finish(), data, "the recording written again differs");
    1 + recording.frame_count() as usize
}

/// Seeds of [`replay_recording`]: a short recording of the master's frames as the
/// host scenario writes them, and one with no frames.
pub fn replay_recording_seeds() -> Vec<Vec<u8>> {
    let header = RecordingHeader {
        m: 8,
        samples_per_command: 1,
        margin_periods: 20,
        start_m: [0.0, 0.0, -0.25],
        laser_power_w: 10.0,
        approach_s: 0.3,
        periods: 200,
        measure_from: 50,
    };
    let mut writer = RecordingWriter::new(header);
    for tick in 100..104 {
        writer.reference(tick, [1e-3 * tick as f32, 0.0, -0.25]);
    }
    for (k, frame) in master_frames(7, 100, 3).iter().enumerate() {
        writer.frame(16 * k as u32 + 3, frame);
    }
    let empty = RecordingWriter::new(header);
    vec![writer.finish(), empty.finish()]
}
