//! The remote slave (T 5.3.2, eq. 93–96): the Keops delta executing, a fixed latency
//! behind the master, the task accelerations the master side computed for it.
//!
//! The master closes the tracking loop on its delay observer's estimate of this
//! machine (`control::delay_observer`) and sends the law's task acceleration ẍdes; the
//! slave's playout (`app::playout`) hands the command of each period to this machine,
//! which makes the slave the nominal plant the master's observer assumes, ẍs = ẍdes.
//! The per-carriage disturbance observers cancel what they can see (friction, load,
//! gravity); what they leave (friction's reversals, the drive's ripple, sensing) would
//! reach the master only through the round trip and its 5 Hz correction. So the slave
//! also integrates the commands itself, exactly as the master's observer does (the
//! same piecewise-constant commands in the same order, from the playout), and a local
//! PD (`model_following`, per task axis) holds it on that nominal trajectory:
//! ẍ = ẍdes + Kp(xmodel − x) + Kd(ẋmodel − ẋ), to the carriages as
//! q̈ = Jx⁻¹(ẍ − J̇x q̇) and through the observers. Nothing here needs the delay or
//! the master's position; the master still sees the slave's measured position (the
//! image reports it) and corrects for whatever the model misses (a lost frame).
//!
//! The link can fall silent. While commands keep coming (a command holds for the
//! periods between link samples, and a lost frame leaves the previous one holding)
//! the slave follows. Once no fresh command has played for `hold_after_s`, the laser
//! goes off and the carriages ramp to rest at the stop deceleration and hold there
//! under their position loops; commands that arrive again resume the following (the
//! master's observer takes up the difference). After `give_up_after_s` of silence the
//! machine faults with [`RemoteSlaveFault::LinkLost`]: the supervisor's safe outputs,
//! zero force and the laser off, until the operator resets it. A job starts with a
//! joint-space approach to its start (the master's start mapped into the slave's
//! workspace); there the slave holds, without a time limit, until the first command
//! (the master may not have started), and only from there does it report its position.
//!
//! As a product on the host link the slave plays a recorded master session
//! ([`session`], [`recording`]) through its own end of the link; [`link`] describes it
//! to the host, [`product`] holds what is flashed.

use super::{DeltaFault, DeltaSlave, DeltaSlaveConfig, DeltaTelemetry};
use crate::app::axis::{AxisConfig, AxisLaw, HallAxis};
use crate::app::calibrate::{
    fit_sensors, CalibrationFailure, CalibrationFit, HallMachine, HallSample,
};
use crate::app::joints::{JobError, JointJob, Segment};
use crate::app::remote_link::RemoteCommand;
use crate::app::supervisor::{Machine, NonFiniteOutput, Step};
use crate::control::laser::LaserMode;
use crate::control::pd::{Pd, PdConfig};
use crate::error::{positive, ConfigContext, ConfigError, ConfigErrorKind};
use crate::hal::ForceAndLaser;
use crate::kinematics::delta::KinematicsError;
use crate::scalar::{lit, Float};
use crate::sensing::hall::{HallConfig, SelfCalibration};
use crate::trajectory::Reference;
use nalgebra::Vector3;

pub mod link;
pub mod product;
pub mod recording;
pub mod session;

/// One period's inputs: the carriages' Hall counts and what the playout plays.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct RemoteSlaveInputs {
    /// Hall counts of each carriage.
    pub hall: [[u16; 3]; 3],
    /// The command playing this period (`None` before the first).
    pub command: Option<RemoteCommand>,
    /// The command started this period (it is not a held one).
    pub fresh: bool,
}

/// The slave and its link timeouts, in SI units.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct RemoteSlaveConfig {
    /// The delta slave: carriages, geometry, laser; its stop deceleration is the
    /// carriages' acceleration limit.
    pub slave: DeltaSlaveConfig,
    /// Silence (no fresh command) after which the slave stops following, s.
    pub hold_after_s: f64,
    /// Silence after which the slave faults, s (longer than `hold_after_s`).
    pub give_up_after_s: f64,
    /// Largest task acceleration a command may ask for, m/s²: each component is
    /// clamped to it (a sane master never asks for more).
    pub max_acceleration_m_s2: f64,
    /// The local loop that holds the slave on the nominal model the master's observer
    /// integrates (module docs), per task axis.
    pub model_following: PdConfig,
}

impl RemoteSlaveConfig {
    /// The Keops slave over a 1 kHz command stream in 16-sample blocks: it holds after
    /// 50 ms without a fresh command (three blocks lost in a row, or a delay 30 ms
    /// beyond the playout's margin) and gives up after 0.5 s; 20 m/s², the carriages'
    /// own limit; the model-following loop at the carriages' own 40 Hz.
    pub const KEOPS: Self = Self {
        slave: DeltaSlaveConfig::KEOPS,
        hold_after_s: 0.05,
        give_up_after_s: 0.5,
        max_acceleration_m_s2: 20.0,
        model_following: AxisConfig::LM1247_SLAVE.pd,
    };
}

/// A follow job: where the slave waits for the master, and what the beam does.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct FollowJob {
    /// The effector's position at which the slave waits for the first command (the
    /// master's start mapped into the slave's workspace), m.
    pub start_m: [f64; 3],
    /// The joint-space approach from where the carriages are to `start_m`, s.
    pub approach_s: f64,
    /// The beam's mode when the master asks for it: constant power (T's manual
    /// depth control: depth ∝ 1/speed) or constant energy per length (`None`: the
    /// empty default job, refused).
    pub laser: Option<LaserMode<f64>>,
}

/// Why the remote slave stopped.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RemoteSlaveFault {
    /// The delta slave's own fault (a carriage's sensor, a non-finite value).
    Slave(DeltaFault),
    /// No fresh command for `give_up_after_s`.
    LinkLost,
}

/// Why a follow job does not fit.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FollowJobError {
    /// No laser mode given.
    NoLaserMode,
    /// The laser mode does not suit the source.
    Laser(ConfigErrorKind),
    /// The start is out of reach, outside a carriage's travel or singular.
    Unreachable(KinematicsError),
    /// The approach: its time, or its speed from where the carriages are.
    Approach(JobError),
}

/// Where a follow job is.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FollowPhase {
    /// Moving to the job's start.
    Approach,
    /// Holding at the start, no command yet.
    Waiting,
    /// Executing the commands.
    Following,
    /// The link fell silent: ramping to rest, then holding.
    Holding,
}

/// One period's telemetry.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct RemoteSlaveTelemetry<T> {
    /// The delta slave's (carriages, laser).
    pub slave: DeltaTelemetry<T>,
    /// The effector, FK of the measured carriages, m (`None` if it failed).
    pub effector_m: Option<[T; 3]>,
    /// The follow job's phase (`None` outside a job).
    pub phase: Option<FollowPhase>,
    /// Periods since the last fresh command.
    pub silent_periods: u32,
    /// Commands refused as not finite so far.
    pub bad_commands: u32,
    /// While following: the nominal model the local loop holds the slave on (the
    /// commands integrated as the master's observer integrates them), m.
    pub model_m: Option<[T; 3]>,
}

/// The following's own law, validated: the local loop and the link's timeouts in
/// periods. What a configuration sets at [`RemoteSlave::new`] and a change of the
/// session's link settings replaces ([`session`]).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FollowLaw<T: Float> {
    model_following: Pd<T>,
    hold_periods: u32,
    give_up_periods: u32,
}

impl<T: Float> FollowLaw<T> {
    /// Validates the timeouts (finite, positive, whole periods below 2^32, the
    /// give-up more periods than the hold) and the local loop at `period_s`.
    pub fn new(
        hold_after_s: f64,
        give_up_after_s: f64,
        model_following: &PdConfig,
        period_s: f64,
    ) -> Result<Self, ConfigError> {
        let period = positive("period_s", period_s)?;
        let periods = |name, s: f64| -> Result<u32, ConfigError> {
            let n = libm::ceil(positive(name, s)? / period);
            if n >= f64::from(u32::MAX) {
                return Err(ConfigError::out_of_range(name));
            }
            Ok(n as u32)
        };
        let hold_periods = periods("hold_after_s", hold_after_s)?;
        let give_up_periods = periods("give_up_after_s", give_up_after_s)?;
        if give_up_periods <= hold_periods {
            return Err(ConfigError::out_of_range("give_up_after_s"));
        }
        Ok(Self {
            model_following: Pd::new(model_following).within("model_following")?,
            hold_periods,
            give_up_periods,
        })
    }
}

/// The remote slave as a [`Machine`].
#[derive(Clone, Debug)]
pub struct RemoteSlave<T: Float> {
    slave: DeltaSlave<T>,
    law: FollowLaw<T>,
    max_acceleration: T,
    /// The nominal model's position and velocity, m and m/s (`None` until following).
    model: Option<(Vector3<T>, Vector3<T>)>,
    ts: T,
    laser_mode: LaserMode<T>,
    approach: JointJob<3>,
    phase: Option<FollowPhase>,
    silent_periods: u32,
    bad_commands: u32,
    effector_m: Option<Vector3<T>>,
    laser_power_w: T,
}

impl<T: Float> RemoteSlave<T> {
    /// Validates `config` (the slave's fields named under `slave.`; the timeouts
    /// finite, positive, the hold shorter than the give-up).
    pub fn new(config: &RemoteSlaveConfig) -> Result<Self, ConfigError> {
        let slave = DeltaSlave::new(&config.slave).within("slave")?;
        let period = config.slave.joints.period_s;
        let law = FollowLaw::new(
            config.hold_after_s,
            config.give_up_after_s,
            &config.model_following,
            period,
        )?;
        let max = positive("max_acceleration_m_s2", config.max_acceleration_m_s2)?;
        Ok(Self {
            slave,
            law,
            max_acceleration: crate::error::representable("max_acceleration_m_s2", max)?,
            model: None,
            ts: crate::error::coefficient("period_s", period).within("slave.joints")?,
            laser_mode: LaserMode::Off,
            approach: JointJob::new(),
            phase: None,
            silent_periods: 0,
            bad_commands: 0,
            effector_m: None,
            laser_power_w: T::zero(),
        })
    }

    /// The delta slave inside.
    pub fn slave(&self) -> &DeltaSlave<T> {
        &self.slave
    }

    /// Replaces the following's law (the local loop, the timeouts), keeping every
    /// state: the silence counted so far is measured against the new timeouts.
    /// Private: only the session machine ([`session`]) retunes it, with its link
    /// settings (host test `remote_slave_link` shortens the timeouts mid-session and
    /// hears the link given up).
    fn set_follow_law(&mut self, law: &FollowLaw<T>) {
        self.law = *law;
    }

    /// The effector as last measured (FK of the carriages), m.
    pub fn effector_m(&self) -> Option<[T; 3]> {
        self.effector_m.map(|p| [p.x, p.y, p.z])
    }

    /// The follow job's phase (`None` outside a job).
    pub fn phase(&self) -> Option<FollowPhase> {
        self.phase
    }

    /// What the slave reports to the master: the effector, except while it
    /// approaches the job's start (the master's observer starts from a slave at rest
    /// there).
    pub fn report_position_m(&self) -> Option<[T; 3]> {
        match self.phase {
            Some(FollowPhase::Approach) => None,
            _ => self.effector_m(),
        }
    }

    /// The job's approach, built in `approach`: one joint-space segment to IK(start),
    /// checked against the carriages' travel.
    fn plan_approach(
        slave: &DeltaSlave<T>,
        job: &FollowJob,
        approach: &mut JointJob<3>,
    ) -> Result<(), FollowJobError> {
        let [x, y, z] = job.start_m.map(lit::<T>);
        let q = slave
            .geometry()
            .inverse(&Vector3::new(x, y, z))
            .map_err(FollowJobError::Unreachable)?;
        approach.clear();
        // Capacity MAX_SEGMENTS ≥ 1.
        let _ = approach.push(Segment {
            target_m: [q.x, q.y, q.z].map(|c| c.to_f64()),
            duration_s: job.approach_s,
        });
        slave
            .joints()
            .check_job(approach)
            .map_err(FollowJobError::Approach)
    }

    /// The command's acceleration in `T`, clamped; `None` if a component is not finite.
    fn acceleration(&self, command: &RemoteCommand) -> Option<Vector3<T>> {
        let [x, y, z] = command.acceleration_m_s2.map(|a| lit::<T>(f64::from(a)));
        let a = Vector3::new(x, y, z);
        // Each component (a sum would overflow on finite extremes, which clamp).
        if !a.iter().all(|c| c.is_finite()) {
            return None;
        }
        let max = self.max_acceleration;
        Some(a.map(|c| c.max(-max).min(max)))
    }

    /// One following period: measure, map the command to the carriages, actuate.
    /// Returns the forces and the measured task speed in the x–y plane.
    fn follow(
        &mut self,
        hall: &[[u16; 3]; 3],
        acceleration: &Vector3<T>,
    ) -> Result<([T; 3], T), DeltaFault> {
        let (geometry, joints) = self.slave.geometry_and_joints();
        let (q, q_dot) = joints.measure(hall).map_err(DeltaFault::Joint)?;
        let (q, q_dot) = (Vector3::from(q), Vector3::from(q_dot));
        let (p, v) = geometry
            .task_state(&q, &q_dot)
            .map_err(DeltaFault::Kinematics)?;
        // The nominal model executes the command as the master's does (semi-implicit
        // Euler, `control::delay_observer`); the local loop holds the slave on it. It
        // starts where the slave rests (waiting, or held after a silence) and at rest,
        // as the master's observer starts from the slave's report: a measured velocity
        // would lock its noise into the model as a drift only the round trip corrects.
        let (mut model_p, mut model_v) = self.model.unwrap_or((p, Vector3::zeros()));
        model_v += acceleration * self.ts;
        model_p += model_v * self.ts;
        self.model = Some((model_p, model_v));
        let pd = &self.law.model_following;
        let mut demand = Vector3::zeros();
        for (d, (((mp, mv), a), (pi, vi))) in demand.iter_mut().zip(
            model_p
                .iter()
                .zip(model_v.iter())
                .zip(acceleration.iter())
                .zip(p.iter().zip(v.iter())),
        ) {
            let reference = Reference {
                position: *mp,
                velocity: *mv,
                acceleration: *a,
            };
            *d = pd.acceleration(&reference, *pi, *vi);
        }
        let q_ddot = geometry
            .joint_acceleration(&q, &p, &q_dot, &demand)
            .map_err(DeltaFault::Kinematics)?;
        self.effector_m = Some(p);
        let reference = |k: usize| Reference {
            position: q.get(k).copied().unwrap_or(T::zero()),
            velocity: q_dot.get(k).copied().unwrap_or(T::zero()),
            acceleration: q_ddot.get(k).copied().unwrap_or(T::zero()),
        };
        let reference = [reference(0), reference(1), reference(2)];
        let (forces, _) = joints
            .actuate(
                reference,
                &[q_ddot.x, q_ddot.y, q_ddot.z],
                &[q_dot.x, q_dot.y, q_dot.z],
            )
            .map_err(DeltaFault::Joint)?;
        Ok((forces, (v.x * v.x + v.y * v.y).sqrt()))
    }

    /// One holding period: the carriages' stop ramp, then rest, under their PD.
    fn hold(&mut self, hall: &[[u16; 3]; 3]) -> Result<[T; 3], DeltaFault> {
        let forces = self
            .slave
            .joints_mut()
            .ramp_to_rest(hall)
            .map_err(DeltaFault::Joint)?;
        self.measure_effector();
        Ok(match forces {
            Step::Continue(f) | Step::Done(f) => f,
        })
    }

    fn measure_effector(&mut self) {
        let q = Vector3::from(self.slave.joints().axes().map(|a| a.position_m()));
        self.effector_m = self.slave.geometry().forward(&q).ok();
    }

    fn with_beam(&self, force_n: [T; 3]) -> ForceAndLaser<T, 3> {
        ForceAndLaser {
            force_n,
            laser_duty: self.slave.laser().duty(self.laser_power_w),
        }
    }
}

impl<T: Float> Machine for RemoteSlave<T> {
    type Inputs = RemoteSlaveInputs;
    type Outputs = ForceAndLaser<T, 3>;
    type Job = FollowJob;
    type JobError = FollowJobError;
    type Coefficients = AxisLaw<T>;
    type SweepSample = HallSample;
    type Calibration = [HallAxis<T>; 3];
    type Fault = RemoteSlaveFault;
    type Telemetry = RemoteSlaveTelemetry<T>;

    fn safe_outputs(&self) -> ForceAndLaser<T, 3> {
        self.slave.safe_outputs()
    }

    fn monitor(&mut self, inputs: &RemoteSlaveInputs) -> Result<(), RemoteSlaveFault> {
        self.laser_power_w = T::zero();
        self.slave
            .monitor(&inputs.hall)
            .map_err(RemoteSlaveFault::Slave)?;
        self.measure_effector();
        Ok(())
    }

    fn begin_calibration(&mut self) {
        self.slave.begin_calibration();
    }

    fn calibrate(
        &mut self,
        inputs: &RemoteSlaveInputs,
        record: &mut dyn FnMut(HallSample),
    ) -> Result<Step<ForceAndLaser<T, 3>>, RemoteSlaveFault> {
        self.laser_power_w = T::zero();
        self.slave
            .calibrate(&inputs.hall, record)
            .map_err(RemoteSlaveFault::Slave)
    }

    fn finish_calibration(&mut self, sensors: &[HallAxis<T>; 3]) {
        self.slave.finish_calibration(sensors);
    }

    fn check_job(&self, job: &FollowJob) -> Result<(), FollowJobError> {
        let mode = job.laser.ok_or(FollowJobError::NoLaserMode)?;
        self.slave
            .laser()
            .mode(&mode)
            .map_err(|e| FollowJobError::Laser(e.kind))?;
        // The slower context's check: a temporary job is fine there.
        Self::plan_approach(&self.slave, job, &mut JointJob::new())
    }

    fn begin_job(&mut self, job: &FollowJob) -> Result<(), FollowJobError> {
        let mode = job.laser.ok_or(FollowJobError::NoLaserMode)?;
        self.laser_mode = self
            .slave
            .laser()
            .mode(&mode)
            .map_err(|e| FollowJobError::Laser(e.kind))?;
        // Built in place: begin_job runs in the control period.
        Self::plan_approach(&self.slave, job, &mut self.approach)?;
        let approach = &self.approach;
        self.slave
            .joints_mut()
            .begin_job(approach)
            .map_err(FollowJobError::Approach)?;
        self.phase = Some(FollowPhase::Approach);
        self.silent_periods = 0;
        Ok(())
    }

    fn run(
        &mut self,
        _: &FollowJob,
        inputs: &RemoteSlaveInputs,
    ) -> Result<Step<ForceAndLaser<T, 3>>, RemoteSlaveFault> {
        self.laser_power_w = T::zero();
        self.silent_periods = if inputs.fresh {
            0
        } else {
            self.silent_periods.saturating_add(1)
        };
        let command = match inputs.command.map(|c| (self.acceleration(&c), c.laser_on)) {
            Some((None, _)) => {
                self.bad_commands = self.bad_commands.saturating_add(1);
                None
            }
            Some((Some(a), laser_on)) => Some((a, laser_on)),
            None => None,
        };
        let phase = self.phase.unwrap_or(FollowPhase::Waiting);
        if phase == FollowPhase::Approach {
            // Commands that arrive meanwhile are not followed: the master starts from
            // the slave's first report, sent once it rests at the start.
            let approach = &self.approach;
            let step = self
                .slave
                .joints_mut()
                .run(approach, &inputs.hall)
                .map_err(|f| RemoteSlaveFault::Slave(DeltaFault::Joint(f)))?;
            self.measure_effector();
            let forces = match step {
                Step::Continue(f) => f,
                Step::Done(f) => {
                    // Hold at the start (its rest reference) until the first command.
                    self.slave.joints_mut().begin_stop();
                    self.phase = Some(FollowPhase::Waiting);
                    f
                }
            };
            return Ok(Step::Continue(self.with_beam(forces)));
        }
        let silent = self.silent_periods > self.law.hold_periods;
        let forces = match (command, silent) {
            (Some((acceleration, laser_on)), false) => {
                if phase != FollowPhase::Following {
                    self.slave.joints_mut().cancel_stop();
                    // The model starts from the slave as it is.
                    self.model = None;
                }
                self.phase = Some(FollowPhase::Following);
                let (forces, speed) = self
                    .follow(&inputs.hall, &acceleration)
                    .map_err(RemoteSlaveFault::Slave)?;
                if laser_on {
                    self.laser_power_w = self.slave.laser().power_w(&self.laser_mode, speed);
                }
                forces
            }
            _ => {
                if phase == FollowPhase::Following {
                    self.slave.joints_mut().begin_stop();
                    self.phase = Some(FollowPhase::Holding);
                }
                if phase != FollowPhase::Waiting && self.silent_periods > self.law.give_up_periods {
                    return Err(RemoteSlaveFault::LinkLost);
                }
                self.hold(&inputs.hall).map_err(RemoteSlaveFault::Slave)?
            }
        };
        Ok(Step::Continue(self.with_beam(forces)))
    }

    fn begin_stop(&mut self) {
        self.phase = None;
        self.slave.begin_stop();
    }

    fn stop(
        &mut self,
        _job: &Self::Job,
        inputs: &RemoteSlaveInputs,
    ) -> Result<Step<ForceAndLaser<T, 3>>, RemoteSlaveFault> {
        self.laser_power_w = T::zero();
        let step = self
            .slave
            .ramp_to_rest(&inputs.hall)
            .map_err(RemoteSlaveFault::Slave)?;
        self.measure_effector();
        Ok(step)
    }

    fn set_coefficients(&mut self, law: &AxisLaw<T>) {
        self.slave.set_coefficients(law);
    }

    fn reset(&mut self) {
        self.slave.reset();
        self.phase = None;
        self.silent_periods = 0;
        self.laser_power_w = T::zero();
    }

    fn telemetry(&self) -> RemoteSlaveTelemetry<T> {
        let mut slave = self.slave.telemetry();
        slave.laser_power_w = self.laser_power_w;
        RemoteSlaveTelemetry {
            slave,
            effector_m: self.effector_m(),
            phase: self.phase,
            silent_periods: self.silent_periods,
            bad_commands: self.bad_commands,
            model_m: match self.phase {
                Some(FollowPhase::Following) => self.model.map(|(p, _)| [p.x, p.y, p.z]),
                _ => None,
            },
        }
    }
}

impl<T: Float> HallMachine<3> for RemoteSlave<T> {
    fn fit(
        hall: &[HallConfig; 3],
        samples: &CalibrationFit<3>,
    ) -> Result<([HallAxis<T>; 3], [SelfCalibration; 3]), CalibrationFailure> {
        fit_sensors(hall, samples)
    }
}

/// The remote slave's outputs are its delta slave's.
impl From<NonFiniteOutput> for RemoteSlaveFault {
    fn from(output: NonFiniteOutput) -> Self {
        Self::Slave(DeltaFault::Output(output))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::string::ToString;

    fn rejected(config: &RemoteSlaveConfig) -> std::string::String {
        match RemoteSlave::<f32>::new(config) {
            Err(e) => e.to_string(),
            Ok(_) => std::panic!("accepted {config:?}"),
        }
    }

    #[test]
    fn bad_timeouts_and_limits_are_named() {
        let keops = RemoteSlaveConfig::KEOPS;
        assert!(RemoteSlave::<f32>::new(&keops).is_ok());
        for (config, field) in [
            (
                RemoteSlaveConfig {
                    hold_after_s: f64::NAN,
                    ..keops
                },
                "hold_after_s",
            ),
            (
                RemoteSlaveConfig {
                    hold_after_s: 0.0,
                    ..keops
                },
                "hold_after_s",
            ),
            (
                RemoteSlaveConfig {
                    give_up_after_s: f64::INFINITY,
                    ..keops
                },
                "give_up_after_s",
            ),
            // Giving up before holding would skip the safe stop.
            (
                RemoteSlaveConfig {
                    give_up_after_s: keops.hold_after_s,
                    ..keops
                },
                "give_up_after_s",
            ),
            (
                RemoteSlaveConfig {
                    max_acceleration_m_s2: -1.0,
                    ..keops
                },
                "max_acceleration_m_s2",
            ),
            (
                RemoteSlaveConfig {
                    max_acceleration_m_s2: 1e39,
                    ..keops
                },
                "max_acceleration_m_s2",
            ),
        ] {
            let message = rejected(&config);
            assert!(message.starts_with(field), "{message}");
        }
        let mut bad_slave = keops;
        bad_slave.slave.joints.period_s = 0.0;
        assert!(
            rejected(&bad_slave).starts_with("slave."),
            "{}",
            rejected(&bad_slave)
        );
    }

    #[test]
    fn commands_are_clamped_and_non_finite_ones_refused() {
        let slave = RemoteSlave::<f32>::new(&RemoteSlaveConfig::KEOPS).unwrap();
        let max = RemoteSlaveConfig::KEOPS.max_acceleration_m_s2 as f32;
        let command = |a: [f32; 3]| RemoteCommand {
            acceleration_m_s2: a,
            laser_on: true,
        };
        let a = slave.acceleration(&command([0.5, -3.0, 1e-6])).unwrap();
        assert_eq!([a.x, a.y, a.z], [0.5, -3.0, 1e-6]);
        let a = slave.acceleration(&command([1e30, -1e30, max])).unwrap();
        assert_eq!([a.x, a.y, a.z], [max, -max, max]);
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            for k in 0..3 {
                let mut a = [0.1; 3];
                a[k] = bad;
                assert_eq!(slave.acceleration(&command(a)), None, "{a:?}");
            }
        }
        // Finite components whose sum overflows f32 are still finite commands.
        let a = slave
            .acceleration(&command([f32::MAX, f32::MAX, 0.0]))
            .unwrap();
        assert_eq!([a.x, a.y], [max, max]);
    }
}
