//! Forward kinematics: closed-form elimination with the vector trilateration fallback.

use super::{at_least, cross3, dot3, exceeds, or_not_finite, DeltaGeometry, KinematicsError};
use crate::scalar::{lit, Float};
use nalgebra::Vector3;

impl<T: Float> DeltaGeometry<T> {
    /// Forward kinematics: effector position p = (x, y, z) in m from the displacements
    /// q = (d1, d2, d3) in m. Closed form, no iteration (docs/equations.md §6, forward
    /// kinematics; T eqs. 106–131).
    ///
    /// Subtracting sphere 3 from spheres 1 and 2 leaves two planes mi · p = hi whose
    /// intersection is the radical line with direction n = m1 × m2. Normally x, y are
    /// eliminated as functions of z (the print's A [x y]ᵀ = Γ z + Λ, with det A ∝ nz);
    /// where A is singular or nearly so the line is parameterized along n instead. The
    /// line is then intersected with sphere 1 using the cancellation-free root formula.
    ///
    /// NaN or ±∞ in q fails the travel check. Sphere centres closer together than
    /// `SINGULAR_SINE` times the arm length are [`KinematicsError::CoincidentCentres`].
    pub fn forward(&self, q: &Vector3<T>) -> Result<Vector3<T>, KinematicsError> {
        let [act1, act2, act3] = &self.actuators;
        let (d1, d2, d3) = (q.x, q.y, q.z);
        if !(act1.in_travel(d1) && act2.in_travel(d2) && act3.in_travel(d3)) {
            return Err(self.travel_error(q));
        }
        let a1 = act1.half_sigma(d1);
        let a2 = act2.half_sigma(d2);
        let a3 = act3.half_sigma(d3);
        // Sphere i minus sphere 3: 2 (ai − a3) · p = λi − λ3 (T eqs. 111–112, halved).
        let lambda3 = act3.lambda(d3);
        let half: T = lit(0.5);
        let h1 = (act1.lambda(d1) - lambda3) * half;
        let h2 = (act2.lambda(d2) - lambda3) * half;
        let m1 = a1 - a3;
        let m2 = a2 - a3;
        let n = cross3(&m1, &m2);
        let (m1_sq, m2_sq) = (dot3(&m1, &m1), dot3(&m2, &m2));
        // Absolute before relative: the direction between centres a rounding apart is
        // arbitrary, so n of tiny m1, m2 can pass the sine tests below.
        let m12 = m1 - m2;
        let apart = self.coincident_sq_m2;
        if !(exceeds(m1_sq, apart) && exceeds(m2_sq, apart) && exceeds(dot3(&m12, &m12), apart)) {
            return Err(KinematicsError::CoincidentCentres);
        }
        let scale_sq = m1_sq * m2_sq;
        // Strict, so that nz = 0 never divides below (not even with the test hook
        // `elimination_sine_sq = 0`).
        if !exceeds(n.z * n.z, self.elimination_sine_sq * scale_sq) {
            return self.forward_along_normal(q);
        }
        // Elimination: det A = 4 nz; x = e1 + g1 z, y = e2 + g2 z (T eqs. 118–124), so
        // the line is p = e + t g with g = (g1, g2, 1), e = (e1, e2, 0) and t = z.
        let inv = T::one() / n.z;
        let (g1, g2) = (n.x * inv, n.y * inv);
        let e1 = (m2.y * h1 - m1.y * h2) * inv;
        let e2 = (m1.x * h2 - m2.x * h1) * inv;
        // |e + t g + a1|² = l1²  ⇒  η t² + 2 β t + γ = 0 (T eqs. 125–129, halved υ).
        let (wx, wy, wz) = (e1 + a1.x, e2 + a1.y, a1.z);
        let eta = g1 * g1 + g2 * g2 + T::one();
        let beta = g1 * wx + g2 * wy + wz;
        let gamma = wx * wx + wy * wy + wz * wz - act1.arm_sq_m2;
        let disc = beta * beta - eta * gamma;
        if !at_least(disc, T::zero()) {
            return Err(KinematicsError::OutOfReach(0));
        }
        let t = line_parameter(beta, gamma, eta, self.fk_sign * disc.fsqrt());
        let p = Vector3::new(e1 + g1 * t, e2 + g2 * t, t);
        self.check_branches(q, &p)?;
        Ok(p)
    }

    /// The error for a q that failed the travel check.
    #[cold]
    #[inline(never)]
    fn travel_error(&self, q: &Vector3<T>) -> KinematicsError {
        let outside = (self.actuators.iter().zip(q.iter()))
            .position(|(act, d)| !act.in_travel(*d))
            .unwrap_or(0);
        or_not_finite(&[q], KinematicsError::OutsideTravel(outside as u8))
    }

    /// Forward kinematics where the radical line is (nearly) horizontal (vector
    /// trilateration): the point of the line in the plane of the centres is
    /// e = (h1 (m2 × n) − h2 (m1 × n)) / |n|², since m1·(m2 × n) = |n|² and
    /// m1·(m1 × n) = 0 (likewise for m2). n is oriented upwards so that the `Plus` root
    /// is still the larger z. Out of line and starting over from q, so that the common
    /// path keeps its intermediate values in registers.
    #[inline(never)]
    fn forward_along_normal(&self, q: &Vector3<T>) -> Result<Vector3<T>, KinematicsError> {
        let [act1, act2, act3] = &self.actuators;
        let a1 = act1.half_sigma(q.x);
        let a3 = act3.half_sigma(q.z);
        let lambda3 = act3.lambda(q.z);
        let half: T = lit(0.5);
        let h1 = (act1.lambda(q.x) - lambda3) * half;
        let h2 = (act2.lambda(q.y) - lambda3) * half;
        let m1 = a1 - a3;
        let m2 = act2.half_sigma(q.y) - a3;
        let n = cross3(&m1, &m2);
        let scale_sq = dot3(&m1, &m1) * dot3(&m2, &m2);
        let n_sq = dot3(&n, &n);
        if !exceeds(n_sq, self.singular_sine_sq * scale_sq) {
            return Err(KinematicsError::SingularCentres);
        }
        let e = (cross3(&m2, &n) * h1 - cross3(&m1, &n) * h2) / n_sq;
        let g = if n.z < T::zero() { -n } else { n };
        let w = e + a1;
        let eta = n_sq;
        let beta = dot3(&g, &w);
        let gamma = dot3(&w, &w) - self.actuators[0].arm_sq_m2;
        let disc = beta * beta - eta * gamma;
        if !at_least(disc, T::zero()) {
            return Err(KinematicsError::OutOfReach(0));
        }
        let root = self.fk_sign * disc.fsqrt();
        let p = e + g * line_parameter(beta, gamma, eta, root);
        match self.check_branches(q, &p) {
            // Where the line is (nearly) horizontal both roots have (nearly) the same z,
            // so "larger z" no longer tells the assembly modes apart: take the other
            // root when only it is in the working mode.
            Err(err) => {
                let other = e + g * line_parameter(beta, gamma, eta, -root);
                self.check_branches(q, &other).map_err(|_| err)?;
                Ok(other)
            }
            Ok(()) => Ok(p),
        }
    }

    /// Working mode: each arm must be on its configured IK branch, sign(fdi) = si
    /// (docs/equations.md §6, branches).
    #[inline]
    fn check_branches(&self, q: &Vector3<T>, p: &Vector3<T>) -> Result<(), KinematicsError> {
        let [act1, act2, act3] = &self.actuators;
        if act1.fd(q.x, p) * act1.ik_sign < T::zero() {
            return Err(KinematicsError::WrongBranch(0));
        }
        if act2.fd(q.y, p) * act2.ik_sign < T::zero() {
            return Err(KinematicsError::WrongBranch(1));
        }
        if act3.fd(q.z, p) * act3.ik_sign < T::zero() {
            return Err(KinematicsError::WrongBranch(2));
        }
        Ok(())
    }
}

/// The parameter t of the root of η t² + 2 β t + γ = 0 on the line, t = (−β + root)/η
/// with root = ±√(β² − ηγ). When root and −β have opposite signs that sum cancels, so
/// the equivalent t = γ / (−β − root) is used (T eq. 131 in its cancellation-free
/// form).
#[inline]
fn line_parameter<T: Float>(beta: T, gamma: T, eta: T, root: T) -> T {
    if root * beta <= T::zero() {
        (root - beta) / eta
    } else {
        gamma / (-beta - root)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use crate::kinematics::delta::test_util::*;
    use crate::kinematics::delta::*;
    use nalgebra::Matrix3;

    /// Independent reference: Newton's method on the three sphere equations
    /// |p − ci|² = li² with the carriage-minus-joint-offset centres ci built from the
    /// geometric description (T eqs. 98–102), not from the σ/λ coefficients.
    fn newton_fk(c: &DeltaConfig, q: &V) -> Option<V> {
        newton_fk_from(c, q, V::zeros())
    }

    /// [`newton_fk`] with the start moved by `nudge`.
    fn newton_fk_from(c: &DeltaConfig, q: &V, nudge: V) -> Option<V> {
        let centre = |i: usize| {
            let a = &c.actuators[i];
            let (st, ct) = a.theta_rad.sin_cos();
            let (sa, ca) = a.alpha_rad.sin_cos();
            let base = V::new(ct, st, 0.0) * a.base_radius_m;
            let rail = V::new(-ca * ct, -ca * st, sa);
            base + rail * q[i] - V::new(ct, st, 0.0) * a.effector_radius_m
        };
        let cs = [centre(0), centre(1), centre(2)];
        let mean_arm = c.actuators.iter().map(|a| a.arm_m).sum::<f64>() / 3.0;
        // Start above (or below, for the `Minus` root) the centres' centroid.
        let mut p = (cs[0] + cs[1] + cs[2]) / 3.0 + V::z() * (c.fk_root.sign() * mean_arm) + nudge;
        for _ in 0..100 {
            let r = V::from_fn(|i, _| (p - cs[i]).norm_squared() - c.actuators[i].arm_m.powi(2));
            let jac = Matrix3::from_fn(|i, j| 2.0 * (p - cs[i])[j]);
            let step = jac.lu().solve(&r)?;
            p -= step;
            if step.norm() < 1e-15 {
                break;
            }
        }
        Some(p)
    }

    #[test]
    fn fk_agrees_with_a_newton_solve_of_the_sphere_equations() {
        for (name, c) in all() {
            let mut g = geometry::<f64>(&c);
            // Both closed forms everywhere: always eliminate (unless nz = 0 exactly), then
            // always take the vector fallback.
            for (path, sine_sq) in [("elimination", 0.0), ("fallback", 2.0)] {
                g.elimination_sine_sq = sine_sq;
                let mut compared = 0;
                for (q, _) in workspace(&c, 10) {
                    let p = g.forward(&q).unwrap();
                    let reference = newton_fk(&c, &q).unwrap();
                    // Newton may land on the other assembly mode from its fixed start;
                    // compare only where it found this mode (same side in z).
                    if (reference.z - p.z).abs() > 1e-3 {
                        continue;
                    }
                    compared += 1;
                    // Newton converges quadratically to rounding (1e-16 × 0.3 m); the
                    // closed form's conditioning is bounded by SINGULAR_SINE: 1e-10 m.
                    assert!(
                        (reference - p).amax() < 1e-10,
                        "{name} {path}: {p} vs {reference}"
                    );
                }
                assert!(compared > 100, "{name} {path}: only {compared} compared");
            }
        }
    }

    #[test]
    fn fallback_solves_where_the_elimination_matrix_is_singular() {
        // Keops whose centres' horizontal projections are collinear: with
        // ζ1 = ζ2 = 2k and ζ3 = −k at 90°/210°/330°, ζ1ζ2 + ζ2ζ3 + ζ3ζ1 = 0, so det A = 0
        // and both assembly modes have the same z.
        let mut c = DeltaConfig::SLAVE_KEOPS;
        for a in c.actuators.iter_mut() {
            a.base_radius_m = 0.040;
            a.effector_radius_m = 0.020;
            a.travel_max_m = 0.080;
        }
        let ca = (30.0 * DEG).cos();
        let k = 0.01;
        let q = V::new(
            (2.0 * k + 0.02) / ca,
            (2.0 * k + 0.02) / ca,
            (0.02 - k) / ca,
        );
        // Take the working mode of the pose an independent solve finds there (started
        // off the vertical plane of the centres, where its Jacobian would be singular).
        let reference = newton_fk_from(&c, &q, V::x() * 0.02).unwrap();
        let probe = geometry::<f64>(&c);
        for (i, a) in c.actuators.iter_mut().enumerate() {
            let fd = probe.actuators[i].fd(q[i], &reference);
            a.ik_root = if fd > 0.0 { Root::Plus } else { Root::Minus };
        }
        let g = geometry::<f64>(&c);
        let [m1, m2] =
            [0, 1].map(|i| g.actuators[i].half_sigma(q[i]) - g.actuators[2].half_sigma(q[2]));
        assert!(m1.cross(&m2).z.abs() < 1e-15, "det A = 0 by construction");
        let p = g.forward(&q).unwrap();
        assert!((p - reference).amax() < 1e-10, "{p} vs {reference}");
        assert!(loop_residual(&c, &q, &p) < ROUND_TRIP_M);
        let back = g.inverse(&p).unwrap();
        assert!((back - q).amax() < ROUND_TRIP_M, "{q} -> {p} -> {back}");
    }
    /// Vertical rails with equal base and effector radii put every sphere centre on
    /// the z axis, up to the rounding of cos 90° (6e-17): at equal displacements the
    /// three centres coincide within 1e-18 m, and their separations point anywhere,
    /// so the sine tests pass on rounding. Refused by the absolute test, as is a
    /// pair of centres closer than SINGULAR_SINE · l; centres 1 mm apart still solve.
    #[test]
    fn coincident_sphere_centres_are_refused() {
        let mut c = DeltaConfig::VERTICAL;
        for a in c.actuators.iter_mut() {
            a.effector_radius_m = a.base_radius_m;
        }
        let g = geometry::<f64>(&c);
        let g32 = geometry::<f32>(&c);
        let d = 0.5 * (c.actuators[0].travel_min_m + c.actuators[0].travel_max_m);
        assert_eq!(
            g.forward(&V::repeat(d)),
            Err(KinematicsError::CoincidentCentres)
        );
        assert_eq!(
            g32.forward(&Vector3::repeat(d as f32)),
            Err(KinematicsError::CoincidentCentres)
        );
        // The threshold from the geometry alone: SINGULAR_SINE × the mean arm.
        let arm = libm::cbrt(c.actuators.iter().map(|a| a.arm_m).product::<f64>());
        let limit = 1e-3 * arm;
        // Centre i is at z = −di here: a pair (1, 3) closer than the limit, the other
        // centre far, is refused; every pair beyond it is not.
        let near = V::new(d + 0.5 * limit, d + 0.02, d);
        assert_eq!(g.forward(&near), Err(KinematicsError::CoincidentCentres));
        let spread = V::new(d + 0.01, d + 0.02, d);
        assert_ne!(g.forward(&spread), Err(KinematicsError::CoincidentCentres));
    }
}
