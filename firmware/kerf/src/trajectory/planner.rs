//! Look-ahead planning of straight moves, as CNC controllers plan them (grbl's planner
//! buffer, Klipper's look-ahead): each move at its own feed, corners passed at the
//! speed a junction-deviation limit allows instead of stopping or rounding them, and
//! every speed change within the machine's acceleration. Programs of any length go
//! through a buffer of `N` moves: a move is planned as it is added, and the executor
//! takes moves from the front while the rest are re-planned.
//!
//! # Corners (junction deviation)
//!
//! A corner between two moves is passed at the speed at which a circle tangent to both
//! moves, whose nearest point lies `δ` ([`PlannerLimits::junction_deviation_m`]) from
//! the corner, could be followed at the machine's acceleration `a`: with `α` half the
//! angle between the two legs (from the corner back along the first move and along
//! the second), the circle's radius is `r = δ sin α / (1 − sin α)` and the speed
//! `v = √(a r)`. A straight continuation (`α` = 90°) sets no limit; a full reversal
//! (`α` = 0) stops. The path itself stays the programmed polyline: `δ` only chooses a
//! corner's speed. (grbl's `junction_deviation`; Klipper sets the same from a square
//! corner's speed, `δ = v²(√2 − 1)/a`.)
//!
//! # Speeds along the buffer
//!
//! Each move `i` of length `L_i` has a nominal speed (its feed, at most the machine's
//! largest) and an entry limit (the corner before it; the first move of a program
//! starts from rest). The plan is the fastest under these limits with constant
//! acceleration `±a`: a backward pass from the last move, which must be able to stop
//! (nothing is known after it), gives each entry `v_i ≤ √(v_{i+1}² + 2 a L_i)`; a
//! forward pass from the first, whose entry is fixed (the executor is already at
//! it), gives `v_{i+1} ≤ √(v_i² + 2 a L_i)`. Each move is then a trapezoid (a
//! triangle when it is too short to cruise): accelerate from its entry, cruise at
//! `min(nominal, √((2 a L + v_in² + v_out²)/2))`, decelerate to its exit. With
//! acceleration bounded and speed limits along the path, this bang–bang profile is
//! the time-optimal one.
//!
//! # Jerk-limited ramps
//!
//! With a finite jerk `j` ([`PlannerLimits::jerk_m_s3`]) each speed change is an
//! S-curve instead of a constant acceleration: the acceleration rises at `j` to
//! `a_p = min(a, √(j Δv))`, holds, and falls at `j` back to zero, so it is continuous
//! across the moves. The change takes `T = Δv/a_p + a_p/j` and, the speed being
//! symmetric about the ramp's middle, covers `(v₀ + v₁)/2 · T`. The passes and the
//! cruise speed use that distance in place of `(v₁² − v₀²)/2a` (the largest speed
//! reachable within a length, or the largest cruise that leaves room for both ramps,
//! found by bisection: the distance grows with the speed); an infinite jerk gives the
//! constant-acceleration ramps back exactly. (docs/equations.md §17.)
//!
//! # Following the plan
//!
//! [`PlanFollower`] samples the plan once per control period: the point along the
//! current move at the time since it began (its trapezoid's distance), carrying the
//! time left over at a move's end into the next, which it takes from the planner only
//! then (so the planner looks as far ahead as it can). A move taken while it was the
//! last one planned ends at rest, as it was planned to: when the program is fed more
//! slowly than it runs, the machine stops and starts again rather than overrun.

use crate::error::{positive, ConfigError};
use heapless::Deque;

/// The machine's limits for the planner.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PlannerLimits {
    /// The largest speed along the path, m/s (a move's feed above it is lowered).
    pub max_speed_m_s: f64,
    /// Acceleration along the path, m/s².
    pub accel_m_s2: f64,
    /// How far from a corner the circle that sets its speed passes, m (module docs).
    pub junction_deviation_m: f64,
    /// The rate of change of the acceleration in the ramps, m/s³; `f64::INFINITY` for
    /// ramps of constant acceleration (module docs).
    pub jerk_m_s3: f64,
}

impl PlannerLimits {
    /// Checked: every limit finite and positive (the jerk may be infinite).
    ///
    /// Errors: the field that is not.
    pub fn check(&self) -> Result<(), ConfigError> {
        positive("max_speed_m_s", self.max_speed_m_s)?;
        positive("accel_m_s2", self.accel_m_s2)?;
        positive("junction_deviation_m", self.junction_deviation_m)?;
        if self.jerk_m_s3 != f64::INFINITY {
            positive("jerk_m_s3", self.jerk_m_s3)?;
        }
        Ok(())
    }

    /// The speed at which a corner between moves in the unit directions `from` and
    /// `to` is passed, m/s (`f64::INFINITY` for a straight continuation).
    pub fn corner_speed_m_s<const D: usize>(&self, from: &[f64; D], to: &[f64; D]) -> f64 {
        // cos of the angle between the legs: from the corner back along `from`, and
        // along `to`; sin α = sin(angle / 2) = √((1 − cos) / 2).
        let cos_legs = -dot(from, to);
        if cos_legs <= -1.0 + 1e-12 {
            return f64::INFINITY;
        }
        let sin_half = libm::sqrt(0.5 * (1.0 - cos_legs).max(0.0));
        if sin_half <= 1e-12 {
            return 0.0;
        }
        let radius_m = self.junction_deviation_m * sin_half / (1.0 - sin_half);
        libm::sqrt(self.accel_m_s2 * radius_m)
    }

    /// The largest speed reachable from `from_m_s` within `length_m` (the passes'
    /// limit), m/s.
    pub fn reach_m_s(&self, from_m_s: f64, length_m: f64) -> f64 {
        let a = self.accel_m_s2;
        let constant = libm::sqrt(from_m_s * from_m_s + 2.0 * a * length_m);
        if self.jerk_m_s3 == f64::INFINITY {
            return constant;
        }
        // An S-curve covers more length than a constant acceleration for the same
        // change: its reach lies between the start and the constant one's.
        largest_within(from_m_s, constant, |v| {
            Ramp::new(from_m_s, v, a, self.jerk_m_s3).length_m() <= length_m
        })
    }
}

/// The largest `v` in `[lo, hi]` for which `fits` holds, `fits` holding at `lo` and
/// failing past some point (bisection to the last bit, 64 halvings at most).
fn largest_within(lo: f64, hi: f64, fits: impl Fn(f64) -> bool) -> f64 {
    if fits(hi) {
        return hi;
    }
    let (mut lo, mut hi) = (lo, hi);
    for _ in 0..64 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if fits(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// One speed change, from `from` to `to`, at most `accel` and `jerk` (an S-curve:
/// module docs).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Ramp {
    /// Speed at its start, m/s.
    pub from_m_s: f64,
    /// Speed at its end, m/s.
    pub to_m_s: f64,
    /// Its largest acceleration, m/s².
    pub peak_m_s2: f64,
    /// The jerk of its rising and falling parts, m/s³ (0 where they take no time).
    pub jerk_m_s3: f64,
    /// Time of its rising (and of its falling) part, s.
    pub rise_s: f64,
    /// Time at the peak acceleration, s.
    pub hold_s: f64,
}

impl Ramp {
    /// The change from `from_m_s` to `to_m_s` at acceleration `accel` and `jerk`
    /// (`f64::INFINITY`: constant acceleration).
    pub fn new(from_m_s: f64, to_m_s: f64, accel: f64, jerk: f64) -> Self {
        let change = (to_m_s - from_m_s).abs();
        let peak = if jerk == f64::INFINITY {
            accel
        } else {
            accel.min(libm::sqrt(jerk * change))
        };
        let (rise_s, hold_s, jerk) = if change == 0.0 || peak <= 0.0 {
            (0.0, 0.0, 0.0)
        } else if jerk == f64::INFINITY {
            (0.0, change / peak, 0.0)
        } else {
            let rise = peak / jerk;
            (rise, (change / peak - rise).max(0.0), jerk)
        };
        Self {
            from_m_s,
            to_m_s,
            peak_m_s2: peak,
            jerk_m_s3: jerk,
            rise_s,
            hold_s,
        }
    }

    /// Duration, s.
    pub fn duration_s(&self) -> f64 {
        2.0 * self.rise_s + self.hold_s
    }

    /// Length covered, m: the mean of the two speeds over the duration.
    pub fn length_m(&self) -> f64 {
        0.5 * (self.from_m_s + self.to_m_s) * self.duration_s()
    }

    /// Distance and speed `t_s` after its start (held at its end past it), m and m/s.
    pub fn at(&self, t_s: f64) -> (f64, f64) {
        let sign = if self.to_m_s >= self.from_m_s {
            1.0
        } else {
            -1.0
        };
        let (j, a) = (sign * self.jerk_m_s3, sign * self.peak_m_s2);
        // max/min rather than clamp: no panic on a NaN bound in the control period.
        let t = t_s.max(0.0).min(self.duration_s());
        // Rising: the acceleration grows at j.
        let t1 = t.min(self.rise_s);
        let mut s = self.from_m_s * t1 + j * t1 * t1 * t1 / 6.0;
        let mut v = self.from_m_s + 0.5 * j * t1 * t1;
        // Holding the peak.
        let t2 = (t - self.rise_s).max(0.0).min(self.hold_s);
        s += v * t2 + 0.5 * a * t2 * t2;
        v += a * t2;
        // Falling back to zero acceleration.
        let t3 = (t - self.rise_s - self.hold_s).max(0.0);
        s += v * t3 + 0.5 * a * t3 * t3 - j * t3 * t3 * t3 / 6.0;
        v += a * t3 - 0.5 * j * t3 * t3;
        (s, v)
    }

    /// Acceleration `t_s` after its start (zero outside it), m/s².
    pub fn accel_at(&self, t_s: f64) -> f64 {
        if !(0.0..self.duration_s()).contains(&t_s) {
            return 0.0;
        }
        let sign = if self.to_m_s >= self.from_m_s {
            1.0
        } else {
            -1.0
        };
        // Rising at j, holding the peak, falling at j (as in `at`).
        let magnitude = if t_s < self.rise_s {
            self.jerk_m_s3 * t_s
        } else if t_s < self.rise_s + self.hold_s {
            self.peak_m_s2
        } else {
            self.peak_m_s2 - self.jerk_m_s3 * (t_s - self.rise_s - self.hold_s)
        };
        sign * magnitude.max(0.0)
    }
}

/// Why a move is not taken.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PlanError {
    /// The buffer is full: take a move from the front first.
    Full,
    /// A coordinate or the feed is not finite.
    NotFinite,
    /// The feed is not positive.
    NoFeed,
}

/// A move's speed profile: a ramp up to its cruise, the cruise, a ramp down.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SpeedProfile {
    /// From the entry to the cruise.
    pub up: Ramp,
    /// Speed of the flat part (the peak where there is none), m/s.
    pub cruise_m_s: f64,
    /// Length at the cruise speed, m.
    pub cruise_m: f64,
    /// From the cruise to the exit.
    pub down: Ramp,
}

impl SpeedProfile {
    /// The profile over `length_m` from `entry` to `exit` with at most `nominal`,
    /// under `limits` (the entry and exit reachable from each other): the largest
    /// cruise whose two ramps fit the length.
    pub fn new(
        length_m: f64,
        entry_m_s: f64,
        exit_m_s: f64,
        nominal_m_s: f64,
        limits: &PlannerLimits,
    ) -> Self {
        let (a, j) = (limits.accel_m_s2, limits.jerk_m_s3);
        let ramps = |v: f64| (Ramp::new(entry_m_s, v, a, j), Ramp::new(v, exit_m_s, a, j));
        let fits = |v: f64| {
            let (up, down) = ramps(v);
            up.length_m() + down.length_m() <= length_m
        };
        let low = entry_m_s.max(exit_m_s);
        // Constant acceleration's peak bounds the S-curves' from above.
        let peak = libm::sqrt(
            (a * length_m + 0.5 * (entry_m_s * entry_m_s + exit_m_s * exit_m_s)).max(0.0),
        );
        let high = peak.min(nominal_m_s).max(low);
        let cruise = if j == f64::INFINITY {
            high
        } else {
            largest_within(low, high, fits)
        };
        Self::with_cruise(length_m, entry_m_s, exit_m_s, cruise, limits)
    }

    /// The profile over `length_m` from `entry` to `exit` through `cruise_m_s`, found
    /// before by [`SpeedProfile::new`] (no search: what a control period can afford).
    pub fn with_cruise(
        length_m: f64,
        entry_m_s: f64,
        exit_m_s: f64,
        cruise_m_s: f64,
        limits: &PlannerLimits,
    ) -> Self {
        let (a, j) = (limits.accel_m_s2, limits.jerk_m_s3);
        let up = Ramp::new(entry_m_s, cruise_m_s, a, j);
        let down = Ramp::new(cruise_m_s, exit_m_s, a, j);
        Self {
            up,
            cruise_m_s,
            cruise_m: (length_m - up.length_m() - down.length_m()).max(0.0),
            down,
        }
    }

    /// Time of the three parts, s.
    pub fn times_s(&self) -> [f64; 3] {
        let cruise = if self.cruise_m > 0.0 {
            self.cruise_m / self.cruise_m_s
        } else {
            0.0
        };
        [self.up.duration_s(), cruise, self.down.duration_s()]
    }

    /// Duration, s.
    pub fn duration_s(&self) -> f64 {
        self.times_s().iter().sum()
    }

    /// Distance travelled and speed at `t_s` after the start (held at the end past
    /// it), m and m/s.
    pub fn at(&self, t_s: f64) -> (f64, f64) {
        let [ta, tc, _] = self.times_s();
        let t = t_s.max(0.0);
        if t < ta {
            return self.up.at(t);
        }
        let t = t - ta;
        let accel_m = self.up.length_m();
        if t < tc {
            return (accel_m + self.cruise_m_s * t, self.cruise_m_s);
        }
        let (s, v) = self.down.at(t - tc);
        (accel_m + self.cruise_m + s, v)
    }

    /// Acceleration along the path at `t_s` after the start (zero outside), m/s².
    pub fn accel_at(&self, t_s: f64) -> f64 {
        let [ta, tc, _] = self.times_s();
        if t_s < ta {
            self.up.accel_at(t_s)
        } else {
            self.down.accel_at(t_s - ta - tc)
        }
    }
}

/// One straight move in `D` axes, planned.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Block<const D: usize> {
    /// Where it starts, m.
    pub start_m: [f64; D],
    /// Where it ends, m.
    pub end_m: [f64; D],
    /// Its length, m.
    pub length_m: f64,
    /// Its direction (unit).
    pub unit: [f64; D],
    /// Its feed, at most the machine's largest speed, m/s.
    pub nominal_m_s: f64,
    /// The corner before it allows at most this entry speed, m/s.
    pub max_entry_m_s: f64,
    /// Planned entry speed, m/s.
    pub entry_m_s: f64,
    /// Planned exit speed (the next move's entry), m/s.
    pub exit_m_s: f64,
}

impl<const D: usize> Block<D> {
    /// Its speed profile under `limits`.
    pub fn profile(&self, limits: &PlannerLimits) -> SpeedProfile {
        SpeedProfile::new(
            self.length_m,
            self.entry_m_s,
            self.exit_m_s,
            self.nominal_m_s,
            limits,
        )
    }

    /// The point `s_m` along it (clamped to its ends), m.
    pub fn point_at(&self, s_m: f64) -> [f64; D] {
        let s = s_m.max(0.0).min(self.length_m);
        let mut point = self.start_m;
        for (x, u) in point.iter_mut().zip(&self.unit) {
            *x += u * s;
        }
        point
    }
}

/// Where a plan takes over from moves planned before it, not at rest: the last of
/// those moves (its direction and feed, which set the corner's speed) and the speed
/// planned at its end. A program cut as several plans (parts) passes it from one to the
/// next.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Continuation<const D: usize> {
    /// The direction of the move before (unit).
    pub unit: [f64; D],
    /// Its feed, at most the machine's largest speed, m/s.
    pub nominal_m_s: f64,
    /// The speed at its end, where the plan begins, m/s.
    pub speed_m_s: f64,
}

/// The look-ahead planner over a buffer of `N` moves in `D` axes (module docs).
pub struct Planner<const D: usize, const N: usize> {
    limits: PlannerLimits,
    blocks: Deque<Block<D>, N>,
    /// Where the last move added ends (the next one starts there), m.
    position_m: [f64; D],
    /// The entry speed of the front move, fixed once the move before it was taken.
    front_entry_m_s: f64,
    /// The moves before the first one added, while none is ([`Planner::continue_from`]).
    before: Option<Continuation<D>>,
    /// The largest entry speed of the front move the backward pass allows, m/s.
    front_limit_m_s: f64,
}

impl<const D: usize, const N: usize> Planner<D, N> {
    /// An empty buffer at rest at `start_m`.
    ///
    /// Errors: a limit that is not finite and positive; a start not finite.
    pub fn new(limits: &PlannerLimits, start_m: [f64; D]) -> Result<Self, ConfigError> {
        limits.check()?;
        if !start_m.iter().all(|v| v.is_finite()) {
            return Err(ConfigError::not_finite("start_m"));
        }
        Ok(Self {
            limits: *limits,
            blocks: Deque::new(),
            position_m: start_m,
            front_entry_m_s: 0.0,
            before: None,
            front_limit_m_s: 0.0,
        })
    }

    /// Makes the empty buffer continue the moves before it, as `before` says: its first
    /// move enters at their end speed, its corner with them limited as any corner.
    ///
    /// Errors: a `before` that is not finite or a negative speed; moves already added.
    pub fn continue_from(&mut self, before: Continuation<D>) -> Result<(), ConfigError> {
        let finite = before.unit.iter().all(|u| u.is_finite())
            && before.nominal_m_s.is_finite()
            && before.speed_m_s.is_finite()
            && before.speed_m_s >= 0.0;
        if !finite || !self.blocks.is_empty() {
            return Err(ConfigError::out_of_range("before"));
        }
        self.before = Some(before);
        Ok(())
    }

    /// The largest speed at which the front move can be entered under the plan (the
    /// backward pass: every corner's limit, and the last move stopping), m/s. A plan
    /// that continues others ([`Planner::continue_from`]) is feasible when their end
    /// speed is at most this.
    pub fn front_limit_m_s(&self) -> f64 {
        self.front_limit_m_s
    }

    /// The limits it plans with.
    pub fn limits(&self) -> &PlannerLimits {
        &self.limits
    }

    /// Adds a straight move to `target_m` at `feed_m_s` and re-plans the buffer. A move
    /// of no length is taken and adds nothing.
    ///
    /// Errors: the buffer is full; a coordinate or the feed is not finite; the feed
    /// is not positive. Nothing changes.
    pub fn push(&mut self, target_m: [f64; D], feed_m_s: f64) -> Result<(), PlanError> {
        if !feed_m_s.is_finite() || !target_m.iter().all(|v| v.is_finite()) {
            return Err(PlanError::NotFinite);
        }
        if feed_m_s <= 0.0 {
            return Err(PlanError::NoFeed);
        }
        let mut delta = target_m;
        for (d, from) in delta.iter_mut().zip(&self.position_m) {
            *d -= from;
        }
        let length_m = libm::sqrt(dot(&delta, &delta));
        if length_m <= 0.0 {
            return Ok(());
        }
        if self.blocks.is_full() {
            return Err(PlanError::Full);
        }
        let unit = delta.map(|d| d / length_m);
        let nominal_m_s = feed_m_s.min(self.limits.max_speed_m_s);
        let max_entry_m_s = match self.blocks.back() {
            Some(prev) => self
                .limits
                .corner_speed_m_s(&prev.unit, &unit)
                .min(prev.nominal_m_s)
                .min(nominal_m_s),
            // The moves before this plan, or after the buffer ran empty: at rest.
            None => self.before.map_or(0.0, |b| {
                self.limits
                    .corner_speed_m_s(&b.unit, &unit)
                    .min(b.nominal_m_s)
                    .min(nominal_m_s)
            }),
        };
        let block = Block {
            start_m: self.position_m,
            end_m: target_m,
            length_m,
            unit,
            nominal_m_s,
            max_entry_m_s,
            entry_m_s: 0.0,
            exit_m_s: 0.0,
        };
        if self.blocks.push_back(block).is_err() {
            return Err(PlanError::Full);
        }
        if self.blocks.len() == 1 {
            self.front_entry_m_s = self.before.take().map_or(0.0, |b| b.speed_m_s);
        }
        self.position_m = target_m;
        self.replan();
        Ok(())
    }

    /// Takes the front move for execution, planned; the next one's entry is then
    /// fixed at its exit.
    pub fn pop(&mut self) -> Option<Block<D>> {
        let block = self.blocks.pop_front()?;
        self.front_entry_m_s = block.exit_m_s;
        Some(block)
    }

    /// The moves in the buffer, planned, front first.
    pub fn blocks(&self) -> impl Iterator<Item = &Block<D>> {
        self.blocks.iter()
    }

    /// Moves in the buffer.
    pub fn len(&self) -> usize {
        self.blocks.len()
    }

    /// Whether the buffer is empty.
    pub fn is_empty(&self) -> bool {
        self.blocks.is_empty()
    }

    /// Whether another move fits.
    pub fn is_full(&self) -> bool {
        self.blocks.is_full()
    }

    /// Duration of the moves in the buffer as planned, s.
    pub fn duration_s(&self) -> f64 {
        let limits = &self.limits;
        self.blocks
            .iter()
            .map(|b| b.profile(limits).duration_s())
            .sum()
    }

    /// The backward pass (the last move stops), then the forward pass from the
    /// front's fixed entry (module docs).
    fn replan(&mut self) {
        let limits = self.limits;
        let mut exit = 0.0f64;
        for b in self.blocks.iter_mut().rev() {
            b.exit_m_s = exit;
            b.entry_m_s = b.max_entry_m_s.min(limits.reach_m_s(exit, b.length_m));
            exit = b.entry_m_s;
        }
        self.front_limit_m_s = exit;
        let mut entry = self.front_entry_m_s;
        for b in self.blocks.iter_mut() {
            b.entry_m_s = entry;
            b.exit_m_s = b.exit_m_s.min(limits.reach_m_s(entry, b.length_m));
            entry = b.exit_m_s;
        }
    }
}

/// Where a [`PlanFollower`] takes its moves from, each with its speed profile: a
/// [`Planner`] (which plans the profile as the move is taken) or a program planned
/// before it runs.
pub trait MoveSource<const D: usize> {
    /// The next move and its profile, `None` when there is none (yet).
    fn next_move(&mut self) -> Option<(Block<D>, SpeedProfile)>;
    /// At most this many moves can be taken one after another without a new one
    /// added (what bounds a period's loop over moves shorter than a period).
    fn bound(&self) -> usize;
}

impl<const D: usize, const N: usize> MoveSource<D> for Planner<D, N> {
    fn next_move(&mut self) -> Option<(Block<D>, SpeedProfile)> {
        let limits = self.limits;
        self.pop().map(|block| (block, block.profile(&limits)))
    }

    fn bound(&self) -> usize {
        N
    }
}

/// One period's point of a followed plan.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PlanSample<const D: usize> {
    /// Where the tool is, m.
    pub position_m: [f64; D],
    /// Its speed along the path, m/s.
    pub speed_m_s: f64,
    /// Its acceleration along the path, m/s².
    pub accel_m_s2: f64,
    /// The move's direction (unit).
    pub unit: [f64; D],
}

/// Follows a [`Planner`]'s moves at a fixed period (module docs).
#[derive(Copy, Clone, Debug)]
pub struct PlanFollower<const D: usize> {
    period_s: f64,
    /// The move being followed, its profile and the time since it began, s.
    current: Option<(Block<D>, SpeedProfile, f64)>,
    /// Where the last move ended (held when there is none), m.
    rest_m: [f64; D],
    /// The time into the first move taken, s (0: a start from rest).
    resume_s: f64,
}

impl<const D: usize> PlanFollower<D> {
    /// A follower at rest at `start_m`, stepping every `period_s`.
    ///
    /// Errors: a period that is not finite and positive, a start not finite.
    pub fn new(period_s: f64, start_m: [f64; D]) -> Result<Self, ConfigError> {
        positive("period_s", period_s)?;
        if !start_m.iter().all(|v| v.is_finite()) {
            return Err(ConfigError::not_finite("start_m"));
        }
        Ok(Self {
            period_s,
            current: None,
            rest_m: start_m,
            resume_s: 0.0,
        })
    }

    /// A follower that takes over a plan begun elsewhere: its first move is taken
    /// `since_s` past its start plus a period (the step after the one that was made
    /// `since_s` past it).
    ///
    /// Errors: as [`PlanFollower::new`], and a `since_s` not finite or negative.
    pub fn resuming(period_s: f64, start_m: [f64; D], since_s: f64) -> Result<Self, ConfigError> {
        if !(since_s.is_finite() && since_s >= 0.0) {
            return Err(ConfigError::out_of_range("since_s"));
        }
        let mut follower = Self::new(period_s, start_m)?;
        follower.resume_s = since_s + period_s;
        Ok(follower)
    }

    /// The time since the move being followed began, s (`None` at rest).
    pub fn time_in_move_s(&self) -> Option<f64> {
        self.current.map(|(_, _, t)| t)
    }

    /// Whether a move is being followed (false: at rest, waiting for one).
    pub fn is_moving(&self) -> bool {
        self.current.is_some()
    }

    /// One period: the point a period further along the plan, taking moves from
    /// `moves` as the current one ends; at rest where the last one ended when there
    /// is none (a move taken at rest starts at its first point).
    pub fn step(&mut self, moves: &mut impl MoveSource<D>) -> PlanSample<D> {
        let mut t = match self.current {
            Some((_, _, t)) => t + self.period_s,
            None => core::mem::take(&mut self.resume_s),
        };
        // Each pass ends in a move or crosses one whole: bounded by the source's
        // moves.
        for _ in 0..=moves.bound() {
            let (block, profile) = match self.current {
                Some((block, profile, _)) => (block, profile),
                None => match moves.next_move() {
                    Some(next) => next,
                    None => break,
                },
            };
            let duration = profile.duration_s();
            if t < duration {
                self.current = Some((block, profile, t));
                let (s, v) = profile.at(t);
                return PlanSample {
                    position_m: block.point_at(s),
                    speed_m_s: v,
                    accel_m_s2: profile.accel_at(t),
                    unit: block.unit,
                };
            }
            // Past its end: the time left goes into the next move.
            t -= duration;
            self.rest_m = block.end_m;
            self.current = None;
        }
        self.current = None;
        PlanSample {
            position_m: self.rest_m,
            speed_m_s: 0.0,
            accel_m_s2: 0.0,
            unit: [0.0; D],
        }
    }
}

fn dot<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
