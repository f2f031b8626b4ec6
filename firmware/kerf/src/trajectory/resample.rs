//! Open contours (T 3.1.5, 3.2.1; docs/equations.md §13).
//!
//! [`densify`]: iterated 3-point quadratic interpolation. Each pass fits, per axis, the
//! quadratic through a window of 3 consecutive points (parameter = point index) and
//! inserts its value halfway between the first two; the last window also fills the
//! gap between its last two. A pass turns N points into 2N − 1, so k passes give
//! 2ᵏ(N − 1) + 1 (T eq. 5). Lagrange weights at the half-index: (3, 6, −1)/8 at 0.5
//! and (−1, 6, 3)/8 at 1.5.
//!
//! [`ArcResampler`]: walks the polyline by arc length, one commanded step per period,
//! and places each sample at the exact crossing point inside its segment (linear
//! interpolation). It follows the point order, never a nearest-point search, so a
//! self-crossing curve (a handwritten 'e') is traced through its crossing.

use super::{check_open, lit, ContourError, Float};
use heapless::Vec;
use nalgebra::Vector2;

fn mix(w: [f64; 3], p: [[f64; 2]; 3]) -> [f64; 2] {
    let [[ax, ay], [bx, by], [cx, cy]] = p;
    let [wa, wb, wc] = w;
    [
        (wa * ax + wb * bx + wc * cx) / 8.0,
        (wa * ay + wb * by + wc * cy) / 8.0,
    ]
}

/// Densifies open-contour `points` with `passes` quadratic passes into capacity `CAP`.
///
/// Errors: fewer than 3 points, a non-finite or repeated consecutive point, a result
/// of more than `CAP` points, or points so large that an inserted one overflows `f64`
/// (`NotRepresentable("points")`).
pub fn densify<const CAP: usize>(
    points: &[[f64; 2]],
    passes: u32,
) -> Result<Vec<[f64; 2], CAP>, ContourError> {
    check_open(points)?;
    1usize
        .checked_shl(passes)
        .and_then(|s| s.checked_mul(points.len() - 1))
        .and_then(|n| n.checked_add(1))
        .filter(|&n| n <= CAP && passes < usize::BITS)
        .ok_or(ContourError::Capacity)?;
    let mut current: Vec<[f64; 2], CAP> = Vec::new();
    current
        .extend_from_slice(points)
        .map_err(|_| ContourError::Capacity)?;
    for _ in 0..passes {
        let mut next: Vec<[f64; 2], CAP> = Vec::new();
        let mut last = None;
        for w in current.windows(3) {
            if let [a, b, c] = *w {
                next.push(a).map_err(|_| ContourError::Capacity)?;
                next.push(mix([3.0, 6.0, -1.0], [a, b, c]))
                    .map_err(|_| ContourError::Capacity)?;
                last = Some([a, b, c]);
            }
        }
        if let Some([a, b, c]) = last {
            for p in [b, mix([-1.0, 6.0, 3.0], [a, b, c]), c] {
                next.push(p).map_err(|_| ContourError::Capacity)?;
            }
        }
        current = next;
    }
    // Each inserted point weighs its neighbours by up to 10/8: finite points near
    // f64::MAX can overflow.
    if current.iter().flatten().any(|v| !v.is_finite()) {
        return Err(crate::ConfigError::not_representable("points").into());
    }
    Ok(current)
}

/// Length of a polyline, m.
pub fn polyline_length(points: &[[f64; 2]]) -> f64 {
    points
        .windows(2)
        .map(|w| match w {
            [a, b] => libm::hypot(b[0] - a[0], b[1] - a[1]),
            _ => 0.0,
        })
        .sum()
}

/// A sample of [`ArcResampler`].
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PathSample<T: Float> {
    /// Position on the polyline, m.
    pub position: Vector2<T>,
    /// Unit direction of the segment it lies on.
    pub direction: Vector2<T>,
    /// Index of that segment (from point `segment` to `segment + 1`).
    pub segment: usize,
}

/// Online arc-length walk along a polyline (borrowed points in `T`).
#[derive(Clone, Debug)]
pub struct ArcResampler<'a, T: Float> {
    points: &'a [[T; 2]],
    segment: usize,
    /// Distance already covered inside `segment`, m.
    along: T,
}

impl<'a, T: Float> ArcResampler<'a, T> {
    /// Starts at the first point. Errors: fewer than 3 points, non-finite points, or
    /// consecutive points that repeat or whose segment has no length in `T` (underflow
    /// or overflow of the scalar).
    pub fn new(points: &'a [[T; 2]]) -> Result<Self, ContourError> {
        // Validate in f64 (repeats and NaN are the same in either scalar).
        for (i, w) in points.windows(2).enumerate() {
            if let [a, b] = w {
                if a == b {
                    return Err(ContourError::RepeatedPoint(i + 1));
                }
            }
        }
        if let Some(i) = points
            .iter()
            .position(|p| !p.iter().all(|v| super::to_f64(*v).is_finite()))
        {
            return Err(ContourError::NotFinitePoint(i));
        }
        if points.len() < 3 {
            return Err(ContourError::TooFewPoints);
        }
        // Every segment needs a length, and with it a direction, in the scalar itself:
        // distinct points can still underflow (or overflow) it.
        for (i, w) in points.windows(2).enumerate() {
            if let [a, b] = w {
                let len = (Vector2::new(b[0], b[1]) - Vector2::new(a[0], a[1])).norm();
                if !(len > T::ZERO && len.is_finite()) {
                    return Err(ContourError::RepeatedPoint(i + 1));
                }
            }
        }
        Ok(Self {
            points,
            segment: 0,
            along: T::ZERO,
        })
    }

    fn segment_ends(&self, i: usize) -> Option<(Vector2<T>, Vector2<T>)> {
        match (self.points.get(i), self.points.get(i + 1)) {
            (Some(a), Some(b)) => Some((Vector2::new(a[0], a[1]), Vector2::new(b[0], b[1]))),
            _ => None,
        }
    }

    /// Moves `ds` (m, ≥ 0) further along the polyline; `None` once past the last point
    /// (the walk then stays at the end).
    pub fn advance(&mut self, ds: T) -> Option<PathSample<T>> {
        let mut remaining = self.along + ds.max(T::ZERO);
        // Bounded: at most one pass over the remaining segments.
        while let Some((a, b)) = self.segment_ends(self.segment) {
            let d = b - a;
            let len = d.norm();
            if remaining <= len {
                self.along = remaining;
                let direction = d / len;
                return Some(PathSample {
                    position: a + direction * remaining,
                    direction,
                    segment: self.segment,
                });
            }
            remaining -= len;
            self.segment += 1;
        }
        self.along = T::ZERO;
        None
    }

    /// The sample where the walk stands now.
    pub fn current(&self) -> Option<PathSample<T>> {
        self.clone().advance(T::ZERO)
    }
}

/// Resamples `points` every `step_m` of arc length (first point included) into `out`.
/// Errors: bad points (see [`ArcResampler::new`]), a non-positive step or a step longer
/// than the polyline, or more samples than `CAP`.
pub fn resample<T: Float, const CAP: usize>(
    points: &[[T; 2]],
    step_m: f64,
) -> Result<Vec<Vector2<T>, CAP>, ContourError> {
    let step = crate::error::positive("step_m", step_m)?;
    let mut walk = ArcResampler::new(points)?;
    let length: f64 = points
        .windows(2)
        .map(|w| match w {
            [a, b] => super::to_f64((Vector2::new(b[0], b[1]) - Vector2::new(a[0], a[1])).norm()),
            _ => 0.0,
        })
        .sum();
    if step > length {
        return Err(ContourError::StepLongerThanContour);
    }
    let mut out = Vec::new();
    let mut next = walk.current();
    while let Some(s) = next {
        out.push(s.position).map_err(|_| ContourError::Capacity)?;
        next = walk.advance(lit(step));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::shapes;

    #[test]
    fn densify_counts_and_is_exact_on_quadratics() {
        // x, y quadratic in the point index: every inserted point must lie on the same
        // quadratic at the half-index (the interpolant is exact for degree ≤ 2).
        let f = |u: f64| [1e-3 * (u * u - 3.0 * u + 1.0), 2e-3 * (0.5 * u * u + u)];
        let pts: [[f64; 2]; 7] = core::array::from_fn(|i| f(i as f64));
        for k in 0..4u32 {
            let d = densify::<512>(&pts, k).unwrap();
            assert_eq!(d.len(), (1 << k) * (pts.len() - 1) + 1);
            for (j, p) in d.iter().enumerate() {
                let e = f(j as f64 / (1 << k) as f64);
                assert!((p[0] - e[0]).abs() < 1e-17 && (p[1] - e[1]).abs() < 1e-17);
            }
        }
    }

    #[test]
    fn densify_approaches_a_circle() {
        // 9 points on a 90° arc: the polyline's worst distance to the circle is the
        // sagitta R(1 − cos(Δφ/2)); densified points must be far closer than that.
        let r = 10e-3;
        let pts: [[f64; 2]; 9] = core::array::from_fn(|i| {
            let a = (i as f64) * core::f64::consts::FRAC_PI_2 / 8.0;
            [r * libm::cos(a), r * libm::sin(a)]
        });
        let sagitta = r * (1.0 - libm::cos(core::f64::consts::FRAC_PI_2 / 16.0));
        let d = densify::<256>(&pts, 4).unwrap();
        let worst = d
            .iter()
            .map(|p| (libm::hypot(p[0], p[1]) - r).abs())
            .fold(0.0, f64::max);
        assert!(worst < sagitta / 50.0, "{worst} vs {sagitta}");
    }

    #[test]
    fn resampling_walks_through_a_self_crossing() {
        let e = densify::<1024>(&shapes::letter_e(), 3).unwrap();
        let step = 8e-6 * 20.0;
        let s = resample::<f64, 4096>(&e, step).unwrap();
        let length = polyline_length(&e);
        assert_eq!(s.len(), libm::floor(length / step) as usize + 1);
        let mut walk = ArcResampler::new(&e).unwrap();
        let mut prev = walk.current().unwrap();
        let mut crossings = 0;
        for q in s.iter().skip(1) {
            let cur = walk.advance(step).unwrap();
            assert_eq!(cur.position, *q);
            // On its segment: collinear with the segment ends and between them.
            let a = Vector2::new(e[cur.segment][0], e[cur.segment][1]);
            let b = Vector2::new(e[cur.segment + 1][0], e[cur.segment + 1][1]);
            assert!((q - a).perp(&(b - a)).abs() < 1e-18);
            assert!((q - a).dot(&(b - a)) >= 0.0 && (q - b).dot(&(a - b)) >= 0.0);
            // Same segment: the chord is the step exactly; across vertices, not longer.
            let chord = (q - prev.position).norm();
            if cur.segment == prev.segment {
                assert!((chord - step).abs() < 1e-15);
            } else {
                assert!(chord <= step + 1e-15);
            }
            // Count passes over the crossing (x = −5 mm on the bar line): the walk must
            // cross y = 0 near there going down, never jump.
            if prev.position.y > 0.0 && q.y <= 0.0 && (q.x + 5e-3).abs() < 0.5e-3 {
                crossings += 1;
            }
            prev = cur;
        }
        assert_eq!(crossings, 1);
        assert!(walk.advance(step).is_none());
    }

    #[test]
    fn points_whose_midpoints_overflow_are_refused() {
        let pts = [[0.0, 0.0], [1e-3, 0.0], [f64::MAX, 1e-3], [2e-3, 0.0]];
        assert_eq!(
            densify::<64>(&pts, 2),
            Err(ContourError::Config(crate::ConfigError::not_representable(
                "points"
            )))
        );
    }

    #[test]
    fn rejects_bad_input() {
        assert_eq!(
            densify::<64>(&[[0.0, 0.0], [1.0, 0.0]], 1).err(),
            Some(ContourError::TooFewPoints)
        );
        assert_eq!(
            densify::<64>(&[[0.0, 0.0], [1.0, 0.0], [1.0, 0.0]], 1).err(),
            Some(ContourError::RepeatedPoint(2))
        );
        assert_eq!(
            densify::<8>(&shapes::letter_s(), 1).err(),
            Some(ContourError::Capacity)
        );
        assert_eq!(
            densify::<64>(&shapes::letter_s(), 200).err(),
            Some(ContourError::Capacity)
        );
        let s = shapes::letter_s();
        assert_eq!(
            resample::<f64, 64>(&s, 1.0).err(),
            Some(ContourError::StepLongerThanContour)
        );
        assert!(resample::<f64, 64>(&s, 0.0).is_err());
        assert_eq!(
            resample::<f64, 4>(&s, 1e-3).err(),
            Some(ContourError::Capacity)
        );
        assert_eq!(
            ArcResampler::<f32>::new(&[[0.0, 0.0], [0.0, 0.0], [1.0, 0.0]]).err(),
            Some(ContourError::RepeatedPoint(1))
        );
    }

    /// Points distinct in value but so close that the segment's length underflows f32
    /// (or so far apart that it overflows): no direction, so a typed error at
    /// construction instead of NaN samples.
    #[test]
    fn segments_without_a_length_in_the_scalar_are_refused() {
        let under = [[0.0f32, 0.0], [1e-30, 0.0], [1.0, 0.0]];
        assert_eq!(
            ArcResampler::new(&under).err(),
            Some(ContourError::RepeatedPoint(1))
        );
        let over = [[0.0f32, 0.0], [1.0, 0.0], [3e38, 3e38]];
        assert_eq!(
            ArcResampler::new(&over).err(),
            Some(ContourError::RepeatedPoint(2))
        );
        let fine = [[0.0f32, 0.0], [1e-6, 0.0], [1.0, 0.0]];
        let mut walk = ArcResampler::new(&fine).unwrap();
        let s = walk.advance(0.0).unwrap();
        assert!(s.position.x.is_finite() && s.direction.x.is_finite());
    }
}
