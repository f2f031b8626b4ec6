//! Laser power for a constant cut depth (docs/control.md §23, T ch. 4 and 9.2).
//!
//! At constant laser power P the depth removed along the path is inversely
//! proportional to the speed v of the spot along it (T ch. 4: "the removed material
//! from the processed region is inversely proportional to the processing velocity"):
//! what sets the depth is the energy per unit path length
//!
//!   e = P / v   (J/m).
//!
//! T keeps P constant and relies on the controller to hold v, so the depth
//! errs wherever v dips (corners); T 9.2 proposes adapting to the velocity instead.
//! [`LaserMode::ConstantEnergy`] does that: P = e_nom · |v_measured|, clamped to
//! [0, P_max], and the beam is off below a minimum speed (a dwell would burn
//! through). [`LaserMode::ConstantPower`] is T's mode: the beam stays on at
//! the set power while the job cuts, slow or not.
//!
//! The law has coefficients only ([`Laser`], from a machine-side [`LaserConfig`]) and
//! a per-job [`LaserMode`] validated against them; it keeps no state. The period's
//! step uses `+ − ×` and comparisons only, so it runs in `f32`, `f64` and [`Q31_32`]
//! alike. It never panics and never returns NaN: a speed that is NaN or infinite (a
//! sensor fault) turns the beam off, the safe state.
//!
//! [`Q31_32`]: crate::scalar::Q31_32

use crate::error::{coefficient, positive, representable, ConfigError};
use crate::scalar::Real;

/// The laser source as fitted to the machine (SI units).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct LaserConfig {
    /// Largest power the source delivers, W (duty 1).
    pub max_power_w: f64,
    /// Below this speed along the path the constant-energy mode turns the beam off,
    /// m/s (strictly positive).
    pub min_speed_m_s: f64,
}

impl LaserConfig {
    /// T's source (T 7.1.3): an SPI redENERGY G3 HS pulsed fibre laser,
    /// nanosecond pulses at up to 500 kHz, 1065 nm, maximum operating power 20 W.
    ///
    /// T gives no minimum speed. Assumed: 0.2 mm/s, a tenth of the 2 mm/s
    /// T cuts its letters at (T 8.1), so the constant-energy mode follows the
    /// corners' slow-down down to a tenth of the nominal speed and only a near-stop
    /// turns the beam off.
    pub const SPI_REDENERGY_G3_20W: Self = Self {
        max_power_w: 20.0,
        min_speed_m_s: 2e-4,
    };
}

/// What the beam does during a job. Built in `f64` by the user (the default `T`) and
/// validated into the target scalar with [`Laser::mode`].
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum LaserMode<T = f64> {
    /// Beam off.
    Off,
    /// T's mode: constant power whatever the speed (the depth varies as 1/v).
    ConstantPower {
        /// Power in W, in [0, max_power_w].
        power_w: T,
    },
    /// Constant depth: P = e · |v|, clamped to [0, max_power_w], off below the
    /// minimum speed.
    ConstantEnergy {
        /// Energy per unit path length e in J/m (finite, ≥ 0).
        energy_per_length_j_per_m: T,
    },
}

impl LaserMode<f64> {
    /// Constant energy at the depth that `power_w` cuts at the nominal speed
    /// `speed_m_s`: e = P / v. Not validated here ([`Laser::mode`] does: a zero speed
    /// gives an infinite e, refused there).
    pub fn constant_energy_of(power_w: f64, speed_m_s: f64) -> Self {
        Self::ConstantEnergy {
            energy_per_length_j_per_m: power_w / speed_m_s,
        }
    }
}

/// Laser coefficients in the scalar `T` (no state: one set serves every job).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Laser<T> {
    max_power_w: T,
    inv_max_power: T,
    min_speed_m_s: T,
    one: T,
}

impl<T: Real> Laser<T> {
    /// Validates the source: both fields finite and strictly positive, and
    /// representable in `T` together with 1/max_power_w.
    pub fn new(config: &LaserConfig) -> Result<Self, ConfigError> {
        let max = positive("max_power_w", config.max_power_w)?;
        let min_speed = positive("min_speed_m_s", config.min_speed_m_s)?;
        Ok(Self {
            max_power_w: coefficient("max_power_w", max)?,
            inv_max_power: coefficient("max_power_w", 1.0 / max)?,
            min_speed_m_s: coefficient("min_speed_m_s", min_speed)?,
            one: T::from_f64(1.0),
        })
    }

    /// Largest power, W, as stored in `T`.
    pub fn max_power_w(&self) -> T {
        self.max_power_w
    }

    /// Minimum speed of the constant-energy mode, m/s, as stored in `T`.
    pub fn min_speed_m_s(&self) -> T {
        self.min_speed_m_s
    }

    /// Validates a job's mode for this source and converts it to `T`.
    ///
    /// Constant power: finite (`NotFinite`), in [0, max_power_w] (`OutOfRange`).
    /// Constant energy: finite (`NotFinite`), ≥ 0 (`OutOfRange`), representable in `T`
    /// (`NotRepresentable`). The error names `power_w` or `energy_per_length_j_per_m`.
    pub fn mode(&self, mode: &LaserMode<f64>) -> Result<LaserMode<T>, ConfigError> {
        match *mode {
            LaserMode::Off => Ok(LaserMode::Off),
            LaserMode::ConstantPower { power_w } => {
                const NAME: &str = "power_w";
                let power = non_negative(NAME, power_w)?;
                if power > self.max_power_w.to_f64() {
                    return Err(ConfigError::out_of_range(NAME));
                }
                Ok(LaserMode::ConstantPower {
                    power_w: representable(NAME, power)?,
                })
            }
            LaserMode::ConstantEnergy {
                energy_per_length_j_per_m,
            } => {
                const NAME: &str = "energy_per_length_j_per_m";
                let energy = non_negative(NAME, energy_per_length_j_per_m)?;
                Ok(LaserMode::ConstantEnergy {
                    energy_per_length_j_per_m: representable(NAME, energy)?,
                })
            }
        }
    }

    /// Power to command this period, W, in [0, max_power_w], from the job's mode and
    /// the measured speed of the spot along the path (its sign, the direction, does
    /// not matter: |v| is used).
    ///
    /// - [`LaserMode::Off`] gives 0.
    /// - [`LaserMode::ConstantPower`] gives the set power at any speed, standstill included
    ///   (T's mode; only the constant-energy mode knows about dwells).
    /// - [`LaserMode::ConstantEnergy`] gives 0 if |v| < min_speed_m_s (on at exactly the
    ///   minimum), else e·|v| clamped to max_power_w.
    ///
    /// A NaN or infinite speed gives 0 in every mode. A mode that skipped
    /// [`Laser::mode`] is still clamped to [0, max_power_w] (NaN → 0).
    #[inline]
    pub fn power_w(&self, mode: &LaserMode<T>, tangential_speed_m_s: T) -> T {
        if !tangential_speed_m_s.is_finite() {
            return T::ZERO;
        }
        match *mode {
            LaserMode::Off => T::ZERO,
            LaserMode::ConstantPower { power_w } => self.clamp_power(power_w),
            LaserMode::ConstantEnergy {
                energy_per_length_j_per_m,
            } => {
                let speed = if tangential_speed_m_s < T::ZERO {
                    -tangential_speed_m_s
                } else {
                    tangential_speed_m_s
                };
                if speed < self.min_speed_m_s {
                    T::ZERO
                } else {
                    self.clamp_power(energy_per_length_j_per_m * speed)
                }
            }
        }
    }

    /// PWM duty the HAL writes for `power_w`: P / max_power_w in [0, 1] (power
    /// clamped first; NaN → 0).
    #[inline]
    pub fn duty(&self, power_w: T) -> T {
        let duty = self.clamp_power(power_w) * self.inv_max_power;
        // P_max · (1/P_max) may round a hair above one.
        if duty > self.one {
            self.one
        } else {
            duty
        }
    }

    /// `power` clamped to [0, max_power_w]; NaN fails both comparisons and gives 0.
    #[inline]
    fn clamp_power(&self, power: T) -> T {
        if power > self.max_power_w {
            self.max_power_w
        } else if power > T::ZERO {
            power
        } else {
            T::ZERO
        }
    }
}

/// Checks that `value` is finite and ≥ 0 (zero power or energy is a valid job).
fn non_negative(name: &'static str, value: f64) -> Result<f64, ConfigError> {
    if !value.is_finite() {
        Err(ConfigError::not_finite(name))
    } else if value < 0.0 {
        Err(ConfigError::out_of_range(name))
    } else {
        Ok(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scalar::Q31_32;

    const PUBLISHED: LaserConfig = LaserConfig::SPI_REDENERGY_G3_20W;
    /// The depth T's 20 W cuts at its 2 mm/s: e = 20 / 0.002 = 10 000 J/m.
    const E_SEED: f64 = 10_000.0;

    fn laser<T: Real>() -> Laser<T> {
        Laser::new(&PUBLISHED).unwrap()
    }

    fn energy<T: Real>(l: &Laser<T>, e: f64) -> LaserMode<T> {
        l.mode(&LaserMode::ConstantEnergy {
            energy_per_length_j_per_m: e,
        })
        .unwrap()
    }

    #[test]
    fn preset_is_the_seeds_20_w_laser() {
        assert_eq!(PUBLISHED.max_power_w, 20.0);
        assert_eq!(
            LaserMode::constant_energy_of(20.0, 2e-3),
            LaserMode::ConstantEnergy {
                energy_per_length_j_per_m: E_SEED
            }
        );
        let l = laser::<f64>();
        assert_eq!(l.max_power_w(), 20.0);
        assert_eq!(l.min_speed_m_s(), 2e-4);
    }

    #[test]
    fn constant_energy_matches_hand_computation() {
        let l = laser::<f64>();
        let m = energy(&l, E_SEED);
        // 10 000 J/m · 1 mm/s = 10 W; 2 mm/s = 20 W (T's operating point).
        assert!((l.power_w(&m, 1e-3) - 10.0).abs() < 1e-12);
        assert!((l.power_w(&m, 2e-3) - 20.0).abs() < 1e-12);
        // Backwards along the path: |v|.
        assert!((l.power_w(&m, -1e-3) - 10.0).abs() < 1e-12);
        assert!((l.power_w(&m, -5e-4) - 5.0).abs() < 1e-12);
        // Faster than the source can follow: clamped at P_max.
        assert_eq!(l.power_w(&m, 3e-3), 20.0);
        assert_eq!(l.power_w(&m, -1.0), 20.0);
        // e = 0 is a valid (empty) job.
        assert_eq!(l.power_w(&energy(&l, 0.0), 1e-3), 0.0);
    }

    #[test]
    fn constant_energy_is_off_below_the_minimum_speed_only() {
        let l = laser::<f64>();
        let m = energy(&l, E_SEED);
        // On at exactly v_min: 10 000 · 2e-4 = 2 W.
        assert!((l.power_w(&m, 2e-4) - 2.0).abs() < 1e-12);
        assert!((l.power_w(&m, -2e-4) - 2.0).abs() < 1e-12);
        // Just below, and standing still: off.
        assert_eq!(l.power_w(&m, 1.999_999e-4), 0.0);
        assert_eq!(l.power_w(&m, -1.999_999e-4), 0.0);
        assert_eq!(l.power_w(&m, 0.0), 0.0);
        assert_eq!(l.power_w(&m, -0.0), 0.0);
    }

    #[test]
    fn constant_power_stays_on_at_any_speed_and_off_is_off() {
        let l = laser::<f64>();
        let p = l.mode(&LaserMode::ConstantPower { power_w: 7.5 }).unwrap();
        for v in [0.0, 1e-6, 2e-3, -2e-3, 10.0] {
            assert_eq!(l.power_w(&p, v), 7.5, "{v}");
            assert_eq!(l.power_w(&LaserMode::Off, v), 0.0, "{v}");
        }
        // The limits themselves are valid.
        let full = l.mode(&LaserMode::ConstantPower { power_w: 20.0 }).unwrap();
        assert_eq!(l.power_w(&full, 1e-3), 20.0);
        let zero = l.mode(&LaserMode::ConstantPower { power_w: 0.0 }).unwrap();
        assert_eq!(l.power_w(&zero, 1e-3), 0.0);
    }

    #[test]
    fn non_finite_speed_turns_the_beam_off_in_every_mode() {
        let l = laser::<f64>();
        let modes = [
            LaserMode::Off,
            LaserMode::ConstantPower { power_w: 10.0 },
            energy(&l, E_SEED),
        ];
        for m in &modes {
            for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                assert_eq!(l.power_w(m, v), 0.0, "{m:?} {v}");
            }
        }
        let l32 = laser::<f32>();
        let m32 = energy(&l32, E_SEED);
        assert_eq!(l32.power_w(&m32, f32::NAN), 0.0);
    }

    #[test]
    fn unvalidated_modes_are_still_clamped() {
        let l = laser::<f64>();
        let cases = [
            (LaserMode::ConstantPower { power_w: f64::NAN }, 0.0),
            (LaserMode::ConstantPower { power_w: -3.0 }, 0.0),
            (LaserMode::ConstantPower { power_w: 1e9 }, 20.0),
            (
                LaserMode::ConstantEnergy {
                    energy_per_length_j_per_m: f64::NAN,
                },
                0.0,
            ),
            (
                LaserMode::ConstantEnergy {
                    energy_per_length_j_per_m: -E_SEED,
                },
                0.0,
            ),
            (
                LaserMode::ConstantEnergy {
                    energy_per_length_j_per_m: f64::INFINITY,
                },
                20.0,
            ),
        ];
        for (m, want) in cases {
            assert_eq!(l.power_w(&m, 1e-3), want, "{m:?}");
        }
    }

    #[test]
    fn duty_is_power_over_max_in_the_unit_interval() {
        let l = laser::<f64>();
        assert_eq!(l.duty(5.0), 0.25);
        assert_eq!(l.duty(20.0), 1.0);
        assert_eq!(l.duty(25.0), 1.0);
        assert_eq!(l.duty(0.0), 0.0);
        assert_eq!(l.duty(-1.0), 0.0);
        assert_eq!(l.duty(f64::NAN), 0.0);
        assert_eq!(l.duty(f64::INFINITY), 1.0);
        // 24.79 W in f32: P_max · (1/P_max) rounds to 1 + 2^-23; the duty stays one.
        let odd = Laser::<f32>::new(&LaserConfig {
            max_power_w: 24.79,
            min_speed_m_s: 1e-4,
        })
        .unwrap();
        assert!(odd.max_power_w() * odd.inv_max_power > 1.0);
        assert_eq!(odd.duty(odd.max_power_w()), 1.0);
        assert_eq!(odd.duty(30.0), 1.0);
    }

    #[test]
    fn f32_and_fixed_point_agree_with_f64() {
        let l64 = laser::<f64>();
        let l32 = laser::<f32>();
        let lq = laser::<Q31_32>();
        let (m64, m32, mq) = (
            energy(&l64, E_SEED),
            energy(&l32, E_SEED),
            energy(&lq, E_SEED),
        );
        for k in -40..=40 {
            let v = f64::from(k) * 1e-4; // ±4 mm/s, across v_min and the clamp
            let want = l64.power_w(&m64, v);
            let got32 = f64::from(l32.power_w(&m32, v as f32));
            let gotq = lq.power_w(&mq, Q31_32::from_f64(v)).to_f64();
            // Off exactly where the f64 law is off, elsewhere within the rounding of v.
            assert!((got32 - want).abs() <= 1e-5 * want.max(1.0), "{v}: {got32}");
            assert!((gotq - want).abs() <= 1e-4, "{v}: {gotq}");
            let dq = lq.duty(Q31_32::from_f64(want)).to_f64();
            assert!((dq - want / 20.0).abs() < 1e-6 && dq <= 1.0, "{v}: {dq}");
        }
    }

    #[test]
    fn bad_configs_are_refused_naming_the_field() {
        let with = |max: f64, min: f64| {
            Laser::<f32>::new(&LaserConfig {
                max_power_w: max,
                min_speed_m_s: min,
            })
            .err()
        };
        assert_eq!(
            with(f64::NAN, 1e-4),
            Some(ConfigError::not_finite("max_power_w"))
        );
        assert_eq!(
            with(0.0, 1e-4),
            Some(ConfigError::not_positive("max_power_w"))
        );
        assert_eq!(
            with(-20.0, 1e-4),
            Some(ConfigError::not_positive("max_power_w"))
        );
        assert_eq!(
            with(1e300, 1e-4),
            Some(ConfigError::not_representable("max_power_w"))
        );
        assert_eq!(
            with(20.0, 0.0),
            Some(ConfigError::not_positive("min_speed_m_s"))
        );
        assert_eq!(
            with(20.0, f64::INFINITY),
            Some(ConfigError::not_finite("min_speed_m_s"))
        );
        assert_eq!(
            with(20.0, 1e-50),
            Some(ConfigError::not_representable("min_speed_m_s"))
        );
    }

    #[test]
    fn bad_modes_are_refused_naming_the_field() {
        let l = laser::<f64>();
        let power = |p: f64| l.mode(&LaserMode::ConstantPower { power_w: p }).err();
        assert_eq!(power(20.5), Some(ConfigError::out_of_range("power_w")));
        assert_eq!(power(-0.1), Some(ConfigError::out_of_range("power_w")));
        assert_eq!(power(f64::NAN), Some(ConfigError::not_finite("power_w")));
        let energy = |e: f64| {
            l.mode(&LaserMode::ConstantEnergy {
                energy_per_length_j_per_m: e,
            })
            .err()
        };
        const E: &str = "energy_per_length_j_per_m";
        assert_eq!(energy(-1.0), Some(ConfigError::out_of_range(E)));
        assert_eq!(energy(f64::INFINITY), Some(ConfigError::not_finite(E)));
        assert_eq!(
            l.mode(&LaserMode::constant_energy_of(20.0, 0.0)).err(),
            Some(ConfigError::not_finite(E))
        );
        // Beyond Q31.32's ±2.1e9.
        assert_eq!(
            laser::<Q31_32>()
                .mode(&LaserMode::ConstantEnergy {
                    energy_per_length_j_per_m: 3e9
                })
                .err(),
            Some(ConfigError::not_representable(E))
        );
        assert_eq!(l.mode(&LaserMode::Off), Ok(LaserMode::Off));
    }
}
