//! The scalar the control laws are generic over: `f32` on the MCU, `f64` as the host
//! reference, and [`Q32`] (saturating Q31.32 fixed point) for FPU-less parts.
//!
//! Control laws use only `+ - *`, negation and comparisons in the periodic step;
//! every division or transcendental function is done once in `new()` in `f64` and
//! stored as a coefficient with [`Real::from_f64`].

use core::fmt::Debug;
use core::ops::{Add, Mul, Neg, Sub};
use fixed::types::I32F32;

/// Arithmetic a periodic control step needs. Implemented for `f32`, `f64` and [`Q32`].
pub trait Real:
    Copy
    + Debug
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Neg<Output = Self>
{
    /// Additive identity.
    const ZERO: Self;
    /// Converts a configuration value (call at configuration time, not per period).
    fn from_f64(v: f64) -> Self;
    /// Converts to `f64` for reporting and tests.
    fn to_f64(self) -> f64;
    /// `bits / 2^32`: the exact form of a wrapping phase accumulator
    /// (one magnetic pitch = 2^32).
    fn from_q32(bits: i64) -> Self;
    /// `round(self · 2^32)`, saturating (NaN → 0): the inverse of [`Real::from_q32`].
    fn to_q32(self) -> i64;

    /// Clamps to `[-limit, limit]` (`limit >= 0`).
    #[inline]
    fn clamp_abs(self, limit: Self) -> Self {
        if self > limit {
            limit
        } else if self < -limit {
            -limit
        } else {
            self
        }
    }
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    #[inline]
    fn from_f64(v: f64) -> Self {
        v as f32
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline]
    fn from_q32(bits: i64) -> Self {
        // One rounding (i64 → f32), then an exact power-of-two scale.
        bits as f32 * (1.0 / 4_294_967_296.0)
    }
    #[inline]
    fn to_q32(self) -> i64 {
        (self * 4_294_967_296.0) as i64
    }
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    #[inline]
    fn from_f64(v: f64) -> Self {
        v
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline]
    fn from_q32(bits: i64) -> Self {
        bits as f64 * (1.0 / 4_294_967_296.0)
    }
    #[inline]
    fn to_q32(self) -> i64 {
        (self * 4_294_967_296.0) as i64
    }
}

/// Saturating signed Q31.32 fixed point (64-bit word).
///
/// Why one 64-bit format for every signal of the DOB+PD loop: in SI units the loop's
/// signals span from 1e-9 m (position resolution needed) to 3.6e4 s⁻² (position gain).
/// A 32-bit word cannot hold both ends in one format (I16F16 quantizes metres to 15 µm;
/// I8F24 cannot hold the gains), so a 32-bit design would need a separate Q format per
/// signal and per product. Q31.32 covers ±2.1e9 with 2.3e-10 resolution, so every
/// signal fits one format with at least 10⁴ headroom (ranges in `control` docs and
/// checked by the fixed-point scenario test). Arithmetic saturates instead of wrapping.
#[derive(Copy, Clone, Debug, PartialEq, PartialOrd, Default)]
pub struct Q32(pub I32F32);

impl Add for Q32 {
    type Output = Self;
    #[inline]
    fn add(self, rhs: Self) -> Self {
        Q32(self.0.saturating_add(rhs.0))
    }
}
impl Sub for Q32 {
    type Output = Self;
    #[inline]
    fn sub(self, rhs: Self) -> Self {
        Q32(self.0.saturating_sub(rhs.0))
    }
}
impl Mul for Q32 {
    type Output = Self;
    #[inline]
    fn mul(self, rhs: Self) -> Self {
        Q32(self.0.saturating_mul(rhs.0))
    }
}
impl Neg for Q32 {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        Q32(self.0.saturating_neg())
    }
}

impl Real for Q32 {
    const ZERO: Self = Q32(I32F32::ZERO);
    #[inline]
    fn from_f64(v: f64) -> Self {
        // NaN maps to zero; out-of-range values saturate.
        Q32(I32F32::saturating_from_num(if v.is_nan() {
            0.0
        } else {
            v
        }))
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self.0.to_num::<f64>()
    }
    #[inline]
    fn from_q32(bits: i64) -> Self {
        Q32(I32F32::from_bits(bits))
    }
    #[inline]
    fn to_q32(self) -> i64 {
        self.0.to_bits()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn q32_saturates_instead_of_wrapping() {
        let big = Q32::from_f64(2.0e9);
        assert_eq!((big + big).0, I32F32::MAX);
        assert_eq!((-big - big).0, I32F32::MIN);
        assert_eq!((big * big).0, I32F32::MAX);
        assert_eq!(Q32::from_f64(f64::NAN), Q32::ZERO);
        assert_eq!(Q32::from_f64(1e300).0, I32F32::MAX);
    }

    #[test]
    fn from_q32_agrees_across_scalars() {
        for bits in [0i64, 1, -1, 3 << 31, -(7 << 32) + 12345, i64::MAX / 4] {
            let exact = bits as f64 / 4_294_967_296.0;
            assert_eq!(f64::from_q32(bits), exact);
            assert_eq!(Q32::from_q32(bits).to_f64(), exact);
            assert_eq!(Q32::from_q32(bits).to_q32(), bits);
            if bits.unsigned_abs() < 1 << 52 {
                assert_eq!(f64::from_q32(bits).to_q32(), bits);
            }
            let e32 = (f32::from_q32(bits) as f64 - exact).abs();
            assert!(e32 <= exact.abs() * 1.2e-7 + 1e-12, "{bits}: {e32}");
        }
    }

    #[test]
    fn clamp_abs_limits_both_sides() {
        assert_eq!(5.0f64.clamp_abs(2.0), 2.0);
        assert_eq!((-5.0f64).clamp_abs(2.0), -2.0);
        assert_eq!(1.5f32.clamp_abs(2.0), 1.5);
        assert_eq!(
            Q32::from_f64(-3.0).clamp_abs(Q32::from_f64(1.0)).to_f64(),
            -1.0
        );
    }
}
