//! Three analog Hall sensors 120° apart over one magnetic pitch, digitized by an ADC.
//!
//! uᵢ = offsetᵢ + Aᵢ sin(2π x/τ + shiftᵢ) + noise, rounded and clipped to the ADC range.

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
    /// (uᵢ ∝ sin aᵢ + hᵢ sin 3aᵢ, aᵢ the channel's own phase).
    pub harmonic3: [f64; 3],
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
            noise_lsb,
        }
    }
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
        for (k, count) in out.iter_mut().enumerate() {
            let a = phi + p.phase_rad[k];
            let u = p.offset_counts[k]
                + p.amplitude_counts[k] * (libm::sin(a) + p.harmonic3[k] * libm::sin(3.0 * a))
                + p.noise_lsb * self.noise.normal();
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
