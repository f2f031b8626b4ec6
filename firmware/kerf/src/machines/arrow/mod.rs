//! ARROW's control period (A eq. 46): the PID with computed feedforward for the
//! parallel module and the turntable, from the desired motion and the measured joints.
//!
//! Each period: the joint references and Jm from the nominal model at the desired pose
//! (eq. 7, 13), Rm = Jm Jm⁺ (eq. 38), the inverse dynamic model on the desired motion
//! (eq. 22, 24), and the regularized PID of each part (eq. 45–46). Any error (an
//! unreachable or singular desired pose, a NaN) is returned; the caller's outputs go
//! to zero force.

pub mod drives;
pub mod job;
pub mod link;
pub mod machine;
pub mod product;

use crate::control::redundant_pid::{Factored, RedundantPid, RedundantPidError, RedundantPidState};
use crate::kinematics::arrow::{ActuatorVector, ArrowDynamics, ArrowError, ArrowGeometry, Pose};
use crate::scalar::{lit, Float};
use nalgebra::{Matrix2, Vector2};

/// The desired motion of a period.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowDesired<T> {
    /// Pose, rate and acceleration of the plate.
    pub pose: Pose<T>,
    /// Rate.
    pub rate: Pose<T>,
    /// Acceleration.
    pub acceleration: Pose<T>,
    /// Table angle θx and its acceleration, rad and rad/s².
    pub theta_x_rad: T,
    /// θ̈x, rad/s².
    pub theta_x_accel_rad_s2: T,
}

/// One period's commands.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowCommand<T> {
    /// Linear actuator forces, N.
    pub forces_n: ActuatorVector<T>,
    /// Turntable motor torques, N·m.
    pub torques_n_m: [T; 2],
    /// Whether an output is at its limit.
    pub saturated: bool,
    /// The joint references of the desired pose on the nominal model (eq. 7), m.
    pub joints_ref_m: ActuatorVector<T>,
}

/// Why a period has no command.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ArrowPeriodError {
    /// The desired pose has no model (eq. 7, 30–32).
    Model(ArrowError),
    /// A measurement or the feedforward is not finite.
    Law(RedundantPidError),
}

/// The state of both parts' loops.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowLoopState<T: Float> {
    /// Parallel module.
    pub parallel: RedundantPidState<T, 6>,
    /// Turntable.
    pub turntable: RedundantPidState<T, 2>,
}

/// At rest: integrators empty.
impl<T: Float> Default for ArrowLoopState<T> {
    fn default() -> Self {
        Self {
            parallel: RedundantPidState::default(),
            turntable: RedundantPidState::default(),
        }
    }
}

/// The laws and the model, coefficients only.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowLaw<T: Float> {
    /// Nominal geometry.
    pub geometry: ArrowGeometry<T>,
    /// Nominal dynamics.
    pub dynamics: ArrowDynamics<T>,
    /// Parallel module PID.
    pub parallel: RedundantPid<T>,
    /// Turntable PID.
    pub turntable: RedundantPid<T>,
    /// Add the inverse dynamic model's forces.
    pub feedforward: bool,
}

impl<T: Float> ArrowLaw<T> {
    /// One period from the desired motion and the measured joints and table motors.
    pub fn period(
        &self,
        state: &mut ArrowLoopState<T>,
        desired: &ArrowDesired<T>,
        joints_m: &ActuatorVector<T>,
        table_rad: [T; 2],
    ) -> Result<ArrowCommand<T>, ArrowPeriodError> {
        let model = ArrowPeriodError::Model;
        let rate = self.feedforward.then_some(&desired.rate);
        let (qd, jm, jm_dot) = self
            .geometry
            .differential(&desired.pose, rate)
            .map_err(model)?;
        let pinv = ArrowGeometry::pseudo_inverse(&jm).map_err(model)?;
        // Eq. 38's Rm = Jm Jm⁺, applied in its factors (not formed).
        let rm = Factored {
            jm: &jm,
            jm_pinv: &pinv,
        };
        let ff = if self.feedforward {
            self.dynamics
                .feedforward_with(
                    &jm,
                    &pinv,
                    &jm_dot,
                    &desired.pose,
                    &desired.rate,
                    &desired.acceleration,
                )
                .map_err(model)?
                .forces_n
        } else {
            ActuatorVector::zeros()
        };
        let out = self
            .parallel
            .update(&mut state.parallel, &(qd - joints_m), &rm, &ff)
            .map_err(ArrowPeriodError::Law)?;
        // Eq. 15: the turntable's Jm is (1, −1)ᵀ, so Rm = ½ [[1, −1], [−1, 1]].
        let half: T = lit(0.5);
        let table_rm = Matrix2::new(half, -half, -half, half);
        let table_ff = if self.feedforward {
            let [a, b] = self
                .dynamics
                .turntable_torques(desired.theta_x_accel_rad_s2);
            Vector2::new(a, b)
        } else {
            Vector2::zeros()
        };
        let table_error = Vector2::new(desired.theta_x_rad, -desired.theta_x_rad)
            - Vector2::new(table_rad[0], table_rad[1]);
        let table = self
            .turntable
            .update(&mut state.turntable, &table_error, &table_rm, &table_ff)
            .map_err(ArrowPeriodError::Law)?;
        Ok(ArrowCommand {
            forces_n: out.forces,
            torques_n_m: [table.forces.x, table.forces.y],
            saturated: out.saturated || table.saturated,
            joints_ref_m: qd,
        })
    }
}
