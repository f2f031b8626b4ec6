//! The slave's tracking law for remote machining (docs/control.md §21, T 5.3.1): the
//! slave delta reproduces the master's motion, scaled.
//!
//! Scaling as users think of it: slave displacement = `scale` × master displacement,
//! each about its own workspace centre (T 8.3 cuts at 0.5 and 2/3). The print writes
//! the law in joint space,
//!
//!   q̈s = Ψ1 q̈m + Ψ2 q̇m − Ψ3 q̇s + Ψ4 F(qm) − Ψ5 F(qs),
//!
//! with Ψ1 = Js⁻¹β⁻¹Jm, Ψ2 = Js⁻¹β⁻¹(J̇m + W2⁻¹W1Jm + W2⁻¹KmsW2Jm),
//! Ψ3 = Js⁻¹β⁻¹(βJ̇s + W2⁻¹W1βJs + W2⁻¹KmsW2βJs), Ψ4 = Js⁻¹β⁻¹W2⁻¹KmsW1, Ψ5 = Ψ4β and
//! β = 1/scale. With diagonal, equal weights (W2⁻¹W1 = λ, Kms = k) every term is a
//! task-space quantity of one machine or the other, and the law is
//!
//!   ẍs,des = s ẍm + (λ + k)(s ẋm − ẋs) + λk (s (xm − cm) − (xs − cs)),
//!   q̈s = Js⁻¹ (ẍs,des − J̇s q̇s),
//!
//! where s = scale, ẍm = Jm q̈m + J̇m q̇m, and cm, cs are the workspace centres (the
//! print's F(qm) − βF(qs) puts both at the origin). The tracking error
//! e = s(xm − cm) − (xs − cs) then obeys ë + (λ + k)ė + λk e = 0: the sliding surface
//! ė + λe = 0 reached at rate k, poles at −λ and −k. So the slave needs only the
//! master's task-space position, velocity and acceleration — what the link carries
//! ([`MasterState`]) — and never the master's kinematics.

use crate::control::contouring::TaskReference;
use crate::error::{coefficient, positive, representable, ConfigError};
use crate::kinematics::delta::{DeltaGeometry, KinematicsError};
use crate::scalar::Float;
use nalgebra::Vector3;

/// The tracking law's settings, SI units.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct BilateralConfig {
    /// Slave displacement per master displacement (finite, > 0; T 8.3: 0.5, 2/3).
    pub scale: f64,
    /// The master's workspace centre, m (its displacements are taken about it).
    pub master_centre_m: [f64; 3],
    /// The slave's workspace centre, m.
    pub slave_centre_m: [f64; 3],
    /// λ = W2⁻¹W1: the sliding surface's slope, 1/s.
    pub surface_slope_per_s: f64,
    /// k = Kms: the rate at which the surface is reached, 1/s.
    pub reaching_rate_per_s: f64,
}

impl BilateralConfig {
    /// Both poles at `bandwidth_rad_s` (critically damped tracking error).
    pub fn critically_damped(
        scale: f64,
        master_centre_m: [f64; 3],
        slave_centre_m: [f64; 3],
        bandwidth_rad_s: f64,
    ) -> Self {
        Self {
            scale,
            master_centre_m,
            slave_centre_m,
            surface_slope_per_s: bandwidth_rad_s,
            reaching_rate_per_s: bandwidth_rad_s,
        }
    }
}

/// What the slave knows of the master: its effector's task state, m, m/s, m/s².
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MasterState<T> {
    /// Position, m.
    pub position: Vector3<T>,
    /// Velocity, m/s.
    pub velocity: Vector3<T>,
    /// Acceleration, m/s².
    pub acceleration: Vector3<T>,
}

/// What the law computed.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct BilateralOutput<T> {
    /// Desired acceleration of each slave joint, m/s².
    pub joint_acceleration: Vector3<T>,
    /// The tracking error e = s(xm − cm) − (xs − cs), m.
    pub tracking_error_m: Vector3<T>,
    /// The slave effector's measured position, m.
    pub position_m: Vector3<T>,
    /// The slave effector's measured velocity, m/s.
    pub velocity_m_s: Vector3<T>,
}

/// The law's coefficients (it keeps no state).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Bilateral<T> {
    scale: T,
    master_centre: Vector3<T>,
    slave_centre: Vector3<T>,
    /// λk, s⁻².
    kp: T,
    /// λ + k, s⁻¹.
    kd: T,
}

impl<T: Float> Bilateral<T> {
    /// Validates `config`: scale and rates finite and > 0, centres finite, and the
    /// gains λk and λ + k representable in `T`. Errors name the field.
    pub fn new(config: &BilateralConfig) -> Result<Self, ConfigError> {
        let scale = positive("scale", config.scale)?;
        let lambda = positive("surface_slope_per_s", config.surface_slope_per_s)?;
        let k = positive("reaching_rate_per_s", config.reaching_rate_per_s)?;
        let centre = |name: &'static str, c: [f64; 3]| -> Result<Vector3<T>, ConfigError> {
            let mut v = Vector3::zeros();
            for (i, (o, x)) in v.iter_mut().zip(c).enumerate() {
                if !x.is_finite() {
                    return Err(ConfigError::not_finite(name).indexed(i));
                }
                *o = representable::<T>(name, x).map_err(|e| e.indexed(i))?;
            }
            Ok(v)
        };
        Ok(Self {
            scale: coefficient("scale", scale)?,
            master_centre: centre("master_centre_m", config.master_centre_m)?,
            slave_centre: centre("slave_centre_m", config.slave_centre_m)?,
            // λk and λ + k overflow only with the rates themselves: named after them.
            kp: coefficient("reaching_rate_per_s", lambda * k)?,
            kd: coefficient("reaching_rate_per_s", lambda + k)?,
        })
    }

    /// The slave's reference: the master's motion scaled about the centres (no jerk:
    /// the master's is not sent).
    pub fn slave_reference(&self, master: &MasterState<T>) -> TaskReference<T> {
        TaskReference {
            position: self.slave_centre + (master.position - self.master_centre) * self.scale,
            velocity: master.velocity * self.scale,
            acceleration: master.acceleration * self.scale,
            jerk: Vector3::zeros(),
        }
    }

    /// Desired slave joint accelerations from the master's state and the slave's
    /// measured joints (module docs): FK and Jx of the slave at `q`, the task-space
    /// law, then back through Jx⁻¹ and J̇x.
    pub fn joint_acceleration(
        &self,
        geometry: &DeltaGeometry<T>,
        master: &MasterState<T>,
        q: &Vector3<T>,
        q_dot: &Vector3<T>,
    ) -> Result<BilateralOutput<T>, KinematicsError> {
        let (position, velocity) = geometry.task_state(q, q_dot)?;
        let (acceleration, e) = self.task_acceleration(master, &position, &velocity);
        Ok(BilateralOutput {
            joint_acceleration: geometry.joint_acceleration(q, &position, q_dot, &acceleration)?,
            tracking_error_m: e,
            position_m: position,
            velocity_m_s: velocity,
        })
    }

    /// The law in task space: the slave's desired acceleration, m/s², and the tracking
    /// error e, m, for the slave effector at `position` moving at `velocity` (measured,
    /// or the master side's estimate of them: T eq. 96).
    pub fn task_acceleration(
        &self,
        master: &MasterState<T>,
        position: &Vector3<T>,
        velocity: &Vector3<T>,
    ) -> (Vector3<T>, Vector3<T>) {
        let reference = self.slave_reference(master);
        let e = reference.position - position;
        let e_dot = reference.velocity - velocity;
        (reference.acceleration + e_dot * self.kd + e * self.kp, e)
    }

    /// The tracking error's gains (λk in s⁻², λ + k in s⁻¹), as stored in `T`.
    pub fn gains(&self) -> (T, T) {
        (self.kp, self.kd)
    }

    /// The scale s, as stored in `T`.
    pub fn scale(&self) -> T {
        self.scale
    }
}

#[cfg(test)]
mod tests;
