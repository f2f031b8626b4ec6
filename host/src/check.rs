//! `kerf check`: a job file checked on the host as the machine checks it at load,
//! with the machine's own loader and the presets it is flashed with, so that a job
//! the machine would refuse is refused before the upload, in the machine's words.
//!
//! - The Keops slave (`keops-slave`) takes EFD files (closed contours) and points files
//!   (open paths): [`check`] runs its loader
//!   ([`LinkMachine::load_job`] with
//!   [`contour_defaults`] of the Keops configuration: speed, ramps, laser power, cutting
//!   height, approach), which plans the contour and checks its length against the
//!   ramps, its curvature against the speed, and 512 points per lap for reach, carriage
//!   travel, singularities and carriage speed and acceleration. A refusal carries the
//!   words of the machine's refusal table (the same the link reports after an upload).
//!   An accepted job comes with its duration and a [`Preview`]: the cut, the approach
//!   from the workspace's centre, and the outline of the workspace at the cutting
//!   height.
//! - ARROW (`arrow`) takes G-code: its check is [`crate::gcode::check`] (line and
//!   column of the first problem, the job's moves and duration); its preview is seen
//!   along its tool (x and z), with the edge of its workspace at y0.
//! - The grinding cell (`grinding`) and the single axis (`single-axis`) take G-code:
//!   their own loaders (the cell's pass at its preset law and force, the axis' moves
//!   within its travel), with the pass's or the moves' duration and length; no
//!   preview.
//!
//! A file of several parts (their job files back to back, [`crate::job::split`]) is
//! checked part by part, as the machine loads them one after the other: the first
//! refused part is named; an accepted program's duration is the parts' sum (each
//! part's approach leads from where the one before ended) and its preview draws
//! every part and the travels between them.
//!
//! Which machine: the one named, or the one that takes the (first) file's kind
//! ([`Machine::for_kind`]).

use crate::job::{split, JobFileError, JobKind};
use kerf::app::host_link::LinkMachine;
use kerf::app::joints::JointJob;
use kerf::codec::job::JobFile;
use kerf::codec::link::{CodeWords, LINK_JOB_REFUSALS};
use kerf::kinematics::arrow::{ArrowConfig, ArrowGeometry, Pose};
use kerf::kinematics::delta::DeltaGeometry;
use kerf::machines::arrow::job::split_pose;
use kerf::machines::arrow::machine::ArrowLimits;
use kerf::machines::delta_slave::link::SlaveJobContext;
use kerf::machines::delta_slave::product::{contour_defaults, JOB_LAPS};
use kerf::machines::delta_slave::{DeltaJob, DeltaSlave, DeltaSlaveConfig};
use kerf::machines::grinding::product::PASS;
use kerf::machines::grinding::GrindingJob;
use kerf::machines::single_axis::product::CONFIG as AXIS;
use kerf::trajectory::gcode::MoveKind;
use kerf::trajectory::task_spline::Pose as TaskPose;
use nalgebra::Vector3;

/// The machines a job can be checked for on the host (on the command line by the
/// names they announce: `keops-slave`, `arrow`, `grinding`, `single-axis`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Machine {
    /// The Keops slave, the laser delta: contours (EFD, points and moves files).
    KeopsSlave,
    /// ARROW: G-code programs.
    Arrow,
    /// The grinding cell: a G-code pass along X.
    Grinding,
    /// The single axis: G-code moves along X.
    SingleAxis,
}

/// Every machine [`Machine`] names, in the order the help lists them (a G-code job
/// with no machine named is ARROW's).
pub const MACHINES: [Machine; 4] = [
    Machine::KeopsSlave,
    Machine::Arrow,
    Machine::Grinding,
    Machine::SingleAxis,
];

/// The Keops slave as the link and the board images run it (its scalar).
type Keops = DeltaSlave<f32>;
/// ARROW as the link runs it.
type ArrowMachine = kerf::machines::arrow::product::Arrow<f32>;
/// The grinding cell as the link runs it.
type GrindingMachine = kerf::machines::grinding::product::Cell<f32>;
/// The single axis as the link runs it.
type AxisMachine = kerf::machines::single_axis::product::Axis<f32>;

impl Machine {
    /// The name the machine announces on the link.
    pub fn name(self) -> &'static str {
        match self {
            Machine::KeopsSlave => Keops::NAME,
            Machine::Arrow => ArrowMachine::NAME,
            Machine::Grinding => GrindingMachine::NAME,
            Machine::SingleAxis => AxisMachine::NAME,
        }
    }

    /// The job kinds it takes.
    pub fn kinds(self) -> &'static [JobKind] {
        match self {
            Machine::KeopsSlave => Keops::JOB_KINDS,
            Machine::Arrow => ArrowMachine::JOB_KINDS,
            Machine::Grinding => GrindingMachine::JOB_KINDS,
            Machine::SingleAxis => AxisMachine::JOB_KINDS,
        }
    }

    /// The plane its paths are seen in, as indices of x, y, z: ARROW's along its tool
    /// (x and z: the tool points along y), the others from above (x and y).
    pub fn path_plane(self) -> [usize; 2] {
        match self {
            Machine::Arrow => [0, 2],
            Machine::KeopsSlave | Machine::Grinding | Machine::SingleAxis => [0, 1],
        }
    }

    /// The machine of `name` (as it announces itself).
    pub fn from_name(name: &str) -> Option<Self> {
        MACHINES.into_iter().find(|m| m.name() == name)
    }

    /// The machine that takes jobs of `kind`.
    pub fn for_kind(kind: JobKind) -> Option<Self> {
        MACHINES.into_iter().find(|m| m.kinds().contains(&kind))
    }
}

/// Why a job does not pass.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CheckError {
    /// The file is not a job file the firmware reads.
    #[error("{0}")]
    File(JobFileError),
    /// No machine of that name can be checked on the host.
    #[error("no machine named '{0}' can be checked here (known: {known})", known = known_machines())]
    UnknownMachine(String),
    /// No machine takes this kind of job.
    #[error("no machine takes {0} jobs")]
    NoMachineFor(String),
    /// The machine does not take this kind of job.
    #[error("{machine} does not take {kind} jobs (it takes {takes})")]
    Kind {
        /// The machine.
        machine: &'static str,
        /// The file's kind.
        kind: String,
        /// What it takes.
        takes: String,
    },
    /// The machine's loader refuses the job: its code and words.
    #[error("{machine} would refuse this job: job code {code:#06x}: {words}")]
    Refused {
        /// The machine.
        machine: &'static str,
        /// The refusal code, as the link reports it.
        code: u16,
        /// Its words, from the machine's table.
        words: &'static str,
    },
    /// ARROW's G-code check (line and column).
    #[error("{0}")]
    Gcode(#[from] crate::gcode::GcodeCheckError),
    /// A part of ARROW's program that does not start where the machine stands after
    /// the part before it.
    #[error(
        "arrow would refuse to start it: it starts {gap_mm:.3} mm from where the part \
         before ends (a joint {joint_mm:.3} mm away; the machine starts a job within \
         {tolerance_mm:.1} mm of its joints)"
    )]
    ArrowStart {
        /// Between the tool points, mm.
        gap_mm: f64,
        /// The farthest joint, mm.
        joint_mm: f64,
        /// The machine's start tolerance, mm.
        tolerance_mm: f64,
    },
    /// A part of a program of several.
    #[error("part {part} of {of}: {error}")]
    Part {
        /// Which part, from 1.
        part: usize,
        /// Of how many.
        of: usize,
        /// What is wrong with it.
        error: Box<CheckError>,
    },
}

fn known_machines() -> String {
    MACHINES.map(Machine::name).join(", ")
}

/// A job kind in an operator's words.
pub fn kind_words(kind: JobKind) -> &'static str {
    match kind {
        JobKind::Efd => "EFD (closed contour)",
        JobKind::Points => "points (open path)",
        JobKind::Gcode => "G-code",
        JobKind::Recording => "recording",
        JobKind::Schedule => "schedule",
        JobKind::Moves => "moves (sharp corners)",
    }
}

/// What a preview draws, in the plane of the machine's cuts (m): the Keops slave's x
/// and y, ARROW's x and z (seen along its tool, the y axis).
#[derive(Clone, Debug, PartialEq)]
pub struct Preview {
    /// Where the workspace ends in that plane (closed), m; found once for a program
    /// ([`workspace_outline`], [`arrow_outline`]).
    pub workspace_m: Vec<[f64; 2]>,
    /// The travels with the tool off or clear: to the first cut's start, then from
    /// each cut's end to the next one's start, m.
    pub travels_m: Vec<Vec<[f64; 2]>>,
    /// The cuts, one per part (a run of feed moves) in order, m.
    pub cuts_m: Vec<Vec<[f64; 2]>>,
    /// Whether each cut is closed.
    pub closed: Vec<bool>,
    /// How the picture names what it draws.
    pub view: View,
}

/// The words and axes of a machine's preview.
#[derive(Clone, Debug, PartialEq)]
pub struct View {
    /// The horizontal and vertical axes' labels.
    pub axes: [&'static str; 2],
    /// The workspace's edge: where it is taken.
    pub section: String,
    /// A cut.
    pub cut: &'static str,
    /// A travel.
    pub travel: &'static str,
}

/// A job the machine accepts.
#[derive(Clone, Debug, PartialEq)]
pub struct Checked {
    /// The machine.
    pub machine: Machine,
    /// The (first) part's kind.
    pub kind: JobKind,
    /// Parts of the program (1: a single job file).
    pub parts: usize,
    /// From start to the end of the job, s (the approach included).
    pub duration_s: f64,
    /// Length of the cut (one lap of a closed contour; the single axis: its travel
    /// between its targets), m.
    pub cut_length_m: f64,
    /// What the preview draws (`None` where the machine has no preview yet).
    pub preview: Option<Preview>,
}

/// Points of a preview's cut.
pub const PREVIEW_POINTS: usize = 1024;
/// Directions in which the workspace's edge is sought.
pub const OUTLINE_DIRECTIONS: usize = 180;

/// Checks the job file `bytes` (one job, or several parts back to back) for
/// `machine`, or for the machine that takes its kind (module docs).
pub fn check(bytes: &[u8], machine: Option<Machine>) -> Result<Checked, CheckError> {
    let parts = split(bytes).map_err(CheckError::File)?;
    let of = parts.len();
    let mut all: Option<Checked> = None;
    let mut carried = Carried {
        keops: SlaveJobContext::from(contour_defaults(&DeltaSlaveConfig::KEOPS, JOB_LAPS)),
        arrow_end: None,
    };
    for (k, part) in parts.into_iter().enumerate() {
        let machine = machine.or(all.as_ref().map(|c| c.machine));
        let checked = check_part(part, machine, &mut carried).map_err(|error| match of {
            1 => error,
            _ => CheckError::Part {
                part: k + 1,
                of,
                error: Box::new(error),
            },
        })?;
        all = Some(match all {
            None => checked,
            Some(so_far) => so_far.then(checked),
        });
    }
    // `split` returns at least one part.
    let mut all = all.ok_or(CheckError::File(JobFileError::Truncated))?;
    // The workspace is the machine's, not a part's: found once for the program.
    if let Some(preview) = &mut all.preview {
        preview.workspace_m = match all.machine {
            Machine::KeopsSlave => {
                let config = DeltaSlaveConfig::KEOPS;
                let centre = contour_defaults(&config, JOB_LAPS).centre_m;
                workspace_outline(&config, [centre[0], centre[1]], centre[2])
            }
            Machine::Arrow => arrow_outline(&ArrowConfig::ARROW),
            // No preview is drawn for them.
            Machine::Grinding | Machine::SingleAxis => Vec::new(),
        };
    }
    Ok(all)
}

impl Checked {
    /// This program followed by `next`: durations and lengths added, the previews
    /// joined by the travel from this one's end to the next one's start.
    fn then(mut self, next: Checked) -> Checked {
        self.parts += next.parts;
        self.duration_s += next.duration_s;
        self.cut_length_m += next.cut_length_m;
        self.preview = match (self.preview, next.preview) {
            (Some(mut a), Some(b)) => {
                let end = a.cuts_m.last().and_then(|c| c.last()).copied();
                let start = b.cuts_m.first().and_then(|c| c.first()).copied();
                if let (Some(end), Some(start)) = (end, start) {
                    a.travels_m.push(vec![end, start]);
                }
                a.cuts_m.extend(b.cuts_m);
                a.closed.extend(b.closed);
                Some(a)
            }
            _ => None,
        };
        self
    }
}

/// What one part leaves to the next: the Keops slave's join, ARROW's last point.
struct Carried {
    keops: SlaveJobContext,
    arrow_end: Option<[f64; 5]>,
}

/// ARROW's own test at a job's start ([`ArrowLimits::start_tolerance_m`], on the
/// nominal model): the part starting at `start` (x, y, z in m, A and B in rad) may
/// follow the part that ended at `end`.
fn arrow_continues(end: &[f64; 5], start: &[f64; 5]) -> Result<(), CheckError> {
    let limits = ArrowLimits::ARROW;
    let geometry = ArrowGeometry::<f64>::new(&ArrowConfig::ARROW).ok();
    let joints = |p: &[f64; 5]| {
        let (pose, theta_x) = split_pose(&TaskPose::new(p[0], p[1], p[2], p[3], p[4]));
        let q = geometry.as_ref().and_then(|g| g.inverse(&pose).ok());
        (q, theta_x)
    };
    let ((qa, ta), (qb, tb)) = (joints(end), joints(start));
    let joint_m = match (qa, qb) {
        (Some(a), Some(b)) => (a - b).amax(),
        // A pose off the model was refused by the part's own check.
        _ => 0.0,
    };
    let gap_m = (0..3)
        .map(|k| (end[k] - start[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    if joint_m > limits.start_tolerance_m || (ta - tb).abs() > limits.start_tolerance_rad {
        return Err(CheckError::ArrowStart {
            gap_mm: gap_m * 1e3,
            joint_mm: joint_m * 1e3,
            tolerance_mm: limits.start_tolerance_m * 1e3,
        });
    }
    Ok(())
}

/// Checks one job file for `machine`, or for the machine that takes its kind (the
/// Keops slave's parts with `carried`, which carries one part's join or end to the
/// next).
fn check_part(
    bytes: &[u8],
    machine: Option<Machine>,
    carried: &mut Carried,
) -> Result<Checked, CheckError> {
    let file = JobFile::read(bytes).map_err(CheckError::File)?;
    let kind = file.kind();
    let machine = match machine {
        Some(m) => m,
        None => Machine::for_kind(kind).ok_or(CheckError::NoMachineFor(kind_words(kind).into()))?,
    };
    if !machine.kinds().contains(&kind) {
        return Err(kind_refused(machine, kind));
    }
    match (machine, file) {
        (Machine::Arrow, JobFile::Gcode { text }) => {
            let report = crate::gcode::check(text)?;
            if let Some(end) = carried.arrow_end {
                arrow_continues(&end, &report.start)?;
            }
            carried.arrow_end = Some(report.end);
            Ok(Checked {
                machine,
                kind,
                parts: 1,
                duration_s: report.duration_s,
                cut_length_m: report.length_m,
                preview: Some(arrow_preview(&report)),
            })
        }
        // ARROW's kinds are G-code only: refused above, refused the same here.
        (Machine::Arrow, _) => Err(kind_refused(machine, kind)),
        (Machine::KeopsSlave, file) => check_keops(&file, &mut carried.keops),
        (Machine::Grinding, file) => {
            let mut pass = GrindingJob::default();
            GrindingMachine::load_job(&mut PASS.clone(), &file, &mut pass)
                .map_err(refused::<GrindingMachine>)?;
            Ok(Checked {
                machine,
                kind,
                parts: 1,
                duration_s: pass.length_m / pass.feed_m_s,
                cut_length_m: pass.length_m,
                preview: None,
            })
        }
        (Machine::SingleAxis, file) => {
            let mut moves = Box::<JointJob<1>>::default();
            AxisMachine::load_job(&mut AXIS.clone(), &file, &mut moves)
                .map_err(refused::<AxisMachine>)?;
            // Between its targets: the first move starts where the carriage stands.
            let travel_m = moves
                .windows(2)
                .map(|w| (w[1].target_m[0] - w[0].target_m[0]).abs())
                .fold(0.0, |sum, d| sum + d);
            Ok(Checked {
                machine,
                kind,
                parts: 1,
                duration_s: moves.iter().map(|m| m.duration_s).sum(),
                cut_length_m: travel_m,
                preview: None,
            })
        }
    }
}

/// `M`'s refusal `code` with its words.
fn refused<M: LinkMachine>(code: u16) -> CheckError {
    CheckError::Refused {
        machine: M::NAME,
        code,
        words: words(M::JOB_REFUSALS, code),
    }
}

/// `machine` does not take jobs of `kind`.
fn kind_refused(machine: Machine, kind: JobKind) -> CheckError {
    CheckError::Kind {
        machine: machine.name(),
        kind: kind_words(kind).into(),
        takes: machine
            .kinds()
            .iter()
            .map(|&k| kind_words(k))
            .collect::<Vec<_>>()
            .join(", "),
    }
}

/// The words of `code` in `table`, or the link's own.
fn words(table: &'static [CodeWords], code: u16) -> &'static str {
    CodeWords::find(table, code)
        .or_else(|| CodeWords::find(&LINK_JOB_REFUSALS, code))
        .map_or("a refusal the machine does not describe", |c| c.words)
}

/// The Keops slave's check of one part, `context` carrying what a part loaded before it
/// left (where a program of moves goes on).
fn check_keops(file: &JobFile<'_>, context: &mut SlaveJobContext) -> Result<Checked, CheckError> {
    let mut job = Box::<DeltaJob>::default();
    Keops::load_job(context, file, &mut job).map_err(refused::<Keops>)?;
    let context = &context.defaults;
    let cut_m: Vec<[f64; 2]> = (0..=PREVIEW_POINTS)
        .filter_map(|i| job.contour_point_m(i as f64 / PREVIEW_POINTS as f64))
        .map(|p| [p[0], p[1]])
        .collect();
    let cut_length_m = cut_m
        .windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum();
    let height_m = context.centre_m[2];
    let centre = [context.centre_m[0], context.centre_m[1]];
    let travels_m = cut_m
        .first()
        .map_or(Vec::new(), |&start| vec![vec![centre, start]]);
    Ok(Checked {
        machine: Machine::KeopsSlave,
        kind: file.kind(),
        parts: 1,
        duration_s: job.duration_s(),
        cut_length_m,
        preview: Some(Preview {
            workspace_m: Vec::new(),
            travels_m,
            closed: vec![job.contour_is_closed() == Some(true)],
            cuts_m: vec![cut_m],
            view: View {
                axes: ["x, mm", "y, mm"],
                section: format!("workspace at z = {:.1} mm", height_m * 1e3),
                cut: "cut, beam on",
                travel: "travel, beam off",
            },
        }),
    })
}

/// The edge of the delta's workspace at `height_m` around `centre` (m): where the
/// inverse kinematics reaches within the carriages' travel (in each of
/// [`OUTLINE_DIRECTIONS`] directions, stepped out 1 mm at a time and bisected to
/// 1 µm). Empty when
/// the centre itself is out of reach.
pub fn workspace_outline(
    machine: &DeltaSlaveConfig,
    centre: [f64; 2],
    height_m: f64,
) -> Vec<[f64; 2]> {
    let Ok(geometry) = DeltaGeometry::<f64>::new(&machine.delta) else {
        return Vec::new();
    };
    outline(centre, |p| {
        geometry
            .inverse(&Vector3::new(p[0], p[1], height_m))
            .is_ok()
    })
}

/// The edge of ARROW's workspace (A eq. 25, the actuators' reach and travel) seen
/// along its tool: x and z at the workspace's centre y0, the platform and the table
/// square to the tool (found as [`workspace_outline`] finds the delta's).
pub fn arrow_outline(config: &ArrowConfig) -> Vec<[f64; 2]> {
    let Ok(geometry) = ArrowGeometry::<f64>::new(config) else {
        return Vec::new();
    };
    let y0 = config.workspace.y0_m;
    outline([0.0, 0.0], |p| {
        geometry
            .check_workspace(&Pose::new(p[0], y0, p[1], 0.0), 0.0)
            .is_ok()
    })
}

/// In each of [`OUTLINE_DIRECTIONS`] directions from `centre` (m), the farthest point
/// `reaches` takes: stepped out 1 mm at a time (to 2 m at most) and the last step
/// bisected to 1 µm. Empty when `centre` itself is out of reach. The region is taken
/// as star-shaped about the centre (both machines' are: boxes cut by reach).
fn outline(centre: [f64; 2], reaches: impl Fn([f64; 2]) -> bool) -> Vec<[f64; 2]> {
    let at = |r: f64, phi: f64| [centre[0] + r * phi.cos(), centre[1] + r * phi.sin()];
    if !reaches(centre) {
        return Vec::new();
    }
    (0..OUTLINE_DIRECTIONS)
        .map(|k| {
            let phi = std::f64::consts::TAU * k as f64 / OUTLINE_DIRECTIONS as f64;
            let (mut inside, mut step) = (0.0, 1e-3);
            while inside < 2.0 && reaches(at(inside + step, phi)) {
                inside += step;
            }
            while step > 1e-6 {
                step /= 2.0;
                if reaches(at(inside + step, phi)) {
                    inside += step;
                }
            }
            at(inside, phi)
        })
        .collect()
}

/// ARROW's program seen along its tool (x right, z up): each run of feed moves one
/// cut, the rapids between them travels.
fn arrow_preview(report: &crate::gcode::GcodeReport) -> Preview {
    let [a, b] = Machine::Arrow.path_plane();
    let xz = |p: &[f64; 3]| [p[a], p[b]];
    let mut cuts_m: Vec<Vec<[f64; 2]>> = Vec::new();
    let mut travels_m: Vec<Vec<[f64; 2]>> = Vec::new();
    let mut cutting = false;
    for (m, path) in report.moves.iter().zip(&report.paths_m) {
        let points: Vec<[f64; 2]> = path.iter().map(xz).collect();
        let feed = m.kind == MoveKind::Feed;
        let list = if feed { &mut cuts_m } else { &mut travels_m };
        match list.last_mut() {
            // A run of moves of one kind is one line.
            Some(last) if feed == cutting => last.extend(points),
            _ => list.push(points),
        }
        cutting = feed;
    }
    let closed = cuts_m
        .iter()
        .map(|c| match (c.first(), c.last()) {
            (Some(a), Some(b)) => (a[0] - b[0]).hypot(a[1] - b[1]) < 1e-6 && c.len() > 2,
            _ => false,
        })
        .collect();
    Preview {
        workspace_m: Vec::new(),
        travels_m,
        cuts_m,
        closed,
        view: View {
            axes: ["x, mm", "z, mm"],
            section: format!(
                "workspace at y = {:.0} mm, seen along the tool",
                ArrowConfig::ARROW.workspace.y0_m * 1e3
            ),
            cut: "feed, tool cutting",
            travel: "rapid, tool clear",
        },
    }
}
