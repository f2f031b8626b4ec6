//! Field-oriented current control of a three-phase permanent-magnet motor: the force
//! command of the position loop becomes phase currents, closed at the PWM rate
//! (docs/control.md §30).
//!
//! One step per PWM period, from the phase currents sampled at the PWM centre:
//!
//! 1. the shunt currents, the one a too-short low-side pulse left unreadable rebuilt
//!    from the other two (the three sum to zero);
//! 2. Clarke (amplitude-invariant) and Park with the electrical angle at the sample;
//! 3. d/q PI with the motor's resistance cancelled (zero at R/L, crossover ω_c), the
//!    speed voltages fed forward (−ω_e L i_q on d, ω_e L i_d + back-EMF on q);
//! 4. the voltage limited to what the bridge can make with two shunts readable,
//!    the integrators tracking the limited voltage (no wind-up);
//! 5. inverse Park at the angle the voltage acts at: it is loaded at the timer's
//!    update half a period after the sample and held for a period, so on average it
//!    acts one period after the sample;
//! 6. space-vector duties (min-max common mode), the common mode lowered where a
//!    second phase's low-side pulse would be too short, and each phase's dead-time
//!    loss added back in the direction of its current.
//!
//! Coefficients ([`Foc`]) are apart from the state ([`FocState`]); the angle comes in
//! as its sine and cosine ([`ElectricalAngle`]), so a board can take them from its
//! CORDIC. A step with an input that is not finite is refused and changes nothing:
//! the caller turns the bridge off. Generic over [`Float`] (`f32` on the board).

use crate::error::{coefficient, in_range, positive, ConfigError};
use crate::scalar::{lit, Float};
use core::f64::consts::PI;

/// A three-phase motor's windings (star, per phase) and magnets, SI.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MotorWindings {
    /// Phase resistance R, Ω (half the terminal resistance phase to phase).
    pub resistance_ohm: f64,
    /// Phase inductance L, H (d and q alike: the coil is ironless).
    pub inductance_h: f64,
    /// Force per ampere of i_q (amplitude-invariant: i_q is the phase current's
    /// amplitude), N/A. The back-EMF follows by power balance: e_q = (2/3)·K_f·v.
    pub force_constant_n_per_a: f64,
    /// One electrical period of the magnets along the travel, m.
    pub pitch_m: f64,
}

impl MotorWindings {
    /// The Keops slave's Faulhaber LM1247: 18 mm pitch (the Hall sensors'), the rest
    /// assumptions of the series' order, not read from a data sheet here: terminal
    /// resistance 10.5 Ω and inductance 0.72 mH phase to phase (so 5.25 Ω and
    /// 0.36 mH per phase, L/R = 69 µs), force constant 9.9 N/A, so that the 3.6 N
    /// continuous force takes 0.36 A.
    pub const LM1247: Self = Self {
        resistance_ohm: 5.25,
        inductance_h: 0.36e-3,
        force_constant_n_per_a: 9.9,
        pitch_m: 0.018,
    };
}

/// The bridge and its sensing.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PowerStage {
    /// PWM frequency, Hz: the current loop runs once per PWM period.
    pub pwm_hz: f64,
    /// Dead time between a leg's two switches, s.
    pub dead_time_s: f64,
    /// Shortest low-side on time in which a shunt reads, s (the op-amp's settling and
    /// the ADC's sampling time).
    pub min_low_side_s: f64,
    /// Largest phase current the loop commands, A (the amplitude, i_q).
    pub current_limit_a: f64,
}

impl PowerStage {
    /// A stage for the LM1247 at 20 kHz: 200 ns dead time, 1.5 µs for the shunt
    /// amplifier to settle and the ADC to sample, 1.1 A (the LM1247's peak force).
    pub const KEOPS: Self = Self {
        pwm_hz: 20_000.0,
        dead_time_s: 200e-9,
        min_low_side_s: 1.5e-6,
        current_limit_a: 1.1,
    };
}

/// A current loop's configuration.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FocConfig {
    /// The motor.
    pub motor: MotorWindings,
    /// The bridge.
    pub stage: PowerStage,
    /// Crossover of the current loop, Hz (the PI cancels R/L, so the open loop is
    /// ω_c/s behind the one-period delay).
    pub current_bandwidth_hz: f64,
}

impl FocConfig {
    /// The Keops slave's carriages: crossover 2 kHz (the current loop the drive
    /// model assumed), a phase margin of 54° at 20 kHz.
    pub const KEOPS: Self = Self {
        motor: MotorWindings::LM1247,
        stage: PowerStage::KEOPS,
        current_bandwidth_hz: 2000.0,
    };

    /// Phase margin of the loop, degrees: 90° less the delay's phase at crossover.
    pub fn phase_margin_deg(&self) -> f64 {
        let delay_s = DELAY_PERIODS / self.stage.pwm_hz;
        90.0 - 2.0 * PI * self.current_bandwidth_hz * delay_s * 180.0 / PI
    }
}

/// Periods between a current sample and the middle of the PWM period that applies
/// its voltage: loaded at the update half a period after the sample, held a period.
const DELAY_PERIODS: f64 = 1.0;

/// The least phase margin a configuration may leave, degrees (below it the step
/// response rings; at 0 the loop oscillates).
pub const MIN_PHASE_MARGIN_DEG: f64 = 30.0;

/// Current below which the dead-time compensation is proportional rather than the
/// full pulse (its sign is unsure near zero), as a fraction of the current limit.
const DEAD_TIME_BAND: f64 = 0.02;

/// The electrical angle as its sine and cosine.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ElectricalAngle<T> {
    /// sin θ_e.
    pub sin: T,
    /// cos θ_e.
    pub cos: T,
}

impl<T: Float> ElectricalAngle<T> {
    /// The angle `theta_rad`.
    pub fn from_rad(theta_rad: T) -> Self {
        let (sin, cos) = theta_rad.fsin_cos();
        Self { sin, cos }
    }

    /// The angle advanced by `delta_rad`, small (|δ| ≤ 0.3 rad: the series to δ⁴
    /// errs below 3e-6).
    fn advanced(self, delta_rad: T) -> Self {
        let d2 = delta_rad * delta_rad;
        let s = delta_rad * (T::one() - d2 * lit(1.0 / 6.0));
        let c = T::one() - d2 * (lit::<T>(0.5) - d2 * lit(1.0 / 24.0));
        Self {
            sin: self.sin * c + self.cos * s,
            cos: self.cos * c - self.sin * s,
        }
    }
}

/// One period's measurements and command.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FocInput<T> {
    /// Phase currents from the shunts at the PWM centre, A (into the motor).
    pub phase_currents_a: [T; 3],
    /// The electrical angle at the sample.
    pub angle: ElectricalAngle<T>,
    /// The mover's speed, m/s.
    pub speed_m_s: T,
    /// Force commanded by the position loop, N.
    pub force_n: T,
    /// The bus voltage, V.
    pub bus_v: T,
}

/// What a step commands and what it saw.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FocOutput<T> {
    /// Duty of each phase's high side, 0 to 1.
    pub duties: [T; 3],
    /// Which shunts the next sample can read (a low-side pulse long enough).
    pub readable: [bool; 3],
    /// Measured i_d, i_q, A.
    pub current_dq_a: [T; 2],
    /// Applied v_d, v_q, V.
    pub voltage_dq_v: [T; 2],
    /// The voltage was limited (the bridge could not make the PI's).
    pub limited: bool,
}

/// Why a step was refused.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FocError {
    /// An input is NaN or infinite.
    NotFinite,
    /// The bus voltage is not above zero.
    NoBus,
    /// The angle's sine and cosine are not a unit vector (off by more than 5 %).
    BadAngle,
    /// The angle moved more than [`MAX_ANGLE_STEP_RAD`] from where the last sample and
    /// the speed put it: a Hall sensor or its decoding failed.
    AngleJump,
}

/// The most the electrical angle may differ from the last sample's advanced by the
/// speed, rad: 0.5 rad is 1.4 mm of unexplained motion in a period at an 18 mm pitch
/// (28 m/s at 20 kHz), far past any carriage.
pub const MAX_ANGLE_STEP_RAD: f64 = 0.5;

/// The loop's coefficients in `T`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Foc<T> {
    /// Kp = L·ω_c, V/A.
    kp: T,
    /// Ki·Ts = R·ω_c·Ts, V/A.
    ki_ts: T,
    /// L, H (the speed voltages).
    inductance: T,
    /// (2/3)·K_f, V·s/m (the back-EMF on q).
    back_emf_per_m_s: T,
    /// 1/K_f, A/N.
    amperes_per_newton: T,
    /// 2π/pitch, rad/m.
    rad_per_m: T,
    /// The delay from sample to voltage, s.
    delay_s: T,
    /// t_dead/T.
    dead_duty: T,
    /// 1 / the current below which the dead-time compensation is proportional, 1/A.
    per_dead_band_a: T,
    /// 1 − t_min/T: the highest duty whose shunt still reads.
    readable_duty: T,
    current_limit: T,
    /// The PWM period, s.
    period_s: T,
    /// cos [`MAX_ANGLE_STEP_RAD`].
    min_angle_agreement: T,
}

/// A loop's integrators and what the last step left for the next sample.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FocState<T> {
    /// The d and q integrators, V.
    pub integral_v: [T; 2],
    /// Which shunts read in the period the next sample is taken in.
    pub readable: [bool; 3],
    /// Where the last sample and the speed put the next sample's angle (`None` before
    /// the first step).
    pub expected_angle: Option<ElectricalAngle<T>>,
}

impl<T: Float> Default for FocState<T> {
    fn default() -> Self {
        Self {
            integral_v: [T::zero(); 2],
            readable: [true; 3],
            expected_angle: None,
        }
    }
}

/// √3 and its inverse.
const SQRT_3: f64 = 1.732_050_807_568_877_2;

impl<T: Float> Foc<T> {
    /// The coefficients of `config`.
    ///
    /// Errors: a value not finite and positive; a dead time or shunt pulse that leaves
    /// less than half the period; a crossover whose phase margin behind the loop's
    /// delay is below [`MIN_PHASE_MARGIN_DEG`] (`current_bandwidth_hz`); a coefficient
    /// `T` cannot hold.
    pub fn new(config: &FocConfig) -> Result<Self, ConfigError> {
        let m = &config.motor;
        let s = &config.stage;
        let r = positive("resistance_ohm", m.resistance_ohm)?;
        let l = positive("inductance_h", m.inductance_h)?;
        let kf = positive("force_constant_n_per_a", m.force_constant_n_per_a)?;
        let pitch = positive("pitch_m", m.pitch_m)?;
        let period = 1.0 / positive("pwm_hz", s.pwm_hz)?;
        let dead = in_range("dead_time_s", s.dead_time_s, 0.0, 0.25 * period)?;
        let pulse = in_range("min_low_side_s", s.min_low_side_s, 0.0, 0.25 * period)?;
        let limit = positive("current_limit_a", s.current_limit_a)?;
        let wc = 2.0 * PI * positive("current_bandwidth_hz", config.current_bandwidth_hz)?;
        if config.phase_margin_deg() < MIN_PHASE_MARGIN_DEG {
            return Err(ConfigError::out_of_range("current_bandwidth_hz"));
        }
        Ok(Self {
            kp: coefficient("inductance_h", l * wc)?,
            ki_ts: coefficient("resistance_ohm", r * wc * period)?,
            inductance: coefficient("inductance_h", l)?,
            back_emf_per_m_s: coefficient("force_constant_n_per_a", 2.0 / 3.0 * kf)?,
            amperes_per_newton: coefficient("force_constant_n_per_a", 1.0 / kf)?,
            rad_per_m: coefficient("pitch_m", 2.0 * PI / pitch)?,
            delay_s: coefficient("pwm_hz", DELAY_PERIODS * period)?,
            dead_duty: lit(dead / period),
            per_dead_band_a: coefficient("current_limit_a", 1.0 / (DEAD_TIME_BAND * limit))?,
            readable_duty: lit(1.0 - pulse / period),
            current_limit: coefficient("current_limit_a", limit)?,
            period_s: coefficient("pwm_hz", period)?,
            min_angle_agreement: lit(libm::cos(MAX_ANGLE_STEP_RAD)),
        })
    }

    /// One PWM period (module docs). Errors ([`FocError`]): an input not finite, no
    /// bus voltage, an angle that is not one or jumped; the state is then left as it
    /// was, and the bridge is the caller's to turn off (a fresh [`FocState`] starts
    /// again).
    pub fn step(
        &self,
        state: &mut FocState<T>,
        input: &FocInput<T>,
    ) -> Result<FocOutput<T>, FocError> {
        // One test for all: a NaN or an infinity in any input makes the sum one (so
        // would inputs near the scalar's largest value, which are no measurement).
        let [i_a, i_b, i_c] = input.phase_currents_a;
        let sum = i_a + i_b + i_c + input.angle.sin + input.angle.cos;
        if !(sum + input.speed_m_s + input.force_n + input.bus_v).is_finite() {
            return Err(FocError::NotFinite);
        }
        if input.bus_v <= T::zero() {
            return Err(FocError::NoBus);
        }
        let angle = input.angle;
        let radius2 = angle.sin * angle.sin + angle.cos * angle.cos;
        if (radius2 - T::one()).abs() > lit(0.1) {
            return Err(FocError::BadAngle);
        }
        if let Some(expected) = state.expected_angle {
            // cos of the difference, against cos of the largest step.
            let agreement = expected.cos * angle.cos + expected.sin * angle.sin;
            if agreement < self.min_angle_agreement {
                return Err(FocError::AngleJump);
            }
        }
        let [i_a, i_b, i_c] = rebuilt(input.phase_currents_a, state.readable);
        // Clarke, amplitude-invariant, then Park.
        let i_alpha = (i_a + i_a - i_b - i_c) * lit(1.0 / 3.0);
        let i_beta = (i_b - i_c) * lit(1.0 / SQRT_3);
        let (s, c) = (input.angle.sin, input.angle.cos);
        let i_d = c * i_alpha + s * i_beta;
        let i_q = c * i_beta - s * i_alpha;
        let i_q_ref = (input.force_n * self.amperes_per_newton).clamp_abs(self.current_limit);
        let omega = input.speed_m_s * self.rad_per_m;
        let [int_d, int_q] = state.integral_v;
        let (e_d, e_q) = (-i_d, i_q_ref - i_q);
        let v_d = self.kp * e_d + int_d - omega * self.inductance * i_q;
        let v_q = self.kp * e_q
            + int_q
            + omega * self.inductance * i_d
            + self.back_emf_per_m_s * input.speed_m_s;
        let applied = input.angle.advanced(omega * self.delay_s);
        let per_bus = T::one() / input.bus_v;
        let (v_phase, sorted, scale) = self.phase_voltages(v_d, v_q, applied, input.bus_v);
        let (v_d_out, v_q_out) = (v_d * scale, v_q * scale);
        // Reference currents at the applied angle: the dead-time loss's sign.
        let i_ref = phases(-applied.sin * i_q_ref, applied.cos * i_q_ref);
        let duties = self.duties(v_phase, sorted, i_ref, per_bus);
        let readable = duties.map(|d| d <= self.readable_duty);
        state.integral_v = [
            int_d + self.ki_ts * e_d + (v_d_out - v_d),
            int_q + self.ki_ts * e_q + (v_q_out - v_q),
        ];
        state.readable = readable;
        state.expected_angle = Some(angle.advanced(omega * self.period_s));
        Ok(FocOutput {
            duties,
            readable,
            current_dq_a: [i_d, i_q],
            voltage_dq_v: [v_d_out, v_q_out],
            limited: scale < T::one(),
        })
    }

    /// Duties that make the stationary voltage `v_alpha_beta_v` on `bus_v` (limited as
    /// in [`Foc::step`]), the dead time added back along `phase_currents_a`: for the
    /// voltages a caller injects itself ([`commissioning`]).
    pub fn duties_for(&self, v_alpha_beta_v: [T; 2], phase_currents_a: [T; 3], bus_v: T) -> [T; 3] {
        let unrotated = ElectricalAngle {
            sin: T::zero(),
            cos: T::one(),
        };
        let [v_alpha, v_beta] = v_alpha_beta_v;
        let (v_phase, sorted, _) = self.phase_voltages(v_alpha, v_beta, unrotated, bus_v);
        self.duties(v_phase, sorted, phase_currents_a, T::one() / bus_v)
    }

    /// The phase voltages of (v_d, v_q) at `angle`, and the factor (≤ 1) they were
    /// scaled by to fit the bridge: the line voltages within the bus, and the middle
    /// phase within `readable_duty` of the bus above the lowest, so that two shunts
    /// always read (with room for the dead-time compensation).
    /// Also the phases from lowest to highest (scaled alike).
    fn phase_voltages(
        &self,
        v_d: T,
        v_q: T,
        angle: ElectricalAngle<T>,
        bus: T,
    ) -> ([T; 3], [T; 3], T) {
        let v_alpha = angle.cos * v_d - angle.sin * v_q;
        let v_beta = angle.sin * v_d + angle.cos * v_q;
        let v = phases(v_alpha, v_beta);
        let [lo, mid, hi] = sorted(v);
        let room = self.readable_duty - self.dead_duty - self.dead_duty;
        let mut scale = T::one();
        if hi - lo > bus {
            scale = bus / (hi - lo);
        }
        if (mid - lo) * scale > room * bus {
            scale = room * bus / (mid - lo);
        }
        (
            v.map(|x| x * scale),
            [lo, mid, hi].map(|x| x * scale),
            scale,
        )
    }

    /// Duties of the phase voltages `v` (`sorted` from lowest to highest) on a bus of
    /// 1/`per_bus`: centred (min-max common mode, the
    /// lowest phase at ½ − (hi − lo)/2V), lowered where the middle phase's low-side
    /// pulse would be short (its duty at most `readable_duty` less a dead time, which
    /// [`Foc::phase_voltages`] left room for), each phase's dead time added back along
    /// its reference current `i_ref`, within [0, 1].
    fn duties(&self, v: [T; 3], sorted: [T; 3], i_ref: [T; 3], per_bus: T) -> [T; 3] {
        let [lo, mid, hi] = sorted;
        let centred = lit::<T>(0.5) - (hi - lo) * per_bus * lit(0.5);
        let lowest = centred.min(self.readable_duty - self.dead_duty - (mid - lo) * per_bus);
        let mut duties = v;
        for (d, &i) in duties.iter_mut().zip(&i_ref) {
            let share = (i * self.per_dead_band_a).max(-T::one()).min(T::one());
            *d = (lowest + (*d - lo) * per_bus + share * self.dead_duty)
                .max(T::zero())
                .min(T::one());
        }
        duties
    }
}

/// The three phases of (α, β): a, b = −α/2 + (√3/2)β, c = −α/2 − (√3/2)β.
fn phases<T: Float>(alpha: T, beta: T) -> [T; 3] {
    let half_alpha = alpha * lit(0.5);
    let beta_part = beta * lit(SQRT_3 / 2.0);
    [alpha, beta_part - half_alpha, -half_alpha - beta_part]
}

/// (lowest, middle, highest) of three values.
fn sorted<T: Float>([a, b, c]: [T; 3]) -> [T; 3] {
    let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
    if c <= lo {
        [c, lo, hi]
    } else if c >= hi {
        [lo, hi, c]
    } else {
        [lo, c, hi]
    }
}

/// The phase currents with an unreadable one rebuilt from the other two (they sum to
/// zero in a star without neutral). With two or none unreadable, which the duties
/// never leave, the samples are taken as they are.
fn rebuilt<T: Float>(i: [T; 3], readable: [bool; 3]) -> [T; 3] {
    let [a, b, c] = i;
    match readable {
        [false, true, true] => [-(b + c), b, c],
        [true, false, true] => [a, -(a + c), c],
        [true, true, false] => [a, b, -(a + b)],
        _ => i,
    }
}

pub mod commissioning;
pub mod winding_heat;

#[cfg(test)]
mod test_motor;
#[cfg(test)]
mod tests;
