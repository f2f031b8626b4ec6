//! Analog Hall position decoding (docs/equations.md §2, T 7.2.1).
//!
//! Three linear Hall sensors 120° apart over one magnetic pitch τm give, ideally,
//! u1 = A sin φ, u2 = A sin(φ + 2π/3), u3 = A sin(φ − 2π/3) around an ADC offset.
//! Real sensors add per-channel offset, gain and phase errors and a third harmonic
//! (which is common-mode across 120° channels: sin 3(φ ± 2π/3) = sin 3φ). The pipeline,
//! integer from ADC counts to the unwrapped phase accumulator:
//!
//! 1. rail check on the raw counts: beyond each channel's healthy range by more than
//!    [`RAIL_MARGIN`] of A (open wire, short, clipped front end, a channel stuck near a
//!    rail);
//! 2. offset removal per channel (counts, Q4);
//! 3. a calibrated 2×3 demodulation matrix (the generalized Clarke transform, rows of
//!    the 3×3 inverse of the channel model — see [`calibration`]) giving
//!    s = R sin φ, c = R cos φ with R = 2^19 (sub-count resolution for the atan2);
//! 4. ψ = atan2(s, c) by [`atan::atan2_turns`] into a `u32` phase word (one pitch =
//!    2^32: wrapping arithmetic *is* the modulo);
//! 5. health checks: the residual (the plain sum u1 + u2 + u3 for nominal sensors;
//!    after calibration the health row, which sees none of the fitted fundamentals,
//!    minus its healthy value at ψ from a [`residual::ResidualTable`]) against a limit,
//!    the vector magnitude √(s² + c²) against its band, and on a failed check the
//!    channel that stopped changing, named as stuck; then the phase is corrected by a
//!    table ([`correction::HallCorrection`]);
//! 6. unwrapping against a predicted phase: the caller passes the expected step
//!    (from its velocity estimate), so any speed unwraps as long as the prediction is
//!    within a quarter pitch; a larger innovation is an implausible jump.
//!
//! # Detection guarantee
//!
//! With a self-calibration installed, every single-channel failure (frozen, stuck at
//! any level, open wire floating or pulled to a rail, gain collapse) is flagged before
//! the position error it causes exceeds [`HallConfig::fault_error_budget_m`] (20 µm by
//! default): the residual limit is derived from the budget through the decoder's own
//! demodulation columns (the inequality in [`residual`]), with the healthy noise kept
//! [`NOISE_SIGMAS`] away from both a false alarm and a missed budget; a budget that
//! leaves no such limit is refused at [`HallDecoder::new`], and a machine's calibration
//! installs the smallest one its sensors allow instead, said as [`FaultBudgetRaised`]
//! ([`HallConfig::with_self_calibration_within_noise`]). A channel that fails
//! while the axis stands still is harmless until the axis moves (a frozen channel
//! holds the right value); it is caught within the same distance once motion starts.
//! Without a calibration the decoder cannot know the sensors' harmonics and uses the
//! loose [`HallConfig::sum_limit`]: a frozen channel can then cost about 1 mm before
//! it is flagged.
//!
//! The pitch count is the upper half of an `i64` accumulator in units of 2^-32 pitch.
//! On any fault the accumulator holds. A floating-point path ([`HallArithmetic::F32`])
//! does the demodulation, magnitude check and angle in f32 with `atan2f` instead; on
//! the Cortex-M4F it costs more instructions than the integer path (BENCHMARKS.md)
//! and serves as a cross-check.

pub mod atan;
pub mod calibration;
pub mod correction;
pub mod residual;

pub use atan::atan2_turns;
pub use calibration::{
    CalibrationError, CalibrationWarning, ChannelModel, HallCalibration, HallCalibrator,
    SelfCalibration, SensorModel, UNCALIBRATED_RANGE,
};
pub use correction::{CorrectionLearner, HallCorrection, CORRECTION_ENTRIES};
pub use residual::{ResidualTable, NOISE_SIGMAS, RESIDUAL_ENTRIES};

use crate::error::{in_range, positive, ConfigError};
use crate::scalar::Real;

/// Radius of the demodulated vector (s, c) in the integer path.
pub const DEMODULATED_RADIUS: i32 = 1 << 19;
/// Margin beyond a channel's healthy range (`HallCalibration::range_counts`), as a
/// fraction of A, before a count is a rail fault: room for temperature drift of gain
/// and offset and for noise (6σ of 4 LSB is 0.1 % of A at 16 bits), while a channel
/// pulled to within a few percent of a rail is still named as such.
pub const RAIL_MARGIN: f64 = 0.05;
/// Fraction bits of offset-free counts in the integer path.
const COUNT_FRACTION_BITS: u32 = 4;
/// Right shift after the integer demodulation sum: coefficients are row × R × 2^20
/// so 16-bit rows (≈ 1/26214) keep 23 significant bits and 12-bit rows 27.
const COEFFICIENT_SHIFT: u32 = 24;

/// Which arithmetic decodes the angle.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum HallArithmetic {
    /// Integer demodulation and table atan2 (no FPU needed, exact and repeatable).
    Integer,
    /// f32 demodulation and `libm::atan2f`.
    F32,
}

/// Decoder configuration: plain data a user can edit.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HallConfig {
    /// Magnetic pitch τm in metres (18 mm for the Faulhaber LM1247 / LM2070).
    pub pitch_m: f64,
    /// ADC resolution in bits (8..=16); samples are offset-binary counts.
    pub adc_bits: u8,
    /// Nominal peak amplitude A of each channel in counts (sets the fault thresholds).
    pub amplitude_counts: f64,
    /// Offsets, demodulation matrix and phase table.
    pub calibration: HallCalibration,
    /// Accepted band of the demodulated magnitude as a fraction of nominal, e.g. (0.7, 1.3).
    pub magnitude_band: (f64, f64),
    /// Largest accepted channel-sum residual of a decoder without a healthy-residual
    /// table (`calibration.residual` is `None`): the plain sum u1 + u2 + u3 for nominal
    /// sensors, as a fraction of A. Uncalibrated sensors need room for offsets and gain
    /// mismatch (0.5). Ignored once a self-calibration is installed: the limit then
    /// follows from `fault_error_budget_m`.
    pub sum_limit: f64,
    /// Position error in metres that a single-channel failure may cause before the
    /// decoder flags it, for a calibrated decoder (20 µm by default). A larger budget
    /// gives a larger residual limit; one the healthy sensor's noise does not fit under
    /// is refused by [`HallDecoder::new`] (see [`residual`]).
    pub fault_error_budget_m: f64,
    /// Integer or f32 angle computation.
    pub arithmetic: HallArithmetic,
}

impl HallConfig {
    /// Faulhaber LM1247 Hall outputs on an ADC of `adc_bits`: mid-scale offsets,
    /// amplitude 40 % of full scale, ideal demodulation (calibrate for better),
    /// magnitude band 0.7–1.3, sum limit 0.5 A, a 20 µm fault-error budget once
    /// calibrated, integer arithmetic. Widths the decoder
    /// does not support (outside 8–16 bits) give a configuration it rejects by name.
    pub const fn lm1247(adc_bits: u8) -> Self {
        // 63 at most: the shift cannot overflow; `adc_bits` is kept for the check.
        let shift = if adc_bits > 63 { 63 } else { adc_bits };
        let full_scale = (1u64 << shift) as f64;
        let amplitude = 0.4 * full_scale;
        Self {
            pitch_m: 0.018,
            adc_bits,
            amplitude_counts: amplitude,
            calibration: HallCalibration::ideal(0.5 * full_scale, amplitude),
            magnitude_band: (0.7, 1.3),
            sum_limit: 0.5,
            fault_error_budget_m: 20e-6,
            arithmetic: HallArithmetic::Integer,
        }
    }

    /// This configuration with a self-calibration installed in one step: its
    /// demodulation, phase table, healthy-residual table and channel ranges. The
    /// residual limit then follows from [`HallConfig::fault_error_budget_m`] and the
    /// noise the fit measured ([`HallDecoder::new`] refuses a budget it cannot keep).
    pub fn with_self_calibration(&self, fit: &SelfCalibration) -> Self {
        Self {
            calibration: fit.calibration,
            ..*self
        }
    }

    /// This configuration with a self-calibration installed as
    /// [`HallConfig::with_self_calibration`] does, and with the configured
    /// `fault_error_budget_m` if the fitted noise allows it; otherwise with the smallest
    /// budget it allows ([`HallConfig::smallest_fault_error_budget_m`]), reported as
    /// [`FaultBudgetRaised`]. A machine calibrates whatever its sensors' noise (a 12-bit
    /// ADC's rounding alone shows about as much residual as a 20 µm fault, see
    /// [`residual`]); what it can promise is said, never loosened quietly.
    #[inline(never)]
    pub fn with_self_calibration_within_noise(
        &self,
        fit: &SelfCalibration,
    ) -> (Self, Option<FaultBudgetRaised>) {
        let installed = self.with_self_calibration(fit);
        match installed.smallest_fault_error_budget_m() {
            // The ratio's rounding (a few ulp) must not refuse the smallest budget itself.
            Some(smallest) if smallest > self.fault_error_budget_m => {
                let raised = smallest * (1.0 + 1e-9);
                (
                    Self {
                        fault_error_budget_m: raised,
                        ..installed
                    },
                    Some(FaultBudgetRaised {
                        requested_m: self.fault_error_budget_m,
                        installed_m: raised,
                    }),
                )
            }
            _ => (installed, None),
        }
    }

    /// The smallest `fault_error_budget_m` the installed calibration can keep with
    /// neither a false alarm nor a missed budget within [`NOISE_SIGMAS`] of the noise
    /// (where the budget's own limit is twice the healthy band, see [`residual`]);
    /// `None` without a healthy-residual table. A budget below it is refused by
    /// [`HallDecoder::new`].
    pub fn smallest_fault_error_budget_m(&self) -> Option<f64> {
        let table = self.calibration.residual?;
        let slope = residual::correction_slope(&self.calibration);
        // The budget's limit is proportional to the budget; the smallest is the one
        // whose limit is twice the healthy band.
        let per_pitch = table.budget_limit_counts(2.0 * core::f64::consts::PI, slope);
        Some(2.0 * table.healthy_band_counts() / per_pitch * self.pitch_m)
    }

    /// [`HallConfig::lm1247`] on a 16-bit ADC.
    pub const LM1247_16BIT: Self = Self::lm1247(16);
    /// [`HallConfig::lm1247`] on a 12-bit ADC.
    pub const LM1247_12BIT: Self = Self::lm1247(12);
}

/// A calibration installed with a larger fault-error budget than configured, because
/// the fitted noise does not allow the configured one
/// ([`HallConfig::with_self_calibration_within_noise`]).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FaultBudgetRaised {
    /// The configured budget (`HallConfig::fault_error_budget_m`), m.
    pub requested_m: f64,
    /// The budget installed instead: the smallest the fitted noise allows, m.
    pub installed_m: f64,
}

/// Why a sample was rejected. The accumulator does not move on a fault.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HallFault {
    /// Channel `0..3` reads beyond its healthy range by more than [`RAIL_MARGIN`] of A,
    /// 0 and full scale included (open wire, short, clipped front end, a channel stuck
    /// near a rail).
    AdcRail(u8),
    /// Channel `0..3` has not changed while the others moved and the channels no
    /// longer agree (frozen ADC input, broken multiplexer).
    StuckChannel(u8),
    /// The channels no longer agree with each other: the health row (the plain sum
    /// u1 + u2 + u3 for nominal sensors) minus its healthy value at the decoded phase is
    /// beyond its limit. Any single-channel failure (a value frozen or stuck mid-range,
    /// a floating wire, a gain collapse) ends here unless it is named more precisely.
    ResidualOutOfBand,
    /// √(s² + c²) left the configured band (lost magnet, dead channel, gain fault).
    MagnitudeOutOfBand,
    /// The phase moved more than a quarter pitch away from its prediction.
    ImplausibleJump,
    /// The predicted step is half a pitch per sample or more: no phase can be
    /// unwrapped against it (the velocity estimate is wrong, or the motion is faster
    /// than the sensor can follow at this sample rate).
    SpeedBeyondUnwrap,
}

/// One decoded sample.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct HallPosition {
    /// Unwrapped position in units of 2^-32 pitch: upper 32 bits = pitch count,
    /// lower 32 bits = phase word.
    pub accumulator: i64,
}

impl HallPosition {
    /// Whole pitches since the origin (floor).
    pub fn pitch_count(self) -> i32 {
        (self.accumulator >> 32) as i32
    }

    /// Phase within the pitch, full pitch = 2^32.
    pub fn phase(self) -> u32 {
        self.accumulator as u32
    }

    /// Position in metres: `accumulator / 2^32 · pitch_m`, the pitch as the scalar's
    /// coefficient ([`Real::coef`]).
    #[inline]
    pub fn position_m<T: Real>(self, pitch_m: T::Coef) -> T {
        T::from_q32(self.accumulator).scale(pitch_m)
    }
}

/// Decoder coefficients of one sensor set: offsets, demodulation rows, fault limits
/// and the optional phase correction, fixed once validated. The running part is a
/// [`HallState`].
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HallDecoder {
    arithmetic: HallArithmetic,
    rail_low: [u16; 3],
    /// `rail_high − rail_low` per channel: one unsigned comparison checks both rails.
    rail_span: [u16; 3],
    sin_row_q: [i32; 3],
    cos_row_q: [i32; 3],
    sum_row_q16: [i32; 3],
    /// The offsets and the rounding folded into each row's sum at configuration:
    /// Σ row·(16 r − o) + ½ = Σ row·16 r + (½ − Σ row·o), exact in i64, so the sample
    /// path multiplies raw counts and adds one constant per row.
    sin_constant: i64,
    cos_constant: i64,
    sum_constant: i64,
    offset_f32: [f32; 3],
    sin_row_f32: [f32; 3],
    cos_row_f32: [f32; 3],
    residual: Option<ResidualTable>,
    residual_limit_q4: u32,
    magnitude_sq_min: u32,
    /// `magnitude_sq_max − magnitude_sq_min`: one unsigned comparison checks the band.
    magnitude_sq_span: u32,
    magnitude_sq_min_f32: f32,
    magnitude_sq_max_f32: f32,
    correction: Option<HallCorrection>,
}

/// What a decoder remembers between samples.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct HallState {
    /// Per channel, the two samples before the present one: the newer in the low 16
    /// bits, the older in the high 16 bits (stuck-channel diagnosis). One shift and
    /// one OR per channel keep it.
    history: [u32; 3],
    /// Unwrapped position; `None` until the first good sample (pitch count zero).
    accumulator: Option<i64>,
}

impl HallState {
    /// Forgets the pitch count: the next good sample restarts at pitch zero.
    pub fn reset(&mut self) {
        *self = Self::default();
    }
}

/// Scale of the demodulated vector in the f32 path (kept equal to the integer one so
/// the same magnitude thresholds apply).
const RADIUS_F32: f32 = DEMODULATED_RADIUS as f32;

impl HallDecoder {
    /// Validates `config`; the first good sample defines pitch count zero.
    // Out of line: a cold path. Inlined into its callers once per axis, its tables
    // and matrices were scalarised into one frame of tens of KB and copied word by
    // word (about 100 KB of flash per caller); see BENCHMARKS.md, Memory.
    #[inline(never)]
    pub fn new(config: &HallConfig) -> Result<Self, ConfigError> {
        positive("pitch_m", config.pitch_m)?;
        in_range("adc_bits", f64::from(config.adc_bits), 8.0, 16.0)?;
        let full_scale = f64::from((1u32 << config.adc_bits) - 1);
        let amplitude = positive("amplitude_counts", config.amplitude_counts)?;
        in_range("amplitude_counts", amplitude, 1.0, full_scale / 2.0)?;
        let (lo, hi) = config.magnitude_band;
        positive("magnitude_band", lo)?;
        // hi < 2 keeps every accepted vector below 2^20, the atan2's direct range.
        in_range("magnitude_band", hi, lo, 1.99)?;
        let sum_limit = positive("sum_limit", config.sum_limit)?;
        in_range("sum_limit", sum_limit, 0.0, 3.0)?;
        let budget_m = positive("fault_error_budget_m", config.fault_error_budget_m)?;
        in_range("fault_error_budget_m", budget_m, 0.0, config.pitch_m)?;
        let cal = &config.calibration;
        let limit_counts = match &cal.residual {
            Some(table) => residual_limit_counts(table, cal, budget_m / config.pitch_m)?,
            None => sum_limit * amplitude,
        };
        let mut rail_low = [0u16; 3];
        let mut rail_span = [0u16; 3];
        for (([lo, hi], low), span) in cal
            .range_counts
            .iter()
            .zip(&mut rail_low)
            .zip(&mut rail_span)
        {
            let margin = RAIL_MARGIN * amplitude;
            let lo = in_range(
                "calibration.range_counts",
                f64::from(*lo),
                -full_scale,
                full_scale,
            )?;
            let hi = in_range(
                "calibration.range_counts",
                f64::from(*hi),
                lo,
                2.0 * full_scale,
            )?;
            // Exact 0 and full scale stay rails whatever the range says.
            // max/min rather than clamp, which panics on crossed bounds.
            *low = libm::ceil(lo - margin).max(1.0).min(full_scale - 1.0) as u16;
            let high = libm::floor(hi + margin)
                .min(full_scale - 1.0)
                .max(f64::from(*low)) as u16;
            // high ≥ low (the `max` above): never saturates.
            *span = high.saturating_sub(*low);
        }
        let mut offset_q4 = [0i32; 3];
        let mut sin_row_q = [0i32; 3];
        let mut cos_row_q = [0i32; 3];
        let mut sum_row_q16 = [0i32; 3];
        let unit = f64::from(DEMODULATED_RADIUS)
            * f64::from(1u32 << (COEFFICIENT_SHIFT - COUNT_FRACTION_BITS));
        let inputs = cal
            .offset_counts
            .iter()
            .zip(&cal.sin_row)
            .zip(&cal.cos_row)
            .zip(&cal.sum_row);
        let outputs = offset_q4
            .iter_mut()
            .zip(&mut sin_row_q)
            .zip(&mut cos_row_q)
            .zip(&mut sum_row_q16);
        for ((((offset, sin), cos), sum), (((offset_q, sin_q), cos_q), sum_q)) in
            inputs.zip(outputs)
        {
            let offset = in_range(
                "calibration.offset_counts",
                f64::from(*offset),
                0.0,
                full_scale,
            )?;
            *offset_q = libm::round(offset * f64::from(1u32 << COUNT_FRACTION_BITS)) as i32;
            // |coefficient| < 2^30 keeps 3 products of (2^21 counts·Q4) × 2^30 inside i64;
            // it requires amplitudes above ~256 counts (a 10-bit ADC or better).
            let limit = f64::from(1u32 << 30) / unit;
            let s = in_range("calibration.sin_row", f64::from(*sin), -limit, limit)?;
            let c = in_range("calibration.cos_row", f64::from(*cos), -limit, limit)?;
            *sin_q = libm::round(s * unit) as i32;
            *cos_q = libm::round(c * unit) as i32;
            let w = in_range("calibration.sum_row", f64::from(*sum), -4.0, 4.0)?;
            *sum_q = libm::round(w * 65536.0) as i32;
        }
        if let Some(table) = &cal.residual {
            // Entries far beyond any channel sum (|w| ≤ 4 on 16-bit counts is below
            // 2^24 in Q4) are not a residual: refusing them keeps the sample path's
            // difference in i32.
            if table.value_q4.iter().any(|v| v.unsigned_abs() > 1 << 26) {
                return Err(ConfigError::out_of_range("calibration.residual"));
            }
        }
        // Σ row·o in i64: |row| < 2^30 and |o| < 2^21 (checked above), so every sum
        // stays below 2^53: the wrapping operations never wrap, and state that no
        // overflow check is needed.
        let folded = |row: &[i32; 3], rounding: i64| {
            rounding.wrapping_sub(
                row.iter()
                    .zip(&offset_q4)
                    .map(|(&w, &o)| i64::from(w) * i64::from(o))
                    .fold(0i64, i64::wrapping_add),
            )
        };
        let nominal = f64::from(DEMODULATED_RADIUS);
        // In the integer path's 2^-5 scale (see `phase`).
        let magnitude_sq_min = ((lo * nominal / 32.0) * (lo * nominal / 32.0)) as u32;
        let magnitude_sq_max = ((hi * nominal / 32.0) * (hi * nominal / 32.0)) as u32;
        Ok(Self {
            arithmetic: config.arithmetic,
            rail_low,
            rail_span,
            sin_row_q,
            cos_row_q,
            sum_row_q16,
            sin_constant: folded(&sin_row_q, 1 << (COEFFICIENT_SHIFT - 1)),
            cos_constant: folded(&cos_row_q, 1 << (COEFFICIENT_SHIFT - 1)),
            sum_constant: folded(&sum_row_q16, 0),
            offset_f32: cal.offset_counts,
            sin_row_f32: cal.sin_row.map(|v| v * RADIUS_F32),
            cos_row_f32: cal.cos_row.map(|v| v * RADIUS_F32),
            residual: cal.residual,
            residual_limit_q4: libm::round(limit_counts * f64::from(1u32 << COUNT_FRACTION_BITS))
                .max(0.0) as u32,
            magnitude_sq_min,
            magnitude_sq_span: magnitude_sq_max.saturating_sub(magnitude_sq_min),
            magnitude_sq_min_f32: ((lo * nominal) * (lo * nominal)) as f32,
            magnitude_sq_max_f32: ((hi * nominal) * (hi * nominal)) as f32,
            correction: cal.correction,
        })
    }

    /// Decodes one sample of raw ADC counts `[u1, u2, u3]`.
    ///
    /// `predicted_step` is the expected phase change since the last sample in units of
    /// 2^-32 pitch (velocity × period / pitch; 0 if unknown, which unwraps correctly up
    /// to a quarter pitch per sample).
    pub fn update(
        &self,
        state: &mut HallState,
        raw: [u16; 3],
        predicted_step: i64,
    ) -> Result<HallPosition, HallFault> {
        let phase = self.phase(&mut state.history, raw)?;
        let phase = match &self.correction {
            Some(table) => table.apply(phase),
            None => phase,
        };
        // Beyond half a pitch per sample the unwrapping is ambiguous (and a wild
        // prediction would move the pitch count by its own size).
        if predicted_step.unsigned_abs() >= 1 << 31 {
            return Err(HallFault::SpeedBeyondUnwrap);
        }
        let accumulator = match state.accumulator {
            Some(last) => {
                let predicted = last.wrapping_add(predicted_step);
                let innovation = phase.wrapping_sub(predicted as u32) as i32;
                if innovation.unsigned_abs() > 1 << 30 {
                    return Err(HallFault::ImplausibleJump);
                }
                predicted.wrapping_add(i64::from(innovation))
            }
            None => i64::from(phase),
        };
        state.accumulator = Some(accumulator);
        Ok(HallPosition { accumulator })
    }

    /// The residual limit in counts: the budget-derived limit of a calibrated decoder
    /// (see [`residual`]), `sum_limit · A` without a healthy-residual table.
    pub fn residual_limit_counts(&self) -> f64 {
        f64::from(self.residual_limit_q4) / f64::from(1u32 << COUNT_FRACTION_BITS)
    }

    /// The lowest and highest count of each channel that is not a rail fault.
    pub fn rail_band_counts(&self) -> [[u16; 2]; 3] {
        let [l0, l1, l2] = self.rail_low;
        let [w0, w1, w2] = self.rail_span;
        // `new` made each span from a high at or above its low: no overflow.
        [
            [l0, l0.saturating_add(w0)],
            [l1, l1.saturating_add(w1)],
            [l2, l2.saturating_add(w2)],
        ]
    }

    /// Checks the sample and returns its phase word (no unwrapping, no correction).
    ///
    /// The per-sample work is what the sample itself decides: the offsets, the
    /// rounding and the magnitude band are folded into constants by [`HallDecoder::new`],
    /// and which channel failed is worked out only once a check has failed.
    fn phase(&self, history: &mut [u32; 3], raw: [u16; 3]) -> Result<u32, HallFault> {
        let [r0, r1, r2] = raw;
        let [l0, l1, l2] = self.rail_low;
        let [w0, w1, w2] = self.rail_span;
        // Below `low` wraps to a large value: one comparison catches both sides.
        let outside = |r: u16, low: u16, span: u16| {
            u32::from(r).wrapping_sub(u32::from(low)) > u32::from(span)
        };
        if outside(r0, l0, w0) | outside(r1, l1, w1) | outside(r2, l2, w2) {
            let channel = if outside(r0, l0, w0) {
                0
            } else if outside(r1, l1, w1) {
                1
            } else {
                2
            };
            return Err(HallFault::AdcRail(channel));
        }
        // Counts in Q4; the offsets are in the rows' constants.
        let v = [r0, r1, r2].map(|r| i32::from(r) << COUNT_FRACTION_BITS);
        // The health row w·(u − o), Q4 counts: |w| ≤ 4 in Q16 and |u| < 2^21 keep it
        // below 2^25.
        let sum = (dot_q(&self.sum_row_q16, self.sum_constant, &v) >> 16) as i32;
        let (phase, in_band) = match self.arithmetic {
            HallArithmetic::Integer => {
                let s = (dot_q(&self.sin_row_q, self.sin_constant, &v) >> COEFFICIENT_SHIFT) as i32;
                let c = (dot_q(&self.cos_row_q, self.cos_constant, &v) >> COEFFICIENT_SHIFT) as i32;
                // Only |s|, |c| < 2^20 can pass the band (hi < 2); below that the squares
                // in a 2^-5 scale fit a u32 sum.
                let (s_abs, c_abs) = (s.unsigned_abs(), c.unsigned_abs());
                if (s_abs | c_abs) >= 1 << 20 {
                    (atan::atan2_turns(s, c), false)
                } else {
                    let magnitude_sq = (s_abs >> 5) * (s_abs >> 5) + (c_abs >> 5) * (c_abs >> 5);
                    (
                        atan::atan2_turns_below_2_20(s < 0, c < 0, s_abs, c_abs),
                        magnitude_sq.wrapping_sub(self.magnitude_sq_min) <= self.magnitude_sq_span,
                    )
                }
            }
            HallArithmetic::F32 => self.phase_f32(raw),
        };
        // The residual is checked first: it sees every single-channel failure, and its
        // limit is the one derived from the error budget. The table is read at the
        // faulty phase; that shift is part of the derivation (see `residual`). `new`
        // bounds the table's entries, so the difference stays in i32.
        let healthy = match &self.residual {
            Some(table) => table.at(phase),
            None => 0,
        };
        let fault = if sum.wrapping_sub(healthy).unsigned_abs() > self.residual_limit_q4 {
            Some(HallFault::ResidualOutOfBand)
        } else if !in_band {
            Some(HallFault::MagnitudeOutOfBand)
        } else {
            None
        };
        let previous = *history;
        *history = [(r0, previous[0]), (r1, previous[1]), (r2, previous[2])]
            .map(|(r, h)| h << 16 | u32::from(r));
        match fault {
            None => Ok(phase),
            Some(fault) => Err(stuck_channel(raw, &previous).unwrap_or(fault)),
        }
    }

    /// The f32 path of steps 2–4 (kept out of line so the integer path does not carry
    /// its floating-point register saves): the phase word and whether the magnitude is
    /// in band.
    #[inline(never)]
    fn phase_f32(&self, raw: [u16; 3]) -> (u32, bool) {
        let [r0, r1, r2] = raw;
        let [o0, o1, o2] = self.offset_f32;
        let uf = [(r0, o0), (r1, o1), (r2, o2)].map(|(r, o)| f32::from(r) - o);
        let dot = |row: &[f32; 3]| row.iter().zip(&uf).map(|(w, u)| w * u).sum::<f32>();
        let (s, c) = (dot(&self.sin_row_f32), dot(&self.cos_row_f32));
        let magnitude_sq = s * s + c * c;
        (
            turns_from_rad(libm::atan2f(s, c)),
            magnitude_sq >= self.magnitude_sq_min_f32 && magnitude_sq <= self.magnitude_sq_max_f32,
        )
    }
}

/// The residual limit of a calibrated decoder, counts: half the largest residual
/// T_budget a fault shows while within the budget (`budget_pitches` of a pitch), the
/// middle of [H, T_budget − H] in which neither the healthy band H reaches the limit
/// nor a fault at the budget stays under it; `fault_error_budget_m` is refused when
/// that interval is empty, T_budget < 2H (see [`residual`]).
fn residual_limit_counts(
    table: &ResidualTable,
    calibration: &HallCalibration,
    budget_pitches: f64,
) -> Result<f64, ConfigError> {
    let budget_rad = 2.0 * core::f64::consts::PI * budget_pitches;
    let budget = table.budget_limit_counts(budget_rad, residual::correction_slope(calibration));
    let healthy = table.healthy_band_counts();
    if !(budget.is_finite() && healthy.is_finite()) {
        return Err(ConfigError::not_finite("calibration.residual"));
    }
    if budget < 2.0 * healthy {
        return Err(ConfigError::out_of_range("fault_error_budget_m"));
    }
    Ok(0.5 * budget)
}

/// The channel that read the same value in this and the two previous samples while
/// another channel changed: the suspect once the consistency checks fail. `history`
/// holds per channel the previous sample in the low and the one before in the high
/// 16 bits.
fn stuck_channel(raw: [u16; 3], history: &[u32; 3]) -> Option<HallFault> {
    let moved = raw
        .iter()
        .zip(history)
        .any(|(&r, &h)| u32::from(r) != h & 0xFFFF);
    let repeated = |(&r, &h): (&u16, &u32)| h == u32::from(r) * 0x0001_0001;
    (0u8..3)
        .zip(raw.iter().zip(history))
        .find(|&(_, pair)| moved && repeated(pair))
        .map(|(k, _)| HallFault::StuckChannel(k))
}

/// Σ row·v + constant in the integer path (offsets and rounding in the constant).
#[inline]
fn dot_q(row: &[i32; 3], constant: i64, v: &[i32; 3]) -> i64 {
    // Each product of two i32 is below 2^62 in magnitude; the rows (< 2^30), the
    // channels (< 2^21) and the constant (the offsets folded in, below 2^53) keep the
    // sum far from 2^63, so the wrapping adds never wrap (no overflow check needed).
    constant
        .wrapping_add(i64::from(row[0]) * i64::from(v[0]))
        .wrapping_add(i64::from(row[1]) * i64::from(v[1]))
        .wrapping_add(i64::from(row[2]) * i64::from(v[2]))
}

/// Radians (−π, π] to a phase word.
#[inline]
fn turns_from_rad(angle_rad: f32) -> u32 {
    // (−π, π] maps to (−2^31, 2^31]; the saturating f32 → i32 conversion (one VCVT)
    // turns +π into 2^31 − 1, one unit of 2^-32 turn short. The wrap to u32 is the
    // modulo one turn.
    (angle_rad * (2_147_483_648.0 / core::f32::consts::PI)) as i32 as u32
}

#[cfg(test)]
mod tests;
