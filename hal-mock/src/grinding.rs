//! The grinding cell's process (G ch. 3, 5.2): the piezo stage that sets the tool's
//! depth, a workpiece whose surface the tool removes, and the force the contact makes.
//!
//! Geometry, in the plane of the pass: x along the feed (the hexapod's motion), y
//! normal to the workpiece's mean surface, material below the surface height h(x).
//! The tool is a disc of radius r whose centre moves along x with the feed and along
//! −y with the piezo's extension p: centre (x_t, y_0 − p). The unknown surface is
//! G fig. 30's sinusoid written in space, h(x) = A + B sin(C x + D): G moves it
//! past the tool at the feed, which is the same thing.
//!
//! Local depth of cut (G 5.2, fig. 34): the height of the leading intersection of the
//! tool's circle with the present surface above the tool's lowest point, measured
//! along the normal to the motion. The tool removes what lies inside its circle (the
//! new surface is the lower of the old one and the circle), so after one pass the
//! surface is the envelope of the tool's path, and a constant depth of cut leaves it
//! parallel to the surface before.
//!
//! Forces: grinding (spindle turning) by Werner's model of the normal force per unit
//! width, F′n = K (v_w/v_s)^(2ε−1) a^ε d_s^(1−ε) (Werner, "Kinematik und Mechanik
//! des Schleifprozesses", 1971; in the form of Tönshoff et al., "Modelling and
//! simulation of grinding processes", CIRP Annals 41/2, 1992), with the tangential
//! force Ft = μ Fn by the force ratio μ. G's own force model (its reference
//! 11) is not printed; [`GrindingForces::ST37_CBN_4MM`] documents the constants
//! chosen in its place. With the spindle stopped (the contour-tracking run, G 7.3)
//! nothing is removed and the force is the elastic contact of the tool on the surface.

use libm::{pow, sqrt};

/// A second-order discrete plant b1 z / (z² + a1 z + a2), one sample per control
/// period: y(k) = −a1 y(k−1) − a2 y(k−2) + b1 u(k−1).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PiezoModel {
    /// Numerator coefficient b1.
    pub b1: f64,
    /// Denominator coefficient a1.
    pub a1: f64,
    /// Denominator coefficient a2.
    pub a2: f64,
    /// Sample time, s.
    pub ts_s: f64,
    /// Travel of the stage: the command is clipped to [0, stroke], m.
    pub stroke_m: f64,
}

impl PiezoModel {
    /// The piezo stage as identified in G eq. 34: G(z) = 0.001333 z / (z² − 1.949 z +
    /// 0.9503) at 1 ms (poles 0.9748 e^(±0.025 i): about 5.7 Hz, damping 0.72; DC gain
    /// 1.025). Stroke 1 mm: the P-602 stage of G 3.1.1 (0–10 V for 0–1 mm, closed
    /// loop on its strain gauges).
    pub const IDENTIFIED: Self = Self {
        b1: 0.001333,
        a1: -1.949,
        a2: 0.9503,
        ts_s: 1e-3,
        stroke_m: 1e-3,
    };

    /// Static gain G(1).
    pub fn dc_gain(&self) -> f64 {
        self.b1 / (1.0 + self.a1 + self.a2)
    }
}

/// The piezo stage: the model's state, stepped once per period.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PiezoStage {
    model: PiezoModel,
    y1: f64,
    y2: f64,
    u1: f64,
}

impl PiezoStage {
    /// At rest at extension `position_m` (the state the model holds for a constant
    /// command).
    pub fn at_rest(model: PiezoModel, position_m: f64) -> Self {
        Self {
            model,
            y1: position_m,
            y2: position_m,
            u1: position_m / model.dc_gain(),
        }
    }

    /// One period: takes the command, returns the extension at the end of the period.
    pub fn step(&mut self, command_m: f64) -> f64 {
        let m = &self.model;
        let y = -m.a1 * self.y1 - m.a2 * self.y2 + m.b1 * self.u1;
        self.y2 = self.y1;
        self.y1 = y;
        self.u1 = command_m.clamp(0.0, m.stroke_m);
        y
    }

    /// The present extension, m.
    pub fn position_m(&self) -> f64 {
        self.y1
    }
}

/// G fig. 30's surface in space: h(x) = A + B sin(C x + D).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SinusoidalSurface {
    /// Mean height A, m.
    pub offset_m: f64,
    /// Amplitude B, m.
    pub amplitude_m: f64,
    /// Spatial frequency C, rad/m.
    pub wavenumber_rad_m: f64,
    /// Phase D, rad.
    pub phase_rad: f64,
}

impl SinusoidalSurface {
    /// Height at x, m.
    pub fn height_m(&self, x_m: f64) -> f64 {
        self.offset_m + self.amplitude_m * libm::sin(self.wavenumber_rad_m * x_m + self.phase_rad)
    }
}

/// Where the tool meets the surface in one period.
#[derive(Copy, Clone, Debug, PartialEq, Default)]
pub struct Engagement {
    /// Local depth of cut (module docs), m; zero without contact.
    pub depth_m: f64,
    /// Direction of the contact normal, from the contact towards the tool centre, as
    /// an angle from +y, rad (positive towards +x).
    pub normal_angle_rad: f64,
}

/// The workpiece along the pass: its surface height sampled every `dx` from `x0`.
#[derive(Clone, Debug)]
pub struct Workpiece<const N: usize> {
    x0_m: f64,
    dx_m: f64,
    height_m: [f64; N],
}

impl<const N: usize> Workpiece<N> {
    /// The surface `surface` sampled at x0 + i·dx.
    pub fn new(surface: &SinusoidalSurface, x0_m: f64, dx_m: f64) -> Self {
        Self {
            x0_m,
            dx_m,
            height_m: core::array::from_fn(|i| surface.height_m(x0_m + dx_m * i as f64)),
        }
    }

    /// The sampled heights, m.
    pub fn heights_m(&self) -> &[f64; N] {
        &self.height_m
    }

    /// x of sample `i`, m.
    pub fn x_m(&self, i: usize) -> f64 {
        self.x0_m + self.dx_m * i as f64
    }

    /// The tool (centre at `centre_x_m`, lowest point at `bottom_y_m`, radius
    /// `radius_m`) against the surface: the local depth of cut at the leading
    /// intersection, and, with `remove`, the material inside the circle taken away.
    pub fn engage(
        &mut self,
        centre_x_m: f64,
        bottom_y_m: f64,
        radius_m: f64,
        remove: bool,
    ) -> Engagement {
        let centre_y = bottom_y_m + radius_m;
        let circle = |x: f64| {
            let u = x - centre_x_m;
            centre_y - sqrt((radius_m * radius_m - u * u).max(0.0))
        };
        let first = libm::ceil((centre_x_m - radius_m - self.x0_m) / self.dx_m).max(0.0) as usize;
        let last =
            (libm::floor((centre_x_m + radius_m - self.x0_m) / self.dx_m).max(-1.0) + 1.0) as usize;
        let range = first.min(N)..last.min(N);
        // Leading intersection: the furthest sample ahead of the centre still inside
        // the circle.
        let mut contact: Option<usize> = None;
        for i in range.clone() {
            let x = self.x_m(i);
            if x >= centre_x_m && self.height_m[i] >= circle(x) {
                contact = Some(i);
            }
        }
        // Behind the centre only (a surface that dips under the leading half): the
        // deepest point inside the circle.
        let contact = contact.or_else(|| {
            range
                .clone()
                .filter(|&i| self.height_m[i] >= circle(self.x_m(i)))
                .max_by(|&a, &b| self.height_m[a].total_cmp(&self.height_m[b]))
        });
        let engagement = match contact {
            Some(i) => {
                // Between the last sample inside and the next one outside, the
                // crossing of the surface (linear between samples) with the circle, by
                // linear interpolation of their difference: off by about dx²/(8r).
                let xi = self.x_m(i);
                let gap_i = self.height_m[i] - circle(xi);
                let x = match self.height_m.get(i + 1) {
                    Some(&next) if xi >= centre_x_m => {
                        let x1 = self.x_m(i + 1);
                        let gap_1 = next - circle(x1);
                        if gap_1 < 0.0 {
                            xi + (x1 - xi) * gap_i / (gap_i - gap_1)
                        } else {
                            xi
                        }
                    }
                    _ => xi,
                };
                let y = circle(x);
                Engagement {
                    depth_m: (y - bottom_y_m).max(0.0),
                    normal_angle_rad: libm::atan2(centre_x_m - x, centre_y - y),
                }
            }
            None => Engagement::default(),
        };
        if remove {
            for i in range {
                let c = circle(self.x_m(i));
                if self.height_m[i] > c {
                    self.height_m[i] = c;
                }
            }
        }
        engagement
    }
}

/// Werner's grinding force model and the elastic contact (module docs).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct GrindingForces {
    /// Werner's specific force constant K, in the units that give F′n in N/mm for the
    /// depth a and the tool diameter d_s in mm.
    pub werner_k: f64,
    /// Werner's exponent ε (0 < ε < 1).
    pub werner_epsilon: f64,
    /// Force ratio μ = Ft/Fn.
    pub force_ratio: f64,
    /// Width of the cut b (the plate's thickness), m.
    pub width_m: f64,
    /// Tool diameter d_s, m.
    pub tool_diameter_m: f64,
    /// Contact stiffness of the tool on the surface with the spindle stopped, N/m.
    pub contact_stiffness_n_m: f64,
}

impl GrindingForces {
    /// G 7.1's cut: a 4 mm CBN tool on a 4 mm ST37 plate. ε = 0.7 and μ = 0.35 are
    /// mid-range values for steel with CBN (Tönshoff et al. 1992 give ε between 0.5 and
    /// 0.9 and force ratios of 0.2 to 0.5); K = 2,400 puts G's 7.5 N at a depth
    /// of cut of 10 µm at its feed (0.1 mm/s) and spindle speed (25,000 rpm: v_s =
    /// 5.24 m/s), the light abrasive regime G grinds in. The contact stiffness
    /// (1 N/µm) is that of a tool on a compliant robotic setup (G 1.5: about 30 times
    /// softer than a CNC grinder's).
    pub const ST37_CBN_4MM: Self = Self {
        werner_k: 2400.0,
        werner_epsilon: 0.7,
        force_ratio: 0.35,
        width_m: 4e-3,
        tool_diameter_m: 4e-3,
        contact_stiffness_n_m: 1e6,
    };

    /// (Fn, Ft) in N for a depth of cut, the feed v_w and the tool's surface speed v_s
    /// (both m/s; v_s = 0 for a stopped spindle: elastic contact, no tangential force).
    pub fn forces_n(&self, depth_m: f64, feed_m_s: f64, surface_speed_m_s: f64) -> (f64, f64) {
        if depth_m <= 0.0 {
            return (0.0, 0.0);
        }
        if surface_speed_m_s <= 0.0 {
            return (self.contact_stiffness_n_m * depth_m, 0.0);
        }
        let e = self.werner_epsilon;
        let ratio = (feed_m_s.abs() / surface_speed_m_s).max(1e-12);
        let per_mm = self.werner_k
            * pow(ratio, 2.0 * e - 1.0)
            * pow(depth_m * 1e3, e)
            * pow(self.tool_diameter_m * 1e3, 1.0 - e);
        let normal = per_mm * self.width_m * 1e3;
        (normal, self.force_ratio * normal)
    }

    /// The tool's surface speed at `rpm`, m/s.
    pub fn surface_speed_m_s(&self, rpm: f64) -> f64 {
        core::f64::consts::PI * self.tool_diameter_m * rpm / 60.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The difference equation against G(z) evaluated on the unit circle: the
    /// steady-state response to a sinusoid of frequency ω has gain |G(e^{iωT})|.
    #[test]
    fn piezo_follows_its_transfer_function() {
        let model = PiezoModel::IDENTIFIED;
        assert!((model.dc_gain() - 1.0254).abs() < 1e-3);
        for omega in [2.0, 20.0, 60.0] {
            let mut stage = PiezoStage::at_rest(model, 50e-6);
            let mut peak: f64 = 0.0;
            for k in 0..20_000 {
                let t = k as f64 * model.ts_s;
                let y = stage.step(50e-6 + 10e-6 * libm::sin(omega * t));
                if k > 15_000 {
                    peak = peak.max((y - 50e-6 * model.dc_gain()).abs());
                }
            }
            // |G(e^{iθ})| by complex arithmetic written out.
            let th = omega * model.ts_s;
            let (c, s) = (libm::cos(th), libm::sin(th));
            let (c2, s2) = (libm::cos(2.0 * th), libm::sin(2.0 * th));
            let den_re = c2 + model.a1 * c + model.a2;
            let den_im = s2 + model.a1 * s;
            let gain = model.b1 / sqrt(den_re * den_re + den_im * den_im);
            // Sampled peak of a sinusoid: within (1 − cos(θ/2)) of the true amplitude.
            assert!(
                (peak / 10e-6 - gain).abs() < 2e-3 * gain + 1e-3,
                "{omega}: {peak}"
            );
        }
    }

    /// A flat surface ground at a fixed depth: the depth is the set interference, the
    /// new surface lies that much lower where the tool passed and untouched ahead.
    #[test]
    fn flat_cut_removes_the_depth_and_reports_it() {
        let flat = SinusoidalSurface {
            offset_m: 0.0,
            amplitude_m: 0.0,
            wavenumber_rad_m: 0.0,
            phase_rad: 0.0,
        };
        let mut w = Workpiece::<4000>::new(&flat, 0.0, 5e-6);
        let (r, a) = (2e-3, 10e-6);
        let mut x = 3e-3;
        let mut last = Engagement::default();
        while x < 15e-3 {
            last = w.engage(x, -a, r, true);
            x += 1e-7 * 50.0;
        }
        assert!((last.depth_m - a).abs() < 0.05e-6, "{}", last.depth_m);
        // Leading contact ahead of the centre: the normal leans back by about
        // √(2a/r) rad.
        let lean = -last.normal_angle_rad;
        assert!((lean - sqrt(2.0 * a / r)).abs() < 0.01, "{lean}");
        let h = w.heights_m();
        assert!((h[2000] + a).abs() < 1e-9, "{}", h[2000]);
        assert_eq!(h[3999], 0.0);
    }

    /// Werner's model scales as a^ε and (v_w/v_s)^(2ε−1); at the preset's operating
    /// point it gives the stated 7.5 N.
    #[test]
    fn werner_forces_scale_as_the_model() {
        let f = GrindingForces::ST37_CBN_4MM;
        let vs = f.surface_speed_m_s(25_000.0);
        assert!((vs - 5.236).abs() < 1e-3);
        let (fn1, ft1) = f.forces_n(10e-6, 1e-4, vs);
        assert!((fn1 - 7.5).abs() < 0.1, "{fn1}");
        assert!((ft1 / fn1 - 0.35).abs() < 1e-12);
        let (fn2, _) = f.forces_n(20e-6, 1e-4, vs);
        assert!((fn2 / fn1 - pow(2.0, 0.7)).abs() < 1e-12);
        let (fn3, _) = f.forces_n(10e-6, 2e-4, vs);
        assert!((fn3 / fn1 - pow(2.0, 0.4)).abs() < 1e-12);
        assert_eq!(f.forces_n(10e-6, 1e-4, 0.0), (10.0, 0.0));
        assert_eq!(f.forces_n(-1e-6, 1e-4, vs), (0.0, 0.0));
    }
}
