//! Plain-data configuration of a linear delta and its presets.

use super::{Root, DEG};

/// Plain-data description of one actuator (all lengths in metres, angles in radians).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ActuatorConfig {
    /// Azimuth θi of the actuator's vertical plane about the base z axis.
    pub theta_rad: f64,
    /// Attack angle αi between the rail and the base plane (0 horizontal, π/2 vertical).
    pub alpha_rad: f64,
    /// Arm length li (joint centre to joint centre).
    pub arm_m: f64,
    /// Base circumradius rb to the rail's origin (where di = 0).
    pub base_radius_m: f64,
    /// Effector circumradius re to the arm's effector joint.
    pub effector_radius_m: f64,
    /// Smallest allowed displacement di.
    pub travel_min_m: f64,
    /// Largest allowed displacement di.
    pub travel_max_m: f64,
    /// Inverse-kinematics branch (sign of fdi) of this actuator's working mode.
    pub ik_root: Root,
}

/// Plain-data description of a linear delta robot.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DeltaConfig {
    /// The three actuators.
    pub actuators: [ActuatorConfig; 3],
    /// Forward-kinematics root ([`Root::Plus`] = larger z).
    pub fk_root: Root,
}

/// The azimuths of a symmetric delta, 90°/210°/330° (T fig. 6.2 B).
pub const SYMMETRIC_THETA_RAD: [f64; 3] = [90.0 * DEG, 210.0 * DEG, 330.0 * DEG];

const fn symmetric(
    alpha_rad: f64,
    arm_m: f64,
    base_radius_m: f64,
    effector_radius_m: f64,
    travel_m: (f64, f64),
    fk_root: Root,
    ik_root: Root,
) -> DeltaConfig {
    let base = ActuatorConfig {
        theta_rad: 0.0,
        alpha_rad,
        arm_m,
        base_radius_m,
        effector_radius_m,
        travel_min_m: travel_m.0,
        travel_max_m: travel_m.1,
        ik_root,
    };
    DeltaConfig {
        actuators: [
            ActuatorConfig {
                theta_rad: SYMMETRIC_THETA_RAD[0],
                ..base
            },
            ActuatorConfig {
                theta_rad: SYMMETRIC_THETA_RAD[1],
                ..base
            },
            ActuatorConfig {
                theta_rad: SYMMETRIC_THETA_RAD[2],
                ..base
            },
        ],
        fk_root,
    }
}

impl DeltaConfig {
    /// Horizontal master (T 7.1.1: α = 0°, θ = 90°/210°/330°, LM2070 motors, 0.5 µm
    /// encoders). Dimensions are not printed; chosen for the LM2070 force scale:
    /// arms 150 mm, rb = 200 mm, re = 40 mm, travel 30–110 mm (80 mm stroke), T's
    /// frame (effector on +z, FK `Plus`, IK `Minus`).
    ///
    /// Workspace sampled on a 16³ grid of the travel box (cell centres, FK; test
    /// `workspace_extent_of_the_presets`): x −50.3…+50.3 mm, y −58.1…+43.9 mm,
    /// z 79.0…140.5 mm, 100 % of the grid assembles in the working mode.
    /// f32 vs f64 over that grid: FK ≤ 0.026 µm, IK ≤ 0.028 µm.
    pub const MASTER_HORIZONTAL: Self = symmetric(
        0.0,
        0.150,
        0.200,
        0.040,
        (0.030, 0.110),
        Root::Plus,
        Root::Minus,
    );

    /// Keops slave (T 7.1.2: α = 30°, LM1247 motors, Hall position). Dimensions chosen
    /// for a miniature robot: arms 70 mm, rb = 86 mm, re = 20 mm, travel 0–40 mm,
    /// T's frame (FK `Plus`, IK `Minus`).
    ///
    /// Workspace (same sampling): x −29.4…+29.4 mm, y −33.7…+31.5 mm, z 26.8…81.4 mm,
    /// 100 % of the grid assembles. f32 vs f64: FK ≤ 0.015 µm, IK ≤ 0.016 µm.
    pub const SLAVE_KEOPS: Self = symmetric(
        30.0 * DEG,
        0.070,
        0.086,
        0.020,
        (0.0, 0.040),
        Root::Plus,
        Root::Minus,
    );

    /// Vertical delta (T fig. 6.3 C: α = 90°) in the printer frame: z up, effector
    /// below the carriages, di = carriage height (FK `Minus`, IK `Plus`). Arms 150 mm,
    /// rb − re = 80 mm (rb = 110 mm, re = 30 mm), carriage travel 100–300 mm.
    ///
    /// Workspace (same sampling; a bounding box, the usable cylinder is smaller):
    /// x −80.2…+80.2 mm, y −69.9…+92.5 mm, z −20.6…+166.9 mm, 80 % of the grid
    /// assembles. f32 vs f64: FK ≤ 0.084 µm; IK ≤ 0.051 µm where |Jx⁻¹| ≤ 3 and up to
    /// 1.1 µm with nearly horizontal arms (the map's own gain on f32 rounding).
    pub const VERTICAL: Self = symmetric(
        90.0 * DEG,
        0.150,
        0.110,
        0.030,
        (0.100, 0.300),
        Root::Minus,
        Root::Plus,
    );

    /// A vertical delta printer described the way Klipper and Marlin do: towers at
    /// `tower_angle_rad` about z, each at horizontal distance `delta_radius_m` from the
    /// centre to the carriage joint minus the effector joint offset, diagonal rods
    /// `arm_m`, z up, di = carriage height above z = 0. The textbook inverse is then
    /// carriage = z + √(l² − (x − xt)² − (y − yt)²) with (xt, yt) = R (cθ, sθ).
    ///
    /// Mapping: α = 90°, rb − re = R (stored as rb = R, re = 0), FK `Minus`, IK `Plus`.
    pub fn printer(
        delta_radius_m: f64,
        tower_angle_rad: [f64; 3],
        arm_m: [f64; 3],
        carriage_travel_m: (f64, f64),
    ) -> Self {
        let one = |(theta_rad, arm_m): (f64, f64)| ActuatorConfig {
            theta_rad,
            alpha_rad: 90.0 * DEG,
            arm_m,
            base_radius_m: delta_radius_m,
            effector_radius_m: 0.0,
            travel_min_m: carriage_travel_m.0,
            travel_max_m: carriage_travel_m.1,
            ik_root: Root::Plus,
        };
        let [t1, t2, t3] = tower_angle_rad;
        let [l1, l2, l3] = arm_m;
        Self {
            actuators: [one((t1, l1)), one((t2, l2)), one((t3, l3))],
            fk_root: Root::Minus,
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use crate::kinematics::delta::test_util::*;
    use crate::kinematics::delta::*;
    use proptest::prelude::*;
    use std::println;

    proptest! {
        /// A printer configured as Klipper / Marlin describe one (tower angles, delta
        /// radius, per-tower rod lengths, z up, carriage height) has the textbook
        /// inverse carriage = z + √(l² − (x − xt)² − (y − yt)²).
        #[test]
        fn printer_mapping_matches_the_textbook_inverse(
            radius in 0.06f64..0.15,
            trims in proptest::array::uniform3(-2.0f64..2.0),
            arms in proptest::array::uniform3(0.2f64..0.3),
            pose in proptest::array::uniform3(-0.06f64..0.06),
        ) {
            let angles = [210.0 + trims[0], 330.0 + trims[1], 90.0 + trims[2]].map(|a| a * DEG);
            let c = DeltaConfig::printer(radius, angles, arms, (0.0, 1.0));
            let g = geometry::<f64>(&c);
            let p = V::new(pose[0], pose[1], pose[2] + 0.1);
            let textbook = V::from_fn(|i, _| {
                let (xt, yt) = (radius * angles[i].cos(), radius * angles[i].sin());
                p.z + (arms[i].powi(2) - (p.x - xt).powi(2) - (p.y - yt).powi(2)).sqrt()
            });
            match g.inverse(&p) {
                Ok(q) => {
                    prop_assert!((q - textbook).amax() < 1e-12, "{} vs {}", q, textbook);
                    let back = g.forward(&q).unwrap();
                    prop_assert!((back - p).amax() < ROUND_TRIP_M);
                }
                // Out of reach exactly where the textbook radicand is negative.
                Err(KinematicsError::OutOfReach(i)) => prop_assert!(textbook[i as usize].is_nan()),
                Err(e) => prop_assert!(false, "{:?}", e),
            }
        }
    }

    #[test]
    fn workspace_extent_of_the_presets() {
        for (name, c) in all() {
            let grid = joint_grid(&c, 16);
            let ws = workspace(&c, 16);
            let mut lo = V::repeat(f64::INFINITY);
            let mut hi = V::repeat(f64::NEG_INFINITY);
            for (_, p) in &ws {
                lo = lo.inf(p);
                hi = hi.sup(p);
            }
            println!(
                "{name}: x {:.1}..{:.1} mm, y {:.1}..{:.1} mm, z {:.1}..{:.1} mm, {:.0} % of the joint box",
                lo.x * 1e3, hi.x * 1e3, lo.y * 1e3, hi.y * 1e3, lo.z * 1e3, hi.z * 1e3,
                100.0 * ws.len() as f64 / grid.len() as f64
            );
            // Every sampled pose is reachable by the reachability check.
            let g = geometry::<f64>(&c);
            assert!(ws.iter().all(|(_, p)| g.reachable(p)), "{name}");
            assert!(hi.z > lo.z && hi.x > lo.x && hi.y > lo.y, "{name}");
        }
    }
}
