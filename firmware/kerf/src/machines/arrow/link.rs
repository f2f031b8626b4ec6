//! ARROW on the host link ([`crate::app::host_link`]): its settings (the two parts'
//! gains and the feedforward switch), how an uploaded G-code job becomes a job on the
//! nominal model ([`super::product::load_job`]), and its telemetry and faults on the
//! wire.
//!
//! Settings (JSON values, SI units):
//!
//! | path | what |
//! |---|---|
//! | `/parallel/{kp,kd,ki,k_awp,force_limit}` | the parallel module's PID (A eq. 45) |
//! | `/turntable/{kp,kd,ki,k_awp,force_limit}` | the turntable's |
//! | `/feedforward` | add the inverse dynamic model's forces (A eq. 46) |
//!
//! A change is validated as [`super::product::law`] validates the presets and applies
//! bumplessly: the integrators and the path continue.

use super::job::ArrowJobErrorKind;
use super::machine::{ArrowFault, ArrowJobRefusal, ArrowTelemetry};
use super::product::{law, load_job, Arrow, Job, PROGRAM_POINTS};
use super::ArrowLaw;
use crate::app::drive_set::DriveFault;
use crate::app::host_link::LinkMachine;
use crate::codec::job::JobFile;
use crate::codec::link::code_words as words;
use crate::codec::link::{Channel, ChannelValues, CodeWords, JobKind};
use crate::control::redundant_pid::RedundantPidConfig;
use crate::error::ConfigError;
use crate::scalar::{to_f64, Float};
use miniconf::Tree;

/// The parallel module's gains (forces on the six linear actuators).
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct ParallelSettings {
    /// K_P.
    #[tree(meta(unit = "N/m", range = "> 0"))]
    pub kp: f64,
    /// K_D.
    #[tree(meta(unit = "N·s/m", range = "≥ 0"))]
    pub kd: f64,
    /// K_I.
    #[tree(meta(unit = "N/(m·s)", range = "≥ 0"))]
    pub ki: f64,
    /// Anti-windup back-calculation gain.
    #[tree(meta(unit = "m/N", range = "≥ 0"))]
    pub k_awp: f64,
    /// Force limit of each actuator.
    #[tree(meta(unit = "N", range = "> 0"))]
    pub force_limit: f64,
}

/// The turntable's gains (torques on its two motors).
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct TurntableSettings {
    /// K_P.
    #[tree(meta(unit = "N·m/rad", range = "> 0"))]
    pub kp: f64,
    /// K_D.
    #[tree(meta(unit = "N·m·s/rad", range = "≥ 0"))]
    pub kd: f64,
    /// K_I.
    #[tree(meta(unit = "N·m/(rad·s)", range = "≥ 0"))]
    pub ki: f64,
    /// Anti-windup back-calculation gain.
    #[tree(meta(unit = "rad/(N·m)", range = "≥ 0"))]
    pub k_awp: f64,
    /// Torque limit of each motor.
    #[tree(meta(unit = "N·m", range = "> 0"))]
    pub force_limit: f64,
}

/// ARROW's settings tree.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct ArrowSettings {
    /// The parallel module.
    pub parallel: ParallelSettings,
    /// The turntable.
    pub turntable: TurntableSettings,
    /// Add the inverse dynamic model's forces.
    #[tree(meta(range = "true or false"))]
    pub feedforward: bool,
}

impl ArrowSettings {
    /// The settings of the two parts' configurations (both regularized, as ARROW's
    /// law is) and the feedforward switch.
    pub const fn of(
        parallel: &RedundantPidConfig,
        turntable: &RedundantPidConfig,
        feedforward: bool,
    ) -> Self {
        Self {
            parallel: ParallelSettings {
                kp: parallel.kp,
                kd: parallel.kd,
                ki: parallel.ki,
                k_awp: parallel.k_awp,
                force_limit: parallel.force_limit,
            },
            turntable: TurntableSettings {
                kp: turntable.kp,
                kd: turntable.kd,
                ki: turntable.ki,
                k_awp: turntable.k_awp,
                force_limit: turntable.force_limit,
            },
            feedforward,
        }
    }

    /// ARROW's own (A table 2, feedforward on).
    pub const ARROW: Self = Self::of(
        &RedundantPidConfig::ARROW_PARALLEL,
        &RedundantPidConfig::ARROW_TURNTABLE,
        true,
    );

    /// The parallel module's configuration.
    pub fn parallel(&self) -> RedundantPidConfig {
        let p = &self.parallel;
        RedundantPidConfig {
            kp: p.kp,
            kd: p.kd,
            ki: p.ki,
            k_awp: p.k_awp,
            force_limit: p.force_limit,
            regularize: true,
        }
    }

    /// The turntable's configuration.
    pub fn turntable(&self) -> RedundantPidConfig {
        let t = &self.turntable;
        RedundantPidConfig {
            kp: t.kp,
            kd: t.kd,
            ki: t.ki,
            k_awp: t.k_awp,
            force_limit: t.force_limit,
            regularize: true,
        }
    }
}

/// Refusals of [`LinkMachine::load_job`]: the loader's ([`ArrowJobErrorKind`]) and a
/// job of another kind.
pub mod load_codes {
    /// The G-code does not parse (`kerf gcode` names the line and column).
    pub const GCODE: u16 = 0x301;
    /// The program has no move.
    pub const EMPTY: u16 = 0x302;
    /// More moves, or more points in a move, than the machine holds.
    pub const TOO_LARGE: u16 = 0x303;
    /// A move's spline cannot be built.
    pub const SPLINE: u16 = 0x304;
    /// A move cannot be planned.
    pub const FEED: u16 = 0x305;
    /// The path leaves the workspace or an arm's reach.
    pub const WORKSPACE: u16 = 0x306;
    /// The path comes within the singularity margin.
    pub const SINGULAR: u16 = 0x307;
    /// The machine's job configuration is bad.
    pub const CONFIG: u16 = 0x308;
    /// Not a G-code job.
    pub const KIND: u16 = 0x309;
}

/// What the encoder index of a fault's detail means.
const ENCODER: &str = "encoder (0-5 the actuators, 6-7 the table motors)";

/// The fault codes of [`LinkMachine::fault_code`].
const FAULTS: [CodeWords; 7] = [
    words(1, "an encoder reading was not a number", ""),
    words(
        2,
        "an encoder moved farther in one period than the machine can",
        ENCODER,
    ),
    words(
        3,
        "a joint fell behind its reference by more than the tracking limit",
        ENCODER,
    ),
    words(
        4,
        "the law had no command (a pose off the model, or a value not finite)",
        "",
    ),
    words(5, "the path follower lost the spline", ""),
    words(
        6,
        "an output (an actuator force or a table torque) was not finite",
        "output (0-5 the actuator forces, 6-7 the table torques)",
    ),
    words(
        7,
        "an actuator's drive stopped (in Fault, out of Operation enabled, silent, or refused bring-up)",
        "drive (0-5 the actuators; 255 none: the master stopped them)",
    ),
];

/// The drive a drive fault names (255 for none).
fn drive_index(fault: &DriveFault) -> u16 {
    match *fault {
        DriveFault::LeftOperation { drive, .. }
        | DriveFault::InFault { drive, .. }
        | DriveFault::Silent { drive, .. }
        | DriveFault::SdoAbort { drive, .. }
        | DriveFault::BringUpTimeout { drive, .. }
        | DriveFault::ModeRefused { drive, .. }
        | DriveFault::RatedForce { drive, .. }
        | DriveFault::SdoProtocol { drive, .. }
        | DriveFault::Rebooted { drive } => u16::from(drive),
        DriveFault::Stopped => 255,
    }
}

/// The job refusal codes of the supervisor's check ([`LinkMachine::job_error_code`])
/// and the loader ([`load_codes`]).
const JOB_REFUSALS: [CodeWords; 13] = [
    words(1, "the job has no move", ""),
    words(2, "the job was planned for another control period", ""),
    words(
        3,
        "the machine is not at the job's start (a joint is off by more than the start tolerance)",
        "",
    ),
    words(4, "no encoder reading yet", ""),
    words(load_codes::GCODE, "the G-code does not parse", ""),
    words(load_codes::EMPTY, "the program has no move", ""),
    words(
        load_codes::TOO_LARGE,
        "more moves, or more points in one move, than the machine holds",
        "",
    ),
    words(load_codes::SPLINE, "a move's spline cannot be built", ""),
    words(
        load_codes::FEED,
        "a move cannot be planned (feed, length)",
        "",
    ),
    words(
        load_codes::WORKSPACE,
        "the path leaves the workspace or an arm's reach",
        "",
    ),
    words(
        load_codes::SINGULAR,
        "the path comes within the singularity margin",
        "",
    ),
    words(
        load_codes::CONFIG,
        "the machine's job configuration is bad",
        "",
    ),
    words(load_codes::KIND, "this machine runs G-code jobs only", ""),
];

/// The telemetry channels.
const CHANNELS: [Channel; 16] = [
    Channel {
        name: "x_ref",
        unit: "m",
    },
    Channel {
        name: "y_ref",
        unit: "m",
    },
    Channel {
        name: "z_ref",
        unit: "m",
    },
    Channel {
        name: "theta_z_ref",
        unit: "rad",
    },
    Channel {
        name: "theta_x_ref",
        unit: "rad",
    },
    Channel {
        name: "joint_error",
        unit: "m",
    },
    Channel {
        name: "table_error",
        unit: "rad",
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
        name: "force4",
        unit: "N",
    },
    Channel {
        name: "force5",
        unit: "N",
    },
    Channel {
        name: "force6",
        unit: "N",
    },
    Channel {
        name: "torque1",
        unit: "N·m",
    },
    Channel {
        name: "torque2",
        unit: "N·m",
    },
    Channel {
        name: "move",
        unit: "1",
    },
];
const _: () = assert!(CHANNELS.len() <= crate::codec::link::MAX_CHANNELS);

impl<T: Float> LinkMachine for Arrow<T> {
    type Settings = ArrowSettings;
    type JobContext = ();
    const NAME: &'static str = "arrow";
    const CHANNELS: &'static [Channel] = &CHANNELS;
    const JOB_KINDS: &'static [JobKind] = &[JobKind::Gcode];
    const FAULTS: &'static [CodeWords] = &FAULTS;
    const JOB_REFUSALS: &'static [CodeWords] = &JOB_REFUSALS;

    fn coefficients(settings: &ArrowSettings, period_s: f64) -> Result<ArrowLaw<T>, ConfigError> {
        law(
            &settings.parallel(),
            &settings.turntable(),
            settings.feedforward,
            period_s,
        )
    }

    /// The program read into the job on the nominal model; the parse buffer is on
    /// the link task's stack for the call.
    fn load_job(_: &mut (), file: &JobFile<'_>, job: &mut Job<T>) -> Result<(), u16> {
        let JobFile::Gcode { text } = file else {
            return Err(load_codes::KIND);
        };
        let mut points = heapless::Vec::<_, PROGRAM_POINTS>::new();
        load_job(text, &mut points, job).map_err(|e| match e.kind {
            ArrowJobErrorKind::Gcode { .. } => load_codes::GCODE,
            ArrowJobErrorKind::Empty => load_codes::EMPTY,
            ArrowJobErrorKind::TooLarge => load_codes::TOO_LARGE,
            ArrowJobErrorKind::Spline(_) => load_codes::SPLINE,
            ArrowJobErrorKind::Feed(_) => load_codes::FEED,
            ArrowJobErrorKind::Workspace(_) => load_codes::WORKSPACE,
            ArrowJobErrorKind::Singular => load_codes::SINGULAR,
            ArrowJobErrorKind::Config(_) => load_codes::CONFIG,
        })
    }

    fn job_error_code(error: &ArrowJobRefusal) -> u16 {
        match error {
            ArrowJobRefusal::Empty => 1,
            ArrowJobRefusal::WrongPeriod => 2,
            ArrowJobRefusal::NotAtStart(_) => 3,
            ArrowJobRefusal::NoReading => 4,
        }
    }

    fn fault_code(fault: &ArrowFault) -> (u16, u16) {
        match fault {
            ArrowFault::NotFinite => (1, 0),
            ArrowFault::EncoderJump(i) => (2, u16::from(*i)),
            ArrowFault::TrackingError(i) => (3, u16::from(*i)),
            ArrowFault::Law(_) => (4, 0),
            ArrowFault::Path => (5, 0),
            ArrowFault::Output(output) => (6, u16::from(output.index)),
            ArrowFault::Drive(fault) => (7, drive_index(fault)),
        }
    }

    /// The desired pose (the reference: `x_ref` … `theta_x_ref`), the largest joint error (reference − encoder, which holds
    /// the geometric error's inconsistency that the regularized law leaves alone),
    /// the table's error, the commands and the move.
    fn sample(t: &ArrowTelemetry<T>, values: &mut ChannelValues) {
        let f = |v: T| to_f64(v) as f32;
        let error = t
            .joint_error_m
            .iter()
            .fold(0.0f32, |worst, e| worst.max(f(*e).abs()));
        let d = &t.desired;
        let forces = &t.outputs.forces_n;
        let [t1, t2] = t.outputs.torques_n_m;
        let row: [f32; CHANNELS.len()] = [
            f(d[0]),
            f(d[1]),
            f(d[2]),
            f(d[3]),
            f(t.theta_x_rad),
            error,
            f(t.table_error_rad),
            f(forces[0]),
            f(forces[1]),
            f(forces[2]),
            f(forces[3]),
            f(forces[4]),
            f(forces[5]),
            f(t1),
            f(t2),
            f32::from(t.move_index),
        ];
        values.clear();
        // Within the capacity: checked at compile time above.
        let _ = values.extend_from_slice(&row);
    }
}

#[cfg(test)]
mod tests;
