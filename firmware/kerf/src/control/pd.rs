//! Joint PD tracking law with acceleration feedforward (T 4.2, without preview):
//! q̈des = q̈ref + Kd (q̇ref − q̇) + Kp (qref − q).

use crate::error::{factor, positive, ConfigError};
use crate::scalar::Real;
use crate::trajectory::Reference;

/// PD gains, usually designed from a closed-loop bandwidth with [`PdConfig::critically_damped`].
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PdConfig {
    /// Position gain Kp in s⁻².
    pub kp_per_s2: f64,
    /// Velocity gain Kd in s⁻¹.
    pub kd_per_s: f64,
}

impl PdConfig {
    /// Error dynamics ë + Kd ė + Kp e = 0 with a double pole at −ω: Kp = ω², Kd = 2ω.
    pub const fn critically_damped(bandwidth_rad_s: f64) -> Self {
        Self {
            kp_per_s2: bandwidth_rad_s * bandwidth_rad_s,
            kd_per_s: 2.0 * bandwidth_rad_s,
        }
    }
}

/// PD law with gains in the scalar `T` (coefficients only: the law has no state).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Pd<T: Real> {
    kp: T::Coef,
    kd: T::Coef,
}

impl<T: Real> Pd<T> {
    /// Validates the gains (finite, strictly positive).
    pub fn new(config: &PdConfig) -> Result<Self, ConfigError> {
        Ok(Self {
            kp: factor::<T>("kp_per_s2", positive("kp_per_s2", config.kp_per_s2)?)?,
            kd: factor::<T>("kd_per_s", positive("kd_per_s", config.kd_per_s)?)?,
        })
    }

    /// Desired acceleration in m/s² from the reference and the measured state.
    ///
    /// NaN or ±∞ in (or finite input so large that the arithmetic overflows) passes through to the output: a pure kernel of the period, it does not test; the machine's step does (`AxisLaw::step` latches a fault).
    #[inline]
    pub fn acceleration(&self, reference: &Reference<T>, position: T, velocity: T) -> T {
        reference.acceleration
            + (reference.velocity - velocity).scale(self.kd)
            + (reference.position - position).scale(self.kp)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn law_matches_hand_computation() {
        let pd = Pd::<f64>::new(&PdConfig {
            kp_per_s2: 400.0,
            kd_per_s: 40.0,
        })
        .unwrap();
        let r = Reference {
            position: 0.01,
            velocity: 0.2,
            acceleration: 3.0,
        };
        // 3 + 40·(0.2 − 0.1) + 400·(0.01 − 0.004) = 3 + 4 + 2.4
        assert!((pd.acceleration(&r, 0.004, 0.1) - 9.4).abs() < 1e-12);
    }

    #[test]
    fn rejects_non_positive_gains() {
        assert_eq!(
            Pd::<f32>::new(&PdConfig {
                kp_per_s2: 0.0,
                kd_per_s: 1.0
            })
            .err(),
            Some(ConfigError::not_positive("kp_per_s2"))
        );
        assert_eq!(
            Pd::<f32>::new(&PdConfig {
                kp_per_s2: 1.0,
                kd_per_s: f64::NAN
            })
            .err(),
            Some(ConfigError::not_finite("kd_per_s"))
        );
        assert_eq!(
            Pd::<f32>::new(&PdConfig {
                kp_per_s2: 1.0,
                kd_per_s: -2.0
            })
            .err(),
            Some(ConfigError::not_positive("kd_per_s"))
        );
    }
}
