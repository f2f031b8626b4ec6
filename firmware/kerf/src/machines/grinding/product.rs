//! The grinding cell as it is flashed: its configuration (G's cell with both
//! laws tuned, [`GrindingConfig::TUNED`]), its device link, the pass a job file is
//! ground with, the link's job buffer and telemetry decimation, and how a G-code
//! program becomes a pass. The QEMU image and the simulator take these from here.
//!
//! # A pass in G-code
//!
//! The hexapod feeds the workpiece along its feed axis (X, [`DEVICES`]) while the
//! piezo holds the normal force; the force loop follows the surface's shape, so the
//! path of a pass is a stretch of X at one feed. What is read ([`load_pass`], with the
//! parser of [`crate::trajectory::gcode`]):
//!
//! - `G1` moves along +X from where the hexapod stands (the program's origin), all at
//!   one feed `F`: their lengths add up to the pass's length, `F` is its feed;
//! - the spindle as the first move finds it: `M3`/`M4` with `S` (rpm), or stopped (the
//!   tool rolls on the surface, G 7.3); `M5` after the last move is the pass's end;
//! - the law and the normal force are the cell's pass ([`PASS`]): G-code has no word
//!   for a force.
//!
//! Refused: no move, a rapid (`G0`: the cell has no positioning move in contact), a
//! move off X (Y, Z, A, B) or backwards, a feed or a spindle that changes between
//! moves. The cell's own check (feed, length, speed in range) follows at the load.

use super::devices::DeviceLinkConfig;
use super::{ForceLawKind, GrindingCell, GrindingConfig, GrindingJob};
use crate::trajectory::gcode::{GcodeError, MoveKind, Parser};

/// The cell's configuration: G's 1 ms period, sensor, tool and bias capture,
/// with both laws tuned on the simulated cell (their gains in 1 nm of piezo travel per
/// unit of law output).
pub const CONFIG: GrindingConfig = GrindingConfig::TUNED;

/// The control period, s (1 kHz).
pub const PERIOD_S: f64 = CONFIG.period_s;

/// The device link (hexapod and spindle): G's, a 10 ms tick.
pub const DEVICES: DeviceLinkConfig = DeviceLinkConfig::PUBLISHED;

/// Control periods per device tick: the tick over the period, rounded (10).
pub fn device_tick_periods() -> u32 {
    libm::round(DEVICES.tick_s / PERIOD_S) as u32
}

/// Bytes of an uploaded job the cell holds: a pass's G-code is a few lines; 1 KiB
/// leaves room for comments.
pub const LINK_JOB_BYTES: usize = 1024;

/// The supervisor reports telemetry every this many control periods (every period:
/// 1 kHz); the host link decimates further to the rate the host asks for.
pub const TELEMETRY_DECIMATION: u32 = 1;

/// What a pass takes from the cell rather than from its job file.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct GrindingPass {
    /// The force law.
    pub law: ForceLawKind,
    /// The normal force reference, N.
    pub normal_force_n: f64,
}

/// The cell's pass: the tuned PID at 7.5 N, G's experiments' force (G 7).
pub const PASS: GrindingPass = GrindingPass {
    law: ForceLawKind::Pid,
    normal_force_n: 7.5,
};

/// The grinding cell as flashed.
pub type Cell<T> = GrindingCell<T>;

/// Why a G-code program is not a pass.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PassErrorKind {
    /// The parser's refusal.
    Gcode(GcodeError),
    /// The program has no move.
    Empty,
    /// A `G0`.
    Rapid,
    /// A move changes Y, Z, A or B.
    OffAxis,
    /// A move goes along −X or nowhere.
    Backward,
    /// A move's feed differs from the first's.
    FeedChanges,
    /// The spindle at a move differs from the first's.
    SpindleChanges,
}

/// A refused program: the 1-based line (0: the whole program) and why.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PassError {
    /// The line.
    pub line: u32,
    /// Why.
    pub kind: PassErrorKind,
}

/// Reads a G-code program into a pass of `pass`'s law and force (module docs), line
/// by line, without a buffer of points.
///
/// Errors: the first refused line and why.
pub fn load_pass(pass: &GrindingPass, text: &[u8]) -> Result<GrindingJob, PassError> {
    let mut parser = Parser::new();
    let mut at_m = [0.0f64; 3];
    let mut run: Option<(f64, f64)> = None;
    let mut length_m = 0.0;
    for line in text.split(|&b| b == b'\n') {
        if parser.ended() {
            break;
        }
        let moved = parser.parse_line(line).map_err(|e| PassError {
            line: e.line,
            kind: PassErrorKind::Gcode(e),
        })?;
        let Some(point) = moved else { continue };
        let err = |kind| PassError {
            line: point.line,
            kind,
        };
        if point.kind == MoveKind::Rapid {
            return Err(err(PassErrorKind::Rapid));
        }
        let [x, y, z] = point.position_m;
        if y != at_m[1] || z != at_m[2] || point.angles_rad != [0.0; 2] {
            return Err(err(PassErrorKind::OffAxis));
        }
        if x <= at_m[0] {
            return Err(err(PassErrorKind::Backward));
        }
        let program = parser.program();
        let rpm = if program.spindle_on {
            program.spindle_rpm
        } else {
            0.0
        };
        match run {
            None => run = Some((point.feed_m_s, rpm)),
            Some((feed, _)) if feed != point.feed_m_s => {
                return Err(err(PassErrorKind::FeedChanges))
            }
            Some((_, spindle)) if spindle != rpm => return Err(err(PassErrorKind::SpindleChanges)),
            Some(_) => {}
        }
        length_m += x - at_m[0];
        at_m = point.position_m;
    }
    let (feed_m_s, spindle_rpm) = run.ok_or(PassError {
        line: 0,
        kind: PassErrorKind::Empty,
    })?;
    Ok(GrindingJob {
        law: pass.law,
        normal_force_n: pass.normal_force_n,
        feed_m_s,
        length_m,
        spindle_rpm,
    })
}
