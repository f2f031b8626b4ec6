//! The remote slave on the host link ([`crate::app::host_link`]): a recorded master
//! session uploaded as a job ([`super::session`]), its settings, and its telemetry and
//! faults on the wire.
//!
//! Settings (JSON values, SI units and Hz):
//!
//! | path | what |
//! |---|---|
//! | `/slave/{pd,dob,velocity}/…` | the carriages' law, as the Keops slave names it ([`AxisSettings`]) |
//! | `/model_following/bandwidth_hz` | the local loop on the nominal model, critically damped: Kp = ω², Kd = 2ω |
//! | `/link/hold_after_s` | silence after which the slave stops following and holds |
//! | `/link/give_up_after_s` | silence after which it faults (more whole periods than the hold) |
//!
//! A change is validated as a configuration is ([`AxisLaw::new`], [`FollowLaw::new`],
//! at the 10 kHz period) and applies bumplessly: a running session continues from its
//! state, the silence counted so far measured against the new timeouts.

use super::product::{CONFIG, SESSION_FRAME_BYTES};
use super::recording::{Recording, RecordingError};
use super::session::{SessionJob, SessionJobError, SessionLaw, SessionSlave, SessionTelemetry};
use super::{DeltaFault, FollowJobError, FollowLaw, FollowPhase, RemoteSlaveFault};
use crate::app::axis::settings::AxisSettings;
use crate::app::axis::AxisLaw;
use crate::app::host_link::LinkMachine;
use crate::app::joints::JobError;
use crate::codec::job::JobFile;
use crate::codec::link::code_words as words;
use crate::codec::link::{Channel, ChannelValues, CodeWords, JobKind, JOB_NOT_AT_REST};
use crate::control::pd::PdConfig;
use crate::error::ConfigError;
use crate::scalar::{to_f64, Float};
use core::f64::consts::TAU;
use miniconf::Tree;

/// The local loop's settings.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct ModelFollowingSettings {
    /// Bandwidth of the critically damped error dynamics, Hz.
    #[tree(meta(unit = "Hz", range = "> 0"))]
    pub bandwidth_hz: f64,
}

/// The link's timeouts.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct TimeoutSettings {
    /// Silence (no fresh command) after which the slave holds, s.
    #[tree(meta(unit = "s", range = "> 0"))]
    pub hold_after_s: f64,
    /// Silence after which the slave faults, s.
    #[tree(meta(unit = "s", range = "> hold_after_s, in whole periods"))]
    pub give_up_after_s: f64,
}

/// The remote slave's settings tree.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct RemoteSlaveSettings {
    /// The carriages' law.
    pub slave: AxisSettings,
    /// The local loop on the nominal model.
    pub model_following: ModelFollowingSettings,
    /// The link's timeouts.
    pub link: TimeoutSettings,
}

impl RemoteSlaveSettings {
    /// The settings of the slave as flashed ([`CONFIG`]; its PDs read as critically
    /// damped at √Kp: the presets are).
    pub fn of_product() -> Self {
        Self {
            slave: AxisSettings::of(&CONFIG.slave.joints.axis),
            model_following: ModelFollowingSettings {
                bandwidth_hz: libm::sqrt(CONFIG.model_following.kp_per_s2) / TAU,
            },
            link: TimeoutSettings {
                hold_after_s: CONFIG.hold_after_s,
                give_up_after_s: CONFIG.give_up_after_s,
            },
        }
    }

    /// The local loop these settings describe.
    pub fn model_following(&self) -> PdConfig {
        PdConfig::critically_damped(TAU * self.model_following.bandwidth_hz)
    }
}

/// Refusals of [`LinkMachine::load_job`] before the slave's check.
pub mod load_codes {
    /// Not a recording of this format (magic, version).
    pub const FORMAT: u16 = 0x401;
    /// Blocks of another length than the slave's.
    pub const BLOCK: u16 = 0x402;
    /// Truncated, frames out of order or too long, bytes after the last.
    pub const DAMAGED: u16 = 0x403;
    /// Not a recording job.
    pub const KIND: u16 = 0x404;
}

/// The fault codes of [`LinkMachine::fault_code`].
const FAULTS: [CodeWords; 5] = [
    words(
        1,
        "a carriage faulted (its Hall decoder, a reference or a value not finite)",
        "carriage",
    ),
    words(
        2,
        "the kinematics could not be solved (the commanded motion or the measured effector)",
        "",
    ),
    words(
        3,
        "a supervision of the delta slave's own jobs faulted (contour, following error, saturation)",
        "",
    ),
    words(
        4,
        "an output (a carriage force, the laser duty) was not finite",
        "output (0-2 the carriage forces, 3 the laser duty)",
    ),
    words(
        5,
        "the link to the master fell silent for longer than give_up_after_s (no fresh command)",
        "",
    ),
];

/// The job refusal codes of the slave's check ([`LinkMachine::job_error_code`]) and the
/// loader ([`load_codes`]).
const JOB_REFUSALS: [CodeWords; 11] = [
    words(1, "the session has no frame or no period to play", ""),
    words(
        2,
        "the session's frames pass what a session job holds (12 KiB, about 2 s)",
        "",
    ),
    words(
        3,
        "the session's stream is not one the slave's end takes (periods per command, report coding)",
        "",
    ),
    words(4, "the session names no beam", ""),
    words(5, "the session's beam power is out of the laser's range", ""),
    words(
        6,
        "the session's start is out of the slave's reach (workspace, carriage travel or a singularity)",
        "",
    ),
    words(
        7,
        "the approach to the session's start is too fast or too long",
        "",
    ),
    words(
        load_codes::FORMAT,
        "not a recording the slave reads (magic or format version)",
        "",
    ),
    words(
        load_codes::BLOCK,
        "the recording's blocks are not the slave's 16 samples",
        "",
    ),
    words(
        load_codes::DAMAGED,
        "the recording is damaged (truncated, frames out of order or too long)",
        "",
    ),
    words(
        load_codes::KIND,
        "this slave plays recorded master sessions only",
        "",
    ),
];

/// The telemetry channels: the effector (m); `tracking_error`, its distance from the
/// nominal model while following (0 otherwise); the carriage forces; the beam;
/// `phase` (0 outside a session, 1 approach, 2 waiting, 3 following, 4 holding);
/// `silent`, control periods since the last fresh command; `master_tick`, the master
/// period of the command playing (−1 before the first); `late`, commands that
/// arrived after their play time.
const CHANNELS: [Channel; 12] = [
    Channel {
        name: "x",
        unit: "m",
    },
    Channel {
        name: "y",
        unit: "m",
    },
    Channel {
        name: "z",
        unit: "m",
    },
    Channel {
        name: "tracking_error",
        unit: "m",
    },
    Channel {
        name: "force1",
        unit: "N",
    },
    Channel {
        name: "force2",
        unit: "N",
    },
    Channel {
        name: "force3",
        unit: "N",
    },
    Channel {
        name: "laser",
        unit: "W",
    },
    Channel {
        name: "phase",
        unit: "1",
    },
    Channel {
        name: "silent",
        unit: "1",
    },
    Channel {
        name: "master_tick",
        unit: "1",
    },
    Channel {
        name: "late",
        unit: "1",
    },
];
const _: () = assert!(CHANNELS.len() <= crate::codec::link::MAX_CHANNELS);

/// The wire form of a phase.
fn phase_code(phase: Option<FollowPhase>) -> f32 {
    match phase {
        None => 0.0,
        Some(FollowPhase::Approach) => 1.0,
        Some(FollowPhase::Waiting) => 2.0,
        Some(FollowPhase::Following) => 3.0,
        Some(FollowPhase::Holding) => 4.0,
    }
}

impl<T: Float> LinkMachine for SessionSlave<T> {
    type Settings = RemoteSlaveSettings;
    type JobContext = ();
    const NAME: &'static str = "remote-slave";
    const CHANNELS: &'static [Channel] = &CHANNELS;
    const JOB_KINDS: &'static [JobKind] = &[JobKind::Recording];
    const FAULTS: &'static [CodeWords] = &FAULTS;
    const JOB_REFUSALS: &'static [CodeWords] = &JOB_REFUSALS;

    fn coefficients(
        settings: &RemoteSlaveSettings,
        period_s: f64,
    ) -> Result<SessionLaw<T>, ConfigError> {
        let link = &settings.link;
        Ok(SessionLaw {
            axis: AxisLaw::new(&settings.slave.config(), period_s)?,
            follow: FollowLaw::new(
                link.hold_after_s,
                link.give_up_after_s,
                &settings.model_following(),
                period_s,
            )?,
        })
    }

    /// The recording read and its frames copied into the job.
    fn load_job(_: &mut (), file: &JobFile<'_>, job: &mut SessionJob) -> Result<(), u16> {
        let JobFile::Recording { bytes } = file else {
            return Err(load_codes::KIND);
        };
        let recording = Recording::parse(bytes).map_err(|e| match e {
            RecordingError::Magic | RecordingError::Version(_) => load_codes::FORMAT,
            RecordingError::Block(_) => load_codes::BLOCK,
            RecordingError::Truncated(_)
            | RecordingError::FrameTooLong(_)
            | RecordingError::OutOfOrder(_)
            | RecordingError::TrailingBytes
            | RecordingError::TicksNotRising => load_codes::DAMAGED,
        })?;
        job.load(&recording)
            .map_err(|e| <Self as LinkMachine>::job_error_code(&e))
    }

    fn job_error_code(error: &SessionJobError) -> u16 {
        match error {
            SessionJobError::Empty => 1,
            SessionJobError::TooLong => 2,
            SessionJobError::Stream => 3,
            SessionJobError::Follow(FollowJobError::NoLaserMode) => 4,
            SessionJobError::Follow(FollowJobError::Laser(_)) => 5,
            SessionJobError::Follow(FollowJobError::Unreachable(_)) => 6,
            SessionJobError::Follow(FollowJobError::Approach(JobError::Moving { .. })) => {
                JOB_NOT_AT_REST
            }
            SessionJobError::Follow(FollowJobError::Approach(_)) => 7,
        }
    }

    fn fault_code(fault: &RemoteSlaveFault) -> (u16, u16) {
        match fault {
            RemoteSlaveFault::Slave(DeltaFault::Joint(j)) => (1, u16::from(j.axis)),
            RemoteSlaveFault::Slave(DeltaFault::Kinematics(_)) => (2, 0),
            RemoteSlaveFault::Slave(
                DeltaFault::Contour(_)
                | DeltaFault::ContourError
                | DeltaFault::FollowingError { .. }
                | DeltaFault::Saturated,
            ) => (3, 0),
            RemoteSlaveFault::Slave(DeltaFault::Output(output)) => (4, u16::from(output.index)),
            RemoteSlaveFault::LinkLost => (5, 0),
        }
    }

    /// The effector, how far it is from the nominal model, the forces, the beam, and
    /// where the session is.
    fn sample(t: &SessionTelemetry<T>, values: &mut ChannelValues) {
        let f = |v: T| to_f64(v) as f32;
        let s = &t.slave;
        let [x, y, z] = s.effector_m.map_or([0.0; 3], |p| p.map(f));
        let tracking = match (s.model_m, s.effector_m) {
            (Some(model), Some(p)) => {
                let squares = model.iter().zip(&p).map(|(m, p)| {
                    let d = to_f64(*m) - to_f64(*p);
                    d * d
                });
                libm::sqrt(squares.sum()) as f32
            }
            _ => 0.0,
        };
        let [f1, f2, f3] = s.slave.joints.axes.map(|a| f(a.force_n));
        // Ticks below 2^24 are exact in f32 (28 min of the master at 10 kHz).
        let tick = t.master_tick.map_or(-1.0, |k| k as f32);
        let row: [f32; CHANNELS.len()] = [
            x,
            y,
            z,
            tracking,
            f1,
            f2,
            f3,
            f(s.slave.laser_power_w),
            phase_code(s.phase),
            s.silent_periods as f32,
            tick,
            t.late as f32,
        ];
        values.clear();
        // Within the capacity: checked at compile time above.
        let _ = values.extend_from_slice(&row);
    }
}

// The refusal's words name the session's capacity.
const _: () = assert!(SESSION_FRAME_BYTES == 12 * 1024);

#[cfg(test)]
mod tests;
