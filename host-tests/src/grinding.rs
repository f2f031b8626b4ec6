//! The grinding cell in closed loop on the host (G ch. 7–8): the `GrindingCell`
//! machine under its supervisor, the simulated cell of `hal-mock` (piezo, workpiece,
//! Werner forces, G's noise), and the F/T sensor between them: the cell's
//! wrench becomes six gauge voltages through the inverse of the sensor's calibration
//! matrix, plus a bias the machine captures at rest.

use hal_mock::grinding_cell::{Cell, CellConfig, CellReading};
use heapless::spsc::Queue;
use kerf::app::jobs::{JobSlot, JobSlots};
use kerf::app::supervisor::{Command, Machine, Mode, Report, Supervisor};
use kerf::machines::grinding::{
    ForceLawKind, GrindingCalibration, GrindingCell, GrindingConfig, GrindingInputs, GrindingJob,
};
use kerf::sensing::force::Eccentricity;
use nalgebra::{Matrix6, Vector6};

/// Samples of the workpiece (5 µm apart over 15 mm).
pub const SAMPLES: usize = 3000;
/// Sample spacing, m.
pub const DX_M: f64 = 5e-6;
/// The sensor's bias, V (what the capture at rest must find).
pub const BIAS_V: [f64; 6] = [0.12, -0.31, 0.05, 0.22, -0.08, 0.17];

/// A pass to run.
#[derive(Copy, Clone, Debug)]
pub struct PassSetup {
    /// The machine.
    pub config: GrindingConfig,
    /// The cell.
    pub cell: CellConfig,
    /// The pass.
    pub job: GrindingJob,
    /// Hand the machine the cell's true eccentricity (as a fit would).
    pub eccentricity: Eccentricity,
}

/// One period of a pass.
#[derive(Copy, Clone, Debug)]
pub struct PassSample {
    /// Time since the start, s.
    pub t_s: f64,
    /// The cell's truth and readings.
    pub cell: CellReading,
    /// The normal force the machine measured, N.
    pub measured_n: f64,
}

/// What a pass did.
pub struct PassRun {
    /// Every period.
    pub samples: Vec<PassSample>,
    /// The surface before and after, m, at the workpiece's samples.
    pub before_m: Vec<f64>,
    /// After.
    pub after_m: Vec<f64>,
    /// x of the samples, m.
    pub x_m: Vec<f64>,
    /// The mode at the end.
    pub mode: Mode<kerf::machines::grinding::GrindingFault>,
}

/// Gauge voltages for a wrench over the bias (the calibration inverted in f64).
pub fn raw_for(config: &GrindingConfig, wrench: [f64; 6]) -> [f64; 6] {
    let cal = Matrix6::from_fn(|r, c| config.sensor.calibration[r][c]);
    let inverse = cal.try_inverse().unwrap_or_else(Matrix6::zeros);
    let raw = inverse * Vector6::from(wrench);
    core::array::from_fn(|k| raw[k] + BIAS_V[k])
}

/// Runs a pass from rest: the bias capture with the tool retracted, the calibration
/// command, then the job until the machine is Ready again (or faults), at most
/// `max_periods`.
pub fn run_pass(setup: &PassSetup, max_periods: usize) -> PassRun {
    let jobs = JobSlots::new(setup.job, GrindingJob::default());
    let mut commands = Queue::<Command<GrindingCell<f64>>, 4>::new();
    let mut reports = Queue::<Report<GrindingCell<f64>>, 8>::new();
    let (mut to, from) = commands.split();
    let (report_to, mut report_from) = reports.split();
    let machine = GrindingCell::<f64>::new(&setup.config).expect("grinding config");
    let mut supervisor = Supervisor::new(machine, from, report_to, &jobs);
    supervisor.set_telemetry_decimation(0);
    let mut cell = Cell::<SAMPLES>::new(&setup.cell, 0.0, DX_M);
    let before_m = cell.workpiece().heights_m().to_vec();
    let x_m = (0..SAMPLES).map(|i| cell.workpiece().x_m(i)).collect();
    let mut reading = cell.step(0.0, 0.0);
    let mut step = |supervisor: &mut Supervisor<'_, GrindingCell<f64>>, reading: &CellReading| {
        let inputs = GrindingInputs {
            ft_raw_v: raw_for(&setup.config, reading.wrench),
            device_fault: None,
        };
        let out = supervisor.step(&inputs);
        while report_from.dequeue().is_some() {}
        out
    };
    let _ = to.enqueue(Command::Calibrate);
    while supervisor.mode() != Mode::Ready {
        let out = step(&mut supervisor, &reading);
        reading = cell.step(out.piezo_m, out.hexapod_feed_m_s);
        if matches!(supervisor.mode(), Mode::Calibrating) && supervisor.machine().bias().is_some() {
            let _ = to.enqueue(Command::FinishCalibration(GrindingCalibration {
                eccentricity: setup.eccentricity,
            }));
        }
        if matches!(supervisor.mode(), Mode::Fault(_)) {
            break;
        }
    }
    let _ = to.enqueue(Command::LoadJob(JobSlot::First));
    let _ = to.enqueue(Command::Start);
    let mut samples = Vec::new();
    for k in 0..max_periods {
        let out = step(&mut supervisor, &reading);
        if k > 0 && supervisor.mode() != Mode::Running {
            break;
        }
        let measured_n = supervisor.machine().telemetry().forces.normal_n;
        reading = cell.step(out.piezo_m, out.hexapod_feed_m_s);
        samples.push(PassSample {
            t_s: k as f64 * setup.config.period_s,
            cell: reading,
            measured_n,
        });
    }
    PassRun {
        samples,
        before_m,
        after_m: cell.workpiece().heights_m().to_vec(),
        x_m,
        mode: supervisor.mode(),
    }
}

/// G's figures of a pass.
#[derive(Copy, Clone, Debug)]
pub struct PassFigures {
    /// RMS of the true normal force minus the reference while in contact, N.
    pub force_rms_error_n: f64,
    /// RMS of the measured (noisy) normal force minus the reference, N.
    pub measured_rms_error_n: f64,
    /// Surface form error: the mean square of (after − before) minus its mean over the
    /// ground stretch (G 8.1: the two forms superimposed), mm².
    pub form_mse_mm2: f64,
    /// Mean depth removed, µm.
    pub mean_depth_um: f64,
}

/// Why a pass has no figures: it did not grind.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum NotGround {
    /// The tool never touched the workpiece.
    NoContact,
    /// It touched, but left part of the stretch it passed over as it was: the share of
    /// the stretch's surface points it removed material from.
    Partly {
        /// Points with material removed over points of the stretch, 0 to 1.
        ground_fraction: f64,
        /// RMS of the true normal force minus the reference from the first contact
        /// and the settling time on, N (the force loop's figure, which a partial pass
        /// still has; `None` if the pass ended before the settling time).
        force_rms_error_n: Option<f64>,
    },
}

impl core::fmt::Display for NotGround {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NoContact => write!(f, "never touched the workpiece"),
            Self::Partly {
                ground_fraction,
                force_rms_error_n,
            } => {
                write!(f, "ground {:.0} % of the stretch", ground_fraction * 100.0)?;
                match force_rms_error_n {
                    Some(e) => write!(f, " (force RMS error {e:.3} N)"),
                    None => write!(f, " (stopped before the force settled)"),
                }
            }
        }
    }
}

/// A pass's figures in words: G's, or why it has none.
pub fn describe(figures: &Result<PassFigures, NotGround>) -> String {
    match figures {
        Ok(f) => format!(
            "force RMS error {:.3} N true, {:.3} N measured; mean depth {:.1} µm; surface form MSE {:.6} mm²",
            f.force_rms_error_n, f.measured_rms_error_n, f.mean_depth_um, f.form_mse_mm2
        ),
        Err(e) => format!("no surface figures: it {e}"),
    }
}

/// Depth below which a surface point counts as untouched, m (the surface model's
/// resolution is far finer; a pass removes micrometres).
const UNTOUCHED_M: f64 = 1e-9;

/// Figures over the pass, from the first contact plus `settle_s`, on the stretch the
/// tool ground with a tool radius's margin at both ends. A pass counts only if it
/// removed material at every point of that stretch; otherwise says how much it did.
pub fn figures(
    run: &PassRun,
    reference_n: f64,
    settle_s: f64,
    tool_radius_m: f64,
) -> Result<PassFigures, NotGround> {
    let first = run
        .samples
        .iter()
        .find(|s| s.cell.normal_force_n > 0.0)
        .map(|s| s.t_s)
        .ok_or(NotGround::NoContact)?;
    let steady: Vec<&PassSample> = run
        .samples
        .iter()
        .filter(|s| s.t_s > first + settle_s)
        .collect();
    let rms = |f: &dyn Fn(&PassSample) -> f64| {
        (steady
            .iter()
            .map(|s| (f(s) - reference_n).powi(2))
            .sum::<f64>()
            / steady.len().max(1) as f64)
            .sqrt()
    };
    let (start, end) = match (steady.first(), run.samples.last()) {
        (Some(a), Some(b)) => (a.cell.x_m + tool_radius_m, b.cell.x_m - tool_radius_m),
        _ => (0.0, 0.0),
    };
    let removed: Vec<f64> = run
        .x_m
        .iter()
        .zip(run.before_m.iter().zip(&run.after_m))
        .filter(|(x, _)| **x > start && **x < end)
        .map(|(_, (b, a))| b - a)
        .collect();
    let ground = removed.iter().filter(|d| **d > UNTOUCHED_M).count();
    if removed.is_empty() || ground < removed.len() {
        return Err(NotGround::Partly {
            ground_fraction: ground as f64 / removed.len().max(1) as f64,
            force_rms_error_n: (!steady.is_empty()).then(|| rms(&|s| s.cell.normal_force_n)),
        });
    }
    // Sums from +0.0 (an empty float sum is −0.0): a mean of squares is never negative.
    let n = removed.len() as f64;
    let mean = removed.iter().fold(0.0, |a, d| a + d) / n;
    let mse = removed.iter().fold(0.0, |a, d| a + (d - mean).powi(2)) / n;
    Ok(PassFigures {
        force_rms_error_n: rms(&|s| s.cell.normal_force_n),
        measured_rms_error_n: rms(&|s| s.measured_n),
        form_mse_mm2: mse * 1e6,
        mean_depth_um: mean * 1e6,
    })
}

/// A pass of G's experiments: law, reference, G's feed and spindle, and
/// `length_m` along the surface.
pub fn seed_pass(law: ForceLawKind, normal_force_n: f64, length_m: f64) -> PassSetup {
    let cell = CellConfig::PUBLISHED;
    PassSetup {
        config: GrindingConfig::PUBLISHED,
        cell,
        job: GrindingJob {
            law,
            normal_force_n,
            feed_m_s: 1e-4,
            length_m,
            spindle_rpm: cell.spindle_rpm,
        },
        eccentricity: Eccentricity {
            dx_m: cell.sensor_offset_m[0],
            dy_m: cell.sensor_offset_m[1],
        },
    }
}
