//! The contour-machining experiment of T 8.2.1 on the simulated Keops slave: a shape
//! planned as a contour job, run by the machine app (calibration, approach, contour)
//! under the supervisor, with the plant read back only through its Hall sensors.
//!
//! The figures are measured on the plant's true state, not on what the machine
//! believes: the contour error is the signed distance from the true effector to the
//! reference path (the polyline of every period's reference, 0.8 µm apart at 8 mm/s and
//! 10 kHz, so the chord error of the polyline is below 1e-13 m), found by walking
//! the nearest reference index along with the effector; the tangential speed is the
//! true effector velocity along the path's direction at that point.

use hal_mock::delta_plant::DeltaPlantParams;
use hal_mock::hall_sensor::HallSensorParams;
use kerf::app::supervisor::{Machine, Mode};
use kerf::control::laser::LaserMode;
use kerf::machines::delta_slave::product::{
    APPROACH_S, CUT_HEIGHT_M, CUT_MOTION, JUNCTION_DEVIATION_M,
};
use kerf::machines::delta_slave::{
    ContourConfig, ContourCurve, ContourLaw, ContourPlan, DeltaFault, DeltaJob, DeltaJobError,
    DeltaSlaveConfig, MovePoint, CONTOUR_HARMONICS, OPEN_PATH_POINTS,
};
use kerf::trajectory::curve::Curve;
use kerf::trajectory::efd::Efd;
use kerf::trajectory::open_path::OpenPath;
use kerf::Float;
use kerf_sim::slave::{run_slave_job, SlaveError, SlaveScenario};

/// What a case cuts, m, centred near the origin.
#[derive(Clone, Debug)]
pub enum CaseCurve {
    /// A closed polygon, as an EFD of `harmonics` harmonics, one lap from θ = 0.
    Closed {
        /// The polygon's vertices.
        polygon: Vec<[f64; 2]>,
        /// Harmonics of its EFD.
        harmonics: usize,
    },
    /// An open path through the points, first to last.
    Open(Vec<[f64; 2]>),
    /// A program of straight moves through the points, corners sharp, each move at
    /// its feed (at most the case's speed), with the Keops junction deviation.
    Moves(Vec<MovePoint>),
}

/// One contour run: what to cut, how, on which machine.
#[derive(Clone, Debug)]
pub struct ContourCase {
    /// The shape.
    pub curve: CaseCurve,
    /// Tangential speed, m/s.
    pub speed_m_s: f64,
    /// The law.
    pub law: ContourLaw,
    /// Control period, s.
    pub period_s: f64,
    /// The plant.
    pub plant: DeltaPlantParams,
    /// From this job time on (s), carriage `.1` is blocked.
    pub blocked_carriage: Option<(f64, usize)>,
    /// What the beam does along the contour.
    pub laser: LaserMode,
    /// The contour laws' gains and limits (the Keops preset unless a case retunes
    /// them).
    pub contour: ContourConfig,
    /// Noise-free nominal sensors with the nominal decoders installed (no
    /// calibration): what the laws do when sensing is not the limit. Otherwise the
    /// square scenario's imperfect, noisy sensors, calibrated by the machine.
    pub ideal_sensors: bool,
}

impl ContourCase {
    /// `curve` at `speed_m_s` under `law` every `period_s` on the realistic Keops slave
    /// (`SLAVE_REALISTIC`, the calibrated imperfect sensors, the Keops contour
    /// preset), nothing blocked, the laser as `laser`.
    pub fn realistic(
        curve: CaseCurve,
        speed_m_s: f64,
        law: ContourLaw,
        period_s: f64,
        laser: LaserMode,
    ) -> Self {
        Self {
            curve,
            speed_m_s,
            law,
            period_s,
            plant: DeltaPlantParams::SLAVE_REALISTIC,
            blocked_carriage: None,
            contour: ContourConfig::KEOPS,
            ideal_sensors: false,
            laser,
        }
    }
}

/// One period of a run, in the contour phase.
#[derive(Copy, Clone, Debug)]
pub struct ContourSample {
    /// Time since the contour's first period, s.
    pub t_s: f64,
    /// The machine's reference, m.
    pub reference_m: [f64; 3],
    /// The true effector, m.
    pub effector_m: [f64; 3],
    /// The true effector velocity, m/s.
    pub effector_velocity_m_s: [f64; 3],
    /// Forces applied, N.
    pub force_n: [f64; 3],
    /// Laser power written for the period, W (duty × the source's maximum).
    pub laser_power_w: f64,
    /// The contour error as the machine measured it (through its Hall decoders), m.
    pub measured_contour_error_m: f64,
}

/// What a run measured.
#[derive(Clone, Debug)]
pub struct ContourReport {
    /// Largest |contour error|, m.
    pub max_normal_m: f64,
    /// RMS contour error, m.
    pub rms_normal_m: f64,
    /// Largest |contour error| at cruise (the periods whose reference moves at the
    /// set speed: the start and stop ramps left out), m.
    pub max_normal_cruise_m: f64,
    /// Largest |tangential speed − reference speed| at cruise, m/s.
    pub max_speed_error_m_s: f64,
    /// Largest |force| on any carriage, N.
    pub peak_force_n: f64,
    /// Largest contour error as the machine measured it, m: what its law acts on;
    /// the rest of [`Self::max_normal_m`] is the sensors' residual error.
    pub max_measured_normal_m: f64,
    /// The machine's fault, if it stopped on one.
    pub fault: Option<DeltaFault>,
    /// Job time of the fault, s.
    pub fault_at_s: Option<f64>,
    /// Largest |force| commanded from the fault's period on, N.
    pub force_after_fault_n: f64,
    /// Largest laser duty written from the fault's period on.
    pub laser_after_fault: f64,
    /// The contour error of every period (signed, left of the path positive), m.
    pub normal_m: Vec<f64>,
    /// Where the true effector is along the reference path at the end of each
    /// period: arc length of its nearest point on the path, m.
    pub arc_m: Vec<f64>,
    /// Every period of the contour phase.
    pub samples: Vec<ContourSample>,
}

/// The shape scaled by `scale` about its centroid.
pub fn scaled(points: &[[f64; 2]], scale: f64) -> Vec<[f64; 2]> {
    let n = points.len() as f64;
    let cx = points.iter().map(|p| p[0]).sum::<f64>() / n;
    let cy = points.iter().map(|p| p[1]).sum::<f64>() / n;
    points
        .iter()
        .map(|p| [(p[0] - cx) * scale, (p[1] - cy) * scale])
        .collect()
}

/// The machine of a case: [`machine`] with the case's contour configuration.
fn case_machine(case: &ContourCase) -> DeltaSlaveConfig {
    DeltaSlaveConfig {
        contour: case.contour,
        ..machine(case.period_s)
    }
}

/// The Keops preset at `period_s`.
pub fn machine(period_s: f64) -> DeltaSlaveConfig {
    let mut config = DeltaSlaveConfig::KEOPS;
    config.joints.period_s = period_s;
    config
}

/// The case's curve, built in `f64` (boxed: the two differ in size by a kilobyte).
enum Planned {
    Closed(Box<Efd<f64, CONTOUR_HARMONICS>>),
    Open(Box<OpenPath<f64, OPEN_PATH_POINTS>>),
    Moves(Vec<MovePoint>),
}

impl Planned {
    fn of(case: &ContourCase) -> Result<Self, DeltaJobError> {
        Ok(match &case.curve {
            CaseCurve::Closed { polygon, harmonics } => Self::Closed(Box::new(
                Efd::from_polygon(polygon, *harmonics).map_err(DeltaJobError::Contour)?,
            )),
            CaseCurve::Open(points) => Self::Open(Box::new(
                OpenPath::from_points(points).map_err(DeltaJobError::Contour)?,
            )),
            CaseCurve::Moves(points) => Self::Moves(points.clone()),
        })
    }

    /// One lap of a closed curve, from θ = 0; an open path, first to last point.
    fn curve(&self) -> ContourCurve<'_> {
        match self {
            Self::Closed(efd) => ContourCurve::Closed {
                efd,
                theta0_rad: 0.0,
                laps: 1.0,
            },
            Self::Open(path) => ContourCurve::Open(path),
            Self::Moves(points) => ContourCurve::Moves {
                points,
                junction_deviation_m: JUNCTION_DEVIATION_M,
                lookahead: 0,
                before: None,
            },
        }
    }
}

/// Length of the case's path, m (one lap of a closed one).
pub fn path_length_m(case: &ContourCase) -> Result<f64, DeltaJobError> {
    Ok(match Planned::of(case)? {
        Planned::Closed(efd) => efd.arc_length(0.0, efd.span(), 1024),
        Planned::Open(path) => path.arc_length(0.0, path.span(), 1024),
        Planned::Moves(points) => points
            .windows(2)
            .map(|w| (w[1].point_m[0] - w[0].point_m[0]).hypot(w[1].point_m[1] - w[0].point_m[1]))
            .sum(),
    })
}

/// Plans the case's job: one lap from θ = 0 (or the open path) at the Keops slave's
/// cutting height, approach and ramps ([`CUT_MOTION`]), the case's speed, law and
/// laser.
pub fn plan(case: &ContourCase) -> Result<DeltaJob, DeltaJobError> {
    let planned = Planned::of(case)?;
    let curve = planned.curve();
    DeltaJob::plan_contour(
        &case_machine(case),
        &ContourPlan {
            curve,
            centre_m: [0.0, 0.0, CUT_HEIGHT_M],
            speed_m_s: case.speed_m_s,
            accel_m_s2: CUT_MOTION.accel_m_s2,
            jerk_m_s3: CUT_MOTION.jerk_m_s3,
            approach_s: APPROACH_S,
            law: case.law,
            laser: case.laser,
        },
    )
}

/// Runs the case in the scalar `T` and measures it (module docs).
pub fn run<T: Float>(case: &ContourCase) -> Result<ContourReport, SlaveError> {
    let job = plan(case).map_err(SlaveError::Job)?;
    let mut scenario = SlaveScenario::square();
    scenario.machine = case_machine(case);
    scenario.plant = case.plant;
    scenario.blocked_carriage = case.blocked_carriage;
    if case.ideal_sensors {
        let mut nominal = HallSensorParams::LM1247_16BIT;
        nominal.noise_lsb = 0.0;
        scenario.sensors = [nominal; 3];
        scenario.stored_nominal_calibration = true;
    }
    let job_s = job.duration_s() + 1.0;
    let max_power_w = scenario.machine.laser.max_power_w;
    let mut samples = Vec::new();
    let mut fault = None;
    let mut t0 = None;
    let outcome = run_slave_job::<T>(&scenario, job, job_s, 200, |period, rig| {
        let telemetry = rig.supervisor().machine().telemetry();
        if let Mode::Fault(f) = period.mode {
            fault.get_or_insert(f);
        }
        let (Some(contour), Some(reference)) = (telemetry.contour, telemetry.effector_reference_m)
        else {
            return;
        };
        let start = *t0.get_or_insert(period.t_s);
        let plant = &rig.plant().plant;
        let (Ok(p), Ok(v)) = (plant.effector_m(), plant.effector_velocity_m_s()) else {
            return;
        };
        samples.push(ContourSample {
            t_s: period.t_s - start,
            reference_m: reference.map(|r| r.to_f64()),
            effector_m: p.into(),
            effector_velocity_m_s: v.into(),
            force_n: plant.applied_force_n().into(),
            laser_power_w: rig.plant().laser_duty * max_power_w,
            measured_contour_error_m: contour.contour_error_m.to_f64(),
        });
    })?;
    let mut report = measure(samples, fault, case.period_s, case.speed_m_s);
    report.fault_at_s = outcome.fault_at_s;
    report.force_after_fault_n = outcome.force_after_fault_n;
    report.laser_after_fault = outcome.laser_after_fault;
    Ok(report)
}

/// The figures of a run's samples (module docs).
pub fn measure(
    samples: Vec<ContourSample>,
    fault: Option<DeltaFault>,
    period_s: f64,
    speed_m_s: f64,
) -> ContourReport {
    let reference: Vec<[f64; 2]> = samples
        .iter()
        .map(|s| [s.reference_m[0], s.reference_m[1]])
        .collect();
    let distance_sq = |j: usize, p: [f64; 2]| {
        let r = reference[j];
        (r[0] - p[0]).powi(2) + (r[1] - p[1]).powi(2)
    };
    // Arc length of each reference vertex.
    let mut vertex_arc_m = Vec::with_capacity(reference.len());
    let mut along = 0.0;
    for (i, r) in reference.iter().enumerate() {
        if i > 0 {
            along += (r[0] - reference[i - 1][0]).hypot(r[1] - reference[i - 1][1]);
        }
        vertex_arc_m.push(along);
    }
    let mut normal_m = Vec::with_capacity(samples.len());
    let mut arc_m = Vec::with_capacity(samples.len());
    let mut j = 0;
    let (mut max_normal, mut sum_sq, mut max_speed_error, mut peak_force) =
        (0.0f64, 0.0, 0.0f64, 0.0f64);
    let mut max_normal_cruise = 0.0f64;
    for (i, s) in samples.iter().enumerate() {
        let p = [s.effector_m[0], s.effector_m[1]];
        while j + 1 < reference.len() && distance_sq(j + 1, p) <= distance_sq(j, p) {
            j += 1;
        }
        while j > 0 && distance_sq(j - 1, p) < distance_sq(j, p) {
            j -= 1;
        }
        // Distance to the segments on either side of the nearest vertex, signed by the
        // path's left normal.
        let mut best = f64::INFINITY;
        let mut signed = 0.0;
        let mut arc = vertex_arc_m.get(j).copied().unwrap_or(0.0);
        for (a, b) in [
            (j.saturating_sub(1), j),
            (j, (j + 1).min(reference.len() - 1)),
        ] {
            let (ra, rb) = (reference[a], reference[b]);
            let d = [rb[0] - ra[0], rb[1] - ra[1]];
            let len_sq = d[0] * d[0] + d[1] * d[1];
            let u = if len_sq > 0.0 {
                (((p[0] - ra[0]) * d[0] + (p[1] - ra[1]) * d[1]) / len_sq).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let c = [ra[0] + u * d[0], ra[1] + u * d[1]];
            let off = [p[0] - c[0], p[1] - c[1]];
            let dist = off[0].hypot(off[1]);
            if dist < best {
                best = dist;
                arc = vertex_arc_m[a] + u * len_sq.sqrt();
                signed = if len_sq > 0.0 && d[0] * off[1] - d[1] * off[0] < 0.0 {
                    -dist
                } else {
                    dist
                };
            }
        }
        normal_m.push(signed);
        arc_m.push(arc);
        max_normal = max_normal.max(best);
        sum_sq += best * best;
        // Tangential speed along the path at the nearest point, against the reference
        // speed of this period; at cruise only (the ramps change speed on purpose).
        let (a, b) = (
            j.min(reference.len().saturating_sub(2)),
            (j + 1).min(reference.len() - 1),
        );
        let d = [
            reference[b][0] - reference[a][0],
            reference[b][1] - reference[a][1],
        ];
        let step = d[0].hypot(d[1]);
        let reference_speed = if i + 1 < reference.len() {
            let n = [
                reference[i + 1][0] - reference[i][0],
                reference[i + 1][1] - reference[i][1],
            ];
            n[0].hypot(n[1]) / period_s
        } else {
            0.0
        };
        let cruising = (reference_speed - speed_m_s).abs() < 1e-6 * speed_m_s;
        if cruising {
            max_normal_cruise = max_normal_cruise.max(best);
        }
        if step > 0.0 && cruising {
            let v = s.effector_velocity_m_s;
            let along = (v[0] * d[0] + v[1] * d[1]) / step;
            max_speed_error = max_speed_error.max((along - reference_speed).abs());
        }
        peak_force = s.force_n.iter().fold(peak_force, |m, f| m.max(f.abs()));
    }
    let n = samples.len().max(1) as f64;
    ContourReport {
        max_normal_m: max_normal,
        rms_normal_m: (sum_sq / n).sqrt(),
        max_normal_cruise_m: max_normal_cruise,
        max_speed_error_m_s: max_speed_error,
        peak_force_n: peak_force,
        max_measured_normal_m: samples
            .iter()
            .map(|s| s.measured_contour_error_m)
            .fold(0.0, f64::max),
        fault,
        fault_at_s: None,
        force_after_fault_n: 0.0,
        laser_after_fault: 0.0,
        normal_m,
        arc_m,
        samples,
    }
}

/// Every carriage's sensors in the experiment: the square scenario's (imperfect 16-bit,
/// different on each carriage, calibrated by the machine).
pub fn sensors() -> [HallSensorParams; 3] {
    SlaveScenario::square().sensors
}

/// Pictures of runs of one case under different laws (`runs`: legend and report):
/// `<dir>/<name>_xy.svg`, the reference and each run's true effector in the x–y plane
/// with a zoom on the first run's worst contour error (a window of six times that
/// error, so the error spans a third of it), and `<dir>/<name>_normal.svg`, each
/// run's contour error against time.
pub fn draw_runs(
    dir: &std::path::Path,
    name: &str,
    title: &str,
    runs: &[(&str, &ContourReport)],
) -> crate::plot::PlotResult {
    use crate::plot::{time_series, xy_with_zoom, Series, ZoomBox};
    let Some((_, first)) = runs.first() else {
        return Ok(());
    };
    let mm = |p: [f64; 3]| (1e3 * p[0], 1e3 * p[1]);
    let reference: Vec<(f64, f64)> = first.samples.iter().map(|s| mm(s.reference_m)).collect();
    let paths: Vec<Vec<(f64, f64)>> = runs
        .iter()
        .map(|(_, r)| r.samples.iter().map(|s| mm(s.effector_m)).collect())
        .collect();
    let worst = first
        .normal_m
        .iter()
        .enumerate()
        .fold((0, 0.0f64), |best, (i, e)| {
            if e.abs() > best.1 {
                (i, e.abs())
            } else {
                best
            }
        });
    let zoom = first.samples.get(worst.0).map(|s| {
        let (x, y) = mm(s.effector_m);
        ZoomBox::around(x, y, 3e3 * worst.1.max(1e-7))
    });
    let mut series = vec![Series::new("reference", &reference, 0)];
    for (i, ((label, _), path)) in runs.iter().zip(&paths).enumerate() {
        series.push(Series::new(label, path, i + 1));
    }
    xy_with_zoom(&dir.join(format!("{name}_xy.svg")), title, &series, zoom)?;
    let errors: Vec<Vec<(f64, f64)>> = runs
        .iter()
        .map(|(_, r)| {
            r.samples
                .iter()
                .zip(&r.normal_m)
                .map(|(s, e)| (s.t_s, 1e6 * e))
                .collect()
        })
        .collect();
    let series: Vec<Series> = runs
        .iter()
        .zip(&errors)
        .enumerate()
        .map(|(i, ((label, _), points))| Series::new(label, points, i + 1))
        .collect();
    time_series(
        &dir.join(format!("{name}_normal.svg")),
        title,
        "contour error (µm)",
        &series,
    )
}
