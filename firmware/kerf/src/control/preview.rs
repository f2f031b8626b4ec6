//! Joint PD with preview of the reference (docs/control.md §18, T 4.2.1):
//!
//!   q̈des(k) = q̈ref(k+2) + KP2 (q̇ref(k+1) − q̇(k)) + KP1 (qref(k) − q(k)),
//!   KP2 = S2⁻¹ (S1 + λ S2),   KP1 = S2⁻¹ λ S1.
//!
//! The gains come from a sliding surface σ = S1 e + S2 ė (e = qref − q) reached at the
//! rate σ̇ = −λσ: S2 ë + S1 ė = −λ (S1 e + S2 ė), i.e. ë + KP2 ė + KP1 e = 0 with the
//! error poles at −S1/S2 and −λ. Per joint the matrices are scalars, so the law takes
//! the surface slope c = S1/S2 and the reaching rate λ (both s⁻¹); c = λ = ω is the
//! critically damped PD of bandwidth ω (KP1 = ω², KP2 = 2ω).
//!
//! The preview is the shift of the reference: the acceleration feedforward is taken two
//! periods ahead and the velocity one ahead. A force computed at k is held over the
//! next period and reaches the carriage through the current loop and the disturbance
//! observer, so the acceleration it produces lags the command; feeding the reference
//! that far ahead cancels the lag where the path turns (the corners of an open
//! contour, T fig. 8.1), where plain PD lets the carriages fall behind. The reference
//! must therefore be known two periods ahead: [`PreviewWindow`] keeps the three taps.
//!
//! The velocity tap has a price the print does not state: under a constant reference
//! acceleration q̈ref the error dynamics are driven by −KP2·Ts·q̈ref, so the carriage
//! settles KP2·Ts·q̈ref/KP1 ahead of the reference (at 40 Hz and 10 kHz, 0.8 µm per
//! m/s²). Plain PD with the exact feedforward settles on it.

use crate::error::{coefficient, positive, ConfigError};
use crate::scalar::Real;
use crate::trajectory::Reference;

/// The sliding-surface design of the law, per joint.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PreviewConfig {
    /// Slope of the sliding surface c = S1/S2 in s⁻¹ (one error pole at −c).
    pub surface_slope_per_s: f64,
    /// Reaching rate λ in s⁻¹ (the other error pole at −λ).
    pub reaching_rate_per_s: f64,
}

impl PreviewConfig {
    /// Both error poles at −ω: the same gains as
    /// [`PdConfig::critically_damped`](crate::control::pd::PdConfig::critically_damped)
    /// of the same bandwidth, so plain PD and preview are compared at one stiffness.
    pub fn critically_damped(bandwidth_rad_s: f64) -> Self {
        Self {
            surface_slope_per_s: bandwidth_rad_s,
            reaching_rate_per_s: bandwidth_rad_s,
        }
    }
}

/// The law's gains in the scalar `T` (it keeps no state; the reference taps are the
/// caller's [`PreviewWindow`]).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Preview<T> {
    /// KP1 = λ c, s⁻².
    kp1: T,
    /// KP2 = c + λ, s⁻¹.
    kp2: T,
}

impl<T: Real> Preview<T> {
    /// Validates the design (finite, strictly positive) into gains.
    pub fn new(config: &PreviewConfig) -> Result<Self, ConfigError> {
        let c = positive("surface_slope_per_s", config.surface_slope_per_s)?;
        let lambda = positive("reaching_rate_per_s", config.reaching_rate_per_s)?;
        Ok(Self {
            kp1: coefficient("reaching_rate_per_s", lambda * c)?,
            kp2: coefficient("reaching_rate_per_s", c + lambda)?,
        })
    }

    /// KP1 in s⁻² and KP2 in s⁻¹, as `f64`.
    pub fn gains(&self) -> (f64, f64) {
        (self.kp1.to_f64(), self.kp2.to_f64())
    }

    /// Desired acceleration (m/s²) of one joint from the window's taps and the measured
    /// position and velocity. NaN in passes through (the machine's step tests the loop).
    #[inline]
    pub fn acceleration(
        &self,
        window: &PreviewWindow<Reference<T>>,
        position: T,
        velocity: T,
    ) -> T {
        let [now, next, after_next] = &window.taps;
        after_next.acceleration
            + self.kp2 * (next.velocity - velocity)
            + self.kp1 * (now.position - position)
    }
}

/// The reference at k, k+1 and k+2: the generator runs two periods ahead and
/// [`PreviewWindow::push`] shifts in each new sample.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PreviewWindow<R> {
    /// [k, k+1, k+2].
    taps: [R; 3],
}

impl<R: Copy> PreviewWindow<R> {
    /// A window holding `reference` in every tap (a reference at rest).
    pub fn filled(reference: R) -> Self {
        Self {
            taps: [reference; 3],
        }
    }

    /// Shifts in the sample for k+3: what was k+1 becomes the present.
    pub fn push(&mut self, after_next: R) {
        let [_, next, last] = self.taps;
        self.taps = [next, last, after_next];
    }

    /// The sample for the present period k.
    pub fn now(&self) -> &R {
        let [now, _, _] = &self.taps;
        now
    }

    /// The sample for k+2, the newest.
    pub fn newest(&self) -> &R {
        let [_, _, newest] = &self.taps;
        newest
    }

    /// Maps every tap (for example joint references from task references).
    pub fn map<S>(&self, f: impl FnMut(R) -> S) -> PreviewWindow<S> {
        PreviewWindow {
            taps: self.taps.map(f),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    fn reference(position: f64, velocity: f64, acceleration: f64) -> Reference<f64> {
        Reference {
            position,
            velocity,
            acceleration,
        }
    }

    #[test]
    fn error_poles_are_the_surface_slope_and_the_reaching_rate() {
        // ë + KP2 ė + KP1 e = 0: the roots of s² + KP2 s + KP1 by the quadratic
        // formula must be −c and −λ.
        for (c, lambda) in [(200.0, 300.0), (251.3, 251.3), (50.0, 900.0)] {
            let law = Preview::<f64>::new(&PreviewConfig {
                surface_slope_per_s: c,
                reaching_rate_per_s: lambda,
            })
            .unwrap();
            let (kp1, kp2) = law.gains();
            let disc = (kp2 * kp2 - 4.0 * kp1).max(0.0).sqrt();
            let mut roots = [(-kp2 - disc) / 2.0, (-kp2 + disc) / 2.0];
            roots.sort_by(f64::total_cmp);
            let mut expected = [-c, -lambda];
            expected.sort_by(f64::total_cmp);
            for (r, e) in roots.iter().zip(expected) {
                // A double root loses half the digits to the discriminant's rounding.
                assert!((r - e).abs() < 1e-6 * e.abs(), "{roots:?} vs {expected:?}");
            }
        }
    }

    #[test]
    fn each_term_takes_its_own_tap() {
        let law = Preview::<f64>::new(&PreviewConfig {
            surface_slope_per_s: 10.0,
            reaching_rate_per_s: 20.0,
        })
        .unwrap();
        let mut window = PreviewWindow::filled(reference(0.0, 0.0, 0.0));
        window.push(reference(1.0, 2.0, 3.0)); // k+2 → k+1 after the next push
        window.push(reference(4.0, 5.0, 6.0));
        window.push(reference(7.0, 8.0, 9.0));
        assert_eq!(window.now().position, 1.0);
        assert_eq!(window.newest().acceleration, 9.0);
        // 9 + 30·(5 − 0.5) + 200·(1 − 0.25), by hand.
        let a = law.acceleration(&window, 0.25, 0.5);
        assert_eq!(a, 9.0 + 30.0 * 4.5 + 200.0 * 0.75);
    }

    #[test]
    fn bad_designs_are_refused_by_name() {
        let refused = |c: f64, l: f64| {
            Preview::<f32>::new(&PreviewConfig {
                surface_slope_per_s: c,
                reaching_rate_per_s: l,
            })
            .err()
            .map(|e| std::string::ToString::to_string(&e))
        };
        assert!(refused(f64::NAN, 1.0)
            .unwrap()
            .contains("surface_slope_per_s"));
        assert!(refused(1.0, -1.0).unwrap().contains("reaching_rate_per_s"));
        assert!(refused(1e30, 1e30).unwrap().contains("reaching_rate_per_s"));
        assert!(refused(100.0, 100.0).is_none());
    }

    /// Runs the law on a double integrator (exact zero-order hold, the command acting
    /// in the period it is computed) tracking q = a0 t²/2 from rest, and returns the
    /// error qref − q after 0.1 s, when the transient (poles at −251 s⁻¹) has died out.
    fn steady_error(preview: bool, a0: f64) -> f64 {
        let ts = 1e-4;
        let law = Preview::<f64>::new(&PreviewConfig::critically_damped(2.0 * PI * 40.0)).unwrap();
        let (kp1, kp2) = law.gains();
        let at = |k: usize| {
            let t = k as f64 * ts;
            reference(0.5 * a0 * t * t, a0 * t, a0)
        };
        let mut window = PreviewWindow::filled(at(0));
        window.push(at(1));
        window.push(at(2));
        let (mut q, mut v) = (0.0, 0.0);
        for k in 0..1000 {
            let a = if preview {
                law.acceleration(&window, q, v)
            } else {
                let now = window.now();
                now.acceleration + kp2 * (now.velocity - v) + kp1 * (now.position - q)
            };
            q += v * ts + 0.5 * a * ts * ts;
            v += a * ts;
            window.push(at(k + 4));
        }
        window.now().position - q
    }

    #[test]
    fn the_velocity_tap_leads_by_kp2_ts_acceleration_over_kp1() {
        // Under a constant reference acceleration a0 the error dynamics are
        // ë + KP2 ė + KP1 e = −KP2·Ts·a0 (the velocity tap is one period, Ts·a0,
        // ahead), so the carriage settles ahead of the reference by KP2·Ts·a0/KP1;
        // plain PD with the exact feedforward settles on it.
        let (omega, ts) = (2.0 * PI * 40.0, 1e-4);
        for a0 in [1.0, -3.0] {
            let expected = -(2.0 * omega) * ts * a0 / (omega * omega);
            let preview = steady_error(true, a0);
            let plain = steady_error(false, a0);
            // The transient left after 0.1 s: (1 + 25) e^(−25) of the start-up error.
            assert!(
                (preview - expected).abs() < 1e-3 * expected.abs(),
                "{preview} vs {expected}"
            );
            assert!(plain.abs() < 1e-3 * expected.abs(), "{plain}");
        }
    }
}
