//! ARROW as it is flashed: its control period, the capacities of a job (moves, points
//! of a move, points of a program being read), and how a G-code program becomes a job
//! on the nominal model. The QEMU image, the simulator and the host tool's program
//! check take these from here.

use super::job::{ArrowJob, ArrowJobConfig, ArrowJobError, ArrowJobErrorKind};
use super::machine::ArrowMachine;
use super::ArrowLaw;
use crate::control::redundant_pid::{RedundantPid, RedundantPidConfig};
use crate::error::{ConfigContext, ConfigError};
use crate::kinematics::arrow::{ArrowConfig, ArrowDynamics, ArrowGeometry, ArrowMasses};
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

/// Where ARROW stands when it is switched on and where a program starts from unless
/// the machine was left elsewhere: the plate at the pyramid's first point
/// (`data/pyramid.gcode`), as `x, y, z` in m and the angles `A` (the turntable's
/// θx) and `B` (the plate's θz) in rad, the axes of a G-code point.
pub const HOME: [f64; 5] = [
    13.333e-3,
    464.604e-3,
    -13.333e-3,
    -15.0 * DEGREE,
    15.0 * DEGREE,
];

/// One degree in radians.
const DEGREE: f64 = core::f64::consts::PI / 180.0;

/// Bytes of an uploaded job the machine holds: the pyramid's G-code file is 9.0 KB.
pub const LINK_JOB_BYTES: usize = 12 * 1024;

/// The supervisor reports telemetry every this many control periods (1 kHz at the
/// 5 kHz period); the host link decimates further to the rate the host asks for.
pub const TELEMETRY_DECIMATION: u32 = 5;

/// A job of ARROW as flashed.
pub type Job<T> = ArrowJob<T, JOB_POINTS, JOB_MOVES>;

/// ARROW as flashed.
pub type Arrow<T> = ArrowMachine<T, JOB_POINTS, JOB_MOVES>;

/// The law on the controller's nominal model (A table 1–2: [`ArrowConfig::ARROW`],
/// [`ArrowMasses::ARROW`]) with the gains of the parallel module and the turntable,
/// feedforward on or off, at `period_s`.
///
/// Errors: a gain the scalar cannot carry, named by its part (`parallel.kd`).
pub fn law<T: Float>(
    parallel: &RedundantPidConfig,
    turntable: &RedundantPidConfig,
    feedforward: bool,
    period_s: f64,
) -> Result<ArrowLaw<T>, ConfigError> {
    let model = ArrowConfig::ARROW;
    let geometry = ArrowGeometry::<T>::new(&model).within("geometry")?;
    let masses = ArrowMasses::ARROW;
    let dynamics = ArrowDynamics::<T>::new(&masses, model.arms[0].length_m, model.arms[2].length_m)
        .within("dynamics")?;
    Ok(ArrowLaw {
        geometry,
        dynamics,
        parallel: RedundantPid::<T>::new(parallel, period_s).within("parallel")?,
        turntable: RedundantPid::<T>::new(turntable, period_s).within("turntable")?,
        feedforward,
    })
}

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
    job.read_gcode(text, points, &geometry, &ArrowJobConfig::ARROW)
}
