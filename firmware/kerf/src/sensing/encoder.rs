//! Incremental (quadrature) encoder position from a hardware counter that wraps.
//!
//! The master's carriages carry 0.5 µm linear encoders (T 7.1.1; docs/equations.md
//! §6, presets). A timer in encoder mode counts their edges in a 16-bit register that
//! wraps every 65 536 counts (33 mm at 0.5 µm); the control period reads it once and
//! extends it in software by the wrapping difference from the last read, which is
//! exact while the carriage moves less than half the counter's range per period
//! (16 m/s at 10 kHz). A difference larger than the carriage can move in a period
//! (`max_speed_m_s`) is a counter glitch, a lost cable or a reset timer: the counts
//! no longer say where the carriage is, and the decoder latches a fault rather than
//! jump.
//!
//! The extended count is 64-bit (it never wraps in a machine's life); the position
//! is `home + direction · (count − count at homing) · resolution`, computed from the
//! count relative to homing so that `f32` keeps the resolution anywhere within
//! ±8 m of home (2^24 counts).

use crate::error::{positive, ConfigError};
use crate::scalar::Real;

/// An encoder axis' settings.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct EncoderConfig {
    /// Distance per count, m (0.5 µm on the master).
    pub resolution_m: f64,
    /// Whether counting up moves the carriage towards negative positions.
    pub reversed: bool,
    /// The fastest the carriage can move, m/s: a period's count change beyond it is a
    /// fault.
    pub max_speed_m_s: f64,
}

impl EncoderConfig {
    /// The master's linear encoders (T 7.1.1): 0.5 µm per count, up to 2 m/s (twice
    /// the fastest an operator's hand moves the carriages).
    pub const MASTER_0_5_UM: Self = Self {
        resolution_m: 0.5e-6,
        reversed: false,
        max_speed_m_s: 2.0,
    };
}

/// Why a count was not accepted.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EncoderFault {
    /// The count changed by more than the carriage can move in a period.
    Jump {
        /// The change, counts (wrapping difference).
        counts: i16,
    },
    /// The position is more than 2^31 counts from home.
    OutOfRange,
}

/// An encoder axis' coefficients.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Encoder<T> {
    /// Signed metres per count.
    step_m: T,
    max_counts_per_period: u16,
}

/// An encoder axis' state: the last raw count and the count since homing.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct EncoderState {
    last_raw: Option<u16>,
    counts_since_home: i64,
}

impl EncoderState {
    /// Not yet read: the first count read is the homing position.
    pub const fn unhomed() -> Self {
        Self {
            last_raw: None,
            counts_since_home: 0,
        }
    }

    /// Counts since homing.
    pub fn counts_since_home(&self) -> i64 {
        self.counts_since_home
    }
}

impl<T: Real> Encoder<T> {
    /// Validates `config` for control period `period_s`: resolution and speed finite
    /// and > 0, and the most counts per period below half the 16-bit counter (else a
    /// wrap could not be told from motion).
    pub fn new(config: &EncoderConfig, period_s: f64) -> Result<Self, ConfigError> {
        let resolution = positive("resolution_m", config.resolution_m)?;
        let speed = positive("max_speed_m_s", config.max_speed_m_s)?;
        let period = positive("period_s", period_s)?;
        // Rounded up, less a part per billion so that a whole number stays whole.
        let counts = libm::ceil(speed * period / resolution * (1.0 - 1e-9));
        if counts >= f64::from(i16::MAX) {
            return Err(ConfigError::out_of_range("max_speed_m_s"));
        }
        let sign = if config.reversed { -1.0 } else { 1.0 };
        Ok(Self {
            step_m: crate::error::coefficient("resolution_m", sign * resolution)?,
            max_counts_per_period: counts as u16,
        })
    }

    /// Reads the counter's `raw` value: the position relative to home, m. The first
    /// read homes the axis (position 0). A fault leaves the state as it was.
    pub fn update(&self, state: &mut EncoderState, raw: u16) -> Result<T, EncoderFault> {
        let counts = match state.last_raw {
            None => 0,
            Some(last) => {
                let step = raw.wrapping_sub(last) as i16;
                if step.unsigned_abs() > self.max_counts_per_period {
                    return Err(EncoderFault::Jump { counts: step });
                }
                state.counts_since_home + i64::from(step)
            }
        };
        let within = i32::try_from(counts).map_err(|_| EncoderFault::OutOfRange)?;
        state.last_raw = Some(raw);
        state.counts_since_home = counts;
        Ok(T::from_q32(i64::from(within) << 32) * self.step_m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PERIOD_S: f64 = 1e-4;

    /// A carriage moving back and forth over 100 mm (three wraps of the 16-bit counter
    /// each way) at up to 1.9 m/s: the decoded position matches the true one to half a
    /// count, through every wrap, in f32 and f64 alike.
    #[test]
    fn positions_survive_counter_wraps() {
        let f64_enc = Encoder::<f64>::new(&EncoderConfig::MASTER_0_5_UM, PERIOD_S).unwrap();
        let f32_enc = Encoder::<f32>::new(&EncoderConfig::MASTER_0_5_UM, PERIOD_S).unwrap();
        let (mut s64, mut s32) = (EncoderState::unhomed(), EncoderState::unhomed());
        let start_raw: u16 = 65_000; // wraps soon after the start
        let mut worst = 0.0f64;
        for k in 0..40_000 {
            let t = k as f64 * PERIOD_S;
            // 0.05 m amplitude at 6 rad/s: peak 0.3 m/s … plus a faster ripple.
            let x = 0.05 * (6.0 * t).sin() + 0.002 * (800.0 * t).sin();
            let counts = libm::round(x / 0.5e-6) as i64;
            let raw = (i64::from(start_raw) + counts).rem_euclid(65_536) as u16;
            let p64 = f64_enc.update(&mut s64, raw).unwrap();
            let p32 = f32_enc.update(&mut s32, raw).unwrap();
            worst = worst.max((p64 - x).abs()).max((f64::from(p32) - x).abs());
        }
        // Rounding to a count is ±0.25 µm; f32 of 0.05 m adds 3.7e-9.
        assert!(worst <= 0.25e-6 + 4e-9, "{worst}");
        assert!(s64.counts_since_home().abs() < 200_000);
    }

    /// A glitch (the counter reset to 0 mid-travel) and a jump of more than the speed
    /// allows are faults; the state keeps the last good count.
    #[test]
    fn jumps_beyond_the_speed_are_faults() {
        let enc = Encoder::<f32>::new(&EncoderConfig::MASTER_0_5_UM, PERIOD_S).unwrap();
        let mut state = EncoderState::unhomed();
        assert_eq!(enc.update(&mut state, 30_000), Ok(0.0));
        // 2 m/s · 0.1 ms = 0.2 mm = 400 counts per period at most.
        assert!(enc.update(&mut state, 30_400).is_ok());
        assert_eq!(
            enc.update(&mut state, 0),
            Err(EncoderFault::Jump {
                counts: -30_400_i32 as i16
            })
        );
        assert_eq!(
            enc.update(&mut state, 30_801),
            Err(EncoderFault::Jump { counts: 401 })
        );
        assert_eq!(state.counts_since_home(), 400);
        let reversed = Encoder::<f64>::new(
            &EncoderConfig {
                reversed: true,
                ..EncoderConfig::MASTER_0_5_UM
            },
            PERIOD_S,
        )
        .unwrap();
        let mut state = EncoderState::unhomed();
        reversed.update(&mut state, 5).unwrap();
        let p = reversed.update(&mut state, 105).unwrap();
        assert!((p + 50e-6).abs() < 1e-18, "{p}");
    }

    #[test]
    fn settings_that_cannot_tell_a_wrap_are_refused() {
        // 200 m/s at 10 kHz is 40 000 counts per period: more than half the counter.
        let fast = EncoderConfig {
            max_speed_m_s: 200.0,
            ..EncoderConfig::MASTER_0_5_UM
        };
        assert!(Encoder::<f32>::new(&fast, PERIOD_S).is_err());
        let bad = EncoderConfig {
            resolution_m: f64::NAN,
            ..EncoderConfig::MASTER_0_5_UM
        };
        assert!(Encoder::<f32>::new(&bad, PERIOD_S).is_err());
    }
}
