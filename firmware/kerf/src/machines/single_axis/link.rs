//! The single axis on the host link ([`crate::app::host_link`]): its settings (the
//! axis law), how an uploaded G-code job becomes a job of moves
//! ([`super::product::load_moves`]), and its telemetry and faults on the wire.
//!
//! Settings (JSON values, SI units and Hz):
//!
//! | path | what |
//! |---|---|
//! | `/pd/kp_per_s2`, `/pd/kd_per_s` | the PD's gains on position and velocity error |
//! | `/dob/bandwidth_hz` | disturbance observer bandwidth |
//! | `/dob/nominal_mass_kg` | its nominal mass An |
//! | `/dob/force_limit_n` | force saturation |
//! | `/dob/compensate` | add the estimate to the command |
//! | `/velocity/bandwidth_hz` | velocity observer bandwidth |
//!
//! A change is validated as [`AxisLaw::new`] validates a configuration and applies
//! bumplessly (the state is kept in physical units, [`AxisLaw::step`]).

use super::product::{load_moves, Axis, MovesErrorKind};
use crate::app::axis::{AxisConfig, AxisFault, AxisLaw};
use crate::app::host_link::LinkMachine;
use crate::app::joints::{JobError, JointFault, JointJob, JointTelemetry, JointsConfig};
use crate::codec::job::JobFile;
use crate::codec::link::code_words as words;
use crate::codec::link::{Channel, ChannelValues, CodeWords, JobKind, JOB_NOT_AT_REST};
use crate::control::dob::DobConfig;
use crate::control::pd::PdConfig;
use crate::error::ConfigError;
use crate::scalar::Real;
use crate::sensing::hall::HallFault;
use crate::sensing::velocity::TrackingObserverConfig;
use core::f64::consts::TAU;
use miniconf::Tree;

/// The PD's gains.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct PdSettings {
    /// Kp, on the position error.
    #[tree(meta(unit = "1/s²", range = "> 0"))]
    pub kp_per_s2: f64,
    /// Kd, on the velocity error.
    #[tree(meta(unit = "1/s", range = "> 0"))]
    pub kd_per_s: f64,
}

/// The disturbance observer's settings.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct DobSettings {
    /// Observer bandwidth, Hz (ω·Ts ≤ 2: 3183 Hz at the 10 kHz period).
    #[tree(meta(unit = "Hz", range = "> 0 and ≤ 3183"))]
    pub bandwidth_hz: f64,
    /// Nominal moving mass An, kg.
    #[tree(meta(unit = "kg", range = "> 0"))]
    pub nominal_mass_kg: f64,
    /// Force saturation, N.
    #[tree(meta(unit = "N", range = "> 0"))]
    pub force_limit_n: f64,
    /// Add the estimate to the command.
    #[tree(meta(range = "true or false"))]
    pub compensate: bool,
}

/// The velocity observer's settings.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct VelocitySettings {
    /// Observer bandwidth, Hz (ω·Ts ≤ 2: 3183 Hz at the 10 kHz period).
    #[tree(meta(unit = "Hz", range = "> 0 and ≤ 3183"))]
    pub bandwidth_hz: f64,
}

/// The axis' settings tree: its law.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct AxisSettings {
    /// PD.
    pub pd: PdSettings,
    /// Disturbance observer.
    pub dob: DobSettings,
    /// Velocity observer.
    pub velocity: VelocitySettings,
}

impl AxisSettings {
    /// The settings of a configuration.
    pub fn of(config: &AxisConfig) -> Self {
        Self {
            pd: PdSettings {
                kp_per_s2: config.pd.kp_per_s2,
                kd_per_s: config.pd.kd_per_s,
            },
            dob: DobSettings {
                bandwidth_hz: config.dob.bandwidth_rad_s / TAU,
                nominal_mass_kg: config.dob.nominal_mass_kg,
                force_limit_n: config.dob.force_limit_n,
                compensate: config.dob.compensate,
            },
            velocity: VelocitySettings {
                bandwidth_hz: config.velocity.bandwidth_rad_s / TAU,
            },
        }
    }

    /// The configuration these settings describe (validated by [`AxisLaw::new`]).
    pub fn config(&self) -> AxisConfig {
        AxisConfig {
            velocity: TrackingObserverConfig {
                bandwidth_rad_s: TAU * self.velocity.bandwidth_hz,
            },
            pd: PdConfig {
                kp_per_s2: self.pd.kp_per_s2,
                kd_per_s: self.pd.kd_per_s,
            },
            dob: DobConfig {
                nominal_mass_kg: self.dob.nominal_mass_kg,
                bandwidth_rad_s: TAU * self.dob.bandwidth_hz,
                force_limit_n: self.dob.force_limit_n,
                compensate: self.dob.compensate,
            },
        }
    }
}

/// Refusals of [`LinkMachine::load_job`] before the machine's check (its own are
/// [`LinkMachine::job_error_code`]'s).
pub mod load_codes {
    /// The G-code does not parse (a feed of zero or none included).
    pub const GCODE: u16 = 0x401;
    /// The program has no move.
    pub const EMPTY: u16 = 0x402;
    /// A move of another axis.
    pub const OFF_AXIS: u16 = 0x403;
    /// A target outside the travel.
    pub const OUT_OF_TRAVEL: u16 = 0x404;
    /// More moves than a job holds.
    pub const TOO_MANY: u16 = 0x405;
    /// Not a G-code job.
    pub const KIND: u16 = 0x406;
}

/// What a Hall fault's detail means.
const HALL_CHECK: &str = "check (0-2 a channel at a rail, 3-5 a channel stuck, 6 the channels disagree, 7 the magnitude, 8 a jump, 9 too fast to unwrap)";

/// What the fault codes of [`LinkMachine::fault_code`] mean.
const FAULTS: [CodeWords; 4] = [
    words(1, "the Hall sensors failed a check", HALL_CHECK),
    words(2, "the reference was not finite", ""),
    words(
        3,
        "a calibration coast strayed beyond its bound from the cruise",
        "",
    ),
    words(4, "a value in the loop or the force was not finite", ""),
];

/// What the job refusal codes of the machine's check ([`LinkMachine::job_error_code`])
/// and the loader ([`load_codes`]) mean.
const JOB_REFUSALS: [CodeWords; 11] = [
    words(1, "the job has no move", ""),
    words(
        2,
        "a target or duration is not finite, or a duration is not positive",
        "",
    ),
    words(3, "a target lies outside the axis' travel", ""),
    words(
        4,
        "a move needs more speed or acceleration than the limits allow",
        "",
    ),
    words(
        5,
        "a move lasts longer than the machine can time (split it)",
        "",
    ),
    words(
        load_codes::GCODE,
        "the G-code does not parse (or a feed is zero or missing)",
        "",
    ),
    words(load_codes::EMPTY, "the program has no move", ""),
    words(
        load_codes::OFF_AXIS,
        "a move of Y, Z, A or B: this machine has the X axis only",
        "",
    ),
    words(
        load_codes::OUT_OF_TRAVEL,
        "a move's target is outside the axis' travel",
        "",
    ),
    words(load_codes::TOO_MANY, "more moves than a job holds (16)", ""),
    words(load_codes::KIND, "this machine runs G-code jobs only", ""),
];
const _: () = assert!(super::product::JOB_MOVES == 16);

/// The telemetry channels.
const CHANNELS: [Channel; 6] = [
    Channel {
        name: "position",
        unit: "m",
    },
    Channel {
        name: "reference",
        unit: "m",
    },
    Channel {
        name: "tracking_error",
        unit: "m",
    },
    Channel {
        name: "velocity",
        unit: "m/s",
    },
    Channel {
        name: "force",
        unit: "N",
    },
    Channel {
        name: "disturbance",
        unit: "N",
    },
];
const _: () = assert!(CHANNELS.len() <= crate::codec::link::MAX_CHANNELS);

/// The detail of a Hall fault: which check (the [`HALL_CHECK`] words).
fn hall_detail(fault: &HallFault) -> u16 {
    match fault {
        HallFault::AdcRail(c) => u16::from(*c).min(2),
        HallFault::StuckChannel(c) => 3 + u16::from(*c).min(2),
        HallFault::ResidualOutOfBand => 6,
        HallFault::MagnitudeOutOfBand => 7,
        HallFault::ImplausibleJump => 8,
        HallFault::SpeedBeyondUnwrap => 9,
    }
}

impl<T: Real> LinkMachine for Axis<T> {
    type Settings = AxisSettings;
    type JobContext = JointsConfig<1>;
    const NAME: &'static str = "single-axis";
    const CHANNELS: &'static [Channel] = &CHANNELS;
    const JOB_KINDS: &'static [JobKind] = &[JobKind::Gcode];
    const FAULTS: &'static [CodeWords] = &FAULTS;
    const JOB_REFUSALS: &'static [CodeWords] = &JOB_REFUSALS;

    fn coefficients(settings: &AxisSettings, period_s: f64) -> Result<AxisLaw<T>, ConfigError> {
        AxisLaw::new(&settings.config(), period_s)
    }

    /// The program read into a job of moves for the axis of `config`.
    fn load_job(
        config: &mut JointsConfig<1>,
        file: &JobFile<'_>,
        job: &mut JointJob<1>,
    ) -> Result<(), u16> {
        let JobFile::Gcode { text } = file else {
            return Err(load_codes::KIND);
        };
        load_moves(config, text, job).map_err(|e| match e.kind {
            MovesErrorKind::Gcode(_) => load_codes::GCODE,
            MovesErrorKind::Empty => load_codes::EMPTY,
            MovesErrorKind::OffAxis => load_codes::OFF_AXIS,
            MovesErrorKind::OutOfTravel => load_codes::OUT_OF_TRAVEL,
            MovesErrorKind::TooMany => load_codes::TOO_MANY,
        })
    }

    fn job_error_code(error: &JobError) -> u16 {
        match error {
            JobError::Empty => 1,
            JobError::NotFinite { .. } => 2,
            JobError::OutOfTravel { .. } => 3,
            JobError::TooFast { .. } => 4,
            JobError::TooLong { .. } => 5,
            JobError::Moving { .. } => JOB_NOT_AT_REST,
        }
    }

    fn fault_code(fault: &JointFault) -> (u16, u16) {
        match &fault.fault {
            AxisFault::Sensor(hall) => (1, hall_detail(hall)),
            AxisFault::ReferenceNotFinite => (2, 0),
            AxisFault::CoastOutOfBound => (3, 0),
            AxisFault::NotFinite => (4, 0),
        }
    }

    /// The measured position, the reference, their difference (reference −
    /// measured), the velocity estimate, the force command and the disturbance
    /// estimate.
    fn sample(t: &JointTelemetry<T, 1>, values: &mut ChannelValues) {
        let f = |v: T| v.to_f64() as f32;
        let [reference] = t.reference;
        let [axis] = t.axes;
        let row: [f32; CHANNELS.len()] = [
            f(axis.position_m),
            f(reference.position),
            f(reference.position - axis.position_m),
            f(axis.velocity_m_s),
            f(axis.force_n),
            f(axis.disturbance_n),
        ];
        values.clear();
        // Within the capacity: checked at compile time above.
        let _ = values.extend_from_slice(&row);
    }
}

#[cfg(test)]
mod tests;
