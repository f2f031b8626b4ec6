//! The modal state a program sets line by line, and one line's effect on it in RS-274's
//! order of execution (feed, spindle, tool, dwell, plane, units, coordinate system,
//! distance modes, offsets, then the move, then the program's end).

use super::diagnostic::{Diagnostic, GcodeErrorKind, Severity};
use super::lex::{self, BOM};
use super::{GcodePoint, Program, ReaderConfig, Spindle};
use crate::error::ConfigError;

mod block;

/// Metres per inch (exact by definition).
const M_PER_INCH: f64 = 0.0254;

/// Radians per degree: `A` and `B` are in degrees in both unit modes.
const RAD_PER_DEG: f64 = core::f64::consts::PI / 180.0;

/// Axis letters, in the order of a point's coordinates (x, y, z, A, B).
pub(super) const AXES: &[u8; 5] = b"XYZAB";

/// The motion modes.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
enum Motion {
    Rapid,
    Feed,
    Clockwise,
    CounterClockwise,
}

/// Modal state of a program read line by line ([`Parser::read_line`]); [`super::read`]
/// drives it over a whole file.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Parser {
    config: ReaderConfig,
    line: u32,
    incremental: bool,
    /// `G90.1`: arc centres in absolute coordinates.
    absolute_centers: bool,
    /// Metres per length unit: 1e-3 (G21) or 0.0254 (G20).
    unit_m: f64,
    /// In-plane axes and the normal (indices into x, y, z): G17 (0, 1, 2), G18 (2, 0,
    /// 1), G19 (1, 2, 0).
    plane: [usize; 3],
    motion: Option<Motion>,
    feed_m_s: Option<f64>,
    inverse_time: bool,
    /// Machine position: x, y, z in m, A, B in rad.
    position: [f64; 5],
    /// Active work offset `G54`…`G59` (0…5).
    system: usize,
    /// `G92` offset and whether it is applied (`G92.2` suspends it).
    g92: [f64; 5],
    g92_on: bool,
    spindle: Spindle,
    spindle_s: f64,
    dwell_s: f64,
    ended: bool,
    /// The line of `M2`/`M30`.
    end_line: u32,
    /// A line after the end has been reported.
    after_end_reported: bool,
    /// Refuse arcs ([`Parser::parse_line`] returns one point a line).
    line_by_line: bool,
    /// The buffer was full: reported once.
    full: bool,
    errors: u32,
    warnings: u32,
}

impl Default for Parser {
    fn default() -> Self {
        Self::new()
    }
}

/// A G or M code's value × 10, when it has at most one decimal.
fn code_x10(value: f64) -> Option<u32> {
    let x10 = libm::round(value * 10.0);
    // Within 0..=9999: the conversion is exact.
    ((0.0..=9999.0).contains(&x10) && libm::fabs(value * 10.0 - x10) < 1e-6).then_some(x10 as u32)
}

/// The modal group of a G code (0: non-modal) or `None` when unknown.
fn g_group(code: u32) -> Option<u8> {
    Some(match code {
        40 | 100 | 280 | 281 | 300 | 301 | 530 | 920..=923 => 0,
        0 | 10 | 20 | 30 | 380..=389 | 730 | 760 | 800..=899 => 1,
        170 | 180 | 190 => 2,
        900 | 910 => 3,
        901 | 911 => 4,
        930 | 940 | 950 => 5,
        200 | 210 => 6,
        400 | 410 | 420 => 7,
        430 | 431 | 490 => 8,
        980 | 990 => 10,
        540 | 550 | 560 | 570 | 580 | 590 => 12,
        610 | 611 | 640 => 13,
        _ => return None,
    })
}

/// The modal group of an M code or `None` when unknown.
fn m_group(code: u32) -> Option<u8> {
    Some(match code {
        0 | 10 | 20 | 300 | 600 => 4,
        60 => 6,
        30 | 40 | 50 => 7,
        70 | 80 | 90 => 8,
        _ => return None,
    })
}

/// One line's words sorted by use.
#[derive(Default)]
struct Line {
    /// G codes × 10 with their column, one per group (index: group).
    g: [Option<(u32, u32)>; 14],
    /// M codes × 10 with their column, one per group.
    m: [Option<(u32, u32)>; 9],
    axes: [Option<(f64, u32)>; 5],
    /// I, J, K.
    center: [Option<(f64, u32)>; 3],
    r: Option<(f64, u32)>,
    p: Option<(f64, u32)>,
    f: Option<(f64, u32)>,
    s: Option<(f64, u32)>,
    t: Option<(f64, u32)>,
}

impl Parser {
    /// At the origin, G90, G21, G17, G54, no motion mode and no feed yet, with
    /// [`ReaderConfig::DEFAULT`].
    pub const fn new() -> Self {
        Self {
            config: ReaderConfig::DEFAULT,
            line: 0,
            incremental: false,
            absolute_centers: false,
            unit_m: 1e-3,
            plane: [0, 1, 2],
            motion: None,
            feed_m_s: None,
            inverse_time: false,
            position: [0.0; 5],
            system: 0,
            g92: [0.0; 5],
            g92_on: true,
            spindle: Spindle::Off,
            spindle_s: 0.0,
            dwell_s: 0.0,
            ended: false,
            end_line: 0,
            after_end_reported: false,
            line_by_line: false,
            full: false,
            errors: 0,
            warnings: 0,
        }
    }

    /// As [`Parser::new`] for the machine of `config`, at the origin of its `G54`
    /// system. Errors: a tolerance not positive or an offset not finite (names it).
    pub fn with_config(config: &ReaderConfig) -> Result<Self, ConfigError> {
        config.check()?;
        let mut parser = Self::new();
        parser.config = *config;
        Ok(parser)
    }

    /// Whether `M2`/`M30` has ended the program (later lines are skipped).
    pub fn ended(&self) -> bool {
        self.ended
    }

    /// Lines read so far.
    pub fn lines(&self) -> u32 {
        self.line
    }

    /// The summary of what was read so far.
    pub fn program(&self) -> Program {
        Program {
            lines: if self.ended { self.end_line } else { self.line },
            ended: self.ended,
            spindle_on: self.spindle != Spindle::Off,
            spindle_rpm: self.spindle_s,
            errors: self.errors,
            warnings: self.warnings,
        }
    }

    /// Reads the next line (without its `\n`; a trailing `\r` is dropped, and a UTF-8
    /// byte-order mark before the first line), gives each point it moves to to `emit`
    /// (which returns false when it has no room: reported once as
    /// [`GcodeErrorKind::TooManyPoints`]) and each warning and error to `sink`. A line
    /// with an error has no effect: its points are not given and the state stays as
    /// before it. After `M2`/`M30` lines are counted and skipped (one warning when
    /// one of them is not blank).
    pub fn read_line(
        &mut self,
        line: &[u8],
        emit: &mut (impl FnMut(&GcodePoint) -> bool + ?Sized),
        sink: &mut (impl FnMut(&Diagnostic) + ?Sized),
    ) {
        self.line = self.line.saturating_add(1);
        let line_no = self.line;
        let mut errors = 0u32;
        let mut warnings = 0u32;
        let mut report = |column: u32, kind: GcodeErrorKind| {
            match kind.severity() {
                Severity::Error => errors = errors.saturating_add(1),
                Severity::Warning => warnings = warnings.saturating_add(1),
            }
            sink(&Diagnostic {
                line: line_no,
                column,
                kind,
            });
        };
        let line = match line {
            [rest @ .., b'\r'] => rest,
            _ => line,
        };
        let line = match line.strip_prefix(BOM) {
            Some(rest) if line_no == 1 => rest,
            _ => line,
        };
        if self.ended {
            if !self.after_end_reported && line.iter().any(|&b| b > b' ' && b != b'%') {
                self.after_end_reported = true;
                report(0, GcodeErrorKind::AfterEnd);
            }
        } else {
            match lex::words(line, &mut |column, kind| report(column, kind)) {
                Err((column, kind)) => report(column, kind),
                Ok(words) => {
                    let mut next = *self;
                    let mut clean = true;
                    let plan = next.apply(&words, &mut |column, kind| {
                        clean &= kind.severity() == Severity::Warning;
                        report(column, kind)
                    });
                    if clean {
                        *self = next;
                        if self.ended {
                            self.end_line = line_no;
                        }
                        self.emit(line_no, plan, emit, &mut report);
                    }
                }
            }
        }
        self.errors = self.errors.saturating_add(errors);
        self.warnings = self.warnings.saturating_add(warnings);
    }

    /// Reads the next line as [`Parser::read_line`] and returns the one point it moves
    /// to, if it moves, for machines that read a program line by line without a buffer
    /// of points. Arcs, which make several points, are refused
    /// ([`GcodeErrorKind::ArcNotLineByLine`]); warnings are dropped.
    ///
    /// Errors: the line's first error; the state is then as before the line (only the
    /// line count advanced).
    pub fn parse_line(&mut self, line: &[u8]) -> Result<Option<GcodePoint>, Diagnostic> {
        self.line_by_line = true;
        let mut point = None;
        let mut first_error = None;
        self.read_line(
            line,
            &mut |p| {
                point = Some(*p);
                true
            },
            &mut |d| {
                if d.severity() == Severity::Error && first_error.is_none() {
                    first_error = Some(*d);
                }
            },
        );
        match first_error {
            Some(e) => Err(e),
            None => Ok(point),
        }
    }
}
