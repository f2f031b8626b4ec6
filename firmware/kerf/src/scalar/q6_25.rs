//! [`Q6_25`]: signals in one 32-bit Q format, constant factors as [`Gain`]s.

use super::Real;
use core::ops::{Add, Mul, Neg, Sub};

/// Fraction bits of a [`Q6_25`] signal.
pub const SIGNAL_FRACTION_BITS: u32 = 25;
const SIGNAL_ONE: f64 = (1u64 << SIGNAL_FRACTION_BITS) as f64;
/// `from_q32`/`to_q32` move between 2^-32 and 2^-25 units.
const Q32_SHIFT: u32 = 32 - SIGNAL_FRACTION_BITS;

/// Saturating signed Q6.25 fixed point in one 32-bit word: ±64 in steps of
/// 2^-25 ≈ 2.98e-8, for FPU-less cores (Cortex-M0/M3), where every operation of a
/// period is one or two 32-bit instructions and only products widen to 64 bits.
///
/// The format is chosen from the single axis' physics (the table in
/// [`crate::control`]): in SI units its signals (position within ±0.1 m, velocity
/// within ±2 m/s, acceleration commands within the ±50.7 m/s² the 3.6 N force limit
/// gives the 71 g nominal mass, forces within ±3.6 N, times within a segment of
/// seconds) all fit ±64, and the 30 nm step is a sixth of the Hall sensor's
/// 0.18 µm RMS noise. Constant factors (gains from 5e-9 to 6.3e4) do not fit this
/// format; they are [`Gain`]s, applied by [`Real::scale`]. Every operation saturates
/// instead of wrapping; a product `signal × signal` (`Mul`, used by the reference
/// generators) is rounded to nearest.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub struct Q6_25(pub i32);

impl Q6_25 {
    /// Smallest step, 2^-25.
    pub const RESOLUTION: f64 = 1.0 / SIGNAL_ONE;
    /// Largest value, 64 − 2^-25.
    pub const MAX: Self = Q6_25(i32::MAX);
    /// Smallest value, −64.
    pub const MIN: Self = Q6_25(i32::MIN);
}

/// `v` saturated into an `i32` (in range when its low word, sign-extended, is `v`:
/// one comparison of the high word on a 32-bit core).
#[inline]
fn saturate(v: i64) -> i32 {
    let low = v as i32;
    if i64::from(low) == v {
        low
    } else if v < 0 {
        i32::MIN
    } else {
        i32::MAX
    }
}

impl Add for Q6_25 {
    type Output = Self;
    #[inline]
    fn add(self, rhs: Self) -> Self {
        Q6_25(self.0.saturating_add(rhs.0))
    }
}
impl Sub for Q6_25 {
    type Output = Self;
    #[inline]
    fn sub(self, rhs: Self) -> Self {
        Q6_25(self.0.saturating_sub(rhs.0))
    }
}
impl Mul for Q6_25 {
    type Output = Self;
    /// Rounded to nearest (ties up), saturating.
    #[inline]
    fn mul(self, rhs: Self) -> Self {
        let p = i64::from(self.0) * i64::from(rhs.0);
        Q6_25(saturate(
            (p + (1 << (SIGNAL_FRACTION_BITS - 1))) >> SIGNAL_FRACTION_BITS,
        ))
    }
}
impl Neg for Q6_25 {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        Q6_25(self.0.saturating_neg())
    }
}

/// A constant factor for [`Q6_25`] signals: `mantissa · 2^-shift`, with the mantissa
/// normalized into [2^30, 2^31) in magnitude when the shift allows (shift 1..=62), so
/// every factor from 2^-31 to 2^30 keeps 31 significant bits (relative step below
/// 1e-9). A product with a signal is one 32 × 32 → 64-bit multiply, a rounding add
/// and a shift by the factor's own shift, then a saturation to 32 bits.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Gain {
    mantissa: i32,
    shift: u32,
    /// 2^(shift − 1): rounds the product to nearest (stored: a variable 64-bit shift
    /// costs more on a Cortex-M than loading the constant).
    half: i64,
}

impl Gain {
    /// Zero (what NaN, zero and values below 2^-63 convert to).
    pub const ZERO: Self = Gain {
        mantissa: 0,
        shift: 1,
        half: 1,
    };

    /// The factor nearest to `v` (ties to even): exact to 31 significant bits for
    /// 2^-31 ≤ |v| < 2^30, with fewer bits down to 2^-62, saturated at about ±2^30
    /// above; NaN gives zero.
    pub fn from_f64(v: f64) -> Self {
        if v.is_nan() || v == 0.0 {
            return Self::ZERO;
        }
        // |v| ∈ [2^(e−1), 2^e): |v| · 2^(31 − e) ∈ [2^30, 2^31).
        let (_, e) = libm::frexp(v);
        // e is within ±1100 for any f64; saturating keeps the clamp's input in range
        // without an overflow check.
        let shift = 31i32.saturating_sub(e).clamp(1, 62);
        // `as` saturates the ±∞ and out-of-range products; a mantissa that rounds up
        // to 2^31 saturates to 2^31 − 1, a relative change of 5e-10. −2^31 is kept
        // out too: with |mantissa| < 2^31 every product with a signal is below 2^62
        // in magnitude, which the carried sums below rely on.
        let mantissa = (libm::rint(libm::ldexp(v, shift)) as i32).max(-i32::MAX);
        let shift = shift as u32;
        Gain {
            mantissa,
            shift,
            half: 1 << (shift - 1),
        }
    }

    /// The exact value.
    pub fn to_f64(self) -> f64 {
        // The shift is 1..=62: negating it never saturates.
        libm::ldexp(
            f64::from(self.mantissa),
            (self.shift as i32).saturating_neg(),
        )
    }
}

impl Real for Q6_25 {
    const ZERO: Self = Q6_25(0);
    const FIXED_STEP: f64 = Self::RESOLUTION;
    // The magnitude of MIN, 2^31 steps: 64.
    const RANGE: f64 = -(Self::MIN.0 as f64) * Self::RESOLUTION;
    /// Round to nearest (ties to even), saturating; NaN → 0.
    #[inline]
    fn from_f64(v: f64) -> Self {
        Q6_25(libm::rint(v * SIGNAL_ONE) as i32)
    }
    #[inline]
    fn to_f64(self) -> f64 {
        f64::from(self.0) * Self::RESOLUTION
    }
    /// Rounded to nearest (ties up), saturating.
    #[inline]
    fn from_q32(bits: i64) -> Self {
        Q6_25(saturate(
            bits.saturating_add(1 << (Q32_SHIFT - 1)) >> Q32_SHIFT,
        ))
    }
    #[inline]
    fn to_q32(self) -> i64 {
        i64::from(self.0) << Q32_SHIFT
    }
    #[inline]
    fn is_finite(self) -> bool {
        true
    }
    type Coef = Gain;
    #[inline]
    fn coef(v: f64) -> Gain {
        Gain::from_f64(v)
    }
    #[inline]
    fn coef_to_f64(c: Gain) -> f64 {
        c.to_f64()
    }
    /// `self × c` rounded to nearest (ties up), saturating.
    #[inline]
    fn scale(self, c: Gain) -> Self {
        // |product| ≤ 2^62 and half ≤ 2^61: no overflow in i64.
        let p = i64::from(self.0) * i64::from(c.mantissa);
        Q6_25(saturate((p + c.half) >> c.shift))
    }
    type Carry = i64;
    /// The sum of both products rounded once, with error feedback. The products are
    /// aligned to the smaller of the two shifts (bits more than that shift below the
    /// result's step are dropped: for the observer's Ts and Ts²/2, 2^-44 of a step);
    /// the carry is the remainder in units of 2^-shift of a step, clamped to half a
    /// step so that a carry left by other coefficients cannot move the result by more.
    #[inline]
    fn mul_add_carry(self, a: Gain, b: Self, c: Gain, carry: &mut i64) -> Self {
        let p = i64::from(self.0) * i64::from(a.mantissa);
        let q = i64::from(b.0) * i64::from(c.mantissa);
        // Shifts are 1..=62, so the differences are below 64. |p|, |q| < 2^62 (the
        // mantissa's magnitude is below 2^31), so their sum cannot overflow.
        let (sum, shift, half) = if a.shift <= c.shift {
            (p + (q >> (c.shift - a.shift)), a.shift, a.half)
        } else {
            ((p >> (a.shift - c.shift)) + q, c.shift, c.half)
        };
        // `max`/`min`, not `clamp`: the bounds are not constants, and `clamp`'s check
        // of their order would stay linked as a panic path. The carried half is in
        // [0, 2^62]: beside a sum of up to 2^63 − 2^32 only a saturating add is safe.
        let biased = sum.saturating_add((*carry).max(-half).min(half) + half);
        *carry = (biased & ((half << 1) - 1)) - half;
        Q6_25(saturate(biased >> shift))
    }
    /// The product rounded with error feedback, as [`Real::mul_add_carry`].
    #[inline]
    fn scale_carry(self, c: Gain, carry: &mut i64) -> Self {
        // `max`/`min`, not `clamp` (see `mul_add_carry`). The product is below 2^62
        // − 2^31 in magnitude and the carried half in [0, 2^62]: no overflow.
        let biased = i64::from(self.0) * i64::from(c.mantissa)
            + ((*carry).max(-c.half).min(c.half) + c.half);
        *carry = (biased & ((c.half << 1) - 1)) - c.half;
        Q6_25(saturate(biased >> c.shift))
    }
    /// `n × c` rounded to nearest, saturating.
    #[inline]
    fn count_times(n: u32, c: Gain) -> Self {
        // |n · mantissa| < 2^63; the result's bits are n · c · 2^25.
        let p = i64::from(n) * i64::from(c.mantissa);
        if c.shift > SIGNAL_FRACTION_BITS {
            let shift = c.shift - SIGNAL_FRACTION_BITS;
            Q6_25(saturate(p.saturating_add(1 << (shift - 1)) >> shift))
        } else {
            let shift = SIGNAL_FRACTION_BITS - c.shift;
            Q6_25(saturate(p.checked_mul(1 << shift).unwrap_or(if p < 0 {
                i64::MIN
            } else {
                i64::MAX
            })))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The signal arithmetic against exact f64 arithmetic on the represented values:
    /// sums exact, products within half a step, and saturation at the ends.
    #[test]
    fn signal_arithmetic_matches_f64_and_saturates() {
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x as i64 >> 32) as i32
        };
        for _ in 0..20_000 {
            let (a, b) = (Q6_25(next() >> (next() & 15)), Q6_25(next() >> 8));
            let (fa, fb) = (a.to_f64(), b.to_f64());
            let clamp = |v: f64| v.clamp(Q6_25::MIN.to_f64(), Q6_25::MAX.to_f64());
            assert_eq!((a + b).to_f64(), clamp(fa + fb));
            assert_eq!((a - b).to_f64(), clamp(fa - fb));
            let p = (a * b).to_f64();
            if libm::fabs(fa * fb) < 63.0 {
                assert!(
                    libm::fabs(p - fa * fb) <= Q6_25::RESOLUTION / 2.0,
                    "{fa} {fb}"
                );
            } else {
                assert!(p.abs() >= 63.0 && p.signum() == (fa * fb).signum());
            }
        }
        assert_eq!(Q6_25::MAX + Q6_25::MAX, Q6_25::MAX);
        assert_eq!(Q6_25::MIN - Q6_25::MAX, Q6_25::MIN);
        assert_eq!(-Q6_25::MIN, Q6_25::MAX);
        assert_eq!(Q6_25::from_f64(1e9), Q6_25::MAX);
        assert_eq!(Q6_25::from_f64(-1e9), Q6_25::MIN);
        assert_eq!(Q6_25::from_f64(f64::NAN), Q6_25::ZERO);
        assert_eq!(Q6_25::from_f64(0.5 / SIGNAL_ONE), Q6_25::ZERO);
        assert_eq!(Q6_25::from_f64(1.5 / SIGNAL_ONE).0, 2);
    }

    /// Gains keep 31 significant bits over their normalized range, and a product
    /// with a signal is the exact product rounded to the signal's step.
    #[test]
    fn gains_are_exact_to_31_bits_and_products_round_to_nearest() {
        let mut v = 3.1e-9;
        while v < 1e9 {
            for s in [v, -v] {
                let g = Gain::from_f64(s);
                let rel = libm::fabs(g.to_f64() / s - 1.0);
                assert!(rel <= 1.0 / f64::from(1u32 << 30), "{s:e}: {rel:e}");
            }
            v *= 1.37;
        }
        assert_eq!(Gain::from_f64(0.0), Gain::ZERO);
        assert_eq!(Gain::from_f64(f64::NAN), Gain::ZERO);
        assert_eq!(Gain::from_f64(1e-30).to_f64(), 0.0);
        // Saturated: far from the value, which `error::factor` refuses.
        assert!(Gain::from_f64(1e12).to_f64() < 2.2e9);
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let signal = Q6_25((x >> 32) as i32 >> (x & 7));
            let gain = Gain::from_f64(f64::from((x & 0xffff) as u16) * 1e-3 - 30.0);
            let exact = signal.to_f64() * gain.to_f64();
            let got = signal.scale(gain).to_f64();
            if libm::fabs(exact) < 63.9 {
                assert!(
                    libm::fabs(got - exact) <= Q6_25::RESOLUTION / 2.0,
                    "{exact}"
                );
            } else {
                assert_eq!(got.signum(), exact.signum());
                assert!(got.abs() >= 63.9);
            }
        }
    }

    /// The carried products at the ends of both ranges (the test profile checks
    /// overflow): they saturate, and their rounded sums over many periods stay within
    /// a step of the exact sums where they do not.
    #[test]
    fn carried_products_saturate_at_the_extremes_and_do_not_drift() {
        let largest = Gain::from_f64(1.07e9);
        let smallest = Gain::from_f64(-3e-18);
        assert!(largest.mantissa > 0 && smallest.mantissa > -i32::MAX - 1);
        assert_eq!(Gain::from_f64(-1e12).mantissa, -i32::MAX);
        for x in [Q6_25::MIN, Q6_25::MAX, Q6_25(-1), Q6_25::ZERO] {
            for g in [
                largest,
                smallest,
                Gain::from_f64(-1e12),
                Gain::from_f64(0.75),
            ] {
                for mut carry in [i64::MIN, -1, 0, i64::MAX] {
                    let one = x.scale_carry(g, &mut carry);
                    let two = x.mul_add_carry(g, x, g, &mut carry);
                    let exact = x.to_f64() * g.to_f64();
                    let limit = Q6_25::MAX.to_f64();
                    if libm::fabs(exact) >= limit {
                        assert_eq!(one.0.signum(), exact.signum() as i32, "{x:?} {g:?}");
                    }
                    if libm::fabs(2.0 * exact) >= limit {
                        assert_eq!(two.0.signum(), exact.signum() as i32, "{x:?} {g:?}");
                    }
                }
            }
        }
        // A constant step of 0.3 steps, and Ts·v + Ts²/2·a: the carried sums follow
        // the exact ones within one step over 100 000 periods.
        let third = Gain::from_f64(0.3);
        let (mut carry, mut sum) = (0i64, 0i64);
        for k in 1..=100_000i64 {
            sum += i64::from(Q6_25(1).scale_carry(third, &mut carry).0);
            assert!(((sum as f64) - 0.3 * k as f64).abs() <= 1.0, "{k}");
        }
        let (ts, half_ts_sq) = (Gain::from_f64(1e-4), Gain::from_f64(5e-9));
        let (v, a) = (Q6_25::from_f64(0.1407), Q6_25::from_f64(1.08));
        let (mut carry, mut sum) = (0i64, 0i64);
        let exact = v.to_f64() * ts.to_f64() + a.to_f64() * half_ts_sq.to_f64();
        for k in 1..=100_000i64 {
            sum += i64::from(v.mul_add_carry(ts, a, half_ts_sq, &mut carry).0);
            let drift = sum as f64 * Q6_25::RESOLUTION - exact * k as f64;
            assert!(drift.abs() <= Q6_25::RESOLUTION, "{k}: {drift}");
        }
    }

    #[test]
    fn counts_times_gains_do_not_pass_through_the_signal_range() {
        let ts = Gain::from_f64(1e-4);
        for n in [0u32, 1, 7, 4000, 10_000, 500_000] {
            let exact = f64::from(n) * ts.to_f64();
            let got = Q6_25::count_times(n, ts).to_f64();
            assert!(libm::fabs(got - exact) <= Q6_25::RESOLUTION / 2.0, "{n}");
        }
        // Large factors (left shift) and saturation.
        let big = Gain::from_f64(100.0);
        assert_eq!(Q6_25::count_times(0, big), Q6_25::ZERO);
        assert_eq!(Q6_25::count_times(1, big), Q6_25::MAX);
        let g = Gain::from_f64(0.75);
        assert_eq!(Q6_25::count_times(3, g).to_f64(), 2.25);
        assert_eq!(Q6_25::count_times(u32::MAX, ts), Q6_25::MAX);
    }

    #[test]
    fn phase_conversions_round_and_saturate() {
        assert_eq!(Q6_25::from_q32(1 << 32).to_f64(), 1.0);
        assert_eq!(Q6_25::from_q32(64).0, 1);
        assert_eq!(Q6_25::from_q32(63).0, 0);
        assert_eq!(Q6_25::from_q32(-64).0, 0);
        assert_eq!(Q6_25::from_q32(-65).0, -1);
        assert_eq!(Q6_25::from_q32(i64::MAX), Q6_25::MAX);
        assert_eq!(Q6_25::from_q32(i64::MIN), Q6_25::MIN);
        assert_eq!(Q6_25(-3).to_q32(), -3 * 128);
        for bits in [0i64, 12_345_678_901, -98_765_432_109] {
            let exact = bits as f64 / 4_294_967_296.0;
            assert!(libm::fabs(Q6_25::from_q32(bits).to_f64() - exact) <= Q6_25::RESOLUTION / 2.0);
        }
    }
}
