//! Discrete PID with back-calculation anti-windup, output saturation and a rate limit
//! (docs/control.md §25, G 4.1 eq. 12; anti-windup A 3.2 with the sign **CORRECTION**
//! of docs/control.md §26).
//!
//! One channel, error e = reference − measurement (G ch. 4: "the error is defined as
//! the difference between reference normal force and the actual normal force"),
//! period Ts. With the proposed command u_k, the applied command c_k (after
//! saturation, then the rate limit) and a first-order derivative filter of time
//! constant τ (backward Euler, stable for every τ ≥ 0):
//!
//!   D_k = (τ D_{k−1} + Kd (e_k − e_{k−1})) / (τ + Ts)
//!   u_k = Kp e_k + I_k + D_k
//!   c_k = rate_limit(sat(u_k))          sat to [min, max], then |c_k − c_{k−1}| ≤ R Ts
//!   I_{k+1} = I_k + Ts (Ki e_k + Kaw (c_k − u_k))
//!
//! The integrator is forward Euler (I_k holds the errors up to k − 1), the discrete
//! form of eq. 12's K/(T_I s) that Simulink's PID block uses by default, which is
//! where G's gains were tuned (G 5.3). Back-calculation: while the command is
//! limited, c − u has the sign that pulls the integrator back toward the limit
//! (**CORRECTION** of the print, whose sign pushes it further), at the rate Kaw.
//!
//! Coefficients ([`Pid`]) are apart from the state ([`PidState`]), so one gain set
//! drives any number of channels. The step is split so that a caller that limits or
//! transforms the command itself (the hybrid force loop limits the piezo *position*;
//! the redundant robot's n-channel PID projects the commands and the integrators with
//! Rm = Jm Jm⁺ between the steps) reuses the same law: [`Pid::propose`] gives u_k,
//! the caller applies c_k, and [`Pid::settle`] integrates with the c_k applied.
//! [`Pid::update`] does the three with this channel's own limits.
//!
//! Only `+ − ×` and comparisons run per period, so the law is generic over
//! [`Real`] (`f32`, `f64`, [`Q31_32`](crate::scalar::Q31_32)).

use crate::error::{coefficient, coefficient_or_zero, in_range, positive, ConfigError};
use crate::scalar::Real;

/// Lower and upper bound of the command, in the command's unit.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct OutputLimits {
    /// Smallest command.
    pub min: f64,
    /// Largest command (≥ `min`).
    pub max: f64,
}

/// PID gains and limits in SI units (the error's unit e, the command's unit c).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PidConfig {
    /// Proportional gain Kp, c per e. Any finite sign.
    pub kp: f64,
    /// Integral gain Ki, c per (e·s). Any finite sign (see [`PidConfig::GRINDING_SEED`]).
    pub ki_per_s: f64,
    /// Derivative gain Kd, c·s per e. Any finite sign.
    pub kd_s: f64,
    /// Time constant τ of the derivative's first-order filter, s (0: plain backward
    /// difference).
    pub derivative_filter_s: f64,
    /// Back-calculation gain Kaw, 1/s: the integrator relaxes toward the limited command
    /// with time constant 1/Kaw. 0 turns anti-windup off; Kaw·Ts ≤ 1 (a larger gain
    /// overshoots the limit in one period).
    pub anti_windup_per_s: f64,
    /// Saturation of the command (`None`: unlimited).
    pub limits: Option<OutputLimits>,
    /// Largest change of the command per second, c/s (`None`: unlimited).
    pub rate_limit_per_s: Option<f64>,
}

impl PidConfig {
    /// G's grinding force law, tuned by genetic algorithm (G 7.1): Kp 84.06,
    /// Kd 14.1, Ki −0.01766, error in N, command the piezo position increment per
    /// period (G ch. 7: "Control Input is the amount of change in the piezo position").
    ///
    /// G prints neither the command's unit nor the derivative filter, nor an
    /// anti-windup gain; it prints Ki negative. What the print supports:
    /// - The error sign is stated (reference − actual) and Kp, Kd are positive, so a
    ///   flipped error convention does not explain the sign: Ki is kept as printed.
    /// - The command is an *increment*, integrated into the piezo position, so Ki acts
    ///   on the double sum of the error. With a force proportional to the position
    ///   (contact stiffness k) and x' = u/Ts, the closed loop's characteristic
    ///   polynomial is (Ts + k Kd) s² + k Kp s + k Ki: Ki < 0 gives one real unstable
    ///   root s ≈ −Ki/Kp = 2.1e-4 s⁻¹ (time constant ≈ 79 min, whatever k), against a
    ///   pass of a few minutes at G's 0.1 mm/s. The negative gain is therefore a
    ///   harmless artefact of an unconstrained search — provided Ki multiplies Ts in
    ///   the integrator as here (Simulink's convention). Without the Ts factor the
    ///   same root would be 0.21 s⁻¹ and G's experiments would have drifted
    ///   visibly within seconds.
    /// - Derivative filter: Simulink's PID block default N = 100 s⁻¹, τ = 1/N = 10 ms.
    /// - Anti-windup: Kaw = 100 s⁻¹ (the integrator follows a limit within 10 ms);
    ///   with G's |Ki| it is never the limiting factor.
    /// - Limits: none here; the hybrid force loop limits the piezo position and rate
    ///   (G ch. 7, fig. 42), not the increment.
    pub const GRINDING_SEED: Self = Self {
        kp: 84.06,
        ki_per_s: -0.01766,
        kd_s: 14.1,
        derivative_filter_s: 0.01,
        anti_windup_per_s: 100.0,
        limits: None,
        rate_limit_per_s: None,
    };
}

/// PID coefficients in the scalar `T` for a fixed period; one set drives the
/// [`PidState`]s of any number of channels.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Pid<T> {
    kp: T,
    /// Ki·Ts.
    ki_ts: T,
    /// τ/(τ + Ts): the derivative filter's memory.
    d_memory: T,
    /// Kd/(τ + Ts).
    d_gain: T,
    /// Kaw·Ts.
    kaw_ts: T,
    limits: Option<(T, T)>,
    /// R·Ts: the largest change per period.
    max_step: Option<T>,
}

/// One channel's state, in the command's units (new gains take over without a jump).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PidState<T> {
    /// Integral term I_k, in the command's unit.
    pub integral: T,
    /// Filtered derivative term D_{k−1}, in the command's unit.
    pub derivative: T,
    /// Error of the last proposal e_{k−1} (after [`Pid::propose`]: e_k).
    pub error: T,
    /// Command applied last period c_{k−1} (the rate limit's reference).
    pub command: T,
}

impl<T: Real> PidState<T> {
    /// Rest: no integral, no error history, last command `command` (the value the
    /// actuator holds, so the rate limit starts from it).
    pub fn at(command: T) -> Self {
        Self {
            integral: T::ZERO,
            derivative: T::ZERO,
            error: T::ZERO,
            command,
        }
    }
}

/// One period's result of [`Pid::update`].
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PidOutput<T> {
    /// Command c_k to apply (saturated, then rate limited).
    pub command: T,
    /// What the law asked for, u_k.
    pub proposed: T,
    /// The saturation cut the proposal.
    pub saturated: bool,
    /// The rate limit cut the command.
    pub rate_limited: bool,
}

/// A bound that may be zero or negative, checked in the target scalar.
fn bound<T: Real>(name: &'static str, value: f64) -> Result<T, ConfigError> {
    crate::error::representable(name, value)
}

impl<T: Real> Pid<T> {
    /// Validates the configuration for the period `ts_s`: finite gains, τ ≥ 0,
    /// 0 ≤ Kaw·Ts ≤ 1, min ≤ max, a strictly positive rate, every coefficient
    /// representable in `T`.
    pub fn new(config: &PidConfig, ts_s: f64) -> Result<Self, ConfigError> {
        let ts = positive("period_s", ts_s)?;
        let tau = in_range("derivative_filter_s", config.derivative_filter_s, 0.0, 1e9)?;
        let kaw_ts = in_range("anti_windup_per_s", config.anti_windup_per_s, 0.0, 1.0 / ts)? * ts;
        for (name, v) in [
            ("kp", config.kp),
            ("ki_per_s", config.ki_per_s),
            ("kd_s", config.kd_s),
        ] {
            if !v.is_finite() {
                return Err(ConfigError::not_finite(name));
            }
        }
        let limits = match config.limits {
            None => None,
            Some(l) => {
                let min = bound("min", l.min).map_err(|e| e.within("limits"))?;
                let max = bound("max", l.max).map_err(|e| e.within("limits"))?;
                if l.max < l.min {
                    return Err(ConfigError::out_of_range("max").within("limits"));
                }
                Some((min, max))
            }
        };
        let max_step = match config.rate_limit_per_s {
            None => None,
            Some(rate) => Some(coefficient(
                "rate_limit_per_s",
                positive("rate_limit_per_s", rate)? * ts,
            )?),
        };
        Ok(Self {
            kp: coefficient_or_zero("kp", config.kp)?,
            ki_ts: coefficient_or_zero("ki_per_s", config.ki_per_s * ts)?,
            d_memory: coefficient_or_zero("derivative_filter_s", tau / (tau + ts))?,
            d_gain: coefficient_or_zero("kd_s", config.kd_s / (tau + ts))?,
            kaw_ts: coefficient_or_zero("anti_windup_per_s", kaw_ts)?,
            limits,
            max_step,
        })
    }

    /// u_k = Kp e_k + I_k + D_k for the error `error` = reference − measurement; updates
    /// the derivative filter and remembers e_k for [`Pid::settle`].
    ///
    /// NaN in passes through (a kernel of the period: the caller checks its inputs,
    /// as the hybrid force loop does).
    #[inline]
    pub fn propose(&self, state: &mut PidState<T>, error: T) -> T {
        state.derivative = self.d_memory * state.derivative + self.d_gain * (error - state.error);
        state.error = error;
        self.kp * error + state.integral + state.derivative
    }

    /// Integrates the period: I ← I + Ts (Ki e_k + Kaw (c_k − u_k)), with the proposal
    /// u_k of [`Pid::propose`] and the command c_k actually applied, which becomes the
    /// rate limit's reference.
    #[inline]
    pub fn settle(&self, state: &mut PidState<T>, proposed: T, applied: T) {
        state.integral =
            state.integral + self.ki_ts * state.error + self.kaw_ts * (applied - proposed);
        state.command = applied;
    }

    /// This channel's limits on a proposal, from the last command `previous`:
    /// saturation, then the rate limit. Returns (command, saturated, rate limited).
    #[inline]
    pub fn limit(&self, previous: T, proposed: T) -> (T, bool, bool) {
        let (mut command, mut saturated) = (proposed, false);
        if let Some((min, max)) = self.limits {
            if command > max {
                (command, saturated) = (max, true);
            } else if command < min {
                (command, saturated) = (min, true);
            }
        }
        let mut rate_limited = false;
        if let Some(step) = self.max_step {
            let change = command - previous;
            if change > step || change < -step {
                command = previous + change.clamp_abs(step);
                rate_limited = true;
            }
        }
        (command, saturated, rate_limited)
    }

    /// One period with this channel's own limits: [`Pid::propose`], [`Pid::limit`],
    /// [`Pid::settle`].
    #[inline]
    pub fn update(&self, state: &mut PidState<T>, error: T) -> PidOutput<T> {
        let proposed = self.propose(state, error);
        let (command, saturated, rate_limited) = self.limit(state.command, proposed);
        self.settle(state, proposed, command);
        PidOutput {
            command,
            proposed,
            saturated,
            rate_limited,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    const TS: f64 = 1e-3;

    fn cfg() -> PidConfig {
        PidConfig {
            kp: 2.0,
            ki_per_s: 30.0,
            kd_s: 0.05,
            derivative_filter_s: 0.004,
            anti_windup_per_s: 0.0,
            limits: None,
            rate_limit_per_s: None,
        }
    }

    /// Deterministic pseudo-random sequence in [−1, 1).
    fn noise(n: usize, seed: u64) -> Vec<f64> {
        let mut x = seed;
        (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
            })
            .collect()
    }

    /// Reference: the same law as one rational transfer function in z⁻¹,
    ///   C(z) = Kp + Ki Ts z⁻¹/(1 − z⁻¹) + c (1 − z⁻¹)/(1 − a z⁻¹),
    /// a = τ/(τ+Ts), c = Kd/(τ+Ts), over the common denominator (1 − z⁻¹)(1 − a z⁻¹),
    /// run as one direct-form difference equation. Agreement to 1e-9 relative (f64
    /// rounding over 2000 steps of a marginally stable recursion).
    #[test]
    fn matches_the_transfer_function_as_a_difference_equation() {
        let c = cfg();
        let pid = Pid::<f64>::new(&c, TS).unwrap();
        let tau = c.derivative_filter_s;
        let a = tau / (tau + TS);
        let d = c.kd_s / (tau + TS);
        let kits = c.ki_per_s * TS;
        let n0 = c.kp + d;
        let n1 = -c.kp * (1.0 + a) + kits - 2.0 * d;
        let n2 = c.kp * a - kits * a + d;
        let e = noise(2000, 7);
        let mut state = PidState::at(0.0);
        let (mut u1, mut u2, mut e1, mut e2) = (0.0, 0.0, 0.0, 0.0);
        let mut worst = 0.0f64;
        for &ek in &e {
            let got = pid.update(&mut state, ek).command;
            let want = (1.0 + a) * u1 - a * u2 + n0 * ek + n1 * e1 + n2 * e2;
            (u2, u1, e2, e1) = (u1, want, e1, ek);
            worst = worst.max((got - want).abs() / (1.0 + want.abs()));
        }
        assert!(worst < 1e-9, "{worst}");
    }

    /// First-order plant y' = c (velocity actuator), command limited to ±1, reference
    /// step to 5 for 2 s then back to 0. Without anti-windup the integrator grows with
    /// the error's integral and the output overshoots 0 long after the step back; with
    /// it, the integrator stays near the limit and the recovery is fast.
    fn windup_run(kaw: f64) -> (f64, f64, usize) {
        let c = PidConfig {
            kp: 4.0,
            ki_per_s: 8.0,
            kd_s: 0.0,
            derivative_filter_s: 0.0,
            anti_windup_per_s: kaw,
            limits: Some(OutputLimits {
                min: -1.0,
                max: 1.0,
            }),
            rate_limit_per_s: None,
        };
        let pid = Pid::<f64>::new(&c, TS).unwrap();
        let mut state = PidState::at(0.0);
        let (mut y, mut peak_integral, mut undershoot) = (0.0f64, 0.0f64, 0.0f64);
        let mut settled_at = usize::MAX;
        for k in 0..12_000 {
            let r = if k < 2000 { 5.0 } else { 0.0 };
            let out = pid.update(&mut state, r - y);
            y += TS * out.command;
            peak_integral = peak_integral.max(state.integral.abs());
            if k >= 2000 {
                undershoot = undershoot.min(y);
                if y.abs() > 0.01 {
                    settled_at = usize::MAX;
                } else if settled_at == usize::MAX {
                    settled_at = k;
                }
            }
        }
        (peak_integral, undershoot, settled_at)
    }

    #[test]
    fn anti_windup_bounds_the_integrator_and_recovers_faster() {
        let (i_on, under_on, settle_on) = windup_run(100.0);
        let (i_off, under_off, settle_off) = windup_run(0.0);
        // With back-calculation the integrator cannot exceed the limit (1) plus what
        // the proportional term asks beyond it: |I| ≤ 1 + Kp·|e|max = 1 + 4·5.
        assert!(i_on <= 21.0, "{i_on}");
        // Without it, it integrates Ki·∫e over the saturated rise (e from 5 down).
        assert!(i_off > 2.0 * i_on, "{i_off} vs {i_on}");
        assert!(under_on > under_off, "{under_on} vs {under_off}");
        assert!(settle_on < settle_off, "{settle_on} vs {settle_off}");
        // The print's sign (integrator pushed further while saturated) is worse still:
        // it is what Kaw < 0 would do, which the configuration refuses.
        assert!(Pid::<f64>::new(
            &PidConfig {
                anti_windup_per_s: -100.0,
                ..cfg()
            },
            TS
        )
        .is_err());
    }

    #[test]
    fn saturation_and_rate_limit_are_honoured() {
        let c = PidConfig {
            limits: Some(OutputLimits {
                min: -0.5,
                max: 2.0,
            }),
            rate_limit_per_s: Some(100.0),
            anti_windup_per_s: 500.0,
            ..cfg()
        };
        let pid = Pid::<f32>::new(&c, TS).unwrap();
        let mut state = PidState::at(0.0f32);
        let mut previous = 0.0f32;
        let (mut saw_rate, mut saw_sat) = (false, false);
        for e in noise(5000, 3) {
            let out = pid.update(&mut state, (e * 40.0) as f32);
            // One period may move by R·Ts = 0.1 (plus f32 rounding of the sum).
            assert!((out.command - previous).abs() <= 0.1 + 1e-6, "{out:?}");
            assert!((-0.5..=2.0).contains(&out.command), "{out:?}");
            saw_rate |= out.rate_limited;
            saw_sat |= out.saturated;
            previous = out.command;
        }
        assert!(saw_rate && saw_sat);
    }

    #[test]
    fn integrates_like_a_forward_euler_integrator() {
        // Pure I with a constant error: u_k = Ki·Ts·e·k (the first command holds none).
        let c = PidConfig {
            kp: 0.0,
            ki_per_s: 10.0,
            kd_s: 0.0,
            ..cfg()
        };
        let pid = Pid::<f64>::new(&c, TS).unwrap();
        let mut state = PidState::at(0.0);
        for k in 0..100 {
            let u = pid.update(&mut state, 2.0).command;
            assert!((u - 10.0 * TS * 2.0 * k as f64).abs() < 1e-12);
        }
    }

    #[test]
    fn seed_preset_keeps_the_printed_gains() {
        let p = PidConfig::GRINDING_SEED;
        assert_eq!((p.kp, p.kd_s, p.ki_per_s), (84.06, 14.1, -0.01766));
        let pid = Pid::<f32>::new(&p, TS).unwrap();
        let mut state = PidState::at(0.0f32);
        // A negative integral gain: a constant positive error drives I down.
        for _ in 0..1000 {
            pid.update(&mut state, 1.0);
        }
        // 1000 periods of Ki·Ts·e = −1.766e-5 each; f32 rounding of the sum ≤ 1e-3 relative.
        assert!(
            (state.integral + 0.01766).abs() < 2e-5,
            "{}",
            state.integral
        );
    }

    #[test]
    fn rejects_bad_config() {
        let err = |c: PidConfig| Pid::<f32>::new(&c, TS).err();
        assert_eq!(
            err(PidConfig {
                kp: f64::NAN,
                ..cfg()
            }),
            Some(ConfigError::not_finite("kp"))
        );
        assert_eq!(
            err(PidConfig {
                anti_windup_per_s: 2000.0,
                ..cfg()
            }),
            Some(ConfigError::out_of_range("anti_windup_per_s"))
        );
        assert_eq!(
            err(PidConfig {
                limits: Some(OutputLimits { min: 1.0, max: 0.0 }),
                ..cfg()
            }),
            Some(ConfigError::out_of_range("max").within("limits"))
        );
        assert_eq!(
            err(PidConfig {
                rate_limit_per_s: Some(0.0),
                ..cfg()
            }),
            Some(ConfigError::not_positive("rate_limit_per_s"))
        );
        assert_eq!(
            err(PidConfig {
                derivative_filter_s: -1.0,
                ..cfg()
            }),
            Some(ConfigError::out_of_range("derivative_filter_s"))
        );
        assert_eq!(
            Pid::<f32>::new(&cfg(), 0.0).err(),
            Some(ConfigError::not_positive("period_s"))
        );
        // Fine in f64, beyond f32.
        let huge = PidConfig { kp: 1e300, ..cfg() };
        assert!(Pid::<f64>::new(&huge, TS).is_ok());
        assert_eq!(err(huge), Some(ConfigError::not_representable("kp")));
    }
}
