//! Contour jobs of the delta slave (T ch. 4, 8.1–8.2): the effector follows a closed
//! EFD curve or an open path ([`ContourCurve`]) at a constant tangential speed, or a
//! program of straight moves with sharp corners as the look-ahead planner plans it
//! (the `moves` module), in the cutting plane z = const, driven by one of three laws on
//! the per-joint disturbance observers ([`ContourLaw`]).
//!
//! Planning (the slower context, `f64`, the `plan` submodule): the curve's length and
//! curvature against the speed ([`CurveFollower::new`]), then [`PLAN_SAMPLES_PER_LAP`]
//! points per lap (per open path), in path order, each checked for reach, travel,
//! singularity and the carriages' speed and acceleration at cruise (centripetal V²κ plus the ramp's tangential acceleration, a
//! bound of what the ramps and cruise ask). The first point that fails is named in the
//! error with its coordinates. Samples 2π/512 apart in θ are a few tens of
//! micrometres of path on the test contours, far closer than the workspace boundary
//! bends.
//!
//! Running (each control period, in the scalar `T`): the follower steps the reference
//! two periods ahead ([`PreviewWindow`]); the newest sample's joint references come
//! from the kinematics (T eq. 146); the law of the job turns the present (or, for
//! preview, the shifted) taps and the measured joints into desired joint accelerations;
//! the disturbance observers turn those into forces. Every period is supervised: the
//! contour error (normal to the path; the planar error where the reference is too slow
//! for a frame), every joint's following error and the force saturation, each against
//! a limit of [`ContourConfig`]; past one, the machine faults with zero force in the
//! same period.
//!
//! The laser follows the job's [`LaserMode`] from the measured speed along the
//! reference's tangent (T 9.2's adaptive mode: constant energy per length), and only in
//! a period that passed its supervision; the approach, a stop and a fault keep it off.

use super::moves::{MovePoint, MovesRun, MovesStep};
use super::{joint_references, ContourTelemetry, DeltaFault, DeltaJobError, DeltaSlave};
use crate::app::supervisor::{Machine, Step};
use crate::control::contouring::ContouringError;
use crate::control::contouring::{ContouringConfig, TaskReference};
use crate::control::laser::{Laser, LaserMode};
use crate::control::preview::{PreviewConfig, PreviewWindow};
use crate::error::ConfigError;
use crate::kinematics::delta::DeltaGeometry;
use crate::scalar::{lit, norm, Float};
use crate::trajectory::curve::{Curve, CurveSample};
use crate::trajectory::efd::Efd;
use crate::trajectory::open_path::OpenPath;
use crate::trajectory::planner::Continuation;
use crate::trajectory::tangential::{
    ContourReference, CurveFollower, FollowerConfig, SpeedRampConfig,
};
use crate::trajectory::ContourError;
use crate::trajectory::Reference;
use core::f64::consts::PI;
use nalgebra::Vector3;

/// Harmonics a contour job can carry.
pub const CONTOUR_HARMONICS: usize = 30;

/// Points an open path of a contour job can carry (the letters of T fig. 8.1 have 25
/// and 29).
pub const OPEN_PATH_POINTS: usize = 32;

/// Periods a contour runs beyond its ramps and cruise: the preview window, two taps
/// ahead of the present one, drains until its present tap rests at the end (the count
/// a job's duration adds, checked period by period against the simulated slave).
const DRAIN_PERIODS: u32 = 1;

/// Points per lap (per open path) at which a plan checks reach and limits.
pub const PLAN_SAMPLES_PER_LAP: usize = 512;

mod plan;

pub(super) use plan::ContourJob;
use plan::JobPath;

/// What a contour job follows.
#[derive(Copy, Clone, Debug)]
pub enum ContourCurve<'a> {
    /// A closed contour, from θ0 for a number of laps.
    Closed {
        /// The curve, relative to its own centre.
        efd: &'a Efd<f64, CONTOUR_HARMONICS>,
        /// Where on the curve the cut starts, rad.
        theta0_rad: f64,
        /// How far to go, in laps of the curve (more than the two speed ramps' length).
        laps: f64,
    },
    /// An open path, from its first point to its last (T 8.1's letters), relative to
    /// the centroid of its points.
    Open(&'a OpenPath<f64, OPEN_PATH_POINTS>),
    /// A program of straight moves with sharp corners, relative to the job's centre,
    /// each move at its feed (at most the plan's speed) and each corner at the speed
    /// a circle `junction_deviation_m` from it allows (the `moves` module).
    Moves {
        /// The points, the first where the cut starts.
        points: &'a [MovePoint],
        /// How far from a corner the circle that sets its speed passes, m.
        junction_deviation_m: f64,
        /// Of the points, the last this many are room to stop in, which the next part
        /// cuts (0: the part ends at rest at its last point).
        lookahead: usize,
        /// The part before, which this one continues without a stop at its join.
        before: Option<Continuation<2>>,
    },
}

/// The curve of a job (`f64`, planned) or of a run (`T`). `Copy`: a job's curve is
/// copied in place.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(super) enum PathCurve<T: Float> {
    Closed(Efd<T, CONTOUR_HARMONICS>),
    Open(OpenPath<T, OPEN_PATH_POINTS>),
}

impl<T: Float> Curve<T> for PathCurve<T> {
    fn evaluate(&self, theta: T) -> CurveSample<T> {
        match self {
            Self::Closed(c) => Curve::evaluate(c, theta),
            Self::Open(c) => c.evaluate(theta),
        }
    }
    fn tangent(&self, theta: T) -> nalgebra::Vector2<T> {
        match self {
            Self::Closed(c) => Curve::tangent(c, theta),
            Self::Open(c) => c.tangent(theta),
        }
    }
    fn span(&self) -> T {
        match self {
            Self::Closed(c) => c.span(),
            Self::Open(c) => c.span(),
        }
    }
    fn is_closed(&self) -> bool {
        matches!(self, Self::Closed(_))
    }
    fn pieces(&self) -> usize {
        match self {
            Self::Closed(c) => c.pieces(),
            Self::Open(c) => c.pieces(),
        }
    }
}

impl<T: Float> PathCurve<T> {
    /// The job's curve converted into this one, in place (see [`Efd::assign_f64`]).
    /// Out of line: its frame is not added to the start's.
    #[inline(never)]
    fn assign_f64(&mut self, curve: &PathCurve<f64>) -> Result<(), ContourError> {
        match curve {
            PathCurve::Closed(c) => {
                if !matches!(self, Self::Closed(_)) {
                    self.become_closed();
                }
                match self {
                    Self::Closed(this) => this.assign_f64(c),
                    Self::Open(_) => Err(ContourError::LostContour),
                }
            }
            PathCurve::Open(c) => {
                if !matches!(self, Self::Open(_)) {
                    self.become_open();
                }
                match self {
                    Self::Open(this) => this.assign_f64(c),
                    Self::Closed(_) => Err(ContourError::LostContour),
                }
            }
        }
    }

    /// An empty closed curve in place of an open one. Out of line: its temporary is on
    /// the stack only while it runs, not in every start's frame.
    #[inline(never)]
    fn become_closed(&mut self) {
        *self = Self::Closed(Efd::empty());
    }

    /// An empty open path in place of a closed curve (out of line, as above).
    #[inline(never)]
    fn become_open(&mut self) {
        *self = Self::Open(OpenPath::empty());
    }
}

/// The law that drives the joints along a contour. All three end in the same per-joint
/// disturbance observers.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ContourLaw {
    /// Independent joint control: each joint's PD (the axis law's gains) on its own
    /// reference, the baseline of T fig. 8.4.
    Joint,
    /// Joint PD with preview of the reference (T 4.2.1, `control::preview`).
    Preview,
    /// The law in the frame moving with the path (T 4.3.2, `control::contouring`).
    Contouring,
}

/// The slave's contour laws and the limits that supervise a contour.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ContourConfig {
    /// Preview law gains.
    pub preview: PreviewConfig,
    /// Contouring law gains and the slowest reference with a frame.
    pub contouring: ContouringConfig,
    /// Largest contour error (normal to the path) before a fault, m.
    pub normal_error_limit_m: f64,
    /// Largest following error of any carriage before a fault, m.
    pub joint_error_limit_m: f64,
    /// Longest time any carriage's force may stay at its limit before a fault, s.
    pub saturation_limit_s: f64,
    /// Newton corrections of the arc-length step per period
    /// ([`FollowerConfig::newton_steps`]).
    pub newton_steps: u8,
}

impl ContourConfig {
    /// The Keops slave's stiffness budget, matched across the laws: every law has the
    /// axis PD's error poles, a double pole at 2π·40 rad/s, in each direction it
    /// regulates (joint PD and preview per joint; contouring along the tangent, the
    /// normal and z). The laws differ only in where they measure the error and which
    /// reference taps they use. Frames below 0.5 mm/s (the ramps pass it within a
    /// few periods). Limits: 50 µm normal, 0.5 mm per carriage (a blocked carriage
    /// reaches it within tens of milliseconds at cutting speeds), 20 ms at the force
    /// limit. No Newton correction: the Taylor step is exact to 1e-13 m per period.
    pub const KEOPS: Self = Self {
        preview: PreviewConfig {
            surface_slope_per_s: 2.0 * PI * 40.0,
            reaching_rate_per_s: 2.0 * PI * 40.0,
        },
        contouring: ContouringConfig {
            tangential: crate::control::pd::PdConfig {
                kp_per_s2: (2.0 * PI * 40.0) * (2.0 * PI * 40.0),
                kd_per_s: 2.0 * 2.0 * PI * 40.0,
            },
            normal: crate::control::pd::PdConfig {
                kp_per_s2: (2.0 * PI * 40.0) * (2.0 * PI * 40.0),
                kd_per_s: 2.0 * 2.0 * PI * 40.0,
            },
            vertical: crate::control::pd::PdConfig {
                kp_per_s2: (2.0 * PI * 40.0) * (2.0 * PI * 40.0),
                kd_per_s: 2.0 * 2.0 * PI * 40.0,
            },
            min_speed_m_s: 5e-4,
        },
        normal_error_limit_m: 50e-6,
        joint_error_limit_m: 0.5e-3,
        saturation_limit_s: 0.02,
        newton_steps: 0,
    };
}

/// What an operator asks of a contour job.
#[derive(Copy, Clone, Debug)]
pub struct ContourPlan<'a> {
    /// The curve, and where on it the cut starts and ends.
    pub curve: ContourCurve<'a>,
    /// Where the curve's centre goes, and the cutting height z, m.
    pub centre_m: [f64; 3],
    /// Tangential speed V, m/s.
    pub speed_m_s: f64,
    /// Largest tangential acceleration of the start and stop ramps, m/s².
    pub accel_m_s2: f64,
    /// Largest tangential jerk of the ramps, m/s³.
    pub jerk_m_s3: f64,
    /// Time of the joint-space approach to the start point, s.
    pub approach_s: f64,
    /// The law.
    pub law: ContourLaw,
    /// What the beam does along the contour (off during the approach).
    pub laser: LaserMode,
}

/// The effector's reference from the follower's sample (relative to the curve centre).
fn task_reference<T: Float>(centre: &Vector3<T>, r: &ContourReference<T>) -> TaskReference<T> {
    let planar = |v: nalgebra::Vector2<T>| Vector3::new(v.x, v.y, T::zero());
    TaskReference {
        position: centre + planar(r.position),
        velocity: planar(r.velocity),
        acceleration: planar(r.acceleration),
        jerk: planar(r.jerk),
    }
}

/// A contour in progress. In declaration order (`repr(C)`): what every period reads
/// first, the program of moves (a kilobyte of f64, which the default layout would put
/// first for its alignment) last, so the period's loads keep short offsets.
#[derive(Clone, Debug)]
#[repr(C)]
pub(super) struct ContourRun<T: Float> {
    /// Task references at k, k+1, k+2.
    pub(super) task: PreviewWindow<TaskReference<T>>,
    /// The joint references of the same taps.
    pub(super) joints: PreviewWindow<[Reference<T>; 3]>,
    centre: Vector3<T>,
    law: ContourLaw,
    laser: LaserMode<T>,
    started: bool,
    period: u32,
    stop_after_periods: u32,
    /// Periods the window has been draining since the follower came to rest.
    drained: u8,
    /// Consecutive periods with a force at its limit.
    pub(super) saturated_periods: u32,
    follower: CurveFollower<T, PathCurve<T>>,
    /// Whether the moves below make the reference (not the curve follower).
    on_moves: bool,
    /// The time past the join where the moves handed over to the next part, s.
    joined_s: Option<f64>,
    /// The moves of a program.
    moves: MovesRun,
}

impl<T: Float> ContourRun<T> {
    /// An idle run (a zero curve, never stepped): the machine's storage for the runs
    /// it starts, built once with the machine.
    pub(super) fn idle() -> Result<Self, ConfigError> {
        let follower = FollowerConfig {
            ramp: SpeedRampConfig {
                speed_m_s: 1e-3,
                accel_m_s2: 1.0,
                jerk_m_s3: 100.0,
                ts_s: 1e-3,
            },
            accel_limit_m_s2: 1.0,
            newton_steps: 0,
        };
        let follower =
            CurveFollower::for_checked_curve(PathCurve::Closed(Efd::empty()), &follower, 0.0)
                .map_err(|_| ConfigError::out_of_range("contour"))?;
        let zero = Vector3::zeros();
        let rest = TaskReference {
            position: zero,
            velocity: zero,
            acceleration: zero,
            jerk: zero,
        };
        let hold = Reference {
            position: T::zero(),
            velocity: T::zero(),
            acceleration: T::zero(),
        };
        Ok(Self {
            follower,
            moves: MovesRun::idle()?,
            on_moves: false,
            joined_s: None,
            centre: zero,
            law: ContourLaw::Joint,
            laser: LaserMode::Off,
            task: PreviewWindow::filled(rest),
            joints: PreviewWindow::filled([hold; 3]),
            started: false,
            period: 0,
            stop_after_periods: 0,
            drained: 0,
            saturated_periods: 0,
        })
    }

    /// Makes this the run of `job`, at rest at its start, in place: the curve is
    /// converted to `T` where it lies (a few hundred conversions: it was checked when
    /// the job was planned), so no copy of it passes through the control period's
    /// stack. Out of line, like the period.
    #[inline(never)]
    pub(super) fn start(
        &mut self,
        job: &ContourJob,
        geometry: &DeltaGeometry<T>,
        laser: &Laser<T>,
    ) -> Result<(), DeltaJobError> {
        self.centre = Vector3::new(
            lit(job.centre_m[0]),
            lit(job.centre_m[1]),
            lit(job.centre_m[2]),
        );
        let first = match &job.path {
            JobPath::Curve {
                curve,
                theta0_rad,
                follower,
                stop_after_periods,
            } => {
                self.follower
                    .curve_mut()
                    .assign_f64(curve)
                    .map_err(DeltaJobError::Contour)?;
                self.follower
                    .restart(follower, *theta0_rad)
                    .map_err(DeltaJobError::Contour)?;
                self.stop_after_periods = *stop_after_periods;
                self.on_moves = false;
                task_reference(&self.centre, &self.follower.at_rest())
            }
            JobPath::Moves { plan, period_s } => {
                self.moves
                    .start(plan, *period_s)
                    .map_err(|e| DeltaJobError::Contour(ContourError::Config(e)))?;
                self.on_moves = true;
                self.moves.at_rest(&self.centre)
            }
        };
        let joints = joint_references(
            geometry,
            &first.position,
            &first.velocity,
            &first.acceleration,
        )
        .map_err(|error| DeltaJobError::ContourUnreachable {
            point_m: job.centre_m,
            error,
        })?;
        self.law = job.law;
        self.laser = laser
            .mode(&job.laser)
            .map_err(|e| DeltaJobError::Laser(e.kind))?;
        self.joined_s = None;
        self.task = PreviewWindow::filled(first);
        self.joints = PreviewWindow::filled(joints);
        self.started = false;
        self.period = 0;
        self.drained = 0;
        self.saturated_periods = 0;
        Ok(())
    }

    /// Makes this the run of `job`, a program of moves that continues the one this run
    /// handed over at its join: the references and the state go on, the moves are
    /// the new part's (its law and laser too). Refused when the run did not hand over
    /// or `job` is not a program of moves at the same centre.
    #[inline(never)]
    pub(super) fn resume(
        &mut self,
        job: &ContourJob,
        laser: &Laser<T>,
    ) -> Result<(), DeltaJobError> {
        let (JobPath::Moves { plan, period_s }, Some(since_s)) = (&job.path, self.joined_s.take())
        else {
            return Err(DeltaJobError::NotAtJoin);
        };
        let centre = Vector3::new(
            lit(job.centre_m[0]),
            lit(job.centre_m[1]),
            lit(job.centre_m[2]),
        );
        if centre != self.centre {
            return Err(DeltaJobError::NotAtJoin);
        }
        self.moves
            .resume(plan, *period_s, since_s)
            .map_err(|e| DeltaJobError::Contour(ContourError::Config(e)))?;
        self.law = job.law;
        self.laser = laser
            .mode(&job.laser)
            .map_err(|e| DeltaJobError::Laser(e.kind))?;
        self.drained = 0;
        Ok(())
    }

    /// Whether `next` continues this run's program of moves at its join (not yet
    /// passed); if so, the run hands over to it there.
    pub(super) fn arm(&mut self, next: &ContourJob) -> bool {
        match &next.path {
            JobPath::Moves { plan, .. } if self.on_moves => self.moves.arm(plan),
            _ => false,
        }
    }

    /// No part continues this run: its moves brake in their look-ahead.
    pub(super) fn disarm(&mut self) {
        self.moves.disarm();
        self.joined_s = None;
    }

    /// Whether the present reference is cut (the beam may be on).
    pub(super) fn cutting(&self) -> bool {
        !self.on_moves || self.moves.cutting()
    }

    /// The law.
    pub(super) fn law(&self) -> ContourLaw {
        self.law
    }

    /// Pushes the curve follower's reference a period further; whether it is at rest
    /// after its stop ramp.
    fn curve_step(&mut self) -> Result<bool, super::DeltaFault> {
        if !self.started {
            self.follower.start();
            self.started = true;
        }
        if self.period == self.stop_after_periods {
            self.follower.stop();
        }
        self.period = self.period.saturating_add(1);
        let r = self.follower.step().map_err(super::DeltaFault::Contour)?;
        self.task.push(task_reference(&self.centre, &r));
        Ok(self.period > self.stop_after_periods && self.follower.ramp().is_at_rest())
    }

    /// Steps the reference one period (the newest tap, two periods ahead) and shifts the
    /// windows. Returns `true` once the follower has stopped and the present tap is at
    /// rest at the end.
    pub(super) fn advance(
        &mut self,
        geometry: &DeltaGeometry<T>,
    ) -> Result<bool, super::DeltaFault> {
        let ended = if self.on_moves {
            let (task, step) = self.moves.step(&self.centre);
            self.task.push(task);
            if let MovesStep::Join(since_s) = step {
                // The next part goes on from here: no draining.
                self.joined_s = Some(since_s);
                let joints =
                    joint_references(geometry, &task.position, &task.velocity, &task.acceleration)
                        .map_err(super::DeltaFault::Kinematics)?;
                self.joints.push(joints);
                return Ok(true);
            }
            step == MovesStep::AtRest
        } else {
            self.curve_step()?
        };
        let task = self.task.newest();
        let joints = joint_references(geometry, &task.position, &task.velocity, &task.acceleration)
            .map_err(super::DeltaFault::Kinematics)?;
        self.joints.push(joints);
        if ended {
            self.drained = self.drained.saturating_add(1);
        }
        Ok(self.drained > 2)
    }
}

impl<T: Float> DeltaSlave<T> {
    /// One period of the contour in progress (module docs). Out of line: its frame
    /// (the kinematics' and the law's matrices) is paid only while a contour runs.
    #[inline(never)]
    pub(super) fn contour_period(
        &mut self,
        inputs: &[[u16; 3]; 3],
    ) -> Result<Step<[T; 3]>, DeltaFault> {
        if !self.contour_active {
            return Ok(Step::Done(self.joints.safe_outputs()));
        }
        let run = &mut self.contour;
        let done = run.advance(&self.geometry)?;
        let (q, q_dot) = self.joints.measure(inputs).map_err(DeltaFault::Joint)?;
        let (q_m, q_dot_m_s) = (Vector3::from(q), Vector3::from(q_dot));
        let task = *run.task.now();
        let joint_references = *run.joints.now();
        let kinematics = DeltaFault::Kinematics;
        let lost = || DeltaFault::Contour(ContourError::LostContour);
        let (acceleration, frame_error_m, contour_error_m, effector_m, effector_velocity) =
            match run.law() {
                ContourLaw::Contouring => {
                    let out = self
                        .contouring
                        .joint_acceleration(&self.geometry, &task, &q_m, &q_dot_m_s)
                        .map_err(|e| match e {
                            // Only a reference that is not finite has no frame here.
                            ContouringError::Frame(_) => lost(),
                            ContouringError::Kinematics(e) => kinematics(e),
                        })?;
                    (
                        out.joint_acceleration.into(),
                        out.frame_error_m,
                        out.contour_error_m,
                        out.position_m,
                        out.velocity_m_s,
                    )
                }
                law => {
                    let (p, v) = self
                        .geometry
                        .task_state(&q_m, &q_dot_m_s)
                        .map_err(kinematics)?;
                    let (e, contour_error) =
                        self.contouring.frame_error(&task, &p).map_err(|_| lost())?;
                    let mut acceleration = [T::zero(); 3];
                    for (k, (a, (position, velocity))) in acceleration
                        .iter_mut()
                        .zip(q.iter().copied().zip(q_dot.iter().copied()))
                        .enumerate()
                    {
                        *a = match law {
                            ContourLaw::Preview => {
                                let window = run.joints.map(|r| {
                                    r.get(k).copied().unwrap_or(Reference {
                                        position,
                                        velocity,
                                        acceleration: T::zero(),
                                    })
                                });
                                self.preview.acceleration(&window, position, velocity)
                            }
                            _ => match joint_references.get(k) {
                                Some(r) => self.joints.law().pd_acceleration(r, position, velocity),
                                None => T::zero(),
                            },
                        };
                    }
                    (acceleration, e, contour_error, p, v)
                }
            };
        let (forces, saturated) = self
            .joints
            .actuate(joint_references, &acceleration, &q_dot)
            .map_err(DeltaFault::Joint)?;
        run.saturated_periods = if saturated {
            run.saturated_periods.saturating_add(1)
        } else {
            0
        };
        // The measured speed along the reference's tangent (zero where it has none).
        let reference_speed = norm(&task.velocity);
        let tangential_speed_m_s = if reference_speed > T::zero() {
            effector_velocity.dot(&task.velocity) / reference_speed
        } else {
            T::zero()
        };
        self.effector_reference_m = Some(task.position.into());
        self.contour_telemetry = Some(ContourTelemetry {
            effector_m: effector_m.into(),
            frame_error_m: frame_error_m.into(),
            contour_error_m,
            tangential_speed_m_s,
        });
        // Supervision; a NaN fails every comparison and faults too.
        let within = |error: T, limit: T| {
            matches!(
                error.partial_cmp(&limit),
                Some(core::cmp::Ordering::Less | core::cmp::Ordering::Equal)
            )
        };
        if !within(contour_error_m, self.normal_error_limit_m) {
            return Err(DeltaFault::ContourError);
        }
        for (k, (r, position)) in joint_references.iter().zip(q.iter()).enumerate() {
            let error = r.position - *position;
            if !(within(error, self.joint_error_limit_m)
                && within(-error, self.joint_error_limit_m))
            {
                return Err(DeltaFault::FollowingError { axis: k as u8 });
            }
        }
        if run.saturated_periods > self.saturation_periods {
            return Err(DeltaFault::Saturated);
        }
        // A look-ahead is room to stop in, cut by the next part: the beam is off there.
        if run.cutting() {
            self.laser_power_w = self.laser.power_w(&run.laser, tangential_speed_m_s);
        }
        Ok(if done {
            self.contour_active = false;
            self.phase = None;
            Step::Done(forces)
        } else {
            Step::Continue(forces)
        })
    }
}
