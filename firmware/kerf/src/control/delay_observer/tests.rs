//! The observer on a simulated link: the master circles at 10 mm/s, commands go out at
//! 1 kHz and the slave's measured position comes back after a delay the observer is
//! never told; the "true" slave executes the newest command it has, with a disturbance
//! the model lacks (a constant push, like friction or an unknown load).

use super::*;
use crate::app::playout::{Playing, Playout};
use crate::control::bilateral::{Bilateral, BilateralConfig, MasterState};
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

/// What a run measured over its last second.
struct Run {
    /// Largest |s·(xm(tick) − cm) + cs − xs| with tick the master period of the command
    /// the slave is executing: the tracking error with the forward delay taken out, m.
    tracking: f64,
    observer: DelayObserver<f64, 256>,
}

/// Runs 2 s of T's loop (module docs): the master computes the slave's command
/// at 1 kHz from the estimate (`with_observer`) or from the newest measurement that
/// came back, holds it for the packet period and sends it; the slave executes the
/// newest command that has arrived, with a push its model lacks, and reports its
/// position and velocity with the command's tick.
fn run(forward: (u32, u32), backward: (u32, u32), start_tick: u32, with_observer: bool) -> Run {
    let config = DelayObserverConfig {
        period_s: TS,
        correction_bandwidth_rad_s: 2.0 * core::f64::consts::PI * 5.0,
    };
    let law = Bilateral::<f64>::new(&tracking()).unwrap();
    let start = law.slave_reference(&master_at(0.0)).position;
    let mut observer = DelayObserver::<f64, 256>::new(&config, start).unwrap();
    observer.tick = start_tick;
    // The true slave: a double integrator pushed by a constant load (m/s²) that its
    // disturbance observer (300 rad/s) cancels — after a transient that leaves it a
    // velocity offset of push/g the model knows nothing of.
    let push = Vector3::new(3.0, -2.0, 1.0);
    let mut push_estimate = Vector3::zeros();
    let (mut xs, mut vs) = (start, Vector3::zeros());
    let mut executing: Option<(u32, Vector3<f64>)> = None;
    // The margin: one and a half times the jitter's half-width (none without jitter).
    let mut playout = Playout::<Vector3<f64>, 64>::new(forward.1 * 3 / 2);
    let mut to_slave: VecDeque<(u32, u32, Vector3<f64>)> = VecDeque::new(); // (arrive, tick, u)
    let mut to_master: VecDeque<(u32, u32, Vector3<f64>, Vector3<f64>)> = VecDeque::new();
    let mut measured = (start, Vector3::zeros());
    let mut command = Vector3::zeros();
    let mut ticks = std::collections::HashMap::new();
    let mut tracking = 0.0f64;
    let mut packets = 0u64;
    for k in 0..20_000u32 {
        let t = f64::from(k) * TS;
        if k % PACKET_PERIODS == 0 {
            let (x, v) = if with_observer {
                observer.estimate()
            } else {
                measured
            };
            command = law.task_acceleration(&master_at(t), &x, &v).0;
        }
        let tick = observer.step(&command);
        ticks.insert(tick, t);
        if k % PACKET_PERIODS == 0 {
            observer.sent();
            packets += 1;
            let d = delay(packets, forward.0, forward.1);
            to_slave.push_back((k + d, tick, command));
        }
        // Packets may overtake each other under jitter: the slave's playout puts them
        // back in order, 15 ms behind the first one's delay when there is jitter (one
        // overtaken by a newer one that has already played is stale and dropped).
        for &(arrive, tick, u) in to_slave.iter() {
            if arrive == k {
                let _ = playout.push(k, tick, u);
            }
        }
        to_slave.retain(|p| p.0 > k);
        if let Playing::Command { tick, value, .. } = playout.next(k) {
            executing = Some((tick, value));
        }
        if let Some((_, u)) = executing {
            vs += (u + push - push_estimate) * TS;
            xs += vs * TS;
            push_estimate += (push - push_estimate) * (300.0 * TS);
        }
        if k % PACKET_PERIODS == 5 {
            if let Some((echo, _)) = executing {
                let d = delay(packets + 1_000_000, backward.0, backward.1);
                to_master.push_back((k + d, echo, xs, vs));
            }
        }
        for &(arrive, echo, position, velocity) in to_master.iter() {
            if arrive == k {
                // Under jitter a report can be overtaken: the observer drops it.
                if observer.received(echo, &position).is_ok() || !with_observer {
                    measured = (position, velocity);
                }
            }
        }
        to_master.retain(|p| p.0 > k);
        if let (true, Some((tick, _))) = (k >= 10_000, executing) {
            let reference = law.slave_reference(&master_at(ticks[&tick])).position;
            tracking = tracking.max((reference - xs).amax());
        }
    }
    Run { tracking, observer }
}

#[test]
fn the_observer_keeps_the_delayed_loop_tracking() {
    for (name, forward, backward) in [
        ("no delay", (0, 0), (0, 0)),
        ("20 ms each way", (200, 0), (200, 0)),
        ("20 ± 10 ms each way", (200, 100), (200, 100)),
    ] {
        let with = run(forward, backward, 0, true);
        let without = run(forward, backward, 0, false);
        println!(
            "{name}: tracking error {:.2} µm with the observer, {:.2} µm without, round trip {} periods",
            with.tracking * 1e6,
            without.tracking * 1e6,
            with.observer.round_trip_periods()
        );
        if backward.1 == 0 {
            assert_eq!(with.observer.rejected(), 0);
        }
        // The slave moves at 5 mm/s. What is left with the observer is the command's
        // 1 ms hold (5 µm of motion, the law's error a fraction of it) and, under
        // jitter, the rare command that came later than the playout's margin.
        assert!(with.tracking < 10e-6, "{name}: {}", with.tracking);
        if forward.0 > 0 {
            // Without it the 40 ms round trip sits inside a 30 Hz loop.
            assert!(
                without.tracking.is_nan() || without.tracking >= 10.0 * with.tracking,
                "{name}: {} against {}",
                without.tracking,
                with.tracking
            );
        } else {
            // Without delay the two agree up to the push, which only the observer's
            // correction cancels (offset push/λK ≈ 84 µm without it).
            assert!(without.tracking < 120e-6, "{name}: {}", without.tracking);
        }
    }
}

#[test]
fn the_tick_wraps_without_a_jump() {
    // Start 0.5 s before the u32 tick wraps: the run crosses it.
    let wrapped = run((200, 100), (200, 100), u32::MAX - 5_000, true);
    let plain = run((200, 100), (200, 100), 0, true);
    assert_eq!(wrapped.observer.rejected(), plain.observer.rejected());
    assert!(
        (wrapped.tracking - plain.tracking).abs() < 1e-12,
        "{} against {}",
        wrapped.tracking,
        plain.tracking
    );
}

#[test]
fn stale_unknown_and_bad_echoes_are_rejected_and_counted() {
    let config = DelayObserverConfig {
        period_s: TS,
        correction_bandwidth_rad_s: 10.0,
    };
    let mut observer = DelayObserver::<f64, 4>::new(&config, Vector3::from(CS)).unwrap();
    let mut ticks = std::vec::Vec::new();
    for k in 0..6 {
        ticks.push(observer.step(&Vector3::new(0.1 * f64::from(k), 0.0, 0.0)));
        observer.sent();
    }
    let here = observer.estimate().0;
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
    assert_eq!(observer.estimate().0, here);
    assert!(observer.received(ticks[5], &here).is_ok());
    // Config errors are named.
    let mut c = config;
    c.correction_bandwidth_rad_s = f64::NAN;
    assert!(DelayObserver::<f32, 4>::new(&c, Vector3::zeros()).is_err());
}
