//! G-code programs (A §4; docs/equations.md §16) read as grbl and LinuxCNC's RS-274/NGC
//! read them, line by line without allocation, into points in SI units, with every
//! warning and error reported at once by line and column.
//!
//! # What is read
//!
//! - The text: a UTF-8 byte-order mark before the first line, `\n` or `\r\n` line ends,
//!   upper or lower case, blanks anywhere outside comments (`G 1`, `X - 1 . 5` are `G1`,
//!   `X-1.5`: grbl strips every blank before parsing), `( … )` comments (a `(` inside one
//!   is a warning and the comment ends at the first `)`, as grbl and LinuxCNC), `;`
//!   comments to the end of the line, a `%` tape mark, `N` line numbers, a leading `/`
//!   (block delete, switch off: the line is read), RepRap `*nn` checksums (the XOR of
//!   every byte before `*`, checked when present), an `O` program number (warning; `O`
//!   subroutines and flow control are errors, as are `#` parameters and `[ ]`
//!   expressions: their values are not known to the reader).
//! - Motion, modal: `G0` rapid, `G1` feed, `G2`/`G3` arcs (clockwise / counter-clockwise
//!   in the plane `G17` XY, `G18` ZX, `G19` YZ) by centre `I J K` (relative to the start,
//!   or absolute after `G90.1`; `G91.1` back) or radius `R` (negative: the longer way),
//!   full circles by centre, extra turns `P`; helical moves on the plane's normal and on
//!   `A B`. Arcs become chords within the caller's tolerance ([`arc`](self) module docs:
//!   the sagitta r·(1 − cos(φ/2)) of each chord at most the tolerance).
//! - Axes `X Y Z` (length) and `A B` (degrees, always); an axis word the machine lacks
//!   ([`ReaderConfig::axes`]) is an error. `G20`/`G21` inch / millimetre (1 in = 0.0254 m
//!   exactly), `G90`/`G91` absolute / incremental. Offsets: `G54`…`G59` select the
//!   caller's work offsets ([`ReaderConfig::work_offsets`], zero by default), `G92` sets
//!   the current position, `G92.1` clears, `G92.2` suspends and `G92.3` restores it;
//!   `G53` moves in machine coordinates on its line. Points are machine positions.
//! - Feed `F` in length per minute (`G94`); `G93` inverse time is a warning and feed
//!   moves under it are errors; `G95` is refused. `S` spindle speed or laser power and
//!   `M3`/`M4`/`M5` (`M4` is grbl's dynamic laser power: [`Spindle`]), `G4 P` dwell in
//!   seconds (carried by the next point), `M2`/`M30` end the program.
//! - Warnings, skipped safely: `T`, `M6`, `M7`/`M8`/`M9`, `M1`, `G43`, `G61`/`G61.1`/`G64`,
//!   `G28.1`/`G30.1`. Silent, the reader's own state restated: `G17`, `G40`, `G49`,
//!   `G80`, `G94`, `G98`/`G99`.
//! - Errors: a feed move before any `F`, unknown G/M codes, a malformed number, two words
//!   of one modal group or one letter twice on a line, `I J K R P` no code uses, an arc
//!   whose end misses its circle, and the codes whose effect the reader cannot follow:
//!   `G28`/`G30` (go to the machine's home: where that is, is not in the program),
//!   `G10`, `G38.x` probing, `G41`/`G42` cutter compensation, canned cycles, `M0`/`M60`
//!   (a pause for the operator).
//!
//! A line with an error has no effect (its points are not given, the state is kept);
//! reading goes on with the next line, so one pass reports every problem.
//!
//! For ARROW (A §2) the post-processor names the turntable's θx `A` and the
//! platform's θz `B`; the reader itself gives both as angles and assigns no machine
//! meaning.

use crate::error::ConfigError;
use heapless::Vec;

mod arc;
mod diagnostic;
mod lex;
mod modal;

pub use diagnostic::{Diagnostic, GcodeError, GcodeErrorKind, Severity};
pub use modal::Parser;

/// How the tool moves to a point.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MoveKind {
    /// `G0`: positioning at the machine's rapid rate, no cutting.
    Rapid,
    /// `G1`, or a chord of a `G2`/`G3` arc: cutting at the feed `F`.
    Feed,
}

/// The spindle, or a laser's beam, as `M3`/`M4`/`M5` left it.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Spindle {
    /// `M5` (and at the start).
    Off,
    /// `M3`: clockwise; for a laser, constant power.
    Clockwise,
    /// `M4`: counter-clockwise; for a laser, grbl's dynamic power (scaled by speed).
    CounterClockwise,
}

/// One target point of the path, SI units.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GcodePoint {
    /// x, y, z, m (machine position: work and `G92` offsets applied).
    pub position_m: [f64; 3],
    /// A, B, rad.
    pub angles_rad: [f64; 2],
    /// Feed in force for this move, m/s (0 for a rapid before any `F`).
    pub feed_m_s: f64,
    /// Rapid or feed move.
    pub kind: MoveKind,
    /// 1-based line of the file that gave the point.
    pub line: u32,
    /// Spindle or beam state during the move.
    pub spindle: Spindle,
    /// The last `S` (spindle rpm or laser power, in the program's own scale).
    pub spindle_s: f64,
    /// Dwell (`G4`) before this move, s.
    pub dwell_s: f64,
}

/// A whole file's result beside its points.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Program {
    /// Lines read (up to and including `M2`/`M30`, or the last).
    pub lines: u32,
    /// Whether `M2`/`M30` ended the program.
    pub ended: bool,
    /// Spindle state after the last `M3`/`M4`/`M5`.
    pub spindle_on: bool,
    /// Last `S` value, rpm.
    pub spindle_rpm: f64,
    /// Errors reported.
    pub errors: u32,
    /// Warnings reported.
    pub warnings: u32,
}

/// What the reader knows of the machine.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ReaderConfig {
    /// Which of the axes `X Y Z A B` the machine has.
    pub axes: [bool; 5],
    /// `G54`…`G59`: the machine position of each system's origin (x, y, z in m, A, B
    /// in rad).
    pub work_offsets: [[f64; 5]; 6],
    /// Largest distance of an arc's chord from the arc (its sagitta), m.
    pub chord_tolerance_m: f64,
}

impl ReaderConfig {
    /// All five axes, zero work offsets, chords within 1 µm.
    pub const DEFAULT: Self = Self {
        axes: [true; 5],
        work_offsets: [[0.0; 5]; 6],
        chord_tolerance_m: 1e-6,
    };

    /// Checks the tolerance (finite, positive) and the offsets (finite).
    pub fn check(&self) -> Result<(), ConfigError> {
        let t = self.chord_tolerance_m;
        if !t.is_finite() {
            return Err(ConfigError::not_finite("chord_tolerance_m"));
        }
        if t <= 0.0 {
            return Err(ConfigError::not_positive("chord_tolerance_m"));
        }
        for (i, offset) in self.work_offsets.iter().enumerate() {
            if !offset.iter().all(|v| v.is_finite()) {
                return Err(ConfigError::not_finite("work_offsets").at(i));
            }
        }
        Ok(())
    }
}

impl Default for ReaderConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Reads a whole file (lines ended by `\n`, optionally `\r\n`) for the machine of
/// `config` into `points`, which is cleared first, giving every warning and error to
/// `sink` in the order of the file. Stops reading at `M2`/`M30`.
///
/// Errors: only a bad `config` (nothing is read). The program's own errors are in the
/// returned [`Program::errors`] and were given to `sink`.
pub fn read<const N: usize>(
    text: &[u8],
    config: &ReaderConfig,
    points: &mut Vec<GcodePoint, N>,
    sink: &mut (impl FnMut(&Diagnostic) + ?Sized),
) -> Result<Program, ConfigError> {
    points.clear();
    let mut parser = Parser::with_config(config)?;
    for line in text.split(|&b| b == b'\n') {
        parser.read_line(line, &mut |p| points.push(*p).is_ok(), sink);
    }
    // A final line end leaves an empty last piece: not a line of the file.
    let mut program = parser.program();
    if text.last() == Some(&b'\n') && !program.ended {
        program.lines = program.lines.saturating_sub(1);
    }
    Ok(program)
}

/// Reads a whole file as [`read`] with [`ReaderConfig::DEFAULT`].
///
/// Errors: the first error's [`GcodeError`] (warnings are dropped); `points` then holds
/// the points of the lines without errors.
pub fn parse<const N: usize>(
    text: &[u8],
    points: &mut Vec<GcodePoint, N>,
) -> Result<Program, GcodeError> {
    let mut first = None;
    let program = read(text, &ReaderConfig::DEFAULT, points, &mut |d| {
        if d.severity() == Severity::Error && first.is_none() {
            first = Some(*d);
        }
    });
    match (first, program) {
        (Some(e), _) => Err(e),
        (None, Ok(program)) => Ok(program),
        // The default configuration is valid: never taken.
        (None, Err(_)) => Ok(Parser::new().program()),
    }
}

/// The runs of a program a constant-feed path follows ([`super::feed`]): each is a
/// maximal run of consecutive [`MoveKind::Feed`] moves at one feed, preceded by the
/// point it starts from (the point before its first move; a run at the very start of
/// the program starts from its first target). Rapid moves between runs are left out.
pub fn feed_runs(points: &[GcodePoint]) -> FeedRuns<'_> {
    FeedRuns { points, next: 0 }
}

/// Iterator of [`feed_runs`].
#[derive(Clone, Debug)]
pub struct FeedRuns<'a> {
    points: &'a [GcodePoint],
    next: usize,
}

impl<'a> Iterator for FeedRuns<'a> {
    type Item = &'a [GcodePoint];

    fn next(&mut self) -> Option<Self::Item> {
        let rest = self.points.get(self.next..)?;
        let first = self.next + rest.iter().position(|p| p.kind == MoveKind::Feed)?;
        let feed = self.points.get(first)?.feed_m_s;
        let len = self
            .points
            .get(first..)?
            .iter()
            .take_while(|p| p.kind == MoveKind::Feed && p.feed_m_s == feed)
            .count();
        self.next = first + len;
        self.points.get(first.saturating_sub(1)..first + len)
    }
}

#[cfg(test)]
mod tests;
