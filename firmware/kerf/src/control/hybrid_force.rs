//! Hybrid force/velocity control of the grinding cell (docs/control.md §28, G ch. 4
//! eq. 11, G ch. 7 fig. 42).
//!
//! Normal direction: a force law ([`ForceLaw`]: [`Pid`] or [`Adrc`], one
//! implementation for both) turns the normal-force reference and measurement into a
//! piezo position increment; the increment is added to the piezo position, which is
//! saturated to the travel, then rate limited (G ch. 7: "the signal goes through a
//! saturation block before reaching the rate limiter"). The law is told the increment
//! actually applied, so neither the PID's integrator nor the ADRC's observer winds up.
//!
//! Tangential direction: the feed along the surface is F_R = √(V_hex² + V_pzo²)
//! (G eq. 11), so the hexapod keeps it at the set F_R with
//! V_hex = √(F_R² − V_pzo²), V_pzo the discrete derivative of the piezo command. When
//! |V_pzo| > F_R the piezo alone exceeds the feed: V_hex = 0 and the output says so.
//!
//! Sign convention: a positive increment moves the piezo toward the surface and raises
//! the normal force. **Safe** is the opposite: on a NaN or infinite force or
//! reference, or a law output that is not finite, [`HybridForce::step`] returns the
//! error together with the safe output — the piezo retracting away from the surface
//! (toward the low end of its travel) at the rate limit, and the hexapod feed zero —
//! and leaves the law's state as it was (re-create it before resuming).

use crate::control::adrc::{Adrc, AdrcState, FalPower};
use crate::control::pid::{Pid, PidState};
use crate::error::{coefficient, positive, representable, ConfigError};
use crate::scalar::{Float, Real};

/// A law for the piezo force loop: proposes an increment (in the law's output unit),
/// then learns the increment actually applied.
pub trait ForceLaw<T> {
    /// One loop's state.
    type State;
    /// The increment for this period from the reference and measured normal forces, N.
    fn propose(&self, state: &mut Self::State, reference_n: T, measured_n: T) -> T;
    /// The increment actually applied after the piezo's saturation and rate limit.
    fn settle(&self, state: &mut Self::State, proposed: T, applied: T);
}

impl<T: Real> ForceLaw<T> for Pid<T> {
    type State = PidState<T>;
    /// Error = reference − measured (G ch. 4).
    #[inline]
    fn propose(&self, state: &mut PidState<T>, reference_n: T, measured_n: T) -> T {
        Pid::propose(self, state, reference_n - measured_n)
    }
    #[inline]
    fn settle(&self, state: &mut PidState<T>, proposed: T, applied: T) {
        Pid::settle(self, state, proposed, applied);
    }
}

impl<T: FalPower> ForceLaw<T> for Adrc<T> {
    type State = AdrcState<T>;
    #[inline]
    fn propose(&self, state: &mut AdrcState<T>, reference_n: T, measured_n: T) -> T {
        self.update(state, reference_n, measured_n)
    }
    #[inline]
    fn settle(&self, state: &mut AdrcState<T>, _proposed: T, applied: T) {
        Adrc::settle(self, state, applied);
    }
}

/// The piezo stage and the feed, SI units.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HybridForceConfig {
    /// Retracted end of the piezo travel, m (the safe side).
    pub piezo_min_m: f64,
    /// Extended end of the travel (toward the surface), m.
    pub piezo_max_m: f64,
    /// Largest piezo speed, m/s (the rate limiter).
    pub piezo_rate_m_s: f64,
    /// Set local feed F_R, m/s.
    pub feed_m_s: f64,
    /// Piezo travel per unit of the law's output, m (the unit the law's gains assume).
    pub increment_unit_m: f64,
}

impl HybridForceConfig {
    /// G's cell (G 3.1.1, 7.1): P-602 travel 0–1 mm; set feed 0.1 mm/s; the rate
    /// limiter at the set feed ("to prevent the piezo actuator to exceed the set
    /// feedrate", G ch. 7). G does not print the unit of its laws' output.
    /// On the simulated cell (Werner's force model, about 0.5 N per µm of depth at
    /// G's operating point, and its 0.8 N² force noise) G's PID
    /// gains engage and hold the force only at 3·10⁻¹¹ m per unit or less: at larger
    /// units the proportional and derivative terms alone turn the force noise into
    /// piezo steps beyond the rate limit (0.1 µm per period), and the piezo chatters
    /// in place without reaching the surface (the scan is the scenario test
    /// `grinding_cell::published_gain_unit_scan`). 1·10⁻¹¹ m (10 pm) per unit is used:
    /// G's gains then give a loop gain of 4·10⁻⁴ per period on 0.5 N/µm (a force
    /// time constant of about 2.4 s). A different
    /// force model would move this scale by its stiffness; the gains tuned on the cell
    /// are in `control::pid` and `control::adrc` presets with their own units.
    pub const GRINDING_SEED: Self = Self {
        piezo_min_m: 0.0,
        piezo_max_m: 1e-3,
        piezo_rate_m_s: 1e-4,
        feed_m_s: 1e-4,
        increment_unit_m: 1e-11,
    };
}

/// Why a period went to the safe output.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HybridForceError {
    /// The measured normal force is NaN or ±∞.
    ForceNotFinite,
    /// The force reference is NaN or ±∞.
    ReferenceNotFinite,
    /// The law's output is not finite (its state is corrupt).
    CommandNotFinite,
}

/// One period's commands.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HybridOutput<T> {
    /// Piezo position command, m.
    pub piezo_m: T,
    /// Its discrete derivative V_pzo, m/s.
    pub piezo_velocity_m_s: T,
    /// Hexapod feed V_hex along the surface, m/s.
    pub hexapod_feed_m_s: T,
    /// |V_pzo| > F_R: the feed cannot be kept (V_hex = 0).
    pub feed_exceeded: bool,
    /// The travel limits cut the command.
    pub saturated: bool,
    /// The rate limit cut the command.
    pub rate_limited: bool,
}

/// A rejected period: what went wrong and the safe output to apply.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HybridFault<T> {
    /// The cause.
    pub error: HybridForceError,
    /// Piezo retracting at the rate limit, hexapod feed zero.
    pub output: HybridOutput<T>,
}

/// The loop's state: the law's and the piezo command.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HybridForceState<S, T> {
    /// The force law's state.
    pub law: S,
    /// Piezo position commanded last period, m.
    pub piezo_m: T,
}

/// Coefficients of the loop in the scalar `T` with the law `L`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HybridForce<T, L> {
    law: L,
    min: T,
    max: T,
    max_step: T,
    inv_ts: T,
    feed: T,
    unit: T,
    inv_unit: T,
}

impl<T: Float, L: ForceLaw<T>> HybridForce<T, L> {
    /// Validates the configuration for the period `ts_s` (min < max, positive rate,
    /// feed and unit, all representable in `T`).
    pub fn new(law: L, config: &HybridForceConfig, ts_s: f64) -> Result<Self, ConfigError> {
        let ts = positive("period_s", ts_s)?;
        let min = representable("piezo_min_m", config.piezo_min_m)?;
        let max = representable("piezo_max_m", config.piezo_max_m)?;
        if config.piezo_max_m <= config.piezo_min_m {
            return Err(ConfigError::out_of_range("piezo_max_m"));
        }
        let rate = positive("piezo_rate_m_s", config.piezo_rate_m_s)?;
        let unit = positive("increment_unit_m", config.increment_unit_m)?;
        Ok(Self {
            law,
            min,
            max,
            max_step: coefficient("piezo_rate_m_s", rate * ts)?,
            inv_ts: coefficient("period_s", 1.0 / ts)?,
            feed: coefficient("feed_m_s", positive("feed_m_s", config.feed_m_s)?)?,
            unit: coefficient("increment_unit_m", unit)?,
            inv_unit: coefficient("increment_unit_m", 1.0 / unit)?,
        })
    }

    /// The law.
    pub fn law(&self) -> &L {
        &self.law
    }

    /// One period (module docs). On bad input, the error and the safe output.
    pub fn step(
        &self,
        state: &mut HybridForceState<L::State, T>,
        reference_n: T,
        measured_n: T,
    ) -> Result<HybridOutput<T>, HybridFault<T>> {
        if !<T as Real>::is_finite(measured_n) {
            return Err(self.fault(state, HybridForceError::ForceNotFinite));
        }
        if !<T as Real>::is_finite(reference_n) {
            return Err(self.fault(state, HybridForceError::ReferenceNotFinite));
        }
        let proposed = self.law.propose(&mut state.law, reference_n, measured_n);
        if !<T as Real>::is_finite(proposed) {
            return Err(self.fault(state, HybridForceError::CommandNotFinite));
        }
        let previous = state.piezo_m;
        // Add the increment, saturate to the travel, then rate limit (G ch. 7).
        let wanted = previous + proposed * self.unit;
        let (mut piezo, mut saturated) = (wanted, false);
        if piezo > self.max {
            (piezo, saturated) = (self.max, true);
        } else if piezo < self.min {
            (piezo, saturated) = (self.min, true);
        }
        let change = piezo - previous;
        let rate_limited = change > self.max_step || change < -self.max_step;
        if rate_limited {
            piezo = previous + change.clamp_abs(self.max_step);
        }
        self.law
            .settle(&mut state.law, proposed, (piezo - previous) * self.inv_unit);
        state.piezo_m = piezo;
        Ok(self.output(previous, piezo, saturated, rate_limited))
    }

    /// The safe output from the present state: the piezo one rate-limited step away
    /// from the surface (not below the travel), the hexapod feed zero. Applies it to
    /// `state.piezo_m`.
    pub fn retract(&self, state: &mut HybridForceState<L::State, T>) -> HybridOutput<T> {
        let previous = state.piezo_m;
        let target = previous - self.max_step;
        // A NaN position (never produced here, but the state is public) retracts fully.
        let inside = target > self.min;
        let piezo = if inside { target } else { self.min };
        state.piezo_m = piezo;
        HybridOutput {
            piezo_m: piezo,
            piezo_velocity_m_s: if <T as Real>::is_finite(previous) {
                (piezo - previous) * self.inv_ts
            } else {
                T::ZERO
            },
            hexapod_feed_m_s: T::ZERO,
            feed_exceeded: false,
            saturated: !inside,
            rate_limited: true,
        }
    }

    fn fault(
        &self,
        state: &mut HybridForceState<L::State, T>,
        error: HybridForceError,
    ) -> HybridFault<T> {
        HybridFault {
            error,
            output: self.retract(state),
        }
    }

    /// V_pzo from the applied step and V_hex = √(F_R² − V_pzo²) (G eq. 11).
    fn output(
        &self,
        previous: T,
        piezo: T,
        saturated: bool,
        rate_limited: bool,
    ) -> HybridOutput<T> {
        let velocity = (piezo - previous) * self.inv_ts;
        let radicand = self.feed * self.feed - velocity * velocity;
        let feed_exceeded = radicand < T::ZERO;
        HybridOutput {
            piezo_m: piezo,
            piezo_velocity_m_s: velocity,
            hexapod_feed_m_s: if feed_exceeded {
                T::ZERO
            } else {
                radicand.fsqrt()
            },
            feed_exceeded,
            saturated,
            rate_limited,
        }
    }
}

#[cfg(test)]
mod tests;
