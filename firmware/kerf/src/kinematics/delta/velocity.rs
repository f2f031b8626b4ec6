//! Velocity level: the Jacobian Jx, its inverse and its time derivative.

use super::{cross3, dot3, or_not_finite, zero_if_finite, DeltaGeometry, KinematicsError};
use crate::scalar::Float;
use nalgebra::{Matrix3, Vector3};

/// What the velocity maps share at (q, p) (docs/equations.md §6, velocity;
/// T eqs. 138–145).
struct VelocityTerms<T> {
    /// Arm vectors gi = p + ai; J2's rows are fi = −gi, so J2 = −G.
    g: [Vector3<T>; 3],
    /// J1's diagonal fdi = wi · gi.
    fd: Vector3<T>,
    /// Columns g2 × g3, g3 × g1, g1 × g2 of adj G = adj J2 (3 × 3: adj(−G) = adj G).
    adj: [Vector3<T>; 3],
    /// 1 / det J2 = −1 / det G, so that J2⁻¹ = adj G / det J2.
    inv_det_j2: T,
}

impl<T: Float> VelocityTerms<T> {
    /// Jx = J2⁻¹ J1: the diagonal J1 scales column j of adj G / det J2 by fdj.
    #[inline]
    fn jacobian(&self) -> Matrix3<T> {
        let s = self.fd * self.inv_det_j2;
        Matrix3::from_columns(&[self.adj[0] * s.x, self.adj[1] * s.y, self.adj[2] * s.z])
    }

    /// Jx v without forming Jx: adj G (fd ∘ v) / det J2.
    #[inline(always)]
    fn jacobian_times(&self, v: &Vector3<T>) -> Vector3<T> {
        let [c1, c2, c3] = &self.adj;
        let s = self.fd.component_mul(v) * self.inv_det_j2;
        c1 * s.x + c2 * s.y + c3 * s.z
    }

    /// Jx⁻¹ v without forming Jx⁻¹: row i of Jx⁻¹ is −gi / fdi.
    #[inline(always)]
    fn inverse_times(&self, v: &Vector3<T>) -> Vector3<T> {
        let [g1, g2, g3] = &self.g;
        Vector3::new(
            -dot3(g1, v) / self.fd.x,
            -dot3(g2, v) / self.fd.y,
            -dot3(g3, v) / self.fd.z,
        )
    }
}

#[inline]
fn finite_vectors<T: Float, const K: usize>(
    v: [Vector3<T>; K],
) -> Result<[Vector3<T>; K], KinematicsError> {
    let sum = v.iter().fold(T::zero(), |sum, v| sum + v.x + v.y + v.z);
    if zero_if_finite(sum) == T::zero() {
        Ok(v)
    } else {
        Err(KinematicsError::NotFinite)
    }
}

/// `m`, or [`KinematicsError::NotFinite`] when an entry overflowed the scalar: finite
/// inputs far outside the travel (|q| near `f32::MAX`) pass the singularity tests but
/// not the products after them. One test on the sum of the entries times zero: an
/// infinite or NaN entry makes the sum ±∞ or NaN (∞ − ∞ is NaN), and so does a sum of
/// finite entries beyond the scalar's range, which no Jacobian of a robot has.
#[inline]
fn finite_matrix<T: Float>(m: Matrix3<T>) -> Result<Matrix3<T>, KinematicsError> {
    if zero_if_finite(m.iter().fold(T::zero(), |sum, x| sum + *x)) == T::zero() {
        Ok(m)
    } else {
        Err(KinematicsError::NotFinite)
    }
}

impl<T: Float> DeltaGeometry<T> {
    /// J2 = −G, J1 = diag(fdi) and J2⁻¹ = adj G / det J2 (docs/equations.md §6,
    /// T eqs. 138–145), with the singularity checks. Inlined so that each map keeps
    /// only what it uses in registers.
    ///
    /// NaN or ±∞ in q or p makes a row gi non-finite and with it det G (every entry
    /// of G enters a product of det G = g1 · (g2 × g3)), which fails the J2 check.
    #[inline(always)]
    fn velocity_terms(
        &self,
        q: &Vector3<T>,
        p: &Vector3<T>,
    ) -> Result<VelocityTerms<T>, KinematicsError> {
        let [act1, act2, act3] = &self.actuators;
        let g = [
            p + act1.half_sigma(q.x),
            p + act2.half_sigma(q.y),
            p + act3.half_sigma(q.z),
        ];
        let fd = Vector3::new(
            dot3(&act1.rail, &g[0]),
            dot3(&act2.rail, &g[1]),
            dot3(&act3.rail, &g[2]),
        );
        self.terms_of(g, fd)
            .map_err(|err| or_not_finite(&[q, p], err))
    }

    /// [`DeltaGeometry::velocity_terms`] from the arm vectors and J1's diagonal, with
    /// the singularity checks (the caller names non-finite inputs).
    #[inline(always)]
    fn terms_of(
        &self,
        g: [Vector3<T>; 3],
        fd: Vector3<T>,
    ) -> Result<VelocityTerms<T>, KinematicsError> {
        let [act1, act2, act3] = &self.actuators;
        let err = if fd.x.abs() < act1.singular_fd_m {
            KinematicsError::SingularJ1(0)
        } else if fd.y.abs() < act2.singular_fd_m {
            KinematicsError::SingularJ1(1)
        } else if fd.z.abs() < act3.singular_fd_m {
            KinematicsError::SingularJ1(2)
        } else {
            let [g1, g2, g3] = &g;
            let adj = [cross3(g2, g3), cross3(g3, g1), cross3(g1, g2)];
            let det_g = dot3(g1, &adj[0]);
            if det_g.abs() >= self.singular_det_m3 && zero_if_finite(det_g) == T::zero() {
                return Ok(VelocityTerms {
                    g,
                    fd,
                    adj,
                    inv_det_j2: -T::one() / det_g,
                });
            }
            KinematicsError::SingularJ2
        };
        Err(err)
    }

    /// Inverse kinematics and Jx at the same pose in one pass: q = IK(p) and Jx(q, p),
    /// equal to [`inverse`](Self::inverse) then [`jacobian`](Self::jacobian) up to
    /// rounding. The two share each arm's vector: IK gives J1's entry fdi = si √Δi
    /// and the carriage di, so the arm gi = p + bi + di wi costs one multiply-add per
    /// component and no dot product (J1 comes free from IK: docs/equations.md §6).
    pub fn inverse_with_jacobian(
        &self,
        p: &Vector3<T>,
    ) -> Result<(Vector3<T>, Matrix3<T>), KinematicsError> {
        let (q, terms) = self.inverse_and_terms(p)?;
        Ok((q, finite_matrix(terms.jacobian())?))
    }

    /// IK and the velocity terms at p in one pass (see [`Self::inverse_with_jacobian`]).
    #[inline(always)]
    fn inverse_and_terms(
        &self,
        p: &Vector3<T>,
    ) -> Result<(Vector3<T>, VelocityTerms<T>), KinematicsError> {
        let [act1, act2, act3] = &self.actuators;
        let solved = (|| {
            let (d1, fd1) = act1.displacement_and_fd(p, 0)?;
            let (d2, fd2) = act2.displacement_and_fd(p, 1)?;
            let (d3, fd3) = act3.displacement_and_fd(p, 2)?;
            let g = [
                p + act1.half_sigma(d1),
                p + act2.half_sigma(d2),
                p + act3.half_sigma(d3),
            ];
            let terms = self.terms_of(g, Vector3::new(fd1, fd2, fd3))?;
            Ok((Vector3::new(d1, d2, d3), terms))
        })();
        solved.map_err(|err| or_not_finite(&[p], err))
    }

    /// J̇x q̇ (m/s²) at the pose of `terms`, moving with q̇ and ṗ = Jx q̇, without forming
    /// Jx or J̇x: with M = J̇1 + Ġ Jx as in [`Self::jacobian_derivative`], entry i of
    /// M q̇ is ġi · ṗ + ḟdi q̇i (ġi = ṗ + wi q̇i, ḟdi = wi · ġi), and J̇x q̇ = adj G (M q̇) /
    /// det J2: about 40 multiply-adds against the matrix products' 110.
    #[inline(always)]
    fn jacobian_derivative_times(
        &self,
        terms: &VelocityTerms<T>,
        p_dot: &Vector3<T>,
        q_dot: &Vector3<T>,
    ) -> Vector3<T> {
        let [act1, act2, act3] = &self.actuators;
        let row = |rail: &Vector3<T>, q_dot_i: T| {
            let g_dot = p_dot + rail * q_dot_i;
            dot3(&g_dot, p_dot) + dot3(rail, &g_dot) * q_dot_i
        };
        let m = Vector3::new(
            row(&act1.rail, q_dot.x),
            row(&act2.rail, q_dot.y),
            row(&act3.rail, q_dot.z),
        );
        let [c1, c2, c3] = &terms.adj;
        (c1 * m.x + c2 * m.y + c3 * m.z) * terms.inv_det_j2
    }

    /// Jx = J2⁻¹ J1 at the consistent pair (q, p), so that ṗ = Jx q̇ (T eq. 146).
    pub fn jacobian(&self, q: &Vector3<T>, p: &Vector3<T>) -> Result<Matrix3<T>, KinematicsError> {
        finite_matrix(self.velocity_terms(q, p)?.jacobian())
    }

    /// Jx⁻¹ = J1⁻¹ J2 at (q, p), so that q̇ = Jx⁻¹ ṗ: row i is fi / fdi = −gi / fdi.
    pub fn jacobian_inverse(
        &self,
        q: &Vector3<T>,
        p: &Vector3<T>,
    ) -> Result<Matrix3<T>, KinematicsError> {
        let VelocityTerms { g, fd, .. } = self.velocity_terms(q, p)?;
        let [g1, g2, g3] = g;
        finite_matrix(Matrix3::from_rows(&[
            (-g1 / fd.x).transpose(),
            (-g2 / fd.y).transpose(),
            (-g3 / fd.z).transpose(),
        ]))
    }

    /// J̇x at (q, p) moving with joint velocity q̇ (m/s): from J2 Jx = J1,
    /// J̇x = J2⁻¹ (J̇1 − J̇2 Jx) with ṗ = Jx q̇, ḟi = −(ṗ + ȧi) and
    /// ḟdi = cαi (cθi ẋ + sθi ẏ) − sαi ż + ḋi (time derivatives of T eqs. 139–142).
    /// With ġi = ṗ + ḋi wi = −ḟi (ȧi = ḋi wi) that is ḟdi = wi · ġi and
    /// J̇x = adj G (J̇1 + Ġ Jx) / det J2.
    pub fn jacobian_derivative(
        &self,
        q: &Vector3<T>,
        p: &Vector3<T>,
        q_dot: &Vector3<T>,
    ) -> Result<Matrix3<T>, KinematicsError> {
        let zero = T::zero();
        if zero_if_finite(q_dot.x) + zero_if_finite(q_dot.y) + zero_if_finite(q_dot.z) != zero {
            return Err(KinematicsError::NotFinite);
        }
        let terms = self.velocity_terms(q, p)?;
        let jx = terms.jacobian();
        let p_dot = Vector3::new(
            dot3(&jx.row(0).transpose(), q_dot),
            dot3(&jx.row(1).transpose(), q_dot),
            dot3(&jx.row(2).transpose(), q_dot),
        );
        let [act1, act2, act3] = &self.actuators;
        let g_dot = [
            p_dot + act1.rail * q_dot.x,
            p_dot + act2.rail * q_dot.y,
            p_dot + act3.rail * q_dot.z,
        ];
        // M = J̇1 + Ġ Jx: row i is ġiᵀ Jx plus ḟdi = wi · ġi on the diagonal.
        let [gd1, gd2, gd3] = &g_dot;
        let g_dot_rows = Matrix3::from_rows(&[gd1.transpose(), gd2.transpose(), gd3.transpose()]);
        let fd_dot = Vector3::new(
            dot3(&act1.rail, gd1),
            dot3(&act2.rail, gd2),
            dot3(&act3.rail, gd3),
        );
        let m = g_dot_rows * jx + Matrix3::from_diagonal(&fd_dot);
        let [c1, c2, c3] = &terms.adj;
        finite_matrix(Matrix3::from_columns(&[*c1, *c2, *c3]) * m * terms.inv_det_j2)
    }

    /// The effector's position FK(q) and velocity Jx q̇ (m, m/s) from the measured
    /// joints: what a task-space law starts from.
    pub fn task_state(
        &self,
        q: &Vector3<T>,
        q_dot: &Vector3<T>,
    ) -> Result<(Vector3<T>, Vector3<T>), KinematicsError> {
        let p = self.forward(q)?;
        let v = self.jacobian(q, &p)? * q_dot;
        Ok((p, v))
    }

    /// Joint position, velocity and acceleration for the effector's position, velocity
    /// and acceleration (T eq. 146 and its time derivative): q = IK(p), q̇ = Jx⁻¹ṗ,
    /// q̈ = Jx⁻¹(p̈ − J̇x q̇).
    pub fn joint_motion(
        &self,
        p: &Vector3<T>,
        p_dot: &Vector3<T>,
        p_ddot: &Vector3<T>,
    ) -> Result<[Vector3<T>; 3], KinematicsError> {
        // IK and the velocity terms in one pass; J̇x q̇ and Jx⁻¹ applied as vectors.
        let (q, terms) = self.inverse_and_terms(p)?;
        let q_dot = terms.inverse_times(p_dot);
        let rhs = p_ddot - self.jacobian_derivative_times(&terms, p_dot, &q_dot);
        let q_ddot = terms.inverse_times(&rhs);
        finite_vectors([q, q_dot, q_ddot])
    }

    /// The joint accelerations that give the effector the acceleration `p_ddot` (m/s²)
    /// at (q, p) moving with q̇: q̈ = Jx⁻¹ (p̈ − J̇x q̇), the time derivative of T eq. 146.
    pub fn joint_acceleration(
        &self,
        q: &Vector3<T>,
        p: &Vector3<T>,
        q_dot: &Vector3<T>,
        p_ddot: &Vector3<T>,
    ) -> Result<Vector3<T>, KinematicsError> {
        // One set of velocity terms, and J̇x q̇ and Jx⁻¹ applied as vectors.
        let terms = self.velocity_terms(q, p)?;
        let p_dot = terms.jacobian_times(q_dot);
        let rhs = p_ddot - self.jacobian_derivative_times(&terms, &p_dot, q_dot);
        let [q_ddot] = finite_vectors([terms.inverse_times(&rhs)])?;
        Ok(q_ddot)
    }
}

#[cfg(test)]
mod tests {
    use crate::kinematics::delta::test_util::*;
    use nalgebra::Matrix3;

    #[test]
    fn jacobian_matches_finite_differences_of_fk() {
        let h = 1e-6;
        for (name, c) in all() {
            let g = geometry::<f64>(&c);
            for (q, p) in workspace(&c, 8) {
                let jx = g.jacobian(&q, &p).unwrap();
                let mut fd = Matrix3::zeros();
                let mut ok = true;
                for j in 0..3 {
                    let mut dq = V::zeros();
                    dq[j] = h;
                    match (g.forward(&(q + dq)), g.forward(&(q - dq))) {
                        (Ok(a), Ok(b)) => fd.set_column(j, &((a - b) / (2.0 * h))),
                        _ => ok = false, // at the edge of travel
                    }
                }
                if !ok {
                    continue;
                }
                // Central differences: truncation h² |FK'''| ≲ 1e-12 / l², rounding
                // 1e-16 × 0.3 m / h = 3e-11; relative 1e-6 of |Jx| covers both.
                let scale = jx.amax().max(1.0);
                assert!((fd - jx).amax() < 1e-6 * scale, "{name} {q}: {jx} vs {fd}");
                let jinv = g.jacobian_inverse(&q, &p).unwrap();
                assert!(
                    (jx * jinv - Matrix3::identity()).amax() < 1e-9 * scale,
                    "{name}"
                );
            }
        }
    }

    #[test]
    fn jacobian_derivative_matches_finite_differences_along_a_trajectory() {
        let h = 1e-6;
        for (name, c) in all() {
            let g = geometry::<f64>(&c);
            // Each actuator oscillates about the middle of its travel with its own
            // frequency and phase (q̇ up to ~1 m/s).
            let mid = travel_point(&c, [0.5; 3]);
            let amp = 0.25 * (c.actuators[0].travel_max_m - c.actuators[0].travel_min_m);
            let w = [11.0, 17.0, 23.0];
            let q_at = |t: f64| V::from_fn(|i, _| mid[i] + amp * (w[i] * t + i as f64).sin());
            let qd_at = |t: f64| V::from_fn(|i, _| amp * w[i] * (w[i] * t + i as f64).cos());
            let jx_at = |t: f64| {
                let q = q_at(t);
                g.forward(&q).and_then(|p| g.jacobian(&q, &p))
            };
            let mut compared = 0;
            for k in 0..200 {
                let t = k as f64 * 2e-3;
                let q = q_at(t);
                let Ok(p) = g.forward(&q) else { continue };
                let (Ok(jd), Ok(a), Ok(b)) = (
                    g.jacobian_derivative(&q, &p, &qd_at(t)),
                    jx_at(t + h),
                    jx_at(t - h),
                ) else {
                    continue;
                };
                let fd = (a - b) / (2.0 * h);
                // As above: relative 1e-5 of |J̇x| (an extra derivative in the
                // truncation term), with a floor for where J̇x passes through zero.
                let scale = jd.amax().max(1.0);
                assert!(
                    (fd - jd).amax() < 1e-5 * scale,
                    "{name} t={t}: {jd} vs {fd}"
                );
                compared += 1;
            }
            assert!(compared > 20, "{name}: {compared}");
        }
    }

    /// The one-pass IK + Jx against the two maps called one after the other (f64:
    /// they differ by rounding only, fdi taken as si √Δi instead of wi · gi).
    #[test]
    fn inverse_with_jacobian_equals_inverse_then_jacobian() {
        for (name, c) in all() {
            let g = geometry::<f64>(&c);
            let mut compared = 0;
            for (_, p) in workspace(&c, 10) {
                let (Ok(q), Ok(both)) = (g.inverse(&p), g.inverse_with_jacobian(&p)) else {
                    assert!(
                        g.inverse(&p).is_err() || g.jacobian(&g.inverse(&p).unwrap(), &p).is_err()
                    );
                    continue;
                };
                let Ok(jx) = g.jacobian(&q, &p) else {
                    continue;
                };
                assert_eq!(both.0, q, "{name}: IK is the same code");
                let scale = jx.amax().max(1.0);
                assert!(
                    (both.1 - jx).amax() < 1e-10 * scale,
                    "{name} {p}: {} vs {jx}",
                    both.1
                );
                compared += 1;
            }
            assert!(compared > 100, "{name}: {compared}");
        }
        // Errors as the two maps give them: out of reach, and NaN.
        let g = geometry::<f32>(&crate::kinematics::delta::DeltaConfig::SLAVE_KEOPS);
        let far = nalgebra::Vector3::new(1.0f32, 0.0, 0.05);
        assert_eq!(g.inverse_with_jacobian(&far).err(), g.inverse(&far).err());
        let nan = nalgebra::Vector3::new(f32::NAN, 0.0, 0.05);
        assert_eq!(
            g.inverse_with_jacobian(&nan).err(),
            Some(crate::kinematics::delta::KinematicsError::NotFinite)
        );
    }

    /// The vector forms (J̇x q̇ and Jx⁻¹ v without the matrices) against the matrix
    /// products they replace, over each preset's workspace with velocities and
    /// accelerations in every direction.
    #[test]
    fn joint_motion_and_acceleration_equal_the_matrix_products() {
        use nalgebra::Vector3;
        for (name, c) in all() {
            let g = geometry::<f64>(&c);
            let mut compared = 0;
            for (i, (q, p)) in workspace(&c, 8).into_iter().enumerate() {
                let (Ok(jx_inv), Ok(jx)) = (g.jacobian_inverse(&q, &p), g.jacobian(&q, &p)) else {
                    continue;
                };
                let k = i as f64;
                let p_dot = Vector3::new((0.7 * k).sin(), (1.3 * k).cos(), (0.4 * k).sin()) * 0.3;
                let p_ddot = Vector3::new((0.9 * k).cos(), (0.2 * k).sin(), (1.1 * k).cos()) * 20.0;
                let q_dot = jx_inv * p_dot;
                let jx_dot = g.jacobian_derivative(&q, &p, &q_dot).unwrap();
                let q_ddot = jx_inv * (p_ddot - jx_dot * q_dot);
                let [mq, mq_dot, mq_ddot] = g.joint_motion(&p, &p_dot, &p_ddot).unwrap();
                let close =
                    |a: Vector3<f64>, b: Vector3<f64>| (a - b).amax() <= 1e-10 * b.amax().max(1.0);
                assert_eq!(Ok(mq), g.inverse(&p), "{name} {p}: IK is the same code");
                assert!(close(mq_dot, q_dot), "{name} {p}: {mq_dot} vs {q_dot}");
                assert!(close(mq_ddot, q_ddot), "{name} {p}: {mq_ddot} vs {q_ddot}");
                let measured = g.joint_acceleration(&q, &p, &q_dot, &p_ddot).unwrap();
                assert!(
                    close(measured, q_ddot),
                    "{name} {p}: {measured} vs {q_ddot}"
                );
                assert!(close(jx * q_dot, p_dot), "{name} {p}: round trip");
                compared += 1;
            }
            assert!(compared > 100, "{name}: {compared}");
        }
        // A non-finite velocity or acceleration is an error, not a NaN.
        let c = crate::kinematics::delta::DeltaConfig::SLAVE_KEOPS;
        let g = geometry::<f32>(&c);
        let (q, p) = workspace(&c, 4)[5];
        let (q, p) = (q.cast::<f32>(), p.cast::<f32>());
        let nan = Vector3::new(0.0, f32::NAN, 0.0);
        let zero = Vector3::zeros();
        let not_finite = Some(crate::kinematics::delta::KinematicsError::NotFinite);
        assert_eq!(g.joint_motion(&p, &nan, &zero).err(), not_finite);
        assert_eq!(g.joint_motion(&p, &zero, &nan).err(), not_finite);
        assert_eq!(g.joint_acceleration(&q, &p, &nan, &zero).err(), not_finite);
        assert_eq!(g.joint_acceleration(&q, &p, &zero, &nan).err(), not_finite);
    }

    /// Finite inputs so far outside the travel that the Jacobians' products overflow:
    /// NotFinite, not a matrix of infinities.
    #[test]
    fn overflowing_jacobians_are_refused() {
        use crate::kinematics::delta::{DeltaConfig, DeltaGeometry, KinematicsError};
        use nalgebra::Vector3;
        let g = DeltaGeometry::<f32>::new(&DeltaConfig::SLAVE_KEOPS).unwrap();
        let q = Vector3::new(0.02f32, 0.02, 0.02);
        let p = g.forward(&q).unwrap();
        let far = Vector3::new(p.x, f32::MAX, p.z);
        assert_eq!(g.jacobian(&q, &far), Err(KinematicsError::NotFinite));
        let fast = Vector3::new(f32::MAX, 0.0, 0.0);
        assert_eq!(
            g.jacobian_derivative(&q, &p, &fast),
            Err(KinematicsError::NotFinite)
        );
        assert!(g.jacobian(&q, &p).is_ok() && g.jacobian_inverse(&q, &p).is_ok());
    }
}
