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

use crate::error::{positive, ConfigError};
use crate::scalar::Real;

/// Observer configuration.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TrackingObserverConfig {
    /// Observer bandwidth ω in rad/s (both poles at −ω).
    pub bandwidth_rad_s: f64,
    /// Sample period in seconds.
    pub ts_s: f64,
}

/// Tracking observer state and coefficients in the scalar `T`.
#[derive(Copy, Clone, Debug)]
pub struct TrackingObserver<T> {
    ts: T,
    half_ts_sq: T,
    alpha: T,
    beta_over_ts: T,
    position: T,
    velocity: T,
}

impl<T: Real> TrackingObserver<T> {
    /// Validates the configuration; `ω Ts` must stay below 2 (beyond that the discrete
    /// design no longer approximates a continuous bandwidth).
    pub fn new(config: &TrackingObserverConfig) -> Result<Self, ConfigError> {
        let w = positive("bandwidth_rad_s", config.bandwidth_rad_s)?;
        let ts = positive("ts_s", config.ts_s)?;
        if w * ts > 2.0 {
            return Err(ConfigError::out_of_range("bandwidth_rad_s"));
        }
        let p = libm::exp(-w * ts);
        Ok(Self {
            ts: T::from_f64(ts),
            half_ts_sq: T::from_f64(0.5 * ts * ts),
            alpha: T::from_f64(1.0 - p * p),
            beta_over_ts: T::from_f64((1.0 - p) * (1.0 - p) / ts),
            position: T::ZERO,
            velocity: T::ZERO,
        })
    }

    /// Starts tracking at `position` with zero velocity.
    pub fn reset(&mut self, position: T) {
        self.position = position;
        self.velocity = T::ZERO;
    }

    /// Feeds one position sample and the acceleration applied over the last period
    /// (`T::ZERO` when unknown); returns the velocity estimate.
    #[inline]
    pub fn update(&mut self, measured: T, acceleration: T) -> T {
        let predicted = self.position + self.predicted_step(acceleration);
        let innovation = measured - predicted;
        self.position = predicted + self.alpha * innovation;
        self.velocity = self.velocity + self.ts * acceleration + self.beta_over_ts * innovation;
        self.velocity
    }

    /// Position change expected over the next period, `Ts v̂ + Ts²/2 a` (used to
    /// unwrap the next Hall sample).
    #[inline]
    pub fn predicted_step(&self, acceleration: T) -> T {
        self.ts * self.velocity + self.half_ts_sq * acceleration
    }

    /// Filtered position estimate.
    pub fn position(&self) -> T {
        self.position
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn observer(w: f64) -> TrackingObserver<f64> {
        TrackingObserver::new(&TrackingObserverConfig {
            bandwidth_rad_s: w,
            ts_s: 1e-4,
        })
        .unwrap()
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
            TrackingObserver::<f32>::new(&TrackingObserverConfig {
                bandwidth_rad_s: w,
                ts_s: ts,
            })
            .err()
        };
        assert_eq!(
            bad(f64::NAN, 1e-4),
            Some(ConfigError::not_finite("bandwidth_rad_s"))
        );
        assert_eq!(bad(100.0, 0.0), Some(ConfigError::not_positive("ts_s")));
        assert_eq!(
            bad(1e5, 1e-4),
            Some(ConfigError::out_of_range("bandwidth_rad_s"))
        );
    }
}
