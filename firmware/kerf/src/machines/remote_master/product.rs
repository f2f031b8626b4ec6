//! The remote machining master as it is flashed: its configuration (the horizontal
//! master delta of T 7.1 at 10 kHz behind 0.5 µm encoders, the fixture's and the
//! tracking law's poles of the remote scenarios), the remote link's sample clock, the
//! host link's job buffer and telemetry decimation, and how an uploaded contour
//! becomes a fixture job. The QEMU image and the simulator take these from here.
//!
//! # A fixture job
//!
//! The host uploads the contour the fixture holds the operator's hand to as a points
//! job file ([`crate::codec::job`]): at most [`FIXTURE_POINTS`] points (x, y) of a
//! closed contour in the master's frame, m, in the order the hand follows them (the
//! windows of [`ConstraintConfig::closed_contour`] wrap around; the last point is not
//! the first again). The operator starts on it: the master stands at its rest point
//! ([`rest_point`], the effector over the carriages at [`HOME_M`]), where the
//! product's contours begin. What the file has no word for comes from the session
//! ([`FixtureSession`]): the height of the plane the fixture holds (the rest point's),
//! and the slave's beam, on.
//!
//! The slave's commands map the master's motion about the rest point onto the slave's
//! workspace about the middle of the Keops slave's travel ([`SLAVE_CENTRE_Q_M`]),
//! scaled by [`SCALE`] (T 5.3.2).

use super::{FixtureJob, RemoteMaster, RemoteMasterConfig, SlaveEstimate, FIXTURE_POINTS};
use crate::codec::job::{JobFile, HEADER_BYTES};
use crate::control::bilateral::BilateralConfig;
use crate::control::constraint::FixtureConfig;
use crate::control::dob::DobConfig;
use crate::control::preview::PreviewConfig;
use crate::error::ConfigError;
use crate::kinematics::delta::{DeltaConfig, DeltaGeometry};
use crate::scalar::Float;
use crate::sensing::encoder::EncoderConfig;
use crate::sensing::velocity::TrackingObserverConfig;
use crate::trajectory::constraint::ConstraintConfig;
use crate::trajectory::ContourError;
use core::f64::consts::PI;
use nalgebra::Vector3;

/// The control period, s (10 kHz, the remote scenarios' master).
pub const PERIOD_S: f64 = 1e-4;

/// Control periods per remote link sample (1 kHz samples).
pub const SAMPLES_PER_COMMAND: u32 = 10;

pub use crate::app::remote_link::BLOCK;

/// Times the master sends each command frame (`MasterLink::with_copies`): with three,
/// 1 % and 5 % frame loss leave the slave's tracking as without loss, for three times
/// the command stream's bytes (17 kB/s) and 16 ms more playout latency
/// (docs/control.md §22).
pub const COMMAND_COPIES: usize = 3;

/// The carriages at power-up (the homing stops), m.
pub const HOME_M: [f64; 3] = [0.07; 3];

/// Slave displacement per master displacement.
pub const SCALE: f64 = 0.5;

/// The Keops slave's carriages at the middle of their travel, m: the slave's centre
/// of the mapping is its effector there.
pub const SLAVE_CENTRE_Q_M: [f64; 3] = [0.02; 3];

/// The fixture's row, across the curve and in z alike: error poles at 20 and 40 Hz.
pub const FIXTURE_ROW: PreviewConfig = PreviewConfig {
    surface_slope_per_s: 2.0 * PI * 20.0,
    reaching_rate_per_s: 2.0 * PI * 40.0,
};

/// The fixture as flashed.
pub const FIXTURE: FixtureConfig = FixtureConfig {
    normal: FIXTURE_ROW,
    vertical: FIXTURE_ROW,
};

/// The tracking law's poles, rad/s (15 Hz, critically damped).
pub const TRACKING_RAD_S: f64 = 2.0 * PI * 15.0;

/// Bytes of an uploaded job the master holds: a points file of [`FIXTURE_POINTS`]
/// points (header, 8 bytes a point, CRC).
pub const LINK_JOB_BYTES: usize = HEADER_BYTES + 8 * FIXTURE_POINTS + 4;

/// The supervisor reports telemetry every this many control periods (1 kHz at the
/// 10 kHz period); the host link decimates further to the rate the host asks for.
pub const TELEMETRY_DECIMATION: u32 = 10;

/// The master as flashed.
pub type Master<T> = RemoteMaster<T>;

/// The master's rest point: its effector over the carriages at [`HOME_M`], m.
///
/// Errors: none for the product's geometry (a geometry that does not assemble there
/// is named `home_m`).
pub fn rest_point() -> Result<[f64; 3], ConfigError> {
    effector(&DeltaConfig::MASTER_HORIZONTAL, HOME_M)
}

/// The effector of `delta` over carriages `q_m`, in f64.
fn effector(delta: &DeltaConfig, q_m: [f64; 3]) -> Result<[f64; 3], ConfigError> {
    let geometry = DeltaGeometry::<f64>::new(delta).map_err(|e| e.within("delta"))?;
    geometry
        .forward(&Vector3::from(q_m))
        .map(Into::into)
        .map_err(|_| ConfigError::out_of_range("home_m"))
}

/// The master's configuration as flashed: the remote scenarios' master (T 7.1:
/// encoders, velocity and disturbance observers, the fixture, the delay observer on,
/// haptics off), its tracking law mapping the [`rest_point`] onto the Keops slave's
/// middle ([`SLAVE_CENTRE_Q_M`]).
///
/// Errors: none for the product's geometries (one that does not assemble at its
/// point is named).
pub fn config() -> Result<RemoteMasterConfig, ConfigError> {
    let master_centre_m = rest_point()?;
    let slave_centre_m =
        effector(&DeltaConfig::SLAVE_KEOPS, SLAVE_CENTRE_Q_M).map_err(|e| e.within("slave"))?;
    Ok(RemoteMasterConfig {
        period_s: PERIOD_S,
        delta: DeltaConfig::MASTER_HORIZONTAL,
        encoders: [EncoderConfig::MASTER_0_5_UM; 3],
        home_m: HOME_M,
        velocity: TrackingObserverConfig {
            bandwidth_rad_s: 2.0 * PI * 300.0,
        },
        dob: DobConfig {
            nominal_mass_kg: 0.335,
            bandwidth_rad_s: 2.0 * PI * 40.0,
            force_limit_n: 10.0,
            compensate: true,
        },
        fixture: FIXTURE,
        constraint: ConstraintConfig::closed_contour(),
        tracking: BilateralConfig::critically_damped(
            SCALE,
            master_centre_m,
            slave_centre_m,
            TRACKING_RAD_S,
        ),
        observer_bandwidth_rad_s: 2.0 * PI * 5.0,
        slave_estimate: SlaveEstimate::EchoedTicks,
        samples_per_command: SAMPLES_PER_COMMAND,
        haptic: None,
    })
}

/// What a fixture job takes from the master rather than from its file.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FixtureSession {
    /// How the points become the fixture's windows.
    pub constraint: ConstraintConfig,
    /// The height of the plane the fixture holds, m.
    pub z_m: f64,
    /// The slave's beam.
    pub laser_on: bool,
}

/// The session as flashed: the closed contour's windows, the rest point's height,
/// the beam on.
///
/// Errors: those of [`rest_point`].
pub fn session() -> Result<FixtureSession, ConfigError> {
    Ok(FixtureSession {
        constraint: ConstraintConfig::closed_contour(),
        z_m: rest_point()?[2],
        laser_on: true,
    })
}

/// Why a job file is not a fixture job.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FixtureLoadError {
    /// Not a points file.
    Kind,
    /// More than [`FIXTURE_POINTS`] points.
    TooManyPoints,
    /// The contour the points make is refused ([`FixtureJob::new`]).
    Contour(ContourError),
}

/// Reads a points job file into a fixture job of `session` (module docs), the points
/// on the caller's stack.
///
/// Errors: another kind of file, more points than the master holds, a contour the
/// fixture refuses.
pub fn load_fixture<T: Float>(
    session: &FixtureSession,
    file: &JobFile<'_>,
) -> Result<FixtureJob<T>, FixtureLoadError> {
    let JobFile::Points { .. } = file else {
        return Err(FixtureLoadError::Kind);
    };
    let n = file.count();
    if n > FIXTURE_POINTS {
        return Err(FixtureLoadError::TooManyPoints);
    }
    let mut points = [[0.0f64; 2]; FIXTURE_POINTS];
    for (k, p) in points.iter_mut().enumerate().take(n) {
        *p = file
            .point(k)
            .ok_or(FixtureLoadError::TooManyPoints)?
            .map(f64::from);
    }
    let points = points.get(..n).ok_or(FixtureLoadError::TooManyPoints)?;
    FixtureJob::new(points, &session.constraint, session.z_m, session.laser_on)
        .map_err(FixtureLoadError::Contour)
}

/// Semi-axes of the product's sample contour, m (the remote scenarios' ellipse).
pub const SAMPLE_SEMI_AXES_M: [f64; 2] = [0.015, 0.011];

/// The product's sample contour, the points of `data/remote_master_fixture.krfj`:
/// the ellipse of [`SAMPLE_SEMI_AXES_M`] in [`FIXTURE_POINTS`] points,
/// counter-clockwise from the [`rest_point`] (its rightmost point).
///
/// Errors: those of [`rest_point`].
pub fn sample_contour() -> Result<[[f64; 2]; FIXTURE_POINTS], ConfigError> {
    let [x0, y0, _] = rest_point()?;
    let [a, b] = SAMPLE_SEMI_AXES_M;
    let shape: [[f64; 2]; FIXTURE_POINTS] = crate::trajectory::shapes::ellipse(a, b);
    Ok(shape.map(|[x, y]| [x - a + x0, y + y0]))
}
