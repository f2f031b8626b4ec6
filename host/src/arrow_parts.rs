//! ARROW's programs of any length: a G-code program read on the host, placed in the
//! machine's workspace and cut into parts the machine holds, each a G-code program of
//! its own that starts where the part before it ends.
//!
//! ARROW plans a whole job at load ([`kerf::machines::arrow::job`]): at most
//! [`JOB_MOVES`] rest-to-rest moves, [`JOB_POINTS`] points in one move,
//! [`PROGRAM_POINTS`] points read and [`LINK_JOB_BYTES`] bytes uploaded. A longer
//! program is read here with the firmware's reader and written again as parts, every
//! point at full precision (1 nm, 10⁻⁶°) in absolute millimetres, so the machine
//! reads the same points whatever modes, units and offsets the program used:
//!
//! - A part ends where the next move would not fit. A move never spans two parts
//!   unless it alone is larger than a part: it is then cut at its sharpest corner in
//!   the second half of what fits, where the tool turns anyway, and the machine stops
//!   there ([`ArrowProgram::stops`] names the lines). Every other part boundary falls
//!   between two moves, where the machine stops anyway (its moves are rest-to-rest).
//! - A move to where the tool already is (a repeated point) is left out
//!   ([`ArrowProgram::left_out`]); the machine's spline needs a direction at every
//!   point.
//! - The program starts from [`HOME`], where the machine stands when switched on: when
//!   its first point lies elsewhere, a rapid move from home to it comes first.
//! - A program written for a three-axis mill ([`Placement::mill`]: Z is its tool axis,
//!   cutting deeper as Z falls) is turned onto ARROW, whose tool points along +y
//!   towards the part: the program's X is the machine's x, its Y the machine's z, its
//!   Z the machine's −y, and its zero sits at the workspace's centre (x = 0, y = y0,
//!   z = 0). The turn is a rotation (a quarter turn about x): arcs keep their sense.
//! - With [`Placement::centre`], the program is moved so that the box around its
//!   points is centred on the workspace's centre, as a work offset (`G54`) set for the
//!   part would do: programs written about their own zero fit.
//!
//! Each part is checked by the machine's own loader ([`crate::gcode::check`]); a
//! refusal names the line of the original program.

use crate::gcode::{check, GcodeCheckError, GcodeReport};
use kerf::kinematics::arrow::ArrowConfig;
use kerf::machines::arrow::product::{HOME, JOB_MOVES, JOB_POINTS, LINK_JOB_BYTES, PROGRAM_POINTS};
use kerf::trajectory::gcode::{GcodePoint, MoveKind};
use std::fmt::Write as _;

/// Where a program goes in ARROW's workspace (module docs).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct Placement {
    /// The box around its points centred on the workspace's centre.
    pub centre: bool,
    /// Written for a three-axis mill: its Z turned onto ARROW's tool axis.
    pub mill: bool,
}

/// One part: its program and what the machine's loader made of it.
#[derive(Clone, Debug, PartialEq)]
pub struct ArrowPart {
    /// Its G-code program.
    pub text: Vec<u8>,
    /// The lines of the original program its moves come from (first, last).
    pub lines: [u32; 2],
    /// The machine's check of it, its moves named by their lines in the original.
    pub report: GcodeReport,
}

/// A program as ARROW runs it: its parts in order.
#[derive(Clone, Debug, PartialEq)]
pub struct ArrowProgram {
    /// The parts.
    pub parts: Vec<ArrowPart>,
    /// How far the program was moved (`centre`), x, y, z in m.
    pub shift_m: [f64; 3],
    /// Whether it was turned from a mill's axes ([`Placement::mill`]).
    pub mill: bool,
    /// Whether a rapid move from [`HOME`] to the program's first point was added.
    pub from_home: bool,
    /// Lines where a move too long for one part was cut (the machine stops there).
    pub stops: Vec<u32>,
    /// Lines whose move goes nowhere (to the point before it), left out.
    pub left_out: Vec<u32>,
}

impl ArrowProgram {
    /// Total duration, s.
    pub fn duration_s(&self) -> f64 {
        self.parts.iter().map(|p| p.report.duration_s).sum()
    }

    /// Total path length, m.
    pub fn length_m(&self) -> f64 {
        self.parts.iter().map(|p| p.report.length_m).sum()
    }

    /// The parts' job files back to back ([`crate::job::split`] reads them apart).
    pub fn to_bytes(&self) -> Result<Vec<u8>, crate::job::JobFileError> {
        let mut out = Vec::new();
        for part in &self.parts {
            let job = crate::job::Job::Gcode {
                text: part.text.clone(),
            };
            out.extend(job.to_bytes()?);
        }
        Ok(out)
    }

    /// The job file of the program `text` this was made of: the program as written
    /// where the machine takes it so (one part, from where it is written, nothing left
    /// out), else its parts ([`ArrowProgram::to_bytes`]).
    pub fn job_file(&self, text: &[u8]) -> Result<Vec<u8>, crate::job::JobFileError> {
        let as_written = self.parts.len() == 1
            && !self.from_home
            && self.shift_m == [0.0; 3]
            && self.left_out.is_empty();
        if as_written {
            crate::job::Job::Gcode {
                text: text.to_vec(),
            }
            .to_bytes()
        } else {
            self.to_bytes()
        }
    }
}

/// Bytes of a part's text: the upload buffer less the job file's header and settings
/// (64 bytes is more than the format's 12 + settings + 4).
const TEXT_BYTES: usize = LINK_JOB_BYTES - 64;

/// A point as the parts carry it: x, y, z in m, A, B in rad, its kind and feed, and
/// the line it came from (0 for home).
#[derive(Copy, Clone, Debug, PartialEq)]
struct Point {
    axes: [f64; 5],
    kind: MoveKind,
    feed_m_s: f64,
    line: u32,
}

impl Point {
    fn of(p: &GcodePoint) -> Self {
        let [x, y, z] = p.position_m;
        let [a, b] = p.angles_rad;
        Point {
            axes: [x, y, z, a, b],
            kind: p.kind,
            feed_m_s: p.feed_m_s,
            line: p.line,
        }
    }

    /// What makes consecutive points one move of the machine (its loader's rule).
    fn run_key(&self) -> (MoveKind, u64) {
        match self.kind {
            MoveKind::Rapid => (MoveKind::Rapid, 0),
            MoveKind::Feed => (MoveKind::Feed, self.feed_m_s.to_bits()),
        }
    }
}

/// A number as a part writes it: six decimals, trailing zeros dropped.
fn number(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    match s {
        "-0" | "" => "0".into(),
        s => s.into(),
    }
}

/// What a part's writer has said so far (G-code is modal: a word is written when it
/// changes).
#[derive(Copy, Clone)]
struct Modal {
    axes: Option<[f64; 5]>,
    kind: Option<MoveKind>,
    feed_m_s: Option<f64>,
}

impl Modal {
    const NONE: Self = Modal {
        axes: None,
        kind: None,
        feed_m_s: None,
    };

    /// The line that moves to `p` (with its `\n`), and the state after it.
    fn line(mut self, p: &Point) -> (String, Self) {
        let mut out = String::new();
        if self.kind != Some(p.kind) {
            out.push_str(match p.kind {
                MoveKind::Rapid => "G0",
                MoveKind::Feed => "G1",
            });
        }
        for (k, letter) in ['X', 'Y', 'Z', 'A', 'B'].iter().enumerate() {
            let v = p.axes[k];
            if self.axes.is_none_or(|a| a[k] != v) {
                let shown = if k < 3 { v * 1e3 } else { v.to_degrees() };
                let _ = write!(out, " {letter}{}", number(shown));
            }
        }
        if p.kind == MoveKind::Feed && self.feed_m_s != Some(p.feed_m_s) {
            let _ = write!(out, " F{}", number(p.feed_m_s * 6e4));
            self.feed_m_s = Some(p.feed_m_s);
        }
        out = out.trim_start().to_owned();
        out.push('\n');
        self.axes = Some(p.axes);
        self.kind = Some(p.kind);
        (out, self)
    }
}

/// The lines before a part's start point.
const PREAMBLE: &str = "G21 G90 G94\n";

/// The line that puts a part's start `p` (every axis, as a rapid), and the state after.
fn start_line(p: &Point) -> (String, Modal) {
    Modal::NONE.line(&Point {
        kind: MoveKind::Rapid,
        ..*p
    })
}

/// Where the part that starts at `all[s]` ends, and whether it cuts a move (module
/// docs).
fn part_end(all: &[Point], s: usize) -> (usize, bool) {
    let (start_line, mut modal) = start_line(&all[s]);
    // The heading comment: some 60 bytes.
    let mut bytes = 64 + PREAMBLE.len() + start_line.len();
    let (mut targets, mut moves, mut run_first) = (0usize, 0usize, s + 1);
    for i in s + 1..all.len() {
        let p = &all[i];
        let new_run = targets == 0 || p.run_key() != all[i - 1].run_key();
        let (line, next) = modal.line(p);
        let full = (new_run && moves == JOB_MOVES)
            || (!new_run && i - run_first >= JOB_POINTS - 1)
            || targets == PROGRAM_POINTS - 1
            || bytes + line.len() > TEXT_BYTES;
        if full {
            if new_run {
                return (i - 1, false);
            }
            if moves > 1 {
                return (run_first - 1, false);
            }
            return (sharpest(all, run_first + (i - run_first) / 2, i - 1), true);
        }
        if new_run {
            moves += 1;
            run_first = i;
        }
        targets += 1;
        bytes += line.len();
        modal = next;
    }
    (all.len() - 1, false)
}

/// Of `all[lo..=hi]` (each with a point before and after it), the one where the path
/// turns most.
fn sharpest(all: &[Point], lo: usize, hi: usize) -> usize {
    let turn = |j: usize| {
        let d = |a: &Point, b: &Point| -> [f64; 3] {
            [
                b.axes[0] - a.axes[0],
                b.axes[1] - a.axes[1],
                b.axes[2] - a.axes[2],
            ]
        };
        let (u, v) = (d(&all[j - 1], &all[j]), d(&all[j], &all[j + 1]));
        let dot: f64 = u.iter().zip(&v).map(|(a, b)| a * b).sum();
        let norm = |w: [f64; 3]| w.iter().map(|c| c * c).sum::<f64>().sqrt();
        // The cosine of the turn: least where it turns most.
        dot / (norm(u) * norm(v)).max(f64::MIN_POSITIVE)
    };
    (lo..=hi)
        .min_by(|&a, &b| turn(a).total_cmp(&turn(b)))
        .unwrap_or(hi)
}

/// The lines of the original program the moves of `all[s..=e]` come from (first,
/// last).
fn lines_of(all: &[Point], s: usize, e: usize) -> [u32; 2] {
    let lines = || all[s + 1..=e].iter().map(|p| p.line);
    [lines().min().unwrap_or(0), lines().max().unwrap_or(0)]
}

/// The text of the part `all[s..=e]`, part `k` of `of`, from the program's `lines`.
fn part_text(
    all: &[Point],
    s: usize,
    e: usize,
    [first, last]: [u32; 2],
    k: usize,
    of: usize,
) -> Vec<u8> {
    let mut out = format!("(part {k} of {of}: lines {first} to {last} of the program)\n{PREAMBLE}");
    let (line, mut modal) = start_line(&all[s]);
    out.push_str(&line);
    for p in &all[s + 1..=e] {
        let (line, next) = modal.line(p);
        out.push_str(&line);
        modal = next;
    }
    out.into_bytes()
}

/// Line of a part's text on which `all[s]`'s own point is written (its start): the
/// heading comment, the modes, then the points.
const START_LINE: u32 = 3;

/// `text` as ARROW's parts (module docs), each checked by the machine's loader.
///
/// Errors: the program's first error as it reads (a line is never left out for one);
/// the program has no move; a part the machine refuses, at the line of the original
/// program the refusal names.
pub fn parts(text: &[u8], placement: Placement) -> Result<ArrowProgram, GcodeCheckError> {
    let (read, found) = crate::gcode::read_all(text);
    if let Some(d) = found
        .iter()
        .find(|d| d.severity() == kerf::trajectory::gcode::Severity::Error)
    {
        return Err(GcodeCheckError {
            line: d.line,
            column: d.column,
            message: crate::gcode::describe_gcode(d.kind),
        });
    }
    let mut left_out = Vec::new();
    let mut all: Vec<Point> = Vec::with_capacity(read.len() + 1);
    let y0_m = ArrowConfig::ARROW.workspace.y0_m;
    for mut p in read.iter().map(Point::of) {
        if placement.mill {
            let [x, y, z, _, _] = p.axes;
            p.axes[..3].copy_from_slice(&[x, y0_m - z, y]);
        }
        if all.last().is_some_and(|q| q.axes == p.axes) {
            left_out.push(p.line);
        } else {
            all.push(p);
        }
    }
    let shift_m = match (placement.centre, all.is_empty()) {
        (true, false) => {
            let mid = |k: usize| {
                let lo = all.iter().map(|p| p.axes[k]).fold(f64::INFINITY, f64::min);
                let hi = all
                    .iter()
                    .map(|p| p.axes[k])
                    .fold(f64::NEG_INFINITY, f64::max);
                (lo + hi) / 2.0
            };
            [-mid(0), y0_m - mid(1), -mid(2)]
        }
        _ => [0.0; 3],
    };
    for p in &mut all {
        for (a, d) in p.axes.iter_mut().zip(shift_m) {
            *a += d;
        }
    }
    // Within a nanometre (the parser's mm → m rounding): the pyramid starts there.
    let from_home = all
        .first()
        .is_some_and(|p| p.axes.iter().zip(HOME).any(|(a, h)| (a - h).abs() > 1e-9));
    if from_home {
        all.insert(
            0,
            Point {
                axes: HOME,
                kind: MoveKind::Rapid,
                feed_m_s: 0.0,
                line: 0,
            },
        );
    }
    if all.len() < 2 {
        return Err(GcodeCheckError {
            line: read.first().map_or(0, |p| p.line),
            column: 1,
            message: "the program has no move".into(),
        });
    }
    let mut bounds = Vec::new();
    let mut stops = Vec::new();
    let mut s = 0;
    while s + 1 < all.len() {
        let (e, cut) = part_end(&all, s);
        if cut {
            stops.push(all[e].line);
        }
        bounds.push((s, e));
        s = e;
    }
    let of = bounds.len();
    let mut parts = Vec::with_capacity(of);
    for (k, &(s, e)) in bounds.iter().enumerate() {
        let lines = lines_of(&all, s, e);
        let text = part_text(&all, s, e, lines, k + 1, of);
        // A line of the part is one of its points (the original's line), or its
        // heading (the part's first line); home has none (the part's first).
        let original = |line: u32| {
            let point = line.checked_sub(START_LINE).map(|j| s + j as usize);
            point
                .and_then(|i| all.get(i))
                .map_or(0, |p| p.line)
                .max(lines[0])
        };
        let mut report = check(&text).map_err(|mut error| {
            error.line = original(error.line);
            error.column = 1;
            error
        })?;
        for m in &mut report.moves {
            m.line = original(m.line);
        }
        parts.push(ArrowPart {
            text,
            lines,
            report,
        });
    }
    Ok(ArrowProgram {
        parts,
        mill: placement.mill,
        shift_m,
        from_home,
        stops,
        left_out,
    })
}
