//! kerf's delay observer against T's network disturbance observer (docs/control.md
//! §22), on the same remote machining runs (`host_tests::remote`): the same master,
//! operator, network and slave, only the estimate the master's law closes on changed.
//! Run with `--nocapture` for the tables; the figure goes to
//! `target/debug/plots/remote_observers.svg`.
//!
//! Both run with all 16 SDCT coefficients of each command block (the codec's Q15
//! rounding only): T's observer integrates the commands the master computed and has no
//! term that would correct a slave executing anything else, so with the product's 6 of
//! 16 the coded commands' integral leaves it for good (the last test shows it).

use host_tests::plot::{self, Series};
use host_tests::remote::{run, Network, RemoteCase, RemoteRun, N};
use kerf::machines::remote_master::SlaveEstimate;
use std::f64::consts::PI;

/// Tracking is measured from here on (past the start from rest).
const FROM_S: f64 = 2.0;

/// The delay cases: (name, mean one-way delay ms, ± jitter ms).
const DELAYS: [(&str, u32, u32); 5] = [
    ("0", 0, 0),
    ("20 ms", 20, 0),
    ("20 ± 10 ms", 20, 10),
    ("50 ± 25 ms", 50, 25),
    ("100 ms", 100, 0),
];

/// T's observer: both filters at 200 Hz (of 20, 50 and 200 Hz, the only one that held
/// every delay case; 50 Hz let 100 ms diverge).
const T_OBSERVER: SlaveEstimate = SlaveEstimate::NetworkDisturbance {
    bandwidth_rad_s: 2.0 * PI * 200.0,
};

/// One row: the tracking error (max, RMS) µm, the playout latency ms, the fixture's
/// stiffness the operator felt at the push's step, N/mm.
#[derive(Copy, Clone, Debug)]
struct Row {
    max_um: f64,
    rms_um: f64,
    latency_ms: f64,
    stiffness_n_per_mm: f64,
}

fn measure(r: &RemoteRun, case: &RemoteCase) -> Row {
    let (max_um, rms_um) = r.tracking_um(case, FROM_S);
    // The push across the contour steps by 2 N at 3 s: the operator feels the
    // fixture's stiffness as that step over the largest deviation it causes.
    let window = |from: f64, to: f64| {
        r.samples
            .iter()
            .filter(move |s| s.t_s >= from && s.t_s < to)
            .map(|s| s.master_across_m)
    };
    let before = window(2.5, 3.0).sum::<f64>() / window(2.5, 3.0).count().max(1) as f64;
    let peak = window(3.0, 3.3)
        .map(|a| (a - before).abs())
        .fold(0.0, f64::max);
    Row {
        max_um,
        rms_um,
        latency_ms: r.latency_ms(FROM_S).unwrap_or(f64::NAN),
        stiffness_n_per_mm: 2.0 / (peak * 1e3),
    }
}

fn case(
    scale: f64,
    delay_ms: u32,
    jitter_ms: u32,
    loss: f64,
    estimate: SlaveEstimate,
) -> RemoteCase {
    RemoteCase {
        scale,
        network: Network {
            delay_ms,
            jitter_ms,
            loss,
        },
        estimate,
        m: N,
        ..RemoteCase::nominal()
    }
}

fn run_case(c: &RemoteCase) -> Row {
    measure(&run(c).unwrap_or_else(|e| panic!("{e:?}")), c)
}

/// One line of the table: the delay case, the loss, and each observer's row with
/// each command frame sent once and (with loss) three times.
struct Line {
    delay: &'static str,
    loss: f64,
    kerf: Row,
    t: Row,
    copies: Option<(Row, Row)>,
}

/// Every delay and loss case at `scale`, both observers: the table's lines.
fn sweep(scale: f64) -> Vec<Line> {
    println!("| scale | delay | loss | kerf max µm | kerf RMS µm | T max µm | T RMS µm | kerf / T max µm, 3 copies | latency ms | fixture N/mm |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut lines = Vec::new();
    for (delay, delay_ms, jitter_ms) in DELAYS {
        for loss in [0.0, 0.01, 0.05] {
            let pair = |copies: usize| {
                let with = |estimate| RemoteCase {
                    command_copies: copies,
                    ..case(scale, delay_ms, jitter_ms, loss, estimate)
                };
                (
                    run_case(&with(SlaveEstimate::EchoedTicks)),
                    run_case(&with(T_OBSERVER)),
                )
            };
            let (kerf, t) = pair(1);
            let copies = (loss > 0.0).then(|| pair(3));
            let copied = copies.map_or(String::new(), |(k, t)| {
                format!("{:.1} / {:.1}", k.max_um, t.max_um)
            });
            println!(
                "| {scale:.3} | {delay} | {:.0} % | {:.1} | {:.1} | {:.1} | {:.1} | {copied} | {:.1} | {:.1} |",
                loss * 100.0,
                kerf.max_um,
                kerf.rms_um,
                t.max_um,
                t.rms_um,
                kerf.latency_ms,
                kerf.stiffness_n_per_mm
            );
            lines.push(Line {
                delay,
                loss,
                kerf,
                t,
                copies,
            });
        }
    }
    lines
}

/// What the sweep shows at either scale (docs/control.md §22): without loss both
/// observers track every delay case within 45 µm (measured 22–40 µm for T's, 24–36
/// for kerf's); with loss and each frame sent once, T's leaves the slave for good at
/// the first lost block (no convergence term: measured 5–42 mm) while kerf's takes it
/// up (under 1.2 mm, mostly a few hundred µm); with three copies of each frame both
/// are back near their lossless figures. Neither changes what the operator feels (the
/// fixture is the master's own) nor the latency (the playout's).
fn check(lines: &[Line]) {
    for l in lines {
        let (kerf, t) = (l.kerf, l.t);
        let what = format!("{} {}: {kerf:?} {t:?}", l.delay, l.loss);
        if l.loss == 0.0 {
            assert!(kerf.max_um < 45.0 && t.max_um < 45.0, "{what}");
        } else {
            assert!(kerf.max_um < 1500.0, "{what}");
            assert!(t.max_um > 3.0 * kerf.max_um, "{what}");
        }
        if let Some((kerf, t)) = l.copies {
            assert!(
                kerf.max_um < 60.0 && t.max_um < 60.0,
                "{what}, copies {kerf:?} {t:?}"
            );
        }
        assert!((kerf.stiffness_n_per_mm / t.stiffness_n_per_mm - 1.0).abs() < 0.05);
    }
}

#[test]
fn both_observers_over_the_delay_and_loss_cases_at_half_scale() {
    let lines = sweep(0.5);
    check(&lines);
    // The figure: the largest error against the worst one-way delay, per observer
    // and loss (clipped at 1 mm: T's with loss leaves the plot), and at 5 % with
    // three copies of each frame.
    let worst_delay = |name: &str| {
        DELAYS
            .iter()
            .find(|d| d.0 == name)
            .map_or(0.0, |d| f64::from(d.1 + d.2))
    };
    let mut curves: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    let clip = |um: f64| um.min(1000.0);
    for loss in [0.0, 0.01, 0.05] {
        for (observer, pick) in [("kerf", 0usize), ("T", 1)] {
            let points: Vec<(f64, f64)> = lines
                .iter()
                .filter(|l| l.loss == loss)
                .map(|l| {
                    let row = if pick == 0 { l.kerf } else { l.t };
                    (worst_delay(l.delay), clip(row.max_um))
                })
                .collect();
            curves.push((format!("{observer}, {:.0} % loss", loss * 100.0), points));
        }
    }
    for (observer, pick) in [("kerf", 0usize), ("T", 1)] {
        let points: Vec<(f64, f64)> = lines
            .iter()
            .filter(|l| l.loss == 0.05)
            .filter_map(|l| {
                let (kerf, t) = l.copies?;
                let row = if pick == 0 { kerf } else { t };
                Some((worst_delay(l.delay), clip(row.max_um)))
            })
            .collect();
        curves.push((format!("{observer}, 5 % loss, 3 copies"), points));
    }
    let series: Vec<Series> = curves
        .iter()
        .enumerate()
        .map(|(i, (label, points))| Series::new(label, points, i))
        .collect();
    plot::line_plot(
        &plot::plots_dir().unwrap().join("remote_observers.svg"),
        "Slave tracking error: kerf's delay observer and T's network observer (scale 0.5)",
        "worst one-way delay (ms)",
        "largest |slave − scaled master| (µm, clipped at 1000)",
        &series,
    )
    .unwrap();
}

#[test]
fn both_observers_over_the_delay_and_loss_cases_at_two_thirds_scale() {
    check(&sweep(2.0 / 3.0));
}

/// With the product's coding (6 of 16 coefficients) the slave executes commands whose
/// integral differs from the master's: kerf's observer corrects the difference, T's
/// estimate drifts from the slave and the slave with it.
#[test]
fn the_codecs_truncation_leaves_t_observer_behind() {
    let coded = |estimate| RemoteCase {
        m: 6,
        ..case(0.5, 20, 10, 0.0, estimate)
    };
    let kerf = run_case(&coded(SlaveEstimate::EchoedTicks));
    let t = run_case(&coded(T_OBSERVER));
    println!("m = 6, 20 ± 10 ms: kerf {kerf:?}, T {t:?}");
    assert!(kerf.max_um < 40.0, "{kerf:?}");
    assert!(t.max_um > 10.0 * kerf.max_um, "{t:?}");
}

/// T's observer's bandwidth is checked with the master's configuration and named by
/// its path; kerf's needs none of it.
#[test]
fn a_bad_network_observer_bandwidth_is_refused_by_name() {
    use host_tests::remote::master_config;
    use kerf::machines::remote_master::RemoteMaster;
    for bandwidth_rad_s in [0.0, -1.0, f64::NAN, 1e9] {
        let case = RemoteCase {
            estimate: SlaveEstimate::NetworkDisturbance { bandwidth_rad_s },
            ..RemoteCase::nominal()
        };
        let config = master_config(&case, [0.0; 3], [0.0; 3]);
        let e = RemoteMaster::<f32>::new(&config).unwrap_err();
        assert_eq!(
            e.to_string().split(':').next(),
            Some("slave_estimate.bandwidth_rad_s"),
            "{e}"
        );
    }
    let config = master_config(&RemoteCase::nominal(), [0.0; 3], [0.0; 3]);
    assert!(RemoteMaster::<f32>::new(&config).is_ok());
}
