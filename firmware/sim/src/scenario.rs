//! The single LM1247 axis as a machine app (`Joints<T, 1>` under the supervisor) on the
//! simulated axis, with the slower context's side ([`Operator`]) that calibrates, loads
//! the job and starts it through the command queue, as a host or task would.

use hal_mock::axis::SimulatedAxis;
use hal_mock::delta_plant::DeltaPlantParams;
use hal_mock::hall_sensor::{ChannelFault, HallSensorParams};
use hal_mock::linear_motor::LinearMotorParams;
use heapless::spsc::{Consumer, Producer};
use kerf::app::axis::{AxisFault, HallAxis};
use kerf::app::jobs::JobSlots;
use kerf::app::joints::{JointFault, JointJob, Joints, JointsConfig, Segment};
use kerf::app::supervisor::{Command, Machine, Mode, Report, Supervisor};
use kerf::app::PeriodClock;
use kerf::hal::{Monotonic, SampleInputs, WriteOutputs};
use kerf::machines::delta_slave::DeltaSlaveConfig;
use kerf::sensing::hall::SelfCalibration;
use kerf::trajectory::quintic::Quintic;
use kerf::trajectory::Reference;
use kerf::{ConfigContext, ConfigError, Real};

pub use crate::operator::{
    Operator, OperatorError, OperatorState, COMMAND_CAPACITY, REPORT_CAPACITY,
};

/// The single axis' operator.
pub type AxisOperator<T> = Operator<Joints<T, 1>, 1>;

/// Control period of the single-axis scenarios (10 kHz): the machine's, stated once in
/// [`JointsConfig::LM1247`].
pub const TS_S: f64 = JointsConfig::LM1247.period_s;
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

/// The 1 s tracking profile as a job: dwell 50 ms, 30 mm out in 0.4 s, dwell 50 ms,
/// back in 0.4 s, dwell 0.1 s (the same reference as [`profile`]).
fn profile_job() -> JointJob<1> {
    let at = |target: f64, duration_s: f64| Segment {
        target_m: [target],
        duration_s,
    };
    JointJob::from_slice(&[
        at(START_M, 0.05),
        at(START_M + STROKE_M, 0.4),
        at(START_M + STROKE_M, 0.05),
        at(START_M, 0.4),
        at(START_M, 0.1),
    ])
    .expect("5 segments fit a job")
}

/// What the axis is asked to do.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Motion {
    /// The 1 s [`profile`].
    Profile,
    /// Hold the start position.
    Hold,
}

impl Motion {
    /// The job for `periods` periods of this motion.
    pub fn job(self, periods: u32) -> JointJob<1> {
        match self {
            Motion::Profile => profile_job(),
            Motion::Hold => JointJob::from_slice(&[Segment {
                target_m: [START_M],
                duration_s: f64::from(periods) * TS_S,
            }])
            .expect("1 segment fits a job"),
        }
    }
}

/// Scenario knobs.
#[derive(Copy, Clone, Debug)]
pub struct Scenario {
    /// The machine: control law, decoder, period, limits.
    pub machine: JointsConfig<1>,
    /// Plant.
    pub motor: LinearMotorParams,
    /// Sensors.
    pub sensor: HallSensorParams,
    /// Noise seed.
    pub seed: u64,
    /// Number of control periods of the job.
    pub periods: u32,
    /// The motion to follow.
    pub motion: Motion,
    /// External load step: (time in s, force in N).
    pub load_step: Option<(f64, f64)>,
    /// Inject a sensor fault from this time in s on.
    pub sensor_fault: Option<(f64, ChannelFault)>,
    /// Run the calibration mode first (sweep, fit) instead of installing the
    /// configured decoder as a stored calibration.
    pub calibrate: bool,
}

impl Scenario {
    /// The reference scenario: LM1247 axis with payload, 1 s of [`profile`].
    pub const TRACKING: Self = Self {
        machine: JointsConfig::LM1247,
        motor: LinearMotorParams::LM1247_WITH_PAYLOAD,
        sensor: HallSensorParams::LM1247_16BIT,
        seed: 0x6b65_7266,
        periods: 10_000,
        motion: Motion::Profile,
        load_step: None,
        sensor_fault: None,
        calibrate: false,
    };

    /// One carriage of the Keops slave on the simulated axis: the slave's joint
    /// configuration (`DeltaSlaveConfig::KEOPS.joints`: law, first carriage's decoder,
    /// speed and acceleration limits) with its actuator's 0–40 mm travel, the realistic
    /// slave plant's carriage share (`DeltaPlantParams::SLAVE_REALISTIC`: the 71 g
    /// slider plus a third of the 68 g effector and its 20 g payload, 100 g; its
    /// friction) and a constant load of the order of the carriage's gravity from the
    /// job's start: the slider's weight along its 30° rail plus a third of the
    /// effector's and payload's weight, 0.64 N down the rail. The arms' changing share of the
    /// effector's weight and inertia over the workspace is not modelled. Same sensors,
    /// seed and [`profile`] (4.3 to 34.3 mm, inside the travel) as [`Self::TRACKING`];
    /// the rig homes at the profile's start, not at the slave's 10 mm home.
    pub fn keops_joint() -> Self {
        let slave = DeltaSlaveConfig::KEOPS;
        let plant = DeltaPlantParams::SLAVE_REALISTIC;
        let actuator = slave.delta.actuators[0];
        let shared_kg = (plant.effector_mass_kg + plant.payload_kg) / 3.0;
        // Down the rail (z up, the carriage rises with q): a negative load.
        let gravity_n = plant.gravity_z_m_s2
            * (plant.carriage_mass_kg * libm::sin(actuator.alpha_rad) + shared_kg);
        Self {
            machine: JointsConfig {
                period_s: slave.joints.period_s,
                axis: slave.joints.axis,
                hall: [slave.joints.hall[0]],
                home_m: [slave.joints.home_m[0]],
                travel_m: [[actuator.travel_min_m, actuator.travel_max_m]],
                speed_limit_m_s: slave.joints.speed_limit_m_s,
                accel_limit_m_s2: slave.joints.accel_limit_m_s2,
            },
            motor: LinearMotorParams {
                mass_kg: plant.carriage_mass_kg + shared_kg,
                coulomb_n: plant.coulomb_n,
                viscous_n_s_per_m: plant.viscous_n_s_per_m,
                force_limit_n: plant.force_limit_n,
                ..LinearMotorParams::LM1247_WITH_PAYLOAD
            },
            load_step: Some((0.0, gravity_n)),
            ..Self::TRACKING
        }
    }

    /// Periods after which a run that has not finished counts as hung: the
    /// calibration (0.8 s), the wait for the fit, then the job, with margin.
    pub fn period_limit(&self) -> u32 {
        4 * self.periods + 20_000
    }

    /// The slower context for this scenario: calibrates when `calibrate` is set,
    /// otherwise installs the configured decoder (with its calibration) as a stored
    /// calibration; then loads and starts the motion's job.
    pub fn operator<T: Real>(&self) -> Result<AxisOperator<T>, ConfigError> {
        let stored = if self.calibrate {
            None
        } else {
            let sensor = HallAxis::<T>::new(&self.machine.hall[0])
                .at(0)
                .within("hall")?;
            Some([sensor])
        };
        Ok(Operator::new(
            self.machine.hall,
            stored,
            self.motion.job(self.periods),
        ))
    }
}

/// One simulated control period, as the rig sees it.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Period {
    /// Time since the job started, s (−1 before).
    pub t_s: f64,
    /// The supervisor's mode after the period.
    pub mode: Mode<kerf::app::joints::JointFault>,
    /// Whether the job was running in this period (it may have ended in it).
    pub ran_job: bool,
    /// Reference position minus true plant position, m.
    pub error_m: f64,
    /// Force command, N.
    pub force_n: f64,
    /// Disturbance estimate, N.
    pub disturbance_n: f64,
    /// The PD's acceleration command, m/s², recomputed from the period's reference
    /// and the measured position and velocity (what the DOB was handed).
    pub acceleration_m_s2: f64,
    /// Velocity estimate, m/s.
    pub velocity_m_s: f64,
    /// Measured position, m.
    pub position_m: f64,
    /// The latched fault, if any.
    pub fault: Option<AxisFault>,
    /// Raw Hall counts the controller read this period.
    pub hall_counts: [u16; 3],
}

impl Period {
    /// Whether the period counts for the job's statistics (running, or faulted).
    pub fn in_job(&self) -> bool {
        self.ran_job || matches!(self.mode, Mode::Fault(_))
    }
}

/// The machine app in scalar `T` and the simulated axis: what the control interrupt
/// owns. Commands reach it only through the supervisor's queue.
pub struct Rig<'q, T: Real> {
    scenario: Scenario,
    supervisor: Supervisor<'q, Joints<T, 1>>,
    plant: SimulatedAxis,
    clock: PeriodClock,
    period: u32,
    job_start: Option<u32>,
}

impl<'q, T: Real> Rig<'q, T> {
    /// Builds the machine (validating its configuration) and the plant at rest.
    pub fn new(
        scenario: &Scenario,
        commands: Consumer<'q, Command<Joints<T, 1>>>,
        reports: Producer<'q, Report<Joints<T, 1>>>,
        jobs: &'q JobSlots<<Joints<T, 1> as Machine>::Job>,
    ) -> Result<Self, ConfigError> {
        let mut machine_config = scenario.machine;
        machine_config.home_m = [START_M];
        let machine = Joints::<T, 1>::new(&machine_config)?;
        let mut supervisor = Supervisor::new(machine, commands, reports, jobs);
        supervisor.set_telemetry_decimation(0);
        let plant = SimulatedAxis::new(
            scenario.motor,
            scenario.sensor,
            machine_config.period_s,
            scenario.seed,
            START_M,
        );
        let clock = PeriodClock::new(machine_config.period_s, plant.tick_hz())?;
        Ok(Self {
            scenario: *scenario,
            supervisor,
            plant,
            period: 0,
            clock,
            job_start: None,
        })
    }

    /// The control period's clock (late periods).
    pub fn clock(&self) -> &PeriodClock {
        &self.clock
    }

    /// The supervisor (mode, machine).
    pub fn supervisor(&self) -> &Supervisor<'q, Joints<T, 1>> {
        &self.supervisor
    }

    /// Reports telemetry every `every` control periods (0: never, as built).
    pub fn set_telemetry_decimation(&mut self, every: u32) {
        self.supervisor.set_telemetry_decimation(every);
    }

    /// One control period: inputs sampled, supervisor stepped, outputs written (the
    /// plant advances one period), as the control interrupt does it.
    pub fn step(&mut self) -> Period {
        let ts = self.scenario.machine.period_s;
        let before = self.supervisor.mode();
        self.period += 1;
        let true_position_m = self.plant.motor.position_m;
        let mut hal = Recording {
            plant: &mut self.plant,
            inputs: [[0; 3]],
        };
        let force = kerf::app::control_period(&mut self.supervisor, &mut self.clock, &mut hal);
        let hall_counts = hal.inputs[0];
        let mode = self.supervisor.mode();
        // Scenario times count from the job's start (after any calibration); set up the
        // plant's load and sensor for the next period.
        if mode == Mode::Running && self.job_start.is_none() {
            self.job_start = Some(self.period - 1);
        }
        let t = self
            .job_start
            .map_or(-1.0, |start| f64::from(self.period - 1 - start) * ts);
        if let Some(start) = self.job_start {
            let t_next = f64::from(self.period - start) * ts;
            if let Some((at, force)) = self.scenario.load_step {
                self.plant.motor.load_force_n = if t_next >= at { force } else { 0.0 };
            }
            if let Some((at, fault)) = self.scenario.sensor_fault {
                if t_next >= at {
                    self.plant.sensor.fault = Some(fault);
                }
            }
        }
        let machine = self.supervisor.machine();
        let reference = machine.reference()[0];
        let out = machine.telemetry().axes[0];
        let moving = |m| matches!(m, Mode::Running | Mode::Stopping);
        Period {
            t_s: t,
            mode,
            ran_job: moving(mode) || (moving(before) && self.job_start.is_some()),
            error_m: reference.position.to_f64() - true_position_m,
            force_n: force[0].to_f64(),
            disturbance_n: out.disturbance_n.to_f64(),
            acceleration_m_s2: machine
                .law()
                .pd_acceleration(&reference, out.position_m, out.velocity_m_s)
                .to_f64(),
            velocity_m_s: out.velocity_m_s.to_f64(),
            position_m: out.position_m.to_f64(),
            fault: match mode {
                Mode::Fault(f) => Some(f.fault),
                _ => None,
            },
            hall_counts,
        }
    }
}

/// The simulated axis behind the HAL traits, keeping what it sampled for the record.
struct Recording<'a> {
    plant: &'a mut SimulatedAxis,
    inputs: [[u16; 3]; 1],
}

impl SampleInputs<[[u16; 3]; 1]> for Recording<'_> {
    fn sample(&mut self) -> [[u16; 3]; 1] {
        self.inputs = self.plant.sample();
        self.inputs
    }
}

impl Monotonic for Recording<'_> {
    fn tick_hz(&self) -> u64 {
        self.plant.tick_hz()
    }
    fn now(&mut self) -> u64 {
        self.plant.now()
    }
}

impl<T: Real> WriteOutputs<[T; 1]> for Recording<'_> {
    fn write(&mut self, force_n: &[T; 1]) {
        self.plant.write(force_n);
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
    /// Peak |acceleration command|, m/s².
    pub peak_acceleration_m_s2: f64,
    /// Peak |measured position|, m.
    pub peak_position_m: f64,
    /// First period in fault, if any.
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
        if p.fault.is_none() {
            self.peak_acceleration_m_s2 = self
                .peak_acceleration_m_s2
                .max(libm::fabs(p.acceleration_m_s2));
        }
        self.peak_position_m = self.peak_position_m.max(libm::fabs(p.position_m));
        if let Some(fault) = p.fault {
            self.fault_period.get_or_insert(self.periods - 1);
            self.fault.get_or_insert(fault);
            self.force_after_fault_n = self.force_after_fault_n.max(libm::fabs(p.force_n));
        }
    }
}

/// Runs `scenario` with the machine in scalar `T`: the operator and the rig in
/// lockstep (the operator polls after every period), collecting the job's periods into
/// `outcome` and handing every period to `each`. Returns the outcome and the fit (when
/// the scenario calibrates).
pub fn run_with<T: Real>(
    scenario: &Scenario,
    mut outcome: Outcome,
    mut each: impl FnMut(&Period),
) -> Result<(Outcome, Option<SelfCalibration>), ScenarioError> {
    let jobs = JobSlots::default();
    let mut commands = heapless::spsc::Queue::<Command<Joints<T, 1>>, COMMAND_CAPACITY>::new();
    let mut reports = heapless::spsc::Queue::<Report<Joints<T, 1>>, REPORT_CAPACITY>::new();
    let (mut send, from_sender) = commands.split();
    let (to_operator, mut receive) = reports.split();
    let mut rig =
        Rig::<T>::new(scenario, from_sender, to_operator, &jobs).map_err(ScenarioError::Config)?;
    let mut operator = scenario.operator::<T>().map_err(ScenarioError::Config)?;
    operator.start(&mut send, &jobs);
    for _ in 0..scenario.period_limit() {
        let period = rig.step();
        if period.in_job() {
            outcome.add(&period);
        }
        each(&period);
        match operator.poll(&mut receive, &mut send, &jobs) {
            OperatorState::Finished => return Ok((outcome, operator.fit().copied())),
            OperatorState::Failed(OperatorError::Fault(_)) => {}
            OperatorState::Failed(e) => return Err(ScenarioError::Operator(e)),
            _ => {}
        }
        if outcome.periods >= scenario.periods {
            return Ok((outcome, operator.fit().copied()));
        }
    }
    Err(ScenarioError::Timeout)
}

/// Why a scenario could not be run to its end.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum ScenarioError {
    /// The machine configuration was rejected.
    Config(ConfigError),
    /// The operator gave up (refused command, failed fit).
    Operator(OperatorError<JointFault>),
    /// The job did not finish in time.
    Timeout,
}

/// Runs `scenario` with the machine in scalar `T`, collecting into `outcome`.
pub fn run_into<T: Real>(scenario: &Scenario, outcome: Outcome) -> Result<Outcome, ScenarioError> {
    run_with::<T>(scenario, outcome, |_| {}).map(|(o, _)| o)
}

/// Runs `scenario` with the machine in scalar `T`.
pub fn run<T: Real>(scenario: &Scenario) -> Result<Outcome, ScenarioError> {
    run_into::<T>(scenario, Outcome::with_window(f64::INFINITY, f64::INFINITY))
}
