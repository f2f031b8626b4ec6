//! The Keops delta slave as a machine: three Hall-sensed carriages ([`Joints<T, 3>`])
//! under the delta kinematics, following straight effector moves.
//!
//! A job ([`DeltaJob`]) is planned in the slower context, where there is time to
//! check it: every move is sampled in time and each sample's joint position, speed
//! and acceleration must be reachable and inside the carriages' limits. The control
//! period then only checks that the job was planned for this machine (geometry,
//! travel, limits and period compared: a few dozen comparisons), and evaluates one
//! inverse kinematics, Jx⁻¹ and J̇x per period.
//!
//! Running a job: a joint-space approach move from wherever the carriages are to the
//! job's start (checked against the speed and acceleration limits at `Start`), then the
//! straight moves, each a rest-to-rest minimum-jerk profile along the line. The joint
//! references come from the effector's (docs/equations.md §6, velocity; T eq. 146):
//! q = IK(p), q̇ = Jx⁻¹ ṗ, q̈ = Jx⁻¹ (p̈ − J̇x q̇).
//!
//! Calibration sweeps the three carriages together, by the same displacement. From a
//! pose on the axis of symmetry (the preset homes there), equal displacements keep
//! the effector on that axis: it moves straight up and back, the arms share the load
//! evenly, and one sweep calibrates all three sensor sets in the time of one. One
//! carriage at a time would take three times as long and tilt the arms of the two
//! holding carriages towards the moving one. A stop ramps the joint references to rest
//! ([`Joints`]'s synchronized ramp): over the ≤ 25 ms of a stop at the preset's limits
//! the effector leaves the line by well under a micrometre.

use crate::app::axis::{AxisConfig, AxisLaw, HallAxis};
use crate::app::calibrate::{
    fit_sensors, CalibrationFailure, CalibrationFit, HallMachine, HallSample,
};
use crate::app::joints::{JointFault, JointJob, JointTelemetry, Joints, JointsConfig, Segment};
use crate::app::supervisor::{Machine, NonFiniteOutput, Step};
use crate::control::contouring::Contouring;
use crate::control::laser::{Laser, LaserConfig};
use crate::control::preview::Preview;
use crate::error::{positive, ConfigContext, ConfigError};
use crate::hal::ForceAndLaser;
use crate::kinematics::delta::{DeltaConfig, DeltaGeometry, KinematicsError};
use crate::scalar::{Float, Real};
use crate::sensing::hall::{HallConfig, SelfCalibration};
use crate::trajectory::planner::Continuation;
use crate::trajectory::ContourError;
pub use contour::{
    ContourConfig, ContourCurve, ContourLaw, ContourPlan, CONTOUR_HARMONICS, OPEN_PATH_POINTS,
    PLAN_SAMPLES_PER_LAP,
};
use contour::{ContourJob, ContourRun};
pub use job_error::DeltaJobError;
use line::{joint_references, Line};
pub use moves::{MovePoint, MOVE_POINTS, MOVE_SAMPLES};
use nalgebra::Vector3;

mod contour;
mod job_error;
mod line;
pub mod link;
mod moves;
pub mod product;
pub mod remote;

/// Instants per move at which a plan checks the joint limits (plus the end). A
/// minimum-jerk move's joint speed and acceleration are smooth in time; between
/// samples 1/64 of the move apart they exceed the sampled peak by well under 1 %.
pub const PLAN_SAMPLES: usize = 64;

/// Everything the delta slave needs, in SI units.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DeltaSlaveConfig {
    /// The three carriages: period, control law, Hall decoders, homes and the joint
    /// speed and acceleration limits. Its `travel_m` is not used: the carriages' travel
    /// is the delta actuators' (stated once, in `delta`).
    pub joints: JointsConfig<3>,
    /// The delta's geometry, with each actuator's travel.
    pub delta: DeltaConfig,
    /// The contour laws and the limits that supervise a contour.
    pub contour: ContourConfig,
    /// The laser source; a contour job says what the beam does
    /// ([`ContourPlan::laser`]), every other phase keeps it off.
    pub laser: LaserConfig,
}

impl DeltaSlaveConfig {
    /// The Keops slave (T 7.1.2) at 10 kHz: LM1247 carriages with 16-bit Hall sensing,
    /// homed at 10 mm with the effector on the axis of symmetry (so the calibration
    /// sweep, 1.5 pitches = 27 mm up, stays inside the 0–40 mm travel), 0.5 m/s and
    /// 20 m/s² per carriage.
    pub const KEOPS: Self = Self {
        joints: JointsConfig {
            period_s: 1e-4,
            axis: AxisConfig::LM1247_SLAVE,
            hall: [HallConfig::LM1247_16BIT; 3],
            home_m: [0.010; 3],
            travel_m: [[0.0, 0.040]; 3],
            speed_limit_m_s: 0.5,
            accel_limit_m_s2: 20.0,
        },
        delta: DeltaConfig::SLAVE_KEOPS,
        contour: ContourConfig::KEOPS,
        laser: LaserConfig::SPI_REDENERGY_G3_20W,
    };

    /// The carriages' configuration with the delta actuators' travel.
    fn joints_config(&self) -> JointsConfig<3> {
        let [a0, a1, a2] = self.delta.actuators;
        JointsConfig {
            travel_m: [a0, a1, a2].map(|a| [a.travel_min_m, a.travel_max_m]),
            ..self.joints
        }
    }
}

/// A planned job: a start point, the approach time to reach it, and straight moves or
/// a contour. Only [`DeltaJob::plan`] and [`DeltaJob::plan_contour`] make one;
/// `clone_from` copies in place (see [`JointJob`]).
#[derive(Debug, Default, PartialEq)]
pub struct DeltaJob {
    start_m: [f64; 3],
    start_joints_m: [f64; 3],
    approach_s: f64,
    moves: JointJob<3>,
    contour: Option<ContourJob>,
    /// `None` only for the empty default job, which every machine refuses.
    planned_for: Option<Limits>,
}

impl Clone for DeltaJob {
    fn clone(&self) -> Self {
        let mut job = Self::default();
        job.clone_from(self);
        job
    }

    fn clone_from(&mut self, source: &Self) {
        self.start_m = source.start_m;
        self.start_joints_m = source.start_joints_m;
        self.approach_s = source.approach_s;
        self.moves.clone_from(&source.moves);
        if self.contour.is_some() || source.contour.is_some() {
            replace_contour(&mut self.contour, &source.contour);
        }
        self.planned_for = source.planned_for;
    }
}

/// Copies a contour job (or its absence) in place: the job is `Copy`, so this is a
/// memory copy with no temporary (a contour job is two kilobytes; the control period's
/// stack budget is two). Out of line, to keep it out of straight moves' `clone_from`.
#[inline(never)]
fn replace_contour(contour: &mut Option<ContourJob>, from: &Option<ContourJob>) {
    *contour = *from;
}

/// What a plan was checked against.
#[derive(Copy, Clone, Debug, PartialEq)]
struct Limits {
    delta: DeltaConfig,
    laser: LaserConfig,
    speed_limit_m_s: f64,
    accel_limit_m_s2: f64,
    period_s: f64,
}

impl Limits {
    fn of(config: &DeltaSlaveConfig) -> Self {
        Self {
            delta: config.delta,
            laser: config.laser,
            speed_limit_m_s: config.joints.speed_limit_m_s,
            accel_limit_m_s2: config.joints.accel_limit_m_s2,
            period_s: config.joints.period_s,
        }
    }
}

impl DeltaJob {
    /// Where a program of moves' cut ends (relative to the job's centre, m) and how
    /// the next part takes over there; `None` when the job ends at rest.
    pub(crate) fn join(&self) -> Option<([f64; 2], Continuation<2>)> {
        self.contour.as_ref().and_then(ContourJob::join)
    }

    /// Plans a job for `config`: reach `start_m` by a joint-space approach of
    /// `approach_s`, then the straight `moves` (effector targets in m). Every move is
    /// checked at [`PLAN_SAMPLES`] instants: reachable, inside travel, away from
    /// singularities, within the carriages' speed and acceleration limits.
    pub fn plan(
        config: &DeltaSlaveConfig,
        start_m: [f64; 3],
        approach_s: f64,
        moves: &[Segment<3>],
    ) -> Result<Self, DeltaJobError> {
        let not_finite = |segment: usize| DeltaJobError::NotFinite {
            segment: segment as u8,
        };
        let moves = JointJob::from_slice(moves).ok_or(DeltaJobError::Size)?;
        if moves.is_empty() {
            return Err(DeltaJobError::Size);
        }
        let geometry =
            DeltaGeometry::<f64>::new(&config.delta).map_err(|_| DeltaJobError::OtherMachine)?;
        let finite = |p: &[f64; 3]| p.iter().all(|c| c.is_finite());
        if !(approach_s.is_finite() && approach_s > 0.0 && finite(&start_m)) {
            return Err(not_finite(0));
        }
        let start = Vector3::from(start_m);
        let start_joints = geometry
            .inverse(&start)
            .map_err(|error| DeltaJobError::Unreachable { segment: 0, error })?;
        let limits = &config.joints;
        let mut from = start_m;
        for (index, segment) in moves.iter().enumerate() {
            if !finite(&segment.target_m) {
                return Err(not_finite(index));
            }
            if segment.duration_s / limits.period_s >= f64::from(u32::MAX) {
                return Err(DeltaJobError::TooLong {
                    segment: index as u8,
                });
            }
            let line = Line::<f64>::new(from, segment.target_m, segment.duration_s)
                .map_err(|_| not_finite(index))?;
            for n in 0..=PLAN_SAMPLES {
                let t = segment.duration_s * n as f64 / PLAN_SAMPLES as f64;
                let (p, p_dot, p_ddot) = line.at(t);
                let joints = joint_references(&geometry, &p, &p_dot, &p_ddot).map_err(|error| {
                    DeltaJobError::Unreachable {
                        segment: index as u8,
                        error,
                    }
                })?;
                // The inverse kinematics has checked reach and travel.
                for (axis, r) in joints.iter().enumerate() {
                    if libm::fabs(r.velocity) > limits.speed_limit_m_s
                        || libm::fabs(r.acceleration) > limits.accel_limit_m_s2
                    {
                        return Err(DeltaJobError::TooFast {
                            segment: index as u8,
                            axis: axis as u8,
                        });
                    }
                }
            }
            from = segment.target_m;
        }
        Ok(Self {
            start_m,
            start_joints_m: start_joints.into(),
            approach_s,
            moves,
            contour: None,
            planned_for: Some(Limits::of(config)),
        })
    }

    /// Plans a contour job for `config` ([`ContourPlan`]; the checks are in the
    /// `contour` module's docs): a joint-space approach of `plan.approach_s` to the
    /// curve's start (θ0 of a closed curve, the first point of an open path), then the
    /// curve at constant tangential speed between jerk-limited ramps, for the laps of a
    /// closed curve or to the end of an open path.
    pub fn plan_contour(
        config: &DeltaSlaveConfig,
        plan: &ContourPlan<'_>,
    ) -> Result<Self, DeltaJobError> {
        if !(plan.approach_s.is_finite() && plan.approach_s > 0.0) {
            return Err(DeltaJobError::NotFinite { segment: 0 });
        }
        let (contour, start_m) = ContourJob::plan(config, plan)?;
        let geometry =
            DeltaGeometry::<f64>::new(&config.delta).map_err(|_| DeltaJobError::OtherMachine)?;
        let start_joints = geometry.inverse(&Vector3::from(start_m)).map_err(|error| {
            DeltaJobError::ContourUnreachable {
                point_m: start_m,
                error,
            }
        })?;
        Ok(Self {
            start_m,
            start_joints_m: start_joints.into(),
            approach_s: plan.approach_s,
            moves: JointJob::new(),
            contour: Some(contour),
            planned_for: Some(Limits::of(config)),
        })
    }

    /// The law of a contour job (`None` for straight moves).
    pub fn contour_law(&self) -> Option<ContourLaw> {
        self.contour.as_ref().map(ContourJob::law)
    }

    /// Where the straight moves start, m.
    pub fn start_m(&self) -> [f64; 3] {
        self.start_m
    }

    /// The straight moves.
    pub fn moves(&self) -> &[Segment<3>] {
        &self.moves
    }
}

/// Why the slave stopped.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DeltaFault {
    /// A carriage's fault.
    Joint(JointFault),
    /// The joint references, or the measured effector, could not be computed.
    Kinematics(KinematicsError),
    /// The contour follower could not take a step.
    Contour(ContourError),
    /// The effector left the contour by more than the normal-error limit.
    ContourError,
    /// A carriage fell behind its reference by more than the joint-error limit.
    FollowingError {
        /// Carriage index.
        axis: u8,
    },
    /// A carriage's force stayed at its limit longer than the saturation limit.
    Saturated,
    /// An output was NaN or infinite: the carriage forces 0–2, the laser duty 3.
    Output(NonFiniteOutput),
}

/// One period's commands: the carriages' forces and the laser, written together.
pub type SlaveOutputs<T> = ForceAndLaser<T, 3>;

/// One period's telemetry.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DeltaTelemetry<T> {
    /// The carriages.
    pub joints: JointTelemetry<T, 3>,
    /// The effector's reference position during a job, m: a straight move's or a
    /// contour's, and during the approach where its joint references put the effector.
    pub effector_reference_m: Option<[T; 3]>,
    /// During a contour: what the supervision measured.
    pub contour: Option<ContourTelemetry<T>>,
    /// The laser power commanded this period, W.
    pub laser_power_w: T,
}

/// One contour period as measured.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ContourTelemetry<T> {
    /// The effector, FK of the measured carriages, m.
    pub effector_m: [T; 3],
    /// The error in the path's frame (tangential, normal, vertical), m; in the base
    /// frame (x, y, z) where the reference is too slow for a frame.
    pub frame_error_m: [T; 3],
    /// The contour error the supervision checks: |normal error|, or the planar error
    /// without a frame, m.
    pub contour_error_m: T,
    /// The effector's measured speed along the reference's tangent, m/s.
    pub tangential_speed_m_s: T,
}

/// Where a running job is.
#[derive(Copy, Clone, Debug)]
enum Phase<T> {
    Approach,
    Move {
        index: usize,
        line: Line<T>,
        period: u32,
        periods: u32,
    },
    Contour,
}

/// The delta slave as a [`Machine`] the supervisor runs. In declaration order
/// (`repr(C)`): what every period reads first, the contour's run (whose program of
/// moves is f64, which the default layout would put first for its alignment) and the
/// approach's moves last, so the period's loads keep short offsets.
#[derive(Clone, Debug)]
#[repr(C)]
pub struct DeltaSlave<T: Float> {
    joints: Joints<T, 3>,
    geometry: DeltaGeometry<T>,
    preview: Preview<T>,
    contouring: Contouring<T>,
    laser: Laser<T>,
    /// The control period in `T`, s.
    ts: T,
    normal_error_limit_m: T,
    joint_error_limit_m: T,
    saturation_periods: u32,
    /// The power commanded in the last period, W (zero outside a contour).
    laser_power_w: T,
    phase: Option<Phase<T>>,
    effector_reference_m: Option<[T; 3]>,
    contour_active: bool,
    contour_telemetry: Option<ContourTelemetry<T>>,
    /// The contour's run: rebuilt in place at `Start`, run after the approach while
    /// `contour_active`.
    contour: ContourRun<T>,
    limits: Limits,
    /// The joint-space move to a job's start (built in place at `Start`).
    approach: JointJob<3>,
}

impl<T: Float> DeltaSlave<T> {
    /// Validates `config`; a bad field is named with its path
    /// (`joints.axis.dob.bandwidth_rad_s`, `delta.actuators[1].theta_rad`).
    pub fn new(config: &DeltaSlaveConfig) -> Result<Self, ConfigError> {
        let geometry = DeltaGeometry::new(&config.delta).within("delta")?;
        // Homes are checked against the actuators' travel there.
        let joints = Joints::new(&config.joints_config()).within("joints")?;
        let limits = &config.contour;
        let limit = |name, value| {
            positive(name, value)
                .and_then(|v| crate::error::representable::<T>(name, v))
                .within("contour")
        };
        let saturation_periods = positive("saturation_limit_s", limits.saturation_limit_s)
            .within("contour")?
            / config.joints.period_s;
        Ok(Self {
            joints,
            geometry,
            limits: Limits::of(config),
            ts: crate::error::coefficient("period_s", config.joints.period_s).within("joints")?,
            approach: JointJob::new(),
            phase: None,
            effector_reference_m: None,
            contour: ContourRun::idle().within("contour")?,
            contour_active: false,
            contour_telemetry: None,
            preview: Preview::new(&limits.preview).within("contour.preview")?,
            contouring: Contouring::new(&limits.contouring).within("contour.contouring")?,
            normal_error_limit_m: limit("normal_error_limit_m", limits.normal_error_limit_m)?,
            joint_error_limit_m: limit("joint_error_limit_m", limits.joint_error_limit_m)?,
            saturation_periods: libm::ceil(saturation_periods).min(f64::from(u32::MAX)) as u32,
            laser: Laser::new(&config.laser).within("laser")?,
            laser_power_w: T::zero(),
        })
    }

    /// `force_n` with the beam off.
    fn beam_off(force_n: [T; 3]) -> SlaveOutputs<T> {
        SlaveOutputs {
            force_n,
            laser_duty: T::zero(),
        }
    }

    /// The carriages.
    pub fn joints(&self) -> &Joints<T, 3> {
        &self.joints
    }

    /// The geometry.
    pub fn geometry(&self) -> &DeltaGeometry<T> {
        &self.geometry
    }

    /// The carriages, for a machine that drives them with its own law.
    pub(crate) fn joints_mut(&mut self) -> &mut Joints<T, 3> {
        &mut self.joints
    }

    /// The geometry and the carriages together (a law that needs both in a period).
    pub(crate) fn geometry_and_joints(&mut self) -> (&DeltaGeometry<T>, &mut Joints<T, 3>) {
        (&self.geometry, &mut self.joints)
    }

    /// The laser source.
    pub(crate) fn laser(&self) -> &Laser<T> {
        &self.laser
    }

    /// The travel (tool off) in the workspace during an approach: where its joint
    /// references put the effector (`None` where that cannot be solved). Solved for
    /// telemetry only, when it is reported; out of line, so its frame is not added to
    /// the period's.
    #[inline(never)]
    fn travel_reference_m(&self) -> Option<[T; 3]> {
        let [a, b, c] = self.joints.reference();
        self.geometry
            .forward(&Vector3::new(a.position, b.position, c.position))
            .ok()
            .map(|p| [p.x, p.y, p.z])
    }

    /// The forces of a running job's period (the laser's power is left in
    /// `laser_power_w`).
    fn run_forces(
        &mut self,
        job: &DeltaJob,
        inputs: &[[u16; 3]; 3],
    ) -> Result<Step<[T; 3]>, DeltaFault> {
        match self.phase {
            Some(Phase::Approach) => {
                let step = self
                    .joints
                    .run(&self.approach, inputs)
                    .map_err(DeltaFault::Joint)?;
                Ok(match step {
                    Step::Continue(forces) => Step::Continue(forces),
                    Step::Done(forces) if self.contour_active => {
                        self.phase = Some(Phase::Contour);
                        Step::Continue(forces)
                    }
                    Step::Done(forces) => match self.next_move(job, 0) {
                        Some(phase) => {
                            self.phase = Some(phase);
                            Step::Continue(forces)
                        }
                        None => Step::Done(forces),
                    },
                })
            }
            Some(Phase::Move {
                index,
                line,
                period,
                periods,
            }) => {
                let t = <T as Real>::from_q32(i64::from(period) << 32) * self.ts;
                let (p, p_dot, p_ddot) = line.at(t);
                let references = joint_references(&self.geometry, &p, &p_dot, &p_ddot)
                    .map_err(DeltaFault::Kinematics)?;
                self.effector_reference_m = Some([p.x, p.y, p.z]);
                let forces = self
                    .joints
                    .follow(inputs, references)
                    .map_err(DeltaFault::Joint)?;
                let period = period + 1;
                if period < periods {
                    self.phase = Some(Phase::Move {
                        index,
                        line,
                        period,
                        periods,
                    });
                    return Ok(Step::Continue(forces));
                }
                self.phase = self.next_move(job, index + 1);
                // The last move ends at rest: its joint references hold there.
                Ok(match self.phase {
                    Some(_) => Step::Continue(forces),
                    None => Step::Done(forces),
                })
            }
            Some(Phase::Contour) => self.contour_period(inputs),
            None => Ok(Step::Done(self.joints.safe_outputs())),
        }
    }

    fn next_move(&self, job: &DeltaJob, index: usize) -> Option<Phase<T>> {
        let segment = job.moves.get(index)?;
        let from = match index.checked_sub(1) {
            None => job.start_m,
            Some(previous) => job.moves.get(previous)?.target_m,
        };
        // Planned and checked: the line's inputs are finite and its duration positive.
        let line = Line::new(from, segment.target_m, segment.duration_s).ok()?;
        Some(Phase::Move {
            index,
            line,
            period: 0,
            periods: libm::round(segment.duration_s / self.limits.period_s) as u32,
        })
    }

    /// One period of the stop ramp begun by `begin_stop` with the beam off, then rest
    /// (the job is not needed: the ramp starts from the present motion).
    pub fn ramp_to_rest(
        &mut self,
        inputs: &[[u16; 3]; 3],
    ) -> Result<Step<SlaveOutputs<T>>, DeltaFault> {
        self.laser_power_w = T::zero();
        let step = self.joints.ramp_to_rest(inputs);
        Ok(step.map_err(DeltaFault::Joint)?.map(Self::beam_off))
    }
}

impl<T: Float> Machine for DeltaSlave<T> {
    type Inputs = [[u16; 3]; 3];
    type Outputs = SlaveOutputs<T>;
    type Job = DeltaJob;
    type JobError = DeltaJobError;
    type Coefficients = AxisLaw<T>;
    type SweepSample = HallSample;
    type Calibration = [HallAxis<T>; 3];
    type Fault = DeltaFault;
    type Telemetry = DeltaTelemetry<T>;

    /// Zero force on every carriage, laser off.
    fn safe_outputs(&self) -> SlaveOutputs<T> {
        SlaveOutputs {
            force_n: self.joints.safe_outputs(),
            laser_duty: T::zero(),
        }
    }

    fn monitor(&mut self, inputs: &[[u16; 3]; 3]) -> Result<(), DeltaFault> {
        self.laser_power_w = T::zero();
        self.joints.monitor(inputs).map_err(DeltaFault::Joint)
    }

    fn begin_calibration(&mut self) {
        self.joints.begin_calibration();
    }

    fn calibrate(
        &mut self,
        inputs: &[[u16; 3]; 3],
        record: &mut dyn FnMut(HallSample),
    ) -> Result<Step<SlaveOutputs<T>>, DeltaFault> {
        self.laser_power_w = T::zero();
        let step = self
            .joints
            .calibrate(inputs, record)
            .map_err(DeltaFault::Joint)?;
        Ok(step.map(Self::beam_off))
    }

    fn finish_calibration(&mut self, sensors: &[HallAxis<T>; 3]) {
        self.joints.finish_calibration(sensors);
    }

    fn check_job(&self, job: &DeltaJob) -> Result<(), DeltaJobError> {
        // Its floats hold any time a job can have: `plan` bounds them by the period
        // counter (`Real::RANGE` binds the fixed-point joints only).
        if job.planned_for == Some(self.limits) {
            Ok(())
        } else {
            Err(DeltaJobError::OtherMachine)
        }
    }

    fn queued(&mut self, next: &DeltaJob) {
        let continues = match &next.contour {
            Some(contour) if self.contour_active => self.contour.arm(contour),
            _ => false,
        };
        if !continues {
            self.contour.disarm();
        }
    }

    fn begin_job(&mut self, job: &DeltaJob) -> Result<(), DeltaJobError> {
        self.check_job(job)?;
        if let Some(contour) = job.contour.as_ref().filter(|c| c.continues()) {
            // The part before handed over at its join: the references go on, no
            // approach.
            self.contour.resume(contour, &self.laser)?;
            self.contour_active = true;
            self.phase = Some(Phase::Contour);
            return Ok(());
        }
        self.contour.disarm();
        self.approach.clear();
        // Capacity MAX_SEGMENTS ≥ 1.
        let _ = self.approach.push(Segment {
            target_m: job.start_joints_m,
            duration_s: job.approach_s,
        });
        // A contour's run is built before anything moves: a curve that does not fit
        // the scalar refuses the start.
        self.contour_active = false;
        if let Some(contour) = &job.contour {
            self.contour.start(contour, &self.geometry, &self.laser)?;
            self.contour_active = true;
        }
        self.joints
            .begin_job(&self.approach)
            .map_err(DeltaJobError::Approach)?;
        self.phase = Some(Phase::Approach);
        self.effector_reference_m = None;
        self.contour_telemetry = None;
        Ok(())
    }

    fn run(
        &mut self,
        job: &DeltaJob,
        inputs: &[[u16; 3]; 3],
    ) -> Result<Step<SlaveOutputs<T>>, DeltaFault> {
        // Only a contour period that passes its supervision turns the beam on.
        self.laser_power_w = T::zero();
        let step = self.run_forces(job, inputs)?;
        let laser_duty = self.laser.duty(self.laser_power_w);
        Ok(step.map(|force_n| SlaveOutputs {
            force_n,
            laser_duty,
        }))
    }

    fn begin_stop(&mut self) {
        self.contour.disarm();
        self.phase = None;
        self.contour_active = false;
        self.effector_reference_m = None;
        self.contour_telemetry = None;
        self.joints.begin_stop();
    }

    fn stop(
        &mut self,
        _job: &Self::Job,
        inputs: &[[u16; 3]; 3],
    ) -> Result<Step<SlaveOutputs<T>>, DeltaFault> {
        self.ramp_to_rest(inputs)
    }

    fn set_coefficients(&mut self, law: &AxisLaw<T>) {
        self.joints.set_coefficients(law);
    }

    fn reset(&mut self) {
        self.contour.disarm();
        self.joints.reset();
        self.laser_power_w = T::zero();
        self.phase = None;
        self.contour_active = false;
        self.effector_reference_m = None;
        self.contour_telemetry = None;
    }

    fn telemetry(&self) -> DeltaTelemetry<T> {
        DeltaTelemetry {
            joints: self.joints.telemetry(),
            effector_reference_m: match self.phase {
                Some(Phase::Approach) => self.travel_reference_m(),
                _ => self.effector_reference_m,
            },
            contour: self.contour_telemetry,
            laser_power_w: self.laser_power_w,
        }
    }
}

impl<T: Float> HallMachine<3> for DeltaSlave<T> {
    fn fit(
        hall: &[HallConfig; 3],
        samples: &CalibrationFit<3>,
    ) -> Result<([HallAxis<T>; 3], [SelfCalibration; 3]), CalibrationFailure> {
        fit_sensors(hall, samples)
    }
}

impl From<NonFiniteOutput> for DeltaFault {
    fn from(output: NonFiniteOutput) -> Self {
        Self::Output(output)
    }
}

#[cfg(test)]
mod tests;
