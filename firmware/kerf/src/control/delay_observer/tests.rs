//! The observer on a simulated link: the master circles at 10 mm/s, packets go out at
//! 1 kHz and come back with the slave's measured position after a delay the observer
//! is never told; the "true" slave runs the tracking law on the newest master packet
//! it has, with a disturbance the model lacks (a constant push, like friction or an
//! unknown load).

use super::*;
extern crate std;
use std::collections::VecDeque;
use std::println;

const TS: f64 = 1e-4;
const PACKET_PERIODS: u32 = 10;
const SPEED_M_S: f64 = 0.01;
const RADIUS_M: f64 = 0.01;
const SCALE: f64 = 0.5;
const CM: [f64; 3] = [0.0, 0.0, 0.1];
const CS: [f64; 3] = [0.0, 0.0, 0.05];

fn tracking() -> BilateralConfig {
    BilateralConfig::critically_damped(SCALE, CM, CS, 2.0 * core::f64::consts::PI * 30.0)
}

fn master_at(t: f64) -> MasterState<f64> {
    let w = SPEED_M_S / RADIUS_M;
    let (s, c) = (w * t).sin_cos();
    MasterState {
        position: Vector3::new(CM[0] + RADIUS_M * c, CM[1] + RADIUS_M * s, CM[2]),
        velocity: Vector3::new(-SPEED_M_S * s, SPEED_M_S * c, 0.0),
        acceleration: Vector3::new(-SPEED_M_S * w * c, -SPEED_M_S * w * s, 0.0),
    }
}

/// Delay of packet `n` in periods: `base` ± `jitter` (deterministic pseudo-random).
fn delay(n: u64, base: u32, jitter: u32) -> u32 {
    if jitter == 0 {
        return base;
    }
    let x = n
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407)
        >> 33;
    base - jitter + (x % u64::from(2 * jitter + 1)) as u32
}

/// Runs 2 s. The estimate is the slave's delay-free response: the slave's reference
/// for the present master state plus what the model misses (the push's steady
/// offset push/λK). Returns the largest deviation from that over the last second of the
/// observer's estimate and of the newest raw measurement, and the observer.
fn run(
    forward: (u32, u32),
    backward: (u32, u32),
    start_tick: u32,
) -> (f64, f64, DelayObserver<f64, 256>) {
    let config = DelayObserverConfig {
        tracking: tracking(),
        period_s: TS,
        correction_bandwidth_rad_s: 2.0 * core::f64::consts::PI * 2.0,
    };
    let mut observer = DelayObserver::<f64, 256>::new(&config, master_at(0.0).position).unwrap();
    observer.tick = start_tick;
    let law = Bilateral::<f64>::new(&tracking()).unwrap();
    let (kp, kd) = law.gains();
    // The true slave: the same law on the newest master packet, plus a push.
    let push = Vector3::new(3.0, -2.0, 1.0);
    let offset = push / kp;
    let mut xs = law.slave_reference(&master_at(0.0)).position;
    let mut vs = Vector3::zeros();
    let mut applied: Option<(u32, MasterState<f64>)> = None;
    let mut to_slave: VecDeque<(u32, u32, MasterState<f64>)> = VecDeque::new(); // (arrive, tick, state)
    let mut to_master: VecDeque<(u32, u32, Vector3<f64>)> = VecDeque::new(); // (arrive, echo, xs)
    let mut raw: Option<Vector3<f64>> = None;
    let (mut worst_estimate, mut worst_raw) = (0.0f64, 0.0f64);
    let mut packets = 0u64;
    for k in 0..20_000u32 {
        let t = f64::from(k + 1) * TS;
        let master = master_at(t);
        let tick = observer.step(&master);
        if k % PACKET_PERIODS == 0 {
            observer.sent();
            packets += 1;
            let d = delay(packets, forward.0, forward.1);
            to_slave.push_back((k + d, tick, master));
        }
        // Packets may overtake each other under jitter: the slave applies the newest.
        for &(arrive, tick, state) in to_slave.iter() {
            if arrive == k && applied.is_none_or(|(t, _)| tick.wrapping_sub(t) < 1 << 31) {
                applied = Some((tick, state));
            }
        }
        to_slave.retain(|p| p.0 > k);
        if let Some((_, m)) = applied {
            let r = law.slave_reference(&m);
            let a = r.acceleration + (r.velocity - vs) * kd + (r.position - xs) * kp + push;
            vs += a * TS;
            xs += vs * TS;
        }
        if k % PACKET_PERIODS == 5 {
            if let Some((echo, _)) = applied {
                let d = delay(packets + 1_000_000, backward.0, backward.1);
                to_master.push_back((k + d, echo, xs));
            }
        }
        for &(arrive, echo, position) in to_master.iter() {
            if arrive == k {
                observer.received(echo, &position).unwrap();
                raw = Some(position);
            }
        }
        to_master.retain(|p| p.0 > k);
        if k >= 10_000 {
            let delay_free = law.slave_reference(&master).position + offset;
            worst_estimate = worst_estimate.max((observer.estimate() - delay_free).amax());
            if let Some(r) = raw {
                worst_raw = worst_raw.max((r - delay_free).amax());
            }
        }
    }
    (worst_estimate, worst_raw, observer)
}

#[test]
fn the_estimate_is_the_delay_free_slave_whatever_the_delay() {
    for (name, forward, backward) in [
        ("no delay", (0, 0), (0, 0)),
        ("20 ms each way", (200, 0), (200, 0)),
        ("20 ± 10 ms each way", (200, 100), (200, 100)),
    ] {
        let (estimate, raw, observer) = run(forward, backward, 0);
        println!(
            "{name}: estimate off by {:.2} µm, newest measurement by {:.2} µm, round trip {} periods",
            estimate * 1e6,
            raw * 1e6,
            observer.round_trip_periods()
        );
        assert_eq!(observer.rejected(), 0);
        // The slave moves at 5 mm/s: the 1 kHz packets' hold is 5 µm per packet period,
        // and under jitter the slave's lag varies by ±10 ms (±50 µm) about the mean the
        // correction has learnt; the push's 84 µm offset is found in every case.
        let bound = if forward.1 > 0 { 60e-6 } else { 10e-6 };
        assert!(estimate < bound, "{name}: {estimate}");
        if forward.0 > 0 {
            // The raw measurement is a round trip and the forward delay old (60 ms at
            // 5 mm/s: 300 µm).
            assert!(raw > 4.0 * estimate, "{name}: {raw} against {estimate}");
        }
    }
}

#[test]
fn the_tick_wraps_without_a_jump() {
    // Start 0.5 s before the u32 tick wraps: the run crosses it.
    let (wrapped, _, observer) = run((200, 100), (200, 100), u32::MAX - 5_000);
    let (plain, _, _) = run((200, 100), (200, 100), 0);
    assert_eq!(observer.rejected(), 0);
    assert!((wrapped - plain).abs() < 1e-12, "{wrapped} against {plain}");
}

#[test]
fn stale_unknown_and_bad_echoes_are_rejected_and_counted() {
    let config = DelayObserverConfig {
        tracking: tracking(),
        period_s: TS,
        correction_bandwidth_rad_s: 10.0,
    };
    let mut observer = DelayObserver::<f64, 4>::new(&config, master_at(0.0).position).unwrap();
    let mut ticks = std::vec::Vec::new();
    for k in 0..6 {
        ticks.push(observer.step(&master_at(f64::from(k) * TS)));
        observer.sent();
    }
    let here = observer.estimate();
    // The two oldest fell out of the 4-entry history; a tick never sent; a NaN.
    assert_eq!(
        observer.received(ticks[0], &here),
        Err(EchoRejected::NotInHistory)
    );
    assert_eq!(
        observer.received(12345, &here),
        Err(EchoRejected::NotInHistory)
    );
    let bad = Vector3::new(f64::NAN, 0.0, 0.0);
    assert_eq!(
        observer.received(ticks[5], &bad),
        Err(EchoRejected::NotFinite)
    );
    assert_eq!(observer.rejected(), 3);
    assert_eq!(observer.estimate(), here);
    assert!(observer.received(ticks[5], &here).is_ok());
    // Config errors are named.
    let mut c = config;
    c.correction_bandwidth_rad_s = f64::NAN;
    assert!(DelayObserver::<f32, 4>::new(&c, Vector3::zeros()).is_err());
}
