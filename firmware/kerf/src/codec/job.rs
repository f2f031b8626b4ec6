//! The job file: what the host tool plans (`kerf plan`, `kerf gcode`) and uploads, and
//! what a machine loads (issue 16). One format on both sides, written and read here.
//!
//! Version 1, all numbers little-endian:
//!
//! | offset | bytes | field |
//! |---|---|---|
//! | 0 | 4 | magic `KRFJ` |
//! | 4 | 1 | format version (= [`JOB_FORMAT_VERSION`]) |
//! | 5 | 1 | kind: 0 EFD, 1 points, 2 G-code ([`JobKind`]) |
//! | 6 | 2 | reserved, 0 |
//! | 8 | 4 | count: harmonics (EFD), points (points), text bytes (G-code) |
//! | 12 | … | body |
//! | end − 4 | 4 | CRC-32 (ISO-HDLC) of every byte before it |
//!
//! A reader checks, in this order: length, magic, version, kind, the body's length
//! against the count, the CRC, the reserved bytes, and that every number is finite; a
//! new layout gets a new version, and readers refuse versions they do not know.
//!
//! Bodies: EFD, the centre (x, y) then (a_k, b_k, c_k, d_k) per harmonic, f32, m;
//! points, (x, y) per point, f32, m; G-code, the text (ASCII).

pub use super::link::JobKind;

/// Version of the job file.
pub const JOB_FORMAT_VERSION: u8 = 1;

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
    },
    /// An open contour's points (x, y), read with [`JobFile::point`].
    Points {
        /// The body.
        points: &'a [u8],
    },
    /// G-code text.
    Gcode {
        /// The text.
        text: &'a [u8],
    },
}

fn f32_at(bytes: &[u8], index: usize) -> Option<f32> {
    let b = bytes.get(4 * index..4 * index + 4)?;
    Some(f32::from_le_bytes(b.try_into().ok()?))
}

impl<'a> JobFile<'a> {
    /// The kind.
    pub fn kind(&self) -> JobKind {
        match self {
            Self::Efd { .. } => JobKind::Efd,
            Self::Points { .. } => JobKind::Points,
            Self::Gcode { .. } => JobKind::Gcode,
        }
    }

    /// Harmonics (EFD), points (points) or text bytes (G-code).
    pub fn count(&self) -> usize {
        match self {
            Self::Efd { coefficients, .. } => coefficients.len() / 16,
            Self::Points { points } => points.len() / 8,
            Self::Gcode { text } => text.len(),
        }
    }

    /// Harmonic `k` (0-based) of an EFD job, m.
    pub fn harmonic(&self, k: usize) -> Option<[f32; 4]> {
        let Self::Efd { coefficients, .. } = self else {
            return None;
        };
        Some([
            f32_at(coefficients, 4 * k)?,
            f32_at(coefficients, 4 * k + 1)?,
            f32_at(coefficients, 4 * k + 2)?,
            f32_at(coefficients, 4 * k + 3)?,
        ])
    }

    /// Point `k` of a point job, m.
    pub fn point(&self, k: usize) -> Option<[f32; 2]> {
        let Self::Points { points } = self else {
            return None;
        };
        Some([f32_at(points, 2 * k)?, f32_at(points, 2 * k + 1)?])
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
        if version != JOB_FORMAT_VERSION {
            return Err(JobFileError::Version(version));
        }
        let kind = header.get(5).copied().unwrap_or(u8::MAX);
        let count = header
            .get(8..12)
            .and_then(|b| b.try_into().ok())
            .map_or(0, u32::from_le_bytes);
        let count = u64::from(count);
        let expected = match kind {
            0 => 8 + 16 * count,
            1 => 8 * count,
            2 => count,
            k => return Err(JobFileError::Kind(k)),
        };
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
        let finite = |b: &[u8]| (0..b.len() / 4).all(|i| f32_at(b, i).is_some_and(f32::is_finite));
        match kind {
            0 => {
                if !finite(body) {
                    return Err(JobFileError::NotFinite);
                }
                let (centre, coefficients) = body.split_at(8);
                Ok(Self::Efd {
                    centre_m: [
                        f32_at(centre, 0).unwrap_or(0.0),
                        f32_at(centre, 1).unwrap_or(0.0),
                    ],
                    coefficients,
                })
            }
            1 => {
                if !finite(body) {
                    return Err(JobFileError::NotFinite);
                }
                Ok(Self::Points { points: body })
            }
            _ => Ok(Self::Gcode { text: body }),
        }
    }
}

/// Writes a job file of `kind` with `count` and the body `write_body` produces into
/// `out`; returns the file's length.
fn write(
    kind: u8,
    count: usize,
    body_bytes: usize,
    out: &mut [u8],
    write_body: impl FnOnce(&mut [u8]),
) -> Result<usize, JobFileError> {
    let count = u32::try_from(count).map_err(|_| JobFileError::NoRoom)?;
    let len = HEADER_BYTES + body_bytes + 4;
    let file = out.get_mut(..len).ok_or(JobFileError::NoRoom)?;
    let (checked, crc) = file.split_at_mut(len - 4);
    let (header, body) = checked.split_at_mut(HEADER_BYTES);
    let [c0, c1, c2, c3] = count.to_le_bytes();
    let [m0, m1, m2, m3] = MAGIC;
    let fields = [
        m0,
        m1,
        m2,
        m3,
        JOB_FORMAT_VERSION,
        kind,
        0,
        0,
        c0,
        c1,
        c2,
        c3,
    ];
    header.copy_from_slice(&fields);
    write_body(body);
    crc.copy_from_slice(&crc32(checked).to_le_bytes());
    Ok(len)
}

/// Writes an EFD job (centre and harmonics, m, stored as f32).
pub fn write_efd(
    centre_m: [f64; 2],
    coefficients: &[[f64; 4]],
    out: &mut [u8],
) -> Result<usize, JobFileError> {
    let values = centre_m.iter().chain(coefficients.iter().flatten());
    if !values.clone().all(|v| v.is_finite()) {
        return Err(JobFileError::NotFinite);
    }
    write(
        0,
        coefficients.len(),
        8 + 16 * coefficients.len(),
        out,
        |body| {
            for (chunk, v) in body.chunks_exact_mut(4).zip(values) {
                chunk.copy_from_slice(&(*v as f32).to_le_bytes());
            }
        },
    )
}

/// Writes a point job ((x, y) per point, m, stored as f32).
pub fn write_points(points: &[[f64; 2]], out: &mut [u8]) -> Result<usize, JobFileError> {
    let values = points.iter().flatten();
    if !values.clone().all(|v| v.is_finite()) {
        return Err(JobFileError::NotFinite);
    }
    write(1, points.len(), 8 * points.len(), out, |body| {
        for (chunk, v) in body.chunks_exact_mut(4).zip(values) {
            chunk.copy_from_slice(&(*v as f32).to_le_bytes());
        }
    })
}

/// Writes a G-code job.
pub fn write_gcode(text: &[u8], out: &mut [u8]) -> Result<usize, JobFileError> {
    write(2, text.len(), text.len(), out, |body| {
        body.copy_from_slice(text)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let mut bad = buf;
        bad[4] = 2;
        assert_eq!(JobFile::read(&bad[..n]), Err(JobFileError::Version(2)));
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
        assert_eq!(
            write_points(&[[f64::NAN, 0.0]], &mut buf),
            Err(JobFileError::NotFinite)
        );
        assert_eq!(
            write_gcode(&[b'x'; 600], &mut buf),
            Err(JobFileError::NoRoom)
        );
    }
}
