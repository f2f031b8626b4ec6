//! The autofocus stage as a machine: a camera with a motorized zoom on a focus axis,
//! kept at the sharpness peak by the self-optimizing focus law (T 7.2.2,
//! docs/control.md §24, [`crate::control::autofocus`]) while a job steps the zoom
//! through a schedule of magnifications ([`product`]), operable over the host link
//! ([`link`]).
//!
//! # Inputs and outputs
//!
//! Each control period the stage reads the focus axis' position and, in a period in
//! which a camera frame has been read out, that frame's window moments
//! ([`crate::sensing::sharpness::window_moments`]: the exact integer sums Σ i and Σ i²
//! over the window) with the axis position latched at the frame's exposure. A board
//! computes the moments in the period the frame's DMA completes (4096 pixels, four
//! integer sums and squares to an iteration: no floating point, no rounding), so the
//! 4 KiB frame stays in its DMA buffer and 16 bytes of it reach the machine; the
//! sharpness S = (n S2 − S1²)/(n S1) is formed here, once per frame.
//!
//! It writes the focus axis' acceleration command (the axis follows acceleration
//! behind its disturbance observer, T 4.1.2) and the zoom drive's magnification
//! setpoint. Safe outputs: no acceleration, the zoom where it was commanded last.
//!
//! # A period of a job
//!
//! At the start of a step the zoom is commanded to the step's magnification. A frame
//! goes to [`Autofocus::frame`] (gradient window, mode, velocity target); every period
//! the position goes to a velocity observer ([`TrackingObserver`], fed the command
//! applied) and the law's [`Autofocus::step`] gives the acceleration command. When the
//! schedule's last dwell is over, the velocity reference ramps to zero over a frame
//! period and the job is done once the axis rests; a stop does the same at once.
//!
//! # Faults
//!
//! [`StageFault`]: frames missing for longer than [`StageConfig::missed_frames`]
//! frame periods, a dark frame (zero mean: a closed shutter, a dead lamp), a scene
//! without texture (the law's [`AutofocusError::NoTexture`]), a position that is not
//! finite, the axis at a hard stop, the law coming to rest at the end of its travel
//! (the sharpness still rising there: no peak within the travel), a non-finite
//! output. The stage has no calibration run: its sweep sample is [`NoSweep`] and its
//! calibration `()`, so the framework's `FinishCalibration(())` makes it ready.

pub mod link;
pub mod product;

use crate::app::supervisor::{
    first_non_finite_index, FiniteOutputs, Machine, NoSweep, NonFiniteOutput, Step,
};
use crate::control::autofocus::{
    Autofocus, AutofocusConfig, AutofocusError, AutofocusMode, AutofocusState,
};
use crate::error::{in_range, positive, ConfigContext, ConfigError};
use crate::scalar::{lit, Float, Real};
use crate::sensing::sharpness::WindowMoments;
use crate::sensing::velocity::{TrackingObserver, TrackingObserverConfig, TrackingObserverState};
use product::{JOB_STEPS, RING};

/// The stage's fixed configuration (what the settings do not change).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct StageConfig {
    /// Control period, s.
    pub period_s: f64,
    /// Control periods per camera frame.
    pub periods_per_frame: u32,
    /// Frame periods without a frame, in a row, after which a running job stops.
    pub missed_frames: u32,
    /// The focus axis' hard stops [min, max], m.
    pub stops_m: [f64; 2],
    /// The zoom's magnifications [min, max].
    pub zoom_range: [f64; 2],
    /// The zoom's magnification at power-up.
    pub power_up_magnification: f64,
    /// The longest dwell of a step, periods.
    pub max_dwell_periods: u32,
}

/// One step of a zoom schedule.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ZoomStep {
    /// Magnification the zoom is commanded to.
    pub magnification: f32,
    /// Control periods the step lasts.
    pub dwell_periods: u32,
}

/// A job: the zoom's steps in order.
pub type ZoomSchedule = heapless::Vec<ZoomStep, JOB_STEPS>;

/// A camera frame read out in this period.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Frame<T> {
    /// The window's exact moments.
    pub moments: WindowMoments,
    /// The focus axis' position at the frame's exposure, m.
    pub exposure_position_m: T,
}

/// One period's inputs.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct StageInputs<T> {
    /// The focus axis' position, m.
    pub position_m: T,
    /// The frame read out in this period, if one was.
    pub frame: Option<Frame<T>>,
}

/// One period's outputs.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct StageOutputs<T> {
    /// The focus axis' acceleration command, m/s².
    pub acceleration_m_s2: T,
    /// The zoom drive's setpoint.
    pub magnification: T,
}

/// Index 0 the acceleration, 1 the magnification.
impl<T: Real> FiniteOutputs for StageOutputs<T> {
    fn first_not_finite(&self) -> Option<u8> {
        first_non_finite_index([self.acceleration_m_s2, self.magnification])
    }
}

/// Why the stage stopped.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StageFault {
    /// No frame for longer than [`StageConfig::missed_frames`] frame periods.
    FrameMissing,
    /// A frame whose window is all zero.
    DarkFrame,
    /// A sharpness below the law's `min_sharpness`.
    NoTexture,
    /// A position (now or at an exposure) or a value of the law not finite.
    NotFinite,
    /// The axis at a hard stop.
    HardStop {
        /// The upper stop (else the lower).
        upper: bool,
    },
    /// The law came to rest within its window's excursion of the end of its travel:
    /// the sharpness rose to there, its peak lies beyond.
    NoPeak,
    /// An output not finite.
    Output(NonFiniteOutput),
}

impl From<NonFiniteOutput> for StageFault {
    fn from(fault: NonFiniteOutput) -> Self {
        Self::Output(fault)
    }
}

/// Why a job does not fit the stage.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum JobError {
    /// No step.
    Empty,
    /// A magnification not finite or outside the zoom's range.
    Magnification {
        /// The step.
        step: u8,
    },
    /// A dwell of no period, or longer than the limit.
    Dwell {
        /// The step.
        step: u8,
    },
}

/// What the law does, as telemetry carries it.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum LawMode {
    /// Searching from rest.
    Search,
    /// Following the gradient.
    Track,
    /// At rest at the peak, watching the sharpness.
    Hold,
}

/// One period's telemetry.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct StageTelemetry<T> {
    /// Focus position, m.
    pub position_m: T,
    /// Its velocity estimate, m/s.
    pub velocity_m_s: T,
    /// The last frame's sharpness, grey levels.
    pub sharpness: T,
    /// The last gradient estimate (of −ln S, 1/m), if the window spanned δ.
    pub gradient: Option<T>,
    /// The velocity reference q̇ref, m/s.
    pub velocity_reference_m_s: T,
    /// The acceleration command, m/s².
    pub acceleration_m_s2: T,
    /// The zoom's setpoint.
    pub magnification: T,
    /// The law's mode.
    pub mode: LawMode,
    /// The schedule's step (its length once the schedule is over).
    pub step: u8,
}

/// The stage's coefficients: the focus law and the velocity observer.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FocusLaw<T: Float> {
    /// The self-optimizing focus law.
    pub autofocus: Autofocus<T, RING>,
    /// The focus axis' velocity observer.
    pub observer: TrackingObserver<T>,
    /// The positions inside which the law's rest is a peak: its travel narrowed by
    /// its window's excursion δ at each end, m.
    peak_band: [T; 2],
}

impl<T: Float> FocusLaw<T> {
    /// Validates the law (path `law.…`) and the observer (`velocity.…`) for the
    /// control period `period_s`.
    pub fn new(
        law: &AutofocusConfig,
        velocity: &TrackingObserverConfig,
        period_s: f64,
    ) -> Result<Self, ConfigError> {
        let autofocus = Autofocus::new(law, period_s).within("law")?;
        let observer = TrackingObserver::new(velocity, period_s).within("velocity")?;
        let [lo, hi] = law.travel_m;
        let delta = law.window_excursion_m;
        // The travel must leave room for a peak between its two bands.
        let band = in_range("window_excursion_m", delta, 0.0, 0.25 * (hi - lo)).within("law")?;
        Ok(Self {
            autofocus,
            observer,
            peak_band: [lit::<T>(lo + band), lit::<T>(hi - band)],
        })
    }
}

/// Speed below which a ramp to rest counts as at rest, m/s (a twentieth of the
/// search speed).
const REST_SPEED_M_S: f64 = 5e-5;

/// The longest ramp to rest, s: past it the job ends regardless (the law's
/// acceleration limit brings μ0 to rest in 10 ms; the velocity loop settles in 5/C).
const RAMP_LIMIT_S: f64 = 0.5;

/// The autofocus stage in the scalar `T`.
pub struct FocusStage<T: Float> {
    config: StageConfig,
    law: FocusLaw<T>,
    stops: [T; 2],
    inv_frame_period: T,
    rest_speed: T,
    ramp_limit: u32,
    missed_limit: u32,
    state: AutofocusState<T, RING>,
    observer: Option<TrackingObserverState<T>>,
    position: T,
    acceleration: T,
    magnification: T,
    sharpness: T,
    step: usize,
    in_step: u32,
    since_frame: u32,
    /// Periods of the ramp to rest, once it began.
    ramp: Option<u32>,
}

impl<T: Float> FocusStage<T> {
    /// The stage of `config` running `law`, at rest, the zoom at its power-up
    /// magnification.
    ///
    /// Errors: a period, frame count, stop or zoom range that is not finite and
    /// ordered (`period_s`, `periods_per_frame`, `stops_m`, `zoom_range`,
    /// `power_up_magnification`).
    pub fn new(config: &StageConfig, law: FocusLaw<T>) -> Result<Self, ConfigError> {
        let ts = positive("period_s", config.period_s)?;
        if config.periods_per_frame == 0 {
            return Err(ConfigError::not_positive("periods_per_frame"));
        }
        let [lo, hi] = config.stops_m;
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(ConfigError::out_of_range("stops_m"));
        }
        let [m_lo, m_hi] = config.zoom_range;
        // Both finite and positive: ordered as numbers.
        if positive("zoom_range", m_lo)? >= positive("zoom_range", m_hi)? {
            return Err(ConfigError::out_of_range("zoom_range"));
        }
        let m0 = in_range(
            "power_up_magnification",
            config.power_up_magnification,
            m_lo,
            m_hi,
        )?;
        let frame_s = ts * f64::from(config.periods_per_frame);
        Ok(Self {
            config: *config,
            law,
            stops: [lit::<T>(lo), lit::<T>(hi)],
            inv_frame_period: lit::<T>(1.0 / frame_s),
            rest_speed: lit::<T>(REST_SPEED_M_S),
            ramp_limit: (RAMP_LIMIT_S / ts) as u32,
            missed_limit: config
                .missed_frames
                .saturating_mul(config.periods_per_frame),
            state: AutofocusState::default(),
            observer: None,
            position: T::ZERO,
            acceleration: T::ZERO,
            magnification: lit::<T>(m0),
            sharpness: T::ZERO,
            step: 0,
            in_step: 0,
            since_frame: 0,
            ramp: None,
        })
    }

    /// The stage's fixed configuration.
    pub fn config(&self) -> &StageConfig {
        &self.config
    }

    /// The position checked (finite, off the hard stops) and the velocity estimate,
    /// the observer fed the acceleration applied over the last period.
    fn sense(&mut self, position_m: T) -> Result<(T, T), StageFault> {
        if !position_m.is_finite() {
            return Err(StageFault::NotFinite);
        }
        self.position = position_m;
        let observer = self
            .observer
            .get_or_insert_with(|| TrackingObserverState::at_rest(position_m));
        let velocity = self
            .law
            .observer
            .update(observer, position_m, self.acceleration);
        if !velocity.is_finite() {
            return Err(StageFault::NotFinite);
        }
        Ok((position_m, velocity))
    }

    fn off_the_stops(&self, position_m: T) -> Result<(), StageFault> {
        let [lo, hi] = self.stops;
        if position_m <= lo || position_m >= hi {
            return Err(StageFault::HardStop {
                upper: position_m >= hi,
            });
        }
        Ok(())
    }

    /// A frame to the law; a law at rest at the end of its travel is a fault.
    fn take_frame(&mut self, frame: &Frame<T>) -> Result<(), StageFault> {
        let sharpness = frame
            .moments
            .normalized_variance_f64()
            .map_err(|_| StageFault::DarkFrame)?;
        self.sharpness = lit::<T>(sharpness);
        let was_holding = matches!(self.state.mode, AutofocusMode::Hold { .. });
        let mode = self
            .law
            .autofocus
            .frame(&mut self.state, frame.exposure_position_m, self.sharpness)
            .map_err(|e| match e {
                AutofocusError::NotFinite => StageFault::NotFinite,
                AutofocusError::NoTexture => StageFault::NoTexture,
            })?;
        let [lo, hi] = self.law.peak_band;
        let q = frame.exposure_position_m;
        if matches!(mode, AutofocusMode::Hold { .. }) && !was_holding && (q < lo || q > hi) {
            return Err(StageFault::NoPeak);
        }
        Ok(())
    }

    /// Starts the ramp of the velocity reference to zero over a frame period.
    fn begin_ramp(&mut self) {
        self.state.target_velocity_m_s = T::ZERO;
        self.state.ramp_m_s2 =
            (T::ZERO - self.state.reference_velocity_m_s) * self.inv_frame_period;
        self.ramp = Some(0);
    }

    /// One period of the ramp to rest: done once the reference is zero and the axis
    /// rests, or past the ramp's limit.
    fn ramp_period(
        &mut self,
        position_m: T,
        velocity: T,
    ) -> Result<Step<StageOutputs<T>>, StageFault> {
        let a = self.law_step(position_m, velocity)?;
        let periods = self.ramp.unwrap_or(0).saturating_add(1);
        self.ramp = Some(periods);
        let at_rest = self.state.reference_velocity_m_s == T::ZERO
            && velocity < self.rest_speed
            && velocity > -self.rest_speed;
        let outputs = self.outputs(a);
        Ok(if at_rest || periods >= self.ramp_limit {
            Step::Done(outputs)
        } else {
            Step::Continue(outputs)
        })
    }

    fn law_step(&mut self, position_m: T, velocity: T) -> Result<T, StageFault> {
        let a = self
            .law
            .autofocus
            .step(&mut self.state, position_m, velocity)
            .map_err(|_| StageFault::NotFinite)?;
        self.acceleration = a;
        Ok(a)
    }

    fn outputs(&self, acceleration: T) -> StageOutputs<T> {
        StageOutputs {
            acceleration_m_s2: acceleration,
            magnification: self.magnification,
        }
    }
}

impl<T: Float> Machine for FocusStage<T> {
    type Inputs = StageInputs<T>;
    type Outputs = StageOutputs<T>;
    type Job = ZoomSchedule;
    type JobError = JobError;
    type Coefficients = FocusLaw<T>;
    type SweepSample = NoSweep;
    type Calibration = ();
    type Fault = StageFault;
    type Telemetry = StageTelemetry<T>;

    fn safe_outputs(&self) -> StageOutputs<T> {
        self.outputs(T::ZERO)
    }

    /// The position checked and the velocity observed (the safe outputs applied:
    /// no acceleration); frames are not needed at rest.
    fn monitor(&mut self, inputs: &StageInputs<T>) -> Result<(), StageFault> {
        self.acceleration = T::ZERO;
        self.sense(inputs.position_m).map(|_| ())
    }

    fn begin_calibration(&mut self) {}

    fn calibrate(
        &mut self,
        inputs: &StageInputs<T>,
        _record: &mut dyn FnMut(NoSweep),
    ) -> Result<Step<StageOutputs<T>>, StageFault> {
        self.monitor(inputs)?;
        Ok(Step::Done(self.safe_outputs()))
    }

    fn finish_calibration(&mut self, _calibration: &()) {}

    fn check_job(&self, job: &ZoomSchedule) -> Result<(), JobError> {
        if job.is_empty() {
            return Err(JobError::Empty);
        }
        let [m_lo, m_hi] = self.config.zoom_range;
        for (k, step) in job.iter().enumerate() {
            let step_no = u8::try_from(k).unwrap_or(u8::MAX);
            let m = f64::from(step.magnification);
            // Not `!(lo..=hi).contains`: a NaN is refused too.
            if !(m >= m_lo && m <= m_hi) {
                return Err(JobError::Magnification { step: step_no });
            }
            if step.dwell_periods == 0 || step.dwell_periods > self.config.max_dwell_periods {
                return Err(JobError::Dwell { step: step_no });
            }
        }
        Ok(())
    }

    /// A new search from the present position, the first step's zoom.
    fn begin_job(&mut self, job: &ZoomSchedule) -> Result<(), JobError> {
        self.check_job(job)?;
        self.state = AutofocusState::default();
        self.step = 0;
        self.in_step = 0;
        self.since_frame = 0;
        self.ramp = None;
        Ok(())
    }

    fn run(
        &mut self,
        job: &ZoomSchedule,
        inputs: &StageInputs<T>,
    ) -> Result<Step<StageOutputs<T>>, StageFault> {
        let (q, v) = self.sense(inputs.position_m)?;
        self.off_the_stops(q)?;
        if self.ramp.is_some() {
            return self.ramp_period(q, v);
        }
        let Some(step) = job.get(self.step) else {
            self.begin_ramp();
            return self.ramp_period(q, v);
        };
        if self.in_step == 0 {
            self.magnification = lit::<T>(f64::from(step.magnification));
        }
        match &inputs.frame {
            Some(frame) => {
                self.since_frame = 0;
                self.take_frame(frame)?;
            }
            None => {
                self.since_frame = self.since_frame.saturating_add(1);
                if self.since_frame > self.missed_limit {
                    return Err(StageFault::FrameMissing);
                }
            }
        }
        let a = self.law_step(q, v)?;
        self.in_step += 1;
        if self.in_step >= step.dwell_periods {
            self.in_step = 0;
            self.step += 1;
            if self.step >= job.len() {
                self.begin_ramp();
            }
        }
        Ok(Step::Continue(self.outputs(a)))
    }

    fn begin_stop(&mut self) {
        self.begin_ramp();
    }

    fn stop(
        &mut self,
        _job: &ZoomSchedule,
        inputs: &StageInputs<T>,
    ) -> Result<Step<StageOutputs<T>>, StageFault> {
        let (q, v) = self.sense(inputs.position_m)?;
        self.off_the_stops(q)?;
        self.ramp_period(q, v)
    }

    fn set_coefficients(&mut self, law: &FocusLaw<T>) {
        self.law = *law;
    }

    /// The law searches again; the observer restarts at the next position read.
    fn reset(&mut self) {
        self.state = AutofocusState::default();
        self.observer = None;
        self.acceleration = T::ZERO;
        self.ramp = None;
    }

    fn telemetry(&self) -> StageTelemetry<T> {
        StageTelemetry {
            position_m: self.position,
            velocity_m_s: self.observer.map_or(T::ZERO, |o| o.velocity),
            sharpness: self.sharpness,
            gradient: self.state.gradient,
            velocity_reference_m_s: self.state.reference_velocity_m_s,
            acceleration_m_s2: self.acceleration,
            magnification: self.magnification,
            mode: match self.state.mode {
                AutofocusMode::Search { .. } => LawMode::Search,
                AutofocusMode::Track => LawMode::Track,
                AutofocusMode::Hold { .. } => LawMode::Hold,
            },
            step: u8::try_from(self.step).unwrap_or(u8::MAX),
        }
    }
}

#[cfg(test)]
mod tests;
