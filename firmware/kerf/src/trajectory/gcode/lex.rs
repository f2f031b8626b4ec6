//! One line into words: comments (`( )`, `;`, and a line starting with `#` where no
//! parameter follows), blanks, checksums and program numbers removed.
//!
//! As grbl (`protocol.c` strips every blank and control byte before the parser) and
//! LinuxCNC (blanks are ignored anywhere outside comments), blanks may stand inside a
//! word: `G 1`, `X - 1 . 5` read as `G1`, `X-1.5`.

use super::diagnostic::GcodeErrorKind;
use heapless::Vec;

/// Most words on one line.
pub(super) const MAX_WORDS: usize = 24;

/// Most significant characters of one number (sign, digits, point).
const MAX_NUMBER_CHARS: usize = 40;

/// The UTF-8 byte-order mark some editors write before the first line.
pub(super) const BOM: &[u8] = b"\xEF\xBB\xBF";

/// One word of a line: letter (upper case), value, and the column of the letter.
#[derive(Copy, Clone, Debug)]
pub(super) struct Word {
    pub letter: u8,
    pub value: f64,
    pub column: u32,
}

/// The 1-based character column of byte `i` of `line`: the characters before it
/// (UTF-8 lead bytes; continuation bytes are `0b10xx_xxxx`), plus one.
pub(super) fn column_of(line: &[u8], i: usize) -> u32 {
    let chars = line.iter().take(i).filter(|&&b| b & 0xC0 != 0x80).count();
    u32::try_from(chars).unwrap_or(u32::MAX).saturating_add(1)
}

/// Blanks: grbl discards every byte up to the space.
fn blank(b: u8) -> bool {
    b <= b' '
}

/// Splits `line` (no line end) into words. Warnings go to `warn` with their column;
/// the first error ends the line and is returned with its column.
pub(super) fn words(
    line: &[u8],
    warn: &mut (impl FnMut(u32, GcodeErrorKind) + ?Sized),
) -> Result<Vec<Word, MAX_WORDS>, (u32, GcodeErrorKind)> {
    let mut words: Vec<Word, MAX_WORDS> = Vec::new();
    let at = |k: usize| line.get(k).copied();
    let err = |i: usize, kind| (column_of(line, i), kind);
    let first = line.iter().position(|&b| !blank(b));
    let mut i = first.unwrap_or(line.len());
    match at(i) {
        // A tape mark alone on its line (blanks and a comment may follow).
        Some(b'%') => i = i.saturating_add(1),
        // Block delete: with the switch off, as LinuxCNC's default and grbl, the line
        // is read.
        Some(b'/') => i = i.saturating_add(1),
        // A comment line of the hobby controllers, where no parameter follows.
        Some(b'#') if !matches!(at(i.saturating_add(1)), Some(b'0'..=b'9' | b'<' | b'[')) => {
            warn(column_of(line, i), GcodeErrorKind::HashComment);
            return Ok(words);
        }
        _ => {}
    }
    // The RepRap checksum covers every byte before `*`.
    let xor_before = |end: usize| line.iter().take(end).fold(0u8, |a, &b| a ^ b);
    while let Some(byte) = at(i) {
        match byte {
            b if blank(b) => i = i.saturating_add(1),
            b'(' => {
                let rest = line.get(i..).unwrap_or(&[]);
                let Some(close) = rest.iter().position(|&b| b == b')') else {
                    return Err(err(i, GcodeErrorKind::UnclosedComment));
                };
                let inner = rest.get(1..close).unwrap_or(&[]);
                if let Some(k) = inner.iter().position(|&b| b == b'(') {
                    warn(
                        column_of(line, i.saturating_add(1).saturating_add(k)),
                        GcodeErrorKind::NestedComment,
                    );
                }
                // Positions in the line (fewer than usize::MAX bytes): never saturate.
                i = i.saturating_add(close).saturating_add(1);
            }
            b')' => return Err(err(i, GcodeErrorKind::UnclosedComment)),
            b';' => break,
            b'*' => {
                let computed = xor_before(i);
                let digits = line
                    .iter()
                    .skip(i.saturating_add(1))
                    .take_while(|b| b.is_ascii_digit())
                    .count();
                let given = line
                    .get(i.saturating_add(1)..i.saturating_add(1).saturating_add(digits))
                    .and_then(|d| core::str::from_utf8(d).ok())
                    .and_then(|d| d.parse::<u8>().ok())
                    .ok_or(err(i.saturating_add(1), GcodeErrorKind::MalformedNumber))?;
                if given != computed {
                    return Err(err(i, GcodeErrorKind::BadChecksum { given, computed }));
                }
                // Only blanks or a `;` comment may follow the checksum.
                let end = i.saturating_add(1).saturating_add(digits);
                let rest = line.get(end..).unwrap_or(&[]);
                return match rest.iter().position(|&b| !blank(b)) {
                    None => Ok(words),
                    Some(k) => match rest.get(k) {
                        Some(b';') => Ok(words),
                        b => Err(err(
                            end.saturating_add(k),
                            GcodeErrorKind::UnexpectedByte(b.copied().unwrap_or(0)),
                        )),
                    },
                };
            }
            letter if letter.is_ascii_alphabetic() => {
                let upper = letter.to_ascii_uppercase();
                let number = number(line, i.saturating_add(1));
                if upper == b'O' {
                    // A program number alone; anything else (`o100 sub`, `o<name> call`)
                    // is flow control.
                    let end = number.map_or(i.saturating_add(1), |(_, end)| end);
                    if number.is_none() || !rest_is_empty(line.get(end..).unwrap_or(&[])) {
                        return Err(err(i, GcodeErrorKind::FlowControl));
                    }
                    warn(column_of(line, i), GcodeErrorKind::ProgramNumber);
                    i = end;
                    continue;
                }
                let (value, end) =
                    number.ok_or(err(i.saturating_add(1), GcodeErrorKind::MalformedNumber))?;
                let word = Word {
                    letter: upper,
                    value,
                    column: column_of(line, i),
                };
                words
                    .push(word)
                    .map_err(|_| err(i, GcodeErrorKind::TooManyWords))?;
                i = end;
            }
            other => return Err(err(i, GcodeErrorKind::UnexpectedByte(other))),
        }
    }
    Ok(words)
}

/// Whether only blanks and comments follow (for a program number's line).
fn rest_is_empty(rest: &[u8]) -> bool {
    let mut in_comment = false;
    for &b in rest {
        match b {
            b';' if !in_comment => return true,
            b'(' => in_comment = true,
            b')' => in_comment = false,
            b if in_comment || blank(b) => {}
            _ => return false,
        }
    }
    true
}

/// A number `[+-]digits[.digits]` (at least one digit; blanks anywhere in it) starting
/// at byte `start`: its value and the byte after it.
fn number(line: &[u8], start: usize) -> Option<(f64, usize)> {
    let mut text = [0u8; MAX_NUMBER_CHARS];
    let mut len = 0usize;
    let mut digits = 0usize;
    let mut point = false;
    let mut end = start;
    for (k, &b) in line.iter().enumerate().skip(start) {
        let accept = match b {
            b'+' | b'-' => len == 0,
            b'.' => {
                !point && {
                    point = true;
                    true
                }
            }
            b'0'..=b'9' => {
                digits = digits.saturating_add(1);
                true
            }
            b if blank(b) => {
                continue;
            }
            _ => false,
        };
        if !accept {
            break;
        }
        *text.get_mut(len)? = b;
        len = len.saturating_add(1);
        end = k.saturating_add(1);
    }
    if digits == 0 {
        return None;
    }
    let text = core::str::from_utf8(text.get(..len)?).ok()?;
    // `core` parses "1." and ".5" and a leading '+'; the grammar above admits nothing
    // else (no exponent, no "inf"/"nan").
    let value: f64 = text.parse().ok()?;
    Some((value, end))
}
