//! Jobs, the period counter across a week, times the scalar holds, and in-place job
//! copies.

use super::*;
use crate::sensing::hall::HallConfig;
use core::f64::consts::PI;

/// Nominal Hall counts at phase `phi` (rad) of the pitch.
fn counts(phi: f64) -> [[u16; 3]; 1] {
    let c = HallConfig::LM1247_16BIT;
    let ch = |k: usize, s: f64| {
        (f64::from(c.calibration.offset_counts[k]) + c.amplitude_counts * libm::sin(phi + s)) as u16
    };
    [[ch(0, 0.0), ch(1, 2.0 * PI / 3.0), ch(2, -2.0 * PI / 3.0)]]
}

fn job(segments: &[(f64, f64)]) -> JointJob<1> {
    let segments: std::vec::Vec<_> = segments
        .iter()
        .map(|&(target, duration_s)| Segment {
            target_m: [target],
            duration_s,
        })
        .collect();
    JointJob::from_slice(&segments).unwrap()
}

/// `clone_from` (the supervisor's in-place load) leaves exactly the source's
/// segments, whatever was there before; a job holds at most MAX_SEGMENTS.
#[test]
fn a_job_cloned_in_place_is_the_source() {
    let long = job(&[(0.01, 0.1), (0.02, 0.1), (0.03, 0.1)]);
    let short = job(&[(0.05, 0.2)]);
    let mut loaded = long.clone();
    assert_eq!(loaded, long);
    loaded.clone_from(&short);
    assert_eq!(loaded, short);
    assert_eq!(&loaded[..], &short[..]);
    loaded.clone_from(&long);
    assert_eq!(loaded.len(), 3);
    let full = [Segment {
        target_m: [0.0],
        duration_s: 0.1,
    }; MAX_SEGMENTS + 1];
    assert!(JointJob::from_slice(&full[..MAX_SEGMENTS]).is_some());
    assert!(JointJob::from_slice(&full).is_none());
}

/// A segment of 2^32 periods or more would overflow the period counter (and end
/// early, jumping the reference): refused; a week-long job is two segments.
#[test]
fn a_segment_beyond_the_period_counter_is_refused() {
    let machine = Joints::<f32, 1>::new(&JointsConfig::LM1247).unwrap();
    let home = JointsConfig::LM1247.home_m[0];
    let day_s = 86_400.0;
    assert_eq!(
        machine.check_job(&job(&[(home, 6.0 * day_s)])),
        Err(JobError::TooLong { segment: 0 })
    );
    assert_eq!(
        machine.check_job(&job(&[(home, 3.5 * day_s), (home, 3.5 * day_s)])),
        Ok(())
    );
}

/// A 7-day job (two 3.5-day dwells, then a 10 mm move), fast-forwarded to the end
/// of each segment: the period counter crosses 3e9 without a fault, the reference
/// is continuous at each boundary, and the job ends.
#[test]
fn a_week_long_job_fast_forwarded_across_its_segments() {
    let mut machine = Joints::<f32, 1>::new(&JointsConfig::LM1247).unwrap();
    let home = JointsConfig::LM1247.home_m[0];
    let day_s = 86_400.0;
    let week = job(&[(home, 3.5 * day_s), (home, 3.5 * day_s), (home + 0.01, 0.2)]);
    assert_eq!(machine.check_job(&week), Ok(()));
    let at = counts(0.3);
    machine.monitor(&at).unwrap();
    machine.begin_job(&week).unwrap();
    let mut last = machine.reference()[0].position;
    let mut boundaries = 0;
    for _ in 0..3 {
        // Jump to three periods before the segment's end, then step across it.
        let run = machine.run.as_mut().unwrap();
        assert!(
            run.periods > 3_000_000_000 || run.segment == 2,
            "{}",
            run.periods
        );
        run.period = run.periods - 3;
        let segment = run.segment;
        for step in 0..6 {
            match machine.run(&week, &at).unwrap() {
                Step::Continue(_) => {}
                Step::Done(_) => {
                    assert_eq!(segment, 2);
                    boundaries += 1;
                    break;
                }
            }
            let now = machine.reference()[0].position;
            // Dwells hold; the move's start is at rest: no jump at a boundary (the
            // first step after the fast-forward lands wherever it was sent).
            assert!(step == 0 || (now - last).abs() < 1e-6, "{last} -> {now}");
            last = now;
            if machine.run.as_ref().map(|r| r.segment) != Some(segment) {
                boundaries += 1;
                break;
            }
        }
    }
    assert_eq!(boundaries, 3);
    assert!((f64::from(last) - (home + 0.01)).abs() < 1e-6, "{last}");
}

/// The time into a move is a signal of the machine's scalar: in Q6.25 it saturates
/// at 64 s, so a longer move froze there and jumped at its end (30 mm in 100 s: 7.5
/// mm in the last period). Refused at load in Q6.25, accepted in f32.
#[test]
fn a_move_longer_than_the_scalar_holds_a_time_is_refused() {
    use crate::scalar::Q6_25;
    let ts = <Q6_25 as Real>::coef(JointsConfig::LM1247.period_s);
    assert_eq!(
        Q6_25::count_times(1_000_000, ts),
        Q6_25::MAX,
        "100 s saturates"
    );
    let home = JointsConfig::LM1247.home_m[0];
    let fixed = Joints::<Q6_25, 1>::new(&JointsConfig::LM1247).unwrap();
    let float = Joints::<f32, 1>::new(&JointsConfig::LM1247).unwrap();
    let slow = job(&[(home + 0.03, 100.0)]);
    assert_eq!(
        fixed.check_job(&slow),
        Err(JobError::TooLong { segment: 0 })
    );
    assert_eq!(float.check_job(&slow), Ok(()));
    // Split in two moves below 64 s, it runs.
    let split = job(&[(home + 0.015, 50.0), (home + 0.03, 50.0)]);
    assert_eq!(fixed.check_job(&split), Ok(()));
}

/// The stop ramp from a cruise, against the kinematics of a constant deceleration
/// (not the ramp's own closed form): it takes the fewest whole periods n that keep
/// |v0|/(n·Ts) within the acceleration limit, its velocity falls by the same step each
/// period to exactly zero, the position advances by the trapezoid of the velocities
/// (exact for a linear velocity) to v0·n·Ts/2 past the start, `Done` comes on the n-th
/// period and not before, and the axis then rests where it stopped. Both directions.
#[test]
fn the_stop_ramp_decelerates_uniformly_to_rest_within_the_limit() {
    let config = JointsConfig::LM1247;
    let (ts, limit) = (config.period_s, config.accel_limit_m_s2);
    let pitch = config.hall[0].pitch_m;
    let start = 0.03;
    for v0 in [0.3, -0.17] {
        let mut machine = Joints::<f64, 1>::new(&config).unwrap();
        // Counts that follow the reference (the first sample is the home), so that
        // the decoder sees a smooth motion.
        let at = |x: f64| counts(0.3 + 2.0 * PI * (x - start) / pitch);
        machine.monitor(&at(start)).unwrap();
        machine.reference = [Reference {
            position: start,
            velocity: v0,
            acceleration: 0.0,
        }];
        machine.begin_stop();
        let (mut previous, mut n) = (machine.reference()[0], 0u32);
        let mut steps = std::vec::Vec::new();
        loop {
            n += 1;
            let step = machine.ramp_to_rest(&at(previous.position)).unwrap();
            let r = machine.reference()[0];
            // Trapezoid of the velocities, to rounding of positions near 0.03 m.
            let advance = 0.5 * ts * (r.velocity + previous.velocity);
            assert!(
                (r.position - previous.position - advance).abs() < 1e-14,
                "{v0}: period {n}: {r:?} after {previous:?}"
            );
            steps.push(previous.velocity - r.velocity);
            previous = r;
            if let Step::Done(_) = step {
                break;
            }
            assert!(n < 10_000, "{v0}: no end");
        }
        let t = f64::from(n) * ts;
        // The fewest periods within the limit (1e-9 relative: the rounding of v0/a/Ts).
        assert!(v0.abs() / t <= limit * (1.0 + 1e-9), "{v0}: {n}");
        assert!(v0.abs() / (t - ts) > limit * (1.0 - 1e-9), "{v0}: {n}");
        // Uniform steps of v0/n (the last also brings the velocity to exactly zero).
        let step = v0 / f64::from(n);
        assert!(steps.iter().all(|d| (d - step).abs() < 1e-12), "{steps:?}");
        assert_eq!(previous.velocity, 0.0);
        // The distance of a uniform stop, to the rounding of the sum above.
        let stop_at = start + 0.5 * v0 * t;
        assert!(
            (previous.position - stop_at).abs() < 1e-12,
            "{v0}: {previous:?}"
        );
        // At rest afterwards, where it stopped.
        for _ in 0..3 {
            let step = machine.ramp_to_rest(&at(stop_at)).unwrap();
            assert!(matches!(step, Step::Done(_)));
            assert_eq!(machine.reference()[0].position, previous.position);
            assert_eq!(machine.reference()[0].velocity, 0.0);
        }
    }
}
