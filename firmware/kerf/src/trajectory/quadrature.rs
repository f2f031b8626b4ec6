//! Numerical quadrature shared by the arc-length integrals of the curves
//! ([`super::curve`], [`super::task_spline`]) and the arc-length step ([`super::arc`]).

use super::{lit, Float};

/// ∫₀ʰ f(u) du by 3-point Gauss–Legendre (nodes h/2 ± (h/2)√(3/5), weights 5/18, 8/18).
#[inline]
pub(crate) fn gauss3<T: Float>(h: T, f: impl Fn(T) -> T) -> T {
    let half = h * lit(0.5);
    let off = half * lit(0.774_596_669_241_483_4);
    (f(half - off) * lit(5.0) + f(half) * lit(8.0) + f(half + off) * lit(5.0)) * (half / lit(9.0))
}
