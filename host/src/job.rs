//! The job file: what the host hands the firmware to run, in one small binary
//! container (format version 1). Everything is little-endian.
//!
//! | offset | size | field                                                          |
//! |-------:|-----:|----------------------------------------------------------------|
//! | 0      | 4    | magic `KJOB` (`4B 4A 4F 42`)                                    |
//! | 4      | 2    | `format_version`, u16 = [`FORMAT_VERSION`]                      |
//! | 6      | 1    | kind, u8: 1 = EFD (closed), 2 = path (open), 3 = G-code        |
//! | 7      | 1    | reserved, 0                                                    |
//! | 8      | 4    | count, u32: harmonics n / points m / text bytes               |
//! | 12     | 4    | payload length L in bytes, u32                                 |
//! | 16     | L    | payload (below)                                                |
//! | 16 + L | 4    | CRC-32 (ISO-HDLC, the zlib/PNG CRC) of bytes 0 .. 16 + L, u32   |
//!
//! Payloads (lengths in metres, f32, the firmware's scalar):
//! - EFD (kind 1, T 3.2.2): the centre (a0, c0), then (ak, bk, ck, dk) for
//!   k = 1..=n: L = 8 + 16 n. θ = 0 is the contour's start point. The firmware builds the
//!   curve with `kerf::trajectory::efd::Efd::from_coefficients`; n ≤ 30
//!   (`CONTOUR_HARMONICS`).
//! - Path (kind 2, T 3.1.5): m points (x, y) in cutting order: L = 8 m, for
//!   `kerf::trajectory::open_path::OpenPath::from_points`; m ≤ 32 (`OPEN_PATH_POINTS`).
//! - G-code (kind 3, A §4): the program's text as read, L = m bytes, for
//!   `kerf::app::arrow::job::ArrowJob::from_gcode`.
//!
//! A reader checks, in this order: length, magic, version, the declared payload
//! length against the file's, the CRC, the reserved byte, the kind, the count against
//! the payload length, and that every number is finite. A new layout gets a new
//! version; readers refuse versions they do not know.

use crc::{Crc, CRC_32_ISO_HDLC};
use thiserror::Error;

/// The first four bytes of every job file.
pub const MAGIC: [u8; 4] = *b"KJOB";
/// The layout this crate writes and reads.
pub const FORMAT_VERSION: u16 = 1;
/// Bytes before the payload.
pub const HEADER_LEN: usize = 16;
/// Bytes of the trailing CRC.
pub const CRC_LEN: usize = 4;

const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// What a job file carries.
#[derive(Clone, Debug, PartialEq)]
pub enum Job {
    /// A closed contour as elliptic Fourier descriptors (T 3.2.2), m.
    Efd {
        /// (a0, c0), m.
        centre_m: [f32; 2],
        /// (ak, bk, ck, dk) for k = 1..=n, m.
        coefficients: Vec<[f32; 4]>,
    },
    /// An open contour as points in cutting order (T 3.1.5), m.
    Path {
        /// (x, y), m.
        points_m: Vec<[f32; 2]>,
    },
    /// A G-code program's text (A §4).
    Gcode {
        /// The bytes of the file.
        text: Vec<u8>,
    },
}

/// The kind byte of each [`Job`] variant.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum JobKind {
    /// [`Job::Efd`].
    Efd = 1,
    /// [`Job::Path`].
    Path = 2,
    /// [`Job::Gcode`].
    Gcode = 3,
}

/// Why bytes are not a job file this reader accepts.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Error)]
pub enum JobFileError {
    /// Shorter than a header and a CRC.
    #[error("too short for a job file ({len} bytes)")]
    TooShort {
        /// The length given.
        len: usize,
    },
    /// The first four bytes are not [`MAGIC`].
    #[error("not a kerf job file (bad magic)")]
    BadMagic,
    /// A `format_version` this reader does not know.
    #[error("job file format version {0} is not supported (this reader knows {FORMAT_VERSION})")]
    UnsupportedVersion(u16),
    /// The declared payload length disagrees with the file's length.
    #[error("payload length {declared} does not match the file ({actual} bytes of payload)")]
    Length {
        /// From the header.
        declared: u32,
        /// From the file's length.
        actual: usize,
    },
    /// The stored CRC differs from the CRC of the bytes: the file is damaged.
    #[error("CRC mismatch: stored {stored:#010x}, computed {computed:#010x}")]
    Crc {
        /// The value in the file.
        stored: u32,
        /// The CRC of the header and payload.
        computed: u32,
    },
    /// The reserved byte is not zero.
    #[error("reserved byte is {0}, not 0")]
    Reserved(u8),
    /// An unknown kind byte.
    #[error("unknown job kind {0}")]
    UnknownKind(u8),
    /// The count does not fit the payload length of its kind.
    #[error("count {count} does not fit a payload of {payload_len} bytes")]
    Count {
        /// From the header.
        count: u32,
        /// From the header.
        payload_len: u32,
    },
    /// A number of the payload is NaN or infinite (index of the f32).
    #[error("value {0} of the payload is not finite")]
    NotFinite(usize),
    /// The job is too large for the format (more than u32::MAX bytes or items).
    #[error("job too large for the format")]
    TooLarge,
}

impl Job {
    /// The kind byte of this job.
    pub fn kind(&self) -> JobKind {
        match self {
            Job::Efd { .. } => JobKind::Efd,
            Job::Path { .. } => JobKind::Path,
            Job::Gcode { .. } => JobKind::Gcode,
        }
    }

    /// The complete file: header, payload, CRC. Errors: [`JobFileError::TooLarge`]
    /// (a count or payload beyond u32).
    pub fn to_bytes(&self) -> Result<Vec<u8>, JobFileError> {
        let mut payload = Vec::new();
        let count = match self {
            Job::Efd {
                centre_m,
                coefficients,
            } => {
                centre_m
                    .iter()
                    .chain(coefficients.iter().flatten())
                    .for_each(|v| payload.extend_from_slice(&v.to_le_bytes()));
                coefficients.len()
            }
            Job::Path { points_m } => {
                points_m
                    .iter()
                    .flatten()
                    .for_each(|v| payload.extend_from_slice(&v.to_le_bytes()));
                points_m.len()
            }
            Job::Gcode { text } => {
                payload.extend_from_slice(text);
                text.len()
            }
        };
        let count = u32::try_from(count).map_err(|_| JobFileError::TooLarge)?;
        let payload_len = u32::try_from(payload.len()).map_err(|_| JobFileError::TooLarge)?;
        let mut out = Vec::with_capacity(HEADER_LEN + payload.len() + CRC_LEN);
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        out.push(self.kind() as u8);
        out.push(0);
        out.extend_from_slice(&count.to_le_bytes());
        out.extend_from_slice(&payload_len.to_le_bytes());
        out.extend_from_slice(&payload);
        let crc = CRC32.checksum(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        Ok(out)
    }

    /// Reads a job file (module docs for the order of the checks).
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, JobFileError> {
        let too_short = JobFileError::TooShort { len: bytes.len() };
        if bytes.len() < HEADER_LEN + CRC_LEN {
            return Err(too_short);
        }
        let (header, rest) = bytes.split_at(HEADER_LEN);
        if header[0..4] != MAGIC {
            return Err(JobFileError::BadMagic);
        }
        let version = u16::from_le_bytes([header[4], header[5]]);
        if version != FORMAT_VERSION {
            return Err(JobFileError::UnsupportedVersion(version));
        }
        let (kind, reserved) = (header[6], header[7]);
        let count = u32_at(header, 8);
        let payload_len = u32_at(header, 12);
        let actual = rest.len() - CRC_LEN;
        if usize::try_from(payload_len).ok() != Some(actual) {
            return Err(JobFileError::Length {
                declared: payload_len,
                actual,
            });
        }
        let (payload, crc) = rest.split_at(actual);
        let stored = u32_at(crc, 0);
        let computed = CRC32.checksum(&bytes[..HEADER_LEN + actual]);
        if stored != computed {
            return Err(JobFileError::Crc { stored, computed });
        }
        if reserved != 0 {
            return Err(JobFileError::Reserved(reserved));
        }
        let n = count as usize;
        let bad_count = JobFileError::Count { count, payload_len };
        let floats = || {
            payload
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        };
        let check_finite = || match floats().position(|v| !v.is_finite()) {
            Some(i) => Err(JobFileError::NotFinite(i)),
            None => Ok(()),
        };
        match kind {
            1 => {
                if n.checked_mul(16).and_then(|b| b.checked_add(8)) != Some(actual) {
                    return Err(bad_count);
                }
                check_finite()?;
                let v: Vec<f32> = floats().collect();
                let coefficients = v[2..]
                    .chunks_exact(4)
                    .map(|c| [c[0], c[1], c[2], c[3]])
                    .collect();
                Ok(Job::Efd {
                    centre_m: [v[0], v[1]],
                    coefficients,
                })
            }
            2 => {
                if n.checked_mul(8) != Some(actual) {
                    return Err(bad_count);
                }
                check_finite()?;
                let v: Vec<f32> = floats().collect();
                Ok(Job::Path {
                    points_m: v.chunks_exact(2).map(|c| [c[0], c[1]]).collect(),
                })
            }
            3 => {
                if n != actual {
                    return Err(bad_count);
                }
                Ok(Job::Gcode {
                    text: payload.to_vec(),
                })
            }
            other => Err(JobFileError::UnknownKind(other)),
        }
    }
}

/// The u32 at `at` (the caller has checked the length).
fn u32_at(bytes: &[u8], at: usize) -> u32 {
    let mut b = [0; 4];
    b.copy_from_slice(&bytes[at..at + 4]);
    u32::from_le_bytes(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_header_is_laid_out_as_documented() {
        let job = Job::Path {
            points_m: vec![[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]],
        };
        let b = job.to_bytes().unwrap();
        assert_eq!(&b[0..4], b"KJOB");
        assert_eq!(&b[4..8], &[1, 0, 2, 0]);
        assert_eq!(&b[8..12], &[3, 0, 0, 0]);
        assert_eq!(&b[12..16], &[24, 0, 0, 0]);
        assert_eq!(&b[16..20], &1.0f32.to_le_bytes());
        assert_eq!(b.len(), 16 + 24 + 4);
        // The CRC-32 check value of the catalogue ("123456789" → 0xCBF43926).
        assert_eq!(CRC32.checksum(b"123456789"), 0xCBF4_3926);
    }
}
