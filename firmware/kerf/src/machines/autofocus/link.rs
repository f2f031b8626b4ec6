//! The autofocus stage on the host link ([`crate::app::host_link`]): its settings
//! (the focus law and the velocity observer), how an uploaded schedule job becomes a
//! zoom schedule ([`super::product::load_schedule`]), and its telemetry and faults on
//! the wire.
//!
//! Settings (JSON values, SI units and Hz):
//!
//! | path | what |
//! |---|---|
//! | `/law/max_speed_m_s` | μ0 of eq. 158, the largest reference speed |
//! | `/law/sigmoid_gain_m` | α of eq. 158, on the gradient of −ln S |
//! | `/law/tracking_gain_per_s` | C of eq. 160–161 |
//! | `/law/max_acceleration_m_s2` | the acceleration command's limit |
//! | `/law/window_excursion_m` | δ of eq. 157, the gradient window's extent |
//! | `/law/search_speed_m_s` | speed of the search from rest |
//! | `/law/refocus_change` | relative change of the held sharpness that searches again |
//! | `/law/min_sharpness` | least sharpness of a textured scene |
//! | `/velocity/bandwidth_hz` | the velocity observer's bandwidth |
//!
//! The travel, the camera's frame period and the window's fewest frames are the
//! product's ([`super::product::LAW`]). A change is validated as
//! [`FocusLaw::new`] validates a configuration and applies bumplessly: the law's
//! window and velocity reference and the observer's state are kept.

use super::product::{self, load_schedule, ScheduleError};
use super::{
    FocusLaw, FocusStage, JobError, LawMode, StageConfig, StageFault, StageTelemetry, ZoomSchedule,
};
use crate::app::host_link::LinkMachine;
use crate::codec::job::JobFile;
use crate::codec::link::code_words as words;
use crate::codec::link::{Channel, ChannelValues, CodeWords, JobKind};
use crate::control::autofocus::AutofocusConfig;
use crate::error::ConfigError;
use crate::scalar::{Float, Real};
use crate::sensing::velocity::TrackingObserverConfig;
use core::f64::consts::TAU;
use miniconf::Tree;

/// The focus law's settings (docs/control.md §24).
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct LawSettings {
    /// μ0, m/s.
    #[tree(meta(unit = "m/s", range = "> 0"))]
    pub max_speed_m_s: f64,
    /// α, m (on the relative gradient).
    #[tree(meta(unit = "m", range = "> 0"))]
    pub sigmoid_gain_m: f64,
    /// C, 1/s (C·Ts ≤ 1: 1000 at the 1 kHz period).
    #[tree(meta(unit = "1/s", range = "> 0 and ≤ 1000"))]
    pub tracking_gain_per_s: f64,
    /// |q̈des| limit, m/s².
    #[tree(meta(unit = "m/s²", range = "> 0"))]
    pub max_acceleration_m_s2: f64,
    /// δ, m (at most a quarter of the 9.6 mm travel).
    #[tree(meta(unit = "m", range = "> 0 and ≤ 0.0024"))]
    pub window_excursion_m: f64,
    /// Search speed, m/s.
    #[tree(meta(unit = "m/s", range = "> 0 and ≤ max_speed_m_s"))]
    pub search_speed_m_s: f64,
    /// Relative change of the held sharpness that starts a new search.
    #[tree(meta(range = "> 0 and < 1"))]
    pub refocus_change: f64,
    /// Least sharpness of a textured scene, grey levels.
    #[tree(meta(unit = "grey", range = "> 0"))]
    pub min_sharpness: f64,
}

/// The velocity observer's settings.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct VelocitySettings {
    /// Observer bandwidth, Hz (ω·Ts ≤ 2: 318 Hz at the 1 kHz period).
    #[tree(meta(unit = "Hz", range = "> 0 and ≤ 318"))]
    pub bandwidth_hz: f64,
}

/// The stage's settings tree.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct StageSettings {
    /// The focus law.
    pub law: LawSettings,
    /// The velocity observer.
    pub velocity: VelocitySettings,
}

impl StageSettings {
    /// The settings of a law (the product's travel, frame period and window frames
    /// aside) and an observer bandwidth in Hz.
    pub const fn of(law: &AutofocusConfig, velocity_bandwidth_hz: f64) -> Self {
        Self {
            law: LawSettings {
                max_speed_m_s: law.max_speed_m_s,
                sigmoid_gain_m: law.sigmoid_gain,
                tracking_gain_per_s: law.tracking_gain_per_s,
                max_acceleration_m_s2: law.max_acceleration_m_s2,
                window_excursion_m: law.window_excursion_m,
                search_speed_m_s: law.search_speed_m_s,
                refocus_change: law.refocus_change,
                min_sharpness: law.min_sharpness,
            },
            velocity: VelocitySettings {
                bandwidth_hz: velocity_bandwidth_hz,
            },
        }
    }

    /// The stage's settings at power-up.
    pub const POWER_UP: Self = Self::of(&product::LAW, product::VELOCITY_BANDWIDTH_HZ);

    /// The law these settings describe, on the product's travel, frame period and
    /// window frames (validated by [`FocusLaw::new`]).
    pub fn law(&self) -> AutofocusConfig {
        let l = &self.law;
        AutofocusConfig {
            max_speed_m_s: l.max_speed_m_s,
            sigmoid_gain: l.sigmoid_gain_m,
            tracking_gain_per_s: l.tracking_gain_per_s,
            max_acceleration_m_s2: l.max_acceleration_m_s2,
            window_excursion_m: l.window_excursion_m,
            search_speed_m_s: l.search_speed_m_s,
            refocus_change: l.refocus_change,
            min_sharpness: l.min_sharpness,
            ..product::LAW
        }
    }

    /// The velocity observer these settings describe.
    pub fn velocity(&self) -> TrackingObserverConfig {
        TrackingObserverConfig {
            bandwidth_rad_s: TAU * self.velocity.bandwidth_hz,
        }
    }
}

/// Refusals of [`LinkMachine::load_job`] before the machine's check (its own are
/// [`LinkMachine::job_error_code`]'s).
pub mod load_codes {
    /// Not a schedule job.
    pub const KIND: u16 = 0x401;
    /// More steps than a job holds.
    pub const TOO_MANY: u16 = 0x402;
}

/// What the fault codes of [`LinkMachine::fault_code`] mean.
const FAULTS: [CodeWords; 7] = [
    words(
        1,
        "no camera frame for longer than the frame timeout (5 frame periods)",
        "",
    ),
    words(
        2,
        "a camera frame was dark (every pixel zero: shutter closed or lamp off)",
        "",
    ),
    words(
        3,
        "the scene has too little texture to focus on (sharpness below min_sharpness)",
        "",
    ),
    words(
        4,
        "a position or a value of the focus law was not finite",
        "",
    ),
    words(
        5,
        "the focus axis reached a hard stop",
        "stop (0 the lower, 1 the upper)",
    ),
    words(
        6,
        "no sharpness peak within the travel: the focus came to rest at the travel's end",
        "",
    ),
    words(
        7,
        "an output was not finite",
        "output (0 the acceleration, 1 the magnification)",
    ),
];

/// What the job refusal codes of the machine's check ([`LinkMachine::job_error_code`])
/// and the loader ([`load_codes`]) mean.
const JOB_REFUSALS: [CodeWords; 5] = [
    words(1, "the schedule has no step", ""),
    words(
        2,
        "a step's magnification is outside the zoom's range (1 to 3)",
        "",
    ),
    words(3, "a step's dwell is not positive or longer than 600 s", ""),
    words(load_codes::KIND, "this machine runs schedule jobs only", ""),
    words(load_codes::TOO_MANY, "more steps than a job holds (16)", ""),
];
const _: () = assert!(product::JOB_STEPS == 16 && product::MAX_DWELL_S == 600.0);
const _: () = assert!(product::ZOOM_RANGE[0] == 1.0 && product::ZOOM_RANGE[1] == 3.0);
const _: () = assert!(product::MISSED_FRAMES == 5);

/// The telemetry channels: SI units, the sharpness in grey levels (the normalized
/// variance is a variance over a mean), plain numbers in "1": the magnification, the
/// law's mode (0 search, 1 track, 2 hold) and the schedule's step (0-based; the
/// schedule's length once it is over).
const CHANNELS: [Channel; 9] = [
    Channel {
        name: "position",
        unit: "m",
    },
    Channel {
        name: "sharpness",
        unit: "grey",
    },
    Channel {
        name: "gradient",
        unit: "1/m",
    },
    Channel {
        name: "velocity_reference",
        unit: "m/s",
    },
    Channel {
        name: "velocity",
        unit: "m/s",
    },
    Channel {
        name: "acceleration",
        unit: "m/s²",
    },
    Channel {
        name: "magnification",
        unit: "1",
    },
    Channel {
        name: "law_mode",
        unit: "1",
    },
    Channel {
        name: "step",
        unit: "1",
    },
];
const _: () = assert!(CHANNELS.len() <= crate::codec::link::MAX_CHANNELS);

impl<T: Float> LinkMachine for FocusStage<T> {
    type Settings = StageSettings;
    type JobContext = StageConfig;
    const NAME: &'static str = "autofocus";
    const CHANNELS: &'static [Channel] = &CHANNELS;
    const JOB_KINDS: &'static [JobKind] = &[JobKind::Schedule];
    const FAULTS: &'static [CodeWords] = &FAULTS;
    const JOB_REFUSALS: &'static [CodeWords] = &JOB_REFUSALS;

    fn coefficients(settings: &StageSettings, period_s: f64) -> Result<FocusLaw<T>, ConfigError> {
        FocusLaw::new(&settings.law(), &settings.velocity(), period_s)
    }

    /// The schedule read for the stage of `config`.
    fn load_job(
        config: &mut StageConfig,
        file: &JobFile<'_>,
        job: &mut ZoomSchedule,
    ) -> Result<(), u16> {
        load_schedule(config, file, job).map_err(|e| match e {
            ScheduleError::Kind => load_codes::KIND,
            ScheduleError::TooMany => load_codes::TOO_MANY,
        })
    }

    fn job_error_code(error: &JobError) -> u16 {
        match error {
            JobError::Empty => 1,
            JobError::Magnification { .. } => 2,
            JobError::Dwell { .. } => 3,
        }
    }

    fn fault_code(fault: &StageFault) -> (u16, u16) {
        match fault {
            StageFault::FrameMissing => (1, 0),
            StageFault::DarkFrame => (2, 0),
            StageFault::NoTexture => (3, 0),
            StageFault::NotFinite => (4, 0),
            StageFault::HardStop { upper } => (5, u16::from(*upper)),
            StageFault::NoPeak => (6, 0),
            StageFault::Output(o) => (7, u16::from(o.index)),
        }
    }

    /// The position, the last frame's sharpness, the gradient of −ln S (0 while the
    /// window does not span δ: the law's mode says which), the velocity reference,
    /// the velocity estimate, the acceleration command, the zoom's setpoint, the law's
    /// mode and the schedule's step.
    fn sample(t: &StageTelemetry<T>, values: &mut ChannelValues) {
        let f = |v: T| <T as Real>::to_f64(v) as f32;
        let mode = match t.mode {
            LawMode::Search => 0.0,
            LawMode::Track => 1.0,
            LawMode::Hold => 2.0,
        };
        let row: [f32; CHANNELS.len()] = [
            f(t.position_m),
            f(t.sharpness),
            t.gradient.map_or(0.0, f),
            f(t.velocity_reference_m_s),
            f(t.velocity_m_s),
            f(t.acceleration_m_s2),
            f(t.magnification),
            mode,
            f32::from(t.step),
        ];
        values.clear();
        // Within the capacity: checked at compile time above.
        let _ = values.extend_from_slice(&row);
    }
}

#[cfg(test)]
mod tests;
