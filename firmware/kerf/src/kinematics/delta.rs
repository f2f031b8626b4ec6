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
use crate::scalar::Float;
use nalgebra::{Matrix3, Vector3};

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
    ///
    /// Workspace sampled on a 16³ grid of the travel box (cell centres, FK; test
    /// `workspace_extent_of_the_presets`): x −50.3…+50.3 mm, y −58.1…+43.9 mm,
    /// z 79.0…140.5 mm, 100 % of the grid assembles in the working mode.
    /// f32 vs f64 over that grid: FK ≤ 0.023 µm, IK ≤ 0.041 µm.
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
    ///
    /// Workspace (same sampling): x −29.4…+29.4 mm, y −33.7…+31.5 mm, z 26.8…81.4 mm,
    /// 100 % of the grid assembles. f32 vs f64: FK ≤ 0.015 µm, IK ≤ 0.016 µm.
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
    ///
    /// Workspace (same sampling; a bounding box, the usable cylinder is smaller):
    /// x −80.2…+80.2 mm, y −69.9…+92.5 mm, z −20.6…+166.9 mm, 80 % of the grid
    /// assembles. f32 vs f64: FK ≤ 0.055 µm; IK ≤ 0.04 µm where |Jx⁻¹| ≤ 3 and up to
    /// 0.9 µm with nearly horizontal arms (the map's own gain on f32 rounding).
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

impl<T: Float> Actuator<T> {
    /// Half coefficients ai = (σ1i, σ2i, σ3i)/2 (SPEC FK, T eqs. 107–109).
    #[inline]
    fn half_sigma(&self, d_m: T) -> Vector3<T> {
        let zeta = self.offset_m + d_m * self.c_alpha;
        Vector3::new(
            self.c_theta * zeta,
            self.s_theta * zeta,
            -d_m * self.s_alpha,
        )
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

/// J2's rows, J1's diagonal and J2⁻¹.
type VelocityTerms<T> = ([Vector3<T>; 3], Vector3<T>, Matrix3<T>);

/// A validated delta geometry with precomputed constants, for scalar `T`.
#[derive(Copy, Clone, Debug)]
pub struct DeltaGeometry<T> {
    actuators: [Actuator<T>; 3],
    fk_sign: T,
    arm_product_m3: T,
    elimination_sine_sq: T,
    singular_sine: T,
}

fn convert<T: Float>(v: f64) -> T {
    nalgebra::convert::<f64, T>(v)
}

fn finite3<T: Float>(v: &Vector3<T>) -> Result<(), KinematicsError> {
    if v.iter().all(|c| c.is_finite()) {
        Ok(())
    } else {
        Err(KinematicsError::NotFinite)
    }
}

impl<T: Float> DeltaGeometry<T> {
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
        let (e, g, fallback) = if n.z * n.z >= self.elimination_sine_sq * scale_sq {
            // Elimination: det A = 4 nz; g = (g1, g2, 1), e = (e1, e2, 0) (T eqs. 118–124).
            let inv = T::one() / n.z;
            let e = Vector3::new(
                (m2.y * h1 - m1.y * h2) * inv,
                (m1.x * h2 - m2.x * h1) * inv,
                T::zero(),
            );
            (e, n * inv, false)
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
            (e, g, true)
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
        let sqrt_disc = disc.fsqrt();
        let p = self.line_point(&e, &g, beta, gamma, eta, self.fk_sign * sqrt_disc);
        match self.check_branches(q, &p) {
            // Where the line is (nearly) horizontal both roots have (nearly) the same z,
            // so "larger z" no longer tells the assembly modes apart: take the other
            // root when only it is in the working mode.
            Err(err) if fallback => {
                let other = self.line_point(&e, &g, beta, gamma, eta, -self.fk_sign * sqrt_disc);
                self.check_branches(q, &other).map_err(|_| err)?;
                Ok(other)
            }
            checked => checked.map(|()| p),
        }
    }

    /// The point e + t g with t = (−β + root)/η, root = ±√disc. When root and −β have
    /// opposite signs that sum cancels, so the equivalent t = γ / (−β − root) is used
    /// (T eq. 131 in its cancellation-free form).
    #[inline]
    fn line_point(
        &self,
        e: &Vector3<T>,
        g: &Vector3<T>,
        beta: T,
        gamma: T,
        eta: T,
        root: T,
    ) -> Vector3<T> {
        let t = if root * beta <= T::zero() {
            (root - beta) / eta
        } else {
            gamma / (-beta - root)
        };
        e + g * t
    }

    /// Working mode: each arm must be on its configured IK branch, sign(fdi) = si (SPEC).
    #[inline]
    fn check_branches(&self, q: &Vector3<T>, p: &Vector3<T>) -> Result<(), KinematicsError> {
        for (i, (act, d)) in self.actuators.iter().zip(q.iter()).enumerate() {
            if act.fd(*d, p) * act.ik_sign < T::zero() {
                return Err(KinematicsError::WrongBranch(i as u8));
            }
        }
        Ok(())
    }

    /// Inverse kinematics: displacements q in m for the effector position p in m
    /// (SPEC IK, T eqs. 132–137): di = −μ1i/2 + si √(μ1i²/4 − μ2i), si the configured
    /// branch. Errors when a discriminant is negative or di leaves the travel.
    ///
    /// Evaluated in the equivalent geometric form: with vi = p + (re − rb)(cθi, sθi, 0)
    /// and the unit vector wi = (cθi cαi, sθi cαi, −sαi), the loop closure is
    /// |vi + di wi|² = li², so μ1i/2 = vi · wi and μ1i²/4 − μ2i = li² − |vi × wi|²
    /// (li² minus the squared distance of the joint from the rail). Expanding μ2i
    /// instead subtracts two nearly equal ~0.05 m² terms, which cost 1 µm in f32 on
    /// the vertical preset; this form keeps it below 0.1 µm.
    pub fn inverse(&self, p: &Vector3<T>) -> Result<Vector3<T>, KinematicsError> {
        finite3(p)?;
        let mut q = Vector3::zeros();
        for (i, (act, d)) in self.actuators.iter().zip(q.iter_mut()).enumerate() {
            let v = Vector3::new(
                p.x + act.offset_m * act.c_theta,
                p.y + act.offset_m * act.s_theta,
                p.z,
            );
            let w = Vector3::new(
                act.c_theta * act.c_alpha,
                act.s_theta * act.c_alpha,
                -act.s_alpha,
            );
            let half_mu1 = v.dot(&w);
            let disc = act.arm_sq_m2 - v.cross(&w).norm_squared();
            if disc < T::zero() {
                return Err(KinematicsError::OutOfReach(i as u8));
            }
            *d = act.ik_sign * disc.fsqrt() - half_mu1;
            act.check_travel(*d, i as u8)?;
        }
        Ok(q)
    }

    /// `true` when the pose p is reachable in the working mode within travel and away
    /// from singularities: [`inverse`](Self::inverse) and [`jacobian`](Self::jacobian)
    /// both succeed.
    pub fn reachable(&self, p: &Vector3<T>) -> bool {
        self.inverse(p).and_then(|q| self.jacobian(&q, p)).is_ok()
    }

    /// J2 rows fi = (fxi, fyi, fzi) = −(p + ai), J1 = diag(fdi) and J2⁻¹ (SPEC velocity,
    /// T eqs. 138–145). J2⁻¹ is the adjugate over the determinant: its columns are
    /// f2 × f3, f3 × f1, f1 × f2 divided by f1 · (f2 × f3).
    fn velocity_terms(
        &self,
        q: &Vector3<T>,
        p: &Vector3<T>,
    ) -> Result<VelocityTerms<T>, KinematicsError> {
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
        let j2_inv =
            Matrix3::from_columns(&[c1 * inv_det, f3.cross(f1) * inv_det, f1.cross(f2) * inv_det]);
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
        let j2_dot =
            Matrix3::from_rows(&[f1_dot.transpose(), f2_dot.transpose(), f3_dot.transpose()]);
        let j1_dot = Matrix3::from_diagonal(&Vector3::new(fd1_dot, fd2_dot, fd3_dot));
        Ok(j2_inv * (j1_dot - j2_dot * jx))
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use proptest::prelude::*;
    use std::println;
    use std::vec::Vec;

    type V = Vector3<f64>;

    /// Seed frame, θ = 90°/190°/350° (T fig. 6.2 A) on the Keops dimensions.
    fn asymmetric_keops() -> DeltaConfig {
        let mut c = DeltaConfig::SLAVE_KEOPS;
        for (a, t) in c.actuators.iter_mut().zip([90.0, 190.0, 350.0]) {
            a.theta_rad = t * DEG;
        }
        c
    }

    /// Asymmetric master: θ = 90°/190°/350° on the horizontal master.
    fn asymmetric_master() -> DeltaConfig {
        let mut c = DeltaConfig::MASTER_HORIZONTAL;
        for (a, t) in c.actuators.iter_mut().zip([90.0, 190.0, 350.0]) {
            a.theta_rad = t * DEG;
        }
        c
    }

    /// Unequal αi, li and radii on asymmetric azimuths.
    fn unequal() -> DeltaConfig {
        let mut c = asymmetric_keops();
        let alpha = [20.0, 30.0, 40.0];
        let arm = [0.066, 0.070, 0.074];
        let rb = [0.084, 0.086, 0.090];
        let re = [0.019, 0.020, 0.022];
        for (i, a) in c.actuators.iter_mut().enumerate() {
            a.alpha_rad = alpha[i] * DEG;
            a.arm_m = arm[i];
            a.base_radius_m = rb[i];
            a.effector_radius_m = re[i];
        }
        c
    }

    /// Every geometry the checks run on.
    fn all() -> Vec<(&'static str, DeltaConfig)> {
        std::vec![
            ("master", DeltaConfig::MASTER_HORIZONTAL),
            ("slave", DeltaConfig::SLAVE_KEOPS),
            ("vertical", DeltaConfig::VERTICAL),
            ("asymmetric master", asymmetric_master()),
            ("asymmetric keops", asymmetric_keops()),
            ("unequal", unequal()),
        ]
    }

    fn geometry<T: Float>(c: &DeltaConfig) -> DeltaGeometry<T> {
        DeltaGeometry::new(c).unwrap()
    }

    /// `n`³ joint grid over the travel box (cell centres, so that rounding at the
    /// travel limits cannot turn a round trip into `OutsideTravel`).
    fn joint_grid(c: &DeltaConfig, n: usize) -> Vec<V> {
        let axis = |i: usize, k: usize| {
            let a = &c.actuators[i];
            a.travel_min_m + (a.travel_max_m - a.travel_min_m) * (k as f64 + 0.5) / n as f64
        };
        let mut out = Vec::new();
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    out.push(V::new(axis(0, i), axis(1, j), axis(2, k)));
                }
            }
        }
        out
    }

    /// Pairs (q, p) of the grid where FK succeeds and the Jacobian is regular.
    fn workspace(c: &DeltaConfig, n: usize) -> Vec<(V, V)> {
        let g = geometry::<f64>(c);
        joint_grid(c, n)
            .into_iter()
            .filter_map(|q| {
                let p = g.forward(&q).ok()?;
                g.jacobian(&q, &p).ok()?;
                Some((q, p))
            })
            .collect()
    }

    /// Residual of the loop closure |p + ai| − li of every arm (m).
    fn loop_residual(c: &DeltaConfig, q: &V, p: &V) -> f64 {
        let g = geometry::<f64>(c);
        g.actuators
            .iter()
            .zip(q.iter())
            .map(|(a, d)| ((p + a.half_sigma(*d)).norm() - a.arm_m).abs())
            .fold(0.0, f64::max)
    }

    // f64 round trips: rounding is ~1e-16 × 0.3 m, amplified by at most the condition
    // number allowed by SINGULAR_SINE (1e3): 1e-9 m leaves four decades of margin.
    const ROUND_TRIP_M: f64 = 1e-9;

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

    fn travel_point(c: &DeltaConfig, u: [f64; 3]) -> V {
        let a = &c.actuators;
        V::from_fn(|i, _| a[i].travel_min_m + u[i] * (a[i].travel_max_m - a[i].travel_min_m))
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

    proptest! {
        /// A printer configured as Klipper / Marlin describe one (tower angles, delta
        /// radius, per-tower rod lengths, z up, carriage height) has the textbook
        /// inverse carriage = z + √(l² − (x − xt)² − (y − yt)²).
        #[test]
        fn printer_mapping_matches_the_textbook_inverse(
            radius in 0.06f64..0.15,
            trims in proptest::array::uniform3(-2.0f64..2.0),
            arms in proptest::array::uniform3(0.2f64..0.3),
            pose in proptest::array::uniform3(-0.06f64..0.06),
        ) {
            let angles = [210.0 + trims[0], 330.0 + trims[1], 90.0 + trims[2]].map(|a| a * DEG);
            let c = DeltaConfig::printer(radius, angles, arms, (0.0, 1.0));
            let g = geometry::<f64>(&c);
            let p = V::new(pose[0], pose[1], pose[2] + 0.1);
            let textbook = V::from_fn(|i, _| {
                let (xt, yt) = (radius * angles[i].cos(), radius * angles[i].sin());
                p.z + (arms[i].powi(2) - (p.x - xt).powi(2) - (p.y - yt).powi(2)).sqrt()
            });
            match g.inverse(&p) {
                Ok(q) => {
                    prop_assert!((q - textbook).amax() < 1e-12, "{} vs {}", q, textbook);
                    let back = g.forward(&q).unwrap();
                    prop_assert!((back - p).amax() < ROUND_TRIP_M);
                }
                // Out of reach exactly where the textbook radicand is negative.
                Err(KinematicsError::OutOfReach(i)) => prop_assert!(textbook[i as usize].is_nan()),
                Err(e) => prop_assert!(false, "{:?}", e),
            }
        }
    }

    #[test]
    fn f32_accuracy_against_f64() {
        // f32 carries ε = 6e-8 relative precision. Rounding the ~0.3 m terms of the
        // formulas costs a few ε × 0.3 m ≈ 0.02 µm; the map then amplifies it by its
        // local gain (|Jx| for FK, |Jx⁻¹| for IK), which grows without bound towards
        // the singularities at the workspace edge. So each pose is held to
        // 8 ε × 0.3 m × max(1, gain), and the report separates well-conditioned poses
        // (gain ≤ 3), where the master's 0.5 µm encoder sets the requirement.
        const UNIT_M: f64 = 8.0 * f32::EPSILON as f64 * 0.3;
        for (name, c) in all() {
            let g32 = geometry::<f32>(&c);
            let g64 = geometry::<f64>(&c);
            let (mut fk_err, mut ik_err, mut j_err) = (0.0f64, 0.0f64, 0.0f64);
            let (mut fk_good, mut ik_good) = (0.0f64, 0.0f64);
            for (q, _) in workspace(&c, 16) {
                // Compare on the same (f32-representable) input.
                let q32 = q.map(|v| v as f32);
                let q = q32.map(f64::from);
                let (Ok(p32), Ok(p)) = (g32.forward(&q32), g64.forward(&q)) else {
                    continue;
                };
                let Ok(jx) = g64.jacobian(&q, &p) else {
                    continue;
                };
                let jx_inv = g64.jacobian_inverse(&q, &p).unwrap();
                let fk_gain = jx.abs().row_sum().max();
                let ik_gain = jx_inv.abs().row_sum().max();
                let e = (p32.map(f64::from) - p).amax();
                assert!(
                    e < UNIT_M * fk_gain.max(1.0),
                    "{name} FK {q}: {e} gain {fk_gain}"
                );
                fk_err = fk_err.max(e);
                if fk_gain <= 3.0 {
                    fk_good = fk_good.max(e);
                }
                let p32 = p.map(|v| v as f32);
                let p = p32.map(f64::from);
                let (Ok(b32), Ok(b)) = (g32.inverse(&p32), g64.inverse(&p)) else {
                    continue;
                };
                let e = (b32.map(f64::from) - b).amax();
                assert!(
                    e < UNIT_M * ik_gain.max(1.0),
                    "{name} IK {p}: {e} gain {ik_gain}"
                );
                ik_err = ik_err.max(e);
                if ik_gain <= 3.0 {
                    ik_good = ik_good.max(e);
                }
                let (Ok(j32), Ok(j)) = (g32.jacobian(&b32, &p32), g64.jacobian(&b, &p)) else {
                    continue;
                };
                j_err = j_err.max((j32.map(f64::from) - j).amax() / j.amax());
            }
            println!(
                "{name}: f32 vs f64 max FK {:.3} µm, IK {:.3} µm; gain <= 3: FK {:.3} µm, \
                 IK {:.3} µm; Jx {:.1e} relative",
                fk_err * 1e6,
                ik_err * 1e6,
                fk_good * 1e6,
                ik_good * 1e6,
                j_err
            );
            assert!(fk_good < 0.5e-6 && ik_good < 0.5e-6, "{name}");
            // Jx: f32 rounding amplified by the conditioning (≤ 1e3): 1e-3 relative.
            assert!(j_err < 1e-3, "{name}");
        }
    }

    #[test]
    fn workspace_extent_of_the_presets() {
        for (name, c) in all() {
            let grid = joint_grid(&c, 16);
            let ws = workspace(&c, 16);
            let mut lo = V::repeat(f64::INFINITY);
            let mut hi = V::repeat(f64::NEG_INFINITY);
            for (_, p) in &ws {
                lo = lo.inf(p);
                hi = hi.sup(p);
            }
            println!(
                "{name}: x {:.1}..{:.1} mm, y {:.1}..{:.1} mm, z {:.1}..{:.1} mm, {:.0} % of the joint box",
                lo.x * 1e3, hi.x * 1e3, lo.y * 1e3, hi.y * 1e3, lo.z * 1e3, hi.z * 1e3,
                100.0 * ws.len() as f64 / grid.len() as f64
            );
            // Every sampled pose is reachable by the reachability check.
            let g = geometry::<f64>(&c);
            assert!(ws.iter().all(|(_, p)| g.reachable(p)), "{name}");
            assert!(hi.z > lo.z && hi.x > lo.x && hi.y > lo.y, "{name}");
        }
    }

    #[test]
    fn errors_instead_of_nan() {
        let g = geometry::<f32>(&DeltaConfig::SLAVE_KEOPS);
        let nan = Vector3::new(f32::NAN, 0.0, 0.0);
        assert_eq!(g.forward(&nan), Err(KinematicsError::NotFinite));
        assert_eq!(g.inverse(&nan), Err(KinematicsError::NotFinite));
        assert_eq!(g.jacobian(&nan, &nan), Err(KinematicsError::NotFinite));
        // Far away: no arm reaches.
        assert!(matches!(
            g.inverse(&Vector3::new(1.0, 0.0, 0.0)),
            Err(KinematicsError::OutOfReach(_))
        ));
        assert_eq!(
            g.forward(&Vector3::new(0.05, 0.01, 0.01)),
            Err(KinematicsError::OutsideTravel(0))
        );
        // Reachable but needs a displacement beyond travel (z low → carriages out).
        let g64 = geometry::<f64>(&DeltaConfig::SLAVE_KEOPS);
        let p = g64.forward(&V::new(0.0, 0.0, 0.0)).unwrap();
        assert!(matches!(
            g64.inverse(&(p - V::z() * 0.005)),
            Err(KinematicsError::OutsideTravel(_)) | Err(KinematicsError::OutOfReach(_))
        ));
        // Arms of the horizontal master at z = 0 lie in the base plane: J2 singular.
        let m = geometry::<f64>(&DeltaConfig::MASTER_HORIZONTAL);
        let p = V::zeros();
        let q = m.inverse(&p).unwrap_or(V::repeat(0.05));
        assert!(m.jacobian(&q, &p).is_err());
    }

    #[test]
    fn rejects_bad_config() {
        let with = |f: fn(&mut DeltaConfig)| {
            let mut c = DeltaConfig::SLAVE_KEOPS;
            f(&mut c);
            DeltaGeometry::<f32>::new(&c).err()
        };
        assert_eq!(
            with(|c| c.actuators[1].arm_m = 0.0),
            Some(ConfigError::NotPositive("arm_m"))
        );
        assert_eq!(
            with(|c| c.actuators[2].alpha_rad = f64::NAN),
            Some(ConfigError::NotFinite("alpha_rad"))
        );
        assert_eq!(
            with(|c| c.actuators[0].travel_max_m = c.actuators[0].travel_min_m),
            Some(ConfigError::OutOfRange("travel_max_m"))
        );
        assert_eq!(
            with(|c| c.actuators[0].effector_radius_m = -0.01),
            Some(ConfigError::OutOfRange("effector_radius_m"))
        );
    }
}
