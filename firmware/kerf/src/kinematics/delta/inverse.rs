//! Inverse kinematics and the reachability check.

use super::{at_least, or_not_finite, Actuator, DeltaGeometry, KinematicsError};
use crate::scalar::Float;
use nalgebra::Vector3;

impl<T: Float> Actuator<T> {
    /// di = si √(μ1i²/4 − μ2i) − μ1i/2 for actuator `index` (docs/equations.md §6,
    /// inverse kinematics; T eqs. 132–137),
    /// see [`DeltaGeometry::inverse`].
    #[inline]
    fn displacement(&self, p: &Vector3<T>, index: u8) -> Result<T, KinematicsError> {
        self.displacement_and_fd(p, index).map(|(d_m, _)| d_m)
    }

    /// [`Actuator::displacement`] and J1's entry fdi = wi · (vi + di wi) = vi · wi + di,
    /// which is si √(μ1i²/4 − μ2i) (J1 comes free from IK: docs/equations.md §6).
    #[inline]
    pub(super) fn displacement_and_fd(
        &self,
        p: &Vector3<T>,
        index: u8,
    ) -> Result<(T, T), KinematicsError> {
        // vi = p + bi in the actuator's frame (radial cθi, sθi; tangential −sθi, cθi; z).
        let radial = self.c_theta * p.x + self.s_theta * p.y + self.offset_m;
        let tangential = self.c_theta * p.y - self.s_theta * p.x;
        // There wi = (cαi, 0, −sαi): vi · wi, and the two components of vi across the rail.
        let along = self.c_alpha * radial - self.s_alpha * p.z;
        let across = self.s_alpha * radial + self.c_alpha * p.z;
        let disc = self.arm_sq_m2 - tangential * tangential - across * across;
        if !at_least(disc, T::zero()) {
            return Err(KinematicsError::OutOfReach(index));
        }
        let fd_m = self.ik_sign * disc.fsqrt();
        let d_m = fd_m - along;
        if !self.in_travel(d_m) {
            return Err(KinematicsError::OutsideTravel(index));
        }
        Ok((d_m, fd_m))
    }
}

impl<T: Float> DeltaGeometry<T> {
    /// Inverse kinematics: displacements q in m for the effector position p in m
    /// (docs/equations.md §6, T eqs. 132–137): di = −μ1i/2 + si √(μ1i²/4 − μ2i), si the
    /// configured branch. Errors when a discriminant is negative or di leaves the travel.
    ///
    /// Evaluated in the equivalent geometric form: with vi = p + (re − rb)(cθi, sθi, 0)
    /// and the unit vector wi = (cθi cαi, sθi cαi, −sαi), the loop closure is
    /// |vi + di wi|² = li², so μ1i/2 = vi · wi and μ1i²/4 − μ2i = li² − |vi × wi|²
    /// (li² minus the squared distance of the joint from the rail). Expanding μ2i
    /// instead subtracts two nearly equal ~0.05 m² terms, which cost 1 µm in f32 on
    /// the vertical preset; this form keeps it below 0.1 µm. Both products are taken
    /// in the actuator's vertical plane, where wi has two non-zero components.
    ///
    /// NaN or ±∞ in p makes μ1i or |vi × wi|² NaN or ±∞ (|vi|² is their sum), which
    /// fails the discriminant or the travel check.
    pub fn inverse(&self, p: &Vector3<T>) -> Result<Vector3<T>, KinematicsError> {
        let [act1, act2, act3] = &self.actuators;
        let q = (|| {
            Ok(Vector3::new(
                act1.displacement(p, 0)?,
                act2.displacement(p, 1)?,
                act3.displacement(p, 2)?,
            ))
        })();
        q.map_err(|err| or_not_finite(&[p], err))
    }

    /// `true` when the pose p is reachable in the working mode within travel and away
    /// from singularities: [`inverse`](Self::inverse) and [`jacobian`](Self::jacobian)
    /// both succeed.
    pub fn reachable(&self, p: &Vector3<T>) -> bool {
        self.inverse(p).and_then(|q| self.jacobian(&q, p)).is_ok()
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use crate::kinematics::delta::test_util::*;
    use crate::kinematics::delta::*;
    use proptest::prelude::*;
    use std::println;

    #[test]
    fn ik_inverts_fk_over_the_joint_grid() {
        for (name, c) in all() {
            let g = geometry::<f64>(&c);
            let grid = joint_grid(&c, 14);
            let ws = workspace(&c, 14);
            // Not vacuous: a fair share of every travel box assembles.
            assert!(
                ws.len() * 5 > grid.len(),
                "{name}: {} of {}",
                ws.len(),
                grid.len()
            );
            for (q, p) in ws {
                assert!(loop_residual(&c, &q, &p) < ROUND_TRIP_M, "{name} {q}");
                let back = g.inverse(&p).unwrap();
                assert!(
                    (back - q).amax() < ROUND_TRIP_M,
                    "{name}: {q} -> {p} -> {back}"
                );
            }
        }
    }

    proptest! {
        /// IK∘FK from random joint points, and FK∘IK at random poses near them (up to
        /// ±10 mm away, so poses off the joint grid and outside the workspace occur).
        #[test]
        fn round_trips_over_the_workspace(
            which in 0usize..6,
            u in proptest::array::uniform3(0.0f64..=1.0),
            dp in proptest::array::uniform3(-0.01f64..=0.01),
        ) {
            let (name, c) = all()[which];
            let g = geometry::<f64>(&c);
            let q = travel_point(&c, u);
            if let Ok(p) = g.forward(&q) {
                let back = g.inverse(&p).unwrap();
                prop_assert!((back - q).amax() < ROUND_TRIP_M, "{} {} {}", name, q, back);
                let p2 = p + V::from(dp);
                if g.reachable(&p2) {
                    let q2 = g.inverse(&p2).unwrap();
                    let p3 = g.forward(&q2).unwrap();
                    prop_assert!((p3 - p2).amax() < ROUND_TRIP_M, "{} {} {}", name, p2, p3);
                }
            }
        }
    }

    /// Whether Q31.32 fixed point is usable: the inverse kinematics (the per-period map
    /// of the slave) evaluated with the same formula as `Actuator::displacement` in
    /// `fixed`'s I32F32 (exactly rounded products and square root), against f64 over
    /// the presets' workspaces. Expected: each product rounds at 2^-33 m (about
    /// 1e-10 m), the discriminant (~l² ≈ 5e-3 m²) then carries a few such roundings
    /// into √ with gain 1/(2√Δ) ≈ 7, so a few nm.
    #[test]
    fn q31_32_inverse_kinematics_is_usable_to_nanometres() {
        use fixed::types::I32F32;
        let q = |v: f64| I32F32::from_num(v);
        for (name, c) in all() {
            let g = geometry::<f64>(&c);
            let mut worst = 0.0f64;
            for (_, p) in workspace(&c, 12) {
                let exact = g.inverse(&p).unwrap();
                for (i, a) in c.actuators.iter().enumerate() {
                    let (ct, st) = (q(libm::cos(a.theta_rad)), q(libm::sin(a.theta_rad)));
                    let (ca, sa) = (q(libm::cos(a.alpha_rad)), q(libm::sin(a.alpha_rad)));
                    let offset = q(a.effector_radius_m - a.base_radius_m);
                    let (x, y, z) = (q(p.x), q(p.y), q(p.z));
                    let radial = ct * x + st * y + offset;
                    let tangential = ct * y - st * x;
                    let along = ca * radial - sa * z;
                    let across = sa * radial + ca * z;
                    let disc = q(a.arm_m * a.arm_m) - tangential * tangential - across * across;
                    let root = disc.sqrt();
                    let d = if a.ik_root == Root::Plus { root } else { -root } - along;
                    worst = worst.max((d.to_num::<f64>() - exact[i]).abs());
                }
            }
            println!(
                "{name}: Q31.32 inverse kinematics within {:.2} nm of f64",
                worst * 1e9
            );
            assert!(worst < 20e-9, "{name}: {worst}");
        }
    }
}
