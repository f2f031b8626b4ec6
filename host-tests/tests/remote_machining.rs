//! Remote machining end to end (`host_tests::remote`, T ch. 5 and 8.3): the master
//! and slave machine images over the simulated network. Run with `--nocapture` for the
//! tables; the pictures go to `target/debug/plots/remote_*.svg`.

use host_tests::plot::{self, Series, ZoomBox};
use host_tests::remote::{
    run, Faults, Network, RemoteCase, RemoteRun, D, LASER_POWER_W, N, OPERATOR_SPEED_M_S, TS,
};
use kerf::app::stream::FRAME_CRC_LEN;
use kerf::app::supervisor::Mode;
use kerf::control::laser::LaserMode;
use kerf::machines::delta_slave::remote::RemoteSlaveFault;
use kerf::machines::remote_master::SlaveEstimate;

/// Tracking is measured from here on (the first seconds include the start from rest).
const FROM_S: f64 = 2.0;

fn network(delay_ms: u32, jitter_ms: u32, loss: f64) -> Network {
    Network {
        delay_ms,
        jitter_ms,
        loss,
    }
}

fn run_ok(case: &RemoteCase) -> RemoteRun {
    run(case).unwrap_or_else(|e| panic!("{e:?}"))
}

/// Tracking error of a run, µm (max, RMS), from [`FROM_S`] on.
fn tracking_um(r: &RemoteRun, case: &RemoteCase) -> (f64, f64) {
    r.tracking_um(case, FROM_S)
}

#[test]
fn the_slave_follows_the_scaled_master_over_the_network() {
    println!(
        "| scale | link | observer | max µm | RMS µm | latency ms | bytes/s out | bytes/s back |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let links = [
        ("no delay", network(0, 0, 0.0)),
        ("20 ms", network(20, 0, 0.0)),
        ("20 ± 10 ms", network(20, 10, 0.0)),
        ("50 ± 25 ms", network(50, 25, 0.0)),
        ("100 ms", network(100, 0, 0.0)),
    ];
    let mut errors = Vec::new();
    let mut error_series = Vec::new();
    for scale in [0.5, 2.0 / 3.0] {
        for (name, link) in links {
            for observer in [true, false] {
                let case = RemoteCase {
                    scale,
                    network: link,
                    estimate: if observer {
                        SlaveEstimate::EchoedTicks
                    } else {
                        SlaveEstimate::Newest
                    },
                    push_window: None,
                    ..RemoteCase::nominal()
                };
                let r = run_ok(&case);
                let (max, rms) = tracking_um(&r, &case);
                println!(
                    "| {scale:.3} | {name} | {observer} | {max:.1} | {rms:.1} | {:.1} | {:.0} | {:.0} |",
                    r.latency_ms(FROM_S).unwrap_or(f64::NAN),
                    r.bytes_per_s[0],
                    r.bytes_per_s[1]
                );
                errors.push((scale, name, observer, max));
                if scale == 0.5 {
                    let points: Vec<(f64, f64)> = r
                        .samples
                        .iter()
                        .step_by(10)
                        .filter_map(|s| {
                            let reference = s.slave_reference_m?;
                            let e = (0..3)
                                .map(|i| (reference[i] - s.slave_m[i]).powi(2))
                                .sum::<f64>()
                                .sqrt();
                            Some((s.t_s, (e * 1e6).min(200.0)))
                        })
                        .collect();
                    let label = format!("{name}{}", if observer { "" } else { ", no observer" });
                    error_series.push((label, points));
                }
            }
        }
    }
    // With the observer every link tracks within 40 µm (measured 23–31 µm: the
    // realistic slave's friction and ripple left by its 40 Hz model-following loop and
    // the Hall decoders' residual), 60 µm at 50 ± 25 ms (measured 38 and 51 µm: a
    // delay that varies by 50 ms within the observer's 5 Hz correction); without it
    // the round trip (the network's and the blocks' 16 ms of coding each way) sits
    // inside the 15 Hz loop, and every case is at least 3× worse or diverges.
    for &(scale, name, observer, max) in &errors {
        if observer {
            let bound = if name == "50 ± 25 ms" { 60.0 } else { 40.0 };
            assert!(max < bound, "scale {scale} {name}: {max} µm");
            let without = errors
                .iter()
                .find(|e| e.0 == scale && e.1 == name && !e.2)
                .map_or(f64::NAN, |e| e.3);
            assert!(
                without > 3.0 * max,
                "scale {scale} {name}: {without} against {max}"
            );
        }
    }
    let dir = plot::plots_dir().unwrap();
    let series: Vec<Series> = error_series
        .iter()
        .enumerate()
        .map(|(i, (label, points))| Series::new(label, points, i))
        .collect();
    plot::time_series(
        &dir.join("remote_tracking_error.svg"),
        "Slave tracking error against the scaled master (scale 0.5; clipped at 200 µm)",
        "|slave − scaled master| (µm)",
        &series,
    )
    .unwrap();
}

#[test]
fn packet_loss_and_compression() {
    let lossy = RemoteCase {
        network: network(20, 10, 0.01),
        ..RemoteCase::nominal()
    };
    let all_coefficients = RemoteCase {
        m: N,
        ..RemoteCase::nominal()
    };
    let nominal = RemoteCase::nominal();
    println!("| case | max µm | RMS µm | bytes/s out | bytes/s back | lost frames |");
    println!("|---|---|---|---|---|---|");
    let mut out = Vec::new();
    for (name, case) in [
        ("20 ± 10 ms, SDCT m = 6 of 16", &nominal),
        ("20 ± 10 ms, all 16 coefficients", &all_coefficients),
        ("20 ± 10 ms, 1 % loss, m = 6", &lossy),
    ] {
        let r = run_ok(case);
        let (max, rms) = tracking_um(&r, case);
        println!(
            "| {name} | {max:.1} | {rms:.1} | {:.0} | {:.0} | {} |",
            r.bytes_per_s[0], r.bytes_per_s[1], r.lost_frames
        );
        out.push((max, r));
    }
    // Three f32 channels at 1 kHz with the same 13-byte packet overhead per block and
    // channel, and the same 8-byte frame header and frame CRC.
    let raw = 1000.0 * 12.0 + (3.0 * 13.0 + 8.0 + FRAME_CRC_LEN as f64) * 1000.0 / N as f64;
    println!(
        "uncompressed f32 samples: {raw:.0} bytes/s; coding latency: a block of {N} samples at {} Hz, {:.0} ms for its first sample",
        1.0 / (f64::from(D) * TS),
        N as f64 * f64::from(D) * TS * 1e3
    );
    let [(sdct, sdct_run), (full, full_run), (loss, loss_run)] =
        <[(f64, RemoteRun); 3]>::try_from(out).ok().unwrap();
    // 6 of 16 coefficients: under 65 % of the bytes of all 16 (measured 62 %: the
    // packet and frame overheads do not shrink), 2.5× fewer than raw
    // samples, at an error within 1.5× (the command is smooth: its energy is in the
    // low coefficients).
    assert!(sdct_run.bytes_per_s[0] < 0.65 * full_run.bytes_per_s[0]);
    assert!(sdct_run.bytes_per_s[0] < raw / 2.5);
    assert!(sdct < 1.5 * full, "{sdct} against {full}");
    // A lost frame is 16 ms of commands the slave's model never integrates (the
    // previous command holds meanwhile): with ±0.1 m/s² of tremor and corrections in
    // the command the slave's model leaves the master's by up to a millimetre per
    // second, which the observer's 5 Hz correction takes up within ~0.2 s. Measured
    // 206 µm at the worst loss, 25 µm RMS over the run.
    assert!(loss_run.lost_frames > 0);
    let rms = loss_run
        .tracking_m(FROM_S)
        .map_or(f64::INFINITY, |t| t.1 * 1e6);
    assert!(loss < 300.0 && rms < 40.0, "{loss} {rms}");
}

#[test]
fn the_fixture_holds_the_master_on_the_contour() {
    // The nominal case: 0.5 N across all the time, 2.5 N from 3 to 4 s.
    let case = RemoteCase::nominal();
    let r = run_ok(&case);
    let window = |from: f64, to: f64| {
        r.samples
            .iter()
            .filter(move |s| s.t_s >= from && s.t_s < to)
    };
    let mean = |from, to| {
        let v: Vec<f64> = window(from, to).map(|s| s.master_across_m).collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    let peak = |from, to| {
        window(from, to)
            .map(|s| s.master_across_m.abs())
            .fold(0.0, f64::max)
    };
    draw_paths(&r, &case);
    draw_forces(&r);
    let before = mean(2.0, 3.0);
    let pushed = mean(3.2, 4.0);
    let step_um_per_n = (pushed - before).abs() * 1e6 / 2.0;
    let transient_um_per_n = (peak(3.0, 3.2) - before.abs()) * 1e6 / 2.0;
    let along: Vec<f64> = window(FROM_S, case.seconds)
        .map(|s| s.master_speed_m_s)
        .collect();
    println!(
        "fixture: deviation across the curve {:.2} µm per N held (mean over the push), {:.2} µm per N at the step's transient; largest deviation over the run {:.1} µm; speed along the curve {:.1}–{:.1} mm/s",
        step_um_per_n,
        transient_um_per_n,
        peak(FROM_S, case.seconds) * 1e6,
        along.iter().copied().fold(f64::INFINITY, f64::min) * 1e3,
        along.iter().copied().fold(0.0, f64::max) * 1e3
    );
    // The disturbance observer compensates a held push in the constrained subspace: it
    // costs well under a micrometre per newton once settled; the step's transient is
    // bounded by the fixture's stiffness m·λK (about 30 N/mm at the master's ~1 kg).
    assert!(step_um_per_n < 1.0, "{step_um_per_n}");
    assert!(transient_um_per_n < 40.0, "{transient_um_per_n}");
    // The largest deviation of the run is that step's transient.
    assert!(peak(FROM_S, case.seconds) < 80e-6);
    // Free along the curve: the hand's speed profile goes through, 5 to 15 mm/s.
    assert!(along.iter().copied().fold(0.0, f64::max) > 1.3 * OPERATOR_SPEED_M_S);
}

/// Energy per length along the slave's path in 0.25 mm bins: (arc mm, J/m, mean speed
/// mm/s) for bins where the beam was on.
fn energy_per_length(r: &RemoteRun) -> Vec<(f64, f64, f64)> {
    let mut bins = Vec::new();
    let (mut arc, mut length, mut energy, mut time) = (0.0, 0.0, 0.0, 0.0);
    let follow: Vec<_> = r.samples.iter().filter(|s| s.t_s >= FROM_S).collect();
    for pair in follow.windows(2) {
        let d = (0..2)
            .map(|i| (pair[1].slave_m[i] - pair[0].slave_m[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        length += d;
        energy += pair[1].laser_w * TS;
        time += TS;
        if length >= 0.25e-3 {
            arc += length;
            if energy > 0.0 {
                bins.push((arc * 1e3, energy / length, length / time * 1e3));
            }
            (length, energy, time) = (0.0, 0.0, 0.0);
        }
    }
    bins
}

#[test]
fn the_operators_speed_sets_the_depth_unless_the_energy_is_held() {
    let constant_power = RemoteCase::nominal();
    let slave_speed = constant_power.scale * OPERATOR_SPEED_M_S;
    let constant_energy = RemoteCase {
        laser: LaserMode::constant_energy_of(LASER_POWER_W, slave_speed),
        ..RemoteCase::nominal()
    };
    let mut series = Vec::new();
    let mut spreads = Vec::new();
    for (name, case) in [
        ("constant power (manual depth)", &constant_power),
        ("constant energy per length", &constant_energy),
    ] {
        let bins = energy_per_length(&run_ok(case));
        let e: Vec<f64> = bins.iter().map(|b| b.1).collect();
        let (lo, hi) = (
            e.iter().copied().fold(f64::INFINITY, f64::min),
            e.iter().copied().fold(0.0, f64::max),
        );
        // Depth ∝ energy per length; against the operator's speed.
        let slow: Vec<f64> = bins
            .iter()
            .filter(|b| b.2 < 0.6 * slave_speed * 1e3)
            .map(|b| b.1)
            .collect();
        let fast: Vec<f64> = bins
            .iter()
            .filter(|b| b.2 > 1.2 * slave_speed * 1e3)
            .map(|b| b.1)
            .collect();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
        println!(
            "{name}: energy per length {:.0}–{:.0} J/m over {} bins of 0.25 mm; mean {:.0} J/m where the slave is slow (< {:.1} mm/s), {:.0} J/m where fast (> {:.1} mm/s)",
            lo,
            hi,
            bins.len(),
            mean(&slow),
            0.6 * slave_speed * 1e3,
            mean(&fast),
            1.2 * slave_speed * 1e3
        );
        spreads.push((hi / lo, mean(&slow) / mean(&fast)));
        series.push((name, bins.iter().map(|b| (b.0, b.1)).collect::<Vec<_>>()));
    }
    // Constant power: the operator's speed (2.5 to 7.5 mm/s at the slave) sets the
    // depth, slow bins getting twice the energy of fast ones and more; constant energy
    // holds it within ±15 % whatever the speed.
    assert!(spreads[0].1 > 1.8, "{:?}", spreads[0]);
    assert!(
        spreads[1].0 < 1.35 && (spreads[1].1 - 1.0).abs() < 0.1,
        "{:?}",
        spreads[1]
    );
    let dir = plot::plots_dir().unwrap();
    let drawn: Vec<Series> = series
        .iter()
        .enumerate()
        .map(|(i, (name, points))| Series::new(name, points, i))
        .collect();
    plot::along_path(
        &dir.join("remote_energy_per_length.svg"),
        "Slave beam energy per length along the cut (the operator's speed varies ±50 %)",
        "energy per length (J/m)",
        &drawn,
    )
    .unwrap();
}

#[test]
fn haptics_keep_the_operator_inside_the_speed_band() {
    // The hand wants up to 15 mm/s; the band ends at 11 mm/s.
    let mut above = Vec::new();
    for haptic in [false, true] {
        let case = RemoteCase {
            haptic,
            ..RemoteCase::nominal()
        };
        let r = run_ok(&case);
        let band = 1.1 * OPERATOR_SPEED_M_S;
        let excess: Vec<f64> = r
            .samples
            .iter()
            .filter(|s| s.t_s >= FROM_S)
            .map(|s| (s.master_speed_m_s.abs() - band).max(0.0))
            .collect();
        let peak = excess.iter().copied().fold(0.0, f64::max);
        let mean = excess.iter().sum::<f64>() / excess.len() as f64;
        let force = r
            .samples
            .iter()
            .map(|s| s.haptic_n.abs())
            .fold(0.0, f64::max);
        let (max, rms) = tracking_um(&r, &case);
        println!(
            "haptics {}: speed above the band peak {:.2} mm/s, mean {:.3} mm/s; largest haptic force {force:.2} N; tracking {max:.1} / {rms:.1} µm",
            if haptic { "on" } else { "off" },
            peak * 1e3,
            mean * 1e3
        );
        above.push((peak, mean));
    }
    // The operator feels the excursion and slows: the excursions shrink by half or more.
    assert!(above[1].0 < 0.5 * above[0].0, "{above:?}");
    assert!(above[1].1 < 0.5 * above[0].1, "{above:?}");
}

#[test]
fn link_silence_holds_then_stops_the_slave_safely() {
    let case = RemoteCase {
        faults: Faults {
            silence_from_s: Some(5.0),
            ..Faults::default()
        },
        seconds: 6.0,
        ..RemoteCase::nominal()
    };
    let r = run_ok(&case);
    // The slave stops following 50 ms after its last command (which was already a
    // latency behind), ramps to rest with the beam off and holds; after 0.5 s it
    // gives up: Fault(LinkLost), zero force.
    assert_eq!(r.slave_mode, Mode::Fault(RemoteSlaveFault::LinkLost));
    let at = |t: f64| r.samples.iter().find(|s| s.t_s >= t).unwrap();
    let beam_off_from = r
        .samples
        .iter()
        .rposition(|s| s.laser_w > 0.0)
        .map(|i| r.samples[i].t_s)
        .unwrap();
    let hold = at(5.3).slave_m;
    let drift = (0..3)
        .map(|i| (at(5.45).slave_m[i] - hold[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    println!(
        "silence at 5 s: beam off from {beam_off_from:.3} s, hold drift 5.3–5.45 s {:.2} µm, then {:?}",
        drift * 1e6,
        r.slave_mode
    );
    assert!(beam_off_from < 5.0 + 0.06 + 0.1, "{beam_off_from}");
    assert!(drift < 5e-6, "{drift}");
}

#[test]
fn corrupt_and_replayed_frames_are_dropped_and_counted() {
    let case = RemoteCase {
        faults: Faults {
            replay_and_corrupt_at_s: Some(5.0),
            ..Faults::default()
        },
        ..RemoteCase::nominal()
    };
    let r = run_ok(&case);
    let (max, rms) = tracking_um(&r, &case);
    println!(
        "replayed and corrupted frame at 5 s: {} frames refused, {} repeated; tracking {max:.1} / {rms:.1} µm",
        r.refused_frames, r.repeated_frames
    );
    // The corrupt frame fails its CRC; the replay is refused as a repeat by the
    // packet layer's sequence check (or as stale by the playout): the slave never executes either. The
    // corrupt frame's 16 ms of commands are lost, as in the lossy case (measured
    // 104 µm at that moment).
    assert!(r.refused_frames >= 1, "{}", r.refused_frames);
    assert!(r.repeated_frames >= 1, "{}", r.repeated_frames);
    assert!(max < 300.0 && rms < 20.0, "{max} {rms}");
}

/// A second master joins the network at 4 s and streams its own session: the slave
/// keeps the master it follows, drops every frame of the other and tracks as before.
#[test]
fn a_second_master_is_ignored() {
    let case = RemoteCase {
        faults: Faults {
            second_master_from_s: Some(4.0),
            ..Faults::default()
        },
        ..RemoteCase::nominal()
    };
    let r = run_ok(&case);
    let (max, rms) = tracking_um(&r, &case);
    let nominal = run_ok(&RemoteCase::nominal());
    let (nominal_max, _) = tracking_um(&nominal, &RemoteCase::nominal());
    println!(
        "second master from 4 s: {} frames dropped, {} restarts; tracking {max:.1} / {rms:.1} µm (alone {nominal_max:.1})",
        r.foreign_frames, r.restarts
    );
    // 6 s of 62.5 frames a second.
    assert!(r.foreign_frames > 300, "{}", r.foreign_frames);
    assert_eq!((r.restarts, r.slave_mode), (0, Mode::Running));
    assert!(max < 1.2 * nominal_max, "{max} against {nominal_max}");
}

#[test]
fn a_master_restart_is_recovered() {
    let case = RemoteCase {
        faults: Faults {
            master_restart_at_s: Some(5.0),
            ..Faults::default()
        },
        ..RemoteCase::nominal()
    };
    let r = run_ok(&case);
    let after = r.tracking_m(6.0).unwrap();
    println!(
        "master restart at 5 s: restarts seen {}, slave {:?}, tracking from 6 s {:.1} / {:.1} µm",
        r.restarts,
        r.slave_mode,
        after.0 * 1e6,
        after.1 * 1e6
    );
    assert_eq!(r.restarts, 1);
    assert_eq!(r.slave_mode, Mode::Running);
    assert!(after.0 < 40e-6, "{after:?}");
}

/// The master's path and contour, and the slave's path mapped back into the master's
/// frame ((xs − cs)/s + cm), mm, with a zoom where the push across is held.
fn draw_paths(r: &RemoteRun, case: &RemoteCase) {
    let mm = |p: [f64; 2]| (p[0] * 1e3, p[1] * 1e3);
    let mut contour: Vec<(f64, f64)> = r.contour_m.iter().map(|p| mm(*p)).collect();
    contour.push(contour[0]);
    let (cm, cs) = (r.master_centre_m, r.slave_centre_m);
    let follow = r.samples.iter().filter(|s| s.t_s >= FROM_S).step_by(20);
    let master: Vec<(f64, f64)> = follow
        .clone()
        .map(|s| mm([s.master_m[0], s.master_m[1]]))
        .collect();
    let slave: Vec<(f64, f64)> = follow
        .map(|s| {
            mm([
                (s.slave_m[0] - cs[0]) / case.scale + cm[0],
                (s.slave_m[1] - cs[1]) / case.scale + cm[1],
            ])
        })
        .collect();
    let pushed = r.samples.iter().find(|s| s.t_s >= 3.5).unwrap();
    let (zx, zy) = mm([pushed.master_m[0], pushed.master_m[1]]);
    plot::xy_with_zoom(
        &plot::plots_dir().unwrap().join("remote_paths.svg"),
        "Master on its fixture, slave mapped back (scale 0.5, 20 ± 10 ms)",
        &[
            Series::new("fixture contour", &contour, 0),
            Series::new("master", &master, 1),
            Series::new("slave / scale", &slave, 2),
        ],
        Some(ZoomBox::around(zx, zy, 0.15)),
    )
    .unwrap();
}

/// What the operator's hand does and feels: its force along the contour (towards the
/// wanted speed) and across it (the steady push and its 2 N step), and the deviation
/// across the fixture that the push causes, against time.
fn draw_forces(r: &RemoteRun) {
    let series = |f: &dyn Fn(&host_tests::remote::RemoteSample) -> f64| -> Vec<(f64, f64)> {
        r.samples
            .iter()
            .step_by(10)
            .map(|s| (s.t_s, f(s)))
            .collect()
    };
    let along = series(&|s| s.hand_along_n);
    let across = series(&|s| s.push_across_n);
    let deviation = series(&|s| s.master_across_m * 1e5);
    plot::time_series(
        &plot::plots_dir()
            .unwrap()
            .join("remote_operator_forces.svg"),
        "The operator's hand on the master: along and across the fixture (scale 0.5, 20 ± 10 ms)",
        "force (N); deviation across (10 µm)",
        &[
            Series::new("hand along the contour (N)", &along, 0),
            Series::new("push across (N)", &across, 1),
            Series::new("deviation across the contour (10 µm)", &deviation, 2),
        ],
    )
    .unwrap();
}

/// Loss that costs little (docs/control.md §22): each command frame sent once, twice
/// or three times (`RemoteCase::command_copies`), over 20 ± 10 ms with 0, 1 % and 5 %
/// of the frames lost each way.
#[test]
fn copies_of_each_command_frame_make_loss_cheap() {
    println!(
        "| loss | copies | max µm | RMS µm | latency ms | bytes/s out | frames lost | repeats |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let mut rows = Vec::new();
    for loss in [0.0, 0.01, 0.05] {
        for copies in [1, 2, 3] {
            let case = RemoteCase {
                network: network(20, 10, loss),
                command_copies: copies,
                push_window: None,
                ..RemoteCase::nominal()
            };
            let r = run_ok(&case);
            let (max, rms) = tracking_um(&r, &case);
            let latency = r.latency_ms(FROM_S).unwrap_or(f64::NAN);
            println!(
                "| {:.0} % | {copies} | {max:.1} | {rms:.1} | {latency:.1} | {:.0} | {} | {} |",
                loss * 100.0,
                r.bytes_per_s[0],
                r.lost_frames,
                r.repeated_frames
            );
            rows.push((loss, copies, max, latency, r.bytes_per_s[0]));
        }
    }
    let row = |loss: f64, copies: usize| {
        *rows
            .iter()
            .find(|r| r.0 == loss && r.1 == copies)
            .unwrap_or_else(|| panic!("{loss} {copies}"))
    };
    let lossless = row(0.0, 1);
    // Sent once, a lost frame is 16 ms of commands the slave never executes: 1 % costs
    // several times the lossless error (measured 229 µm against 23), 5 % more.
    assert!(row(0.01, 1).2 > 3.0 * lossless.2, "{:?}", row(0.01, 1));
    assert!(row(0.05, 1).2 > 3.0 * lossless.2, "{:?}", row(0.05, 1));
    // Three copies: a block is lost only with all three frames (p³, 1.25e-4 of the
    // blocks at 5 %): within twice the lossless error at 1 % and 5 % (measured 25 µm).
    for loss in [0.01, 0.05] {
        let (.., max, _, _) = row(loss, 3);
        assert!(
            max < 2.0 * lossless.2,
            "{loss}: {max} against {}",
            lossless.2
        );
    }
    // The cost: the command stream's bytes times the copies (the reports unchanged),
    // and one block period (16 ms) more playout latency, whatever the loss.
    for copies in [2, 3] {
        let (.., latency, bytes) = row(0.0, copies);
        let ratio = bytes / lossless.4;
        assert!((ratio - copies as f64).abs() < 0.01, "{copies}: {ratio}");
        assert!((latency - lossless.3 - 16.0).abs() < 0.5, "{latency}");
    }
}
