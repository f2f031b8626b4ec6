//! The Keops slave as it is flashed: what the board image, the QEMU images, the
//! simulator and the host tool all take from here rather than each writing its own
//! copy — the job buffer of the host link, how often telemetry is reported, how an
//! uploaded contour is cut (height, motion, laser), and the nominal Hall decoders
//! installed as the stored calibration at power-up.

use super::link::ContourDefaults;
use super::{ContourCurve, ContourLaw, ContourPlan, DeltaSlaveConfig};
use crate::app::axis::HallAxis;
use crate::control::laser::LaserMode;
use crate::error::ConfigError;
use crate::scalar::Float;
use crate::trajectory::tangential::SpeedRampConfig;

/// Bytes of an uploaded job the machine holds: a 30-harmonic EFD job file is 504.
pub const LINK_JOB_BYTES: usize = 1024;

/// The supervisor reports telemetry every this many control periods (1 kHz at the
/// 10 kHz period); the host link decimates further to the rate the host asks for.
pub const TELEMETRY_DECIMATION: u32 = 10;

/// Height of the cutting plane, m.
pub const CUT_HEIGHT_M: f64 = 0.050;

/// How a contour is cut: 8 mm/s, with start and stop ramps of 0.1 m/s² and 10 m/s³.
/// `ts_s` is the Keops period; a job is planned at its machine's period.
pub const CUT_MOTION: SpeedRampConfig = SpeedRampConfig {
    speed_m_s: 8e-3,
    accel_m_s2: 0.1,
    jerk_m_s3: 10.0,
    ts_s: 1e-4,
};

/// Laser power at the cutting speed, W: half the 20 W source of the Keops cell,
/// held at constant energy per length through the ramps.
pub const LASER_POWER_W: f64 = 10.0;

/// How far from a corner of a program of moves the circle that sets the corner's
/// speed passes, m: 10 µm (grbl's default junction deviation). At the ramps' 0.1 m/s²
/// a square corner is passed at 1.6 mm/s.
pub const JUNCTION_DEVIATION_M: f64 = 10e-6;

/// Laps of an uploaded contour: one, the part.
pub const JOB_LAPS: f64 = 1.0;

/// Time of the joint-space approach from rest to a contour's start point, s.
pub const APPROACH_S: f64 = 0.3;

/// How an uploaded contour is cut on `machine`: at [`CUT_HEIGHT_M`] around the
/// workspace axis, with [`CUT_MOTION`], [`LASER_POWER_W`] and the contouring law,
/// `laps` laps.
pub fn contour_defaults(machine: &DeltaSlaveConfig, laps: f64) -> ContourDefaults {
    ContourDefaults {
        machine: *machine,
        centre_m: [0.0, 0.0, CUT_HEIGHT_M],
        speed_m_s: CUT_MOTION.speed_m_s,
        accel_m_s2: CUT_MOTION.accel_m_s2,
        jerk_m_s3: CUT_MOTION.jerk_m_s3,
        approach_s: APPROACH_S,
        laps,
        junction_deviation_m: JUNCTION_DEVIATION_M,
        law: ContourLaw::Contouring,
        laser_power_w: LASER_POWER_W,
    }
}

impl ContourDefaults {
    /// What the beam does along a part that leaves it to the machine: the energy per
    /// length its power cuts at its speed, whatever the part's speed.
    pub fn laser(&self) -> LaserMode {
        LaserMode::constant_energy_of(self.laser_power_w, self.speed_m_s)
    }

    /// The plan of cutting `curve` with these defaults.
    pub fn plan<'a>(&self, curve: ContourCurve<'a>) -> ContourPlan<'a> {
        ContourPlan {
            curve,
            centre_m: self.centre_m,
            speed_m_s: self.speed_m_s,
            accel_m_s2: self.accel_m_s2,
            jerk_m_s3: self.jerk_m_s3,
            approach_s: self.approach_s,
            law: self.law,
            laser: self.laser(),
        }
    }
}

/// The nominal Hall decoders of `machine`'s three carriages, in the scalar `T`: what a
/// machine installs as its stored calibration at power-up until a calibration run
/// replaces them.
pub fn nominal_calibration<T: Float>(
    machine: &DeltaSlaveConfig,
) -> Result<[HallAxis<T>; 3], ConfigError> {
    let [a, b, c] = &machine.joints.hall;
    Ok([HallAxis::new(a)?, HallAxis::new(b)?, HallAxis::new(c)?])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::job::{write_efd, JobFile};
    use crate::machines::delta_slave::CONTOUR_HARMONICS;

    /// The largest contour the machine cuts, written as a job file, fits the link's
    /// job buffer.
    #[test]
    fn the_job_buffer_holds_a_contour_of_every_harmonic() {
        let coefficients = [[1e-3, 0.0, 0.0, 1e-3]; CONTOUR_HARMONICS];
        let mut file = [0u8; 2 * LINK_JOB_BYTES];
        let n = write_efd([0.0, 0.0], &coefficients, &mut file).unwrap();
        assert!(n <= LINK_JOB_BYTES, "{n} bytes");
        let read = JobFile::read(&file[..n]).unwrap();
        assert_eq!(read.count(), CONTOUR_HARMONICS);
    }

    /// The stored calibration at power-up decodes as each carriage's own nominal
    /// decoder does, in order.
    #[test]
    fn the_nominal_calibration_is_each_carriages_decoder() {
        let mut machine = DeltaSlaveConfig::KEOPS;
        machine.joints.hall[1].pitch_m *= 2.0;
        let stored = nominal_calibration::<f64>(&machine).unwrap();
        for (axis, hall) in stored.iter().zip(&machine.joints.hall) {
            assert_eq!(*axis, HallAxis::new(hall).unwrap());
        }
        assert_ne!(stored[0], stored[1]);
        machine.joints.hall[2].pitch_m = f64::NAN;
        assert!(nominal_calibration::<f64>(&machine).is_err());
    }

    /// A contour is planned with the defaults' motion, law and laser, and the cut
    /// starts at the cutting height.
    #[test]
    fn the_defaults_plan_the_cut_they_describe() {
        let defaults = contour_defaults(&DeltaSlaveConfig::KEOPS, JOB_LAPS);
        let efd = crate::trajectory::efd::Efd::<f64, CONTOUR_HARMONICS>::from_coefficients(
            [0.0, 0.0],
            &[[4e-3, 0.0, 0.0, 4e-3]],
        )
        .unwrap();
        let plan = defaults.plan(ContourCurve::Closed {
            efd: &efd,
            theta0_rad: 0.0,
            laps: JOB_LAPS,
        });
        assert_eq!(plan.centre_m, [0.0, 0.0, CUT_HEIGHT_M]);
        assert_eq!(plan.speed_m_s, CUT_MOTION.speed_m_s);
        assert_eq!(plan.jerk_m_s3, CUT_MOTION.jerk_m_s3);
        assert_eq!(plan.law, ContourLaw::Contouring);
        assert_eq!(
            plan.laser,
            LaserMode::constant_energy_of(LASER_POWER_W, CUT_MOTION.speed_m_s)
        );
    }
}
