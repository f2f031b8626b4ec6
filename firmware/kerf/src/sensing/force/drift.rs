//! A bias that drifts: out of contact the bias-compensated forces
//! are the sensor's noise around zero, so the mean of a window of them estimates how
//! far the bias has moved since its capture.
//!
//! The bound: with force noise σ per component (G 5.2: the measured data's variance
//! 0.8 N², σ = 0.894 N) the mean of a window of n independent samples has the
//! standard deviation σ/√n, and the captured bias, itself the mean of m samples, is
//! off by σ/√m; the difference of the two has σ_d = σ·√(1/n + 1/m). A component whose
//! window mean exceeds k·σ_d is a drift. G's cell (n = 1000, 1 s at 1 kHz;
//! m = 500; k = 6) gives σ_d = 0.049 N and a bound of 0.294 N: noise alone crosses
//! 6σ in 2.0·10⁻⁹ of windows, over three components once in about five years of
//! one-second windows at rest, while a drift is found before it adds 0.3 N plus the
//! drift of one and a half windows to the normal force.
//!
//! Non-overlapping windows: a linear drift of rate r gives a window ending at t the
//! mean r·(t − W/2) (from the capture), so it is found at the end of the first window
//! whose mean exceeds the bound; the drift then is at most the bound plus 1.5·r·W.
//! The watch only knows forces: which samples are out of contact is the machine's
//! call (`machines::grinding` feeds it at rest only).

use super::Wrench;
use crate::error::{positive, ConfigError};
use crate::scalar::{to_f64, Float};

/// How to watch for drift.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct BiasDriftConfig {
    /// Samples in a window (0: no watch).
    pub window_samples: u32,
    /// The bound in standard deviations of the window mean's difference from the
    /// capture (module docs).
    pub sigmas: f64,
    /// Time at rest before the watch starts, s: the piezo's retraction takes the tool
    /// off the surface (G eq. 34's identified stage, 5.7 Hz with damping 0.72,
    /// settles to 2 % in about 0.16 s).
    pub settle_s: f64,
}

impl BiasDriftConfig {
    /// G's cell: windows of 1 s at 1 kHz, 6σ, watching after 0.5 s at rest
    /// (three settling times of the stage).
    pub const PUBLISHED: Self = Self {
        window_samples: 1000,
        sigmas: 6.0,
        settle_s: 0.5,
    };
}

/// The bias moved: a force component's window mean left the bound.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BiasDrift {
    /// The component, 0 Fx, 1 Fy, 2 Fz.
    pub component: u8,
    /// Its window mean, N.
    pub mean_n: f32,
    /// The bound, N.
    pub bound_n: f32,
}

/// Window means of the compensated forces against a bound set by the noise.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct BiasDriftWatch {
    window: u32,
    bound_n: f64,
    count: u32,
    sum_n: [f64; 3],
}

impl BiasDriftWatch {
    /// The watch for readings with force noise `noise_n` (σ per component, N) against
    /// a bias captured from `capture_samples` samples; `None` when
    /// `config.window_samples` is 0.
    pub fn new(
        config: &BiasDriftConfig,
        noise_n: f64,
        capture_samples: u32,
    ) -> Result<Option<Self>, ConfigError> {
        if config.window_samples == 0 {
            return Ok(None);
        }
        let sigmas = positive("sigmas", config.sigmas)?;
        let noise = positive("noise_n", noise_n)?;
        if capture_samples == 0 {
            return Err(ConfigError::not_positive("samples"));
        }
        let n = f64::from(config.window_samples);
        let m = f64::from(capture_samples);
        Ok(Some(Self {
            window: config.window_samples,
            bound_n: sigmas * noise * libm::sqrt(1.0 / n + 1.0 / m),
            count: 0,
            sum_n: [0.0; 3],
        }))
    }

    /// The bound on a window mean, N.
    pub fn bound_n(&self) -> f64 {
        self.bound_n
    }

    /// Starts a new window (after contact, or a new bias).
    pub fn restart(&mut self) {
        self.count = 0;
        self.sum_n = [0.0; 3];
    }

    /// Adds one compensated reading taken out of contact; at the end of a window
    /// checks its means (lowest component first) and starts the next. Sums in `f64`
    /// as the bias capture does. A mean that is not finite is a drift too.
    pub fn push<T: Float>(&mut self, wrench: &Wrench<T>) -> Result<(), BiasDrift> {
        for (s, &f) in self.sum_n.iter_mut().zip(&wrench.force_n) {
            *s += to_f64(f);
        }
        self.count += 1;
        if self.count < self.window {
            return Ok(());
        }
        let n = f64::from(self.count);
        let sums = self.sum_n;
        self.restart();
        for (component, s) in (0u8..).zip(sums) {
            let mean = s / n;
            let within = libm::fabs(mean) <= self.bound_n;
            if !within {
                return Err(BiasDrift {
                    component,
                    mean_n: mean as f32,
                    bound_n: self.bound_n as f32,
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn force(f: [f64; 3]) -> Wrench<f64> {
        Wrench {
            force_n: f,
            torque_n_m: [0.0; 3],
        }
    }

    /// G's bound is 6 · 0.894 · √(1/1000 + 1/500) = 0.294 N; a window whose
    /// mean is just inside passes, just outside faults at its last sample with the
    /// component and mean; NaN faults; a zero window is no watch.
    #[test]
    fn window_means_against_the_noise_bound() {
        let mut w = BiasDriftWatch::new(&BiasDriftConfig::PUBLISHED, 0.894, 500)
            .unwrap()
            .unwrap();
        assert!((w.bound_n() - 0.29380).abs() < 1e-4, "{}", w.bound_n());
        for _ in 0..1000 {
            assert_eq!(w.push(&force([0.29, -0.29, 0.0])), Ok(()));
        }
        for _ in 0..999 {
            assert_eq!(w.push(&force([0.0, -0.30, 0.0])), Ok(()));
        }
        let e = w.push(&force([0.0, -0.30, 0.0])).unwrap_err();
        assert_eq!(e.component, 1);
        assert!((e.mean_n + 0.30).abs() < 1e-6);
        // The next window starts afresh.
        for _ in 0..1000 {
            assert_eq!(w.push(&force([0.0; 3])), Ok(()));
        }
        for _ in 0..999 {
            let _ = w.push(&force([0.0, 0.0, f64::NAN]));
        }
        assert_eq!(w.push(&force([0.0; 3])).unwrap_err().component, 2);
        let off = BiasDriftConfig {
            window_samples: 0,
            ..BiasDriftConfig::PUBLISHED
        };
        assert_eq!(BiasDriftWatch::new(&off, 0.0, 500), Ok(None));
        assert!(BiasDriftWatch::new(&BiasDriftConfig::PUBLISHED, 0.0, 500).is_err());
    }
}
