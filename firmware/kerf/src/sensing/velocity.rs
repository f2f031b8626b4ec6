//! Velocity from a position measurement: a second-order tracking observer.
//!
//! Prediction x̂ ← x̂ + Ts v̂ + Ts²/2 a, v̂ ← v̂ + Ts a (a: the acceleration the
//! controller commanded, if known), innovation e = x − x̂, correction x̂ ← x̂ + α e,
//! v̂ ← v̂ + (β/Ts) e. Without the acceleration input the estimate lags by 2a/ω under
//! constant acceleration; with it the lag is only the part of the acceleration the
//! plant did not follow. Its characteristic polynomial is z² − (2 − α − β) z + (1 − α);
//! placing both poles at p = exp(−ω Ts) (critically damped, bandwidth ω) gives
//! α = 1 − p² and β = (1 − p)². Unlike a finite difference, v̂ does not amplify
//! position noise by 1/Ts, which matters because the DOB multiplies v̂ by its gain.

use crate::error::{factor, positive, ConfigError};
use crate::scalar::Real;

/// Observer configuration (the period comes from the machine).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TrackingObserverConfig {
    /// Observer bandwidth ω in rad/s (both poles at −ω).
    pub bandwidth_rad_s: f64,
}

/// Tracking observer coefficients in the scalar `T`; one set drives any number of
/// [`TrackingObserverState`]s.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TrackingObserver<T: Real> {
    ts: T::Coef,
    half_ts_sq: T::Coef,
    alpha: T::Coef,
    beta_over_ts: T::Coef,
}

/// State of one tracking observer: the filtered position and the velocity estimate,
/// in physical units, so replacing the coefficients keeps it meaningful (bumpless).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TrackingObserverState<T: Real> {
    /// Filtered position, m.
    pub position: T,
    /// Velocity estimate, m/s.
    pub velocity: T,
    /// The roundings of the position update carried to the next period (the step,
    /// [`Real::mul_add_carry`], and the correction, [`Real::scale_carry`]; nothing
    /// for the floats). Every rounding of a position increment needs it: a constant
    /// rounding error δ per period is, to this observer, a velocity error of δ/Ts.
    carry: [T::Carry; 2],
}

impl<T: Real> TrackingObserverState<T> {
    /// At rest at `position`.
    pub fn at_rest(position: T) -> Self {
        Self {
            position,
            velocity: T::ZERO,
            carry: [T::Carry::default(); 2],
        }
    }
}

impl<T: Real> TrackingObserver<T> {
    /// Validates the configuration for control period `ts_s`; `ω Ts` must stay below 2
    /// (beyond that the discrete design no longer approximates a continuous bandwidth),
    /// and every coefficient must be representable in `T`.
    pub fn new(config: &TrackingObserverConfig, ts_s: f64) -> Result<Self, ConfigError> {
        let w = positive("bandwidth_rad_s", config.bandwidth_rad_s)?;
        let ts = positive("period_s", ts_s)?;
        if w * ts > 2.0 {
            return Err(ConfigError::out_of_range("bandwidth_rad_s"));
        }
        let p = libm::exp(-w * ts);
        // 1 − p and 1 − p² without cancellation for small ω Ts.
        let one_minus_p = -libm::expm1(-w * ts);
        Ok(Self {
            ts: factor::<T>("period_s", ts)?,
            half_ts_sq: factor::<T>("period_s", 0.5 * ts * ts)?,
            alpha: factor::<T>("bandwidth_rad_s", one_minus_p * (1.0 + p))?,
            beta_over_ts: factor::<T>("bandwidth_rad_s", one_minus_p * one_minus_p / ts)?,
        })
    }

    /// Feeds one position sample and the acceleration applied over the last period
    /// (`T::ZERO` when unknown); returns the velocity estimate.
    ///
    /// NaN or ±∞ in (or finite input so large that the arithmetic overflows) passes through to the output: a pure kernel of the period, it does not test; the machine's step does (`AxisLaw::step` latches a fault).
    #[inline]
    pub fn update(&self, state: &mut TrackingObserverState<T>, measured: T, acceleration: T) -> T {
        // The step as `predicted_step` computes it, with the fixed-point rounding
        // carried from period to period (a float step is the same expression).
        let [step_carry, correction_carry] = &mut state.carry;
        let step = state
            .velocity
            .mul_add_carry(self.ts, acceleration, self.half_ts_sq, step_carry);
        let predicted = state.position + step;
        let innovation = measured - predicted;
        state.position = predicted + innovation.scale_carry(self.alpha, correction_carry);
        state.velocity =
            state.velocity + acceleration.scale(self.ts) + innovation.scale(self.beta_over_ts);
        state.velocity
    }

    /// Position change expected over the next period, `Ts v̂ + Ts²/2 a` (used to
    /// unwrap the next Hall sample).
    #[inline]
    pub fn predicted_step(&self, state: &TrackingObserverState<T>, acceleration: T) -> T {
        state.velocity.scale(self.ts) + acceleration.scale(self.half_ts_sq)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Coefficients at 10 kHz and a state at rest at 0, paired for the tests.
    struct Observer(TrackingObserver<f64>, TrackingObserverState<f64>);

    impl Observer {
        fn update(&mut self, measured: f64, acceleration: f64) -> f64 {
            self.0.update(&mut self.1, measured, acceleration)
        }
    }

    fn observer(w: f64) -> Observer {
        let coefficients =
            TrackingObserver::new(&TrackingObserverConfig { bandwidth_rad_s: w }, 1e-4).unwrap();
        Observer(coefficients, TrackingObserverState::at_rest(0.0))
    }

    #[test]
    fn tracks_a_ramp_without_steady_state_error() {
        // A type-2 loop: constant velocity is tracked exactly once transients decay.
        let mut obs = observer(2000.0);
        let mut v = 0.0;
        for k in 0..5000 {
            v = obs.update(0.25 * k as f64 * 1e-4 + 0.01, 0.0);
        }
        assert!((v - 0.25).abs() < 1e-9, "{v}");
    }

    #[test]
    fn acceleration_input_removes_the_lag() {
        // x = a t²/2: without the input the estimate lags by 2a/ω; with it, not at all.
        let (a, w, ts) = (2.0, 2000.0, 1e-4);
        let (mut plain, mut fed) = (observer(w), observer(w));
        let (mut v_plain, mut v_fed) = (0.0, 0.0);
        for k in 0..5000 {
            let x = 0.5 * a * (k as f64 * ts).powi(2);
            v_plain = plain.update(x, 0.0);
            v_fed = fed.update(x, a);
        }
        let v_true = a * 4999.0 * ts;
        // The discrete lag differs from 2a/ω by O(ω Ts) = 20 %.
        assert!(
            ((v_true - v_plain) / (2.0 * a / w) - 1.0).abs() < 0.25,
            "{}",
            v_true - v_plain
        );
        // Sampled x at t_k and the estimate at t_k: exact up to rounding.
        assert!((v_true - v_fed).abs() < 1e-9, "{}", v_true - v_fed);
    }

    #[test]
    fn bandwidth_matches_the_design() {
        // The continuous model of the observer is V̂/X = ω² s / (s + ω)², so a sine of
        // frequency ω is seen with velocity amplitude ω/2 (−6 dB: the double pole).
        let w = 2.0 * core::f64::consts::PI * 100.0;
        let mut obs = observer(w);
        let f = w; // test at ω
        let (mut sum_c, mut sum_s) = (0.0, 0.0);
        let n = 200_000;
        for k in 0..n {
            let t = k as f64 * 1e-4;
            let v = obs.update((f * t).sin(), 0.0);
            if k >= n / 2 {
                sum_c += v * (f * t).cos();
                sum_s += v * (f * t).sin();
            }
        }
        let amp = 2.0 * (sum_c * sum_c + sum_s * sum_s).sqrt() / (n / 2) as f64;
        let expected = f / 2.0;
        assert!((amp / expected - 1.0).abs() < 0.02, "{amp} vs {expected}");
    }

    #[test]
    fn rejects_bad_config() {
        let bad = |w: f64, ts: f64| {
            TrackingObserver::<f32>::new(&TrackingObserverConfig { bandwidth_rad_s: w }, ts).err()
        };
        assert_eq!(
            bad(f64::NAN, 1e-4),
            Some(ConfigError::not_finite("bandwidth_rad_s"))
        );
        assert_eq!(bad(100.0, 0.0), Some(ConfigError::not_positive("period_s")));
        assert_eq!(
            bad(1e5, 1e-4),
            Some(ConfigError::out_of_range("bandwidth_rad_s"))
        );
        // Valid in f64, but Ts²/2 underflows f32 at a 1e-25 s period.
        assert_eq!(
            bad(100.0, 1e-25),
            Some(ConfigError::not_representable("period_s"))
        );
        assert!(TrackingObserver::<f64>::new(
            &TrackingObserverConfig {
                bandwidth_rad_s: 100.0
            },
            1e-25
        )
        .is_ok());
    }

    #[test]
    fn new_coefficients_keep_the_state() {
        // A bandwidth change mid-ramp leaves position and velocity where they were.
        let mut obs = observer(2000.0);
        for k in 0..3000 {
            obs.update(0.25 * k as f64 * 1e-4, 0.0);
        }
        let before = obs.1;
        obs.0 = TrackingObserver::new(
            &TrackingObserverConfig {
                bandwidth_rad_s: 500.0,
            },
            1e-4,
        )
        .unwrap();
        assert_eq!(obs.1, before);
        let v = obs.update(0.25 * 3000.0 * 1e-4, 0.0);
        assert!((v - 0.25).abs() < 1e-9, "{v}");
    }
}
