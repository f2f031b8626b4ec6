//! ARROW's pyramid job (A §5) as the QEMU image and the host tests both run it: the
//! G-code file read into a job on the machine, run through the supervisor at 5 kHz on
//! the simulated ARROW with its geometric error, errors measured each period at its
//! end against the period's reference and accumulated in constant memory as A
//! eq. 55–58's sums.

use hal_mock::arrow::{ArrowPlant, ArrowPlantConfig, ArrowReading};
use heapless::spsc::Queue;
use kerf::app::jobs::{JobSlot, JobSlots};
use kerf::app::supervisor::{Command, Machine, Mode, Report, Supervisor};
use kerf::control::redundant_pid::RedundantPidConfig;
use kerf::kinematics::arrow::{ActuatorVector, ArrowError, ArrowGeometry, ForwardConfig, Pose};
use kerf::machines::arrow::machine::{ArrowFault, ArrowInputs, ArrowLimits, ArrowOutputs};
use kerf::machines::arrow::product::{law, Arrow, Job, PERIOD_S};
use kerf::machines::arrow::ArrowLaw;
use kerf::{Float, Real};

/// The pyramid of A fig. 26–27 as the G-code file the firmware image carries.
pub const PYRAMID_GCODE: &str = include_str!("../../../data/pyramid.gcode");

/// The smoke run's bounds: A table 3's Cartesian figures (eq. 55, 56), which the
/// host's f64 run of the same scenario meets with margin (docs/modules.md).
pub const ARROW_SMOKE_BOUNDS: TrackingBounds = TrackingBounds {
    cartesian_m: 7.06e-6,
    cartesian_deg: 0.0170,
};

/// How far the f32 image's RMS figures may lie from the host's f64 run of the same
/// scenario (eq. 55 in m, eq. 56 in deg): f32 rounds the plate's position near
/// 0.5 m to 0.03 µm and the loop carries such perturbations with a gain of a few, so
/// some 0.1 µm per period, far less once averaged over the run; measured 6 nm and
/// 1 µdeg apart over the pyramid.
pub const ARROW_F32_TOLERANCE: TrackingBounds = TrackingBounds {
    cartesian_m: 50e-9,
    cartesian_deg: 20e-6,
};

/// Upper bounds on the Cartesian RMS errors.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TrackingBounds {
    /// Eq. 55, m.
    pub cartesian_m: f64,
    /// Eq. 56, deg.
    pub cartesian_deg: f64,
}

impl TrackingBounds {
    /// Whether `r` is within the bounds.
    pub fn holds(&self, r: &TrackingRms) -> bool {
        r.cartesian_m < self.cartesian_m && r.cartesian_deg < self.cartesian_deg
    }
}

/// What a run varies.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowScenario {
    /// Parallel module gains (the regularization in it).
    pub parallel: RedundantPidConfig,
    /// Turntable gains.
    pub turntable: RedundantPidConfig,
    /// Add the inverse dynamic model's forces (eq. 46's Γ_ff).
    pub feedforward: bool,
    /// The simulated machine.
    pub plant: ArrowPlantConfig,
}

impl ArrowScenario {
    /// A's PID with feedforward and regularization on the machine with its
    /// geometric error, the plant integrated with 4 RK4 steps per period.
    pub fn published() -> Self {
        Self {
            parallel: RedundantPidConfig::ARROW_PARALLEL,
            turntable: RedundantPidConfig::ARROW_TURNTABLE,
            feedforward: true,
            plant: ArrowPlantConfig::with_geometric_error(PERIOD_S),
        }
    }

    /// A's, with one RK4 step per period: what the emulated MCU pays for (the
    /// closed loop's fastest mode, √(K_P/m) ≈ 540 rad/s, is 0.11 rad per period, well
    /// inside RK4's stable step).
    pub fn smoke() -> Self {
        let mut s = Self::published();
        s.plant.substeps = 1;
        s
    }

    /// The law on the controller's nominal model (A table 1–2) with this scenario's
    /// gains ([`kerf::machines::arrow::product::law`]).
    pub fn law<T: Float>(&self) -> Result<ArrowLaw<T>, ArrowError> {
        law(
            &self.parallel,
            &self.turntable,
            self.feedforward,
            self.plant.period_s,
        )
        .map_err(|_| ArrowError::NotFinite)
    }
}

/// One period's errors, at its end against its reference.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowPeriod<T> {
    /// Period index from the start.
    pub k: u64,
    /// Desired plate pose.
    pub desired: Pose<T>,
    /// θx desired, rad.
    pub theta_x_rad: T,
    /// Encoders minus the joint references (eq. 57's q̃), m.
    pub joint_error_m: ActuatorVector<T>,
    /// Table motors minus their references (eq. 58's q̃), rad.
    pub table_error_rad: [T; 2],
    /// X̃ = Jm⁺ q̃ (eq. 13): the Cartesian error the encoders show, as A
    /// monitors it (A §5).
    pub cartesian_error: Pose<T>,
    /// Rm q̃ = Jm X̃ (eq. 38): the joints' error that moves the plate; the rest is
    /// the geometric error's inconsistency, which the regularized law leaves alone.
    pub joint_error_consistent_m: ActuatorVector<T>,
    /// θx error from the table motors, (q̃T1 − q̃T2)/2, rad.
    pub theta_x_error_rad: T,
    /// The plate's true pose minus the desired one.
    pub true_pose_error: Pose<T>,
    /// The outputs written.
    pub outputs: ArrowOutputs<T>,
    /// Whether a command was at its limit.
    pub saturated: bool,
}

/// The sums of A eq. 55–58 over a run, in f64.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct TrackingSums {
    /// Periods summed.
    pub periods: u64,
    cartesian_m2: f64,
    cartesian_rad2: f64,
    joint_m2: f64,
    consistent_m2: f64,
    table_rad2: f64,
    true_m2: f64,
    /// Periods with a command at its limit.
    pub saturated: u64,
}

/// RMS tracking errors of A eq. 55–58.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct TrackingRms {
    /// Eq. 55, Cartesian translation, m.
    pub cartesian_m: f64,
    /// Eq. 56, Cartesian rotation (θz and θx), deg.
    pub cartesian_deg: f64,
    /// Eq. 57, the six actuators, m.
    pub joint_m: f64,
    /// Eq. 57 on Rm q̃ (the joints' error that moves the plate), m.
    pub joint_consistent_m: f64,
    /// Eq. 58, the two table motors, deg.
    pub joint_deg: f64,
    /// Eq. 55 on the true pose (geometric error included), m.
    pub true_cartesian_m: f64,
}

impl TrackingSums {
    /// Adds a period.
    pub fn push<T: Float>(&mut self, p: &ArrowPeriod<T>) {
        let sq = |v: T| {
            let v = v.to_f64();
            v * v
        };
        let xyz = |v: &Pose<T>| sq(v.x) + sq(v.y) + sq(v.z);
        self.periods += 1;
        self.cartesian_m2 += xyz(&p.cartesian_error);
        self.cartesian_rad2 += sq(p.cartesian_error.w) + sq(p.theta_x_error_rad);
        self.joint_m2 += p.joint_error_m.iter().map(|v| sq(*v)).sum::<f64>();
        self.consistent_m2 += p
            .joint_error_consistent_m
            .iter()
            .map(|v| sq(*v))
            .sum::<f64>();
        self.table_rad2 += sq(p.table_error_rad[0]) + sq(p.table_error_rad[1]);
        self.true_m2 += xyz(&p.true_pose_error);
        self.saturated += u64::from(p.saturated);
    }

    /// The RMS figures.
    pub fn rms(&self) -> TrackingRms {
        let n = self.periods.max(1) as f64;
        let root = |s: f64| libm::sqrt(s / n);
        TrackingRms {
            cartesian_m: root(self.cartesian_m2),
            cartesian_deg: root(self.cartesian_rad2).to_degrees(),
            joint_m: root(self.joint_m2),
            joint_consistent_m: root(self.consistent_m2),
            joint_deg: root(self.table_rad2).to_degrees(),
            true_cartesian_m: root(self.true_m2),
        }
    }
}

/// How a run ended.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowRunEnd<T> {
    /// Periods run.
    pub periods: u64,
    /// The supervisor's mode at the end.
    pub mode: Mode<ArrowFault>,
    /// The outputs written in the last period.
    pub last_outputs: ArrowOutputs<T>,
}

/// How the machine meets its plant: the encoders it reads at a period's start, the
/// outputs it writes, and the plate's true pose (for the figures). [`PlantIo`] is
/// the plant wired directly; `crate::arrow_drives` puts the actuators' drives and
/// their buses in between.
pub trait ArrowIo<T: Float> {
    /// The inputs of period `k` (at its start), as the machine reads them.
    fn read(&mut self, k: u64) -> Result<ArrowInputs<T>, ArrowError>;
    /// The period's outputs written; the encoders at its end, as the figures see them.
    fn step(&mut self, outputs: &ArrowOutputs<T>) -> Result<ArrowReading<T>, ArrowError>;
    /// The plate's true pose now.
    fn pose(&self) -> Pose<T>;
}

/// The plant wired directly: the machine reads its encoders, and its forces act in
/// the period they were computed in.
pub struct PlantIo<'d, T: Float> {
    /// The plant.
    pub plant: ArrowPlant<T>,
    /// May corrupt the encoders of period k before the machine reads them.
    pub disturb: &'d mut dyn FnMut(u64, &mut ArrowReading<T>),
}

impl<T: Float> ArrowIo<T> for PlantIo<'_, T> {
    fn read(&mut self, k: u64) -> Result<ArrowInputs<T>, ArrowError> {
        let mut reading = self.plant.read()?;
        (self.disturb)(k, &mut reading);
        Ok(ArrowInputs {
            joints_m: reading.joints_m,
            table_rad: reading.turntable_rad,
            drive_fault: None,
        })
    }

    fn step(&mut self, outputs: &ArrowOutputs<T>) -> Result<ArrowReading<T>, ArrowError> {
        self.plant.step(&outputs.forces_n, outputs.torques_n_m)
    }

    fn pose(&self) -> Pose<T> {
        self.plant.state().0
    }
}

/// The plant at rest where its joints are the job's start joints on the model (its
/// least-squares pose for them: the geometric error leaves a joint inconsistency
/// the regularized law does not fight).
pub fn start_plant<T: Float>(
    scenario: &ArrowScenario,
    job: &Job<T>,
) -> Result<ArrowPlant<T>, ArrowError> {
    let (start, theta_x0) = job.start();
    let plant_geometry =
        ArrowGeometry::<T>::new(&scenario.plant.geometry).map_err(|_| ArrowError::NotFinite)?;
    let loose = ForwardConfig {
        residual_tolerance_m: 1e-3,
        ..ForwardConfig::MONITOR
    };
    let start_true = plant_geometry.forward(job.start_joints_m(), &start, &loose)?;
    ArrowPlant::<T>::new(&scenario.plant, start_true, theta_x0)
}

/// Runs `job` on the simulated ARROW through the supervisor: calibrate, load, start,
/// then one period at a time until the machine leaves `Running` or `max_periods`
/// pass. `disturb(k, reading)` may corrupt the encoders before the machine reads them
/// in period k; `observe` sees every period's errors. The plant starts as
/// [`start_plant`] puts it.
pub fn run_job<T: Float>(
    scenario: &ArrowScenario,
    job: &Job<T>,
    max_periods: u64,
    disturb: &mut dyn FnMut(u64, &mut ArrowReading<T>),
    observe: &mut dyn FnMut(&ArrowPeriod<T>),
) -> Result<ArrowRunEnd<T>, ArrowError> {
    let plant = start_plant(scenario, job)?;
    let mut io = PlantIo { plant, disturb };
    run_job_on(scenario, job, max_periods, &mut io, observe)
}

/// [`run_job`] on any [`ArrowIo`].
pub fn run_job_on<T: Float>(
    scenario: &ArrowScenario,
    job: &Job<T>,
    max_periods: u64,
    io: &mut dyn ArrowIo<T>,
    observe: &mut dyn FnMut(&ArrowPeriod<T>),
) -> Result<ArrowRunEnd<T>, ArrowError> {
    let law = scenario.law::<T>()?;
    let geometry = law.geometry;
    let machine = Arrow::<T>::new(law, scenario.plant.period_s, &ArrowLimits::ARROW)
        .map_err(|_| ArrowError::NotFinite)?;
    let jobs = JobSlots::new(job.clone(), Job::default());
    let mut commands: Queue<Command<Arrow<T>>, 2> = Queue::new();
    let mut reports: Queue<Report<Arrow<T>>, 8> = Queue::new();
    let (mut to_machine, from_sender) = commands.split();
    let (to_sender, mut from_machine) = reports.split();
    let mut supervisor = Supervisor::new(machine, from_sender, to_sender, &jobs);
    supervisor.set_telemetry_decimation(u32::MAX);
    let mut inputs = io.read(0)?;
    let mut outputs = supervisor.step(&inputs);
    // One command a period (the queue holds one command).
    for command in [
        Command::Calibrate,
        Command::FinishCalibration(()),
        Command::LoadJob(JobSlot::First),
        Command::Start,
    ] {
        if to_machine.enqueue(command).is_err() {
            return Err(ArrowError::NotFinite);
        }
        outputs = supervisor.step(&inputs);
        while from_machine.dequeue().is_some() {}
    }
    let mut k = 0;
    while k < max_periods && supervisor.mode() == Mode::Running {
        inputs = io.read(k)?;
        outputs = supervisor.step(&inputs);
        while from_machine.dequeue().is_some() {}
        let telemetry = supervisor.machine().telemetry();
        let after = io.step(&outputs)?;
        k += 1;
        if matches!(supervisor.mode(), Mode::Fault(_)) {
            break;
        }
        // The period's references, recovered from the telemetry's errors against the
        // inputs it saw.
        let q_ref = telemetry.joint_error_m + inputs.joints_m;
        let joint_error_m = after.joints_m - q_ref;
        let table_error_rad = [
            after.turntable_rad[0] - telemetry.theta_x_rad,
            after.turntable_rad[1] + telemetry.theta_x_rad,
        ];
        let (_, jm) = geometry.jacobian(&telemetry.desired)?;
        let cartesian_error = ArrowGeometry::pseudo_inverse(&jm)? * joint_error_m;
        let half = <T as Real>::from_f64(0.5);
        observe(&ArrowPeriod {
            k,
            desired: telemetry.desired,
            theta_x_rad: telemetry.theta_x_rad,
            joint_error_m,
            table_error_rad,
            cartesian_error,
            joint_error_consistent_m: jm * cartesian_error,
            theta_x_error_rad: half * (table_error_rad[0] - table_error_rad[1]),
            true_pose_error: io.pose() - telemetry.desired,
            outputs,
            saturated: telemetry.saturated,
        });
    }
    Ok(ArrowRunEnd {
        periods: k,
        mode: supervisor.mode(),
        last_outputs: outputs,
    })
}
