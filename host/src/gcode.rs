//! `kerf gcode`: a G-code program checked as ARROW will check it at load (A §4), with
//! the firmware's own parser and job loader ([`kerf::machines::arrow::product::load_job`])
//! and the capacities of the machine as flashed ([`JOB_MOVES`] moves of
//! [`JOB_POINTS`] points, [`PROGRAM_POINTS`] points read). [`diagnose`] first lists
//! every warning and error of the program in one pass.

use crate::check::{CheckError, Checked, Machine};
use kerf::app::joints::JointJob;
use kerf::kinematics::arrow::{ArrowConfig, ArrowError};
use kerf::machines::arrow::job::ArrowJobErrorKind;
use kerf::machines::arrow::product::{load_job, JOB_MOVES, JOB_POINTS, PROGRAM_POINTS};
use kerf::machines::grinding::product::{load_pass, PASS};
use kerf::machines::single_axis::product::{load_moves, CONFIG as AXIS};
use kerf::trajectory::feed::FeedError;
use kerf::trajectory::gcode::{Diagnostic, GcodeErrorKind, GcodePoint, MoveKind, Parser, Severity};
use kerf::trajectory::task_spline::TaskSplineError;

/// The job as the machine holds it.
pub type Job = kerf::machines::arrow::product::Job<f64>;

/// One rest-to-rest move of a checked program.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MoveReport {
    /// G-code line of its first target.
    pub line: u32,
    /// Feed (`G1`) or rapid (`G0`).
    pub kind: MoveKind,
    /// Points of its spline (the start included).
    pub points: usize,
    /// Path length, m.
    pub length_m: f64,
    /// Cruise speed, m/s.
    pub speed_m_s: f64,
    /// Duration with its S-curve ramps, s.
    pub duration_s: f64,
}

/// Points a move's path is sampled at per spline segment ([`GcodeReport::paths_m`]).
pub const PATH_SAMPLES_PER_SEGMENT: usize = 16;

/// A program the machine accepts.
#[derive(Clone, Debug, PartialEq)]
pub struct GcodeReport {
    /// Its moves, in order.
    pub moves: Vec<MoveReport>,
    /// Each move's path as the machine follows it (its spline), x, y, z in m, sampled
    /// [`PATH_SAMPLES_PER_SEGMENT`] times a segment, both ends included.
    pub paths_m: Vec<Vec<[f64; 3]>>,
    /// Total path length, m.
    pub length_m: f64,
    /// Total duration, s (whole control periods).
    pub duration_s: f64,
    /// Its first point, where the machine must stand to start it: x, y, z in m, A and
    /// B in rad.
    pub start: [f64; 5],
    /// Its last point, where it leaves the machine (as `start`).
    pub end: [f64; 5],
}

/// A refused program: where and why. `column` is 1-based; it is 1 where the cause is
/// the whole line (the loader's path checks name a line, not a column); `line` is 0
/// where no line is to blame (an empty program, a bad machine configuration).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{line}:{column}: {message}")]
pub struct GcodeCheckError {
    /// 1-based line (0: none).
    pub line: u32,
    /// 1-based byte column.
    pub column: u32,
    /// What is wrong.
    pub message: String,
}

/// Checks `text` for ARROW's preset machine (module docs).
pub fn check(text: &[u8]) -> Result<GcodeReport, GcodeCheckError> {
    let mut points = Box::new(heapless::Vec::<GcodePoint, PROGRAM_POINTS>::new());
    let mut job = Box::<Job>::default();
    load_job(text, &mut points, &mut job).map_err(|e| {
        let (column, message) = match e.kind {
            ArrowJobErrorKind::Gcode { kind, column } => (column.max(1), describe_gcode(kind)),
            other => (1, describe_job(other)),
        };
        GcodeCheckError {
            line: e.line,
            column,
            message,
        }
    })?;
    let moves: Vec<MoveReport> = job
        .moves()
        .iter()
        .map(|m| MoveReport {
            line: m.line,
            kind: points
                .iter()
                .find(|p| p.line == m.line)
                .map_or(MoveKind::Feed, |p| p.kind),
            points: m.spline.points(),
            length_m: m.plan.length_m,
            speed_m_s: m.plan.speed_m_s,
            duration_s: m.plan.duration_s(),
        })
        .collect();
    let paths_m = job
        .moves()
        .iter()
        .map(|m| {
            let spline = &m.spline;
            let at = |i: usize, t: f64| {
                let p = spline.evaluate(i, t).position;
                [p[0], p[1], p[2]]
            };
            let mut path: Vec<[f64; 3]> = (0..spline.segments())
                .flat_map(|i| {
                    let h = spline.segment_parameter(i);
                    (0..PATH_SAMPLES_PER_SEGMENT)
                        .map(move |k| (i, h * k as f64 / PATH_SAMPLES_PER_SEGMENT as f64))
                })
                .map(|(i, t)| at(i, t))
                .collect();
            let last = spline.segments().saturating_sub(1);
            path.push(at(last, spline.segment_parameter(last)));
            path
        })
        .collect();
    let axes = |p: Option<&GcodePoint>| {
        p.map_or([0.0; 5], |p| {
            let ([x, y, z], [a, b]) = (p.position_m, p.angles_rad);
            [x, y, z, a, b]
        })
    };
    Ok(GcodeReport {
        start: axes(points.first()),
        end: axes(points.last()),
        paths_m,
        length_m: moves.iter().map(|m| m.length_m).sum(),
        duration_s: job.periods() as f64 * job.period_s(),
        moves,
    })
}

/// Checks `text` for the grinding cell or the single axis with the machine's own
/// loader ([`crate::check`]): a refusal in the machine's words at the line its loader
/// names (column 1: the loader blames a line).
///
/// Errors: the refusal; for ARROW and the Keops slave, which have their own checks
/// ([`check`], [`crate::laser`]), that this is not one.
pub fn check_on(machine: Machine, text: &[u8]) -> Result<Checked, GcodeCheckError> {
    let whole = |message: String| GcodeCheckError {
        line: 0,
        column: 1,
        message,
    };
    let bytes = crate::job::Job::Gcode {
        text: text.to_vec(),
    }
    .to_bytes()
    .map_err(|e| whole(e.to_string()))?;
    let line = || match machine {
        Machine::Grinding => load_pass(&PASS, text).err().map(|e| e.line),
        Machine::SingleAxis => {
            let mut job = Box::<JointJob<1>>::default();
            load_moves(&AXIS, text, &mut job).err().map(|e| e.line)
        }
        Machine::Arrow | Machine::KeopsSlave => None,
    };
    match machine {
        Machine::Grinding | Machine::SingleAxis => crate::check::check(&bytes, Some(machine))
            .map_err(|e| GcodeCheckError {
                line: line().unwrap_or(0),
                column: 1,
                message: match e {
                    CheckError::Refused { words, .. } => words.to_owned(),
                    other => other.to_string(),
                },
            }),
        Machine::Arrow | Machine::KeopsSlave => Err(whole(format!(
            "{} has its own G-code check",
            machine.name()
        ))),
    }
}

/// Every point and every warning and error of `text`, read line by line with the
/// firmware's reader for all five axes, however many points it has (no buffer limit:
/// a program longer than a machine holds goes as parts, [`crate::arrow_parts`]).
pub fn read_all(text: &[u8]) -> (Vec<GcodePoint>, Vec<Diagnostic>) {
    let mut parser = Parser::new();
    let (mut points, mut found) = (Vec::new(), Vec::new());
    for line in text.split(|&b| b == b'\n') {
        parser.read_line(
            line,
            &mut |p| {
                points.push(*p);
                true
            },
            &mut |d| found.push(*d),
        );
    }
    (points, found)
}

/// Every warning and error of `text` ([`read_all`]), in the order of the file.
pub fn diagnose(text: &[u8]) -> Vec<Diagnostic> {
    read_all(text).1
}

/// `FILE:LINE:COLUMN: warning|error: message`, as compilers print.
pub fn format_diagnostic(file: &str, d: &Diagnostic) -> String {
    format!("{file}:{d}")
}

/// Whether any of `found` is an error.
pub fn has_errors(found: &[Diagnostic]) -> bool {
    found.iter().any(|d| d.severity() == Severity::Error)
}

/// The parser's refusal in words.
pub fn describe_gcode(kind: GcodeErrorKind) -> String {
    match kind {
        GcodeErrorKind::TooManyPoints => format!(
            "more than {PROGRAM_POINTS} points (the machine's buffer): `kerf gcode` writes \
             a longer program as parts"
        ),
        other => other.to_string(),
    }
}

/// Where ARROW's preset workspace ends on each axis of [`ArrowError::OutsideWorkspace`],
/// in the units a program uses (mm, degrees).
fn workspace_words(axis: u8) -> String {
    let w = ArrowConfig::ARROW.workspace;
    let mm = |m: f64| m * 1e3;
    match axis {
        0 => format!(
            "an actuator would run past the end of its rail (±{:.0} mm of travel)",
            mm(w.q_half_m)
        ),
        1 => format!(
            "Y must stay between {:.0} and {:.0} mm",
            mm(w.y0_m - w.y_half_m),
            mm(w.y0_m + w.y_half_m)
        ),
        2 => format!("Z must stay within ±{:.0} mm", mm(w.z_half_m)),
        3 => format!(
            "the tool's rotation B must stay within ±{:.0}°",
            w.theta_z_half_rad.to_degrees()
        ),
        _ => format!(
            "the turntable A must stay within ±{:.0}°",
            w.theta_x_half_rad.to_degrees()
        ),
    }
}

/// Why ARROW cannot take a pose, in words.
fn pose_words(e: ArrowError) -> String {
    match e {
        ArrowError::OutsideWorkspace(axis) => {
            format!("the path leaves the workspace: {}", workspace_words(axis))
        }
        ArrowError::OutOfReach(i) => format!("arm {} cannot reach the tool there", i + 1),
        ArrowError::ArmAcrossRails(i) | ArrowError::ArmVertical(i) => format!(
            "arm {} reaches a singular pose there (its actuator no longer moves the tool)",
            i + 1
        ),
        ArrowError::PlateSingular => {
            "the tool plate reaches a singular pose there (it could no longer be held)".into()
        }
        ArrowError::NotFinite => "a coordinate is not a number".into(),
        ArrowError::NotConverged | ArrowError::InconsistentJoints => {
            "the machine cannot solve the pose there".into()
        }
    }
}

/// The loader's refusal of a parsed program in words (no equation numbers, no type
/// names: what a machinist can act on).
pub fn describe_job(kind: ArrowJobErrorKind) -> String {
    match kind {
        ArrowJobErrorKind::Gcode { kind, .. } => describe_gcode(kind),
        ArrowJobErrorKind::Empty => "the program has no move".into(),
        ArrowJobErrorKind::TooLarge => format!(
            "more than {JOB_MOVES} moves, or more than {JOB_POINTS} points in one move: \
             `kerf gcode` writes a longer program as parts"
        ),
        ArrowJobErrorKind::Spline(e) => match e {
            TaskSplineError::Config(e) => format!("the move's spline: {e}"),
            TaskSplineError::TooFewPoints => "the move has fewer than 2 points".into(),
            TaskSplineError::Capacity => {
                format!("more than {JOB_POINTS} points in one move")
            }
            TaskSplineError::NotFinitePoint(_) => "a coordinate is not a number".into(),
            TaskSplineError::RepeatedPoint(_) => {
                "the tool point does not move between this point and the one before (a \
                 move of A or B alone, or to the same point): the machine's moves follow \
                 the tool point's path"
                    .into()
            }
            TaskSplineError::NotRepresentable => {
                "the move's points lie too close together to be followed".into()
            }
        },
        ArrowJobErrorKind::Feed(FeedError::Config(e)) => format!("the move's feed: {e}"),
        ArrowJobErrorKind::Feed(FeedError::TooLong) => {
            "the move takes longer than the machine can count (2^31 control periods)".into()
        }
        ArrowJobErrorKind::Feed(FeedError::NoLength | FeedError::Lost) => {
            "the move has no length the machine can follow".into()
        }
        ArrowJobErrorKind::Workspace(e) => pose_words(e),
        ArrowJobErrorKind::Singular => {
            "the path comes too near a singular pose (an arm across its rails or upright, \
             or the plate's arms in one plane)"
                .into()
        }
        ArrowJobErrorKind::Config(e) => format!("the machine's configuration: {e}"),
    }
}
