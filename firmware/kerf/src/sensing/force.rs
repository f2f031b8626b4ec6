//! Six-axis force/torque sensing and the local grinding forces (docs/equations.md §4;
//! G ch. 4 eq. 1–4, G 3.1.4, G app. D).
//!
//! - Calibration: wrench = CAL · (raw − bias), CAL the sensor's 6×6 matrix from gauge
//!   channels (V) to (Fx, Fy, Fz) in N and (Mx, My, Mz) in N·m ([`FtSensor`]).
//! - Bias: the mean of N raw samples taken at rest, refused when the calibrated
//!   readings spread more than the configured amount ([`BiasCapture`]).
//! - Local forces (G eq. 2 and 4): with the tool radius r and the sensor's eccentricity
//!   (Δx, Δy) from the spindle axis,
//!   Ft = (Mz − Fx Δy − Fy Δx)/r and Fn = √(Fx² + Fy² − Ft²) ([`ToolGeometry`]).
//!   (Δx, Δy) are taken with G's signs (fig. 27); under the right-hand rule
//!   M = x Fy − y Fx, the spindle axis sits at (Δx, −Δy) in the sensor's frame.
//!   Whatever the convention, the fit below estimates them in the same formula.
//! - Eccentricity (G ch. 4: "simple least squares parameter estimation", after its
//!   ref. 23): from samples with a known moment about the spindle axis M_s
//!   (zero when the spindle turns freely, as in G's contour tracking, G 7.3; or
//!   Ft·r for a known tangential load), eq. 2 gives the linear model
//!   Mz − M_s = Fy Δx + Fx Δy, fitted by least squares ([`EccentricityFit`]).
//! - Bias drift: window means of the compensated forces out of contact against a
//!   bound from the noise ([`BiasDriftWatch`]).

use crate::error::{coefficient, positive, ConfigError};
use crate::scalar::{lit, to_f64, Float};
use nalgebra::{Matrix6, Vector6};

/// What went wrong with a reading or a data set.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ForceError {
    /// A raw channel (0–5) or a fit input (0 Fx, 1 Fy, 2 Mz, 3 M_s) is NaN or ±∞.
    NotFinite {
        /// The channel.
        channel: u8,
    },
    /// A raw channel (0–5) is at or beyond the configured full scale.
    Saturated {
        /// The channel.
        channel: u8,
    },
    /// During bias capture, the wrench component (0–2 force, 3–5 moment) spread more
    /// than allowed: the sensor was not at rest.
    NotAtRest {
        /// The wrench component.
        component: u8,
    },
    /// Bias capture finished before its sample count.
    TooFewSamples,
    /// Ft² exceeds Fx² + Fy² beyond rounding (the radicand, N², is reported): the
    /// reading is inconsistent (wrong eccentricity, drifted bias, no contact).
    NegativeRadicand {
        /// Fx² + Fy² − Ft² in N².
        radicand_n2: f32,
    },
    /// The fit's force directions do not span the plane (too few samples, or all
    /// forces along one line): the eccentricity is not observable.
    Degenerate,
}

/// A force/torque sensor as fitted (SI units; raw channels in volts).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FtSensorConfig {
    /// Model and calibration, for logs.
    pub name: &'static str,
    /// CAL: rows Fx, Fy, Fz (N/V), Mx, My, Mz (N·m/V); columns the six gauge channels.
    pub calibration: [[f64; 6]; 6],
    /// |raw| at or beyond this (V) is treated as clipped.
    pub raw_full_scale_v: f64,
}

impl FtSensorConfig {
    /// G's sensor: an ATI Gamma (IP60) read through an NI PCI-6052E (G 3.1.4,
    /// table 6), with the calibration matrix of the hexapod GUI's initialization
    /// callback (G app. D, `CAL = [...]`, shown as fig. 67 in app. C), copied as
    /// printed. Its magnitudes (14–25 N/V on the force rows, 0.3–0.8 N·m/V on the
    /// moment rows) are those of a Gamma calibration read as ±10 V gauge signals.
    ///
    /// Full scale: the transducer electronics and the card's input range are ±10 V;
    /// readings within 0.5 % of it (9.95 V) are treated as clipped (the ADC's last
    /// codes and the amplifier's rail).
    pub const ATI_GAMMA_IP60: Self = Self {
        name: "ATI Gamma IP60 (G app. D calibration)",
        calibration: [
            [-0.02106, -0.00725, 0.22614, -13.82224, 0.08640, 13.98781],
            [-0.22758, 16.33921, 0.10624, -8.03676, -0.12379, -8.05002],
            [24.95057, -1.06034, 25.17707, -1.04570, 25.01689, -0.47779],
            [-0.00955, 0.30094, -0.72927, -0.11766, 0.72374, -0.16452],
            [0.84126, -0.03894, -0.42088, 0.27778, -0.42192, -0.25142],
            [0.00460, -0.43627, 0.00710, -0.42940, -0.00189, -0.43578],
        ],
        raw_full_scale_v: 9.95,
    };
}

/// Forces and moments at the sensor.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Wrench<T> {
    /// (Fx, Fy, Fz), N.
    pub force_n: [T; 3],
    /// (Mx, My, Mz), N·m.
    pub torque_n_m: [T; 3],
}

/// Raw readings at rest (subtracted before calibration), V.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FtBias<T> {
    /// Per-channel offset, V.
    pub raw_v: [T; 6],
}

/// Calibration in the scalar `T`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FtSensor<T: Float> {
    matrix: Matrix6<T>,
    full_scale: T,
}

impl<T: Float> FtSensor<T> {
    /// Validates the configuration: finite matrix entries, positive full scale.
    pub fn new(config: &FtSensorConfig) -> Result<Self, ConfigError> {
        let mut matrix = Matrix6::<T>::zeros();
        for (i, row) in config.calibration.iter().enumerate() {
            for (j, &v) in row.iter().enumerate() {
                if !v.is_finite() {
                    return Err(ConfigError::not_finite("calibration").indexed(i));
                }
                if let Some(m) = matrix.get_mut((i, j)) {
                    *m = crate::error::representable("calibration", v).map_err(|e| e.indexed(i))?;
                }
            }
        }
        let full_scale = positive("raw_full_scale_v", config.raw_full_scale_v)?;
        Ok(Self {
            matrix,
            full_scale: coefficient("raw_full_scale_v", full_scale)?,
        })
    }

    /// NaN/±∞ or clipped channels, lowest channel first.
    pub fn check_raw(&self, raw_v: &[T; 6]) -> Result<(), ForceError> {
        for (channel, &v) in (0u8..).zip(raw_v.iter()) {
            if !<T as crate::scalar::Real>::is_finite(v) {
                return Err(ForceError::NotFinite { channel });
            }
            if v >= self.full_scale || v <= -self.full_scale {
                return Err(ForceError::Saturated { channel });
            }
        }
        Ok(())
    }

    /// wrench = CAL · (raw − bias) (docs/equations.md §4), after [`FtSensor::check_raw`].
    pub fn wrench(&self, raw_v: &[T; 6], bias: &FtBias<T>) -> Result<Wrench<T>, ForceError> {
        self.check_raw(raw_v)?;
        let mut x = Vector6::<T>::zeros();
        for ((xi, &r), &b) in x.iter_mut().zip(raw_v).zip(&bias.raw_v) {
            *xi = r - b;
        }
        Ok(to_wrench(&(self.matrix * x)))
    }
}

fn to_wrench<T: Float>(w: &Vector6<T>) -> Wrench<T> {
    let mut out = Wrench {
        force_n: [T::ZERO; 3],
        torque_n_m: [T::ZERO; 3],
    };
    for (o, &v) in out
        .force_n
        .iter_mut()
        .chain(out.torque_n_m.iter_mut())
        .zip(w.iter())
    {
        *o = v;
    }
    out
}

/// How to capture the bias.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct BiasCaptureConfig {
    /// Samples averaged (≥ 1).
    pub samples: u32,
    /// Largest max − min of any force component over the capture, N.
    pub max_force_spread_n: f64,
    /// Largest max − min of any moment component over the capture, N·m.
    pub max_torque_spread_n_m: f64,
}

/// Bias capture at rest: push raw samples, then [`BiasCapture::finish`]. Sums in
/// `f64` (a thousand `f32` sums would lose 1e-4 of full scale); the spread is judged
/// on the calibrated wrench, in the units a user can reason about.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct BiasCapture<T> {
    samples: u32,
    count: u32,
    sum_v: [f64; 6],
    low: [T; 6],
    high: [T; 6],
    max_force_spread_n: T,
    max_torque_spread_n_m: T,
}

impl<T: Float> BiasCapture<T> {
    /// Validates the configuration (positive count and spreads).
    pub fn new(config: &BiasCaptureConfig) -> Result<Self, ConfigError> {
        if config.samples == 0 {
            return Err(ConfigError::not_positive("samples"));
        }
        let f = positive("max_force_spread_n", config.max_force_spread_n)?;
        let m = positive("max_torque_spread_n_m", config.max_torque_spread_n_m)?;
        Ok(Self {
            samples: config.samples,
            count: 0,
            sum_v: [0.0; 6],
            low: [T::ZERO; 6],
            high: [T::ZERO; 6],
            max_force_spread_n: coefficient("max_force_spread_n", f)?,
            max_torque_spread_n_m: coefficient("max_torque_spread_n_m", m)?,
        })
    }

    /// Adds one raw sample (checked like a reading). Samples beyond the count are
    /// ignored.
    pub fn push(&mut self, sensor: &FtSensor<T>, raw_v: &[T; 6]) -> Result<(), ForceError> {
        sensor.check_raw(raw_v)?;
        if self.count >= self.samples {
            return Ok(());
        }
        let zero = FtBias {
            raw_v: [T::ZERO; 6],
        };
        let w = sensor.wrench(raw_v, &zero)?;
        let components = w.force_n.iter().chain(w.torque_n_m.iter());
        for ((&c, lo), hi) in components.zip(&mut self.low).zip(&mut self.high) {
            if self.count == 0 || c < *lo {
                *lo = c;
            }
            if self.count == 0 || c > *hi {
                *hi = c;
            }
        }
        for (s, &r) in self.sum_v.iter_mut().zip(raw_v) {
            *s += to_f64(r);
        }
        self.count += 1;
        Ok(())
    }

    /// Whether the sample count is reached.
    pub fn is_complete(&self) -> bool {
        self.count >= self.samples
    }

    /// The mean of the samples, if enough were pushed and the sensor was at rest.
    pub fn finish(&self) -> Result<FtBias<T>, ForceError> {
        if !self.is_complete() {
            return Err(ForceError::TooFewSamples);
        }
        for (component, (&lo, &hi)) in (0u8..).zip(self.low.iter().zip(&self.high)) {
            let limit = if component < 3 {
                self.max_force_spread_n
            } else {
                self.max_torque_spread_n_m
            };
            if hi - lo > limit {
                return Err(ForceError::NotAtRest { component });
            }
        }
        let n = f64::from(self.count);
        let mut raw_v = [T::ZERO; 6];
        for (b, &s) in raw_v.iter_mut().zip(&self.sum_v) {
            *b = lit(s / n);
        }
        Ok(FtBias { raw_v })
    }
}

/// Sensor eccentricity from the spindle axis, in G's signs (module docs), m.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Eccentricity {
    /// Δx, m.
    pub dx_m: f64,
    /// Δy, m.
    pub dy_m: f64,
}

/// Tool and mounting in SI units.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ToolConfig {
    /// Tool radius r, m (G's CBN tool: 4 mm diameter, G 7.1).
    pub tool_radius_m: f64,
    /// Sensor eccentricity, m (measure it with [`EccentricityFit`]).
    pub eccentricity: Eccentricity,
    /// Standard deviation of the force noise the readings carry, N (0 for exact
    /// data). Out of contact Fx, Fy and Ft are noise alone, and Ft² exceeds
    /// Fx² + Fy² about half the time; a radicand within (7σ)² below zero is that
    /// noise and clamps to Fn = 0, not a fault (Ft beyond 7σ: 2.6·10⁻¹² of readings,
    /// once in 12 years at 1 kHz; at 4σ a pass of a minute would fault).
    pub noise_n: f64,
}

/// Local tangential and normal grinding forces.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct LocalForces<T> {
    /// Ft, N (sign of the moment about the spindle axis).
    pub tangential_n: T,
    /// Fn ≥ 0, N.
    pub normal_n: T,
}

/// G eq. 2 and 4 in the scalar `T`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ToolGeometry<T> {
    inv_radius: T,
    dx: T,
    dy: T,
    /// 16 ε of `T`: the radicand's rounding allowance (see [`ToolGeometry::local`]).
    rounding: T,
    /// (7σ)² of the readings' noise, N².
    noise_sq: T,
}

impl<T: Float> ToolGeometry<T> {
    /// Validates the radius (positive) and eccentricity (finite, below 1 m).
    pub fn new(config: &ToolConfig) -> Result<Self, ConfigError> {
        let r = positive("tool_radius_m", config.tool_radius_m)?;
        let e = config.eccentricity;
        let dx = crate::error::in_range("dx_m", e.dx_m, -1.0, 1.0)
            .map_err(|x| x.within("eccentricity"))?;
        let dy = crate::error::in_range("dy_m", e.dy_m, -1.0, 1.0)
            .map_err(|x| x.within("eccentricity"))?;
        Ok(Self {
            inv_radius: coefficient("tool_radius_m", 1.0 / r)?,
            dx: crate::error::representable("dx_m", dx).map_err(|x| x.within("eccentricity"))?,
            dy: crate::error::representable("dy_m", dy).map_err(|x| x.within("eccentricity"))?,
            rounding: lit::<T>(16.0) * T::default_epsilon(),
            noise_sq: crate::error::coefficient_or_zero("noise_n", {
                let noise = crate::error::in_range("noise_n", config.noise_n, 0.0, 1e3)?;
                49.0 * noise * noise
            })?,
        })
    }

    /// Ft = (Mz − Fx Δy − Fy Δx)/r (G eq. 2), Fn = √(Fx² + Fy² − Ft²) (G eq. 4).
    ///
    /// The radicand is computed from exact inputs with a bounded rounding error. With
    /// u = ε/2 the unit roundoff and S = (|Mz| + |Fx Δy| + |Fy Δx|)/r ≥ |Ft|, the
    /// computed Ft is off by at most about 4u·S, so Ft² by 8u·S² (plus its own
    /// rounding); Fx² + Fy² carries 3u(Fx² + Fy²) and the subtraction u of the larger
    /// side: in all below 10u (Fx² + Fy² + S²). A radicand above −16ε(Fx² + Fy² + S²)
    /// (= −32u·…, three times that bound) is rounding, and so is one within the
    /// readings' noise, (7σ)² ([`ToolConfig::noise_n`]): both clamp to Fn = 0; below
    /// that it is [`ForceError::NegativeRadicand`]. NaN in any input is
    /// [`ForceError::NotFinite`].
    pub fn local(&self, wrench: &Wrench<T>) -> Result<LocalForces<T>, ForceError> {
        let [fx, fy, _] = wrench.force_n;
        let mz = wrench.torque_n_m[2];
        for (channel, v) in [(0u8, fx), (1, fy), (2, mz)] {
            if !<T as crate::scalar::Real>::is_finite(v) {
                return Err(ForceError::NotFinite { channel });
            }
        }
        let ft = (mz - fx * self.dy - fy * self.dx) * self.inv_radius; // G eq. 2
        let planar = fx * fx + fy * fy;
        let radicand = planar - ft * ft; // G eq. 4
        if radicand >= T::ZERO {
            return Ok(LocalForces {
                tangential_n: ft,
                normal_n: radicand.fsqrt(),
            });
        }
        let s = (mz.abs() + (fx * self.dy).abs() + (fy * self.dx).abs()) * self.inv_radius;
        if radicand >= -(self.rounding * (planar + s * s) + self.noise_sq) {
            Ok(LocalForces {
                tangential_n: ft,
                normal_n: T::ZERO,
            })
        } else {
            Err(ForceError::NegativeRadicand {
                radicand_n2: to_f64(radicand) as f32,
            })
        }
    }
}

/// Least-squares eccentricity from samples (module docs): rows [Fy Fx] · [Δx Δy]ᵀ =
/// Mz − M_s, accumulated as the 2×2 normal equations in `f64` (fixed memory, any
/// number of samples).
#[derive(Copy, Clone, Debug, PartialEq, Default)]
pub struct EccentricityFit {
    count: u32,
    syy: f64,
    sxy: f64,
    sxx: f64,
    sy_m: f64,
    sx_m: f64,
}

impl EccentricityFit {
    /// Empty data set.
    pub fn new() -> Self {
        Self::default()
    }

    /// One sample: sensor forces Fx, Fy (N), sensor moment Mz (N·m), and the known
    /// moment about the spindle axis M_s (N·m; 0 with a free spindle, Ft·r with a
    /// known tangential load).
    pub fn push(
        &mut self,
        fx_n: f64,
        fy_n: f64,
        mz_n_m: f64,
        spindle_moment_n_m: f64,
    ) -> Result<(), ForceError> {
        for (channel, v) in [(0u8, fx_n), (1, fy_n), (2, mz_n_m), (3, spindle_moment_n_m)] {
            if !v.is_finite() {
                return Err(ForceError::NotFinite { channel });
            }
        }
        let m = mz_n_m - spindle_moment_n_m;
        self.count = self.count.saturating_add(1);
        self.syy += fy_n * fy_n;
        self.sxy += fx_n * fy_n;
        self.sxx += fx_n * fx_n;
        self.sy_m += fy_n * m;
        self.sx_m += fx_n * m;
        Ok(())
    }

    /// Solves [Σ Fy², Σ FxFy; Σ FxFy, Σ Fx²] [Δx Δy]ᵀ = [Σ Fy m; Σ Fx m] by Cramer's
    /// rule. [`ForceError::Degenerate`] below two samples or when the matrix's
    /// det/trace² (≈ its smallest over largest eigenvalue) is below 1e-9: the forces
    /// then lie on one line to within 3e-5 rad and one component of the eccentricity
    /// is unobservable (its noise gain 1/√λmin would be 3e4 times the other's).
    pub fn solve(&self) -> Result<Eccentricity, ForceError> {
        let det = self.syy * self.sxx - self.sxy * self.sxy;
        let trace = self.syy + self.sxx;
        if self.count < 2 || det.is_nan() || det <= 1e-9 * trace * trace {
            return Err(ForceError::Degenerate);
        }
        Ok(Eccentricity {
            dx_m: (self.sxx * self.sy_m - self.sxy * self.sx_m) / det,
            dy_m: (self.syy * self.sx_m - self.sxy * self.sy_m) / det,
        })
    }
}

mod drift;
pub use drift::{BiasDrift, BiasDriftConfig, BiasDriftWatch};

#[cfg(test)]
mod tests;
