//! The plate's pose from the six joints, for monitoring (A 2.2: no closed form).
//!
//! Gauss–Newton on the inverse model: X ← X + Jm⁺ (q − IKM(X)), from a guess (the
//! last pose). Six measurements for four unknowns: at the solution the residual
//! q − IKM(X) is what no rigid pose explains, and a residual beyond the tolerance is
//! reported ([`ArrowError::InconsistentJoints`]) instead of a pose.

use super::{ActuatorVector, ArrowError, ArrowGeometry, Pose};
use crate::scalar::{lit, Float};

/// How the forward solve stops.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ForwardConfig {
    /// Most Gauss–Newton steps.
    pub max_iterations: u8,
    /// Converged when the step's largest component is below this (m, rad).
    pub step_tolerance: f64,
    /// Largest joint residual accepted at the solution, m.
    pub residual_tolerance_m: f64,
}

impl ForwardConfig {
    /// For monitoring in f64 or f32 from the last period's pose: 8 steps (Newton's
    /// quadratic convergence takes a guess a few millimetres off to round-off in 3–4),
    /// 1e-9 step (f64; f32 stops on the iteration count at its ~1e-7 m round-off),
    /// 10 µm of joint residual (encoders and calibration well inside it).
    pub const MONITOR: Self = Self {
        max_iterations: 8,
        step_tolerance: 1e-9,
        residual_tolerance_m: 10e-6,
    };
}

impl<T: Float> ArrowGeometry<T> {
    /// The pose whose inverse kinematics best matches `q` (least squares), from `guess`.
    pub fn forward(
        &self,
        q: &ActuatorVector<T>,
        guess: &Pose<T>,
        config: &ForwardConfig,
    ) -> Result<Pose<T>, ArrowError> {
        if !q.iter().chain(guess.iter()).all(|v| v.is_finite()) {
            return Err(ArrowError::NotFinite);
        }
        let step_tolerance: T = lit(config.step_tolerance);
        let mut pose = *guess;
        for _ in 0..config.max_iterations {
            let (at, jm) = self.jacobian(&pose)?;
            let step = Self::pseudo_inverse(&jm)? * (q - at);
            pose += step;
            if step.amax() <= step_tolerance {
                return self.accept(q, pose, config);
            }
        }
        // Out of steps: accept only a pose that explains the joints.
        self.accept(q, pose, config)
            .map_err(|_| ArrowError::NotConverged)
    }

    fn accept(
        &self,
        q: &ActuatorVector<T>,
        pose: Pose<T>,
        config: &ForwardConfig,
    ) -> Result<Pose<T>, ArrowError> {
        let residual = (q - self.inverse(&pose)?).amax();
        if residual <= lit(config.residual_tolerance_m) {
            Ok(pose)
        } else {
            Err(ArrowError::InconsistentJoints)
        }
    }
}
