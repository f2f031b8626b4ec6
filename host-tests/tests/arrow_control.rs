//! ARROW's PID with computed feedforward on the simulated machine (A 3.2–3.3):
//! the regularization against the geometric error, and the
//! anti-windup in saturation. Pictures in `<target>/<profile>/plots/`.

use host_tests::arrow::{hold, quintic_move, run, ArrowRunConfig, ArrowSample};
use host_tests::plot::{plots_dir, time_series, Series};
use kerf::kinematics::arrow::Pose;

fn config(regularize: bool) -> ArrowRunConfig {
    ArrowRunConfig::published(true, regularize, 10_000)
}

fn series(samples: &[ArrowSample], f: impl Fn(&ArrowSample) -> f64) -> Vec<(f64, f64)> {
    samples.iter().map(|s| (s.t_s, f(s))).collect()
}

/// Holding a pose for 2 s with the model's references on the plant with its
/// geometric error: without regularization the integrators build internal forces
/// (the actuators pushing against each other, growing with time); with it they stay
/// at the level of the encoder quantization.
#[test]
fn regularization_keeps_internal_forces_from_building() {
    let pose = Pose::new(0.1, 0.5, 0.05, 0.2);
    let plain = run(&config(false), &hold(pose)).unwrap();
    let regular = run(&config(true), &hold(pose)).unwrap();
    let at = |s: &[ArrowSample], t: f64| s[(t / 2e-4) as usize - 1].internal_force_n;
    let last = |s: &[ArrowSample]| s.last().unwrap().internal_force_n;
    println!(
        "internal force at 0.05 / 0.2 / 2 s: without regularization {:.0} / {:.0} / {:.0} N, with {:.1e} / {:.1e} / {:.1e} N",
        at(&plain, 0.05),
        at(&plain, 0.2),
        last(&plain),
        at(&regular, 0.05),
        at(&regular, 0.2),
        last(&regular)
    );
    println!(
        "pose error at 2 s (mm): without {:.4}, with {:.4}",
        plain.last().unwrap().pose_error.fixed_rows::<3>(0).amax() * 1e3,
        regular.last().unwrap().pose_error.fixed_rows::<3>(0).amax() * 1e3
    );
    // The proportional term's share at once, then growing with the integrators
    // until the actuators' 2,500 N bound it.
    assert!(last(&plain) > at(&plain, 0.05) + 1000.0);
    assert!(last(&plain) > 1000.0);
    assert!(last(&regular) < 1e-6 * last(&plain).max(1.0) + 1e-6);
    let dir = plots_dir().unwrap();
    let a = series(&plain, |s| s.internal_force_n);
    let b = series(&regular, |s| s.internal_force_n);
    time_series(
        &dir.join("arrow_internal_forces.svg"),
        "ARROW holding a pose under a geometric error: internal force |(I − Rm) Γ|",
        "internal force (N)",
        &[
            Series::new("PID without regularization", &a, 2),
            Series::new("regularized PID (Rm on input, output, integral)", &b, 1),
        ],
    )
    .unwrap();
}

/// Sustained saturation: a 2 mm move in x (a quintic over 50 ms from 0.05 s) runs
/// into a wall 0.5 mm on (a tool stalled in hard material) that gives way at 0.4 s.
/// Against the wall the actuators saturate for 0.3 s. Without anti-windup the
/// integrators grow the whole time and, when the wall goes, throw the plate past its
/// target; with back-calculation at A's K_AWP the integral holds still (it
/// keeps the command at the limit) and the plate arrives without overshoot, from
/// below: what the integral held back unwinds with its time constant K_P/K_I =
/// 0.29 s.
#[test]
fn anti_windup_bounds_the_integrator_in_saturation() {
    let pose = Pose::new(0.0, 0.5, 0.0, 0.0);
    let jump = Pose::new(0.002, 0.0, 0.0, 0.0);
    let mut with = config(true);
    with.periods = 7500;
    with.wall = Some((0.0005, 0.4));
    let mut without = with;
    without.parallel.k_awp = 0.0;
    let reference = quintic_move(pose, jump, 0.05, 0.05);
    let a = run(&with, &reference).unwrap();
    let b = run(&without, &reference).unwrap();
    let at = |s: &[ArrowSample], t: f64| s[(t / 2e-4) as usize - 1];
    // The integral's mean over the actuators (the x direction: Jm's first column is
    // all ones) at 0.2 s and at 0.4 s, against the wall.
    let growth = |s: &[ArrowSample]| at(s, 0.4).integral_n.mean() - at(s, 0.2).integral_n.mean();
    let after = |s: &[ArrowSample]| {
        s.iter()
            .filter(|s| s.t_s > 0.4)
            .map(|s| s.pose_error.x)
            .fold(f64::MIN, f64::max)
    };
    let saturated = |s: &[ArrowSample]| s.iter().filter(|s| s.saturated).count();
    println!(
        "wall 0.1-0.4 s: saturated periods {} / {}; integral growth 0.2-0.4 s {:.0} / {:.0} N; overshoot after release {:.3} / {:.3} mm; error at 1.5 s {:.3} / {:.3} mm (with / without anti-windup)",
        saturated(&a),
        saturated(&b),
        growth(&a),
        growth(&b),
        after(&a) * 1e3,
        after(&b) * 1e3,
        a.last().unwrap().pose_error.x * 1e3,
        b.last().unwrap().pose_error.x * 1e3,
    );
    assert!(saturated(&b) > 1000 && saturated(&a) > 1000);
    assert!(growth(&a).abs() < 100.0, "{}", growth(&a));
    assert!(growth(&b) > 2000.0, "{}", growth(&b));
    assert!(after(&a) < 0.05e-3 && after(&b) > 1e-3);
    let dir = plots_dir().unwrap();
    let xa = series(&a, |s| s.pose_error.x * 1e3);
    let xb = series(&b, |s| s.pose_error.x * 1e3);
    time_series(
        &dir.join("arrow_wall_anti_windup.svg"),
        "ARROW: 2 mm move against a wall (0.5 mm, until 0.4 s), actuators saturated",
        "x error (mm)",
        &[
            Series::new("back-calculation anti-windup (K_AWP 0.00166)", &xa, 1),
            Series::new("no anti-windup", &xb, 2),
        ],
    )
    .unwrap();
    let ia = series(&a, |s| s.integral_n.mean());
    let ib = series(&b, |s| s.integral_n.mean());
    time_series(
        &dir.join("arrow_wall_integral.svg"),
        "ARROW against the wall: integral term (mean over the actuators)",
        "integral force (N)",
        &[
            Series::new("back-calculation anti-windup (K_AWP 0.00166)", &ia, 1),
            Series::new("no anti-windup", &ib, 2),
        ],
    )
    .unwrap();
}
