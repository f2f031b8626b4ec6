//! Disturbance observer, velocity form (SPEC `control` DOB, T 4.1.2).
//!
//! The plant is An q̈ = F − Fdis, where Fdis lumps friction, load, and the error of the
//! nominal mass An. The estimate is F̂dis = LPF_g(F − An q̈) with LPF_g = g/(s + g).
//! Writing An q̈ = An s q̇ and moving it through the filter removes the derivative:
//!
//!   F̂dis = LPF_g(F + g An q̇) − g An q̇,
//!
//! so only the velocity is needed. The first-order filter is discretized exactly
//! (zero-order hold): z ← z + (1 − e^(−g Ts)) (F + g An q̇ − z).
//!
//! The command is F = An q̈des + F̂dis, saturated to the force limit, and the
//! saturated force is what the filter sees (otherwise it winds up). Choose An at or
//! below the lightest expected moving mass: overestimating it destabilizes the loop
//! at high observer bandwidth.

use crate::error::{positive, ConfigError};
use crate::scalar::Real;

/// Observer configuration.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DobConfig {
    /// Nominal moving mass An in kg.
    pub nominal_mass_kg: f64,
    /// Observer bandwidth g in rad/s.
    pub bandwidth_rad_s: f64,
    /// Sample period in s.
    pub ts_s: f64,
    /// Force saturation |F| ≤ limit in N (the motor's continuous force).
    pub force_limit_n: f64,
    /// Add the estimate to the command. `false` runs the observer as a monitor only
    /// (plain An·q̈des), which is how the benefit of the DOB is measured.
    pub compensate: bool,
}

/// Disturbance observer for one axis.
#[derive(Copy, Clone, Debug)]
pub struct Dob<T> {
    mass: T,
    inv_mass: T,
    g_mass: T,
    filter_gain: T,
    force_limit: T,
    compensate: bool,
    filtered: T,
    estimate: T,
}

/// One period's result.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DobOutput<T> {
    /// Force to apply in N (saturated).
    pub force_n: T,
    /// Disturbance estimate F̂dis in N used in this command.
    pub disturbance_n: T,
}

impl<T: Real> Dob<T> {
    /// Validates the configuration (all fields finite and positive; g·Ts ≤ 2).
    pub fn new(config: &DobConfig) -> Result<Self, ConfigError> {
        let mass = positive("nominal_mass_kg", config.nominal_mass_kg)?;
        let g = positive("bandwidth_rad_s", config.bandwidth_rad_s)?;
        let ts = positive("ts_s", config.ts_s)?;
        let limit = positive("force_limit_n", config.force_limit_n)?;
        if g * ts > 2.0 {
            return Err(ConfigError::out_of_range("bandwidth_rad_s"));
        }
        Ok(Self {
            mass: T::from_f64(mass),
            inv_mass: T::from_f64(1.0 / mass),
            g_mass: T::from_f64(g * mass),
            filter_gain: T::from_f64(1.0 - libm::exp(-g * ts)),
            force_limit: T::from_f64(limit),
            compensate: config.compensate,
            filtered: T::ZERO,
            estimate: T::ZERO,
        })
    }

    /// Clears the estimate (after a fault or at enable); `velocity` is the present one.
    pub fn reset(&mut self, velocity: T) {
        self.filtered = self.g_mass * velocity;
        self.estimate = T::ZERO;
    }

    /// Force command for the desired acceleration, then the observer update with the
    /// force actually applied and the present velocity estimate.
    #[inline]
    pub fn update(&mut self, acceleration_des: T, velocity: T) -> DobOutput<T> {
        let g_mass_velocity = self.g_mass * velocity;
        let disturbance_n = self.estimate;
        let compensation = if self.compensate {
            disturbance_n
        } else {
            T::ZERO
        };
        let force_n = (self.mass * acceleration_des + compensation).clamp_abs(self.force_limit);
        self.filtered =
            self.filtered + self.filter_gain * (force_n + g_mass_velocity - self.filtered);
        self.estimate = self.filtered - g_mass_velocity;
        DobOutput {
            force_n,
            disturbance_n,
        }
    }
}

impl<T: Real> Dob<T> {
    /// Acceleration the nominal plant gets from `out`: (F − F̂dis)/An.
    #[inline]
    pub fn applied_acceleration(&self, out: &DobOutput<T>) -> T {
        (out.force_n - out.disturbance_n) * self.inv_mass
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CFG: DobConfig = DobConfig {
        nominal_mass_kg: 0.1,
        bandwidth_rad_s: 600.0,
        ts_s: 1e-4,
        force_limit_n: 3.6,
        compensate: true,
    };

    /// Open loop against an exact plant m v̇ = F − d: with a constant disturbance the
    /// estimate converges to d, and its step response follows 1 − e^(−g t).
    #[test]
    fn estimate_converges_with_the_designed_time_constant() {
        let mut dob = Dob::<f64>::new(&CFG).unwrap();
        let (m, d, ts) = (0.1, 0.5, 1e-4);
        let mut v = 0.0;
        let mut at_tau = 0.0;
        for k in 0..2000 {
            let out = dob.update(0.0, v);
            v += ts * (out.force_n - d) / m;
            if k == (1.0 / 600.0 / ts) as usize {
                at_tau = dob.estimate;
            }
        }
        assert!((dob.estimate - d).abs() < 1e-6, "{}", dob.estimate);
        // After one time constant the estimate is (1 − 1/e) of the step (±3 % for the
        // one-period delay of the discrete loop).
        assert!(
            (at_tau / d - (1.0 - (-1.0f64).exp())).abs() < 0.03,
            "{at_tau}"
        );
    }

    #[test]
    fn output_saturates_and_the_observer_sees_the_saturated_force() {
        let mut dob = Dob::<f64>::new(&CFG).unwrap();
        // Ask for 100 m/s² with a blocked axis (v = 0): force clamps at the limit and the
        // estimate tends to the applied force (the "disturbance" holding the axis), not beyond.
        let mut out = dob.update(100.0, 0.0);
        for _ in 0..5000 {
            out = dob.update(100.0, 0.0);
        }
        assert_eq!(out.force_n, 3.6);
        assert!((dob.estimate - 3.6).abs() < 1e-6, "{}", dob.estimate);
    }

    #[test]
    fn rejects_bad_config() {
        let with = |f: fn(&mut DobConfig)| {
            let mut c = CFG;
            f(&mut c);
            Dob::<f32>::new(&c).err()
        };
        assert_eq!(
            with(|c| c.nominal_mass_kg = -0.1),
            Some(ConfigError::not_positive("nominal_mass_kg"))
        );
        assert_eq!(
            with(|c| c.bandwidth_rad_s = f64::INFINITY),
            Some(ConfigError::not_finite("bandwidth_rad_s"))
        );
        assert_eq!(
            with(|c| c.ts_s = 0.0),
            Some(ConfigError::not_positive("ts_s"))
        );
        assert_eq!(
            with(|c| c.force_limit_n = 0.0),
            Some(ConfigError::not_positive("force_limit_n"))
        );
        assert_eq!(
            with(|c| c.bandwidth_rad_s = 3e4),
            Some(ConfigError::out_of_range("bandwidth_rad_s"))
        );
    }
}
