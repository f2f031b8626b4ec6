use super::*;
use crate::trajectory::gcode::{feed_runs, parse, GcodePoint, MoveKind};
use crate::trajectory::task_spline::{KnotSpacing, TaskSplineConfig};
use std::println;
use std::vec::Vec;

/// The time-optimal rest-to-rest duration of one degree of freedom under |v| ≤ V,
/// |a| ≤ A, |j| ≤ J over a distance L — the profile Ruckig computes for this case —
/// in closed form by cases (not the planner's bisection): reach V (with or without
/// reaching A) and cruise, or peak below V with A reached (the peak vp solves
/// vp² + vp·A²/J − A·L = 0), or below both (four jerk phases of (L/2J)^⅓).
fn time_optimal_s(l: f64, v: f64, a: f64, j: f64) -> f64 {
    // Distance of the shortest rest → v → rest with no cruise.
    let (t_acc, reaches_a) = if v * j >= a * a {
        (v / a + a / j, true)
    } else {
        (2.0 * (v / j).sqrt(), false)
    };
    if v * t_acc <= l {
        return l / v + t_acc;
    }
    if reaches_a {
        let vp = 0.5 * (-a * a / j + ((a * a / j).powi(2) + 4.0 * a * l).sqrt());
        if vp * j >= a * a {
            return 2.0 * (vp / a + a / j);
        }
    }
    4.0 * (l / (2.0 * j)).cbrt()
}

#[test]
fn the_reference_is_the_known_profile_in_each_case() {
    // Long move, V and A reached: 1 m at 0.1 m/s, A 1, J 10: ramp 0.1 + 0.1 s.
    assert!((time_optimal_s(1.0, 0.1, 1.0, 10.0) - (10.0 + 0.2)).abs() < 1e-12);
    // V reached without A (V < A²/J): ramp 2√(V/J).
    assert!((time_optimal_s(1.0, 0.1, 10.0, 10.0) - (10.0 + 2.0 * 0.01f64.sqrt())).abs() < 1e-12);
    // Very short: four jerk phases t with 2Jt³ = L.
    let t = (1e-6f64 / 20.0).cbrt();
    assert!((time_optimal_s(1e-6, 0.1, 1.0, 10.0) - 4.0 * t).abs() < 1e-15);
}

/// Checks a plan's limits and exact length; returns (duration / time-optimal, excess).
fn check_plan(l: f64, limits: &FeedLimits) -> (f64, f64) {
    let plan = FeedPlan::rest_to_rest(l, limits).unwrap();
    let tol = 1.0 + 1e-12;
    assert!(plan.speed_m_s <= limits.feed_m_s * tol, "{plan:?}");
    assert!(plan.accel_m_s2() <= limits.accel_m_s2 * tol, "{plan:?}");
    assert!(plan.jerk_m_s3() <= limits.jerk_m_s3 * tol, "{plan:?}");
    let covered = plan.speed_m_s * plan.ts_s * f64::from(plan.ramp_periods() + plan.n_cruise);
    assert!((covered - l).abs() <= 1e-12 * l, "{plan:?}");
    let optimal = time_optimal_s(l, limits.feed_m_s, limits.accel_m_s2, limits.jerk_m_s3);
    (plan.duration_s() / optimal, plan.duration_s() - optimal)
}

#[test]
fn plans_honour_the_limits_and_stay_within_four_periods_of_time_optimal() {
    let mut worst = (f64::INFINITY, 0.0f64, 0.0f64);
    for l in [1e-5, 3e-4, 2e-3, 0.01, 0.1, 1.0, 3.7] {
        for feed in [0.025, 0.1, 0.5] {
            for accel in [0.5, 2.0, 20.0] {
                for jerk in [10.0, 100.0, 5000.0] {
                    for ts in [2e-4, 1e-3] {
                        let limits = FeedLimits {
                            feed_m_s: feed,
                            accel_m_s2: accel,
                            jerk_m_s3: jerk,
                            ts_s: ts,
                        };
                        let (ratio, excess) = check_plan(l, &limits);
                        // Never faster than the time-optimal profile under the same
                        // limits (the plan honours them); slower only by rounding
                        // its phases to whole periods: four jerk phases and the
                        // cruise each round up by less than a period, the flat
                        // phases are absorbed in the cruise (module docs).
                        assert!(ratio >= 1.0 - 1e-12, "{l} {limits:?}: {ratio}");
                        assert!(excess <= 4.0 * ts + 1e-12, "{l} {limits:?}: {excess}");
                        worst = (
                            worst.0.min(ratio),
                            worst.1.max(ratio),
                            worst.2.max(excess / ts),
                        );
                    }
                }
            }
        }
    }
    println!(
        "plan / time-optimal: ratio in [{:.6}, {:.4}], at most {:.2} periods longer",
        worst.0, worst.1, worst.2
    );
}

/// A eq. 53 (start) and eq. 54 (stop, from the peak V′) at time t of a phase.
fn eq53(t: f64, j: f64, a: f64, t1: f64, t2: f64) -> f64 {
    if t < t1 {
        j * t * t / 2.0
    } else if t < t2 {
        j * t1 * t1 / 2.0 + a * (t - t1)
    } else {
        j * t1 * t1 / 2.0 + a * (t2 - t1) + a * (t - t2) - j * (t - t2).powi(2) / 2.0
    }
}

#[test]
fn the_ramp_follows_a_eq_51_to_54_period_by_period() {
    let limits = FeedLimits {
        feed_m_s: 0.025,
        accel_m_s2: 2.0,
        jerk_m_s3: 100.0,
        ts_s: 2e-4,
    };
    for l in [0.2, 4e-4] {
        let plan = FeedPlan::rest_to_rest(l, &limits).unwrap();
        let mut ramp = plan.ramp::<f64>().unwrap();
        let (j, a, v) = (plan.jerk_m_s3(), plan.accel_m_s2(), plan.speed_m_s);
        let t1 = f64::from(plan.n_jerk) * plan.ts_s;
        let t2 = f64::from(plan.n_jerk + plan.n_flat) * plan.ts_s;
        let t3 = f64::from(plan.ramp_periods()) * plan.ts_s;
        let t_stop = t3 + f64::from(plan.n_cruise) * plan.ts_s;
        ramp.start();
        let mut travelled = 0.0;
        for k in 1..=plan.periods() {
            if k == plan.ramp_periods() + plan.n_cruise + 1 || plan.n_cruise == 0 {
                ramp.stop();
            }
            let s = ramp.step();
            let t = f64::from(k) * plan.ts_s;
            let expected = if t <= t3 {
                eq53(t, j, a, t1, t2)
            } else if t <= t_stop {
                v
            } else {
                v - eq53(t - t_stop, j, a, t1, t2)
            };
            // Exact integration per period in f64: rounding only.
            assert!((s.v - expected).abs() < 1e-12, "{k}: {} {expected}", s.v);
            assert!(s.v <= limits.feed_m_s * (1.0 + 1e-12) && s.v >= -1e-15);
            assert!(s.a.abs() <= limits.accel_m_s2 * (1.0 + 1e-12));
            assert!(s.j.abs() <= limits.jerk_m_s3 * (1.0 + 1e-12));
            travelled += s.ds;
        }
        assert!(ramp.is_at_rest());
        assert!(
            (travelled - l).abs() < 1e-12 * l.max(1e-3),
            "{travelled} {l}"
        );
    }
}

/// A 5-axis helix: radius 50 mm about y around the workspace centre, 20 mm per turn,
/// the angles swinging ±20°; 48 points over 1.5 turns.
fn helix() -> Vec<Pose<f64>> {
    (0..48)
        .map(|i| {
            let phi = 3.0 * core::f64::consts::PI * f64::from(i) / 47.0;
            Pose::new(
                0.05 * phi.cos(),
                0.5 + 0.02 * phi / (2.0 * core::f64::consts::PI),
                0.05 * phi.sin(),
                0.35 * (2.0 * phi).sin(),
                0.35 * phi.cos(),
            )
        })
        .collect()
}

const LIMITS: FeedLimits = FeedLimits {
    feed_m_s: 0.025,
    accel_m_s2: 2.0,
    jerk_m_s3: 100.0,
    ts_s: 2e-4,
};

/// How far a step's chord may fall short of its arc Δs: κ²Δs³/24 (the chord of an arc
/// of curvature κ; κ from the spline's derivatives where the step ends, in the
/// metric, with 10 % for its change over the step), plus 1e-14 m of rounding of the
/// ~0.5 m coordinates (their ulp is 1.1e-16) and of the Newton step.
fn chord_bound<const N: usize>(spline: &TaskSpline<f64, N>, s: &FeedSample<f64>) -> f64 {
    let d = spline.evaluate(s.segment, s.parameter);
    let (d11, d12, d22) = (
        spline.metric_dot(&d.d1, &d.d1),
        spline.metric_dot(&d.d1, &d.d2),
        spline.metric_dot(&d.d2, &d.d2),
    );
    let kappa2 = (d11 * d22 - d12 * d12).max(0.0) / (d11 * d11 * d11);
    1.1 * kappa2 * s.step_m.powi(3) / 24.0 + 1e-14
}

/// Runs a whole move; returns every sample.
fn run<T: Float, const N: usize>(spline: &TaskSpline<T, N>, plan: &FeedPlan) -> Vec<FeedSample<T>> {
    let mut follower = FeedFollower::<T>::new(plan).unwrap();
    let mut out = Vec::new();
    while !follower.is_done() {
        out.push(follower.step(spline).unwrap());
    }
    out
}

#[test]
fn every_step_moves_the_planned_arc_and_the_move_ends_on_the_last_point() {
    let config = TaskSplineConfig {
        knots: KnotSpacing::Centripetal,
        angle_length_m_per_rad: 0.05,
    };
    let spline = TaskSpline::<f64, 64>::through(&helix(), &config).unwrap();
    let length = spline.length_m();
    let plan = FeedPlan::rest_to_rest(length, &LIMITS).unwrap();
    let samples = run(&spline, &plan);
    assert_eq!(samples.len(), plan.periods() as usize);
    let mut previous = spline.point(0).unwrap();
    let (mut worst_cruise, mut worst_any) = (0.0f64, 0.0f64);
    let n = samples.len();
    for (k, s) in samples.iter().enumerate() {
        let chord = spline.metric_norm(&(s.pose - previous));
        previous = s.pose;
        if k + 1 == n {
            // The last period also closes what rounding left of the length.
            assert!((chord - s.step_m).abs() < 1e-9, "{chord} {}", s.step_m);
            continue;
        }
        let error = (chord - s.step_m).abs();
        assert!(error <= chord_bound(&spline, s), "{k} {s:?}: {error:e}");
        worst_any = worst_any.max(error);
        if s.speed_m_s == plan.speed_m_s && s.jerk_m_s3 == 0.0 {
            worst_cruise = worst_cruise.max((chord - plan.speed_m_s * LIMITS.ts_s).abs());
        }
    }
    println!(
        "helix: {n} periods, |chord − F·Ts| ≤ {worst_cruise:.2e} m cruising, |chord − Δs| ≤ \
         {worst_any:.2e} m on every step (F·Ts = {:.1e} m)",
        plan.speed_m_s * LIMITS.ts_s
    );
    // Each step is checked above against the chord of its arc (`chord_bound`); on
    // this gentle helix (κ ≈ 20 m⁻¹) that is rounding alone. 1e-12 m is 2e-7 of a
    // step and catches a missed knot crossing (which shortens a step by the part of
    // the arc skipped).
    assert!(worst_any < 1e-12 && worst_cruise < 1e-12);
    let end = samples.last().unwrap();
    assert!((end.pose - spline.point(47).unwrap()).amax() < 1e-15);
    assert_eq!(end.velocity.amax(), 0.0);
}

/// A stop while cruising and one while still accelerating: the speed falls to zero
/// along the plan's mirrored ramp (its jerk, no faster), the distance travelled after
/// the stop is what the ramp covers (summed independently from the per-period
/// speeds), and the follower rests short of the end, where it stopped.
#[test]
fn an_early_stop_ramps_down_along_the_path_and_rests_there() {
    let config = TaskSplineConfig {
        knots: KnotSpacing::Centripetal,
        angle_length_m_per_rad: 0.05,
    };
    let spline = TaskSpline::<f64, 64>::through(&helix(), &config).unwrap();
    let plan = FeedPlan::rest_to_rest(spline.length_m(), &LIMITS).unwrap();
    let ramp = plan.ramp_periods();
    for stop_at in [ramp + 100, ramp / 2] {
        let mut follower = FeedFollower::<f64>::new(&plan).unwrap();
        let mut before = None;
        let (mut travelled, mut after_stop) = (0.0, Vec::new());
        for _ in 0..stop_at {
            before = Some(follower.step(&spline).unwrap());
        }
        follower.stop();
        while !follower.is_done() {
            let s = follower.step(&spline).unwrap();
            travelled += s.step_m;
            after_stop.push(s);
        }
        let speed_at_stop = before.unwrap().speed_m_s;
        // Cruising: the stop ramp at once. Accelerating: the rest of the start ramp,
        // then the stop ramp.
        let expected_periods = stop_at.max(ramp) + ramp - stop_at;
        assert_eq!(after_stop.len() as u32, expected_periods);
        let jerk = plan.jerk_m_s3() * (1.0 + 1e-9);
        assert!(after_stop.iter().all(|s| s.jerk_m_s3.abs() <= jerk));
        let last = *after_stop.last().unwrap();
        assert_eq!(last.speed_m_s, 0.0);
        if stop_at > ramp {
            // From cruise: the ramp covers V·Ts·(2nj + nf)/2 (symmetric S-curve).
            let ramp_m = 0.5 * speed_at_stop * LIMITS.ts_s * f64::from(ramp);
            assert!((travelled - ramp_m).abs() < 1e-12, "{travelled} {ramp_m}");
        }
        // At rest short of the end, and it stays there.
        let end = spline.point(47).unwrap();
        assert!((last.pose - end).amax() > 1e-3);
        let held = follower.step(&spline).unwrap();
        assert_eq!(held.pose, last.pose);
        assert_eq!(held.velocity.amax(), 0.0);
    }
}

#[test]
fn velocity_and_acceleration_match_finite_differences_of_the_pose() {
    let config = TaskSplineConfig {
        knots: KnotSpacing::ChordLength,
        angle_length_m_per_rad: 0.05,
    };
    let spline = TaskSpline::<f64, 64>::through(&helix(), &config).unwrap();
    let plan = FeedPlan::rest_to_rest(spline.length_m(), &LIMITS).unwrap();
    let samples = run(&spline, &plan);
    let ts = LIMITS.ts_s;
    let jerk_max = samples.iter().map(|s| s.jerk.amax()).fold(0.0, f64::max);
    let snap_max = 2.0 * jerk_max / ts;
    let (mut ev, mut ea) = (0.0f64, 0.0f64);
    for w in samples.windows(3).take(samples.len() - 3) {
        let (p0, p1, p2) = (w[0].pose, w[1].pose, w[2].pose);
        ev = ev.max(((p2 - p0) / (2.0 * ts) - w[1].velocity).amax());
        ea = ea.max(((p2 - p1 * 2.0 + p0) / (ts * ts) - w[1].acceleration).amax());
    }
    // Central differences err by Ts²/6·p⃛ (velocity) and Ts²/12·p⁗ (acceleration);
    // p⁗ is bounded here by twice the largest jerk change per period (the jerk is
    // piecewise constant in the ramp), plus rounding of the poses (1e-16/Ts²).
    assert!(
        ev <= ts * ts / 6.0 * jerk_max * 1.01 + 1e-12,
        "{ev} {jerk_max}"
    );
    assert!(
        ea <= ts * ts / 12.0 * snap_max + jerk_max * ts + 1e-8,
        "{ea}"
    );
}

#[test]
fn an_f32_follower_tracks_the_f64_one() {
    let config = TaskSplineConfig {
        knots: KnotSpacing::Centripetal,
        angle_length_m_per_rad: 0.05,
    };
    let s64 = TaskSpline::<f64, 64>::through(&helix(), &config).unwrap();
    let s32 = TaskSpline::<f32, 64>::through(&helix(), &config).unwrap();
    let plan = FeedPlan::rest_to_rest(s64.length_m(), &LIMITS).unwrap();
    let (a, b) = (run(&s64, &plan), run(&s32, &plan));
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x.pose - y.pose.cast::<f64>()).amax())
        .fold(0.0, f64::max);
    println!("f32 follower vs f64 over {} periods: {worst:.2e}", a.len());
    // f32 rounds each step's 5 µm to ~1e-7 relative of the local parameter (the
    // segment parameter stays small) and the 0.5 m coordinates to 3e-8 m; the arc
    // position drifts by at most the sum of step roundings, ~1e-12·periods.
    assert!(worst < 2e-6, "{worst}");
}

#[test]
fn bad_limits_and_lengths_are_refused() {
    let mut limits = LIMITS;
    limits.jerk_m_s3 = 0.0;
    assert!(matches!(
        FeedPlan::rest_to_rest(1.0, &limits),
        Err(FeedError::Config(_))
    ));
    for l in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert_eq!(FeedPlan::rest_to_rest(l, &LIMITS), Err(FeedError::NoLength));
    }
    limits = LIMITS;
    limits.ts_s = 1e-9;
    assert_eq!(
        FeedPlan::rest_to_rest(100.0, &limits),
        Err(FeedError::TooLong)
    );
}

/// A plan built by hand whose periods do not count in a `u32`: refused, where the
/// follower's period count used to wrap (or overflow) on its total.
#[test]
fn hand_built_plans_beyond_a_u32_of_periods_are_refused() {
    let plan = FeedPlan::rest_to_rest(0.01, &LIMITS).unwrap();
    assert!(FeedFollower::<f64>::new(&plan).is_ok());
    let endless = FeedPlan {
        n_cruise: u32::MAX,
        ..plan
    };
    assert_eq!(endless.periods(), u32::MAX);
    assert_eq!(
        FeedFollower::<f64>::new(&endless).err(),
        Some(FeedError::TooLong)
    );
    let long_ramp = FeedPlan {
        n_jerk: 1 << 31,
        ..plan
    };
    assert_eq!(long_ramp.ramp_periods(), u32::MAX);
    assert_eq!(
        FeedFollower::<f64>::new(&long_ramp).err(),
        Some(FeedError::Config(ConfigError::out_of_range("n_jerk")))
    );
}

/// The pyramid of A §5 (fig. 26–27) as the G-code file the experiment runs.
const PYRAMID: &str = include_str!("../../../../../data/pyramid.gcode");

#[test]
fn the_pyramid_file_parses_inside_the_workspace_and_runs_at_constant_feed() {
    let mut points: heapless::Vec<GcodePoint, 512> = heapless::Vec::new();
    let program = parse(PYRAMID.as_bytes(), &mut points).unwrap();
    assert!(program.ended && !program.spindle_on);
    // A eq. 25 workspace: |x| ≤ 0.5 m, |y − y0| ≤ 0.15 m (y0 = 0.5 m), |z| ≤ 0.15 m,
    // |θz|, |θx| ≤ 45°.
    let limit = 45f64.to_radians() + 1e-12;
    for p in &points {
        let [x, y, z] = p.position_m;
        assert!(
            x.abs() <= 0.5 && (y - 0.5).abs() <= 0.15 && z.abs() <= 0.15,
            "{p:?}"
        );
        assert!(p.angles_rad.iter().all(|a| a.abs() <= limit), "{p:?}");
    }
    let runs: Vec<&[GcodePoint]> = feed_runs(&points).collect();
    assert_eq!(runs.len(), 2, "plunge, then the contour passes");
    let contour = runs[1];
    assert!(contour[1..].iter().all(|p| p.kind == MoveKind::Feed));
    let feed = contour[1].feed_m_s;
    assert!((feed - 0.025).abs() < 1e-15);
    // Every cutting point on the pyramid: half width ∝ depth from the apex.
    let (b, h) = (0.08, 0.08 * 30f64.to_radians().tan());
    let apex_y = 0.5 - h / 2.0;
    for p in &contour[1..] {
        let [x, y, z] = p.position_m;
        let half = b * (y - apex_y) / h;
        assert!((x.abs().max(z.abs()) - half).abs() < 2e-6, "{p:?}");
    }
    // A's spline is in the tool point (A eq. 48): ρ = 0.
    let mut deviations = Vec::new();
    for knots in [KnotSpacing::Centripetal, KnotSpacing::ChordLength] {
        let config = TaskSplineConfig {
            knots,
            angle_length_m_per_rad: 0.0,
        };
        let spline = TaskSpline::<f64, 512>::through_gcode(contour, &config).unwrap();
        let deviation = spline.polyline_deviation(64);
        let length = spline.length_m();
        let limits = FeedLimits {
            feed_m_s: feed,
            ..LIMITS
        };
        let plan = FeedPlan::rest_to_rest(length, &limits).unwrap();
        let optimal = time_optimal_s(length, feed, limits.accel_m_s2, limits.jerk_m_s3);
        let samples = run(&spline, &plan);
        let mut previous = spline.point(0).unwrap();
        let mut worst = 0.0f64;
        for s in &samples[..samples.len() - 1] {
            let chord = spline.metric_norm(&(s.pose - previous));
            previous = s.pose;
            let error = (chord - s.step_m).abs();
            assert!(error <= chord_bound(&spline, s), "{s:?}: {error:e}");
            worst = worst.max(error);
        }
        println!(
            "pyramid ({knots:?}): {} points, path {length:.6} m, spline vs polyline ≤ \
             {:.3} mm, {} periods = {:.4} s at 5 kHz, time-optimal {optimal:.4} s, ratio \
             {:.8}, |chord − Δs| ≤ {worst:.1e} m",
            contour.len(),
            deviation * 1e3,
            plan.periods(),
            plan.duration_s(),
            plan.duration_s() / optimal,
        );
        assert!(plan.duration_s() / optimal >= 1.0);
        // The corners are blended over 12 mm with 6 mm legs, and each pass steps to
        // the next along the pyramid's edge: the natural spline strays from those
        // straight moves by 0.83 mm (centripetal) and 1.28 mm (chord length) where
        // the step meets the next pass. Centripetal knots stray less, as intended.
        deviations.push(deviation);
        assert!(
            deviation < [1e-3, 1.5e-3][deviations.len() - 1],
            "{deviation}"
        );
    }
    assert!(deviations[0] < deviations[1]);
}
