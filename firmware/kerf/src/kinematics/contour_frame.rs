//! The orthogonal frame moving with a contour reference (docs/equations.md §8,
//! T 4.3.1), extended to 3-D.
//!
//! For the planar part of a reference C(t) = (x, y) with speed v = |Ċ| > 0 and tangent
//! angle ψ, the frame's axes are the unit tangent t = (cos ψ, sin ψ) and the unit
//! normal n = (−sin ψ, cos ψ); a task-space vector e has frame coordinates
//! e_O = J_O e with J_O = R(ψ)ᵀ = (1/v)[[ẋ, ẏ], [−ẏ, ẋ]]. The 3-D frame is
//! blockdiag(J_O, 1): z keeps its own axis (T's future work "3D contouring
//! control", T 9.2), so one law regulates the tangential, normal and vertical errors.
//!
//! The frame turns at ψ̇ = (ẋÿ − ẏẍ)/v² and accelerates its turn at
//! ψ̈ = (ẋ y⃛ − ẏ x⃛)/v² − 2ψ̇ (ẋẍ + ẏÿ)/v² (the ẍÿ products cancel in the numerator's
//! derivative). Because R′(ψ)ᵀ e = (e_n, −e_t) in frame coordinates, J̇_O e and
//! J̈_O e never need a matrix: J̇_O e = ψ̇ (e_n, −e_t) and
//! J̈_O e = ψ̈ (e_n, −e_t) − ψ̇² (e_t, e_n).

use crate::scalar::{Float, Real};
use core::cmp::Ordering;
use nalgebra::Vector3;

/// Why there is no frame.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ContourFrameError {
    /// The reference's speed in the x–y plane is below the minimum: its tangent (and
    /// with it the normal direction) is undefined (a dwell, a cusp, a vertical move).
    SpeedTooLow,
    /// A derivative of the reference is NaN or infinite, or its square overflowed.
    NotFinite,
}

/// The frame of one reference sample: its direction and turning rates.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ContourFrame<T> {
    /// cos ψ = ẋ/v.
    cos: T,
    /// sin ψ = ẏ/v.
    sin: T,
    /// ψ̇, rad/s.
    turn_rate_rad_s: T,
    /// ψ̈, rad/s².
    turn_accel_rad_s2: T,
}

impl<T: Float> ContourFrame<T> {
    /// The frame of a reference moving with `velocity`, `acceleration` and `jerk`
    /// (m/s, m/s², m/s³); only their x–y parts define it. Planar speeds below
    /// `min_speed_m_s` are refused.
    pub fn new(
        velocity: &Vector3<T>,
        acceleration: &Vector3<T>,
        jerk: &Vector3<T>,
        min_speed_m_s: T,
    ) -> Result<Self, ContourFrameError> {
        let (vx, vy) = (velocity.x, velocity.y);
        let (ax, ay) = (acceleration.x, acceleration.y);
        let (jx, jy) = (jerk.x, jerk.y);
        let speed_sq = vx * vx + vy * vy;
        let inputs = [vx, vy, ax, ay, jx, jy, speed_sq];
        if inputs.iter().any(|v| !<T as Real>::is_finite(*v)) {
            return Err(ContourFrameError::NotFinite);
        }
        // Unordered (a NaN minimum) refuses too.
        let below_minimum = !matches!(
            speed_sq.partial_cmp(&(min_speed_m_s * min_speed_m_s)),
            Some(Ordering::Greater | Ordering::Equal)
        );
        if below_minimum || speed_sq <= T::zero() {
            return Err(ContourFrameError::SpeedTooLow);
        }
        let inv_speed_sq = T::one() / speed_sq;
        let inv_speed = inv_speed_sq.fsqrt();
        let turn_rate = (vx * ay - vy * ax) * inv_speed_sq;
        let speed_sq_rate = (vx * ax + vy * ay) * inv_speed_sq;
        let two = T::one() + T::one();
        let turn_accel = (vx * jy - vy * jx) * inv_speed_sq - two * turn_rate * speed_sq_rate;
        let (cos, sin) = (vx * inv_speed, vy * inv_speed);
        if [turn_rate, turn_accel, cos, sin]
            .iter()
            .any(|v| !<T as Real>::is_finite(*v))
        {
            return Err(ContourFrameError::NotFinite);
        }
        Ok(Self {
            cos,
            sin,
            turn_rate_rad_s: turn_rate,
            turn_accel_rad_s2: turn_accel,
        })
    }

    /// ψ̇, rad/s: the tangential speed over the radius of curvature.
    pub fn turn_rate_rad_s(&self) -> T {
        self.turn_rate_rad_s
    }

    /// ψ̈, rad/s².
    pub fn turn_accel_rad_s2(&self) -> T {
        self.turn_accel_rad_s2
    }

    /// J_O e: task-space `e` in frame coordinates (tangential, normal, vertical).
    #[inline]
    pub fn to_frame(&self, e: &Vector3<T>) -> Vector3<T> {
        Vector3::new(
            self.cos * e.x + self.sin * e.y,
            self.cos * e.y - self.sin * e.x,
            e.z,
        )
    }

    /// J_O⁻¹ e_O = J_Oᵀ e_O: frame coordinates back to task space.
    #[inline]
    pub fn from_frame(&self, e: &Vector3<T>) -> Vector3<T> {
        Vector3::new(
            self.cos * e.x - self.sin * e.y,
            self.sin * e.x + self.cos * e.y,
            e.z,
        )
    }

    /// R′(ψ)ᵀ e in frame coordinates, given e_O = J_O e: (e_n, −e_t, 0).
    #[inline]
    pub(crate) fn quarter_turn(e_frame: &Vector3<T>) -> Vector3<T> {
        Vector3::new(e_frame.y, -e_frame.x, T::zero())
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use nalgebra::Matrix3;

    /// An ellipse with a vertical wobble, x = a cos ωt, y = b sin ωt, z = h sin 3ωt, and
    /// its analytic derivatives.
    fn ellipse(t: f64) -> [Vector3<f64>; 4] {
        let (a, b, h, w) = (0.006, 0.003, 0.001, 2.5);
        let (s, c) = (libm::sin(w * t), libm::cos(w * t));
        let (s3, c3) = (libm::sin(3.0 * w * t), libm::cos(3.0 * w * t));
        [
            Vector3::new(a * c, b * s, h * s3),
            Vector3::new(-a * w * s, b * w * c, 3.0 * h * w * c3),
            Vector3::new(-a * w * w * c, -b * w * w * s, -9.0 * h * w * w * s3),
            Vector3::new(
                a * w * w * w * s,
                -b * w * w * w * c,
                -27.0 * h * w * w * w * c3,
            ),
        ]
    }

    /// The frame matrices of docs/equations.md §8 built literally for a reference
    /// moving at `v` and turning at ψ̇, ψ̈: J_O = (1/v)[[ẋ, ẏ], [−ẏ, ẋ]] ⊕ 1,
    /// J̇_O = ψ̇ R′(ψ)ᵀ ⊕ 0 and J̈_O = (ψ̈ R′(ψ)ᵀ − ψ̇² R(ψ)ᵀ) ⊕ 0, with ψ from atan2 (the
    /// reference the frame's matrix-free maps are checked against, here and in
    /// `control::contouring`).
    pub(crate) fn literal_frame_matrices(
        v: &Vector3<f64>,
        turn_rate: f64,
        turn_accel: f64,
    ) -> [Matrix3<f64>; 3] {
        let speed = (v.x * v.x + v.y * v.y).sqrt();
        let (ct, st) = (v.x / speed, v.y / speed);
        let jo = Matrix3::new(ct, st, 0.0, -st, ct, 0.0, 0.0, 0.0, 1.0);
        let psi = libm::atan2(v.y, v.x);
        let (s, c) = (libm::sin(psi), libm::cos(psi));
        let r_prime_t = Matrix3::new(-s, c, 0.0, -c, -s, 0.0, 0.0, 0.0, 0.0);
        let r_t = Matrix3::new(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 0.0);
        let jo_dot = r_prime_t * turn_rate;
        let jo_ddot = r_prime_t * turn_accel - r_t * (turn_rate * turn_rate);
        [jo, jo_dot, jo_ddot]
    }

    fn frame_at(t: f64) -> ContourFrame<f64> {
        let [_, v, a, j] = ellipse(t);
        ContourFrame::new(&v, &a, &j, 1e-6).unwrap()
    }

    /// ψ̇ and ψ̈ against central differences of ψ = atan2(ẏ, ẋ) (a different
    /// computation: the angle itself, differentiated numerically). With step h the
    /// differences' truncation error is about h²/6 · ψ⁗ ≈ 1e-9 relative here.
    #[test]
    fn turn_rates_match_differences_of_the_tangent_angle() {
        let angle = |t: f64| {
            let [_, v, _, _] = ellipse(t);
            libm::atan2(v.y, v.x)
        };
        let unwrap = |d: f64| libm::remainder(d, 2.0 * core::f64::consts::PI);
        let h = 1e-4;
        for k in 0..50 {
            let t = 0.05 * k as f64;
            let (before, here, after) = (angle(t - h), angle(t), angle(t + h));
            let rate = (unwrap(after - here) + unwrap(here - before)) / (2.0 * h);
            let accel = (unwrap(after - here) - unwrap(here - before)) / (h * h);
            let f = frame_at(t);
            assert!(
                (f.turn_rate_rad_s() - rate).abs() < 1e-7 * (1.0 + rate.abs()),
                "{t}"
            );
            assert!(
                (f.turn_accel_rad_s2() - accel).abs() < 1e-4 * (1.0 + accel.abs()),
                "{t}: {} vs {accel}",
                f.turn_accel_rad_s2()
            );
        }
    }

    /// The frame maps against the matrices of docs/equations.md §8 built literally:
    /// J_O = (1/v)[[ẋ, ẏ], [−ẏ, ẋ]] ⊕ 1, J̇_O = ψ̇ R′(ψ)ᵀ ⊕ 0,
    /// J̈_O = (ψ̈ R′(ψ)ᵀ − ψ̇² R(ψ)ᵀ) ⊕ 0, with ψ from atan2.
    #[test]
    fn frame_maps_match_the_literal_matrices() {
        let e = Vector3::new(0.3e-3, -0.7e-3, 0.2e-3);
        for k in 0..40 {
            let t = 0.07 * k as f64;
            let [_, v, _, _] = ellipse(t);
            let f = frame_at(t);
            let [jo, jo_dot, jo_ddot] =
                literal_frame_matrices(&v, f.turn_rate_rad_s(), f.turn_accel_rad_s2());
            let e_o = f.to_frame(&e);
            assert!((e_o - jo * e).norm() < 1e-15);
            assert!((f.from_frame(&e_o) - e).norm() < 1e-15);
            let q = ContourFrame::quarter_turn(&e_o);
            assert!((q * f.turn_rate_rad_s() - jo_dot * e).norm() < 1e-15);
            let w = f.turn_rate_rad_s();
            let jdd = q * f.turn_accel_rad_s2() - Vector3::new(e_o.x, e_o.y, 0.0) * (w * w);
            assert!((jdd - jo_ddot * e).norm() < 1e-13 * (1.0 + jo_ddot.norm()));
        }
    }

    #[test]
    fn no_frame_without_planar_speed_or_with_non_finite_input() {
        let z = Vector3::zeros();
        let up = Vector3::new(0.0, 0.0, 0.01);
        assert_eq!(
            ContourFrame::new(&up, &z, &z, 1e-4),
            Err(ContourFrameError::SpeedTooLow)
        );
        let slow = Vector3::new(0.5e-4, 0.0, 0.0);
        assert_eq!(
            ContourFrame::new(&slow, &z, &z, 1e-4),
            Err(ContourFrameError::SpeedTooLow)
        );
        let v = Vector3::new(0.008, 0.0, 0.0);
        assert_eq!(
            ContourFrame::new(&v, &z, &z, f64::NAN),
            Err(ContourFrameError::SpeedTooLow)
        );
        assert_eq!(
            ContourFrame::new(&v, &Vector3::new(f64::NAN, 0.0, 0.0), &z, 1e-4),
            Err(ContourFrameError::NotFinite)
        );
        assert_eq!(
            ContourFrame::new(&Vector3::new(1e200, 1e200, 0.0), &z, &z, 1e-4),
            Err(ContourFrameError::NotFinite)
        );
        let tiny = Vector3::new(1e-30f32, 0.0, 0.0);
        assert_eq!(
            ContourFrame::new(&tiny, &Vector3::zeros(), &Vector3::zeros(), 0.0),
            Err(ContourFrameError::SpeedTooLow)
        );
    }
}
