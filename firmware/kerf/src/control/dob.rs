//! Disturbance observer, velocity form (docs/control.md §17, T 4.1.2).
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

use crate::error::{coefficient, factor, positive, ConfigError};
use crate::scalar::Real;

/// Observer configuration (the period comes from the machine).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DobConfig {
    /// Nominal moving mass An in kg.
    pub nominal_mass_kg: f64,
    /// Observer bandwidth g in rad/s.
    pub bandwidth_rad_s: f64,
    /// Force saturation |F| ≤ limit in N (the motor's continuous force).
    pub force_limit_n: f64,
    /// Add the estimate to the command. `false` runs the observer as a monitor only
    /// (plain An·q̈des), which is how the benefit of the DOB is measured.
    pub compensate: bool,
}

/// Disturbance observer coefficients in the scalar `T`; one set drives the
/// [`DobState`]s of any number of axes.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Dob<T: Real> {
    mass: T::Coef,
    inv_mass: T::Coef,
    g_mass: T::Coef,
    filter_gain: T::Coef,
    /// (1 − k)·g·An: weight of the velocity change in the state update.
    decay_g_mass: T::Coef,
    force_limit: T,
    compensate: bool,
}

/// State of one axis' observer, in physical units (so new coefficients take over
/// without a jump in the estimate).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DobState<T> {
    /// Disturbance estimate F̂dis for the next command, N.
    pub estimate_n: T,
    /// Velocity at the last update, m/s.
    pub velocity_m_s: T,
}

impl<T: Real> DobState<T> {
    /// No disturbance estimated yet, moving at `velocity` (after a fault or at enable).
    pub fn at(velocity: T) -> Self {
        Self {
            estimate_n: T::ZERO,
            velocity_m_s: velocity,
        }
    }
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
    /// Validates the configuration for control period `ts_s` (all fields finite and
    /// positive; g·Ts ≤ 2; every coefficient representable in `T`).
    pub fn new(config: &DobConfig, ts_s: f64) -> Result<Self, ConfigError> {
        let mass = positive("nominal_mass_kg", config.nominal_mass_kg)?;
        let g = positive("bandwidth_rad_s", config.bandwidth_rad_s)?;
        let ts = positive("period_s", ts_s)?;
        let limit = positive("force_limit_n", config.force_limit_n)?;
        if g * ts > 2.0 {
            return Err(ConfigError::out_of_range("bandwidth_rad_s"));
        }
        // k = 1 − e^(−g Ts) without cancellation when g Ts is small.
        let k = -libm::expm1(-g * ts);
        Ok(Self {
            mass: factor::<T>("nominal_mass_kg", mass)?,
            inv_mass: factor::<T>("nominal_mass_kg", 1.0 / mass)?,
            g_mass: factor::<T>("bandwidth_rad_s", g * mass)?,
            filter_gain: factor::<T>("bandwidth_rad_s", k)?,
            decay_g_mass: factor::<T>("bandwidth_rad_s", (1.0 - k) * g * mass)?,
            force_limit: coefficient("force_limit_n", limit)?,
            compensate: config.compensate,
        })
    }

    /// Force command for the desired acceleration, then the observer update with the
    /// force actually applied and the present velocity estimate.
    ///
    /// NaN or ±∞ in (or finite input so large that the arithmetic overflows) passes through to the output: a pure kernel of the period, it does not test; the machine's step does (`AxisLaw::step` latches a fault). The saturation passes NaN.
    ///
    /// With z = LPF(F + g An v) and F̂ = z − g An v (module docs), one ZOH step
    /// z ← z + k (F + g An v − z) is, in terms of the estimate and the last velocity v₋,
    /// F̂ ← F̂ + k (F − F̂) + (1 − k) g An (v₋ − v).
    #[inline]
    pub fn update(
        &self,
        state: &mut DobState<T>,
        acceleration_des: T,
        velocity: T,
    ) -> DobOutput<T> {
        let disturbance_n = state.estimate_n;
        let compensation = if self.compensate {
            disturbance_n
        } else {
            T::ZERO
        };
        let force_n =
            (acceleration_des.scale(self.mass) + compensation).clamp_abs(self.force_limit);
        state.estimate_n = disturbance_n
            + (force_n - disturbance_n).scale(self.filter_gain)
            + (state.velocity_m_s - velocity).scale(self.decay_g_mass);
        state.velocity_m_s = velocity;
        DobOutput {
            force_n,
            disturbance_n,
        }
    }

    /// Whether `out`'s force is at the limit (the law asked for at least as much).
    #[inline]
    pub fn is_saturated(&self, out: &DobOutput<T>) -> bool {
        !(out.force_n < self.force_limit && out.force_n > -self.force_limit)
    }

    /// Acceleration the nominal plant gets from `out`: (F − F̂dis)/An.
    #[inline]
    pub fn applied_acceleration(&self, out: &DobOutput<T>) -> T {
        (out.force_n - out.disturbance_n).scale(self.inv_mass)
    }

    /// The same observer in the filtered form z = F̂ + g·An·v, for the tests' check
    /// of the state update against the module docs' filter.
    #[cfg(test)]
    fn g_mass(&self) -> T::Coef {
        self.g_mass
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CFG: DobConfig = DobConfig {
        nominal_mass_kg: 0.1,
        bandwidth_rad_s: 600.0,
        force_limit_n: 3.6,
        compensate: true,
    };
    const TS_S: f64 = 1e-4;

    /// Open loop against an exact plant m v̇ = F − d: with a constant disturbance the
    /// estimate converges to d, and its step response follows 1 − e^(−g t).
    #[test]
    fn estimate_converges_with_the_designed_time_constant() {
        let dob = Dob::<f64>::new(&CFG, TS_S).unwrap();
        let mut state = DobState::at(0.0);
        let (m, d, ts) = (0.1, 0.5, 1e-4);
        let mut v = 0.0;
        let mut at_tau = 0.0;
        for k in 0..2000 {
            let out = dob.update(&mut state, 0.0, v);
            v += ts * (out.force_n - d) / m;
            if k == (1.0 / 600.0 / ts) as usize {
                at_tau = state.estimate_n;
            }
        }
        assert!((state.estimate_n - d).abs() < 1e-6, "{}", state.estimate_n);
        // After one time constant the estimate is (1 − 1/e) of the step (±3 % for the
        // one-period delay of the discrete loop).
        assert!(
            (at_tau / d - (1.0 - (-1.0f64).exp())).abs() < 0.03,
            "{at_tau}"
        );
    }

    #[test]
    fn output_saturates_and_the_observer_sees_the_saturated_force() {
        let dob = Dob::<f64>::new(&CFG, TS_S).unwrap();
        let mut state = DobState::at(0.0);
        // Ask for 100 m/s² with a blocked axis (v = 0): force clamps at the limit and the
        // estimate tends to the applied force (the "disturbance" holding the axis), not beyond.
        let mut out = dob.update(&mut state, 100.0, 0.0);
        for _ in 0..5000 {
            out = dob.update(&mut state, 100.0, 0.0);
        }
        assert_eq!(out.force_n, 3.6);
        assert!(
            (state.estimate_n - 3.6).abs() < 1e-6,
            "{}",
            state.estimate_n
        );
    }

    #[test]
    fn rejects_bad_config() {
        let with = |f: fn(&mut DobConfig)| {
            let mut c = CFG;
            f(&mut c);
            Dob::<f32>::new(&c, TS_S).err()
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
            Dob::<f32>::new(&CFG, 0.0).err(),
            Some(ConfigError::not_positive("period_s"))
        );
        // Fine in f64, but g·An overflows f32 and a tiny bandwidth's filter gain
        // underflows it.
        let huge_mass = DobConfig {
            nominal_mass_kg: 1e37,
            ..CFG
        };
        assert!(Dob::<f64>::new(&huge_mass, TS_S).is_ok());
        assert_eq!(
            Dob::<f32>::new(&huge_mass, TS_S).err(),
            Some(ConfigError::not_representable("bandwidth_rad_s"))
        );
        let tiny_bandwidth = DobConfig {
            bandwidth_rad_s: 1e-300,
            ..CFG
        };
        assert!(Dob::<f64>::new(&tiny_bandwidth, TS_S).is_ok());
        assert_eq!(
            Dob::<f32>::new(&tiny_bandwidth, TS_S).err(),
            Some(ConfigError::not_representable("bandwidth_rad_s"))
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

    /// The state update in estimate form against the filter form of the module docs,
    /// z ← z + k (F + g An v − z), F̂ = z − g An v, run side by side on a noisy input.
    #[test]
    fn estimate_form_matches_the_filter_form() {
        let dob = Dob::<f64>::new(&CFG, TS_S).unwrap();
        let k = 1.0 - (-600.0f64 * TS_S).exp();
        let mut state = DobState::at(0.02);
        let mut z = dob.g_mass() * 0.02;
        let mut worst = 0.0f64;
        for n in 0..5000 {
            let v = 0.02 + 0.1 * (n as f64 * 0.013).sin() + 0.003 * ((n * 7919) % 13) as f64;
            let a = 50.0 * (n as f64 * 0.007).cos();
            let out = dob.update(&mut state, a, v);
            z += k * (out.force_n + dob.g_mass() * v - z);
            worst = worst.max((state.estimate_n - (z - dob.g_mass() * v)).abs());
        }
        assert!(worst < 1e-12, "{worst}");
    }

    /// A new bandwidth (or mass) mid-run: the estimate carries over, so the next force
    /// differs from the old coefficients' only by ΔAn·q̈des, not by a Δ(g·An)·v jump.
    #[test]
    fn new_coefficients_keep_the_estimate() {
        let dob = Dob::<f64>::new(&CFG, TS_S).unwrap();
        let mut state = DobState::at(0.0);
        let mut v = 0.0;
        for _ in 0..3000 {
            let out = dob.update(&mut state, 2.0, v);
            v += TS_S * (out.force_n - 0.5) / 0.1;
        }
        let wider = Dob::<f64>::new(
            &DobConfig {
                bandwidth_rad_s: 900.0,
                ..CFG
            },
            TS_S,
        )
        .unwrap();
        let (mut old_state, mut new_state) = (state, state);
        let old = dob.update(&mut old_state, 2.0, v);
        let new = wider.update(&mut new_state, 2.0, v);
        assert_eq!(old.force_n, new.force_n);
        assert!(v > 0.5, "{v}");
    }
}
