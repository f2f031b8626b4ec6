//! ARROW's dimensions and workspace (SI, checked by [`ArrowConfig::check`]).

use crate::error::{in_range, positive, ConfigContext, ConfigError};
use core::f64::consts::PI;

/// One actuator and its arm (A fig. 6–9).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArmConfig {
    /// Arm length L_i, m.
    pub length_m: f64,
    /// The rail's y (the base wall), m.
    pub rail_y_m: f64,
    /// The rail's height z_i, m.
    pub rail_z_m: f64,
    /// D_i in the plate's frame (origin at the tool centre point P), m.
    pub plate_m: [f64; 3],
    /// Offset |B_iC_i| = r_i along the arm, m.
    pub bc_m: f64,
    /// Offset |C_iD_i| = r′_i across the arm, m.
    pub cd_m: f64,
}

/// The workspace of A eq. 25.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowWorkspace {
    /// Every actuator within ±this along its rail, m.
    pub q_half_m: f64,
    /// y of the workspace's centre y0 (the turntable's axis passes through (0, y0, 0)),
    /// m.
    pub y0_m: f64,
    /// y − y0 within ±this, m.
    pub y_half_m: f64,
    /// z within ±this, m.
    pub z_half_m: f64,
    /// θz within ±this, rad.
    pub theta_z_half_rad: f64,
    /// θx (the turntable) within ±this, rad.
    pub theta_x_half_rad: f64,
}

/// The whole parallel module.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowConfig {
    /// Actuators 1 … 6 in A's numbering.
    pub arms: [ArmConfig; 6],
    /// Eq. 25.
    pub workspace: ArrowWorkspace,
}

/// Rail spacing L_z of the preset (A fig. 7), m.
const RAIL_SPACING_M: f64 = 0.25;
/// Height a of the simple arms' plate points above / below P, m (eq. 1: a < L_z).
const PLATE_HEIGHT_M: f64 = 0.10;
/// Distance of the parallelograms' plate point from P towards the rails, m.
const PLATE_DEPTH_M: f64 = 0.05;

const fn simple(rail_z_m: f64, plate_z_m: f64) -> ArmConfig {
    ArmConfig {
        length_m: 0.96,
        rail_y_m: 0.0,
        rail_z_m,
        plate_m: [0.0, 0.0, plate_z_m],
        bc_m: 0.05,
        cd_m: 0.04,
    }
}

const fn parallelogram() -> ArmConfig {
    ArmConfig {
        length_m: 0.61,
        rail_y_m: 0.0,
        rail_z_m: 0.0,
        plate_m: [0.0, -PLATE_DEPTH_M, 0.0],
        bc_m: 0.05,
        cd_m: 0.04,
    }
}

impl ArrowConfig {
    /// ARROW with the arm lengths of A table 1 (0.96 m simple, 0.61 m parallelogram)
    /// and eq. 25's workspace (q ±1.5 m, y − y0 ±0.15 m, z ±0.15 m, θz and θx ±45°).
    /// The print gives no other dimension; chosen here:
    /// - rails in the wall y = 0, L_z = 0.25 m apart (top z = +0.25: actuators 1, 2;
    ///   middle z = 0: 3, 4; bottom z = −0.25: 5, 6), so that no arm slopes by more
    ///   than 18° over eq. 25's ±0.15 m of z (far from the vertical arm of eq. 30);
    /// - the simple arms' plate points a = 0.10 m above and below P (eq. 1: a < L_z),
    ///   the parallelograms' 0.05 m from P towards the rails;
    /// - joint offsets r = 0.05 m and r′ = 0.04 m (revolute joints of a 0.1 m plate);
    /// - y0 = 0.50 m: at the workspace's far edge (y = 0.65 m, θz = ±45°) the
    ///   parallelograms' reaches still have |e_x·m|/|m| ≥ 0.28 (eq. 30), and at the
    ///   near edge (y = 0.35 m) the simple arms reach at most 0.95 m along the rails,
    ///   so that a plate x within ±0.5 m keeps every actuator within ±1.5 m.
    ///
    /// Over eq. 25's workspace (x ±0.5 m) the sines of [`super::SingularityDistance`]
    /// stay above 0.28 (eq. 30, across the rails), 0.94 (eq. 30–31, vertical arm) and
    /// 0.15 (eq. 32, the plate).
    pub const ARROW: Self = Self {
        arms: [
            simple(RAIL_SPACING_M, PLATE_HEIGHT_M),
            simple(RAIL_SPACING_M, PLATE_HEIGHT_M),
            parallelogram(),
            parallelogram(),
            simple(-RAIL_SPACING_M, -PLATE_HEIGHT_M),
            simple(-RAIL_SPACING_M, -PLATE_HEIGHT_M),
        ],
        workspace: ArrowWorkspace {
            q_half_m: 1.5,
            y0_m: 0.50,
            y_half_m: 0.15,
            z_half_m: 0.15,
            theta_z_half_rad: PI / 4.0,
            theta_x_half_rad: PI / 4.0,
        },
    };

    /// Every length finite and positive (offsets may be zero), positions finite, the
    /// pairs of the assembly (1–2, 3–4, 5–6) sharing their plate point (eq. 2:
    /// x_di ≡ x_di+1), the workspace's half-widths positive and its angles within
    /// ±90°.
    pub fn check(&self) -> Result<(), ConfigError> {
        for (i, arm) in self.arms.iter().enumerate() {
            let arm_ok = || -> Result<(), ConfigError> {
                positive("length_m", arm.length_m)?;
                in_range("rail_y_m", arm.rail_y_m, -1e3, 1e3)?;
                in_range("rail_z_m", arm.rail_z_m, -1e3, 1e3)?;
                for v in arm.plate_m {
                    in_range("plate_m", v, -1e3, 1e3)?;
                }
                in_range("bc_m", arm.bc_m, 0.0, 1e3)?;
                in_range("cd_m", arm.cd_m, 0.0, 1e3)?;
                Ok(())
            };
            arm_ok().at(i).within("arms")?;
        }
        for (i, pair) in self.arms.chunks_exact(2).enumerate() {
            if let [a, b] = pair {
                if a.plate_m != b.plate_m {
                    return Err(ConfigError::out_of_range("plate_m")
                        .at(2 * i + 1)
                        .within("arms"));
                }
            }
        }
        let w = &self.workspace;
        (|| -> Result<(), ConfigError> {
            positive("q_half_m", w.q_half_m)?;
            in_range("y0_m", w.y0_m, -1e3, 1e3)?;
            positive("y_half_m", w.y_half_m)?;
            positive("z_half_m", w.z_half_m)?;
            in_range("theta_z_half_rad", w.theta_z_half_rad, 1e-9, PI / 2.0)?;
            in_range("theta_x_half_rad", w.theta_x_half_rad, 1e-9, PI / 2.0)?;
            Ok(())
        })()
        .within("workspace")
    }
}
