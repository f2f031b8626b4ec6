//! The Keops slave on the host link ([`crate::app::host_link`]): its settings tree,
//! how an uploaded job file becomes a contour job (an EFD file a closed contour cut
//! for [`ContourDefaults::laps`] laps from θ = 0, a points file an open path cut once
//! from its first point to its last; the file's x and y are the workspace's, about
//! [`ContourDefaults::centre_m`], so the parts of a program keep their places), and
//! its telemetry and faults on the wire.
//!
//! Settings (JSON values, SI units and Hz):
//!
//! | path | what |
//! |---|---|
//! | `/slave/pd/bandwidth_hz` | PD tracking, critically damped: Kp = ω², Kd = 2ω |
//! | `/slave/dob/bandwidth_hz` | disturbance observer bandwidth |
//! | `/slave/dob/nominal_mass_kg` | its nominal mass An |
//! | `/slave/dob/force_limit_n` | force saturation |
//! | `/slave/dob/compensate` | add the estimate to the command |
//! | `/slave/velocity/bandwidth_hz` | velocity observer bandwidth |
//!
//! A change is validated as [`AxisLaw::new`] validates a configuration and applies
//! bumplessly to all three carriages.

use super::{
    ContourCurve, ContourLaw, DeltaFault, DeltaJob, DeltaJobError, DeltaSlave, DeltaSlaveConfig,
    DeltaTelemetry, MovePoint, CONTOUR_HARMONICS, MOVE_POINTS, OPEN_PATH_POINTS,
};
pub use crate::app::axis::settings::{AxisSettings, DobSettings, PdSettings, VelocitySettings};
use crate::app::axis::{AxisConfig, AxisLaw};
use crate::app::host_link::LinkMachine;
use crate::app::joints::JobError;
use crate::codec::job::{CutLaser, CutSettings, JobFile};
use crate::codec::link::code_words as words;
use crate::codec::link::{Channel, ChannelValues, CodeWords, JobKind, JOB_NOT_AT_REST};
use crate::control::laser::LaserMode;
use crate::error::ConfigError;
use crate::scalar::{to_f64, Float};
use crate::trajectory::efd::Efd;
use crate::trajectory::open_path::OpenPath;
use crate::trajectory::planner::Continuation;
use miniconf::Tree;

/// The slave's settings tree.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct SlaveSettings {
    /// The carriages' law.
    pub slave: AxisSettings,
}

impl SlaveSettings {
    /// The settings of a configuration (its PD read as critically damped at
    /// √Kp: the presets are).
    pub fn of(config: &AxisConfig) -> Self {
        Self {
            slave: AxisSettings::of(config),
        }
    }

    /// The configuration these settings describe (validated by [`AxisLaw::new`]).
    pub fn config(&self) -> AxisConfig {
        self.slave.config()
    }
}

/// How an uploaded contour is cut: everything a job file does not carry.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ContourDefaults {
    /// The machine.
    pub machine: DeltaSlaveConfig,
    /// The origin of a job file's x and y in the workspace, and the cutting height, m.
    pub centre_m: [f64; 3],
    /// Tangential speed, m/s.
    pub speed_m_s: f64,
    /// Ramp acceleration, m/s².
    pub accel_m_s2: f64,
    /// Ramp jerk, m/s³.
    pub jerk_m_s3: f64,
    /// Approach time, s.
    pub approach_s: f64,
    /// Laps of the contour.
    pub laps: f64,
    /// The corners' junction deviation of a program of moves, m.
    pub junction_deviation_m: f64,
    /// The law.
    pub law: ContourLaw,
    /// Laser power at the cutting speed (held at constant energy per length), W.
    pub laser_power_w: f64,
}

/// Refusals of [`LinkMachine::load_job`] before the planner (the planner's own are
/// [`DeltaSlave::job_error_code`]'s).
pub mod load_codes {
    /// More harmonics than a contour job holds.
    pub const TOO_MANY_HARMONICS: u16 = 0x201;
    /// The coefficients do not make a curve.
    pub const BAD_CURVE: u16 = 0x202;
    /// A kind of job this machine does not cut (G-code, schedules, recordings).
    pub const KIND: u16 = 0x203;
    /// More points than an open path holds.
    pub const TOO_MANY_POINTS: u16 = 0x204;
    /// The points do not make a path: fewer than three, or one repeated.
    pub const BAD_PATH: u16 = 0x205;
    /// The part's speed is not above zero.
    pub const SPEED: u16 = 0x206;
    /// Passes asked of an open path (it is cut once).
    pub const PASSES: u16 = 0x207;
    /// The part's energy per length needs more power at its speed than the source has.
    pub const ENERGY: u16 = 0x208;
    /// A part that continues another, which is not the one loaded just before it or
    /// does not end where it starts.
    pub const NO_JOIN: u16 = 0x209;
}

/// What the slave's link builds jobs with: the contour defaults, and where the last
/// program of moves it loaded goes on (its join), for a part that continues it.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SlaveJobContext {
    /// The contour defaults: speed, ramps, laser, law, height.
    pub defaults: ContourDefaults,
    /// Where the last part loaded ends its cut (relative to the job's centre, m) and
    /// how the next part takes over there; `None` when it ends at rest.
    last_join: Option<([f64; 2], Continuation<2>)>,
}

impl From<ContourDefaults> for SlaveJobContext {
    fn from(defaults: ContourDefaults) -> Self {
        Self {
            defaults,
            last_join: None,
        }
    }
}

/// What the fault codes of [`LinkMachine::fault_code`] mean.
const FAULTS: [CodeWords; 7] = [
    words(
        1,
        "a carriage faulted (its Hall decoder or joint limits)",
        "",
    ),
    words(
        2,
        "the kinematics could not be solved (joint references or measured effector)",
        "",
    ),
    words(3, "the contour follower could not take a step", ""),
    words(
        4,
        "the effector left the contour by more than the contour-error limit",
        "",
    ),
    words(
        5,
        "a carriage fell behind its reference by more than the following-error limit",
        "carriage",
    ),
    words(
        6,
        "a carriage's force stayed at its limit longer than allowed",
        "",
    ),
    words(
        7,
        "an output (a carriage force, the laser duty) was not finite",
        "output (0-2 the carriage forces, 3 the laser duty)",
    ),
];

/// What the job refusal codes of the planner ([`LinkMachine::job_error_code`]) and
/// the loader ([`load_codes`]) mean.
const JOB_REFUSALS: [CodeWords; 21] = [
    words(
        1,
        "the job has no move, or more moves than the machine holds",
        "",
    ),
    words(
        2,
        "a point or duration is not finite, or a duration is not positive",
        "",
    ),
    words(
        3,
        "a move leaves the workspace (reach, carriage travel or a singularity)",
        "",
    ),
    words(
        4,
        "a move needs more carriage speed or acceleration than the limits allow",
        "",
    ),
    words(5, "the job was planned for another machine", ""),
    words(
        6,
        "the approach from where the carriages are is too fast",
        "",
    ),
    words(7, "a move lasts 2^32 control periods or more", ""),
    words(
        8,
        "the contour, its speed or its ramps are bad (too short, above the curvature limit)",
        "",
    ),
    words(9, "a point of the contour leaves the workspace", ""),
    words(
        10,
        "a point of the contour needs more carriage speed or acceleration than allowed",
        "",
    ),
    words(11, "the laser setting is out of range", ""),
    words(
        load_codes::TOO_MANY_HARMONICS,
        "more harmonics than a contour job holds (30)",
        "",
    ),
    words(
        load_codes::BAD_CURVE,
        "the coefficients do not make a curve",
        "",
    ),
    words(
        load_codes::KIND,
        "this machine cuts contours only (EFD jobs closed, points jobs open, moves jobs with sharp corners)",
        "",
    ),
    words(
        load_codes::TOO_MANY_POINTS,
        "more points than an open path or a program of moves holds (32, passes included)",
        "",
    ),
    words(
        load_codes::BAD_PATH,
        "the points do not make a path (fewer than 3, or 2 for moves, or a point repeated)",
        "",
    ),
    words(load_codes::SPEED, "the part's speed is not above zero", ""),
    words(
        load_codes::PASSES,
        "an open path is cut in one pass (passes are for closed contours and programs)",
        "",
    ),
    words(
        load_codes::ENERGY,
        "the energy per length needs more than the laser's power at the part's speed",
        "",
    ),
    words(
        load_codes::NO_JOIN,
        "the part continues another that was not loaded just before it, or that ends elsewhere",
        "",
    ),
    words(
        12,
        "the part before stopped without it (it came too late): upload it again to start from rest",
        "",
    ),
];

/// The telemetry channels.
const CHANNELS: [Channel; 11] = [
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
        name: "x_ref",
        unit: "m",
    },
    Channel {
        name: "y_ref",
        unit: "m",
    },
    Channel {
        name: "z_ref",
        unit: "m",
    },
    Channel {
        name: "error",
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
        name: "laser",
        unit: "W",
    },
];
const _: () = assert!(CHANNELS.len() <= crate::codec::link::MAX_CHANNELS);

impl<T: Float> LinkMachine for DeltaSlave<T> {
    type Settings = SlaveSettings;
    type JobContext = SlaveJobContext;
    const NAME: &'static str = "keops-slave";
    const CHANNELS: &'static [Channel] = &CHANNELS;
    const JOB_KINDS: &'static [JobKind] = &[JobKind::Efd, JobKind::Points, JobKind::Moves];
    const FAULTS: &'static [CodeWords] = &FAULTS;
    const JOB_REFUSALS: &'static [CodeWords] = &JOB_REFUSALS;

    fn coefficients(settings: &SlaveSettings, period_s: f64) -> Result<AxisLaw<T>, ConfigError> {
        AxisLaw::new(&settings.config(), period_s)
    }

    fn load_job(
        context: &mut SlaveJobContext,
        file: &JobFile<'_>,
        job: &mut DeltaJob,
    ) -> Result<(), u16> {
        let last_join = context.last_join.take();
        let defaults = &context.defaults;
        match file {
            JobFile::Efd { centre_m, .. } => load_closed(defaults, file, *centre_m, job),
            JobFile::Points { .. } => load_open(defaults, file, job),
            JobFile::Moves { .. } => {
                load_moves(defaults, file, last_join, job)?;
                context.last_join = job.join();
                Ok(())
            }
            _ => Err(load_codes::KIND),
        }
    }

    fn job_error_code(error: &DeltaJobError) -> u16 {
        refusal_code(error)
    }

    fn fault_code(fault: &DeltaFault) -> (u16, u16) {
        match fault {
            DeltaFault::Joint(_) => (1, 0),
            DeltaFault::Kinematics(_) => (2, 0),
            DeltaFault::Contour(_) => (3, 0),
            DeltaFault::ContourError => (4, 0),
            DeltaFault::FollowingError { axis } => (5, u16::from(*axis)),
            DeltaFault::Saturated => (6, 0),
            DeltaFault::Output(output) => (7, u16::from(output.index)),
        }
    }

    fn sample(t: &DeltaTelemetry<T>, values: &mut ChannelValues) {
        let f = |v: T| to_f64(v) as f32;
        let reference = t.effector_reference_m.map_or([0.0; 3], |r| r.map(f));
        let (position, error) = t.contour.map_or((reference, 0.0), |c| {
            (c.effector_m.map(f), f(c.contour_error_m))
        });
        let [x, y, z] = position;
        let [x_ref, y_ref, z_ref] = reference;
        let [f1, f2, f3] = t.joints.axes.map(|a| f(a.force_n));
        let row: [f32; CHANNELS.len()] = [
            x,
            y,
            z,
            x_ref,
            y_ref,
            z_ref,
            error,
            f1,
            f2,
            f3,
            f(t.laser_power_w),
        ];
        values.clear();
        // Within the capacity: checked at compile time below.
        let _ = values.extend_from_slice(&row);
    }
}

/// The refusal code of a planner error (the words are [`JOB_REFUSALS`]').
fn refusal_code(error: &DeltaJobError) -> u16 {
    match error {
        DeltaJobError::Size => 1,
        DeltaJobError::NotFinite { .. } => 2,
        DeltaJobError::Unreachable { .. } => 3,
        DeltaJobError::TooFast { .. } => 4,
        DeltaJobError::OtherMachine => 5,
        DeltaJobError::Approach(JobError::Moving { .. }) => JOB_NOT_AT_REST,
        DeltaJobError::Approach(_) => 6,
        DeltaJobError::TooLong { .. } => 7,
        DeltaJobError::Contour(_) => 8,
        DeltaJobError::ContourUnreachable { .. } => 9,
        DeltaJobError::ContourTooFast { .. } => 10,
        DeltaJobError::Laser(_) => 11,
        DeltaJobError::NotAtJoin => 12,
    }
}

/// An EFD file as a closed contour, cut for the context's laps (times the file's
/// passes) from θ = 0, its centre where the file puts it.
fn load_closed(
    context: &ContourDefaults,
    file: &JobFile<'_>,
    centre_m: [f32; 2],
    job: &mut DeltaJob,
) -> Result<(), u16> {
    let n = file.count();
    if n > CONTOUR_HARMONICS {
        return Err(load_codes::TOO_MANY_HARMONICS);
    }
    let mut coefficients = [[0.0f64; 4]; CONTOUR_HARMONICS];
    for (k, row) in coefficients.iter_mut().enumerate().take(n) {
        let h = file.harmonic(k).ok_or(load_codes::BAD_CURVE)?;
        *row = h.map(f64::from);
    }
    let centre = [f64::from(centre_m[0]), f64::from(centre_m[1])];
    let efd = Efd::<f64, CONTOUR_HARMONICS>::from_coefficients(
        centre,
        coefficients.get(..n).unwrap_or(&[]),
    )
    .map_err(|_| load_codes::BAD_CURVE)?;
    plan_into(
        context,
        ContourCurve::Closed {
            efd: &efd,
            theta0_rad: 0.0,
            laps: context.laps * f64::from(file.settings().passes.unwrap_or(1)),
        },
        centre,
        file.settings(),
        job,
    )
}

/// A points file as an open path, cut once from its first point to its last, each
/// point where the file puts it.
fn load_open(context: &ContourDefaults, file: &JobFile<'_>, job: &mut DeltaJob) -> Result<(), u16> {
    if file.settings().passes.is_some_and(|n| n > 1) {
        return Err(load_codes::PASSES);
    }
    let n = file.count();
    if n > OPEN_PATH_POINTS {
        return Err(load_codes::TOO_MANY_POINTS);
    }
    let mut points = [[0.0f64; 2]; OPEN_PATH_POINTS];
    for (k, point) in points.iter_mut().enumerate().take(n) {
        let p = file.point(k).ok_or(load_codes::BAD_PATH)?;
        *point = p.map(f64::from);
    }
    let path = OpenPath::<f64, OPEN_PATH_POINTS>::from_points(points.get(..n).unwrap_or(&[]))
        .map_err(|_| load_codes::BAD_PATH)?;
    let centre = path.centre();
    plan_into(
        context,
        ContourCurve::Open(&path),
        [centre.x, centre.y],
        file.settings(),
        job,
    )
}

/// A moves file as a program of straight moves with sharp corners, each point where
/// the file puts it, for its passes (a closed program again from its start).
fn load_moves(
    context: &ContourDefaults,
    file: &JobFile<'_>,
    last_join: Option<([f64; 2], Continuation<2>)>,
    job: &mut DeltaJob,
) -> Result<(), u16> {
    let n = file.count();
    if n > MOVE_POINTS {
        return Err(load_codes::TOO_MANY_POINTS);
    }
    let continuity = file.settings().continuity;
    let lookahead = usize::from(continuity.lookahead_points);
    if n < 2 + lookahead {
        return Err(load_codes::BAD_PATH);
    }
    let passes = usize::from(file.settings().passes.unwrap_or(1));
    if passes > 1 && (lookahead > 0 || continuity.continues) {
        return Err(load_codes::PASSES);
    }
    let mut points = [MovePoint {
        point_m: [0.0; 2],
        feed_m_s: 0.0,
    }; MOVE_POINTS];
    for (k, point) in points.iter_mut().enumerate().take(n) {
        let [x, y, feed] = file
            .move_point(k)
            .ok_or(load_codes::BAD_PATH)?
            .map(f64::from);
        *point = MovePoint {
            point_m: [x, y],
            feed_m_s: feed,
        };
    }
    let closed = points.first().map(|p| p.point_m) == points.get(n - 1).map(|p| p.point_m);
    if passes > 1 && !closed {
        return Err(load_codes::PASSES);
    }
    // Passes of a closed program: its moves again after the first (the start point
    // repeated at each end).
    let total = 1 + (n - 1) * passes;
    if total > MOVE_POINTS {
        return Err(load_codes::TOO_MANY_POINTS);
    }
    for k in n..total {
        let again = points.get(1 + (k - 1) % (n - 1)).copied();
        if let (Some(again), Some(point)) = (again, points.get_mut(k)) {
            *point = again;
        }
    }
    // A part that continues another starts where that one's cut ends, at its speed.
    let before = match (continuity.continues, last_join) {
        (false, _) => None,
        (true, Some((at_m, join))) if points.first().map(|p| p.point_m) == Some(at_m) => Some(join),
        (true, _) => return Err(load_codes::NO_JOIN),
    };
    plan_into(
        context,
        ContourCurve::Moves {
            points: points.get(..total).unwrap_or(&[]),
            junction_deviation_m: context.junction_deviation_m,
            lookahead,
            before,
        },
        [0.0; 2],
        file.settings(),
        job,
    )
}

/// Plans `curve` (relative to its centre, at `centre_m` in the file's x and y) with
/// the context's ramps and law into `job`, at the part's speed and laser where its
/// settings give them, the context's otherwise (its laser: the energy per length its
/// power cuts at its speed, whatever the part's speed, so the depth stays).
fn plan_into(
    context: &ContourDefaults,
    curve: ContourCurve<'_>,
    centre_m: [f64; 2],
    settings: CutSettings,
    job: &mut DeltaJob,
) -> Result<(), u16> {
    let mut plan = context.plan(curve);
    plan.centre_m[0] += centre_m[0];
    plan.centre_m[1] += centre_m[1];
    if let Some(speed) = settings.speed_m_s {
        if speed <= 0.0 {
            return Err(load_codes::SPEED);
        }
        plan.speed_m_s = f64::from(speed);
    }
    plan.laser = match settings.laser {
        None => plan.laser,
        Some(CutLaser::Off) => LaserMode::Off,
        Some(CutLaser::PowerW(power)) => LaserMode::ConstantPower {
            power_w: f64::from(power),
        },
        Some(CutLaser::EnergyJPerM(energy)) => LaserMode::ConstantEnergy {
            energy_per_length_j_per_m: f64::from(energy),
        },
    };
    // Constant energy at the cutting speed within the source (below, the planner's
    // own laser check refuses what is not a setting at all).
    if let LaserMode::ConstantEnergy {
        energy_per_length_j_per_m: energy,
    } = plan.laser
    {
        if energy * plan.speed_m_s > context.machine.laser.max_power_w {
            return Err(load_codes::ENERGY);
        }
    }
    *job = DeltaJob::plan_contour(&context.machine, &plan).map_err(|e| refusal_code(&e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::axis::AxisLaw;
    use miniconf::json_core;
    use std::string::String;
    use std::vec::Vec;

    #[test]
    fn every_fault_and_refusal_code_has_its_own_words() {
        use crate::codec::link::LINK_JOB_REFUSALS;
        type S = DeltaSlave<f32>;
        let faults = [
            DeltaFault::ContourError,
            DeltaFault::FollowingError { axis: 2 },
            DeltaFault::Saturated,
            DeltaFault::Output(crate::app::supervisor::NonFiniteOutput { index: 3 }),
        ];
        for fault in &faults {
            let (code, _) = S::fault_code(fault);
            assert!(CodeWords::find(&FAULTS, code).is_some(), "{fault:?}");
        }
        // The codes of the variants with inner faults (1, 2, 3) are the table's too.
        assert!(FAULTS.iter().map(|f| f.code).eq(1..=7));
        let (code, axis) = S::fault_code(&DeltaFault::FollowingError { axis: 2 });
        let entry = CodeWords::find(&FAULTS, code).unwrap();
        assert!(entry.words.contains("following-error"));
        assert_eq!((entry.detail, axis), ("carriage", 2));
        let contour = CodeWords::find(&FAULTS, S::fault_code(&DeltaFault::ContourError).0);
        assert!(contour.unwrap().words.contains("contour-error"));
        let code = S::job_error_code(&DeltaJobError::OtherMachine);
        assert!(CodeWords::find(&JOB_REFUSALS, code)
            .unwrap()
            .words
            .contains("another machine"));
        let code = S::job_error_code(&DeltaJobError::Approach(JobError::Moving { axis: 0 }));
        assert!(CodeWords::find(&LINK_JOB_REFUSALS, code).is_some());
        // Codes and words are each one of a kind, and the machine's refusals are not
        // the link's.
        crate::app::host_link::test_support::assert_code_tables(&FAULTS, &JOB_REFUSALS);
    }

    /// The description lists the channels in the order of a sample's values, the
    /// job kind, every setting with its unit and range, and the codes' words; the
    /// announced upper bound of a bandwidth is where validation refuses.
    #[test]
    fn the_slave_describes_itself() {
        use crate::app::host_link::{describe, SettingText};
        use crate::codec::link::Description;
        type S = DeltaSlave<f32>;
        let mut items = Vec::new();
        for index in 0.. {
            let mut text = SettingText::default();
            match describe::<S>(
                index,
                &SlaveSettings::of(&DeltaSlaveConfig::KEOPS.joints.axis),
                &mut text,
            ) {
                Some(Description::Setting {
                    path, unit, range, ..
                }) => items.push(std::format!("setting {path} {unit} {range}")),
                Some(item) => items.push(std::format!("{item:?}")),
                None => break,
            }
        }
        let settings: Vec<&String> = items.iter().filter(|i| i.starts_with("setting")).collect();
        assert_eq!(settings.len(), 6, "{settings:?}");
        assert!(items.contains(&"setting /slave/dob/bandwidth_hz Hz > 0 and ≤ 3183".into()));
        assert!(items.contains(&"setting /slave/dob/compensate  true or false".into()));
        assert_eq!(
            items.len(),
            CHANNELS.len() + 3 + 6 + FAULTS.len() + JOB_REFUSALS.len()
        );
        assert!(items[0].contains("\"x\"") && items[CHANNELS.len()] == "JobKind(Efd)");
        assert_eq!(items[CHANNELS.len() + 1], "JobKind(Points)");
        assert_eq!(items[CHANNELS.len() + 2], "JobKind(Moves)");
        // The bound announced for the observers' bandwidths, at the Keops period.
        let mut settings = SlaveSettings::of(&AxisConfig::LM1247_SLAVE);
        for (path, ok) in [
            ("/slave/dob/bandwidth_hz", true),
            ("/slave/velocity/bandwidth_hz", true),
        ] {
            for (value, accepted) in [(&b"3183"[..], ok), (&b"3184"[..], false)] {
                let mut candidate = settings;
                json_core::set(&mut candidate, path, value).unwrap();
                assert_eq!(
                    S::coefficients(&candidate, 1e-4).is_ok(),
                    accepted,
                    "{path}"
                );
            }
        }
        settings.slave.pd.bandwidth_hz = 0.0;
        assert!(S::coefficients(&settings, 1e-4).is_err());
    }

    /// A sample carries one value per channel, in the channels' order.
    #[test]
    fn a_sample_has_a_value_per_channel() {
        let axis = |force_n| crate::app::axis::AxisOutput {
            force_n,
            position_m: 0.0,
            velocity_m_s: 0.0,
            disturbance_n: 0.0,
            saturated: false,
            status: crate::app::axis::AxisStatus::Running,
        };
        let still = crate::trajectory::Reference {
            position: 0.0,
            velocity: 0.0,
            acceleration: 0.0,
        };
        let telemetry = DeltaTelemetry::<f32> {
            joints: crate::app::joints::JointTelemetry {
                reference: [still; 3],
                axes: [axis(0.5), axis(-4.0), axis(2.0)],
            },
            effector_reference_m: Some([1.0, 2.0, 3.0]),
            contour: None,
            laser_power_w: 7.5,
        };
        let mut values = ChannelValues::new();
        <DeltaSlave<f32> as LinkMachine>::sample(&telemetry, &mut values);
        assert_eq!(values.len(), CHANNELS.len());
        let at = |name: &str| values[CHANNELS.iter().position(|c| c.name == name).unwrap()];
        assert_eq!((at("x_ref"), at("z_ref"), at("x")), (1.0, 3.0, 1.0));
        assert_eq!((at("force2"), at("laser"), at("error")), (-4.0, 7.5, 0.0));
    }

    #[test]
    fn the_presets_settings_give_back_its_configuration_and_paths_address_them() {
        let config = AxisConfig::LM1247_SLAVE;
        let settings = SlaveSettings::of(&config);
        let back = settings.config();
        // Through Hz and back: a few ulps of round-off.
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-14 * b.abs();
        assert!(close(back.pd.kp_per_s2, config.pd.kp_per_s2));
        assert!(close(back.pd.kd_per_s, config.pd.kd_per_s));
        assert!(close(back.dob.bandwidth_rad_s, config.dob.bandwidth_rad_s));
        assert!(close(
            back.velocity.bandwidth_rad_s,
            config.velocity.bandwidth_rad_s
        ));
        assert_eq!(back.dob.compensate, config.dob.compensate);
        let mut buf = [0u8; 32];
        let n = json_core::get(&settings, "/slave/dob/bandwidth_hz", &mut buf).unwrap();
        let hz: f64 = core::str::from_utf8(&buf[..n]).unwrap().parse().unwrap();
        assert!(close(hz, 150.0));
        let mut changed = settings;
        json_core::set(&mut changed, "/slave/dob/bandwidth_hz", b"120").unwrap();
        assert_eq!(changed.slave.dob.bandwidth_hz, 120.0);
        // Validation is the configuration's: a negative mass is refused by name.
        json_core::set(&mut changed, "/slave/dob/nominal_mass_kg", b"-1").unwrap();
        let e = <DeltaSlave<f32> as LinkMachine>::coefficients(&changed, 1e-4).unwrap_err();
        assert_eq!(e.field(), "nominal_mass_kg");
        assert!(AxisLaw::<f32>::new(&settings.config(), 1e-4).is_ok());
    }
}
