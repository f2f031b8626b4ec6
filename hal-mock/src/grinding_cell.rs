//! The simulated grinding cell (G ch. 3, 5.2): the piezo stage pushes the tool into a
//! workpiece of unknown shape while the hexapod feeds it along the surface and the
//! spindle turns it; the F/T sensor on the spindle mount measures the wrench.
//!
//! Each period takes the piezo command and the hexapod's feed command and returns
//! what the sensors read at the end of the period. The process (depth of cut, forces,
//! material removal) is [`crate::grinding`]'s.
//!
//! The wrench in the sensor frame (x along the feed, y the workpiece's normal pointing
//! away from the material, z the spindle axis): the normal force Fn pushes the tool
//! along the contact normal, the tangential force Ft acts along the tangent against
//! the tool's rotation, and the sensor, mounted Δ = (Δx, Δy) off the spindle axis,
//! sees the spindle moment Ft·r plus the moment of the force about its own centre, in
//! the convention of G eq. 2: Mz = Ft·r + Fx·Δy + Fy·Δx. Force noise (G 5.2: variance
//! 0.8 N², the measured force data's) is added to Fx and Fy, and to Mz scaled by the
//! tool radius (the same variance on the tangential force it implies).

use crate::grinding::{
    Engagement, GrindingForces, PiezoModel, PiezoStage, SinusoidalSurface, Workpiece,
};
use crate::noise::Noise;

/// Everything that makes a cell.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CellConfig {
    /// The piezo stage.
    pub piezo: PiezoModel,
    /// Forces of the cut and of the contact.
    pub forces: GrindingForces,
    /// The workpiece's surface before the pass.
    pub surface: SinusoidalSurface,
    /// Tool radius, m.
    pub tool_radius_m: f64,
    /// Spindle speed, rpm (0: stopped, the tool rolls on the surface and cuts nothing).
    pub spindle_rpm: f64,
    /// Where the tool's centre starts along the feed, m.
    pub start_x_m: f64,
    /// Height of the tool's lowest point at zero piezo extension, m (above the
    /// surface: the pass starts out of contact).
    pub retracted_bottom_m: f64,
    /// The hexapod's largest feed acceleration, m/s² (its velocity follows the
    /// command within this rate).
    pub hexapod_accel_m_s2: f64,
    /// Variance of the force noise, N².
    pub force_noise_n2: f64,
    /// Eccentricity of the F/T sensor from the spindle axis (Δx, Δy), m.
    pub sensor_offset_m: [f64; 2],
    /// Seed of the noise.
    pub seed: u64,
    /// A bias that drifts: each wrench component [Fx, Fy, Fz, Mx, My, Mz] gains this
    /// much per second (N/s, N·m/s) from `bias_drift_start_s` on (zero: no drift).
    pub bias_drift_per_s: [f64; 6],
    /// Time since the cell's start when the drift begins, s.
    pub bias_drift_start_s: f64,
}

impl CellConfig {
    /// The cell of G ch. 7 on the surface of G fig. 30: the identified piezo, a 4 mm
    /// CBN tool at 25,000 rpm on ST37, noise of 0.8 N², and a surface with 50 µm
    /// amplitude and 4 mm wavelength (the figure gives no values; this one asks the
    /// piezo for up to 8 µm/s at G's 0.1 mm/s feed). The tool starts 20 µm
    /// above the surface's crest. The sensor sits 3 mm and 2 mm off the spindle axis
    /// (of the order of a spindle clamp's offset; estimated by the firmware).
    pub const PUBLISHED: Self = Self {
        piezo: PiezoModel::IDENTIFIED,
        forces: GrindingForces::ST37_CBN_4MM,
        surface: SinusoidalSurface {
            offset_m: 0.0,
            amplitude_m: 50e-6,
            wavenumber_rad_m: core::f64::consts::TAU / 4e-3,
            phase_rad: 0.0,
        },
        tool_radius_m: 2e-3,
        spindle_rpm: 25_000.0,
        start_x_m: 3e-3,
        retracted_bottom_m: 70e-6,
        hexapod_accel_m_s2: 0.01,
        force_noise_n2: 0.8,
        sensor_offset_m: [3e-3, 2e-3],
        seed: 17,
        bias_drift_per_s: [0.0; 6],
        bias_drift_start_s: 0.0,
    };
}

/// What the cell's sensors read at the end of a period, and what only the simulation
/// knows.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CellReading {
    /// F/T wrench in the sensor frame [Fx, Fy, Fz, Mx, My, Mz], N and N·m, with noise
    /// (and the bias drift, if configured).
    pub wrench: [f64; 6],
    /// The piezo's extension (its strain gauge), m.
    pub piezo_position_m: f64,
    /// The hexapod's feed velocity, m/s.
    pub feed_m_s: f64,
    /// The tool centre's position along the feed, m.
    pub x_m: f64,
    /// The true local normal force (no noise), N.
    pub normal_force_n: f64,
    /// The true tangential force, N.
    pub tangential_force_n: f64,
    /// The contact of the period.
    pub engagement: Engagement,
}

/// The simulated cell over a workpiece sampled at `N` points.
#[derive(Clone, Debug)]
pub struct Cell<const N: usize> {
    config: CellConfig,
    piezo: PiezoStage,
    workpiece: Workpiece<N>,
    x_m: f64,
    feed_m_s: f64,
    noise: Noise,
    /// Periods stepped.
    periods: u64,
}

impl<const N: usize> Cell<N> {
    /// The cell at rest, piezo retracted, the workpiece sampled every `dx_m` from
    /// `x0_m`.
    pub fn new(config: &CellConfig, x0_m: f64, dx_m: f64) -> Self {
        Self {
            config: *config,
            piezo: PiezoStage::at_rest(config.piezo, 0.0),
            workpiece: Workpiece::new(&config.surface, x0_m, dx_m),
            x_m: config.start_x_m,
            feed_m_s: 0.0,
            noise: Noise::new(config.seed),
            periods: 0,
        }
    }

    /// The workpiece as it is now.
    pub fn workpiece(&self) -> &Workpiece<N> {
        &self.workpiece
    }

    /// One period: the piezo command (extension, m) and the hexapod's feed command
    /// (m/s) in, the sensors' readings out.
    pub fn step(&mut self, piezo_command_m: f64, feed_command_m_s: f64) -> CellReading {
        let c = &self.config;
        let ts = c.piezo.ts_s;
        let dv = c.hexapod_accel_m_s2 * ts;
        let command = if feed_command_m_s.is_finite() {
            feed_command_m_s
        } else {
            0.0
        };
        self.feed_m_s += (command - self.feed_m_s).clamp(-dv, dv);
        self.x_m += self.feed_m_s * ts;
        let piezo_m = self.piezo.step(if piezo_command_m.is_finite() {
            piezo_command_m
        } else {
            0.0
        });
        let bottom = c.retracted_bottom_m - piezo_m;
        let cutting = c.spindle_rpm > 0.0;
        let engagement = self
            .workpiece
            .engage(self.x_m, bottom, c.tool_radius_m, cutting);
        let surface_speed = c.forces.surface_speed_m_s(c.spindle_rpm);
        let (fn_n, ft_n) = c
            .forces
            .forces_n(engagement.depth_m, self.feed_m_s, surface_speed);
        // The normal from the contact to the tool centre, at the engagement's angle
        // from +y; the tangent against the rotation (down-cut: the tool's surface
        // moves along +x at the contact under the tool).
        let (s, co) = (
            libm::sin(engagement.normal_angle_rad),
            libm::cos(engagement.normal_angle_rad),
        );
        let normal = [s, co];
        let tangent = [-co, s];
        let sigma = libm::sqrt(c.force_noise_n2);
        let fx = fn_n * normal[0] + ft_n * tangent[0] + sigma * self.noise.normal();
        let fy = fn_n * normal[1] + ft_n * tangent[1] + sigma * self.noise.normal();
        let [dx, dy] = c.sensor_offset_m;
        let mz = ft_n * c.tool_radius_m
            + fx * dy
            + fy * dx
            + sigma * c.tool_radius_m * self.noise.normal();
        self.periods += 1;
        let drifted_s = (self.periods as f64 * ts - c.bias_drift_start_s).max(0.0);
        let mut wrench = [fx, fy, 0.0, 0.0, 0.0, mz];
        for (w, rate) in wrench.iter_mut().zip(c.bias_drift_per_s) {
            *w += rate * drifted_s;
        }
        CellReading {
            wrench,
            piezo_position_m: piezo_m,
            feed_m_s: self.feed_m_s,
            x_m: self.x_m,
            normal_force_n: fn_n,
            tangential_force_n: ft_n,
            engagement,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With the tool held at a fixed extension on G's surface, the wrench
    /// decomposes back into the model's forces by G eq. 2 and 4 (computed here from
    /// the wrench alone, no noise): the sensor model and the firmware's formula agree.
    #[test]
    fn wrench_decomposes_by_the_seeds_formulas() {
        let config = CellConfig {
            force_noise_n2: 0.0,
            ..CellConfig::PUBLISHED
        };
        let mut cell = Cell::<3000>::new(&config, 0.0, 5e-6);
        let mut last = None;
        for _ in 0..3000 {
            last = Some(cell.step(120e-6 / config.piezo.dc_gain(), 1e-4));
        }
        let r = last.unwrap();
        assert!(r.normal_force_n > 1.0, "{r:?}");
        let [fx, fy, _, _, _, mz] = r.wrench;
        let [dx, dy] = config.sensor_offset_m;
        let ft = (mz - fx * dy - fy * dx) / config.tool_radius_m;
        let fnorm = (fx * fx + fy * fy - ft * ft).sqrt();
        assert!((ft - r.tangential_force_n).abs() < 1e-9 * r.normal_force_n);
        assert!((fnorm - r.normal_force_n).abs() < 1e-9 * r.normal_force_n);
    }

    /// The hexapod's feed reaches its command at the set acceleration, and a NaN
    /// command stops it instead of moving it anywhere.
    #[test]
    fn feed_is_rate_limited_and_safe_on_nan() {
        let mut cell = Cell::<10>::new(&CellConfig::PUBLISHED, 0.0, 1e-3);
        let r = cell.step(0.0, 1e-4);
        assert!((r.feed_m_s - 1e-5).abs() < 1e-15);
        for _ in 0..20 {
            cell.step(0.0, 1e-4);
        }
        assert!((cell.step(0.0, 1e-4).feed_m_s - 1e-4).abs() < 1e-15);
        let mut v = 1e-4;
        for _ in 0..12 {
            v = cell.step(0.0, f64::NAN).feed_m_s;
        }
        assert_eq!(v, 0.0);
    }
}
