//! One linear-motor axis: Hall decode → velocity observer → PD → DOB → force.
//!
//! A sensor fault latches the axis into [`AxisState::Fault`]: the force command is
//! zero from the faulty period on and stays zero until [`AxisLoop::reset`].

use crate::control::dob::{Dob, DobConfig};
use crate::control::pd::{Pd, PdConfig, Reference};
use crate::error::ConfigError;
use crate::scalar::Real;
use crate::sensing::hall::{HallConfig, HallCorrection, HallDecoder, HallFault};
use crate::sensing::velocity::{TrackingObserver, TrackingObserverConfig};

/// Everything one axis needs; [`AxisConfig::LM1247_SLAVE`] is the seed's slave motor.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct AxisConfig {
    /// Hall decoder.
    pub hall: HallConfig,
    /// Velocity observer.
    pub velocity: TrackingObserverConfig,
    /// PD tracking gains.
    pub pd: PdConfig,
    /// Disturbance observer (`ts_s` must equal the velocity observer's).
    pub dob: DobConfig,
}

impl AxisConfig {
    /// LM1247 axis at 10 kHz: PD at 2π·40 rad/s, DOB at 2π·150 rad/s with An = 71 g (the
    /// bare slider: at or below any payload, as the DOB needs), velocity observer at
    /// 2π·600 rad/s, force limited to the 3.6 N continuous rating.
    pub const LM1247_SLAVE: Self = Self {
        hall: HallConfig::LM1247_16BIT,
        velocity: TrackingObserverConfig {
            bandwidth_rad_s: 2.0 * core::f64::consts::PI * 600.0,
            ts_s: 1e-4,
        },
        pd: PdConfig {
            kp_per_s2: 63_165.468_5,
            kd_per_s: 502.654_8,
        },
        dob: DobConfig {
            nominal_mass_kg: 0.071,
            bandwidth_rad_s: 2.0 * core::f64::consts::PI * 150.0,
            ts_s: 1e-4,
            force_limit_n: 3.6,
            compensate: true,
        },
    };
}

/// Why the axis stopped.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AxisFault {
    /// The Hall sensors failed a check.
    Sensor(HallFault),
    /// The reference was NaN or infinite: nothing sensible can be commanded.
    ReferenceNotFinite,
}

/// Supervisory state of the axis.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AxisState {
    /// Waiting for the first good Hall sample.
    Starting,
    /// Closed loop running.
    Running,
    /// Latched fault: zero force until reset.
    Fault(AxisFault),
}

/// One period's output.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct AxisOutput<T> {
    /// Force command in N (zero unless running).
    pub force_n: T,
    /// Measured position in m (held on a fault).
    pub position_m: T,
    /// Velocity estimate in m/s.
    pub velocity_m_s: T,
    /// Disturbance estimate in N.
    pub disturbance_n: T,
    /// Supervisory state after this period.
    pub state: AxisState,
}

/// The closed loop of one axis in the scalar `T`.
#[derive(Clone, Debug)]
pub struct AxisLoop<T> {
    decoder: HallDecoder,
    pitch_m: T,
    pitches_per_m: T,
    observer: TrackingObserver<T>,
    pd: Pd<T>,
    dob: Dob<T>,
    state: AxisState,
    position_m: T,
    applied_acceleration: T,
    home_m: T,
    offset_m: T,
}

impl<T: Real> AxisLoop<T> {
    /// Validates every part of the configuration.
    pub fn new(config: &AxisConfig) -> Result<Self, ConfigError> {
        let decoder = HallDecoder::new(&config.hall)?;
        let observer = TrackingObserver::new(&config.velocity)?;
        let pd = Pd::new(&config.pd)?;
        let dob = Dob::new(&config.dob)?;
        if config.velocity.ts_s != config.dob.ts_s {
            return Err(ConfigError::out_of_range("ts_s"));
        }
        Ok(Self {
            decoder,
            pitch_m: T::from_f64(config.hall.pitch_m),
            pitches_per_m: T::from_f64(1.0 / config.hall.pitch_m),
            observer,
            pd,
            dob,
            state: AxisState::Starting,
            position_m: T::ZERO,
            applied_acceleration: T::ZERO,
            home_m: T::ZERO,
            offset_m: T::ZERO,
        })
    }

    /// Declares the position of the axis at the first good sample after start or
    /// reset, in the reference's frame (homing; zero by default).
    pub fn set_home(&mut self, home_m: T) {
        self.home_m = home_m;
    }

    /// Installs (or removes) the Hall decoder's phase correction table.
    pub fn set_hall_correction(&mut self, correction: Option<HallCorrection>) {
        self.decoder.set_correction(correction);
    }

    /// Leaves a latched fault: the next good sample restarts the loop from rest and is
    /// taken as the home position again (the pitch count is not trusted across a fault).
    pub fn reset(&mut self) {
        self.decoder.reset();
        self.state = AxisState::Starting;
    }

    /// Present supervisory state.
    pub fn state(&self) -> AxisState {
        self.state
    }

    /// One control period: raw Hall counts and the reference in, force command out.
    pub fn step(&mut self, hall_counts: [u16; 3], reference: &Reference<T>) -> AxisOutput<T> {
        if let AxisState::Fault(_) = self.state {
            return self.safe_output();
        }
        if !(reference.position.is_finite()
            && reference.velocity.is_finite()
            && reference.acceleration.is_finite())
        {
            self.state = AxisState::Fault(AxisFault::ReferenceNotFinite);
            return self.safe_output();
        }
        // Unwrap against the observer's prediction, so that any reachable speed decodes.
        let predicted_step =
            (self.observer.predicted_step(self.applied_acceleration) * self.pitches_per_m).to_q32();
        let sample = match self.decoder.update(hall_counts, predicted_step) {
            Ok(sample) => sample,
            Err(fault) => {
                self.state = AxisState::Fault(AxisFault::Sensor(fault));
                return self.safe_output();
            }
        };
        let position_m = sample.position_m(self.pitch_m);
        if self.state == AxisState::Starting {
            // Absolute position = home + travel since the first sample.
            self.offset_m = self.home_m - position_m;
            self.observer.reset(position_m);
            self.dob.reset(T::ZERO);
            self.applied_acceleration = T::ZERO;
            self.state = AxisState::Running;
        }
        self.position_m = self.offset_m + position_m;
        let velocity = self.observer.update(position_m, self.applied_acceleration);
        let acceleration = self.pd.acceleration(reference, self.position_m, velocity);
        let out = self.dob.update(acceleration, velocity);
        // With the DOB active the axis follows An·q̈ = F − F̂dis, so this is the
        // acceleration the observer should predict with (zero when saturated away).
        self.applied_acceleration = self.dob.applied_acceleration(&out);
        AxisOutput {
            force_n: out.force_n,
            position_m: self.position_m,
            velocity_m_s: velocity,
            disturbance_n: out.disturbance_n,
            state: self.state,
        }
    }

    fn safe_output(&self) -> AxisOutput<T> {
        AxisOutput {
            force_n: T::ZERO,
            position_m: self.position_m,
            velocity_m_s: T::ZERO,
            disturbance_n: T::ZERO,
            state: self.state,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    fn counts(phi: f64) -> [u16; 3] {
        let c = HallConfig::LM1247_16BIT;
        let ch = |k: usize, s: f64| {
            (f64::from(c.calibration.offset_counts[k]) + c.amplitude_counts * (phi + s).sin())
                .round() as u16
        };
        [ch(0, 0.0), ch(1, 2.0 * PI / 3.0), ch(2, -2.0 * PI / 3.0)]
    }

    #[test]
    fn rejects_bad_gains_pitch_and_period() {
        let with = |f: fn(&mut AxisConfig)| {
            let mut c = AxisConfig::LM1247_SLAVE;
            f(&mut c);
            AxisLoop::<f32>::new(&c).err()
        };
        assert_eq!(
            with(|c| c.pd.kp_per_s2 = f64::NAN),
            Some(ConfigError::not_finite("kp_per_s2"))
        );
        assert_eq!(
            with(|c| c.pd.kd_per_s = -1.0),
            Some(ConfigError::not_positive("kd_per_s"))
        );
        assert_eq!(
            with(|c| c.dob.bandwidth_rad_s = 0.0),
            Some(ConfigError::not_positive("bandwidth_rad_s"))
        );
        assert_eq!(
            with(|c| c.hall.pitch_m = -0.018),
            Some(ConfigError::not_positive("pitch_m"))
        );
        assert_eq!(
            with(|c| c.velocity.ts_s = f64::NAN),
            Some(ConfigError::not_finite("ts_s"))
        );
        assert_eq!(
            with(|c| c.velocity.ts_s = 2e-4),
            Some(ConfigError::out_of_range("ts_s"))
        );
        assert_eq!(
            with(|c| {
                c.velocity.ts_s = 0.0;
                c.dob.ts_s = 0.0
            }),
            Some(ConfigError::not_positive("ts_s"))
        );
        assert!(AxisLoop::<f32>::new(&AxisConfig::LM1247_SLAVE).is_ok());
    }

    #[test]
    fn non_finite_reference_latches_zero_force() {
        for bad in [f64::NAN, f64::INFINITY] {
            let mut axis = AxisLoop::<f64>::new(&AxisConfig::LM1247_SLAVE).unwrap();
            let good = Reference {
                position: 0.0,
                velocity: 0.0,
                acceleration: 0.0,
            };
            axis.step(counts(0.2), &good);
            let out = axis.step(
                counts(0.2),
                &Reference {
                    velocity: bad,
                    ..good
                },
            );
            assert_eq!(out.force_n, 0.0);
            assert_eq!(out.state, AxisState::Fault(AxisFault::ReferenceNotFinite));
            assert_eq!(axis.step(counts(0.2), &good).force_n, 0.0);
        }
    }

    #[test]
    fn fault_latches_zero_force_until_reset() {
        let mut axis = AxisLoop::<f64>::new(&AxisConfig::LM1247_SLAVE).unwrap();
        // Reference 1 mm away: a large force while running.
        let r = Reference {
            position: 0.001,
            velocity: 0.0,
            acceleration: 0.0,
        };
        let out = axis.step(counts(0.2), &r);
        assert_eq!(out.state, AxisState::Running);
        assert!(out.force_n.abs() > 1.0);
        let mut railed = counts(0.2);
        railed[1] = 65535;
        assert_eq!(
            axis.step(railed, &r).state,
            AxisState::Fault(AxisFault::Sensor(HallFault::AdcRail(1)))
        );
        // Healthy samples again: still latched, still zero.
        for _ in 0..10 {
            let out = axis.step(counts(0.2), &r);
            assert_eq!(out.force_n, 0.0);
            assert_eq!(
                out.state,
                AxisState::Fault(AxisFault::Sensor(HallFault::AdcRail(1)))
            );
        }
        axis.reset();
        assert_eq!(axis.state(), AxisState::Starting);
        assert_eq!(axis.step(counts(0.2), &r).state, AxisState::Running);
    }
}
