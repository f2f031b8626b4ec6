//! One carriage law's settings as a host link addresses them (miniconf): the PD as a
//! bandwidth (critically damped), the disturbance observer, the velocity observer, in
//! Hz and SI units. Every machine whose axes run [`super::AxisLaw`] names them so; its
//! link validates a change as [`super::AxisLaw::new`] validates a configuration.

use super::AxisConfig;
use crate::control::dob::DobConfig;
use crate::control::pd::PdConfig;
use crate::sensing::velocity::TrackingObserverConfig;
use core::f64::consts::TAU;
use miniconf::Tree;

/// The PD's settings.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct PdSettings {
    /// Bandwidth of the critically damped error dynamics, Hz.
    #[tree(meta(unit = "Hz", range = "> 0"))]
    pub bandwidth_hz: f64,
}

/// The disturbance observer's settings.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct DobSettings {
    /// Observer bandwidth, Hz (ω·Ts ≤ 2: 3183 Hz at the 10 kHz period).
    #[tree(meta(unit = "Hz", range = "> 0 and ≤ 3183"))]
    pub bandwidth_hz: f64,
    /// Nominal moving mass An, kg.
    #[tree(meta(unit = "kg", range = "> 0"))]
    pub nominal_mass_kg: f64,
    /// Force saturation, N.
    #[tree(meta(unit = "N", range = "> 0"))]
    pub force_limit_n: f64,
    /// Add the estimate to the command.
    #[tree(meta(range = "true or false"))]
    pub compensate: bool,
}

/// The velocity observer's settings.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct VelocitySettings {
    /// Observer bandwidth, Hz (ω·Ts ≤ 2: 3183 Hz at the 10 kHz period).
    #[tree(meta(unit = "Hz", range = "> 0 and ≤ 3183"))]
    pub bandwidth_hz: f64,
}

/// One carriage law's settings.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct AxisSettings {
    /// PD.
    pub pd: PdSettings,
    /// Disturbance observer.
    pub dob: DobSettings,
    /// Velocity observer.
    pub velocity: VelocitySettings,
}

impl AxisSettings {
    /// The settings of a configuration (its PD read as critically damped at √Kp: the
    /// presets are).
    pub fn of(config: &AxisConfig) -> Self {
        Self {
            pd: PdSettings {
                bandwidth_hz: libm::sqrt(config.pd.kp_per_s2) / TAU,
            },
            dob: DobSettings {
                bandwidth_hz: config.dob.bandwidth_rad_s / TAU,
                nominal_mass_kg: config.dob.nominal_mass_kg,
                force_limit_n: config.dob.force_limit_n,
                compensate: config.dob.compensate,
            },
            velocity: VelocitySettings {
                bandwidth_hz: config.velocity.bandwidth_rad_s / TAU,
            },
        }
    }

    /// The configuration these settings describe (validated by
    /// [`super::AxisLaw::new`]).
    pub fn config(&self) -> AxisConfig {
        AxisConfig {
            velocity: TrackingObserverConfig {
                bandwidth_rad_s: TAU * self.velocity.bandwidth_hz,
            },
            pd: PdConfig::critically_damped(TAU * self.pd.bandwidth_hz),
            dob: DobConfig {
                nominal_mass_kg: self.dob.nominal_mass_kg,
                bandwidth_rad_s: TAU * self.dob.bandwidth_hz,
                force_limit_n: self.dob.force_limit_n,
                compensate: self.dob.compensate,
            },
        }
    }
}
