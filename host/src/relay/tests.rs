//! Two machine ends (`kerf::app::lockstep`) in their own threads, each sending a frame
//! carrying its period every period, joined by the relay over socket pairs.

use super::*;
use kerf::app::lockstep::LockstepEnd;
use kerf::hal::FrameLink;
use std::os::unix::net::UnixStream;
use std::thread;

/// A machine of `periods` periods: (period received, period sent) of every frame.
fn machine(stream: UnixStream, periods: u32) -> thread::JoinHandle<Vec<(u32, u32)>> {
    thread::spawn(move || {
        let mut reader = stream.try_clone().unwrap();
        let mut writer = stream;
        let mut end = LockstepEnd::<8, 64>::new();
        let mut received = Vec::new();
        let mut buf = [0u8; 256];
        while end.tick() < periods {
            let mut write = |b: &[u8]| writer.write_all(b).unwrap();
            if !end.may_run(&mut write) {
                let n = reader.read(&mut buf).unwrap();
                end.feed(&buf[..n]);
                continue;
            }
            let tick = end.tick();
            let mut link = end.link(&mut write);
            let mut frame = [0u8; 4];
            while let Some(4) = link.receive(&mut frame) {
                received.push((tick, u32::from_le_bytes(frame)));
            }
            link.send(&tick.to_le_bytes()).unwrap();
            end.end_period();
        }
        // The last wait, so the relay's round ends; then what the relay still carries,
        // until it closes the port.
        end.may_run(&mut |b| writer.write_all(b).unwrap());
        while reader.read(&mut buf).is_ok_and(|n| n > 0) {}
        received
    })
}

/// Runs two machines through `rounds` rounds of the relay.
fn pair(profile: &NetworkProfile, rounds: u32) -> (Relay, [Vec<(u32, u32)>; 2]) {
    let mut relay = Relay::new(profile, 1e-3).unwrap();
    let periods = rounds * relay.round_periods();
    let (mut a, a_end) = UnixStream::pair().unwrap();
    let (mut b, b_end) = UnixStream::pair().unwrap();
    let machines = [machine(a_end, periods), machine(b_end, periods)];
    for _ in 0..rounds {
        relay.round(&mut a, &mut b).unwrap();
    }
    drop((a, b));
    let [x, y] = machines.map(|m| m.join().unwrap());
    (relay, [x, y])
}

/// A constant 5 ms at 1 kHz: every frame arrives exactly 5 periods after it was sent,
/// none lost, in rounds of 5 periods.
#[test]
fn a_constant_delay_is_exact_between_two_threads() {
    let profile = NetworkProfile {
        delay_ms: 5,
        jitter_ms: 0,
        loss: 0.0,
        seed: 1,
    };
    let (relay, received) = pair(&profile, 40);
    assert_eq!((relay.round_periods(), relay.periods()), (5, 200));
    for r in &received {
        assert_eq!(r.len(), 195);
        assert!(r.iter().all(|(at, sent)| at - sent == 5), "{r:?}");
    }
    assert_eq!(relay.counts()[0].frames, 200);
    assert_eq!(relay.counts()[0].bytes, 800);
}

/// 20 ± 10 ms and 5 % loss: rounds of 10 periods, every delay in [10, 30], frames in
/// order, the losses the relay counts missing from what arrived, and the loss near 5 %
/// (drawn by the scenarios' link model, seeded).
#[test]
fn a_jittering_lossy_link_keeps_its_bounds_and_order() {
    let profile = NetworkProfile {
        delay_ms: 20,
        jitter_ms: 10,
        loss: 0.05,
        seed: 7,
    };
    let (relay, received) = pair(&profile, 200);
    assert_eq!(relay.round_periods(), 10);
    for (k, r) in received.iter().enumerate() {
        assert!(r.iter().all(|(at, sent)| (10..=30).contains(&(at - sent))));
        assert!(r.windows(2).all(|w| w[0].1 < w[1].1));
        let counts = relay.counts()[1 - k];
        // Frames still in flight at the end arrive in no period.
        let in_flight = counts.frames - counts.lost - r.len() as u64;
        assert!(in_flight <= 30, "{in_flight}");
        let loss = counts.lost as f64 / counts.frames as f64;
        // Within four standard deviations of 5 % over 2,000 frames (0.49 %).
        assert!((0.03..0.07).contains(&loss), "{loss}");
    }
}

#[test]
fn a_profile_that_cannot_be_drawn_is_refused_in_words() {
    let bad = |delay_ms, jitter_ms, loss| {
        let profile = NetworkProfile {
            delay_ms,
            jitter_ms,
            loss,
            seed: 0,
        };
        Relay::new(&profile, 1e-3).err().map(|e| e.to_string())
    };
    assert_eq!(
        bad(10, 20, 0.0).as_deref(),
        Some("network profile: the jitter is larger than the delay")
    );
    assert_eq!(
        bad(10, 0, 1.5).as_deref(),
        Some("network profile: the loss is not a probability")
    );
    assert!(bad(0, 0, 0.0).is_none());
    let closed = Relay::new(
        &NetworkProfile {
            delay_ms: 1,
            jitter_ms: 0,
            loss: 0.0,
            seed: 0,
        },
        1e-3,
    );
    let (mut a, a_end) = UnixStream::pair().unwrap();
    drop(a_end);
    let (mut b, _b_end) = UnixStream::pair().unwrap();
    let e = closed
        .unwrap()
        .round(&mut a, &mut b)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("the first machine's network port"), "{e}");
}
