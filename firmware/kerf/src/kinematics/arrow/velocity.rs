//! The differential model of the parallel module (A eq. 13–14) and its singularities
//! (eq. 30–32).
//!
//! Eq. 13 gives Jq q̇ = Jx Ẋ with Jq diagonal, Jq,ii = (m_i·e_x)(e_z·(L_i × μ_i)), and
//! the rows of Jx: [(e_z·(L_i × μ_i))(e_x·m_i), (e_z·(L_i × μ_i))(e_y·m_i),
//! (e_z·(n_i × μ_i))(e_z·m_i), −(e_z·(L_i × μ_i))(e_z·(m_i × PD_i))]. Row i of
//! Jm = Jq⁻¹ Jx is therefore
//!
//!   [1, m_y/m_x, ((n × μ)_z/(L × μ)_z) m_z/m_x, −(m × PD)_z/m_x]_i,
//!
//! and since n_i and L_i have the same horizontal direction u_i (A†, B, C collinear)
//! with horizontal lengths ℓ_i + r_i and ℓ_i, (n × μ)_z/(L × μ)_z = (ℓ_i + r_i)/ℓ_i.
//! [`ArrowGeometry::jacobian_rate`] differentiates that form. The redundancy makes
//! Jm 6×4: the forward differential model is its pseudo-inverse Jm⁺ = (JmᵀJm)⁻¹Jmᵀ
//! (eq. 14).

use super::{ActuatorVector, Arm, ArmClosure, ArrowError, ArrowGeometry, Pose, ACTUATORS};
use crate::scalar::{norm, Float};
use nalgebra::{Matrix4, SMatrix, Vector3};

/// Jm: 6 × 4.
pub type InverseJacobian<T> = SMatrix<T, ACTUATORS, 4>;
/// Jm⁺: 4 × 6.
pub type ForwardJacobian<T> = SMatrix<T, 4, ACTUATORS>;
/// Joint positions, Jm and J̇m at a pose ([`ArrowGeometry::differential`]).
pub type Differential<T> = (ActuatorVector<T>, InverseJacobian<T>, InverseJacobian<T>);

/// How far a pose is from each singularity of eq. 30–32, as sines of the angles whose
/// zero is the singularity (1: as far as it gets; the maps fail below 1e-3).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SingularityDistance<T> {
    /// Eq. 30, min over the arms of |e_x·m_i| / |m_i|: the reach's angle to the wall.
    pub across_rails: T,
    /// Eq. 30–31, min over the arms of |e_z·(L_i × μ_i)| / L_i: the arm's angle to the
    /// vertical.
    pub vertical: T,
    /// Eq. 32, the larger over the two parallelograms of |e_z·(m_i × r_c)| /
    /// (|m_i| |r_c|), with r_c = D_1D_3: the plate's turning lever against the
    /// parallelogram's reach (eq. 32 needs both terms zero).
    pub plate: T,
}

impl<T: Float> SingularityDistance<T> {
    /// The smallest of the three.
    pub fn min(&self) -> T {
        self.across_rails.min(self.vertical).min(self.plate)
    }
}

impl<T: Float> ArrowGeometry<T> {
    /// How far `pose` is from the singularities of eq. 30–32.
    pub fn singularity_distance(
        &self,
        pose: &Pose<T>,
    ) -> Result<SingularityDistance<T>, ArrowError> {
        let mut d = SingularityDistance {
            across_rails: T::one(),
            vertical: T::one(),
            plate: T::zero(),
        };
        let turn = Self::turn(pose)?;
        let mut d1 = Vector3::zeros();
        // Arm by arm, each closure used where it is computed (no array of them copied
        // through the period).
        for (i, arm) in self.arms.iter().enumerate() {
            let c = Self::closure(arm, pose, turn, i)?;
            let reach = norm(&c.reach);
            d.across_rails = d.across_rails.min(c.reach.x.abs() / reach);
            d.vertical = d.vertical.min(c.arm.cross(&c.mu).z.abs() / arm.length_m);
            if i == 0 {
                d1 = c.plate;
            }
            // Eq. 32 with r_c = D1D3 (the print moves P onto D1 for this test):
            // singular when both parallelograms' terms vanish together, so the larger
            // one counts.
            if i == 2 || i == 3 {
                let r_c = c.plate - d1;
                d.plate = d
                    .plate
                    .max(c.reach.cross(&r_c).z.abs() / (reach * norm(&r_c)));
            }
        }
        Ok(d)
    }

    /// Joint positions and Jm = Jq⁻¹ Jx at `pose` (eq. 7, 13). Errors on the
    /// singularities of eq. 30–32 (sines below 1e-3, see [`SingularityDistance`]).
    pub fn jacobian(
        &self,
        pose: &Pose<T>,
    ) -> Result<(ActuatorVector<T>, InverseJacobian<T>), ArrowError> {
        let (q, jm, _) = self.differential(pose, None)?;
        Ok((q, jm))
    }

    /// J̇m at `pose` moving at `rate` (Ẋ): the time derivative of [`Self::jacobian`]'s
    /// rows in the form of the module docs, for q̈ = Jm Ẍ + J̇m Ẋ.
    pub fn jacobian_rate(
        &self,
        pose: &Pose<T>,
        rate: &Pose<T>,
    ) -> Result<InverseJacobian<T>, ArrowError> {
        let (_, _, jm_dot) = self.differential(pose, Some(rate))?;
        Ok(jm_dot)
    }

    /// Joint positions, Jm and, given the `rate` Ẋ, J̇m at `pose` (zeros without a
    /// rate): [`Self::jacobian`] and [`Self::jacobian_rate`] from one evaluation of
    /// each arm's closure (a control period with feedforward needs all three).
    pub fn differential(
        &self,
        pose: &Pose<T>,
        rate: Option<&Pose<T>>,
    ) -> Result<Differential<T>, ArrowError> {
        let turn = Self::turn(pose)?;
        let mut q = ActuatorVector::zeros();
        let mut jm = InverseJacobian::zeros();
        let mut jm_dot = InverseJacobian::zeros();
        let mut d1 = Vector3::zeros();
        let mut plate = T::zero();
        let rows = self
            .arms
            .iter()
            .zip(q.iter_mut())
            .zip(jm_dot.row_iter_mut());
        for (i, (((arm, q_i), mut dot_row), mut row)) in rows.zip(jm.row_iter_mut()).enumerate() {
            let index = i as u8;
            let c = Self::closure(arm, pose, turn, i)?;
            let ez = |v: Vector3<T>| v.z;
            let l_mu = ez(c.arm.cross(&c.mu));
            let n_mu = ez(c.to_c.cross(&c.mu));
            let m = &c.reach;
            let reach = norm(m);
            if m.x.abs() <= self.singular_sine * reach {
                return Err(ArrowError::ArmAcrossRails(index));
            }
            if l_mu.abs() <= self.singular_sine * arm.length_m {
                return Err(ArrowError::ArmVertical(index));
            }
            // Eq. 13 as printed: the diagonal of Jq and the row of Jx.
            let jq = m.x * l_mu;
            let jx = [
                l_mu * m.x,
                l_mu * m.y,
                n_mu * m.z,
                -l_mu * ez(m.cross(&c.plate)),
            ];
            for (out, v) in row.iter_mut().zip(jx) {
                *out = v / jq;
            }
            if let Some(rate) = rate {
                // q̇_i = (Jm Ẋ)_i from the row just formed.
                let q_dot = row.transpose().dot(rate);
                for (out, v) in dot_row
                    .iter_mut()
                    .skip(1)
                    .zip(rate_row(arm, &c, q_dot, rate))
                {
                    *out = v;
                }
            }
            *q_i = c.q_m;
            // Eq. 32, as in `singularity_distance`.
            if i == 0 {
                d1 = c.plate;
            }
            if i == 2 || i == 3 {
                let r_c = c.plate - d1;
                plate = plate.max(m.cross(&r_c).z.abs() / (reach * norm(&r_c)));
            }
        }
        if plate <= self.singular_sine {
            return Err(ArrowError::PlateSingular);
        }
        Ok((q, jm, jm_dot))
    }

    /// Jm⁺ = (JmᵀJm)⁻¹Jmᵀ (eq. 14): Ẋ = Jm⁺ q̇ in the least-squares sense.
    ///
    /// The normal matrix JmᵀJm is symmetric positive definite away from the
    /// singularities of eq. 30–32: its Cholesky factor L (square roots by
    /// [`Float::fsqrt`], the FPU's on the firmware targets) and two triangular solves
    /// for the six columns of Jmᵀ give Jm⁺ with no explicit inverse, and nothing that
    /// can panic (nalgebra's `try_inverse` and LU do not compile without bounds checks).
    pub fn pseudo_inverse(jm: &InverseJacobian<T>) -> Result<ForwardJacobian<T>, ArrowError> {
        let n: Matrix4<T> = jm.tr_mul(jm);
        // A pivot not above zero (or NaN) is a rank-deficient Jm: eq. 32.
        let pivot = |v: T| {
            if v > T::zero() {
                Ok(v.fsqrt())
            } else {
                Err(ArrowError::PlateSingular)
            }
        };
        let l11 = pivot(n.m11)?;
        let (l21, l31, l41) = (n.m21 / l11, n.m31 / l11, n.m41 / l11);
        let l22 = pivot(n.m22 - l21 * l21)?;
        let (l32, l42) = ((n.m32 - l31 * l21) / l22, (n.m42 - l41 * l21) / l22);
        let l33 = pivot(n.m33 - l31 * l31 - l32 * l32)?;
        let l43 = (n.m43 - l41 * l31 - l42 * l32) / l33;
        let l44 = pivot(n.m44 - l41 * l41 - l42 * l42 - l43 * l43)?;
        let z = T::zero();
        #[rustfmt::skip]
        let l = Matrix4::new(
            l11, z, z, z,
            l21, l22, z, z,
            l31, l32, l33, z,
            l41, l42, l43, l44,
        );
        // L Lᵀ Jm⁺ = Jmᵀ; the diagonal is positive, so the unchecked solves are safe.
        let mut out = jm.transpose();
        l.solve_lower_triangular_unchecked_mut(&mut out);
        l.tr_solve_lower_triangular_unchecked_mut(&mut out);
        // Through the slice: nalgebra's matrix iterator walks rows and columns with
        // strides, about 40 instructions per entry here against a few for the slice.
        if out.as_slice().iter().all(|v| v.is_finite()) {
            Ok(out)
        } else {
            Err(ArrowError::PlateSingular)
        }
    }
}

/// Row i of J̇m but its first entry (the constant 1 of the module docs' form), from
/// arm i's closure, q̇_i and Ẋ: the time derivative of that form.
fn rate_row<T: Float>(arm: &Arm<T>, c: &ArmClosure<T>, q_dot: T, rate: &Pose<T>) -> [T; 3] {
    let m = &c.reach;
    let a = &c.plate;
    let theta_dot = rate.w;
    // ȧ = θ̇ e_z × a; Ḋ = Ṗ + ȧ; ṁ = Ḋ − Ȧ with Ȧ = q̇ e_x.
    let a_dot = Vector3::new(-a.y, a.x, T::zero()) * theta_dot;
    let m_dot = Vector3::new(rate.x + a_dot.x - q_dot, rate.y + a_dot.y, rate.z);
    let (l, r) = (c.horizontal_m, arm.bc_m);
    // ℓ = √(L² − Δz²) with Δz = m_z: ℓ̇ = −m_z ṁ_z / ℓ; g = (ℓ + r)/ℓ.
    let l_dot = -m.z * m_dot.z / l;
    let g = (l + r) / l;
    let g_dot = -r * l_dot / (l * l);
    let inv = T::one() / m.x;
    let inv_dot = -m_dot.x * inv * inv;
    let e1 = m.y * inv;
    let e1_dot = m_dot.y * inv + m.y * inv_dot;
    let e2_dot = (g_dot * m.z + g * m_dot.z) * inv + g * m.z * inv_dot;
    // −(m × a)_z / m_x = e1 a_x − a_y.
    let e3_dot = e1_dot * a.x + e1 * a_dot.x - a_dot.y;
    [e1_dot, e2_dot, e3_dot]
}
