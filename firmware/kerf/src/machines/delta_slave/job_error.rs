//! Why a job of the delta slave cannot be planned, or started.

use crate::app::joints::JobError;
use crate::error::ConfigErrorKind;
use crate::kinematics::delta::KinematicsError;
use crate::trajectory::ContourError;

/// Why a job cannot be planned, or started. `segment` indexes the job's moves.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DeltaJobError {
    /// The job has no move, or more than [`MAX_SEGMENTS`](crate::app::joints::MAX_SEGMENTS).
    Size,
    /// A point or duration is NaN or infinite, or a duration is not positive.
    NotFinite {
        /// Move index (the start point and approach count as move 0).
        segment: u8,
    },
    /// A move leaves the workspace (out of reach, outside a carriage's travel, or
    /// through a singularity).
    Unreachable {
        /// Move index.
        segment: u8,
        /// What the kinematics said.
        error: KinematicsError,
    },
    /// A move needs more carriage speed or acceleration than the limits allow.
    TooFast {
        /// Move index.
        segment: u8,
        /// Carriage index.
        axis: u8,
    },
    /// The job was planned for another configuration than this machine's.
    OtherMachine,
    /// At `Start`: the approach from where the carriages are is too fast.
    Approach(JobError),
    /// A move lasts 2^32 control periods or more (about 5 days at 10 kHz).
    TooLong {
        /// Move index.
        segment: u8,
    },
    /// The contour, its speed or ramps are bad (a setting named, a curve too short
    /// for one period's step, a speed above the curvature limit, …).
    Contour(ContourError),
    /// The first point of the contour, in path order, that leaves the workspace.
    ContourUnreachable {
        /// The point, m.
        point_m: [f64; 3],
        /// What the kinematics said.
        error: KinematicsError,
    },
    /// The first point of the contour where a carriage would exceed its speed or
    /// acceleration limit.
    ContourTooFast {
        /// The point, m.
        point_m: [f64; 3],
        /// Carriage index.
        axis: u8,
    },
    /// The laser mode's setting (the constant power, or the energy per length) does
    /// not suit the machine's source: not finite, negative or above the maximum
    /// power (`OutOfRange`), or not representable in the machine's scalar.
    Laser(ConfigErrorKind),
    /// A part that continues the one before at its join, begun where that one did
    /// not hand over to it (it came too late: the part before stopped in its
    /// look-ahead).
    NotAtJoin,
}
