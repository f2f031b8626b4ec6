//! A machine of N Hall-sensed linear axes following joint-space jobs: the single
//! LM1247 axis is `Joints<T, 1>`, the three carriages of a delta `Joints<T, 3>`.
//!
//! One [`AxisLaw`] (coefficients) drives N [`AxisState`]s; each axis has its own
//! [`HallAxis`] because each sensor set is calibrated on its own. The control period
//! is [`JointsConfig::period_s`], given once and passed down to every part.
//!
//! A job is a list of [`Segment`]s: rest-to-rest minimum-jerk moves of every axis to a
//! target in a given time (a move to where the axis already is, is a dwell). Stopping
//! ramps every axis from its present reference velocity to rest in the same time at
//! the configured deceleration, so the joint-space direction of motion is kept.

use crate::app::axis::{AxisConfig, AxisFault, AxisLaw, AxisOutput, AxisState, HallAxis};
use crate::app::calibrate::{
    fit_sensors, CalibrationFailure, CalibrationFit, CalibrationSweep, HallMachine, HallSample,
    SweepMode, COAST_BOUND_M,
};
use crate::app::supervisor::{Machine, NonFiniteOutput, Step};
use crate::error::{
    build_each, factor, in_range, positive, representable_each, ConfigContext, ConfigError,
};
use crate::scalar::Real;
use crate::sensing::hall::{HallConfig, SelfCalibration};
use crate::trajectory::quintic::Quintic;
use crate::trajectory::Reference;

mod job;
pub use job::{JointJob, Segment, MAX_SEGMENTS};

/// Everything a machine of N axes needs, in SI units.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct JointsConfig<const N: usize> {
    /// Control period, s: the only place it is stated.
    pub period_s: f64,
    /// The control law, shared by every axis.
    pub axis: AxisConfig,
    /// Hall decoder of each axis.
    pub hall: [HallConfig; N],
    /// Position of each axis at its first good sample (homing), m.
    pub home_m: [f64; N],
    /// Travel of each axis `[min, max]`, m: job targets must lie inside.
    pub travel_m: [[f64; 2]; N],
    /// Largest speed a job may ask of an axis, m/s.
    pub speed_limit_m_s: f64,
    /// Largest acceleration a job may ask of an axis, and the deceleration of a stop, m/s².
    pub accel_limit_m_s2: f64,
}

impl JointsConfig<1> {
    /// One LM1247 axis at 10 kHz, homed at 4.3 mm, 0–100 mm travel, 0.5 m/s and
    /// 20 m/s² (below the 3.6 N rating on the 121 g slider with payload: 30 m/s²).
    pub const LM1247: Self = Self {
        period_s: 1e-4,
        axis: AxisConfig::LM1247_SLAVE,
        hall: [HallConfig::LM1247_16BIT],
        home_m: [0.0043],
        travel_m: [[0.0, 0.1]],
        speed_limit_m_s: 0.5,
        accel_limit_m_s2: 20.0,
    };
}

/// Why a job does not fit the machine. `segment` and `axis` index the job.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum JobError {
    /// The job has no segment.
    Empty,
    /// A target or duration is NaN or infinite, or a duration is not positive.
    NotFinite {
        /// Segment index.
        segment: u8,
    },
    /// A target lies outside the axis' travel.
    OutOfTravel {
        /// Segment index.
        segment: u8,
        /// Axis index.
        axis: u8,
    },
    /// A move needs more speed or acceleration than the limits allow.
    TooFast {
        /// Segment index.
        segment: u8,
        /// Axis index.
        axis: u8,
    },
    /// A segment lasts 2^32 control periods or more (about 5 days at 10 kHz), or longer
    /// than the scalar holds a time (`Real::RANGE`: 64 s in Q6.25): split it (a
    /// week-long dwell is two segments).
    TooLong {
        /// Segment index.
        segment: u8,
    },
    /// At `Start`: an axis moves faster than [`AT_REST_M_S`] (a carriage sliding down
    /// its rail with the drive off); the first move starts from rest.
    Moving {
        /// Axis index.
        axis: u8,
    },
}

/// Fastest an axis may move at `Start`, m/s. The first move is planned from rest: a
/// Keops carriage caught at 0.12 m/s while it slid to its end stop met the 3.6 N
/// limit for 20 ms, at 15 mm/s the peak stays within 0.1 N of a start from rest. The
/// velocity observer's noise at rest is below 0.5 mm/s RMS, ten times less.
pub const AT_REST_M_S: f64 = 5e-3;

/// Which axis stopped the machine, and why.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct JointFault {
    /// Axis index.
    pub axis: u8,
    /// The axis' fault.
    pub fault: AxisFault,
}

/// One period's telemetry.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct JointTelemetry<T, const N: usize> {
    /// Reference of each axis.
    pub reference: [Reference<T>; N],
    /// What each axis did (force, measured position, velocity, disturbance, status).
    pub axes: [AxisOutput<T>; N],
}

/// Where the job in progress is (the job itself is lent to each period by the
/// supervisor, which keeps it).
#[derive(Copy, Clone, Debug)]
struct Run<T, const N: usize> {
    segment: usize,
    moves: [Quintic<T>; N],
    period: u32,
    periods: u32,
}

/// The stop ramp: every axis from (p0, v0) to rest in `periods`.
#[derive(Copy, Clone, Debug)]
struct StopRamp<T, const N: usize> {
    start: [Reference<T>; N],
    /// −v0/T per axis.
    deceleration: [T; N],
    period: u32,
    periods: u32,
}

/// N axes as a [`Machine`] the supervisor runs.
#[derive(Clone, Debug)]
pub struct Joints<T: Real, const N: usize> {
    period_s: f64,
    ts: T::Coef,
    law: AxisLaw<T>,
    sensors: [HallAxis<T>; N],
    axes: [AxisState<T>; N],
    pitch_m: f64,
    travel_m: [[f64; 2]; N],
    speed_limit_m_s: f64,
    accel_limit_m_s2: f64,
    sweep: Option<CalibrationSweep<T, N>>,
    sweep_start_m: [T; N],
    /// Sum of each axis' force over the settle of each direction (out, back), in
    /// 2^-32 N ([`Real::to_q32`]), and its periods: the force held during the coast
    /// the same way. Not in `T`: a sum of periods passes Q6.25's ±64 N.
    settle_force_q32: [[i64; N]; 2],
    settle_periods: [u32; 2],
    /// The sweep's mode in the last period (to engage the loop after a coast).
    sweep_mode: SweepMode,
    run: Option<Run<T, N>>,
    stop: Option<StopRamp<T, N>>,
    reference: [Reference<T>; N],
    last: [AxisOutput<T>; N],
}

/// Peak speed of a minimum-jerk move of D in T, times T/D: 1.875
/// ([`crate::trajectory::quintic`]).
pub const PEAK_SPEED_RATIO: f64 = 1.875;

/// Peak acceleration of a minimum-jerk move of D in T, times T²/D: 10/√3 = 5.7735
/// ([`crate::trajectory::quintic`]).
pub const PEAK_ACCEL_RATIO: f64 = 5.7735;

/// Whether a minimum-jerk move of `distance_m` in `duration_s` exceeds the limits:
/// peak speed [`PEAK_SPEED_RATIO`]·D/T, peak acceleration [`PEAK_ACCEL_RATIO`]·D/T².
fn too_fast(speed_limit_m_s: f64, accel_limit_m_s2: f64, distance_m: f64, duration_s: f64) -> bool {
    let d = libm::fabs(distance_m);
    PEAK_SPEED_RATIO * d > speed_limit_m_s * duration_s
        || PEAK_ACCEL_RATIO * d > accel_limit_m_s2 * duration_s * duration_s
}

/// Runs `each(k, sensor, state, counts)` on every axis in order; the first fault
/// stops the rest and is named with its axis.
fn each_axis<T: Real, const N: usize>(
    axes: &mut [AxisState<T>; N],
    sensors: &[HallAxis<T>; N],
    inputs: &[[u16; 3]; N],
    mut each: impl FnMut(usize, &HallAxis<T>, &mut AxisState<T>, [u16; 3]) -> Result<(), AxisFault>,
) -> Result<(), JointFault> {
    for (k, ((axis, sensor), counts)) in axes.iter_mut().zip(sensors).zip(inputs).enumerate() {
        each(k, sensor, axis, *counts).map_err(|fault| JointFault {
            axis: k as u8,
            fault,
        })?;
    }
    Ok(())
}

fn rest<T: Real>(position: T) -> Reference<T> {
    Reference {
        position,
        velocity: T::ZERO,
        acceleration: T::ZERO,
    }
}

impl<T: Real, const N: usize> Joints<T, N> {
    /// Validates `config`; a bad field is named with its path
    /// (`axis.dob.bandwidth_rad_s`, `hall[2].pitch_m`, `travel_m[1]`).
    pub fn new(config: &JointsConfig<N>) -> Result<Self, ConfigError> {
        let period_s = positive("period_s", config.period_s)?;
        let law = AxisLaw::new(&config.axis, period_s).within("axis")?;
        let sensors = build_each(
            "hall",
            &config.hall,
            |k, hall| HallAxis::new(hall).at(k).within("hall"),
            |e| e,
        )?;
        let pitch_m = config.hall.first().map_or(0.018, |h| h.pitch_m);
        for (k, (home, [lo, hi])) in config.home_m.iter().zip(config.travel_m.iter()).enumerate() {
            let element = |e: ConfigError| e.indexed(k);
            in_range("travel_m", *lo, f64::MIN, f64::MAX).map_err(element)?;
            in_range("travel_m", *hi, *lo, f64::MAX).map_err(element)?;
            in_range("home_m", *home, *lo, *hi).map_err(element)?;
        }
        let speed_limit_m_s = positive("speed_limit_m_s", config.speed_limit_m_s)?;
        let accel_limit_m_s2 = positive("accel_limit_m_s2", config.accel_limit_m_s2)?;
        let home = representable_each::<T, N>("home_m", config.home_m)?;
        let axes = home.map(AxisState::homed_at);
        let reference = home.map(rest);
        Ok(Self {
            period_s,
            ts: factor::<T>("period_s", period_s)?,
            law,
            sensors,
            last: axes.map(|a| AxisOutput {
                force_n: T::ZERO,
                position_m: a.position_m(),
                velocity_m_s: T::ZERO,
                disturbance_n: T::ZERO,
                saturated: false,
                status: a.status(),
            }),
            axes,
            pitch_m,
            travel_m: config.travel_m,
            speed_limit_m_s,
            accel_limit_m_s2,
            sweep: None,
            sweep_start_m: home,
            settle_force_q32: [[0; N]; 2],
            settle_periods: [0; 2],
            sweep_mode: SweepMode::Track,
            run: None,
            stop: None,
            reference,
        })
    }

    /// The control period, s.
    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    /// The law every axis runs.
    pub fn law(&self) -> &AxisLaw<T> {
        &self.law
    }

    /// The axes' states.
    pub fn axes(&self) -> &[AxisState<T>; N] {
        &self.axes
    }

    /// This period's references.
    pub fn reference(&self) -> &[Reference<T>; N] {
        &self.reference
    }

    /// Steps every axis towards `reference` (a machine built on these joints computes
    /// it, for example from kinematics); the first fault stops all of them.
    pub(crate) fn follow(
        &mut self,
        inputs: &[[u16; 3]; N],
        reference: [Reference<T>; N],
    ) -> Result<[T; N], JointFault> {
        self.reference = reference;
        self.control(inputs)
    }

    /// Drops a stop ramp that is under way (a machine that resumes its own law
    /// after holding).
    pub(crate) fn cancel_stop(&mut self) {
        self.stop = None;
    }

    /// The measured half of a period for a law that couples the axes: every axis
    /// decoded, checked and tracked. Returns each axis' position and velocity estimate
    /// (m, m/s); the first fault stops the rest and is named with its axis. Follow with
    /// [`Joints::actuate`] in the same period.
    pub(crate) fn measure(
        &mut self,
        inputs: &[[u16; 3]; N],
    ) -> Result<([T; N], [T; N]), JointFault> {
        let mut velocity = [T::ZERO; N];
        let law = &self.law;
        each_axis(
            &mut self.axes,
            &self.sensors,
            inputs,
            |k, sensor, axis, counts| {
                let v = law.measure(sensor, axis, counts)?;
                if let Some(out) = velocity.get_mut(k) {
                    *out = v;
                }
                Ok(())
            },
        )?;
        Ok((self.axes.map(|a| a.position_m()), velocity))
    }

    /// The commanded half: each axis' disturbance observer turns its desired
    /// acceleration (m/s²) into a force. `velocity` is what [`Joints::measure`]
    /// returned; `reference` is this period's joint reference (kept for telemetry and
    /// a stop ramp's start). Returns the forces and whether any axis saturated.
    pub(crate) fn actuate(
        &mut self,
        reference: [Reference<T>; N],
        acceleration: &[T; N],
        velocity: &[T; N],
    ) -> Result<([T; N], bool), JointFault> {
        self.reference = reference;
        let mut forces = [T::ZERO; N];
        let mut saturated = false;
        for (k, axis) in self.axes.iter_mut().enumerate() {
            let a = acceleration.get(k).copied().unwrap_or(T::ZERO);
            let v = velocity.get(k).copied().unwrap_or(T::ZERO);
            let out = self.law.actuate(axis, a, v);
            if let crate::app::axis::AxisStatus::Fault(fault) = out.status {
                return Err(JointFault {
                    axis: k as u8,
                    fault,
                });
            }
            saturated |= out.saturated;
            if let (Some(force), Some(last)) = (forces.get_mut(k), self.last.get_mut(k)) {
                *force = out.force_n;
                *last = out;
            }
        }
        Ok((forces, saturated))
    }

    /// Steps every axis with `self.reference`; the first fault stops all of them.
    fn control(&mut self, inputs: &[[u16; 3]; N]) -> Result<[T; N], JointFault> {
        let mut forces = [T::ZERO; N];
        let (law, reference, last) = (&self.law, &self.reference, &mut self.last);
        each_axis(
            &mut self.axes,
            &self.sensors,
            inputs,
            |k, sensor, axis, counts| {
                let r = reference.get(k).copied().unwrap_or(rest(T::ZERO));
                let out = law.step(sensor, axis, counts, &r);
                if let crate::app::axis::AxisStatus::Fault(fault) = out.status {
                    return Err(fault);
                }
                if let (Some(force), Some(last)) = (forces.get_mut(k), last.get_mut(k)) {
                    *force = out.force_n;
                    *last = out;
                }
                Ok(())
            },
        )?;
        Ok(forces)
    }

    /// One coast period of every axis: the settle's mean force held, open loop; an axis
    /// whose decoded position strays beyond [`COAST_BOUND_M`] from the cruise faults.
    fn coast(&mut self, inputs: &[[u16; 3]; N], way: usize) -> Result<[T; N], JointFault> {
        let periods = i64::from(self.settle_periods.get(way).copied().unwrap_or(0).max(1));
        let bound = T::from_f64(COAST_BOUND_M);
        let held = self.settle_force_q32.get(way).map_or([T::ZERO; N], |sums| {
            sums.map(|sum| T::from_q32(sum / periods))
        });
        let mut forces = [T::ZERO; N];
        let (law, reference, last) = (&self.law, &self.reference, &mut self.last);
        each_axis(
            &mut self.axes,
            &self.sensors,
            inputs,
            |k, sensor, axis, counts| {
                let target = reference.get(k).map_or(axis.position_m(), |r| r.position);
                let force = held.get(k).copied().unwrap_or(T::ZERO);
                let out = law.coast(sensor, axis, counts, force)?;
                let stray = out.position_m - target;
                if stray > bound || stray < -bound {
                    law.latch(axis, AxisFault::CoastOutOfBound);
                    return Err(AxisFault::CoastOutOfBound);
                }
                if let (Some(f), Some(last)) = (forces.get_mut(k), last.get_mut(k)) {
                    *f = force;
                    *last = out;
                }
                Ok(())
            },
        )?;
        Ok(forces)
    }

    /// [`too_fast`] with this machine's limits.
    fn too_fast(&self, distance_m: f64, duration_s: f64) -> bool {
        too_fast(
            self.speed_limit_m_s,
            self.accel_limit_m_s2,
            distance_m,
            duration_s,
        )
    }

    fn engage(&mut self) {
        for axis in &mut self.axes {
            axis.engage();
        }
    }

    fn begin_segment(
        &mut self,
        job: &JointJob<N>,
        index: usize,
        from: [f64; N],
    ) -> Result<(), JobError> {
        let (speed_limit, accel_limit) = (self.speed_limit_m_s, self.accel_limit_m_s2);
        let Some(run) = self.run.as_mut() else {
            return Ok(());
        };
        let Some(segment) = job.get(index) else {
            return Err(JobError::Empty);
        };
        let err = |kind: fn(u8, u8) -> JobError, axis: usize| kind(index as u8, axis as u8);
        for (axis, (out, (start, target))) in run
            .moves
            .iter_mut()
            .zip(from.iter().zip(segment.target_m.iter()))
            .enumerate()
        {
            if too_fast(speed_limit, accel_limit, target - start, segment.duration_s) {
                return Err(err(
                    |segment, axis| JobError::TooFast { segment, axis },
                    axis,
                ));
            }
            *out = Quintic::new(*start, target - start, segment.duration_s).map_err(|_| {
                JobError::NotFinite {
                    segment: index as u8,
                }
            })?;
        }
        run.segment = index;
        run.period = 0;
        run.periods = libm::round(segment.duration_s / self.period_s) as u32;
        Ok(())
    }

    /// One period of the stop ramp begun by `begin_stop`, then rest under the PD
    /// (the job is not needed: the ramp starts from the present motion).
    pub fn ramp_to_rest(&mut self, inputs: &[[u16; 3]; N]) -> Result<Step<[T; N]>, JointFault> {
        let mut done = true;
        if let Some(ramp) = self.stop.as_mut() {
            ramp.period = (ramp.period + 1).min(ramp.periods);
            let t = T::count_times(ramp.period, self.ts);
            let half_t_sq = T::from_f64(0.5) * t * t;
            for ((r, s), a) in self
                .reference
                .iter_mut()
                .zip(ramp.start.iter())
                .zip(ramp.deceleration.iter())
            {
                *r = Reference {
                    position: s.position + s.velocity * t + *a * half_t_sq,
                    velocity: s.velocity + *a * t,
                    acceleration: *a,
                };
            }
            done = ramp.period >= ramp.periods;
            if done {
                self.reference = self.reference.map(|r| rest(r.position));
            }
        }
        let forces = self.control(inputs)?;
        if done {
            self.stop = None;
            return Ok(Step::Done(forces));
        }
        Ok(Step::Continue(forces))
    }
}

impl<T: Real, const N: usize> Machine for Joints<T, N> {
    type Inputs = [[u16; 3]; N];
    type Outputs = [T; N];
    type Job = JointJob<N>;
    type JobError = JobError;
    type Coefficients = AxisLaw<T>;
    type SweepSample = HallSample;
    type Calibration = [HallAxis<T>; N];
    type Fault = JointFault;
    type Telemetry = JointTelemetry<T, N>;

    fn safe_outputs(&self) -> [T; N] {
        [T::ZERO; N]
    }

    fn monitor(&mut self, inputs: &[[u16; 3]; N]) -> Result<(), JointFault> {
        let law = &self.law;
        each_axis(
            &mut self.axes,
            &self.sensors,
            inputs,
            |_, sensor, axis, counts| law.monitor(sensor, axis, counts),
        )?;
        self.reference = self.axes.map(|a| rest(a.position_m()));
        Ok(())
    }

    fn begin_calibration(&mut self) {
        self.sweep_start_m = self.axes.map(|a| a.position_m());
        // Valid period and pitch were checked in `new`; a failure leaves no sweep, and
        // `calibrate` then reports the sweep done at once.
        self.sweep = CalibrationSweep::new(self.sweep_start_m, self.pitch_m, self.period_s).ok();
        self.engage();
    }

    fn calibrate(
        &mut self,
        inputs: &[[u16; 3]; N],
        record: &mut dyn FnMut(HallSample),
    ) -> Result<Step<[T; N]>, JointFault> {
        let Some(sweep) = self.sweep.as_mut() else {
            return Ok(Step::Done(self.safe_outputs()));
        };
        self.reference = sweep.reference();
        let mode = sweep.mode();
        let way = usize::from(sweep.backwards());
        let done = sweep.advance(inputs, record);
        let previous = core::mem::replace(&mut self.sweep_mode, mode);
        let forces = match mode {
            SweepMode::Coast => self.coast(inputs, way)?,
            SweepMode::Settle | SweepMode::Track => {
                if previous == SweepMode::Coast {
                    // Back to closed loop: the disturbance estimate restarts here.
                    self.engage();
                }
                let forces = self.control(inputs)?;
                if mode == SweepMode::Settle {
                    if let (Some(sums), Some(periods)) = (
                        self.settle_force_q32.get_mut(way),
                        self.settle_periods.get_mut(way),
                    ) {
                        if previous != SweepMode::Settle {
                            *sums = [0; N];
                            *periods = 0;
                        }
                        for (sum, f) in sums.iter_mut().zip(&forces) {
                            *sum = sum.saturating_add(f.to_q32());
                        }
                        *periods = periods.saturating_add(1);
                    }
                }
                forces
            }
        };
        Ok(if done {
            Step::Done(forces)
        } else {
            Step::Continue(forces)
        })
    }

    fn finish_calibration(&mut self, sensors: &[HallAxis<T>; N]) {
        self.sensors = *sensors;
        // Re-home where the axes are, with the calibrated decoders. After a sweep they
        // rest where it started, to within the loop's last error: the nominal decoders
        // measured that small displacement from the start (their error is the same
        // at the same phase, so it does not carry over), the start would ignore it.
        self.sweep = None;
        self.axes = self.axes.map(|a| AxisState::homed_at(a.position_m()));
    }

    fn check_job(&self, job: &JointJob<N>) -> Result<(), JobError> {
        if job.is_empty() {
            return Err(JobError::Empty);
        }
        for (s, segment) in job.iter().enumerate() {
            let segment_index = s as u8;
            if !(segment.duration_s.is_finite() && segment.duration_s > 0.0)
                || segment.target_m.iter().any(|t| !t.is_finite())
            {
                return Err(JobError::NotFinite {
                    segment: segment_index,
                });
            }
            // The move's time since its start is a signal of the scalar (64 s in Q6.25).
            if segment.duration_s / self.period_s >= f64::from(u32::MAX)
                || segment.duration_s >= T::RANGE
            {
                return Err(JobError::TooLong {
                    segment: segment_index,
                });
            }
            for (axis, (target, [lo, hi])) in segment
                .target_m
                .iter()
                .zip(self.travel_m.iter())
                .enumerate()
            {
                if target < lo || target > hi {
                    return Err(JobError::OutOfTravel {
                        segment: segment_index,
                        axis: axis as u8,
                    });
                }
            }
            // Moves between targets are known now; the first one's start only at Start.
            if let Some(previous) = s.checked_sub(1).and_then(|p| job.get(p)) {
                for (axis, (a, b)) in previous
                    .target_m
                    .iter()
                    .zip(segment.target_m.iter())
                    .enumerate()
                {
                    if self.too_fast(b - a, segment.duration_s) {
                        return Err(JobError::TooFast {
                            segment: segment_index,
                            axis: axis as u8,
                        });
                    }
                }
            }
        }
        Ok(())
    }

    fn begin_job(&mut self, job: &JointJob<N>) -> Result<(), JobError> {
        let moving = |a: &AxisState<T>| libm::fabs(a.velocity_m_s().to_f64()) > AT_REST_M_S;
        if let Some(axis) = self.axes.iter().position(moving) {
            return Err(JobError::Moving { axis: axis as u8 });
        }
        let from = self.axes.map(|a| a.position_m().to_f64());
        self.run = Some(Run {
            segment: 0,
            // Placeholders until `begin_segment` builds the real moves.
            moves: from.map(|p| Quintic::at_rest(T::from_f64(p))),
            period: 0,
            periods: 0,
        });
        if let Err(e) = self.begin_segment(job, 0, from) {
            self.run = None;
            return Err(e);
        }
        self.engage();
        Ok(())
    }

    fn run(
        &mut self,
        job: &JointJob<N>,
        inputs: &[[u16; 3]; N],
    ) -> Result<Step<[T; N]>, JointFault> {
        let mut done = false;
        if let Some(run) = self.run.as_mut() {
            let t = T::count_times(run.period, self.ts);
            self.reference = run.moves.map(|m| m.sample(t));
            run.period += 1;
            if run.period >= run.periods {
                let next = run.segment + 1;
                let from = job.get(run.segment).map(|s| s.target_m);
                match (job.get(next).is_some(), from) {
                    (true, Some(from)) => done = self.begin_segment(job, next, from).is_err(),
                    _ => done = true,
                }
            }
        } else {
            done = true;
        }
        let forces = self.control(inputs)?;
        if done {
            self.run = None;
            return Ok(Step::Done(forces));
        }
        Ok(Step::Continue(forces))
    }

    fn begin_stop(&mut self) {
        self.run = None;
        let start = self.reference;
        let peak = start
            .iter()
            .map(|r| libm::fabs(r.velocity.to_f64()))
            .fold(0.0, f64::max);
        // Same time for every axis: v/a of the fastest, at least one period.
        let periods = libm::ceil(peak / self.accel_limit_m_s2 / self.period_s).max(1.0);
        let inv_duration = 1.0 / (periods * self.period_s);
        self.stop = Some(StopRamp {
            deceleration: start.map(|r| -r.velocity * T::from_f64(inv_duration)),
            start,
            period: 0,
            periods: periods as u32,
        });
    }

    fn stop(
        &mut self,
        _job: &Self::Job,
        inputs: &[[u16; 3]; N],
    ) -> Result<Step<[T; N]>, JointFault> {
        self.ramp_to_rest(inputs)
    }

    fn set_coefficients(&mut self, law: &AxisLaw<T>) {
        self.law = *law;
    }

    fn reset(&mut self) {
        for axis in &mut self.axes {
            axis.reset();
        }
        self.run = None;
        self.stop = None;
        self.sweep = None;
    }

    fn telemetry(&self) -> JointTelemetry<T, N> {
        JointTelemetry {
            reference: self.reference,
            axes: self.last,
        }
    }
}

impl<T: Real, const N: usize> HallMachine<N> for Joints<T, N> {
    fn fit(
        hall: &[HallConfig; N],
        samples: &CalibrationFit<N>,
    ) -> Result<([HallAxis<T>; N], [SelfCalibration; N]), CalibrationFailure> {
        fit_sensors(hall, samples)
    }
}

/// Output `index` is axis `index`'s force: that axis, a value not finite.
impl From<NonFiniteOutput> for JointFault {
    fn from(output: NonFiniteOutput) -> Self {
        Self {
            axis: output.index,
            fault: AxisFault::NotFinite,
        }
    }
}

#[cfg(test)]
mod tests;
