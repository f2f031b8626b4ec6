//! ARROW in closed loop on the host: the simulated plant of `hal-mock` (with its
//! geometric error) under the PID with computed feedforward of A eq. 46, the
//! references and the feedforward computed from the controller's nominal model.

use hal_mock::arrow::{ArrowPlant, ArrowPlantConfig, ArrowReading};
use heapless::spsc::Queue;
use kerf::app::arrow::job::{ArrowJob, ArrowJobConfig, ArrowJobError, ArrowJobErrorKind};
use kerf::app::arrow::machine::{ArrowFault, ArrowInputs, ArrowLimits, ArrowMachine, ArrowOutputs};
use kerf::app::arrow::{ArrowDesired, ArrowLaw, ArrowLoopState, ArrowPeriodError};
use kerf::app::supervisor::{Command, Machine as _, Mode, Report, Supervisor};
use kerf::control::redundant_pid::{regularization, RedundantPid, RedundantPidConfig};
use kerf::kinematics::arrow::{
    ArrowConfig, ArrowDynamics, ArrowError, ArrowGeometry, ArrowMasses, ForwardConfig, Joints, Pose,
};
use kerf::trajectory::gcode::GcodePoint;
use nalgebra::SMatrix;

/// The desired motion at time t: pose, rate, acceleration, and θx with its
/// acceleration.
pub type Reference = dyn Fn(f64) -> (Pose<f64>, Pose<f64>, Pose<f64>, f64, f64);

/// How a run is set up.
#[derive(Copy, Clone, Debug)]
pub struct ArrowRunConfig {
    /// Parallel module gains (regularization and anti-windup in it).
    pub parallel: RedundantPidConfig,
    /// Turntable gains.
    pub turntable: RedundantPidConfig,
    /// Add the inverse dynamic model's forces (eq. 46's Γ_ff).
    pub feedforward: bool,
    /// Control periods.
    pub periods: usize,
    /// A stiff wall the plate meets while it moves along +x: its position and when
    /// it goes (m, s), as a tool stalled in hard material and then free.
    pub wall: Option<(f64, f64)>,
}

/// One period's record.
#[derive(Copy, Clone, Debug)]
pub struct ArrowSample {
    /// Time, s.
    pub t_s: f64,
    /// The plate's true pose minus the desired one.
    pub pose_error: Pose<f64>,
    /// Measured minus desired joints, m.
    pub joint_error_m: Joints<f64>,
    /// The commanded actuator forces, N.
    pub forces_n: Joints<f64>,
    /// Their part outside Jm's column space (what the actuators push against each
    /// other with), N: |(I − Rm) Γ|.
    pub internal_force_n: f64,
    /// The integral state Γ_I, N.
    pub integral_n: Joints<f64>,
    /// Whether a force was at its limit.
    pub saturated: bool,
    /// Table angle error, rad.
    pub theta_x_error_rad: f64,
}

/// The law of a run on the controller's nominal model.
pub fn law(config: &ArrowRunConfig) -> Result<ArrowLaw<f64>, ArrowError> {
    let model = ArrowConfig::ARROW;
    let bad = |_| ArrowError::NotFinite;
    let ts = ArrowPlantConfig::with_geometric_error().period_s;
    Ok(ArrowLaw {
        geometry: ArrowGeometry::<f64>::new(&model).map_err(bad)?,
        dynamics: ArrowDynamics::<f64>::new(
            &ArrowMasses::ARROW,
            model.arms[0].length_m,
            model.arms[2].length_m,
        )
        .map_err(bad)?,
        parallel: RedundantPid::<f64>::new(&config.parallel, ts).map_err(bad)?,
        turntable: RedundantPid::<f64>::new(&config.turntable, ts).map_err(bad)?,
        feedforward: config.feedforward,
    })
}

/// Runs the plant from rest at the reference's start, with `kerf::app::arrow`'s period.
pub fn run(config: &ArrowRunConfig, reference: &Reference) -> Result<Vec<ArrowSample>, ArrowError> {
    let plant_config = ArrowPlantConfig::with_geometric_error();
    let ts = plant_config.period_s;
    let law = law(config)?;
    let (x0, _, _, tx0, _) = reference(0.0);
    let mut plant = ArrowPlant::new(&plant_config, x0, tx0)?;
    let mut state = ArrowLoopState::<f64>::default();
    let mut reading = plant.read()?;
    let mut samples = Vec::with_capacity(config.periods);
    for k in 0..config.periods {
        let t = k as f64 * ts;
        let (pose, rate, acceleration, theta_x_rad, theta_x_accel_rad_s2) = reference(t);
        let desired = ArrowDesired {
            pose,
            rate,
            acceleration,
            theta_x_rad,
            theta_x_accel_rad_s2,
        };
        let command = law
            .period(
                &mut state,
                &desired,
                &reading.joints_m,
                reading.turntable_rad,
            )
            .map_err(|e| match e {
                ArrowPeriodError::Model(e) => e,
                ArrowPeriodError::Law(_) => ArrowError::NotFinite,
            })?;
        let load = match config.wall {
            Some((x_wall, until_s)) if t < until_s => {
                let (x, v) = plant.state();
                let depth = x.x - x_wall;
                // 1e8 N/m with damping that stops the plate within a few periods.
                let push = if depth > 0.0 {
                    -(1e8 * depth + 2e5 * v.x.max(0.0))
                } else {
                    0.0
                };
                Pose::new(push, 0.0, 0.0, 0.0)
            }
            _ => Pose::zeros(),
        };
        reading = plant.step_loaded(&command.forces_n, command.torques_n_m, &load)?;
        let (x, _) = plant.state();
        let (_, jm) = law.geometry.jacobian(&pose)?;
        let rm: SMatrix<f64, 6, 6> = regularization(&jm, &ArrowGeometry::pseudo_inverse(&jm)?);
        let next = reference(t + ts);
        samples.push(ArrowSample {
            t_s: t + ts,
            pose_error: x - next.0,
            joint_error_m: reading.joints_m - law.geometry.inverse(&next.0)?,
            forces_n: command.forces_n,
            internal_force_n: (command.forces_n - rm * command.forces_n).amax(),
            integral_n: state.parallel.integral,
            saturated: command.saturated,
            theta_x_error_rad: plant.theta_x_rad() - next.3,
        });
    }
    Ok(samples)
}

/// A hold at `pose` (the table at 0).
pub fn hold(pose: Pose<f64>) -> impl Fn(f64) -> (Pose<f64>, Pose<f64>, Pose<f64>, f64, f64) {
    move |_| (pose, Pose::zeros(), Pose::zeros(), 0.0, 0.0)
}

/// A rest-to-rest move of `step` from `pose` between `start_s` and `start_s +
/// duration_s` along a quintic (zero velocity and acceleration at both ends), with
/// its rate and acceleration.
pub fn quintic_move(
    pose: Pose<f64>,
    step: Pose<f64>,
    start_s: f64,
    duration_s: f64,
) -> impl Fn(f64) -> (Pose<f64>, Pose<f64>, Pose<f64>, f64, f64) {
    move |t| {
        let u = ((t - start_s) / duration_s).clamp(0.0, 1.0);
        let inside = t > start_s && t < start_s + duration_s;
        let s = u * u * u * (10.0 - 15.0 * u + 6.0 * u * u);
        let ds = if inside {
            30.0 * u * u * (1.0 - u) * (1.0 - u) / duration_s
        } else {
            0.0
        };
        let dds = if inside {
            60.0 * u * (1.0 - u) * (1.0 - 2.0 * u) / (duration_s * duration_s)
        } else {
            0.0
        };
        (pose + step * s, step * ds, step * dds, 0.0, 0.0)
    }
}

/// Points a move of a host job holds (the pyramid's contour has 166).
pub const JOB_POINTS: usize = 192;
/// Moves a host job holds.
pub const JOB_MOVES: usize = 4;
/// A job on the host.
pub type Job = ArrowJob<f64, JOB_POINTS, JOB_MOVES>;
/// The machine on the host.
pub type Machine = ArrowMachine<f64, JOB_POINTS, JOB_MOVES>;

/// The pyramid of A §5 as the G-code file the firmware image carries.
pub const PYRAMID_GCODE: &str = include_str!("../../firmware/app/data/pyramid.gcode");

/// A checked job from G-code on the nominal model.
#[allow(clippy::result_large_err)]
pub fn job_from_gcode(text: &str) -> Result<Job, ArrowJobError> {
    let geometry = ArrowGeometry::<f64>::new(&ArrowConfig::ARROW).map_err(|e| ArrowJobError {
        line: 0,
        kind: ArrowJobErrorKind::Config(e),
    })?;
    let mut points: heapless::Vec<GcodePoint, 1024> = heapless::Vec::new();
    Job::from_gcode(
        text.as_bytes(),
        &mut points,
        &geometry,
        &ArrowJobConfig::ARROW,
    )
}

/// One period of a job run, errors measured at the end of the period against the
/// period's reference (the follower's pose for that instant).
#[derive(Copy, Clone, Debug)]
pub struct JobSample {
    /// Time, s.
    pub t_s: f64,
    /// Desired plate pose and table angle.
    pub desired: Pose<f64>,
    /// θx desired, rad.
    pub theta_x_rad: f64,
    /// Encoders minus the joint references (eq. 57's q̃), m.
    pub joint_error_m: Joints<f64>,
    /// Table motors minus their references (eq. 58's q̃), rad.
    pub table_error_rad: [f64; 2],
    /// The Cartesian error the encoders show through the model, X̃ = Jm⁺ q̃ (eq. 13),
    /// as the seed monitors it (A §5).
    pub cartesian_error: Pose<f64>,
    /// The part of q̃ that moves the plate, Rm q̃ = Jm X̃ (eq. 38): what is left is
    /// the geometric error's inconsistency, which the regularized law leaves alone.
    pub joint_error_consistent_m: Joints<f64>,
    /// θx error from the table motors, (q̃T1 − q̃T2)/2, rad.
    pub theta_x_error_rad: f64,
    /// The plate's true pose minus the desired one (includes the geometric error the
    /// encoders cannot see).
    pub true_pose_error: Pose<f64>,
    /// Commanded actuator forces, N.
    pub forces_n: Joints<f64>,
    /// Whether a command was at its limit.
    pub saturated: bool,
}

/// How a job run ended.
#[derive(Clone, Debug)]
pub struct JobRun {
    /// Every period while the machine ran.
    pub samples: Vec<JobSample>,
    /// The supervisor's mode at the end.
    pub mode: Mode<ArrowFault>,
    /// The outputs written in the last period.
    pub last_outputs: ArrowOutputs<f64>,
}

/// Runs `job` on the simulated ARROW through the supervisor: calibrate, load, start,
/// then one period at a time until the machine leaves `Running` (done or faulted) or
/// `max_periods` pass. `disturb(k, reading)` may corrupt the encoders before the
/// machine reads them in period k. The plant starts at rest where its joints are the
/// job's start joints on the model (its least-squares pose for them: the geometric
/// error leaves a joint inconsistency the regularized law does not fight).
pub fn run_job(
    config: &ArrowRunConfig,
    job: &Job,
    max_periods: usize,
    disturb: &mut dyn FnMut(usize, &mut ArrowReading),
) -> Result<JobRun, ArrowError> {
    let plant_config = ArrowPlantConfig::with_geometric_error();
    let law = law(config)?;
    let machine = Machine::new(law, plant_config.period_s, &ArrowLimits::ARROW)
        .map_err(|_| ArrowError::NotFinite)?;
    let (start, theta_x0) = job.start();
    let plant_geometry =
        ArrowGeometry::<f64>::new(&plant_config.geometry).map_err(|_| ArrowError::NotFinite)?;
    let loose = ForwardConfig {
        residual_tolerance_m: 1e-3,
        ..ForwardConfig::MONITOR
    };
    let start_true = plant_geometry.forward(job.start_joints_m(), &start, &loose)?;
    let mut plant = ArrowPlant::new(&plant_config, start_true, theta_x0)?;
    let mut commands: Box<Queue<Command<Machine>, 2>> = Box::new(Queue::new());
    let mut reports: Box<Queue<Report<Machine>, 64>> = Box::new(Queue::new());
    let (mut to_machine, from_sender) = commands.split();
    let (to_sender, mut from_machine) = reports.split();
    let mut supervisor = Supervisor::new(machine, from_sender, to_sender);
    supervisor.set_telemetry_decimation(u32::MAX);
    let read = |plant: &ArrowPlant| {
        plant.read().map(|r| ArrowInputs {
            joints_m: r.joints_m,
            table_rad: r.turntable_rad,
        })
    };
    let mut inputs = read(&plant)?;
    let mut setup = [
        Command::Calibrate,
        Command::FinishCalibration(()),
        Command::LoadJob(job.clone()),
        Command::Start,
    ]
    .into_iter();
    let mut outputs = supervisor.step(&inputs);
    while supervisor.mode() != Mode::Running {
        let Some(command) = setup.next() else {
            break;
        };
        to_machine.enqueue(command).ok();
        outputs = supervisor.step(&inputs);
        while from_machine.dequeue().is_some() {}
    }
    let ts = plant_config.period_s;
    let mut samples = Vec::new();
    for k in 0..max_periods {
        if supervisor.mode() != Mode::Running {
            break;
        }
        let mut reading = plant.read()?;
        disturb(k, &mut reading);
        inputs = ArrowInputs {
            joints_m: reading.joints_m,
            table_rad: reading.turntable_rad,
        };
        outputs = supervisor.step(&inputs);
        while from_machine.dequeue().is_some() {}
        let telemetry = supervisor.machine().telemetry();
        let after = plant.step(&outputs.forces_n, outputs.torques_n_m)?;
        if supervisor.mode() != Mode::Running && !matches!(supervisor.mode(), Mode::Ready) {
            break;
        }
        // The period's references, recovered from the telemetry's errors against
        // the inputs it saw.
        let q_ref = telemetry.joint_error_m + inputs.joints_m;
        let table_ref = [telemetry.theta_x_rad, -telemetry.theta_x_rad];
        let joint_error_m = after.joints_m - q_ref;
        let table_error_rad = [
            after.turntable_rad[0] - table_ref[0],
            after.turntable_rad[1] - table_ref[1],
        ];
        let (_, jm) = law.geometry.jacobian(&telemetry.desired)?;
        let cartesian_error = ArrowGeometry::pseudo_inverse(&jm)? * joint_error_m;
        let (true_pose, _) = plant.state();
        samples.push(JobSample {
            t_s: (k + 1) as f64 * ts,
            desired: telemetry.desired,
            theta_x_rad: telemetry.theta_x_rad,
            joint_error_m,
            table_error_rad,
            cartesian_error,
            joint_error_consistent_m: jm * cartesian_error,
            theta_x_error_rad: 0.5 * (table_error_rad[0] - table_error_rad[1]),
            true_pose_error: true_pose - telemetry.desired,
            forces_n: outputs.forces_n,
            saturated: telemetry.saturated,
        });
    }
    Ok(JobRun {
        samples,
        mode: supervisor.mode(),
        last_outputs: outputs,
    })
}

/// RMS tracking errors of A eq. 55–58.
#[derive(Copy, Clone, Debug, Default)]
pub struct TrackingRms {
    /// Eq. 55, Cartesian translation, m.
    pub cartesian_m: f64,
    /// Eq. 56, Cartesian rotation (θz and θx), deg.
    pub cartesian_deg: f64,
    /// Eq. 57, the six actuators, m.
    pub joint_m: f64,
    /// Eq. 58, the two table motors, deg.
    pub joint_deg: f64,
    /// Eq. 57 on Rm q̃ (the joints' error that moves the plate), m.
    pub joint_consistent_m: f64,
    /// Eq. 55 on the true pose (geometric error included), m.
    pub true_cartesian_m: f64,
}

impl TrackingRms {
    /// Over `samples`.
    pub fn of(samples: &[JobSample]) -> Self {
        let n = samples.len().max(1) as f64;
        let mean = |f: &dyn Fn(&JobSample) -> f64| (samples.iter().map(f).sum::<f64>() / n).sqrt();
        Self {
            cartesian_m: mean(&|s| s.cartesian_error.fixed_rows::<3>(0).norm_squared()),
            cartesian_deg: mean(&|s| s.cartesian_error.w.powi(2) + s.theta_x_error_rad.powi(2))
                .to_degrees(),
            joint_m: mean(&|s| s.joint_error_m.norm_squared()),
            joint_consistent_m: mean(&|s| s.joint_error_consistent_m.norm_squared()),
            joint_deg: mean(&|s| s.table_error_rad[0].powi(2) + s.table_error_rad[1].powi(2))
                .to_degrees(),
            true_cartesian_m: mean(&|s| s.true_pose_error.fixed_rows::<3>(0).norm_squared()),
        }
    }
}
