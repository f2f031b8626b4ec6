//! The look-ahead planner (`kerf::trajectory::planner`) against references computed
//! another way: the corner speed from the inscribed circle's construction (angles
//! by atan2, not the dot-product identity), and the whole plan's duration against the
//! time-optimal profile found on a dense grid of arc length (forward and backward
//! passes of v² ≤ v₀² + 2aΔs on 0.1 mm steps, with the corner speeds and feeds as
//! limits), which converges to the same optimum by a different route.

use kerf::trajectory::planner::{Block, PlanError, Planner, PlannerLimits, SpeedProfile};
use proptest::prelude::*;

const LIMITS: PlannerLimits = PlannerLimits {
    max_speed_m_s: 0.05,
    accel_m_s2: 0.5,
    junction_deviation_m: 0.02e-3,
    jerk_m_s3: f64::INFINITY,
};

/// The same machine with jerk-limited ramps (an S-curve reaches 0.5 m/s² in 0.1 s).
const JERK_LIMITED: PlannerLimits = PlannerLimits {
    jerk_m_s3: 5.0,
    ..LIMITS
};

/// The speed of a corner from its geometry: the legs' directions by atan2, the
/// circle tangent to both legs whose nearest point is δ from the corner (centre on
/// the bisector at d = δ / (1 − sin α), radius d sin α), and v = √(a r).
fn corner_by_construction(from: [f64; 2], to: [f64; 2], limits: &PlannerLimits) -> f64 {
    let back = (-from[1]).atan2(-from[0]);
    let ahead = to[1].atan2(to[0]);
    let mut between = (ahead - back).abs();
    if between > std::f64::consts::PI {
        between = 2.0 * std::f64::consts::PI - between;
    }
    let half = 0.5 * between;
    let d = limits.junction_deviation_m / (1.0 - half.sin());
    let r = d * half.sin();
    (limits.accel_m_s2 * r).sqrt()
}

#[test]
fn a_corner_is_passed_at_the_speed_of_its_inscribed_circle() {
    for turn_deg in [5.0f64, 30.0, 45.0, 90.0, 120.0, 150.0, 175.0] {
        let t = turn_deg.to_radians();
        let from = [1.0, 0.0];
        let to = [t.cos(), t.sin()];
        let got = LIMITS.corner_speed_m_s(&from, &to);
        let want = corner_by_construction(from, to, &LIMITS);
        assert!(
            (got - want).abs() <= 1e-12 * want.max(1e-6),
            "{turn_deg}°: {got} vs {want}"
        );
    }
    // The 90° corner: r = δ (√2/2)/(1 − √2/2) = 2.414 δ, v = √(a r).
    let square = LIMITS.corner_speed_m_s(&[1.0, 0.0], &[0.0, 1.0]);
    let r = LIMITS.junction_deviation_m * 2f64.sqrt() / (2.0 - 2f64.sqrt());
    assert!((square - (LIMITS.accel_m_s2 * r).sqrt()).abs() < 1e-15);
    assert_eq!(
        LIMITS.corner_speed_m_s(&[1.0, 0.0], &[1.0, 0.0]),
        f64::INFINITY
    );
    assert_eq!(LIMITS.corner_speed_m_s(&[1.0, 0.0], &[-1.0, 0.0]), 0.0);
}

/// A profile (constant-acceleration ramps, and jerk-limited ones) covers its length,
/// starts and ends at its speeds, and its distance and speed over time agree with
/// integrating its speed numerically.
#[test]
fn a_profile_covers_its_length_at_its_speeds() {
    for limits in [LIMITS, JERK_LIMITED] {
        for (length, entry, exit, nominal) in [
            (0.01, 0.0, 0.0, 0.05),   // accelerates, cruises, stops
            (0.001, 0.0, 0.0, 0.05),  // too short to cruise: a peak
            (0.01, 0.02, 0.01, 0.05), // enters and leaves moving
            (0.002, 0.03, 0.03, 0.03),
        ] {
            let p = SpeedProfile::new(length, entry, exit, nominal, &limits);
            let (up, down) = (p.up.length_m(), p.down.length_m());
            assert!(p.cruise_m_s <= nominal + 1e-15);
            assert!((up + p.cruise_m + down - length).abs() < 1e-12, "{p:?}");
            let duration = p.duration_s();
            // The phases end where their lengths say: the ramp up at its length, the
            // cruise at the length before the ramp down.
            let [ta, tc, td] = p.times_s();
            assert!((ta + tc + td - duration).abs() < 1e-15);
            assert!((p.at(ta).0 - up).abs() < 1e-12);
            assert!((p.at(ta + tc).0 - (up + p.cruise_m)).abs() < 1e-12);
            assert!((p.at(0.0).1 - entry).abs() < 1e-12);
            assert!(
                (p.at(duration).1 - exit).abs() < 1e-9,
                "{:?}",
                p.at(duration)
            );
            assert!((p.at(duration).0 - length).abs() < 1e-12);
            // ∫ v dt by the midpoint rule over 10⁴ steps.
            let n = 10_000;
            let dt = duration / n as f64;
            let integral: f64 = (0..n).map(|k| p.at((k as f64 + 0.5) * dt).1 * dt).sum();
            assert!(
                (integral - length).abs() < 1e-9 * length.max(1.0),
                "{integral} vs {length}"
            );
            // Rebuilt from its cruise speed (what a control period does), the same
            // profile.
            let again = SpeedProfile::with_cruise(length, entry, exit, p.cruise_m_s, &limits);
            assert_eq!(again, p);
            // Its acceleration is the speed's rate of change: a central difference of
            // the speed 1 µs either side, away from the instants where the jerk (or,
            // with constant acceleration, the acceleration) steps.
            let h = 1e-6;
            let kinks = [
                0.0,
                p.up.rise_s,
                p.up.rise_s + p.up.hold_s,
                ta,
                ta + tc,
                ta + tc + p.down.rise_s,
                ta + tc + p.down.rise_s + p.down.hold_s,
                duration,
            ];
            for k in 1..200 {
                let t = duration * k as f64 / 200.0;
                if kinks.iter().any(|&x| (t - x).abs() < 2.0 * h) {
                    continue;
                }
                let rate = (p.at(t + h).1 - p.at(t - h).1) / (2.0 * h);
                let a = p.accel_at(t);
                // The central difference is exact for the quadratic speed of a jerk
                // phase, up to rounding: 1e-16 m/s over 2 µs.
                assert!((rate - a).abs() < 1e-7, "t {t}: {rate} against {a}");
                assert!(a.abs() <= limits.accel_m_s2 + 1e-12);
            }
            assert_eq!((p.accel_at(-1e-3), p.accel_at(duration + 1e-3)), (0.0, 0.0));
        }
    }
}

/// A jerk-limited ramp is the textbook S-curve: its duration by cases (|Δv| ≥ a²/j:
/// |Δv|/a + a/j; below, the peak not reached: 2√(|Δv|/j)), its end speed, and its
/// acceleration and jerk (finite differences of its speed every 10 µs) within the
/// limits; the planner's reach from a speed within a length is the speed whose ramp
/// covers that length.
#[test]
fn a_jerk_limited_ramp_is_the_textbook_s_curve() {
    use kerf::trajectory::planner::Ramp;
    let (a, j) = (0.5, 5.0);
    for (from, to) in [
        (0.0, 0.05),
        (0.05, 0.0),
        (0.01, 0.03),
        (0.02, 0.021),
        (0.03, 0.03),
    ] {
        let ramp = Ramp::new(from, to, a, j);
        let dv: f64 = (to - from).abs();
        let textbook = if dv >= a * a / j {
            dv / a + a / j
        } else {
            2.0 * (dv / j).sqrt()
        };
        assert!((ramp.duration_s() - textbook).abs() < 1e-12, "{from} {to}");
        assert!((ramp.at(ramp.duration_s()).1 - to).abs() < 1e-12);
        let dt = 1e-5;
        let steps = (ramp.duration_s() / dt).ceil() as usize;
        let v: Vec<f64> = (0..=steps).map(|k| ramp.at(k as f64 * dt).1).collect();
        let accel: Vec<f64> = v.windows(2).map(|w| (w[1] - w[0]) / dt).collect();
        for w in accel.windows(2) {
            assert!(w[0].abs() <= a * (1.0 + 1e-9) + 1e-9, "{}", w[0]);
            assert!(
                ((w[1] - w[0]) / dt).abs() <= j * 1.01,
                "{}",
                (w[1] - w[0]) / dt
            );
        }
    }
    for (from, length) in [(0.0, 1e-4), (0.0, 0.01), (0.02, 0.003)] {
        let v = JERK_LIMITED.reach_m_s(from, length);
        let covered = Ramp::new(from, v, a, j).length_m();
        assert!((covered - length).abs() < 1e-12, "{covered} vs {length}");
        assert!(v < LIMITS.reach_m_s(from, length));
    }
}

/// The time-optimal duration of a polyline on a dense grid of arc length (module
/// docs): limits per grid point (feed of its move; at a vertex, the corner speed of
/// the construction above), then the forward and backward passes, then Σ Δs / v̄.
fn grid_duration(
    start: [f64; 2],
    moves: &[([f64; 2], f64)],
    limits: &PlannerLimits,
    ds: f64,
) -> (f64, Vec<f64>) {
    let mut cap = vec![0.0f64];
    // The grid points of each move, to find its peak speed.
    let mut spans: Vec<std::ops::Range<usize>> = Vec::new();
    let mut steps = Vec::new();
    let mut at = start;
    let mut last_unit: Option<[f64; 2]> = None;
    for &(target, feed) in moves {
        let d = [target[0] - at[0], target[1] - at[1]];
        let len = d[0].hypot(d[1]);
        if len == 0.0 {
            continue;
        }
        let unit = [d[0] / len, d[1] / len];
        let nominal = feed.min(limits.max_speed_m_s);
        if let Some(prev) = last_unit {
            let corner = corner_by_construction(prev, unit, limits);
            let last = cap.len() - 1;
            cap[last] = cap[last].min(corner).min(nominal);
        }
        let n = (len / ds).ceil() as usize;
        spans.push(cap.len() - 1..cap.len() + n);
        for _ in 0..n {
            steps.push(len / n as f64);
            cap.push(nominal);
        }
        last_unit = Some(unit);
        at = target;
    }
    let last = cap.len() - 1;
    cap[last] = 0.0;
    let a2 = 2.0 * limits.accel_m_s2;
    let mut v = cap.clone();
    for i in 1..v.len() {
        v[i] = v[i].min((v[i - 1] * v[i - 1] + a2 * steps[i - 1]).sqrt());
    }
    for i in (0..v.len() - 1).rev() {
        v[i] = v[i].min((v[i + 1] * v[i + 1] + a2 * steps[i]).sqrt());
    }
    let duration = steps
        .iter()
        .enumerate()
        .map(|(i, s)| 2.0 * s / (v[i] + v[i + 1]))
        .sum();
    let peaks = spans
        .into_iter()
        .map(|span| v[span].iter().copied().fold(0.0, f64::max))
        .collect();
    (duration, peaks)
}

/// The grid's durations at 0.1 mm and 25 µm, and how near the optimum a plan must
/// be: within their difference, and the grid's own error at its kinks. A step is
/// exact where the acceleration is constant over it; where the speed reaches its
/// cruise V inside a step of length h (or leaves it, or peaks), taking the whole step
/// at constant acceleration costs at most a·h²/(2V³) (the step's speed change is
/// a·h/V). Two such steps a move, V its peak speed on the grid.
fn grids(moves: &[([f64; 2], f64)]) -> (f64, f64, f64) {
    let h = 2.5e-5;
    let (coarse, _) = grid_duration([0.0, 0.0], moves, &LIMITS, 4.0 * h);
    let (fine, peaks) = grid_duration([0.0, 0.0], moves, &LIMITS, h);
    let a = LIMITS.accel_m_s2;
    let kinks: f64 = peaks
        .iter()
        .filter(|&&v| v > 0.0)
        .map(|v| a * h * h / v.powi(3))
        .sum();
    (coarse, fine, (coarse - fine).abs() + kinks)
}

fn planned(start: [f64; 2], moves: &[([f64; 2], f64)]) -> Vec<Block<2>> {
    let mut planner = Planner::<2, 64>::new(&LIMITS, start).unwrap();
    for &(target, feed) in moves {
        planner.push(target, feed).unwrap();
    }
    planner.blocks().copied().collect()
}

fn total(blocks: &[Block<2>]) -> f64 {
    blocks.iter().map(|b| b.profile(&LIMITS).duration_s()).sum()
}

/// A square of 10 mm at 30 mm/s with one slow side: the plan's duration is the grid's
/// to the grid's own error, every corner passed at its circle's speed, and the move
/// ends at rest.
#[test]
fn a_square_takes_the_time_optimal_duration() {
    let moves = [
        ([0.01, 0.0], 0.03),
        ([0.01, 0.01], 0.03),
        ([0.0, 0.01], 0.01),
        ([0.0, 0.0], 0.03),
    ];
    let blocks = planned([0.0, 0.0], &moves);
    let got = total(&blocks);
    let (coarse, fine, tolerance) = grids(&moves);
    assert!(
        (got - fine).abs() <= tolerance,
        "{got} s vs the grid's {fine} s (and {coarse} s on a grid 4 times coarser)"
    );
    let corner = LIMITS.corner_speed_m_s(&[1.0, 0.0], &[0.0, 1.0]);
    assert!((blocks[1].entry_m_s - corner).abs() < 1e-12);
    assert_eq!(blocks[0].entry_m_s, 0.0);
    assert_eq!(blocks[3].exit_m_s, 0.0);
}

/// Random programs as a machinist's would run: a heading that mostly turns a little
/// (gentle corners, where the speeds are highest and the braking binds) and now and
/// then sharply, moves from 0.2 to 20 mm, feeds from 2 to 80 mm/s.
fn polyline() -> impl Strategy<Value = Vec<([f64; 2], f64)>> {
    prop::collection::vec(
        (
            prop_oneof![4 => -0.3f64..0.3, 1 => -3.1f64..3.1],
            0.0002f64..0.02,
            0.002f64..0.08,
        ),
        1..12,
    )
    .prop_map(|v| {
        let (mut heading, mut at) = (0.0f64, [0.0f64, 0.0]);
        v.into_iter()
            .map(|(turn, length, feed)| {
                heading += turn;
                at = [
                    at[0] + length * heading.cos(),
                    at[1] + length * heading.sin(),
                ];
                (at, feed)
            })
            .collect()
    })
}

/// `moves` fed into a `N`-move buffer as it runs and followed every `period` s under
/// `limits`: the samples, to rest.
fn follow<const N: usize>(
    limits: &PlannerLimits,
    moves: &[([f64; 2], f64)],
    period: f64,
) -> Vec<kerf::trajectory::planner::PlanSample<2>> {
    use kerf::trajectory::planner::PlanFollower;
    let mut planner = Planner::<2, N>::new(limits, [0.0, 0.0]).unwrap();
    let mut follower = PlanFollower::new(period, [0.0, 0.0]).unwrap();
    let mut pending = moves.iter();
    let mut samples = Vec::new();
    for _ in 0..1_000_000 {
        while !planner.is_full() {
            match pending.next() {
                Some(&(target, feed)) => planner.push(target, feed).unwrap(),
                None => break,
            }
        }
        samples.push(follower.step(&mut planner));
        if !follower.is_moving() && planner.is_empty() && pending.len() == 0 {
            break;
        }
    }
    samples
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Random polylines followed at 10 kHz with jerk-limited ramps, streamed through 8
    /// moves: the speed along the path changes by at most a·T a period, and its
    /// change by at most j·T² from one period to the next (second differences of the
    /// speed: the acceleration continuous across the moves, corners included, within
    /// 1 % for the periods that straddle a phase's end); the plan ends at the last
    /// point, at rest, no sooner than with constant-acceleration ramps.
    #[test]
    fn jerk_limited_plans_are_followed_within_the_jerk(moves in polyline()) {
        let period = 1e-4;
        let samples = follow::<8>(&JERK_LIMITED, &moves, period);
        let last = samples.last().unwrap();
        let end = moves.last().unwrap().0;
        prop_assert!((last.position_m[0] - end[0]).hypot(last.position_m[1] - end[1]) < 1e-12);
        prop_assert_eq!(last.speed_m_s, 0.0);
        let (a, j) = (JERK_LIMITED.accel_m_s2, JERK_LIMITED.jerk_m_s3);
        let v: Vec<f64> = samples.iter().map(|s| s.speed_m_s).collect();
        for w in v.windows(3) {
            prop_assert!((w[1] - w[0]).abs() <= a * period * (1.0 + 1e-9) + 1e-15);
            let second = (w[2] - 2.0 * w[1] + w[0]).abs();
            prop_assert!(second <= j * period * period * 1.01 + 1e-15, "{second}");
        }
        let constant = follow::<8>(&LIMITS, &moves, period);
        prop_assert!(samples.len() + 1 >= constant.len());
    }

    /// Random polylines: speeds continuous across moves, within every limit (feed,
    /// corner, reachable by the acceleration within each move), from and to rest, and
    /// the duration the grid's time-optimal one.
    #[test]
    fn random_programs_are_planned_within_every_limit(moves in polyline()) {
        let blocks = planned([0.0, 0.0], &moves);
        prop_assume!(!blocks.is_empty());
        let a2 = 2.0 * LIMITS.accel_m_s2;
        prop_assert_eq!(blocks[0].entry_m_s, 0.0);
        prop_assert_eq!(blocks[blocks.len() - 1].exit_m_s, 0.0);
        for pair in blocks.windows(2) {
            prop_assert_eq!(pair[0].exit_m_s, pair[1].entry_m_s);
        }
        for b in &blocks {
            prop_assert!(b.entry_m_s <= b.max_entry_m_s + 1e-12);
            let p = b.profile(&LIMITS);
            prop_assert!(p.cruise_m_s <= b.nominal_m_s + 1e-12);
            let dv2 = (b.exit_m_s * b.exit_m_s - b.entry_m_s * b.entry_m_s).abs();
            prop_assert!(dv2 <= a2 * b.length_m * (1.0 + 1e-9) + 1e-15);
        }
        let got = total(&blocks);
        let (coarse, fine, tolerance) = grids(&moves);
        prop_assert!(
            (got - fine).abs() <= tolerance + 1e-9,
            "{} s vs the grid's {} s ({} s on the coarse grid)", got, fine, coarse
        );
    }

    /// Through a buffer of 4 moves (taken from the front whenever it is full), the
    /// program is never faster than with the whole program in view, and never leaves
    /// a limit; with the buffer at least the program's length it is the same plan.
    #[test]
    fn a_short_buffer_plans_safely_and_a_long_one_plans_the_whole(moves in polyline()) {
        let whole = planned([0.0, 0.0], &moves);
        prop_assume!(!whole.is_empty());
        let mut short = Planner::<2, 4>::new(&LIMITS, [0.0, 0.0]).unwrap();
        let mut taken = Vec::new();
        for &(target, feed) in &moves {
            if short.is_full() {
                taken.push(short.pop().unwrap());
            }
            short.push(target, feed).unwrap();
        }
        while let Some(b) = short.pop() {
            taken.push(b);
        }
        prop_assert_eq!(taken.len(), whole.len());
        for pair in taken.windows(2) {
            prop_assert!((pair[0].exit_m_s - pair[1].entry_m_s).abs() < 1e-12);
        }
        prop_assert_eq!(taken[taken.len() - 1].exit_m_s, 0.0);
        prop_assert!(total(&taken) >= total(&whole) - 1e-12);
        if moves.len() <= 4 {
            prop_assert!((total(&taken) - total(&whole)).abs() < 1e-12);
        }
    }
}

#[test]
fn bad_moves_and_limits_are_refused_and_change_nothing() {
    let mut p = Planner::<2, 2>::new(&LIMITS, [0.0, 0.0]).unwrap();
    assert_eq!(p.push([f64::NAN, 0.0], 0.01), Err(PlanError::NotFinite));
    assert_eq!(p.push([0.01, 0.0], 0.0), Err(PlanError::NoFeed));
    assert_eq!(
        p.push([0.01, 0.0], f64::INFINITY),
        Err(PlanError::NotFinite)
    );
    assert!(p.is_empty());
    // A move of no length is taken and adds nothing.
    assert_eq!(p.push([0.0, 0.0], 0.01), Ok(()));
    assert!(p.is_empty());
    p.push([0.01, 0.0], 0.01).unwrap();
    p.push([0.02, 0.0], 0.01).unwrap();
    assert_eq!(p.push([0.03, 0.0], 0.01), Err(PlanError::Full));
    assert_eq!(p.len(), 2);
    assert_eq!(p.blocks().last().unwrap().end_m, [0.02, 0.0]);
    assert!(p.duration_s() > 0.0);
    for bad in [
        PlannerLimits {
            accel_m_s2: 0.0,
            ..LIMITS
        },
        PlannerLimits {
            max_speed_m_s: f64::NAN,
            ..LIMITS
        },
        PlannerLimits {
            junction_deviation_m: -1.0,
            ..LIMITS
        },
        PlannerLimits {
            jerk_m_s3: 0.0,
            ..LIMITS
        },
        PlannerLimits {
            jerk_m_s3: f64::NAN,
            ..LIMITS
        },
    ] {
        assert!(Planner::<2, 2>::new(&bad, [0.0, 0.0]).is_err());
    }
    assert!(Planner::<2, 2>::new(&LIMITS, [f64::INFINITY, 0.0]).is_err());
    assert_eq!(p.limits(), &LIMITS);
    let b = p.pop().unwrap();
    assert_eq!(b.point_at(0.005), [0.005, 0.0]);
    assert_eq!(b.point_at(1.0), [0.01, 0.0]);
}

/// A fast move straight into a short last one: the speed where they meet is what the
/// last millimetre can brake from, √(2 a L), and the profile's lengths add up to the
/// moves' (a plan that brakes harder than the machine can would not).
#[test]
fn the_speed_before_a_short_last_move_is_what_it_can_brake_from() {
    let blocks = planned([0.0, 0.0], &[([0.04, 0.0], 0.05), ([0.041, 0.0], 0.05)]);
    let brake = (2.0 * LIMITS.accel_m_s2 * 0.001f64).sqrt();
    assert!(
        (blocks[1].entry_m_s - brake).abs() < 1e-12,
        "{}",
        blocks[1].entry_m_s
    );
    for b in &blocks {
        let p = b.profile(&LIMITS);
        assert!((p.up.length_m() + p.cruise_m + p.down.length_m() - b.length_m).abs() < 1e-12);
    }
}

/// The square followed at 1 kHz with the program fed into an 8-move buffer as it
/// runs: each period's step no longer than the fastest feed allows, the speed along
/// each move changing by at most a·T a period, the path from the first point to the
/// last, as long as the polyline less what the corners' chords cut (at most a step a
/// corner), in the planned number of periods.
#[test]
fn a_followed_plan_moves_within_its_limits_from_start_to_end() {
    let square = [
        ([0.01, 0.0], 0.03),
        ([0.01, 0.01], 0.03),
        ([0.0, 0.01], 0.01),
        ([0.0, 0.0], 0.03),
    ];
    let moves: Vec<([f64; 2], f64)> = (0..3).flat_map(|_| square).collect();
    let period = 1e-3;
    let samples = follow::<8>(&LIMITS, &moves, period);
    let last = samples.last().unwrap();
    assert_eq!(last.position_m, [0.0, 0.0]);
    assert_eq!(last.speed_m_s, 0.0);
    let mut path = 0.0;
    for pair in samples.windows(2) {
        let d = (pair[1].position_m[0] - pair[0].position_m[0])
            .hypot(pair[1].position_m[1] - pair[0].position_m[1]);
        assert!(d <= 0.03 * period + 1e-12, "a step of {d} m");
        if pair[0].unit == pair[1].unit {
            let dv = (pair[1].speed_m_s - pair[0].speed_m_s).abs();
            assert!(dv <= LIMITS.accel_m_s2 * period * (1.0 + 1e-9), "dv {dv}");
        }
        path += d;
    }
    let polyline = 12.0 * 0.01;
    let corners = 11.0;
    assert!(
        path <= polyline + 1e-12 && path >= polyline - corners * 0.03 * period,
        "{path}"
    );
    let planned = total(&planned([0.0, 0.0], &moves));
    let periods = samples.len() as f64;
    assert!(
        (periods * period - planned).abs() < 0.02 * planned,
        "{periods} periods for {planned} s"
    );
}

/// Straight on through a junction at cruise: every period's step is the feed times the
/// period, the one that crosses from one move into the next included (the time left of
/// the first move is carried into the second).
#[test]
fn time_is_carried_across_a_junction() {
    use kerf::trajectory::planner::PlanFollower;
    let period = 1e-3;
    let mut planner = Planner::<2, 4>::new(&LIMITS, [0.0, 0.0]).unwrap();
    // The junction at 5.0037 mm falls between two periods' points.
    planner.push([0.0050037, 0.0], 0.01).unwrap();
    planner.push([0.0102345, 0.0], 0.01).unwrap();
    let mut follower = PlanFollower::new(period, [0.0, 0.0]).unwrap();
    let xs: Vec<f64> = (0..1100)
        .map(|_| follower.step(&mut planner).position_m[0])
        .collect();
    // Cruising from 0.1 mm (the ramp to 10 mm/s takes 0.1 mm) to 0.1 mm before the end.
    let cruise: Vec<f64> = xs
        .windows(2)
        .filter(|w| w[0] > 0.0002 && w[1] < 0.0101)
        .map(|w| w[1] - w[0])
        .collect();
    assert!(cruise.len() > 900);
    for d in cruise {
        assert!((d - 0.01 * period).abs() < 1e-12, "a step of {d} m");
    }
}

/// A plan continued from another's join: a straight line of 1 mm moves at 40 mm/s
/// (a = 0.5 m/s², constant-acceleration ramps) planned as moves 1–10, ending at rest
/// after move 10, reaches the end of move 6 at the speed that can still stop in the
/// 4 mm left, √(2·a·4 mm) = 63 mm/s capped at the feed; a plan of moves 7–20 from there
/// continues at exactly that speed; a follower resumed 0.3 ms past the join is at
/// 0.3 ms + one period of travel at it. A turn at the join limits the continuing plan
/// to the corner's speed, below the join's: it cannot take it.
#[test]
fn a_plan_continues_another_at_its_join() {
    use kerf::trajectory::planner::{Continuation, PlanFollower};
    let feed = 0.04;
    let mut first = Planner::<2, 16>::new(&LIMITS, [0.0; 2]).unwrap();
    for k in 1..=10 {
        first.push([k as f64 * 1e-3, 0.0], feed).unwrap();
    }
    let blocks: Vec<Block<2>> = first.blocks().copied().collect();
    let join = blocks[5];
    let expected = feed.min((2.0 * LIMITS.accel_m_s2 * 4e-3).sqrt());
    assert!(
        (join.exit_m_s - expected).abs() < 1e-12,
        "{}",
        join.exit_m_s
    );
    let before = Continuation {
        unit: join.unit,
        nominal_m_s: join.nominal_m_s,
        speed_m_s: join.exit_m_s,
    };
    let mut next = Planner::<2, 16>::new(&LIMITS, join.end_m).unwrap();
    next.continue_from(before).unwrap();
    for k in 7..=20 {
        next.push([k as f64 * 1e-3, 0.0], feed).unwrap();
    }
    let front = *next.blocks().next().unwrap();
    assert_eq!(front.entry_m_s, join.exit_m_s);
    assert!(next.front_limit_m_s() >= join.exit_m_s);
    // Moves already added: too late to say what came before.
    assert!(next.continue_from(before).is_err());
    let period = 1e-4;
    let since = 3e-4;
    let mut follower = PlanFollower::resuming(period, join.end_m, since).unwrap();
    assert_eq!(follower.time_in_move_s(), None);
    let sample = follower.step(&mut next);
    assert_eq!(follower.time_in_move_s(), Some(since + period));
    let travel = sample.position_m[0] - join.end_m[0];
    assert!((travel - feed * (since + period)).abs() < 1e-12, "{travel}");
    assert!(PlanFollower::<2>::resuming(period, [0.0; 2], -1.0).is_err());
    // A square turn at the join: its corner speed is the most the next plan takes.
    let mut turned = Planner::<2, 16>::new(&LIMITS, join.end_m).unwrap();
    turned.continue_from(before).unwrap();
    turned.push([join.end_m[0], 5e-3], feed).unwrap();
    let corner = LIMITS.corner_speed_m_s(&[1.0, 0.0], &[0.0, 1.0]);
    assert!((turned.front_limit_m_s() - corner).abs() < 1e-15);
    assert!(turned.front_limit_m_s() < before.speed_m_s);
    let bad = Continuation {
        speed_m_s: f64::NAN,
        ..before
    };
    assert!(Planner::<2, 16>::new(&LIMITS, [0.0; 2])
        .unwrap()
        .continue_from(bad)
        .is_err());
}
