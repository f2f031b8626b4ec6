//! The job file on the host: the firmware's own format and code
//! ([`kerf::codec::job`]: magic `KRFJ`, format version, kind, count, body, CRC-32;
//! documented there and in `host/README.md`), held here as an owned value.
//!
//! Bodies (lengths in metres, f32, the firmware's scalar):
//! - EFD (T 3.2.2): the centre (a0, c0), then (ak, bk, ck, dk) for k = 1..=n. θ = 0
//!   is the contour's start point. The firmware builds the curve with
//!   `kerf::trajectory::efd::Efd::from_coefficients`; n ≤ 30 (`CONTOUR_HARMONICS`).
//! - Path (T 3.1.5): m points (x, y) in cutting order, for
//!   `kerf::trajectory::open_path::OpenPath::from_points`; m ≤ 32 (`OPEN_PATH_POINTS`).
//! - G-code (A §4): the program's text as read, for
//!   `kerf::machines::arrow::job::ArrowJob::from_gcode`.
//! - Recording (T ch. 5): a recorded master session (`KRFR`) as it is, for
//!   `kerf::machines::delta_slave::remote::recording::Recording::parse`.
//! - Schedule: steps of (setpoint, duration s), the setpoint in the machine's own unit
//!   (the autofocus stage's zoom schedule, `kerf::machines::autofocus::product`).
//! - Moves: m points (x, y, feed m/s) of straight moves with sharp corners, the feed
//!   that of the move ending at the point, for the laser delta's look-ahead planner;
//!   m ≤ 32 (`MOVE_POINTS`).
//!
//! A contour part (EFD, path, moves) may carry its cut settings (speed, laser, passes:
//! [`CutSettings`]) between the header and the body; [`Job`] holds the geometry, and
//! [`with_settings`] gives a file's parts their settings.

use kerf::codec::cut_settings::CUT_SETTINGS_BYTES;
use kerf::codec::job::{
    file_len, write_efd, write_gcode, write_moves, write_points, write_recording, write_schedule,
    JobFile,
};
pub use kerf::codec::job::{
    Continuity, CutLaser, CutSettings, JobFileError, HEADER_BYTES, JOB_FORMAT_VERSION,
};
pub use kerf::codec::link::JobKind;

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
    /// A recorded master session (`KRFR`) for a remote slave to play.
    Recording {
        /// The recording's bytes.
        bytes: Vec<u8>,
    },
    /// A schedule: setpoints, each held for a duration.
    Schedule {
        /// (setpoint, duration s) per step.
        steps: Vec<[f32; 2]>,
    },
    /// Straight moves with sharp corners.
    Moves {
        /// (x, y, feed of the move ending there) per point, m and m/s.
        points: Vec<[f32; 3]>,
    },
}

impl Job {
    /// Its kind.
    pub fn kind(&self) -> JobKind {
        match self {
            Job::Efd { .. } => JobKind::Efd,
            Job::Path { .. } => JobKind::Points,
            Job::Gcode { .. } => JobKind::Gcode,
            Job::Recording { .. } => JobKind::Recording,
            Job::Schedule { .. } => JobKind::Schedule,
            Job::Moves { .. } => JobKind::Moves,
        }
    }

    /// The complete file, written by the firmware's writer. Errors: a number not
    /// finite, a count beyond u32.
    pub fn to_bytes(&self) -> Result<Vec<u8>, JobFileError> {
        let body = match self {
            Job::Efd { coefficients, .. } => 8 + 16 * coefficients.len(),
            Job::Path { points_m } => 8 * points_m.len(),
            Job::Gcode { text } => text.len(),
            Job::Recording { bytes } => bytes.len(),
            Job::Schedule { steps } => 8 * steps.len(),
            Job::Moves { points } => 12 * points.len(),
        };
        let mut out = vec![0u8; HEADER_BYTES + body + 4];
        let n = match self {
            Job::Efd {
                centre_m,
                coefficients,
            } => {
                let wide: Vec<[f64; 4]> = coefficients.iter().map(|c| c.map(f64::from)).collect();
                write_efd(centre_m.map(f64::from), &wide, &mut out)?
            }
            Job::Path { points_m } => {
                let wide: Vec<[f64; 2]> = points_m.iter().map(|p| p.map(f64::from)).collect();
                write_points(&wide, &mut out)?
            }
            Job::Gcode { text } => write_gcode(text, &mut out)?,
            Job::Recording { bytes } => write_recording(bytes, &mut out)?,
            Job::Schedule { steps } => {
                let wide: Vec<[f64; 2]> = steps.iter().map(|p| p.map(f64::from)).collect();
                write_schedule(&wide, &mut out)?
            }
            Job::Moves { points } => {
                let wide: Vec<[f64; 3]> = points.iter().map(|p| p.map(f64::from)).collect();
                write_moves(&wide, &mut out)?
            }
        };
        out.truncate(n);
        Ok(out)
    }

    /// Reads a job file with the firmware's reader.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, JobFileError> {
        let file = JobFile::read(bytes)?;
        let n = file.count();
        Ok(match file {
            JobFile::Efd { centre_m, .. } => Job::Efd {
                centre_m,
                coefficients: (0..n).filter_map(|k| file.harmonic(k)).collect(),
            },
            JobFile::Points { .. } => Job::Path {
                points_m: (0..n).filter_map(|k| file.point(k)).collect(),
            },
            JobFile::Gcode { text } => Job::Gcode {
                text: text.to_vec(),
            },
            JobFile::Recording { bytes } => Job::Recording {
                bytes: bytes.to_vec(),
            },
            JobFile::Schedule { .. } => Job::Schedule {
                steps: (0..n).filter_map(|k| file.step(k)).collect(),
            },
            JobFile::Moves { .. } => Job::Moves {
                points: (0..n).filter_map(|k| file.move_point(k)).collect(),
            },
        })
    }
}

/// The parts of a job file: one job file, or several back to back (a program of
/// several parts, `kerf plan --all`), each read and checked by the firmware's reader.
///
/// Errors: the first part that is not a whole job file (an empty file is truncated).
pub fn split(bytes: &[u8]) -> Result<Vec<&[u8]>, JobFileError> {
    let mut parts = Vec::new();
    let mut rest = bytes;
    loop {
        let part = match file_len(rest) {
            Some(n) if n <= rest.len() => &rest[..n],
            // Not a header, or shorter than it says: the reader names what is wrong.
            _ => rest,
        };
        JobFile::read(part)?;
        parts.push(part);
        rest = &rest[part.len()..];
        if rest.is_empty() {
            return Ok(parts);
        }
    }
}

/// The part `part` (one job file) made to start at rest: the same points and settings,
/// no longer continuing the part before it (what the machine takes when the part before
/// stopped without it); any other part unchanged.
///
/// Errors: a part that does not read.
pub fn starting_at_rest(part: &[u8]) -> Result<Vec<u8>, JobFileError> {
    let mut settings = JobFile::read(part)?.settings();
    if !settings.continuity.continues {
        return Ok(part.to_vec());
    }
    settings.continuity.continues = false;
    let mut buf = vec![0u8; part.len() + CUT_SETTINGS_BYTES];
    let n = kerf::codec::job::with_settings(part, &settings, &mut buf)?;
    buf.truncate(n);
    Ok(buf)
}

/// `settings` over each part's own, field by field (a field `settings` gives replaces
/// the part's; the others stay), for every part of the program `bytes`; the program
/// unchanged (not read) where `settings` gives none.
///
/// Errors: a part that does not read; settings given for a part of another kind than
/// EFD, points and moves ([`JobFileError::Settings`]: G-code carries its own), or that the
/// file cannot say (a zero speed, zero passes).
pub fn with_settings(bytes: &[u8], settings: &CutSettings) -> Result<Vec<u8>, JobFileError> {
    if *settings == CutSettings::MACHINE {
        return Ok(bytes.to_vec());
    }
    let parts = split(bytes)?;
    let mut out = Vec::with_capacity(bytes.len() + parts.len() * CUT_SETTINGS_BYTES);
    for part in parts {
        let own = JobFile::read(part)?.settings();
        let merged = CutSettings {
            speed_m_s: settings.speed_m_s.or(own.speed_m_s),
            laser: settings.laser.or(own.laser),
            passes: settings.passes.or(own.passes),
            // A part's place in its program: the one given, else its own (the
            // command line gives none).
            continuity: match settings.continuity {
                Continuity::NONE => own.continuity,
                given => given,
            },
        };
        let mut buf = vec![0u8; part.len() + CUT_SETTINGS_BYTES];
        let n = kerf::codec::job::with_settings(part, &merged, &mut buf)?;
        out.extend_from_slice(&buf[..n]);
    }
    Ok(out)
}
