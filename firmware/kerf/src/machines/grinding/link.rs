//! The grinding cell on the host link ([`crate::app::host_link`]): its settings (the
//! force laws' gains), how an uploaded G-code job becomes a pass
//! ([`super::product::load_pass`]), and its telemetry and faults on the wire.
//!
//! Settings (JSON values; the laws' output is the piezo's increment per period in
//! 1 nm, [`super::product::CONFIG`]'s unit):
//!
//! | path | what |
//! |---|---|
//! | `/pid/{kp,ki,kd,derivative_filter,anti_windup}` | the PID law (G 4.1) |
//! | `/adrc/{kp,kd,alpha,b0,eso_bandwidth,td_acceleration}` | the ADRC law (G 4.2) |
//!
//! A change is validated as the configuration's laws are ([`GrindingLaws::new`]) and
//! applies bumplessly: a running pass continues from its state with the new gains.
//! The ranges announced are the ones that validation refuses past, at the cell's
//! 1 ms period (the anti-windup gain and the observer's bandwidth are bounded by
//! 1/period).

use super::devices::{HexapodFault, SpindleFault};
use super::product::{load_pass, GrindingPass, PassErrorKind, CONFIG};
use super::{
    GrindingCell, GrindingConfig, GrindingFault, GrindingJob, GrindingJobError, GrindingLaws,
    GrindingTelemetry,
};
use crate::app::host_link::LinkMachine;
use crate::codec::job::JobFile;
use crate::codec::link::code_words as words;
use crate::codec::link::{Channel, ChannelValues, CodeWords, JobKind};
use crate::control::adrc::{AdrcConfig, FalPower};
use crate::control::pid::PidConfig;
use crate::error::ConfigError;
use crate::scalar::{to_f64, Float};
use crate::sensing::force::ForceError;
use miniconf::Tree;

// The settings' units are stated in 1 nm of piezo travel per unit of law output.
const _: () = assert!(CONFIG.hybrid.increment_unit_m == 1e-9);

/// The PID law's gains (error in N, output the piezo's increment per period in nm).
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct PidSettings {
    /// Kp.
    #[tree(meta(unit = "nm/N", range = "finite"))]
    pub kp: f64,
    /// Ki (multiplied by the period in the integrator).
    #[tree(meta(unit = "nm/(N·s)", range = "finite"))]
    pub ki: f64,
    /// Kd.
    #[tree(meta(unit = "nm·s/N", range = "finite"))]
    pub kd: f64,
    /// Time constant of the derivative's filter (0: a plain difference).
    #[tree(meta(unit = "s", range = "0 to 1e9"))]
    pub derivative_filter: f64,
    /// Anti-windup back-calculation gain (0: off; at most 1/period).
    #[tree(meta(unit = "1/s", range = "0 to 1000"))]
    pub anti_windup: f64,
}

/// The ADRC law's gains (output in N, command the piezo's increment per period in
/// nm). Kp and Kd weigh fal of the errors in force and its rate; with fal's linear
/// zone of 1 N (the cell's δ) they are rates.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct AdrcSettings {
    /// Kp, the weight of fal(e1).
    #[tree(meta(unit = "1/s²", range = "> 0"))]
    pub kp: f64,
    /// Kd, the weight of fal(e2).
    #[tree(meta(unit = "1/s", range = "> 0"))]
    pub kd: f64,
    /// The feedback fal's exponent α.
    #[tree(meta(unit = "1", range = "0.01 to 1"))]
    pub alpha: f64,
    /// The plant's input gain b0.
    #[tree(meta(unit = "N/(s²·nm)", range = "> 0"))]
    pub b0: f64,
    /// The observer's bandwidth ωo (at most 1/period).
    #[tree(meta(unit = "rad/s", range = "> 0 and ≤ 1000"))]
    pub eso_bandwidth: f64,
    /// The tracking differentiator's acceleration limit r0.
    #[tree(meta(unit = "N/s²", range = "> 0"))]
    pub td_acceleration: f64,
}

/// The cell's settings tree.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct GrindingSettings {
    /// The PID law.
    pub pid: PidSettings,
    /// The ADRC law.
    pub adrc: AdrcSettings,
}

impl GrindingSettings {
    /// The settings of a configuration's laws.
    pub const fn of(config: &GrindingConfig) -> Self {
        let (p, a) = (&config.pid, &config.adrc);
        Self {
            pid: PidSettings {
                kp: p.kp,
                ki: p.ki_per_s,
                kd: p.kd_s,
                derivative_filter: p.derivative_filter_s,
                anti_windup: p.anti_windup_per_s,
            },
            adrc: AdrcSettings {
                kp: a.kp,
                kd: a.kd,
                alpha: a.alpha,
                b0: a.b0,
                eso_bandwidth: a.eso_bandwidth_rad_s,
                td_acceleration: a.td_acceleration,
            },
        }
    }

    /// The cell's own ([`CONFIG`]).
    pub const CELL: Self = Self::of(&CONFIG);

    /// The PID's configuration: these gains, the rest ([`CONFIG`]'s limits) kept.
    pub fn pid(&self) -> PidConfig {
        let p = &self.pid;
        PidConfig {
            kp: p.kp,
            ki_per_s: p.ki,
            kd_s: p.kd,
            derivative_filter_s: p.derivative_filter,
            anti_windup_per_s: p.anti_windup,
            ..CONFIG.pid
        }
    }

    /// The ADRC's configuration: these gains, the rest ([`CONFIG`]'s filter period
    /// and linear zones) kept.
    pub fn adrc(&self) -> AdrcConfig {
        let a = &self.adrc;
        AdrcConfig {
            kp: a.kp,
            kd: a.kd,
            alpha: a.alpha,
            b0: a.b0,
            eso_bandwidth_rad_s: a.eso_bandwidth,
            td_acceleration: a.td_acceleration,
            ..CONFIG.adrc
        }
    }
}

/// Refusals of [`LinkMachine::load_job`]: the loader's ([`PassErrorKind`]) and a job
/// of another kind.
pub mod load_codes {
    /// The G-code does not parse.
    pub const GCODE: u16 = 0x301;
    /// The program has no move.
    pub const EMPTY: u16 = 0x302;
    /// A rapid move.
    pub const RAPID: u16 = 0x303;
    /// A move off the feed axis.
    pub const OFF_AXIS: u16 = 0x304;
    /// A move backwards.
    pub const BACKWARD: u16 = 0x305;
    /// The feed changes.
    pub const FEED_CHANGES: u16 = 0x306;
    /// The spindle changes.
    pub const SPINDLE_CHANGES: u16 = 0x307;
    /// Not a G-code job.
    pub const KIND: u16 = 0x308;
}

/// The fault codes of [`LinkMachine::fault_code`].
const FAULTS: [CodeWords; 13] = [
    words(
        1,
        "the force/torque sensor's reading failed its checks (not a number, clipped, not at rest during the bias capture, inconsistent)",
        "gauge channel (0-5) or wrench component",
    ),
    words(
        2,
        "the normal force exceeded the cell's limit (a crash into the workpiece)",
        "",
    ),
    words(
        3,
        "the force loop had no finite command (a force or reference not finite)",
        "",
    ),
    words(
        4,
        "the hexapod's controller reported a GCS error",
        "code",
    ),
    words(5, "the hexapod's reply did not parse", ""),
    words(6, "the hexapod's serial link failed", ""),
    words(
        7,
        "the hexapod fell behind the pass's path by more than the following tolerance",
        "|position − path|, µm",
    ),
    words(
        8,
        "the spindle's converter stopped answering",
        "silent ticks in a row",
    ),
    words(
        9,
        "the spindle stayed off its commanded speed after its spin-up",
        "measured speed, rpm/10",
    ),
    words(
        10,
        "a spindle speed the converter's protocol cannot carry",
        "",
    ),
    words(11, "the spindle's serial link failed", ""),
    words(
        12,
        "the force sensor's bias drifted at rest (recalibrate)",
        "force component (0 Fx, 1 Fy, 2 Fz)",
    ),
    words(
        13,
        "an output was not finite",
        "output (0 the piezo, 1 the hexapod's feed, 2 the spindle)",
    ),
];

/// Job refusal code of the cell's check for a field of the pass out of range
/// ([`GrindingJobError::Field`]).
fn field_code(name: &str) -> u16 {
    match name {
        "normal_force_n" => 2,
        "feed_m_s" => 3,
        "length_m" => 4,
        "spindle_rpm" => 5,
        _ => 6,
    }
}

/// The job refusal codes of the cell's check ([`LinkMachine::job_error_code`]) and the
/// loader ([`load_codes`]).
const JOB_REFUSALS: [CodeWords; 14] = [
    words(
        1,
        "the cell has no force sensor bias yet (calibrate first)",
        "",
    ),
    words(2, "the pass's normal force is out of the cell's range", ""),
    words(
        3,
        "the pass's feed is out of the cell's range (0 to 1 m/s)",
        "",
    ),
    words(
        4,
        "the pass's length is out of the cell's range (0 to 10 m)",
        "",
    ),
    words(
        5,
        "the pass's spindle speed is out of the cell's range (0 to 100000 rpm)",
        "",
    ),
    words(6, "a field of the pass is out of the cell's range", ""),
    words(load_codes::GCODE, "the G-code does not parse", ""),
    words(load_codes::EMPTY, "the program has no move", ""),
    words(
        load_codes::RAPID,
        "a rapid move (G0): a pass is one feed in contact",
        "",
    ),
    words(
        load_codes::OFF_AXIS,
        "a move leaves the feed axis (the pass runs along X only)",
        "",
    ),
    words(
        load_codes::BACKWARD,
        "a move goes backwards or nowhere (the pass runs along +X)",
        "",
    ),
    words(
        load_codes::FEED_CHANGES,
        "the feed changes between moves (a pass runs at one feed)",
        "",
    ),
    words(
        load_codes::SPINDLE_CHANGES,
        "the spindle changes between moves",
        "",
    ),
    words(load_codes::KIND, "this cell runs G-code passes only", ""),
];

/// The telemetry channels.
const CHANNELS: [Channel; 9] = [
    Channel {
        name: "normal_force",
        unit: "N",
    },
    Channel {
        name: "force_reference",
        unit: "N",
    },
    Channel {
        name: "tangential_force",
        unit: "N",
    },
    Channel {
        name: "piezo",
        unit: "m",
    },
    Channel {
        name: "piezo_velocity",
        unit: "m/s",
    },
    Channel {
        name: "feed",
        unit: "m/s",
    },
    Channel {
        name: "fed",
        unit: "m",
    },
    Channel {
        name: "spindle",
        unit: "rpm",
    },
    Channel {
        name: "feed_exceeded",
        unit: "1",
    },
];
const _: () = assert!(CHANNELS.len() <= crate::codec::link::MAX_CHANNELS);

/// A sensor fault's detail: the channel or component it names.
fn sensor_detail(e: &ForceError) -> u16 {
    match e {
        ForceError::NotFinite { channel } | ForceError::Saturated { channel } => {
            u16::from(*channel)
        }
        ForceError::NotAtRest { component } => u16::from(*component),
        _ => 0,
    }
}

impl<T: Float + FalPower> LinkMachine for GrindingCell<T> {
    type Settings = GrindingSettings;
    type JobContext = GrindingPass;
    const NAME: &'static str = "grinding";
    const CHANNELS: &'static [Channel] = &CHANNELS;
    const JOB_KINDS: &'static [JobKind] = &[JobKind::Gcode];
    const FAULTS: &'static [CodeWords] = &FAULTS;
    const JOB_REFUSALS: &'static [CodeWords] = &JOB_REFUSALS;

    fn coefficients(
        settings: &GrindingSettings,
        period_s: f64,
    ) -> Result<GrindingLaws<T>, ConfigError> {
        GrindingLaws::new(&GrindingConfig {
            period_s,
            pid: settings.pid(),
            adrc: settings.adrc(),
            ..CONFIG
        })
    }

    /// The program read into a pass of the cell's law and force.
    fn load_job(
        pass: &mut GrindingPass,
        file: &JobFile<'_>,
        job: &mut GrindingJob,
    ) -> Result<(), u16> {
        let JobFile::Gcode { text } = file else {
            return Err(load_codes::KIND);
        };
        *job = load_pass(pass, text).map_err(|e| match e.kind {
            PassErrorKind::Gcode(_) => load_codes::GCODE,
            PassErrorKind::Empty => load_codes::EMPTY,
            PassErrorKind::Rapid => load_codes::RAPID,
            PassErrorKind::OffAxis => load_codes::OFF_AXIS,
            PassErrorKind::Backward => load_codes::BACKWARD,
            PassErrorKind::FeedChanges => load_codes::FEED_CHANGES,
            PassErrorKind::SpindleChanges => load_codes::SPINDLE_CHANGES,
        })?;
        Ok(())
    }

    fn job_error_code(error: &GrindingJobError) -> u16 {
        match error {
            GrindingJobError::NotCalibrated => 1,
            GrindingJobError::Field(name) => field_code(name),
        }
    }

    fn fault_code(fault: &GrindingFault) -> (u16, u16) {
        let clamp = |v: f64| libm::fmin(libm::fabs(v), f64::from(u16::MAX)) as u16;
        match fault {
            GrindingFault::Sensor(e) => (1, sensor_detail(e)),
            GrindingFault::ForceLimit => (2, 0),
            GrindingFault::Loop(_) => (3, 0),
            // The code's low 16 bits (PI's negative codes in two's complement).
            GrindingFault::Hexapod(HexapodFault::Controller(code)) => (4, *code as u16),
            GrindingFault::Hexapod(HexapodFault::Reply(_)) => (5, 0),
            GrindingFault::Hexapod(HexapodFault::Link(_)) => (6, 0),
            GrindingFault::Hexapod(HexapodFault::Following { error_mm }) => {
                (7, clamp(f64::from(*error_mm) * 1e3))
            }
            GrindingFault::Spindle(SpindleFault::Silent { ticks }) => (8, *ticks),
            GrindingFault::Spindle(SpindleFault::Speed { measured_rpm, .. }) => {
                (9, clamp(f64::from(*measured_rpm) / 10.0))
            }
            GrindingFault::Spindle(SpindleFault::Request(_)) => (10, 0),
            GrindingFault::Spindle(SpindleFault::Link(_)) => (11, 0),
            GrindingFault::BiasDrift(d) => (12, u16::from(d.component)),
            GrindingFault::Output(output) => (13, u16::from(output.index)),
        }
    }

    /// The forces, the piezo, the feed and how far it went, the spindle.
    fn sample(t: &GrindingTelemetry<T>, values: &mut ChannelValues) {
        let f = |v: T| to_f64(v) as f32;
        let row: [f32; CHANNELS.len()] = [
            f(t.forces.normal_n),
            f(t.reference_n),
            f(t.forces.tangential_n),
            f(t.outputs.piezo_m),
            f(t.piezo_velocity_m_s),
            f(t.outputs.hexapod_feed_m_s),
            f(t.fed_m),
            f(t.outputs.spindle_rpm),
            f32::from(u8::from(t.feed_exceeded)),
        ];
        values.clear();
        // Within the capacity: checked at compile time above.
        let _ = values.extend_from_slice(&row);
    }
}

#[cfg(test)]
mod tests;
