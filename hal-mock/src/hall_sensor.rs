//! Three analog Hall sensors 120° apart over one magnetic pitch, digitized by an ADC.
//!
//! uᵢ = offsetᵢ + Aᵢ (sin aᵢ + h3ᵢ sin(3aᵢ + ψ3ᵢ) + h5ᵢ sin(5aᵢ + ψ5ᵢ)) + noise with
//! aᵢ = 2π x/τ + shiftᵢ, rounded and clipped to the ADC range. Real linear-motor Hall
//! sensors show 3rd and 5th harmonics whose amplitude and phase differ from channel to
//! channel (magnet shape, sensor placement over the magnet's edge).

use crate::noise::Noise;
use core::f64::consts::PI;

/// Sensor and ADC model.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HallSensorParams {
    /// Magnetic pitch in m.
    pub pitch_m: f64,
    /// ADC resolution in bits.
    pub adc_bits: u8,
    /// Per-channel zero level in counts.
    pub offset_counts: [f64; 3],
    /// Per-channel peak amplitude in counts.
    pub amplitude_counts: [f64; 3],
    /// Phase of each channel in rad (0, +2π/3, −2π/3 for an ideal sensor).
    pub phase_rad: [f64; 3],
    /// Third-harmonic amplitude of each channel relative to its fundamental
    /// (uᵢ ∝ sin aᵢ + h3ᵢ sin(3aᵢ + ψ3ᵢ), aᵢ the channel's own phase).
    pub harmonic3: [f64; 3],
    /// Phase ψ3ᵢ of each channel's third harmonic against three times its own phase, rad
    /// (0: the harmonic turns with the channel's mounting, as for an ideal magnet).
    pub harmonic3_phase_rad: [f64; 3],
    /// Fifth-harmonic amplitude of each channel relative to its fundamental.
    pub harmonic5: [f64; 3],
    /// Phase ψ5ᵢ of each channel's fifth harmonic against five times its own phase, rad.
    pub harmonic5_phase_rad: [f64; 3],
    /// Signed error of each channel's gain above mid-scale of its own swing, relative
    /// (a kink at the channel's zero: a front end whose gain differs for the two signs,
    /// which no harmonic model describes). 0 for every preset.
    pub kink: [f64; 3],
    /// Seventh-harmonic amplitude of each channel relative to its fundamental (beyond
    /// the decoder's model; 0 for every preset).
    pub harmonic7: [f64; 3],
    /// Standard deviation of the additive noise in LSB.
    pub noise_lsb: f64,
}

impl HallSensorParams {
    /// Ideal LM1247 sensors on a 16-bit ADC: mid-scale offsets, amplitude 40 % of full
    /// scale, 2 LSB RMS noise.
    pub const LM1247_16BIT: Self = Self {
        pitch_m: 0.018,
        adc_bits: 16,
        offset_counts: [32768.0; 3],
        amplitude_counts: [26214.0; 3],
        phase_rad: [0.0, 2.0 * PI / 3.0, -2.0 * PI / 3.0],
        harmonic3: [0.0; 3],
        harmonic3_phase_rad: [0.0; 3],
        harmonic5: [0.0; 3],
        harmonic5_phase_rad: [0.0; 3],
        kink: [0.0; 3],
        harmonic7: [0.0; 3],
        noise_lsb: 2.0,
    };

    /// Real-world LM1247 sensors on an ADC of `adc_bits`: offsets up to ±3 % of full
    /// scale, gains ±5 %, channel phase errors up to 1.5°, a 2 % third harmonic that
    /// differs slightly per channel (1.8–2.2 %), and `noise_lsb` RMS noise.
    pub fn lm1247_imperfect(adc_bits: u8, noise_lsb: f64) -> Self {
        let full_scale = libm::exp2(f64::from(adc_bits));
        let mid = 0.5 * full_scale;
        let amplitude = 0.4 * full_scale;
        let degree = PI / 180.0;
        Self {
            pitch_m: 0.018,
            adc_bits,
            offset_counts: [
                mid + 0.03 * full_scale,
                mid - 0.02 * full_scale,
                mid + 0.015 * full_scale,
            ],
            amplitude_counts: [1.05 * amplitude, 0.96 * amplitude, 1.02 * amplitude],
            phase_rad: [
                0.0,
                2.0 * PI / 3.0 + 1.0 * degree,
                -2.0 * PI / 3.0 - 1.5 * degree,
            ],
            harmonic3: [0.020, 0.022, 0.018],
            harmonic3_phase_rad: [0.0; 3],
            harmonic5: [0.0; 3],
            harmonic5_phase_rad: [0.0; 3],
            kink: [0.0; 3],
            harmonic7: [0.0; 3],
            noise_lsb,
        }
    }

    /// The worst LM1247 sensors the decoder's model covers: the
    /// offsets, gains and mounting errors of [`HallSensorParams::lm1247_imperfect`],
    /// third harmonics of 1–3 % and fifth harmonics of 0.5–1 % per channel, each with
    /// its own phase up to ±10° away from the channel's mounting.
    pub fn lm1247_worst(adc_bits: u8, noise_lsb: f64) -> Self {
        let degree = PI / 180.0;
        Self {
            harmonic3: [0.030, 0.010, 0.022],
            harmonic3_phase_rad: [10.0 * degree, -10.0 * degree, 4.0 * degree],
            harmonic5: [0.010, 0.005, 0.008],
            harmonic5_phase_rad: [-10.0 * degree, 7.0 * degree, 10.0 * degree],
            ..Self::lm1247_imperfect(adc_bits, noise_lsb)
        }
    }
}

/// Bounds of the LM1247 class a drawn sensor set stays within
/// ([`HallSensorParams::lm1247_drawn`]): what the decoder's uncalibrated range
/// (`kerf::sensing::hall::UNCALIBRATED_RANGE`, 1.15 A) still holds at a channel's peak
/// with every error at its bound (7.5 % of A offset, 5 % gain, 4 % third and 1.5 % fifth
/// harmonic: 1.183 A, inside the rail margin's 1.2 A).
pub mod drawn_bounds {
    /// Largest offset from mid-scale, fraction of full scale.
    pub const OFFSET: f64 = 0.03;
    /// Largest gain error, relative.
    pub const GAIN: f64 = 0.05;
    /// Largest mounting error of a channel's phase, rad (1.5°).
    pub const MOUNTING_RAD: f64 = 1.5 * core::f64::consts::PI / 180.0;
    /// Largest third-harmonic amplitude relative to the fundamental.
    pub const HARMONIC3: f64 = 0.04;
    /// Largest fifth-harmonic amplitude relative to the fundamental.
    pub const HARMONIC5: f64 = 0.015;
}

impl HallSensorParams {
    /// A seeded random LM1247 sensor set, each channel drawn on its own within
    /// [`drawn_bounds`]: offset, gain and mounting error uniform within their bounds,
    /// third and fifth harmonics of any amplitude up to their bounds and of any phase
    /// (a magnet's shape and a sensor's placement over its edge set both per channel;
    /// [`HallSensorParams::lm1247_worst`] keeps them within ±10° of the mounting), and
    /// `noise_lsb` RMS noise (tests pass the model's limit: 4 LSB at 16 bits, 1 LSB at
    /// 12).
    pub fn lm1247_drawn(adc_bits: u8, noise_lsb: f64, seed: u64) -> Self {
        use drawn_bounds::*;
        let mut draw = Noise::new(seed ^ 0x4a11_5e75);
        // Uniform in [−1, 1).
        let mut symmetric = move || 2.0 * draw.uniform() - 1.0;
        let full_scale = libm::exp2(f64::from(adc_bits));
        let amplitude = 0.4 * full_scale;
        let nominal = [0.0, 2.0 * PI / 3.0, -2.0 * PI / 3.0];
        let mut p = Self::lm1247_imperfect(adc_bits, noise_lsb);
        for (k, nominal) in nominal.iter().enumerate() {
            p.offset_counts[k] = 0.5 * full_scale + OFFSET * full_scale * symmetric();
            p.amplitude_counts[k] = amplitude * (1.0 + GAIN * symmetric());
            p.phase_rad[k] = nominal + MOUNTING_RAD * symmetric();
            p.harmonic3[k] = HARMONIC3 * 0.5 * (1.0 + symmetric());
            p.harmonic3_phase_rad[k] = PI * symmetric();
            p.harmonic5[k] = HARMONIC5 * 0.5 * (1.0 + symmetric());
            p.harmonic5_phase_rad[k] = PI * symmetric();
        }
        p
    }
}

/// Pitches covered by one [`calibration_coast_m`].
pub const COAST_PITCHES: f64 = 1.5;

/// Slider positions of one calibration coast as the Hall fit asks for them: `samples`
/// at a fixed rate over 0.25 s, covering [`COAST_PITCHES`] of `pitch_m` from `start_m`
/// in `direction` (+1 or −1), the speed easing smoothly from 0.12 to about 0.1 m/s (a
/// coast under constant force against viscous friction, time constant 0.24 s:
/// x(t) = v∞ t + (v0 − v∞) T (1 − e^(−t/T)), scaled to the distance).
pub fn calibration_coast_m(
    start_m: f64,
    direction: f64,
    pitch_m: f64,
    samples: u32,
) -> impl Iterator<Item = f64> {
    let (v0, v_end, tau_s, duration_s) = (0.12, 0.1, 0.24, 0.25);
    let x = move |t: f64| v_end * t + (v0 - v_end) * tau_s * (1.0 - libm::exp(-t / tau_s));
    let scale = COAST_PITCHES * pitch_m / x(duration_s);
    let last = f64::from(samples.max(2) - 1);
    (0..samples).map(move |k| start_m + direction * scale * x(duration_s * f64::from(k) / last))
}

/// A fault injected into one channel.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum ChannelFault {
    /// Broken wire with a pull-down: reads 0.
    OpenWire(usize),
    /// Channel frozen at a count.
    Stuck(usize, u16),
    /// Channel frozen at whatever it read last (a hung ADC conversion).
    Frozen(usize),
    /// Broken wire left floating: the channel reads the level (counts) plus the
    /// sensor's noise.
    Floating(usize, f64),
    /// The channel's swing around its offset scaled by a gain (a failing sensor supply
    /// or front end; 0 leaves the offset alone), noise unchanged.
    Gain(usize, f64),
}

/// Sensor instance with its noise source and optional fault.
#[derive(Clone, Debug)]
pub struct HallSensor {
    params: HallSensorParams,
    noise: Noise,
    /// Injected fault, if any.
    pub fault: Option<ChannelFault>,
    last: [u16; 3],
}

impl HallSensor {
    /// Sensor with seeded noise.
    pub fn new(params: HallSensorParams, seed: u64) -> Self {
        Self {
            params,
            noise: Noise::new(seed),
            fault: None,
            last: [0; 3],
        }
    }

    /// Parameters in use.
    pub fn params(&self) -> &HallSensorParams {
        &self.params
    }

    /// Samples the three channels at slider position `position_m`.
    pub fn sample(&mut self, position_m: f64) -> [u16; 3] {
        let p = self.params;
        let full_scale = libm::exp2(f64::from(p.adc_bits)) - 1.0;
        let phi = 2.0 * PI * position_m / p.pitch_m;
        let mut out = [0u16; 3];
        let fault = self.fault;
        for (k, count) in out.iter_mut().enumerate() {
            let a = phi + p.phase_rad[k];
            let mut shape = libm::sin(a)
                + p.harmonic3[k] * libm::sin(3.0 * a + p.harmonic3_phase_rad[k])
                + p.harmonic5[k] * libm::sin(5.0 * a + p.harmonic5_phase_rad[k])
                + p.harmonic7[k] * libm::sin(7.0 * a);
            if shape > 0.0 {
                shape *= 1.0 + p.kink[k];
            }
            let gain = match fault {
                Some(ChannelFault::Gain(ch, g)) if ch == k => g,
                _ => 1.0,
            };
            let mut u = p.offset_counts[k]
                + gain * p.amplitude_counts[k] * shape
                + p.noise_lsb * self.noise.normal();
            if let Some(ChannelFault::Floating(ch, level)) = fault {
                if ch == k {
                    u += level - p.offset_counts[k] - gain * p.amplitude_counts[k] * shape;
                }
            }
            *count = libm::round(u).clamp(0.0, full_scale) as u16;
        }
        match self.fault {
            Some(ChannelFault::OpenWire(ch)) if ch < 3 => out[ch] = 0,
            Some(ChannelFault::Stuck(ch, value)) if ch < 3 => out[ch] = value,
            Some(ChannelFault::Frozen(ch)) if ch < 3 => out[ch] = self.last[ch],
            _ => {}
        }
        self.last = out;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_follow_the_model_and_sum_to_three_offsets() {
        let mut p = HallSensorParams::LM1247_16BIT;
        p.noise_lsb = 0.0;
        let mut s = HallSensor::new(p, 1);
        for k in 0..100 {
            let x = k as f64 * 0.0007;
            let c = s.sample(x);
            let sum: i32 = c.iter().map(|&v| i32::from(v)).sum();
            assert!((sum - 3 * 32768).abs() <= 2, "{sum}");
            let expect = 32768.0 + 26214.0 * (2.0 * PI * x / 0.018).sin();
            assert!((f64::from(c[0]) - expect).abs() <= 0.5);
        }
        s.fault = Some(ChannelFault::OpenWire(1));
        assert_eq!(s.sample(0.001)[1], 0);
    }
}
