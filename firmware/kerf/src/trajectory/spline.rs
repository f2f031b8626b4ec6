//! Joint references (T 3.2.3–3.2.4; docs/equations.md §14): task-space samples taken
//! every `h` seconds are mapped through an inverse kinematics q = I(x) (T eq. 10) and a
//! C² cubic spline in time is fitted per joint, so that each control period can read q,
//! q̇, q̈ and q⃛ (T eq. 11–14).
//!
//! The IK is a parameter (any `FnMut(Vector3<f64>) -> Result<Vector3<f64>, E>`), so the
//! same code serves every kinematics. With knot values qi and second derivatives Mi,
//! continuity of q̇ gives Mi−1 + 4Mi + Mi+1 = 6(qi+1 − 2qi + qi−1)/h² inside; the ends are
//! clamped to given joint velocities (zero for a move from and to rest):
//! 2M0 + M1 = 6((q1 − q0)/h − v0)/h and Mn−2 + 2Mn−1 = 6(vn − (qn−1 − qn−2)/h)/h.
//! A clamped cubic spline reproduces any cubic exactly. The tridiagonal system is
//! diagonally dominant and is solved by the Thomas algorithm in O(n).

use super::{lit, ContourError, Float};
use crate::error::{coefficient, positive, representable, ConfigError};
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

/// When the knots are: one every `periods_per_knot` control periods of `period_s`.
///
/// Time is counted in control periods (an integer), never accumulated in the scalar:
/// an `f32` time in seconds loses a whole 10 kHz period after about 1 s of running
/// and stops advancing near 2,048 s (week-long runs).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct KnotTiming {
    /// Control period Ts, s.
    pub period_s: f64,
    /// Control periods from one knot to the next (≥ 1): the knot period is
    /// `periods_per_knot · period_s`.
    pub periods_per_knot: u32,
    /// The control period (on the machine's 64-bit period counter) at which the first
    /// knot is: [`JointSpline::evaluate`] takes that counter as it is.
    pub first_period: u64,
}

impl KnotTiming {
    /// Knot period h, s.
    pub fn knot_period_s(&self) -> f64 {
        self.period_s * f64::from(self.periods_per_knot)
    }
}

/// C² cubic spline through up to `N` joint-space knots at a uniform period.
#[derive(Clone, Debug)]
pub struct JointSpline<T: Float, const N: usize> {
    q: Vec<Vector3<T>, N>,
    m: Vec<Vector3<T>, N>,
    h: T,
    inv_h: T,
    ts: T,
    periods_per_knot: u32,
    first_period: u64,
    duration_s: f64,
}

/// `v` in `T`, or `ContourError::Config(NotRepresentable(field))` (a NaN is refused
/// before: here only what `T` cannot hold is).
fn in_scalar<T: Float>(field: &'static str, v: &Vector3<f64>) -> Result<Vector3<T>, ContourError> {
    let mut out = Vector3::zeros();
    for (o, x) in out.iter_mut().zip(v.iter()) {
        *o = representable::<T>(field, *x)?;
    }
    Ok(out)
}

impl<T: Float, const N: usize> JointSpline<T, N> {
    /// Maps `task` samples (m, one per knot of `timing`) through `ik` and fits the
    /// spline with joint velocities `start_velocity` and `end_velocity` at the ends.
    ///
    /// Errors: fewer than 3 samples, more than `N`, a non-finite sample, velocity or
    /// period, no periods per knot, the joint map's error for a sample, and values
    /// valid in `f64` that `T` cannot hold (`NotRepresentable`, naming `task`,
    /// `start_velocity`/`end_velocity` or `period_s`: joint values or velocities beyond
    /// the scalar's range, a knot period whose square or inverse overflows it, or
    /// second derivatives (q / h²) that do).
    pub fn fit<E, F>(
        task: &[Vector3<f64>],
        timing: KnotTiming,
        start_velocity: Vector3<f64>,
        end_velocity: Vector3<f64>,
        mut ik: F,
    ) -> Result<Self, SplineError<E>>
    where
        F: FnMut(Vector3<f64>) -> Result<Vector3<f64>, E>,
    {
        let ts = positive("period_s", timing.period_s).map_err(ContourError::from)?;
        if timing.periods_per_knot == 0 {
            return Err(ContourError::Config(ConfigError::not_positive("periods_per_knot")).into());
        }
        let h = positive("period_s", timing.knot_period_s()).map_err(ContourError::from)?;
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
            return Err(ContourError::Config(ConfigError::not_finite("velocity")).into());
        }
        // The period, its knot multiple, h² (the evaluation's w², u²) and 1/h in T.
        let period = |v: f64| coefficient::<T>("period_s", v).map_err(ContourError::from);
        let (ts_t, ht, inv_h) = (period(ts)?, period(h)?, period(1.0 / h)?);
        period(h * h)?;
        let mut q: Vec<Vector3<T>, N> = Vec::new();
        for (index, p) in task.iter().enumerate() {
            let joint = ik(*p).map_err(|error| SplineError::Joint { index, error })?;
            if !finite(&joint) {
                return Err(ContourError::NotFinitePoint(index).into());
            }
            q.push(in_scalar("task", &joint)?)
                .map_err(|_| SplineError::Contour(ContourError::Capacity))?;
        }
        let n = q.len();
        let six = lit::<T>(6.0);
        // Right-hand sides, then forward elimination (Thomas), storing d′ in `m` and the
        // modified upper diagonal c′ in `upper`.
        let mut m: Vec<Vector3<T>, N> = Vec::new();
        let mut upper = [T::ZERO; N];
        let v0 = in_scalar::<T>("start_velocity", &start_velocity)?;
        let vn = in_scalar::<T>("end_velocity", &end_velocity)?;
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
        // What the evaluation computes must stay finite in T: M h², q / h and the jerk
        // (Mi+1 − Mi) / h (overflow means the knots are too close for these values).
        let h_sixth = ht * lit::<T>(1.0 / 6.0);
        let finite_t = |v: Vector3<T>| v.iter().all(|x| x.is_finite());
        let overflow = q.iter().zip(m.iter()).enumerate().any(|(i, (qi, mi))| {
            let jerk = m
                .get(i + 1)
                .map_or(Vector3::zeros(), |next| (next - mi) * inv_h);
            !(finite_t(qi * inv_h - mi * h_sixth) && finite_t(mi * (ht * ht)) && finite_t(jerk))
        });
        if overflow {
            return Err(ContourError::Config(ConfigError::not_representable("period_s")).into());
        }
        Ok(Self {
            q,
            m,
            h: ht,
            inv_h,
            ts: ts_t,
            periods_per_knot: timing.periods_per_knot,
            first_period: timing.first_period,
            duration_s: h * (n - 1) as f64,
        })
    }

    /// Time from the first to the last knot, s.
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// Control periods from the first to the last knot.
    pub fn periods(&self) -> u64 {
        self.q.len().saturating_sub(1) as u64 * u64::from(self.periods_per_knot)
    }

    /// Number of knots.
    pub fn knots(&self) -> usize {
        self.q.len()
    }

    /// Reference at control period `period` of the machine's counter (held at the
    /// first knot before [`KnotTiming::first_period`], at the last one after
    /// [`JointSpline::periods`] more). The period is split into a knot index and a
    /// remainder in integers, so the time inside the knot interval, remainder · Ts, is
    /// as exact at period 10¹⁰ as at period 10.
    pub fn evaluate(&self, period: u64) -> JointReference<T> {
        let Some(period) = period.checked_sub(self.first_period) else {
            return self.evaluate_at(0, T::ZERO);
        };
        let per_knot = u64::from(self.periods_per_knot.max(1));
        let (knot, within) = (period / per_knot, period % per_knot);
        let last = self.q.len().saturating_sub(2) as u64;
        if knot > last {
            return self.evaluate_at(last as usize, self.h);
        }
        // within < 2^32: exact in f64, one rounding in T.
        self.evaluate_at(knot as usize, lit::<T>(within as f64) * self.ts)
    }

    /// Reference `offset_s` seconds after knot `knot` (the offset clamped to one knot
    /// period, a NaN offset taken as 0; a knot past the last interval is the last
    /// interval): for evaluation between control periods.
    pub fn evaluate_at(&self, knot: usize, offset_s: T) -> JointReference<T> {
        let i = knot.min(self.q.len().saturating_sub(2));
        let u = offset_s.max(T::ZERO).min(self.h);
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
        // w³/h as w²·(w/h), so that only h² (checked in `fit`) need be finite.
        JointReference {
            q: m0 * (w * w * (w * ih) * sixth) + m1 * (u * u * (u * ih) * sixth) + a * w + b * u,
            qd: m1 * (u * (u * ih) * half) - m0 * (w * (w * ih) * half) + b - a,
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

    /// Knots every `h` s: ten control periods of h/10 each, from period 0.
    fn every(h: f64) -> KnotTiming {
        KnotTiming {
            period_s: h / 10.0,
            periods_per_knot: 10,
            first_period: 0,
        }
    }

    /// The spline at `t` s after the first knot (f64 tests between periods).
    fn at_time(s: &JointSpline<f64, 1024>, h: f64, t: f64) -> JointReference<f64> {
        let knot = libm::floor(t / h).clamp(0.0, (s.knots() - 2) as f64);
        s.evaluate_at(knot as usize, t - knot * h)
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
        let s = JointSpline::<f64, 1024>::fit(
            &samples,
            every(h),
            dcubic(0.0),
            dcubic(0.39),
            Ok::<_, ()>,
        )
        .unwrap();
        for k in 0..=390 {
            let t = k as f64 * 1e-3 + 3e-4 * (k % 3) as f64;
            let t = t.min(0.39);
            let r = at_time(&s, h, t);
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
        let s = JointSpline::fit(
            &task,
            every(h),
            Vector3::zeros(),
            Vector3::zeros(),
            vertical_delta,
        )
        .unwrap();
        (s, h)
    }

    #[test]
    fn derivatives_match_finite_differences_and_are_c2() {
        let (s, h) = s_letter_spline::<f64>();
        assert!(s.knots() > 300);
        let e = 1e-6;
        let mut t = 2.5e-3;
        while t < s.duration_s() - e {
            let (a, b, r) = (
                at_time(&s, h, t - e),
                at_time(&s, h, t + e),
                at_time(&s, h, t),
            );
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
            let (l, r) = (s.evaluate_at(k - 1, h - 1e-12), s.evaluate_at(k, 1e-12));
            assert!((l.q - r.q).norm() < 1e-12);
            assert!((l.qd - r.qd).norm() < 1e-9);
            assert!((l.qdd - r.qdd).norm() < 1e-6 * l.qddd.norm().max(1.0));
        }
        // Clamped ends: at rest.
        assert!(s.evaluate(0).qd.norm() < 1e-15);
        assert!(s.evaluate(s.periods()).qd.norm() < 1e-12);
        assert!((s.periods() as f64 * h / 10.0 - s.duration_s()).abs() < 1e-12);
    }

    #[test]
    fn f32_spline_follows_f64() {
        let (s64, _) = s_letter_spline::<f64>();
        let (s32, _) = s_letter_spline::<f32>();
        let mut worst: f64 = 0.0;
        for k in 0..3000 {
            let d = s64.evaluate(k).q - s32.evaluate(k).q.map(|v| v as f64);
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
            JointSpline::<f32, 8>::fit(&three[..2], every(0.01), z, z, ok).err(),
            Some(SplineError::Contour(ContourError::TooFewPoints))
        );
        assert_eq!(
            JointSpline::<f32, 2>::fit(&three, every(0.01), z, z, ok).err(),
            Some(SplineError::Contour(ContourError::Capacity))
        );
        assert!(JointSpline::<f32, 8>::fit(&three, every(0.0), z, z, ok).is_err());
        let far = [z, Vector3::new(0.5, 0.0, 0.0), z];
        assert_eq!(
            JointSpline::<f32, 8>::fit(&far, every(0.01), z, z, vertical_delta).err(),
            Some(SplineError::Joint {
                index: 1,
                error: Unreachable
            })
        );
        let nan = [z, Vector3::new(f64::NAN, 0.0, 0.0), z];
        assert_eq!(
            JointSpline::<f32, 8>::fit(&nan, every(0.01), z, z, ok).err(),
            Some(SplineError::Contour(ContourError::NotFinitePoint(1)))
        );
    }

    /// Valid in f64, beyond f32: typed errors naming the field, not a spline of
    /// infinities.
    #[test]
    fn f32_extremes_are_refused_by_name() {
        let z = Vector3::zeros();
        let ok = |p| Ok::<_, ()>(p);
        let line = |scale: f64| -> [Vector3<f64>; 4] {
            core::array::from_fn(|k| Vector3::new(scale * k as f64, 0.0, 0.0))
        };
        let refused = |r: Result<JointSpline<f32, 8>, SplineError<()>>| match r {
            Err(SplineError::Contour(ContourError::Config(e))) => {
                assert_eq!(e.kind, crate::ConfigErrorKind::NotRepresentable);
                e.field()
            }
            other => panic!("{other:?}"),
        };
        assert_eq!(
            refused(JointSpline::fit(&line(1e39), every(0.01), z, z, ok)),
            "task"
        );
        let fast = Vector3::new(1e39, 0.0, 0.0);
        assert_eq!(
            refused(JointSpline::fit(&line(1e-3), every(0.01), fast, z, ok)),
            "start_velocity"
        );
        assert_eq!(
            refused(JointSpline::fit(&line(1e-3), every(0.01), z, fast, ok)),
            "end_velocity"
        );
        // The jerk (Mi+1 − Mi)/h overflows first at 2e-15 s.
        assert_eq!(
            refused(JointSpline::fit(&line(1e-3), every(2e-15), z, z, ok)),
            "period_s"
        );
        // Knots 1e-30 s apart: 1/h and h² leave f32; at 1e-21 s h² is still held
        // (subnormal) but q/h² overflows.
        assert_eq!(
            refused(JointSpline::fit(&line(1e-3), every(1e-30), z, z, ok)),
            "period_s"
        );
        assert_eq!(
            refused(JointSpline::fit(&line(1e-3), every(1e-21), z, z, ok)),
            "period_s"
        );
        assert_eq!(
            refused(JointSpline::fit(&line(1e-3), every(1e20), z, z, ok)),
            "period_s"
        );
        // Each is fine in f64, and evaluates finite there.
        let s = JointSpline::<f64, 8>::fit(&line(1e39), every(0.01), z, z, ok).unwrap();
        assert!(s.evaluate(15).q.iter().all(|v| v.is_finite()));
        assert!(JointSpline::<f64, 8>::fit(&line(1e-3), every(1e-21), z, z, ok).is_ok());
    }

    /// Week-long runs: the spline takes the machine's 64-bit period counter, so one
    /// that starts at period 10⁷ (17 min at 10 kHz) or 6.048·10⁹ (7 days) evaluates in
    /// f32 exactly as one that starts at period 10. Reference: the cubic the clamped
    /// spline reproduces, in f64, at the exact time (k − first)·Ts.
    #[test]
    fn evaluation_late_in_a_week_long_run_is_as_accurate_as_at_the_start() {
        let cubic = |t: f64| {
            Vector3::new(
                0.01 + 0.02 * t - 0.03 * t * t + 0.04 * t * t * t,
                0.02,
                -t * t * t,
            )
        };
        let dcubic = |t: f64| Vector3::new(0.02 - 0.06 * t + 0.12 * t * t, 0.0, -3.0 * t * t);
        let (ts, per_knot, knots) = (1e-4, 100u32, 20usize);
        let h = ts * f64::from(per_knot);
        let samples: StdVec<_> = (0..knots).map(|i| cubic(i as f64 * h)).collect();
        let end = (knots - 1) as f64 * h;
        let worst_from = |first_period: u64| {
            let timing = KnotTiming {
                period_s: ts,
                periods_per_knot: per_knot,
                first_period,
            };
            let s = JointSpline::<f32, 32>::fit(
                &samples,
                timing,
                dcubic(0.0),
                dcubic(end),
                Ok::<_, ()>,
            )
            .unwrap();
            let mut worst: f64 = 0.0;
            for k in 0..=s.periods() {
                let r = s.evaluate(first_period + k);
                let t = k as f64 * ts;
                worst = worst.max((r.q.map(f64::from) - cubic(t)).amax());
                worst = worst.max((r.qd.map(f64::from) - dcubic(t)).amax());
            }
            // Held at the ends.
            assert_eq!(
                s.evaluate(first_period.saturating_sub(1)).q,
                s.evaluate(first_period).q
            );
            assert_eq!(
                s.evaluate(first_period + s.periods() + 5).q,
                s.evaluate(first_period + s.periods()).q
            );
            worst
        };
        let near = worst_from(10);
        // f32 rounding of q ≈ 0.01 (ε = 6e-8: 6e-10 m) and of q̇, which takes the
        // difference of knots over h = 10 ms (6e-8 m/s), a few roundings each.
        assert!(near < 1e-6, "{near}");
        for first in [10_000_000u64, 6_048_000_000] {
            assert_eq!(worst_from(first), near, "first period {first}");
        }
        // What an f32 time in seconds would have done instead: at 7 days its step is
        // 1/16 s (625 periods), so 100 periods later it has not moved.
        let t = 6_048_000_000.0 * ts + 3.0 * ts;
        assert_eq!(t as f32, (t + 100.0 * ts) as f32);
    }
}
