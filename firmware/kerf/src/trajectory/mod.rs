//! What to follow: references evaluated once per control period.
//!
//! Contour references follow T ch. 3 as restated in docs/equations.md §10–16:
//! [`efd`] (closed contours as elliptic Fourier descriptors), [`open_path`] (open
//! contours as a C² spline in chord length), [`curve`] (what both are to a follower:
//! position and derivatives, arc length, curvature), [`tangential`] (constant
//! tangential speed along either curve, with a jerk-limited start and stop),
//! [`resample`] (open contours: quadratic densification and arc-length resampling),
//! [`spline`] (joint references: IK of the samples and a C² cubic spline in time),
//! [`constraint`] (circle/line motion constraints for manual machining), [`shapes`]
//! (the test contours of T fig. 8.1, 8.2 and 8.4), and the G-code path of A §4:
//! [`gcode`] (the file), [`task_spline`] (a natural cubic spline through its points in
//! task space) and [`feed`] (constant feed along it with S-curve start and stop);
//! [`planner`] plans programs of straight moves as CNC controllers do (look-ahead over
//! a buffer, corners at a junction-deviation speed).

mod arc;
pub mod constraint;
pub mod curve;
pub mod efd;
pub mod feed;
pub mod gcode;
pub mod open_path;
pub mod planner;
mod quadrature;
pub mod quintic;
pub mod resample;
pub mod shapes;
pub mod spline;
pub mod tangential;
pub mod task_spline;

use crate::error::ConfigError;

pub use crate::scalar::Float;
pub(crate) use crate::scalar::{lit, to_f64};

/// One axis' reference sample for a period: what a trajectory produces (a [`quintic`]
/// move, a machine's sample of its path) and a tracking law
/// ([`control::pd`](crate::control::pd)) follows.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Reference<T> {
    /// Position in m.
    pub position: T,
    /// Velocity in m/s.
    pub velocity: T,
    /// Acceleration in m/s².
    pub acceleration: T,
}

/// Why a contour, a speed or a joint map was rejected.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ContourError {
    /// A configuration value is bad (names the field).
    Config(ConfigError),
    /// A point coordinate is NaN or infinite (index of the point).
    NotFinitePoint(usize),
    /// Fewer than 3 distinct points (a contour needs at least a triangle or a bend).
    TooFewPoints,
    /// Point `index` repeats point `index − 1`, or lies so close to it (or so far from
    /// it) that the segment has no length in the scalar: open contours and constraint
    /// data need a direction on every segment.
    RepeatedPoint(usize),
    /// All points coincide: the contour has no length.
    ZeroLength,
    /// The point is not finite, or so far from the contour that the constraint
    /// overflows the scalar.
    FarFromContour,
    /// Every point of a closed contour lies on one line (within rounding): a
    /// back-and-forth stroke with cusps, not a contour to follow.
    Collinear,
    /// The contour follower could not solve a step on this curve (it nearly stops
    /// there, as at the ends of a nearly collinear contour): it holds where it was.
    LostContour,
    /// No harmonics asked for, or more than the capacity N.
    TooManyHarmonics,
    /// The result does not fit the fixed capacity.
    Capacity,
    /// One period's step V·Ts is longer than the contour.
    StepLongerThanContour,
    /// V²·κmax exceeds the acceleration limit; the highest allowed speed is given (m/s).
    SpeedAboveCurvatureLimit {
        /// Highest constant tangential speed the limit allows, m/s.
        max_speed_m_s: f64,
    },
}

impl From<ConfigError> for ContourError {
    fn from(e: ConfigError) -> Self {
        ContourError::Config(e)
    }
}

/// Checks a list of 2-D points for NaN/infinity.
pub(crate) fn check_finite(points: &[[f64; 2]]) -> Result<(), ContourError> {
    match points
        .iter()
        .position(|&[x, y]| !(x.is_finite() && y.is_finite()))
    {
        Some(i) => Err(ContourError::NotFinitePoint(i)),
        None => Ok(()),
    }
}

/// Rejects open-contour data with fewer than 3 points or a repeated consecutive point.
pub(crate) fn check_open(points: &[[f64; 2]]) -> Result<(), ContourError> {
    check_finite(points)?;
    if points.len() < 3 {
        return Err(ContourError::TooFewPoints);
    }
    match points
        .windows(2)
        .position(|w| matches!(w, [a, b] if a == b))
    {
        Some(i) => Err(ContourError::RepeatedPoint(i + 1)),
        None => Ok(()),
    }
}
