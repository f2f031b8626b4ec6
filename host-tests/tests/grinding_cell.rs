//! G's grinding experiments on the simulated cell (G ch. 7–8):
//! PID and ADRC at 7.5 N and 10 N, then contour tracking at 1 N with the spindle
//! stopped. Pictures in `<target>/<profile>/plots/grinding_*.svg`.

use hal_mock::grinding_cell::CellConfig;
use host_tests::grinding::{
    describe, figures, run_pass, seed_pass, NotGround, PassFigures, PassRun,
};
use host_tests::plot::{line_plot, plots_dir, time_series, Series};
use kerf::app::supervisor::Mode;
use kerf::machines::grinding::{ForceLawKind, GrindingConfig, GrindingFault};

/// 8 mm at 0.1 mm/s: 80 s, two periods of the test surface.
const LENGTH_M: f64 = 8e-3;
const MAX_PERIODS: usize = 120_000;

fn plot_pass(name: &str, title: &str, run: &PassRun, reference_n: f64) {
    let dir = plots_dir().unwrap();
    let measured: Vec<(f64, f64)> = run.samples.iter().map(|s| (s.t_s, s.measured_n)).collect();
    let truth: Vec<(f64, f64)> = run
        .samples
        .iter()
        .map(|s| (s.t_s, s.cell.normal_force_n))
        .collect();
    let reference: Vec<(f64, f64)> = run.samples.iter().map(|s| (s.t_s, reference_n)).collect();
    time_series(
        &dir.join(format!("grinding_{name}_force.svg")),
        &format!("{title}: normal force"),
        "normal force (N)",
        &[
            Series::new("measured (with G's 0.8 N² noise)", &measured, 5),
            Series::new("true", &truth, 1),
            Series::new("reference", &reference, 0),
        ],
    )
    .unwrap();
    let before: Vec<(f64, f64)> = run
        .x_m
        .iter()
        .zip(&run.before_m)
        .map(|(x, h)| (x * 1e3, h * 1e3))
        .collect();
    let after: Vec<(f64, f64)> = run
        .x_m
        .iter()
        .zip(&run.after_m)
        .map(|(x, h)| (x * 1e3, h * 1e3))
        .collect();
    line_plot(
        &dir.join(format!("grinding_{name}_surface.svg")),
        &format!("{title}: surface before and after"),
        "x along the feed (mm)",
        "height (mm)",
        &[
            Series::new("before", &before, 0),
            Series::new("after one pass", &after, 2),
        ],
    )
    .unwrap();
}

/// One experiment: the pass of `config` with `law` at `force`, its figures printed
/// beside G's surface MSE, and its pictures.
fn experiment(
    config: GrindingConfig,
    law: ForceLawKind,
    force: f64,
    name: &str,
    title: &str,
    published_mse: f64,
) -> (Mode<GrindingFault>, Result<PassFigures, NotGround>) {
    let mut setup = seed_pass(law, force, LENGTH_M);
    setup.config = config;
    let run = run_pass(&setup, MAX_PERIODS);
    let f = figures(&run, force, 5.0, setup.cell.tool_radius_m);
    println!(
        "{title}: {:?} after {:.1} s; {} (G's surface form MSE {published_mse} mm²)",
        run.mode,
        run.samples.len() as f64 * 1e-3,
        describe(&f),
    );
    plot_pass(name, title, &run, force);
    (run.mode, f)
}

/// G's three grinding experiments with its gains (G 8.1–8.3) at the unit where
/// they work (10 pm per unit, `published_gain_unit_scan`), and whether PID beats ADRC on
/// the surface form as G found (0.00174 against 0.0043 mm²).
#[test]
fn published_experiments() {
    let cases = [
        (
            ForceLawKind::Pid,
            7.5,
            "pid_7_5N",
            "PID, Fn = 7.5 N",
            0.00174,
        ),
        (ForceLawKind::Pid, 10.0, "pid_10N", "PID, Fn = 10 N", 0.0036),
        (
            ForceLawKind::Adrc,
            7.5,
            "adrc_7_5N",
            "ADRC, Fn = 7.5 N",
            0.0043,
        ),
    ];
    let (mut mse, mut modes) = (Vec::new(), Vec::new());
    for (law, force, name, title, published_mse) in cases {
        let (mode, f) = experiment(
            GrindingConfig::PUBLISHED,
            law,
            force,
            name,
            title,
            published_mse,
        );
        mse.push(f.map(|f| f.form_mse_mm2));
        modes.push(mode);
    }
    // G's PID gains complete both passes; its ADRC gains drive the tool into
    // the workpiece past the crash limit on this cell (the fault stops it safely).
    assert_eq!(modes[..2], [Mode::Ready, Mode::Ready]);
    // Completing the pass is not grinding it: at 10 N the PID removes material all
    // along, at 7.5 N it leaves a tenth of the stretch untouched (measured 90 %
    // ground, 5.8 N RMS force error), so only the 10 N pass has surface figures.
    assert!(mse[1].is_ok(), "{mse:?}");
    assert!(
        matches!(mse[0], Err(NotGround::Partly { ground_fraction, .. }) if ground_fraction > 0.8),
        "{mse:?}"
    );
    assert_eq!(modes[2], Mode::Fault(GrindingFault::ForceLimit));
    println!(
        "surface form MSE at 7.5 N: PID {:?} mm², ADRC {:?} (G: PID 0.00174, ADRC 0.0043 mm²)",
        mse[0], modes[2]
    );
}

/// The same experiments with the gains tuned on the cell (`GrindingConfig::TUNED`):
/// figures beside G's, and whether PID beats ADRC.
#[test]
fn tuned_experiments() {
    let cases = [
        (
            ForceLawKind::Pid,
            7.5,
            "tuned_pid_7_5N",
            "tuned PID, Fn = 7.5 N",
            0.00174,
        ),
        (
            ForceLawKind::Pid,
            10.0,
            "tuned_pid_10N",
            "tuned PID, Fn = 10 N",
            0.0036,
        ),
        (
            ForceLawKind::Adrc,
            7.5,
            "tuned_adrc_7_5N",
            "tuned ADRC, Fn = 7.5 N",
            0.0043,
        ),
    ];
    let mut results = Vec::new();
    for (law, force, name, title, published_mse) in cases {
        let (mode, f) = experiment(
            GrindingConfig::TUNED,
            law,
            force,
            name,
            title,
            published_mse,
        );
        assert_eq!(mode, Mode::Ready, "{title}");
        // The tuned ADRC completes the pass but touches only in places (its force
        // error is the best the search found, 6 N RMS): it has no surface figures, and
        // only the force loops can be compared. The PID grinds all along.
        let force_rms = match f {
            Ok(f) => {
                assert!(f.mean_depth_um > 1.0 && f.form_mse_mm2 >= 0.0, "{title}");
                assert!(f.force_rms_error_n < 1.0, "{title}");
                f.force_rms_error_n
            }
            Err(NotGround::Partly {
                ground_fraction,
                force_rms_error_n: Some(e),
            }) => {
                assert_eq!(law, ForceLawKind::Adrc, "{title}: {ground_fraction}");
                e
            }
            Err(e) => panic!("{title}: {e}"),
        };
        results.push(force_rms);
    }
    println!(
        "tuned at 7.5 N: force RMS error PID {:.3} N, ADRC {:.3} N: the PID grinds the surface and holds the force; the ADRC does neither (G measured both grinding: surface MSE 0.00174 against 0.0043 mm²)",
        results[0], results[2]
    );
    assert!(results[0] < results[2]);
}

/// Contour tracking (G 7.3, 8.4): the spindle stopped, 1 N, the tool rolls on the
/// surface without cutting; the path of its lowest point measures the surface's form
/// (G: 0.000724 mm² against a laser scan).
#[test]
fn contour_tracking_measures_the_form() {
    let mut setup = seed_pass(ForceLawKind::Pid, 1.0, LENGTH_M);
    setup.cell = CellConfig {
        spindle_rpm: 0.0,
        ..setup.cell
    };
    setup.job.spindle_rpm = 0.0;
    let run = run_pass(&setup, MAX_PERIODS);
    assert_eq!(run.mode, Mode::Ready);
    let first = run
        .samples
        .iter()
        .position(|s| s.cell.normal_force_n > 0.0)
        .unwrap();
    let settle = first + 5000;
    // The tool's lowest point under the force: its height is the retracted height less
    // the extension; where the surface is under it the difference is the contact's
    // deflection (1 N on 1 N/µm: 1 µm) plus the form error.
    let retracted = setup.cell.retracted_bottom_m;
    let mut errors = Vec::new();
    let mut traced = Vec::new();
    for s in &run.samples[settle..] {
        let bottom = retracted - s.cell.piezo_position_m;
        let surface = setup.cell.surface.height_m(s.cell.x_m);
        errors.push(bottom - surface);
        traced.push((s.cell.x_m * 1e3, bottom * 1e3));
    }
    let n = errors.len() as f64;
    let mean = errors.iter().sum::<f64>() / n;
    let mse = errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / n * 1e6;
    println!("contour tracking at 1 N: {:.1} s, form MSE against the true surface {mse:.6} mm² (G 0.000724 mm² against a laser scan); mean offset {:.2} µm", run.samples.len() as f64 * 1e-3, mean * 1e6);
    let truth: Vec<(f64, f64)> = traced
        .iter()
        .map(|(x, _)| (*x, setup.cell.surface.height_m(x * 1e-3) * 1e3))
        .collect();
    line_plot(
        &plots_dir().unwrap().join("grinding_contour_tracking.svg"),
        "Contour tracking at 1 N, spindle stopped",
        "x along the feed (mm)",
        "height (mm)",
        &[
            Series::new("surface", &truth, 0),
            Series::new("traced by the tool", &traced, 1),
        ],
    )
    .unwrap();
    assert!(mse < 0.000724, "{mse}");
}

/// The unit of G's law output (not printed): a PID pass of 4 mm with G's
/// gains for units from 1 µm down. At 10 nm and above the force noise alone, through
/// K_P and K_D, asks for piezo steps beyond the rate limit: the piezo chatters, the
/// chatter takes the whole feed (V_hex = 0) and the pass never ends; at 1 nm and
/// 0.1 nm the loop engages but overshoots into the workpiece past the 40 N crash
/// limit; at 30 pm and 10 pm it completes the 4 mm pass but grinds none of it
/// (measured 0 % of the stretch, 5.5–5.8 N RMS force error against 7.5 N).
#[test]
fn published_gain_unit_scan() {
    let mut engaged = Vec::new();
    for unit in [1e-6, 1e-8, 1e-9, 1e-10, 3e-11, 1e-11] {
        let mut setup = seed_pass(ForceLawKind::Pid, 7.5, 4e-3);
        setup.config.hybrid.increment_unit_m = unit;
        let run = run_pass(&setup, 60_000);
        let f = figures(&run, 7.5, 5.0, setup.cell.tool_radius_m);
        println!(
            "unit {unit:e} m: {:?} after {:.1} s, {}",
            run.mode,
            run.samples.len() as f64 * 1e-3,
            describe(&f)
        );
        engaged.push(run.mode);
    }
    assert!(
        engaged[..2].iter().all(|m| *m == Mode::Running),
        "{engaged:?}"
    );
    assert!(
        engaged[2..4].iter().all(|m| matches!(m, Mode::Fault(_))),
        "{engaged:?}"
    );
    assert!(
        engaged[4..].iter().all(|m| *m == Mode::Ready),
        "{engaged:?}"
    );
}
