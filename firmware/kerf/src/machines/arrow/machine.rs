//! ARROW as a machine of the supervisor: jobs from G-code
//! ([`super::job`]), each period's reference from the constant-feed follower, the
//! regularized PID with computed feedforward ([`super::ArrowLaw`]), and the checks
//! that stop it.
//!
//! # Faults
//!
//! Every period, in every mode, a fault of the actuators' drive set
//! ([`ArrowInputs::drive_fault`]) is [`ArrowFault::Drive`], and the encoders are
//! checked: a reading that is not finite
//! is [`ArrowFault::NotFinite`]; one that moved farther in a period than the machine
//! can (an encoder that skipped or a cable that picked up a burst) is
//! [`ArrowFault::EncoderJump`]. While moving, a joint farther from its reference than
//! [`ArrowLimits::tracking_error_m`] (a collision, a drive that stopped) is
//! [`ArrowFault::TrackingError`], and a law or path that cannot produce a command is
//! [`ArrowFault::Law`] or [`ArrowFault::Path`]. The supervisor then writes zero force
//! and torque in the same period.
//!
//! # Calibration
//!
//! ARROW's scales are read as absolute positions here (A describes no homing),
//! so the calibration sweep is empty: `Calibrate` finishes at once and
//! `FinishCalibration(())` makes the machine ready.

use super::job::{split_pose, ArrowJob};
use super::{ArrowDesired, ArrowLaw, ArrowLoopState, ArrowPeriodError};
use crate::app::drive_set::DriveFault;
use crate::app::supervisor::NoSweep;
use crate::app::supervisor::{
    first_non_finite_index, FiniteOutputs, Machine, NonFiniteOutput, Step,
};
use crate::error::{coefficient, positive, ConfigError};
use crate::kinematics::arrow::{ActuatorVector, Pose};
use crate::scalar::Float;
use crate::trajectory::feed::FeedFollower;

/// One period's encoder readings.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowInputs<T> {
    /// Linear actuator positions q_1 … q_6, m.
    pub joints_m: ActuatorVector<T>,
    /// Turntable motor angles q_T1, q_T2, rad.
    pub table_rad: [T; 2],
    /// The actuators' drive set's fault, when it has one
    /// ([`crate::app::drive_set::DriveSet::feedback`]; `None` for drives not on a bus).
    pub drive_fault: Option<DriveFault>,
}

/// One period's commands.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowOutputs<T> {
    /// Linear actuator forces, N.
    pub forces_n: ActuatorVector<T>,
    /// Turntable motor torques, N·m.
    pub torques_n_m: [T; 2],
}

/// Why the machine stopped.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ArrowFault {
    /// An encoder reading is NaN or infinite.
    NotFinite,
    /// Encoder `i` (0–5 the actuators, 6–7 the table motors) moved more in one period
    /// than the machine can.
    EncoderJump(u8),
    /// Joint `i` (as above) is farther from its reference than the limit.
    TrackingError(u8),
    /// The law has no command (a desired pose without a model, a value not finite).
    Law(ArrowPeriodError),
    /// The path follower lost the spline.
    Path,
    /// An output was NaN or infinite: the actuator forces 0–5, the table torques 6–7.
    Output(NonFiniteOutput),
    /// The actuators' drives stopped ([`DriveFault`] says why, in words).
    Drive(DriveFault),
}

/// Why a job may not start.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ArrowJobRefusal {
    /// The job has no move (the empty job).
    Empty,
    /// It was planned for another control period.
    WrongPeriod,
    /// The machine is not at the job's start: joint `i` (as in [`ArrowFault`]) is
    /// farther from it than the start tolerance.
    NotAtStart(u8),
    /// No encoder reading yet.
    NoReading,
}

/// The checks' limits.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowLimits {
    /// Largest encoder change of an actuator in one period, m.
    pub encoder_jump_m: f64,
    /// Largest encoder change of a table motor in one period, rad.
    pub table_jump_rad: f64,
    /// Largest joint tracking error of an actuator while moving, m.
    pub tracking_error_m: f64,
    /// Largest tracking error of a table motor while moving, rad.
    pub table_tracking_rad: f64,
    /// How close to a job's start the joints must be for it to start, m.
    pub start_tolerance_m: f64,
    /// The same for the table motors, rad.
    pub start_tolerance_rad: f64,
}

impl ArrowLimits {
    /// ARROW at 5 kHz: a jump of 1 mm per period is 5 m/s, beyond what its linear
    /// motors reach; 0.05 rad per period is 250 rad/s at the table. A tracking error
    /// of 2 mm (0.05 rad) is some 300 times the published RMS (A table 3) and far above
    /// a start transient under A's gains. A job starts within 0.5 mm
    /// (0.01 rad) of its first point's joints on the model: at rest the joints keep
    /// the geometric error's inconsistency (A 3.2.1), which the regularized law
    /// leaves alone, 0.1–0.3 mm on an assembled machine.
    pub const ARROW: Self = Self {
        encoder_jump_m: 1e-3,
        table_jump_rad: 0.05,
        tracking_error_m: 2e-3,
        table_tracking_rad: 0.05,
        start_tolerance_m: 5e-4,
        start_tolerance_rad: 0.01,
    };
}

/// The limits in the machine's scalar.
#[derive(Copy, Clone, Debug, PartialEq)]
struct Limits<T> {
    jump: [T; 2],
    tracking: [T; 2],
    start: [T; 2],
}

/// What the machine reports each period.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowTelemetry<T> {
    /// Move of the job (0 when idle).
    pub move_index: u8,
    /// The desired plate pose (x, y, z, θz) and table angle θx.
    pub desired: Pose<T>,
    /// θx desired, rad.
    pub theta_x_rad: T,
    /// Joint tracking errors (reference − measured), m.
    pub joint_error_m: ActuatorVector<T>,
    /// Table tracking error of motor 1, rad.
    pub table_error_rad: T,
    /// The commands of the period.
    pub outputs: ArrowOutputs<T>,
    /// Whether a command was at its limit.
    pub saturated: bool,
}

/// The ARROW machine: the law, the checks, and the state of a running job of up to
/// `R` moves of `N` points.
#[derive(Clone, Debug)]
pub struct ArrowMachine<T: Float, const N: usize, const R: usize> {
    law: ArrowLaw<T>,
    limits: Limits<T>,
    period_s: f64,
    loop_state: ArrowLoopState<T>,
    follower: Option<FeedFollower<T>>,
    move_index: usize,
    last: Option<ArrowInputs<T>>,
    telemetry: ArrowTelemetry<T>,
}

impl<T: Float, const N: usize, const R: usize> ArrowMachine<T, N, R> {
    /// A machine running `law` at `period_s` under `limits`.
    ///
    /// Errors: a limit or the period not finite and positive.
    pub fn new(law: ArrowLaw<T>, period_s: f64, limits: &ArrowLimits) -> Result<Self, ConfigError> {
        positive("period_s", period_s)?;
        let t = |name, v| coefficient::<T>(name, positive(name, v)?);
        let limits = Limits {
            jump: [
                t("encoder_jump_m", limits.encoder_jump_m)?,
                t("table_jump_rad", limits.table_jump_rad)?,
            ],
            tracking: [
                t("tracking_error_m", limits.tracking_error_m)?,
                t("table_tracking_rad", limits.table_tracking_rad)?,
            ],
            start: [
                t("start_tolerance_m", limits.start_tolerance_m)?,
                t("start_tolerance_rad", limits.start_tolerance_rad)?,
            ],
        };
        let zero = ArrowOutputs {
            forces_n: ActuatorVector::zeros(),
            torques_n_m: [T::zero(); 2],
        };
        Ok(Self {
            law,
            limits,
            period_s,
            loop_state: ArrowLoopState::default(),
            follower: None,
            move_index: 0,
            last: None,
            telemetry: ArrowTelemetry {
                move_index: 0,
                desired: Pose::zeros(),
                theta_x_rad: T::zero(),
                joint_error_m: ActuatorVector::zeros(),
                table_error_rad: T::zero(),
                outputs: zero,
                saturated: false,
            },
        })
    }

    /// The law in use.
    pub fn law(&self) -> &ArrowLaw<T> {
        &self.law
    }

    /// The index of the first of the eight encoders (six actuators, two table motors)
    /// whose |value| exceeds its bound (`bounds[0]` for the actuators, `[1]` for the
    /// table).
    fn first_beyond(joints: &ActuatorVector<T>, table: &[T; 2], bounds: [T; 2]) -> Option<u8> {
        let [linear, angular] = bounds;
        let actuators = joints.iter().map(|v| (*v, linear));
        let motors = table.iter().map(|v| (*v, angular));
        actuators
            .chain(motors)
            .position(|(v, bound)| v.abs() > bound)
            .map(|i| i as u8)
    }

    /// One period along the running job: the follower's reference, the law, the
    /// tracking check. `Ok(None)` when the present move has ended.
    fn follow(
        &mut self,
        job: &ArrowJob<T, N, R>,
        inputs: &ArrowInputs<T>,
    ) -> Result<Option<ArrowOutputs<T>>, ArrowFault> {
        let (Some(follower), Some(m)) = (self.follower.as_mut(), job.moves().get(self.move_index))
        else {
            return Ok(None);
        };
        if follower.is_done() {
            return Ok(None);
        }
        let sample = follower.step(&m.spline).map_err(|_| ArrowFault::Path)?;
        let (pose, theta_x_rad) = split_pose(&sample.pose);
        let (rate, _) = split_pose(&sample.velocity);
        let (acceleration, theta_x_accel_rad_s2) = split_pose(&sample.acceleration);
        let desired = ArrowDesired {
            pose,
            rate,
            acceleration,
            theta_x_rad,
            theta_x_accel_rad_s2,
        };
        let command = self
            .law
            .period(
                &mut self.loop_state,
                &desired,
                &inputs.joints_m,
                inputs.table_rad,
            )
            .map_err(ArrowFault::Law)?;
        let joint_error_m = command.joints_ref_m - inputs.joints_m;
        let [t1, t2] = inputs.table_rad;
        let table_error = [theta_x_rad - t1, -theta_x_rad - t2];
        if let Some(i) = Self::first_beyond(&joint_error_m, &table_error, self.limits.tracking) {
            return Err(ArrowFault::TrackingError(i));
        }
        let outputs = ArrowOutputs {
            forces_n: command.forces_n,
            torques_n_m: command.torques_n_m,
        };
        self.telemetry = ArrowTelemetry {
            move_index: self.move_index.min(usize::from(u8::MAX)) as u8,
            desired: pose,
            theta_x_rad,
            joint_error_m,
            table_error_rad: table_error[0],
            outputs,
            saturated: command.saturated,
        };
        Ok(Some(outputs))
    }
}

impl<T: Float, const N: usize, const R: usize> Machine for ArrowMachine<T, N, R> {
    type Inputs = ArrowInputs<T>;
    type Outputs = ArrowOutputs<T>;
    type Job = ArrowJob<T, N, R>;
    type JobError = ArrowJobRefusal;
    type Coefficients = ArrowLaw<T>;
    type SweepSample = NoSweep;
    type Calibration = ();
    type Fault = ArrowFault;
    type Telemetry = ArrowTelemetry<T>;

    fn safe_outputs(&self) -> ArrowOutputs<T> {
        ArrowOutputs {
            forces_n: ActuatorVector::zeros(),
            torques_n_m: [T::zero(); 2],
        }
    }

    fn monitor(&mut self, inputs: &ArrowInputs<T>) -> Result<(), ArrowFault> {
        if let Some(f) = inputs.drive_fault {
            return Err(ArrowFault::Drive(f));
        }
        let finite = inputs
            .joints_m
            .iter()
            .chain(&inputs.table_rad)
            .all(|v| v.is_finite());
        if !finite {
            return Err(ArrowFault::NotFinite);
        }
        if let Some(last) = self.last {
            let dq = inputs.joints_m - last.joints_m;
            let [a, b] = inputs.table_rad;
            let [c, d] = last.table_rad;
            if let Some(i) = Self::first_beyond(&dq, &[a - c, b - d], self.limits.jump) {
                return Err(ArrowFault::EncoderJump(i));
            }
        }
        self.last = Some(*inputs);
        Ok(())
    }

    fn begin_calibration(&mut self) {}

    fn calibrate(
        &mut self,
        inputs: &ArrowInputs<T>,
        _record: &mut dyn FnMut(NoSweep),
    ) -> Result<Step<ArrowOutputs<T>>, ArrowFault> {
        self.monitor(inputs)?;
        Ok(Step::Done(self.safe_outputs()))
    }

    fn finish_calibration(&mut self, _calibration: &()) {}

    fn check_job(&self, job: &ArrowJob<T, N, R>) -> Result<(), ArrowJobRefusal> {
        if job.moves().is_empty() {
            return Err(ArrowJobRefusal::Empty);
        }
        // Planned in whole periods of this machine's period.
        if (job.period_s() - self.period_s).abs() > 1e-12 * self.period_s {
            return Err(ArrowJobRefusal::WrongPeriod);
        }
        Ok(())
    }

    fn begin_job(&mut self, job: &ArrowJob<T, N, R>) -> Result<(), ArrowJobRefusal> {
        self.check_job(job)?;
        let last = self.last.ok_or(ArrowJobRefusal::NoReading)?;
        let (_, theta_x) = job.start();
        let start_table = [theta_x, -theta_x];
        let dq = job.start_joints_m() - last.joints_m;
        let [a, b] = last.table_rad;
        let [c, d] = start_table;
        let off = [c - a, d - b];
        if let Some(i) = Self::first_beyond(&dq, &off, self.limits.start) {
            return Err(ArrowJobRefusal::NotAtStart(i));
        }
        let first = job.moves().first().ok_or(ArrowJobRefusal::Empty)?;
        self.follower = Some(FeedFollower::new(&first.plan).map_err(|_| ArrowJobRefusal::Empty)?);
        self.move_index = 0;
        // From rest at the start: the integrators start empty.
        self.loop_state = ArrowLoopState::default();
        Ok(())
    }

    fn run(
        &mut self,
        job: &ArrowJob<T, N, R>,
        inputs: &ArrowInputs<T>,
    ) -> Result<Step<ArrowOutputs<T>>, ArrowFault> {
        self.monitor(inputs)?;
        if let Some(outputs) = self.follow(job, inputs)? {
            return Ok(Step::Continue(outputs));
        }
        // The move has ended at rest on its last point: the next one starts there.
        self.move_index += 1;
        let Some(next) = job.moves().get(self.move_index) else {
            self.follower = None;
            return Ok(Step::Done(self.telemetry.outputs));
        };
        self.follower = FeedFollower::new(&next.plan).ok();
        match self.follow(job, inputs)? {
            Some(outputs) => Ok(Step::Continue(outputs)),
            None => Err(ArrowFault::Path),
        }
    }

    fn begin_stop(&mut self) {
        if let Some(follower) = self.follower.as_mut() {
            follower.stop();
        }
    }

    /// The stop ramp along the path (the S-curve mirrored, [`FeedFollower::stop`]),
    /// under the same law; done at rest.
    fn stop(
        &mut self,
        job: &ArrowJob<T, N, R>,
        inputs: &ArrowInputs<T>,
    ) -> Result<Step<ArrowOutputs<T>>, ArrowFault> {
        self.monitor(inputs)?;
        match self.follow(job, inputs)? {
            Some(outputs) => Ok(Step::Continue(outputs)),
            None => {
                self.follower = None;
                Ok(Step::Done(self.telemetry.outputs))
            }
        }
    }

    /// New gains and model; the integrators and the path continue (bumpless).
    fn set_coefficients(&mut self, law: &ArrowLaw<T>) {
        self.law = *law;
    }

    fn reset(&mut self) {
        self.follower = None;
        self.move_index = 0;
        self.loop_state = ArrowLoopState::default();
        self.last = None;
    }

    fn telemetry(&self) -> ArrowTelemetry<T> {
        self.telemetry
    }
}

/// The actuator forces 0–5, the table torques 6–7.
impl<T: Float> FiniteOutputs for ArrowOutputs<T> {
    fn first_not_finite(&self) -> Option<u8> {
        first_non_finite_index(self.forces_n.iter().chain(&self.torques_n_m).copied())
    }
}

impl From<NonFiniteOutput> for ArrowFault {
    fn from(output: NonFiniteOutput) -> Self {
        Self::Output(output)
    }
}
