//! The slave's contour job as the QEMU image and the host tests both run it: the
//! octagon of T fig. 8.4 (±6 mm, 30 harmonics) at 8 mm/s under contouring control, the
//! machine calibrating its Hall sensors first, the plant read back only through them.
//!
//! [`ContourMeter`] measures the contour error online, in constant memory: the true
//! effector's distance to the reference path, the polyline of the last `W` periods'
//! references. The effector is measured `W/2` periods late, so that the path on both
//! sides of where it should be is known (it lags or leads the reference by a few
//! periods at most: 10 µm of timing error is 12 periods at 8 mm/s and 10 kHz).

use crate::slave::{run_slave_job, SlaveError, SlaveScenario};
use hal_mock::delta_plant::DeltaPlantParams;
use hal_mock::hall_sensor::HallSensorParams;
use heapless::Deque;
use kerf::app::supervisor::{Machine, Mode};
use kerf::machines::delta_slave::product::{contour_defaults, APPROACH_S, CUT_MOTION};
use kerf::machines::delta_slave::{
    ContourCurve, ContourLaw, DeltaFault, DeltaJob, DeltaJobError, DeltaSlaveConfig,
    CONTOUR_HARMONICS,
};
use kerf::scalar::Float;
use kerf::trajectory::efd::Efd;
use kerf::trajectory::shapes::{octagon, OCTAGON_POINTS};
use kerf::trajectory::ContourError;

/// Contour error bounds of the smoke run (max, RMS), m: a tenth of the 50 µm the
/// machine's supervision allows, and what the ideal-plant runs reach (1.5 µm max,
/// 0.6 µm RMS on the host) with margin for other noise draws.
pub const CONTOUR_BOUNDS_M: (f64, f64) = (5e-6, 2e-6);

/// How far the f32 machine's figures may lie from the f64 machine's, m: f32 rounds
/// positions to ulp(50 mm) = 3.7 nm and the loop's terms alike, and the stable loop
/// passes such perturbations with a gain of a few, so some 10 nm; 50 nm leaves room
/// for another noise draw (measured 2 nm on the maximum, 6 nm on the RMS).
pub const CONTOUR_F32_TOLERANCE_M: f64 = 50e-9;

/// Laps of the smoke run: a quarter lap, two octagon corners at cruise and both ramps.
pub const SMOKE_LAPS: f64 = 0.25;

/// Plant RK4 steps per period in the smoke run (the emulated CPU pays for each).
pub const SMOKE_SUBSTEPS: u32 = 1;

/// Online contour error against the last `W` references (module docs).
#[derive(Clone, Debug, Default)]
pub struct ContourMeter<const W: usize> {
    reference: Deque<[f64; 2], W>,
    effector: Deque<[f64; 2], W>,
    /// Periods measured.
    pub periods: u32,
    /// Largest |contour error|, m.
    pub max_m: f64,
    sum_sq_m2: f64,
}

/// Distance from `p` to the segment `a`–`b`.
fn segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let len_sq = d[0] * d[0] + d[1] * d[1];
    let u = if len_sq > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len_sq).clamp(0.0, 1.0)
    } else {
        0.0
    };
    libm::hypot(p[0] - (a[0] + u * d[0]), p[1] - (a[1] + u * d[1]))
}

impl<const W: usize> ContourMeter<W> {
    /// A meter with nothing measured.
    pub fn new() -> Self {
        Self {
            reference: Deque::new(),
            effector: Deque::new(),
            periods: 0,
            max_m: 0.0,
            sum_sq_m2: 0.0,
        }
    }

    /// One period: the reference and the true effector (x, y), m.
    pub fn push(&mut self, reference_m: [f64; 2], effector_m: [f64; 2]) {
        if self.reference.is_full() {
            let _ = self.reference.pop_front();
            let _ = self.effector.pop_front();
        }
        let _ = self.reference.push_back(reference_m);
        let _ = self.effector.push_back(effector_m);
        if !self.reference.is_full() {
            return;
        }
        let Some(p) = self.effector.iter().nth(W / 2).copied() else {
            return;
        };
        let mut nearest = f64::INFINITY;
        let mut previous: Option<[f64; 2]> = None;
        for r in self.reference.iter().copied() {
            if let Some(a) = previous {
                nearest = nearest.min(segment_distance(p, a, r));
            }
            previous = Some(r);
        }
        self.periods += 1;
        self.max_m = self.max_m.max(nearest);
        self.sum_sq_m2 += nearest * nearest;
    }

    /// RMS contour error, m.
    pub fn rms_m(&self) -> f64 {
        libm::sqrt(self.sum_sq_m2 / f64::from(self.periods.max(1)))
    }
}

/// What a contour run measured.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ContourSummary {
    /// Periods measured.
    pub periods: u32,
    /// Largest |contour error|, m.
    pub max_normal_m: f64,
    /// RMS contour error, m.
    pub rms_normal_m: f64,
    /// The machine's fault, if any.
    pub fault: Option<DeltaFault>,
}

/// The octagon at ±6 mm (the stored shape scaled by 0.6) in `harmonics` harmonics.
pub fn octagon_efd(harmonics: usize) -> Result<Efd<f64, CONTOUR_HARMONICS>, ContourError> {
    let points = octagon().map(|p| [0.6 * p[0], 0.6 * p[1]]);
    Efd::from_polygon(&points[..OCTAGON_POINTS], harmonics)
}

/// The octagon at ±6 mm in `harmonics` harmonics, `laps` laps under `law`, cut as the
/// Keops slave cuts an uploaded contour ([`contour_defaults`]: its motion and laser),
/// on `machine` (the smoke run's contour with 30 harmonics and contouring control;
/// the benchmark's slave period).
pub fn octagon_job(
    machine: &DeltaSlaveConfig,
    laps: f64,
    harmonics: usize,
    law: ContourLaw,
) -> Result<DeltaJob, DeltaJobError> {
    let efd = octagon_efd(harmonics).map_err(DeltaJobError::Contour)?;
    let mut defaults = contour_defaults(machine, laps);
    defaults.law = law;
    DeltaJob::plan_contour(
        machine,
        &defaults.plan(ContourCurve::Closed {
            efd: &efd,
            theta0_rad: 0.0,
            laps,
        }),
    )
}

/// Runs [`octagon_job`] with the machine in scalar `T` on the ideal slave plant,
/// `substeps` RK4 steps per period, measured by a [`ContourMeter`] of 64 periods. With
/// `calibrate` the sensors are the square scenario's imperfect ones and the machine
/// calibrates them first; without, they are nominal 16-bit sensors (with noise) and
/// the nominal decoders are installed as a stored calibration.
pub fn run_octagon<T: Float>(
    laps: f64,
    substeps: u32,
    calibrate: bool,
) -> Result<ContourSummary, SlaveError> {
    let mut scenario = SlaveScenario::square();
    scenario.plant = DeltaPlantParams::SLAVE;
    scenario.substeps = substeps;
    if !calibrate {
        scenario.sensors = [HallSensorParams::LM1247_16BIT; 3];
        scenario.stored_nominal_calibration = true;
    }
    let job = octagon_job(&scenario.machine, laps, 30, ContourLaw::Contouring)
        .map_err(SlaveError::Job)?;
    // Approach, the lap, the ramps and a margin.
    let job_s = APPROACH_S + laps * 0.045 / CUT_MOTION.speed_m_s + 1.0;
    let mut meter = ContourMeter::<64>::new();
    let mut fault = None;
    run_slave_job::<T>(&scenario, job, job_s, 0, |period, rig| {
        if let Mode::Fault(f) = period.mode {
            fault.get_or_insert(f);
        }
        let telemetry = rig.supervisor().machine().telemetry();
        let (Some(_), Some(r)) = (telemetry.contour, telemetry.effector_reference_m) else {
            return;
        };
        if let Ok(p) = rig.plant().plant.effector_m() {
            meter.push([r[0].to_f64(), r[1].to_f64()], [p.x, p.y]);
        }
    })?;
    Ok(ContourSummary {
        periods: meter.periods,
        max_normal_m: meter.max_m,
        rms_normal_m: meter.rms_m(),
        fault,
    })
}
