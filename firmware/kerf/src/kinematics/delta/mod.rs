//! Generalized linear (prismatic) delta robot (docs/equations.md §6, T ch. 6).
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
//! σ3i)/2, so the loop closure reads |p + ai|² = li² and every formula of
//! docs/equations.md §6 appears with its factor 2 taken out (fewer multiplications,
//! same roots).
//!
//! Branches (docs/equations.md §6): [`Root::Plus`] for forward kinematics is the
//! larger-z solution; the inverse-kinematics branch of actuator i is the sign of
//! fdi = ±√Δi / 2. In T's frame (effector on +z, carriages radially outside) the pair
//! is FK `Plus`, IK `Minus`; in the printer frame (z up, effector below the carriages)
//! it is FK `Minus`, IK `Plus`.
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

mod config;
mod forward;
mod inverse;
#[cfg(test)]
mod test_util;
mod velocity;

pub use config::{ActuatorConfig, DeltaConfig, SYMMETRIC_THETA_RAD};

use crate::error::{in_range, positive, ConfigContext, ConfigError};
use crate::scalar::{lit, Float};
use nalgebra::Vector3;

/// Which root of a quadratic is taken (the `±` of the closed-form solutions,
/// docs/equations.md §6).
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
    /// An input was NaN or infinite, or so large that the map overflows the scalar.
    NotFinite,
    /// No pose / displacement exists (negative discriminant). For inverse kinematics the
    /// field is the actuator index `0..3`; forward kinematics reports actuator 0.
    OutOfReach(u8),
    /// The three sphere centres are (nearly) collinear: the arms' end points form a
    /// circle, not two points. Both forward closed forms fail only here.
    SingularCentres,
    /// Two or three sphere centres (nearly) coincide: closer than
    /// `SINGULAR_SINE` times the arm length, where the pose would move a
    /// thousandfold more than the carriages and, near coincidence, is rounding alone.
    /// The relative test of [`KinematicsError::SingularCentres`] cannot see it: the
    /// direction between two points a rounding apart is arbitrary.
    CoincidentCentres,
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

const DEG: f64 = core::f64::consts::PI / 180.0;

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
    /// Half coefficients ai = (σ1i, σ2i, σ3i)/2 = bi + di wi (docs/equations.md §6,
    /// T eqs. 107–109: ζi (cθi, sθi) = bi + di cαi (cθi, sθi) and −di sαi).
    #[inline]
    fn half_sigma(&self, d_m: T) -> Vector3<T> {
        Vector3::new(
            self.base_x_m + d_m * self.rail.x,
            self.base_y_m + d_m * self.rail.y,
            d_m * self.rail.z,
        )
    }

    /// λi = li² − |ai|² (the corrected λ of docs/equations.md §6; T eq. 110 is
    /// garbled). As |wi| = 1, |ai|² = |bi|² + 2 di wi · bi + di², so
    /// λi = λ0i − di (λ1i + di): no squares of the components at run time.
    #[inline]
    fn lambda(&self, d_m: T) -> T {
        self.lambda0_m2 - d_m * (self.lambda1_m + d_m)
    }

    /// fdi = cαi (re − rb + cθi x + sθi y) − sαi z + di = wi · p + wi · bi + di
    /// (docs/equations.md §6, velocity; T eq. 142), which is wi · (p + ai) since
    /// |wi| = 1.
    #[inline]
    fn fd(&self, d_m: T, p: &Vector3<T>) -> T {
        dot3(&self.rail, p) + (self.rail_offset_m + d_m)
    }

    /// `false` also for NaN and ±∞ (the limits are finite).
    #[inline]
    fn in_travel(&self, d_m: T) -> bool {
        d_m >= self.travel_min_m && d_m <= self.travel_max_m
    }
}

/// A validated delta geometry with precomputed constants, for scalar `T`.
///
/// # Example
///
/// The Keops slave in `f64`: inverse kinematics of a pose in its workspace, forward
/// kinematics back to the same pose, and a pose no arm reaches.
///
/// ```
/// use kerf::kinematics::delta::{DeltaConfig, DeltaGeometry, KinematicsError};
/// use kerf::kinematics::Vector3;
///
/// let keops = DeltaGeometry::<f64>::new(&DeltaConfig::SLAVE_KEOPS).unwrap();
///
/// // (5, −3) mm off the axis, 50 mm above the base (workspace z 26.8…81.4 mm).
/// let p = Vector3::new(0.005, -0.003, 0.050);
/// assert!(keops.reachable(&p));
/// let q = keops.inverse(&p).unwrap(); // carriage displacements d1, d2, d3 in m
/// let back = keops.forward(&q).unwrap();
/// assert!((back - p).amax() < 1e-9);
///
/// // 1 m to the side: no arm reaches, an error instead of a NaN.
/// let far = Vector3::new(1.0, 0.0, 0.050);
/// assert!(matches!(
///     keops.inverse(&far),
///     Err(KinematicsError::OutOfReach(_))
/// ));
/// assert!(!keops.reachable(&far));
/// ```
#[derive(Copy, Clone, Debug)]
pub struct DeltaGeometry<T> {
    actuators: [Actuator<T>; 3],
    fk_sign: T,
    /// SINGULAR_SINE · l1 l2 l3: the smallest |det J2| that is not singular.
    singular_det_m3: T,
    /// (SINGULAR_SINE · l̄)², l̄ = (l1 l2 l3)^(1/3): the smallest squared distance
    /// between two sphere centres that is not singular.
    coincident_sq_m2: T,
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
        // A bounded index range rather than `enumerate`, whose counter keeps an
        // overflow check the optimiser cannot remove.
        for (index, (out, a)) in
            (0..actuators.len()).zip(actuators.iter_mut().zip(config.actuators.iter()))
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
            coincident_sq_m2: lit(libm::pow(SINGULAR_SINE * libm::cbrt(arm_product), 2.0)),
            elimination_sine_sq: lit(ELIMINATION_SINE * ELIMINATION_SINE),
            singular_sine_sq: lit(SINGULAR_SINE * SINGULAR_SINE),
        })
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::test_util::*;
    use super::*;
    use std::println;
    use std::string::{String, ToString};

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
