//! Contouring control in the frame moving with the path (docs/control.md §19, T 4.3.2),
//! extended to 3-D.
//!
//! The law regulates the task-space error e = x_ref − x in the frame of the reference
//! ([`ContourFrame`]): with e_O = J_O e it asks for
//!
//!   ë_O + K_O2 ė_O + K_O1 e_O = 0,
//!
//! K_O1 = diag(k_t, k_n, k_z) and K_O2 = diag(d_t, d_n, d_z), so that the normal
//! (contour) error, the tangential (timing) error and the vertical error each settle
//! with their own gains however the path turns. Differentiating e_O = J_O e twice and
//! solving for ë gives the task acceleration
//!
//!   ẍ_des = ẍ_ref + J_O⁻¹ (J̈_O + K_O2 J̇_O + K_O1 J_O) e + J_O⁻¹ (2 J̇_O + K_O2 J_O) ė,
//!
//! and the joints follow through q̈_des = Jx⁻¹ (ẍ_des − J̇x q̇). The print writes the same
//! law in joint space, q̈_des = q̈_ref + Kv (q̇_ref − q̇) + Kp (F(q_ref) − F(q)) with
//! Kv = Jx⁻¹J̇x + 2Jx⁻¹J_O⁻¹J̇_O Jx + Jx⁻¹J_O⁻¹K_O2 J_O Jx and
//! Kp = Jx⁻¹J_O⁻¹(J̈_O + K_O2 J̇_O + K_O1 J_O), with every Jacobian at the measured q: to
//! first order in the error the two agree; the task-space form is exact and needs no
//! joint reference. With equal gains on all three axes it is not the task-space PD:
//! the frame's rotation terms keep the *frame* errors decoupled on a curve.
//!
//! The output, a desired joint acceleration, goes to each joint's disturbance
//! observer (`control::dob`), like the joint PD's.
//!
//! Below the minimum planar speed the reference has no frame (at rest before and after
//! a contour, at a cusp). There the law holds the reference in the base frame with the
//! normal gains on x and y and the vertical gains on z: ẍ_des = ẍ_ref + K2 ė + K1 e.
//! When the frame appears the tangential gain takes over along the path; the command
//! changes by (k_n − k_t)·e_t + (d_n − d_t)·ė_t, small because the speed, and with it
//! the timing error, is small there.

use crate::control::pd::PdConfig;
use crate::error::{coefficient, positive, ConfigContext, ConfigError};
use crate::kinematics::contour_frame::{ContourFrame, ContourFrameError};
use crate::kinematics::delta::{DeltaGeometry, KinematicsError};
use crate::scalar::Float;
use nalgebra::Vector3;

/// Gains of the three frame directions and the slowest reference that still has a
/// frame.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ContouringConfig {
    /// Along the path (timing error).
    pub tangential: PdConfig,
    /// Across the path in the x–y plane (the contour error a cut shows).
    pub normal: PdConfig,
    /// Along z.
    pub vertical: PdConfig,
    /// Below this planar reference speed there is no frame: m/s.
    pub min_speed_m_s: f64,
}

impl ContouringConfig {
    /// Critically damped directions of the given bandwidths (rad/s).
    pub fn critically_damped(
        tangential_rad_s: f64,
        normal_rad_s: f64,
        vertical_rad_s: f64,
        min_speed_m_s: f64,
    ) -> Self {
        Self {
            tangential: PdConfig::critically_damped(tangential_rad_s),
            normal: PdConfig::critically_damped(normal_rad_s),
            vertical: PdConfig::critically_damped(vertical_rad_s),
            min_speed_m_s,
        }
    }
}

/// Why the law has no output this period.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ContouringError {
    /// The reference has no frame (too slow in x–y, or not finite).
    Frame(ContourFrameError),
    /// The measured joints have no forward kinematics or a singular Jacobian.
    Kinematics(KinematicsError),
}

/// The reference of one period in task space: position and its first three time
/// derivatives (the third turns the frame's turn rate).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TaskReference<T> {
    /// m.
    pub position: Vector3<T>,
    /// m/s.
    pub velocity: Vector3<T>,
    /// m/s².
    pub acceleration: Vector3<T>,
    /// m/s³.
    pub jerk: Vector3<T>,
}

/// What the law computed: the command, the errors it acted on and the measured task
/// state it used.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ContouringOutput<T> {
    /// Desired acceleration of each joint, m/s².
    pub joint_acceleration: Vector3<T>,
    /// The error e_O = J_O (x_ref − x): tangential, normal, vertical, m (x, y, z of
    /// the base frame where the reference has no frame).
    pub frame_error_m: Vector3<T>,
    /// The effector's measured position FK(q), m.
    pub position_m: Vector3<T>,
    /// The effector's measured velocity Jx q̇, m/s.
    pub velocity_m_s: Vector3<T>,
    /// The contour error: |normal error| with a frame, the planar error's length
    /// without one, m.
    pub contour_error_m: T,
}

/// The contouring law's coefficients (it keeps no state).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Contouring<T> {
    /// K_O1 diagonal (t, n, z), s⁻².
    kp: Vector3<T>,
    /// K_O2 diagonal (t, n, z), s⁻¹.
    kd: Vector3<T>,
    min_speed_m_s: T,
}

impl<T: Float> Contouring<T> {
    /// Validates the gains (finite, positive) and the minimum speed (positive).
    pub fn new(config: &ContouringConfig) -> Result<Self, ConfigError> {
        let gains = |pd: &PdConfig, name: &'static str| -> Result<(T, T), ConfigError> {
            let kp = coefficient("kp_per_s2", positive("kp_per_s2", pd.kp_per_s2)?);
            let kd = coefficient("kd_per_s", positive("kd_per_s", pd.kd_per_s)?);
            Ok((kp.within(name)?, kd.within(name)?))
        };
        let (kp_t, kd_t) = gains(&config.tangential, "tangential")?;
        let (kp_n, kd_n) = gains(&config.normal, "normal")?;
        let (kp_z, kd_z) = gains(&config.vertical, "vertical")?;
        let min_speed = positive("min_speed_m_s", config.min_speed_m_s)?;
        Ok(Self {
            kp: Vector3::new(kp_t, kp_n, kp_z),
            kd: Vector3::new(kd_t, kd_n, kd_z),
            min_speed_m_s: coefficient("min_speed_m_s", min_speed)?,
        })
    }

    /// Desired task acceleration (m/s²) and the frame error, from the reference and
    /// the measured task position and velocity. Errors only on a reference that is not
    /// finite; one too slow for a frame is held in the base frame (module docs).
    pub fn task_acceleration(
        &self,
        reference: &TaskReference<T>,
        position: &Vector3<T>,
        velocity: &Vector3<T>,
    ) -> Result<(Vector3<T>, Vector3<T>), ContourFrameError> {
        self.task_acceleration_framed(reference, position, velocity)
            .map(|(a, e, _)| (a, e))
    }

    /// The frame error of the measured `position` and the contour error
    /// ([`ContouringOutput::contour_error_m`]), for supervising another law.
    pub fn frame_error(
        &self,
        reference: &TaskReference<T>,
        position: &Vector3<T>,
    ) -> Result<(Vector3<T>, T), ContourFrameError> {
        let e = reference.position - position;
        Ok(match self.frame(reference)? {
            Some(frame) => {
                let e_o = frame.to_frame(&e);
                (e_o, contour_error(&e_o, true))
            }
            None => (e, contour_error(&e, false)),
        })
    }

    /// The reference's frame, `None` where it is too slow to have one.
    fn frame(
        &self,
        reference: &TaskReference<T>,
    ) -> Result<Option<ContourFrame<T>>, ContourFrameError> {
        match ContourFrame::new(
            &reference.velocity,
            &reference.acceleration,
            &reference.jerk,
            self.min_speed_m_s,
        ) {
            Ok(frame) => Ok(Some(frame)),
            Err(ContourFrameError::SpeedTooLow) => Ok(None),
            Err(error) => Err(error),
        }
    }

    /// [`Contouring::task_acceleration`] and whether the reference had a frame.
    fn task_acceleration_framed(
        &self,
        reference: &TaskReference<T>,
        position: &Vector3<T>,
        velocity: &Vector3<T>,
    ) -> Result<(Vector3<T>, Vector3<T>, bool), ContourFrameError> {
        let Some(frame) = self.frame(reference)? else {
            let (a, e) = self.hold(reference, position, velocity);
            return Ok((a, e, false));
        };
        let (w, w_dot) = (frame.turn_rate_rad_s(), frame.turn_accel_rad_s2());
        let e = reference.position - position;
        let e_dot = reference.velocity - velocity;
        // e_O, and R(ψ)ᵀ ė (not yet ė_O: that adds J̇_O e).
        let e_o = frame.to_frame(&e);
        let rotated_e_dot = frame.to_frame(&e_dot);
        let turned_e = ContourFrame::quarter_turn(&e_o);
        let turned_e_dot = ContourFrame::quarter_turn(&rotated_e_dot);
        let planar_e_o = Vector3::new(e_o.x, e_o.y, T::zero());
        // J̇_O e = ψ̇ R′ᵀe; J̈_O e = ψ̈ R′ᵀe − ψ̇² R ᵀe (planar part only).
        let jo_dot_e = turned_e * w;
        let jo_ddot_e = turned_e * w_dot - planar_e_o * (w * w);
        let jo_dot_e_dot = turned_e_dot * w;
        let two = T::one() + T::one();
        // J_O⁻¹ (J̈_O + K_O2 J̇_O + K_O1 J_O) e + J_O⁻¹ (2 J̇_O + K_O2 J_O) ė, inside the
        // frame first.
        let in_frame = jo_ddot_e
            + self.kd.component_mul(&jo_dot_e)
            + self.kp.component_mul(&e_o)
            + jo_dot_e_dot * two
            + self.kd.component_mul(&rotated_e_dot);
        Ok((
            reference.acceleration + frame.from_frame(&in_frame),
            e_o,
            true,
        ))
    }

    /// Without a frame: the base-frame PD with the normal gains on x and y.
    fn hold(
        &self,
        reference: &TaskReference<T>,
        position: &Vector3<T>,
        velocity: &Vector3<T>,
    ) -> (Vector3<T>, Vector3<T>) {
        let kp = Vector3::new(self.kp.y, self.kp.y, self.kp.z);
        let kd = Vector3::new(self.kd.y, self.kd.y, self.kd.z);
        let e = reference.position - position;
        let e_dot = reference.velocity - velocity;
        (
            reference.acceleration + kd.component_mul(&e_dot) + kp.component_mul(&e),
            e,
        )
    }

    /// The law for the delta's joints: forward kinematics of the measured `q`, the
    /// task state through Jx, the task acceleration, and back through Jx⁻¹ and J̇x.
    pub fn joint_acceleration(
        &self,
        geometry: &DeltaGeometry<T>,
        reference: &TaskReference<T>,
        q: &Vector3<T>,
        q_dot: &Vector3<T>,
    ) -> Result<ContouringOutput<T>, ContouringError> {
        let (position, velocity) = geometry
            .task_state(q, q_dot)
            .map_err(ContouringError::Kinematics)?;
        let (acceleration, frame_error_m, framed) = self
            .task_acceleration_framed(reference, &position, &velocity)
            .map_err(ContouringError::Frame)?;
        let contour_error_m = contour_error(&frame_error_m, framed);
        let joint_acceleration = geometry
            .joint_acceleration(q, &position, q_dot, &acceleration)
            .map_err(ContouringError::Kinematics)?;
        Ok(ContouringOutput {
            joint_acceleration,
            frame_error_m,
            position_m: position,
            velocity_m_s: velocity,
            contour_error_m,
        })
    }
}

/// The contour error of a frame error: |normal| with a frame, the planar length of the
/// base-frame error without one.
fn contour_error<T: Float>(e: &Vector3<T>, framed: bool) -> T {
    if framed {
        e.y.abs()
    } else {
        (e.x * e.x + e.y * e.y).fsqrt()
    }
}

#[cfg(test)]
mod tests;
