//! Planar curves a follower steps along (T 3.2.2, SPEC § trajectory): the [`Curve`]
//! trait the curve definitions implement (closed EFDs in [`super::efd`], open splines
//! in [`super::open_path`]) and the arc-length and curvature tools built on it, which
//! [`super::tangential`] uses without knowing which curve it follows.

use super::quadrature::gauss3;
use super::{lit, Float};
use nalgebra::Vector2;

/// Position and derivatives of a [`Curve`] at one θ, relative to the curve's centre.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CurveSample<T: Float> {
    /// C(θ) minus the curve's centre (an EFD's (a0, c0), an open path's centroid), m.
    pub position: Vector2<T>,
    /// dC/dθ, m per unit θ.
    pub d1: Vector2<T>,
    /// d²C/dθ², m per unit θ².
    pub d2: Vector2<T>,
    /// d³C/dθ³, m per unit θ³.
    pub d3: Vector2<T>,
}

/// A planar curve a [`CurveFollower`](super::tangential::CurveFollower) can step
/// along: position and derivatives at a parameter θ over a span — an
/// [`Efd`](super::efd::Efd) (closed, θ ∈ [0, 2π), wrapping) or an
/// [`OpenPath`](super::open_path::OpenPath) (open, θ = chord length from 0 to its end).
pub trait Curve<T: Float> {
    /// Position (relative to the curve's centre) and its first three θ-derivatives.
    fn evaluate(&self, theta: T) -> CurveSample<T>;
    /// dC/dθ alone (cheaper where the curve allows; used for arc length).
    fn tangent(&self, theta: T) -> Vector2<T>;
    /// Where θ ends: 2π for a closed curve (θ wraps there), the end of an open one.
    fn span(&self) -> T;
    /// Whether θ wraps at [`Curve::span`] (closed) or stops there (open).
    fn is_closed(&self) -> bool;
    /// Pieces of the curve (harmonics, segments): sets how finely the whole-curve
    /// checks sample it.
    fn pieces(&self) -> usize;

    /// Arc length from θ0 to θ1 (m): `intervals` panels of 3-point Gauss–Legendre.
    fn arc_length(&self, theta0: T, theta1: T, intervals: usize) -> T {
        let n = intervals.max(1);
        let h = (theta1 - theta0) / lit(n as f64);
        let mut sum = T::ZERO;
        for i in 0..n {
            let a = theta0 + h * lit(i as f64);
            sum += gauss3(h, |u| self.tangent(a + u).norm());
        }
        sum
    }

    /// Signed curvature κ(θ) = (x′y″ − y′x″)/|C′|³ (1/m); zero where |C′| = 0.
    fn curvature(&self, theta: T) -> T {
        let s = self.evaluate(theta);
        let speed = s.d1.norm();
        if speed > T::ZERO {
            s.d1.perp(&s.d2) / (speed * speed * speed)
        } else {
            T::ZERO
        }
    }

    /// Largest |κ| over the span (1/m): `samples` equal θ steps, the best refined by
    /// golden-section search over its two neighbouring steps (kept inside the span).
    fn max_curvature(&self, samples: usize) -> T {
        let curvature = |theta: T| self.curvature(theta).abs();
        let n = samples.max(8);
        let span = self.span();
        let h = span / lit(n as f64);
        let last = if self.is_closed() { n - 1 } else { n };
        let mut best = (T::ZERO, T::ZERO);
        for i in 0..=last {
            let th = h * lit(i as f64);
            let k = curvature(th);
            if k > best.0 {
                best = (k, th);
            }
        }
        let (mut lo, mut hi) = (best.1 - h, best.1 + h);
        if !self.is_closed() {
            lo = lo.max(T::ZERO);
            hi = hi.min(span);
        }
        let g = lit::<T>(0.618_033_988_749_894_8);
        for _ in 0..40 {
            let m1 = hi - (hi - lo) * g;
            let m2 = lo + (hi - lo) * g;
            if curvature(m1) > curvature(m2) {
                hi = m2;
            } else {
                lo = m1;
            }
        }
        best.0.max(curvature((lo + hi) * lit(0.5)))
    }
}
