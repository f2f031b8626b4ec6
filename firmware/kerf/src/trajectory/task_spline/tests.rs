use super::*;
use std::vec::Vec;

const CENTRIPETAL: TaskSplineConfig = TaskSplineConfig {
    knots: KnotSpacing::Centripetal,
    angle_length_m_per_rad: 0.1,
};
const CHORD: TaskSplineConfig = TaskSplineConfig {
    knots: KnotSpacing::ChordLength,
    angle_length_m_per_rad: 0.1,
};

/// Deterministic scattered 5-D points: a wandering path with uneven steps (a small
/// linear congruential generator, so the test needs no randomness crate).
fn wandering(n: usize) -> Vec<Pose<f64>> {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut p = Pose::new(0.0, 0.5, 0.0, 0.0, 0.0);
    (0..n)
        .map(|_| {
            let scale = 0.005 + 0.05 * (next() + 0.5);
            p += Pose::new(next(), next(), next(), 0.5 * next(), 0.5 * next()) * scale;
            p
        })
        .collect()
}

/// The reference: the natural spline written in slopes kᵢ instead of second
/// derivatives, the full n×n system solved by Gaussian elimination with partial
/// pivoting, evaluated in Hermite form. Knots as `cscvn` writes them:
/// breaks = cumsum((Σ Δ²)^(1/4)) (centripetal) or (Σ Δ²)^(1/2) (chord).
struct Reference {
    u: Vec<f64>,
    p: Vec<Pose<f64>>,
    k: Vec<Pose<f64>>,
}

fn reference(points: &[Pose<f64>], config: &TaskSplineConfig) -> Reference {
    let rho2 = config.angle_length_m_per_rad.powi(2);
    let power = match config.knots {
        KnotSpacing::Centripetal => 0.25,
        KnotSpacing::ChordLength => 0.5,
    };
    let mut u = std::vec![0.0];
    for w in points.windows(2) {
        let d = w[1] - w[0];
        let sum_sq = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] + rho2 * (d[3] * d[3] + d[4] * d[4]);
        u.push(u.last().unwrap() + sum_sq.powf(power));
    }
    let n = points.len();
    // Rows: 2k0 + k1 = 3Δ0/h0; (1/hᵢ₋₁)kᵢ₋₁ + 2(1/hᵢ₋₁ + 1/hᵢ)kᵢ + (1/hᵢ)kᵢ₊₁ =
    // 3(Δᵢ₋₁/hᵢ₋₁² + Δᵢ/hᵢ²); kₙ₋₂ + 2kₙ₋₁ = 3Δₙ₋₂/hₙ₋₂ (zero second derivative at
    // the ends).
    let mut a = std::vec![std::vec![0.0; n]; n];
    let mut rhs = std::vec![Pose::<f64>::zeros(); n];
    let h = |i: usize| u[i + 1] - u[i];
    let delta = |i: usize| points[i + 1] - points[i];
    a[0][0] = 2.0;
    a[0][1] = 1.0;
    rhs[0] = delta(0) * (3.0 / h(0));
    for i in 1..n - 1 {
        a[i][i - 1] = 1.0 / h(i - 1);
        a[i][i] = 2.0 * (1.0 / h(i - 1) + 1.0 / h(i));
        a[i][i + 1] = 1.0 / h(i);
        rhs[i] = delta(i - 1) * (3.0 / (h(i - 1) * h(i - 1))) + delta(i) * (3.0 / (h(i) * h(i)));
    }
    a[n - 1][n - 2] = 1.0;
    a[n - 1][n - 1] = 2.0;
    rhs[n - 1] = delta(n - 2) * (3.0 / h(n - 2));
    // Gaussian elimination with partial pivoting.
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs()))
            .unwrap();
        a.swap(col, pivot);
        rhs.swap(col, pivot);
        for row in col + 1..n {
            let f = a[row][col] / a[col][col];
            let pivot_row = a[col].clone();
            for (x, y) in a[row].iter_mut().zip(&pivot_row).skip(col) {
                *x -= f * y;
            }
            let r = rhs[col];
            rhs[row] -= r * f;
        }
    }
    let mut k = std::vec![Pose::<f64>::zeros(); n];
    for row in (0..n).rev() {
        let mut s = rhs[row];
        for c in row + 1..n {
            s -= k[c] * a[row][c];
        }
        k[row] = s / a[row][row];
    }
    Reference {
        u,
        p: points.to_vec(),
        k,
    }
}

impl Reference {
    /// Hermite cubic on segment i at local t: position and first derivative.
    fn at(&self, i: usize, t: f64) -> (Pose<f64>, Pose<f64>) {
        let h = self.u[i + 1] - self.u[i];
        let s = t / h;
        let (h00, h10, h01, h11) = (
            2.0 * s.powi(3) - 3.0 * s * s + 1.0,
            s.powi(3) - 2.0 * s * s + s,
            -2.0 * s.powi(3) + 3.0 * s * s,
            s.powi(3) - s * s,
        );
        let (d00, d10, d01, d11) = (
            (6.0 * s * s - 6.0 * s) / h,
            3.0 * s * s - 4.0 * s + 1.0,
            (-6.0 * s * s + 6.0 * s) / h,
            3.0 * s * s - 2.0 * s,
        );
        let (p0, p1, k0, k1) = (self.p[i], self.p[i + 1], self.k[i], self.k[i + 1]);
        (
            p0 * h00 + k0 * (h * h10) + p1 * h01 + k1 * (h * h11),
            p0 * d00 + k0 * d10 + p1 * d01 + k1 * d11,
        )
    }
}

#[test]
fn matches_a_dense_solve_in_slopes_for_both_knot_spacings() {
    let points = wandering(40);
    for config in [CENTRIPETAL, CHORD] {
        let spline = TaskSpline::<f64, 64>::through(&points, &config).unwrap();
        let r = reference(&points, &config);
        let mut worst = (0.0f64, 0.0f64);
        for i in 0..spline.segments() {
            let h = spline.segment_parameter(i);
            assert!((h - (r.u[i + 1] - r.u[i])).abs() < 1e-13);
            for k in 0..=8 {
                let t = h * k as f64 / 8.0;
                let ours = spline.evaluate(i, t);
                let (p, d) = r.at(i, t);
                worst.0 = worst.0.max((ours.position - p).amax());
                worst.1 = worst.1.max((ours.d1 - d).amax() / d.amax().max(1.0));
            }
        }
        // Both are O(n) roundings of coordinates ≤ 1 with moderate knot ratios (the
        // condition number of either system is below ~1e3 here): 1e-12 leaves a
        // margin of ~100× over what is seen, and a wrong row or end condition moves
        // points by millimetres.
        assert!(worst.0 < 1e-12 && worst.1 < 1e-10, "{config:?}: {worst:?}");
    }
}

#[test]
fn knots_are_cscvn_breaks_and_the_curve_interpolates_c2_with_natural_ends() {
    let points = wandering(25);
    let spline = TaskSpline::<f64, 32>::through(&points, &CENTRIPETAL).unwrap();
    let mut total = 0.0;
    for (i, w) in points.windows(2).enumerate() {
        let d = w[1] - w[0];
        let metric =
            d.fixed_rows::<3>(0).norm_squared() + 0.01 * d.fixed_rows::<2>(3).norm_squared();
        total += metric.powf(0.25);
        assert!((spline.segment_parameter(i) - metric.powf(0.25)).abs() < 1e-15);
    }
    let sum: f64 = (0..spline.segments())
        .map(|i| spline.segment_parameter(i))
        .sum();
    assert!((sum - total).abs() < 1e-13);
    for i in 0..spline.segments() {
        let end = spline.evaluate(i, spline.segment_parameter(i));
        assert!((end.position - points[i + 1]).amax() < 1e-14);
        assert!((spline.evaluate(i, 0.0).position - points[i]).amax() < 1e-15);
        if i + 1 < spline.segments() {
            let start = spline.evaluate(i + 1, 0.0);
            // C¹ and C² across the knot, to rounding of the slopes (≤ ~1).
            assert!((end.d1 - start.d1).amax() < 1e-12, "{i}");
            assert!(
                (end.d2 - start.d2).amax() < 1e-10 * (1.0 + start.d2.amax()),
                "{i}"
            );
        }
    }
    let last = spline.segments() - 1;
    assert_eq!(spline.evaluate(0, 0.0).d2.amax(), 0.0);
    let end = spline.evaluate(last, spline.segment_parameter(last)).d2;
    assert!(end.amax() < 1e-12 * (1.0 + spline.evaluate(last, 0.0).d2.amax()));
}

#[test]
fn straight_lines_stay_straight() {
    // Collinear points with uneven spacing, angles moving in proportion.
    let dir = Pose::new(0.6, -0.48, 0.64, 0.5, -0.2);
    let base = Pose::new(-0.1, 0.45, 0.02, 0.1, 0.0);
    let steps = [0.0, 0.01, 0.013, 0.05, 0.051, 0.2, 0.23];
    let points: Vec<Pose<f64>> = steps.iter().map(|&s| base + dir * s).collect();
    // Chord-length knots: the parameter is arc length and the line is reproduced.
    let spline = TaskSpline::<f64, 8>::through(&points, &CHORD).unwrap();
    let unit = spline.metric_norm(&dir);
    for i in 0..spline.segments() {
        for k in 0..=4 {
            let t = spline.segment_parameter(i) * k as f64 / 4.0;
            let s = spline.evaluate(i, t);
            assert!((spline.metric_norm(&s.d1) - 1.0).abs() < 1e-14);
            // M comes from differences of slopes rounded to ~1e-16 over chords of 1 mm
            // (×6/h²·h): ~1e-12 seen, and M·h ~1e-14 in the slope; a bent curve has M
            // of order 1/h.
            assert!(
                (s.d1 - dir / unit).amax() < 1e-13 && s.d2.amax() < 1e-10,
                "{i} {k} {:e} {:e}",
                (s.d1 - dir / unit).amax(),
                s.d2.amax()
            );
        }
    }
    assert!(spline.polyline_deviation(16) < 1e-15);
    // Centripetal knots: not arc length, but still on the line (each coordinate is
    // the same scalar spline times the direction).
    let spline = TaskSpline::<f64, 8>::through(&points, &CENTRIPETAL).unwrap();
    for i in 0..spline.segments() {
        for k in 0..=4 {
            let t = spline.segment_parameter(i) * k as f64 / 4.0;
            let rel = spline.evaluate(i, t).position - base;
            let along = rel.dot(&dir) / dir.norm_squared();
            assert!((rel - dir * along).amax() < 1e-15);
        }
    }
}

#[test]
fn length_matches_a_sum_of_many_chords() {
    let points = wandering(20);
    for config in [CENTRIPETAL, CHORD] {
        let spline = TaskSpline::<f64, 32>::through(&points, &config).unwrap();
        // Sums of n and n/4 chords per segment, extrapolated (Richardson: the chord
        // sum's error falls as 1/n², the arc minus chord being κ²δ³/24 per chord).
        let chords = |n: usize| -> f64 {
            let mut sum = 0.0;
            for i in 0..spline.segments() {
                let h = spline.segment_parameter(i);
                let mut prev = spline.evaluate(i, 0.0).position;
                for k in 1..=n {
                    let p = spline.evaluate(i, h * k as f64 / n as f64).position;
                    sum += spline.metric_norm(&(p - prev));
                    prev = p;
                }
            }
            sum
        };
        let (fine, coarse) = (chords(20_000), chords(5_000));
        let extrapolated = fine + (fine - coarse) / 15.0;
        let length = spline.length_m();
        // 32 Gauss panels per segment: error ∝ panel⁶, ~1e-11 relative on this rough
        // path (16 panels give 2e-9); the extrapolated chords are good to ~1e-12.
        let error = (length - extrapolated).abs() / length;
        assert!(error < 1e-10, "{length} {extrapolated} {error:e}");
    }
}

#[test]
fn f32_spline_follows_the_f64_one() {
    let points = wandering(30);
    let s64 = TaskSpline::<f64, 32>::through(&points, &CENTRIPETAL).unwrap();
    let s32 = TaskSpline::<f32, 32>::through(&points, &CENTRIPETAL).unwrap();
    let mut worst = 0.0f64;
    for i in 0..s64.segments() {
        let h = s64.segment_parameter(i);
        for k in 0..=4 {
            let t = h * k as f64 / 4.0;
            let a = s64.evaluate(i, t).position;
            let b = s32.evaluate(i, t as f32).position;
            for (x, y) in a.iter().zip(b.iter()) {
                worst = worst.max((x - f64::from(*y)).abs());
            }
        }
    }
    // Coordinates up to ~1 (ulp 6e-8 in f32) through a few roundings each.
    assert!(worst < 1e-6, "{worst}");
}

#[test]
fn bad_points_are_refused() {
    let p = |x: f64| Pose::new(x, 0.5, 0.0, 0.0, 0.0);
    type S = TaskSpline<f64, 4>;
    assert_eq!(
        S::through(&[p(0.0)], &CHORD).unwrap_err(),
        TaskSplineError::TooFewPoints
    );
    let five = [p(0.0), p(1.0), p(2.0), p(3.0), p(4.0)];
    assert_eq!(
        S::through(&five, &CHORD).unwrap_err(),
        TaskSplineError::Capacity
    );
    assert_eq!(
        S::through(&[p(0.0), p(f64::NAN), p(1.0)], &CHORD).unwrap_err(),
        TaskSplineError::NotFinitePoint(1)
    );
    assert_eq!(
        S::through(&[p(0.0), p(1.0), p(1.0)], &CENTRIPETAL).unwrap_err(),
        TaskSplineError::RepeatedPoint(2)
    );
    // A pure rotation is a repeated point when angles count for nothing.
    let turn = [p(0.0), Pose::new(0.0, 0.5, 0.0, 0.3, 0.0)];
    let tool_point_only = TaskSplineConfig {
        angle_length_m_per_rad: 0.0,
        ..CHORD
    };
    assert_eq!(
        S::through(&turn, &tool_point_only).unwrap_err(),
        TaskSplineError::RepeatedPoint(1)
    );
    assert!(S::through(&turn, &CHORD).is_ok());
    for rho in [-1.0, f64::NAN] {
        let config = TaskSplineConfig {
            angle_length_m_per_rad: rho,
            ..CHORD
        };
        assert!(matches!(
            S::through(&turn, &config),
            Err(TaskSplineError::Config(_))
        ));
    }
    // Too far apart for f32.
    assert_eq!(
        TaskSpline::<f32, 4>::through(&[p(0.0), p(1e300)], &CHORD).unwrap_err(),
        TaskSplineError::NotRepresentable
    );
}
