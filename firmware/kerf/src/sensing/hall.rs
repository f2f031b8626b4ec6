//! Analog Hall position decoding (SPEC `sensing::hall`, T 7.2.1).
//!
//! Three linear Hall sensors 120° apart over one magnetic pitch τm give
//! u1 = A sin φ, u2 = A sin(φ + 2π/3), u3 = A sin(φ − 2π/3) around an ADC offset.
//! The pipeline is integer from ADC counts to an unwrapped phase accumulator:
//!
//! 1. offset removal per channel (counts);
//! 2. integer Clarke, scaled by 3 to stay exact:
//!    α′ = 2u1 − u2 − u3 = 3A sin φ,  β′ = √3 (u2 − u3) = 3A cos φ;
//! 3. φ = atan2(α′, β′) by division and table interpolation into a `u32` phase word
//!    (one pitch = 2^32, so wrapping arithmetic *is* the modulo);
//! 4. unwrapping: the signed wrapping difference of successive phase words is added
//!    to an `i64` accumulator whose upper 32 bits count pitches.
//!
//! Faults are checked on every sample, before the accumulator moves: an ADC channel at
//! a rail (open wire, short, saturated front end) and a vector magnitude √(α′² + β′²)
//! outside its band around the nominal 3A.

use crate::error::{in_range, positive, ConfigError};
use crate::scalar::Real;

mod tables {
    include!(concat!(env!("OUT_DIR"), "/tables.rs"));
}
use tables::{ATAN_INTERVALS, ATAN_TURN_Q32};

/// Decoder configuration: plain data a user can edit (calibration lives here).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HallConfig {
    /// Magnetic pitch τm in metres (18 mm for the Faulhaber LM1247 / LM2070).
    pub pitch_m: f64,
    /// ADC resolution in bits (8..=16); samples are offset-binary counts.
    pub adc_bits: u8,
    /// Per-channel zero level in counts (mid-scale for an ideal offset-binary front end).
    pub offset_counts: [i32; 3],
    /// Nominal peak amplitude A of each channel in counts.
    pub amplitude_counts: f64,
    /// Accepted band of the vector magnitude as a fraction of nominal, e.g. (0.7, 1.3).
    pub magnitude_band: (f64, f64),
}

impl HallConfig {
    /// LM1247 Hall outputs digitized by a 16-bit ADC: mid-scale offsets, amplitude
    /// 40 % of full scale, magnitude band 0.7–1.3 of nominal.
    pub const LM1247_16BIT: Self = Self {
        pitch_m: 0.018,
        adc_bits: 16,
        offset_counts: [32768; 3],
        amplitude_counts: 26214.0,
        magnitude_band: (0.7, 1.3),
    };
}

/// Why a sample was rejected. The accumulator does not move on a fault.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HallFault {
    /// Channel `0..3` reads 0 or full scale (open wire, short or clipped front end).
    AdcRail(u8),
    /// √(α′² + β′²) left the configured band (lost magnet, stuck or dead channel).
    MagnitudeOutOfBand,
}

/// Decoder state for one axis.
#[derive(Clone, Debug)]
pub struct HallDecoder {
    offset: [i32; 3],
    rail_high: u16,
    magnitude_sq_min: i64,
    magnitude_sq_max: i64,
    last_phase: Option<u32>,
    accumulator: i64,
}

impl HallDecoder {
    /// Validates `config` and returns a decoder whose first good sample defines
    /// pitch count zero.
    pub fn new(config: &HallConfig) -> Result<Self, ConfigError> {
        positive("pitch_m", config.pitch_m)?;
        in_range("adc_bits", f64::from(config.adc_bits), 8.0, 16.0)?;
        let full_scale = (1i64 << config.adc_bits) - 1;
        let amplitude = positive("amplitude_counts", config.amplitude_counts)?;
        in_range("amplitude_counts", amplitude, 1.0, full_scale as f64 / 2.0)?;
        for offset in config.offset_counts {
            in_range("offset_counts", f64::from(offset), 0.0, full_scale as f64)?;
        }
        let (lo, hi) = config.magnitude_band;
        positive("magnitude_band", lo)?;
        in_range("magnitude_band", hi, lo, 4.0)?;
        let nominal = 3.0 * amplitude; // |(α′, β′)| = 3A
        Ok(Self {
            offset: config.offset_counts,
            rail_high: full_scale as u16,
            magnitude_sq_min: ((lo * nominal) * (lo * nominal)) as i64,
            magnitude_sq_max: ((hi * nominal) * (hi * nominal)) as i64,
            last_phase: None,
            accumulator: 0,
        })
    }

    /// Decodes one sample of raw ADC counts `[u1, u2, u3]`.
    ///
    /// Returns the unwrapped position in units of 2^-32 pitch (see
    /// [`position_m`](Self::position_m)). On a fault the position is held.
    pub fn update(&mut self, raw: [u16; 3]) -> Result<i64, HallFault> {
        for (channel, &count) in raw.iter().enumerate() {
            if count == 0 || count >= self.rail_high {
                return Err(HallFault::AdcRail(channel as u8));
            }
        }
        let u1 = i32::from(raw[0]) - self.offset[0];
        let u2 = i32::from(raw[1]) - self.offset[1];
        let u3 = i32::from(raw[2]) - self.offset[2];
        let alpha = 2 * u1 - u2 - u3;
        // √3 as Q14 (28378 / 16384 = 1.7320557, 2.8e-6 relative): a gain error on one
        // axis of the vector, i.e. a phase ripple below 1.4e-6 rad. |u2 − u3| < 2^16,
        // so the product stays below 2^31.
        let beta = ((u2 - u3) * 28378) >> 14;
        let magnitude_sq = i64::from(alpha) * i64::from(alpha) + i64::from(beta) * i64::from(beta);
        if magnitude_sq < self.magnitude_sq_min || magnitude_sq > self.magnitude_sq_max {
            return Err(HallFault::MagnitudeOutOfBand);
        }
        let phase = atan2_turns(alpha, beta);
        let step = match self.last_phase {
            Some(last) => i64::from(phase.wrapping_sub(last) as i32),
            None => i64::from(phase),
        };
        self.last_phase = Some(phase);
        self.accumulator = self.accumulator.wrapping_add(step);
        Ok(self.accumulator)
    }

    /// Forgets the pitch count: the next good sample restarts at pitch zero.
    pub fn reset(&mut self) {
        self.last_phase = None;
        self.accumulator = 0;
    }

    /// Converts an accumulator value to metres: `turns · pitch_m`.
    #[inline]
    pub fn position_m<T: Real>(accumulator: i64, pitch_m: T) -> T {
        T::from_q32(accumulator) * pitch_m
    }
}

/// atan2(y, x) as a phase word (full turn = 2^32), integer only.
///
/// Octant reduction to a ratio r = min(|x|,|y|) / max(|x|,|y|) in [0, 1], computed as
/// an exact Q28 floor with two 32-bit hardware divisions (after scaling the larger
/// input below 2^17), then linear interpolation in a 512-interval atan table made by
/// `build.rs`. Error budget: interpolation h²/8·max|atan″| = 3.1e-7 rad, ratio floor
/// 2^-28 rad, table rounding 2^-33 turn: below 6e-8 turn in all (1.1 nm at an
/// 18 mm pitch), checked against `f64::atan2` in the tests.
#[inline]
pub fn atan2_turns(y: i32, x: i32) -> u32 {
    const FRACTION_BITS: u32 = 28 - ATAN_INTERVALS.trailing_zeros();
    let (mut ax, mut ay) = (x.unsigned_abs(), y.unsigned_abs());
    let largest = ax.max(ay);
    if largest == 0 {
        return 0;
    }
    // Keep the larger magnitude below 2^17 so that (value << 14) fits in 32 bits.
    let excess = (32 - largest.leading_zeros()).saturating_sub(17);
    ax >>= excess;
    ay >>= excess;
    let (num, den) = if ay <= ax { (ay, ax) } else { (ax, ay) };
    if den == 0 {
        return 0;
    }
    let high = (num << 14) / den;
    let low = (((num << 14) - high * den) << 14) / den;
    let ratio_q28 = (high << 14) | low;
    let index = (ratio_q28 >> FRACTION_BITS) as usize;
    let fraction = ratio_q28 & ((1 << FRACTION_BITS) - 1);
    let (lo, hi) = match (ATAN_TURN_Q32.get(index), ATAN_TURN_Q32.get(index + 1)) {
        (Some(&lo), Some(&hi)) => (lo, hi),
        (Some(&lo), None) => (lo, lo),
        _ => return 0, // unreachable: ratio ≤ 1 keeps index ≤ ATAN_INTERVALS
    };
    let octant = lo + ((u64::from(hi - lo) * u64::from(fraction)) >> FRACTION_BITS) as u32;
    const QUARTER: u32 = 1 << 30;
    const HALF: u32 = 1 << 31;
    let first_quadrant = if ay <= ax { octant } else { QUARTER - octant };
    let half_plane = if x < 0 {
        HALF - first_quadrant
    } else {
        first_quadrant
    };
    if y < 0 {
        half_plane.wrapping_neg()
    } else {
        half_plane
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    fn turns_error(phase: u32, y: f64, x: f64) -> f64 {
        let exact = y.atan2(x) / (2.0 * PI); // (-0.5, 0.5]
        let got = phase as i32 as f64 / 4_294_967_296.0;
        let mut d = got - exact;
        d -= d.round();
        d.abs()
    }

    #[test]
    fn atan2_matches_f64_over_a_turn() {
        // Worst case over a dense sweep, at 12-bit and 16-bit amplitudes.
        for amplitude in [3.0 * 800.0, 3.0 * 26214.0] {
            let mut worst = 0.0f64;
            for k in 0..100_000 {
                let phi = 2.0 * PI * (k as f64 + 0.37) / 100_000.0;
                let (y, x) = (
                    (amplitude * phi.sin()).round(),
                    (amplitude * phi.cos()).round(),
                );
                worst = worst.max(turns_error(atan2_turns(y as i32, x as i32), y, x));
            }
            // Error budget in the function's docs: 6e-8 turn.
            assert!(worst < 6.0e-8, "amplitude {amplitude}: {worst} turn");
        }
    }

    #[test]
    fn atan2_handles_axes_octant_edges_and_extremes() {
        for (y, x) in [
            (1, 0),
            (0, 1),
            (-1, 0),
            (0, -1),
            (i32::MAX / 2, -i32::MAX / 2),
            (-5, -5),
        ] {
            assert!(
                turns_error(atan2_turns(y, x), y as f64, x as f64) < 4.0e-8,
                "{y},{x}"
            );
        }
        assert_eq!(atan2_turns(0, 0), 0);
    }

    proptest::proptest! {
        #[test]
        fn atan2_matches_f64_for_any_vector_below_2_pow_17(y in -(1i32 << 17)..(1 << 17), x in -(1i32 << 17)..(1 << 17)) {
            proptest::prop_assume!(x != 0 || y != 0);
            proptest::prop_assert!(turns_error(atan2_turns(y, x), f64::from(y), f64::from(x)) < 6.0e-8);
        }
    }

    fn sample(phi: f64, cfg: &HallConfig) -> [u16; 3] {
        let a = cfg.amplitude_counts;
        let ch = |k: usize, shift: f64| {
            (f64::from(cfg.offset_counts[k]) + a * (phi + shift).sin()).round() as u16
        };
        [ch(0, 0.0), ch(1, 2.0 * PI / 3.0), ch(2, -2.0 * PI / 3.0)]
    }

    #[test]
    fn unwraps_across_pitches_in_both_directions() {
        let cfg = HallConfig::LM1247_16BIT;
        let mut dec = HallDecoder::new(&cfg).unwrap();
        let start = 0.3;
        // 5 pitches forward then back in steps just under a quarter pitch... and tiny steps.
        let mut path = heapless::Vec::<f64, 4096>::new();
        for k in 0..2000 {
            path.push(start + 5.0 * (k as f64) / 1999.0).unwrap();
        }
        for k in 0..40 {
            path.push(start + 5.0 - 0.124 * k as f64).unwrap();
        }
        for &turns in &path {
            let acc = dec.update(sample(2.0 * PI * turns, &cfg)).unwrap();
            let got = HallDecoder::position_m(acc, 1.0f64);
            // The first sample sets the origin at phase(start) within pitch zero.
            assert!((got - turns).abs() < 1e-4, "{turns}: {got}");
        }
    }

    #[test]
    fn rail_and_magnitude_faults_hold_position() {
        let cfg = HallConfig::LM1247_16BIT;
        let mut dec = HallDecoder::new(&cfg).unwrap();
        // At φ = −30° channel 2 is at its peak, so sticking it at zero is a large error
        // (at other phases a stuck channel can stay inside a 0.7–1.3 band).
        let good = sample(-PI / 6.0, &cfg);
        let acc = dec.update(good).unwrap();
        assert_eq!(
            dec.update([0, good[1], good[2]]),
            Err(HallFault::AdcRail(0))
        );
        assert_eq!(
            dec.update([good[0], good[1], 65535]),
            Err(HallFault::AdcRail(2))
        );
        // Channel index 1 stuck at its offset.
        let stuck = [good[0], 32768, good[2]];
        assert_eq!(dec.update(stuck), Err(HallFault::MagnitudeOutOfBand));
        // Half amplitude (weak magnet / gain fault).
        let half = good.map(|c| ((i32::from(c) + 32768) / 2) as u16);
        assert_eq!(dec.update(half), Err(HallFault::MagnitudeOutOfBand));
        assert_eq!(dec.update(good), Ok(acc));
    }

    #[test]
    fn bad_configs_are_rejected_by_name() {
        let ok = HallConfig::LM1247_16BIT;
        let with = |f: fn(&mut HallConfig)| {
            let mut c = ok;
            f(&mut c);
            HallDecoder::new(&c).err()
        };
        assert_eq!(
            with(|c| c.pitch_m = f64::NAN),
            Some(ConfigError::NotFinite("pitch_m"))
        );
        assert_eq!(
            with(|c| c.pitch_m = 0.0),
            Some(ConfigError::NotPositive("pitch_m"))
        );
        assert_eq!(
            with(|c| c.pitch_m = -0.018),
            Some(ConfigError::NotPositive("pitch_m"))
        );
        assert_eq!(
            with(|c| c.adc_bits = 24),
            Some(ConfigError::OutOfRange("adc_bits"))
        );
        assert_eq!(
            with(|c| c.amplitude_counts = 40000.0),
            Some(ConfigError::OutOfRange("amplitude_counts"))
        );
        assert_eq!(
            with(|c| c.magnitude_band = (1.3, 0.7)),
            Some(ConfigError::OutOfRange("magnitude_band"))
        );
        assert!(HallDecoder::new(&ok).is_ok());
    }
}
