//! ARROW's dynamic model (A 2.2.3, eq. 16–24): the direct model for simulation and
//! the inverse model for computed feedforward.
//!
//! The actuators carry their carts and half of each arm (eq. 16: M_a), the plate the
//! rest of the arms as point masses at the B_i (eq. 18–19: m_P, I_pzz), with its
//! centre of mass at b along the plate's x axis (eq. 17: M_P). Eliminating the arm
//! forces f between eq. 16 and 17 with q̈ = Jm Ẍ + J̇m Ẋ gives the plate's equation
//!
//!   M Ẍ = Jmᵀ Γ − (Jmᵀ M_a J̇m + Λc) Ẋ + m_P g,   M = M_P + Jmᵀ M_a Jm,
//!
//! which is eq. 20–21 multiplied through by M. The print's Λc carries −b m_P cos θz
//! and −b m_P sin θz in its last column; the centrifugal force of an offset mass is
//! b m_P θ̇z² (cos θz, sin θz), so the column here carries the factor θ̇z the print
//! leaves out (with it, Λc Ẋ has the right unit; the preset's b is zero by symmetry
//! anyway). Eq. 22's minimum-norm forces Γ = H⁺(Ẍ + ΛẊ − A_G), with H = M⁻¹Jmᵀ, are
//! the same as (Jmᵀ)⁺ w with w = M Ẍ + (Jmᵀ M_a J̇m + Λc) Ẋ − m_P g: H⁺ = Jm (JmᵀJm)⁻¹ M.
//!
//! The turntable (eq. 23–24): I_T θ̈x shared by its two motors, Γ_T1 = I_T θ̈x / 2,
//! Γ_T2 = −Γ_T1; the springs balance gravity.

use super::velocity::{ForwardJacobian, InverseJacobian};
use super::{ActuatorVector, ArrowError, ArrowGeometry, Pose, ACTUATORS};
use crate::error::{positive, ConfigError};
use crate::scalar::{lit, Float};
use nalgebra::Matrix4;

/// Gravity, m/s² (A eq. 17: g = (0, 0, −9.8)).
const GRAVITY_M_S2: f64 = 9.8;

/// Masses and inertias (A table 1) and the actuators' limit.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowMasses {
    /// Cart and actuator of a simple arm, kg.
    pub simple_cart_kg: f64,
    /// Cart and actuator of a parallelogram, kg.
    pub parallelogram_cart_kg: f64,
    /// Simple arm mass per length, kg/m.
    pub simple_arm_kg_m: f64,
    /// Parallelogram mass per length, kg/m.
    pub parallelogram_arm_kg_m: f64,
    /// Plate (with the spindle), kg.
    pub plate_kg: f64,
    /// Plate inertia about the z axis through the tool centre point, kg·m².
    pub plate_inertia_kg_m2: f64,
    /// Offset b of the plate cluster's centre of mass along the plate's x, m.
    pub com_offset_m: f64,
    /// Half-arm point masses at the B_i: their inertia about P's z axis, kg·m²
    /// (eq. 19's Σ I_i).
    pub arm_points_inertia_kg_m2: f64,
    /// Turntable inertia I_T = 2 I_act + I_txx (eq. 23), kg·m².
    pub turntable_inertia_kg_m2: f64,
    /// Largest force of a linear actuator, N.
    pub actuator_force_limit_n: f64,
}

impl ArrowMasses {
    /// A table 1: carts 11.1 kg (simple) and 11.34 kg (parallelogram), arms 1.744 and
    /// 3.488 kg/m, plate 10.2 kg and 0.414 kg·m², turntable 1.204 kg·m² in total; the
    /// ETEL ILM12-060 actuators' 2,500 N (A 5.1). With [`super::ArrowConfig::ARROW`]'s
    /// symmetric plate b = 0, and the six half-arm point masses at the B_i (5.5 kg in
    /// all, 0.06–0.11 m from P's z axis: the joint offsets and the parallelograms'
    /// 0.05 m) give Σ I_i = 0.035 kg·m² at the workspace centre, held constant as the
    /// print does.
    pub const ARROW: Self = Self {
        simple_cart_kg: 11.1,
        parallelogram_cart_kg: 11.34,
        simple_arm_kg_m: 1.744,
        parallelogram_arm_kg_m: 3.488,
        plate_kg: 10.2,
        plate_inertia_kg_m2: 0.414,
        com_offset_m: 0.0,
        arm_points_inertia_kg_m2: 0.035,
        turntable_inertia_kg_m2: 1.204,
        actuator_force_limit_n: 2500.0,
    };
}

/// The dynamic model's constants in `T`, for a geometry whose arm lengths it uses.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowDynamics<T> {
    /// M_a's diagonal (eq. 16), kg.
    actuator_kg: [T; ACTUATORS],
    plate_kg: T,
    plate_inertia: T,
    com_offset: T,
    turntable_inertia: T,
    force_limit: T,
}

/// The mass matrix M and the velocity term of the plate's equation.
type PlateTerms<T> = (Matrix4<T>, Pose<T>);

/// What eq. 22 asks of the actuators.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Feedforward<T> {
    /// Minimum-norm actuator forces Γ, N.
    pub forces_n: ActuatorVector<T>,
    /// The first actuator (`0..6`) whose force exceeds the limit, if any: the
    /// trajectory asks more than the machine has, and the feedforward alone cannot
    /// be applied.
    pub over_limit: Option<u8>,
}

impl<T: Float> ArrowDynamics<T> {
    /// The model for arm lengths `simple_m` and `parallelogram_m` (eq. 16, 18, 19).
    pub fn new(
        masses: &ArrowMasses,
        simple_m: f64,
        parallelogram_m: f64,
    ) -> Result<Self, ConfigError> {
        let simple_arm = positive("simple_arm_kg_m", masses.simple_arm_kg_m)? * simple_m;
        let parallelogram_arm =
            positive("parallelogram_arm_kg_m", masses.parallelogram_arm_kg_m)? * parallelogram_m;
        let simple = positive("simple_cart_kg", masses.simple_cart_kg)? + simple_arm / 2.0;
        let parallelogram = positive("parallelogram_cart_kg", masses.parallelogram_cart_kg)?
            + parallelogram_arm / 2.0;
        // Eq. 18: the plate plus half of every arm.
        let plate = positive("plate_kg", masses.plate_kg)?
            + (4.0 * simple_arm + 2.0 * parallelogram_arm) / 2.0;
        let inertia = positive("plate_inertia_kg_m2", masses.plate_inertia_kg_m2)?
            + crate::error::in_range(
                "arm_points_inertia_kg_m2",
                masses.arm_points_inertia_kg_m2,
                0.0,
                1e3,
            )?;
        let offset = crate::error::in_range("com_offset_m", masses.com_offset_m, -10.0, 10.0)?;
        Ok(Self {
            actuator_kg: [simple, simple, parallelogram, parallelogram, simple, simple].map(lit),
            plate_kg: lit(plate),
            plate_inertia: lit(inertia),
            com_offset: lit(offset),
            turntable_inertia: lit(positive(
                "turntable_inertia_kg_m2",
                masses.turntable_inertia_kg_m2,
            )?),
            force_limit: lit(positive(
                "actuator_force_limit_n",
                masses.actuator_force_limit_n,
            )?),
        })
    }

    /// m_P (eq. 18), kg.
    pub fn plate_mass_kg(&self) -> T {
        self.plate_kg
    }

    /// The plate's mass matrix M_P (eq. 17) at θz = atan2(s, c).
    fn plate_matrix(&self, (s, c): (T, T)) -> Matrix4<T> {
        let (m, bm) = (self.plate_kg, self.com_offset * self.plate_kg);
        let z = T::zero();
        Matrix4::new(
            m,
            z,
            z,
            -bm * s, //
            z,
            m,
            z,
            bm * c, //
            z,
            z,
            m,
            z, //
            -bm * s,
            bm * c,
            z,
            self.plate_inertia,
        )
    }

    /// Λc Ẋ with the factor θ̇z (module docs), at θz = atan2(s, c).
    fn centrifugal(&self, (s, c): (T, T), rate: &Pose<T>) -> Pose<T> {
        let bm = self.com_offset * self.plate_kg * rate.w * rate.w;
        Pose::new(-bm * c, -bm * s, T::zero(), T::zero())
    }

    /// M = M_P + Jmᵀ M_a Jm and the velocity term (Jmᵀ M_a J̇m + Λc) Ẋ − m_P g, for Jm
    /// and J̇m of `pose` moving at `rate`.
    fn terms(
        &self,
        jm: &InverseJacobian<T>,
        jm_dot: &InverseJacobian<T>,
        pose: &Pose<T>,
        rate: &Pose<T>,
    ) -> Result<PlateTerms<T>, ArrowError> {
        // M_a is diagonal (eq. 16): M_a Jm scales Jm's rows.
        let mut ma_jm = *jm;
        for (mut row, m) in ma_jm.row_iter_mut().zip(self.actuator_kg) {
            row *= m;
        }
        let turn = ArrowGeometry::turn(pose)?;
        let mass = self.plate_matrix(turn) + jm.tr_mul(&ma_jm);
        let velocity =
            ma_jm.tr_mul(&(jm_dot * rate)) + self.centrifugal(turn, rate) - self.gravity();
        Ok((mass, velocity))
    }

    /// The plate's weight m_P g (eq. 17) as a wrench.
    fn gravity(&self) -> Pose<T> {
        Pose::new(
            T::zero(),
            T::zero(),
            -lit::<T>(GRAVITY_M_S2) * self.plate_kg,
            T::zero(),
        )
    }

    /// w = M Ẍ + (Jmᵀ M_a J̇m + Λc) Ẋ − m_P g (module docs) without forming M: with the
    /// actuators' accelerations q̈ = Jm Ẍ + J̇m Ẋ it is M_P Ẍ + Jmᵀ M_a q̈ + Λc Ẋ − m_P g,
    /// and M_a is diagonal (eq. 16).
    fn wrench(
        &self,
        jm: &InverseJacobian<T>,
        jm_dot: &InverseJacobian<T>,
        pose: &Pose<T>,
        rate: &Pose<T>,
        acceleration: &Pose<T>,
    ) -> Result<Pose<T>, ArrowError> {
        let q_accel = jm * acceleration + jm_dot * rate;
        let ma_q_accel = q_accel.component_mul(&ActuatorVector::from(self.actuator_kg));
        let turn = ArrowGeometry::turn(pose)?;
        Ok(self.plate_matrix(turn) * acceleration
            + jm.tr_mul(&ma_q_accel)
            + self.centrifugal(turn, rate)
            - self.gravity())
    }

    /// Direct model (eq. 20): the plate's acceleration under actuator forces Γ.
    pub fn acceleration(
        &self,
        geometry: &ArrowGeometry<T>,
        pose: &Pose<T>,
        rate: &Pose<T>,
        forces_n: &ActuatorVector<T>,
    ) -> Result<Pose<T>, ArrowError> {
        let (_, jm, jm_dot) = geometry.differential(pose, Some(rate))?;
        let (mass, velocity) = self.terms(&jm, &jm_dot, pose, rate)?;
        let rhs = jm.transpose() * forces_n - velocity;
        mass.lu().solve(&rhs).ok_or(ArrowError::PlateSingular)
    }

    /// Inverse model (eq. 22): the minimum-norm actuator forces for the plate to move
    /// at `rate` with `acceleration` at `pose`, flagged where one exceeds the limit.
    pub fn feedforward(
        &self,
        geometry: &ArrowGeometry<T>,
        pose: &Pose<T>,
        rate: &Pose<T>,
        acceleration: &Pose<T>,
    ) -> Result<Feedforward<T>, ArrowError> {
        let (_, jm, jm_dot) = geometry.differential(pose, Some(rate))?;
        let jm_pinv = ArrowGeometry::pseudo_inverse(&jm)?;
        self.feedforward_with(&jm, &jm_pinv, &jm_dot, pose, rate, acceleration)
    }

    /// [`Self::feedforward`] with Jm of `pose`, its pseudo-inverse Jm⁺ and J̇m at
    /// `rate` already at hand ([`ArrowGeometry::differential`] and
    /// [`ArrowGeometry::pseudo_inverse`]: the control period has Jm and Jm⁺ for its
    /// regularization, and neither the arms nor the normal matrix JmᵀJm are evaluated
    /// again).
    pub fn feedforward_with(
        &self,
        jm: &InverseJacobian<T>,
        jm_pinv: &ForwardJacobian<T>,
        jm_dot: &InverseJacobian<T>,
        pose: &Pose<T>,
        rate: &Pose<T>,
        acceleration: &Pose<T>,
    ) -> Result<Feedforward<T>, ArrowError> {
        let wrench = self.wrench(jm, jm_dot, pose, rate, acceleration)?;
        // Eq. 22's minimum-norm forces Jm (JmᵀJm)⁻¹ w (module docs) are (Jm⁺)ᵀ w: the
        // inverse of the symmetric JmᵀJm is symmetric, so Jm⁺ = (JmᵀJm)⁻¹Jmᵀ (eq. 14)
        // transposes to Jm (JmᵀJm)⁻¹.
        let forces_n = jm_pinv.tr_mul(&wrench);
        if !forces_n.as_slice().iter().all(|f| f.is_finite()) {
            return Err(ArrowError::NotFinite);
        }
        let over_limit = forces_n
            .iter()
            .position(|f| f.abs() > self.force_limit)
            .map(|i| i as u8);
        Ok(Feedforward {
            forces_n,
            over_limit,
        })
    }

    /// The turntable's motor torques for θ̈x (eq. 24), N·m.
    pub fn turntable_torques(&self, theta_x_accel_rad_s2: T) -> [T; 2] {
        let t1 = self.turntable_inertia * theta_x_accel_rad_s2 * lit(0.5);
        [t1, -t1]
    }

    /// The actuators' force limit, N.
    pub fn force_limit_n(&self) -> T {
        self.force_limit
    }
}

#[cfg(test)]
mod tests {
    use super::super::ArrowConfig;
    use super::*;
    use nalgebra::Vector3;

    fn model() -> (ArrowGeometry<f64>, ArrowDynamics<f64>) {
        let config = ArrowConfig::ARROW;
        let geometry = ArrowGeometry::new(&config).unwrap();
        let dynamics = ArrowDynamics::new(
            &ArrowMasses::ARROW,
            config.arms[0].length_m,
            config.arms[2].length_m,
        )
        .unwrap();
        (geometry, dynamics)
    }

    /// Kinetic energy of plate and carts: ½ẊᵀM_PẊ + ½q̇ᵀM_a q̇ with q̇ = Jm Ẋ.
    fn energy(g: &ArrowGeometry<f64>, d: &ArrowDynamics<f64>, x: &Pose<f64>, v: &Pose<f64>) -> f64 {
        let (_, jm) = g.jacobian(x).unwrap();
        let q_dot = jm * v;
        let carts: f64 = q_dot
            .iter()
            .zip(d.actuator_kg)
            .map(|(q, m)| 0.5 * m * q * q)
            .sum();
        let plate = 0.5 * (v.transpose() * d.plate_matrix((x.w.sin(), x.w.cos())) * v)[(0, 0)];
        carts + plate + d.plate_kg * GRAVITY_M_S2 * x.z
    }

    /// The direct model conserves energy with the actuators idle: a check of its
    /// velocity terms (Jmᵀ M_a J̇m Ẋ) that none of its own formulas enters. RK4 at
    /// 0.1 ms over 0.3 s of free motion (the plate falls and swings): the energy stays
    /// within 1e-7 of the kinetic energy it gains.
    #[test]
    fn free_motion_conserves_energy() {
        let (g, d) = model();
        let f = |x: &Pose<f64>, v: &Pose<f64>| {
            d.acceleration(&g, x, v, &ActuatorVector::zeros()).unwrap()
        };
        let mut x = Pose::new(0.1, 0.5, 0.05, 0.2);
        let mut v = Pose::new(0.3, -0.2, 0.1, 1.5);
        let e0 = energy(&g, &d, &x, &v);
        let h = 1e-4;
        let mut worst: f64 = 0.0;
        for _ in 0..3000 {
            let k1 = (v, f(&x, &v));
            let k2 = (
                v + k1.1 * (h / 2.0),
                f(&(x + k1.0 * (h / 2.0)), &(v + k1.1 * (h / 2.0))),
            );
            let k3 = (
                v + k2.1 * (h / 2.0),
                f(&(x + k2.0 * (h / 2.0)), &(v + k2.1 * (h / 2.0))),
            );
            let k4 = (v + k3.1 * h, f(&(x + k3.0 * h), &(v + k3.1 * h)));
            x += (k1.0 + k2.0 * 2.0 + k3.0 * 2.0 + k4.0) * (h / 6.0);
            v += (k1.1 + k2.1 * 2.0 + k3.1 * 2.0 + k4.1) * (h / 6.0);
            worst = worst.max((energy(&g, &d, &x, &v) - e0).abs());
        }
        assert!(x.z < -0.1, "it fell: {x:?}");
        assert!(worst < 1e-6, "{worst}");
    }

    /// Eq. 22 as printed (H⁺ by an SVD of H = M⁻¹Jmᵀ) against the form used, the
    /// direct model run on the result, and the minimum norm: the forces lie in Jm's
    /// column space (no internal force).
    #[test]
    fn feedforward_is_the_minimum_norm_inverse_of_the_direct_model() {
        let (g, d) = model();
        let x = Pose::new(-0.2, 0.45, 0.1, -0.3);
        let v = Pose::new(0.5, 0.1, -0.2, 0.7);
        let a = Pose::new(3.0, -2.0, 1.0, 5.0);
        let ff = d.feedforward(&g, &x, &v, &a).unwrap();
        assert_eq!(ff.over_limit, None);
        let back = d.acceleration(&g, &x, &v, &ff.forces_n).unwrap();
        assert!((back - a).amax() < 1e-9, "{back:?}");
        let (_, jm, jm_dot) = g.differential(&x, Some(&v)).unwrap();
        let (mass, velocity) = d.terms(&jm, &jm_dot, &x, &v).unwrap();
        let minv = mass.try_inverse().unwrap();
        let h = minv * jm.transpose();
        let lambda_x = minv * velocity; // ΛẊ − A_G
        let h_pinv = h.pseudo_inverse(1e-12).unwrap();
        let printed = h_pinv * (a + lambda_x);
        assert!((printed - ff.forces_n).amax() < 1e-6 * ff.forces_n.amax());
        let svd = jm.svd(true, false);
        let u = svd.u.unwrap();
        let mut inside = ActuatorVector::zeros();
        for k in 0..4 {
            inside += u.column(k) * u.column(k).dot(&ff.forces_n);
        }
        assert!((inside - ff.forces_n).amax() < 1e-9 * ff.forces_n.amax());
        // At rest the actuators hold the plate against gravity only: Σ of the vertical
        // support equals m_P g (Jmᵀ Γ's z row).
        let rest = d
            .feedforward(&g, &x, &Pose::zeros(), &Pose::zeros())
            .unwrap();
        let wrench = jm.transpose() * rest.forces_n;
        assert!((wrench.z - d.plate_mass_kg() * GRAVITY_M_S2).abs() < 1e-9);
        // Beyond 2,500 N: named.
        let hard = d.feedforward(&g, &x, &v, &(a * 200.0)).unwrap();
        assert!(hard.over_limit.is_some());
        assert_eq!(d.turntable_torques(2.0), [1.204, -1.204]);
    }

    /// `feedforward_with` on the matrices the control period has (Jm, Jm⁺ and J̇m from
    /// the geometry) against the direct model run on its forces: the plate accelerates
    /// as asked (1e-9 m/s²: a few hundred N through a well-conditioned 4 × 4 solve in
    /// f64), here and at a second pose and rate (a J̇m term taken with the wrong sign
    /// or from the wrong rate shows as Jmᵀ M_a J̇m Ẋ, tens of m/s²). The flag names the
    /// first actuator whose force is beyond `force_limit_n`, the preset's 2,500 N, by
    /// a look at the forces themselves.
    #[test]
    fn feedforward_with_the_control_periods_matrices_inverts_the_direct_model() {
        let (g, d) = model();
        assert_eq!(d.force_limit_n(), ArrowMasses::ARROW.actuator_force_limit_n);
        for (x, v, a) in [
            (
                Pose::new(-0.2, 0.45, 0.1, -0.3),
                Pose::new(0.5, 0.1, -0.2, 0.7),
                Pose::new(3.0, -2.0, 1.0, 5.0),
            ),
            (
                Pose::new(0.15, 0.5, -0.05, 0.4),
                Pose::new(-0.8, 0.3, 0.4, -2.0),
                Pose::new(-30.0, 10.0, 20.0, 100.0),
            ),
        ] {
            let (_, jm, jm_dot) = g.differential(&x, Some(&v)).unwrap();
            let jm_pinv = ArrowGeometry::pseudo_inverse(&jm).unwrap();
            for scale in [1.0, 100.0] {
                let a = a * scale;
                let ff = d
                    .feedforward_with(&jm, &jm_pinv, &jm_dot, &x, &v, &a)
                    .unwrap();
                let back = d.acceleration(&g, &x, &v, &ff.forces_n).unwrap();
                assert!((back - a).amax() < 1e-9 * scale, "{back:?} for {a:?}");
                let first_over = ff
                    .forces_n
                    .iter()
                    .position(|f| f.abs() > 2500.0)
                    .map(|i| i as u8);
                assert_eq!(ff.over_limit, first_over, "{:?}", ff.forces_n);
                if scale > 1.0 {
                    assert!(first_over.is_some(), "{:?}", ff.forces_n);
                }
            }
        }
    }

    /// The preset's Σ I_i: the six half-arm point masses at the B_i about P's z axis at
    /// the workspace centre.
    #[test]
    fn arm_point_inertia_matches_the_geometry() {
        let config = ArrowConfig::ARROW;
        let (g, _) = model();
        let masses = ArrowMasses::ARROW;
        let pose = Pose::new(0.0, config.workspace.y0_m, 0.0, 0.0);
        let mut inertia = 0.0;
        for (i, arm) in g.arms.iter().enumerate() {
            let turn = ArrowGeometry::turn(&pose).unwrap();
            let c = ArrowGeometry::closure(arm, &pose, turn, i).unwrap();
            let a = Vector3::new(c.q_m, arm.rail_y_m, arm.rail_z_m);
            let b = a + c.arm;
            let per_m = if i == 2 || i == 3 {
                masses.parallelogram_arm_kg_m
            } else {
                masses.simple_arm_kg_m
            };
            let half = 0.5 * per_m * arm.length_m;
            let r2 = (b.x - pose.x).powi(2) + (b.y - pose.y).powi(2);
            inertia += half * r2;
        }
        assert!(
            (inertia - masses.arm_points_inertia_kg_m2).abs() < 0.1 * inertia,
            "{inertia}"
        );
    }
}
