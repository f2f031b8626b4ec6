//! Constant tangential speed along a curve — an EFD or an open path (T 3.2.2;
//! docs/equations.md §12), online.
//!
//! The print resamples the curve offline and interpolates linearly between samples.
//! Here the curve parameter θ is advanced each period so that the reference moves the
//! commanded arc length Δs along the curve itself: with σ(θ) = |C′(θ)|, solve
//! ∫θk^θk+1 σ dθ = Δs by Newton's method (g′ = σ), the integral by 3-point
//! Gauss–Legendre over the one-period step (error ∝ Δθ⁷, far below rounding). The first
//! guess is the second-order Taylor inverse Δθ = Δs/σ − σ′Δs²/(2σ³), so two Newton
//! corrections reach rounding. What rounding θ itself loses (in `f32`) is carried into
//! the next period's Δs, so the arc length does not drift against V·t.
//!
//! Task-space derivatives follow from the chain rule through arc length s: with
//! θ′ = 1/σ, θ″ = −σθ/σ³, θ‴ = −σθθ/σ⁴ + 3σθ²/σ⁵ (primes d/ds, subscripts d/dθ),
//! θ̇ = θ′v, θ̈ = θ″v² + θ′a, θ⃛ = θ‴v³ + 3θ″va + θ′j, and
//! ṗ = C′θ̇, p̈ = C″θ̇² + C′θ̈, p⃛ = C‴θ̇³ + 3C″θ̇θ̈ + C′θ⃛.
//!
//! Speed follows a jerk-limited ramp from rest to V and back ([`SpeedRamp`]). At constant
//! speed the acceleration is centripetal, V²κ, so a speed is accepted only if
//! V²·κmax does not exceed the acceleration limit ([`max_speed_m_s`]).

use super::arc::{arc_step, parameter_rates};
use super::curve::{Curve, CurveSample};
use super::efd::Efd;
use super::{lit, to_f64, ContourError, Float};
use crate::error::{positive, representable, ConfigError};
use crate::scalar::norm;
use core::f64::consts::PI;
use nalgebra::Vector2;

/// Jerk-limited speed ramp configuration.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SpeedRampConfig {
    /// Cruise tangential speed V, m/s.
    pub speed_m_s: f64,
    /// Largest tangential acceleration of the ramp, m/s².
    pub accel_m_s2: f64,
    /// Largest tangential jerk of the ramp, m/s³.
    pub jerk_m_s3: f64,
    /// Control period Ts, s.
    pub ts_s: f64,
}

/// One period of the speed profile.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SpeedSample<T> {
    /// Arc length travelled during the period, m.
    pub ds: T,
    /// Speed at the end of the period, m/s.
    pub v: T,
    /// Tangential acceleration at the end of the period, m/s².
    pub a: T,
    /// Jerk during the period (piecewise constant), m/s³.
    pub j: T,
}

#[derive(Copy, Clone, Debug, PartialEq)]
enum Phase {
    Rest,
    Up,
    Cruise,
    Down,
}

/// Most periods one [`SpeedRamp`] (start or stop) may take, 2nj + nf: 2·10⁸, 5.6 hours
/// at 10 kHz. Its double, a start and a stop, still counts in a `u32`.
pub const MAX_RAMP_PERIODS: u32 = 200_000_000;

/// Rest → V → rest with piecewise-constant jerk: +J′ for nj periods, 0 for nf, −J′ for
/// nj (and mirrored to stop) — the constant-jerk S-curve of docs/equations.md §16 (A §4).
/// Phase lengths are whole periods, so each period integrates exactly
/// (Δs = vTs + aTs²/2 + jTs³/6); J′ ≤ J and A′ = J′·nj·Ts ≤ A are chosen so that the
/// speed lands exactly on V.
#[derive(Copy, Clone, Debug)]
pub struct SpeedRamp<T> {
    speed: T,
    jerk: T,
    ts: T,
    n_jerk: u32,
    n_flat: u32,
    phase: Phase,
    count: u32,
    stop_pending: bool,
    v: T,
    a: T,
    ramp_distance_m: f64,
}

impl<T: Float> SpeedRamp<T> {
    /// Validates the configuration (all values finite and positive).
    pub fn new(config: &SpeedRampConfig) -> Result<Self, ConfigError> {
        let v = positive("speed_m_s", config.speed_m_s)?;
        let a = positive("accel_m_s2", config.accel_m_s2)?;
        let j = positive("jerk_m_s3", config.jerk_m_s3)?;
        let ts = positive("ts_s", config.ts_s)?;
        // Jerk phase: A/J if V is reached with a flat acceleration phase, else √(V/J).
        let t_jerk = (a / j).min(libm::sqrt(v / j));
        let n_jerk = libm::ceil(t_jerk / ts).max(1.0);
        let n_flat = libm::ceil(v / a / ts - n_jerk).max(0.0);
        if 2.0 * n_jerk + n_flat > f64::from(MAX_RAMP_PERIODS) {
            return Err(ConfigError::out_of_range("speed_m_s"));
        }
        Self::from_periods(v, n_jerk as u32, n_flat as u32, ts)
    }

    /// The same profile with its phase lengths given in whole periods: jerk +J′ for
    /// `n_jerk` periods, 0 for `n_flat`, −J′ for `n_jerk` (A eq. 51), where
    /// J′ = V/(nj(nj + nf)Ts²) and A′ = J′·nj·Ts = V/((nj + nf)Ts) land the speed
    /// exactly on V (A eq. 53 at t3). A planner that chose the periods under its own
    /// limits (a rest-to-rest move, [`super::feed`]) builds its ramp here.
    ///
    /// Errors: V or Ts not finite and positive, `n_jerk` zero or a ramp of more than
    /// [`MAX_RAMP_PERIODS`] periods (`OutOfRange` naming `n_jerk`), or per-period
    /// terms the scalar `T` cannot hold (`NotRepresentable`).
    pub fn from_periods(
        speed_m_s: f64,
        n_jerk: u32,
        n_flat: u32,
        ts_s: f64,
    ) -> Result<Self, ConfigError> {
        let v = positive("speed_m_s", speed_m_s)?;
        let ts = positive("ts_s", ts_s)?;
        // The ramp's period count 2nj + nf is a u32 (`ramp_periods`): past it the
        // count would wrap, and a ramp of 2³¹ jerk periods would end after nf.
        let ramp_periods = u64::from(n_jerk) * 2 + u64::from(n_flat);
        if n_jerk == 0 || ramp_periods > u64::from(MAX_RAMP_PERIODS) {
            return Err(ConfigError::out_of_range("n_jerk"));
        }
        let (n_jerk_f, n_flat_f) = (f64::from(n_jerk), f64::from(n_flat));
        let a_used = v / ((n_jerk_f + n_flat_f) * ts);
        let j_used = a_used / (n_jerk_f * ts);
        // `step` forms Ts², A·Ts² and J·Ts³ in T: each must be finite there (a period
        // of 1e30 s in f32, or near f64::MAX in f64, overflows them).
        let per_period = |value: f64| {
            if value.is_finite() {
                representable::<T>("ts_s", value)
            } else {
                Err(ConfigError::not_representable("ts_s"))
            }
        };
        per_period(ts * ts)?;
        per_period(a_used * ts * ts)?;
        per_period(j_used * ts * ts * ts)?;
        Ok(Self {
            // In the target scalar: f64-valid extremes can overflow f32.
            speed: representable("speed_m_s", v)?,
            jerk: crate::error::coefficient("jerk_m_s3", j_used)?,
            ts: representable("ts_s", ts)?,
            n_jerk,
            n_flat,
            phase: Phase::Rest,
            count: 0,
            stop_pending: false,
            v: T::ZERO,
            a: T::ZERO,
            // Symmetric S-curve: the mean speed over the ramp is V/2.
            ramp_distance_m: 0.5 * v * (2.0 * n_jerk_f + n_flat_f) * ts,
        })
    }

    /// Jerk J′ of the ramp's jerk phases, m/s³ (at most the configured jerk).
    pub fn jerk(&self) -> T {
        self.jerk
    }

    /// Arc length covered by one ramp (start or stop), m.
    pub fn ramp_distance_m(&self) -> f64 {
        self.ramp_distance_m
    }

    /// Periods one ramp takes.
    pub fn ramp_periods(&self) -> u32 {
        // At most MAX_RAMP_PERIODS (checked at construction): never saturates.
        self.n_jerk.saturating_mul(2).saturating_add(self.n_flat)
    }

    /// Cruise speed V, m/s.
    pub fn speed(&self) -> T {
        self.speed
    }

    /// Begins accelerating (no effect unless at rest).
    pub fn start(&mut self) {
        if self.phase == Phase::Rest {
            self.phase = Phase::Up;
            self.count = 0;
        }
    }

    /// Begins decelerating: at once when cruising, after the start ramp otherwise.
    pub fn stop(&mut self) {
        match self.phase {
            Phase::Cruise => {
                self.phase = Phase::Down;
                self.count = 0;
            }
            Phase::Up => self.stop_pending = true,
            Phase::Rest | Phase::Down => {}
        }
    }

    /// True when at rest.
    pub fn is_at_rest(&self) -> bool {
        self.phase == Phase::Rest
    }

    /// True when cruising at V.
    pub fn is_cruising(&self) -> bool {
        self.phase == Phase::Cruise
    }

    fn jerk_now(&self) -> T {
        let up = if self.count < self.n_jerk {
            self.jerk
        } else if self.count < self.n_jerk + self.n_flat {
            T::ZERO
        } else {
            -self.jerk
        };
        match self.phase {
            Phase::Up => up,
            Phase::Down => -up,
            Phase::Rest | Phase::Cruise => T::ZERO,
        }
    }

    /// Advances one period.
    pub fn step(&mut self) -> SpeedSample<T> {
        let (ts, j) = (self.ts, self.jerk_now());
        let (v, a) = (self.v, self.a);
        if self.phase == Phase::Cruise {
            return SpeedSample {
                ds: self.speed * ts,
                v: self.speed,
                a: T::ZERO,
                j: T::ZERO,
            };
        }
        let ts2 = ts * ts;
        let ds = v * ts + a * ts2 * lit(0.5) + j * ts2 * ts * lit(1.0 / 6.0);
        self.v = v + a * ts + j * ts2 * lit(0.5);
        self.a = a + j * ts;
        if matches!(self.phase, Phase::Up | Phase::Down) {
            self.count += 1;
            if self.count >= self.ramp_periods() {
                // Land exactly on the end state instead of keeping the rounding.
                self.count = 0;
                self.a = T::ZERO;
                if self.phase == Phase::Up {
                    self.v = self.speed;
                    self.phase = Phase::Cruise;
                    if self.stop_pending {
                        self.stop_pending = false;
                        self.phase = Phase::Down;
                    }
                } else {
                    self.v = T::ZERO;
                    self.phase = Phase::Rest;
                }
            }
        }
        SpeedSample {
            ds: ds.max(T::ZERO),
            v: self.v,
            a: self.a,
            j,
        }
    }
}

/// Highest constant tangential speed a curve allows under `accel_limit_m_s2`:
/// √(A/κmax), with κmax from [`Curve::max_curvature`] over `64·pieces` samples (at
/// least 1024; +∞ only for a curve without curvature).
///
/// Errors: a limit that is not finite and positive (its square root would be NaN).
pub fn max_speed_m_s<T: Float, C: Curve<T>>(
    curve: &C,
    accel_limit_m_s2: f64,
) -> Result<f64, ConfigError> {
    let limit = positive("accel_limit_m_s2", accel_limit_m_s2)?;
    let kappa = to_f64(curve.max_curvature(curve.pieces().max(16).saturating_mul(64)));
    Ok(if kappa > 0.0 {
        libm::sqrt(limit / kappa)
    } else {
        f64::INFINITY
    })
}

/// Follower configuration.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FollowerConfig {
    /// Speed ramp (V, its tangential acceleration and jerk, Ts).
    pub ramp: SpeedRampConfig,
    /// Acceleration limit of the machine, m/s²: bounds V²κmax and the ramp acceleration.
    pub accel_limit_m_s2: f64,
    /// Newton corrections of each period's arc-length step, at most
    /// [`MAX_NEWTON_STEPS`]. The first guess is the second-order Taylor inverse, whose
    /// error per step is third order in Δθ: 0 corrections are enough for a control
    /// period's step of a micrometre (see the module tests), 2 reach rounding.
    pub newton_steps: u8,
}

/// Task-space reference for one period.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ContourReference<T: Float> {
    /// Position relative to the curve centre (a0, c0), m.
    pub position: Vector2<T>,
    /// Velocity, m/s.
    pub velocity: Vector2<T>,
    /// Acceleration, m/s².
    pub acceleration: Vector2<T>,
    /// Jerk, m/s³.
    pub jerk: Vector2<T>,
    /// Tangential speed, m/s.
    pub speed: T,
    /// Curve parameter θ: in [0, 2π) on an EFD, chord length in [0, end] (m) on an
    /// open path.
    pub theta: T,
}

/// Every component finite.
trait FiniteAll {
    fn is_finite_all(&self) -> bool;
}

impl<T: Float> FiniteAll for Vector2<T> {
    fn is_finite_all(&self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }
}

/// Most Newton corrections a follower accepts per period (each costs four tangent
/// evaluations of the curve).
pub const MAX_NEWTON_STEPS: u8 = 4;

/// Steps θ along a [`Curve`] at the tangential speed of a [`SpeedRamp`]. On a closed
/// curve θ wraps and laps are counted; on an open one θ stops at the end (a job's
/// stop ramp is planned to bring it to rest there).
///
/// # Example
///
/// A circle of radius 8 mm described by 30 harmonics, followed at 8 mm/s with a 1 ms
/// control period: after the jerk-limited start each period moves the reference by
/// V·Ts = 8 µm along the curve.
///
/// ```
/// use kerf::trajectory::efd::Efd;
/// use kerf::trajectory::shapes;
/// use kerf::trajectory::tangential::{ContourFollower, FollowerConfig, SpeedRampConfig};
///
/// let circle: [[f64; 2]; 128] = shapes::ellipse(8e-3, 8e-3);
/// let efd = Efd::<f64, 30>::from_polygon(&circle, 30).unwrap();
/// let (speed, ts) = (8e-3, 1e-3);
/// let config = FollowerConfig {
///     ramp: SpeedRampConfig {
///         speed_m_s: speed,
///         accel_m_s2: 0.5,
///         jerk_m_s3: 50.0,
///         ts_s: ts,
///     },
///     accel_limit_m_s2: 10.0,
///     newton_steps: 2,
/// };
/// let mut follower = ContourFollower::new(efd, &config, 0.0).unwrap();
/// follower.start();
///
/// let mut previous = follower.step().unwrap().position;
/// let mut steps = [0.0; 300];
/// for step in steps.iter_mut() {
///     let reference = follower.step().unwrap();
///     *step = (reference.position - previous).norm();
///     previous = reference.position;
/// }
/// // The first periods are still on the speed ramp; by the end the follower cruises
/// // at V, and the step (a chord of the curve, as long as the arc to 1e-12 m) is V·Ts.
/// assert!(steps[0] < 0.1 * speed * ts);
/// assert!(follower.ramp().is_cruising());
/// assert!((steps[299] - speed * ts).abs() < 1e-9);
/// ```
#[derive(Clone, Debug)]
pub struct CurveFollower<T: Float, C> {
    curve: C,
    ramp: SpeedRamp<T>,
    theta: T,
    laps: u32,
    sample: CurveSample<T>,
    /// Arc length owed from rounding θ (added to the next step), m.
    carry: T,
    /// 2π − (2π rounded to T), rad: the wrap of θ moves the curve by this much.
    wrap_error: T,
    /// Where θ wraps (closed) or ends (open).
    span: T,
    closed: bool,
    /// Set when a step could not be solved: the follower holds from then on.
    lost: bool,
    newton_steps: u8,
}

/// The follower of an EFD contour.
pub type ContourFollower<T, const N: usize> = CurveFollower<T, Efd<T, N>>;

impl<T: Float, C: Curve<T>> CurveFollower<T, C> {
    /// A follower at rest at θ = `theta0`.
    ///
    /// Errors: a bad ramp configuration or acceleration limit, a ramp acceleration above
    /// the limit, a curve without length ([`ContourError::ZeroLength`]) or whose
    /// length overflows `T` (`NotRepresentable` naming `curve`: every step's σ would),
    /// V·Ts longer than the curve, or V²κmax above the limit
    /// ([`ContourError::SpeedAboveCurvatureLimit`] carries the highest allowed speed).
    pub fn new(curve: C, config: &FollowerConfig, theta0: f64) -> Result<Self, ContourError> {
        let limit = positive("accel_limit_m_s2", config.accel_limit_m_s2)?;
        let length =
            to_f64(curve.arc_length(T::ZERO, curve.span(), curve.pieces().saturating_mul(16)));
        if !length.is_finite() {
            return Err(ConfigError::not_representable("curve").into());
        }
        if length <= 0.0 {
            return Err(ContourError::ZeroLength);
        }
        if config.ramp.speed_m_s * config.ramp.ts_s >= length {
            return Err(ContourError::StepLongerThanContour);
        }
        let v_max = max_speed_m_s(&curve, limit)?;
        if config.ramp.speed_m_s > v_max {
            return Err(ContourError::SpeedAboveCurvatureLimit {
                max_speed_m_s: v_max,
            });
        }
        Self::for_checked_curve(curve, config, theta0)
    }

    /// A follower on a curve whose length and curvature were already checked against
    /// `config` (by [`ContourFollower::new`] on the same curve, or by a job's plan in
    /// `f64`): only the ramp, the limit, θ0 and the Newton count are validated, a few
    /// dozen operations, so a control period can build it. The curve-wide checks of
    /// `new` sample the whole curve and cost far more.
    /// On an open curve θ0 must lie in [0, end] (`OutOfRange` names `theta0`).
    pub fn for_checked_curve(
        curve: C,
        config: &FollowerConfig,
        theta0: f64,
    ) -> Result<Self, ContourError> {
        let zero = Vector2::new(T::ZERO, T::ZERO);
        let mut follower = Self {
            curve,
            ramp: SpeedRamp::new(&config.ramp)?,
            theta: T::ZERO,
            laps: 0,
            sample: CurveSample {
                position: zero,
                d1: zero,
                d2: zero,
                d3: zero,
            },
            carry: T::ZERO,
            wrap_error: T::ZERO,
            span: T::ZERO,
            closed: true,
            lost: false,
            newton_steps: 0,
        };
        follower.restart(config, theta0)?;
        Ok(follower)
    }

    /// Puts the follower at rest at θ = `theta0` on its curve as it now is (after
    /// [`CurveFollower::curve_mut`] replaced it), with the checks of
    /// [`CurveFollower::for_checked_curve`], in place: nothing the size of the curve
    /// passes through the stack, so a control period can start a contour. On an
    /// error the follower is lost (it holds and refuses to step). Out of line: its
    /// frame is not added to its callers'.
    #[inline(never)]
    pub fn restart(&mut self, config: &FollowerConfig, theta0: f64) -> Result<(), ContourError> {
        self.lost = true;
        self.ramp = SpeedRamp::new(&config.ramp)?;
        let limit = positive("accel_limit_m_s2", config.accel_limit_m_s2)?;
        if config.ramp.accel_m_s2 > limit {
            return Err(ConfigError::out_of_range("accel_m_s2").into());
        }
        if !theta0.is_finite() {
            return Err(ConfigError::not_finite("theta0").into());
        }
        if config.newton_steps > MAX_NEWTON_STEPS {
            return Err(ConfigError::out_of_range("newton_steps").into());
        }
        let (span, closed) = (self.curve.span(), self.curve.is_closed());
        let theta = if closed {
            let mut theta = lit::<T>(theta0 - 2.0 * PI * libm::floor(theta0 / (2.0 * PI)));
            if theta >= span {
                theta = T::ZERO;
            }
            theta
        } else {
            let theta = representable::<T>("theta0", theta0)?;
            if !(theta >= T::ZERO && theta <= span) {
                return Err(ConfigError::out_of_range("theta0").into());
            }
            theta
        };
        self.sample = self.curve.evaluate(theta);
        self.theta = theta;
        self.laps = 0;
        self.carry = T::ZERO;
        self.wrap_error = if closed {
            lit(2.0 * PI - to_f64(span))
        } else {
            T::ZERO
        };
        self.span = span;
        self.closed = closed;
        self.newton_steps = config.newton_steps;
        self.lost = false;
        Ok(())
    }

    /// The curve, to replace in place before [`CurveFollower::restart`]. The follower
    /// is lost (it refuses to step) until restarted.
    pub fn curve_mut(&mut self) -> &mut C {
        self.lost = true;
        &mut self.curve
    }

    /// The curve followed.
    pub fn curve(&self) -> &C {
        &self.curve
    }

    /// Whether θ has reached the end of an open curve (never on a closed one).
    pub fn at_end(&self) -> bool {
        !self.closed && self.theta >= self.span
    }

    /// The speed ramp (start/stop state).
    pub fn ramp(&self) -> &SpeedRamp<T> {
        &self.ramp
    }

    /// Starts moving (jerk-limited ramp to V).
    pub fn start(&mut self) {
        self.ramp.start();
    }

    /// Stops (jerk-limited ramp to rest).
    pub fn stop(&mut self) {
        self.ramp.stop();
    }

    /// The reference where the follower stands, at rest (zero derivatives).
    pub fn at_rest(&self) -> ContourReference<T> {
        let zero = Vector2::new(T::ZERO, T::ZERO);
        ContourReference {
            position: self.sample.position,
            velocity: zero,
            acceleration: zero,
            jerk: zero,
            speed: T::ZERO,
            theta: self.theta,
        }
    }

    /// Current θ (see [`ContourReference::theta`]).
    pub fn theta(&self) -> T {
        self.theta
    }

    /// Completed laps (wraps of θ).
    pub fn laps(&self) -> u32 {
        self.laps
    }

    /// Δθ such that the arc from θ to θ + Δθ is `ds` (Newton on the arc-length integral).
    fn solve_step(&self, ds: T) -> T {
        let d1 = self.sample.d1;
        let sigma = norm(&d1);
        if sigma <= T::ZERO {
            return T::ZERO;
        }
        let sigma_theta = d1.dot(&self.sample.d2) / sigma;
        arc_step(sigma, sigma_theta, ds, self.newton_steps, |u| {
            norm(&self.curve.tangent(self.theta + u))
        })
    }

    /// Whether a step has failed (see [`ContourFollower::step`]): the follower holds.
    pub fn is_lost(&self) -> bool {
        self.lost
    }

    /// Advances one control period and returns the reference at its end.
    ///
    /// Errors: [`ContourError::LostContour`] when the arc-length step cannot be solved
    /// on this curve: Δθ not finite or beyond half a turn, a reference not finite, or
    /// a step whose chord is longer than the arc commanded (θ ran past where the
    /// curve nearly stops, as at the ends of a nearly collinear contour, T 3.2.2 asks
    /// for |C(θk+1) − C(θk)| = V·Ts). The follower then holds at its last good θ and
    /// keeps returning the error: nothing is integrated past a step it could not take.
    pub fn step(&mut self) -> Result<ContourReference<T>, ContourError> {
        if self.lost {
            return Err(ContourError::LostContour);
        }
        let sp = self.ramp.step();
        let target = sp.ds + self.carry;
        let dth = self.solve_step(target);
        let next = self.theta + dth;
        let taken = next - self.theta;
        let mut theta = next;
        // The wrap's rounding correction is zero when 2π rounds exactly (f64), so
        // whether θ wrapped is its own flag: every wrap is a lap.
        let mut wrap = T::ZERO;
        let mut wrapped = false;
        let mut taken = taken;
        let mut clamped = false;
        if theta >= self.span {
            if self.closed {
                theta -= self.span;
                wrap = self.wrap_error;
                wrapped = true;
            } else {
                // The end of an open curve: no further. What is left of the step is
                // dropped with the carry below.
                theta = self.span;
                taken = dth;
                clamped = true;
            }
        }
        let sample = self.curve.evaluate(theta);
        // The chord can only be shorter than the arc; allow the rounding of the two
        // positions (a few ulps of their size; their 1-norms bound it, no square root
        // needed) and 1 % of the step. Squared on both sides: the bound is not negative.
        let chord_sq = (sample.position - self.sample.position).norm_squared();
        let size = sample.position.x.abs()
            + sample.position.y.abs()
            + self.sample.position.x.abs()
            + self.sample.position.y.abs();
        let bound = target.max(T::ZERO) * lit(1.01) + size * lit::<T>(8.0) * T::default_epsilon();
        let solved = dth.is_finite()
            && dth < lit(PI)
            && sample.position.is_finite_all()
            && sample.d1.is_finite_all()
            && chord_sq <= bound * bound;
        if !solved {
            self.lost = true;
            return Err(ContourError::LostContour);
        }
        if wrapped {
            self.laps = self.laps.wrapping_add(1);
        }
        self.theta = theta;
        self.sample = sample;
        let s = &self.sample;
        let sigma = norm(&s.d1);
        self.carry = if target > T::ZERO {
            (dth - taken - wrap) * sigma
        } else {
            T::ZERO
        };
        // Stopped at an open curve's end: the reference is at rest there, whatever is
        // left of the ramp.
        let (v, a, j) = if clamped {
            (T::ZERO, T::ZERO, T::ZERO)
        } else {
            (sp.v, sp.a, sp.j)
        };
        let (th_dot, th_ddot, th_dddot) = if sigma > T::ZERO {
            let s_t = s.d1.dot(&s.d2) / sigma;
            let s_tt = (s.d2.norm_squared() + s.d1.dot(&s.d3)) / sigma - s_t * s_t / sigma;
            parameter_rates(sigma, s_t, s_tt, v, a, j)
        } else {
            (T::ZERO, T::ZERO, T::ZERO)
        };
        let reference = ContourReference {
            position: s.position,
            velocity: s.d1 * th_dot,
            acceleration: s.d2 * (th_dot * th_dot) + s.d1 * th_ddot,
            jerk: s.d3 * (th_dot * th_dot * th_dot)
                + s.d2 * (lit::<T>(3.0) * th_dot * th_ddot)
                + s.d1 * th_dddot,
            speed: v,
            theta,
        };
        let derivatives = [reference.velocity, reference.acceleration, reference.jerk];
        if derivatives.iter().all(|d| d.is_finite_all()) {
            Ok(reference)
        } else {
            self.lost = true;
            Err(ContourError::LostContour)
        }
    }
}

#[cfg(test)]
mod tests;
