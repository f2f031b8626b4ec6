//! Output codes: what a force command and a PWM duty become in a peripheral's register.
//!
//! A force command goes to the motor driver as a voltage: the driver turns volts into
//! amps (its transconductance), the motor amps into newtons (its force constant), and
//! the DAC's codes into volts about its mid-scale code (bipolar around a reference).
//! So the code for a force F is `zero + F / (kF · A/V · V/code)`, rounded toward zero
//! and saturated to the DAC's 12 bits. Not-a-number is no force: a control law that
//! fails must not drive the motor to a rail.

/// The scale from a force command to a 12-bit DAC code.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ForceDac {
    /// The code of zero force (the driver's input at its reference).
    pub zero_code: u16,
    /// Codes per newton.
    pub codes_per_newton: f32,
}

/// The largest code of a 12-bit DAC.
pub const DAC_MAX_CODE: u16 = 4095;

impl ForceDac {
    /// The scale of a driver of `amps_per_volt` on a DAC of `volts_per_code`, driving a
    /// motor of `force_constant_n_per_a`, zero force at `zero_code`.
    pub const fn new(
        zero_code: u16,
        force_constant_n_per_a: f32,
        amps_per_volt: f32,
        volts_per_code: f32,
    ) -> Self {
        Self {
            zero_code,
            codes_per_newton: 1.0 / (force_constant_n_per_a * amps_per_volt * volts_per_code),
        }
    }

    /// The DAC code for `force_n`, saturated to 0..=4095; not-a-number gives zero force.
    pub fn code(&self, force_n: f32) -> u16 {
        let code = f32::from(self.zero_code) + force_n * self.codes_per_newton;
        if code.is_nan() {
            self.zero_code
        } else {
            // `as` saturates (below 0 gives 0, beyond gives u16::MAX), then the clamp.
            (code as u16).min(DAC_MAX_CODE)
        }
    }
}

/// The scale from a unipolar command (a piezo stroke, m) to a 12-bit DAC code: the
/// range `[lo, hi]` spans codes 0…4095 (the amplifier's input range on the DAC's).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DacSpan {
    /// The command at code 0.
    pub lo: f32,
    /// Codes per unit of command.
    pub codes_per_unit: f32,
}

impl DacSpan {
    /// `lo` at code 0, `hi` at code 4095 (`hi > lo`).
    pub const fn new(lo: f32, hi: f32) -> Self {
        Self {
            lo,
            codes_per_unit: DAC_MAX_CODE as f32 / (hi - lo),
        }
    }

    /// The code for `value`, saturated to 0..=4095; not-a-number gives code 0 (the
    /// range's low end: a retracted piezo).
    pub fn code(&self, value: f32) -> u16 {
        let code = (value - self.lo) * self.codes_per_unit + 0.5;
        if code.is_nan() {
            0
        } else {
            (code as u16).min(DAC_MAX_CODE)
        }
    }
}

/// The compare value of a PWM duty in [0, 1] on a timer of `period_cycles` counts:
/// saturated to [0, period]; not-a-number is off.
pub fn pwm_compare(duty: f32, period_cycles: u16) -> u16 {
    let value = duty * f32::from(period_cycles);
    if value.is_nan() {
        0
    } else {
        (value as u16).min(period_cycles)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    /// A 0–30 µm piezo stroke over the DAC against the rounding written out in f64:
    /// the nearest code wherever the exact value is not within 1e-3 of a half code;
    /// ends, saturation and NaN (retracted).
    #[test]
    fn a_span_maps_its_ends_to_the_dac_rails() {
        let span = DacSpan::new(0.0, 30e-6);
        for k in 0..=3000 {
            let x = k as f32 * 1e-8;
            let exact = f64::from(x) / 30e-6 * 4095.0;
            if (exact - exact.floor() - 0.5).abs() < 1e-3 {
                continue;
            }
            assert_eq!(span.code(x), exact.round() as u16, "{x} m");
        }
        assert_eq!(span.code(0.0), 0);
        assert_eq!(span.code(30e-6), DAC_MAX_CODE);
        assert_eq!(span.code(-1e-6), 0);
        assert_eq!(span.code(1.0), DAC_MAX_CODE);
        assert_eq!(span.code(f32::NAN), 0);
    }

    /// The board's scale: LM1247 (3.47 N/A), 1 A/V driver, 3.3 V over 4096 codes.
    const BOARD: ForceDac = ForceDac::new(2048, 3.47, 1.0, 3.3 / 4096.0);

    /// Against the chain written out in f64 (newtons → amps → volts → codes): the same
    /// code wherever the f64 value is not within 1e-3 of an integer (f32 rounding of
    /// the product is below 1e-4 code at these magnitudes).
    #[test]
    fn codes_follow_the_drive_chain() {
        for k in -2000..=2000 {
            let force_n = k as f32 * 2.5e-3;
            let volts = f64::from(force_n) / 3.47 / 1.0;
            let exact = 2048.0 + volts / (3.3 / 4096.0);
            if (exact - exact.round()).abs() < 1e-3 {
                continue;
            }
            assert_eq!(BOARD.code(force_n), exact.floor() as u16, "{force_n} N");
        }
        assert_eq!(BOARD.code(0.0), 2048);
    }

    /// Full scale is about ±5.7 N (2048 codes of 0.8 mV through 1 A/V and 3.47 N/A):
    /// beyond it the code stays at the rail; NaN is zero force, infinities are rails.
    #[test]
    fn codes_saturate_and_nan_is_zero_force() {
        assert_eq!(BOARD.code(6.0), DAC_MAX_CODE);
        assert_eq!(BOARD.code(1e30), DAC_MAX_CODE);
        assert_eq!(BOARD.code(f32::INFINITY), DAC_MAX_CODE);
        assert_eq!(BOARD.code(-6.0), 0);
        assert_eq!(BOARD.code(f32::NEG_INFINITY), 0);
        assert_eq!(BOARD.code(f32::NAN), 2048);
        // Monotonic over the whole range.
        let mut last = 0;
        for k in -700..=700 {
            let code = BOARD.code(k as f32 * 0.01);
            assert!(code >= last, "{k}");
            last = code;
        }
    }

    #[test]
    fn compare_values_span_the_period() {
        assert_eq!(pwm_compare(0.0, 17_000), 0);
        assert_eq!(pwm_compare(1.0, 17_000), 17_000);
        assert_eq!(pwm_compare(0.25, 17_000), 4_250);
        assert_eq!(pwm_compare(1.5, 17_000), 17_000);
        assert_eq!(pwm_compare(-0.5, 17_000), 0);
        assert_eq!(pwm_compare(f32::NAN, 17_000), 0);
        assert_eq!(pwm_compare(f32::INFINITY, 17_000), 17_000);
    }
}
