//! T's remote loop (T 5.3.2, 7.2.3) end to end over the simulated network: the
//! master side computes the slave's task-space command from the delay observer's
//! estimate and sends it as SDCT frames (three channels, blocks of N samples at 1 kHz,
//! the packet's first-sample index the master's clock); the slave side decodes them,
//! plays them out in order and executes them under its disturbance observer, and
//! reports its position back the same way with the tick of the command it was
//! executing in the frame's header. The two sides share nothing but the two
//! `hal_mock::link::FrameEnd`s.
//!
//! The slave here is the nominal plant its disturbance observer makes of it (a double
//! integrator per task axis, 300 rad/s observer against a constant load): the law and
//! the link alone. `remote_machining` runs the two delta machines over the same link.
//!
//! Run with `--nocapture` for the table.

use hal_mock::link::FrameEnd;
use host_tests::remote::Network;
use kerf::app::playout::{Playing, Playout};
use kerf::app::stream::{StreamReceiver, StreamSender, FRAME_CRC_LEN, MAX_FRAME_LEN};
use kerf::codec::sdct::{SdctConfig, Selection};
use kerf::control::bilateral::{Bilateral, BilateralConfig, MasterState};
use kerf::control::delay_observer::{DelayObserver, DelayObserverConfig};
use nalgebra::Vector3;

const TS: f64 = 1e-4;
/// Control periods per link sample (1 kHz samples at 10 kHz control).
const D: u32 = 10;
const N: usize = 16;
const SCALE: f64 = 0.5;
const CM: [f64; 3] = [0.0, 0.0, 0.1];
const CS: [f64; 3] = [0.0, 0.0, 0.05];
/// 8 s: the last 4 are measured.
const PERIODS: u32 = 80_000;

/// The operator's master motion: a 20 mm circle at a speed that swings between 5 and
/// 15 mm/s, with a 10 Hz, 20 µm tremor across it.
fn master_at(t: f64) -> MasterState<f64> {
    let r = 0.02;
    // Phase φ(t) with φ̇ = (10 + 5 sin 0.7t) mm/s / r.
    let phase = (0.010 * t - 0.005 / 0.7 * ((0.7 * t).cos() - 1.0)) / r;
    let rate = (0.010 + 0.005 * (0.7 * t).sin()) / r;
    let rate_dot = 0.005 * 0.7 * (0.7 * t).cos() / r;
    let w = 2.0 * std::f64::consts::PI * 10.0;
    let tremor = 20e-6 * (w * t).sin();
    let (s, c) = phase.sin_cos();
    let radius = r + tremor;
    let radius_dot = 20e-6 * w * (w * t).cos();
    let radius_ddot = -20e-6 * w * w * (w * t).sin();
    MasterState {
        position: Vector3::new(CM[0] + radius * c, CM[1] + radius * s, CM[2]),
        velocity: Vector3::new(
            radius_dot * c - radius * rate * s,
            radius_dot * s + radius * rate * c,
            0.0,
        ),
        acceleration: Vector3::new(
            radius_ddot * c
                - 2.0 * radius_dot * rate * s
                - radius * (rate_dot * s + rate * rate * c),
            radius_ddot * s
                + 2.0 * radius_dot * rate * c
                + radius * (rate_dot * c - rate * rate * s),
            0.0,
        ),
    }
}

#[derive(Clone, Copy)]
struct Case {
    name: &'static str,
    delay_ms: u32,
    jitter_ms: u32,
    loss: f64,
    observer: bool,
    m: usize,
}

struct Outcome {
    /// Largest |s(xm(tick) − cm) + cs − xs| over the last 4 s, tick = the command being
    /// executed: the tracking error with the forward latency taken out, m.
    tracking_m: f64,
    /// Frame bytes per second, master → slave and back.
    bytes_per_s: [f64; 2],
    /// The playout's latency behind the master's clock, ms.
    latency_ms: f64,
    late: u32,
    lost_frames: u64,
}

fn link(case: &Case, seed: u64) -> FrameEnd<MAX_FRAME_LEN, 256> {
    let network = Network {
        delay_ms: case.delay_ms,
        jitter_ms: case.jitter_ms,
        loss: case.loss,
    };
    FrameEnd::new(&network.link_config(seed)).unwrap()
}

fn run(case: &Case) -> Outcome {
    let tracking =
        BilateralConfig::critically_damped(SCALE, CM, CS, 2.0 * std::f64::consts::PI * 5.0);
    let law = Bilateral::<f64>::new(&tracking).unwrap();
    let sdct = SdctConfig {
        m: case.m,
        selection: Selection::Largest,
    };
    let mut forward = link(case, 1);
    let mut backward = link(case, 2);

    // The master side.
    let start = law.slave_reference(&master_at(0.0)).position;
    let mut observer = DelayObserver::<f64, 512>::new(
        &DelayObserverConfig {
            period_s: TS,
            correction_bandwidth_rad_s: 2.0 * std::f64::consts::PI * 5.0,
        },
        start,
    )
    .unwrap();
    let mut commands = StreamSender::<3, N>::new(&sdct).unwrap();
    let mut reports_in = StreamReceiver::<3, N>::new().unwrap();
    let mut measured = (start, Vector3::zeros());
    let mut command = Vector3::zeros();
    let mut tick_time = std::collections::HashMap::new();
    let mut bytes = [0usize; 2];

    // The slave side.
    let mut commands_in = StreamReceiver::<3, N>::new().unwrap();
    let margin = case.jitter_ms * 10 * 3 / 2 + 5;
    let mut playout = Playout::<Vector3<f32>, 256>::new(margin);
    let mut reports = StreamSender::<3, N>::new(&sdct).unwrap();
    let push = Vector3::new(3.0, -2.0, 1.0);
    let (mut xs, mut vs, mut push_estimate) = (start, Vector3::zeros(), Vector3::zeros());
    let mut executing: Option<u32> = None;

    let mut tracking_m = 0.0f64;
    for k in 0..PERIODS {
        let t = f64::from(k) * TS;
        forward.set_now(u64::from(k));
        backward.set_now(u64::from(k));
        // Master: a new command every link sample, from the estimate or the newest
        // report; the model executes it; the sample goes into the frame.
        if k % D == 0 {
            let (x, v) = if case.observer {
                observer.estimate()
            } else {
                measured
            };
            command = law.task_acceleration(&master_at(t), &x, &v).0;
        }
        let tick = observer.step(&command);
        if k % D == 0 {
            tick_time.insert(tick, t);
            observer.sent();
            let sample = [command.x, command.y, command.z].map(|c| c as f32);
            let _ = commands.push_frame(sample, &[], &mut Counted(&mut forward, &mut bytes[0]));
        }
        let mut header = [0u8; 4];
        let mut block = [[0.0f32; N]; 3];
        while let Some(frame) = reports_in.poll_frame(&mut backward, &mut header, &mut block) {
            let Ok(_) = frame else { continue };
            let echo = u32::from_le_bytes(header);
            let last = |b: &[[f32; N]; 3], i: usize| {
                Vector3::new(b[0][i], b[1][i], b[2][i]).map(f64::from)
            };
            let position = last(&block, N - 1);
            let velocity = (position - last(&block, N - 2)) / (f64::from(D) * TS);
            if observer.received(echo, &position).is_ok() || !case.observer {
                measured = (position, velocity);
            }
        }

        // Slave: frames into the playout (sample j of a block is master tick
        // (first + j)·D + 1, the tick the observer gave it).
        while let Some(frame) = commands_in.poll_frame(&mut forward, &mut [], &mut block) {
            let Ok(received) = frame else { continue };
            let [bx, by, bz] = &block;
            for (j, ((x, y), z)) in bx.iter().zip(by).zip(bz).enumerate() {
                let sample_tick = ((received.first_sample + j as u64) as u32)
                    .wrapping_mul(D)
                    .wrapping_add(1);
                let _ = playout.push(k, sample_tick, Vector3::new(*x, *y, *z));
            }
        }
        if let Playing::Command { tick, value, .. } = playout.next(k) {
            executing = Some(tick);
            let u = value.map(f64::from);
            vs += (u + push - push_estimate) * TS;
            xs += vs * TS;
            push_estimate += (push - push_estimate) * (300.0 * TS);
        }
        if k % D == 5 {
            if let Some(echo) = executing {
                let sample = [xs.x, xs.y, xs.z].map(|c| c as f32);
                let _ = reports.push_frame(
                    sample,
                    &echo.to_le_bytes(),
                    &mut Counted(&mut backward, &mut bytes[1]),
                );
            }
        }
        if let (true, Some(tick)) = (k >= PERIODS / 2, executing) {
            let reference = law.slave_reference(&master_at(tick_time[&tick])).position;
            tracking_m = tracking_m.max((reference - xs).amax());
        }
    }
    let seconds = f64::from(PERIODS) * TS;
    Outcome {
        tracking_m,
        bytes_per_s: bytes.map(|b| b as f64 / seconds),
        latency_ms: playout
            .offset()
            .map_or(f64::NAN, |o| f64::from(o) * TS * 1e3),
        late: playout.late(),
        lost_frames: forward.link.lost() + backward.link.lost(),
    }
}

/// A link end that counts the bytes sent through it.
struct Counted<'a>(&'a mut FrameEnd<MAX_FRAME_LEN, 256>, &'a mut usize);

impl kerf::hal::FrameLink for Counted<'_> {
    fn send(&mut self, frame: &[u8]) -> Result<(), kerf::hal::LinkBusy> {
        *self.1 += frame.len();
        self.0.send(frame)
    }
    fn receive(&mut self, buf: &mut [u8]) -> Option<usize> {
        self.0.receive(buf)
    }
}

#[test]
fn the_remote_loop_tracks_over_a_delayed_lossy_link() {
    let base = Case {
        name: "",
        delay_ms: 0,
        jitter_ms: 0,
        loss: 0.0,
        observer: true,
        m: 6,
    };
    let cases = [
        Case {
            name: "no delay",
            ..base
        },
        Case {
            name: "no delay, no observer",
            observer: false,
            ..base
        },
        Case {
            name: "20 ms",
            delay_ms: 20,
            ..base
        },
        Case {
            name: "20 ms, no observer",
            delay_ms: 20,
            observer: false,
            ..base
        },
        Case {
            name: "20 ± 10 ms",
            delay_ms: 20,
            jitter_ms: 10,
            ..base
        },
        Case {
            name: "20 ± 10 ms, no observer",
            delay_ms: 20,
            jitter_ms: 10,
            observer: false,
            ..base
        },
        Case {
            name: "20 ± 10 ms, 1 % loss",
            delay_ms: 20,
            jitter_ms: 10,
            loss: 0.01,
            ..base
        },
        Case {
            name: "20 ± 10 ms, all 16 coefficients",
            delay_ms: 20,
            jitter_ms: 10,
            m: 16,
            ..base
        },
    ];
    println!("| case | tracking error µm | bytes/s out | bytes/s back | latency ms | late | lost frames |");
    println!("|---|---|---|---|---|---|---|");
    let mut results = Vec::new();
    for case in &cases {
        let o = run(case);
        println!(
            "| {} | {:.2} | {:.0} | {:.0} | {:.1} | {} | {} |",
            case.name,
            o.tracking_m * 1e6,
            o.bytes_per_s[0],
            o.bytes_per_s[1],
            o.latency_ms,
            o.late,
            o.lost_frames
        );
        results.push(o);
    }
    // Raw f32 samples of the same three channels at 1 kHz with the same overheads per
    // block as the commands: a 13-byte packet per channel and the frame's CRC (no
    // header this way), 1000·12 + (3·13 + 4)·1000/16 bytes/s.
    let raw = 1000.0 * 12.0 + (3.0 * 13.0 + FRAME_CRC_LEN as f64) * 1000.0 / N as f64;
    println!("uncompressed f32 samples: {raw:.0} bytes/s master → slave");
    let [no_delay, no_delay_raw, constant, constant_raw, jitter, jitter_raw, lossy, full] =
        <[Outcome; 8]>::try_from(results).ok().unwrap();
    // The slave moves at up to 7.5 mm/s; with the observer the error is the 1 ms
    // command hold, the SDCT reconstruction of the command (m = 6 of 16) and the
    // tremor's 10 µm at the slave's scale filtered by the 5 Hz law.
    for (o, name) in [
        (&no_delay, "no delay"),
        (&constant, "20 ms"),
        (&jitter, "jitter"),
    ] {
        assert!(o.tracking_m < 30e-6, "{name}: {}", o.tracking_m);
    }
    // Without it the round trip sits inside the loop, and even with no network delay
    // the blocks' coding latency does (a command waits up to 16 ms for its block, a
    // report as long): at 5 Hz tracking poles every case without the observer diverges.
    for raw_case in [&no_delay_raw, &constant_raw, &jitter_raw] {
        assert!(raw_case.tracking_m.is_nan() || raw_case.tracking_m > 1e-3);
    }
    // 1 % of frames lost (16 ms of commands each, the previous command held meanwhile):
    // the correction makes up for them within its 5 Hz.
    assert!(lossy.lost_frames > 0);
    assert!(lossy.tracking_m < 100e-6, "{}", lossy.tracking_m);
    // Compression: 6 of 16 coefficients against all 16, at a similar error.
    assert!(jitter.bytes_per_s[0] < 0.6 * full.bytes_per_s[0]);
    assert!(jitter.tracking_m < 1.5 * full.tracking_m);
    // 2.6× fewer bytes than the raw samples.
    assert!(jitter.bytes_per_s[0] < raw / 2.6);
}
