//! ARROW in closed loop on the host: the simulated plant of `hal-mock` (with its
//! geometric error) under the PID with computed feedforward of A eq. 46, the
//! references and the feedforward computed from the controller's nominal model.

use hal_mock::arrow::{ArrowPlant, ArrowPlantConfig, ArrowReading};
use kerf::app::supervisor::Mode;
use kerf::control::redundant_pid::{regularization, RedundantPidConfig};
use kerf::kinematics::arrow::{ActuatorVector, ArrowError, ArrowGeometry, Pose};
use kerf::machines::arrow::job::ArrowJobError;
use kerf::machines::arrow::machine::{ArrowFault, ArrowOutputs};
use kerf::machines::arrow::product::load_job;
use kerf::machines::arrow::{ArrowDesired, ArrowLaw, ArrowLoopState, ArrowPeriodError};
use kerf_sim::arrow::{ArrowPeriod, ArrowScenario, TrackingRms, TrackingSums};
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

impl ArrowRunConfig {
    /// The published gains (A table 2) with or without the computed feedforward and the
    /// regularization, for `periods` periods, no wall.
    pub fn published(feedforward: bool, regularize: bool, periods: usize) -> Self {
        Self {
            parallel: RedundantPidConfig {
                regularize,
                ..RedundantPidConfig::ARROW_PARALLEL
            },
            turntable: RedundantPidConfig {
                regularize,
                ..RedundantPidConfig::ARROW_TURNTABLE
            },
            feedforward,
            periods,
            wall: None,
        }
    }
}

/// One period's record.
#[derive(Copy, Clone, Debug)]
pub struct ArrowSample {
    /// Time, s.
    pub t_s: f64,
    /// The plate's true pose minus the desired one.
    pub pose_error: Pose<f64>,
    /// Measured minus desired joints, m.
    pub joint_error_m: ActuatorVector<f64>,
    /// The commanded actuator forces, N.
    pub forces_n: ActuatorVector<f64>,
    /// Their part outside Jm's column space (what the actuators push against each
    /// other with), N: |(I − Rm) Γ|.
    pub internal_force_n: f64,
    /// The integral state Γ_I, N.
    pub integral_n: ActuatorVector<f64>,
    /// Whether a force was at its limit.
    pub saturated: bool,
    /// Table angle error, rad.
    pub theta_x_error_rad: f64,
}

/// The law of a run on the controller's nominal model.
pub fn law(config: &ArrowRunConfig) -> Result<ArrowLaw<f64>, ArrowError> {
    scenario(config).law()
}

/// Runs the plant from rest at the reference's start, with `kerf::machines::arrow`'s period.
pub fn run(config: &ArrowRunConfig, reference: &Reference) -> Result<Vec<ArrowSample>, ArrowError> {
    let plant_config =
        ArrowPlantConfig::with_geometric_error(kerf::machines::arrow::product::PERIOD_S);
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

/// A job on the host (the scenario's capacities).
pub type Job = kerf::machines::arrow::product::Job<f64>;

/// A checked job from G-code on the nominal model.
#[allow(clippy::result_large_err)]
pub fn job_from_gcode(text: &str) -> Result<Box<Job>, ArrowJobError> {
    let mut points = Box::new(heapless::Vec::new());
    let mut job = Box::<Job>::default();
    load_job(text.as_bytes(), &mut points, &mut job)?;
    Ok(job)
}

/// The scenario of a run configuration on the plant with its geometric error.
pub fn scenario(config: &ArrowRunConfig) -> ArrowScenario {
    ArrowScenario {
        parallel: config.parallel,
        turntable: config.turntable,
        feedforward: config.feedforward,
        ..ArrowScenario::published()
    }
}

/// How a job run ended, with every period.
#[derive(Clone, Debug)]
pub struct JobRun {
    /// Every period while the machine ran (not the one that faulted).
    pub samples: Vec<ArrowPeriod<f64>>,
    /// The supervisor's mode at the end.
    pub mode: Mode<ArrowFault>,
    /// The outputs written in the last period.
    pub last_outputs: ArrowOutputs<f64>,
}

/// Runs `job` through `kerf_sim::arrow::run_job` in f64 and keeps every period.
pub fn run_job(
    config: &ArrowRunConfig,
    job: &Job,
    max_periods: u64,
    disturb: &mut dyn FnMut(u64, &mut ArrowReading),
) -> Result<JobRun, ArrowError> {
    let mut samples = Vec::new();
    let end = kerf_sim::arrow::run_job(&scenario(config), job, max_periods, disturb, &mut |p| {
        samples.push(*p)
    })?;
    Ok(JobRun {
        samples,
        mode: end.mode,
        last_outputs: end.last_outputs,
    })
}

/// A eq. 55–58 over recorded periods.
pub fn rms(samples: &[ArrowPeriod<f64>]) -> TrackingRms {
    let mut sums = TrackingSums::default();
    samples.iter().for_each(|s| sums.push(s));
    sums.rms()
}
