//! The Keops delta slave as a machine app (`DeltaSlave<T>` under the supervisor) on the
//! simulated delta (Lagrangian plant with gravity, Hall sensors per carriage), driven
//! by the same [`Operator`] as the single axis: calibrate the three carriages, load a
//! planned job, start it.

use crate::operator::{Operator, OperatorError, OperatorState};
use hal_mock::delta::SimulatedDelta;
use hal_mock::delta_plant::{DeltaPlant, DeltaPlantParams};
use hal_mock::hall_sensor::{ChannelFault, HallSensorParams};
use heapless::spsc::{Consumer, Producer, Queue};
use kerf::app::axis::HallAxis;
use kerf::app::jobs::JobSlots;
use kerf::app::joints::Segment;
use kerf::app::supervisor::{Command, Machine, Mode, Report, Supervisor};
use kerf::app::PeriodClock;
use kerf::hal::Monotonic;
use kerf::kinematics::delta::{DeltaConfig, DeltaGeometry, KinematicsError};
use kerf::kinematics::Vector3;
use kerf::machines::delta_slave::{
    DeltaFault, DeltaJob, DeltaJobError, DeltaSlave, DeltaSlaveConfig,
};
use kerf::scalar::Float;
use kerf::ConfigError;

/// The slave's operator.
pub type SlaveOperator<T> = Operator<DeltaSlave<T>, 3>;

/// A slave scenario: machine, plant, sensors and the job.
#[derive(Copy, Clone, Debug)]
pub struct SlaveScenario {
    /// The machine.
    pub machine: DeltaSlaveConfig,
    /// The plant's masses and limits.
    pub plant: DeltaPlantParams,
    /// Each carriage's Hall sensors.
    pub sensors: [HallSensorParams; 3],
    /// Noise seed (carriage k uses `seed + k`).
    pub seed: u64,
    /// Side of the square the effector traces, m, centred on the axis at `height_m`.
    pub side_m: f64,
    /// Time per side, s.
    pub side_s: f64,
    /// Height of the square: the effector's z, m.
    pub height_m: f64,
    /// Approach from home to the first corner, s.
    pub approach_s: f64,
    /// From this job time on (s), carriage `.1`'s sensor has fault `.2`.
    pub sensor_fault: Option<(f64, usize, ChannelFault)>,
    /// From this job time on (s), carriage `.1` is blocked where it is (a crash into
    /// a fixture, a jammed bearing): its position holds whatever force it gets.
    pub blocked_carriage: Option<(f64, usize)>,
    /// RK4 steps of the plant per control period.
    pub substeps: u32,
    /// Install the nominal decoders instead of calibrating (with sensors that match
    /// them): no sweep and no fit, for the emulated MCU, whose RAM holds the slave's
    /// queues and state but not also the fit's working set.
    pub stored_nominal_calibration: bool,
}

/// `params` with its channels' imperfections rotated by `k` places: each carriage's
/// sensors are imperfect in a different way.
fn rotated(params: HallSensorParams, k: usize) -> HallSensorParams {
    let mut p = params;
    p.offset_counts.rotate_left(k);
    p.amplitude_counts.rotate_left(k);
    p.harmonic3.rotate_left(k);
    p.harmonic3_phase_rad.rotate_left(k);
    p.harmonic5.rotate_left(k);
    p.harmonic5_phase_rad.rotate_left(k);
    p
}

impl SlaveScenario {
    /// A 20 mm square at 50 mm height (the middle of the Keops workspace's z range),
    /// 0.5 s per side (peak 75 mm/s along a side), after a 0.3 s approach; imperfect
    /// 16-bit Hall sensors (offsets, gains, phase errors, third harmonic, 4 LSB noise),
    /// different on each carriage, so the calibration must find each set.
    pub fn square() -> Self {
        let sensor = HallSensorParams::lm1247_imperfect(16, 4.0);
        Self {
            machine: DeltaSlaveConfig::KEOPS,
            plant: DeltaPlantParams::SLAVE,
            sensors: [rotated(sensor, 0), rotated(sensor, 1), rotated(sensor, 2)],
            seed: 0x6b65_7266,
            side_m: 0.020,
            side_s: 0.5,
            height_m: 0.050,
            approach_s: 0.3,
            sensor_fault: None,
            blocked_carriage: None,
            substeps: 4,
            stored_nominal_calibration: false,
        }
    }

    /// The corners of the square in order, the last one first (the start).
    fn corners(&self) -> [[f64; 3]; 4] {
        let h = 0.5 * self.side_m;
        [[h, -h], [h, h], [-h, h], [-h, -h]].map(|[x, y]| [x, y, self.height_m])
    }

    /// The job: approach the last corner, then the four sides.
    pub fn job(&self) -> Result<DeltaJob, DeltaJobError> {
        let corners = self.corners();
        let moves = corners.map(|target_m| Segment {
            target_m,
            duration_s: self.side_s,
        });
        DeltaJob::plan(&self.machine, corners[3], self.approach_s, &moves)
    }

    /// The operator: calibrates the three carriages, then loads and starts the job.
    pub fn operator<T: Float>(&self) -> Result<SlaveOperator<T>, SlaveError> {
        let job = self.job().map_err(SlaveError::Job)?;
        Ok(Operator::new(self.machine.joints.hall, None, job))
    }

    /// Time from `Start` to the end of the square, s.
    pub fn job_s(&self) -> f64 {
        self.approach_s + 4.0 * self.side_s
    }
}

/// One simulated period of the slave.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SlavePeriod {
    /// Time since the job started, s (−1 before).
    pub t_s: f64,
    /// The supervisor's mode after the period.
    pub mode: Mode<DeltaFault>,
    /// |effector reference − true effector| during a straight move, m.
    pub effector_error_m: Option<f64>,
    /// ‖Jx‖∞ at the true pose: how far a joint error can move the effector.
    pub jacobian_gain: f64,
    /// Force commands, N.
    pub force_n: [f64; 3],
    /// The laser's PWM duty commanded, in [0, 1].
    pub laser_duty: f64,
}

/// The simulated delta at rest at carriage positions `home_m` with `substeps` RK4 steps
/// per period of `period_s`; carriage k's sensors are `sensors[k]`, seeded `seed + k`.
pub(crate) fn simulated_delta(
    delta: &DeltaConfig,
    plant: DeltaPlantParams,
    sensors: [HallSensorParams; 3],
    period_s: f64,
    seed: u64,
    home_m: [f64; 3],
    substeps: u32,
) -> Result<SimulatedDelta, KinematicsError> {
    let mut simulated = SimulatedDelta::new(delta, plant, sensors, period_s, seed, home_m)?;
    if substeps != 4 {
        simulated.plant = DeltaPlant::new(delta, plant, period_s, substeps, Vector3::from(home_m))?;
    }
    Ok(simulated)
}

/// Where the carriages of `scenario` stand after resting unpowered (the drives off)
/// for up to `max_s`: each slides down its rail from the machine's home until it rests
/// on its end stop, as a machine stands when it is switched on. [`SlaveError::Timeout`]
/// if they still move then.
pub fn rest_unpowered(scenario: &SlaveScenario, max_s: f64) -> Result<[f64; 3], SlaveError> {
    let joints = &scenario.machine.joints;
    let mut delta = simulated_delta(
        &scenario.machine.delta,
        scenario.plant,
        scenario.sensors,
        joints.period_s,
        scenario.seed,
        joints.home_m,
        scenario.substeps,
    )
    .map_err(SlaveError::Plant)?;
    let plant = &mut delta.plant;
    for _ in 0..libm::ceil(max_s / joints.period_s) as u32 {
        plant.step(Vector3::zeros()).map_err(SlaveError::Plant)?;
        if plant.q_dot_m_s.iter().all(|v| *v == 0.0) {
            return Ok(plant.q_m.into());
        }
    }
    Err(SlaveError::Timeout)
}

/// The slave machine and the simulated delta: what the control interrupt owns.
pub struct SlaveRig<'q, T: Float> {
    scenario: SlaveScenario,
    supervisor: Supervisor<'q, DeltaSlave<T>>,
    plant: SimulatedDelta,
    geometry: DeltaGeometry<f64>,
    clock: PeriodClock,
    period: u32,
    job_start: Option<u32>,
    blocked_at_m: Option<f64>,
}

impl<'q, T: Float> SlaveRig<'q, T> {
    /// The machine (config validated) and the plant at rest at the machine's home.
    pub fn new(
        scenario: &SlaveScenario,
        commands: Consumer<'q, Command<DeltaSlave<T>>>,
        reports: Producer<'q, Report<DeltaSlave<T>>>,
        jobs: &'q JobSlots<<DeltaSlave<T> as Machine>::Job>,
    ) -> Result<Self, SlaveError> {
        let machine = DeltaSlave::<T>::new(&scenario.machine).map_err(SlaveError::Config)?;
        let mut supervisor = Supervisor::new(machine, commands, reports, jobs);
        supervisor.set_telemetry_decimation(0);
        let config = &scenario.machine;
        let plant = simulated_delta(
            &config.delta,
            scenario.plant,
            scenario.sensors,
            config.joints.period_s,
            scenario.seed,
            config.joints.home_m,
            scenario.substeps,
        )
        .map_err(SlaveError::Plant)?;
        let geometry =
            DeltaGeometry::new(&config.delta).map_err(|e| SlaveError::Config(e.within("delta")))?;
        let clock = PeriodClock::new(config.joints.period_s, plant.tick_hz())
            .map_err(SlaveError::Config)?;
        Ok(Self {
            scenario: *scenario,
            supervisor,
            plant,
            geometry,
            clock,
            period: 0,
            job_start: None,
            blocked_at_m: None,
        })
    }

    /// The supervisor.
    pub fn supervisor(&self) -> &Supervisor<'q, DeltaSlave<T>> {
        &self.supervisor
    }

    /// Telemetry reports every `every` periods (0: none, the default here).
    pub fn set_telemetry_decimation(&mut self, every: u32) {
        self.supervisor.set_telemetry_decimation(every);
    }

    /// The control period's clock (late periods).
    pub fn clock(&self) -> &PeriodClock {
        &self.clock
    }

    /// The simulated delta.
    pub fn plant(&self) -> &SimulatedDelta {
        &self.plant
    }

    /// One control period.
    pub fn step(&mut self) -> Result<SlavePeriod, SlaveError> {
        let ts = self.scenario.machine.joints.period_s;
        self.period += 1;
        let q = self.plant.plant.q_m;
        let p = self.geometry.forward(&q).map_err(SlaveError::Plant)?;
        let jacobian_gain = self
            .geometry
            .jacobian(&q, &p)
            .map(|j| (0..3).map(|i| j.row(i).abs().sum()).fold(0.0, f64::max))
            .map_err(SlaveError::Plant)?;
        let outputs =
            kerf::app::control_period(&mut self.supervisor, &mut self.clock, &mut self.plant);
        if let Some(e) = self.plant.error {
            return Err(SlaveError::Plant(e));
        }
        let mode = self.supervisor.mode();
        if mode == Mode::Running && self.job_start.is_none() {
            self.job_start = Some(self.period - 1);
        }
        let t = self
            .job_start
            .map_or(-1.0, |start| f64::from(self.period - 1 - start) * ts);
        if let (Some(start), Some((at, axis, fault))) = (self.job_start, self.scenario.sensor_fault)
        {
            if f64::from(self.period - start) * ts >= at {
                if let Some(sensor) = self.plant.sensors.get_mut(axis) {
                    sensor.fault = Some(fault);
                }
            }
        }
        if let (Some(start), Some((at, axis))) = (self.job_start, self.scenario.blocked_carriage) {
            if f64::from(self.period - start) * ts >= at {
                let plant = &mut self.plant.plant;
                let held = *self.blocked_at_m.get_or_insert(plant.q_m[axis.min(2)]);
                plant.q_m[axis.min(2)] = held;
                plant.q_dot_m_s[axis.min(2)] = 0.0;
            }
        }
        // The straight moves' error: the approach before them (its reference is the
        // travel's, by forward kinematics) is not part of the square.
        let moving = t >= self.scenario.approach_s - 0.5 * ts;
        let reference = self.supervisor.machine().telemetry().effector_reference_m;
        let effector_error_m = reference.filter(|_| moving).map(|r| {
            let r = Vector3::new(r[0].to_f64(), r[1].to_f64(), r[2].to_f64());
            (r - p).norm()
        });
        Ok(SlavePeriod {
            t_s: t,
            mode,
            effector_error_m,
            jacobian_gain,
            force_n: outputs.force_n.map(|f| f.to_f64()),
            laser_duty: outputs.laser_duty.to_f64(),
        })
    }
}

/// Why a slave scenario could not run to its end.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum SlaveError {
    /// The machine configuration was rejected.
    Config(ConfigError),
    /// The job could not be planned.
    Job(DeltaJobError),
    /// The simulated mechanism left the region where it assembles.
    Plant(KinematicsError),
    /// The operator gave up (refused command, failed fit).
    Operator(OperatorError<DeltaFault>),
    /// The job did not finish in time.
    Timeout,
}

/// What a slave run did, over the straight moves.
#[derive(Copy, Clone, Debug, Default)]
pub struct SlaveOutcome {
    /// Periods with an effector reference (the straight moves).
    pub periods: u32,
    /// RMS effector error, m.
    pub rms_effector_error_m: f64,
    /// Largest effector error, m.
    pub max_effector_error_m: f64,
    /// Largest ‖Jx‖∞ along the way.
    pub max_jacobian_gain: f64,
    /// Job time of the first period in fault, s.
    pub fault_at_s: Option<f64>,
    /// The fault.
    pub fault: Option<DeltaFault>,
    /// Largest |force| from the fault on, N (must be 0).
    pub force_after_fault_n: f64,
    /// Largest laser duty from the fault on (must be 0).
    pub laser_after_fault: f64,
    /// Control periods that started late (must be 0 in simulation).
    pub late_periods: u32,
    sum_sq_m2: f64,
}

impl SlaveOutcome {
    fn add(&mut self, p: &SlavePeriod) {
        if let Some(e) = p.effector_error_m {
            self.periods += 1;
            self.sum_sq_m2 += e * e;
            self.rms_effector_error_m = libm::sqrt(self.sum_sq_m2 / f64::from(self.periods));
            self.max_effector_error_m = self.max_effector_error_m.max(e);
            self.max_jacobian_gain = self.max_jacobian_gain.max(p.jacobian_gain);
        }
        if let Mode::Fault(fault) = p.mode {
            self.fault_at_s.get_or_insert(p.t_s);
            self.fault.get_or_insert(fault);
            let peak = p.force_n.iter().fold(0.0f64, |m, f| m.max(libm::fabs(*f)));
            self.force_after_fault_n = self.force_after_fault_n.max(peak);
            self.laser_after_fault = self.laser_after_fault.max(p.laser_duty);
        }
    }
}

/// Command queue of a slave run: the operator has at most a job load and a start in
/// flight. A command carries a calibration of three decoders or a job (5 KB each), so
/// the queue is kept short enough for the emulated MCU's 128 KB of RAM.
pub const SLAVE_COMMAND_CAPACITY: usize = 4;

/// Report queue of a slave run: the operator drains it every period, and a period
/// reports at most a calibration sample per carriage, a reply and a mode change.
pub const SLAVE_REPORT_CAPACITY: usize = 16;

/// Runs `scenario` with the machine in scalar `T`, operator and rig in lockstep, until
/// the job is done (or the machine faults and `fault_periods` more have passed).
pub fn run_slave<T: Float>(
    scenario: &SlaveScenario,
    fault_periods: u32,
    each: impl FnMut(&SlavePeriod, &SlaveRig<'_, T>),
) -> Result<SlaveOutcome, SlaveError> {
    let job = scenario.job().map_err(SlaveError::Job)?;
    run_slave_job(scenario, job, scenario.job_s(), fault_periods, each)
}

/// [`run_slave`] with another job (a contour) that lasts about `job_s` from `Start`.
pub fn run_slave_job<T: Float>(
    scenario: &SlaveScenario,
    job: DeltaJob,
    job_s: f64,
    fault_periods: u32,
    mut each: impl FnMut(&SlavePeriod, &SlaveRig<'_, T>),
) -> Result<SlaveOutcome, SlaveError> {
    let jobs = JobSlots::default();
    let mut commands = Queue::<Command<DeltaSlave<T>>, SLAVE_COMMAND_CAPACITY>::new();
    let mut reports = Queue::<Report<DeltaSlave<T>>, SLAVE_REPORT_CAPACITY>::new();
    let (mut send, from_sender) = commands.split();
    let (to_operator, mut receive) = reports.split();
    let mut rig = SlaveRig::<T>::new(scenario, from_sender, to_operator, &jobs)?;
    let hall = scenario.machine.joints.hall;
    let stored = if scenario.stored_nominal_calibration {
        let [a, b, c] = hall.map(|h| HallAxis::<T>::new(&h));
        match (a, b, c) {
            (Ok(a), Ok(b), Ok(c)) => Some([a, b, c]),
            (Err(e), _, _) | (_, Err(e), _) | (_, _, Err(e)) => return Err(SlaveError::Config(e)),
        }
    } else {
        None
    };
    let mut operator = Operator::new(hall, stored, job);
    operator.start(&mut send, &jobs);
    let mut outcome = SlaveOutcome::default();
    // Calibration sweep (0.8 s), the job, and a margin.
    let limit = ((job_s + 2.0) / scenario.machine.joints.period_s) as u32;
    let mut after_fault = 0;
    for _ in 0..limit {
        let period = rig.step()?;
        outcome.late_periods = rig.clock().late_periods();
        outcome.add(&period);
        each(&period, &rig);
        match operator.poll(&mut receive, &mut send, &jobs) {
            OperatorState::Finished => return Ok(outcome),
            OperatorState::Failed(OperatorError::Fault(_)) => {
                after_fault += 1;
                if after_fault > fault_periods {
                    return Ok(outcome);
                }
            }
            OperatorState::Failed(e) => return Err(SlaveError::Operator(e)),
            _ => {}
        }
    }
    Err(SlaveError::Timeout)
}
