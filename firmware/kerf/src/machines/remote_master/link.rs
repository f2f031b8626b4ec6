//! The remote machining master on the host link ([`crate::app::host_link`]): its
//! settings (the virtual fixture's poles), how an uploaded contour becomes a fixture
//! job ([`super::product::load_fixture`]), and its telemetry and faults on the wire.
//!
//! Settings (JSON values, SI units):
//!
//! | path | what |
//! |---|---|
//! | `/fixture/normal/{surface_slope,reaching_rate}` | the fixture's poles across the curve (`control::constraint`, docs/control.md §20) |
//! | `/fixture/vertical/{surface_slope,reaching_rate}` | its poles in z |
//!
//! A change is validated as the configuration's fixture is ([`Fixture::new`]: finite,
//! positive, their product and sum representable in the scalar) and applies at the
//! next period: the fixture keeps no state, so the change is bumpless.

use super::product::{load_fixture, FixtureLoadError, FixtureSession, Master, FIXTURE, PERIOD_S};
use super::{FixtureJob, FixtureJobError, MasterTelemetry, RemoteMasterFault};
use crate::app::host_link::LinkMachine;
use crate::codec::job::JobFile;
use crate::codec::link::code_words as words;
use crate::codec::link::{Channel, ChannelValues, CodeWords, JobKind};
use crate::control::constraint::{Fixture, FixtureConfig};
use crate::control::preview::PreviewConfig;
use crate::error::ConfigError;
use crate::scalar::{to_f64, Float};
use crate::sensing::encoder::EncoderFault;
use crate::trajectory::ContourError;
use miniconf::Tree;

/// One row of the fixture: its two error poles (T 5.2, the preview law's pair).
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct RowSettings {
    /// The sliding surface's slope λ (one error pole at −λ).
    #[tree(meta(unit = "1/s", range = "> 0"))]
    pub surface_slope: f64,
    /// The reaching rate K (the other pole at −K).
    #[tree(meta(unit = "1/s", range = "> 0"))]
    pub reaching_rate: f64,
}

impl RowSettings {
    const fn of(row: &PreviewConfig) -> Self {
        Self {
            surface_slope: row.surface_slope_per_s,
            reaching_rate: row.reaching_rate_per_s,
        }
    }

    fn config(&self) -> PreviewConfig {
        PreviewConfig {
            surface_slope_per_s: self.surface_slope,
            reaching_rate_per_s: self.reaching_rate,
        }
    }
}

/// The fixture's poles: across the curve in the plane, and in z.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct FixtureSettings {
    /// Across the curve.
    pub normal: RowSettings,
    /// In z.
    pub vertical: RowSettings,
}

/// The master's settings tree.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct MasterSettings {
    /// The virtual fixture.
    pub fixture: FixtureSettings,
}

impl MasterSettings {
    /// The settings of a fixture's configuration.
    pub const fn of(fixture: &FixtureConfig) -> Self {
        Self {
            fixture: FixtureSettings {
                normal: RowSettings::of(&fixture.normal),
                vertical: RowSettings::of(&fixture.vertical),
            },
        }
    }

    /// The master's own ([`FIXTURE`]).
    pub const MASTER: Self = Self::of(&FIXTURE);

    /// The fixture's configuration.
    pub fn fixture(&self) -> FixtureConfig {
        FixtureConfig {
            normal: self.fixture.normal.config(),
            vertical: self.fixture.vertical.config(),
        }
    }
}

/// Refusals of [`LinkMachine::load_job`]: the loader's ([`FixtureLoadError`]).
pub mod load_codes {
    /// Not a points job.
    pub const KIND: u16 = 0x301;
    /// More points than the master holds.
    pub const TOO_MANY: u16 = 0x302;
    /// Fewer points than the fixture's windows need.
    pub const TOO_FEW: u16 = 0x303;
    /// A point repeats the one before it (or the last the first).
    pub const REPEATED: u16 = 0x304;
    /// A point the scalar cannot carry.
    pub const POINT: u16 = 0x305;
    /// Another refusal of the contour.
    pub const CONTOUR: u16 = 0x306;
}

/// What a fault's detail holds: the carriage, 0 to 2.
const CARRIAGE: &str = "carriage";

/// The fault codes of [`LinkMachine::fault_code`].
const FAULTS: [CodeWords; 6] = [
    words(
        1,
        "an encoder count jumped farther than the carriage can move in a period",
        CARRIAGE,
    ),
    words(
        2,
        "an encoder's count left its range (more than 2^31 counts from home)",
        CARRIAGE,
    ),
    words(
        3,
        "the master's effector or its Jacobians could not be computed (a pose off the mechanism)",
        "",
    ),
    words(
        4,
        "the effector is too far from the fixture's contour to evaluate it",
        "",
    ),
    words(
        5,
        "the fixture's law had no output (the effector at a fitted circle's centre)",
        "",
    ),
    words(
        6,
        "a value of the period was not finite (a force, an estimate, an output, the slave's command)",
        "",
    ),
];

/// The job refusal codes of the master's check ([`LinkMachine::job_error_code`]) and
/// the loader ([`load_codes`]).
const JOB_REFUSALS: [CodeWords; 8] = [
    words(1, "the job has no contour", ""),
    words(2, "the job's height is not finite", ""),
    words(
        load_codes::KIND,
        "this master takes contours as points only",
        "",
    ),
    words(
        load_codes::TOO_MANY,
        "more points than the master holds (128)",
        "",
    ),
    words(
        load_codes::TOO_FEW,
        "fewer points than the fixture's windows need (11)",
        "",
    ),
    words(
        load_codes::REPEATED,
        "a point repeats the one before it (or the last repeats the first)",
        "",
    ),
    words(
        load_codes::POINT,
        "a point the master's scalar cannot carry",
        "",
    ),
    words(
        load_codes::CONTOUR,
        "the points make no contour the fixture can hold",
        "",
    ),
];

/// The telemetry channels.
const CHANNELS: [Channel; 16] = [
    Channel {
        name: "x",
        unit: "m",
    },
    Channel {
        name: "y",
        unit: "m",
    },
    Channel {
        name: "z",
        unit: "m",
    },
    Channel {
        name: "speed",
        unit: "m/s",
    },
    Channel {
        name: "error",
        unit: "m",
    },
    Channel {
        name: "height_error",
        unit: "m",
    },
    Channel {
        name: "force1",
        unit: "N",
    },
    Channel {
        name: "force2",
        unit: "N",
    },
    Channel {
        name: "force3",
        unit: "N",
    },
    Channel {
        name: "haptic",
        unit: "N",
    },
    Channel {
        name: "slave_x",
        unit: "m",
    },
    Channel {
        name: "slave_y",
        unit: "m",
    },
    Channel {
        name: "slave_z",
        unit: "m",
    },
    Channel {
        name: "tracking_error",
        unit: "m",
    },
    Channel {
        name: "beam",
        unit: "1",
    },
    Channel {
        name: "round_trip",
        unit: "s",
    },
];
const _: () = assert!(CHANNELS.len() <= crate::codec::link::MAX_CHANNELS);

/// The code of a contour the loader refuses.
fn contour_code(e: &ContourError) -> u16 {
    match e {
        ContourError::TooFewPoints => load_codes::TOO_FEW,
        ContourError::RepeatedPoint(_) => load_codes::REPEATED,
        ContourError::NotFinitePoint(_) | ContourError::Config(_) => load_codes::POINT,
        ContourError::Capacity => load_codes::TOO_MANY,
        _ => load_codes::CONTOUR,
    }
}

impl<T: Float> LinkMachine for Master<T> {
    type Settings = MasterSettings;
    type JobContext = FixtureSession;
    const NAME: &'static str = "remote-master";
    const CHANNELS: &'static [Channel] = &CHANNELS;
    const JOB_KINDS: &'static [JobKind] = &[JobKind::Points];
    const FAULTS: &'static [CodeWords] = &FAULTS;
    const JOB_REFUSALS: &'static [CodeWords] = &JOB_REFUSALS;

    fn coefficients(settings: &MasterSettings, _period_s: f64) -> Result<Fixture<T>, ConfigError> {
        Fixture::new(&settings.fixture()).map_err(|e| e.within("fixture"))
    }

    /// The points read into the session's fixture job.
    fn load_job(
        session: &mut FixtureSession,
        file: &JobFile<'_>,
        job: &mut FixtureJob<T>,
    ) -> Result<(), u16> {
        *job = load_fixture(session, file).map_err(|e| match e {
            FixtureLoadError::Kind => load_codes::KIND,
            FixtureLoadError::TooManyPoints => load_codes::TOO_MANY,
            FixtureLoadError::Contour(e) => contour_code(&e),
        })?;
        Ok(())
    }

    fn job_error_code(error: &FixtureJobError) -> u16 {
        match error {
            FixtureJobError::NoContour => 1,
            FixtureJobError::NotFinite => 2,
        }
    }

    fn fault_code(fault: &RemoteMasterFault) -> (u16, u16) {
        match fault {
            RemoteMasterFault::Encoder {
                axis,
                fault: EncoderFault::Jump { .. },
            } => (1, u16::from(*axis)),
            RemoteMasterFault::Encoder {
                axis,
                fault: EncoderFault::OutOfRange,
            } => (2, u16::from(*axis)),
            RemoteMasterFault::Kinematics(_) => (3, 0),
            RemoteMasterFault::Constraint(_) => (4, 0),
            RemoteMasterFault::Fixture(_) => (5, 0),
            RemoteMasterFault::NotFinite => (6, 0),
        }
    }

    /// The master's effector and speed, its distance across the contour (`error`)
    /// and below the height, the carriage forces and the haptic part, the slave as
    /// the master's estimate has it (NaN before the first report), the tracking law's
    /// error, the beam and the round trip.
    fn sample(t: &MasterTelemetry<T>, values: &mut ChannelValues) {
        let f = |v: T| to_f64(v) as f32;
        let [x, y, z] = t.effector_m.map(f);
        let [vx, vy, vz] = t.velocity_m_s.map(to_f64);
        let speed = libm::sqrt(vx * vx + vy * vy + vz * vz) as f32;
        let [across, below] = t.constraint_m.map(f);
        let [f1, f2, f3] = t.force_n.map(f);
        let [sx, sy, sz] = t.slave_estimate_m.map_or([f32::NAN; 3], |s| s.map(f));
        let [ex, ey, ez] = t.tracking_error_m.map(to_f64);
        let tracking = libm::sqrt(ex * ex + ey * ey + ez * ez) as f32;
        let round_trip = (f64::from(t.round_trip_periods) * PERIOD_S) as f32;
        let row: [f32; CHANNELS.len()] = [
            x,
            y,
            z,
            speed,
            across,
            below,
            f1,
            f2,
            f3,
            f(t.haptic_n),
            sx,
            sy,
            sz,
            tracking,
            f32::from(u8::from(t.laser_on)),
            round_trip,
        ];
        values.clear();
        // Within the capacity: checked at compile time above.
        let _ = values.extend_from_slice(&row);
    }
}

#[cfg(test)]
mod tests;
