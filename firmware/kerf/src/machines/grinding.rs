//! The robotic grinding cell as a machine (G ch. 3–8): a piezo stage regulates the
//! normal grinding force while the hexapod keeps the local feed along the surface and
//! the spindle turns the tool.
//!
//! Each period: the F/T sensor's six gauge voltages are checked (NaN, clipped) and
//! calibrated into a wrench with the bias captured at rest (`sensing::force`); the
//! local normal and tangential forces follow from the wrench with the sensor's
//! eccentricity (G eq. 2–4); the hybrid loop (`control::hybrid_force`) turns the
//! normal-force error into the piezo command through the job's law (PID or ADRC,
//! G 4.1–4.2) and the hexapod feed V_hex = √(F_R² − V_pzo²) (G eq. 11). A normal force
//! above the cell's limit (a crash into the workpiece), a reading that fails its
//! checks, or a law that stops producing finite commands faults the machine: the
//! outputs go safe in the same period.
//!
//! Safe outputs: the piezo at the retracted end of its travel (away from the surface;
//! the stage's own controller moves it there at its speed), the hexapod feed zero, the
//! spindle off.
//!
//! Calibration: the bias capture at rest. The sweep holds the piezo retracted (out of
//! contact) and averages the gauge voltages until the capture is complete; a spread
//! beyond the configured one (the sensor was not at rest) faults. The calibration
//! command then installs the sensor's eccentricity (measured by
//! [`crate::sensing::force::EccentricityFit`] from recorded data, or a stored value).
//!
//! A job is one pass: the law, the normal force, the feed and the length along the
//! surface; it ends when the hexapod has fed that far, and a stop retracts the piezo at
//! its rate limit with the feed at zero.
//!
//! Devices: the hexapod and the spindle are driven by the slower task through
//! [`devices::DeviceLink`]; a fault it finds reaches the control period in
//! [`GrindingInputs::device_fault`] and faults the cell in that period, in any mode.
//!
//! Bias drift: at rest (Idle, Ready, or waiting for the calibration's fit: the piezo
//! retracted, the tool off the surface) for longer than the watch's settling time,
//! the bias-compensated forces feed a [`BiasDriftWatch`]; a window mean beyond its
//! bound faults the cell with [`GrindingFault::BiasDrift`]. The cell does not
//! recapture the bias by itself: at rest a drifted reading looks the same as a tool
//! resting on something or a loosened sensor mount, which a new bias would hide; the
//! operator's `Calibrate` (after `ResetFault`) is the recapture, one command away.
//! Between periods of contact the watch starts a new window, so only readings at rest
//! are ever averaged; a drift during a pass shows at the first rest after it.

use crate::app::supervisor::NoSweep;
use crate::app::supervisor::{
    first_non_finite_index, FiniteOutputs, Machine, NonFiniteOutput, Step,
};
use crate::control::adrc::{Adrc, AdrcConfig, AdrcState};
use crate::control::hybrid_force::{
    HybridFault, HybridForce, HybridForceConfig, HybridForceError, HybridForceState, HybridOutput,
};
use crate::control::pid::{Pid, PidConfig, PidState};
use crate::error::{coefficient, positive, ConfigContext, ConfigError};
use crate::scalar::{lit, Float, Real};
use crate::sensing::force::{
    BiasCapture, BiasCaptureConfig, BiasDrift, BiasDriftConfig, BiasDriftWatch, Eccentricity,
    ForceError, FtBias, FtSensor, FtSensorConfig, LocalForces, ToolConfig, ToolGeometry,
};

pub mod devices;
pub mod link;
pub mod product;
pub use devices::{DeviceFault, HexapodFault, SpindleFault};

#[cfg(test)]
mod tests;

/// Everything the cell needs, in SI units.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct GrindingConfig {
    /// Control period, s (G's 1 ms).
    pub period_s: f64,
    /// The F/T sensor.
    pub sensor: FtSensorConfig,
    /// The tool and the sensor's eccentricity until a calibration replaces it.
    pub tool: ToolConfig,
    /// Bias capture at rest.
    pub bias: BiasCaptureConfig,
    /// The watch for a drifting bias at rest (its bound follows `tool.noise_n` and
    /// `bias.samples`).
    pub bias_drift: BiasDriftConfig,
    /// The piezo stage and the feed's default (a job sets its own feed).
    pub hybrid: HybridForceConfig,
    /// The PID law's gains.
    pub pid: PidConfig,
    /// The ADRC law's gains.
    pub adrc: AdrcConfig,
    /// Largest normal force before a fault, N.
    pub force_limit_n: f64,
    /// Largest normal force a job may ask, N.
    pub max_reference_n: f64,
}

impl GrindingConfig {
    /// G's cell (G 3, 7): 1 ms, the ATI Gamma with its printed calibration, the
    /// 4 mm CBN tool (no eccentricity until one is measured), a 500-sample bias capture
    /// (0.5 s; at rest the spread is the sensor's noise: 500 samples of G's
    /// 0.8 N² span about 6σ ≈ 5.4 N, so 8 N and 0.05 N·m are allowed), the drift watch
    /// of [`BiasDriftConfig::PUBLISHED`] (a bound of 0.294 N on 1 s means), the P-602 stage
    /// and 0.1 mm/s feed, G's PID and ADRC gains. A normal force above 40 N (four times
    /// G's largest reference) is a crash; a job may ask up to 20 N.
    pub const PUBLISHED: Self = Self {
        period_s: 1e-3,
        sensor: FtSensorConfig::ATI_GAMMA_IP60,
        tool: ToolConfig {
            tool_radius_m: 2e-3,
            eccentricity: Eccentricity {
                dx_m: 0.0,
                dy_m: 0.0,
            },
            // The measured force noise, 0.8 N² (G 5.2).
            noise_n: 0.894,
        },
        bias: BiasCaptureConfig {
            samples: 500,
            max_force_spread_n: 8.0,
            max_torque_spread_n_m: 0.05,
        },
        bias_drift: BiasDriftConfig::PUBLISHED,
        hybrid: HybridForceConfig::GRINDING_SEED,
        pid: PidConfig::GRINDING_SEED,
        adrc: AdrcConfig::GRINDING_SEED,
        force_limit_n: 40.0,
        max_reference_n: 20.0,
    };
}

impl GrindingConfig {
    /// [`GrindingConfig::PUBLISHED`] with both laws tuned on the simulated cell (host test
    /// `grinding_tuning`: Nelder–Mead on the RMS of the normal force's error over the
    /// experiments' 80 s pass at 7.5 N), in 1 nm per unit of law output: PID Kp 8.42,
    /// Ki 0.100/s, Kd 0.00140 s (0.65 N RMS on the cell, against 5.6 N for G's
    /// gains); ADRC Kp 0.111, Kd 0.122, b0 1.42·10⁶, observer bandwidth 183 rad/s
    /// (6.0 N RMS: the best the search found; G's ADRC gains crash the tool).
    pub const TUNED: Self = Self {
        hybrid: HybridForceConfig {
            increment_unit_m: 1e-9,
            ..HybridForceConfig::GRINDING_SEED
        },
        pid: PidConfig {
            kp: 8.42,
            ki_per_s: 0.100,
            kd_s: 0.00140,
            ..PidConfig::GRINDING_SEED
        },
        adrc: AdrcConfig {
            kp: 0.111,
            kd: 0.122,
            b0: 1.42e6,
            eso_bandwidth_rad_s: 183.0,
            ..AdrcConfig::GRINDING_SEED
        },
        ..Self::PUBLISHED
    };
}

/// The force law of a pass.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ForceLawKind {
    /// PID (G 4.1).
    #[default]
    Pid,
    /// ADRC (G 4.2).
    Adrc,
}

/// One grinding pass.
#[derive(Copy, Clone, Debug, PartialEq, Default)]
pub struct GrindingJob {
    /// The law.
    pub law: ForceLawKind,
    /// Normal force reference Fn,ref, N.
    pub normal_force_n: f64,
    /// Local feed F_R along the surface, m/s.
    pub feed_m_s: f64,
    /// Length of the pass along the feed, m.
    pub length_m: f64,
    /// Spindle speed, rpm (0: the tool rolls on the surface, G 7.3's contour tracking).
    pub spindle_rpm: f64,
}

/// Why a job does not fit.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GrindingJobError {
    /// No bias captured yet: run the calibration first.
    NotCalibrated,
    /// A field is NaN, not positive, or out of the cell's range: which one.
    Field(&'static str),
}

/// Why the cell stopped.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GrindingFault {
    /// The F/T reading failed its checks (NaN, clipped, not at rest during the bias
    /// capture, inconsistent forces).
    Sensor(ForceError),
    /// The normal force exceeded the cell's limit.
    ForceLimit,
    /// The force loop could not produce a finite command.
    Loop(HybridForceError),
    /// The hexapod's link reported a fault ([`devices`]).
    Hexapod(HexapodFault),
    /// The spindle's link reported a fault ([`devices`]).
    Spindle(SpindleFault),
    /// At rest, the compensated forces' mean left the noise bound: the sensor's bias
    /// moved since its capture.
    BiasDrift(BiasDrift),
    /// An output was NaN or infinite: the piezo 0, the hexapod feed 1, the spindle 2.
    Output(NonFiniteOutput),
}

impl From<DeviceFault> for GrindingFault {
    fn from(fault: DeviceFault) -> Self {
        match fault {
            DeviceFault::Hexapod(f) => Self::Hexapod(f),
            DeviceFault::Spindle(f) => Self::Spindle(f),
        }
    }
}

/// One period's inputs, sampled together.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct GrindingInputs<T> {
    /// The F/T sensor's six gauge voltages, V.
    pub ft_raw_v: [T; 6],
    /// The device link's latched fault as the slower task last reported it (None:
    /// the devices answer as commanded).
    pub device_fault: Option<DeviceFault>,
}

/// One period's outputs, written together.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct GrindingOutputs<T> {
    /// Piezo position command, m (0: retracted).
    pub piezo_m: T,
    /// Hexapod feed along the surface, m/s.
    pub hexapod_feed_m_s: T,
    /// Spindle speed, rpm.
    pub spindle_rpm: T,
}

/// What the cell reports each period.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct GrindingTelemetry<T> {
    /// The local forces of the period (zero while safe).
    pub forces: LocalForces<T>,
    /// The normal force reference, N (zero while safe).
    pub reference_n: T,
    /// The outputs.
    pub outputs: GrindingOutputs<T>,
    /// Piezo velocity V_pzo, m/s.
    pub piezo_velocity_m_s: T,
    /// The piezo alone exceeded the feed (V_hex = 0).
    pub feed_exceeded: bool,
    /// Distance fed along the pass, m.
    pub fed_m: T,
}

/// The laws' coefficients, replaced together (bumplessly: the states stay).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct GrindingLaws<T> {
    /// PID.
    pub pid: Pid<T>,
    /// ADRC.
    pub adrc: Adrc<T>,
}

impl<T: Float + crate::control::adrc::FalPower> GrindingLaws<T> {
    /// The laws of `config` in `T`.
    pub fn new(config: &GrindingConfig) -> Result<Self, ConfigError> {
        Ok(Self {
            pid: Pid::new(&config.pid, config.period_s).within("pid")?,
            adrc: Adrc::new(&config.adrc, config.period_s).within("adrc")?,
        })
    }
}

/// The calibration command's payload: the sensor's eccentricity.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct GrindingCalibration {
    /// As measured by the eccentricity fit.
    pub eccentricity: Eccentricity,
}

/// The loop of the running pass, with the law it was started with.
#[derive(Copy, Clone, Debug, PartialEq)]
enum PassLoop<T: Float> {
    Pid(HybridForce<T, Pid<T>>, HybridForceState<PidState<T>, T>),
    Adrc(HybridForce<T, Adrc<T>>, HybridForceState<AdrcState<T>, T>),
}

/// The grinding cell.
#[derive(Clone, Debug)]
pub struct GrindingCell<T: Float + crate::control::adrc::FalPower> {
    config: GrindingConfig,
    sensor: FtSensor<T>,
    tool: ToolGeometry<T>,
    laws: GrindingLaws<T>,
    capture: BiasCapture<T>,
    bias: Option<FtBias<T>>,
    drift: Option<BiasDriftWatch>,
    /// Periods at rest since the last contact (saturating at the settling time).
    rest_periods: u32,
    settle_periods: u32,
    pass: Option<PassLoop<T>>,
    /// The running pass's loop configuration (to rebuild it on new coefficients).
    pass_hybrid: HybridForceConfig,
    /// The pass has not run a period yet.
    fresh: bool,
    reference_n: T,
    spindle_rpm: T,
    length_m: T,
    fed_m: T,
    ts: T,
    force_limit: T,
    telemetry: GrindingTelemetry<T>,
}

impl<T: Float + crate::control::adrc::FalPower> GrindingCell<T> {
    /// A cell, uncalibrated, piezo retracted.
    pub fn new(config: &GrindingConfig) -> Result<Self, ConfigError> {
        positive("period_s", config.period_s)?;
        let laws = GrindingLaws::new(config)?;
        // The loop's own checks (travel, rate, unit) once, with the default feed.
        HybridForce::new(laws.pid, &config.hybrid, config.period_s).within("hybrid")?;
        let zero = T::zero();
        let drift =
            BiasDriftWatch::new(&config.bias_drift, config.tool.noise_n, config.bias.samples)
                .within("bias_drift")?;
        let settle = positive("settle_s", config.bias_drift.settle_s).within("bias_drift")?;
        Ok(Self {
            config: *config,
            sensor: FtSensor::new(&config.sensor).within("sensor")?,
            tool: ToolGeometry::new(&config.tool).within("tool")?,
            laws,
            capture: BiasCapture::new(&config.bias).within("bias")?,
            bias: None,
            drift,
            rest_periods: 0,
            settle_periods: libm::ceil(settle / config.period_s).min(f64::from(u32::MAX)) as u32,
            pass: None,
            pass_hybrid: config.hybrid,
            fresh: false,
            reference_n: zero,
            spindle_rpm: zero,
            length_m: zero,
            fed_m: zero,
            ts: coefficient("period_s", config.period_s)?,
            force_limit: coefficient(
                "force_limit_n",
                positive("force_limit_n", config.force_limit_n)?,
            )?,
            telemetry: GrindingTelemetry {
                forces: LocalForces {
                    tangential_n: zero,
                    normal_n: zero,
                },
                reference_n: zero,
                outputs: GrindingOutputs {
                    piezo_m: lit(config.hybrid.piezo_min_m),
                    hexapod_feed_m_s: zero,
                    spindle_rpm: zero,
                },
                piezo_velocity_m_s: zero,
                feed_exceeded: false,
                fed_m: zero,
            },
        })
    }

    /// The bias in use, if captured.
    pub fn bias(&self) -> Option<&FtBias<T>> {
        self.bias.as_ref()
    }

    /// A fault the device link reported.
    fn devices(inputs: &GrindingInputs<T>) -> Result<(), GrindingFault> {
        inputs.device_fault.map_or(Ok(()), |f| Err(f.into()))
    }

    /// Not at rest this period: the next rest starts a new settling time and window.
    fn leave_rest(&mut self) {
        self.rest_periods = 0;
        if let Some(watch) = self.drift.as_mut() {
            watch.restart();
        }
    }

    /// Local forces from a reading (checks, calibration, eq. 2–4), and the crash limit.
    fn forces(&self, inputs: &GrindingInputs<T>) -> Result<LocalForces<T>, GrindingFault> {
        let bias = self.bias.unwrap_or(FtBias {
            raw_v: [T::zero(); 6],
        });
        let wrench = self
            .sensor
            .wrench(&inputs.ft_raw_v, &bias)
            .map_err(GrindingFault::Sensor)?;
        let local = self.tool.local(&wrench).map_err(GrindingFault::Sensor)?;
        if local.normal_n > self.force_limit {
            return Err(GrindingFault::ForceLimit);
        }
        Ok(local)
    }

    fn outputs(&self, out: &HybridOutput<T>) -> GrindingOutputs<T> {
        GrindingOutputs {
            piezo_m: out.piezo_m,
            hexapod_feed_m_s: out.hexapod_feed_m_s,
            spindle_rpm: self.spindle_rpm,
        }
    }

    fn record(&mut self, forces: LocalForces<T>, out: &HybridOutput<T>) {
        self.telemetry = GrindingTelemetry {
            forces,
            reference_n: self.reference_n,
            outputs: self.outputs(out),
            piezo_velocity_m_s: out.piezo_velocity_m_s,
            feed_exceeded: out.feed_exceeded,
            fed_m: self.fed_m,
        };
    }

    /// One step of the pass's loop; the fault carries the loop's safe output. The
    /// first period starts the law from the present measurement (no derivative kick:
    /// the PID's last error is this one, the ADRC's tracked reference and observer
    /// start at the measured force).
    fn step_loop(&mut self, measured_n: T) -> Result<HybridOutput<T>, HybridFault<T>> {
        let reference = self.reference_n;
        if self.fresh && <T as crate::scalar::Real>::is_finite(measured_n) {
            match self.pass.as_mut() {
                Some(PassLoop::Pid(_, s)) => s.law.error = reference - measured_n,
                Some(PassLoop::Adrc(_, s)) => s.law = AdrcState::at(measured_n, T::zero()),
                None => {}
            }
        }
        self.fresh = false;
        match self.pass.as_mut() {
            Some(PassLoop::Pid(l, s)) => l.step(s, reference, measured_n),
            Some(PassLoop::Adrc(l, s)) => l.step(s, reference, measured_n),
            None => Err(HybridFault {
                error: HybridForceError::CommandNotFinite,
                output: self.retract_output(),
            }),
        }
    }

    fn retract_output(&self) -> HybridOutput<T> {
        HybridOutput {
            piezo_m: lit(self.config.hybrid.piezo_min_m),
            piezo_velocity_m_s: T::zero(),
            hexapod_feed_m_s: T::zero(),
            feed_exceeded: false,
            saturated: false,
            rate_limited: false,
        }
    }
}

fn check_job(config: &GrindingConfig, job: &GrindingJob) -> Result<(), GrindingJobError> {
    let field = GrindingJobError::Field;
    let within = |v: f64, hi: f64| v.is_finite() && v > 0.0 && v <= hi;
    if !within(job.normal_force_n, config.max_reference_n) {
        return Err(field("normal_force_n"));
    }
    if !within(job.feed_m_s, 1.0) {
        return Err(field("feed_m_s"));
    }
    if !within(job.length_m, 10.0) {
        return Err(field("length_m"));
    }
    if !(job.spindle_rpm.is_finite() && (0.0..=100_000.0).contains(&job.spindle_rpm)) {
        return Err(field("spindle_rpm"));
    }
    Ok(())
}

impl<T: Float + crate::control::adrc::FalPower> Machine for GrindingCell<T> {
    type Inputs = GrindingInputs<T>;
    type Outputs = GrindingOutputs<T>;
    type Job = GrindingJob;
    type JobError = GrindingJobError;
    type Coefficients = GrindingLaws<T>;
    type SweepSample = NoSweep;
    type Calibration = GrindingCalibration;
    type Fault = GrindingFault;
    type Telemetry = GrindingTelemetry<T>;

    /// Piezo retracted, feed zero, spindle off.
    fn safe_outputs(&self) -> GrindingOutputs<T> {
        GrindingOutputs {
            piezo_m: lit(self.config.hybrid.piezo_min_m),
            hexapod_feed_m_s: T::zero(),
            spindle_rpm: T::zero(),
        }
    }

    /// Checks the reading and the devices; at rest after the settling time, watches
    /// the compensated forces for a drifting bias.
    fn monitor(&mut self, inputs: &GrindingInputs<T>) -> Result<(), GrindingFault> {
        Self::devices(inputs)?;
        self.sensor
            .check_raw(&inputs.ft_raw_v)
            .map_err(GrindingFault::Sensor)?;
        let (Some(bias), Some(watch)) = (self.bias.as_ref(), self.drift.as_mut()) else {
            return Ok(());
        };
        if self.rest_periods < self.settle_periods {
            self.rest_periods += 1;
            return Ok(());
        }
        let wrench = self
            .sensor
            .wrench(&inputs.ft_raw_v, bias)
            .map_err(GrindingFault::Sensor)?;
        watch.push(&wrench).map_err(GrindingFault::BiasDrift)
    }

    fn begin_calibration(&mut self) {
        // The configuration was checked in `new`, so this cannot fail.
        if let Ok(capture) = BiasCapture::new(&self.config.bias) {
            self.capture = capture;
        }
    }

    fn calibrate(
        &mut self,
        inputs: &GrindingInputs<T>,
        _record: &mut dyn FnMut(NoSweep),
    ) -> Result<Step<GrindingOutputs<T>>, GrindingFault> {
        Self::devices(inputs)?;
        self.leave_rest();
        self.capture
            .push(&self.sensor, &inputs.ft_raw_v)
            .map_err(GrindingFault::Sensor)?;
        if !self.capture.is_complete() {
            return Ok(Step::Continue(self.safe_outputs()));
        }
        self.bias = Some(self.capture.finish().map_err(GrindingFault::Sensor)?);
        Ok(Step::Done(self.safe_outputs()))
    }

    fn finish_calibration(&mut self, calibration: &GrindingCalibration) {
        let tool = ToolConfig {
            eccentricity: calibration.eccentricity,
            ..self.config.tool
        };
        // A bad eccentricity (NaN) keeps the one in use.
        if let Ok(geometry) = ToolGeometry::new(&tool) {
            self.tool = geometry;
            self.config.tool = tool;
        }
    }

    fn check_job(&self, job: &GrindingJob) -> Result<(), GrindingJobError> {
        check_job(&self.config, job)
    }

    fn begin_job(&mut self, job: &GrindingJob) -> Result<(), GrindingJobError> {
        check_job(&self.config, job)?;
        if self.bias.is_none() {
            return Err(GrindingJobError::NotCalibrated);
        }
        let hybrid = HybridForceConfig {
            feed_m_s: job.feed_m_s,
            ..self.config.hybrid
        };
        let ts = self.config.period_s;
        let retracted: T = lit(self.config.hybrid.piezo_min_m);
        let field = GrindingJobError::Field("feed_m_s");
        self.pass = Some(match job.law {
            ForceLawKind::Pid => PassLoop::Pid(
                HybridForce::new(self.laws.pid, &hybrid, ts).map_err(|_| field)?,
                HybridForceState {
                    law: PidState::at(T::zero()),
                    piezo_m: retracted,
                },
            ),
            ForceLawKind::Adrc => PassLoop::Adrc(
                HybridForce::new(self.laws.adrc, &hybrid, ts).map_err(|_| field)?,
                HybridForceState {
                    law: AdrcState::at(T::zero(), T::zero()),
                    piezo_m: retracted,
                },
            ),
        });
        self.pass_hybrid = hybrid;
        self.fresh = true;
        self.reference_n = lit(job.normal_force_n);
        self.spindle_rpm = lit(job.spindle_rpm);
        self.length_m = lit(job.length_m);
        self.fed_m = T::zero();
        Ok(())
    }

    fn run(
        &mut self,
        _job: &GrindingJob,
        inputs: &GrindingInputs<T>,
    ) -> Result<Step<GrindingOutputs<T>>, GrindingFault> {
        Self::devices(inputs)?;
        self.leave_rest();
        let forces = self.forces(inputs)?;
        let out = self
            .step_loop(forces.normal_n)
            .map_err(|fault| GrindingFault::Loop(fault.error))?;
        self.fed_m += out.hexapod_feed_m_s * self.ts;
        self.record(forces, &out);
        let outputs = self.outputs(&out);
        Ok(if self.fed_m >= self.length_m {
            self.pass = None;
            Step::Done(outputs)
        } else {
            Step::Continue(outputs)
        })
    }

    fn begin_stop(&mut self) {}

    /// Retracts the piezo at its rate limit with the feed at zero; done at the end of
    /// the travel.
    fn stop(
        &mut self,
        _job: &Self::Job,
        inputs: &GrindingInputs<T>,
    ) -> Result<Step<GrindingOutputs<T>>, GrindingFault> {
        Self::devices(inputs)?;
        self.leave_rest();
        let forces = self.forces(inputs)?;
        let out = match self.pass.as_mut() {
            Some(PassLoop::Pid(l, s)) => l.retract(s),
            Some(PassLoop::Adrc(l, s)) => l.retract(s),
            None => self.retract_output(),
        };
        let out = HybridOutput {
            hexapod_feed_m_s: T::zero(),
            ..out
        };
        self.spindle_rpm = T::zero();
        self.record(forces, &out);
        let retracted: T = lit(self.config.hybrid.piezo_min_m);
        Ok(if out.piezo_m <= retracted {
            self.pass = None;
            Step::Done(self.outputs(&out))
        } else {
            Step::Continue(self.outputs(&out))
        })
    }

    /// New gains; a running pass continues with them from its present state.
    fn set_coefficients(&mut self, laws: &GrindingLaws<T>) {
        self.laws = *laws;
        let (hybrid, ts) = (self.pass_hybrid, self.config.period_s);
        match self.pass.as_mut() {
            Some(PassLoop::Pid(l, _)) => {
                if let Ok(new) = HybridForce::new(laws.pid, &hybrid, ts) {
                    *l = new;
                }
            }
            Some(PassLoop::Adrc(l, _)) => {
                if let Ok(new) = HybridForce::new(laws.adrc, &hybrid, ts) {
                    *l = new;
                }
            }
            None => {}
        }
    }

    fn reset(&mut self) {
        self.leave_rest();
        self.pass = None;
        self.spindle_rpm = T::zero();
        self.reference_n = T::zero();
    }

    fn telemetry(&self) -> GrindingTelemetry<T> {
        self.telemetry
    }
}

/// The piezo 0, the hexapod feed 1, the spindle speed 2.
impl<T: Real> FiniteOutputs for GrindingOutputs<T> {
    fn first_not_finite(&self) -> Option<u8> {
        first_non_finite_index([self.piezo_m, self.hexapod_feed_m_s, self.spindle_rpm])
    }
}

impl From<NonFiniteOutput> for GrindingFault {
    fn from(output: NonFiniteOutput) -> Self {
        Self::Output(output)
    }
}
