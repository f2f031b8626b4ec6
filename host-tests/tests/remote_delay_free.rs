//! T's delay-free bilateral law end to end (T 5.3.1; docs/control.md §21): the master
//! closes the slave's tracking law on the newest report, with no observer and no
//! network delay, the link carrying raw samples (every 1 kHz sample its own frame) as
//! T's baseline, beside the same law over the SDCT blocks, whose coding latency (a
//! block of 16 samples waits 16 ms for its last sample, each way) is then a measured
//! cost. Run with `--nocapture` for the table.

use host_tests::remote::{run, Network, RemoteCase, RemoteRun, N};
use kerf::machines::remote_master::SlaveEstimate;

/// Tracking is measured from here on (past the start from rest).
const FROM_S: f64 = 2.0;

/// Tracking error of a run, µm (max, RMS), from [`FROM_S`] on.
fn tracking_um(r: &RemoteRun, case: &RemoteCase) -> (f64, f64) {
    r.tracking_um(case, FROM_S)
}

#[test]
fn the_delay_free_law_holds_on_raw_samples_and_not_behind_the_blocks() {
    let no_delay = Network {
        delay_ms: 0,
        jitter_ms: 0,
        loss: 0.0,
    };
    let case = |estimate, raw_samples, m| RemoteCase {
        network: no_delay,
        estimate,
        raw_samples,
        m,
        push_window: None,
        ..RemoteCase::nominal()
    };
    println!("| law | link | max µm | RMS µm | latency ms | bytes/s out | bytes/s back |");
    println!("|---|---|---|---|---|---|---|");
    let mut rows = Vec::new();
    for (law, estimate) in [
        ("delay-free (T 5.3.1)", SlaveEstimate::Newest),
        ("kerf's observer", SlaveEstimate::EchoedTicks),
    ] {
        for (link, raw, m) in [
            ("raw samples", true, N),
            ("SDCT, 16 of 16", false, N),
            ("SDCT, 6 of 16", false, 6),
        ] {
            let c = case(estimate, raw, m);
            let r = run(&c).unwrap_or_else(|e| panic!("{e:?}"));
            let (max, rms) = tracking_um(&r, &c);
            let latency = r.latency_ms(FROM_S).unwrap_or(f64::NAN);
            println!(
                "| {law} | {link} | {max:.1} | {rms:.1} | {latency:.1} | {:.0} | {:.0} |",
                r.bytes_per_s[0], r.bytes_per_s[1]
            );
            rows.push((estimate, raw, m, max, latency, r.bytes_per_s));
        }
    }
    let find = |estimate: SlaveEstimate, raw: bool, m: usize| {
        *rows
            .iter()
            .find(|r| r.0 == estimate && r.1 == raw && r.2 == m)
            .unwrap()
    };
    // T's baseline: on raw samples the round trip is two samples and the playout's
    // 0.5 ms, and the law closed on the newest report tracks within 40 µm, as the
    // observer does on the same link (measured below).
    let raw = find(SlaveEstimate::Newest, true, N);
    assert!(raw.3 < 40.0, "{raw:?}");
    assert!(raw.4 < 2.0, "{raw:?}");
    // Behind the blocks the same law sees the slave 16 ms late each way more: its
    // 15 Hz loop rings and the slave leaves the contour (millimetres), whichever the
    // coefficients kept. That is the codec's latency, measured.
    for m in [N, 6] {
        let coded = find(SlaveEstimate::Newest, false, m);
        assert!(coded.3 > 20.0 * raw.3, "{coded:?}");
        assert!(coded.4 > 15.0, "{coded:?}");
    }
    // The observer makes the blocks' latency cost nothing in tracking (within 1.5× of
    // the raw baseline) at a quarter of the raw link's bytes.
    let observed = find(SlaveEstimate::EchoedTicks, false, 6);
    assert!(observed.3 < 1.5 * raw.3.max(20.0), "{observed:?}");
    assert!(observed.5[0] < raw.5[0] / 3.0, "{observed:?} {raw:?}");
}
