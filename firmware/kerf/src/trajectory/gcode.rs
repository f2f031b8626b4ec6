//! G-code paths (A §4; docs/equations.md §16): the subset a CAM post-processor emits
//! for a 5-axis milling path, read line by line without allocation into the caller's
//! fixed-capacity buffer of points in SI units.
//!
//! # What is read
//!
//! - Motion: `G0`/`G00` (rapid) and `G1`/`G01` (feed), modal: a line with axis words
//!   and no G word repeats the last motion mode. Axis words `X Y Z` (length) and
//!   `A B` (degrees, always, in both unit modes), feed `F` (length per minute).
//! - Modes: `G90`/`G91` (absolute / incremental coordinates, default G90),
//!   `G20`/`G21` (inch / millimetre, default G21). Lengths become metres (1 in =
//!   0.0254 m exactly), angles radians, feeds m/s. Mode words act before the motion on
//!   the same line (RS-274 order of execution).
//! - Harmless G words, accepted and without effect on straight moves: `G17` (XY plane),
//!   `G40` (no cutter radius compensation), `G49` (no tool length offset), `G80` (no
//!   canned cycle), `G94` (feed per minute, the only feed mode read).
//! - M words: `M3`/`M4` (spindle on) and `M5` (off) are recorded in
//!   [`Program::spindle_on`] with the last `S` (rpm, [`Program::spindle_rpm`]);
//!   `M7`/`M8`/`M9` (coolant) are ignored; `M2`/`M30` end the program: later lines are
//!   not read. Every other M word (`M6` tool change, `M0` pause, …) is refused: it
//!   would change the tool or need an operator.
//! - `N` line numbers (recorded, not required), comments `( … )` (not nested, closed on
//!   the line) and `;` to the end of the line, a `%` line (tape marker), blank lines.
//! - RepRap checksums: `*nn` after the words, nn (0–255) the XOR of every byte of the
//!   line before the `*`; checked when present.
//!
//! Numbers are a sign, digits and at most one decimal point (no exponent, as RS-274),
//! converted by `core`'s correctly rounded decimal parser.
//!
//! # Errors
//!
//! Every refusal is a [`GcodeError`] with the 1-based line and byte column of its cause
//! and a [`GcodeErrorKind`]: unknown or unsupported word, malformed number, a word given
//! twice, a `G1` before any feed, axis words before any motion mode, a bad checksum, an unclosed comment, a line longer
//! than [`MAX_LINE_BYTES`], more points than the buffer holds, and a coordinate that is
//! not finite (incremental moves accumulating past the `f64` range).
//!
//! Before the first absolute move the position is the origin (all axes 0): an
//! incremental move there is relative to it.
//!
//! For ARROW (A §2) the post-processor names the turntable's θx `A` and the
//! platform's θz `B`; the parser itself gives both as angles and assigns no machine
//! meaning.

use heapless::Vec;

/// Longest line accepted, bytes (without the line end).
pub const MAX_LINE_BYTES: usize = 256;

/// Most words on one line.
const MAX_WORDS: usize = 24;

/// Metres per inch (exact by definition).
const M_PER_INCH: f64 = 0.0254;

/// How the tool moves to a point.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MoveKind {
    /// `G0`: positioning at the machine's rapid rate, no cutting.
    Rapid,
    /// `G1`: straight cutting move at the feed `F`.
    Feed,
}

/// One target point of the path, SI units.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GcodePoint {
    /// x, y, z, m.
    pub position_m: [f64; 3],
    /// A, B, rad.
    pub angles_rad: [f64; 2],
    /// Feed in force for this move, m/s (0 for a rapid before any `F`).
    pub feed_m_s: f64,
    /// Rapid or feed move.
    pub kind: MoveKind,
    /// 1-based line of the file that gave the point.
    pub line: u32,
}

/// What is wrong with a line.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GcodeErrorKind {
    /// A letter that is not a word of this subset (the letter, upper case).
    UnknownWord(u8),
    /// A G or M code outside the subset (letter and the code's value × 10, so that
    /// `G2` is 20 and `G43.4` is 434).
    Unsupported {
        /// `b'G'` or `b'M'`.
        letter: u8,
        /// The code × 10.
        code_x10: u32,
    },
    /// A byte that starts no word (a digit or sign without a letter, a control byte).
    UnexpectedByte(u8),
    /// The number after a letter is missing or not `[+-]digits[.digits]`.
    MalformedNumber,
    /// The same letter twice on one line (two G codes of one modal group, two `X`…).
    DuplicateWord(u8),
    /// A `G1` move before any `F` word gave a feed.
    MissingFeed,
    /// Axis words before any `G0`/`G1` set the motion mode.
    NoMotionMode,
    /// A zero or negative feed.
    BadFeed,
    /// The checksum after `*` differs from the XOR of the line's bytes before it.
    BadChecksum {
        /// The value written after `*`.
        given: u8,
        /// The XOR of the bytes before `*`.
        computed: u8,
    },
    /// A `(` comment not closed on its line, or a `)` without a `(`.
    UnclosedComment,
    /// The line is longer than [`MAX_LINE_BYTES`].
    LineTooLong,
    /// More points than the caller's buffer holds.
    TooManyPoints,
    /// More than the supported number of words on a line.
    TooManyWords,
    /// A coordinate or feed is infinite after conversion and accumulation.
    NotFinite,
}

/// A refused line: where, and why.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GcodeError {
    /// 1-based line number in the input.
    pub line: u32,
    /// 1-based byte column of the cause (0 when it is the whole line).
    pub column: u32,
    /// What is wrong.
    pub kind: GcodeErrorKind,
}

impl core::fmt::Display for GcodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "line {}, column {}: {:?}",
            self.line, self.column, self.kind
        )
    }
}

impl core::error::Error for GcodeError {}

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
}

/// One word of a line: letter, value, and where the letter was.
#[derive(Copy, Clone, Debug)]
struct Word {
    letter: u8,
    value: f64,
    column: u32,
}

/// Modal state of a program read line by line ([`Parser::parse_line`]); [`parse`] drives
/// it over a whole file.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Parser {
    line: u32,
    incremental: bool,
    /// Metres per length unit: 1e-3 (G21) or 0.0254 (G20).
    unit_m: f64,
    motion: Option<MoveKind>,
    feed_m_s: Option<f64>,
    position_m: [f64; 3],
    angles_rad: [f64; 2],
    ended: bool,
    spindle_on: bool,
    spindle_rpm: f64,
}

impl Default for Parser {
    fn default() -> Self {
        Self::new()
    }
}

impl Parser {
    /// At the origin, G90, G21, no motion mode and no feed yet.
    pub const fn new() -> Self {
        Self {
            line: 0,
            incremental: false,
            unit_m: 1e-3,
            motion: None,
            feed_m_s: None,
            position_m: [0.0; 3],
            angles_rad: [0.0; 2],
            ended: false,
            spindle_on: false,
            spindle_rpm: 0.0,
        }
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
            lines: self.line,
            ended: self.ended,
            spindle_on: self.spindle_on,
            spindle_rpm: self.spindle_rpm,
        }
    }

    /// Reads the next line (without its line end; a trailing `\r` is dropped) and
    /// returns the point it moves to, if it moves. After `M2`/`M30` lines are counted
    /// and skipped. On an error the state is as before the line (only the line count
    /// advanced).
    pub fn parse_line(&mut self, line: &[u8]) -> Result<Option<GcodePoint>, GcodeError> {
        self.line = self.line.saturating_add(1);
        let line_no = self.line;
        let err = |column: usize, kind| GcodeError {
            line: line_no,
            column: u32::try_from(column).unwrap_or(u32::MAX),
            kind,
        };
        if self.ended {
            return Ok(None);
        }
        let line = match line {
            [rest @ .., b'\r'] => rest,
            _ => line,
        };
        if line.len() > MAX_LINE_BYTES {
            return Err(err(MAX_LINE_BYTES + 1, GcodeErrorKind::LineTooLong));
        }
        let words = split_words(line).map_err(|(column, kind)| err(column, kind))?;
        let mut next = *self;
        let point = next
            .apply(&words)
            .map_err(|(column, kind)| err(column, kind))?;
        *self = next;
        Ok(point.map(|mut p| {
            p.line = line_no;
            p
        }))
    }

    /// Applies one line's words to the state: modes first, then the move.
    fn apply(&mut self, words: &[Word]) -> Result<Option<GcodePoint>, (usize, GcodeErrorKind)> {
        let mut motion_here: Option<(MoveKind, u32)> = None;
        let mut axes: [Option<(f64, u32)>; 5] = [None; 5];
        let mut feed: Option<(f64, u32)> = None;
        let mut end = false;
        for w in words {
            let column = w.column as usize;
            let unsupported = || {
                // Values are checked to be small non-negative before this conversion.
                let code_x10 = libm::round(w.value * 10.0) as u32;
                (
                    column,
                    GcodeErrorKind::Unsupported {
                        letter: w.letter,
                        code_x10,
                    },
                )
            };
            match w.letter {
                b'G' | b'M' if !(0.0..=999.9).contains(&w.value) => {
                    return Err((column, GcodeErrorKind::MalformedNumber));
                }
                b'G' => match code_x10(w.value) {
                    0 => motion_here = Some((MoveKind::Rapid, w.column)),
                    10 => motion_here = Some((MoveKind::Feed, w.column)),
                    200 => self.unit_m = M_PER_INCH,
                    210 => self.unit_m = 1e-3,
                    900 => self.incremental = false,
                    910 => self.incremental = true,
                    170 | 400 | 490 | 800 | 940 => {}
                    _ => return Err(unsupported()),
                },
                b'M' => match code_x10(w.value) {
                    30 | 40 => self.spindle_on = true,
                    50 => self.spindle_on = false,
                    70 | 80 | 90 => {}
                    20 | 300 => end = true,
                    _ => return Err(unsupported()),
                },
                b'S' => self.spindle_rpm = w.value,
                b'N' => {}
                b'F' => feed = Some((w.value, w.column)),
                letter => {
                    let slot = b"XYZAB"
                        .iter()
                        .position(|&l| l == letter)
                        .and_then(|i| axes.get_mut(i));
                    match slot {
                        Some(slot) => *slot = Some((w.value, w.column)),
                        None => return Err((column, GcodeErrorKind::UnknownWord(letter))),
                    }
                }
            }
        }
        // Feed in the line's units (G20/G21 on the same line already applied).
        if let Some((f, column)) = feed {
            let f_m_s = f * self.unit_m / 60.0;
            if !f_m_s.is_finite() {
                return Err((column as usize, GcodeErrorKind::NotFinite));
            }
            if f_m_s <= 0.0 {
                return Err((column as usize, GcodeErrorKind::BadFeed));
            }
            self.feed_m_s = Some(f_m_s);
        }
        if let Some((kind, _)) = motion_here {
            self.motion = Some(kind);
        }
        let first_axis = axes.iter().flatten().map(|&(_, c)| c).min();
        let moved = if let Some(axis_column) = first_axis {
            let kind = self
                .motion
                .ok_or((axis_column as usize, GcodeErrorKind::NoMotionMode))?;
            let feed_m_s = match (kind, self.feed_m_s) {
                (MoveKind::Feed, None) => {
                    let column = motion_here.map_or(axis_column, |(_, c)| c);
                    return Err((column as usize, GcodeErrorKind::MissingFeed));
                }
                (_, f) => f.unwrap_or(0.0),
            };
            let [x, y, z, a, b] = axes;
            let [px, py, pz] = &mut self.position_m;
            let [pa, pb] = &mut self.angles_rad;
            let rad_per_deg = core::f64::consts::PI / 180.0;
            let targets = [
                (x, px, self.unit_m),
                (y, py, self.unit_m),
                (z, pz, self.unit_m),
                (a, pa, rad_per_deg),
                (b, pb, rad_per_deg),
            ];
            for (word, coordinate, scale) in targets {
                if let Some((value, column)) = word {
                    let v = value * scale;
                    let new = if self.incremental { *coordinate + v } else { v };
                    if !new.is_finite() {
                        return Err((column as usize, GcodeErrorKind::NotFinite));
                    }
                    *coordinate = new;
                }
            }
            Some(GcodePoint {
                position_m: self.position_m,
                angles_rad: self.angles_rad,
                feed_m_s,
                kind,
                line: 0,
            })
        } else {
            None
        };
        if end {
            self.ended = true;
        }
        Ok(moved)
    }
}

/// A G/M code's value × 10, rounded (G43.4 → 434). Values outside 0..=999.9 are
/// refused before this is called.
fn code_x10(value: f64) -> u32 {
    libm::round(value * 10.0) as u32
}

/// Splits a line into words, dropping comments, checking the checksum.
fn split_words(line: &[u8]) -> Result<Vec<Word, MAX_WORDS>, (usize, GcodeErrorKind)> {
    let mut words: Vec<Word, MAX_WORDS> = Vec::new();
    let mut i = 0;
    let mut xor = 0u8;
    let at = |k: usize| line.get(k).copied();
    if let Some(first) = line.iter().position(|b| !b.is_ascii_whitespace()) {
        if at(first) == Some(b'%') && line.iter().skip(first + 1).all(u8::is_ascii_whitespace) {
            return Ok(words);
        }
    }
    while let Some(byte) = at(i) {
        let column = i + 1;
        match byte {
            b' ' | b'\t' => {
                xor ^= byte;
                i += 1;
            }
            b'(' => {
                // Positions in a slice rather than a `skip`ped iterator, whose count
                // keeps an overflow check.
                let rest = line.get(i..).unwrap_or(&[]);
                let Some(close) = rest.iter().position(|&b| b == b')') else {
                    return Err((column, GcodeErrorKind::UnclosedComment));
                };
                // Positions in the line (fewer than usize::MAX bytes): never saturate.
                let end = i.saturating_add(close).saturating_add(1);
                for &b in line.get(i..end).unwrap_or(&[]) {
                    xor ^= b;
                }
                i = end;
            }
            b')' => return Err((column, GcodeErrorKind::UnclosedComment)),
            b';' => break,
            b'*' => {
                let (value, end) = checksum_value(line, i + 1)
                    .ok_or((column + 1, GcodeErrorKind::MalformedNumber))?;
                if value != xor {
                    return Err((
                        column,
                        GcodeErrorKind::BadChecksum {
                            given: value,
                            computed: xor,
                        },
                    ));
                }
                // Only blanks or a `;` comment may follow the checksum.
                let rest = line.get(end..).unwrap_or(&[]);
                match rest.iter().position(|b| !b.is_ascii_whitespace()) {
                    None => break,
                    Some(k) if at(end.saturating_add(k)) == Some(b';') => break,
                    Some(k) => {
                        let at_k = end.saturating_add(k);
                        let b = at(at_k).unwrap_or(0);
                        return Err((at_k.saturating_add(1), GcodeErrorKind::UnexpectedByte(b)));
                    }
                }
            }
            letter if letter.is_ascii_alphabetic() => {
                let upper = letter.to_ascii_uppercase();
                let (value, len) = parse_number(line.get(i + 1..).unwrap_or(&[]))
                    .ok_or((column + 1, GcodeErrorKind::MalformedNumber))?;
                if words
                    .iter()
                    .any(|w| w.letter == upper && upper != b'G' && upper != b'M')
                    || words
                        .iter()
                        .any(|w| w.letter == upper && same_group(upper, w.value, value))
                {
                    return Err((column, GcodeErrorKind::DuplicateWord(upper)));
                }
                let word = Word {
                    letter: upper,
                    value,
                    column: u32::try_from(column).unwrap_or(u32::MAX),
                };
                words
                    .push(word)
                    .map_err(|_| (column, GcodeErrorKind::TooManyWords))?;
                for &b in line.iter().skip(i).take(len + 1) {
                    xor ^= b;
                }
                i += len + 1;
            }
            other => return Err((column, GcodeErrorKind::UnexpectedByte(other))),
        }
    }
    Ok(words)
}

/// Whether two G (or M) codes belong to the same modal group, so may not share a line:
/// motion (G0/G1), units (G20/G21), distance (G90/G91); for M, spindle (M3/M4/M5).
fn same_group(letter: u8, a: f64, b: f64) -> bool {
    let group = |v: f64| match (letter, code_x10(v.clamp(0.0, 999.9))) {
        (b'G', 0 | 10 | 20 | 30) => 1,
        (b'G', 200 | 210) => 2,
        (b'G', 900 | 910) => 3,
        (b'M', 30 | 40 | 50) => 4,
        _ => 0,
    };
    let g = group(a);
    g != 0 && g == group(b)
}

/// The checksum's decimal value (0–255) starting at `start`, and where it ends.
fn checksum_value(line: &[u8], start: usize) -> Option<(u8, usize)> {
    let digits = line
        .iter()
        .skip(start)
        .take_while(|b| b.is_ascii_digit())
        .count();
    if digits == 0 || digits > 3 {
        return None;
    }
    let value = line.iter().skip(start).take(digits).fold(0u32, |acc, &d| {
        // At most three digits (above): never saturates.
        acc.saturating_mul(10)
            .saturating_add(char::from(d).to_digit(10).unwrap_or(0))
    });
    Some((u8::try_from(value).ok()?, start + digits))
}

/// A number `[+-]digits[.digits]` (at least one digit) at the start of `bytes`, its
/// value and its length in bytes. Blanks between the letter and the number are not
/// allowed.
fn parse_number(bytes: &[u8]) -> Option<(f64, usize)> {
    let sign = usize::from(matches!(bytes.first(), Some(b'+' | b'-')));
    let int = bytes
        .iter()
        .skip(sign)
        .take_while(|b| b.is_ascii_digit())
        .count();
    // Lengths within `bytes` (fewer than usize::MAX): the saturating adds never
    // saturate.
    let mut len = sign.saturating_add(int);
    let mut frac = 0;
    if bytes.get(len) == Some(&b'.') {
        frac = bytes
            .iter()
            .skip(len.saturating_add(1))
            .take_while(|b| b.is_ascii_digit())
            .count();
        len = len.saturating_add(1).saturating_add(frac);
    }
    if int == 0 && frac == 0 {
        return None;
    }
    let text = core::str::from_utf8(bytes.get(..len)?).ok()?;
    // `core` parses "1." and ".5" and a leading '+'; the grammar above admits nothing
    // else (no exponent, no "inf"/"nan").
    let value: f64 = text.parse().ok()?;
    Some((value, len))
}

/// Parses a whole file (lines ended by `\n`, optionally `\r\n`) into `points`, which is
/// cleared first. Stops reading at `M2`/`M30`.
///
/// Errors: the first refused line's [`GcodeError`]; `TooManyPoints` (at column 0 of the
/// line) when `points` is full. `points` then holds what was read before it.
pub fn parse<const N: usize>(
    text: &[u8],
    points: &mut Vec<GcodePoint, N>,
) -> Result<Program, GcodeError> {
    points.clear();
    let mut parser = Parser::new();
    for line in text.split(|&b| b == b'\n') {
        if parser.ended() {
            break;
        }
        if let Some(point) = parser.parse_line(line)? {
            points.push(point).map_err(|_| GcodeError {
                line: parser.lines(),
                column: 0,
                kind: GcodeErrorKind::TooManyPoints,
            })?;
        }
    }
    // A final line end leaves an empty last piece: not a line of the file.
    let mut program = parser.program();
    if text.last() == Some(&b'\n') && !parser.ended() {
        program.lines = program.lines.saturating_sub(1);
    }
    Ok(program)
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
