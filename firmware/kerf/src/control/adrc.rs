//! Active disturbance rejection control (docs/control.md §27, G 4.2 eq. 13–29).
//!
//! Three parts, stepped once per period h (G's 1 ms):
//!
//! 1. Tracking differentiator (G eq. 14–16): v1 follows the reference v with the
//!    time-optimal acceleration limit r0, v2 is its derivative:
//!    u_td = fhan(v1 − v, v2, r0, h0); v1 ← v1 + h v2; v2 ← v2 + h u_td.
//! 2. Extended state observer of the plant ÿ = f + b0 u (G eq. 24–29): z1 ≈ y,
//!    z2 ≈ ẏ, z3 ≈ f, the total disturbance:
//!    e = z1 − y; z1 ← z1 + h z2 − β01 e; z2 ← z2 + h (z3 + b0 u) − β02 fal(e, 0.5, δo);
//!    z3 ← z3 − β03 fal(e, 0.25, δo), with u the command applied last period.
//! 3. Nonlinear state-error feedback and disturbance rejection (G fig. 29, after Han,
//!    the reference 54 of G 4.2): e1 = v1 − z1, e2 = v2 − z2,
//!    u0 = Kp fal(e1, α, δ) + Kd fal(e2, α, δ), u = (u0 − z3)/b0.
//!
//! What G's Kp, Kd, α, b0 mean: G tunes four numbers "Kp, Kd, alpha,
//! b0" (G 7.2) for the topology of fig. 29, whose only gains outside the observer are
//! those of the state-error feedback. Kp and Kd are therefore the weights of fal(e1)
//! and fal(e2) (Han's β1, β2), α their common exponent (Han allows one per term;
//! G tuned one), and b0 the input gain of the observer and of u = (u0 − z3)/b0.
//! The print gives no δ, observer gains or tracking-differentiator parameters; see
//! [`AdrcConfig::GRINDING_SEED`] for the values chosen.
//!
//! **CORRECTION** of G eq. 17: the print has d = h r0²; Han's fhan has d = r0 h0²,
//! and only that is dimensionally consistent (y = v1 + h v2 is in the signal's unit,
//! as is r0 h0², while h r0² is not). The test
//! `fhan_reaches_a_step_in_the_minimum_number_of_periods` checks the corrected form
//! against a brute-force minimum-time solution.
//!
//! Numerics, measured (tests `fal_power_accuracy_f32`, `micromath_sqrt_is_too_coarse`):
//! - fal's |e|^α: exponents 0.5 and 0.25 (the observer's) are one and two square
//!   roots, exact to rounding. The general α (the feedback's) uses [`FalPower`]:
//!   `libm::pow` in `f64`; in `f32`, micromath's `ln` and `exp`, as
//!   `exp(α ln |e|)` with `ln |e| = −ln(1/|e|)` below 1 — micromath's own `powf` errs
//!   by up to 10.5 % for |e| < 1 because its `ln` does (0.118 absolute), the
//!   reciprocal form keeps the relative error below 2.5e-3 over |e| ∈ [1e-6, 1e6].
//!   That is accurate enough for this law: it scales a gain by at most 0.25 %, far
//!   inside any gain margin and below the 4 significant digits G gives its
//!   gains; fal stays odd and monotonic, and the equilibria (e = 0) are exact.
//!   `libm::powf` would be exact (7e-8) but runs in double precision, which a
//!   Cortex-M4F has only in software.
//! - fhan's square root: micromath's `sqrt` errs by up to 6 %, which moves the
//!   switching curve of the time-optimal synthesis (chattering and overshoot instead
//!   of a finite-time arrival), so [`Float::fsqrt`] is used: within 1 ulp, and cheaper
//!   than libm's `sqrtf` on the target (see `scalar`).

use crate::error::{coefficient, in_range, positive, ConfigError};
use crate::scalar::{lit, Float, Real};
use micromath::F32Ext;

/// |x|^α for fal, in the scalar's own precision (module docs for the accuracy).
pub trait FalPower: Float {
    /// x^α for x > 0, α ∈ (0, 1].
    fn fal_pow(x: Self, alpha: Self) -> Self;
}

impl FalPower for f64 {
    #[inline]
    fn fal_pow(x: f64, alpha: f64) -> f64 {
        libm::pow(x, alpha)
    }
}

impl FalPower for f32 {
    /// micromath's `exp(α ln x)`, with ln x = −ln(1/x) below 1 (relative error below
    /// 2.5e-3 for x ∈ [1e-6, 1e6], α ≤ 1).
    #[inline]
    fn fal_pow(x: f32, alpha: f32) -> f32 {
        let ln = if x < 1.0 {
            -F32Ext::ln(1.0 / x)
        } else {
            F32Ext::ln(x)
        };
        F32Ext::exp(alpha * ln)
    }
}

/// sign(x) with sign(0) = 0, as G eq. 19–23 use it.
#[inline]
fn sign<T: Float>(x: T) -> T {
    if x > T::ZERO {
        lit(1.0)
    } else if x < T::ZERO {
        lit(-1.0)
    } else {
        T::ZERO
    }
}

#[derive(Copy, Clone, Debug, PartialEq)]
enum Exponent<T> {
    Half,
    Quarter,
    General(T),
}

/// fal(e, α, δ) (G 4.2): e/δ^(1−α) for |e| ≤ δ, |e|^α sign(e) beyond; coefficients
/// for one (α, δ).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Fal<T> {
    exponent: Exponent<T>,
    delta: T,
    /// δ^(α−1): the slope of the linear zone.
    slope: T,
}

impl<T: FalPower> Fal<T> {
    /// Validates α ∈ [0.01, 1] and δ ∈ [1e-6, 1e6] (the range over which the `f32`
    /// power is measured; δ in the signal's unit).
    pub fn new(alpha: f64, delta: f64) -> Result<Self, ConfigError> {
        let alpha = in_range("alpha", alpha, 0.01, 1.0)?;
        let delta = in_range("delta", delta, 1e-6, 1e6)?;
        let exponent = if alpha == 0.5 {
            Exponent::Half
        } else if alpha == 0.25 {
            Exponent::Quarter
        } else {
            Exponent::General(coefficient("alpha", alpha)?)
        };
        Ok(Self {
            exponent,
            delta: coefficient("delta", delta)?,
            slope: coefficient("delta", libm::pow(delta, alpha - 1.0))?,
        })
    }

    /// fal(e). NaN passes through.
    #[inline]
    pub fn eval(&self, e: T) -> T {
        let magnitude = e.abs();
        if magnitude <= self.delta {
            return e * self.slope;
        }
        let power = match self.exponent {
            Exponent::Half => magnitude.fsqrt(),
            Exponent::Quarter => magnitude.fsqrt().fsqrt(),
            Exponent::General(alpha) => T::fal_pow(magnitude, alpha),
        };
        if e < T::ZERO {
            -power
        } else {
            power
        }
    }
}

/// Han's time-optimal synthesis fhan(x1, x2, r, h0) for the discrete double
/// integrator (G eq. 17–23, with the **CORRECTION** d = r h0²).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Fhan<T> {
    r: T,
    h0: T,
    d: T,
    inv_d: T,
}

impl<T: Float> Fhan<T> {
    /// `r` the acceleration limit (signal unit/s²), `h0_s` the filter period (≥ the
    /// sampling period for a chatter-free arrival).
    pub fn new(r: f64, h0_s: f64) -> Result<Self, ConfigError> {
        let r = positive("td_acceleration", r)?;
        let h0 = positive("td_filter_period_s", h0_s)?;
        let d = r * h0 * h0;
        Ok(Self {
            r: coefficient("td_acceleration", r)?,
            h0: coefficient("td_filter_period_s", h0)?,
            d: coefficient("td_acceleration", d)?,
            inv_d: coefficient("td_acceleration", 1.0 / d)?,
        })
    }

    /// The acceleration, |fhan| ≤ r, that drives (x1, x2) to (0, 0) fastest.
    #[inline]
    pub fn eval(&self, x1: T, x2: T) -> T {
        let d = self.d;
        let half: T = lit(0.5);
        let a0 = self.h0 * x2; // eq. 17
        let y = x1 + a0;
        let a1 = (d * (d + lit::<T>(8.0) * y.abs())).fsqrt(); // eq. 18
        let a2 = a0 + sign(y) * (a1 - d) * half; // eq. 19
        let sy = (sign(y + d) - sign(y - d)) * half; // eq. 20
        let a = (a0 + y - a2) * sy + a2; // eq. 21
        let sa = (sign(a + d) - sign(a - d)) * half; // eq. 22
        -self.r * (a * self.inv_d - sign(a)) * sa - self.r * sign(a) // eq. 23
    }
}

/// ADRC settings in SI units; y is the controlled signal (the normal force, N, in the
/// grinding cell), u the command.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct AdrcConfig {
    /// Tracking differentiator's acceleration limit r0, y/s².
    pub td_acceleration: f64,
    /// Tracking differentiator's filter period h0, s (≥ the control period).
    pub td_filter_period_s: f64,
    /// Observer bandwidth ωo, rad/s (ωo·h ≤ 1). The gains of eq. 27–29 follow from it
    /// so that in fal's linear zone the observer's error has a triple pole at −ωo
    /// (the bandwidth parametrization of linear ESOs): with the per-period gains of
    /// G's form, β01 = 3ωo h, β02 = 3ωo² h δo^0.5, β03 = ωo³ h δo^0.75 (the δo
    /// powers undo fal's linear-zone slopes δo^(α−1)).
    pub eso_bandwidth_rad_s: f64,
    /// Observer's fal linear zone δo, y.
    pub eso_delta: f64,
    /// Weight Kp of fal(e1) in the feedback (Han's β1).
    pub kp: f64,
    /// Weight Kd of fal(e2) in the feedback (Han's β2).
    pub kd: f64,
    /// Exponent α of the feedback's fal, (0, 1].
    pub alpha: f64,
    /// Feedback's fal linear zone δ, y.
    pub delta: f64,
    /// Input gain b0 of the modelled plant ÿ = f + b0 u, y/(s²·u).
    pub b0: f64,
}

impl AdrcConfig {
    /// G's grinding force law (G 7.2, genetic algorithm): Kp 61.17, Kd 78.64,
    /// α 0.9448, b0 0.543 (the hexapod GUI's initialization, G app. D, sets a
    /// provisional b0 = 0.5; the tuned value is the one of 7.2).
    ///
    /// Not printed, chosen here:
    /// - δ = δo = 1 N: on the order of the force noise (σ ≈ 0.9 N, G 5.2), so noise
    ///   alone does not drive fal's high-gain zone; with δ = 1, fal's linear slope
    ///   δ^(α−1) is 1 for every α, so fal(e) = e up to 1 N and |e|^α beyond.
    /// - ωo = 300 rad/s (ωo h = 0.3): about four times the feedback's faster pole (with
    ///   fal linear, s² + Kd s + Kp has poles at −0.78 and −77.9 rad/s).
    /// - r0 = 1000 N/s², h0 = h: a reference step of 7.5 N is followed in
    ///   2√(7.5/1000) ≈ 0.17 s without overshoot.
    pub const GRINDING_SEED: Self = Self {
        td_acceleration: 1000.0,
        td_filter_period_s: 1e-3,
        eso_bandwidth_rad_s: 300.0,
        eso_delta: 1.0,
        kp: 61.17,
        kd: 78.64,
        alpha: 0.9448,
        delta: 1.0,
        b0: 0.543,
    };
}

/// ADRC coefficients in the scalar `T` for a fixed period; one set drives any
/// number of [`AdrcState`]s.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Adrc<T> {
    h: T,
    td: Fhan<T>,
    beta01: T,
    beta02: T,
    beta03: T,
    eso_half: Fal<T>,
    eso_quarter: Fal<T>,
    feedback: Fal<T>,
    kp: T,
    kd: T,
    b0: T,
    inv_b0: T,
}

/// One loop's state, in the signal's units.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct AdrcState<T> {
    /// Tracked reference v1, y.
    pub v1: T,
    /// Its derivative v2, y/s.
    pub v2: T,
    /// Estimate z1 of y.
    pub z1: T,
    /// Estimate z2 of ẏ, y/s.
    pub z2: T,
    /// Estimate z3 of the total disturbance f, y/s².
    pub z3: T,
    /// Command applied last period (the observer's input).
    pub command: T,
}

impl<T: Real> AdrcState<T> {
    /// At rest at the measurement `y` with command `command` held: the tracked
    /// reference starts from y, so a new reference is approached along fhan's profile.
    pub fn at(y: T, command: T) -> Self {
        Self {
            v1: y,
            v2: T::ZERO,
            z1: y,
            z2: T::ZERO,
            z3: T::ZERO,
            command,
        }
    }
}

impl<T: FalPower> Adrc<T> {
    /// Validates the configuration for the period `ts_s` (all gains finite and
    /// positive, h0 ≥ h, ωo h ≤ 1, α ∈ [0.01, 1], δ's in [1e-6, 1e6]).
    pub fn new(config: &AdrcConfig, ts_s: f64) -> Result<Self, ConfigError> {
        let h = positive("period_s", ts_s)?;
        let h0 = in_range("td_filter_period_s", config.td_filter_period_s, h, 1e3)?;
        let wo = positive("eso_bandwidth_rad_s", config.eso_bandwidth_rad_s)?;
        in_range("eso_bandwidth_rad_s", wo * h, 0.0, 1.0)?;
        let delta_o = in_range("eso_delta", config.eso_delta, 1e-6, 1e6)?;
        let b0 = positive("b0", config.b0)?;
        Ok(Self {
            h: coefficient("period_s", h)?,
            td: Fhan::new(config.td_acceleration, h0)?,
            beta01: coefficient("eso_bandwidth_rad_s", 3.0 * wo * h)?,
            beta02: coefficient(
                "eso_bandwidth_rad_s",
                3.0 * wo * wo * h * libm::sqrt(delta_o),
            )?,
            beta03: coefficient(
                "eso_bandwidth_rad_s",
                wo * wo * wo * h * libm::pow(delta_o, 0.75),
            )?,
            eso_half: Fal::new(0.5, delta_o).map_err(|_| ConfigError::out_of_range("eso_delta"))?,
            eso_quarter: Fal::new(0.25, delta_o)
                .map_err(|_| ConfigError::out_of_range("eso_delta"))?,
            feedback: Fal::new(config.alpha, config.delta)?,
            kp: coefficient("kp", positive("kp", config.kp)?)?,
            kd: coefficient("kd", positive("kd", config.kd)?)?,
            b0: coefficient("b0", b0)?,
            inv_b0: coefficient("b0", 1.0 / b0)?,
        })
    }

    /// One period: tracking differentiator toward `reference`, observer update with
    /// the measurement `measured` and last period's command, then
    /// u = (u0 − z3)/b0, which is also stored as the command applied unless
    /// [`Adrc::settle`] says otherwise. NaN passes through (the caller checks inputs).
    #[inline]
    pub fn update(&self, state: &mut AdrcState<T>, reference: T, measured: T) -> T {
        let h = self.h;
        // Tracking differentiator, G eq. 14–16.
        let u_td = self.td.eval(state.v1 - reference, state.v2);
        state.v1 += h * state.v2;
        state.v2 += h * u_td;
        // Extended state observer, G eq. 25–29 (all right-hand sides at the old state).
        let e = state.z1 - measured;
        let (z1, z2, z3) = (state.z1, state.z2, state.z3);
        state.z1 = z1 + h * z2 - self.beta01 * e;
        state.z2 = z2 + h * (z3 + self.b0 * state.command) - self.beta02 * self.eso_half.eval(e);
        state.z3 = z3 - self.beta03 * self.eso_quarter.eval(e);
        // State-error feedback and rejection of the estimated disturbance (fig. 29).
        let e1 = state.v1 - state.z1;
        let e2 = state.v2 - state.z2;
        let u0 = self.kp * self.feedback.eval(e1) + self.kd * self.feedback.eval(e2);
        let u = (u0 - state.z3) * self.inv_b0;
        state.command = u;
        u
    }

    /// The command actually applied this period (after the caller's saturation and
    /// rate limit): the observer's input next period, so it does not wind up.
    #[inline]
    pub fn settle(&self, state: &mut AdrcState<T>, applied: T) {
        state.command = applied;
    }
}

#[cfg(test)]
mod tests;
