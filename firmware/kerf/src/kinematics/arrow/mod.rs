//! ARROW, the redundantly actuated 5-DOF parallel machining robot (docs/equations.md
//! §7, A 2.2): a parallel module of six linear actuators that sets the
//! travelling plate in x, y, z and θz (3T-1R), and a turntable that adds θx.
//!
//! # Geometry
//!
//! The actuators run along x on three rails in the base's wall y = const, one pair per
//! rail, L_z apart in z (A fig. 7): actuators 1, 2 (simple arms) on the top rail,
//! 3, 4 (parallelogram arms) on the middle one, 5, 6 (simple arms) at the bottom.
//! Actuator i is at A_i = (q_i, y_i, z_i). Its arm A_iB_i (length L_i) ends in a
//! revolute joint B_i; the horizontal plane of B_i, C_i and D_i holds the joint
//! offsets |B_iC_i| = r_i (along the arm's horizontal direction: A_i†, B_i, C_i are
//! collinear) and |C_iD_i| = r′_i (perpendicular to it), so (A eq. 4–5)
//!
//!   |A_i†D_i|² = (√(L_i² − (z_i − z_di)²) + r_i)² + r′_i²,
//!
//! with D_i = P + R(θz) D_i^plat (eq. 3) on the plate and A_i† = (q_i, y_i, z_di). In the
//! assembly mode of eq. 2 (the odd actuator of each pair on the −x side of its D, the
//! even one on the +x side) the inverse model is eq. 7:
//!
//!   q_i = x_di + (−1)^i √(|A_i†D_i|² − (y_i − y_di)²).
//!
//! The plate points follow A 2.2: D_1 = D_2 and D_5 = D_6 sit at distance a above and
//! below the plate's centre (on its z axis: the simple arms set position and height,
//! and they alone cannot turn the plate), D_3 = D_4 on the plate's y axis, between the
//! parallelogram's two revolute joints: the parallelograms turn the plate about z
//! (A 2.1). Eq. 1's assembly condition L_z ≠ a keeps the top and bottom simple arms
//! from both lying horizontal at once (eq. 34).
//!
//! # Dimensions
//!
//! A table 1 gives only the arm lengths: 0.96 m (simple) and 0.61 m (parallelogram).
//! [`ArrowConfig::ARROW`] chooses the rest so that eq. 25's workspace is reachable
//! everywhere with margins to the singularities of eq. 30–32, and states each choice.
//!
//! # Turntable
//!
//! Two motors turn the table about x in opposite senses (eq. 8): q_T1 = θx, q_T2 = −θx.

mod config;
mod dynamics;
mod forward;
#[cfg(test)]
mod tests;
mod velocity;

pub use config::{ArmConfig, ArrowConfig, ArrowWorkspace};
pub use dynamics::{ArrowDynamics, ArrowMasses, Feedforward};
pub use forward::ForwardConfig;
pub use velocity::{Differential, ForwardJacobian, InverseJacobian, SingularityDistance};

use crate::error::ConfigError;
use crate::scalar::{lit, Float};
use core::cmp::Ordering;
use nalgebra::{SVector, Vector3, Vector4};

/// Actuators of the parallel module.
pub const ACTUATORS: usize = 6;

/// One value per actuator of the parallel module, in actuator order: joint positions
/// q_1 … q_6 (m), their errors, or the actuator forces (N).
pub type ActuatorVector<T> = SVector<T, ACTUATORS>;

/// The plate's pose X_PM = (x, y, z, θz): m, m, m, rad.
pub type Pose<T> = Vector4<T>;

/// Why a kinematic map has no answer.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ArrowError {
    /// An input was NaN or infinite.
    NotFinite,
    /// Arm `i` (`0..6`) cannot reach its plate point: its height difference exceeds
    /// its length, or the horizontal distance its offsets leave is shorter than the
    /// rail's distance (a negative radicand of eq. 5 or 7).
    OutOfReach(u8),
    /// Eq. 30: arm `i`'s reach A_iD_i is (nearly) perpendicular to the rails
    /// (e_x·m_i = 0): its actuator no longer moves the plate along x.
    ArmAcrossRails(u8),
    /// Eq. 30–31: arm `i` is (nearly) vertical (e_z·(L_i × μ_i) = 0).
    ArmVertical(u8),
    /// Eq. 32: J_X loses rank: the parallelograms' reaches and the plate's arm r_c lie
    /// (nearly) in one plane with e_z.
    PlateSingular,
    /// A pose or joint outside eq. 25's workspace: the axis (0 x/q, 1 y, 2 z, 3 θz,
    /// 4 θx).
    OutsideWorkspace(u8),
    /// The forward solve did not converge within its iterations.
    NotConverged,
    /// The forward solve converged to a pose whose joints differ from the measured
    /// ones by more than the tolerance: the six measurements do not fit one rigid
    /// pose (a slipped encoder, a wrong calibration).
    InconsistentJoints,
}

/// Below this sine the maps report the singularities of eq. 30–32 (as the delta's:
/// at 1e-3 the Jacobian already amplifies velocities a thousandfold).
pub(crate) const SINGULAR_SINE: f64 = 1e-3;

/// Per-arm constants in the scalar `T`.
#[derive(Copy, Clone, Debug, PartialEq)]
struct Arm<T> {
    length_m: T,
    rail_y_m: T,
    rail_z_m: T,
    plate_m: Vector3<T>,
    bc_m: T,
    cd_m: T,
    /// (−1)^i of eq. 7 (i = 1..6): −1 for the odd actuators, +1 for the even ones.
    side: T,
}

/// The geometry of one ARROW in the scalar `T`, built from a checked [`ArrowConfig`].
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowGeometry<T> {
    arms: [Arm<T>; ACTUATORS],
    workspace: ArrowWorkspace,
    singular_sine: T,
}

/// One arm's closure at a pose: the points and vectors of eq. 4–13.
#[derive(Copy, Clone, Debug, PartialEq)]
struct ArmClosure<T> {
    /// Actuator position q_i, m.
    q_m: T,
    /// m_i = A_iD_i.
    reach: Vector3<T>,
    /// L_i = A_iB_i.
    arm: Vector3<T>,
    /// n_i = A_iC_i.
    to_c: Vector3<T>,
    /// μ_i: the unit axis of the arm's second rotation (eq. 12).
    mu: Vector3<T>,
    /// R(θz) D_i^plat: the plate point relative to P, rotated.
    plate: Vector3<T>,
    /// √(L_i² − Δz²): the arm's horizontal length.
    horizontal_m: T,
}

impl<T: Float> ArrowGeometry<T> {
    /// Coefficients of a checked configuration.
    pub fn new(config: &ArrowConfig) -> Result<Self, ConfigError> {
        config.check()?;
        let mut index = 0;
        let arms = config.arms.map(|a| {
            index += 1;
            Arm {
                length_m: lit(a.length_m),
                rail_y_m: lit(a.rail_y_m),
                rail_z_m: lit(a.rail_z_m),
                plate_m: Vector3::new(lit(a.plate_m[0]), lit(a.plate_m[1]), lit(a.plate_m[2])),
                bc_m: lit(a.bc_m),
                cd_m: lit(a.cd_m),
                side: if index % 2 == 1 { -T::one() } else { T::one() },
            }
        });
        Ok(Self {
            arms,
            workspace: config.workspace,
            singular_sine: lit(SINGULAR_SINE),
        })
    }

    /// The workspace the geometry was built with.
    pub fn workspace(&self) -> &ArrowWorkspace {
        &self.workspace
    }

    /// Inverse kinematics of the parallel module (eq. 3–7).
    pub fn inverse(&self, pose: &Pose<T>) -> Result<ActuatorVector<T>, ArrowError> {
        let turn = Self::turn(pose)?;
        let mut q = ActuatorVector::zeros();
        // A bounded index range rather than `enumerate` (no counter overflow check).
        for (i, (arm, out)) in (0..self.arms.len()).zip(self.arms.iter().zip(q.iter_mut())) {
            *out = Self::closure(arm, pose, turn, i)?.q_m;
        }
        Ok(q)
    }

    /// (sin θz, cos θz) of a finite `pose`: eq. 3's R(θz), shared by the six arms'
    /// closures (and the plate's mass matrix), computed once per pose.
    fn turn(pose: &Pose<T>) -> Result<(T, T), ArrowError> {
        if pose.as_slice().iter().all(|v| v.is_finite()) {
            Ok(pose.w.fsin_cos())
        } else {
            Err(ArrowError::NotFinite)
        }
    }

    /// The closure of arm `i` at `pose`, whose θz has the sine and cosine `turn`
    /// (from [`Self::turn`]): eq. 3–7 and the vectors of eq. 13.
    fn closure(
        arm: &Arm<T>,
        pose: &Pose<T>,
        turn: (T, T),
        i: usize,
    ) -> Result<ArmClosure<T>, ArrowError> {
        let index = i as u8;
        let (s, c) = turn;
        let p = &arm.plate_m;
        let plate = Vector3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z);
        let d = Vector3::new(pose.x, pose.y, pose.z) + plate;
        // Eq. 5: the arm's horizontal length.
        let dz = d.z - arm.rail_z_m;
        let horizontal_sq = arm.length_m * arm.length_m - dz * dz;
        if !matches!(
            horizontal_sq.partial_cmp(&T::zero()),
            Some(Ordering::Greater)
        ) {
            return Err(ArrowError::OutOfReach(index));
        }
        let horizontal = horizontal_sq.fsqrt();
        // Eq. 4: |A†D|², then eq. 7.
        let along = horizontal + arm.bc_m;
        let reach_sq = along * along + arm.cd_m * arm.cd_m;
        let dy = arm.rail_y_m - d.y;
        let across_sq = reach_sq - dy * dy;
        if !matches!(
            across_sq.partial_cmp(&T::zero()),
            Some(Ordering::Greater | Ordering::Equal)
        ) {
            return Err(ArrowError::OutOfReach(index));
        }
        let q = d.x + arm.side * across_sq.fsqrt();
        // The horizontal direction u of A†→C: A†D turned by β towards its side, with
        // cos β = |A†C| / |A†D| and sin β = r′ / |A†D| (the right angle at C, eq. 4).
        let a_dagger = Vector3::new(q, arm.rail_y_m, d.z);
        let to_d = d - a_dagger;
        let reach = reach_sq.fsqrt();
        let (cos_b, sin_b) = (along / reach, arm.cd_m / reach);
        let (ux, uy) = (to_d.x / reach, to_d.y / reach);
        // C–D offset on the left of the arm seen from above (a choice of the geometry;
        // the other side mirrors μ and changes none of eq. 7's joint positions).
        let u = Vector3::new(ux * cos_b + uy * sin_b, uy * cos_b - ux * sin_b, T::zero());
        let a = Vector3::new(q, arm.rail_y_m, arm.rail_z_m);
        let b = a_dagger + u * horizontal;
        let arm_vec = b - a;
        let to_c = arm_vec + u * arm.bc_m;
        // μ = (r × e_z)/|r × e_z| with r = B→C ∥ u (unit, horizontal): (u_y, −u_x, 0).
        let mu = Vector3::new(u.y, -u.x, T::zero());
        Ok(ArmClosure {
            q_m: q,
            reach: d - a,
            arm: arm_vec,
            to_c,
            mu,
            plate,
            horizontal_m: horizontal,
        })
    }

    /// The turntable's two motor angles for θx (eq. 8), rad.
    pub fn turntable(theta_x_rad: T) -> [T; 2] {
        [theta_x_rad, -theta_x_rad]
    }

    /// Checks a pose, the table angle and the joints it needs against eq. 25.
    pub fn check_workspace(&self, pose: &Pose<T>, theta_x_rad: T) -> Result<(), ArrowError> {
        let w = &self.workspace;
        let within = |v: T, lo: f64, hi: f64| v >= lit(lo) && v <= lit(hi);
        let axes = [
            (pose.y - lit(w.y0_m), w.y_half_m),
            (pose.z, w.z_half_m),
            (pose.w, w.theta_z_half_rad),
            (theta_x_rad, w.theta_x_half_rad),
        ];
        for (k, (v, half)) in axes.into_iter().enumerate() {
            if !v.is_finite() {
                return Err(ArrowError::NotFinite);
            }
            if !within(v, -half, half) {
                return Err(ArrowError::OutsideWorkspace(k as u8 + 1));
            }
        }
        let q = self.inverse(pose)?;
        if q.iter().all(|&v| within(v, -w.q_half_m, w.q_half_m)) {
            Ok(())
        } else {
            Err(ArrowError::OutsideWorkspace(0))
        }
    }
}
