//! Closed-loop scenarios shared by the host tests and the QEMU smoke run, so both
//! check the same thing against the same bounds.

use crate::axis::SimulatedAxis;
use crate::hall_sensor::{ChannelFault, HallSensorParams};
use crate::linear_motor::LinearMotorParams;
use kerf::app::axis::{AxisConfig, AxisFault, AxisLoop, AxisState};
use kerf::app::calibrate::{CalibrationProgress, HallCalibrationMode};
use kerf::control::pd::Reference;
use kerf::hal::HallInput;
use kerf::sensing::hall::{CalibrationError, HallCorrection, SelfCalibration};
use kerf::trajectory::quintic::Quintic;
use kerf::{ConfigError, Real};

/// Control period of the single-axis scenarios (10 kHz).
pub const TS_S: f64 = 1e-4;
/// Where the slider starts (an arbitrary phase inside the first pitch), m.
pub const START_M: f64 = 0.0043;
/// Stroke of the tracking profile: 30 mm, 1.67 magnetic pitches, out and back.
pub const STROKE_M: f64 = 0.030;

/// Bound on the RMS tracking error over the 1 s profile, m.
///
/// Why: the error is set by disturbances, not by the sensor. The noise floor is
/// 2 LSB on a 26214-count amplitude, a phase noise of 2·√(2/3)/26214 rad, i.e. 0.18 µm
/// RMS at an 18 mm pitch. The disturbances are Coulomb friction (0.08 N, switching on
/// at each start) and the nominal-mass error (121 g true vs 71 g nominal, 0.05 kg ×
/// 1.08 m/s² = 0.054 N during acceleration). The loop's response to a force step is
/// measured by the load-step test: 1 N gives a 30 µm peak that the DOB removes with
/// its 1.06 ms time constant. Scaled linearly, 0.08 + 0.054 N gives about 4 µm peak,
/// present only around the transitions, so the RMS over the profile is about 1 µm.
/// The bounds are these estimates with a margin of 2 to 3.
pub const RMS_ERROR_BOUND_M: f64 = 2.5e-6;
/// Bound on the maximum tracking error over the profile, m (see [`RMS_ERROR_BOUND_M`]).
pub const MAX_ERROR_BOUND_M: f64 = 10e-6;

/// The 1 s tracking profile: rest, 30 mm out in 0.4 s, dwell, back in 0.4 s, rest.
/// Peak speed 0.14 m/s, peak acceleration 1.08 m/s².
pub fn profile(t_s: f64) -> Reference<f64> {
    // Constant, valid arguments: construction cannot fail.
    let out = Quintic::<f64>::new(START_M, STROKE_M, 0.4);
    let back = Quintic::<f64>::new(START_M + STROKE_M, -STROKE_M, 0.4);
    match (out, back) {
        (Ok(out), Ok(_)) if t_s < 0.5 => out.sample(t_s - 0.05),
        (Ok(_), Ok(back)) => back.sample(t_s - 0.5),
        _ => Reference {
            position: START_M,
            velocity: 0.0,
            acceleration: 0.0,
        },
    }
}

/// The reference of `motion` at `t_s`.
pub fn reference(motion: Motion, t_s: f64) -> Reference<f64> {
    let hold = Reference {
        position: START_M,
        velocity: 0.0,
        acceleration: 0.0,
    };
    match motion {
        Motion::Profile => profile(t_s),
        Motion::Hold => hold,
    }
}

/// What the axis is asked to do.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Motion {
    /// The 1 s [`profile`].
    Profile,
    /// Hold the start position.
    Hold,
}

/// Scenario knobs.
#[derive(Copy, Clone, Debug)]
pub struct Scenario {
    /// Controller configuration.
    pub axis: AxisConfig,
    /// Plant.
    pub motor: LinearMotorParams,
    /// Sensors.
    pub sensor: HallSensorParams,
    /// Noise seed.
    pub seed: u64,
    /// Number of control periods.
    pub periods: u32,
    /// The motion to follow.
    pub motion: Motion,
    /// Learnt phase correction for the decoder, if any.
    pub correction: Option<HallCorrection>,
    /// External load step: (time in s, force in N).
    pub load_step: Option<(f64, f64)>,
    /// Inject a sensor fault from this time in s on.
    pub sensor_fault: Option<(f64, ChannelFault)>,
}

impl Scenario {
    /// The reference scenario: LM1247 axis with payload, 1 s of [`profile`].
    pub const TRACKING: Self = Self {
        axis: AxisConfig::LM1247_SLAVE,
        motor: LinearMotorParams::LM1247_WITH_PAYLOAD,
        sensor: HallSensorParams::LM1247_16BIT,
        seed: 0x6b65_7266,
        periods: 10_000,
        motion: Motion::Profile,
        correction: None,
        load_step: None,
        sensor_fault: None,
    };
}

/// One simulated control period, as the supervisor sees it.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Period {
    /// Time at the start of the period, s.
    pub t_s: f64,
    /// Reference position minus true plant position, m.
    pub error_m: f64,
    /// Force command, N.
    pub force_n: f64,
    /// Disturbance estimate, N.
    pub disturbance_n: f64,
    /// Velocity estimate, m/s.
    pub velocity_m_s: f64,
    /// Measured position, m.
    pub position_m: f64,
    /// The latched fault, if any.
    pub fault: Option<AxisFault>,
    /// Raw Hall counts the controller read this period.
    pub hall_counts: [u16; 3],
}

/// The controller in scalar `T` closed around the simulated axis, one period a step.
#[derive(Clone, Debug)]
pub struct Simulation<T> {
    scenario: Scenario,
    control: AxisLoop<T>,
    plant: SimulatedAxis,
    period: u32,
}

impl<T: Real> Simulation<T> {
    /// Builds the controller (validating its configuration) and the plant at rest.
    pub fn new(scenario: &Scenario) -> Result<Self, ConfigError> {
        let mut control = AxisLoop::<T>::new(&scenario.axis)?;
        control.set_home(T::from_f64(START_M));
        control.set_hall_correction(scenario.correction);
        let plant = SimulatedAxis::new(
            scenario.motor,
            scenario.sensor,
            TS_S,
            scenario.seed,
            START_M,
        );
        Ok(Self {
            scenario: *scenario,
            control,
            plant,
            period: 0,
        })
    }

    /// Runs one period of the scenario's motion; `None` once its periods are done.
    pub fn step(&mut self) -> Option<Period> {
        if self.period >= self.scenario.periods {
            return None;
        }
        let r = reference(self.scenario.motion, f64::from(self.period) * TS_S);
        Some(self.step_with(&Reference {
            position: T::from_f64(r.position),
            velocity: T::from_f64(r.velocity),
            acceleration: T::from_f64(r.acceleration),
        }))
    }

    /// Runs one period following `reference` (a mode that makes its own reference,
    /// such as calibration, drives the axis through this).
    pub fn step_with(&mut self, reference: &Reference<T>) -> Period {
        let t = f64::from(self.period) * TS_S;
        self.period += 1;
        if let Some((at, force)) = self.scenario.load_step {
            self.plant.motor.load_force_n = if t >= at { force } else { 0.0 };
        }
        if let Some((at, fault)) = self.scenario.sensor_fault {
            if t >= at {
                self.plant.sensor.fault = Some(fault);
            }
        }
        let hall_counts = self.plant.hall_counts(0);
        let out = self.control.step(hall_counts, reference);
        let error_m = reference.position.to_f64() - self.plant.motor.position_m;
        let force_n = out.force_n.to_f64();
        self.plant.apply_force(force_n);
        Period {
            t_s: t,
            error_m,
            force_n,
            disturbance_n: out.disturbance_n.to_f64(),
            velocity_m_s: out.velocity_m_s.to_f64(),
            position_m: out.position_m.to_f64(),
            hall_counts,
            fault: match out.state {
                AxisState::Fault(fault) => Some(fault),
                _ => None,
            },
        }
    }
}

/// Error statistics and signal peaks over a run; fed one [`Period`] at a time.
#[derive(Copy, Clone, Debug, Default)]
pub struct Outcome {
    /// Periods run.
    pub periods: u32,
    /// RMS of (reference − true plant position), m.
    pub rms_error_m: f64,
    /// Maximum |reference − true plant position|, m.
    pub max_error_m: f64,
    /// Maximum |error| at or after [`Outcome::window_from_s`], m.
    pub max_error_after_m: f64,
    /// Start of the window for `max_error_after_m`, s.
    pub window_from_s: f64,
    /// Error level for `last_violation_s`, m.
    pub settle_bound_m: f64,
    /// Last time |error| exceeded `settle_bound_m`, s (negative if never).
    pub last_violation_s: f64,
    /// Peak |force command|, N.
    pub peak_force_n: f64,
    /// Peak |disturbance estimate|, N.
    pub peak_disturbance_n: f64,
    /// Peak |velocity estimate|, m/s.
    pub peak_velocity_m_s: f64,
    /// Peak |measured position|, m.
    pub peak_position_m: f64,
    /// First period in fault and the fault, if any.
    pub fault_period: Option<u32>,
    /// The fault reported.
    pub fault: Option<AxisFault>,
    /// Largest |force command| from the fault on, N (must be 0).
    pub force_after_fault_n: f64,
    sum_sq_error: f64,
}

impl Outcome {
    /// Statistics that also track settling: the max error from `window_from_s` on and
    /// the last time the error exceeded `settle_bound_m`.
    pub fn with_window(window_from_s: f64, settle_bound_m: f64) -> Self {
        Self {
            window_from_s,
            settle_bound_m,
            last_violation_s: -1.0,
            ..Self::default()
        }
    }

    /// Adds one period.
    pub fn add(&mut self, p: &Period) {
        let e = libm::fabs(p.error_m);
        self.sum_sq_error += e * e;
        self.periods += 1;
        self.rms_error_m = libm::sqrt(self.sum_sq_error / f64::from(self.periods));
        self.max_error_m = self.max_error_m.max(e);
        if p.t_s >= self.window_from_s {
            self.max_error_after_m = self.max_error_after_m.max(e);
        }
        if e > self.settle_bound_m {
            self.last_violation_s = p.t_s;
        }
        self.peak_force_n = self.peak_force_n.max(libm::fabs(p.force_n));
        self.peak_disturbance_n = self.peak_disturbance_n.max(libm::fabs(p.disturbance_n));
        self.peak_velocity_m_s = self.peak_velocity_m_s.max(libm::fabs(p.velocity_m_s));
        self.peak_position_m = self.peak_position_m.max(libm::fabs(p.position_m));
        if let Some(fault) = p.fault {
            self.fault_period.get_or_insert(self.periods - 1);
            self.fault.get_or_insert(fault);
            self.force_after_fault_n = self.force_after_fault_n.max(libm::fabs(p.force_n));
        }
    }
}

/// Runs `scenario` with the controller in scalar `T`, collecting into `outcome`.
pub fn run_into<T: Real>(
    scenario: &Scenario,
    mut outcome: Outcome,
) -> Result<Outcome, ConfigError> {
    let mut sim = Simulation::<T>::new(scenario)?;
    while let Some(p) = sim.step() {
        outcome.add(&p);
    }
    Ok(outcome)
}

/// Runs `scenario` with the controller in scalar `T`.
pub fn run<T: Real>(scenario: &Scenario) -> Result<Outcome, ConfigError> {
    run_into::<T>(scenario, Outcome::with_window(f64::INFINITY, f64::INFINITY))
}

/// Why [`self_calibrate`] failed.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum CalibrationRunError {
    /// The controller configuration was rejected.
    Config(ConfigError),
    /// The fit failed.
    Calibration(CalibrationError),
    /// The axis faulted during the sweep.
    Fault(AxisFault),
}

/// Calibration mode ([`HallCalibrationMode`]) in closed loop with the decoder as
/// configured in `scenario` (nominal, uncalibrated), then the fit. Returns the fit and
/// `scenario` with the calibrated decoder and its model-derived correction installed.
pub fn self_calibrate<T: Real>(
    scenario: &Scenario,
) -> Result<(SelfCalibration, Scenario), CalibrationRunError> {
    let mut mode = HallCalibrationMode::<T>::new(START_M, scenario.axis.hall.pitch_m, TS_S)
        .map_err(CalibrationRunError::Config)?;
    let mut sweep = *scenario;
    sweep.correction = None;
    let mut simulation = Simulation::<T>::new(&sweep).map_err(CalibrationRunError::Config)?;
    loop {
        let period = simulation.step_with(&mode.reference());
        if let Some(fault) = period.fault {
            return Err(CalibrationRunError::Fault(fault));
        }
        let progress = mode
            .record(period.hall_counts)
            .map_err(CalibrationRunError::Calibration)?;
        if progress == CalibrationProgress::Done {
            break;
        }
    }
    let fit = mode
        .finish(&scenario.axis.hall.calibration)
        .map_err(CalibrationRunError::Calibration)?;
    let mut calibrated = *scenario;
    calibrated.axis.hall = scenario.axis.hall.with_self_calibration(&fit);
    calibrated.correction = Some(fit.correction);
    Ok((fit, calibrated))
}
