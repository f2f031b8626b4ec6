//! The healthy residual of a calibrated sensor and the fault threshold that follows
//! from a position-error budget.
//!
//! # Why a table
//!
//! Three channels carry one phase: the health row w (`HallCalibration::sum_row`,
//! w·M_fundamental = 0) sees none of the fundamentals, but after calibration it still
//! sees the channels' 3rd and 5th harmonics, which differ per channel (up to about
//! 9 % of A on the worst sensors of the model). A fixed band around zero would have to
//! be that wide. The fitted model says what w·(u − o) reads on a healthy sensor at each
//! phase, so the decoder subtracts that value, looked up by the linear decode's phase
//! word ψ (the table is made on the ψ grid, so it needs no phase-correction table and
//! holds whatever correction is installed), and checks what is left against a limit T
//! close to the noise.
//!
//! # What a single-channel failure does
//!
//! Any failure of channel k (frozen, stuck at a level, open wire floating, gain
//! collapse) is an additive error e on that channel: e = v − u_k for a stuck or frozen
//! value v, ≈ −(u_k − o_k) for a floating wire, (g − 1)(u_k − o_k) for a gain g. To
//! first order it moves the linear phase by δψ = (∂ψ/∂u_k)·e and the checked residual
//! by (w_k − r′(ψ)·∂ψ/∂u_k)·e, the second term being the table read at the shifted
//! phase. Their ratio, the residual counts a fault on channel k shows per radian of
//! phase error it causes, has a worst case over the pitch: [`ResidualTable::
//! sensitivity_counts_per_rad`]. With the correction table's largest slope C and the
//! budget β = 2π·budget/τ rad of final phase, every fault whose error reaches the
//! budget shows at least
//!
//!   T_budget = min_k sensitivity_k · β / C
//!
//! counts of residual from the fault, to which the healthy part of the sample adds its
//! own. A healthy sensor stays within H = [`ResidualTable::healthy_band_counts`] (table
//! error plus [`NOISE_SIGMAS`] standard deviations of the noise seen through the
//! check), and so does the healthy part of a faulty sample, of either sign. A limit T
//! gives no false alarm if T ≥ H, and misses no fault at the budget if
//! T_budget − H ≥ T: both promises at the same [`NOISE_SIGMAS`] hold for T in
//! [H, T_budget − H]. The decoder takes its middle, T = T_budget/2; if T_budget < 2H
//! the interval is empty and [`HallDecoder::new`](super::HallDecoder::new) refuses the
//! configuration by naming `fault_error_budget_m` (never a silently looser check).
//! So the smallest budget a calibration can keep,
//! [`HallConfig::smallest_fault_error_budget_m`](super::HallConfig::smallest_fault_error_budget_m),
//! is the one whose T_budget is 2H: twice the error at which a fault's residual equals
//! the healthy band. At 12 bits with 1 LSB of noise that is about 30 to 35 µm at an
//! 18 mm pitch, at 16 bits with 4 LSB about 12 µm (docs/modules.md).
//!
//! A channel that fails while the axis stands still causes no error until the axis
//! moves (a frozen channel holds the right value): it is caught within the detection
//! distance of the moving case once motion starts.

use super::{HallCalibration, SensorModel};
use core::f64::consts::PI;

/// Entries of the healthy-residual table over one pitch of the linear phase. Linear
/// interpolation of a 5th harmonic on 128 entries errs by (2π·5/128)²/8 ≈ 0.5 % of
/// its amplitude (under 3 counts for the worst 16-bit sensors, measured exactly in
/// [`ResidualTable::systematic_counts`]); 64 entries would be 4 times that.
pub const RESIDUAL_ENTRIES: usize = 128;
/// Bits of the phase word below a table index.
const INDEX_SHIFT: u32 = 32 - RESIDUAL_ENTRIES.trailing_zeros();
/// Standard deviations of the checked residual's noise a healthy sensor is allowed:
/// a Gaussian exceeds 6σ with probability 2·10⁻⁹ per sample, 0.02 expected false alarms
/// in 10⁷ samples.
pub const NOISE_SIGMAS: f64 = 6.0;

/// What the health row reads on the healthy sensor, as a function of the linear
/// decode's phase, and the figures the decoder needs to set its fault limit from a
/// position-error budget (module docs). Plain data, made by a self-calibration.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ResidualTable {
    /// Health-row value w·(u − o) at linear phase j/[`RESIDUAL_ENTRIES`] pitch, in
    /// 1/16 counts (the integer path's Q4).
    pub value_q4: [i32; RESIDUAL_ENTRIES],
    /// Largest difference between the interpolated table and the model's own residual
    /// (interpolation, rounding of entries and of the decoder's sum), counts.
    pub systematic_counts: f32,
    /// Largest gain from independent channel noise of unit RMS to the checked residual
    /// over the pitch: max |w − r′(ψ)·∇ψ|₂ (the table is read at a noisy phase too).
    pub noise_gain: f32,
    /// Noise RMS per channel the healthy band allows for, counts (the fit's residual
    /// RMS; 0 for a model-derived table without measurements).
    pub noise_rms_counts: f32,
    /// Per channel, the smallest ratio over the pitch of the residual a fault on that
    /// channel shows to the phase error it causes: |w_k − r′ ∂ψ/∂u_k| / |∂ψ/∂u_k|,
    /// counts per rad of linear phase.
    pub sensitivity_counts_per_rad: [f32; 3],
}

impl ResidualTable {
    /// Healthy residual at linear phase word `phase`, Q4 counts, linearly interpolated.
    #[inline]
    pub fn at(&self, phase: u32) -> i32 {
        let index = (phase >> INDEX_SHIFT) as usize;
        let fraction = i64::from(phase & ((1 << INDEX_SHIFT) - 1));
        let entry = |i: usize| {
            i64::from(
                self.value_q4
                    .get(i % RESIDUAL_ENTRIES)
                    .copied()
                    .unwrap_or(0),
            )
        };
        let (here, next) = (entry(index), entry(index + 1));
        (here + (((next - here) * fraction) >> INDEX_SHIFT)) as i32
    }

    /// Band a healthy sensor's checked residual stays in, counts:
    /// systematic + [`NOISE_SIGMAS`] · noise gain · noise RMS.
    pub fn healthy_band_counts(&self) -> f64 {
        f64::from(self.systematic_counts)
            + NOISE_SIGMAS * f64::from(self.noise_gain) * f64::from(self.noise_rms_counts)
    }

    /// Largest residual a fault can show while its error stays within `budget_rad` of
    /// final phase, counts: min_k sensitivity_k · budget / `correction_slope`.
    pub fn budget_limit_counts(&self, budget_rad: f64, correction_slope: f64) -> f64 {
        self.sensitivity_counts_per_rad
            .iter()
            .fold(f64::INFINITY, |m, &s| m.min(f64::from(s)))
            * budget_rad
            / correction_slope
    }
}

impl SensorModel {
    /// The healthy-residual table of the linear rows `linear` on this model, without a
    /// noise allowance (set [`ResidualTable::noise_rms_counts`] from measurements).
    pub fn residual_table(&self, linear: &HallCalibration) -> ResidualTable {
        // The decoder's own quantization of the health row and the offsets, so that the
        // table predicts its integer sum, not the f32 one.
        let w = linear
            .sum_row
            .map(|v| libm::round(f64::from(v) * 65536.0) / 65536.0);
        let offset = linear
            .offset_counts
            .map(|v| libm::round(f64::from(v) * 16.0) / 16.0);
        let residual_at = |phi: f64| -> f64 {
            self.predict(phi)
                .iter()
                .zip(&w)
                .zip(&offset)
                .map(|((u, w), o)| w * (u - o))
                .sum()
        };
        // The true phase whose linear decode is ψ, and the residual there.
        let residual_of_linear = |psi: f64| residual_at(self.phase_of_linear(linear, psi));
        let step = 2.0 * PI / RESIDUAL_ENTRIES as f64;
        let mut value_q4 = [0i32; RESIDUAL_ENTRIES];
        for (j, v) in value_q4.iter_mut().enumerate() {
            *v = libm::round(16.0 * residual_of_linear(step * j as f64)) as i32;
        }
        let mut table = ResidualTable {
            value_q4,
            systematic_counts: 0.0,
            noise_gain: 0.0,
            noise_rms_counts: 0.0,
            sensitivity_counts_per_rad: [f32::MAX; 3],
        };
        // Measured on a grid 8 times finer than the table: interpolation error, noise
        // gain and the worst sensitivity per channel.
        let (mut interpolation, mut gain) = (0.0f64, 0.0f64);
        let mut sensitivity = [f64::INFINITY; 3];
        let fine = 8 * RESIDUAL_ENTRIES;
        for i in 0..fine {
            let psi = 2.0 * PI * (i as f64 + 0.5) / fine as f64;
            let word = (psi / (2.0 * PI) * 4_294_967_296.0) as u32;
            let exact = residual_of_linear(psi);
            interpolation = interpolation.max(libm::fabs(f64::from(table.at(word)) / 16.0 - exact));
            // r′(ψ) by a central difference (h = 1e-5 rad: truncation ~1e-10 A·25).
            let h = 1e-5;
            let slope = (residual_of_linear(psi + h) - residual_of_linear(psi - h)) / (2.0 * h);
            let phi = self.phase_of_linear(linear, psi);
            let u: [f64; 3] = core::array::from_fn(|k| {
                self.predict(phi).get(k).copied().unwrap_or(0.0)
                    - offset.get(k).copied().unwrap_or(0.0)
            });
            let (s, c) = linear.demodulate_centred(u);
            let radius_sq = s * s + c * c;
            let mut norm_sq = 0.0;
            for (((w, sin), cos), worst) in w
                .iter()
                .zip(&linear.sin_row)
                .zip(&linear.cos_row)
                .zip(sensitivity.iter_mut())
            {
                // ∂ψ/∂u_k of ψ = atan2(s, c).
                let d_psi = (c * f64::from(*sin) - s * f64::from(*cos)) / radius_sq;
                let seen = w - slope * d_psi;
                norm_sq += seen * seen;
                if libm::fabs(d_psi) > 0.0 {
                    *worst = worst.min(libm::fabs(seen) / libm::fabs(d_psi));
                }
            }
            gain = gain.max(libm::sqrt(norm_sq));
        }
        // Entries round to 1/32 count (included above) and the decoder's sum floors to
        // 1/16 count.
        table.systematic_counts = (interpolation + 1.0 / 16.0) as f32;
        table.noise_gain = gain as f32;
        table.sensitivity_counts_per_rad = sensitivity.map(|s| s as f32);
        table
    }

    /// The true phase whose linear decode by `linear` is `psi` (fixed-point iteration,
    /// as for the correction table: the worst sensors' linear error has a slope well
    /// below 1, so 16 steps settle to rounding).
    fn phase_of_linear(&self, linear: &HallCalibration, psi: f64) -> f64 {
        let mut phi = psi;
        for _ in 0..16 {
            let (s, c) = linear.demodulate_f64(self.predict(phi));
            phi -= super::calibration::wrap_rad(libm::atan2(s, c) - psi);
        }
        phi
    }
}

/// Largest slope of the final phase against the linear phase through a correction
/// table (1 without one): φ̂ = ψ − E(ψ), slope 1 − E′ per interval.
pub(super) fn correction_slope(calibration: &HallCalibration) -> f64 {
    calibration.correction.map_or(1.0, |table| {
        let entries = &table.error_q32;
        let spacing = 4_294_967_296.0 / entries.len() as f64;
        entries
            .iter()
            .zip(entries.iter().cycle().skip(1))
            .map(|(&a, &b)| libm::fabs(1.0 - f64::from(b.wrapping_sub(a)) / spacing))
            .fold(1.0, f64::max)
    })
}

#[cfg(test)]
mod tests;
