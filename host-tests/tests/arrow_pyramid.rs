//! The pyramid of A §5 (fig. 26–27) machined by the simulated ARROW:
//! the G-code file the firmware image carries, read into a job on the machine,
//! run through the supervisor at 5 kHz against the plant with its geometric error,
//! and the RMS tracking errors of eq. 55–58 beside A table 3, with and without the
//! computed feedforward and the regularization. Pictures in `<target>/<profile>/plots/`.

use host_tests::arrow::{job_from_gcode, rms as tracking, run_job, ArrowRunConfig, JobRun};
use host_tests::plot::{line_plot, plots_dir, time_series, Series};
use kerf::app::supervisor::Mode;
use kerf_sim::arrow::{TrackingRms, PYRAMID_GCODE};

/// A table 3: Cartesian 7.06 µm and 0.0170°, joint 6.88 µm and 0.0240°.
const PUBLISHED: TrackingRms = TrackingRms {
    cartesian_m: 7.06e-6,
    cartesian_deg: 0.0170,
    joint_m: 6.88e-6,
    joint_deg: 0.0240,
    joint_consistent_m: f64::NAN,
    true_cartesian_m: f64::NAN,
};

fn config(feedforward: bool, regularize: bool) -> ArrowRunConfig {
    ArrowRunConfig::published(feedforward, regularize, 0)
}

fn run(feedforward: bool, regularize: bool) -> JobRun {
    let job = job_from_gcode(PYRAMID_GCODE).unwrap();
    run_job(
        &config(feedforward, regularize),
        &job,
        u64::MAX,
        &mut |_, _| {},
    )
    .unwrap()
}

#[test]
fn the_pyramid_is_tracked_within_the_seeds_figures_with_feedforward() {
    let job = job_from_gcode(PYRAMID_GCODE).unwrap();
    let cases = [(true, true), (false, true), (true, false), (false, false)];
    let runs: Vec<(bool, bool, JobRun)> = std::thread::scope(|scope| {
        let handles: Vec<_> = cases
            .iter()
            .map(|&(ff, reg)| scope.spawn(move || (ff, reg, run(ff, reg))))
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    println!(
        "A table 3: Cartesian {:.2} µm {:.4}°, joint {:.2} µm {:.4}°",
        PUBLISHED.cartesian_m * 1e6,
        PUBLISHED.cartesian_deg,
        PUBLISHED.joint_m * 1e6,
        PUBLISHED.joint_deg
    );
    let mut rms = Vec::new();
    for (ff, reg, run) in &runs {
        let r = tracking(&run.samples);
        let saturated = run.samples.iter().filter(|s| s.saturated).count();
        let peak = run
            .samples
            .iter()
            .map(|s| s.outputs.forces_n.amax())
            .fold(0.0, f64::max);
        println!(
            "feedforward {ff:5}, regularization {reg:5}: {} periods ({:.2} s), mode {:?}; eq. 55 {:.2} µm, eq. 56 {:.4}°, eq. 57 {:.2} µm (Rm q̃ {:.2} µm), eq. 58 {:.4}°; true pose {:.1} µm; peak force {peak:.0} N, saturated periods {saturated}",
            run.samples.len(),
            run.samples.len() as f64 * 2e-4,
            run.mode,
            r.cartesian_m * 1e6,
            r.cartesian_deg,
            r.joint_m * 1e6,
            r.joint_consistent_m * 1e6,
            r.joint_deg,
            r.true_cartesian_m * 1e6,
        );
        assert_eq!(run.mode, Mode::Ready, "the job ran to its end");
        assert_eq!(run.samples.len() as u64, job.periods());
        rms.push(r);
    }
    let full = rms[0];
    let no_ff = rms[1];
    let (no_reg, none) = (rms[2], rms[3]);
    // With feedforward and regularization: within the published figures (a simulation
    // has no friction or cogging; its errors come from the encoder steps, the
    // model's geometric error and the control delay). Eq. 57 as printed also counts
    // the joints' inconsistency under the plant's uncalibrated geometric error
    // (0.1-0.3 mm, constant, `ArrowPlantConfig::with_geometric_error`), which no
    // controller removes and A's calibrated machine did not have: its part
    // that moves the plate, Rm q̃, is the figure to set beside table 3. It is the
    // one figure above A's: 11.4 µm against 6.88 µm (the six joints' error
    // summed in eq. 57 against the three Cartesian coordinates of eq. 55), bounded
    // here at twice A's.
    assert!(full.cartesian_m < PUBLISHED.cartesian_m, "{full:?}");
    assert!(
        full.joint_consistent_m < 2.0 * PUBLISHED.joint_m,
        "{full:?}"
    );
    assert!(full.cartesian_deg < PUBLISHED.cartesian_deg && full.joint_deg < PUBLISHED.joint_deg);
    assert!(
        full.joint_m > 1e-4 && full.joint_m < 3e-4,
        "the inconsistency: {full:?}"
    );
    // The feedforward carries the inertial and gravity forces the PID would otherwise
    // have to build from error: about half the Cartesian error, a quarter of the
    // turntable's.
    assert!(
        no_ff.cartesian_m > 1.5 * full.cartesian_m,
        "{no_ff:?} {full:?}"
    );
    assert!(no_ff.joint_deg > 2.0 * full.joint_deg, "{no_ff:?} {full:?}");
    // Without regularization the integrators push the actuators against each other
    // into their limits, and the plate is pulled off the path by tenths of a mm.
    for r in [no_reg, none] {
        assert!(r.cartesian_m > 30.0 * full.cartesian_m, "{r:?}");
    }
    let saturated = |i: usize| runs[i].2.samples.iter().filter(|s| s.saturated).count();
    assert_eq!(saturated(0), 0);
    assert!(saturated(2) > runs[2].2.samples.len() / 4);

    let dir = plots_dir().unwrap();
    let (_, _, best) = &runs[0];
    let path: Vec<(f64, f64)> = best
        .samples
        .iter()
        .map(|s| (s.desired.x * 1e3, s.desired.z * 1e3))
        .collect();
    let actual: Vec<(f64, f64)> = best
        .samples
        .iter()
        .map(|s| {
            let p = s.desired + s.cartesian_error;
            (p.x * 1e3, p.z * 1e3)
        })
        .collect();
    line_plot(
        &dir.join("arrow_pyramid_path.svg"),
        "ARROW pyramid (A fig. 26-27): tool point seen along y",
        "x (mm)",
        "z (mm)",
        &[
            Series::new("desired (G-code spline at 25 mm/s)", &path, 0),
            Series::new("measured (encoders through the model)", &actual, 1),
        ],
    )
    .unwrap();
    let err = |i: usize| -> Vec<(f64, f64)> {
        runs[i]
            .2
            .samples
            .iter()
            .map(|s| {
                (
                    s.k as f64 * 2e-4,
                    s.cartesian_error.fixed_rows::<3>(0).norm() * 1e6,
                )
            })
            .collect()
    };
    let (a, b) = (err(0), err(1));
    time_series(
        &dir.join("arrow_pyramid_error.svg"),
        "ARROW pyramid: Cartesian tracking error |X̃| (eq. 55's term)",
        "error (µm)",
        &[
            Series::new("PID + feedforward, regularized", &a, 1),
            Series::new("PID alone, regularized", &b, 2),
        ],
    )
    .unwrap();
    let forces: Vec<Vec<(f64, f64)>> = (0..6)
        .map(|j| {
            best.samples
                .iter()
                .map(|s| (s.k as f64 * 2e-4, s.outputs.forces_n[j]))
                .collect()
        })
        .collect();
    let saturated: Vec<(f64, f64)> = best
        .samples
        .iter()
        .map(|s| {
            (
                s.k as f64 * 2e-4,
                if s.saturated { 2500.0 } else { f64::NAN },
            )
        })
        .collect();
    let labels = ["Γ1", "Γ2", "Γ3", "Γ4", "Γ5", "Γ6"];
    let mut series: Vec<Series> = forces
        .iter()
        .zip(labels)
        .enumerate()
        .map(|(j, (f, l))| Series::new(l, f, j % 6))
        .collect();
    series.push(Series::new("at the 2,500 N limit", &saturated, 2));
    time_series(
        &dir.join("arrow_pyramid_forces.svg"),
        "ARROW pyramid: actuator forces (PID + feedforward)",
        "force (N)",
        &series,
    )
    .unwrap();
}

/// The QEMU image's scenario (one RK4 step per period) in f64, printed in the image's
/// format for `scripts/smoke` to compare within `ARROW_F32_TOLERANCE`.
#[test]
fn the_smoke_pyramid_in_f64() {
    let mut points = Box::new(heapless::Vec::new());
    let mut job = Box::<kerf::machines::arrow::product::Job<f64>>::default();
    kerf::machines::arrow::product::load_job(PYRAMID_GCODE.as_bytes(), &mut points, &mut job)
        .unwrap();
    let mut sums = kerf_sim::arrow::TrackingSums::default();
    let end = kerf_sim::arrow::run_job::<f64>(
        &kerf_sim::arrow::ArrowScenario::smoke(),
        &job,
        u64::MAX,
        &mut |_, _| {},
        &mut |p| sums.push(p),
    )
    .unwrap();
    let r = sums.rms();
    let nm = |m: f64| (m * 1e9).round() as i64;
    let udeg = |d: f64| (d * 1e6).round() as i64;
    println!(
        "host arrow (f64): {} periods, eq. 55 {} nm, eq. 56 {} udeg, eq. 57 {} nm (Rm q {} nm), eq. 58 {} udeg",
        end.periods,
        nm(r.cartesian_m),
        udeg(r.cartesian_deg),
        nm(r.joint_m),
        nm(r.joint_consistent_m),
        udeg(r.joint_deg)
    );
    assert_eq!(end.mode, Mode::Ready);
    assert!(kerf_sim::arrow::ARROW_SMOKE_BOUNDS.holds(&r), "{r:?}");
}
