//! ARROW as it is flashed: its control period, the capacities of a job (moves, points
//! of a move, points of a program being read), and how a G-code program becomes a job
//! on the nominal model. The QEMU image, the simulator and the host tool's program
//! check take these from here.

use super::job::{ArrowJob, ArrowJobConfig, ArrowJobError, ArrowJobErrorKind};
use super::machine::ArrowMachine;
use crate::kinematics::arrow::{ArrowConfig, ArrowGeometry};
use crate::scalar::Float;
use crate::trajectory::gcode::GcodePoint;

/// The control period, s: 5 kHz (A §5.1), as a job is planned.
pub const PERIOD_S: f64 = ArrowJobConfig::ARROW.period_s;

/// Points a move holds (the pyramid's contour run has 166).
pub const JOB_POINTS: usize = 192;

/// Moves a job holds (the pyramid has three: the plunge, the contour, the retract).
pub const JOB_MOVES: usize = 4;

/// Points the G-code buffer holds while a program is read.
pub const PROGRAM_POINTS: usize = 256;

/// A job of ARROW as flashed.
pub type Job<T> = ArrowJob<T, JOB_POINTS, JOB_MOVES>;

/// ARROW as flashed.
pub type Arrow<T> = ArrowMachine<T, JOB_POINTS, JOB_MOVES>;

/// Reads a G-code program into a job checked on the nominal model
/// ([`ArrowConfig::ARROW`], [`ArrowJobConfig::ARROW`]), in place, with `points` as the
/// parse buffer.
///
/// Errors: the program's, with its line ([`ArrowJob::from_gcode`]).
#[allow(clippy::result_large_err)]
pub fn load_job<T: Float>(
    text: &[u8],
    points: &mut heapless::Vec<GcodePoint, PROGRAM_POINTS>,
    job: &mut Job<T>,
) -> Result<(), ArrowJobError> {
    let geometry = ArrowGeometry::<f64>::new(&ArrowConfig::ARROW).map_err(|e| ArrowJobError {
        line: 0,
        kind: ArrowJobErrorKind::Config(e),
    })?;
    *job = Job::<T>::from_gcode(text, points, &geometry, &ArrowJobConfig::ARROW)?;
    Ok(())
}
