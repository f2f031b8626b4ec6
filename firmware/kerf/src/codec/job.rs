//! The job file: what the host tool plans (`kerf plan`, `kerf gcode`) and uploads, and
//! what a machine loads. One format on both sides, written and read here.
//!
//! All numbers little-endian:
//!
//! | offset | bytes | field |
//! |---|---|---|
//! | 0 | 4 | magic `KRFJ` |
//! | 4 | 1 | format version: 1, or 2 with cut settings ([`JOB_FORMAT_VERSION`]) |
//! | 5 | 1 | kind: 0 EFD, 1 points, 2 G-code, 3 recording, 4 schedule, 5 moves ([`JobKind`]) |
//! | 6 | 2 | reserved, 0 |
//! | 8 | 4 | count: harmonics (EFD), points (points, moves), body bytes (G-code, recording), steps (schedule) |
//! | 12 | 12 | version 2 only: the part's cut settings ([`crate::codec::cut_settings`]) |
//! | 12 or 24 | … | body |
//! | end − 4 | 4 | CRC-32 (ISO-HDLC) of every byte before it |
//!
//! Version 2 exists for the contour kinds (EFD, points and moves), the laser's parts; a
//! version 1 file is a part cut with the machine's own settings, and the writers
//! write version 1 wherever the settings are the machine's, so the smallest file
//! that says a part is the one written.
//!
//! A reader checks, in this order: length, magic, version, kind, the body's length
//! against the count, the CRC, the reserved bytes, the settings, and that every number
//! is finite; a new layout gets a new version, and readers refuse versions they do not
//! know.
//!
//! Bodies: EFD, the centre (x, y) then (a_k, b_k, c_k, d_k) per harmonic, f32, m;
//! points, (x, y) per point, f32, m; G-code, the text (ASCII); recording, a recorded
//! master session as its own format writes it (`KRFR`,
//! `machines::delta_slave::remote::recording`, which checks it when a machine loads it);
//! schedule, (setpoint, duration s) per step, f32, the setpoint in the unit of the
//! machine that runs it (the autofocus stage's magnification,
//! `machines::autofocus::product`); moves, (x, y, feed) per point, f32, m and m/s, the
//! feed that of the move ending at the point (the first point's is not used, and is
//! written 0).

pub use super::cut_settings::{Continuity, CutLaser, CutSettings};
pub use super::link::JobKind;

use super::cut_settings::{BlockError, CUT_SETTINGS_BYTES};

/// The newest version of the job file (the reader reads this one and every one
/// before it).
pub const JOB_FORMAT_VERSION: u8 = 2;

/// The version without cut settings.
const VERSION_WITHOUT_SETTINGS: u8 = 1;

/// The file's first bytes.
pub const MAGIC: [u8; 4] = *b"KRFJ";

/// Bytes before the body.
pub const HEADER_BYTES: usize = 12;

use super::link::crc32;

/// Why bytes are not a job file.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum JobFileError {
    /// Shorter than a header and a CRC, or than its count says.
    Truncated,
    /// Not `KRFJ`.
    Magic,
    /// Another format version.
    Version(u8),
    /// An unknown kind byte.
    Kind(u8),
    /// Longer than its count says.
    TrailingBytes,
    /// The CRC does not match.
    Crc,
    /// The reserved bytes are not zero.
    Reserved,
    /// A number is NaN or infinite.
    NotFinite,
    /// Cut settings that do not read, or on a kind that takes none.
    Settings,
    /// The buffer to write into is too small.
    NoRoom,
}

impl core::fmt::Display for JobFileError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Truncated => write!(f, "job file truncated"),
            Self::Magic => write!(f, "not a kerf job file (bad magic)"),
            Self::Version(v) => write!(
                f,
                "job file format version {v} is not supported (this reader knows {JOB_FORMAT_VERSION})"
            ),
            Self::Kind(k) => write!(f, "unknown job kind {k}"),
            Self::TrailingBytes => write!(f, "bytes after the job file's body"),
            Self::Crc => write!(f, "CRC mismatch: the job file is damaged"),
            Self::Reserved => write!(f, "reserved bytes are not zero"),
            Self::NotFinite => write!(f, "a number is NaN or infinite"),
            Self::Settings => write!(
                f,
                "the cut settings do not read (an unknown laser mode), or are on a job kind that takes none"
            ),
            Self::NoRoom => write!(f, "the job does not fit the buffer"),
        }
    }
}

/// A job file's content, borrowed from its bytes.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum JobFile<'a> {
    /// A closed contour: centre and `count` harmonics, the body's f32 little-endian.
    Efd {
        /// Centre, m.
        centre_m: [f32; 2],
        /// (a, b, c, d) per harmonic, read with [`JobFile::harmonic`].
        coefficients: &'a [u8],
        /// How it is cut.
        settings: CutSettings,
    },
    /// An open contour's points (x, y), read with [`JobFile::point`].
    Points {
        /// The body.
        points: &'a [u8],
        /// How it is cut.
        settings: CutSettings,
    },
    /// G-code text.
    Gcode {
        /// The text.
        text: &'a [u8],
    },
    /// A recorded master session (`KRFR`), read by the machine that plays it.
    Recording {
        /// The recording's bytes.
        bytes: &'a [u8],
    },
    /// A schedule: steps of (setpoint, duration s), read with [`JobFile::step`].
    Schedule {
        /// The body.
        steps: &'a [u8],
    },
    /// A program of straight moves: (x, y, feed) per point, read with
    /// [`JobFile::move_point`].
    Moves {
        /// The body.
        points: &'a [u8],
        /// How it is cut.
        settings: CutSettings,
    },
}

/// The body's length of a file of `kind` and `count` (module docs); `None` for an
/// unknown kind.
fn body_len(kind: u8, count: u32) -> Option<u64> {
    let count = u64::from(count);
    match kind {
        0 => Some(8 + 16 * count),
        1 | 4 => Some(8 * count),
        2 | 3 => Some(count),
        5 => Some(12 * count),
        _ => None,
    }
}

/// The length of the job file at the start of `bytes`, from its header (a program of
/// several parts is their files back to back); `None` when the header is incomplete,
/// not a job file's, of an unknown kind, or the length passes `usize`. The file
/// itself is checked by [`JobFile::read`].
pub fn file_len(bytes: &[u8]) -> Option<usize> {
    let header = bytes.get(..HEADER_BYTES)?;
    if header.get(..4) != Some(&MAGIC[..]) {
        return None;
    }
    let count = u32::from_le_bytes(header.get(8..12)?.try_into().ok()?);
    let body = body_len(*header.get(5)?, count)?;
    let fixed = HEADER_BYTES + settings_len(*header.get(4)?) + 4;
    usize::try_from(body.checked_add(fixed as u64)?).ok()
}

/// Bytes of cut settings in a file of `version`.
fn settings_len(version: u8) -> usize {
    match version {
        VERSION_WITHOUT_SETTINGS => 0,
        _ => CUT_SETTINGS_BYTES,
    }
}

/// Row `row` of `N` little-endian f32s; `None` past the end (an index so large that
/// its byte offset passes `usize` included).
fn f32_row<const N: usize>(bytes: &[u8], row: usize) -> Option<[f32; N]> {
    let start = row.checked_mul(4 * N)?;
    let mut out = [0.0f32; N];
    let mut words = bytes.get(start..)?.chunks_exact(4);
    for value in &mut out {
        *value = f32::from_le_bytes(words.next()?.try_into().ok()?);
    }
    Some(out)
}

impl<'a> JobFile<'a> {
    /// The kind.
    pub fn kind(&self) -> JobKind {
        match self {
            Self::Efd { .. } => JobKind::Efd,
            Self::Points { .. } => JobKind::Points,
            Self::Gcode { .. } => JobKind::Gcode,
            Self::Recording { .. } => JobKind::Recording,
            Self::Schedule { .. } => JobKind::Schedule,
            Self::Moves { .. } => JobKind::Moves,
        }
    }

    /// Harmonics (EFD), points (points, moves), text bytes (G-code), recording bytes
    /// or steps (schedule).
    pub fn count(&self) -> usize {
        match self {
            Self::Efd { coefficients, .. } => coefficients.len() / 16,
            Self::Points { points, .. } => points.len() / 8,
            Self::Gcode { text } => text.len(),
            Self::Recording { bytes } => bytes.len(),
            Self::Schedule { steps } => steps.len() / 8,
            Self::Moves { points, .. } => points.len() / 12,
        }
    }

    /// Harmonic `k` (0-based) of an EFD job, m.
    pub fn harmonic(&self, k: usize) -> Option<[f32; 4]> {
        let Self::Efd { coefficients, .. } = self else {
            return None;
        };
        f32_row::<4>(coefficients, k)
    }

    /// Point `k` of a point job, m.
    pub fn point(&self, k: usize) -> Option<[f32; 2]> {
        let Self::Points { points, .. } = self else {
            return None;
        };
        f32_row::<2>(points, k)
    }

    /// Point `k` of a moves job: (x, y, feed of the move ending there), m and m/s.
    pub fn move_point(&self, k: usize) -> Option<[f32; 3]> {
        let Self::Moves { points, .. } = self else {
            return None;
        };
        f32_row::<3>(points, k)
    }

    /// Step `k` of a schedule job: (setpoint, duration s).
    pub fn step(&self, k: usize) -> Option<[f32; 2]> {
        let Self::Schedule { steps } = self else {
            return None;
        };
        f32_row::<2>(steps, k)
    }

    /// How the part is cut: the file's settings (EFD, points and moves), the
    /// machine's own for a version 1 file and the other kinds.
    pub fn settings(&self) -> CutSettings {
        match self {
            Self::Efd { settings, .. }
            | Self::Points { settings, .. }
            | Self::Moves { settings, .. } => *settings,
            _ => CutSettings::MACHINE,
        }
    }

    /// Reads and checks a job file.
    ///
    /// Errors: truncated, wrong magic, version or kind, bytes beyond the count, a CRC
    /// mismatch, a number not finite.
    pub fn read(bytes: &'a [u8]) -> Result<Self, JobFileError> {
        if bytes.len() < HEADER_BYTES + 4 {
            return Err(JobFileError::Truncated);
        }
        let (checked, crc) = bytes.split_at(bytes.len() - 4);
        let crc = u32::from_le_bytes(crc.try_into().map_err(|_| JobFileError::Truncated)?);
        let (header, body) = checked.split_at(HEADER_BYTES);
        if header.get(..4) != Some(&MAGIC[..]) {
            return Err(JobFileError::Magic);
        }
        let version = header.get(4).copied().unwrap_or(0);
        if !(VERSION_WITHOUT_SETTINGS..=JOB_FORMAT_VERSION).contains(&version) {
            return Err(JobFileError::Version(version));
        }
        let (block, body) = body
            .split_at_checked(settings_len(version))
            .ok_or(JobFileError::Truncated)?;
        let kind = header.get(5).copied().unwrap_or(u8::MAX);
        let count = header
            .get(8..12)
            .and_then(|b| b.try_into().ok())
            .map_or(0, u32::from_le_bytes);
        let expected = body_len(kind, count).ok_or(JobFileError::Kind(kind))?;
        let body_len = body.len() as u64;
        if body_len < expected {
            return Err(JobFileError::Truncated);
        }
        if body_len > expected {
            return Err(JobFileError::TrailingBytes);
        }
        if crc32(checked) != crc {
            return Err(JobFileError::Crc);
        }
        if header.get(6..8) != Some(&[0, 0][..]) {
            return Err(JobFileError::Reserved);
        }
        let settings = match CutSettings::read(block) {
            None => CutSettings::MACHINE,
            Some(_) if !matches!(kind, 0 | 1 | 5) => return Err(JobFileError::Settings),
            Some(Ok(settings)) => settings,
            Some(Err(BlockError::NotFinite)) => return Err(JobFileError::NotFinite),
            Some(Err(BlockError::Unknown)) => return Err(JobFileError::Settings),
        };
        let finite = |b: &[u8]| {
            b.chunks_exact(4).all(|w| {
                w.try_into()
                    .is_ok_and(|w| f32::from_le_bytes(w).is_finite())
            })
        };
        match kind {
            0 => {
                if !finite(body) {
                    return Err(JobFileError::NotFinite);
                }
                let (centre, coefficients) =
                    body.split_at_checked(8).ok_or(JobFileError::Truncated)?;
                Ok(Self::Efd {
                    centre_m: f32_row::<2>(centre, 0).unwrap_or([0.0; 2]),
                    coefficients,
                    settings,
                })
            }
            1 => {
                if !finite(body) {
                    return Err(JobFileError::NotFinite);
                }
                Ok(Self::Points {
                    points: body,
                    settings,
                })
            }
            2 => Ok(Self::Gcode { text: body }),
            3 => Ok(Self::Recording { bytes: body }),
            5 => {
                if !finite(body) {
                    return Err(JobFileError::NotFinite);
                }
                Ok(Self::Moves {
                    points: body,
                    settings,
                })
            }
            _ => {
                if !finite(body) {
                    return Err(JobFileError::NotFinite);
                }
                Ok(Self::Schedule { steps: body })
            }
        }
    }
}

/// Writes a job file of `kind` with `count` and the body `write_body` produces into
/// `out`, version 1, or version 2 with the cut settings `block`; returns the file's
/// length.
fn write(
    kind: u8,
    count: usize,
    block: Option<[u8; CUT_SETTINGS_BYTES]>,
    body_bytes: usize,
    out: &mut [u8],
    write_body: impl FnOnce(&mut [u8]),
) -> Result<usize, JobFileError> {
    let count = u32::try_from(count).map_err(|_| JobFileError::NoRoom)?;
    let version = match block {
        None => VERSION_WITHOUT_SETTINGS,
        Some(_) => JOB_FORMAT_VERSION,
    };
    let start = HEADER_BYTES + settings_len(version);
    let len = start + body_bytes + 4;
    let file = out.get_mut(..len).ok_or(JobFileError::NoRoom)?;
    let (checked, crc) = file.split_at_mut(len - 4);
    let (header, body) = checked.split_at_mut(start);
    let [c0, c1, c2, c3] = count.to_le_bytes();
    let [m0, m1, m2, m3] = MAGIC;
    let fields = [m0, m1, m2, m3, version, kind, 0, 0, c0, c1, c2, c3];
    let (fixed, settings) = header.split_at_mut(HEADER_BYTES);
    fixed.copy_from_slice(&fields);
    if let Some(block) = block {
        settings.copy_from_slice(&block);
    }
    write_body(body);
    crc.copy_from_slice(&crc32(checked).to_le_bytes());
    Ok(len)
}

/// The contour job file `file` (EFD, points or moves, either version) written again into
/// `out` with the cut settings `settings`: version 1 where they are the machine's
/// own, version 2 otherwise. Returns the new file's length.
///
/// Errors: `file`'s own ([`JobFile::read`]); [`JobFileError::Settings`] for another
/// kind or settings the block cannot say (a zero or non-finite speed, zero passes, a
/// laser value not finite); [`JobFileError::NoRoom`].
pub fn with_settings(
    file: &[u8],
    settings: &CutSettings,
    out: &mut [u8],
) -> Result<usize, JobFileError> {
    let read = JobFile::read(file)?;
    let kind = match read {
        JobFile::Efd { .. } => 0,
        JobFile::Points { .. } => 1,
        JobFile::Moves { .. } => 5,
        _ => return Err(JobFileError::Settings),
    };
    let block = match settings.block() {
        Some(_) if *settings == CutSettings::MACHINE => None,
        Some(block) => Some(block),
        None => return Err(JobFileError::Settings),
    };
    // Read above: a header, the settings its version has, a body and a CRC.
    let start = HEADER_BYTES + file.get(4).map_or(0, |&v| settings_len(v));
    let body = file
        .get(start..file.len().saturating_sub(4))
        .ok_or(JobFileError::Truncated)?;
    write(kind, read.count(), block, body.len(), out, |b| {
        b.copy_from_slice(body)
    })
}

/// A value as the file stores it: f32, rounded to nearest (a finite f64 beyond
/// f32::MAX rounds to infinity).
fn stored(v: &f64) -> f32 {
    *v as f32
}

/// Writes `values` as the body of a job of `kind`, each as the file stores it, after
/// checking every stored value the way [`JobFile::read`] does (finite in f32, not in
/// f64), so the writer never writes a file its reader refuses.
fn write_values<'v>(
    kind: u8,
    count: usize,
    values: impl Iterator<Item = &'v f64> + Clone,
    out: &mut [u8],
) -> Result<usize, JobFileError> {
    if !values.clone().all(|v| stored(v).is_finite()) {
        return Err(JobFileError::NotFinite);
    }
    let body_bytes = 4 * values.clone().count();
    write(kind, count, None, body_bytes, out, |body| {
        for (chunk, v) in body.chunks_exact_mut(4).zip(values) {
            chunk.copy_from_slice(&stored(v).to_le_bytes());
        }
    })
}

/// Writes an EFD job (centre and harmonics, m, stored as f32).
///
/// Errors: [`JobFileError::NotFinite`] for a value that is not finite once stored (NaN,
/// infinite, or beyond f32's range); [`JobFileError::NoRoom`].
pub fn write_efd(
    centre_m: [f64; 2],
    coefficients: &[[f64; 4]],
    out: &mut [u8],
) -> Result<usize, JobFileError> {
    let values = centre_m.iter().chain(coefficients.iter().flatten());
    write_values(0, coefficients.len(), values, out)
}

/// Writes a point job ((x, y) per point, m, stored as f32).
///
/// Errors: as [`write_efd`].
pub fn write_points(points: &[[f64; 2]], out: &mut [u8]) -> Result<usize, JobFileError> {
    write_values(1, points.len(), points.iter().flatten(), out)
}

/// Writes a moves job ((x, y, feed) per point, m and m/s, stored as f32; the first
/// point's feed is not used: write 0).
///
/// Errors: as [`write_efd`].
pub fn write_moves(points: &[[f64; 3]], out: &mut [u8]) -> Result<usize, JobFileError> {
    write_values(5, points.len(), points.iter().flatten(), out)
}

/// Writes a G-code job.
pub fn write_gcode(text: &[u8], out: &mut [u8]) -> Result<usize, JobFileError> {
    write(2, text.len(), None, text.len(), out, |body| {
        body.copy_from_slice(text)
    })
}

/// Writes a recording job (a recorded master session's bytes, as they are: the
/// recording's own reader checks them).
pub fn write_recording(bytes: &[u8], out: &mut [u8]) -> Result<usize, JobFileError> {
    write(3, bytes.len(), None, bytes.len(), out, |body| {
        body.copy_from_slice(bytes)
    })
}

/// Writes a schedule job ((setpoint, duration s) per step, stored as f32).
///
/// Errors: as [`write_efd`].
pub fn write_schedule(steps: &[[f64; 2]], out: &mut [u8]) -> Result<usize, JobFileError> {
    write_values(4, steps.len(), steps.iter().flatten(), out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file's length from its header alone is the length written, whatever follows
    /// it; a header cut short, another magic or an unknown kind has none.
    #[test]
    fn file_len_reads_the_length_from_the_header() {
        let mut buf = [0u8; 512];
        let efd = write_efd([0.0, 0.0], &[[1e-3, 0.0, 0.0, 1e-3]; 3], &mut buf).unwrap();
        let mut two = std::vec::Vec::from(&buf[..efd]);
        let points = write_points(&[[0.0, 0.0], [1e-3, 0.0], [1e-3, 1e-3]], &mut buf).unwrap();
        two.extend_from_slice(&buf[..points]);
        assert_eq!(file_len(&two), Some(efd));
        assert_eq!(file_len(&two[efd..]), Some(points));
        assert_eq!((efd, points), (12 + 8 + 48 + 4, 12 + 24 + 4));
        assert_eq!(file_len(&two[..HEADER_BYTES - 1]), None);
        let mut other = two.clone();
        other[0] = b'X';
        assert_eq!(file_len(&other), None);
        other = two.clone();
        other[5] = 9;
        assert_eq!(file_len(&other), None);
    }

    #[test]
    fn each_kind_round_trips_and_damage_is_refused_by_kind() {
        let mut buf = [0u8; 512];
        let coefficients = [[1e-3, 2e-3, -3e-3, 4e-3], [0.5e-3, 0.0, 0.0, -0.25e-3]];
        let n = write_efd([1e-3, -2e-3], &coefficients, &mut buf).unwrap();
        assert_eq!(n, 12 + 8 + 32 + 4);
        let file = JobFile::read(&buf[..n]).unwrap();
        assert_eq!(file.kind(), JobKind::Efd);
        assert_eq!(file.count(), 2);
        assert_eq!(file.harmonic(1), Some([0.5e-3, 0.0, 0.0, -0.25e-3]));
        assert_eq!(file.harmonic(2), None);
        let JobFile::Efd { centre_m, .. } = file else {
            panic!()
        };
        assert_eq!(centre_m, [1e-3, -2e-3]);
        // Every single-byte change is refused (magic, version, kind, count, body, CRC).
        for i in 0..n {
            let mut bad = buf;
            bad[i] ^= 0x10;
            assert!(JobFile::read(&bad[..n]).is_err(), "byte {i}");
        }
        for version in [0, JOB_FORMAT_VERSION + 1] {
            let mut bad = buf;
            bad[4] = version;
            assert_eq!(
                JobFile::read(&bad[..n]),
                Err(JobFileError::Version(version))
            );
        }
        assert_eq!(JobFile::read(&buf[..n - 1]), Err(JobFileError::Truncated));
        assert_eq!(JobFile::read(&buf[..5]), Err(JobFileError::Truncated));

        let n = write_points(&[[0.0, 1e-3], [2e-3, 3e-3]], &mut buf).unwrap();
        let file = JobFile::read(&buf[..n]).unwrap();
        assert_eq!((file.kind(), file.count()), (JobKind::Points, 2));
        assert_eq!(file.point(1), Some([2e-3, 3e-3]));

        let n = write_gcode(b"G1 X1 F100\n", &mut buf).unwrap();
        assert_eq!(
            JobFile::read(&buf[..n]).unwrap(),
            JobFile::Gcode {
                text: b"G1 X1 F100\n"
            }
        );
        let n = write_recording(b"KRFR\x01\x00", &mut buf).unwrap();
        let file = JobFile::read(&buf[..n]).unwrap();
        assert_eq!((file.kind(), file.count()), (JobKind::Recording, 6));
        assert_eq!(
            file,
            JobFile::Recording {
                bytes: b"KRFR\x01\x00"
            }
        );
        let n = write_schedule(&[[1.0, 6.0], [2.0, 4.5]], &mut buf).unwrap();
        let file = JobFile::read(&buf[..n]).unwrap();
        assert_eq!((file.kind(), file.count()), (JobKind::Schedule, 2));
        assert_eq!(file.step(1), Some([2.0, 4.5]));
        assert_eq!((file.step(2), file.point(0)), (None, None));
        let mut nan = buf;
        nan[HEADER_BYTES..HEADER_BYTES + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        let crc = crc32(&nan[..n - 4]);
        nan[n - 4..n].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(JobFile::read(&nan[..n]), Err(JobFileError::NotFinite));
        let moves = [[0.0, 1e-3, 0.0], [2e-3, 3e-3, 5e-3], [2e-3, 0.0, 8e-3]];
        let m = write_moves(&moves, &mut buf).unwrap();
        assert_eq!(m, 12 + 36 + 4);
        let file = JobFile::read(&buf[..m]).unwrap();
        assert_eq!((file.kind(), file.count()), (JobKind::Moves, 3));
        assert_eq!(file.move_point(1), Some([2e-3, 3e-3, 5e-3]));
        assert_eq!((file.move_point(3), file.point(0)), (None, None));
        // A kind past the last is still refused by number.
        let mut bad = buf;
        bad[5] = 6;
        assert_eq!(JobFile::read(&bad[..m]), Err(JobFileError::Kind(6)));
        assert_eq!(
            write_points(&[[f64::NAN, 0.0]], &mut buf),
            Err(JobFileError::NotFinite)
        );
        assert_eq!(
            write_gcode(&[b'x'; 600], &mut buf),
            Err(JobFileError::NoRoom)
        );
    }

    /// A contour written again with cut settings reads back with them and the same
    /// body, its length from the header alone; with the machine's settings it is
    /// version 1 again, byte for byte; every byte of it is guarded; settings on
    /// another kind, or that the block cannot say, are refused.
    #[test]
    fn cut_settings_ride_with_contours_only() {
        let mut v1 = [0u8; 256];
        let n = write_efd([1e-3, 0.0], &[[1e-3, 0.0, 0.0, 1e-3]; 2], &mut v1).unwrap();
        let settings = CutSettings {
            speed_m_s: Some(4e-3),
            laser: Some(CutLaser::PowerW(5.0)),
            passes: Some(2),
            ..CutSettings::MACHINE
        };
        let mut v2 = [0u8; 256];
        let m = with_settings(&v1[..n], &settings, &mut v2).unwrap();
        assert_eq!((m, v2[4]), (n + 12, 2));
        assert_eq!(file_len(&v2), Some(m));
        let file = JobFile::read(&v2[..m]).unwrap();
        assert_eq!(file.settings(), settings);
        let first = JobFile::read(&v1[..n]).unwrap();
        assert_eq!(file.count(), first.count());
        assert_eq!(file.harmonic(1), first.harmonic(1));
        assert_eq!(first.settings(), CutSettings::MACHINE);
        for i in 0..m {
            let mut bad = v2;
            bad[i] ^= 0x10;
            assert!(JobFile::read(&bad[..m]).is_err(), "byte {i}");
        }
        let mut again = [0u8; 256];
        let k = with_settings(&v2[..m], &CutSettings::MACHINE, &mut again).unwrap();
        assert_eq!(again[..k], v1[..n]);
        let n = write_points(&[[0.0, 0.0], [1e-3, 0.0], [1e-3, 1e-3]], &mut v1).unwrap();
        let m = with_settings(&v1[..n], &settings, &mut v2).unwrap();
        let file = JobFile::read(&v2[..m]).unwrap();
        assert_eq!((file.kind(), file.settings()), (JobKind::Points, settings));
        assert_eq!(file.point(2), Some([1e-3, 1e-3]));
        let n = write_moves(&[[0.0, 0.0, 0.0], [1e-3, 0.0, 4e-3]], &mut v1).unwrap();
        let m = with_settings(&v1[..n], &settings, &mut v2).unwrap();
        let file = JobFile::read(&v2[..m]).unwrap();
        assert_eq!((file.kind(), file.settings()), (JobKind::Moves, settings));
        assert_eq!(file.move_point(1), Some([1e-3, 0.0, 4e-3]));
        // G-code takes none; a zero speed is not a setting; no room is said.
        let n = write_gcode(b"G1 X1 F100\n", &mut v1).unwrap();
        let refused = with_settings(&v1[..n], &settings, &mut v2);
        assert_eq!(refused, Err(JobFileError::Settings));
        let zero = CutSettings {
            speed_m_s: Some(0.0),
            ..settings
        };
        let n = write_points(&[[0.0, 0.0], [1e-3, 0.0], [1e-3, 1e-3]], &mut v1).unwrap();
        assert_eq!(
            with_settings(&v1[..n], &zero, &mut v2),
            Err(JobFileError::Settings)
        );
        let short = with_settings(&v1[..n], &settings, &mut v2[..n]);
        assert_eq!(short, Err(JobFileError::NoRoom));
        // A version 2 G-code file (made by hand) is refused for its settings.
        let mut gcode = [0u8; 64];
        let n = write_gcode(b"G0 X1\n", &mut gcode[12..]).unwrap();
        gcode.copy_within(12..24, 0);
        gcode[4] = 2;
        gcode[12..24].fill(0);
        let crc = crc32(&gcode[..n + 8]);
        gcode[n + 8..n + 12].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(file_len(&gcode), Some(n + 12));
        assert_eq!(JobFile::read(&gcode[..n + 12]), Err(JobFileError::Settings));
    }

    /// An index whose byte offset passes `usize` is past the end, not a wrapped
    /// offset that reads the first harmonic or point again.
    #[test]
    fn an_index_past_the_address_space_reads_nothing() {
        let mut buf = [0u8; 512];
        let n = write_efd([0.0; 2], &[[1e-3, 2e-3, 3e-3, 4e-3]], &mut buf).unwrap();
        let file = JobFile::read(&buf[..n]).unwrap();
        assert_eq!(file.harmonic(0), Some([1e-3, 2e-3, 3e-3, 4e-3]));
        // 16 bytes a harmonic: 2^(bits − 4) · 16 wraps to 0.
        assert_eq!(file.harmonic(1 << (usize::BITS - 4)), None);
        assert_eq!(file.harmonic(usize::MAX), None);
        let n = write_points(&[[1e-3, 2e-3]], &mut buf).unwrap();
        let file = JobFile::read(&buf[..n]).unwrap();
        assert_eq!(file.point(0), Some([1e-3, 2e-3]));
        assert_eq!(file.point(1 << (usize::BITS - 3)), None);
        assert_eq!(file.point(usize::MAX), None);
    }

    /// Values at the boundary of what the file stores (f32): every value the writer
    /// accepts, the reader accepts and returns as its f32 rounding; the rest (beyond
    /// f32::MAX once rounded, NaN, infinities) the writer refuses. 1e39 and
    /// f32::MAX · (1 + 2^-24) are finite in f64 and round to infinity in f32.
    #[test]
    fn the_writer_writes_only_what_the_reader_reads() {
        let max = f64::from(f32::MAX);
        // The f32 rounding boundary: halfway from f32::MAX (2^128 − 2^104) to 2^128,
        // which rounds to even, that is to infinity; just below it, to f32::MAX.
        let halfway = f64::powi(2.0, 128) - f64::powi(2.0, 103);
        let values = [
            0.0,
            -0.0,
            1e-3,
            f64::from(f32::MIN_POSITIVE),
            1e-46,
            f64::MIN_POSITIVE,
            max,
            -max,
            halfway - f64::powi(2.0, 75),
            halfway,
            -halfway,
            1e39,
            -1e39,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        let mut buf = [0u8; 64];
        for (i, &v) in values.iter().enumerate() {
            let stored = v as f32;
            let others = [1e-3, -2e-3, 3e-3];
            let mut point = [[others[0], others[1]], [others[2], 0.0]];
            point[i % 2][i % 2] = v;
            let written = [
                write_points(&point, &mut buf).map(|n| {
                    let file = JobFile::read(&buf[..n]);
                    file.map(|f| f.point(i % 2).map(|p| p[i % 2]))
                }),
                write_efd([v, 0.0], &[[1e-3, 0.0, 0.0, 1e-3]], &mut buf).map(|n| {
                    let file = JobFile::read(&buf[..n]);
                    file.map(|f| match f {
                        JobFile::Efd { centre_m, .. } => Some(centre_m[0]),
                        _ => None,
                    })
                }),
                write_efd([0.0, 0.0], &[[1e-3, 0.0, v, 1e-3]], &mut buf).map(|n| {
                    let file = JobFile::read(&buf[..n]);
                    file.map(|f| f.harmonic(0).map(|h| h[2]))
                }),
            ];
            for result in written {
                if stored.is_finite() {
                    let read = result.expect("written").expect("read").expect("value");
                    assert_eq!(read.to_bits(), stored.to_bits(), "{v}");
                } else {
                    assert_eq!(result, Err(JobFileError::NotFinite), "{v}");
                }
            }
        }
    }
}
