//! One linear-motor axis: Hall decode → velocity observer → PD → DOB → force, split
//! as the rest of kerf is: a user config ([`AxisConfig`], SI units) validated into
//! coefficients ([`AxisLaw`], shared by every axis of a machine; [`HallAxis`], one per
//! sensor set because each is calibrated on its own) and the running [`AxisState`].
//!
//! A sensor fault latches the axis into [`AxisStatus::Fault`]: the force command is
//! zero from the faulty period on and stays zero until [`AxisState::reset`].
//!
//! ```
//! use kerf::app::axis::{AxisConfig, AxisLaw, AxisState, AxisStatus, HallAxis};
//! use kerf::trajectory::Reference;
//! use kerf::sensing::hall::HallConfig;
//!
//! // The LM1247 law at 10 kHz, one sensor set, an axis homed at 4 mm.
//! let law = AxisLaw::<f32>::new(&AxisConfig::LM1247_SLAVE, 1e-4).unwrap();
//! let sensor = HallAxis::<f32>::new(&HallConfig::LM1247_16BIT).unwrap();
//! let mut axis = AxisState::homed_at(0.004);
//! // Ideal sensors at phase 0: u1 at mid-scale, u2 and u3 at ±A·sin 120°.
//! let a = 0.4 * 65536.0 * 0.866_025_4;
//! let counts = [32768, (32768.0 + a) as u16, (32768.0 - a) as u16];
//! let hold = Reference { position: 0.004, velocity: 0.0, acceleration: 0.0 };
//! let out = law.step(&sensor, &mut axis, counts, &hold);
//! assert_eq!(out.status, AxisStatus::Running);
//! assert!(out.force_n.abs() < 1e-3);
//! // A railed channel: zero force, latched.
//! let out = law.step(&sensor, &mut axis, [0, counts[1], counts[2]], &hold);
//! assert_eq!(out.force_n, 0.0);
//! assert!(matches!(out.status, AxisStatus::Fault(_)));
//! ```

use crate::control::dob::{Dob, DobConfig, DobState};
use crate::control::pd::{Pd, PdConfig};
use crate::error::{factor, ConfigContext, ConfigError};
use crate::scalar::Real;
use crate::sensing::hall::{HallConfig, HallDecoder, HallFault, HallState};
use crate::sensing::velocity::{TrackingObserver, TrackingObserverConfig, TrackingObserverState};
use crate::trajectory::Reference;

pub mod settings;

/// The control law of one axis, in SI units; [`AxisConfig::LM1247_SLAVE`] is T's
/// slave motor. The control period is not here: the machine gives it once.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct AxisConfig {
    /// Velocity observer.
    pub velocity: TrackingObserverConfig,
    /// PD tracking gains.
    pub pd: PdConfig,
    /// Disturbance observer.
    pub dob: DobConfig,
}

impl AxisConfig {
    /// LM1247 axis: PD at 2π·40 rad/s, DOB at 2π·150 rad/s with An = 71 g (the bare
    /// slider: at or below any payload, as the DOB needs), velocity observer at
    /// 2π·600 rad/s, force limited to the 3.6 N continuous rating.
    pub const LM1247_SLAVE: Self = Self {
        velocity: TrackingObserverConfig {
            bandwidth_rad_s: 2.0 * core::f64::consts::PI * 600.0,
        },
        pd: PdConfig::critically_damped(2.0 * core::f64::consts::PI * 40.0),
        dob: DobConfig {
            nominal_mass_kg: 0.071,
            bandwidth_rad_s: 2.0 * core::f64::consts::PI * 150.0,
            force_limit_n: 3.6,
            compensate: true,
        },
    };
}

/// Why an axis stopped.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AxisFault {
    /// The Hall sensors failed a check.
    Sensor(HallFault),
    /// The reference was NaN or infinite: nothing sensible can be commanded.
    ReferenceNotFinite,
    /// A calibration coast (open loop, held force) strayed beyond its bound from the
    /// cruise it should follow (`app::calibrate::COAST_BOUND_M`).
    CoastOutOfBound,
    /// A value inside the loop became NaN or infinite (a finite reference so far off
    /// that the PD terms overflow, a non-finite home): zero force in the same period.
    NotFinite,
}

/// Where an axis is in its own start-up.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AxisStatus {
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
    /// The force command is at the driver's limit (the law asked for more).
    pub saturated: bool,
    /// Status after this period.
    pub status: AxisStatus,
}

/// Coefficients of the axis law in the scalar `T`; one set drives every axis of a
/// machine, and replacing it keeps each axis' state (bumpless: see [`AxisLaw::step`]).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct AxisLaw<T: Real> {
    observer: TrackingObserver<T>,
    pd: Pd<T>,
    dob: Dob<T>,
}

/// One axis' sensor coefficients: the Hall decoder (calibrated per sensor set) and the
/// pitch that turns its phase into metres.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HallAxis<T: Real> {
    decoder: HallDecoder,
    pitch_m: T::Coef,
    pitches_per_m: T::Coef,
}

impl<T: Real> HallAxis<T> {
    /// Validates the decoder configuration.
    pub fn new(config: &HallConfig) -> Result<Self, ConfigError> {
        let decoder = HallDecoder::new(config)?;
        Ok(Self {
            decoder,
            pitch_m: factor::<T>("pitch_m", config.pitch_m)?,
            pitches_per_m: factor::<T>("pitch_m", 1.0 / config.pitch_m)?,
        })
    }

    /// The axis' Hall decoder (its limits, e.g. the installed residual limit).
    pub fn decoder(&self) -> &HallDecoder {
        &self.decoder
    }
}

/// The running part of one axis.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct AxisState<T: Real> {
    hall: HallState,
    observer: TrackingObserverState<T>,
    dob: DobState<T>,
    status: AxisStatus,
    position_m: T,
    applied_acceleration: T,
    home_m: T,
    offset_m: T,
}

impl<T: Real> AxisState<T> {
    /// An axis whose first good sample is taken as `home_m` in the reference's frame.
    pub fn homed_at(home_m: T) -> Self {
        Self {
            hall: HallState::default(),
            observer: TrackingObserverState::at_rest(T::ZERO),
            dob: DobState::at(T::ZERO),
            status: AxisStatus::Starting,
            position_m: home_m,
            applied_acceleration: T::ZERO,
            home_m,
            offset_m: T::ZERO,
        }
    }

    /// Leaves a latched fault: the next good sample restarts the loop from rest and is
    /// taken as the home position again (the pitch count is not trusted across a fault).
    pub fn reset(&mut self) {
        *self = Self::homed_at(self.home_m);
    }

    /// Present status.
    pub fn status(&self) -> AxisStatus {
        self.status
    }

    /// Measured position, m (the last good one on a fault; zero when none was
    /// finite, as with a non-finite home).
    pub fn position_m(&self) -> T {
        if self.position_m.is_finite() {
            self.position_m
        } else {
            T::ZERO
        }
    }

    /// Velocity estimate, m/s.
    pub fn velocity_m_s(&self) -> T {
        self.observer.velocity
    }

    /// Hands the axis to the control law from monitoring: the disturbance estimate
    /// starts at zero at the present velocity, so the first force is the PD's alone.
    pub fn engage(&mut self) {
        self.dob = DobState::at(self.observer.velocity);
        self.applied_acceleration = T::ZERO;
    }

    /// Zero force; the position held (zero when it never was finite).
    fn safe_output(&self) -> AxisOutput<T> {
        AxisOutput {
            force_n: T::ZERO,
            position_m: self.position_m(),
            velocity_m_s: T::ZERO,
            disturbance_n: T::ZERO,
            saturated: false,
            status: self.status,
        }
    }
}

impl<T: Real> AxisLaw<T> {
    /// Validates the law for control period `period_s`; a bad field is reported with
    /// its path (`dob.bandwidth_rad_s`).
    pub fn new(config: &AxisConfig, period_s: f64) -> Result<Self, ConfigError> {
        Ok(Self {
            observer: TrackingObserver::new(&config.velocity, period_s).within("velocity")?,
            pd: Pd::new(&config.pd).within("pd")?,
            dob: Dob::new(&config.dob, period_s).within("dob")?,
        })
    }

    /// One control period of one axis: raw Hall counts and the reference in, force
    /// command out.
    ///
    /// The state is kept in physical units (position, velocity, disturbance estimate),
    /// so stepping with a new law after the old one is bumpless: the force changes only
    /// by what the new gains make of the present errors, An·(ΔKp e + ΔKd ė) + ΔAn q̈des.
    pub fn step(
        &self,
        sensor: &HallAxis<T>,
        state: &mut AxisState<T>,
        hall_counts: [u16; 3],
        reference: &Reference<T>,
    ) -> AxisOutput<T> {
        if let AxisStatus::Fault(_) = state.status {
            return state.safe_output();
        }
        if !(reference.position.is_finite()
            && reference.velocity.is_finite()
            && reference.acceleration.is_finite())
        {
            state.status = AxisStatus::Fault(AxisFault::ReferenceNotFinite);
            return state.safe_output();
        }
        let velocity = match self.measure(sensor, state, hall_counts) {
            Ok(velocity) => velocity,
            Err(_) => return state.safe_output(),
        };
        let acceleration = self.pd.acceleration(reference, state.position_m, velocity);
        self.actuate(state, acceleration, velocity)
    }

    /// The PD law's desired acceleration (m/s²) for `reference` at the measured
    /// position and velocity: what [`AxisLaw::step`] hands its observer.
    pub fn pd_acceleration(&self, reference: &Reference<T>, position_m: T, velocity_m_s: T) -> T {
        self.pd.acceleration(reference, position_m, velocity_m_s)
    }

    /// The measured half of [`AxisLaw::step`]: decode, check and track. Returns the
    /// velocity estimate (the position is [`AxisState::position_m`]); a sensor fault
    /// latches and is returned. A machine whose law couples its axes (contouring)
    /// measures every axis first, computes the desired accelerations together, then
    /// calls [`AxisLaw::actuate`] on each.
    pub fn measure(
        &self,
        sensor: &HallAxis<T>,
        state: &mut AxisState<T>,
        hall_counts: [u16; 3],
    ) -> Result<T, AxisFault> {
        if let AxisStatus::Fault(fault) = state.status {
            return Err(fault);
        }
        self.sense(sensor, state, hall_counts).inspect_err(|fault| {
            state.status = AxisStatus::Fault(*fault);
        })
    }

    /// The commanded half of [`AxisLaw::step`]: the disturbance observer turns the
    /// desired acceleration (m/s², from any law) into the force command. `velocity` is
    /// what [`AxisLaw::measure`] returned this period. A non-finite value anywhere in
    /// the loop latches [`AxisFault::NotFinite`] with zero force in the same period.
    pub fn actuate(&self, state: &mut AxisState<T>, acceleration: T, velocity: T) -> AxisOutput<T> {
        if let AxisStatus::Fault(_) = state.status {
            return state.safe_output();
        }
        let out = self.dob.update(&mut state.dob, acceleration, velocity);
        // The saturation passes NaN, and a saturated ±inf hides an overflow: any
        // non-finite value here latches a fault before the force leaves the period.
        // One test on the sum sees them all (NaN or ±inf in any term makes the sum
        // NaN or ±inf); a sum of finite terms overflows only beyond 1e38 (f32), which
        // is no sane state either.
        let health =
            acceleration + out.force_n + state.dob.estimate_n + state.position_m + velocity;
        if !health.is_finite() {
            state.status = AxisStatus::Fault(AxisFault::NotFinite);
            return state.safe_output();
        }
        // With the DOB active the axis follows An·q̈ = F − F̂dis, so this is the
        // acceleration the observer should predict with (zero when saturated away).
        state.applied_acceleration = self.dob.applied_acceleration(&out);
        AxisOutput {
            force_n: out.force_n,
            position_m: state.position_m,
            velocity_m_s: velocity,
            disturbance_n: out.disturbance_n,
            saturated: self.dob.is_saturated(&out),
            status: state.status,
        }
    }

    /// One period with the outputs safe (the machine idle): the sensors are decoded and
    /// checked and the position and velocity tracked, so the axis can be engaged later
    /// from where it is. A fault latches as in [`AxisLaw::step`].
    pub fn monitor(
        &self,
        sensor: &HallAxis<T>,
        state: &mut AxisState<T>,
        hall_counts: [u16; 3],
    ) -> Result<(), AxisFault> {
        if let AxisStatus::Fault(fault) = state.status {
            return Err(fault);
        }
        // No force: the nominal plant's acceleration is zero.
        state.applied_acceleration = T::ZERO;
        match self.sense(sensor, state, hall_counts) {
            Ok(_) if state.position_m.is_finite() => Ok(()),
            Ok(_) => {
                state.status = AxisStatus::Fault(AxisFault::NotFinite);
                Err(AxisFault::NotFinite)
            }
            Err(fault) => {
                state.status = AxisStatus::Fault(fault);
                Err(fault)
            }
        }
    }

    /// One period open loop with a held force `force_n` (a calibration coast): the
    /// sensors are decoded, checked and tracked as in [`AxisLaw::step`], the loop is
    /// not. Call [`AxisState::engage`] before stepping closed loop again.
    pub fn coast(
        &self,
        sensor: &HallAxis<T>,
        state: &mut AxisState<T>,
        hall_counts: [u16; 3],
        force_n: T,
    ) -> Result<AxisOutput<T>, AxisFault> {
        if let AxisStatus::Fault(fault) = state.status {
            return Err(fault);
        }
        // The held force balances the friction of the cruise: the slider coasts at
        // nearly constant speed, so the observer predicts with no acceleration.
        state.applied_acceleration = T::ZERO;
        let velocity = match self.sense(sensor, state, hall_counts) {
            Ok(v) if (v + force_n + state.position_m).is_finite() => v,
            Ok(_) => {
                state.status = AxisStatus::Fault(AxisFault::NotFinite);
                return Err(AxisFault::NotFinite);
            }
            Err(fault) => {
                state.status = AxisStatus::Fault(fault);
                return Err(fault);
            }
        };
        Ok(AxisOutput {
            force_n,
            position_m: state.position_m,
            velocity_m_s: velocity,
            disturbance_n: state.dob.estimate_n,
            saturated: false,
            status: state.status,
        })
    }

    /// Latches `fault` (a check outside the law, e.g. a coast's bound).
    pub fn latch(&self, state: &mut AxisState<T>, fault: AxisFault) {
        state.status = AxisStatus::Fault(fault);
    }

    /// Decode, home on the first good sample, track: the measured part of a period.
    /// Returns the velocity estimate.
    #[inline]
    fn sense(
        &self,
        sensor: &HallAxis<T>,
        state: &mut AxisState<T>,
        hall_counts: [u16; 3],
    ) -> Result<T, AxisFault> {
        // Unwrap against the observer's prediction, so that any reachable speed decodes.
        let predicted_step = self
            .observer
            .predicted_step(&state.observer, state.applied_acceleration)
            .scale(sensor.pitches_per_m)
            .to_q32();
        let sample = sensor
            .decoder
            .update(&mut state.hall, hall_counts, predicted_step)
            .map_err(AxisFault::Sensor)?;
        let position_m = sample.position_m(sensor.pitch_m);
        if state.status == AxisStatus::Starting {
            // Absolute position = home + travel since the first sample.
            state.offset_m = state.home_m - position_m;
            state.observer = TrackingObserverState::at_rest(position_m);
            state.dob = DobState::at(T::ZERO);
            state.applied_acceleration = T::ZERO;
            state.status = AxisStatus::Running;
        }
        state.position_m = state.offset_m + position_m;
        Ok(self
            .observer
            .update(&mut state.observer, position_m, state.applied_acceleration))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;
    use std::string::{String, ToString};

    fn counts(phi: f64) -> [u16; 3] {
        let c = HallConfig::LM1247_16BIT;
        let ch = |k: usize, s: f64| {
            (f64::from(c.calibration.offset_counts[k]) + c.amplitude_counts * (phi + s).sin())
                .round() as u16
        };
        [ch(0, 0.0), ch(1, 2.0 * PI / 3.0), ch(2, -2.0 * PI / 3.0)]
    }

    fn parts() -> (AxisLaw<f64>, HallAxis<f64>, AxisState<f64>) {
        (
            AxisLaw::new(&AxisConfig::LM1247_SLAVE, 1e-4).unwrap(),
            HallAxis::new(&HallConfig::LM1247_16BIT).unwrap(),
            AxisState::homed_at(0.0),
        )
    }

    #[test]
    fn rejects_bad_gains_and_period_with_the_path() {
        let with = |f: fn(&mut AxisConfig), period_s: f64| -> Option<String> {
            let mut c = AxisConfig::LM1247_SLAVE;
            f(&mut c);
            AxisLaw::<f32>::new(&c, period_s)
                .err()
                .map(|e| e.to_string())
        };
        let keep = |_: &mut AxisConfig| {};
        assert_eq!(
            with(|c| c.pd.kp_per_s2 = f64::NAN, 1e-4).as_deref(),
            Some("pd.kp_per_s2: not finite")
        );
        assert_eq!(
            with(|c| c.pd.kd_per_s = -1.0, 1e-4).as_deref(),
            Some("pd.kd_per_s: not strictly positive")
        );
        assert_eq!(
            with(|c| c.dob.bandwidth_rad_s = 0.0, 1e-4).as_deref(),
            Some("dob.bandwidth_rad_s: not strictly positive")
        );
        assert_eq!(
            with(keep, f64::NAN).as_deref(),
            Some("velocity.period_s: not finite")
        );
        // Valid in f64, gone in f32: a gain beyond f32's range.
        assert_eq!(
            with(|c| c.pd.kp_per_s2 = 1e39, 1e-4).as_deref(),
            Some("pd.kp_per_s2: not representable in the target scalar")
        );
        assert!(AxisLaw::<f64>::new(
            &AxisConfig {
                pd: PdConfig {
                    kp_per_s2: 1e39,
                    kd_per_s: 1.0
                },
                ..AxisConfig::LM1247_SLAVE
            },
            1e-4
        )
        .is_ok());
        assert_eq!(
            HallAxis::<f32>::new(&HallConfig {
                pitch_m: -0.018,
                ..HallConfig::LM1247_16BIT
            })
            .err()
            .map(|e| e.to_string())
            .as_deref(),
            Some("pitch_m: not strictly positive")
        );
        assert!(with(keep, 1e-4).is_none());
    }

    #[test]
    fn non_finite_reference_latches_zero_force() {
        for bad in [f64::NAN, f64::INFINITY] {
            let (law, sensor, mut axis) = parts();
            let good = Reference {
                position: 0.0,
                velocity: 0.0,
                acceleration: 0.0,
            };
            law.step(&sensor, &mut axis, counts(0.2), &good);
            let out = law.step(
                &sensor,
                &mut axis,
                counts(0.2),
                &Reference {
                    velocity: bad,
                    ..good
                },
            );
            assert_eq!(out.force_n, 0.0);
            assert_eq!(out.status, AxisStatus::Fault(AxisFault::ReferenceNotFinite));
            assert_eq!(
                law.step(&sensor, &mut axis, counts(0.2), &good).force_n,
                0.0
            );
        }
    }

    #[test]
    fn fault_latches_zero_force_until_reset() {
        let (law, sensor, mut axis) = parts();
        // Reference 1 mm away: a large force while running.
        let r = Reference {
            position: 0.001,
            velocity: 0.0,
            acceleration: 0.0,
        };
        let out = law.step(&sensor, &mut axis, counts(0.2), &r);
        assert_eq!(out.status, AxisStatus::Running);
        assert!(out.force_n.abs() > 1.0);
        let mut railed = counts(0.2);
        railed[1] = 65535;
        assert_eq!(
            law.step(&sensor, &mut axis, railed, &r).status,
            AxisStatus::Fault(AxisFault::Sensor(HallFault::AdcRail(1)))
        );
        // Healthy samples again: still latched, still zero.
        for _ in 0..10 {
            let out = law.step(&sensor, &mut axis, counts(0.2), &r);
            assert_eq!(out.force_n, 0.0);
            assert_eq!(
                out.status,
                AxisStatus::Fault(AxisFault::Sensor(HallFault::AdcRail(1)))
            );
        }
        axis.reset();
        assert_eq!(axis.status(), AxisStatus::Starting);
        assert_eq!(
            law.step(&sensor, &mut axis, counts(0.2), &r).status,
            AxisStatus::Running
        );
    }

    fn all_finite(out: &AxisOutput<f32>) -> bool {
        out.force_n.is_finite()
            && out.position_m.is_finite()
            && out.velocity_m_s.is_finite()
            && out.disturbance_n.is_finite()
    }

    /// A finite reference far outside any travel overflows Kp e + Kd ė in f32 (−inf
    /// plus +inf): the axis latches a fault with zero force in that period, and every
    /// output stays finite from then on.
    #[test]
    fn huge_finite_reference_latches_a_fault_not_a_nan_force() {
        let law = AxisLaw::<f32>::new(&AxisConfig::LM1247_SLAVE, 1e-4).unwrap();
        let sensor = HallAxis::<f32>::new(&HallConfig::LM1247_16BIT).unwrap();
        let mut axis = AxisState::<f32>::homed_at(0.0);
        let rest = Reference {
            position: 0.0f32,
            velocity: 0.0,
            acceleration: 0.0,
        };
        assert_eq!(
            law.step(&sensor, &mut axis, counts(0.2), &rest).status,
            AxisStatus::Running
        );
        let huge = Reference {
            position: -1e34f32,
            velocity: 1e36,
            acceleration: 0.0,
        };
        let out = law.step(&sensor, &mut axis, counts(0.2), &huge);
        assert_eq!(out.status, AxisStatus::Fault(AxisFault::NotFinite));
        assert_eq!(out.force_n, 0.0);
        assert!(all_finite(&out), "{out:?}");
        for _ in 0..1000 {
            let out = law.step(&sensor, &mut axis, counts(0.2), &rest);
            assert_eq!(out.force_n, 0.0);
            assert!(all_finite(&out), "{out:?}");
        }
        // One overflowing term alone (+inf acceleration) is a fault too, not a
        // silently saturated full force.
        let mut axis = AxisState::<f32>::homed_at(0.0);
        law.step(&sensor, &mut axis, counts(0.2), &rest);
        let far = Reference {
            position: 1e36f32,
            ..rest
        };
        let out = law.step(&sensor, &mut axis, counts(0.2), &far);
        assert_eq!(out.status, AxisStatus::Fault(AxisFault::NotFinite));
        assert_eq!(out.force_n, 0.0);
    }

    /// A NaN home makes every position NaN: the first period faults, outputs finite.
    #[test]
    fn non_finite_home_latches_a_fault_in_the_first_period() {
        let law = AxisLaw::<f32>::new(&AxisConfig::LM1247_SLAVE, 1e-4).unwrap();
        let sensor = HallAxis::<f32>::new(&HallConfig::LM1247_16BIT).unwrap();
        for home in [f32::NAN, f32::INFINITY] {
            let mut axis = AxisState::<f32>::homed_at(home);
            let rest = Reference {
                position: 0.0f32,
                velocity: 0.0,
                acceleration: 0.0,
            };
            let out = law.step(&sensor, &mut axis, counts(0.2), &rest);
            assert_eq!(out.status, AxisStatus::Fault(AxisFault::NotFinite));
            assert!(all_finite(&out), "{out:?}");
            let mut idle = AxisState::<f32>::homed_at(home);
            assert_eq!(
                law.monitor(&sensor, &mut idle, counts(0.2)),
                Err(AxisFault::NotFinite)
            );
            assert!(idle.position_m().is_finite());
        }
    }

    /// A latched fault holds through good samples (zero force, `measure` refuses)
    /// until `reset`; an axis that was never latched keeps running.
    #[test]
    fn latch_holds_the_fault_until_reset() {
        let (law, sensor, mut axis) = parts();
        let rest = Reference {
            position: 0.0,
            velocity: 0.0,
            acceleration: 0.0,
        };
        law.step(&sensor, &mut axis, counts(0.2), &rest);
        assert_eq!(axis.status(), AxisStatus::Running);
        law.latch(&mut axis, AxisFault::CoastOutOfBound);
        let latched = AxisStatus::Fault(AxisFault::CoastOutOfBound);
        assert_eq!(axis.status(), latched);
        // Far from the reference: a running law would push hard.
        let away = Reference {
            position: 0.002,
            ..rest
        };
        for _ in 0..3 {
            let out = law.step(&sensor, &mut axis, counts(0.2), &away);
            assert_eq!((out.force_n, out.status), (0.0, latched));
        }
        assert_eq!(
            law.measure(&sensor, &mut axis, counts(0.2)),
            Err(AxisFault::CoastOutOfBound)
        );
        axis.reset();
        assert_eq!(axis.status(), AxisStatus::Starting);
        let out = law.step(&sensor, &mut axis, counts(0.2), &away);
        assert_eq!(out.status, AxisStatus::Running);
        assert!(out.force_n > 0.1, "{out:?}");
    }

    /// The PD law against its closed form (module docs of `control::pd`) with the
    /// configured gains, and one step as the machine's halves compose it:
    /// `measure`, `pd_acceleration`, `actuate` give what `step` gives.
    #[test]
    fn pd_acceleration_is_the_configured_law_and_step_is_its_halves() {
        let (law, sensor, mut axis) = parts();
        let pd = AxisConfig::LM1247_SLAVE.pd;
        let reference = Reference {
            position: 0.003,
            velocity: -0.02,
            acceleration: 0.7,
        };
        let (x, v) = (0.0012, 0.015);
        let expected = 0.7 + pd.kd_per_s * (-0.02 - v) + pd.kp_per_s2 * (0.003 - x);
        let got = law.pd_acceleration(&reference, x, v);
        assert!(
            (got - expected).abs() <= 1e-12 * expected.abs(),
            "{got} {expected}"
        );

        law.step(&sensor, &mut axis, counts(0.2), &reference);
        let mut halves = axis;
        let whole = law.step(&sensor, &mut axis, counts(0.25), &reference);
        let v = law.measure(&sensor, &mut halves, counts(0.25)).unwrap();
        let a = law.pd_acceleration(&reference, halves.position_m(), v);
        assert_eq!(law.actuate(&mut halves, a, v), whole);
        assert_eq!(halves, axis);
    }

    /// `actuate` after `engage` (no disturbance estimate yet): F = An·q̈des below the
    /// limit, the limit and the flag beyond it, a fault on NaN, nothing once latched.
    #[test]
    fn actuate_commands_the_nominal_mass_times_the_acceleration() {
        let (law, sensor, mut axis) = parts();
        let mass = AxisConfig::LM1247_SLAVE.dob.nominal_mass_kg;
        law.monitor(&sensor, &mut axis, counts(0.2)).unwrap();
        for (a, force, saturated) in [
            (10.0, mass * 10.0, false),
            (-20.0, -mass * 20.0, false),
            (1e3, 3.6, true),
            (-1e3, -3.6, true),
        ] {
            let mut state = axis;
            state.engage();
            let out = law.actuate(&mut state, a, 0.0);
            assert!((out.force_n - force).abs() < 1e-12, "{a}: {out:?}");
            assert_eq!(
                (out.saturated, out.status),
                (saturated, AxisStatus::Running)
            );
        }
        let out = law.actuate(&mut axis, f64::NAN, 0.0);
        assert_eq!(out.status, AxisStatus::Fault(AxisFault::NotFinite));
        assert_eq!(out.force_n, 0.0);
        let out = law.actuate(&mut axis, 10.0, 0.0);
        assert_eq!((out.force_n, out.saturated), (0.0, false));
        assert_eq!(out.status, AxisStatus::Fault(AxisFault::NotFinite));
    }
}
