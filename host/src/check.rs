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
//!   column of the first problem, the job's moves and duration).
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
use kerf::codec::job::JobFile;
use kerf::codec::link::{CodeWords, LINK_JOB_REFUSALS};
use kerf::kinematics::delta::DeltaGeometry;
use kerf::machines::delta_slave::product::{contour_defaults, JOB_LAPS};
use kerf::machines::delta_slave::{DeltaJob, DeltaSlave, DeltaSlaveConfig};
use nalgebra::Vector3;

/// The machines a job can be checked for on the host (on the command line by the
/// names `keops-slave` and `arrow`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Machine {
    /// The Keops slave, the laser delta: contours (EFD and points files).
    KeopsSlave,
    /// ARROW: G-code programs.
    Arrow,
}

/// Every machine [`Machine`] names, in the order the help lists them.
pub const MACHINES: [Machine; 2] = [Machine::KeopsSlave, Machine::Arrow];

/// The Keops slave as the link and the board images run it (its scalar).
type Keops = DeltaSlave<f32>;
/// ARROW as the link runs it.
type ArrowMachine = kerf::machines::arrow::product::Arrow<f32>;

impl Machine {
    /// The name the machine announces on the link.
    pub fn name(self) -> &'static str {
        match self {
            Machine::KeopsSlave => Keops::NAME,
            Machine::Arrow => ArrowMachine::NAME,
        }
    }

    /// The job kinds it takes.
    pub fn kinds(self) -> &'static [JobKind] {
        match self {
            Machine::KeopsSlave => Keops::JOB_KINDS,
            Machine::Arrow => ArrowMachine::JOB_KINDS,
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
    }
}

/// What a preview draws, in the workspace's x and y (m).
#[derive(Clone, Debug, PartialEq)]
pub struct Preview {
    /// Where the workspace ends at the cutting height (closed; reach and carriage
    /// travel), m; found once for a program ([`workspace_outline`]).
    pub workspace_m: Vec<[f64; 2]>,
    /// The beam-off travels: to the first part's start from the workspace's centre,
    /// then from each part's end to the next one's start, m.
    pub travels_m: Vec<[[f64; 2]; 2]>,
    /// The cuts, beam on, one per part in order, m.
    pub cuts_m: Vec<Vec<[f64; 2]>>,
    /// Whether each part is a closed contour.
    pub closed: Vec<bool>,
    /// The cutting height, m.
    pub height_m: f64,
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
    /// Length of the cut (one lap of a closed contour), m.
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
    for (k, part) in parts.into_iter().enumerate() {
        let machine = machine.or(all.as_ref().map(|c| c.machine));
        let checked = check_part(part, machine).map_err(|error| match of {
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
        let config = DeltaSlaveConfig::KEOPS;
        let centre = contour_defaults(&config, JOB_LAPS).centre_m;
        preview.workspace_m = workspace_outline(&config, [centre[0], centre[1]], centre[2]);
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
                    a.travels_m.push([end, start]);
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

/// Checks one job file for `machine`, or for the machine that takes its kind.
fn check_part(bytes: &[u8], machine: Option<Machine>) -> Result<Checked, CheckError> {
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
            Ok(Checked {
                machine,
                kind,
                parts: 1,
                duration_s: report.duration_s,
                cut_length_m: report.length_m,
                preview: None,
            })
        }
        // ARROW's kinds are G-code only: refused above, refused the same here.
        (Machine::Arrow, _) => Err(kind_refused(machine, kind)),
        (Machine::KeopsSlave, file) => check_keops(&file),
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

fn check_keops(file: &JobFile<'_>) -> Result<Checked, CheckError> {
    let machine = DeltaSlaveConfig::KEOPS;
    let context = contour_defaults(&machine, JOB_LAPS);
    let mut job = Box::<DeltaJob>::default();
    Keops::load_job(&context, file, &mut job).map_err(|code| CheckError::Refused {
        machine: Keops::NAME,
        code,
        words: words(Keops::JOB_REFUSALS, code),
    })?;
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
        .map_or(Vec::new(), |&start| vec![[centre, start]]);
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
            height_m,
        }),
    })
}

/// The edge of the delta's workspace at `height_m` around `centre` (m): in each of
/// [`OUTLINE_DIRECTIONS`] directions, the farthest point the inverse kinematics
/// reaches within the carriages' travel, found by stepping out 1 mm at a time and
/// bisecting the last step to 1 µm. Empty when the centre itself is out of reach.
pub fn workspace_outline(
    machine: &DeltaSlaveConfig,
    centre: [f64; 2],
    height_m: f64,
) -> Vec<[f64; 2]> {
    let Ok(geometry) = DeltaGeometry::<f64>::new(&machine.delta) else {
        return Vec::new();
    };
    let at = |r: f64, phi: f64| [centre[0] + r * phi.cos(), centre[1] + r * phi.sin()];
    let reaches = |p: [f64; 2]| {
        geometry
            .inverse(&Vector3::new(p[0], p[1], height_m))
            .is_ok()
    };
    if !reaches(centre) {
        return Vec::new();
    }
    (0..OUTLINE_DIRECTIONS)
        .map(|k| {
            let phi = std::f64::consts::TAU * k as f64 / OUTLINE_DIRECTIONS as f64;
            let (mut inside, mut step) = (0.0, 1e-3);
            // Out to a metre at most: the Keops workspace is tens of millimetres.
            while inside < 1.0 && reaches(at(inside + step, phi)) {
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
