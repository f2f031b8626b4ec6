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
//! Scalars: generic over [`Float`] (`f32` on the target, `f64` as the reference). The
//! measured `f32` error against `f64` is listed on each preset. A fixed-point type is
//! not usable through this code, since `fixed` types do not implement `RealField`; the
//! formulas themselves are: evaluated in Q31.32 (`fixed`'s I32F32, exactly rounded
//! products and square root), the inverse kinematics stays within 4 nm of f64 over the
//! Keops and master workspaces and 10 nm over the vertical one (test
//! `q31_32_inverse_kinematics_is_usable_to_nanometres`), so a dedicated fixed-point
//! port is feasible if an FPU-less part ever needs one.
//!
//! Hot path: no `f64`, no allocation, no panics; `forward` uses one square root and two
//! divisions, `inverse` three square roots, `jacobian` one division.

use crate::error::{in_range, positive, ConfigContext, ConfigError};
use crate::scalar::{lit, Float};
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
    /// f32 vs f64 over that grid: FK ≤ 0.026 µm, IK ≤ 0.028 µm.
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
    /// assembles. f32 vs f64: FK ≤ 0.084 µm; IK ≤ 0.051 µm where |Jx⁻¹| ≤ 3 and up to
    /// 1.1 µm with nearly horizontal arms (the map's own gain on f32 rounding).
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

/// Precomputed per-actuator constants (evaluated in `f64` by [`DeltaGeometry::new`]).
#[derive(Copy, Clone, Debug)]
struct Actuator<T> {
    c_theta: T,
    s_theta: T,
    c_alpha: T,
    s_alpha: T,
    /// re − rb.
    offset_m: T,
    /// Rail direction wi = (cθi cαi, sθi cαi, −sαi), a unit vector: ai = bi + di wi.
    rail: Vector3<T>,
    /// x of bi = (re − rb)(cθi, sθi, 0), the half coefficients at di = 0.
    base_x_m: T,
    /// y of bi.
    base_y_m: T,
    /// wi · bi = (re − rb) cαi.
    rail_offset_m: T,
    /// λ0i = li² − (re − rb)², see [`Actuator::lambda`].
    lambda0_m2: T,
    /// λ1i = 2 (re − rb) cαi, see [`Actuator::lambda`].
    lambda1_m: T,
    arm_sq_m2: T,
    /// SINGULAR_SINE · li: the smallest |fdi| that is not singular.
    singular_fd_m: T,
    travel_min_m: T,
    travel_max_m: T,
    /// ±1, the IK branch.
    ik_sign: T,
}

/// a ≥ b; `false` when either is NaN, so that a NaN fails the check it is used in.
#[inline(always)]
fn at_least<T: Float>(a: T, b: T) -> bool {
    a >= b
}

/// a > b; `false` when either is NaN.
#[inline(always)]
fn exceeds<T: Float>(a: T, b: T) -> bool {
    a > b
}

/// 0 for finite x, NaN for NaN and ±∞ (0 · ∞ is NaN), so that one comparison of a
/// sum of these tests several values.
#[inline(always)]
fn zero_if_finite<T: Float>(x: T) -> T {
    x * T::zero()
}

fn dot3<T: Float>(a: &Vector3<T>, b: &Vector3<T>) -> T {
    a.x * b.x + a.y * b.y + a.z * b.z
}

fn cross3<T: Float>(a: &Vector3<T>, b: &Vector3<T>) -> Vector3<T> {
    Vector3::new(
        a.y * b.z - a.z * b.y,
        a.z * b.x - a.x * b.z,
        a.x * b.y - a.y * b.x,
    )
}

impl<T: Float> Actuator<T> {
    /// Half coefficients ai = (σ1i, σ2i, σ3i)/2 = bi + di wi (SPEC FK, T eqs. 107–109:
    /// ζi (cθi, sθi) = bi + di cαi (cθi, sθi) and −di sαi).
    #[inline]
    fn half_sigma(&self, d_m: T) -> Vector3<T> {
        Vector3::new(
            self.base_x_m + d_m * self.rail.x,
            self.base_y_m + d_m * self.rail.y,
            d_m * self.rail.z,
        )
    }

    /// λi = li² − |ai|² (SPEC's corrected λ; T eq. 110 is garbled). As |wi| = 1,
    /// |ai|² = |bi|² + 2 di wi · bi + di², so λi = λ0i − di (λ1i + di): no squares of
    /// the components at run time.
    #[inline]
    fn lambda(&self, d_m: T) -> T {
        self.lambda0_m2 - d_m * (self.lambda1_m + d_m)
    }

    /// fdi = cαi (re − rb + cθi x + sθi y) − sαi z + di = wi · p + wi · bi + di (SPEC
    /// velocity, T eq. 142), which is wi · (p + ai) since |wi| = 1.
    #[inline]
    fn fd(&self, d_m: T, p: &Vector3<T>) -> T {
        dot3(&self.rail, p) + (self.rail_offset_m + d_m)
    }

    /// `false` also for NaN and ±∞ (the limits are finite).
    #[inline]
    fn in_travel(&self, d_m: T) -> bool {
        d_m >= self.travel_min_m && d_m <= self.travel_max_m
    }

    /// di = si √(μ1i²/4 − μ2i) − μ1i/2 for actuator `index` (SPEC IK, T eqs. 132–137),
    /// see [`DeltaGeometry::inverse`].
    #[inline]
    fn displacement(&self, p: &Vector3<T>, index: u8) -> Result<T, KinematicsError> {
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
        let d_m = self.ik_sign * disc.fsqrt() - along;
        if !self.in_travel(d_m) {
            return Err(KinematicsError::OutsideTravel(index));
        }
        Ok(d_m)
    }
}

/// What the velocity maps share at (q, p) (SPEC velocity, T eqs. 138–145).
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
}

/// A validated delta geometry with precomputed constants, for scalar `T`.
#[derive(Copy, Clone, Debug)]
pub struct DeltaGeometry<T> {
    actuators: [Actuator<T>; 3],
    fk_sign: T,
    /// SINGULAR_SINE · l1 l2 l3: the smallest |det J2| that is not singular.
    singular_det_m3: T,
    elimination_sine_sq: T,
    singular_sine_sq: T,
}

/// The error to report once a check has failed: [`KinematicsError::NotFinite`] when an
/// input is NaN or ±∞, otherwise `err`. The hot paths do not test their inputs: NaN
/// and ±∞ propagate through the arithmetic into a value that fails one of the checks
/// (each map notes which), so only a failed call pays for the test here.
#[cold]
#[inline(never)]
fn or_not_finite<T: Float>(inputs: &[&Vector3<T>], err: KinematicsError) -> KinematicsError {
    if inputs.iter().all(|v| v.iter().all(|c| c.is_finite())) {
        err
    } else {
        KinematicsError::NotFinite
    }
}

impl<T: Float> DeltaGeometry<T> {
    /// Validates `config`: angles finite, αi in [0, π/2], arms positive, radii finite
    /// and non-negative, travel finite with min < max.
    pub fn new(config: &DeltaConfig) -> Result<Self, ConfigError> {
        let zero = T::zero();
        let mut actuators = [Actuator {
            c_theta: zero,
            s_theta: zero,
            c_alpha: zero,
            s_alpha: zero,
            offset_m: zero,
            rail: Vector3::zeros(),
            base_x_m: zero,
            base_y_m: zero,
            rail_offset_m: zero,
            lambda0_m2: zero,
            lambda1_m: zero,
            arm_sq_m2: zero,
            singular_fd_m: zero,
            travel_min_m: zero,
            travel_max_m: zero,
            ik_sign: T::one(),
        }; 3];
        let mut arm_product = 1.0;
        for (index, (out, a)) in actuators
            .iter_mut()
            .zip(config.actuators.iter())
            .enumerate()
        {
            let checked = || {
                let theta = in_range("theta_rad", a.theta_rad, -360.0 * DEG, 360.0 * DEG)?;
                let alpha = in_range("alpha_rad", a.alpha_rad, 0.0, 90.0 * DEG)?;
                let arm = positive("arm_m", a.arm_m)?;
                let rb = in_range("base_radius_m", a.base_radius_m, 0.0, f64::MAX)?;
                let re = in_range("effector_radius_m", a.effector_radius_m, 0.0, f64::MAX)?;
                let lo = in_range("travel_min_m", a.travel_min_m, f64::MIN, f64::MAX)?;
                let hi = in_range("travel_max_m", a.travel_max_m, lo, f64::MAX)?;
                if hi <= lo {
                    return Err(ConfigError::out_of_range("travel_max_m"));
                }
                Ok((theta, alpha, arm, rb, re, lo, hi))
            };
            let (theta, alpha, arm, rb, re, lo, hi) = checked().at(index).within("actuators")?;
            arm_product *= arm;
            let (c_theta, s_theta) = (libm::cos(theta), libm::sin(theta));
            let (c_alpha, s_alpha) = (libm::cos(alpha), libm::sin(alpha));
            let offset = re - rb;
            *out = Actuator {
                c_theta: lit(c_theta),
                s_theta: lit(s_theta),
                c_alpha: lit(c_alpha),
                s_alpha: lit(s_alpha),
                offset_m: lit(offset),
                rail: Vector3::new(
                    lit(c_theta * c_alpha),
                    lit(s_theta * c_alpha),
                    lit(-s_alpha),
                ),
                base_x_m: lit(offset * c_theta),
                base_y_m: lit(offset * s_theta),
                rail_offset_m: lit(offset * c_alpha),
                lambda0_m2: lit(arm * arm - offset * offset),
                lambda1_m: lit(2.0 * offset * c_alpha),
                arm_sq_m2: lit(arm * arm),
                singular_fd_m: lit(SINGULAR_SINE * arm),
                travel_min_m: lit(lo),
                travel_max_m: lit(hi),
                ik_sign: lit(a.ik_root.sign()),
            };
        }
        Ok(Self {
            actuators,
            fk_sign: lit(config.fk_root.sign()),
            singular_det_m3: lit(SINGULAR_SINE * arm_product),
            elimination_sine_sq: lit(ELIMINATION_SINE * ELIMINATION_SINE),
            singular_sine_sq: lit(SINGULAR_SINE * SINGULAR_SINE),
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
    ///
    /// NaN or ±∞ in q fails the travel check.
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
        let scale_sq = dot3(&m1, &m1) * dot3(&m2, &m2);
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

    /// Working mode: each arm must be on its configured IK branch, sign(fdi) = si (SPEC).
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

    /// Inverse kinematics: displacements q in m for the effector position p in m
    /// (SPEC IK, T eqs. 132–137): di = −μ1i/2 + si √(μ1i²/4 − μ2i), si the configured
    /// branch. Errors when a discriminant is negative or di leaves the travel.
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

    /// J2 = −G, J1 = diag(fdi) and J2⁻¹ = adj G / det J2 (SPEC velocity,
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
        Err(or_not_finite(&[q, p], err))
    }

    /// Jx = J2⁻¹ J1 at the consistent pair (q, p), so that ṗ = Jx q̇ (T eq. 146).
    pub fn jacobian(&self, q: &Vector3<T>, p: &Vector3<T>) -> Result<Matrix3<T>, KinematicsError> {
        Ok(self.velocity_terms(q, p)?.jacobian())
    }

    /// Jx⁻¹ = J1⁻¹ J2 at (q, p), so that q̇ = Jx⁻¹ ṗ: row i is fi / fdi = −gi / fdi.
    pub fn jacobian_inverse(
        &self,
        q: &Vector3<T>,
        p: &Vector3<T>,
    ) -> Result<Matrix3<T>, KinematicsError> {
        let VelocityTerms { g, fd, .. } = self.velocity_terms(q, p)?;
        let [g1, g2, g3] = g;
        Ok(Matrix3::from_rows(&[
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
        // M = J̇1 + Ġ Jx: row i is ġiᵀ Jx plus ḟdi on the diagonal.
        let mut m = Matrix3::from_fn(|i, j| dot3(&g_dot[i], &jx.column(j).into_owned()));
        m[(0, 0)] += dot3(&act1.rail, &g_dot[0]);
        m[(1, 1)] += dot3(&act2.rail, &g_dot[1]);
        m[(2, 2)] += dot3(&act3.rail, &g_dot[2]);
        let [c1, c2, c3] = &terms.adj;
        Ok(Matrix3::from_fn(|k, j| {
            (c1[k] * m[(0, j)] + c2[k] * m[(1, j)] + c3[k] * m[(2, j)]) * terms.inv_det_j2
        }))
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
    use super::*;
    use proptest::prelude::*;
    use std::println;
    use std::string::{String, ToString};
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
        (g.actuators.iter().zip(c.actuators.iter()).zip(q.iter()))
            .map(|((a, config), d)| ((p + a.half_sigma(*d)).norm() - config.arm_m).abs())
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
        let with = |f: fn(&mut DeltaConfig)| -> Option<String> {
            let mut c = DeltaConfig::SLAVE_KEOPS;
            f(&mut c);
            DeltaGeometry::<f32>::new(&c).err().map(|e| e.to_string())
        };
        assert_eq!(
            with(|c| c.actuators[1].arm_m = 0.0),
            Some("actuators[1].arm_m: not strictly positive".into())
        );
        assert_eq!(
            with(|c| c.actuators[2].alpha_rad = f64::NAN),
            Some("actuators[2].alpha_rad: not finite".into())
        );
        assert_eq!(
            with(|c| c.actuators[0].travel_max_m = c.actuators[0].travel_min_m),
            Some("actuators[0].travel_max_m: out of the supported range".into())
        );
        assert_eq!(
            with(|c| c.actuators[0].effector_radius_m = -0.01),
            Some("actuators[0].effector_radius_m: out of the supported range".into())
        );
    }
}
