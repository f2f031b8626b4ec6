//! The master's virtual fixture (docs/control.md §20, T 5.2): free and
//! force-transparent along the contour, stiff across it and in z.
//!
//! The constraint φ(x) = [φ₁, φ₂] (φ₁ the signed distance to the contour's local
//! circle or line, φ₂ = z_ref − z; `trajectory::constraint`) is driven to zero through
//! the sliding variable s = C2 φ̇ + C1 φ, reached at the rate K: ṡ = −K s, that is
//!
//!   φ̈ = −(C2⁻¹C1 + K) φ̇ − K C2⁻¹C1 φ,
//!
//! per row (diagonal C1, C2, K), with the poles −λ = −C2⁻¹C1 (the surface) and −K.
//! The print's joint-space law q̈ = −Kq2 q̇ − Kq1 φ(F(q)), Kq1 = Jx⁻¹Jφ#C2⁻¹KC1,
//! Kq2 = Jx⁻¹J̇x + Jx⁻¹Jφ#J̇φJx + Jx⁻¹Jφ#C2⁻¹C1JφJx + Jx⁻¹Jφ#C2⁻¹KC2JφJx, is that
//! demand mapped through φ̈ = Jφẍ + J̇φẋ and ẍ = Jx q̈ + J̇x q̇.
//!
//! The correction of docs/control.md §20 (required by T's own experiment): the operator
//! must stay free along the curve. The law therefore gives the task acceleration only
//! in the constrained subspace, ẍc = Jφ#(φ̈des − J̇φẋ), with Jφ# = Jφᵀ(JφJφᵀ)⁻¹,
//! together with the projector P = Jφ#Jφ onto that subspace: the machine applies its
//! force, and its disturbance compensation, through P only, so nothing acts along the
//! free direction (I − P) and the operator's push there is not resisted or cancelled.
//! The print's full −Jx⁻¹J̇x q̇ is likewise only applied through P.
//!
//! A push across the curve with acceleration a (force over the effective mass) settles
//! at φ = a/(λK): the fixture's stiffness is m·λ·K N/m.

use crate::control::preview::PreviewConfig;
use crate::error::{coefficient, positive, ConfigContext, ConfigError};
use crate::scalar::Float;
use crate::trajectory::constraint::ConstraintValue;
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

/// The fixture's poles across the curve (in the plane) and in z: each row's surface
/// slope λ = C2⁻¹C1 and reaching rate K, 1/s (the same pair as the preview law's).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FixtureConfig {
    /// Across the curve in the x–y plane.
    pub normal: PreviewConfig,
    /// Along z.
    pub vertical: PreviewConfig,
}

/// Why the law has no output.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FixtureError {
    /// JφJφᵀ is singular or not finite (the gradient of φ₁ vanished: a point at a
    /// fitted circle's centre).
    SingularConstraint,
}

/// What the law computed.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FixtureOutput<T> {
    /// ẍc: the task acceleration the fixture asks for, in the constrained subspace
    /// only, m/s².
    pub constrained_acceleration: Vector3<T>,
    /// P = Jφ#Jφ, the projector onto the constrained subspace (symmetric).
    pub projector: Matrix3<T>,
}

/// The fixture's coefficients (it keeps no state).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Fixture<T> {
    /// λK per row, s⁻².
    kp: Vector2<T>,
    /// λ + K per row, s⁻¹.
    kd: Vector2<T>,
}

impl<T: Float> Fixture<T> {
    /// Validates the rates (finite, > 0) and their products in `T`; errors name the
    /// row and field (`normal.reaching_rate_per_s`).
    pub fn new(config: &FixtureConfig) -> Result<Self, ConfigError> {
        let row = |c: &PreviewConfig, name: &'static str| -> Result<(T, T), ConfigError> {
            let lambda = positive("surface_slope_per_s", c.surface_slope_per_s).within(name)?;
            let k = positive("reaching_rate_per_s", c.reaching_rate_per_s).within(name)?;
            Ok((
                coefficient("reaching_rate_per_s", lambda * k).within(name)?,
                coefficient("reaching_rate_per_s", lambda + k).within(name)?,
            ))
        };
        let (kp_n, kd_n) = row(&config.normal, "normal")?;
        let (kp_z, kd_z) = row(&config.vertical, "vertical")?;
        Ok(Self {
            kp: Vector2::new(kp_n, kp_z),
            kd: Vector2::new(kd_n, kd_z),
        })
    }

    /// The constrained task acceleration and the projector at the constraint `value`
    /// (φ, Jφ and J̇φ's rate at the measured position) for the measured task velocity.
    pub fn task_acceleration(
        &self,
        value: &ConstraintValue<T>,
        velocity: &Vector3<T>,
    ) -> Result<FixtureOutput<T>, FixtureError> {
        let j = &value.jacobian;
        let phi_dot = j * velocity;
        let planar_speed_sq = velocity.x * velocity.x + velocity.y * velocity.y;
        let j_dot_v = Vector2::new(value.gradient_rate_per_m * planar_speed_sq, T::zero());
        let phi_ddot = -self.kd.component_mul(&phi_dot) - self.kp.component_mul(&value.phi);
        let gram: Matrix2<T> = j * j.transpose();
        let gram_inv = gram
            .try_inverse()
            .filter(|m| m.iter().all(|v| v.is_finite()))
            .ok_or(FixtureError::SingularConstraint)?;
        let pseudo_inverse = j.transpose() * gram_inv;
        Ok(FixtureOutput {
            constrained_acceleration: pseudo_inverse * (phi_ddot - j_dot_v),
            projector: pseudo_inverse * j,
        })
    }
}

#[cfg(test)]
mod tests;
