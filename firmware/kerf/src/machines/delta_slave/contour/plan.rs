//! Planning a contour job (the slower context, `f64`): the curve's or the moves' plan,
//! and every point of the cut checked against the workspace and the carriages' limits
//! (the parent module's docs).

use super::super::moves::{MovePoint, MovesPlan, MOVE_SAMPLES};
use super::super::{joint_references, DeltaJobError, DeltaSlaveConfig};
use super::{
    ContourCurve, ContourLaw, ContourPlan, PathCurve, DRAIN_PERIODS, PLAN_SAMPLES_PER_LAP,
};
use crate::control::laser::{Laser, LaserMode};
use crate::error::{positive, ConfigError};
use crate::kinematics::delta::DeltaGeometry;
use crate::trajectory::curve::Curve;
use crate::trajectory::planner::{Continuation, PlannerLimits};
use crate::trajectory::tangential::{CurveFollower, FollowerConfig, SpeedRamp, SpeedRampConfig};
use crate::trajectory::ContourError;
use nalgebra::Vector3;

/// A planned contour: everything a period needs, checked. `Copy`: loading a job copies
/// it in place, with no temporary on the control period's stack.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(in crate::machines::delta_slave) struct ContourJob {
    pub(super) path: JobPath,
    pub(super) centre_m: [f64; 3],
    pub(super) law: ContourLaw,
    pub(super) laser: LaserMode,
}

/// How a contour job's reference is made. Both variants are about a kilobyte and the
/// job is copied in place (a box would need an allocator).
#[derive(Copy, Clone, Debug, PartialEq)]
#[allow(clippy::large_enum_variant)]
pub(super) enum JobPath {
    /// A curve at constant tangential speed between two ramps.
    Curve {
        curve: PathCurve<f64>,
        theta0_rad: f64,
        follower: FollowerConfig,
        /// Periods from the start of the ramp to the start of the stop ramp.
        stop_after_periods: u32,
    },
    /// Straight moves as the look-ahead planner planned them, stepped every
    /// `period_s`.
    Moves { plan: MovesPlan, period_s: f64 },
}

impl ContourJob {
    /// Where its cut ends (relative to the job's centre, m) and how the next part
    /// takes over there; `None` when it ends at rest.
    pub(in crate::machines::delta_slave) fn join(&self) -> Option<([f64; 2], Continuation<2>)> {
        match &self.path {
            JobPath::Moves { plan, .. } => plan.join().map(|j| (plan.cut_end_m(), j)),
            JobPath::Curve { .. } => None,
        }
    }

    /// Whether it continues the part before at its join (a program of moves cut as
    /// several parts).
    pub(in crate::machines::delta_slave) fn continues(&self) -> bool {
        matches!(&self.path, JobPath::Moves { plan, .. } if plan.before().is_some())
    }

    /// Plans `plan` for `config` (module docs). Returns the job and the start point.
    pub(in crate::machines::delta_slave) fn plan(
        config: &DeltaSlaveConfig,
        plan: &ContourPlan<'_>,
    ) -> Result<(Self, [f64; 3]), DeltaJobError> {
        if !plan.centre_m.iter().all(|c| c.is_finite()) {
            return Err(config_error(ConfigError::not_finite("centre_m")));
        }
        Laser::<f64>::new(&config.laser)
            .and_then(|laser| laser.mode(&plan.laser))
            .map_err(|e| DeltaJobError::Laser(e.kind))?;
        let geometry =
            DeltaGeometry::<f64>::new(&config.delta).map_err(|_| DeltaJobError::OtherMachine)?;
        let check = PointCheck {
            geometry: &geometry,
            centre: Vector3::from(plan.centre_m),
            config,
        };
        let (path, start) = match plan.curve {
            ContourCurve::Moves {
                points,
                junction_deviation_m,
                lookahead,
                before,
            } => plan_moves(
                &check,
                plan,
                points,
                junction_deviation_m,
                lookahead,
                before,
            )?,
            ContourCurve::Closed {
                efd,
                theta0_rad,
                laps,
            } => {
                let laps = positive("laps", laps).map_err(config_error)?;
                plan_curve(&check, plan, PathCurve::Closed(*efd), theta0_rad, laps)?
            }
            ContourCurve::Open(path) => plan_curve(&check, plan, PathCurve::Open(*path), 0.0, 1.0)?,
        };
        Ok((
            Self {
                path,
                centre_m: plan.centre_m,
                law: plan.law,
                laser: plan.laser,
            },
            start,
        ))
    }

    /// The law.
    pub(in crate::machines::delta_slave) fn law(&self) -> ContourLaw {
        self.law
    }

    /// Periods from the end of the approach until the job is done: the ramps and the
    /// cruise (the moves), and [`DRAIN_PERIODS`] more.
    fn periods(&self) -> u32 {
        match &self.path {
            JobPath::Curve {
                follower,
                stop_after_periods,
                ..
            } => {
                // Checked when the job was planned.
                let ramp_periods =
                    SpeedRamp::<f64>::new(&follower.ramp).map_or(0, |r| r.ramp_periods());
                stop_after_periods
                    .saturating_add(ramp_periods)
                    .saturating_add(DRAIN_PERIODS)
            }
            // The period whose time reaches the end is at rest (bounded when planned).
            JobPath::Moves { plan, period_s } => {
                (libm::floor(plan.duration_s() / period_s) as u32).saturating_add(1 + DRAIN_PERIODS)
            }
        }
    }

    /// The control period the job was planned at, s.
    fn period_s(&self) -> f64 {
        match &self.path {
            JobPath::Curve { follower, .. } => follower.ramp.ts_s,
            JobPath::Moves { period_s, .. } => *period_s,
        }
    }

    /// The cut's point at `fraction` of one lap (a closed curve, from θ0), of the
    /// open path or of the moves' length, m.
    fn point_m(&self, fraction: f64) -> [f64; 3] {
        let p = match &self.path {
            JobPath::Curve {
                curve, theta0_rad, ..
            } => {
                let p = curve
                    .evaluate(theta0_rad + curve.span() * fraction)
                    .position;
                [p.x, p.y]
            }
            JobPath::Moves { plan, .. } => plan.point_at(fraction),
        };
        let [x, y, z] = self.centre_m;
        [x + p[0], y + p[1], z]
    }

    /// Whether the cut ends where it starts.
    fn is_closed(&self) -> bool {
        match &self.path {
            JobPath::Curve { curve, .. } => curve.is_closed(),
            JobPath::Moves { plan, .. } => plan.is_closed(),
        }
    }
}

fn config_error(e: ConfigError) -> DeltaJobError {
    DeltaJobError::Contour(ContourError::Config(e))
}

/// What a plan checks a point of the cut against: reach, travel, singularity and the
/// carriages' speed and acceleration limits.
struct PointCheck<'a> {
    geometry: &'a DeltaGeometry<f64>,
    centre: Vector3<f64>,
    config: &'a DeltaSlaveConfig,
}

impl PointCheck<'_> {
    /// Checks the planar point `p` (relative to the centre) passed at `velocity` and
    /// `acceleration`; returns it in the workspace.
    fn check(
        &self,
        p: nalgebra::Vector2<f64>,
        velocity: nalgebra::Vector2<f64>,
        acceleration: nalgebra::Vector2<f64>,
    ) -> Result<[f64; 3], DeltaJobError> {
        let planar = |w: nalgebra::Vector2<f64>| Vector3::new(w.x, w.y, 0.0);
        let point = self.centre + planar(p);
        let point_m: [f64; 3] = point.into();
        let joints = joint_references(
            self.geometry,
            &point,
            &planar(velocity),
            &planar(acceleration),
        )
        .map_err(|error| DeltaJobError::ContourUnreachable { point_m, error })?;
        let limits = &self.config.joints;
        for (axis, r) in joints.iter().enumerate() {
            if libm::fabs(r.velocity) > limits.speed_limit_m_s
                || libm::fabs(r.acceleration) > limits.accel_limit_m_s2
            {
                return Err(DeltaJobError::ContourTooFast {
                    point_m,
                    axis: axis as u8,
                });
            }
        }
        Ok(point_m)
    }
}

/// A curve's path, from `theta0_rad` for `laps` (one for an open path): its length,
/// curvature and ramps, then [`PLAN_SAMPLES_PER_LAP`] checked points per lap.
fn plan_curve(
    check: &PointCheck<'_>,
    plan: &ContourPlan<'_>,
    curve: PathCurve<f64>,
    theta0_rad: f64,
    laps: f64,
) -> Result<(JobPath, [f64; 3]), DeltaJobError> {
    let contour = DeltaJobError::Contour;
    let period_s = check.config.joints.period_s;
    let follower = FollowerConfig {
        ramp: SpeedRampConfig {
            speed_m_s: plan.speed_m_s,
            accel_m_s2: plan.accel_m_s2,
            jerk_m_s3: plan.jerk_m_s3,
            ts_s: period_s,
        },
        accel_limit_m_s2: check.config.joints.accel_limit_m_s2,
        newton_steps: check.config.contour.newton_steps,
    };
    // Length against the step, curvature against the speed, the ramp, θ0.
    CurveFollower::new(curve, &follower, theta0_rad).map_err(contour)?;
    let ramp = SpeedRamp::<f64>::new(&follower.ramp).map_err(config_error)?;
    let span = curve.span();
    let lap_m = curve.arc_length(0.0, span, curve.pieces().saturating_mul(64));
    let length_m = laps * lap_m;
    let cruise_m = length_m - 2.0 * ramp.ramp_distance_m();
    let cruise_periods = cruise_m / (plan.speed_m_s * period_s);
    let field = if curve.is_closed() { "laps" } else { "curve" };
    if !(cruise_m >= 0.0 && cruise_periods < f64::from(u32::MAX / 2)) {
        // Too short for the ramps (or too long to count).
        return Err(config_error(ConfigError::out_of_range(field)));
    }
    let stop_after_periods = ramp
        .ramp_periods()
        .checked_add(libm::round(cruise_periods) as u32)
        .ok_or(config_error(ConfigError::out_of_range(field)))?;
    let samples = libm::ceil(laps * PLAN_SAMPLES_PER_LAP as f64) as usize;
    let (v, a) = (plan.speed_m_s, plan.accel_m_s2);
    let mut start = [0.0; 3];
    for i in 0..=samples {
        let theta = theta0_rad + span * laps * i as f64 / samples as f64;
        let s = curve.evaluate(theta);
        let sigma = s.d1.norm();
        let tangent = s.d1 / sigma;
        let normal = nalgebra::Vector2::new(-tangent.y, tangent.x);
        let curvature = s.d1.perp(&s.d2) / (sigma * sigma * sigma);
        let point_m = check.check(
            s.position,
            tangent * v,
            normal * (v * v * curvature) + tangent * a,
        )?;
        if i == 0 {
            start = point_m;
        }
    }
    let path = JobPath::Curve {
        curve,
        theta0_rad,
        follower,
        stop_after_periods,
    };
    Ok((path, start))
}

/// A program of moves: planned by the look-ahead planner at the plan's speed, ramps
/// and `junction_deviation_m`, each move checked at [`MOVE_SAMPLES`] points at its
/// cruise speed and the ramps' acceleration.
fn plan_moves(
    check: &PointCheck<'_>,
    plan: &ContourPlan<'_>,
    points: &[MovePoint],
    junction_deviation_m: f64,
    lookahead: usize,
    before: Option<Continuation<2>>,
) -> Result<(JobPath, [f64; 3]), DeltaJobError> {
    let limits = PlannerLimits {
        max_speed_m_s: plan.speed_m_s,
        accel_m_s2: plan.accel_m_s2,
        junction_deviation_m,
        jerk_m_s3: plan.jerk_m_s3,
    };
    let moves =
        MovesPlan::plan(points, &limits, lookahead, before).map_err(DeltaJobError::Contour)?;
    let period_s = check.config.joints.period_s;
    let periods = moves.duration_s() / period_s;
    if periods.partial_cmp(&f64::from(u32::MAX / 2)) != Some(core::cmp::Ordering::Less) {
        return Err(config_error(ConfigError::out_of_range("curve")));
    }
    let start = moves.start_m();
    let start = check.check(start.into(), Default::default(), Default::default())?;
    for (block, profile) in moves.moves() {
        let unit = nalgebra::Vector2::from(block.unit);
        for i in 0..=MOVE_SAMPLES {
            let s = block.length_m * i as f64 / MOVE_SAMPLES as f64;
            check.check(
                block.point_at(s).into(),
                unit * profile.cruise_m_s,
                unit * moves.accel_m_s2(),
            )?;
        }
    }
    let path = JobPath::Moves {
        plan: moves,
        period_s,
    };
    Ok((path, start))
}

impl super::super::DeltaJob {
    /// Time from `Start` until the job is over, s: the approach (none for a part that
    /// continues another), then the straight moves, the contour's two speed ramps and
    /// its cruise between (in whole control periods, as the machine counts them), or
    /// the program of moves up to the end of its cut.
    pub fn duration_s(&self) -> f64 {
        let moves_s: f64 = self.moves.iter().map(|m| m.duration_s).sum();
        let contour_s = self
            .contour
            .as_ref()
            .map_or(0.0, |c| f64::from(c.periods()) * c.period_s());
        // A part that continues another goes on from its join: no approach.
        let approach_s = match self.contour.as_ref().is_some_and(ContourJob::continues) {
            true => 0.0,
            false => self.approach_s,
        };
        approach_s + moves_s + contour_s
    }

    /// Where a contour job cuts: the point at `fraction` (0 at the start, 1 at the end)
    /// of one lap of a closed contour or of an open path, m (what a preview draws).
    /// `None` for straight moves, or a fraction outside [0, 1].
    pub fn contour_point_m(&self, fraction: f64) -> Option<[f64; 3]> {
        let contour = self.contour.as_ref()?;
        (0.0..=1.0)
            .contains(&fraction)
            .then(|| contour.point_m(fraction))
    }

    /// Whether a contour job's curve is closed (`None` for straight moves).
    pub fn contour_is_closed(&self) -> Option<bool> {
        self.contour.as_ref().map(ContourJob::is_closed)
    }
}
