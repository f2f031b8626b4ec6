//! The log: the period across the wire's wrap, the summary, the CSV, the energy per
//! length, the path's plane and runs, the marks' label rows.

use super::*;

/// A machine of an error, three forces and a laser.
fn channels() -> Vec<ChannelInfo> {
    [
        ("error", "m"),
        ("force1", "N"),
        ("force2", "N"),
        ("force3", "N"),
        ("laser", "W"),
    ]
    .map(|(name, unit)| ChannelInfo {
        name: name.into(),
        unit: unit.into(),
    })
    .to_vec()
}

fn sample(period: u32, mode: ModeCode, error_m: f32, force: f32) -> TelemetrySample {
    TelemetrySample {
        period,
        mode,
        values: [error_m, force, -2.0 * force, 0.5, 10.0]
            .into_iter()
            .collect(),
    }
}

#[test]
fn mark_labels_take_rows_where_they_do_not_overlap() {
    let marks: Vec<(f64, String)> = [
        (1.0, "cut starts"),
        (1.1, "set /parallel/kd = 9000"),
        (1.2, "part 2 of 3 started"),
        (5.0, "stop"),
        (1.15, "x"),
    ]
    .map(|(t, l)| (t, l.to_owned()))
    .to_vec();
    // 10 s over 1,000 px: 0.065 s a character.
    let rows = label_rows(&marks, 10.0, 1000.0);
    let extent = |i: usize| {
        let (t, l) = &marks[i];
        (*t, t + (l.chars().count() as f64 + 1.0) * 0.065)
    };
    for i in 0..marks.len() {
        for j in i + 1..marks.len() {
            let ((a0, a1), (b0, b1)) = (extent(i), extent(j));
            let overlap = a0 < b1 && b0 < a1;
            assert!(!(overlap && rows[i] == rows[j]), "{i} {j}: {rows:?}");
        }
    }
    // Far from the others, the stop goes to the top row.
    assert_eq!(rows[3], 0);
    assert_eq!(rows[0], 0);
}

#[test]
fn the_path_is_drawn_in_the_machines_plane_while_it_moves_only() {
    let names = ["x_ref", "y_ref", "z_ref"];
    let arrow: Vec<ChannelInfo> = names
        .map(|name| ChannelInfo {
            name: name.into(),
            unit: "m".into(),
        })
        .to_vec();
    let mut log = TelemetryLog::new(1e-3, &arrow).with_plane([0, 2]);
    let at = |period, mode, v: [f32; 3]| TelemetrySample {
        period,
        mode,
        values: v.into_iter().collect(),
    };
    log.push(at(0, ModeCode::Ready, [0.0; 3]));
    log.push(at(1, ModeCode::Running, [0.01, 0.5, -0.02]));
    log.push(at(2, ModeCode::Stopping, [0.02, 0.5, -0.01]));
    log.push(at(3, ModeCode::Ready, [0.0; 3]));
    let (axes, measured, runs) = log.path_mm();
    assert_eq!(axes, ["x", "z"]);
    assert!(measured.is_empty());
    // No laser channel: one run, cut all along.
    assert_eq!(runs.len(), 1);
    let (cutting, reference) = &runs[0];
    assert!(*cutting);
    let want = [(10.0, -20.0), (20.0, -10.0)];
    assert_eq!(reference.len(), want.len());
    for (got, want) in reference.iter().zip(want) {
        // f32 samples: within 1e-7 of a 20 mm value.
        assert!(
            (got.0 - want.0).abs() < 1e-5 && (got.1 - want.1).abs() < 1e-5,
            "{got:?}"
        );
    }
    // Without a plane: x and y, as a laser cuts.
    let (axes, _, runs) = TelemetryLog {
        plane: [0, 1],
        ..log
    }
    .path_mm();
    assert_eq!(axes, ["x", "y"]);
    assert!((runs[0].1[0].1 - 500.0).abs() < 1e-4);
}

#[test]
fn a_travel_with_the_beam_off_is_a_run_of_its_own_joined_to_the_cut() {
    let laser: Vec<ChannelInfo> = [("x_ref", "m"), ("y_ref", "m"), ("laser", "W")]
        .map(|(name, unit)| ChannelInfo {
            name: name.into(),
            unit: unit.into(),
        })
        .to_vec();
    let mut log = TelemetryLog::new(1e-3, &laser);
    for (k, (x, w)) in [(0.0, 0.0), (1.0, 0.0), (2.0, 5.0), (3.0, 5.0), (4.0, 0.0)]
        .into_iter()
        .enumerate()
    {
        log.push(TelemetrySample {
            period: k as u32,
            mode: ModeCode::Running,
            values: [x * 1e-3, 0.0, w].into_iter().collect(),
        });
    }
    let (_, _, runs) = log.path_mm();
    let shape: Vec<(bool, Vec<f64>)> = runs
        .iter()
        .map(|(c, run)| (*c, run.iter().map(|p| (p.0 * 1e3).round() / 1e3).collect()))
        .collect();
    assert_eq!(
        shape,
        [
            (false, vec![0.0, 1.0]),
            (true, vec![1.0, 2.0, 3.0]),
            (false, vec![3.0, 4.0]),
        ]
    );
}

#[test]
fn the_period_keeps_counting_across_the_wire_wrap() {
    let mut log = TelemetryLog::new(1e-4, &channels());
    let wire = [u32::MAX - 150, u32::MAX - 50, 49, 149, 100_149];
    for p in wire {
        log.push(sample(p, ModeCode::Running, 0.0, 0.0));
    }
    let start = u64::from(u32::MAX - 150);
    let want = [
        start,
        start + 100,
        start + 200,
        start + 300,
        start + 100_300,
    ];
    let got: Vec<u64> = log.entries().iter().map(|e| e.period).collect();
    assert_eq!(got, want);
    let last = log.entries().last().unwrap();
    assert!((last.time_s - want[4] as f64 * 1e-4).abs() < 1e-9);
}

#[test]
fn the_summary_counts_only_the_cut_and_the_csv_has_a_row_per_sample() {
    let mut log = TelemetryLog::new(1e-3, &channels());
    log.push(sample(0, ModeCode::Ready, 9e-6, 9.0));
    let errors = [1e-6f32, -3e-6, 2e-6];
    for (k, e) in errors.iter().enumerate() {
        log.push(sample(10 * (k as u32 + 1), ModeCode::Running, *e, 1.5));
    }
    log.push(sample(40, ModeCode::Ready, 0.0, 0.0));
    let s = log.summary();
    let rms = (errors.iter().map(|e| f64::from(*e).powi(2)).sum::<f64>() / 3.0).sqrt();
    assert_eq!((s.samples, s.cutting_samples), (5, 3));
    assert!((s.error_max_m - 3e-6).abs() < 1e-12, "{s:?}");
    assert!((s.error_rms_m - rms).abs() < 1e-12, "{s:?}");
    assert!((s.force_peak_n - 3.0).abs() < 1e-12, "{s:?}");
    assert!((s.cut_s - 0.02).abs() < 1e-12, "{s:?}");
    // From the first cutting sample (period 10) to the last (period 40).
    assert!((log.since_cut_s() - 0.03).abs() < 1e-12);
    // The latest sample's machine time, the time the run's lines carry.
    let last = log.entries().last().map(|e| e.time_s).unwrap();
    assert_eq!(log.latest_s(), last);
    assert_eq!(TelemetryLog::new(1e-3, &channels()).latest_s(), 0.0);
    let mut csv = Vec::new();
    log.write_csv(&mut csv).unwrap();
    let text = String::from_utf8(csv).unwrap();
    let rows: Vec<&str> = text.lines().collect();
    assert_eq!(rows.len(), 6);
    let header: Vec<&str> = rows[0].split(',').collect();
    let third: Vec<&str> = rows[3].split(',').collect();
    assert_eq!(header.len(), third.len());
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    assert_eq!(third[col("mode")], "Running");
    assert_eq!(third[col("error_m")].parse::<f32>().unwrap(), -3e-6);
    assert_eq!(third[col("force2_n")].parse::<f32>().unwrap(), -3.0);
}

/// An effector moving at 5 mm/s with the beam at 4 W puts 0.8 J into each mm:
/// every sample says so, the summary's median too; samples at rest or with the
/// beam off are left out; the picture has the panel.
#[test]
fn the_energy_per_length_is_the_power_over_the_measured_speed() {
    let laser: Vec<ChannelInfo> = [("x", "m"), ("y", "m"), ("laser", "W")]
        .map(|(name, unit)| ChannelInfo {
            name: name.into(),
            unit: unit.into(),
        })
        .to_vec();
    let mut log = TelemetryLog::new(1e-4, &laser);
    let at = |k: u32, x: f32, power: f32| TelemetrySample {
        period: 10 * k,
        mode: ModeCode::Running,
        values: [x, 0.0, power].into_iter().collect(),
    };
    // Still for 3 samples (beam on), then 20 samples along x at 5 µm per ms, then
    // the beam off.
    for k in 0..3 {
        log.push(at(k, 0.0, 4.0));
    }
    for k in 3..23 {
        log.push(at(k, 5e-6 * (k - 2) as f32, 4.0));
    }
    log.push(at(23, 1.05e-4, 0.0));
    let energy = log.energy_per_length();
    assert_eq!(energy.len(), 20);
    for (_, e) in &energy {
        // f32 positions: 6e-8 relative of 0.1 mm over a 5 µm step.
        assert!((e - 0.8).abs() < 1e-4, "{e}");
    }
    let median = log.summary().energy_median_j_per_mm.unwrap();
    assert!((median - 0.8).abs() < 1e-4);
    assert!(log
        .summary()
        .to_string()
        .contains("energy per length median 0.800 J/mm"));
    assert!(log.svg("run").unwrap().contains("energy per length, J/mm"));
}
