//! One straight effector move and the joint references it gives (T eq. 146).

use crate::error::ConfigError;
use crate::kinematics::delta::{DeltaGeometry, KinematicsError};
use crate::scalar::Float;
use crate::trajectory::quintic::Quintic;
use crate::trajectory::Reference;
use nalgebra::Vector3;

/// Joint references from the effector's position, velocity and acceleration
/// (T eq. 146 and its time derivative).
pub(super) fn joint_references<T: Float>(
    geometry: &DeltaGeometry<T>,
    p: &Vector3<T>,
    p_dot: &Vector3<T>,
    p_ddot: &Vector3<T>,
) -> Result<[Reference<T>; 3], KinematicsError> {
    let [q, q_dot, q_ddot] = geometry.joint_motion(p, p_dot, p_ddot)?;
    let reference = |position, velocity, acceleration| Reference {
        position,
        velocity,
        acceleration,
    };
    Ok([
        reference(q.x, q_dot.x, q_ddot.x),
        reference(q.y, q_dot.y, q_ddot.y),
        reference(q.z, q_dot.z, q_ddot.z),
    ])
}

/// One straight move: the effector at `from + line · s(t)` with s a minimum-jerk 0 → 1.
#[derive(Copy, Clone, Debug)]
pub(super) struct Line<T> {
    from: Vector3<T>,
    line: Vector3<T>,
    profile: Quintic<T>,
}

impl<T: Float> Line<T> {
    pub(super) fn new(from: [f64; 3], to: [f64; 3], duration_s: f64) -> Result<Self, ConfigError> {
        let v = |name, a| crate::error::representable_each::<T, 3>(name, a).map(Vector3::from);
        Ok(Self {
            from: v("from_m", from)?,
            line: v("to_m", [to[0] - from[0], to[1] - from[1], to[2] - from[2]])?,
            profile: Quintic::new(0.0, 1.0, duration_s)?,
        })
    }

    /// The effector's position, velocity and acceleration `t_s` into the move.
    pub(super) fn at(&self, t_s: T) -> (Vector3<T>, Vector3<T>, Vector3<T>) {
        let s = self.profile.sample(t_s);
        (
            self.from + self.line * s.position,
            self.line * s.velocity,
            self.line * s.acceleration,
        )
    }
}
