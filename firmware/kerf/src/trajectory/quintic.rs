//! Rest-to-rest minimum-jerk move: x(t) = x0 + D s(τ), τ = t/T,
//! s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ (zero velocity and acceleration at both ends).
//! Peak velocity 1.875 D/T, peak acceleration 5.7735 D/T².

use super::Reference;
use crate::error::{coefficient, positive, representable, ConfigError};
use crate::scalar::Real;

/// A single rest-to-rest move, coefficients precomputed so evaluation is `+ − *` only.
#[derive(Copy, Clone, Debug)]
pub struct Quintic<T> {
    start: T,
    distance: T,
    inv_duration: T,
    velocity_scale: T,
    acceleration_scale: T,
}

impl<T: Real> Quintic<T> {
    /// A move of `distance_m` (either sign) starting at `start_m`, lasting `duration_s`.
    pub fn new(start_m: f64, distance_m: f64, duration_s: f64) -> Result<Self, ConfigError> {
        let duration = positive("duration_s", duration_s)?;
        if !start_m.is_finite() {
            return Err(ConfigError::not_finite("start_m"));
        }
        if !distance_m.is_finite() {
            return Err(ConfigError::not_finite("distance_m"));
        }
        // Every derived value in the target scalar: f64-valid extremes can overflow f32.
        let scaled = |value: f64| representable("distance_m", value);
        Ok(Self {
            start: representable("start_m", start_m)?,
            distance: representable("distance_m", distance_m)?,
            inv_duration: coefficient("duration_s", 1.0 / duration)?,
            velocity_scale: scaled(distance_m / duration)?,
            acceleration_scale: scaled(distance_m / (duration * duration))?,
        })
    }

    /// Standing still at `position_m`.
    pub fn at_rest(position_m: T) -> Self {
        Self {
            start: position_m,
            distance: T::ZERO,
            inv_duration: T::ZERO,
            velocity_scale: T::ZERO,
            acceleration_scale: T::ZERO,
        }
    }

    /// Reference at `t_s` seconds after the start (held at the ends outside [0, T]).
    ///
    /// `t_s` is the move's own time, k·Ts from an integer period count (as `Joints`
    /// computes it), never an accumulated sum: f32 time summed period by period drifts
    /// by a period within seconds. A NaN `t_s` passes through to the reference (a pure
    /// kernel; the axis step latches a fault on it).
    pub fn sample(&self, t_s: T) -> Reference<T> {
        let one = T::from_f64(1.0);
        let mut tau = t_s * self.inv_duration;
        if tau < T::ZERO {
            tau = T::ZERO;
        } else if tau > one {
            tau = one;
        }
        let c = |v: f64| T::from_f64(v);
        let t2 = tau * tau;
        let t3 = t2 * tau;
        // s = τ³(10 − 15τ + 6τ²), s' = 30τ²(1 − τ)², s'' = 60τ(1 − τ)(1 − 2τ)
        let s = t3 * (c(10.0) - c(15.0) * tau + c(6.0) * t2);
        let u = one - tau;
        let ds = c(30.0) * t2 * u * u;
        let dds = c(60.0) * tau * u * (one - c(2.0) * tau);
        Reference {
            position: self.start + self.distance * s,
            velocity: self.velocity_scale * ds,
            acceleration: self.acceleration_scale * dds,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_match_finite_differences() {
        let q = Quintic::<f64>::new(0.005, 0.03, 0.4).unwrap();
        let h = 1e-6;
        for k in 1..400 {
            let t = k as f64 * 1e-3;
            let (a, b, r) = (q.sample(t - h), q.sample(t + h), q.sample(t));
            assert!(((b.position - a.position) / (2.0 * h) - r.velocity).abs() < 1e-7);
            assert!(((b.velocity - a.velocity) / (2.0 * h) - r.acceleration).abs() < 1e-5);
        }
        assert_eq!(q.sample(-1.0).position, 0.005);
        assert!((q.sample(1.0).position - 0.035).abs() < 1e-15);
        // Peak velocity 1.875 D/T at mid-move.
        assert!((q.sample(0.2).velocity - 1.875 * 0.03 / 0.4).abs() < 1e-12);
    }

    #[test]
    fn rejects_bad_input() {
        assert_eq!(
            Quintic::<f32>::new(0.0, 0.03, 0.0).err(),
            Some(ConfigError::not_positive("duration_s"))
        );
        assert_eq!(
            Quintic::<f32>::new(f64::NAN, 0.03, 1.0).err(),
            Some(ConfigError::not_finite("start_m"))
        );
    }

    /// Valid in f64, overflowing in f32: a typed error, not a curve of infinities.
    #[test]
    fn f32_extremes_are_refused_by_name() {
        let cases = [
            ((1e39, 0.03, 1.0), "start_m"),
            ((0.0, 1e39, 1.0), "distance_m"),
            ((0.0, 0.03, 1e-39), "duration_s"),
            ((0.0, 1e30, 1e-10), "distance_m"),
        ];
        for ((start, distance, duration), field) in cases {
            assert_eq!(
                Quintic::<f32>::new(start, distance, duration).err(),
                Some(ConfigError::not_representable(field)),
                "{start} {distance} {duration}"
            );
        }
        // The same in f64 are fine, and an f32 curve from them samples finite.
        assert!(Quintic::<f64>::new(1e39, 0.03, 1.0).is_ok());
        let q = Quintic::<f32>::new(0.0, 0.03, 1e-6).unwrap();
        let r = q.sample(5e-7);
        assert!(r.position.is_finite() && r.velocity.is_finite() && r.acceleration.is_finite());
    }

    /// 1/T is a coefficient of the scalar: a duration whose inverse underflows f32 (a
    /// move that would never move) is refused there, and accepted in f64.
    #[test]
    fn a_duration_whose_inverse_the_scalar_cannot_hold_is_refused() {
        assert_eq!(
            Quintic::<f32>::new(0.0, 0.01, 1e50).err(),
            Some(ConfigError::not_representable("duration_s"))
        );
        assert!(Quintic::<f64>::new(0.0, 0.01, 1e50).is_ok());
        assert!(Quintic::<f32>::new(0.0, 0.01, 1e30).is_ok());
    }
}
