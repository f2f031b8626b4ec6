//! Hall sensor calibration: a per-channel harmonic fit decoded through a 3×3 inverse,
//! and an optional phase-error table learnt against a reference encoder.
//!
//! Channel model (k = 0, 1, 2), in the frame of the decoded phase φ:
//!
//!   u_k = o_k + A_k sin(φ + p_k) + A_k h_k sin(3(φ + p_k) + ψ).
//!
//! A_k, p_k are each channel's gain and phase (p_k = 0, ±2π/3 plus mounting error),
//! h_k its relative third harmonic and ψ the magnet's harmonic phase. The harmonic of
//! channel k follows its own mounting: sin 3(φ + p_k) = sin(3φ + 3ε_k) for p_k = θ_k + ε_k,
//! so a mounting error of 1° turns the harmonic by 3°. That is why a linear decoder
//! cannot remove it: the three harmonics no longer lie along one direction of channel
//! space. The calibration therefore yields two things:
//!
//! - a linear demodulation (the first two rows of M⁻¹, M's rows being (a_k, b_k, e_k) =
//!   (A_k cos p_k, A_k sin p_k, A_k h_k)): the Clarke transform for ideal sensors, in
//!   general one that undoes offset, gain and phase errors and rejects the harmonic's
//!   main direction;
//! - a [`HallCorrection`] table computed from the model: what the linear decoder still
//!   gets wrong as a function of phase (the harmonic's other direction), subtracted
//!   after the atan2 at the cost of one table interpolation.
//!
//! The fit needs φ, which is what the sensor measures, so it iterates: decode the
//! stored samples with the current model, refit, repeat until the parameters stop
//! moving. A harmonic fitted freely per channel would not be identifiable: a phase
//! distortion φ + ε sin 2φ can pass for harmonic content (sin(φ + ε sin 2φ) ≈ sin φ +
//! ε/2 (sin 3φ + sin φ)). So stage 1 fits one harmonic shared by all channels (which
//! cannot absorb that distortion, since it would appear with a different phase on each
//! channel) and stage 2 the model above, whose harmonic phases are tied to the
//! channels' fundamental phases rather than free.
//! This runs in f64 once, in a calibration mode, not in the control period.

use super::HallDecoder;
use core::f64::consts::PI;
use nalgebra::{Matrix3, SMatrix, SVector};

/// Unknowns of the joint fit: (o, a, b) per channel, then the shared (C, D).
const UNKNOWNS: usize = 11;
/// Unknowns of stage 2: (o, a, b, e) per channel, then the harmonic phase step δψ.
const STAGE2_UNKNOWNS: usize = 13;

/// Offsets and demodulation matrix of one axis' Hall sensors: plain data to store
/// and edit. `sin_row · (u − offset) = sin φ`, `cos_row · (u − offset) = cos φ`.
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
}

impl HallCalibration {
    /// Ideal sensors: equal offsets and amplitudes, exact 120° spacing; the rows are the
    /// Clarke transform sin φ = (2u1 − u2 − u3)/(3A), cos φ = (u2 − u3)/(√3 A).
    pub const fn ideal(offset_counts: f64, amplitude_counts: f64) -> Self {
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
        }
    }

    /// sin φ and cos φ of channel values in f64 (the calibration's own decoder).
    fn demodulate_f64(&self, raw: [f64; 3]) -> (f64, f64) {
        let (mut s, mut c) = (0.0, 0.0);
        for (k, value) in raw.iter().enumerate() {
            let u = value - f64::from(self.offset_counts[k]);
            s += f64::from(self.sin_row[k]) * u;
            c += f64::from(self.cos_row[k]) * u;
        }
        (s, c)
    }
}

/// Why a calibration could not be made.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CalibrationError {
    /// The sample buffer is full.
    Full,
    /// Fewer samples than the fit needs (at least 64).
    TooFewSamples,
    /// The samples do not cover a whole pitch (every 1/16 of the phase circle).
    NotEnoughMotion,
    /// The fit's equations are singular (dead or duplicated channels).
    Singular,
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
    /// Third-harmonic amplitude h_k relative to the fundamental.
    pub harmonic3: f64,
}

/// The fitted sensor model of one axis.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct SensorModel {
    /// The three channels.
    pub channels: [ChannelModel; 3],
    /// Harmonic phase ψ of the magnet, rad.
    pub harmonic_phase_rad: f64,
}

impl SensorModel {
    /// Channel values the model predicts at phase `phi` (counts, not rounded).
    pub fn predict(&self, phi: f64) -> [f64; 3] {
        self.channels.map(|c| {
            let a = phi + c.phase_rad;
            c.offset_counts
                + c.amplitude_counts
                    * (libm::sin(a) + c.harmonic3 * libm::sin(3.0 * a + self.harmonic_phase_rad))
        })
    }

    /// Linear demodulation: offsets and the first two rows of M⁻¹. Without a
    /// measurable harmonic the third direction is the plain common mode (equal entries).
    pub fn linear_calibration(&self) -> Result<HallCalibration, CalibrationError> {
        let c = &self.channels;
        let mean_amplitude = c.iter().map(|ch| ch.amplitude_counts).sum::<f64>() / 3.0;
        let has_harmonic = c.iter().map(|ch| libm::fabs(ch.harmonic3)).sum::<f64>() > 3e-4;
        let row = |k: usize| {
            let (a, p, h) = (c[k].amplitude_counts, c[k].phase_rad, c[k].harmonic3);
            [
                a * libm::cos(p),
                a * libm::sin(p),
                if has_harmonic { a * h } else { mean_amplitude },
            ]
        };
        let (r0, r1, r2) = (row(0), row(1), row(2));
        let m = Matrix3::new(
            r0[0], r0[1], r0[2], r1[0], r1[1], r1[2], r2[0], r2[1], r2[2],
        );
        let inv = m.try_inverse().ok_or(CalibrationError::Singular)?;
        // Σk uk = (Σ ak) sin φ + (Σ bk) cos φ + harmonic: remove the fundamental part.
        let (sum_a, sum_b) = (r0[0] + r1[0] + r2[0], r0[1] + r1[1] + r2[1]);
        let sum_row = [0, 1, 2].map(|k| (1.0 - sum_a * inv[(0, k)] - sum_b * inv[(1, k)]) as f32);
        Ok(HallCalibration {
            offset_counts: c.map(|ch| ch.offset_counts as f32),
            sin_row: [inv[(0, 0)] as f32, inv[(0, 1)] as f32, inv[(0, 2)] as f32],
            cos_row: [inv[(1, 0)] as f32, inv[(1, 1)] as f32, inv[(1, 2)] as f32],
            sum_row,
        })
    }

    /// What `calibration` gets wrong on this model, as a table over the decoded phase.
    pub fn correction(&self, calibration: &HallCalibration) -> HallCorrection {
        let decode = |phi: f64| {
            let u = self.predict(phi);
            let (s, c) = calibration.demodulate_f64(u);
            libm::atan2(s, c)
        };
        let mut error_q32 = [0i32; CORRECTION_ENTRIES];
        for (j, e) in error_q32.iter_mut().enumerate() {
            // Find φ whose linear decode lands on the grid point g (fixed-point iteration;
            // the error is < 1e-2 rad with slope < 0.1, so a few steps reach 1e-12).
            let g = 2.0 * PI * j as f64 / CORRECTION_ENTRIES as f64;
            let mut phi = g;
            for _ in 0..6 {
                phi -= wrap_rad(decode(phi) - g);
            }
            *e = libm::round(wrap_rad(g - phi) / (2.0 * PI) * 4_294_967_296.0) as i32;
        }
        HallCorrection { error_q32 }
    }
}

/// Wraps an angle to (−π, π].
fn wrap_rad(a: f64) -> f64 {
    a - 2.0 * PI * libm::round(a / (2.0 * PI))
}

/// Result of a self-calibration.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SelfCalibration {
    /// Linear demodulation for [`HallConfig::calibration`](super::HallConfig::calibration).
    pub calibration: HallCalibration,
    /// Model-derived phase correction for [`HallDecoder::set_correction`].
    pub correction: HallCorrection,
    /// The fitted model, for diagnosis.
    pub model: SensorModel,
    /// Largest |health row · (u − o)| over the calibration samples, counts: the healthy
    /// band of the channel-sum check for this sensor.
    pub peak_sum_residual_counts: f64,
}

/// Collects raw samples during a calibration move and fits the channel model.
/// `N` is the sample capacity (a few hundred over one or two pitches is plenty).
#[derive(Clone, Debug)]
pub struct HallCalibrator<const N: usize> {
    samples: heapless::Vec<[u16; 3], N>,
}

/// Phase bins that must all be visited: the fit needs at least one whole pitch.
const COVERAGE_BINS: usize = 16;
/// Fit iterations per stage at most (they stop when parameters move < 1e-7 A).
const ITERATIONS: usize = 20;

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
        }
    }

    /// Stores one raw sample (take them spread over the move, e.g. every few periods).
    pub fn push(&mut self, raw: [u16; 3]) -> Result<(), CalibrationError> {
        self.samples.push(raw).map_err(|_| CalibrationError::Full)
    }

    /// Fits the model starting from `initial` (usually the nominal calibration).
    pub fn solve(&self, initial: &HallCalibration) -> Result<SelfCalibration, CalibrationError> {
        if self.samples.len() < 64 {
            return Err(CalibrationError::TooFewSamples);
        }
        // Stage 1: harmonic shared by the channels; fixes the phase scale.
        let mut calibration = *initial;
        let mut previous: Option<SVector<f64, UNKNOWNS>> = None;
        let mut shared = SVector::<f64, UNKNOWNS>::zeros();
        for _ in 0..ITERATIONS {
            let mut gram = SMatrix::<f64, UNKNOWNS, UNKNOWNS>::zeros();
            let mut rhs = SVector::<f64, UNKNOWNS>::zeros();
            for (raw, phi) in self.phases(&calibration, None)? {
                let basis = [
                    1.0,
                    libm::sin(phi),
                    libm::cos(phi),
                    libm::sin(3.0 * phi),
                    libm::cos(3.0 * phi),
                ];
                for (k, &count) in raw.iter().enumerate() {
                    let mut row = SVector::<f64, UNKNOWNS>::zeros();
                    row.fixed_rows_mut::<3>(3 * k).copy_from_slice(&basis[..3]);
                    row.fixed_rows_mut::<2>(9).copy_from_slice(&basis[3..]);
                    gram += row * row.transpose();
                    rhs += row * f64::from(count);
                }
            }
            shared = gram
                .cholesky()
                .ok_or(CalibrationError::Singular)?
                .solve(&rhs);
            let mut model = SensorModel::default();
            for (k, ch) in model.channels.iter_mut().enumerate() {
                *ch = channel(shared[3 * k], shared[3 * k + 1], shared[3 * k + 2], 0.0);
            }
            calibration = model.linear_calibration()?;
            let converged = previous
                .is_some_and(|p| (p - shared).amax() < 1e-7 * model.channels[0].amplitude_counts);
            previous = Some(shared);
            if converged {
                break;
            }
        }
        // Stage 2: each channel's harmonic follows its own phase: basis sin(3(φ + p_k) + ψ).
        let mut model = SensorModel::default();
        for (k, ch) in model.channels.iter_mut().enumerate() {
            *ch = channel(shared[3 * k], shared[3 * k + 1], shared[3 * k + 2], 0.0);
        }
        // The shared fit H sin(3φ + ψs) averages sin(3φ + 3p_k + ψ) over k.
        let (sum_sin, sum_cos) = model.channels.iter().fold((0.0, 0.0), |(s, c), ch| {
            (
                s + libm::sin(3.0 * ch.phase_rad),
                c + libm::cos(3.0 * ch.phase_rad),
            )
        });
        model.harmonic_phase_rad =
            libm::atan2(shared[10], shared[9]) - libm::atan2(sum_sin, sum_cos);
        // Errors-in-variables Gauss–Newton: unknowns are the model (o, a, b, e per channel
        // and ψ) and each sample's phase φ_j. Each φ_j only touches its own three
        // residuals, so it is eliminated per sample (Schur complement): the model step
        // solves Σ J_θᵀ (I − P_j) J_θ δθ = Σ J_θᵀ (I − P_j) r_j with P_j the projector on
        // ∂u/∂φ_j, then each φ_j takes its own step. Converges quadratically where
        // alternating decode-and-refit crawls along the weakly determined directions.
        let mut phases: heapless::Vec<f64, N> = self
            .phases(&calibration, None)?
            .map(|(_, phi)| phi)
            .collect();
        let mut theta = [[0.0f64; 4]; 3];
        for (k, t) in theta.iter_mut().enumerate() {
            *t = [shared[3 * k], shared[3 * k + 1], shared[3 * k + 2], 0.0];
        }
        for _ in 0..ITERATIONS {
            let mut gram = SMatrix::<f64, STAGE2_UNKNOWNS, STAGE2_UNKNOWNS>::zeros();
            let mut rhs = SVector::<f64, STAGE2_UNKNOWNS>::zeros();
            for (raw, &phi) in self.samples.iter().zip(phases.iter()) {
                let (jt, jp, r) = linearize(&model, &theta, raw, phi);
                let n = jp.dot(&jp);
                let jtp = jt * jp; // Σ_k J_φk J_θk
                gram += jt * jt.transpose() - jtp * jtp.transpose() / n;
                rhs += jt * r - jtp * (jp.dot(&r) / n);
            }
            // The common rotation of all phases is undetermined: a tiny ridge pins it.
            let ridge = 1e-10 * gram.trace() / STAGE2_UNKNOWNS as f64;
            for i in 0..STAGE2_UNKNOWNS {
                gram[(i, i)] += ridge;
            }
            let step = gram
                .cholesky()
                .ok_or(CalibrationError::Singular)?
                .solve(&rhs);
            for (raw, phi) in self.samples.iter().zip(phases.iter_mut()) {
                let (jt, jp, r) = linearize(&model, &theta, raw, *phi);
                *phi += jp.dot(&(r - jt.transpose() * step)) / jp.dot(&jp);
            }
            for (k, t) in theta.iter_mut().enumerate() {
                for (i, v) in t.iter_mut().enumerate() {
                    *v += step[4 * k + i];
                }
                model.channels[k] = channel(t[0], t[1], t[2], t[3] / libm::hypot(t[1], t[2]));
            }
            model.harmonic_phase_rad += step[12];
            if step.amax() < 1e-9 * model.channels[0].amplitude_counts {
                break;
            }
        }
        let calibration = model.linear_calibration()?;
        let correction = model.correction(&calibration);
        let residual = |raw: &[u16; 3]| -> f64 {
            (0..3)
                .map(|k| {
                    f64::from(calibration.sum_row[k])
                        * (f64::from(raw[k]) - f64::from(calibration.offset_counts[k]))
                })
                .sum()
        };
        let peak_sum_residual_counts = self
            .samples
            .iter()
            .map(|raw| libm::fabs(residual(raw)))
            .fold(0.0, f64::max);
        Ok(SelfCalibration {
            calibration,
            correction,
            model,
            peak_sum_residual_counts,
        })
    }

    /// Decodes every stored sample (linear demodulation, then the correction table if
    /// any); checks that they cover a whole pitch.
    fn phases<'a>(
        &'a self,
        calibration: &'a HallCalibration,
        correction: Option<&'a HallCorrection>,
    ) -> Result<impl Iterator<Item = ([u16; 3], f64)> + 'a, CalibrationError> {
        let phase = move |raw: &[u16; 3]| {
            let (s, c) = calibration.demodulate_f64(raw.map(f64::from));
            let phi = libm::atan2(s, c);
            match correction {
                Some(table) => {
                    let word = (phi / (2.0 * PI) * 4_294_967_296.0) as i64 as u32;
                    f64::from(table.apply(word) as i32) / 4_294_967_296.0 * 2.0 * PI
                }
                None => phi,
            }
        };
        let mut visited = [false; COVERAGE_BINS];
        for raw in &self.samples {
            let bin = ((phase(raw) / (2.0 * PI) + 0.5) * COVERAGE_BINS as f64) as usize;
            if let Some(v) = visited.get_mut(bin.min(COVERAGE_BINS - 1)) {
                *v = true;
            }
        }
        if !visited.iter().all(|&v| v) {
            return Err(CalibrationError::NotEnoughMotion);
        }
        Ok(self.samples.iter().map(move |raw| (*raw, phase(raw))))
    }
}

/// Jacobians and residuals of one sample for the stage-2 fit: J_θ (13 × 3, one column
/// per channel), ∂u/∂φ (3) and u − model (3). The harmonic's phase p_k is taken from
/// the model of the previous step (its dependence on a, b is third order in h).
fn linearize(
    model: &SensorModel,
    theta: &[[f64; 4]; 3],
    raw: &[u16; 3],
    phi: f64,
) -> (
    SMatrix<f64, STAGE2_UNKNOWNS, 3>,
    nalgebra::Vector3<f64>,
    nalgebra::Vector3<f64>,
) {
    let (s, c) = (libm::sin(phi), libm::cos(phi));
    let mut jt = SMatrix::<f64, STAGE2_UNKNOWNS, 3>::zeros();
    let mut jp = nalgebra::Vector3::zeros();
    let mut r = nalgebra::Vector3::zeros();
    for k in 0..3 {
        let [o, a, b, e] = theta[k];
        let angle = 3.0 * (phi + model.channels[k].phase_rad) + model.harmonic_phase_rad;
        let (hs, hc) = (libm::sin(angle), libm::cos(angle));
        jt[(4 * k, k)] = 1.0;
        jt[(4 * k + 1, k)] = s;
        jt[(4 * k + 2, k)] = c;
        jt[(4 * k + 3, k)] = hs;
        jt[(12, k)] = e * hc;
        jp[k] = a * c - b * s + 3.0 * e * hc;
        r[k] = f64::from(raw[k]) - (o + a * s + b * c + e * hs);
    }
    (jt, jp, r)
}

/// Channel model from the fitted o, a (sin φ coefficient), b (cos φ coefficient), h.
fn channel(offset: f64, a: f64, b: f64, harmonic3: f64) -> ChannelModel {
    ChannelModel {
        offset_counts: offset,
        amplitude_counts: libm::hypot(a, b),
        phase_rad: libm::atan2(b, a),
        harmonic3,
    }
}

/// Entries of the phase-error table over one pitch.
pub const CORRECTION_ENTRIES: usize = 256;

/// Phase-error table over one pitch, subtracted from the decoded phase with linear
/// interpolation: the residual that the channel model cannot describe (harmonics that
/// differ between channels, magnet pitch errors), learnt against a reference encoder.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HallCorrection {
    /// Error at phase k/256 pitch in units of 2^-32 pitch.
    pub error_q32: [i32; CORRECTION_ENTRIES],
}

impl HallCorrection {
    /// Corrected phase word.
    #[inline]
    pub fn apply(&self, phase: u32) -> u32 {
        let index = (phase >> 24) as usize;
        let fraction = i64::from(phase & 0x00FF_FFFF);
        let here = i64::from(self.error_q32[index % CORRECTION_ENTRIES]);
        let next = i64::from(self.error_q32[(index + 1) % CORRECTION_ENTRIES]);
        let error = here + (((next - here) * fraction) >> 24);
        phase.wrapping_sub(error as i32 as u32)
    }
}

/// Learns a [`HallCorrection`] from pairs of decoded and reference phases.
#[derive(Clone, Debug)]
pub struct CorrectionLearner {
    sum: [i64; CORRECTION_ENTRIES],
    count: [u32; CORRECTION_ENTRIES],
    offset: Option<u32>,
}

impl Default for CorrectionLearner {
    fn default() -> Self {
        Self {
            sum: [0; CORRECTION_ENTRIES],
            count: [0; CORRECTION_ENTRIES],
            offset: None,
        }
    }
}

impl CorrectionLearner {
    /// Adds one sample: the decoder's phase (without correction) and the reference
    /// encoder's position as a phase word (any constant offset between the two is
    /// removed when the table is made).
    pub fn add(&mut self, decoded_phase: u32, reference_phase: u32) {
        // Each sample goes to the nearest table entry (bins centred on the entries).
        let index = (decoded_phase.wrapping_add(1 << 23) >> 24) as usize % CORRECTION_ENTRIES;
        // Differences are taken relative to the first one, so that a constant offset
        // near half a pitch cannot wrap individual samples to the other side.
        let difference = decoded_phase.wrapping_sub(reference_phase);
        let offset = *self.offset.get_or_insert(difference);
        // A full entry stops learning: 2^32 samples of at most 2^31 each still fit the
        // i64 sum, and the mean is long settled.
        if let (Some(sum), Some(count)) = (self.sum.get_mut(index), self.count.get_mut(index)) {
            if *count < u32::MAX {
                *sum += i64::from(difference.wrapping_sub(offset) as i32);
                *count += 1;
            }
        }
    }

    /// Averages each entry and removes the mean (a constant offset is homing's job).
    pub fn finish(&self) -> Result<HallCorrection, CalibrationError> {
        let mut error_q32 = [0i32; CORRECTION_ENTRIES];
        for ((entry, &sum), &count) in error_q32.iter_mut().zip(&self.sum).zip(&self.count) {
            if count == 0 {
                return Err(CalibrationError::NotEnoughMotion);
            }
            *entry = (sum / i64::from(count)) as i32;
        }
        let mean = error_q32.iter().map(|&e| i64::from(e)).sum::<i64>() / CORRECTION_ENTRIES as i64;
        // Phase errors are modulo one pitch (applied with wrapping arithmetic), so the
        // removal of the mean wraps too.
        for e in &mut error_q32 {
            *e = e.wrapping_sub(mean as i32);
        }
        Ok(HallCorrection { error_q32 })
    }
}

impl HallDecoder {
    /// Phase word of a raw sample with the decoder's calibration and no unwrapping,
    /// for learning a correction table (`None` on a fault).
    pub fn raw_phase(&self, raw: [u16; 3]) -> Option<u32> {
        self.phase(&mut [0; 2], raw).ok()
    }
}
