//! The Keops slave on the host link ([`crate::app::host_link`]): its settings tree,
//! how an uploaded EFD job file becomes a contour job, and its telemetry and faults on
//! the wire.
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
    DeltaTelemetry, CONTOUR_HARMONICS,
};
use crate::app::axis::{AxisConfig, AxisLaw};
use crate::app::host_link::LinkMachine;
use crate::app::joints::JobError;
use crate::codec::job::JobFile;
use crate::codec::link::{TelemetrySample, JOB_NOT_AT_REST};
use crate::control::dob::DobConfig;
use crate::control::pd::PdConfig;
use crate::error::ConfigError;
use crate::scalar::{to_f64, Float};
use crate::sensing::velocity::TrackingObserverConfig;
use crate::trajectory::efd::Efd;
use core::f64::consts::TAU;
use miniconf::Tree;

/// The PD's settings.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct PdSettings {
    /// Bandwidth of the critically damped error dynamics, Hz.
    pub bandwidth_hz: f64,
}

/// The disturbance observer's settings.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct DobSettings {
    /// Observer bandwidth, Hz.
    pub bandwidth_hz: f64,
    /// Nominal moving mass An, kg.
    pub nominal_mass_kg: f64,
    /// Force saturation, N.
    pub force_limit_n: f64,
    /// Add the estimate to the command.
    pub compensate: bool,
}

/// The velocity observer's settings.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct VelocitySettings {
    /// Observer bandwidth, Hz.
    pub bandwidth_hz: f64,
}

/// One carriage law's settings.
#[derive(Tree, Copy, Clone, Debug, PartialEq)]
pub struct AxisSettings {
    /// PD.
    pub pd: PdSettings,
    /// Disturbance observer.
    pub dob: DobSettings,
    /// Velocity observer.
    pub velocity: VelocitySettings,
}

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
            slave: AxisSettings {
                pd: PdSettings {
                    bandwidth_hz: libm::sqrt(config.pd.kp_per_s2) / TAU,
                },
                dob: DobSettings {
                    bandwidth_hz: config.dob.bandwidth_rad_s / TAU,
                    nominal_mass_kg: config.dob.nominal_mass_kg,
                    force_limit_n: config.dob.force_limit_n,
                    compensate: config.dob.compensate,
                },
                velocity: VelocitySettings {
                    bandwidth_hz: config.velocity.bandwidth_rad_s / TAU,
                },
            },
        }
    }

    /// The configuration these settings describe (validated by [`AxisLaw::new`]).
    pub fn config(&self) -> AxisConfig {
        let s = &self.slave;
        AxisConfig {
            velocity: TrackingObserverConfig {
                bandwidth_rad_s: TAU * s.velocity.bandwidth_hz,
            },
            pd: PdConfig::critically_damped(TAU * s.pd.bandwidth_hz),
            dob: DobConfig {
                nominal_mass_kg: s.dob.nominal_mass_kg,
                bandwidth_rad_s: TAU * s.dob.bandwidth_hz,
                force_limit_n: s.dob.force_limit_n,
                compensate: s.dob.compensate,
            },
        }
    }
}

/// How an uploaded contour is cut: everything a job file does not carry.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ContourDefaults {
    /// The machine.
    pub machine: DeltaSlaveConfig,
    /// Where the contour's centre goes and the cutting height, m.
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
    /// A kind of job this machine does not cut (points, G-code).
    pub const KIND: u16 = 0x203;
}

/// What a fault code of [`LinkMachine::fault_code`] means, for a host to print
/// (`Event::Fault { code, .. }` of a `keops-slave`); the board's own codes
/// (`codec::link::BOARD_FAULT | cause`) are named as `codec::link::board_fault` names
/// them.
pub fn fault_reason(code: u16) -> &'static str {
    if let Some(reason) = crate::codec::link::board_fault::reason(code) {
        return reason;
    }
    match code {
        1 => "a carriage faulted (its Hall decoder or joint limits)",
        2 => "the kinematics could not be solved (joint references or measured effector)",
        3 => "the contour follower could not take a step",
        4 => "the effector left the contour by more than the contour-error limit",
        5 => "a carriage fell behind its reference by more than the following-error limit",
        6 => "a carriage's force stayed at its limit longer than allowed",
        7 => "an output (a carriage force, the laser duty) was not finite",
        _ => "unknown fault",
    }
}

/// What the detail of a fault (`Event::Fault { detail, .. }`) of a `keops-slave` is,
/// for the codes whose detail means something.
pub fn fault_detail(code: u16) -> Option<&'static str> {
    match code {
        5 => Some("carriage"),
        7 => Some("output (0-2 the carriage forces, 3 the laser duty)"),
        _ => crate::codec::link::board_fault::detail(code),
    }
}

/// What a job refusal code (`Refusal::Job`) of a `keops-slave` means: the planner's
/// ([`LinkMachine::job_error_code`]), the loader's ([`load_codes`]) or the link's
/// (`codec::link::JOB_FILE_UNREADABLE`, `JOB_KIND_MISMATCH`, `JOB_NOT_AT_REST`).
pub fn job_refusal_reason(code: u16) -> &'static str {
    use crate::codec::link::{JOB_FILE_UNREADABLE, JOB_KIND_MISMATCH, JOB_NOT_AT_REST};
    match code {
        1 => "the job has no move, or more moves than the machine holds",
        2 => "a point or duration is not finite, or a duration is not positive",
        3 => "a move leaves the workspace (reach, carriage travel or a singularity)",
        4 => "a move needs more carriage speed or acceleration than the limits allow",
        5 => "the job was planned for another machine",
        6 => "the approach from where the carriages are is too fast",
        7 => "a move lasts 2^32 control periods or more",
        8 => "the contour, its speed or its ramps are bad (too short, above the curvature limit)",
        9 => "a point of the contour leaves the workspace",
        10 => "a point of the contour needs more carriage speed or acceleration than allowed",
        11 => "the laser setting is out of range",
        load_codes::TOO_MANY_HARMONICS => "more harmonics than a contour job holds (30)",
        load_codes::BAD_CURVE => "the coefficients do not make a curve",
        load_codes::KIND => "this machine cuts contours (EFD jobs) only",
        JOB_FILE_UNREADABLE => "not a job file the firmware reads (magic, version, CRC)",
        JOB_KIND_MISMATCH => "the job file's kind differs from the announced one",
        JOB_NOT_AT_REST => "a carriage still moves; the job starts from rest",
        _ => "unknown refusal",
    }
}

impl<T: Float> LinkMachine for DeltaSlave<T> {
    type Settings = SlaveSettings;
    type JobContext = ContourDefaults;
    const NAME: &'static str = "keops-slave";

    fn coefficients(settings: &SlaveSettings, period_s: f64) -> Result<AxisLaw<T>, ConfigError> {
        AxisLaw::new(&settings.config(), period_s)
    }

    fn load_job(
        context: &ContourDefaults,
        file: &JobFile<'_>,
        job: &mut DeltaJob,
    ) -> Result<(), u16> {
        let JobFile::Efd { centre_m, .. } = file else {
            return Err(load_codes::KIND);
        };
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
        let plan = context.plan(ContourCurve::Closed {
            efd: &efd,
            theta0_rad: 0.0,
            laps: context.laps,
        });
        *job = DeltaJob::plan_contour(&context.machine, &plan)
            .map_err(|e| <Self as LinkMachine>::job_error_code(&e))?;
        Ok(())
    }

    fn job_error_code(error: &DeltaJobError) -> u16 {
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
        }
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

    fn sample(t: &DeltaTelemetry<T>) -> TelemetrySample {
        let f = |v: T| to_f64(v) as f32;
        let reference = t.effector_reference_m.map_or([0.0; 3], |r| r.map(f));
        let (position, error) = t.contour.map_or((reference, 0.0), |c| {
            (c.effector_m.map(f), f(c.contour_error_m))
        });
        TelemetrySample {
            position_m: position,
            reference_m: reference,
            error_m: error,
            force_n: t.joints.axes.map(|a| f(a.force_n)),
            laser_w: f(t.laser_power_w),
            ..TelemetrySample::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::axis::AxisLaw;
    use miniconf::json_core;
    use std::vec::Vec;

    #[test]
    fn every_fault_and_refusal_code_has_its_own_reason() {
        use crate::codec::link::{JOB_FILE_UNREADABLE, JOB_KIND_MISMATCH, JOB_NOT_AT_REST};
        let faults: Vec<&str> = (1..=6).map(fault_reason).collect();
        let jobs: Vec<&str> = (1..=11)
            .chain([
                load_codes::TOO_MANY_HARMONICS,
                load_codes::BAD_CURVE,
                load_codes::KIND,
                JOB_FILE_UNREADABLE,
                JOB_KIND_MISMATCH,
                JOB_NOT_AT_REST,
            ])
            .map(job_refusal_reason)
            .collect();
        for list in [&faults, &jobs] {
            for (i, a) in list.iter().enumerate() {
                assert!(!a.starts_with("unknown"), "{i}: {a}");
                assert!(list[..i].iter().all(|b| b != a), "{a} twice");
            }
        }
        assert_eq!(fault_reason(0), "unknown fault");
        assert_eq!(job_refusal_reason(12), "unknown refusal");
        // The board's own faults reach a host of this machine with their names.
        use crate::codec::link::{board_fault, BOARD_FAULT};
        let watchdog = fault_reason(BOARD_FAULT | board_fault::WATCHDOG);
        assert!(watchdog.contains("watchdog"), "{watchdog}");
        assert!(faults.iter().all(|f| *f != watchdog));
        // The codes the machine sends name the fault they stand for.
        type S = DeltaSlave<f32>;
        let (code, _) = S::fault_code(&DeltaFault::ContourError);
        assert!(fault_reason(code).contains("contour-error"));
        let (code, axis) = S::fault_code(&DeltaFault::FollowingError { axis: 2 });
        assert!(fault_reason(code).contains("following-error"));
        assert_eq!((fault_detail(code), axis), (Some("carriage"), 2));
        assert_eq!(
            fault_detail(S::fault_code(&DeltaFault::ContourError).0),
            None
        );
        let code = S::job_error_code(&DeltaJobError::OtherMachine);
        assert!(job_refusal_reason(code).contains("another machine"));
    }

    #[test]
    fn the_presets_settings_give_back_its_configuration_and_paths_address_them() {
        let config = AxisConfig::LM1247_SLAVE;
        let settings = SlaveSettings::of(&config);
        let back = settings.config();
        // The preset writes Kd to 7 significant digits.
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * b.abs();
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
