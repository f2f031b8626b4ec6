//! Input codes: what an ADC count means at the sensor. A bipolar sensor signal (the
//! F/T sensor's gauge voltages, ±10 V) reaches the ADC through a conditioning stage
//! that scales it into the ADC's 0–3.3 V about mid-scale; the count, left-aligned in
//! 16 bits (full scale 65,520), is undone to the sensor's volts by
//! `(count / 65536 · Vref − Vmid) · gain`.

/// A conditioned bipolar input.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct BipolarInput {
    /// ADC volts per count of a left-aligned 16-bit result.
    pub volts_per_count: f32,
    /// The ADC voltage of a zero input, V.
    pub mid_v: f32,
    /// Sensor volts per ADC volt (the conditioning stage's gain inverted).
    pub gain: f32,
}

impl BipolarInput {
    /// A stage mapping ±`span_v` at the sensor onto 0…`vref_v` at the ADC.
    pub const fn new(vref_v: f32, span_v: f32) -> Self {
        Self {
            volts_per_count: vref_v / 65_536.0,
            mid_v: vref_v / 2.0,
            gain: 2.0 * span_v / vref_v,
        }
    }

    /// The sensor's voltage for a left-aligned count.
    pub fn volts(&self, count: u16) -> f32 {
        (f32::from(count) * self.volts_per_count - self.mid_v) * self.gain
    }
}

#[cfg(test)]
mod tests {
    use super::BipolarInput;

    /// ±10 V onto 0–3.3 V: mid-scale is 0 V, count 0 is −10 V and the top count one
    /// 12-bit step (20 V / 4096, 4.9 mV) below +10 V, and every count agrees with the chain written out in f64 to f32
    /// rounding (1e-5 V at 10 V).
    #[test]
    fn counts_undo_the_conditioning() {
        let input = BipolarInput::new(3.3, 10.0);
        assert!(input.volts(32_768).abs() < 1e-6);
        assert!((input.volts(0) + 10.0).abs() < 1e-5);
        assert!((f64::from(input.volts(65_520)) - (10.0 - 20.0 / 4096.0)).abs() < 1e-5);
        for count in (0..=65_520u16).step_by(16) {
            let exact = (f64::from(count) / 65_536.0 * 3.3 - 1.65) * (20.0 / 3.3);
            assert!(
                (f64::from(input.volts(count)) - exact).abs() < 1e-5,
                "count {count}"
            );
        }
    }
}
