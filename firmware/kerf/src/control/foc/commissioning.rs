//! What a motor controller measures before it runs a motor (docs/control.md §30):
//! the current sensors' offsets with the bridge off, then the phase resistance and
//! inductance with voltages it injects along phase a, each checked against the range
//! the configuration expects, so that an open or shorted phase, or a motor other
//! than the one configured, is refused in words before the current loop runs.
//!
//! 1. **Offsets**: the bridge off, the mean of each shunt's readings.
//! 2. **Resistance**: an integral controller raises the voltage along α until i_α
//!    holds the test current; over the last quarter R = mean v_α / mean i_α (per
//!    phase: along α, v_a − v_n = v_α and i_a = i_α). The voltage reaching its
//!    ceiling first means no current flows: an open phase.
//! 3. **Inductance**: on that voltage a square wave of ±V, two periods each way (a
//!    voltage is loaded half a period after the sample, so only every other sample
//!    interval sees one voltage throughout); over those intervals the winding obeys
//!    i' − V_k/R = a (i − V_k/R) with a = e^(−RT/L), a found by least squares and
//!    L = −R T / ln a. The test current keeps every phase's current away from zero,
//!    where the dead time's compensation is unsure.
//!
//! Each period the caller passes the raw shunt currents and does what
//! [`Progress::Running`] says: the bridge off, or the stationary voltage made with
//! [`super::Foc::duties_for`] (the dead time compensated along the currents given).

use crate::error::{in_range, positive, ConfigError};
use crate::scalar::{lit, to_f64, Float};

/// The measurement's settings and the motor's expected ranges.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CommissioningConfig {
    /// Periods averaged for the offsets.
    pub offset_periods: u32,
    /// Largest offset a sensor may have, A.
    pub max_offset_a: f64,
    /// The current the resistance is measured at, A.
    pub test_current_a: f64,
    /// Periods the resistance's controller runs (the last quarter is averaged).
    pub resistance_periods: u32,
    /// The highest voltage the resistance's controller may reach, V.
    pub max_test_voltage_v: f64,
    /// Amplitude of the square wave the inductance is measured with, V.
    pub inductance_voltage_v: f64,
    /// Periods of the square wave.
    pub inductance_periods: u32,
    /// Phase resistance the motor must show, Ω (lowest, highest).
    pub resistance_range_ohm: (f64, f64),
    /// Phase inductance the motor must show, H (lowest, highest).
    pub inductance_range_h: (f64, f64),
}

impl CommissioningConfig {
    /// The LM1247 ([`super::MotorWindings::LM1247`]: 5.25 Ω, 0.36 mH) within a factor
    /// of two, measured at 0.3 A (1.6 V) and with a 1 V square wave, 0.2 s each at
    /// 20 kHz; sensor offsets up to 0.1 A.
    pub const LM1247: Self = Self {
        offset_periods: 2048,
        max_offset_a: 0.1,
        test_current_a: 0.3,
        resistance_periods: 4000,
        max_test_voltage_v: 6.0,
        inductance_voltage_v: 1.0,
        inductance_periods: 4000,
        resistance_range_ohm: (2.6, 10.5),
        inductance_range_h: (0.18e-3, 0.72e-3),
    };
}

/// What the caller does this period.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Command<T> {
    /// All six switches off.
    BridgeOff,
    /// Make this stationary voltage, compensating the dead time along these currents.
    Voltage {
        /// v_α, v_β, V.
        alpha_beta_v: [T; 2],
        /// The phase currents less their offsets, A.
        currents_a: [T; 3],
    },
}

/// What was measured.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Measured<T> {
    /// Each shunt's offset, A (subtract from its readings).
    pub offsets_a: [T; 3],
    /// Phase resistance, Ω.
    pub resistance_ohm: T,
    /// Phase inductance, H.
    pub inductance_h: T,
}

/// Why the measurement stopped.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CommissioningError {
    /// A reading was NaN or infinite.
    NotFinite,
    /// A sensor's offset is past the largest one allowed (a broken amplifier).
    Offset {
        /// The phase, 0 to 2.
        phase: u8,
        /// Its offset, A.
        offset_a: f32,
    },
    /// The test voltage reached its ceiling before the current flowed: an open
    /// phase or a broken connection.
    OpenPhase,
    /// The resistance is outside the expected range (a shorted winding, another
    /// motor).
    Resistance {
        /// What was measured, Ω.
        measured_ohm: f32,
    },
    /// The inductance is outside the expected range (or could not be found).
    Inductance {
        /// What was measured, H (NaN when the current did not decay as an RL
        /// circuit's).
        measured_h: f32,
    },
}

/// Where the measurement is.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Progress<T> {
    /// Going on: do this.
    Running(Command<T>),
    /// Finished.
    Done(Measured<T>),
    /// Stopped: turn the bridge off.
    Failed(CommissioningError),
}

#[derive(Copy, Clone, Debug, PartialEq)]
enum Stage {
    Offsets,
    Resistance,
    Inductance,
    Over,
}

/// The measurement in progress.
#[derive(Clone, Debug)]
pub struct Commissioning<T> {
    config: CommissioningConfig,
    period_s: f64,
    /// Integral gain of the resistance's controller per period, V/A.
    gain: T,
    stage: Stage,
    count: u32,
    offsets: [T; 3],
    /// The resistance's controller's voltage, V.
    voltage: T,
    /// Σ v_α, Σ i_α over the averaged quarter.
    sums: [T; 2],
    resistance: T,
    /// Least squares of a: Σ x·y, Σ x², with x = i_k − V_k/R, y = i_{k+1} − V_k/R.
    decay: [T; 2],
    /// The last sample's i_α and the voltage commanded at it.
    last: Option<(T, T)>,
    /// The voltage commanded at the sample before.
    before: Option<T>,
}

impl<T: Float> Commissioning<T> {
    /// A measurement per `config` at a PWM period of `period_s`.
    ///
    /// Errors: a count of zero, a value not finite and positive, a range whose ends
    /// are out of order.
    pub fn new(config: &CommissioningConfig, period_s: f64) -> Result<Self, ConfigError> {
        for (name, n) in [
            ("offset_periods", config.offset_periods),
            ("resistance_periods", config.resistance_periods),
            ("inductance_periods", config.inductance_periods),
        ] {
            positive(name, f64::from(n))?;
        }
        positive("max_offset_a", config.max_offset_a)?;
        positive("test_current_a", config.test_current_a)?;
        positive("max_test_voltage_v", config.max_test_voltage_v)?;
        positive("inductance_voltage_v", config.inductance_voltage_v)?;
        for (name, (lo, hi)) in [
            ("resistance_range_ohm", config.resistance_range_ohm),
            ("inductance_range_h", config.inductance_range_h),
        ] {
            // Both ends positive and in order.
            in_range(name, hi, positive(name, lo)?, f64::MAX)?;
        }
        let period = positive("period_s", period_s)?;
        // The controller's loop is gain/R per period: 20 Hz at the highest resistance.
        let gain = config.resistance_range_ohm.1 * 2.0 * core::f64::consts::PI * 20.0 * period;
        Ok(Self {
            config: *config,
            period_s: period,
            gain: lit(gain),
            stage: Stage::Offsets,
            count: 0,
            offsets: [T::zero(); 3],
            voltage: T::zero(),
            sums: [T::zero(); 2],
            resistance: T::zero(),
            decay: [T::zero(); 2],
            last: None,
            before: None,
        })
    }

    /// One period with the raw shunt currents `raw_a` (module docs).
    pub fn step(&mut self, raw_a: [T; 3]) -> Progress<T> {
        if self.stage == Stage::Over {
            return Progress::Failed(CommissioningError::NotFinite);
        }
        if !raw_a.iter().all(|i| i.is_finite()) {
            return self.fail(CommissioningError::NotFinite);
        }
        let c = &self.config;
        self.count += 1;
        match self.stage {
            Stage::Offsets => {
                for (o, &i) in self.offsets.iter_mut().zip(&raw_a) {
                    *o += i;
                }
                if self.count < c.offset_periods {
                    return Progress::Running(Command::BridgeOff);
                }
                let n = lit::<T>(f64::from(c.offset_periods));
                for (phase, o) in self.offsets.iter_mut().enumerate() {
                    *o /= n;
                    if o.abs() > lit(c.max_offset_a) {
                        let offset_a = to_f64(*o) as f32;
                        return self.fail(CommissioningError::Offset {
                            phase: phase as u8,
                            offset_a,
                        });
                    }
                }
                self.next(Stage::Resistance);
                self.voltage_command(raw_a, T::zero())
            }
            Stage::Resistance => {
                let i_alpha = self.alpha(raw_a);
                self.voltage += self.gain * (lit::<T>(c.test_current_a) - i_alpha);
                if self.voltage.abs() > lit(c.max_test_voltage_v) {
                    return self.fail(CommissioningError::OpenPhase);
                }
                if self.count > c.resistance_periods - c.resistance_periods / 4 {
                    self.sums[0] += self.voltage;
                    self.sums[1] += i_alpha;
                }
                if self.count < c.resistance_periods {
                    return self.voltage_command(raw_a, self.voltage);
                }
                self.resistance = self.sums[0] / self.sums[1];
                let r = to_f64(self.resistance);
                let (lo, hi) = c.resistance_range_ohm;
                if !(lo..=hi).contains(&r) {
                    return self.fail(CommissioningError::Resistance {
                        measured_ohm: r as f32,
                    });
                }
                self.next(Stage::Inductance);
                self.voltage_command(raw_a, self.voltage)
            }
            Stage::Inductance => {
                let i_alpha = self.alpha(raw_a);
                // The interval from the last sample to this one saw one voltage when
                // the two commands before this sample agree.
                if let (Some((i_last, v_last)), Some(v_before)) = (self.last, self.before) {
                    if v_last == v_before {
                        let level = v_last / self.resistance;
                        let (x, y) = (i_last - level, i_alpha - level);
                        self.decay[0] += x * y;
                        self.decay[1] += x * x;
                    }
                }
                let half = (self.count / 2) % 2 == 0;
                let swing = lit::<T>(c.inductance_voltage_v);
                let v = self.voltage + if half { swing } else { -swing };
                self.before = self.last.map(|(_, v)| v);
                self.last = Some((i_alpha, v));
                if self.count < c.inductance_periods {
                    return self.voltage_command(raw_a, v);
                }
                let a = to_f64(self.decay[0] / self.decay[1]);
                let r = to_f64(self.resistance);
                let l = -r * self.period_s / libm::log(a);
                let (lo, hi) = c.inductance_range_h;
                if !(lo..=hi).contains(&l) {
                    return self.fail(CommissioningError::Inductance {
                        measured_h: l as f32,
                    });
                }
                self.stage = Stage::Over;
                Progress::Done(Measured {
                    offsets_a: self.offsets,
                    resistance_ohm: self.resistance,
                    inductance_h: lit(l),
                })
            }
            Stage::Over => Progress::Failed(CommissioningError::NotFinite),
        }
    }

    fn next(&mut self, stage: Stage) {
        self.stage = stage;
        self.count = 0;
    }

    fn fail(&mut self, error: CommissioningError) -> Progress<T> {
        self.stage = Stage::Over;
        Progress::Failed(error)
    }

    /// The raw currents less the offsets.
    fn corrected(&self, raw_a: [T; 3]) -> [T; 3] {
        let mut i = raw_a;
        for (i, o) in i.iter_mut().zip(&self.offsets) {
            *i -= *o;
        }
        i
    }

    /// i_α of the raw currents (Clarke, amplitude-invariant).
    fn alpha(&self, raw_a: [T; 3]) -> T {
        let [a, b, c] = self.corrected(raw_a);
        (a + a - b - c) * lit(1.0 / 3.0)
    }

    fn voltage_command(&self, raw_a: [T; 3], v_alpha: T) -> Progress<T> {
        Progress::Running(Command::Voltage {
            alpha_beta_v: [v_alpha, T::zero()],
            currents_a: self.corrected(raw_a),
        })
    }
}

#[cfg(test)]
mod tests;
