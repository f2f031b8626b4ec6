//! ARROW's jobs (A §4): a G-code program read on the machine into
//! rest-to-rest moves, each a natural spline through its points followed at constant
//! feed with S-curve start and stop, and every move checked against the machine
//! before the job may run.
//!
//! # Moves
//!
//! The program's first point is where the job starts: the machine must stand there
//! (the operator jogs it there, or the previous job ended there). After it, each
//! maximal run of consecutive points of one kind — feed moves at one feed, or rapid
//! moves — is one move from the point before the run to the run's last point, from
//! rest to rest: a feed run at its `F`, a rapid run at the machine's rapid speed. A
//! change of feed or of kind is a stop, as at A's path ends (A 4.3). A feed above the
//! rapid speed is followed at the rapid speed, the machine's fastest (as grbl holds a
//! feed to its axes' largest rate).
//!
//! # Checks at load
//!
//! Each move's spline (what will actually run, in the machine's scalar) is sampled at
//! most [`ArrowJobConfig::check_step_m`] apart along every segment and each sample must
//! lie in eq. 25's workspace (every joint within its stroke) and keep the sines of
//! eq. 30–32 ([`SingularityDistance`](crate::kinematics::arrow::SingularityDistance))
//! above [`ArrowJobConfig::min_singularity_sine`]. Between two samples a sine changes
//! by at most about step / arm length (1 mm / 0.61 m ≈ 1.6e-3), so with the margin at
//! 0.05 a path cannot cross a singularity (a sine through zero) between samples
//! unseen: the band below the margin is some thirty samples wide. A refusal names
//! the G-code line of the move that goes there.

use crate::error::{positive, ConfigError};
use crate::kinematics::arrow::{ActuatorVector, ArrowError, ArrowGeometry, Pose};
use crate::scalar::{lit, to_f64, Float};
use crate::trajectory::feed::{FeedError, FeedLimits, FeedPlan};
use crate::trajectory::gcode::{parse, GcodeErrorKind, GcodePoint, MoveKind};
use crate::trajectory::task_spline::{
    KnotSpacing, Pose as TaskPose, TaskSpline, TaskSplineConfig, TaskSplineError,
};

/// How programs become moves on this machine.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowJobConfig {
    /// Knots and metric of the splines (A's: centripetal, tool point alone).
    pub spline: TaskSplineConfig,
    /// Largest tangential acceleration, m/s².
    pub accel_m_s2: f64,
    /// Largest tangential jerk, m/s³.
    pub jerk_m_s3: f64,
    /// Speed of rapid (`G0`) moves, m/s.
    pub rapid_m_s: f64,
    /// Control period, s.
    pub period_s: f64,
    /// Largest spacing of the load-time checks along a segment, m.
    pub check_step_m: f64,
    /// Smallest sine of eq. 30–32 a path may come to.
    pub min_singularity_sine: f64,
}

impl ArrowJobConfig {
    /// ARROW at 5 kHz (A 5.1). A prints no ramp limits: 2 m/s² and 100 m/s³
    /// give the 25 mm/s pyramid feed a 22 ms S-curve ramp, a small share of 94 s of
    /// cutting; rapids at 0.1 m/s, four times the cutting feed. Checks every 1 mm with
    /// a 0.05 singularity margin (module docs).
    pub const ARROW: Self = Self {
        spline: TaskSplineConfig {
            knots: KnotSpacing::Centripetal,
            angle_length_m_per_rad: 0.0,
        },
        accel_m_s2: 2.0,
        jerk_m_s3: 100.0,
        rapid_m_s: 0.1,
        period_s: 2e-4,
        check_step_m: 1e-3,
        min_singularity_sine: 0.05,
    };

    fn limits(&self, feed_m_s: f64) -> FeedLimits {
        FeedLimits {
            feed_m_s,
            accel_m_s2: self.accel_m_s2,
            jerk_m_s3: self.jerk_m_s3,
            ts_s: self.period_s,
        }
    }

    fn check(&self) -> Result<(), ConfigError> {
        positive("rapid_m_s", self.rapid_m_s)?;
        positive("check_step_m", self.check_step_m)?;
        let margin = self.min_singularity_sine;
        if !(margin.is_finite() && (0.0..1.0).contains(&margin)) {
            return Err(ConfigError::out_of_range("min_singularity_sine"));
        }
        // The feed limits are checked by the planner, naming their field.
        Ok(())
    }
}

/// What is wrong with a program.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ArrowJobErrorKind {
    /// The G-code itself (unknown word, missing feed, …) at `column`.
    Gcode {
        /// What the parser refused.
        kind: GcodeErrorKind,
        /// 1-based byte column.
        column: u32,
    },
    /// The program has no move (fewer than two points).
    Empty,
    /// More moves than the job holds, or more points in one move than a spline holds.
    TooLarge,
    /// A move's spline could not be built.
    Spline(TaskSplineError),
    /// A move could not be planned (bad limits, no length).
    Feed(FeedError),
    /// The path leaves the workspace (eq. 25) or an arm's reach (eq. 7).
    Workspace(ArrowError),
    /// The path comes within the singularity margin (eq. 30–32).
    Singular,
    /// The job configuration is bad (names the field).
    Config(ConfigError),
}

/// Why a program was refused, at the 1-based line that caused it. Large (a
/// configuration error carries its path) but returned only at load, in the slower
/// context: the loaders allow clippy's `result_large_err` for it.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ArrowJobError {
    /// Line of the G-code (of the move's target point for path checks).
    pub line: u32,
    /// What is wrong.
    pub kind: ArrowJobErrorKind,
}

/// One rest-to-rest move.
#[derive(Debug)]
pub struct ArrowMove<T: Float, const N: usize> {
    /// The path, (x, y, z, θx, θz) in m and rad.
    pub spline: TaskSpline<T, N>,
    /// Its S-curve timing.
    pub plan: FeedPlan,
    /// G-code line of its first target.
    pub line: u32,
}

/// The empty move.
impl<T: Float, const N: usize> Default for ArrowMove<T, N> {
    fn default() -> Self {
        Self {
            spline: TaskSpline::default(),
            plan: FeedPlan::default(),
            line: 0,
        }
    }
}

impl<T: Float, const N: usize> Clone for ArrowMove<T, N> {
    fn clone(&self) -> Self {
        let mut m = Self::default();
        m.clone_from(self);
        m
    }

    fn clone_from(&mut self, source: &Self) {
        self.spline.clone_from(&source.spline);
        self.plan = source.plan;
        self.line = source.line;
    }
}

/// A checked program: up to `R` moves of up to `N` points each. The default is the
/// empty job every machine refuses.
#[derive(Debug)]
pub struct ArrowJob<T: Float, const N: usize, const R: usize> {
    moves: [ArrowMove<T, N>; R],
    count: usize,
    start: Pose<T>,
    start_theta_x_rad: T,
    start_joints_m: ActuatorVector<T>,
    period_s: f64,
}

impl<T: Float, const N: usize, const R: usize> Default for ArrowJob<T, N, R> {
    fn default() -> Self {
        Self {
            moves: core::array::from_fn(|_| ArrowMove::default()),
            count: 0,
            start: Pose::zeros(),
            start_theta_x_rad: T::zero(),
            start_joints_m: ActuatorVector::zeros(),
            period_s: 0.0,
        }
    }
}

/// In place, move by move: a job is tens of kilobytes and the supervisor copies it in
/// the control period.
impl<T: Float, const N: usize, const R: usize> Clone for ArrowJob<T, N, R> {
    fn clone(&self) -> Self {
        let mut job = Self::default();
        job.clone_from(self);
        job
    }

    fn clone_from(&mut self, source: &Self) {
        for (to, from) in self.moves.iter_mut().zip(&source.moves).take(source.count) {
            to.clone_from(from);
        }
        self.count = source.count;
        self.start = source.start;
        self.start_theta_x_rad = source.start_theta_x_rad;
        self.start_joints_m = source.start_joints_m;
        self.period_s = source.period_s;
    }
}

/// The plate pose and table angle of a task-space point (x, y, z, A = θx, B = θz).
pub fn split_pose<T: Float>(p: &TaskPose<T>) -> (Pose<T>, T) {
    (Pose::new(p[0], p[1], p[2], p[4]), p[3])
}

impl<T: Float, const N: usize, const R: usize> ArrowJob<T, N, R> {
    /// The moves, in order.
    pub fn moves(&self) -> &[ArrowMove<T, N>] {
        self.moves.get(..self.count).unwrap_or(&[])
    }

    /// Where the job starts: plate pose and table angle.
    pub fn start(&self) -> (Pose<T>, T) {
        (self.start, self.start_theta_x_rad)
    }

    /// The joints at the start on the nominal model, m.
    pub fn start_joints_m(&self) -> &ActuatorVector<T> {
        &self.start_joints_m
    }

    /// The control period the moves were planned for, s (0 for the empty job).
    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    /// Periods the whole job takes.
    pub fn periods(&self) -> u64 {
        self.moves()
            .iter()
            .map(|m| u64::from(m.plan.periods()))
            .sum()
    }

    /// Reads a G-code program into a checked job; `points` is the caller's buffer for
    /// the parsed points.
    ///
    /// Errors: the parser's (with line and column), then the program's: no move, more
    /// than `R` moves or `N` points in one, a spline or plan that cannot be made, a
    /// path outside the workspace or within the singularity margin (module docs).
    #[allow(clippy::result_large_err)]
    pub fn from_gcode<const P: usize>(
        text: &[u8],
        points: &mut heapless::Vec<GcodePoint, P>,
        geometry: &ArrowGeometry<f64>,
        config: &ArrowJobConfig,
    ) -> Result<Self, ArrowJobError> {
        let mut job = Self::default();
        job.read_gcode(text, points, geometry, config)?;
        Ok(job)
    }

    /// [`ArrowJob::from_gcode`] built in place, over the job this one held (a job of
    /// ARROW is 34 KB: built where it will run, it is never copied). On an error the
    /// job is left partly built and must not be run.
    #[allow(clippy::result_large_err)]
    pub fn read_gcode<const P: usize>(
        &mut self,
        text: &[u8],
        points: &mut heapless::Vec<GcodePoint, P>,
        geometry: &ArrowGeometry<f64>,
        config: &ArrowJobConfig,
    ) -> Result<(), ArrowJobError> {
        parse(text, points).map_err(|e| ArrowJobError {
            line: e.line,
            kind: ArrowJobErrorKind::Gcode {
                kind: e.kind,
                column: e.column,
            },
        })?;
        self.plan_points(points, geometry, config)
    }

    /// A checked job from parsed points (module docs), built in place (as
    /// [`ArrowJob::read_gcode`]).
    #[allow(clippy::result_large_err)]
    pub fn plan_points(
        &mut self,
        points: &[GcodePoint],
        geometry: &ArrowGeometry<f64>,
        config: &ArrowJobConfig,
    ) -> Result<(), ArrowJobError> {
        let job = self;
        job.count = 0;
        let first_line = points.first().map_or(0, |p| p.line);
        let at = |line: u32| move |kind| ArrowJobError { line, kind };
        config
            .check()
            .map_err(|e| at(first_line)(ArrowJobErrorKind::Config(e)))?;
        let Some(first) = points.first() else {
            return Err(at(0)(ArrowJobErrorKind::Empty));
        };
        job.period_s = config.period_s;
        let start = TaskPose::new(
            first.position_m[0],
            first.position_m[1],
            first.position_m[2],
            first.angles_rad[0],
            first.angles_rad[1],
        );
        let (pose, theta_x) = split_pose(&start);
        check_pose(geometry, config, &pose, theta_x).map_err(at(first.line))?;
        job.start_joints_m = geometry
            .inverse(&pose)
            .map_err(|e| at(first.line)(ArrowJobErrorKind::Workspace(e)))?
            .map(lit::<T>);
        job.start = pose.map(lit::<T>);
        job.start_theta_x_rad = lit::<T>(theta_x);
        let mut next = 1;
        while let Some(target) = points.get(next) {
            let len = points
                .get(next..)
                .unwrap_or(&[])
                .iter()
                .take_while(|p| {
                    p.kind == target.kind
                        && (p.kind == MoveKind::Rapid || p.feed_m_s == target.feed_m_s)
                })
                .count();
            let run = points.get(next - 1..next + len).unwrap_or(&[]);
            let feed = match target.kind {
                MoveKind::Rapid => config.rapid_m_s,
                MoveKind::Feed => target.feed_m_s.min(config.rapid_m_s),
            };
            let slot = job
                .moves
                .get_mut(job.count)
                .ok_or(at(target.line)(ArrowJobErrorKind::TooLarge))?;
            *slot = plan_move(run, feed, geometry, config)?;
            job.count += 1;
            next += len;
        }
        if job.count == 0 {
            return Err(at(first_line)(ArrowJobErrorKind::Empty));
        }
        Ok(())
    }
}

/// Workspace and singularity margin at one pose.
fn check_pose(
    geometry: &ArrowGeometry<f64>,
    config: &ArrowJobConfig,
    pose: &Pose<f64>,
    theta_x_rad: f64,
) -> Result<(), ArrowJobErrorKind> {
    geometry
        .check_workspace(pose, theta_x_rad)
        .map_err(ArrowJobErrorKind::Workspace)?;
    let distance = geometry
        .singularity_distance(pose)
        .map_err(ArrowJobErrorKind::Workspace)?;
    if distance.min() < config.min_singularity_sine {
        return Err(ArrowJobErrorKind::Singular);
    }
    Ok(())
}

/// One move through `run` (its start point, then its targets) at `feed_m_s`, planned
/// and checked along its spline.
#[allow(clippy::result_large_err)]
fn plan_move<T: Float, const N: usize>(
    run: &[GcodePoint],
    feed_m_s: f64,
    geometry: &ArrowGeometry<f64>,
    config: &ArrowJobConfig,
) -> Result<ArrowMove<T, N>, ArrowJobError> {
    let line_of = |i: usize| run.get(i).or(run.last()).map_or(0, |p| p.line);
    let first_target = line_of(1);
    let at = |line: u32| move |kind| ArrowJobError { line, kind };
    let spline = TaskSpline::<T, N>::through_gcode(run, &config.spline).map_err(|e| {
        let kind = match e {
            TaskSplineError::Capacity => ArrowJobErrorKind::TooLarge,
            e => ArrowJobErrorKind::Spline(e),
        };
        let line = match e {
            TaskSplineError::RepeatedPoint(i) | TaskSplineError::NotFinitePoint(i) => line_of(i),
            _ => first_target,
        };
        at(line)(kind)
    })?;
    let plan = FeedPlan::rest_to_rest(to_f64(spline.length_m()), &config.limits(feed_m_s))
        .map_err(|e| at(first_target)(ArrowJobErrorKind::Feed(e)))?;
    for i in 0..spline.segments() {
        let (Some(a), Some(b)) = (spline.point(i), spline.point(i + 1)) else {
            continue;
        };
        // The spline strays from its chord by a fraction of it (the pyramid's worst
        // is 0.8 mm on 20 mm chords): sampling 1.5 chords' worth of steps keeps the
        // arc between samples under the step.
        let chord = to_f64((b - a).fixed_rows::<3>(0).norm());
        let samples = libm::ceil(1.5 * chord / config.check_step_m).clamp(2.0, 1e6) as u32;
        let h = spline.segment_parameter(i);
        for k in 0..=samples {
            let t = h * lit::<T>(f64::from(k) / f64::from(samples));
            let p = spline.evaluate(i, t).position.map(to_f64);
            let (pose, theta_x) = split_pose(&p);
            check_pose(geometry, config, &pose, theta_x).map_err(at(line_of(i + 1)))?;
        }
    }
    Ok(ArrowMove {
        spline,
        plan,
        line: first_target,
    })
}
