//! The open path against an independent solve: every cubic's four coefficients from
//! the interpolation, continuity and natural-end conditions as one dense linear system
//! (Gaussian elimination with partial pivoting), not the second-derivative recurrence.

use super::*;
use crate::trajectory::shapes::{letter_e, letter_s};
use crate::trajectory::tangential::{CurveFollower, FollowerConfig, SpeedRampConfig};
extern crate std;
use std::vec;
use std::vec::Vec;

/// Coefficients (a, b, c, d) of x = a + b t + c t² + d t³ on each segment (t from the
/// segment's start) of the natural spline through (u, x), by a dense solve.
fn dense_spline(u: &[f64], x: &[f64]) -> Vec<[f64; 4]> {
    let s = u.len() - 1;
    let n = 4 * s;
    let mut a = vec![vec![0.0; n + 1]; n];
    let mut row = 0;
    let put = |row: usize, col: usize, v: f64, a: &mut Vec<Vec<f64>>| a[row][col] = v;
    for i in 0..s {
        let h = u[i + 1] - u[i];
        // x(0) = xi, x(h) = xi+1.
        put(row, 4 * i, 1.0, &mut a);
        a[row][n] = x[i];
        row += 1;
        for (k, p) in [1.0, h, h * h, h * h * h].iter().enumerate() {
            put(row, 4 * i + k, *p, &mut a);
        }
        a[row][n] = x[i + 1];
        row += 1;
        if i + 1 < s {
            // x′ and x″ continuous at the joint.
            for (k, p) in [0.0, 1.0, 2.0 * h, 3.0 * h * h].iter().enumerate() {
                put(row, 4 * i + k, *p, &mut a);
            }
            put(row, 4 * (i + 1) + 1, -1.0, &mut a);
            row += 1;
            for (k, p) in [0.0, 0.0, 2.0, 6.0 * h].iter().enumerate() {
                put(row, 4 * i + k, *p, &mut a);
            }
            put(row, 4 * (i + 1) + 2, -2.0, &mut a);
            row += 1;
        }
    }
    // Natural ends.
    put(row, 2, 2.0, &mut a);
    row += 1;
    let h = u[s] - u[s - 1];
    put(row, 4 * (s - 1) + 2, 2.0, &mut a);
    put(row, 4 * (s - 1) + 3, 6.0 * h, &mut a);
    row += 1;
    assert_eq!(row, n);
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|i, j| a[*i][col].abs().total_cmp(&a[*j][col].abs()))
            .unwrap();
        a.swap(col, pivot);
        let pivot_row = a[col].clone();
        for (r, row) in a.iter_mut().enumerate() {
            if r != col {
                let f = row[col] / pivot_row[col];
                for (x, p) in row.iter_mut().zip(&pivot_row).skip(col) {
                    *x -= f * p;
                }
            }
        }
    }
    (0..s)
        .map(|i| core::array::from_fn(|k| a[4 * i + k][n] / a[4 * i + k][4 * i + k]))
        .collect()
}

#[test]
fn matches_a_dense_solve_of_the_same_conditions() {
    for points in [letter_e().to_vec(), letter_s().to_vec()] {
        let path = OpenPath::<f64, 32>::from_points(&points).unwrap();
        let mut u = vec![0.0];
        for w in points.windows(2) {
            u.push(u.last().unwrap() + libm::hypot(w[1][0] - w[0][0], w[1][1] - w[0][1]));
        }
        let c = path.centre();
        let xs: Vec<f64> = points.iter().map(|p| p[0] - c.x).collect();
        let ys: Vec<f64> = points.iter().map(|p| p[1] - c.y).collect();
        let (cx, cy) = (dense_spline(&u, &xs), dense_spline(&u, &ys));
        let mut worst = 0.0f64;
        for i in 0..u.len() - 1 {
            // Inside each segment (at its end the next one's jerk applies).
            for k in 0..10 {
                let t = (u[i + 1] - u[i]) * f64::from(k) / 10.0;
                let s = path.evaluate(u[i] + t);
                for (got, co) in [(s.position.x, cx[i]), (s.position.y, cy[i])] {
                    let want = co[0] + t * (co[1] + t * (co[2] + t * co[3]));
                    worst = worst.max((got - want).abs());
                }
                for (got, co) in [(s.d1.x, cx[i]), (s.d1.y, cy[i])] {
                    let want = co[1] + t * (2.0 * co[2] + 3.0 * t * co[3]);
                    worst = worst.max((got - want).abs() * 1e-3);
                }
                for (got, co) in [(s.d3.x, cx[i]), (s.d3.y, cy[i])] {
                    worst = worst.max((got - 6.0 * co[3]).abs() * 1e-9);
                }
            }
        }
        // Positions of ~5 mm from two solves of a well-conditioned system: round-off
        // of a few hundred ulps at most (slopes scaled by 1 mm, jerks by 1 nm³).
        assert!(worst < 1e-15 * 1e3, "{worst}");
    }
}

#[test]
fn passes_through_the_points_with_continuous_slope_and_curvature_and_natural_ends() {
    let points = letter_e();
    let path = OpenPath::<f64, 32>::from_points(&points).unwrap();
    let c = path.centre();
    let mut u = 0.0;
    for (i, p) in points.iter().enumerate() {
        if i > 0 {
            let q = points[i - 1];
            u += libm::hypot(p[0] - q[0], p[1] - q[1]);
        }
        let s = path.evaluate(u);
        assert!((s.position.x + c.x - p[0]).abs() < 1e-17 + 1e-15 * p[0].abs());
        assert!((s.position.y + c.y - p[1]).abs() < 1e-17 + 1e-15 * p[1].abs());
        if i > 0 && i + 1 < points.len() {
            // Just left of the knot (previous segment) against the knot itself.
            let left = path.evaluate(u - 1e-9);
            assert!((left.d1 - s.d1).norm() < 1e-9 * s.d2.norm() + 1e-12);
            let jerk = left.d3.norm().max(s.d3.norm());
            assert!((left.d2 - s.d2).norm() < 2e-9 * jerk + 1e-9);
        }
    }
    assert!(path.evaluate(0.0).d2.norm() < 1e-12);
    assert!(path.evaluate(path.chord_length_m()).d2.norm() < 1e-9);
    // Chord length: |C′| stays near 1 (the spline rounds the bar's right-angle
    // corner, where it dips most).
    for k in 0..=100 {
        let speed = path
            .tangent(path.chord_length_m() * f64::from(k) / 100.0)
            .norm();
        assert!((0.5..1.5).contains(&speed), "{speed}");
    }
}

#[test]
fn a_straight_line_stays_straight() {
    let line: Vec<[f64; 2]> = (0..5).map(|i| [f64::from(i), 2.0 * f64::from(i)]).collect();
    let path = OpenPath::<f64, 8>::from_points(&line).unwrap();
    for k in 0..=40 {
        let s = path.evaluate(path.chord_length_m() * f64::from(k) / 40.0);
        assert!(s.d2.norm() < 1e-12 && s.d1.perp(&Vector2::new(1.0, 2.0)).abs() < 1e-12);
    }
}

#[test]
fn bad_points_are_refused() {
    type P = OpenPath<f64, 8>;
    assert_eq!(
        P::from_points(&[[0.0, 0.0], [1.0, 0.0]]),
        Err(ContourError::TooFewPoints)
    );
    let many: Vec<[f64; 2]> = (0..9).map(|i| [f64::from(i), 0.0]).collect();
    assert_eq!(P::from_points(&many), Err(ContourError::Capacity));
    assert_eq!(
        P::from_points(&[[0.0, 0.0], [1.0, f64::NAN], [2.0, 0.0]]),
        Err(ContourError::NotFinitePoint(1))
    );
    assert_eq!(
        P::from_points(&[[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [2.0, 0.0]]),
        Err(ContourError::RepeatedPoint(2))
    );
    let huge = [[0.0, 0.0], [1e39, 0.0], [2e39, 1.0]];
    assert!(matches!(
        OpenPath::<f32, 8>::from_points(&huge),
        Err(ContourError::Config(_))
    ));
}

#[test]
fn f32_follows_f64_to_rounding() {
    let wide = OpenPath::<f64, 32>::from_points(&letter_s()).unwrap();
    let narrow = OpenPath::<f32, 32>::from_f64(&wide).unwrap();
    for k in 0..=200 {
        let u = wide.chord_length_m() * f64::from(k) / 200.0;
        let (a, b) = (wide.evaluate(u), narrow.evaluate(u as f32));
        // Positions of ≤ 8 mm: a few ulps of f32 (1 ulp at 8 mm is 0.5 nm) plus the
        // rounding of u.
        assert!((f64::from(b.position.x) - a.position.x).abs() < 5e-9);
        assert!((f64::from(b.position.y) - a.position.y).abs() < 5e-9);
    }
}

#[test]
fn a_follower_walks_an_open_path_at_constant_speed_and_stops_at_its_end() {
    let path = OpenPath::<f64, 32>::from_points(&letter_s()).unwrap();
    let (speed, ts) = (2e-3, 1e-3);
    let config = FollowerConfig {
        ramp: SpeedRampConfig {
            speed_m_s: speed,
            accel_m_s2: 0.1,
            jerk_m_s3: 10.0,
            ts_s: ts,
        },
        accel_limit_m_s2: 10.0,
        newton_steps: 2,
    };
    let mut f = CurveFollower::new(path, &config, 0.0).unwrap();
    f.start();
    let mut previous = f.at_rest().position;
    let mut arc = 0.0;
    let mut cruise = 0;
    let mut was_cruising = false;
    while !f.at_end() {
        let r = f.step().unwrap();
        let step = (r.position - previous).norm();
        // From the second cruising period on (the first still ends the ramp), up to
        // the end, where the last step is cut short (no stop ramp here).
        let cruising = f.ramp().is_cruising();
        if cruising && was_cruising && !f.at_end() {
            // A chord of the arc V·Ts on curvature ≤ 1/4 mm: shorter by ≤ (V·Ts)³κ²/24.
            assert!(
                (step - speed * ts).abs() < 1e-12,
                "{step} at {} of {}",
                f.theta(),
                path.chord_length_m()
            );
            cruise += 1;
        }
        was_cruising = cruising;
        arc += step;
        previous = r.position;
        assert!(cruise < 100_000);
    }
    let length = path.arc_length(0.0, path.chord_length_m(), 2000);
    assert!((arc - length).abs() < 1e-9 + speed * ts, "{arc} {length}");
    assert_eq!(f.theta(), path.chord_length_m());
    // Held at the end, at rest.
    let r = f.step().unwrap();
    assert_eq!(
        r.velocity.norm() + r.acceleration.norm() + r.jerk.norm(),
        0.0
    );
    assert_eq!(r.position, previous);
    // θ0 outside the path is refused.
    assert!(CurveFollower::new(path, &config, -1e-3).is_err());
}
