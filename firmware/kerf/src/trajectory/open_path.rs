//! Open contours as a smooth planar curve (T 3.1.5, 3.2.1; docs/equations.md §13): a C²
//! cubic spline through the contour's points, one per coordinate, in the chord-length
//! parameter u (m), with natural ends (zero second derivative).
//!
//! The print densifies the points and resamples them at V·Ts offline; a spline in
//! chord length gives the same curve a [`CurveFollower`](super::tangential) can step
//! online at constant tangential speed, like an EFD, with analytic derivatives to third
//! order (the third is constant on each segment). Chord length makes |C′(u)| close to
//! one, so u is nearly arc length and the follower's step is well conditioned.
//!
//! With knots u0 < … < un, hi = ui+1 − ui and second derivatives Mi of one coordinate
//! x, continuity of x′ gives hi−1 Mi−1 + 2(hi−1 + hi) Mi + hi Mi+1 =
//! 6((xi+1 − xi)/hi − (xi − xi−1)/hi−1) inside, M0 = Mn = 0 at the ends. The system is
//! diagonally dominant and solved by the Thomas algorithm. On segment i, with
//! t = u − ui: x = xi + si t + Mi t²/2 + (Mi+1 − Mi) t³/(6hi), with the knot slope
//! si = (xi+1 − xi)/hi − hi(2Mi + Mi+1)/6.

use super::curve::{Curve, CurveSample};
use super::{lit, ContourError, Float};
use crate::error::{representable, ConfigError};
use nalgebra::{SVector, Vector2};

/// One knot: spline parameter (here chord length), position (relative to the points'
/// centroid) and the spline's second derivative there, in `D` coordinates.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct Knot<T, const D: usize> {
    /// Parameter at the knot.
    pub(crate) u: T,
    /// Position.
    pub(crate) p: SVector<T, D>,
    /// Second derivative in the parameter.
    pub(crate) m: SVector<T, D>,
}

/// An open planar curve through up to `N` points (module docs). `Copy`, so that a
/// job's path is copied in place.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct OpenPath<T: Float, const N: usize> {
    centre: Vector2<T>,
    /// The first `len` are the knots.
    knots: [Knot<T, 2>; N],
    len: usize,
}

impl<T: Float, const N: usize> OpenPath<T, N> {
    /// The spline through `points` (m), in their order.
    ///
    /// Errors: fewer than 3 points (`TooFewPoints`), more than `N` (`Capacity`), a
    /// coordinate NaN or infinite (`NotFinitePoint`), a point equal to the one before
    /// (`RepeatedPoint`: the chord parameter would not advance), values `T` cannot hold
    /// (`NotRepresentable`).
    pub fn from_points(points: &[[f64; 2]]) -> Result<Self, ContourError> {
        if points.len() < 3 {
            return Err(ContourError::TooFewPoints);
        }
        if points.len() > N {
            return Err(ContourError::Capacity);
        }
        if let Some(i) = points
            .iter()
            .position(|p| !(p[0].is_finite() && p[1].is_finite()))
        {
            return Err(ContourError::NotFinitePoint(i));
        }
        let n = points.len() as f64;
        let centre = [
            points.iter().map(|p| p[0]).sum::<f64>() / n,
            points.iter().map(|p| p[1]).sum::<f64>() / n,
        ];
        let mut knots: heapless::Vec<Knot<f64, 2>, N> = heapless::Vec::new();
        let mut u = 0.0;
        let mut previous: Option<&[f64; 2]> = None;
        for (i, p) in points.iter().enumerate() {
            if let Some(q) = previous {
                let h = libm::hypot(p[0] - q[0], p[1] - q[1]);
                // A chord that does not move u in f64 has no direction either.
                if u + h <= u {
                    return Err(ContourError::RepeatedPoint(i));
                }
                u += h;
            }
            previous = Some(p);
            let knot = Knot {
                u,
                p: Vector2::new(p[0] - centre[0], p[1] - centre[1]),
                m: Vector2::zeros(),
            };
            // Capacity checked above.
            let _ = knots.push(knot);
        }
        solve_natural(&mut knots);
        let mut path = Self::empty();
        path.assign(Vector2::new(centre[0], centre[1]), &knots)?;
        Ok(path)
    }

    /// No points (a placeholder to convert a path into).
    pub fn empty() -> Self {
        let zero = Vector2::new(T::ZERO, T::ZERO);
        Self {
            centre: zero,
            knots: [Knot {
                u: T::ZERO,
                p: zero,
                m: zero,
            }; N],
            len: 0,
        }
    }

    /// [`OpenPath::from_f64`] into `self`, in place (no copy of the path on the
    /// stack). On an error `self` must not be used.
    pub fn assign_f64(&mut self, curve: &OpenPath<f64, N>) -> Result<(), ContourError> {
        self.assign(curve.centre, curve.knots())
    }

    /// The centre and knots, converted to `T`, into `self`.
    fn assign(&mut self, centre: Vector2<f64>, knots: &[Knot<f64, 2>]) -> Result<(), ContourError> {
        let v = |w: Vector2<f64>| -> Result<Vector2<T>, ConfigError> {
            Ok(Vector2::new(
                representable("points", w.x)?,
                representable("points", w.y)?,
            ))
        };
        self.centre = v(centre)?;
        if knots.len() > N {
            return Err(ContourError::Capacity);
        }
        for (o, k) in self.knots.iter_mut().zip(knots) {
            *o = Knot {
                u: representable("points", k.u)?,
                p: v(k.p)?,
                m: v(k.m)?,
            };
        }
        self.len = knots.len();
        Ok(())
    }

    /// The knots in use.
    fn knots(&self) -> &[Knot<T, 2>] {
        self.knots.get(..self.len).unwrap_or(&[])
    }

    /// The same curve in the scalar `T`, from its `f64` description (a job planned in
    /// `f64`): 5 conversions per knot, no solve.
    pub fn from_f64(curve: &OpenPath<f64, N>) -> Result<Self, ContourError> {
        let mut path = Self::empty();
        path.assign_f64(curve)?;
        Ok(path)
    }

    /// The centroid of the points, m (positions are relative to it).
    pub fn centre(&self) -> Vector2<T> {
        self.centre
    }

    /// Number of points.
    pub fn points(&self) -> usize {
        self.len
    }

    /// Length of the chord polygon: the parameter's range is [0, this], m.
    pub fn chord_length_m(&self) -> T {
        self.knots().last().map_or(T::ZERO, |k| k.u)
    }

    /// Index of the segment holding `u` (the first for u below 0, the last above the
    /// end): binary search over the knots.
    fn segment(&self, u: T) -> usize {
        let last = self.len.saturating_sub(2);
        let (mut lo, mut hi) = (0, last);
        while lo < hi {
            // lo < hi ≤ len: the midpoint without a sum that could pass usize, and
            // mid > lo ≥ 0, so mid − 1 never saturates.
            let mid = lo + (hi - lo).div_ceil(2);
            if self.knots().get(mid).is_some_and(|k| k.u <= u) {
                lo = mid;
            } else {
                hi = mid.saturating_sub(1);
            }
        }
        lo
    }
}

/// Second derivatives of the natural spline through `knots` (module docs), all `D`
/// coordinates at once (one tridiagonal matrix, `D` right-hand sides); `knots` holds
/// at least 3 with increasing u. Shared with the task-space spline of
/// [`super::task_spline`].
pub(crate) fn solve_natural<const D: usize, const N: usize>(
    knots: &mut heapless::Vec<Knot<f64, D>, N>,
) {
    let inner = knots.len().saturating_sub(2);
    // Forward sweep over the inner knots, window (i − 1, i, i + 1) at index i − 1: c′
    // (upper diagonal) and d′ (right side) of the Thomas algorithm; M = 0 at the ends.
    let mut upper = [0.0; N];
    let mut rhs = [SVector::<f64, D>::zeros(); N];
    let (mut previous_upper, mut previous_rhs) = (0.0, SVector::<f64, D>::zeros());
    for (j, ((w, up), r)) in knots
        .windows(3)
        .zip(upper.iter_mut())
        .zip(rhs.iter_mut())
        .enumerate()
    {
        let &[a, b, c] = w else { continue };
        let (h0, h1) = (b.u - a.u, c.u - b.u);
        let d = ((c.p - b.p) / h1 - (b.p - a.p) / h0) * 6.0;
        let lower = if j > 0 { h0 } else { 0.0 };
        let diag = 2.0 * (h0 + h1) - lower * previous_upper;
        *up = if j + 1 < inner { h1 / diag } else { 0.0 };
        *r = (d - previous_rhs * lower) / diag;
        (previous_upper, previous_rhs) = (*up, *r);
    }
    // Back substitution, from the last inner knot: Mi = d′i − c′i Mi+1.
    let mut next_m = SVector::<f64, D>::zeros();
    for (knot, (r, up)) in knots
        .iter_mut()
        .skip(1)
        .take(inner)
        .rev()
        .zip(rhs.iter().zip(upper.iter()).take(inner).rev())
    {
        knot.m = r - next_m * *up;
        next_m = knot.m;
    }
}

impl<T: Float, const N: usize> Curve<T> for OpenPath<T, N> {
    /// Position (relative to the centroid) and derivatives in u; outside [0, end] the
    /// end segments' cubics continue.
    fn evaluate(&self, u: T) -> CurveSample<T> {
        let i = self.segment(u);
        let (Some(a), Some(b)) = (self.knots().get(i), self.knots().get(i + 1)) else {
            let zero = Vector2::new(T::ZERO, T::ZERO);
            return CurveSample {
                position: zero,
                d1: zero,
                d2: zero,
                d3: zero,
            };
        };
        let h = b.u - a.u;
        let t = u - a.u;
        let six = lit::<T>(6.0);
        let half = lit::<T>(0.5);
        let jerk = (b.m - a.m) / h;
        let slope = (b.p - a.p) / h - (a.m * lit::<T>(2.0) + b.m) * (h / six);
        CurveSample {
            position: a.p + slope * t + a.m * (half * t * t) + jerk * (t * t * t / six),
            d1: slope + a.m * t + jerk * (half * t * t),
            d2: a.m + jerk * t,
            d3: jerk,
        }
    }

    fn tangent(&self, u: T) -> Vector2<T> {
        self.evaluate(u).d1
    }

    fn span(&self) -> T {
        self.chord_length_m()
    }

    fn is_closed(&self) -> bool {
        false
    }

    fn pieces(&self) -> usize {
        self.len.saturating_sub(1)
    }
}

#[cfg(test)]
mod tests;
