//! Joint references (T 3.2.3–3.2.4, SPEC § trajectory): task-space samples taken every
//! `h` seconds are mapped through an inverse kinematics q = I(x) (T eq. 10) and a C²
//! cubic spline in time is fitted per joint, so that each control period can read
//! q, q̇, q̈ and q⃛ (T eq. 11–14).
//!
//! The IK is a parameter (any `FnMut(Vector3<f64>) -> Result<Vector3<f64>, E>`), so the
//! same code serves every kinematics. With knot values qi and second derivatives Mi,
//! continuity of q̇ gives Mi−1 + 4Mi + Mi+1 = 6(qi+1 − 2qi + qi−1)/h² inside; the ends are
//! clamped to given joint velocities (zero for a move from and to rest):
//! 2M0 + M1 = 6((q1 − q0)/h − v0)/h and Mn−2 + 2Mn−1 = 6(vn − (qn−1 − qn−2)/h)/h.
//! A clamped cubic spline reproduces any cubic exactly. The tridiagonal system is
//! diagonally dominant and is solved by the Thomas algorithm in O(n).

use super::{lit, to_f64, ContourError, Float};
use crate::error::positive;
use heapless::Vec;
use nalgebra::Vector3;

/// Why a spline fit failed.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum SplineError<E> {
    /// Bad samples or configuration.
    Contour(ContourError),
    /// The joint map rejected sample `index` (for example an unreachable pose).
    Joint {
        /// Index of the task-space sample.
        index: usize,
        /// The joint map's error.
        error: E,
    },
}

impl<E> From<ContourError> for SplineError<E> {
    fn from(e: ContourError) -> Self {
        SplineError::Contour(e)
    }
}

/// Joint-space reference for one instant.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct JointReference<T: Float> {
    /// q (joint units, m for prismatic joints).
    pub q: Vector3<T>,
    /// q̇ per second.
    pub qd: Vector3<T>,
    /// q̈ per second².
    pub qdd: Vector3<T>,
    /// q⃛ per second³ (constant on each knot interval).
    pub qddd: Vector3<T>,
}

/// C² cubic spline through up to `N` joint-space knots at a uniform period.
#[derive(Clone, Debug)]
pub struct JointSpline<T: Float, const N: usize> {
    q: Vec<Vector3<T>, N>,
    m: Vec<Vector3<T>, N>,
    h: T,
    inv_h: T,
    duration_s: f64,
}

impl<T: Float, const N: usize> JointSpline<T, N> {
    /// Maps `task` samples (m, one every `knot_period_s`) through `ik` and fits the spline
    /// with joint velocities `start_velocity` and `end_velocity` at the ends.
    ///
    /// Errors: fewer than 3 samples, more than `N`, a non-finite sample or period, or the
    /// joint map's error for a sample.
    pub fn fit<E, F>(
        task: &[Vector3<f64>],
        knot_period_s: f64,
        start_velocity: Vector3<f64>,
        end_velocity: Vector3<f64>,
        mut ik: F,
    ) -> Result<Self, SplineError<E>>
    where
        F: FnMut(Vector3<f64>) -> Result<Vector3<f64>, E>,
    {
        let h = positive("knot_period_s", knot_period_s).map_err(ContourError::from)?;
        if task.len() < 3 {
            return Err(ContourError::TooFewPoints.into());
        }
        if task.len() > N {
            return Err(ContourError::Capacity.into());
        }
        let finite = |v: &Vector3<f64>| v.iter().all(|x| x.is_finite());
        if let Some(i) = task.iter().position(|p| !finite(p)) {
            return Err(ContourError::NotFinitePoint(i).into());
        }
        if !finite(&start_velocity) || !finite(&end_velocity) {
            return Err(ContourError::Config(crate::ConfigError::not_finite("velocity")).into());
        }
        let mut q: Vec<Vector3<T>, N> = Vec::new();
        for (index, p) in task.iter().enumerate() {
            let joint = ik(*p).map_err(|error| SplineError::Joint { index, error })?;
            if !finite(&joint) {
                return Err(ContourError::NotFinitePoint(index).into());
            }
            q.push(joint.map(lit))
                .map_err(|_| SplineError::Contour(ContourError::Capacity))?;
        }
        let n = q.len();
        let (ht, six) = (lit::<T>(h), lit::<T>(6.0));
        let inv_h = lit::<T>(1.0 / h);
        // Right-hand sides, then forward elimination (Thomas), storing d′ in `m` and the
        // modified upper diagonal c′ in `upper`.
        let mut m: Vec<Vector3<T>, N> = Vec::new();
        let mut upper = [T::ZERO; N];
        let (v0, vn) = (start_velocity.map(lit::<T>), end_velocity.map(lit::<T>));
        let slope = |a: &Vector3<T>, b: &Vector3<T>| (b - a) * inv_h;
        let mut prev_c = T::ZERO;
        let mut prev_d = Vector3::zeros();
        for (i, c_out) in upper.iter_mut().enumerate().take(n) {
            let at = |j: usize| q.get(j).copied().unwrap_or_else(Vector3::zeros);
            let (rhs, diag, up): (Vector3<T>, T, T) = if i == 0 {
                (
                    (slope(&at(0), &at(1)) - v0) * (six * inv_h),
                    lit(2.0),
                    T::one(),
                )
            } else if i + 1 == n {
                (
                    (vn - slope(&at(i - 1), &at(i))) * (six * inv_h),
                    lit(2.0),
                    T::ZERO,
                )
            } else {
                (
                    (at(i + 1) - at(i) * lit::<T>(2.0) + at(i - 1)) * (six * inv_h * inv_h),
                    lit(4.0),
                    T::one(),
                )
            };
            // Lower diagonal is 1 on every row below the first.
            let (lower, pc, pd) = if i == 0 {
                (T::ZERO, T::ZERO, Vector3::zeros())
            } else {
                (T::one(), prev_c, prev_d)
            };
            let denom = diag - lower * pc;
            *c_out = up / denom;
            let d = (rhs - pd * lower) / denom;
            m.push(d)
                .map_err(|_| SplineError::Contour(ContourError::Capacity))?;
            (prev_c, prev_d) = (*c_out, d);
        }
        // Back substitution: Mi = d′i − c′i Mi+1.
        let mut next = Vector3::zeros();
        for (mi, ci) in m.iter_mut().zip(upper.iter()).rev() {
            *mi -= next * *ci;
            next = *mi;
        }
        Ok(Self {
            q,
            m,
            h: ht,
            inv_h,
            duration_s: h * (n - 1) as f64,
        })
    }

    /// Time from the first to the last knot, s.
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// Number of knots.
    pub fn knots(&self) -> usize {
        self.q.len()
    }

    /// Reference at `t_s` seconds after the first knot (clamped to [0, duration]).
    pub fn evaluate(&self, t_s: T) -> JointReference<T> {
        let last = self.q.len().saturating_sub(2);
        let x = to_f64(t_s * self.inv_h);
        let i = if x > 0.0 {
            (libm::floor(x) as usize).min(last)
        } else {
            0
        };
        let u = (t_s - self.h * lit(i as f64)).max(T::ZERO).min(self.h);
        let zero = Vector3::zeros();
        let get = |v: &Vec<Vector3<T>, N>, j: usize| v.get(j).copied().unwrap_or(zero);
        let (q0, q1, m0, m1) = (
            get(&self.q, i),
            get(&self.q, i + 1),
            get(&self.m, i),
            get(&self.m, i + 1),
        );
        let (h, ih) = (self.h, self.inv_h);
        let w = h - u;
        let sixth = lit::<T>(1.0 / 6.0);
        let half = lit::<T>(0.5);
        // Linear part coefficients (qi/h − Mi h/6) and (qi+1/h − Mi+1 h/6).
        let a = q0 * ih - m0 * (h * sixth);
        let b = q1 * ih - m1 * (h * sixth);
        JointReference {
            q: m0 * (w * w * w * ih * sixth) + m1 * (u * u * u * ih * sixth) + a * w + b * u,
            qd: m1 * (u * u * ih * half) - m0 * (w * w * ih * half) + b - a,
            qdd: m0 * (w * ih) + m1 * (u * ih),
            qddd: (m1 - m0) * ih,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::{resample, shapes};
    extern crate std;
    use std::vec::Vec as StdVec;

    /// A test joint map written independently of `kinematics::delta`: a vertical
    /// linear delta (towers at 90°, 210°, 330° on radius 60 mm, arms 120 mm), carriage
    /// height qi = z + √(l² − |pxy − towerᵢ|²).
    #[derive(Debug, PartialEq)]
    struct Unreachable;
    fn vertical_delta(p: Vector3<f64>) -> Result<Vector3<f64>, Unreachable> {
        let mut q = Vector3::zeros();
        for (i, deg) in [90.0f64, 210.0, 330.0].iter().enumerate() {
            let (s, c) = libm::sincos(deg.to_radians());
            let r2 = 0.12f64.powi(2) - (p.x - 0.06 * c).powi(2) - (p.y - 0.06 * s).powi(2);
            if r2 <= 0.0 {
                return Err(Unreachable);
            }
            q[i] = p.z + libm::sqrt(r2);
        }
        Ok(q)
    }

    #[test]
    fn reproduces_a_cubic_exactly() {
        let cubic = |t: f64| {
            Vector3::new(
                0.01 + 0.2 * t - 0.5 * t * t + 0.9 * t * t * t,
                -0.02 * t,
                0.3 * t * t * t,
            )
        };
        let dcubic = |t: f64| Vector3::new(0.2 - t + 2.7 * t * t, -0.02, 0.9 * t * t);
        let h = 0.01;
        let samples: StdVec<_> = (0..40).map(|i| cubic(i as f64 * h)).collect();
        let s = JointSpline::<f64, 64>::fit(&samples, h, dcubic(0.0), dcubic(0.39), Ok::<_, ()>)
            .unwrap();
        for k in 0..=390 {
            let t = k as f64 * 1e-3 + 3e-4 * (k % 3) as f64;
            let t = t.min(0.39);
            let r = s.evaluate(t);
            assert!((r.q - cubic(t)).norm() < 1e-15);
            assert!((r.qd - dcubic(t)).norm() < 1e-12);
            let qdd = Vector3::new(-1.0 + 5.4 * t, 0.0, 1.8 * t);
            assert!((r.qdd - qdd).norm() < 1e-10);
            assert!((r.qddd - Vector3::new(5.4, 0.0, 1.8)).norm() < 1e-8);
        }
    }

    fn s_letter_spline<T: Float>() -> (JointSpline<T, 1024>, f64) {
        let dense = resample::densify::<512>(&shapes::letter_s(), 3).unwrap();
        // One knot every 10 ms at 8 mm/s: 80 µm of arc.
        let h = 0.01;
        let pts = resample::resample::<f64, 1024>(&dense, 8e-3 * h).unwrap();
        let task: StdVec<_> = pts.iter().map(|p| Vector3::new(p.x, p.y, -0.09)).collect();
        let s =
            JointSpline::fit(&task, h, Vector3::zeros(), Vector3::zeros(), vertical_delta).unwrap();
        (s, h)
    }

    #[test]
    fn derivatives_match_finite_differences_and_are_c2() {
        let (s, h) = s_letter_spline::<f64>();
        assert!(s.knots() > 300);
        let e = 1e-6;
        let mut t = 2.5e-3;
        while t < s.duration_s() - e {
            let (a, b, r) = (s.evaluate(t - e), s.evaluate(t + e), s.evaluate(t));
            // Central differences of a cubic: exact for q̈ from q̇ and q⃛ from q̈ inside an
            // interval, error e²/6·q⃛ for q̇ from q; rounding ~1e-16·|q|/e.
            assert!(((b.q - a.q) / (2.0 * e) - r.qd).norm() < 1e-8);
            // |Δ/2e − q̈| ≤ (e/2)·max|q⃛| even across a knot, plus rounding.
            let jerk_max = a.qddd.norm().max(b.qddd.norm());
            assert!(((b.qd - a.qd) / (2.0 * e) - r.qdd).norm() < e * jerk_max + 1e-8);
            let jerk_err = ((b.qdd - a.qdd) / (2.0 * e) - r.qddd).norm();
            // q⃛ steps at knots: compare only where t ± e stays inside one interval.
            let off_knot = (t / h - libm::round(t / h)).abs() * h > 2.0 * e;
            assert!(
                !off_knot || jerk_err < 1e-3 * r.qddd.norm().max(1.0),
                "t {t}: {jerk_err} {}",
                r.qddd
            );
            t += 3.7e-3;
        }
        // C²: q, q̇, q̈ continuous across every knot (q⃛ may step).
        for k in 1..s.knots() - 1 {
            let tk = k as f64 * h;
            let (l, r) = (s.evaluate(tk - 1e-12), s.evaluate(tk + 1e-12));
            assert!((l.q - r.q).norm() < 1e-12);
            assert!((l.qd - r.qd).norm() < 1e-9);
            assert!((l.qdd - r.qdd).norm() < 1e-6 * l.qddd.norm().max(1.0));
        }
        // Clamped ends: at rest.
        assert!(s.evaluate(0.0).qd.norm() < 1e-15);
        assert!(s.evaluate(s.duration_s()).qd.norm() < 1e-12);
    }

    #[test]
    fn f32_spline_follows_f64() {
        let (s64, _) = s_letter_spline::<f64>();
        let (s32, _) = s_letter_spline::<f32>();
        let mut worst: f64 = 0.0;
        for k in 0..3000 {
            let t = k as f64 * 1e-3;
            let d = s64.evaluate(t).q - s32.evaluate(t as f32).q.map(|v| v as f64);
            worst = worst.max(d.norm());
        }
        // q ≈ 0.02–0.03 m: f32 resolution ≈ 2e-9 m, a few roundings per evaluation.
        assert!(worst < 2e-8, "{worst}");
    }

    #[test]
    fn rejects_bad_input_and_reports_the_joint_map() {
        let z = Vector3::zeros();
        let ok = |p| Ok::<_, Unreachable>(p);
        let three = [
            z,
            Vector3::new(1e-3, 0.0, 0.0),
            Vector3::new(2e-3, 0.0, 0.0),
        ];
        assert_eq!(
            JointSpline::<f32, 8>::fit(&three[..2], 0.01, z, z, ok).err(),
            Some(SplineError::Contour(ContourError::TooFewPoints))
        );
        assert_eq!(
            JointSpline::<f32, 2>::fit(&three, 0.01, z, z, ok).err(),
            Some(SplineError::Contour(ContourError::Capacity))
        );
        assert!(JointSpline::<f32, 8>::fit(&three, 0.0, z, z, ok).is_err());
        let far = [z, Vector3::new(0.5, 0.0, 0.0), z];
        assert_eq!(
            JointSpline::<f32, 8>::fit(&far, 0.01, z, z, vertical_delta).err(),
            Some(SplineError::Joint {
                index: 1,
                error: Unreachable
            })
        );
        let nan = [z, Vector3::new(f64::NAN, 0.0, 0.0), z];
        assert_eq!(
            JointSpline::<f32, 8>::fit(&nan, 0.01, z, z, ok).err(),
            Some(SplineError::Contour(ContourError::NotFinitePoint(1)))
        );
    }
}
