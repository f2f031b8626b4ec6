//! The PI GCS ASCII subset the grinding cell's hexapod scripts use (docs/codec.md §31,
//! Device protocols of the grinding cell; G app. D, through PI's MATLAB wrapper):
//! commands into a caller's buffer, replies parsed without allocation.
//!
//! # Commands
//!
//! One line per command, words separated by one space, ended by LF:
//!
//! | command | example | reply |
//! |---|---|---|
//! | MOV: move axes to absolute targets | `MOV X 1.5 W -0.25` | none |
//! | MOV?: targets | `MOV? X Y` (no axis: all) | axis values |
//! | POS?: positions | `POS?` | axis values |
//! | VLS: system velocity | `VLS 1` | none |
//! | VLS?: system velocity | `VLS?` | one value |
//! | SPA: set a parameter | `SPA 1 0x19001900 0` | none |
//! | HLT: halt axes | `HLT X` (no axis: all) | none |
//! | FRF: reference move | `FRF X` (no axis: all) | none |
//! | FRF?: referenced? | `FRF? X` | axis values, 1 or 0 |
//! | SAI?: axis names | `SAI?` | one axis per line |
//! | *IDN?: identification | `*IDN?` | one line of text |
//! | ERR?: error code (and clear it) | `ERR?` | an integer, 0 = no error |
//! | #5: motion status | the byte 0x05 alone | hex bit mask (bit k: axis k moving) |
//! | #7: controller ready | the byte 0x07 alone | the byte 0xB1 (ready) or 0xB0 |
//!
//! Commands without '?' are not answered: a failure sets the controller's error
//! code, which ERR? reads (then [`check_error`] turns a non-zero code into
//! [`GcsError::Controller`]). Axes are the hexapod's X, Y, Z (mm) and U, V, W (deg,
//! PI's rotations, [`crate::kinematics::tool`]); names are written upper case and
//! read in either case (G's scripts send 'x').
//!
//! # Replies
//!
//! A reply is lines ended by LF; every line but the last ends with a space before
//! its LF (docs/codec.md §31: a multi-line reply ends with the first line that has no
//! space before its LF). Axis values are `AXIS=value` lines in the order asked. A reply
//! that stops after a continuation (or without its LF) is [`GcsError::Truncated`];
//! replies longer than [`MAX_REPLY_LEN`] are refused. Numbers are decimal with an
//! optional sign, fraction and exponent; NaN, infinities and values that overflow
//! f64 are refused ([`GcsError::NotFinite`]). #5 is answered by hex digits and LF,
//! #7 by the single byte (PI's GCS command reference).
//!
//! [`Command::parse`] and [`reply`] are the controller's side (the simulated hexapod
//! in `hal-mock` speaks through them).
//!
//! Numbers are written with at most [`DECIMALS`] decimals (1 nm, 1 µdeg), trailing
//! zeros dropped, and must be below [`MAX_VALUE`] in magnitude.

/// Longest reply accepted, bytes (six axis lines of 40 bytes fit).
pub const MAX_REPLY_LEN: usize = 256;
/// Longest command written, bytes (MOV of six axes at full precision fits).
pub const MAX_COMMAND_LEN: usize = 128;
/// Decimals written after the point.
pub const DECIMALS: u32 = 6;
/// Largest magnitude written (10⁹: the scaled integer stays exact in f64).
pub const MAX_VALUE: f64 = 1e9;
/// Longest number accepted in a reply, characters.
pub const MAX_NUMBER_LEN: usize = 32;
/// #7's reply when the controller is ready.
pub const READY: u8 = 0xB1;
/// #7's reply when the controller is busy.
pub const NOT_READY: u8 = 0xB0;

/// GCS error codes the simulated hexapod uses (PI's numbering).
pub mod code {
    /// No error.
    pub const NO_ERROR: i32 = 0;
    /// Parameter syntax error.
    pub const PARAM_SYNTAX: i32 = 1;
    /// Unknown command.
    pub const UNKNOWN_COMMAND: i32 = 2;
    /// Command too long.
    pub const COMMAND_TOO_LONG: i32 = 3;
    /// Move attempted on an unreferenced axis (or with the servo off).
    pub const MOVE_WITHOUT_REFERENCE: i32 = 5;
    /// Position out of limits.
    pub const POS_OUT_OF_LIMITS: i32 = 7;
    /// Velocity out of limits.
    pub const VEL_OUT_OF_LIMITS: i32 = 8;
    /// Controller was stopped by command (HLT).
    pub const STOPPED: i32 = 10;
    /// Invalid axis identifier.
    pub const INVALID_AXIS: i32 = 15;
}

/// Why a command could not be written or a reply was refused.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GcsError {
    /// The caller's buffer cannot hold the command or reply.
    BufferTooSmall,
    /// A value is NaN or infinite (to write, or as read).
    NotFinite,
    /// A value to write is at or above [`MAX_VALUE`] in magnitude.
    OutOfRange,
    /// The reply ends before its last line (a continuation, or no LF).
    Truncated,
    /// The reply (or a number) is longer than accepted, or has more lines than axes.
    TooLong,
    /// A number that is not one.
    MalformedNumber,
    /// A byte that names no axis.
    UnknownAxis(u8),
    /// The same axis twice.
    DuplicateAxis(Axis),
    /// A line or command of the wrong shape (no '=', a line that does not continue
    /// where more follow, bytes after #7's, missing or extra arguments).
    Malformed,
    /// Not a command of this subset (device side).
    UnknownCommand,
    /// The controller reported this GCS error code (ERR? ≠ 0).
    Controller(i32),
}

/// A hexapod axis.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Axis {
    /// Translation X, mm.
    X = 0,
    /// Translation Y, mm.
    Y = 1,
    /// Translation Z, mm.
    Z = 2,
    /// Rotation U about X, deg.
    U = 3,
    /// Rotation V about the rotated Y, deg.
    V = 4,
    /// Rotation W about the twice-rotated Z, deg.
    W = 5,
}

impl Axis {
    /// The six axes in order.
    pub const ALL: [Self; 6] = [Self::X, Self::Y, Self::Z, Self::U, Self::V, Self::W];

    /// The axis' letter, upper case.
    pub const fn name(self) -> u8 {
        match self {
            Self::X => b'X',
            Self::Y => b'Y',
            Self::Z => b'Z',
            Self::U => b'U',
            Self::V => b'V',
            Self::W => b'W',
        }
    }

    /// The axis a letter names, in either case.
    pub fn from_name(byte: u8) -> Result<Self, GcsError> {
        Self::ALL
            .into_iter()
            .find(|a| a.name() == byte.to_ascii_uppercase())
            .ok_or(GcsError::UnknownAxis(byte))
    }

    /// 0 for X … 5 for W.
    pub const fn index(self) -> usize {
        self as usize
    }

    fn from_token(token: &[u8]) -> Result<Self, GcsError> {
        match token {
            [byte] => Self::from_name(*byte),
            [first, ..] => Err(GcsError::UnknownAxis(*first)),
            [] => Err(GcsError::Malformed),
        }
    }
}

/// A set of axes; iterates in the order X … W.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxisSet(u8);

impl AxisSet {
    /// No axis (in a query or HLT/FRF: all axes).
    pub const EMPTY: Self = Self(0);
    /// All six axes.
    pub const ALL: Self = Self(0x3F);

    /// The set with `axis` added.
    #[must_use]
    pub const fn with(self, axis: Axis) -> Self {
        Self(self.0 | 1 << axis as u8)
    }
    /// True when `axis` is in the set.
    pub const fn contains(self, axis: Axis) -> bool {
        self.0 & (1 << axis as u8) != 0
    }
    /// True for the empty set.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }
    /// Bit k set for axis k (the layout of #5's motion status).
    pub const fn bits(self) -> u8 {
        self.0
    }
    /// The set of the low six bits of `bits`.
    pub const fn from_bits(bits: u8) -> Self {
        Self(bits & 0x3F)
    }
    /// The axes in order.
    pub fn iter(self) -> impl Iterator<Item = Axis> {
        Axis::ALL.into_iter().filter(move |a| self.contains(*a))
    }
}

/// A value per axis (mm for X, Y, Z; deg for U, V, W), in the order X … W.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxisValues {
    values: [Option<f64>; 6],
}

impl AxisValues {
    /// No values.
    pub const fn new() -> Self {
        Self { values: [None; 6] }
    }
    /// The same `value` for every axis of `axes`.
    pub fn uniform(axes: AxisSet, value: f64) -> Self {
        let mut v = Self::new();
        for a in axes.iter() {
            v.set(a, value);
        }
        v
    }
    /// Sets the value of `axis`.
    pub fn set(&mut self, axis: Axis, value: f64) {
        if let Some(slot) = self.values.get_mut(axis.index()) {
            *slot = Some(value);
        }
    }
    /// The value of `axis`, if given.
    pub fn get(&self, axis: Axis) -> Option<f64> {
        self.values.get(axis.index()).copied().flatten()
    }
    /// The axes that have a value.
    pub fn axes(&self) -> AxisSet {
        self.iter().fold(AxisSet::EMPTY, |s, (a, _)| s.with(a))
    }
    /// (axis, value) pairs in order.
    pub fn iter(&self) -> impl Iterator<Item = (Axis, f64)> + '_ {
        Axis::ALL
            .into_iter()
            .zip(self.values)
            .filter_map(|(a, v)| v.map(|v| (a, v)))
    }
}

/// SPA's item: an axis or a number (G's scripts use "1").
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SpaItem {
    /// An axis.
    Axis(Axis),
    /// A numbered item, 1–9.
    Number(u8),
}

/// A command of the subset (table in the module docs).
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Command {
    /// MOV: absolute targets.
    Mov(AxisValues),
    /// MOV?: targets of the axes (empty: all).
    MovQuery(AxisSet),
    /// POS?: positions of the axes (empty: all).
    PosQuery(AxisSet),
    /// VLS: system velocity, mm/s.
    Vls(f64),
    /// VLS?: system velocity.
    VlsQuery,
    /// SPA: set a parameter.
    Spa {
        /// The item the parameter belongs to.
        item: SpaItem,
        /// Parameter ID (written in hex, as PI's IDs such as 0x19001900).
        parameter: u32,
        /// The value.
        value: f64,
    },
    /// HLT: halt the axes (empty: all).
    Hlt(AxisSet),
    /// FRF: reference move of the axes (empty: all).
    Frf(AxisSet),
    /// FRF?: whether the axes are referenced (empty: all).
    FrfQuery(AxisSet),
    /// SAI?: axis names.
    SaiQuery,
    /// *IDN?: identification.
    IdnQuery,
    /// ERR?: the error code, cleared by reading.
    ErrQuery,
    /// #5: motion status.
    MotionStatus,
    /// #7: controller ready.
    ControllerReady,
}

/// #5 as sent: the single byte ENQ.
pub const MOTION_STATUS_BYTE: u8 = 0x05;
/// #7 as sent: the single byte BEL.
pub const CONTROLLER_READY_BYTE: u8 = 0x07;

/// Bytes written into a caller's buffer.
struct Out<'a> {
    buf: &'a mut [u8],
    len: usize,
}

impl<'a> Out<'a> {
    fn new(buf: &'a mut [u8]) -> Self {
        Self { buf, len: 0 }
    }
    fn byte(&mut self, b: u8) -> Result<(), GcsError> {
        let slot = self.buf.get_mut(self.len).ok_or(GcsError::BufferTooSmall)?;
        *slot = b;
        self.len += 1;
        Ok(())
    }
    fn bytes(&mut self, bytes: &[u8]) -> Result<(), GcsError> {
        bytes.iter().try_for_each(|b| self.byte(*b))
    }
    fn unsigned(&mut self, mut v: u64) -> Result<(), GcsError> {
        let mut digits = [0u8; 20];
        let mut n = 0;
        loop {
            if let Some(d) = digits.get_mut(n) {
                *d = b'0' + (v % 10) as u8;
            }
            n += 1;
            v /= 10;
            if v == 0 || n >= digits.len() {
                break;
            }
        }
        digits.iter().take(n).rev().try_for_each(|d| self.byte(*d))
    }
    /// `value` with up to [`DECIMALS`] decimals, rounded to nearest, trailing zeros
    /// dropped ("-0.25", "1", "0.000001").
    fn decimal(&mut self, value: f64) -> Result<(), GcsError> {
        if !value.is_finite() {
            return Err(GcsError::NotFinite);
        }
        if libm::fabs(value) >= MAX_VALUE {
            return Err(GcsError::OutOfRange);
        }
        let scale = 10u64.pow(DECIMALS);
        // |value| < 1e9: the scaled magnitude is below 1e15 < 2^53, an exact integer.
        let scaled = libm::round(libm::fabs(value) * scale as f64) as u64;
        if value < 0.0 && scaled != 0 {
            self.byte(b'-')?;
        }
        self.unsigned(scaled / scale)?;
        let mut fraction = scaled % scale;
        if fraction != 0 {
            self.byte(b'.')?;
            let mut place = scale / 10;
            while fraction != 0 && place != 0 {
                self.byte(b'0' + (fraction / place) as u8)?;
                fraction %= place;
                place /= 10;
            }
        }
        Ok(())
    }
    fn hex(&mut self, v: u32) -> Result<(), GcsError> {
        self.bytes(b"0x")?;
        (0..8).rev().try_for_each(|k| {
            let nibble = ((v >> (4 * k)) & 0xF) as u8;
            self.byte(match nibble {
                0..=9 => b'0' + nibble,
                _ => b'A' + nibble - 10,
            })
        })
    }
    fn axes(&mut self, axes: AxisSet) -> Result<(), GcsError> {
        axes.iter().try_for_each(|a| {
            self.byte(b' ')?;
            self.byte(a.name())
        })
    }
}

impl Command {
    /// True when the controller answers this command.
    pub const fn expects_reply(&self) -> bool {
        !matches!(
            self,
            Self::Mov(_) | Self::Vls(_) | Self::Spa { .. } | Self::Hlt(_) | Self::Frf(_)
        )
    }

    /// Writes the command into `buf`; returns its length.
    pub fn encode(&self, buf: &mut [u8]) -> Result<usize, GcsError> {
        let mut out = Out::new(buf);
        match *self {
            Self::MotionStatus => out.byte(MOTION_STATUS_BYTE)?,
            Self::ControllerReady => out.byte(CONTROLLER_READY_BYTE)?,
            Self::Mov(values) => {
                if values.axes().is_empty() {
                    return Err(GcsError::Malformed);
                }
                out.bytes(b"MOV")?;
                for (axis, value) in values.iter() {
                    out.byte(b' ')?;
                    out.byte(axis.name())?;
                    out.byte(b' ')?;
                    out.decimal(value)?;
                }
            }
            Self::Vls(v) => {
                out.bytes(b"VLS ")?;
                out.decimal(v)?;
            }
            Self::Spa {
                item,
                parameter,
                value,
            } => {
                out.bytes(b"SPA ")?;
                match item {
                    SpaItem::Axis(a) => out.byte(a.name())?,
                    SpaItem::Number(n @ 1..=9) => out.byte(b'0' + n)?,
                    SpaItem::Number(_) => return Err(GcsError::OutOfRange),
                }
                out.byte(b' ')?;
                out.hex(parameter)?;
                out.byte(b' ')?;
                out.decimal(value)?;
            }
            Self::MovQuery(a)
            | Self::PosQuery(a)
            | Self::Hlt(a)
            | Self::Frf(a)
            | Self::FrfQuery(a) => {
                out.bytes(self.word())?;
                out.axes(a)?;
            }
            Self::VlsQuery | Self::SaiQuery | Self::IdnQuery | Self::ErrQuery => {
                out.bytes(self.word())?;
            }
        }
        if !matches!(self, Self::MotionStatus | Self::ControllerReady) {
            out.byte(b'\n')?;
        }
        Ok(out.len)
    }

    fn word(&self) -> &'static [u8] {
        match self {
            Self::Mov(_) => b"MOV",
            Self::MovQuery(_) => b"MOV?",
            Self::PosQuery(_) => b"POS?",
            Self::Vls(_) => b"VLS",
            Self::VlsQuery => b"VLS?",
            Self::Spa { .. } => b"SPA",
            Self::Hlt(_) => b"HLT",
            Self::Frf(_) => b"FRF",
            Self::FrfQuery(_) => b"FRF?",
            Self::SaiQuery => b"SAI?",
            Self::IdnQuery => b"*IDN?",
            Self::ErrQuery => b"ERR?",
            Self::MotionStatus => b"#5",
            Self::ControllerReady => b"#7",
        }
    }

    /// Reads one command (the controller's side): a whole line with its LF, or the
    /// single byte of #5 or #7.
    pub fn parse(bytes: &[u8]) -> Result<Self, GcsError> {
        match bytes {
            [MOTION_STATUS_BYTE] => return Ok(Self::MotionStatus),
            [CONTROLLER_READY_BYTE] => return Ok(Self::ControllerReady),
            _ => {}
        }
        if bytes.len() > MAX_COMMAND_LEN {
            return Err(GcsError::TooLong);
        }
        let line = match bytes {
            [line @ .., b'\n'] => line,
            _ => return Err(GcsError::Truncated),
        };
        let mut words = line.split(|b| *b == b' ').filter(|w| !w.is_empty());
        let word = words.next().ok_or(GcsError::UnknownCommand)?;
        let command = match word {
            b"MOV" => {
                let mut values = AxisValues::new();
                while let Some(token) = words.next() {
                    let axis = Axis::from_token(token)?;
                    if values.get(axis).is_some() {
                        return Err(GcsError::DuplicateAxis(axis));
                    }
                    let value = parse_number(words.next().ok_or(GcsError::Malformed)?)?;
                    values.set(axis, value);
                }
                if values.axes().is_empty() {
                    return Err(GcsError::Malformed);
                }
                Self::Mov(values)
            }
            b"MOV?" => Self::MovQuery(axis_list(&mut words)?),
            b"POS?" => Self::PosQuery(axis_list(&mut words)?),
            b"HLT" => Self::Hlt(axis_list(&mut words)?),
            b"FRF" => Self::Frf(axis_list(&mut words)?),
            b"FRF?" => Self::FrfQuery(axis_list(&mut words)?),
            b"VLS" => Self::Vls(parse_number(words.next().ok_or(GcsError::Malformed)?)?),
            b"SPA" => {
                let item = match words.next().ok_or(GcsError::Malformed)? {
                    [d @ b'1'..=b'9'] => SpaItem::Number(d - b'0'),
                    token => SpaItem::Axis(Axis::from_token(token)?),
                };
                let parameter = parse_parameter(words.next().ok_or(GcsError::Malformed)?)?;
                let value = parse_number(words.next().ok_or(GcsError::Malformed)?)?;
                Self::Spa {
                    item,
                    parameter,
                    value,
                }
            }
            b"VLS?" => Self::VlsQuery,
            b"SAI?" => Self::SaiQuery,
            b"*IDN?" => Self::IdnQuery,
            b"ERR?" => Self::ErrQuery,
            _ => return Err(GcsError::UnknownCommand),
        };
        if words.next().is_some() {
            return Err(GcsError::Malformed);
        }
        Ok(command)
    }
}

/// Axis names, each once, until the words run out.
fn axis_list<'a>(words: impl Iterator<Item = &'a [u8]>) -> Result<AxisSet, GcsError> {
    let mut set = AxisSet::EMPTY;
    for token in words {
        let axis = Axis::from_token(token)?;
        if set.contains(axis) {
            return Err(GcsError::DuplicateAxis(axis));
        }
        set = set.with(axis);
    }
    Ok(set)
}

/// A number as GCS writes it: optional sign, digits with an optional point and
/// fraction (at least one digit), optional exponent. Refuses NaN, infinities and
/// overflow.
pub fn parse_number(token: &[u8]) -> Result<f64, GcsError> {
    if token.len() > MAX_NUMBER_LEN {
        return Err(GcsError::TooLong);
    }
    let unsigned = match token {
        [b'+' | b'-', rest @ ..] => rest,
        rest => rest,
    };
    let mantissa_len = unsigned
        .iter()
        .position(|b| matches!(b, b'e' | b'E'))
        .unwrap_or(unsigned.len());
    let (mantissa, exponent) = unsigned.split_at(mantissa_len);
    // Digits and at most one point, at least one digit (tests, not counts: a count
    // keeps an overflow check the optimiser cannot remove).
    let has_digit = mantissa.iter().any(u8::is_ascii_digit);
    let only_digits_and_points = mantissa.iter().all(|b| b.is_ascii_digit() || *b == b'.');
    let mut points = mantissa.iter().filter(|b| **b == b'.');
    let at_most_one_point = points.next().is_none() || points.next().is_none();
    let exponent_ok = match exponent {
        [] => true,
        [_, b'+' | b'-', d @ ..] | [_, d @ ..] => !d.is_empty() && d.iter().all(u8::is_ascii_digit),
    };
    if !has_digit || !at_most_one_point || !only_digits_and_points || !exponent_ok {
        return Err(GcsError::MalformedNumber);
    }
    let text = core::str::from_utf8(token).map_err(|_| GcsError::MalformedNumber)?;
    let value: f64 = text.parse().map_err(|_| GcsError::MalformedNumber)?;
    if value.is_finite() {
        Ok(value)
    } else {
        Err(GcsError::NotFinite)
    }
}

/// A parameter ID: `0x` and hex digits, or decimal.
fn parse_parameter(token: &[u8]) -> Result<u32, GcsError> {
    let text = core::str::from_utf8(token).map_err(|_| GcsError::MalformedNumber)?;
    let parsed = match text.strip_prefix("0x").or_else(|| text.strip_prefix("0X")) {
        Some(hex) if !hex.starts_with('+') => u32::from_str_radix(hex, 16),
        None if !text.starts_with('+') => text.parse(),
        _ => return Err(GcsError::MalformedNumber),
    };
    parsed.map_err(|_| GcsError::MalformedNumber)
}

/// The lines of a reply without their continuation spaces and LFs, each checked for
/// its place: all but the last end with " \n", the last with "\n".
fn lines(reply: &[u8]) -> Result<impl Iterator<Item = &[u8]>, GcsError> {
    if reply.len() > MAX_REPLY_LEN {
        return Err(GcsError::TooLong);
    }
    let body = match reply {
        [body @ .., b'\n'] => body,
        _ => return Err(GcsError::Truncated),
    };
    if body.ends_with(b" ") {
        return Err(GcsError::Truncated);
    }
    let mut parts = body.split(|b| *b == b'\n').peekable();
    let mut malformed = false;
    // Check every continuation before handing out lines.
    let mut check = body.split(|b| *b == b'\n').peekable();
    while let Some(line) = check.next() {
        if check.peek().is_some() && !line.ends_with(b" ") {
            malformed = true;
        }
    }
    if malformed {
        return Err(GcsError::Malformed);
    }
    Ok(core::iter::from_fn(move || {
        let line = parts.next()?;
        Some(match (parts.peek(), line) {
            (Some(_), [line @ .., b' ']) => line,
            _ => line,
        })
    }))
}

/// A reply of `AXIS=value` lines (POS?, MOV?, FRF?).
pub fn parse_axis_values(reply: &[u8]) -> Result<AxisValues, GcsError> {
    let mut values = AxisValues::new();
    for line in lines(reply)? {
        let eq = line
            .iter()
            .position(|b| *b == b'=')
            .ok_or(GcsError::Malformed)?;
        let (name, value) = line.split_at(eq);
        let axis = Axis::from_token(name)?;
        if values.get(axis).is_some() {
            return Err(GcsError::DuplicateAxis(axis));
        }
        values.set(axis, parse_number(value.get(1..).unwrap_or(&[]))?);
    }
    Ok(values)
}

/// FRF?'s reply: the axes reported and the referenced ones among them (each value
/// must be 0 or 1).
pub fn parse_referenced(reply: &[u8]) -> Result<(AxisSet, AxisSet), GcsError> {
    let values = parse_axis_values(reply)?;
    let flags =
        values
            .iter()
            .try_fold((AxisSet::EMPTY, AxisSet::EMPTY), |(all, yes), (axis, v)| {
                if v == 1.0 {
                    Ok((all.with(axis), yes.with(axis)))
                } else if v == 0.0 {
                    Ok((all.with(axis), yes))
                } else {
                    Err(GcsError::MalformedNumber)
                }
            });
    flags
}

/// A one-line reply holding one number (VLS?).
pub fn parse_value(reply: &[u8]) -> Result<f64, GcsError> {
    let mut it = lines(reply)?;
    let value = parse_number(it.next().ok_or(GcsError::Truncated)?)?;
    if it.next().is_some() {
        return Err(GcsError::Malformed);
    }
    Ok(value)
}

/// ERR?'s reply: the integer error code.
pub fn parse_error_code(reply: &[u8]) -> Result<i32, GcsError> {
    let mut it = lines(reply)?;
    let line = it.next().ok_or(GcsError::Truncated)?;
    if it.next().is_some() || line.is_empty() || line.len() > 11 || line.starts_with(b"+") {
        return Err(GcsError::MalformedNumber);
    }
    let text = core::str::from_utf8(line).map_err(|_| GcsError::MalformedNumber)?;
    text.parse().map_err(|_| GcsError::MalformedNumber)
}

/// `Ok` for code 0, else [`GcsError::Controller`] with the code.
pub const fn check_error(code: i32) -> Result<(), GcsError> {
    if code == code::NO_ERROR {
        Ok(())
    } else {
        Err(GcsError::Controller(code))
    }
}

/// SAI?'s reply: one axis name per line.
pub fn parse_axis_names(reply: &[u8]) -> Result<AxisSet, GcsError> {
    lines(reply)?.try_fold(AxisSet::EMPTY, |set, line| {
        let axis = Axis::from_token(line)?;
        if set.contains(axis) {
            Err(GcsError::DuplicateAxis(axis))
        } else {
            Ok(set.with(axis))
        }
    })
}

/// *IDN?'s reply: one line of printable ASCII.
pub fn parse_identification(reply: &[u8]) -> Result<&str, GcsError> {
    let mut it = lines(reply)?;
    let line = it.next().ok_or(GcsError::Truncated)?;
    if it.next().is_some() || !line.iter().all(|b| (b' '..=b'~').contains(b)) {
        return Err(GcsError::Malformed);
    }
    core::str::from_utf8(line).map_err(|_| GcsError::Malformed)
}

/// #5's reply: the moving axes (hex bit mask, bit k for axis k, then LF).
pub fn parse_motion_status(reply: &[u8]) -> Result<AxisSet, GcsError> {
    let digits = match reply {
        [digits @ .., b'\n'] => digits,
        _ => return Err(GcsError::Truncated),
    };
    if digits.is_empty() || digits.len() > 2 {
        return Err(GcsError::MalformedNumber);
    }
    let text = core::str::from_utf8(digits).map_err(|_| GcsError::MalformedNumber)?;
    if text.starts_with('+') {
        return Err(GcsError::MalformedNumber);
    }
    let bits = u8::from_str_radix(text, 16).map_err(|_| GcsError::MalformedNumber)?;
    if bits & !AxisSet::ALL.bits() != 0 {
        return Err(GcsError::UnknownAxis(bits));
    }
    Ok(AxisSet::from_bits(bits))
}

/// #7's reply: true when ready (the single byte [`READY`] or [`NOT_READY`]).
pub fn parse_ready(reply: &[u8]) -> Result<bool, GcsError> {
    match reply {
        [READY] => Ok(true),
        [NOT_READY] => Ok(false),
        [] => Err(GcsError::Truncated),
        _ => Err(GcsError::Malformed),
    }
}

pub mod reply;

#[cfg(test)]
mod tests;
