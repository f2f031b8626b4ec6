//! What the reader says about a program: every warning and error with its line and
//! column, and the words a machinist reads ([`core::fmt::Display`] of
//! [`GcodeErrorKind`]).

use core::fmt;

/// Whether the program can still run as read.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Severity {
    /// Safe to skip: the word is read and has no effect on this machine.
    Warning,
    /// The line is not read: running the program would not do what it says.
    Error,
}

/// What the reader found. Each kind is either a warning or an error
/// ([`GcodeErrorKind::severity`]).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GcodeErrorKind {
    /// Error: a letter that is no word of the language read (the letter, upper case).
    UnknownWord(u8),
    /// Error: a G or M code the reader does not know (letter and the code × 10, so that
    /// `G2` is 20 and `G43.4` is 434).
    Unsupported {
        /// `b'G'` or `b'M'`.
        letter: u8,
        /// The code × 10.
        code_x10: u32,
    },
    /// Error: a known G or M code that would make the machine do something the reader
    /// cannot follow (return home, probe, canned cycle, cutter compensation, a pause
    /// for the operator, setting offsets from the program, feed per revolution).
    NotRead {
        /// `b'G'` or `b'M'`.
        letter: u8,
        /// The code × 10.
        code_x10: u32,
    },
    /// Warning: a word without effect on this machine (tool number and change,
    /// coolant, tool length offset, path blending, optional stop, storing a home
    /// position); the letter and the value × 10.
    Ignored {
        /// The word's letter.
        letter: u8,
        /// Its value × 10.
        code_x10: u32,
    },
    /// Error: a byte that starts no word (a digit without a letter, `#` parameters,
    /// `[` expressions, a character outside ASCII outside a comment).
    UnexpectedByte(u8),
    /// Error: the number after a letter is missing or not `[+-]digits[.digits]`.
    MalformedNumber,
    /// Error: the same letter twice on one line (`X1 X2`, `F1 F2`).
    DuplicateWord(u8),
    /// Error: two codes of one modal group on one line (`G0 G1`, `G90 G91`, `M3 M5`);
    /// the second one.
    ModalConflict {
        /// `b'G'` or `b'M'`.
        letter: u8,
        /// The code × 10.
        code_x10: u32,
    },
    /// Error: a feed move (`G1`, `G2`, `G3`) before any `F` word gave a feed.
    MissingFeed,
    /// Error: axis words before any motion mode (`G0`…`G3`).
    NoMotionMode,
    /// Error: a zero or negative feed.
    BadFeed,
    /// Error: a negative spindle speed or laser power `S`.
    BadSpindle,
    /// Error: a dwell `G4` without a non-negative `P` (seconds).
    BadDwell,
    /// Error: the checksum after `*` differs from the XOR of the line's bytes before it.
    BadChecksum {
        /// The value written after `*`.
        given: u8,
        /// The XOR of the bytes before `*`.
        computed: u8,
    },
    /// Error: a `(` comment not closed on its line, or a `)` without a `(`.
    UnclosedComment,
    /// Warning: a `(` inside a comment; the comment ends at the first `)`, as grbl and
    /// LinuxCNC read it.
    NestedComment,
    /// Warning: a line that starts with `#` not followed by a parameter (`#1`, `#<`,
    /// `#[`) is read as a comment, as hobby laser and 3D-printer programs write them.
    HashComment,
    /// Error: more points than the caller's buffer holds (reported once).
    TooManyPoints,
    /// Error: more than the supported number of words on a line.
    TooManyWords,
    /// Error: a coordinate or feed is infinite after conversion and accumulation.
    NotFinite,
    /// Error: an axis word for an axis the machine does not have (the letter).
    AxisNotOnMachine(u8),
    /// Error: a word no code on its line uses (`I`/`J`/`K`/`R` without an arc, `P`
    /// without a dwell or an arc).
    UnusedWord(u8),
    /// Error: an arc whose end is not on the circle through its start about the given
    /// centre, or whose radius `R` is shorter than half the distance to its end.
    ArcRadiusMismatch,
    /// Error: an arc without its centre (`I`/`J`/`K`) or radius (`R`), with both, or
    /// with no end point in its plane, or with `R` and the end at the start.
    ArcUndefined,
    /// Error: an arc that needs more chords than the reader makes at the caller's
    /// tolerance.
    ArcTooFine,
    /// Error: an arc given to the line-by-line reader, which returns one point a line.
    ArcNotLineByLine,
    /// Error: a feed move in inverse-time feed mode (`G93`).
    InverseTimeMove,
    /// Error: an `O` word with subroutines or flow control (`sub`, `call`, `if`, …).
    FlowControl,
    /// Warning: an `O` program number, ignored.
    ProgramNumber,
    /// Warning: `G93` inverse-time feed mode is set; feed moves in it are refused.
    InverseTimeMode,
    /// Warning: lines after the program's end (`M2`/`M30`) are not read.
    AfterEnd,
}

impl GcodeErrorKind {
    /// Whether the program can still run as read.
    pub fn severity(&self) -> Severity {
        match self {
            Self::Ignored { .. }
            | Self::NestedComment
            | Self::HashComment
            | Self::ProgramNumber
            | Self::InverseTimeMode
            | Self::AfterEnd => Severity::Warning,
            _ => Severity::Error,
        }
    }
}

/// A letter or a byte in a message.
struct Letter(u8);

impl fmt::Display for Letter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.is_ascii_graphic() {
            write!(f, "'{}'", char::from(self.0))
        } else {
            write!(f, "byte {:#04x}", self.0)
        }
    }
}

/// A code as written: `G64`, `G92.1`.
struct Code(u8, u32);

impl fmt::Display for Code {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Code(letter, x10) = *self;
        write!(f, "{}{}", char::from(letter), x10 / 10)?;
        if x10 % 10 != 0 {
            write!(f, ".{}", x10 % 10)?;
        }
        Ok(())
    }
}

/// Why a known code is refused ([`GcodeErrorKind::NotRead`]).
fn not_read_reason(letter: u8, code_x10: u32) -> &'static str {
    match (letter, code_x10) {
        (b'G', 100) => "offsets set by the program are not read",
        (b'G', 280 | 300) => "the home position is the machine's, not the program's",
        (b'G', 380..=389) => "probing is not done by this machine",
        (b'G', 410..=429) => "cutter radius compensation is not done by this machine",
        (b'G', 730 | 760 | 810..=899) => "canned cycles are not read",
        (b'G', 950) => "feed per revolution is not read",
        (b'M', 0 | 600) => "a pause for the operator is not done by this machine",
        _ => "not done by this machine",
    }
}

/// Why a word is skipped ([`GcodeErrorKind::Ignored`]).
fn ignored_reason(letter: u8, code_x10: u32) -> &'static str {
    match (letter, code_x10) {
        (b'T', _) => "the machine has one tool",
        (b'M', 60) => "the machine has one tool, no tool change",
        (b'M', 70..=90) => "the machine has no coolant",
        (b'M', 10) => "optional stop is off",
        (b'G', 430..=439) => "the machine has no tool length offset",
        (b'G', 610..=649) => "path blending is the machine's planner's",
        (b'G', 281 | 301) => "home positions are not stored",
        _ => "no effect on this machine",
    }
}

impl fmt::Display for GcodeErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::UnknownWord(b) => write!(f, "unknown word {}", Letter(b)),
            Self::Unsupported { letter, code_x10 } => {
                write!(f, "unsupported code {}", Code(letter, code_x10))
            }
            Self::NotRead { letter, code_x10 } => write!(
                f,
                "{} refused: {}",
                Code(letter, code_x10),
                not_read_reason(letter, code_x10)
            ),
            Self::Ignored { letter, code_x10 } => write!(
                f,
                "{} ignored: {}",
                Code(letter, code_x10),
                ignored_reason(letter, code_x10)
            ),
            Self::UnexpectedByte(b'#') => f.write_str("parameters (#) are not read"),
            Self::UnexpectedByte(b'[') => f.write_str("expressions ([ ]) are not read"),
            Self::UnexpectedByte(b) => write!(f, "unexpected {}", Letter(b)),
            Self::MalformedNumber => f.write_str("malformed number"),
            Self::DuplicateWord(b) => write!(f, "word {} given twice", Letter(b)),
            Self::ModalConflict { letter, code_x10 } => write!(
                f,
                "{} on the same line as another code of its group",
                Code(letter, code_x10)
            ),
            Self::MissingFeed => f.write_str("feed move before any feed (F)"),
            Self::NoMotionMode => f.write_str("axis words before any G0, G1, G2 or G3"),
            Self::BadFeed => f.write_str("feed must be positive"),
            Self::BadSpindle => f.write_str("spindle speed or laser power S must not be negative"),
            Self::BadDwell => f.write_str("dwell G4 needs P, the time in seconds, not negative"),
            Self::BadChecksum { given, computed } => {
                write!(f, "checksum *{given} does not match the line's {computed}")
            }
            Self::UnclosedComment => f.write_str("comment not closed on its line"),
            Self::NestedComment => {
                f.write_str("'(' inside a comment: the comment ends at the first ')'")
            }
            Self::HashComment => f.write_str("a line starting with '#' read as a comment"),
            Self::TooManyPoints => f.write_str("more points than the machine's buffer holds"),
            Self::TooManyWords => f.write_str("too many words on the line"),
            Self::NotFinite => f.write_str("coordinate or feed too large"),
            Self::AxisNotOnMachine(b) => write!(f, "the machine has no axis {}", Letter(b)),
            Self::UnusedWord(b) => write!(f, "word {} is used by no code on the line", Letter(b)),
            Self::ArcRadiusMismatch => f.write_str("the arc's end is not on its circle"),
            Self::ArcUndefined => f.write_str(
                "arc needs an end in its plane and either a centre (I, J, K) or a radius (R)",
            ),
            Self::ArcTooFine => f.write_str("arc needs too many chords at the chord tolerance"),
            Self::ArcNotLineByLine => f.write_str("arcs are not read by this machine"),
            Self::InverseTimeMove => f.write_str("feed move in inverse-time mode (G93)"),
            Self::FlowControl => f.write_str("subroutines and flow control (O words) are not read"),
            Self::ProgramNumber => f.write_str("program number ignored"),
            Self::InverseTimeMode => {
                f.write_str("inverse-time feed (G93): feed moves are refused until G94")
            }
            Self::AfterEnd => f.write_str("lines after the program end (M2, M30) are not read"),
        }
    }
}

/// One warning or error: where, and what. Lines and columns are 1-based; columns count
/// the characters of the line as written (a byte-order mark before the first line is
/// not a character of it); column 0 means the whole line.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Diagnostic {
    /// 1-based line number in the input.
    pub line: u32,
    /// 1-based character column of the cause (0 when it is the whole line).
    pub column: u32,
    /// What was found.
    pub kind: GcodeErrorKind,
}

/// An error is a [`Diagnostic`] of [`Severity::Error`].
pub type GcodeError = Diagnostic;

impl Diagnostic {
    /// Whether the program can still run as read.
    pub fn severity(&self) -> Severity {
        self.kind.severity()
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let severity = match self.severity() {
            Severity::Warning => "warning",
            Severity::Error => "error",
        };
        // A cause that is the whole line is shown at its first column, as compilers do.
        write!(
            f,
            "{}:{}: {severity}: {}",
            self.line,
            self.column.max(1),
            self.kind
        )
    }
}

impl core::error::Error for Diagnostic {}
