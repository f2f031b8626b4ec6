//! Hall sensor calibration: a per-channel harmonic fit decoded through a 3×3 inverse
//! and a model-derived phase table, and an optional phase-error table learnt against a
//! reference encoder.
//!
//! Channel model (k = 0, 1, 2), in the frame of the true phase φ:
//!
//!   u_k = o_k + A_k (sin a_k + h3_k sin(3a_k + ψ3_k) + h5_k sin(5a_k + ψ5_k)),
//!   a_k = φ + p_k,
//!
//! with each channel's offset o_k, gain A_k, phase p_k (0, ±2π/3 plus mounting error),
//! and third and fifth harmonics of its own amplitude and phase (real
//! linear-motor Hall sensors differ from channel to channel in both). Given φ the model
//! is linear: u_k = θ_k · (1, sin φ, cos φ, sin 3φ, cos 3φ, sin 5φ, cos 5φ).
//!
//! # Why the samples' timing matters
//!
//! The shape of the curve the samples trace in channel space does not determine φ for
//! this model: a reparametrisation φ → φ + e(φ) with e made of harmonics 0, 2 and 4
//! changes each channel by e(φ)·u_k'(φ), which has harmonics 1, 3 and 5 only and is
//! absorbed by the free per-channel coefficients (to second order as well). A fit that
//! solves each sample's phase on its own therefore has four free directions
//! (ε sin 2φ, ε cos 2φ, ε sin 4φ, ε cos 4φ), worth about 30 µm at an 18 mm pitch.
//! What fixes them is time: samples taken at a fixed rate, in time order, while the
//! slider moves smoothly (a coast at nearly constant speed) follow a low-degree
//! polynomial in time, which cannot mimic a ripple of two or four periods per pitch.
//! So the fit's unknowns are θ (7 per channel) and, per segment of samples, the
//! coefficients of φ(t) = Σ_m c_m τ^m (degree [`TIME_MODEL_DEGREE`], τ the sample's
//! time scaled to [−1, 1] over its segment). The timing requirement on the samples
//! given to [`HallCalibrator`]:
//!
//! - a fixed sample rate inside a segment, samples pushed in time order;
//! - the true motion smooth in time independently of the Hall error: recorded open
//!   loop (held force, a coast), never while a loop closed on these sensors tracks a
//!   reference (a stiff loop makes the *decoded* phase smooth and pushes the error into
//!   the true motion);
//! - each segment at least one pitch long (better 1.2 or more), so that its cubic
//!   cannot follow the 2nd and 4th harmonic ripple; a new segment
//!   ([`HallCalibrator::new_segment`]) wherever the rate or the smoothness breaks
//!   (another coast, the way back);
//! - together the samples cover every phase.
//!
//! The Gauss–Newton solve eliminates θ per channel (a 7 × 7 Gram shared by the three
//! channels) and solves the time-model step from the Schur complement
//! (≤ [`MAX_SEGMENTS`]·4 unknowns), so its stack stays a few KB.
//!
//! From the fitted model the calibration gives a linear demodulation (rows of M⁻¹, M's
//! rows (A_k cos p_k, A_k sin p_k, Ā) with Ā the mean amplitude: the common mode, see
//! [`SensorModel::linear_calibration`]) and a [`HallCorrection`] table: what the linear
//! decoder still gets wrong as a function of phase, subtracted after the atan2. Both
//! travel in one
//! [`HallCalibration`], so installing a calibration is one step.
//! The fit's residual (RMS of u − model, counts) is reported; above
//! [`SelfCalibration::residual_limit_counts`] the result carries a typed
//! [`CalibrationWarning::ModelMismatch`] (a 7th harmonic, a kinked channel, samples
//! that were not taken as required).
//! This runs in f64 once, in a calibration mode, not in the control period.

use super::{HallCorrection, ResidualTable, CORRECTION_ENTRIES};
use basis::{add_outer, basis, derivative, dot, powers};
use core::f64::consts::PI;
use nalgebra::{Matrix3, SMatrix, SVector};

/// Degree of the per-segment polynomial of phase against time: a cubic follows a coast
/// under constant force with viscous friction (an exponential approach to a speed) to
/// well below a micrometre over a fraction of its time constant, and cannot follow the
/// 2nd harmonic's four half-waves over a pitch.
pub const TIME_MODEL_DEGREE: usize = 3;
/// Coefficients of one segment's phase polynomial.
const TERMS: usize = TIME_MODEL_DEGREE + 1;
/// Segments of samples one calibration can hold (two coasts out and back, twice).
pub const MAX_SEGMENTS: usize = 4;
/// Time-model unknowns of the joint fit.
const PHASE_UNKNOWNS: usize = MAX_SEGMENTS * TERMS;
/// Model coefficients per channel: offset, then sin and cos of harmonics 1, 3 and 5.
const BASIS: usize = 7;
/// Fewest samples a segment may have: twice its polynomial's coefficients.
const MIN_SEGMENT_SAMPLES: usize = 2 * TERMS;
/// RMS model mismatch, as a fraction of the amplitude, that the fit tolerates before it
/// warns. A mismatch δu on the channels moves the phase by about 0.82 δu / A rad (the
/// norm of a demodulation row), so 1e-3 A costs about 2.3 µm RMS at an 18 mm pitch:
/// beyond the 3 µm peak goal of item 7.
pub const MISMATCH_LIMIT: f64 = 1e-3;
/// Reach of an uncalibrated channel around its nominal offset, in nominal amplitudes:
/// the LM1247 class's offsets (±3 % of full scale, 7.5 % of A at A = 40 % FS), gains
/// (±5 %) and harmonics (up to 4 % at a peak) stay within 1.15 A.
pub const UNCALIBRATED_RANGE: f64 = 1.15;
/// Noise the fit tolerates in its residual before it warns, LSB RMS: twice the 4 LSB
/// of the 16-bit goal. Noise averages out of the fit; model mismatch does not.
pub const NOISE_ALLOWANCE_LSB: f64 = 8.0;

/// Offsets, demodulation matrix and phase table of one axis' Hall sensors: plain data
/// to store and edit, and everything a calibration installs.
/// `sin_row · (u − offset) = sin φ`, `cos_row · (u − offset) = cos φ`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HallCalibration {
    /// Zero level of each channel in counts.
    pub offset_counts: [f32; 3],
    /// Demodulation row giving sin φ from offset-free counts (1/counts).
    pub sin_row: [f32; 3],
    /// Demodulation row giving cos φ from offset-free counts (1/counts).
    pub cos_row: [f32; 3],
    /// Health row: its product with offset-free counts is the part of the channel sum
    /// that the fitted fundamentals do not explain (counts/counts). Healthy sensors leave
    /// only the common-mode harmonic and noise there; `[1, 1, 1]` (the plain sum) for
    /// ideal sensors.
    pub sum_row: [f32; 3],
    /// Phase correction subtracted after the atan2 (what the linear rows get wrong on
    /// the fitted model, or a table learnt against a reference encoder); `None` for
    /// none.
    pub correction: Option<HallCorrection>,
    /// What the health row reads on the healthy sensor over the pitch, and the figures
    /// the fault limit is derived from (see [`super::residual`]); `None` for sensors
    /// without a fitted model, which are checked against `HallConfig::sum_limit`.
    pub residual: Option<ResidualTable>,
    /// Lowest and highest count each channel reaches when healthy. The decoder flags
    /// counts more than [`RAIL_MARGIN`](super::RAIL_MARGIN) of A beyond them as a rail
    /// fault (a wire or front end pulled towards 0 or full scale), not only exact rails.
    pub range_counts: [[f32; 2]; 3],
}

impl HallCalibration {
    /// Ideal sensors: equal offsets and amplitudes, exact 120° spacing; the rows are the
    /// Clarke transform sin φ = (2u1 − u2 − u3)/(3A), cos φ = (u2 − u3)/(√3 A).
    /// The healthy range is offset ± [`UNCALIBRATED_RANGE`] A: the nominal decoder runs
    /// on sensors it does not know.
    pub const fn ideal(offset_counts: f64, amplitude_counts: f64) -> Self {
        let reach = UNCALIBRATED_RANGE * amplitude_counts;
        let range = [
            (offset_counts - reach) as f32,
            (offset_counts + reach) as f32,
        ];
        let inv = 1.0 / amplitude_counts;
        let inv_sqrt3 = 0.577_350_269_189_625_8 * inv;
        Self {
            offset_counts: [offset_counts as f32; 3],
            sin_row: [
                (2.0 / 3.0 * inv) as f32,
                (-1.0 / 3.0 * inv) as f32,
                (-1.0 / 3.0 * inv) as f32,
            ],
            cos_row: [0.0, inv_sqrt3 as f32, -inv_sqrt3 as f32],
            sum_row: [1.0; 3],
            correction: None,
            residual: None,
            range_counts: [range; 3],
        }
    }

    /// The demodulation rows applied to offset-free channel values, f64.
    pub(super) fn demodulate_centred(&self, u: [f64; 3]) -> (f64, f64) {
        u.iter()
            .zip(&self.sin_row)
            .zip(&self.cos_row)
            .fold((0.0, 0.0), |(s, c), ((u, sin), cos)| {
                (s + f64::from(*sin) * u, c + f64::from(*cos) * u)
            })
    }

    /// sin φ and cos φ of channel values in f64 (the calibration's own decoder).
    pub(super) fn demodulate_f64(&self, raw: [f64; 3]) -> (f64, f64) {
        let (mut s, mut c) = (0.0, 0.0);
        for (((value, offset), sin), cos) in raw
            .iter()
            .zip(&self.offset_counts)
            .zip(&self.sin_row)
            .zip(&self.cos_row)
        {
            let u = value - f64::from(*offset);
            s += f64::from(*sin) * u;
            c += f64::from(*cos) * u;
        }
        (s, c)
    }

    /// The linear decode's angle in rad (no table).
    fn linear_phase(&self, raw: &[u16; 3]) -> f64 {
        let (s, c) = self.demodulate_f64(raw.map(f64::from));
        libm::atan2(s, c)
    }
}

/// Why a calibration could not be made.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CalibrationError {
    /// The sample buffer is full.
    Full,
    /// Fewer samples than the fit needs (at least 64, and 8 in every segment).
    TooFewSamples,
    /// More segments than [`MAX_SEGMENTS`].
    TooManySegments,
    /// The samples do not cover a whole pitch (every 1/16 of the phase circle).
    NotEnoughMotion,
    /// The fit's equations are singular (dead or duplicated channels).
    Singular,
    /// The fit did not settle (samples that follow no smooth motion).
    NotConverged,
}

/// A calibration that was made but should not be trusted without a look.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum CalibrationWarning {
    /// The samples do not fit the sensor model: RMS residual above its limit (a
    /// harmonic beyond the 5th, a kinked or clipped channel, samples not taken at a
    /// fixed rate during a smooth motion).
    ModelMismatch {
        /// RMS of u − model over every sample and channel, counts.
        residual_rms_counts: f64,
        /// The limit it exceeded, counts.
        limit_counts: f64,
    },
}

/// Fitted model of one channel.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct ChannelModel {
    /// Offset o_k in counts.
    pub offset_counts: f64,
    /// Fundamental amplitude A_k in counts.
    pub amplitude_counts: f64,
    /// Phase p_k of the fundamental, rad (0, +2π/3, −2π/3 ideally, plus a common
    /// rotation that only moves the origin).
    pub phase_rad: f64,
    /// Third-harmonic amplitude h3_k relative to the fundamental.
    pub harmonic3: f64,
    /// Phase ψ3_k of the third harmonic against 3 p_k, rad.
    pub harmonic3_phase_rad: f64,
    /// Fifth-harmonic amplitude h5_k relative to the fundamental.
    pub harmonic5: f64,
    /// Phase ψ5_k of the fifth harmonic against 5 p_k, rad.
    pub harmonic5_phase_rad: f64,
}

impl ChannelModel {
    /// The channel from its linear coefficients θ = (o, sin φ, cos φ, sin 3φ, cos 3φ,
    /// sin 5φ, cos 5φ).
    fn from_coefficients(theta: &[f64; BASIS]) -> Self {
        let [o, s1, c1, s3, c3, s5, c5] = *theta;
        let amplitude = libm::hypot(s1, c1);
        let phase = libm::atan2(c1, s1);
        // h A sin(n(φ + p) + ψ) = h A (cos(np + ψ) sin nφ + sin(np + ψ) cos nφ).
        let relative = |s: f64, c: f64| {
            if amplitude > 0.0 {
                libm::hypot(s, c) / amplitude
            } else {
                0.0
            }
        };
        Self {
            offset_counts: o,
            amplitude_counts: amplitude,
            phase_rad: phase,
            harmonic3: relative(s3, c3),
            harmonic3_phase_rad: wrap_rad(libm::atan2(c3, s3) - 3.0 * phase),
            harmonic5: relative(s5, c5),
            harmonic5_phase_rad: wrap_rad(libm::atan2(c5, s5) - 5.0 * phase),
        }
    }

    /// The channel's value at phase `phi` (counts, not rounded).
    pub fn predict(&self, phi: f64) -> f64 {
        let a = phi + self.phase_rad;
        self.offset_counts
            + self.amplitude_counts
                * (libm::sin(a)
                    + self.harmonic3 * libm::sin(3.0 * a + self.harmonic3_phase_rad)
                    + self.harmonic5 * libm::sin(5.0 * a + self.harmonic5_phase_rad))
    }
}

/// The fitted sensor model of one axis.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct SensorModel {
    /// The three channels.
    pub channels: [ChannelModel; 3],
}

impl SensorModel {
    /// Channel values the model predicts at phase `phi` (counts, not rounded).
    pub fn predict(&self, phi: f64) -> [f64; 3] {
        self.channels.map(|c| c.predict(phi))
    }

    /// Mean fundamental amplitude, counts.
    pub fn mean_amplitude_counts(&self) -> f64 {
        self.channels
            .iter()
            .map(|c| c.amplitude_counts)
            .sum::<f64>()
            / 3.0
    }

    /// Linear demodulation: offsets and the first two rows of M⁻¹, no table. M's third
    /// column is the plain common mode (equal entries), so the rows are the generalized
    /// Clarke transform of the fitted fundamentals: every channel weighs in the phase by
    /// about (2/3)/A whatever the harmonics, and the correction table takes up what the
    /// harmonics leave. Rejecting the channels' fitted third harmonic instead would
    /// trade the table's work for rows that lean on one channel when the harmonics
    /// differ in phase between channels; a fault on that channel then moves the phase
    /// along the healthy residual's own slope, where the health check is nearly blind
    /// (see [`super::residual`]: sensitivities of 0.3 A per rad instead of 1.4 A).
    pub fn linear_calibration(&self) -> Result<HallCalibration, CalibrationError> {
        let c = &self.channels;
        let mean_amplitude = self.mean_amplitude_counts();
        let row = |ch: &ChannelModel| {
            let (a, p) = (ch.amplitude_counts, ch.phase_rad);
            [a * libm::cos(p), a * libm::sin(p), mean_amplitude]
        };
        let [r0, r1, r2] = [row(&c[0]), row(&c[1]), row(&c[2])];
        let m = Matrix3::new(
            r0[0], r0[1], r0[2], r1[0], r1[1], r1[2], r2[0], r2[1], r2[2],
        );
        let inv = m.try_inverse().ok_or(CalibrationError::Singular)?;
        let inv: [[f64; 3]; 3] = inv.transpose().into();
        let [sin_row, cos_row, _] = inv;
        // Σk uk = (Σ ak) sin φ + (Σ bk) cos φ + harmonic: remove the fundamental part.
        let (sum_a, sum_b) = (r0[0] + r1[0] + r2[0], r0[1] + r1[1] + r2[1]);
        let mut sum_row = [0.0f32; 3];
        for ((w, s), cc) in sum_row.iter_mut().zip(&sin_row).zip(&cos_row) {
            *w = (1.0 - sum_a * s - sum_b * cc) as f32;
        }
        Ok(HallCalibration {
            offset_counts: c.map(|ch| ch.offset_counts as f32),
            sin_row: sin_row.map(|v| v as f32),
            cos_row: cos_row.map(|v| v as f32),
            sum_row,
            correction: None,
            residual: None,
            range_counts: self.range_counts(),
        })
    }

    /// Lowest and highest value of each channel over the pitch (1024 phases; a sample
    /// between them is at most (2π/1024)²/8 · 26 A = 1e-4 A beyond).
    fn range_counts(&self) -> [[f32; 2]; 3] {
        let mut range = [[f32::MAX, f32::MIN]; 3];
        for i in 0..1024 {
            let u = self.predict(2.0 * PI * f64::from(i) / 1024.0);
            for ([lo, hi], u) in range.iter_mut().zip(u) {
                *lo = lo.min(u as f32);
                *hi = hi.max(u as f32);
            }
        }
        range
    }

    /// What `calibration`'s linear rows get wrong on this model, as a table over the
    /// decoded phase.
    pub fn correction(&self, calibration: &HallCalibration) -> HallCorrection {
        let decode = |phi: f64| {
            let u = self.predict(phi);
            let (s, c) = calibration.demodulate_f64(u);
            libm::atan2(s, c)
        };
        let mut error_q32 = [0i32; CORRECTION_ENTRIES];
        for (j, e) in error_q32.iter_mut().enumerate() {
            // Find φ whose linear decode lands on the grid point g (fixed-point iteration;
            // the linear decode's error is below 0.1 rad with a slope below 0.3, so 12
            // steps reach 0.3^12 of it: 5e-8 rad, below a table count of 1.5e-9 rad...
            // at a slope of 0.1 (the worst sensors) 1e-13 rad).
            let g = 2.0 * PI * j as f64 / CORRECTION_ENTRIES as f64;
            let mut phi = g;
            for _ in 0..12 {
                phi -= wrap_rad(decode(phi) - g);
            }
            *e = libm::round(wrap_rad(g - phi) / (2.0 * PI) * 4_294_967_296.0) as i32;
        }
        HallCorrection { error_q32 }
    }

    /// The full calibration of this model: linear rows and their correction table.
    pub fn calibration(&self) -> Result<HallCalibration, CalibrationError> {
        let linear = self.linear_calibration()?;
        Ok(HallCalibration {
            correction: Some(self.correction(&linear)),
            residual: Some(self.residual_table(&linear)),
            ..linear
        })
    }
}

/// Wraps an angle to (−π, π].
pub(super) fn wrap_rad(a: f64) -> f64 {
    a - 2.0 * PI * libm::round(a / (2.0 * PI))
}

/// Result of a self-calibration.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SelfCalibration {
    /// Everything the decoder needs (rows and phase table): install it with
    /// [`HallConfig::with_self_calibration`](super::HallConfig::with_self_calibration)
    /// or as [`HallConfig::calibration`](super::HallConfig::calibration).
    pub calibration: HallCalibration,
    /// The fitted model, for diagnosis.
    pub model: SensorModel,
    /// Largest checked residual over the calibration samples, counts: |health row ·
    /// (u − o)| minus the healthy-residual table at the sample's linear phase (noise,
    /// ADC rounding and what the model misses; compare
    /// [`ResidualTable::healthy_band_counts`]).
    pub peak_sum_residual_counts: f64,
    /// RMS of u − model over every sample and channel, counts (noise, quantization and
    /// whatever the model does not describe).
    pub residual_rms_counts: f64,
    /// Residual beyond which the fit warns: √((MISMATCH_LIMIT·A)² + NOISE_ALLOWANCE²),
    /// counts (see [`MISMATCH_LIMIT`], [`NOISE_ALLOWANCE_LSB`]).
    pub residual_limit_counts: f64,
    /// `Some` when the sensor does not fit the model.
    pub warning: Option<CalibrationWarning>,
    /// `Some` when the calibration was installed with a larger fault-error budget than
    /// configured, the smallest its noise allows (set by the machine path,
    /// `app::calibrate::fit_sensors`; `None` from the fit itself).
    pub fault_budget_raised: Option<super::FaultBudgetRaised>,
}

/// Collects raw samples during calibration coasts and fits the channel model.
/// `N` is the sample capacity (a few hundred per segment is plenty).
///
/// Samples must be pushed in time order at a fixed rate within each segment, while the
/// slider coasts smoothly (see the module docs); call [`HallCalibrator::new_segment`]
/// between coasts.
#[derive(Clone, Debug)]
pub struct HallCalibrator<const N: usize> {
    samples: heapless::Vec<[u16; 3], N>,
    /// Index of each segment's first sample.
    starts: heapless::Vec<usize, MAX_SEGMENTS>,
}

/// Phase bins that must all be visited: the fit needs at least one whole pitch.
const COVERAGE_BINS: usize = 16;
/// Gauss–Newton iterations at most (they stop when the step is below 1e-8 rad and
/// 1e-8 A; from a nominal decode the worst sensors need about 5).
const ITERATIONS: usize = 30;

impl<const N: usize> Default for HallCalibrator<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> HallCalibrator<N> {
    /// An empty calibrator.
    pub const fn new() -> Self {
        Self {
            samples: heapless::Vec::new(),
            starts: heapless::Vec::new(),
        }
    }

    /// Stores the next raw sample of the present segment.
    pub fn push(&mut self, raw: [u16; 3]) -> Result<(), CalibrationError> {
        if self.starts.is_empty() {
            self.new_segment()?;
        }
        self.samples.push(raw).map_err(|_| CalibrationError::Full)
    }

    /// Starts a new segment with the next sample: a new coast, or the way back (each
    /// segment has its own phase polynomial). A no-op on an empty segment.
    pub fn new_segment(&mut self) -> Result<(), CalibrationError> {
        let here = self.samples.len();
        if self.starts.last() == Some(&here) {
            return Ok(());
        }
        self.starts
            .push(here)
            .map_err(|_| CalibrationError::TooManySegments)
    }

    /// The stored samples of each segment, in order.
    fn segments(&self) -> impl Iterator<Item = &[[u16; 3]]> + '_ {
        let ends = self
            .starts
            .iter()
            .skip(1)
            .copied()
            .chain([self.samples.len()]);
        self.starts
            .iter()
            .zip(ends)
            .map(|(&start, end)| self.samples.get(start..end).unwrap_or(&[]))
    }

    /// Fits the model starting from `initial` (usually the nominal calibration).
    pub fn solve(&self, initial: &HallCalibration) -> Result<SelfCalibration, CalibrationError> {
        if self.samples.len() < 64 || self.segments().any(|s| s.len() < MIN_SEGMENT_SAMPLES) {
            return Err(CalibrationError::TooFewSamples);
        }
        self.check_coverage(initial)?;
        // Start: each segment's linear decode, unwrapped in time order, smoothed by its
        // polynomial; θ by least squares on those phases.
        let mut poly = [[0.0f64; TERMS]; MAX_SEGMENTS];
        for (p, samples) in poly.iter_mut().zip(self.segments()) {
            *p = initial_polynomial(initial, samples)?;
        }
        let mut theta = self.fit_theta(&poly)?;
        let mut converged = false;
        for _ in 0..ITERATIONS {
            let (d_theta, d_poly) = self.gauss_newton_step(&theta, &poly)?;
            for (t, d) in theta.iter_mut().zip(&d_theta) {
                for (v, dv) in t.iter_mut().zip(d) {
                    *v += dv;
                }
            }
            for (p, d) in poly.iter_mut().zip(&d_poly) {
                for (v, dv) in p.iter_mut().zip(d) {
                    *v += dv;
                }
            }
            let largest = |a: &[[f64; 7]; 3]| {
                a.iter()
                    .flatten()
                    .fold(0.0f64, |m, v| m.max(libm::fabs(*v)))
            };
            let largest_phase = d_poly
                .iter()
                .flatten()
                .fold(0.0f64, |m, v| m.max(libm::fabs(*v)));
            // Rounding in the solve leaves steps of ~1e-9 A and ~1e-10 rad once settled.
            let amplitude = theta
                .iter()
                .map(|t| libm::hypot(t[1], t[2]))
                .fold(0.0, f64::max);
            if largest(&d_theta) < 1e-8 * amplitude && largest_phase < 1e-8 {
                converged = true;
                break;
            }
        }
        if !converged {
            return Err(CalibrationError::NotConverged);
        }
        let model = SensorModel {
            channels: theta.map(|t| ChannelModel::from_coefficients(&t)),
        };
        let mut calibration = model.calibration()?;
        let residual = |raw: &[u16; 3]| -> f64 {
            let sum: f64 = raw
                .iter()
                .zip(&calibration.sum_row)
                .zip(&calibration.offset_counts)
                .map(|((&u, &w), &o)| f64::from(w) * (f64::from(u) - f64::from(o)))
                .sum();
            let turns = calibration.linear_phase(raw) / (2.0 * PI);
            let word = ((turns - libm::floor(turns)) * 4_294_967_296.0) as u64 as u32;
            let healthy = calibration
                .residual
                .map_or(0.0, |t| f64::from(t.at(word)) / 16.0);
            sum - healthy
        };
        let peak_sum_residual_counts = self
            .samples
            .iter()
            .map(|raw| libm::fabs(residual(raw)))
            .fold(0.0, f64::max);
        let (mut square_sum, mut count) = (0.0, 0usize);
        self.each_sample(&poly, |raw, phi, _| {
            let basis = basis(phi);
            for (t, &u) in theta.iter().zip(raw) {
                let r = f64::from(u) - dot(t, &basis);
                square_sum += r * r;
                count += 1;
            }
        });
        let residual_rms_counts = libm::sqrt(square_sum / count.max(1) as f64);
        // The healthy band allows for the noise the fit measured.
        if let Some(table) = calibration.residual.as_mut() {
            table.noise_rms_counts = residual_rms_counts as f32;
        }
        let mismatch = MISMATCH_LIMIT * model.mean_amplitude_counts();
        let residual_limit_counts = libm::hypot(mismatch, NOISE_ALLOWANCE_LSB);
        let warning = (residual_rms_counts > residual_limit_counts).then_some(
            CalibrationWarning::ModelMismatch {
                residual_rms_counts,
                limit_counts: residual_limit_counts,
            },
        );
        Ok(SelfCalibration {
            calibration,
            model,
            peak_sum_residual_counts,
            residual_rms_counts,
            residual_limit_counts,
            warning,
            fault_budget_raised: None,
        })
    }

    /// Every sample with its phase from the segment polynomials and its time powers.
    fn each_sample(
        &self,
        poly: &[[f64; TERMS]; MAX_SEGMENTS],
        mut f: impl FnMut(&[u16; 3], f64, &[f64; TERMS]),
    ) {
        for (segment, p) in self.segments().zip(poly) {
            let scale = 2.0 / (segment.len().max(2) - 1) as f64;
            for (i, raw) in segment.iter().enumerate() {
                let powers = powers(i as f64 * scale - 1.0);
                f(raw, dot(p, &powers), &powers);
            }
        }
    }

    /// θ of each channel by least squares at the polynomials' phases.
    fn fit_theta(
        &self,
        poly: &[[f64; TERMS]; MAX_SEGMENTS],
    ) -> Result<[[f64; BASIS]; 3], CalibrationError> {
        let mut gram = SMatrix::<f64, BASIS, BASIS>::zeros();
        let mut rhs = SMatrix::<f64, BASIS, 3>::zeros();
        self.each_sample(poly, |raw, phi, _| {
            let b = SVector::<f64, BASIS>::from(basis(phi));
            gram += b * b.transpose();
            let u = nalgebra::RowVector3::from(raw.map(f64::from));
            rhs += b * u;
        });
        let solved = gram
            .cholesky()
            .ok_or(CalibrationError::Singular)?
            .solve(&rhs);
        let columns: [[f64; BASIS]; 3] = solved.into();
        Ok(columns)
    }

    /// One joint Gauss–Newton step of θ and the time polynomials, θ eliminated.
    ///
    /// Residual r_kj = u_kj − θ_k·b(φ_j) with φ_j = c_s·τ_j. Normal equations
    /// [B⊗I₃, G; Gᵀ, C] with B = Σ b bᵀ (shared by the channels), G_k = Σ b g_k τᵀ,
    /// C = Σ_k Σ g_k² τ τᵀ (g_k = θ_k·b′): the time step solves the Schur complement
    /// (C − Σ G_kᵀ B⁻¹ G_k) δc = ρ_c − Σ G_kᵀ B⁻¹ ρ_k, then δθ_k = B⁻¹ (ρ_k − G_k δc).
    #[allow(clippy::type_complexity)]
    fn gauss_newton_step(
        &self,
        theta: &[[f64; BASIS]; 3],
        poly: &[[f64; TERMS]; MAX_SEGMENTS],
    ) -> Result<([[f64; BASIS]; 3], [[f64; TERMS]; MAX_SEGMENTS]), CalibrationError> {
        type Coupling = SMatrix<f64, BASIS, PHASE_UNKNOWNS>;
        let mut gram = SMatrix::<f64, BASIS, BASIS>::zeros();
        let mut coupling = [Coupling::zeros(); 3];
        let mut time = SMatrix::<f64, PHASE_UNKNOWNS, PHASE_UNKNOWNS>::zeros();
        let mut rho_theta = SMatrix::<f64, BASIS, 3>::zeros();
        let mut rho_time = SVector::<f64, PHASE_UNKNOWNS>::zeros();
        // Segments used so far; `index` from a bounded range so that the optimiser
        // sees every block below inside the matrices (no view bounds assertion left).
        let mut segment = 0usize;
        for ((samples, p), index) in self.segments().zip(poly).zip(0..MAX_SEGMENTS) {
            let scale = 2.0 / (samples.len().max(2) - 1) as f64;
            // A sample's phase depends on its own segment's TERMS time unknowns only:
            // the products touch that segment's block of columns (and rows) alone, so
            // they are accumulated there, without full-width temporaries.
            let columns = index * TERMS;
            for (i, raw) in samples.iter().enumerate() {
                let powers = powers(i as f64 * scale - 1.0);
                let phi = dot(p, &powers);
                let powers = SVector::<f64, TERMS>::from(powers);
                let b = SVector::<f64, BASIS>::from(basis(phi));
                let db = derivative(phi);
                add_outer(&mut gram, &b, &b);
                for (((t, &u), g_acc), mut rho) in theta
                    .iter()
                    .zip(raw)
                    .zip(coupling.iter_mut())
                    .zip(rho_theta.column_iter_mut())
                {
                    let g = dot(t, &db);
                    let r = f64::from(u) - dot(t, &basis(phi));
                    let g_powers = powers * g;
                    let mut coupling_block = g_acc.fixed_view_mut::<BASIS, TERMS>(0, columns);
                    add_outer(&mut coupling_block, &b, &g_powers);
                    let mut time_block = time.fixed_view_mut::<TERMS, TERMS>(columns, columns);
                    add_outer(&mut time_block, &g_powers, &g_powers);
                    rho += b * r;
                    let mut rho_block = rho_time.fixed_rows_mut::<TERMS>(columns);
                    rho_block += g_powers * r;
                }
            }
            segment = index + 1;
        }
        let chol = gram.cholesky().ok_or(CalibrationError::Singular)?;
        let mut schur = time;
        let mut rhs = rho_time;
        for (g, rho) in coupling.iter().zip(rho_theta.column_iter()) {
            // B⁻¹G a column at a time, rolled (a matrix solve is its columns' solves).
            let mut b_inv_g = *g;
            let columns = core::hint::black_box(PHASE_UNKNOWNS).min(PHASE_UNKNOWNS);
            for mut column in b_inv_g.column_iter_mut().take(columns) {
                chol.solve_mut(&mut column);
            }
            // Column by column, the count opaque to the optimiser: unrolled whole, this
            // product was a third of the board image's largest routine (which runs once
            // per calibration, in the link task, not in the control period).
            for j in 0..core::hint::black_box(PHASE_UNKNOWNS).min(PHASE_UNKNOWNS) {
                let product = g.transpose() * b_inv_g.column(j);
                let mut column = schur.column_mut(j);
                column -= product;
            }
            rhs -= b_inv_g.transpose() * rho;
        }
        // Unused segments' columns are empty: 1 on their diagonal keeps them at zero.
        // The common rotation of every phase is undetermined: a tiny ridge pins it.
        let ridge = 1e-10 * schur.trace() / (segment * TERMS).max(1) as f64;
        for (i, mut column) in schur.column_iter_mut().enumerate() {
            if let Some(d) = column.get_mut(i) {
                *d += if i < segment * TERMS { ridge } else { 1.0 };
            }
        }
        let d_time = schur
            .cholesky()
            .ok_or(CalibrationError::Singular)?
            .solve(&rhs);
        let mut d_theta = [[0.0; BASIS]; 3];
        for ((d, g), rho) in d_theta
            .iter_mut()
            .zip(&coupling)
            .zip(rho_theta.column_iter())
        {
            // g·δc column by column, rolled (as the product sums it: the first column's
            // term, then each next one added).
            let mut g_d_time = SVector::<f64, BASIS>::zeros();
            let columns = core::hint::black_box(PHASE_UNKNOWNS).min(PHASE_UNKNOWNS);
            for (column, &d_c) in g.column_iter().zip(d_time.iter()).take(columns) {
                g_d_time.axpy(d_c, &column, 1.0);
            }
            *d = chol.solve(&(rho - g_d_time)).into();
        }
        let mut d_poly = [[0.0; TERMS]; MAX_SEGMENTS];
        for (d, chunk) in d_poly.iter_mut().zip(d_time.as_slice().chunks_exact(TERMS)) {
            d.copy_from_slice(chunk);
        }
        Ok((d_theta, d_poly))
    }

    /// Checks that the linear decode of the samples covers every phase bin.
    fn check_coverage(&self, initial: &HallCalibration) -> Result<(), CalibrationError> {
        let mut visited = [false; COVERAGE_BINS];
        for raw in &self.samples {
            let turns = initial.linear_phase(raw) / (2.0 * PI) + 0.5;
            let bin = (turns * COVERAGE_BINS as f64) as usize;
            if let Some(v) = visited.get_mut(bin.min(COVERAGE_BINS - 1)) {
                *v = true;
            }
        }
        if visited.iter().all(|&v| v) {
            Ok(())
        } else {
            Err(CalibrationError::NotEnoughMotion)
        }
    }
}

/// A segment's starting polynomial: its linear decode unwrapped in time order, fitted
/// by least squares in τ.
fn initial_polynomial(
    initial: &HallCalibration,
    samples: &[[u16; 3]],
) -> Result<[f64; TERMS], CalibrationError> {
    let scale = 2.0 / (samples.len().max(2) - 1) as f64;
    let mut gram = SMatrix::<f64, TERMS, TERMS>::zeros();
    let mut rhs = SVector::<f64, TERMS>::zeros();
    let mut last: Option<f64> = None;
    for (i, raw) in samples.iter().enumerate() {
        let wrapped = initial.linear_phase(raw);
        let phi = match last {
            Some(previous) => previous + wrap_rad(wrapped - previous),
            None => wrapped,
        };
        last = Some(phi);
        let t = SVector::<f64, TERMS>::from(powers(i as f64 * scale - 1.0));
        gram += t * t.transpose();
        rhs += t * phi;
    }
    Ok(gram
        .cholesky()
        .ok_or(CalibrationError::Singular)?
        .solve(&rhs)
        .into())
}

mod basis;

#[cfg(test)]
mod tests;
