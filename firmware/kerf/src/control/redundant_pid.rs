//! PID for redundantly actuated machines (docs/control.md §26, A 3.2–3.3): N actuators
//! moving fewer degrees of freedom, regularized so that the actuators do not fight,
//! with back-calculation anti-windup.
//!
//! With more actuators than degrees of freedom, a joint error q̃ measured against
//! references from an imperfect model has a part outside the column space of Jm that
//! no motion of the machine can remove; integrated, it becomes antagonistic internal
//! forces (A 3.2.1). The regularization Rm = Jm Jm⁺ (the projector onto Jm's column
//! space: eq. 38 and 41, equal in the velocity and force spaces) is applied on the
//! input, the output and the integral state each period (A 3.2.2, eq. 43–45):
//!
//!   q̃_reg = Rm q̃,
//!   Γ_I(k) = Rm (Γ_I(k−1) + K_I Ts q̃_reg(k) + γ ΔΓ(k−1)),  γ = 1 − e^(−K_I K_AWP Ts),
//!   U = Rm (K_P q̃_reg + Γ_I + K_D (q̃_reg(k) − q̃_reg(k−1))/Ts) + Γ_ff   (eq. 46),
//!   ΔΓ = sat(U) − U.
//!
//! The back-calculation term's sign is a correction (docs/control.md §26): eq. 45 as
//! printed subtracts K_AWP ΔΓ, which with ΔΓ = sat − unsat pushes a saturated
//! integrator further; here it is added, so that a saturated output pulls its
//! integrator back. Its size: eq. 45's continuous law dΓ_I/dt = K_I (q̃ + K_AWP ΔΓ)
//! relaxes a saturated integrator at the rate K_I K_AWP, which for A table 2's
//! parallel module is 3.4·10⁴ s⁻¹: 6.8 per 0.2 ms period. Taken explicitly, K_I Ts
//! K_AWP ΔΓ, that term overshoots by a factor 5.8 each period and the integrator
//! diverges; γ is the exact decay of the continuous relaxation over one period, equal
//! to eq. 45's K_I K_AWP Ts where that is small (the turntable's 5.5·10⁻⁵) and at most
//! 1 (the whole excess removed in one period) where it is not, so the back-calculation
//! is stable for any K_AWP. ΔΓ is the previous period's (the current one exists only
//! after the output). The feedforward Γ_ff (eq. 46: the inverse dynamic model on the
//! desired motion) is added before the saturation, so the anti-windup sees the force
//! actually asked.
//!
//! Without regularization (`regularize: false`) the same law is the plain joint PID
//! of eq. 35 with anti-windup, the baseline of A 3.2.1.

use crate::error::{coefficient, coefficient_or_zero, positive, ConfigError};
use crate::scalar::Float;
use nalgebra::{SMatrix, SVector};

/// Gains of one machine part (A table 2), the force limit and the period.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct RedundantPidConfig {
    /// K_P, N/m (or N·m/rad).
    pub kp: f64,
    /// K_D, N·s/m (or N·m·s/rad).
    pub kd: f64,
    /// K_I, N/(m·s) (or N·m/(rad·s)).
    pub ki: f64,
    /// Back-calculation gain K_AWP, m/N (or rad/(N·m)).
    pub k_awp: f64,
    /// Output saturation |U_i| ≤ limit, N (or N·m).
    pub force_limit: f64,
    /// Project input, output and integral onto Jm's column space each period.
    pub regularize: bool,
}

impl RedundantPidConfig {
    /// ARROW's parallel module (A table 2), the ETEL ILM12-060's 2,500 N (A 5.1).
    pub const ARROW_PARALLEL: Self = Self {
        kp: 5_860_796.8,
        kd: 8_070.24,
        ki: 20_425_584.8,
        k_awp: 0.00166,
        force_limit: 2_500.0,
        regularize: true,
    };

    /// ARROW's turntable (A table 2), the TMB0140's 127 N·m peak torque (A 5.1).
    pub const ARROW_TURNTABLE: Self = Self {
        kp: 5_550.0,
        kd: 25.9,
        ki: 7_400.0,
        k_awp: 0.000_037,
        force_limit: 127.0,
        regularize: true,
    };
}

/// Coefficients in `T` for `N` actuators.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct RedundantPid<T> {
    kp: T,
    kd_per_ts: T,
    ki_ts: T,
    /// γ = 1 − e^(−K_I K_AWP Ts) (module docs).
    back_calculation: T,
    limit: T,
    regularize: bool,
}

/// State of the N actuators' loops.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct RedundantPidState<T, const N: usize> {
    /// Γ_I: the (regularized) integral forces, N.
    pub integral: SVector<T, N>,
    /// q̃_reg of the last period, m.
    pub last_error: SVector<T, N>,
    /// ΔΓ = sat(U) − U of the last period, N.
    pub last_excess: SVector<T, N>,
    /// Whether `last_error` holds a period's error (no derivative kick at start).
    pub primed: bool,
}

impl<T: Float, const N: usize> RedundantPidState<T, N> {
    /// Nothing integrated.
    pub fn new() -> Self {
        Self {
            integral: SVector::zeros(),
            last_error: SVector::zeros(),
            last_excess: SVector::zeros(),
            primed: false,
        }
    }
}

impl<T: Float, const N: usize> Default for RedundantPidState<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

/// One period's command.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct RedundantPidOutput<T, const N: usize> {
    /// The saturated command U, N.
    pub forces: SVector<T, N>,
    /// Whether any actuator is at its limit.
    pub saturated: bool,
}

/// Why a period's command could not be computed.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RedundantPidError {
    /// An error, feedforward or regularization entry was NaN or infinite.
    NotFinite,
}

impl<T: Float> RedundantPid<T> {
    /// Coefficients for period `ts_s` (gains finite and positive, K_D, K_I and K_AWP
    /// may be zero). Every coefficient is checked in `T`: a K_D/Ts or K_I·Ts that is
    /// finite in `f64` but ∞ or zero in `f32` is refused, naming the gain.
    pub fn new(config: &RedundantPidConfig, ts_s: f64) -> Result<Self, ConfigError> {
        let ts = positive("ts_s", ts_s)?;
        let kd = nonneg_f64("kd", config.kd)?;
        let ki = nonneg_f64("ki", config.ki)?;
        let k_awp = nonneg_f64("k_awp", config.k_awp)?;
        Ok(Self {
            kp: coefficient("kp", positive("kp", config.kp)?)?,
            kd_per_ts: coefficient_or_zero("kd", kd / ts)?,
            ki_ts: coefficient_or_zero("ki", ki * ts)?,
            back_calculation: coefficient_or_zero("k_awp", -libm::expm1(-k_awp * ki * ts))?,
            limit: coefficient("force_limit", positive("force_limit", config.force_limit)?)?,
            regularize: config.regularize,
        })
    }

    /// One period: `error` q̃ = q_d − q, `rm` = Jm Jm⁺ of the present pose (formed, or
    /// [`Factored`]; ignored without regularization), `feedforward` Γ_ff. A non-finite
    /// input leaves the state untouched and returns the error: the caller's outputs
    /// go safe.
    pub fn update<const N: usize, P: Projection<T, N>>(
        &self,
        state: &mut RedundantPidState<T, N>,
        error: &SVector<T, N>,
        rm: &P,
        feedforward: &SVector<T, N>,
    ) -> Result<RedundantPidOutput<T, N>, RedundantPidError> {
        if !(all_finite(error.as_slice()) && rm.is_finite() && all_finite(feedforward.as_slice())) {
            return Err(RedundantPidError::NotFinite);
        }
        let project = |v: SVector<T, N>| if self.regularize { rm.project(&v) } else { v };
        let e = project(*error);
        let last = if state.primed { state.last_error } else { e };
        // Eq. 45 with the corrected back-calculation sign (module docs).
        let integral =
            project(state.integral + e * self.ki_ts + state.last_excess * self.back_calculation);
        let feedback = project(e * self.kp + integral + (e - last) * self.kd_per_ts);
        let unsaturated = feedback + feedforward;
        let forces = unsaturated.map(|u| u.clamp_abs(self.limit));
        let excess = forces - unsaturated;
        let saturated = excess.iter().any(|x| *x != T::zero());
        state.integral = integral;
        state.last_error = e;
        state.last_excess = excess;
        state.primed = true;
        Ok(RedundantPidOutput { forces, saturated })
    }
}

/// `v` if finite and not negative.
fn nonneg_f64(name: &'static str, v: f64) -> Result<f64, ConfigError> {
    if !v.is_finite() {
        Err(ConfigError::not_finite(name))
    } else if v < 0.0 {
        Err(ConfigError::out_of_range(name))
    } else {
        Ok(v)
    }
}

/// Every entry finite.
fn all_finite<T: Float>(v: &[T]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Rm (eq. 38) as the law applies it: v ↦ Rm v, the projection onto Jm's column
/// space.
pub trait Projection<T, const N: usize> {
    /// Rm v.
    fn project(&self, v: &SVector<T, N>) -> SVector<T, N>;
    /// Whether every coefficient is finite.
    fn is_finite(&self) -> bool;
}

/// Rm formed as an N × N matrix (as [`regularization`] returns it).
impl<T: Float, const N: usize> Projection<T, N> for SMatrix<T, N, N> {
    fn project(&self, v: &SVector<T, N>) -> SVector<T, N> {
        self * v
    }
    fn is_finite(&self) -> bool {
        all_finite(self.as_slice())
    }
}

/// Rm = Jm Jm⁺ kept as its two factors, applied as Jm (Jm⁺ v): 2ND multiplications a
/// vector where the formed Rm costs N² and N²D to form (ARROW's 6 × 4 Jm, three
/// vectors a period: 144 against 108 + 144).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Factored<'a, T, const N: usize, const D: usize> {
    /// Jm, N × D, full column rank.
    pub jm: &'a SMatrix<T, N, D>,
    /// Its pseudo-inverse Jm⁺ (eq. 14).
    pub jm_pinv: &'a SMatrix<T, D, N>,
}

impl<T: Float, const N: usize, const D: usize> Projection<T, N> for Factored<'_, T, N, D> {
    fn project(&self, v: &SVector<T, N>) -> SVector<T, N> {
        self.jm * (self.jm_pinv * v)
    }
    fn is_finite(&self) -> bool {
        all_finite(self.jm.as_slice()) && all_finite(self.jm_pinv.as_slice())
    }
}

/// Rm = Jm Jm⁺ (eq. 38) from Jm (N × D, full column rank) and its pseudo-inverse.
pub fn regularization<T: Float, const N: usize, const D: usize>(
    jm: &SMatrix<T, N, D>,
    jm_pinv: &SMatrix<T, D, N>,
) -> SMatrix<T, N, N> {
    jm * jm_pinv
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Vector2};

    fn turntable_rm() -> Matrix2<f64> {
        // Jm = (1, −1)ᵀ (eq. 15): Rm = Jm (JmᵀJm)⁻¹ Jmᵀ = ½ [[1, −1], [−1, 1]].
        let jm = SMatrix::<f64, 2, 1>::new(1.0, -1.0);
        let pinv = SMatrix::<f64, 1, 2>::new(0.5, -0.5);
        regularization(&jm, &pinv)
    }

    /// Unsaturated and without regularization, the law is eq. 35 term by term,
    /// computed here from its own definitions (sums of errors and differences).
    #[test]
    fn unregularized_law_is_the_discrete_pid_of_eq_35() {
        let config = RedundantPidConfig {
            regularize: false,
            force_limit: 1e12,
            ..RedundantPidConfig::ARROW_TURNTABLE
        };
        let ts = 2e-4;
        let pid = RedundantPid::<f64>::new(&config, ts).unwrap();
        let mut state = RedundantPidState::<f64, 2>::new();
        let errors = [0.01, 0.02, -0.005, 0.0, 0.03];
        let mut sum = 0.0;
        let mut prev = errors[0];
        for e in errors {
            sum += e;
            let out = pid
                .update(
                    &mut state,
                    &Vector2::new(e, -2.0 * e),
                    &Matrix2::identity(),
                    &Vector2::zeros(),
                )
                .unwrap();
            let expected = config.kp * e + config.ki * ts * sum + config.kd * (e - prev) / ts;
            assert!((out.forces[0] - expected).abs() < 1e-9 * expected.abs().max(1.0));
            assert!((out.forces[1] + 2.0 * expected).abs() < 1e-9 * expected.abs().max(1.0));
            prev = e;
        }
    }

    /// The turntable's two motors against a constant inconsistent error (both
    /// encoders reading the same offset, which no table angle explains: eq. 8 wants
    /// opposite angles): without regularization both integrators grow, the motors
    /// push against each other; with it, the output and integral stay in Jm's column
    /// space, the two torques are equal and opposite (no internal torque), and the
    /// inconsistent part integrates to nothing.
    #[test]
    fn regularization_removes_the_internal_part() {
        let ts = 2e-4;
        let rm = turntable_rm();
        // (1, 1) is the null space of Jmᵀ = (1, −1): the motors pushing each other.
        let inconsistent = Vector2::new(1e-4, 1e-4);
        for regularize in [false, true] {
            let config = RedundantPidConfig {
                regularize,
                ..RedundantPidConfig::ARROW_TURNTABLE
            };
            let pid = RedundantPid::<f64>::new(&config, ts).unwrap();
            let mut state = RedundantPidState::new();
            let mut out = None;
            for _ in 0..5000 {
                out = Some(
                    pid.update(&mut state, &inconsistent, &rm, &Vector2::zeros())
                        .unwrap(),
                );
            }
            let internal = (out.unwrap().forces[0] + out.unwrap().forces[1]).abs();
            if regularize {
                assert!(
                    internal < 1e-9 && state.integral.amax() < 1e-12,
                    "{internal}"
                );
            } else {
                // K_P e + K_I e t = 5550e-4 + 7400e-4 × 1 s, per motor.
                assert!((internal - 2.0 * (0.555 + 0.74)).abs() < 1e-3, "{internal}");
            }
        }
    }

    /// A saturating step held (a blocked table): with back-calculation the integral
    /// settles where the pull-back balances the integration, K_I Ts e + γ ΔΓ = 0, i.e.
    /// at Γ_I = limit − K_P e + K_I Ts e/γ (≈ limit − K_P e + e/K_AWP, eq. 45's
    /// balance, for the turntable's small γ); with
    /// K_AWP = 0 it grows as K_I Ts Σe without bound (and the printed sign, which
    /// a negative K_AWP would be, is refused by the configuration).
    #[test]
    fn back_calculation_bounds_the_integral() {
        let ts = 2e-4;
        let e = 0.05;
        let step = Vector2::new(e, -e);
        let config = RedundantPidConfig::ARROW_TURNTABLE;
        let run = |k_awp: f64, periods: usize| {
            let config = RedundantPidConfig { k_awp, ..config };
            let pid = RedundantPid::<f64>::new(&config, ts).unwrap();
            let mut state = RedundantPidState::new();
            for _ in 0..periods {
                let out = pid
                    .update(&mut state, &step, &turntable_rm(), &Vector2::zeros())
                    .unwrap();
                assert!(out.saturated);
            }
            state.integral[0]
        };
        let gamma = 1.0 - (-config.ki * config.k_awp * ts).exp();
        let bound = config.force_limit - config.kp * e + config.ki * ts * e / gamma;
        assert!(
            (bound - (config.force_limit - config.kp * e + e / config.k_awp)).abs() < 1e-3 * bound
        );
        let settled = run(config.k_awp, 200_000);
        assert!(
            (settled - bound).abs() < 1e-3 * bound,
            "{settled} vs {bound}"
        );
        assert!(run(config.k_awp, 400_000) <= bound * (1.0 + 1e-9));
        let without = run(0.0, 200_000);
        assert!(
            (without - config.ki * ts * e * 200_000.0).abs() < 1e-6 * without,
            "{without}"
        );
        assert!(without > 2.0 * bound);
    }

    /// Rm applied in its factors, Jm (Jm⁺ v), is the formed Jm Jm⁺ applied: the same
    /// commands and states to round-off, period after period (a 3 × 2 Jm and its
    /// pseudo-inverse by nalgebra's SVD); a NaN in a factor is refused.
    #[test]
    fn factored_regularization_is_the_formed_one() {
        let jm = SMatrix::<f64, 3, 2>::new(1.0, 0.3, -0.4, 1.2, 0.7, -0.9);
        let pinv = jm.pseudo_inverse(1e-14).unwrap();
        let formed = regularization(&jm, &pinv);
        let factored = Factored {
            jm: &jm,
            jm_pinv: &pinv,
        };
        let pid = RedundantPid::<f64>::new(&RedundantPidConfig::ARROW_PARALLEL, 2e-4).unwrap();
        let (mut a, mut b) = (RedundantPidState::new(), RedundantPidState::new());
        for k in 0..50 {
            let t = f64::from(k);
            let e = nalgebra::Vector3::new(1e-5 * t.sin(), 2e-5 * t.cos(), -1e-5);
            let ff = nalgebra::Vector3::new(10.0, -20.0, 5.0 * t);
            let x = pid.update(&mut a, &e, &formed, &ff).unwrap();
            let y = pid.update(&mut b, &e, &factored, &ff).unwrap();
            assert!((x.forces - y.forces).amax() < 1e-9 * x.forces.amax(), "{k}");
            assert!(
                (a.integral - b.integral).amax() <= 1e-9 * a.integral.amax(),
                "{k}"
            );
        }
        let mut bad = pinv;
        bad[(1, 2)] = f64::NAN;
        let factored = Factored {
            jm: &jm,
            jm_pinv: &bad,
        };
        let e = nalgebra::Vector3::zeros();
        assert_eq!(
            pid.update(&mut b, &e, &factored, &e),
            Err(RedundantPidError::NotFinite)
        );
    }

    /// Bad input: NaN anywhere is refused and changes nothing.
    #[test]
    fn nan_is_refused_without_touching_the_state() {
        let pid = RedundantPid::<f64>::new(&RedundantPidConfig::ARROW_TURNTABLE, 2e-4).unwrap();
        let mut state = RedundantPidState::<f64, 2>::new();
        pid.update(
            &mut state,
            &Vector2::new(1e-3, -1e-3),
            &turntable_rm(),
            &Vector2::zeros(),
        )
        .unwrap();
        let before = state;
        for (e, ff) in [
            (Vector2::new(f64::NAN, 0.0), Vector2::zeros()),
            (Vector2::zeros(), Vector2::new(0.0, f64::INFINITY)),
        ] {
            assert_eq!(
                pid.update(&mut state, &e, &turntable_rm(), &ff),
                Err(RedundantPidError::NotFinite)
            );
            assert_eq!(state, before);
        }
        let mut bad = RedundantPidConfig::ARROW_TURNTABLE;
        bad.kd = -1.0;
        assert!(RedundantPid::<f64>::new(&bad, 2e-4).is_err());
    }

    /// Gains whose coefficients are finite in `f64` but not in `f32` are refused for
    /// `f32`, naming the gain: K_D/Ts of 4e38/2e-4 and 1e300/2e-4 overflow f32 (∞ × a
    /// zero first difference is NaN in the first period), K_I·Ts of 1e300 · 2e-4 too,
    /// and K_D/Ts of 1e-49/2e-4 rounds to zero in `f32`. The
    /// same gains build in `f64`, and gains that are off (zero) build in both.
    #[test]
    fn gains_beyond_the_target_scalar_are_refused() {
        let base = RedundantPidConfig::ARROW_PARALLEL;
        for (field, config) in [
            ("kd", RedundantPidConfig { kd: 4e38, ..base }),
            ("kd", RedundantPidConfig { kd: 1e300, ..base }),
            ("kd", RedundantPidConfig { kd: 1e-49, ..base }),
            ("ki", RedundantPidConfig { ki: 1e300, ..base }),
        ] {
            assert_eq!(
                RedundantPid::<f32>::new(&config, 2e-4),
                Err(ConfigError::not_representable(field)),
                "{config:?}"
            );
            assert!(RedundantPid::<f64>::new(&config, 2e-4).is_ok());
        }
        let off = RedundantPidConfig {
            kd: 0.0,
            ki: 0.0,
            k_awp: 0.0,
            ..base
        };
        assert!(RedundantPid::<f32>::new(&off, 2e-4).is_ok());
    }
}
