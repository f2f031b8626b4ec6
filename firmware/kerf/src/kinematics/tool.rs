//! Tool deflection and the hexapod's compensation (docs/equations.md §9, G ch. 6).
//!
//! The tool is a cantilever of diameter d and length L clamped in a rigid spindle
//! (G 6.1): under a tip force P it deflects by y = P L³/(3 E I) and its tip turns by
//! θ = P L²/(2 E I), with I = π d⁴/64 (G eq. 45–47). The normal force bends it by δn
//! along x, the tangential force by δt along y (G eq. 59); the tip's rotations follow:
//! α_t about x from the bend along y, β_t about y from the bend along x.
//!
//! The deflected tool in the hexapod's moving frame (G eq. 56–60):
//! R = R_y(β_t) R_x(α_t) R_CMM, T = (r_x + δn, r_y + δt, r_z − L), H_FK = [R T; 0 1],
//! and the hexapod pose that puts the deflected tool where the undeflected one should
//! be is H_new = H_desired · H_FK⁻¹ (G eq. 61). Its orientation goes to the hexapod as
//! the controller's rotation coordinates U, V, W ([`HexapodPose`]).
//!
//! Signs: the tool points along −z of its frame; a tip displaced along +y turns the
//! axis towards +y, a rotation +α_t about x (R_x(α)(0, 0, −1) = (0, sin α, −cos α));
//! a tip displaced along +x turns it towards +x, a rotation −β_t about y.

use crate::error::{in_range, positive, ConfigError};
use nalgebra::{Matrix3, Matrix4, Vector3};

/// The tool as a beam.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ToolBeamConfig {
    /// Free length L, m.
    pub length_m: f64,
    /// Diameter d, m.
    pub diameter_m: f64,
    /// Young's modulus E, Pa.
    pub youngs_modulus_pa: f64,
}

impl ToolBeamConfig {
    /// G 7.1's tool: 4 mm CBN, 23.5 mm long. G does not print E; an
    /// electroplated CBN tool's body is steel, 210 GPa. Then E I = 264 N·m², and 10 N
    /// bends the tip by 16 µm and turns it by 1.0 mrad.
    pub const CBN_4MM: Self = Self {
        length_m: 23.5e-3,
        diameter_m: 4e-3,
        youngs_modulus_pa: 210e9,
    };
}

/// The tip's deflection under a force.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Deflection {
    /// Tip displacement, m (G eq. 45).
    pub displacement_m: f64,
    /// Tip slope, rad (G eq. 46).
    pub slope_rad: f64,
}

/// Why a compensation has no answer.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ToolError {
    /// A force or pose entry is NaN or infinite.
    NotFinite,
    /// V = ±90°: U and W are not separable (gimbal lock).
    GimbalLock,
}

/// The checked beam.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ToolBeam {
    length_m: f64,
    /// L³/(3EI), m/N.
    compliance_m_n: f64,
    /// L²/(2EI), rad/N.
    slope_rad_n: f64,
}

impl ToolBeam {
    /// Validates the dimensions (positive; E between 1 GPa and 2 TPa).
    pub fn new(config: &ToolBeamConfig) -> Result<Self, ConfigError> {
        let l = positive("length_m", config.length_m)?;
        let d = positive("diameter_m", config.diameter_m)?;
        let e = in_range("youngs_modulus_pa", config.youngs_modulus_pa, 1e9, 2e12)?;
        let i = core::f64::consts::PI * d * d * d * d / 64.0; // G eq. 47
        Ok(Self {
            length_m: l,
            compliance_m_n: l * l * l / (3.0 * e * i),
            slope_rad_n: l * l / (2.0 * e * i),
        })
    }

    /// The tip's deflection under a force `force_n` across the tool (G eq. 45–46).
    pub fn deflection(&self, force_n: f64) -> Deflection {
        Deflection {
            displacement_m: self.compliance_m_n * force_n,
            slope_rad: self.slope_rad_n * force_n,
        }
    }

    /// H_FK of the deflected tool (G eq. 56–60) under the normal force (along x) and
    /// the tangential force (along y), with the spindle tip at `spindle_tip_m`
    /// (r_x, r_y, r_z) and the spindle's measured orientation `r_cmm`.
    pub fn forward(
        &self,
        normal_n: f64,
        tangential_n: f64,
        spindle_tip_m: &Vector3<f64>,
        r_cmm: &Matrix3<f64>,
    ) -> Result<Matrix4<f64>, ToolError> {
        let finite = [normal_n, tangential_n]
            .iter()
            .chain(spindle_tip_m.iter())
            .chain(r_cmm.iter())
            .all(|v| v.is_finite());
        if !finite {
            return Err(ToolError::NotFinite);
        }
        let n = self.deflection(normal_n);
        let t = self.deflection(tangential_n);
        let (alpha, beta) = (t.slope_rad, -n.slope_rad);
        let rotation = rotation_y(beta) * rotation_x(alpha) * r_cmm; // G eq. 56–58
        let translation = Vector3::new(
            spindle_tip_m.x + n.displacement_m,
            spindle_tip_m.y + t.displacement_m,
            spindle_tip_m.z - self.length_m,
        ); // G eq. 59
        let mut h = Matrix4::identity();
        h.fixed_view_mut::<3, 3>(0, 0).copy_from(&rotation);
        h.fixed_view_mut::<3, 1>(0, 3).copy_from(&translation);
        Ok(h)
    }
}

/// The hexapod pose from H_new = H_desired · H_FK⁻¹ (G eq. 61).
pub fn compensate(
    desired: &Matrix4<f64>,
    forward: &Matrix4<f64>,
) -> Result<Matrix4<f64>, ToolError> {
    // H_FK is a rigid transform: its inverse is [Rᵀ, −Rᵀ T; 0 1].
    let r = forward.fixed_view::<3, 3>(0, 0).into_owned();
    let t = forward.fixed_view::<3, 1>(0, 3).into_owned();
    let mut inverse = Matrix4::identity();
    inverse
        .fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&r.transpose());
    inverse
        .fixed_view_mut::<3, 1>(0, 3)
        .copy_from(&(-(r.transpose() * t)));
    let out = desired * inverse;
    if out.iter().all(|v| v.is_finite()) {
        Ok(out)
    } else {
        Err(ToolError::NotFinite)
    }
}

/// A hexapod pose in the controller's coordinates: X, Y, Z in m and U, V, W in rad.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HexapodPose {
    /// Translation, m.
    pub xyz_m: [f64; 3],
    /// Rotations U (about x), V (about y), W (about z), rad.
    pub uvw_rad: [f64; 3],
}

/// Convention used for U, V, W: R = R_x(U) R_y(V) R_z(W), the rotations about the
/// platform's moving axes in the order U, V, W (check it against the controller's
/// manual before driving a hexapod with it; G's scripts pass the angles to PI's
/// MOV command without stating the order).
pub fn hexapod_rotation(uvw_rad: [f64; 3]) -> Matrix3<f64> {
    let [u, v, w] = uvw_rad;
    rotation_x(u) * rotation_y(v) * rotation_z(w)
}

impl HexapodPose {
    /// The pose of a homogeneous transform in the convention of
    /// [`hexapod_rotation`]. Errors at V = ±90° (within 1e-9 of cos V = 0).
    pub fn from_matrix(h: &Matrix4<f64>) -> Result<Self, ToolError> {
        if !h.iter().all(|v| v.is_finite()) {
            return Err(ToolError::NotFinite);
        }
        // R = Rx(U) Ry(V) Rz(W): R[0,2] = sin V, R[0,0] = cos V cos W,
        // R[0,1] = −cos V sin W, R[1,2] = −sin U cos V, R[2,2] = cos U cos V.
        let r = |i: usize, j: usize| h.get((i, j)).copied().unwrap_or(0.0);
        let cos_v = libm::hypot(r(0, 0), r(0, 1));
        if cos_v < 1e-9 {
            return Err(ToolError::GimbalLock);
        }
        Ok(Self {
            xyz_m: [r(0, 3), r(1, 3), r(2, 3)],
            uvw_rad: [
                libm::atan2(-r(1, 2), r(2, 2)),
                libm::atan2(r(0, 2), cos_v),
                libm::atan2(-r(0, 1), r(0, 0)),
            ],
        })
    }
}

fn rotation_x(a: f64) -> Matrix3<f64> {
    let (s, c) = (libm::sin(a), libm::cos(a));
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c) // G eq. 57
}

fn rotation_y(a: f64) -> Matrix3<f64> {
    let (s, c) = (libm::sin(a), libm::cos(a));
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c) // G eq. 58
}

fn rotation_z(a: f64) -> Matrix3<f64> {
    let (s, c) = (libm::sin(a), libm::cos(a));
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The beam formulas against a numerical double integration of E I y″ = P (L − x)
    /// (G eq. 38) by the trapezoid rule on 10⁵ steps.
    #[test]
    fn deflection_is_the_double_integral() {
        let beam = ToolBeam::new(&ToolBeamConfig::CBN_4MM).unwrap();
        let c = ToolBeamConfig::CBN_4MM;
        let ei = c.youngs_modulus_pa * core::f64::consts::PI * c.diameter_m.powi(4) / 64.0;
        let (p, l, n) = (10.0, c.length_m, 100_000);
        let h = l / n as f64;
        let (mut slope, mut y) = (0.0, 0.0);
        for k in 0..n {
            let (x0, x1) = (k as f64 * h, (k + 1) as f64 * h);
            let next = slope + 0.5 * h * (p * (l - x0) + p * (l - x1)) / ei;
            y += 0.5 * h * (slope + next);
            slope = next;
        }
        let d = beam.deflection(p);
        assert!((d.slope_rad / slope - 1.0).abs() < 1e-9);
        assert!((d.displacement_m / y - 1.0).abs() < 1e-8);
        // Stated in the preset's docs.
        assert!(
            (d.displacement_m - 16.0e-6).abs() < 0.5e-6,
            "{}",
            d.displacement_m
        );
        assert!((d.slope_rad - 1.0e-3).abs() < 0.05e-3, "{}", d.slope_rad);
    }

    /// The compensated hexapod pose, rebuilt from its U, V, W and X, Y, Z the way the
    /// controller would, carries the deflected tool so that its face is parallel to
    /// the surface: the deflected tool's axis, built here by bending the undeflected
    /// axis (0, 0, −1) by the beam's tip slopes and turning it by the spindle mount and
    /// the hexapod, is the surface's inward normal, and the tip is on the surface
    /// point. Surface tilted 3° and 1° (a workpiece like G 7's), forces of 7.5 N
    /// normal and 2.6 N tangential.
    #[test]
    fn compensated_tool_face_is_parallel_to_the_surface() {
        let beam = ToolBeam::new(&ToolBeamConfig::CBN_4MM).unwrap();
        // The spindle square to the hexapod (R_CMM = I): the print turns the tool by
        // its slopes about the hexapod's axes after R_CMM (eq. 56), so with a tilted
        // mount the construction below would differ from it at second order.
        let r_cmm = Matrix3::identity();
        let spindle_tip = Vector3::new(0.001, -0.002, 0.12);
        let (fn_n, ft_n) = (7.5, 2.6);
        // The desired tool frame: its −z axis along the surface's inward normal.
        let tilt = rotation_x(3f64.to_radians()) * rotation_y(1f64.to_radians());
        let surface_point = Vector3::new(0.2, 0.1, 0.05);
        let mut desired = Matrix4::identity();
        desired.fixed_view_mut::<3, 3>(0, 0).copy_from(&tilt);
        desired
            .fixed_view_mut::<3, 1>(0, 3)
            .copy_from(&surface_point);
        let forward = beam.forward(fn_n, ft_n, &spindle_tip, &r_cmm).unwrap();
        let new = compensate(&desired, &forward).unwrap();
        let pose = HexapodPose::from_matrix(&new).unwrap();
        // The controller's pose, from its coordinates.
        let hex = hexapod_rotation(pose.uvw_rad);
        let hex_t = Vector3::from(pose.xyz_m);
        // The deflected axis: the undeflected one turned by the tip slopes (tangent
        // of the bent beam: (θ_n, θ_t) across, −1 along, normalized).
        let (sn, st) = (
            beam.deflection(fn_n).slope_rad,
            beam.deflection(ft_n).slope_rad,
        );
        let bent = Vector3::new(sn.sin() * st.cos(), st.sin(), -(sn.cos() * st.cos()));
        let axis_world = hex * r_cmm * bent;
        let normal_in = tilt * Vector3::new(0.0, 0.0, -1.0);
        assert!(
            (axis_world - normal_in).norm() < 1e-6,
            "{}",
            (axis_world - normal_in).norm()
        );
        let tip = hex
            * (spindle_tip
                + Vector3::new(
                    beam.deflection(fn_n).displacement_m,
                    beam.deflection(ft_n).displacement_m,
                    -beam.length_m,
                ))
            + hex_t;
        assert!((tip - surface_point).norm() < 1e-12);
        // Not compensating leaves the face tilted by the tip slopes, 0.8 mrad here.
        let plain = tilt * bent;
        assert!((plain - normal_in).norm() > 5e-4);
        // With a tilted mount, the compensated hexapod pose composed with the
        // deflected tool is the desired tool pose (eq. 61 inverted).
        let r_cmm = rotation_z(0.02) * rotation_x(0.004);
        let forward = beam.forward(fn_n, ft_n, &spindle_tip, &r_cmm).unwrap();
        let new = compensate(&desired, &forward).unwrap();
        assert!((new * forward - desired).amax() < 1e-12);
    }

    /// U, V, W round trip over a grid and the gimbal lock as an error.
    #[test]
    fn euler_angles_round_trip_and_lock() {
        for u in [-1.0, -0.3, 0.0, 0.7] {
            for v in [-1.5, -0.2, 0.0, 1.2] {
                for w in [-2.5, 0.0, 0.4, 3.0] {
                    let mut h = Matrix4::identity();
                    h.fixed_view_mut::<3, 3>(0, 0)
                        .copy_from(&hexapod_rotation([u, v, w]));
                    let p = HexapodPose::from_matrix(&h).unwrap();
                    let back = hexapod_rotation(p.uvw_rad);
                    assert!((back - hexapod_rotation([u, v, w])).amax() < 1e-12);
                    assert!((p.uvw_rad[0] - u).abs() < 1e-9 && (p.uvw_rad[1] - v).abs() < 1e-9);
                }
            }
        }
        let mut h = Matrix4::identity();
        h.fixed_view_mut::<3, 3>(0, 0).copy_from(&hexapod_rotation([
            0.3,
            core::f64::consts::FRAC_PI_2,
            0.2,
        ]));
        assert_eq!(HexapodPose::from_matrix(&h), Err(ToolError::GimbalLock));
        let beam = ToolBeam::new(&ToolBeamConfig::CBN_4MM).unwrap();
        assert_eq!(
            beam.forward(f64::NAN, 0.0, &Vector3::zeros(), &Matrix3::identity()),
            Err(ToolError::NotFinite)
        );
    }
}
