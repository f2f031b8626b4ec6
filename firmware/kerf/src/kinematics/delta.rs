//! Generalized linear (prismatic) delta robot (SPEC `kinematics::delta`, T ch. 6).
//!
//! Actuator i (i = 1..3) has azimuth θi, attack angle αi (0 horizontal, 30° Keops,
//! 90° vertical), arm length li and base / effector circumradii rb, re. With the
//! carriage displacement di and ζi = re − rb + di cαi the loop closure (T eq. 105) is
//!
//!   (x + cθi ζi)² + (y + sθi ζi)² + (z − di sαi)² = li².
//!
//! Geometrically the carriage is Ci = Bi + di ui, ui = (−cαi cθi, −cαi sθi, sαi), and
//! the effector joint is Pi = p + re (cθi, sθi, 0). The radii only appear as re − rb, so
//! they can differ per actuator (calibration trims) at no cost.
//!
//! The code works with half coefficients: ai = (cθi ζi, sθi ζi, −di sαi) = (σ1i, σ2i,
//! σ3i)/2, so the loop closure reads |p + ai|² = li² and every formula of SPEC appears
//! with its factor 2 taken out (fewer multiplications, same roots).
//!
//! Branches (SPEC): [`Root::Plus`] for forward kinematics is the larger-z solution; the
//! inverse-kinematics branch of actuator i is the sign of fdi = ±√Δi / 2. In the seed's
//! frame (effector on +z, carriages radially outside) the pair is FK `Plus`, IK `Minus`;
//! in the printer frame (z up, effector below the carriages) it is FK `Minus`, IK `Plus`.
//!
//! Scalars: generic over nalgebra's `RealField` (`f32` on the target, `f64` as the
//! reference). The measured `f32` error against `f64` is listed on each preset. A
//! fixed-point type is not usable through this code: `fixed` types do not implement
//! `RealField`, and the formulas need square roots and divisions. Q31.32 would have the
//! resolution (the squared lengths here are ~1e-2 m², quantized to 2.3e-10 m², which
//! maps to ~1e-9 m of position), so a dedicated fixed-point port is feasible if an
//! FPU-less part ever needs one.
//!
//! Hot path: no `f64`, no allocation, no panics; `forward` uses one square root and two
//! divisions, `inverse` three square roots, `jacobian` one division.

use crate::error::{in_range, positive, ConfigError};
use nalgebra::{Matrix3, RealField, Vector3};

/// Which root of a quadratic is taken (SPEC: the `±` of the closed-form solutions).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Root {
    /// The `+√` root.
    Plus,
    /// The `−√` root.
    Minus,
}

impl Root {
    fn sign(self) -> f64 {
        match self {
            Root::Plus => 1.0,
            Root::Minus => -1.0,
        }
    }
}

/// Why a kinematic map could not be evaluated. Never a NaN instead.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum KinematicsError {
    /// An input was NaN or infinite.
    NotFinite,
    /// No pose / displacement exists (negative discriminant). For inverse kinematics the
    /// field is the actuator index `0..3`; forward kinematics reports actuator 0.
    OutOfReach(u8),
    /// The three sphere centres are (nearly) collinear: the arms' end points form a
    /// circle, not two points. Both forward closed forms fail only here.
    SingularCentres,
    /// J1 singular: arm `i` (`0..3`) is (nearly) perpendicular to its rail.
    SingularJ1(u8),
    /// J2 singular: the three arms are (nearly) coplanar.
    SingularJ2,
    /// A displacement of actuator `i` (`0..3`) is outside its travel.
    OutsideTravel(u8),
    /// The forward solution has actuator `i` (`0..3`) on the other inverse-kinematics
    /// branch than configured: the robot would have left its working mode.
    WrongBranch(u8),
}

/// Plain-data description of one actuator (all lengths in metres, angles in radians).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ActuatorConfig {
    /// Azimuth θi of the actuator's vertical plane about the base z axis.
    pub theta_rad: f64,
    /// Attack angle αi between the rail and the base plane (0 horizontal, π/2 vertical).
    pub alpha_rad: f64,
    /// Arm length li (joint centre to joint centre).
    pub arm_m: f64,
    /// Base circumradius rb to the rail's origin (where di = 0).
    pub base_radius_m: f64,
    /// Effector circumradius re to the arm's effector joint.
    pub effector_radius_m: f64,
    /// Smallest allowed displacement di.
    pub travel_min_m: f64,
    /// Largest allowed displacement di.
    pub travel_max_m: f64,
    /// Inverse-kinematics branch (sign of fdi) of this actuator's working mode.
    pub ik_root: Root,
}

/// Plain-data description of a linear delta robot.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DeltaConfig {
    /// The three actuators.
    pub actuators: [ActuatorConfig; 3],
    /// Forward-kinematics root ([`Root::Plus`] = larger z).
    pub fk_root: Root,
}

const DEG: f64 = core::f64::consts::PI / 180.0;

/// The azimuths of a symmetric delta, 90°/210°/330° (T fig. 6.2 B).
pub const SYMMETRIC_THETA_RAD: [f64; 3] = [90.0 * DEG, 210.0 * DEG, 330.0 * DEG];

const fn symmetric(
    alpha_rad: f64,
    arm_m: f64,
    base_radius_m: f64,
    effector_radius_m: f64,
    travel_m: (f64, f64),
    fk_root: Root,
    ik_root: Root,
) -> DeltaConfig {
    let base = ActuatorConfig {
        theta_rad: 0.0,
        alpha_rad,
        arm_m,
        base_radius_m,
        effector_radius_m,
        travel_min_m: travel_m.0,
        travel_max_m: travel_m.1,
        ik_root,
    };
    DeltaConfig {
        actuators: [
            ActuatorConfig {
                theta_rad: SYMMETRIC_THETA_RAD[0],
                ..base
            },
            ActuatorConfig {
                theta_rad: SYMMETRIC_THETA_RAD[1],
                ..base
            },
            ActuatorConfig {
                theta_rad: SYMMETRIC_THETA_RAD[2],
                ..base
            },
        ],
        fk_root,
    }
}

impl DeltaConfig {
    /// Horizontal master (T 7.1.1: α = 0°, θ = 90°/210°/330°, LM2070 motors, 0.5 µm
    /// encoders). Dimensions are not printed; chosen for the LM2070 force scale:
    /// arms 150 mm, rb = 200 mm, re = 40 mm, travel 30–110 mm (80 mm stroke), seed
    /// frame (effector on +z, FK `Plus`, IK `Minus`).
    pub const MASTER_HORIZONTAL: Self = symmetric(
        0.0,
        0.150,
        0.200,
        0.040,
        (0.030, 0.110),
        Root::Plus,
        Root::Minus,
    );

    /// Keops slave (T 7.1.2: α = 30°, LM1247 motors, Hall position). Dimensions chosen
    /// for a miniature robot: arms 70 mm, rb = 86 mm, re = 20 mm, travel 0–40 mm,
    /// seed frame (FK `Plus`, IK `Minus`).
    pub const SLAVE_KEOPS: Self = symmetric(
        30.0 * DEG,
        0.070,
        0.086,
        0.020,
        (0.0, 0.040),
        Root::Plus,
        Root::Minus,
    );

    /// Vertical delta (T fig. 6.3 C: α = 90°) in the printer frame: z up, effector
    /// below the carriages, di = carriage height (FK `Minus`, IK `Plus`). Arms 150 mm,
    /// rb − re = 80 mm (rb = 110 mm, re = 30 mm), carriage travel 100–300 mm.
    pub const VERTICAL: Self = symmetric(
        90.0 * DEG,
        0.150,
        0.110,
        0.030,
        (0.100, 0.300),
        Root::Minus,
        Root::Plus,
    );

    /// A vertical delta printer described the way Klipper and Marlin do: towers at
    /// `tower_angle_rad` about z, each at horizontal distance `delta_radius_m` from the
    /// centre to the carriage joint minus the effector joint offset, diagonal rods
    /// `arm_m`, z up, di = carriage height above z = 0. The textbook inverse is then
    /// carriage = z + √(l² − (x − xt)² − (y − yt)²) with (xt, yt) = R (cθ, sθ).
    ///
    /// Mapping: α = 90°, rb − re = R (stored as rb = R, re = 0), FK `Minus`, IK `Plus`.
    pub fn printer(
        delta_radius_m: f64,
        tower_angle_rad: [f64; 3],
        arm_m: [f64; 3],
        carriage_travel_m: (f64, f64),
    ) -> Self {
        let one = |(theta_rad, arm_m): (f64, f64)| ActuatorConfig {
            theta_rad,
            alpha_rad: 90.0 * DEG,
            arm_m,
            base_radius_m: delta_radius_m,
            effector_radius_m: 0.0,
            travel_min_m: carriage_travel_m.0,
            travel_max_m: carriage_travel_m.1,
            ik_root: Root::Plus,
        };
        let [t1, t2, t3] = tower_angle_rad;
        let [l1, l2, l3] = arm_m;
        Self {
            actuators: [one((t1, l1)), one((t2, l2)), one((t3, l3))],
            fk_root: Root::Minus,
        }
    }
}

/// Below this, |det J2| / (l1 l2 l3) and |fdi| / li count as singular. Both ratios are
/// sines of angles between arms or between arm and rail; at 1e-3 the Jacobian already
/// amplifies velocities (and f32 rounding) a thousandfold, which no controller uses.
const SINGULAR_SINE: f64 = 1e-3;

/// The elimination (x, y as functions of z) is used while the radical line of the three
/// spheres is at least this sine away from horizontal (|nz| ≥ 0.1 |m1| |m2|); below it
/// the error of x = g z + e grows like 1 / sine, so the vector form takes over.
const ELIMINATION_SINE: f64 = 0.1;

/// Precomputed per-actuator constants.
#[derive(Copy, Clone, Debug)]
struct Actuator<T> {
    c_theta: T,
    s_theta: T,
    c_alpha: T,
    s_alpha: T,
    /// re − rb.
    offset_m: T,
    arm_m: T,
    arm_sq_m2: T,
    travel_min_m: T,
    travel_max_m: T,
    /// ±1, the IK branch.
    ik_sign: T,
}

impl<T: RealField + Copy> Actuator<T> {
    /// Half coefficients ai = (σ1i, σ2i, σ3i)/2 (SPEC FK, T eqs. 107–109).
    #[inline]
    fn half_sigma(&self, d_m: T) -> Vector3<T> {
        let zeta = self.offset_m + d_m * self.c_alpha;
        Vector3::new(self.c_theta * zeta, self.s_theta * zeta, -d_m * self.s_alpha)
    }

    /// fdi = cαi (re − rb + cθi x + sθi y) − sαi z + di (SPEC velocity, T eq. 142).
    #[inline]
    fn fd(&self, d_m: T, p: &Vector3<T>) -> T {
        self.c_alpha * (self.offset_m + self.c_theta * p.x + self.s_theta * p.y)
            - self.s_alpha * p.z
            + d_m
    }

    fn check_travel(&self, d_m: T, index: u8) -> Result<(), KinematicsError> {
        if d_m < self.travel_min_m || d_m > self.travel_max_m {
            Err(KinematicsError::OutsideTravel(index))
        } else {
            Ok(())
        }
    }
}

/// A validated delta geometry with precomputed constants, for scalar `T`.
#[derive(Copy, Clone, Debug)]
pub struct DeltaGeometry<T> {
    actuators: [Actuator<T>; 3],
    fk_sign: T,
    arm_product_m3: T,
    elimination_sine_sq: T,
    singular_sine: T,
}

fn convert<T: RealField + Copy>(v: f64) -> T {
    nalgebra::convert::<f64, T>(v)
}

fn finite3<T: RealField + Copy>(v: &Vector3<T>) -> Result<(), KinematicsError> {
    if v.iter().all(|c| c.is_finite()) {
        Ok(())
    } else {
        Err(KinematicsError::NotFinite)
    }
}

impl<T: RealField + Copy> DeltaGeometry<T> {
    /// Validates `config`: angles finite, αi in [0, π/2], arms positive, radii finite
    /// and non-negative, travel finite with min < max.
    pub fn new(config: &DeltaConfig) -> Result<Self, ConfigError> {
        let mut actuators = [Actuator {
            c_theta: T::zero(),
            s_theta: T::zero(),
            c_alpha: T::zero(),
            s_alpha: T::zero(),
            offset_m: T::zero(),
            arm_m: T::zero(),
            arm_sq_m2: T::zero(),
            travel_min_m: T::zero(),
            travel_max_m: T::zero(),
            ik_sign: T::one(),
        }; 3];
        let mut arm_product = 1.0;
        for (out, a) in actuators.iter_mut().zip(config.actuators.iter()) {
            let theta = in_range("theta_rad", a.theta_rad, -360.0 * DEG, 360.0 * DEG)?;
            let alpha = in_range("alpha_rad", a.alpha_rad, 0.0, 90.0 * DEG)?;
            let arm = positive("arm_m", a.arm_m)?;
            let rb = in_range("base_radius_m", a.base_radius_m, 0.0, f64::MAX)?;
            let re = in_range("effector_radius_m", a.effector_radius_m, 0.0, f64::MAX)?;
            let lo = in_range("travel_min_m", a.travel_min_m, f64::MIN, f64::MAX)?;
            let hi = in_range("travel_max_m", a.travel_max_m, lo, f64::MAX)?;
            if hi <= lo {
                return Err(ConfigError::OutOfRange("travel_max_m"));
            }
            arm_product *= arm;
            *out = Actuator {
                c_theta: convert(libm::cos(theta)),
                s_theta: convert(libm::sin(theta)),
                c_alpha: convert(libm::cos(alpha)),
                s_alpha: convert(libm::sin(alpha)),
                offset_m: convert(re - rb),
                arm_m: convert(arm),
                arm_sq_m2: convert(arm * arm),
                travel_min_m: convert(lo),
                travel_max_m: convert(hi),
                ik_sign: convert(a.ik_root.sign()),
            };
        }
        Ok(Self {
            actuators,
            fk_sign: convert(config.fk_root.sign()),
            arm_product_m3: convert(arm_product),
            elimination_sine_sq: convert(ELIMINATION_SINE * ELIMINATION_SINE),
            singular_sine: convert(SINGULAR_SINE),
        })
    }

    /// Forward kinematics: effector position p = (x, y, z) in m from the displacements
    /// q = (d1, d2, d3) in m. Closed form, no iteration (SPEC FK, T eqs. 106–131).
    ///
    /// Subtracting sphere 3 from spheres 1 and 2 leaves two planes mi · p = hi whose
    /// intersection is the radical line with direction n = m1 × m2. Normally x, y are
    /// eliminated as functions of z (the print's A [x y]ᵀ = Γ z + Λ, with det A ∝ nz);
    /// where A is singular or nearly so the line is parameterized along n instead. The
    /// line is then intersected with sphere 1 using the cancellation-free root formula.
    pub fn forward(&self, q: &Vector3<T>) -> Result<Vector3<T>, KinematicsError> {
        finite3(q)?;
        let [act1, act2, act3] = &self.actuators;
        act1.check_travel(q.x, 0)?;
        act2.check_travel(q.y, 1)?;
        act3.check_travel(q.z, 2)?;
        let a1 = act1.half_sigma(q.x);
        let a2 = act2.half_sigma(q.y);
        let a3 = act3.half_sigma(q.z);
        // λi = li² − |ai|² (SPEC's corrected λ; T eq. 110 is garbled).
        let lambda1 = act1.arm_sq_m2 - a1.norm_squared();
        let lambda3 = act3.arm_sq_m2 - a3.norm_squared();
        let lambda2 = act2.arm_sq_m2 - a2.norm_squared();
        // Sphere i minus sphere 3: 2 (ai − a3) · p = λi − λ3 (T eqs. 111–112, halved).
        let m1 = a1 - a3;
        let m2 = a2 - a3;
        let half: T = convert(0.5);
        let h1 = (lambda1 - lambda3) * half;
        let h2 = (lambda2 - lambda3) * half;
        let n = m1.cross(&m2);
        let scale_sq = m1.norm_squared() * m2.norm_squared();
        // Line p = e + t g.
        let (e, g) = if n.z * n.z >= self.elimination_sine_sq * scale_sq {
            // Elimination: det A = 4 nz; g = (g1, g2, 1), e = (e1, e2, 0) (T eqs. 118–124).
            let inv = T::one() / n.z;
            let e = Vector3::new(
                (m2.y * h1 - m1.y * h2) * inv,
                (m1.x * h2 - m2.x * h1) * inv,
                T::zero(),
            );
            (e, n * inv)
        } else {
            // Fallback (vector trilateration): the point of the line in the plane of the
            // centres is e = (h1 (m2 × n) − h2 (m1 × n)) / |n|², since m1·(m2 × n) =
            // |n|² and m1·(m1 × n) = 0 (likewise for m2). Orient n upwards so that the
            // `Plus` root is still the larger z.
            let n_sq = n.norm_squared();
            if n_sq <= self.singular_sine * self.singular_sine * scale_sq {
                return Err(KinematicsError::SingularCentres);
            }
            let e = (m2.cross(&n) * h1 - m1.cross(&n) * h2) / n_sq;
            let g = if n.z < T::zero() { -n } else { n };
            (e, g)
        };
        // |e + t g + a1|² = l1²  ⇒  η t² + 2 β t + γ = 0 (T eqs. 125–129, halved υ).
        let w = e + a1;
        let eta = g.norm_squared();
        let beta = g.dot(&w);
        let gamma = w.norm_squared() - act1.arm_sq_m2;
        let disc = beta * beta - eta * gamma;
        if disc < T::zero() {
            return Err(KinematicsError::OutOfReach(0));
        }
        // t = (−β ± √disc)/η; when ±√disc and −β have opposite signs that subtraction
        // cancels, so use the equivalent t = γ / (−β ∓ √disc) instead (T eq. 131).
        let root = self.fk_sign * disc.sqrt();
        let t = if root * beta <= T::zero() {
            (root - beta) / eta
        } else {
            gamma / (-beta - root)
        };
        let p = e + g * t;
        // Working mode: each arm must be on its configured IK branch (SPEC).
        for (i, (act, d)) in self.actuators.iter().zip(q.iter()).enumerate() {
            if act.fd(*d, &p) * act.ik_sign < T::zero() {
                return Err(KinematicsError::WrongBranch(i as u8));
            }
        }
        Ok(p)
    }

    /// Inverse kinematics: displacements q in m for the effector position p in m
    /// (SPEC IK, T eqs. 132–137): di = −μ1i/2 + si √(μ1i²/4 − μ2i), si the configured
    /// branch. Errors when a discriminant is negative or di leaves the travel.
    pub fn inverse(&self, p: &Vector3<T>) -> Result<Vector3<T>, KinematicsError> {
        finite3(p)?;
        let p_sq = p.norm_squared();
        let two: T = convert(2.0);
        let mut q = Vector3::zeros();
        for (i, (act, d)) in self.actuators.iter().zip(q.iter_mut()).enumerate() {
            let radial = act.c_theta * p.x + act.s_theta * p.y;
            // μ1/2 and μ2 of T eqs. 133–134.
            let b = act.c_alpha * (act.offset_m + radial) - act.s_alpha * p.z;
            let c = p_sq + act.offset_m * (act.offset_m + two * radial) - act.arm_sq_m2;
            let disc = b * b - c;
            if disc < T::zero() {
                return Err(KinematicsError::OutOfReach(i as u8));
            }
            *d = act.ik_sign * disc.sqrt() - b;
            act.check_travel(*d, i as u8)?;
        }
        Ok(q)
    }

    /// `true` when the pose p is reachable in the working mode within travel and away
    /// from singularities: [`inverse`](Self::inverse) and [`jacobian`](Self::jacobian)
    /// both succeed.
    pub fn reachable(&self, p: &Vector3<T>) -> bool {
        self.inverse(p)
            .and_then(|q| self.jacobian(&q, p))
            .is_ok()
    }

    /// J2 rows fi = (fxi, fyi, fzi) = −(p + ai), J1 = diag(fdi) and J2⁻¹ (SPEC velocity,
    /// T eqs. 138–145). J2⁻¹ is the adjugate over the determinant: its columns are
    /// f2 × f3, f3 × f1, f1 × f2 divided by f1 · (f2 × f3).
    fn velocity_terms(
        &self,
        q: &Vector3<T>,
        p: &Vector3<T>,
    ) -> Result<([Vector3<T>; 3], Vector3<T>, Matrix3<T>), KinematicsError> {
        finite3(q)?;
        finite3(p)?;
        let [act1, act2, act3] = &self.actuators;
        let f = [
            -(p + act1.half_sigma(q.x)),
            -(p + act2.half_sigma(q.y)),
            -(p + act3.half_sigma(q.z)),
        ];
        let fd = Vector3::new(act1.fd(q.x, p), act2.fd(q.y, p), act3.fd(q.z, p));
        for (i, (act, fdi)) in self.actuators.iter().zip(fd.iter()).enumerate() {
            if fdi.abs() < self.singular_sine * act.arm_m {
                return Err(KinematicsError::SingularJ1(i as u8));
            }
        }
        let [f1, f2, f3] = &f;
        let c1 = f2.cross(f3);
        let det = f1.dot(&c1);
        if det.abs() < self.singular_sine * self.arm_product_m3 {
            return Err(KinematicsError::SingularJ2);
        }
        let inv_det = T::one() / det;
        let j2_inv = Matrix3::from_columns(&[c1 * inv_det, f3.cross(f1) * inv_det, f1.cross(f2) * inv_det]);
        Ok((f, fd, j2_inv))
    }

    /// Jx = J2⁻¹ J1 at the consistent pair (q, p), so that ṗ = Jx q̇ (T eq. 146).
    pub fn jacobian(&self, q: &Vector3<T>, p: &Vector3<T>) -> Result<Matrix3<T>, KinematicsError> {
        let (_, fd, j2_inv) = self.velocity_terms(q, p)?;
        // Multiplying by the diagonal J1 scales column j by fdj.
        Ok(j2_inv * Matrix3::from_diagonal(&fd))
    }

    /// Jx⁻¹ = J1⁻¹ J2 at (q, p), so that q̇ = Jx⁻¹ ṗ: row i is fi / fdi.
    pub fn jacobian_inverse(
        &self,
        q: &Vector3<T>,
        p: &Vector3<T>,
    ) -> Result<Matrix3<T>, KinematicsError> {
        let (f, fd, _) = self.velocity_terms(q, p)?;
        let [f1, f2, f3] = f;
        Ok(Matrix3::from_rows(&[
            (f1 / fd.x).transpose(),
            (f2 / fd.y).transpose(),
            (f3 / fd.z).transpose(),
        ]))
    }

    /// J̇x at (q, p) moving with joint velocity q̇ (m/s): from J2 Jx = J1,
    /// J̇x = J2⁻¹ (J̇1 − J̇2 Jx) with ṗ = Jx q̇, ḟi = −(ṗ + ȧi) and
    /// ḟdi = cαi (cθi ẋ + sθi ẏ) − sαi ż + ḋi (time derivatives of T eqs. 139–142).
    pub fn jacobian_derivative(
        &self,
        q: &Vector3<T>,
        p: &Vector3<T>,
        q_dot: &Vector3<T>,
    ) -> Result<Matrix3<T>, KinematicsError> {
        finite3(q_dot)?;
        let (_, fd, j2_inv) = self.velocity_terms(q, p)?;
        let jx = j2_inv * Matrix3::from_diagonal(&fd);
        let p_dot = jx * q_dot;
        let [act1, act2, act3] = &self.actuators;
        // ȧi = ḋi (cθi cαi, sθi cαi, −sαi).
        let rate = |act: &Actuator<T>, d_dot: T| {
            let a_dot = Vector3::new(
                act.c_theta * act.c_alpha * d_dot,
                act.s_theta * act.c_alpha * d_dot,
                -act.s_alpha * d_dot,
            );
            let fd_dot = act.c_alpha * (act.c_theta * p_dot.x + act.s_theta * p_dot.y)
                - act.s_alpha * p_dot.z
                + d_dot;
            (-(p_dot + a_dot), fd_dot)
        };
        let (f1_dot, fd1_dot) = rate(act1, q_dot.x);
        let (f2_dot, fd2_dot) = rate(act2, q_dot.y);
        let (f3_dot, fd3_dot) = rate(act3, q_dot.z);
        let j2_dot = Matrix3::from_rows(&[
            f1_dot.transpose(),
            f2_dot.transpose(),
            f3_dot.transpose(),
        ]);
        let j1_dot = Matrix3::from_diagonal(&Vector3::new(fd1_dot, fd2_dot, fd3_dot));
        Ok(j2_inv * (j1_dot - j2_dot * jx))
    }
}
