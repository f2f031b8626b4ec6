//! The scalar the control laws are generic over: `f32` on the MCU, `f64` as the host
//! reference, [`Q6_25`] (saturating 32-bit fixed point with [`Gain`] coefficients)
//! for FPU-less parts, and [`Q31_32`] (saturating 64-bit fixed point) as the host's
//! cross-check of fixed point with ample range.
//!
//! Control laws use only `+ - *`, negation and comparisons in the periodic step;
//! every division or transcendental function is done once in `new()` in `f64` and
//! stored as a coefficient, either in the scalar itself ([`Real::from_f64`]) or, for
//! a constant factor of a signal, as the scalar's [`Real::Coef`] ([`Real::coef`]),
//! applied with [`Real::scale`].
//!
//! # Why a coefficient type
//!
//! One Q format for every number of a loop cannot serve both its signals and its
//! gains: in SI units the single axis' signals need a 30 nm step and a ±64 range
//! (position, velocity, acceleration command, force; the table in
//! [`crate::control`]), while its gains run from 5e-9 (Ts²/2 in s²) to 6.3e4 (Kp in
//! s⁻²). So a scalar names a second type for constant factors. For the floats it is
//! the float itself and [`Real::scale`] is one multiplication: the generated code of
//! the `f32`/`f64` laws is what it was with gains stored as `T`. For [`Q6_25`] it is
//! a [`Gain`], a normalized 32-bit mantissa with its own shift chosen in `new()`, so
//! every gain keeps 31 significant bits whatever its size, and a product
//! signal × gain is one 32 × 32 → 64-bit multiply, a rounding shift and a saturation.

use core::fmt::Debug;
use core::ops::{Add, Mul, Neg, Sub};
use fixed::types::I32F32;

mod q6_25;
pub use q6_25::{Gain, Q6_25, SIGNAL_FRACTION_BITS};

/// Arithmetic a periodic control step needs. Implemented for `f32`, `f64` and [`Q31_32`].
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
    /// The step of a fixed-point scalar (its absolute resolution); 0 for the floats,
    /// whose resolution is relative.
    const FIXED_STEP: f64 = 0.0;
    /// Largest magnitude a signal of this scalar holds (a fixed-point scalar saturates
    /// beyond it, a float becomes infinite): a job's times and positions must stay
    /// below it, as `check_job` requires.
    const RANGE: f64;
    /// Converts a configuration value (call at configuration time, not per period).
    fn from_f64(v: f64) -> Self;
    /// Converts to `f64` for reporting and tests.
    fn to_f64(self) -> f64;
    /// `bits / 2^32`: the exact form of a wrapping phase accumulator
    /// (one magnetic pitch = 2^32).
    fn from_q32(bits: i64) -> Self;
    /// `self · 2^32` truncated toward zero, saturating (NaN → 0): the inverse of
    /// [`Real::from_q32`].
    fn to_q32(self) -> i64;
    /// `false` for NaN and ±∞ (always `true` for fixed point).
    fn is_finite(self) -> bool;

    /// A constant factor of a signal (a gain, a period, a mass) in this scalar: the
    /// scalar itself for the floats and [`Q31_32`], a [`Gain`] for [`Q6_25`].
    type Coef: Copy + Debug + PartialEq;
    /// `v` as a coefficient, rounded to nearest; out-of-range values saturate and
    /// NaN gives zero, so check with [`Real::coef_to_f64`] (as `new()` does through
    /// `error::factor`).
    fn coef(v: f64) -> Self::Coef;
    /// The coefficient's exact value.
    fn coef_to_f64(c: Self::Coef) -> f64;
    /// `self × c`, rounded to the scalar (saturating for fixed point).
    fn scale(self, c: Self::Coef) -> Self;
    /// `n × c` for a count `n` (periods since a start): for the floats the same as
    /// `Real::from_q32(n << 32).scale(c)`, for fixed point without passing the count
    /// through the signal format, whose range it may exceed.
    #[inline]
    fn count_times(n: u32, c: Self::Coef) -> Self {
        Self::from_q32(i64::from(n) << 32).scale(c)
    }
    /// What an integrator in this scalar carries from one rounded step to the next
    /// ([`Real::mul_add_carry`]): nothing for the floats and Q31.32, the last
    /// rounding's remainder for [`Q6_25`].
    type Carry: Copy + Debug + PartialEq + Default;
    /// `self × a + b × c` for an integrator's step, with first-order error feedback in
    /// fixed point: the remainder the last step's rounding lost (`carry`) is added
    /// before rounding and this step's is left in `carry`, so the rounded steps sum to
    /// the exact ones within one step of the scalar instead of drifting by up to half
    /// a step per period. (A constant rounding error in a position prediction is, to
    /// the tracking observer, a velocity of error/Ts: 1.5e-4 m/s for half a Q6.25
    /// step at 10 kHz.) For the floats it is the plain expression.
    #[inline]
    fn mul_add_carry(self, a: Self::Coef, b: Self, c: Self::Coef, carry: &mut Self::Carry) -> Self {
        let _ = carry;
        self.scale(a) + b.scale(c)
    }
    /// `self × c` with first-order error feedback (see [`Real::mul_add_carry`]); for
    /// the floats [`Real::scale`].
    #[inline]
    fn scale_carry(self, c: Self::Coef, carry: &mut Self::Carry) -> Self {
        let _ = carry;
        self.scale(c)
    }

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

/// [`Real`] for the primitive floats: conversions are `as` casts (round to nearest,
/// saturating to integers), and the 2^32 scale of the phase conversions is an exact power
/// of two.
///
/// The phase conversions (`from_q32`, `to_q32`) go through 32-bit words: a Cortex-M4F converts between `f32`
/// and a 32-bit integer in one VCVT, while an `i64` conversion is a software routine
/// of about 30 instructions (`__aeabi_l2f`, `__aeabi_f2lz`). `from_q32` adds the two
/// words of the magnitude (the integer part, exact below 2^24 for `f32`, and the
/// fraction scaled by 2^-32; no cancellation, both are positive) and restores the
/// sign: one rounding for `f64` (the sum of two exact terms, the same result as
/// `bits as f64 · 2^-32`), two for `f32` (the fraction, then the sum: within one ulp).
/// `to_q32` takes the 32-bit conversion whenever the result fits one (|x| < 1/2, a
/// predicted phase step) and the saturating `i64` cast otherwise (and for NaN); both
/// truncate toward zero, so the result is the `i64` cast's in every case.
macro_rules! impl_real_for_float {
    ($($float:ty),*) => {$(
        impl Real for $float {
            const ZERO: Self = 0.0;
            const RANGE: f64 = <$float>::MAX as f64;
            #[inline]
            fn from_f64(v: f64) -> Self {
                v as $float
            }
            #[inline]
            fn to_f64(self) -> f64 {
                f64::from(self)
            }
            #[inline]
            fn from_q32(bits: i64) -> Self {
                let magnitude = bits.unsigned_abs();
                let integer = (magnitude >> 32) as u32;
                let fraction = magnitude as u32;
                let value = integer as $float + fraction as $float * (1.0 / 4_294_967_296.0);
                if bits < 0 {
                    -value
                } else {
                    value
                }
            }
            #[inline]
            fn to_q32(self) -> i64 {
                let scaled = self * 4_294_967_296.0;
                if scaled.abs() < 2_147_483_648.0 {
                    i64::from(scaled as i32)
                } else {
                    scaled as i64
                }
            }
            #[inline]
            fn is_finite(self) -> bool {
                self.abs() < <$float>::INFINITY
            }
            type Coef = Self;
            #[inline]
            fn coef(v: f64) -> Self {
                v as $float
            }
            #[inline]
            fn coef_to_f64(c: Self) -> f64 {
                f64::from(c)
            }
            /// `c * self`: the coefficient first, as the laws wrote their products
            /// before the coefficient type (the same result, the same code).
            #[inline]
            fn scale(self, c: Self) -> Self {
                c * self
            }
            type Carry = ();
        }
    )*};
}
impl_real_for_float!(f32, f64);

/// Saturating signed Q31.32 fixed point (64-bit word: `fixed`'s `I32F32`), gains in the
/// same format.
///
/// One format holds every signal and every gain of the DOB+PD loop (±2.1e9 with
/// 2.3e-10 resolution), at the price of 64-bit arithmetic in every operation: on a
/// Cortex-M4F a DOB+PD period costs about ten times the `f32` one (BENCHMARKS.md).
/// It stays as the host's fixed-point cross-check with ample range; the 32-bit
/// format for FPU-less parts is [`Q6_25`]. Arithmetic saturates instead of wrapping.
#[derive(Copy, Clone, Debug, PartialEq, PartialOrd, Default)]
pub struct Q31_32(pub I32F32);

impl Add for Q31_32 {
    type Output = Self;
    #[inline]
    fn add(self, rhs: Self) -> Self {
        Q31_32(self.0.saturating_add(rhs.0))
    }
}
impl Sub for Q31_32 {
    type Output = Self;
    #[inline]
    fn sub(self, rhs: Self) -> Self {
        Q31_32(self.0.saturating_sub(rhs.0))
    }
}
impl Mul for Q31_32 {
    type Output = Self;
    #[inline]
    fn mul(self, rhs: Self) -> Self {
        Q31_32(self.0.saturating_mul(rhs.0))
    }
}
impl Neg for Q31_32 {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        Q31_32(self.0.saturating_neg())
    }
}

impl Real for Q31_32 {
    const ZERO: Self = Q31_32(I32F32::ZERO);
    // The magnitude of I32F32::MIN: 2^31.
    const RANGE: f64 = -(i32::MIN as f64);
    #[inline]
    fn from_f64(v: f64) -> Self {
        // v · 2^32 is exact (a power-of-two scale); `rint` rounds it to the nearest
        // integer, ties to even, as `fixed`'s conversion does; `as` saturates out-of-range
        // values and maps NaN to zero. Done here rather than by `saturating_from_num`,
        // whose NaN branch panics and stays linked even behind a NaN test.
        Q31_32(I32F32::from_bits(libm::rint(v * 4_294_967_296.0) as i64))
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self.0.to_num::<f64>()
    }
    #[inline]
    fn from_q32(bits: i64) -> Self {
        Q31_32(I32F32::from_bits(bits))
    }
    #[inline]
    fn to_q32(self) -> i64 {
        self.0.to_bits()
    }
    #[inline]
    fn is_finite(self) -> bool {
        true
    }
    type Coef = Self;
    #[inline]
    fn coef(v: f64) -> Self {
        Self::from_f64(v)
    }
    #[inline]
    fn coef_to_f64(c: Self) -> f64 {
        c.to_f64()
    }
    /// `c * self`: the coefficient first, as the laws wrote their products before
    /// the coefficient type (`fixed`'s saturating product compiles differently with
    /// its operands swapped).
    #[inline]
    fn scale(self, c: Self) -> Self {
        c * self
    }
    type Carry = ();
}

/// Floating-point scalars (`f32`, `f64`) for the geometric code: nalgebra's
/// `RealField` plus [`Real`], and a square root and sine/cosine that stay in single
/// precision for `f32`. (`libm`'s `sqrtf` and `sinf` compute in software or in double
/// precision, which a Cortex-M4F has only in software: about 50 and 1300 instructions
/// against about 20 and 60 here.) With the `hw-sqrt` feature on a hard-float Arm
/// target, `f32`'s square root is the FPU's VSQRT.F32 (see [`sqrt_f32`]).
pub trait Float: nalgebra::RealField + Copy + Real {
    /// √self (NaN for negative input).
    fn fsqrt(self) -> Self;
    /// (sin self, cos self), self in rad.
    fn fsin_cos(self) -> (Self, Self);
}

impl Float for f64 {
    #[inline]
    fn fsqrt(self) -> Self {
        libm::sqrt(self)
    }
    #[inline]
    fn fsin_cos(self) -> (Self, Self) {
        (libm::sin(self), libm::cos(self))
    }
}

impl Float for f32 {
    /// The FPU's VSQRT.F32 (correctly rounded) with the `hw-sqrt` feature on a
    /// hard-float Arm target, else [`sqrt_f32`] (within 1 ulp).
    #[inline]
    fn fsqrt(self) -> Self {
        #[cfg(all(feature = "hw-sqrt", target_arch = "arm", target_abi = "eabihf"))]
        {
            kerf_vsqrt::sqrt_f32(self)
        }
        #[cfg(not(all(feature = "hw-sqrt", target_arch = "arm", target_abi = "eabihf")))]
        {
            sqrt_f32(self)
        }
    }
    #[inline]
    fn fsin_cos(self) -> (Self, Self) {
        sin_cos_f32(self)
    }
}

/// Euclidean norm by [`Float::fsqrt`]: nalgebra's `norm` takes its square root from
/// `libm` (`sqrtf`, about 50 instructions in software), where `fsqrt` is the FPU's
/// VSQRT on the firmware targets.
#[inline]
pub(crate) fn norm<T: Float, const D: usize>(v: &nalgebra::SVector<T, D>) -> T {
    v.norm_squared().fsqrt()
}

/// A configuration constant or formula literal in `T` (`Real::from_f64`, named so
/// that it does not clash with nalgebra's conversions on the same types).
#[inline]
pub(crate) fn lit<T: Float>(v: f64) -> T {
    <T as Real>::from_f64(v)
}

/// `v` as `f64` for reporting and comparisons at set-up time.
#[inline]
pub(crate) fn to_f64<T: Float>(v: T) -> f64 {
    <T as Real>::to_f64(v)
}

/// Single-precision square root with FPU multiply/add only: a bit-level estimate of
/// 1/√x (relative error ≤ 3.4e-2) refined by two Newton steps y ← y (3 − x y²)/2 (to
/// 1.8e-3, then 4.7e-6), then one Newton correction of √x = x·y, which squares that
/// error far below an ulp. Within 1 ulp of the correctly rounded result (tested against
/// f64 over the whole exponent range, and every input of two binades, which by the
/// exact power-of-4 scaling covers all others).
///
/// Inputs in [2^-125, 2^127), which include everything the geometry produces, cost one
/// integer range check; the rest go to `sqrt_f32_special`, which scales the smallest
/// and largest binades into that range (there x/2 would round, or r² overflow).
///
/// This is [`Float::fsqrt`] for `f32` on the host and without the `hw-sqrt` feature.
/// With `hw-sqrt` on a hard-float Arm target (the firmware images enable it),
/// `fsqrt` is the FPU's VSQRT.F32 instead, inlined through the `kerf-vsqrt` crate
/// (the library itself stays free of `unsafe`): correctly rounded, and cheaper on a
/// Cortex-M4 even though VSQRT takes 14 cycles. Measured in the same benchmark run on
/// the same inputs (BENCHMARKS.md): this Newton root about 21 instructions and 20
/// estimated cycles, the inlined VSQRT 5 instructions and 18 cycles (the value passes
/// through a core register, as stable `asm!` cannot name an FPU register on this
/// target), VSQRT called out of line 3 instructions and 20 cycles (the BL and BX, and
/// the call clobbers s0–s15 in its caller); the general delta IK 231 → 174
/// instructions, 309 → 261 cycles.
#[inline]
pub fn sqrt_f32(x: f32) -> f32 {
    let bits = x.to_bits();
    // x ∈ [2^-125, 2^127) ⟺ bits ∈ [0x0100_0000, 0x7f00_0000).
    if bits.wrapping_sub(0x0100_0000) >= 0x7e00_0000 {
        return sqrt_f32_special(x);
    }
    let mut y = f32::from_bits(0x5f37_5a86 - (bits >> 1));
    let half_x = 0.5 * x;
    y *= 1.5 - half_x * y * y;
    y *= 1.5 - half_x * y * y;
    let r = x * y;
    r + (x - r * r) * (0.5 * y)
}

/// [`sqrt_f32`] outside [2^-125, 2^127).
#[cold]
#[inline(never)]
fn sqrt_f32_special(x: f32) -> f32 {
    if x.is_nan() || x < 0.0 {
        f32::NAN
    } else if x == 0.0 || x == f32::INFINITY {
        x
    } else if x < 1.0 {
        // Subnormal or smallest binade: scale by 2^64, then back by 2^-32.
        sqrt_f32(x * 18_446_744_073_709_551_616.0) * (1.0 / 4_294_967_296.0)
    } else {
        // Largest binade: scale by 2^-64, then back by 2^32.
        sqrt_f32(x * (1.0 / 18_446_744_073_709_551_616.0)) * 4_294_967_296.0
    }
}

/// Single-precision sine and cosine: reduction by π/2 in three parts (Cody–Waite, exact
/// products for |x| < 2^15·π/2), then odd/even minimax polynomials on [−π/4, π/4]
/// (coefficients of the Cephes single-precision library). Beyond |x| = 2^15 it falls
/// back to libm. Absolute error below 2e-7 (tested against f64).
pub fn sin_cos_f32(x: f32) -> (f32, f32) {
    if x.is_nan() || x.abs() >= 51_471.85 {
        return (libm::sinf(x), libm::cosf(x));
    }
    const FRAC_2_PI: f32 = core::f32::consts::FRAC_2_PI;
    // π/2 = P1 + P2 + P3 with P1, P2 short enough that n·P1, n·P2 are exact.
    const P1: f32 = 1.570_312_5;
    const P2: f32 = 4.837_513e-4;
    const P3: f32 = 7.549_79e-8;
    let n = (x * FRAC_2_PI + if x < 0.0 { -0.5 } else { 0.5 }) as i32;
    let nf = n as f32;
    let r = ((x - nf * P1) - nf * P2) - nf * P3;
    let r2 = r * r;
    let sin_r = r + r * r2 * (-1.666_665_5e-1 + r2 * (8.332_161e-3 + r2 * -1.951_529_6e-4));
    let cos_r =
        1.0 - 0.5 * r2 + r2 * r2 * (4.166_664_6e-2 + r2 * (-1.388_731_6e-3 + r2 * 2.443_315_7e-5));
    match n & 3 {
        0 => (sin_r, cos_r),
        1 => (cos_r, -sin_r),
        2 => (-sin_r, -cos_r),
        _ => (-cos_r, sin_r),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sqrt_f32_is_within_one_ulp_everywhere() {
        let mut worst = 0.0f64;
        let mut bits = 1u32; // smallest subnormal upward, stepping through all exponents
        while bits < 0x7f80_0000 {
            let x = f32::from_bits(bits);
            let exact = f64::from(x).sqrt();
            let got = sqrt_f32(x);
            let ulp =
                f64::from(f32::from_bits((exact as f32).to_bits() + 1)) - f64::from(exact as f32);
            worst = worst.max((f64::from(got) - exact).abs() / ulp);
            bits += 0x1_2345; // ~7000 samples per exponent step pattern
        }
        assert!(worst <= 1.0, "{worst} ulp");
        // Every input of [1, 4): both exponent parities, all mantissas.
        for bits in 0x3f80_0000..0x4080_0000u32 {
            let x = f32::from_bits(bits);
            let exact = f64::from(x).sqrt();
            let ulp =
                f64::from(f32::from_bits((exact as f32).to_bits() + 1)) - f64::from(exact as f32);
            assert!((f64::from(sqrt_f32(x)) - exact).abs() <= ulp, "{x}");
        }
        assert_eq!(sqrt_f32(f32::MAX), 1.844_674_3e19);
        assert!(sqrt_f32(-1.0).is_nan() && sqrt_f32(f32::NAN).is_nan());
        assert_eq!(sqrt_f32(0.0), 0.0);
        assert_eq!(sqrt_f32(f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn sin_cos_f32_matches_f64() {
        let mut worst = 0.0f64;
        for k in -200_000..200_000 {
            let x = k as f32 * 3.7e-4; // ±74 rad
            let (s, c) = sin_cos_f32(x);
            let xd = f64::from(x);
            worst = worst
                .max((f64::from(s) - xd.sin()).abs())
                .max((f64::from(c) - xd.cos()).abs());
        }
        // Reduction error n·ulp(P3) plus polynomial error (~6e-8) and rounding.
        assert!(worst < 2e-7, "{worst}");
        let (s, c) = sin_cos_f32(1e6);
        assert!(
            (f64::from(s) - 1e6f64.sin()).abs() < 1e-6
                && (f64::from(c) - 1e6f64.cos()).abs() < 1e-6
        );
        assert!(sin_cos_f32(f32::NAN).0.is_nan());
    }

    #[test]
    fn q32_saturates_instead_of_wrapping() {
        let big = Q31_32::from_f64(2.0e9);
        assert_eq!((big + big).0, I32F32::MAX);
        assert_eq!((-big - big).0, I32F32::MIN);
        assert_eq!((big * big).0, I32F32::MAX);
        assert_eq!(Q31_32::from_f64(f64::NAN), Q31_32::ZERO);
        assert_eq!(Q31_32::from_f64(1e300).0, I32F32::MAX);
    }

    #[test]
    fn q32_from_f64_rounds_and_saturates_as_fixed_does() {
        // Reference: `fixed`'s own conversion (round to nearest, ties to even, saturating).
        let mut values = std::vec![
            0.0,
            -0.0,
            1.5 / 4_294_967_296.0,
            2.5 / 4_294_967_296.0,
            -2.5 / 4_294_967_296.0,
            0.5 / 4_294_967_296.0,
            2_147_483_647.999_999_999,
            -2_147_483_648.0,
            -2_147_483_648.5,
            2_147_483_648.0,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            f64::MAX,
        ];
        let mut x = 0.123_456_789_f64;
        for _ in 0..2000 {
            x = (x * 7.31 + 0.77).fract();
            values.push((x - 0.5) * 1e4);
            values.push((x - 0.5) * 1e-6);
        }
        for v in values {
            assert_eq!(
                Q31_32::from_f64(v).0,
                I32F32::saturating_from_num(v),
                "{v:e}"
            );
        }
        assert_eq!(Q31_32::from_f64(f64::NAN), Q31_32::ZERO);
    }

    #[test]
    fn from_q32_agrees_across_scalars() {
        for bits in [0i64, 1, -1, 3 << 31, -(7 << 32) + 12345, i64::MAX / 4] {
            let exact = bits as f64 / 4_294_967_296.0;
            assert_eq!(f64::from_q32(bits), exact);
            assert_eq!(Q31_32::from_q32(bits).to_f64(), exact);
            assert_eq!(Q31_32::from_q32(bits).to_q32(), bits);
            if bits.unsigned_abs() < 1 << 52 {
                assert_eq!(f64::from_q32(bits).to_q32(), bits);
            }
            let e32 = (f32::from_q32(bits) as f64 - exact).abs();
            assert!(e32 <= exact.abs() * 1.2e-7 + 1e-12, "{bits}: {e32}");
        }
    }

    /// The 32-bit-word conversions against the single `i64` casts they replace: `f32`
    /// within one ulp of the correctly rounded `bits as f32 · 2^-32` (its two
    /// roundings), `f64` and `to_q32` bit for bit, over a sweep of magnitudes from
    /// 2^-32 to 2^31 pitches, both signs, and the edges of the 32-bit path.
    #[test]
    fn q32_conversions_match_the_i64_casts() {
        let mut bits = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            bits ^= bits << 13;
            bits ^= bits >> 7;
            bits ^= bits << 17;
            bits
        };
        for shift in 0..63 {
            for _ in 0..200 {
                let q = (next() >> shift) as i64 * if next() & 1 == 0 { 1 } else { -1 };
                let exact32 = q as f32 * (1.0 / 4_294_967_296.0);
                let ulps = (f32::from_q32(q).to_bits() as i64 - exact32.to_bits() as i64).abs();
                assert!(ulps <= 1, "{q}: {} against {exact32}", f32::from_q32(q));
                assert_eq!(f64::from_q32(q), q as f64 * (1.0 / 4_294_967_296.0), "{q}");
                for x in [exact32, f32::from_bits(exact32.to_bits() + 1)] {
                    assert_eq!(x.to_q32(), (x * 4_294_967_296.0) as i64, "{x:e}");
                }
                let x = q as f64 / 4_294_967_296.0 * 1.000_000_1;
                assert_eq!(x.to_q32(), (x * 4_294_967_296.0) as i64, "{x:e}");
            }
        }
        let half = 0.5f32;
        for x in [
            half,
            -half,
            f32::from_bits(half.to_bits() - 1),
            -f32::from_bits(half.to_bits() - 1),
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            3e9,
            -3e9,
        ] {
            assert_eq!(x.to_q32(), (x * 4_294_967_296.0) as i64, "{x:e}");
        }
        assert_eq!(f32::NAN.to_q32(), 0);
        assert_eq!((-half).to_q32(), -(1 << 31));
        assert_eq!(half.to_q32(), 1 << 31);
    }

    #[test]
    fn clamp_abs_limits_both_sides() {
        assert_eq!(5.0f64.clamp_abs(2.0), 2.0);
        assert_eq!((-5.0f64).clamp_abs(2.0), -2.0);
        assert_eq!(1.5f32.clamp_abs(2.0), 1.5);
        assert_eq!(
            Q31_32::from_f64(-3.0)
                .clamp_abs(Q31_32::from_f64(1.0))
                .to_f64(),
            -1.0
        );
    }
}
