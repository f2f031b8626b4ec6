//! Parts cut as programs of straight moves, corners kept sharp: what a laser program
//! draws, followed as it is drawn rather than fitted with a curve.
//!
//! Planning (the slower context, `f64`): the look-ahead planner
//! ([`crate::trajectory::planner`]) plans the whole part when the job is loaded: each
//! move at its feed (at most the job's speed), each corner at the speed its
//! junction deviation allows, every speed change a jerk-limited ramp, the last move
//! ending at rest. What a control period needs of each move is kept: its entry and
//! cruise speeds (the cruise is the planner's search, which a period could not
//! afford). Every move is then checked at [`MOVE_SAMPLES`] points for reach and for
//! the carriages' speed and acceleration at its cruise speed and the path's
//! acceleration (the corner itself changes only the direction of a speed the
//! junction limit keeps small).
//!
//! Running (each period): the planner's follower takes the moves one after another,
//! each profile rebuilt from its stored speeds (two ramps, no search); the reference is
//! the point along the move, the velocity and acceleration along its direction.
//!
//! # A run longer than a part: streamed parts
//!
//! A part may end with a look-ahead: its last points are the next part's first, room
//! to stop in. It is planned over all its points, ending at rest after the look-ahead,
//! so the cut reaches its last point (the join) at the speed that room allows; what
//! the next part needs of it is kept ([`Continuation`]: the last cut move's direction
//! and feed, the speed at the join), and the next part, loaded after it, is planned
//! from the join at that speed ([`Planner::continue_from`]; refused when its own moves
//! cannot take that speed). When that part is queued before the join is passed
//! (`MovesRun::arm`), the run hands over there: the period in which the reference
//! enters the look-ahead is its last, and the next part's follower takes over at the
//! same time past the join, the references going on without a gap. Otherwise the run
//! brakes in its look-ahead with the beam off (the next part cuts it) and the part that
//! comes too late is refused at its start.

use crate::control::contouring::TaskReference;
use crate::error::ConfigError;
use crate::scalar::{lit, Float};
use crate::trajectory::planner::{
    Block, Continuation, MoveSource, PlanError, PlanFollower, Planner, PlannerLimits, SpeedProfile,
};
use crate::trajectory::ContourError;
use nalgebra::Vector3;

/// Points a program of moves can carry (the first is where it starts).
pub const MOVE_POINTS: usize = 32;

/// Points per move at which a plan checks reach and limits (plus its end).
pub const MOVE_SAMPLES: usize = 16;

/// A point of a program of moves, and the feed of the move that ends there (the first
/// point's is not used).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MovePoint {
    /// Where, relative to the job's centre, m.
    pub point_m: [f64; 2],
    /// The feed of the move to it, m/s.
    pub feed_m_s: f64,
}

/// A part's moves as planned: the points and, per move (from point k to k + 1), its
/// entry and cruise speeds; the points that are cut (the rest, the look-ahead, are
/// room to stop in, which the next part cuts), and where the next part takes over.
/// `Copy`: a job is copied in place.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(super) struct MovesPlan {
    points_m: [[f64; 2]; MOVE_POINTS],
    entry_m_s: [f64; MOVE_POINTS],
    cruise_m_s: [f64; MOVE_POINTS],
    points: usize,
    /// Points cut (the first `cut` of `points`).
    cut: usize,
    limits: PlannerLimits,
    /// What the next part continues from: the last cut move and the speed at its end
    /// (`None` without a look-ahead: the part ends at rest).
    join: Option<Continuation<2>>,
    /// The part before this one, when it continues one.
    before: Option<Continuation<2>>,
}

impl MovesPlan {
    /// Plans `points` under `limits` (module docs), the last `lookahead` of them room to
    /// stop in, continuing `before` when it is given.
    ///
    /// A point on the one before adds no move and is left out.
    ///
    /// Errors: fewer than two points to cut, or more than [`MOVE_POINTS`] in all; a
    /// point or feed not finite (`NotFinitePoint`); every point to cut on the first
    /// (`ZeroLength`); a feed not above zero, a limit that is not a limit or a `before`
    /// not finite (`Config`, naming it); `before`'s speed more than the moves can take
    /// (`SpeedAboveCurvatureLimit`, with the most they can).
    pub(super) fn plan(
        points: &[MovePoint],
        limits: &PlannerLimits,
        lookahead: usize,
        before: Option<Continuation<2>>,
    ) -> Result<Self, ContourError> {
        if points.len() < 2 || lookahead + 2 > points.len() {
            return Err(ContourError::TooFewPoints);
        }
        if points.len() > MOVE_POINTS {
            return Err(ContourError::Capacity);
        }
        let first = points.first().map_or([0.0; 2], |p| p.point_m);
        let mut planner = Planner::<2, MOVE_POINTS>::new(limits, first)?;
        if let Some(b) = before {
            planner.continue_from(b)?;
        }
        let mut plan = Self {
            points_m: [[0.0; 2]; MOVE_POINTS],
            entry_m_s: [0.0; MOVE_POINTS],
            cruise_m_s: [0.0; MOVE_POINTS],
            points: 1,
            cut: 1,
            limits: *limits,
            join: None,
            before,
        };
        // Points of the file that are cut: those before the look-ahead.
        let cut_in_file = points.len() - lookahead;
        plan.points_m[0] = first;
        for (i, p) in points.iter().enumerate() {
            if !(p.point_m.iter().all(|c| c.is_finite()) && p.feed_m_s.is_finite()) {
                return Err(ContourError::NotFinitePoint(i));
            }
            if i == 0 {
                continue;
            }
            let before = planner.len();
            match planner.push(p.point_m, p.feed_m_s) {
                Ok(()) if planner.len() > before => {}
                // A move of no length adds nothing (as a controller reads it).
                Ok(()) => continue,
                Err(PlanError::NoFeed) => return Err(ConfigError::out_of_range("feed_m_s").into()),
                Err(PlanError::NotFinite) => return Err(ContourError::NotFinitePoint(i)),
                Err(PlanError::Full) => return Err(ContourError::Capacity),
            }
            if let Some(stored) = plan.points_m.get_mut(plan.points) {
                *stored = p.point_m;
                plan.points += 1;
            }
            if i < cut_in_file {
                plan.cut = plan.points;
            }
        }
        if plan.cut < 2 {
            return Err(ContourError::ZeroLength);
        }
        // The part before ends at its speed: the plan must be able to take it.
        if let Some(b) = before {
            let limit = planner.front_limit_m_s();
            if b.speed_m_s > limit * (1.0 + 1e-9) + 1e-12 {
                return Err(ContourError::SpeedAboveCurvatureLimit {
                    max_speed_m_s: limit,
                });
            }
        }
        let blocks = planner.blocks();
        let mut last_cut = None;
        for (k, block) in blocks.enumerate() {
            if let (Some(entry), Some(cruise)) =
                (plan.entry_m_s.get_mut(k), plan.cruise_m_s.get_mut(k))
            {
                *entry = block.entry_m_s;
                *cruise = block.profile(limits).cruise_m_s;
            }
            // Move k ends at point k + 1: the last cut move ends at the last cut point.
            if k + 2 == plan.cut && plan.cut < plan.points {
                last_cut = Some(Continuation {
                    unit: block.unit,
                    nominal_m_s: block.nominal_m_s,
                    speed_m_s: block.exit_m_s,
                });
            }
        }
        plan.join = last_cut;
        Ok(plan)
    }

    /// What the next part continues from (`None`: this part ends at rest).
    pub(super) fn join(&self) -> Option<Continuation<2>> {
        self.join
    }

    /// The part this one continues (`None`: it starts at rest).
    pub(super) fn before(&self) -> Option<Continuation<2>> {
        self.before
    }

    /// Where the cut ends, m (relative to the job's centre).
    pub(super) fn cut_end_m(&self) -> [f64; 2] {
        self.points_m
            .get(self.cut.saturating_sub(1))
            .copied()
            .unwrap_or([0.0; 2])
    }

    /// Moves cut (those before the look-ahead).
    pub(super) fn cut_moves(&self) -> usize {
        self.cut.saturating_sub(1)
    }

    /// Move `k` (from point k to k + 1) and its profile; `None` past the last.
    fn planned(&self, k: usize) -> Option<(Block<2>, SpeedProfile)> {
        let next = k.checked_add(1).filter(|&n| n < self.points)?;
        let (start_m, end_m) = (*self.points_m.get(k)?, *self.points_m.get(next)?);
        let delta = [end_m[0] - start_m[0], end_m[1] - start_m[1]];
        // As the planner measured it, to the last bit (the profile fits that length).
        let length_m = libm::sqrt(delta[0] * delta[0] + delta[1] * delta[1]);
        let (entry, cruise) = (*self.entry_m_s.get(k)?, *self.cruise_m_s.get(k)?);
        // The last move ends at rest.
        let exit = match next < self.points - 1 {
            true => *self.entry_m_s.get(next)?,
            false => 0.0,
        };
        let block = Block {
            start_m,
            end_m,
            length_m,
            unit: delta.map(|d| d / length_m),
            nominal_m_s: cruise,
            max_entry_m_s: entry,
            entry_m_s: entry,
            exit_m_s: exit,
        };
        let profile = SpeedProfile::with_cruise(length_m, entry, exit, cruise, &self.limits);
        Some((block, profile))
    }

    /// The planned moves, in order.
    pub(super) fn moves(&self) -> impl Iterator<Item = (Block<2>, SpeedProfile)> + '_ {
        (0..self.points).map_while(|k| self.planned(k))
    }

    /// The largest acceleration along the path, m/s².
    pub(super) fn accel_m_s2(&self) -> f64 {
        self.limits.accel_m_s2
    }

    /// Duration of the moves cut (a look-ahead is the next part's), s.
    pub(super) fn duration_s(&self) -> f64 {
        self.moves()
            .take(self.cut_moves())
            .map(|(_, p)| p.duration_s())
            .sum()
    }

    /// Where the part starts, m (relative to the job's centre).
    pub(super) fn start_m(&self) -> [f64; 2] {
        self.points_m[0]
    }

    /// Whether its cut ends where it starts.
    pub(super) fn is_closed(&self) -> bool {
        self.cut_end_m() == self.points_m[0]
    }

    /// The point at `fraction` of the cut's length, m (relative to the job's centre).
    pub(super) fn point_at(&self, fraction: f64) -> [f64; 2] {
        let cut = self.cut_moves();
        let total: f64 = self.moves().take(cut).map(|(b, _)| b.length_m).sum();
        let mut left = fraction.clamp(0.0, 1.0) * total;
        let mut last = self.start_m();
        for (block, _) in self.moves().take(cut) {
            if left <= block.length_m {
                return block.point_at(left);
            }
            left -= block.length_m;
            last = block.end_m;
        }
        last
    }
}

/// A program's moves as the follower takes them.
#[derive(Copy, Clone, Debug)]
pub(super) struct MovesCursor {
    pub(super) plan: MovesPlan,
    next: usize,
}

impl MoveSource<2> for MovesCursor {
    fn next_move(&mut self) -> Option<(Block<2>, SpeedProfile)> {
        let planned = self.plan.planned(self.next)?;
        self.next = self.next.saturating_add(1);
        Some(planned)
    }

    fn bound(&self) -> usize {
        MOVE_POINTS
    }
}

/// How a period of a program of moves ends.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(super) enum MovesStep {
    /// Moving, or coming to rest.
    Moving,
    /// At rest where its last move ended.
    AtRest,
    /// The reference has passed the join and the next part continues from it: the
    /// time since the join, s (the next part's follower takes it over).
    Join(f64),
}

/// Taps between the newest reference and the present one (the preview's window).
const LEAD_TAPS: u8 = 2;

/// A program of moves in progress.
#[derive(Clone, Debug)]
pub(super) struct MovesRun {
    follower: PlanFollower<2>,
    pub(super) cursor: MovesCursor,
    /// Whether the next part continues this one at its join (queued in time).
    handover: bool,
    /// References made in the look-ahead (the present one lags the newest by
    /// [`LEAD_TAPS`]): the beam is off from the first there.
    lookahead_taps: u8,
}

impl MovesRun {
    /// An idle run (no move).
    pub(super) fn idle() -> Result<Self, ConfigError> {
        let limits = PlannerLimits {
            max_speed_m_s: 1e-3,
            accel_m_s2: 1.0,
            junction_deviation_m: 1e-5,
            jerk_m_s3: f64::INFINITY,
        };
        let plan = MovesPlan {
            points_m: [[0.0; 2]; MOVE_POINTS],
            entry_m_s: [0.0; MOVE_POINTS],
            cruise_m_s: [0.0; MOVE_POINTS],
            points: 0,
            cut: 0,
            limits,
            join: None,
            before: None,
        };
        Ok(Self {
            follower: PlanFollower::new(1e-3, [0.0; 2])?,
            cursor: MovesCursor { plan, next: 0 },
            handover: false,
            lookahead_taps: 0,
        })
    }

    /// Whether the present reference is cut (not yet in the look-ahead).
    pub(super) fn cutting(&self) -> bool {
        self.lookahead_taps <= LEAD_TAPS
    }

    /// Whether `next` continues this run at its join, not yet passed; if so the run
    /// hands over there instead of braking in its look-ahead.
    pub(super) fn arm(&mut self, next: &MovesPlan) -> bool {
        let join = self.cursor.plan.join();
        let ahead = self.cursor.next <= self.cursor.plan.cut_moves();
        self.handover = ahead
            && join.is_some()
            && next.before() == join
            && next.start_m() == self.cursor.plan.cut_end_m();
        self.handover
    }

    /// The next part does not come (it was dropped): brake in the look-ahead.
    pub(super) fn disarm(&mut self) {
        self.handover = false;
    }

    /// Makes this the run of `plan` at rest at its start, stepping every `period_s`
    /// (the plan is copied in place). Out of line, as the step below.
    #[inline(never)]
    pub(super) fn start(&mut self, plan: &MovesPlan, period_s: f64) -> Result<(), ConfigError> {
        self.follower = PlanFollower::new(period_s, plan.start_m())?;
        self.cursor.plan = *plan;
        self.cursor.next = 0;
        self.handover = false;
        self.lookahead_taps = 0;
        Ok(())
    }

    /// Makes this the run of `plan`, which continues the part before at its join, the
    /// newest reference `since_join_s` past it: the next step is a period further.
    #[inline(never)]
    pub(super) fn resume(
        &mut self,
        plan: &MovesPlan,
        period_s: f64,
        since_join_s: f64,
    ) -> Result<(), ConfigError> {
        self.start(plan, period_s)?;
        self.follower = PlanFollower::resuming(period_s, plan.start_m(), since_join_s)?;
        Ok(())
    }

    /// The reference at rest at the start (relative to `centre`).
    pub(super) fn at_rest<T: Float>(&self, centre: &Vector3<T>) -> TaskReference<T> {
        let [x, y] = self.cursor.plan.start_m();
        TaskReference {
            position: centre + Vector3::new(lit(x), lit(y), T::zero()),
            velocity: Vector3::zeros(),
            acceleration: Vector3::zeros(),
            jerk: Vector3::zeros(),
        }
    }

    /// One period's reference (relative to `centre`) and how the run stands. Out of
    /// line: its frame (a move and its profile, in f64) is paid only by a program of
    /// moves, not by every contour's period.
    #[inline(never)]
    pub(super) fn step<T: Float>(&mut self, centre: &Vector3<T>) -> (TaskReference<T>, MovesStep) {
        let s = self.follower.step(&mut self.cursor);
        let cut = self.cursor.plan.cut_moves();
        let in_lookahead = self.cursor.next > cut || !self.follower.is_moving();
        if in_lookahead && self.cursor.plan.join().is_some() {
            self.lookahead_taps = self.lookahead_taps.saturating_add(1);
        }
        let planar =
            |v: [f64; 2], scale: f64| Vector3::new(lit(v[0] * scale), lit(v[1] * scale), T::zero());
        let reference = TaskReference {
            position: centre + planar(s.position_m, 1.0),
            velocity: planar(s.unit, s.speed_m_s),
            acceleration: planar(s.unit, s.accel_m_s2),
            jerk: Vector3::zeros(),
        };
        if self.handover && self.cursor.next == cut + 1 {
            // Past the join, in the first move of the look-ahead: the next part's first.
            let since = self.follower.time_in_move_s().unwrap_or(0.0);
            return (reference, MovesStep::Join(since));
        }
        if self.cursor.next > cut + 1 {
            // A first look-ahead move shorter than a period's travel was crossed whole:
            // the time past the join is not the next part's, which then starts at rest.
            self.handover = false;
        }
        let taken = self.cursor.next.saturating_add(1) >= self.cursor.plan.points;
        match taken && !self.follower.is_moving() {
            true => (reference, MovesStep::AtRest),
            false => (reference, MovesStep::Moving),
        }
    }
}
