//! Constant feed along a [`TaskSpline`] at the control rate, with constant-jerk start
//! and stop (A §4.2–4.3, eq. 51–54; docs/equations.md §16).
//!
//! # Resampling (A 4.2)
//!
//! A steps the spline parameter by small δt until the chord from the last sample
//! exceeds F·Ts. Here each period solves for the parameter whose arc length from the
//! last sample is the period's step Δs (F·Ts while cruising): Newton's method on the
//! arc-length integral from a second-order Taylor guess, the integral by 3-point
//! Gauss–Legendre (the step of [`super::tangential`], shared), two corrections. Over a
//! step of micrometres the guess is already within ~1e-15 of the step (its error is
//! third order in Δu), and the corrections bring it to rounding. The chord is shorter
//! than the arc by κ²Δs³/24: 3e-19 m for Δs = 2 µm at κ = 100 m⁻¹. A step that crosses
//! a knot takes the arc left on its segment and continues on the next with the
//! remainder.
//!
//! # Start and stop (A 4.3)
//!
//! The speed follows A eq. 51–54 — jerk +J, 0, −J to reach V, and the mirror image to
//! stop — which is [`SpeedRamp`]'s profile with its phases rounded up to whole periods
//! (J′ ≤ J and A′ ≤ A chosen so that V is met exactly; A eq. 53 at t3). A move from
//! rest to rest along a path of length L is planned by [`FeedPlan::rest_to_rest`]:
//! the peak speed is F if both ramps fit in L (each covers V·t3/2, the S-curve being
//! symmetric), else the speed at which they exactly fill it (found by bisection); the
//! jerk phase nj, the ramp (nj + nf) and the cruise nc are then whole periods, chosen
//! among the nearest roundings as the shortest whose V′ = L/(Ts(2nj + nf + nc))
//! respects V′ ≤ F, A′ = V′/((nj + nf)Ts) ≤ A and J′ = A′/(nj·Ts) ≤ J. The whole move
//! then covers exactly L: V′Ts(2nj + nf) on the two ramps and V′Ts·nc cruising.
//!
//! Derivatives in time follow by the chain rule through arc length, as for the
//! contour follower: ṗ = p′θ̇, p̈ = p″θ̇² + p′θ̈, p⃛ = p‴θ̇³ + 3p″θ̇θ̈ + p′θ⃛.

use super::arc::{arc_step, parameter_rates};
use super::tangential::SpeedRamp;
use super::task_spline::{Pose, TaskSpline};
use super::{lit, Float};
use crate::error::{positive, ConfigError};

/// Limits of a move along the path.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FeedLimits {
    /// Feed F (cruise speed along the path), m/s.
    pub feed_m_s: f64,
    /// Largest tangential acceleration A, m/s².
    pub accel_m_s2: f64,
    /// Largest tangential jerk J, m/s³.
    pub jerk_m_s3: f64,
    /// Control period Ts, s.
    pub ts_s: f64,
}

/// Why a move could not be planned or followed.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FeedError {
    /// A limit is bad (names the field).
    Config(ConfigError),
    /// The path length is not finite and positive.
    NoLength,
    /// The move would take more than 2³¹ periods.
    TooLong,
    /// A step along the spline could not be solved (not finite): the follower holds.
    Lost,
}

impl From<ConfigError> for FeedError {
    fn from(e: ConfigError) -> Self {
        FeedError::Config(e)
    }
}

/// A rest-to-rest move of length L in whole control periods (module docs). The
/// default is the empty plan (no periods), what a job holds before one is loaded.
#[derive(Copy, Clone, Debug, PartialEq, Default)]
pub struct FeedPlan {
    /// Path length L, m.
    pub length_m: f64,
    /// Peak (cruise) speed V′ ≤ F, m/s.
    pub speed_m_s: f64,
    /// Periods of each jerk phase, nj ≥ 1.
    pub n_jerk: u32,
    /// Periods of constant acceleration in each ramp, nf.
    pub n_flat: u32,
    /// Periods at the peak speed, nc.
    pub n_cruise: u32,
    /// Control period Ts, s.
    pub ts_s: f64,
}

/// Time of one ramp from rest to v under A and J (A eq. 51–53: t3 = 2t1 + (t2 − t1)),
/// s: A/J + v/A when A is reached (v ≥ A²/J), else 2√(v/J).
fn ramp_time_s(v: f64, a: f64, j: f64) -> f64 {
    if v >= a * a / j {
        v / a + a / j
    } else {
        2.0 * libm::sqrt(v / j)
    }
}

/// ⌈x⌉ for a ratio of measured times, forgiving rounding just above an integer.
fn ceil_periods(x: f64) -> f64 {
    libm::ceil(x - 1e-9).max(0.0)
}

impl FeedPlan {
    /// Plans a move from rest to rest over `length_m` under `limits` (module docs).
    ///
    /// Errors: a limit not finite and positive, a length not finite and positive, a
    /// move longer than 2³¹ periods.
    pub fn rest_to_rest(length_m: f64, limits: &FeedLimits) -> Result<Self, FeedError> {
        let f = positive("feed_m_s", limits.feed_m_s)?;
        let a = positive("accel_m_s2", limits.accel_m_s2)?;
        let j = positive("jerk_m_s3", limits.jerk_m_s3)?;
        let ts = positive("ts_s", limits.ts_s)?;
        if !(length_m.is_finite() && length_m > 0.0) {
            return Err(FeedError::NoLength);
        }
        // Two ramps to v cover v·t3(v) (A eq. 53 integrated: mean speed v/2 each).
        let both_ramps = |v: f64| v * ramp_time_s(v, a, j);
        let peak = if both_ramps(f) <= length_m {
            f
        } else {
            let (mut lo, mut hi) = (0.0, f);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if both_ramps(mid) <= length_m {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            lo
        };
        let t_jerk = (a / j).min(libm::sqrt(peak / j));
        let t_ramp = ramp_time_s(peak, a, j);
        let nj0 = ceil_periods(t_jerk / ts).max(1.0);
        let m0 = ceil_periods((t_ramp - t_jerk) / ts).max(nj0);
        if nj0 + m0 >= 1e9 {
            return Err(FeedError::TooLong);
        }
        let mut best: Option<(f64, Self)> = None;
        for nj in [nj0 - 1.0, nj0, nj0 + 1.0] {
            for m in [m0 - 1.0, m0, m0 + 1.0] {
                if nj < 1.0 || m < nj {
                    continue;
                }
                // Highest V′ these phases allow: F, A·m·Ts and J·nj·m·Ts².
                let cap = f.min(a * m * ts).min(j * nj * m * ts * ts);
                let n_cruise = ceil_periods(length_m / (ts * cap) - (nj + m));
                let v = length_m / (ts * (nj + m + n_cruise));
                let total = 2.0 * (nj + m) + n_cruise;
                if total >= 2.0e9 {
                    return Err(FeedError::TooLong);
                }
                if v > cap * (1.0 + 1e-12) || best.as_ref().is_some_and(|(t, _)| *t <= total) {
                    continue;
                }
                let plan = Self {
                    length_m,
                    speed_m_s: v.min(f),
                    n_jerk: nj as u32,
                    n_flat: (m - nj) as u32,
                    n_cruise: n_cruise as u32,
                    ts_s: ts,
                };
                best = Some((total, plan));
            }
        }
        best.map(|(_, p)| p).ok_or(FeedError::TooLong)
    }

    /// Periods of one ramp, 2nj + nf (saturating: a plan built by hand may not count
    /// in a `u32`, which [`FeedFollower::new`] refuses).
    pub fn ramp_periods(&self) -> u32 {
        self.n_jerk.saturating_mul(2).saturating_add(self.n_flat)
    }

    /// Periods of the whole move (saturating, as [`FeedPlan::ramp_periods`]).
    pub fn periods(&self) -> u32 {
        self.ramp_periods()
            .saturating_mul(2)
            .saturating_add(self.n_cruise)
    }

    /// Duration of the whole move, s.
    pub fn duration_s(&self) -> f64 {
        f64::from(self.periods()) * self.ts_s
    }

    /// Acceleration A′ used, m/s².
    pub fn accel_m_s2(&self) -> f64 {
        self.speed_m_s / (f64::from(self.n_jerk + self.n_flat) * self.ts_s)
    }

    /// Jerk J′ used, m/s³.
    pub fn jerk_m_s3(&self) -> f64 {
        self.accel_m_s2() / (f64::from(self.n_jerk) * self.ts_s)
    }

    /// The plan's speed ramp in the scalar `T`.
    pub fn ramp<T: Float>(&self) -> Result<SpeedRamp<T>, ConfigError> {
        SpeedRamp::from_periods(self.speed_m_s, self.n_jerk, self.n_flat, self.ts_s)
    }
}

/// The reference for one period.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FeedSample<T: Float> {
    /// Pose, absolute (m, rad).
    pub pose: Pose<T>,
    /// Its time derivative.
    pub velocity: Pose<T>,
    /// Second time derivative.
    pub acceleration: Pose<T>,
    /// Third time derivative.
    pub jerk: Pose<T>,
    /// Speed along the path (metric of the spline), m/s.
    pub speed_m_s: T,
    /// Tangential acceleration, m/s².
    pub accel_m_s2: T,
    /// Tangential jerk during the period, m/s³.
    pub jerk_m_s3: T,
    /// Arc length travelled this period, m.
    pub step_m: T,
    /// Segment of the spline.
    pub segment: usize,
    /// Parameter on the segment.
    pub parameter: T,
}

/// Steps a rest-to-rest move ([`FeedPlan`]) along a [`TaskSpline`], one control period
/// per call. The spline is passed to each step (coefficients apart from state).
#[derive(Clone, Debug)]
pub struct FeedFollower<T: Float> {
    ramp: SpeedRamp<T>,
    ramp_periods: u32,
    n_cruise: u32,
    total: u32,
    period: u32,
    segment: usize,
    t: T,
    lost: bool,
    /// Stopped before the plan's end ([`FeedFollower::stop`]): rests where the stop
    /// ramp ends instead of at the end of the path.
    stopped: bool,
}

/// Newton corrections per arc-length step (module docs).
const NEWTON_STEPS: u8 = 2;

impl<T: Float> FeedFollower<T> {
    /// A follower at rest at the start of the path, about to run `plan`.
    ///
    /// Errors: a plan whose ramp `T` cannot hold, or (a plan built by hand) whose
    /// periods do not count in a `u32` (`TooLong`).
    pub fn new(plan: &FeedPlan) -> Result<Self, FeedError> {
        let mut ramp = plan.ramp::<T>()?;
        // The ramp is at most `MAX_RAMP_PERIODS`, but the cruise is the plan's own.
        let ramp_periods = ramp.ramp_periods();
        let total = ramp_periods
            .checked_mul(2)
            .and_then(|n| n.checked_add(plan.n_cruise))
            .ok_or(FeedError::TooLong)?;
        ramp.start();
        if plan.n_cruise == 0 {
            // Stop as soon as the start ramp ends.
            ramp.stop();
        }
        Ok(Self {
            ramp,
            ramp_periods,
            n_cruise: plan.n_cruise,
            total,
            period: 0,
            segment: 0,
            t: T::ZERO,
            lost: false,
            stopped: false,
        })
    }

    /// Whether the move is over (the follower rests at the end of the path).
    pub fn is_done(&self) -> bool {
        self.period >= self.total
    }

    /// Periods stepped so far.
    pub fn period(&self) -> u32 {
        self.period
    }

    /// Stops early along the path with the plan's stop ramp: at once when cruising,
    /// after the start ramp while still accelerating (A eq. 51–54 mirrored). No
    /// effect once the planned stop ramp has begun. The follower then rests where
    /// the ramp ends, short of the path's end.
    pub fn stop(&mut self) {
        let planned_stop = self.ramp_periods + self.n_cruise;
        if self.is_done() || self.period >= planned_stop {
            return;
        }
        self.ramp.stop();
        // Down at once when cruising, else once the start ramp is over.
        self.total = self.period.max(self.ramp_periods) + self.ramp_periods;
        self.n_cruise = 0;
        self.stopped = true;
    }

    /// Moves the parameter by the arc `ds` (m); false if a step was not finite.
    fn advance<const N: usize>(&mut self, spline: &TaskSpline<T, N>, ds: T) -> bool {
        let mut remaining = ds;
        let last = spline.segments().saturating_sub(1);
        // Each pass finishes the step or moves to the next segment.
        for _ in 0..=spline.segments() {
            if remaining <= T::ZERO {
                break;
            }
            let h = spline.segment_parameter(self.segment);
            let (seg, t0) = (self.segment, self.t);
            let s = spline.evaluate(seg, t0);
            let sigma = spline.metric_norm(&s.d1);
            if !sigma.is_finite() || sigma <= T::ZERO {
                return false;
            }
            let sigma_u = spline.metric_dot(&s.d1, &s.d2) / sigma;
            let du = arc_step(sigma, sigma_u, remaining, NEWTON_STEPS, |u| {
                spline.speed(seg, t0 + u)
            });
            if !du.is_finite() {
                return false;
            }
            if t0 + du <= h {
                self.t = t0 + du;
                break;
            }
            // Past the knot: the arc left on this segment, then the next one.
            remaining -= spline.arc_length(seg, t0, h, 1);
            if self.segment >= last {
                self.t = h;
                break;
            }
            self.segment += 1;
            self.t = T::ZERO;
        }
        true
    }

    /// Advances one control period and returns the reference at its end. After the
    /// last period the reference rests at the end of the path.
    ///
    /// Errors: [`FeedError::Lost`] when a step is not finite; the follower then holds
    /// and keeps returning it.
    pub fn step<const N: usize>(
        &mut self,
        spline: &TaskSpline<T, N>,
    ) -> Result<FeedSample<T>, FeedError> {
        if self.lost {
            return Err(FeedError::Lost);
        }
        if self.n_cruise > 0 && self.period == self.ramp_periods + self.n_cruise {
            self.ramp.stop();
        }
        let sp = if self.is_done() && self.stopped {
            None
        } else if self.is_done() {
            let last = spline.segments().saturating_sub(1);
            self.segment = last;
            self.t = spline.segment_parameter(last);
            None
        } else {
            self.period += 1;
            Some(self.ramp.step())
        };
        if let Some(sp) = sp {
            if !self.advance(spline, sp.ds) {
                self.lost = true;
                return Err(FeedError::Lost);
            }
        }
        if self.is_done() && !self.stopped {
            // The plan covers exactly the path: what rounding left is closed here.
            let last = spline.segments().saturating_sub(1);
            self.segment = last;
            self.t = spline.segment_parameter(last);
        }
        let (v, a, j, ds) = match sp {
            Some(sp) if !self.is_done() => (sp.v, sp.a, sp.j, sp.ds),
            Some(sp) => (T::ZERO, T::ZERO, T::ZERO, sp.ds),
            None => (T::ZERO, T::ZERO, T::ZERO, T::ZERO),
        };
        let s = spline.evaluate(self.segment, self.t);
        let sigma = spline.metric_norm(&s.d1);
        let (u1, u2, u3) = if sigma > T::ZERO {
            let s_u = spline.metric_dot(&s.d1, &s.d2) / sigma;
            let s_uu = (spline.metric_dot(&s.d2, &s.d2) + spline.metric_dot(&s.d1, &s.d3)) / sigma
                - s_u * s_u / sigma;
            parameter_rates(sigma, s_u, s_uu, v, a, j)
        } else {
            (T::ZERO, T::ZERO, T::ZERO)
        };
        let three = lit::<T>(3.0);
        let sample = FeedSample {
            pose: s.position,
            velocity: s.d1 * u1,
            acceleration: s.d2 * (u1 * u1) + s.d1 * u2,
            jerk: s.d3 * (u1 * u1 * u1) + s.d2 * (three * u1 * u2) + s.d1 * u3,
            speed_m_s: v,
            accel_m_s2: a,
            jerk_m_s3: j,
            step_m: ds,
            segment: self.segment,
            parameter: self.t,
        };
        let finite = [
            sample.pose,
            sample.velocity,
            sample.acceleration,
            sample.jerk,
        ]
        .iter()
        .all(|p| p.iter().all(|x| x.is_finite()));
        if finite {
            Ok(sample)
        } else {
            self.lost = true;
            Err(FeedError::Lost)
        }
    }
}

#[cfg(test)]
mod tests;
