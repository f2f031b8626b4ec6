//! Laser G-code for the Keops slave (`kerf gcode --machine keops-slave`): a program
//! read with the firmware's own G-code reader (`kerf::trajectory::gcode::Parser`, line
//! by line, no buffer limit) and cut as the parts of one job ([`crate::parts`]'s
//! format: the parts' job files back to back).
//!
//! A run is a run of feed moves (`G1`, arcs as their chords) with the beam on: `M3` or
//! `M4` with `S` above zero. It starts where the beam comes on and ends where it goes
//! off (`M5`, `S0`), at a rapid move (`G0`: a travel, beam off), or at the end. A run
//! that ends where it began (within 1 µm) is closed.
//!
//! How a run becomes parts ([`Corners`]): by default as the program draws it, straight
//! moves with sharp corners, each at its own feed, planned by the slave's look-ahead
//! planner (a moves job of at most 32 points; a longer run is cut as parts of 24
//! points and 8 more of the next part's, the look-ahead: the machine plans each part
//! to go on at speed into the next, and does so when it has the next part in time,
//! stopping in the look-ahead, beam off, when it has not). Or fitted with a smooth
//! curve: a closed run an EFD of [`PlanConfig`]'s harmonics, an open one the
//! firmware's spline through at most 32 of its points, chosen along the path sampled
//! every [`SAMPLE_MM`]; each fit is measured against the program's path (both ways,
//! brute force), since the program's sharp corners come out rounded by that much.
//!
//! Each part carries its cut settings from the program ([`Beam`]): the speed (for
//! moves the fastest move's feed, which caps the others; for a fit the feed `F` of its
//! first move), and the laser `S` of `S_max` of the source's power, held constant
//! under `M3` and as energy per length under `M4` (grbl's laser mode: the power scaled
//! with the speed, `S` at the programmed feed), so `P/F`.
//!
//! A power that changes within a run (`S`, or `M3`/`M4`) ends a run there, and the
//! next run, at its own power, is joined to it ([`LaserRun::joined`]): cut as moves,
//! the two go on into each other without a stop (the streamed parts above); fitted,
//! each is a part of its own. What the slave does not take from the program is said
//! once each: Z (it cuts in its own plane; a fitted part at its first move's feed);
//! `kerf gcode` says where `S` passes `S_max` (full power).
//! `centre` moves the program so that the box around its cuts is centred on the
//! workspace's centre (a laser bed's origin is its corner, the slave's its centre).
//! [`PlanConfig`]'s kerf moves each closed run off its drawn line to the scrap's side,
//! corners sharp, and its lead-in enters each closed run from the scrap
//! (`kerf_and_lead_in`).

use crate::job::{with_settings, Continuity, CutLaser, CutSettings, Job, JobFileError};

use crate::kerf_offset::{offset_polygon, signed_area2};
use crate::plan::{
    self, efd_job, kerf_distance_mm, kerf_sign, path_job, Fit, PlanConfig, PlanError,
};
use kerf::machines::delta_slave::MOVE_POINTS;
use kerf::trajectory::gcode::{Diagnostic, GcodePoint, MoveKind, Parser, Severity, Spindle};

/// Spacing of the points an open path is sampled at before its spline points are
/// chosen, mm.
pub const SAMPLE_MM: f64 = 0.05;

/// A run of the program with the beam on.
#[derive(Clone, Debug, PartialEq)]
pub struct LaserRun {
    /// First and last lines of the file in it.
    pub lines: [u32; 2],
    /// The programmed path, mm (the workspace's x and y).
    pub path_mm: Vec<[f64; 2]>,
    /// The feed of the move ending at each point of the path, m/s (the first point's
    /// 0); a closed run has one more, the feed of the move back to its start.
    pub feeds_m_s: Vec<f64>,
    /// Whether it ends where it began.
    pub closed: bool,
    /// Its first move's feed, m/s.
    pub feed_m_s: f64,
    /// Its first move's `S`, in the program's scale.
    pub s: f64,
    /// Whether the beam is grbl's dynamic power (`M4`) rather than constant (`M3`).
    pub dynamic: bool,
    /// Whether it begins where the run before ends, going on from it without a stop
    /// (the power changed there: `S`, or `M3`/`M4`).
    pub joined: bool,
}

/// How a program's `S` becomes power.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Beam {
    /// `S` of full power (grbl's `$30`, 1000 by default).
    pub s_max: f64,
    /// The source's full power, W.
    pub max_power_w: f64,
}

impl Beam {
    /// `S` of full power when the program's controller says nothing else (grbl's `$30`
    /// default).
    pub const GRBL_S_MAX: f64 = 1000.0;

    /// The Keops slave's laser with full power at `S` = `s_max`.
    pub fn keops(s_max: f64) -> Self {
        Beam {
            s_max,
            max_power_w: kerf::machines::delta_slave::DeltaSlaveConfig::KEOPS
                .laser
                .max_power_w,
        }
    }

    /// The cut settings of `run`: its first move's feed, and `S` as power (`M3`) or as
    /// the energy per length that power gives at the feed (`M4`); `S` past `s_max` is
    /// full power.
    pub fn settings(&self, run: &LaserRun) -> CutSettings {
        let power_w = (run.s / self.s_max).clamp(0.0, 1.0) * self.max_power_w;
        // The reader refuses a feed move before any `F`: a feed is above zero here,
        // and without one the part would be cut at the machine's speed and power.
        let feed = (run.feed_m_s > 0.0).then_some(run.feed_m_s);
        let laser = match feed {
            Some(v) if run.dynamic => CutLaser::EnergyJPerM((power_w / v) as f32),
            _ => CutLaser::PowerW(power_w as f32),
        };
        CutSettings {
            speed_m_s: feed.map(|v| v as f32),
            laser: Some(laser),
            ..CutSettings::MACHINE
        }
    }
}

/// The runs of a program and everything the reader said of it.
#[derive(Clone, Debug, PartialEq)]
pub struct LaserProgram {
    /// The runs with the beam on, in the program's order.
    pub runs: Vec<LaserRun>,
    /// Warnings and errors, in the order of the file.
    pub diagnostics: Vec<Diagnostic>,
    /// What the slave does not take from the program, said once each.
    pub notes: Vec<&'static str>,
}

/// How a run's corners are cut (module docs).
#[derive(Copy, Clone, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Corners {
    /// As programmed: straight moves, sharp corners, each move at its feed.
    Sharp,
    /// Fitted with a smooth curve (an EFD or a spline), at one speed.
    Fit,
}

/// A run (or, as moves, a piece of one) as a part of the job.
#[derive(Clone, Debug)]
pub struct LaserPart {
    /// The run (its path the piece's).
    pub run: LaserRun,
    /// The curve the part carries where it is fitted; `None` for moves.
    pub fit: Option<Fit>,
    /// The part's job file.
    pub job: Job,
    /// Largest distance between the fitted curve and the programmed path, mm (0 for
    /// moves: they are the path).
    pub deviation_mm: f64,
    /// How it is cut, from the program.
    pub settings: CutSettings,
}

/// Reads `text` (module docs). Errors are in the diagnostics; the runs are those of
/// the lines without one.
pub fn read(text: &[u8]) -> LaserProgram {
    let mut parser = Parser::new();
    let mut diagnostics = Vec::new();
    let mut runs: Vec<LaserRun> = Vec::new();
    let mut notes = Vec::new();
    let mut note = |n: &'static str| {
        if !notes.contains(&n) {
            notes.push(n);
        }
    };
    let mut at: Option<[f64; 3]> = None;
    let mut current: Option<LaserRun> = None;
    let mut z: Option<f64> = None;
    let finish = |run: Option<LaserRun>, runs: &mut Vec<LaserRun>| {
        if let Some(mut run) = run.filter(|r| r.path_mm.len() >= 2) {
            let (first, last) = (run.path_mm[0], run.path_mm[run.path_mm.len() - 1]);
            run.closed = !run.joined
                && run.path_mm.len() >= 4
                && (first[0] - last[0]).hypot(first[1] - last[1]) < 1e-3;
            if run.closed {
                // The move back keeps its feed (`feeds_m_s` has one more).
                run.path_mm.pop();
            }
            runs.push(run);
        }
    };
    for line in text.split(|&b| b == b'\n') {
        let mut points: Vec<GcodePoint> = Vec::new();
        parser.read_line(
            line,
            &mut |p| {
                points.push(*p);
                true
            },
            &mut |d| diagnostics.push(*d),
        );
        for p in points {
            let mm = [p.position_m[0] * 1e3, p.position_m[1] * 1e3];
            if z.is_some_and(|z| (z - p.position_m[2]).abs() > 1e-9) {
                note("Z is not followed: the slave cuts in its own plane");
            }
            z = Some(p.position_m[2]);
            let beam_on =
                p.kind == MoveKind::Feed && p.spindle != Spindle::Off && p.spindle_s > 0.0;
            if beam_on {
                let dynamic = p.spindle == Spindle::CounterClockwise;
                // A power change: a run of its own, going on from this one's end.
                let changed = current
                    .as_ref()
                    .is_some_and(|r| (r.s, r.dynamic) != (p.spindle_s, dynamic));
                let joined = changed && current.as_ref().is_some_and(|r| r.path_mm.len() >= 2);
                if changed {
                    finish(current.take(), &mut runs);
                    // The run goes on: the one before ends here, not closed.
                    if let Some(before) = runs.last_mut().filter(|r| joined && r.closed) {
                        before.path_mm.push(before.path_mm[0]);
                        before.closed = false;
                    }
                }
                let run = current.get_or_insert_with(|| {
                    let path_mm: Vec<[f64; 2]> = at
                        .map(|a| vec![[a[0] * 1e3, a[1] * 1e3]])
                        .unwrap_or_default();
                    LaserRun {
                        lines: [p.line, p.line],
                        feeds_m_s: vec![0.0; path_mm.len()],
                        path_mm,
                        closed: false,
                        feed_m_s: p.feed_m_s,
                        s: p.spindle_s,
                        dynamic,
                        joined,
                    }
                });
                run.lines[1] = p.line;
                if run.path_mm.last() != Some(&mm) {
                    run.path_mm.push(mm);
                    run.feeds_m_s.push(p.feed_m_s);
                }
            } else {
                finish(current.take(), &mut runs);
            }
            at = Some(p.position_m);
        }
    }
    finish(current.take(), &mut runs);
    LaserProgram {
        runs,
        diagnostics,
        notes,
    }
}

/// Whether any of the program's diagnostics is an error.
pub fn has_errors(program: &LaserProgram) -> bool {
    program
        .diagnostics
        .iter()
        .any(|d| d.severity() == Severity::Error)
}

/// The program's runs as parts, their corners as `corners` says (module docs), moved
/// to the workspace's centre when `centre` is set.
///
/// Errors: no run with the beam on; a run the firmware's curve code refuses.
pub fn parts(
    program: &LaserProgram,
    config: &PlanConfig,
    centre: bool,
    beam: &Beam,
    corners: Corners,
) -> Result<Vec<LaserPart>, PlanError> {
    if program.runs.is_empty() {
        return Err(PlanError::NoCut);
    }
    let all = program.runs.iter().flat_map(|r| r.path_mm.iter());
    let (lo, hi) = plan::bounds(all);
    let shift = if centre {
        [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0]
    } else {
        [0.0; 2]
    };
    let shifted = |run: &LaserRun| LaserRun {
        path_mm: run
            .path_mm
            .iter()
            .map(|p| [p[0] - shift[0], p[1] - shift[1]])
            .collect(),
        ..run.clone()
    };
    let runs = kerf_and_lead_in(program.runs.iter().map(shifted).collect(), config)?;
    if corners == Corners::Sharp {
        let pieces = pieces(&runs).into_iter();
        return Ok(pieces.map(|run| moves_part(run, beam)).collect());
    }
    runs.iter()
        .map(|run| {
            let path = run.path_mm.clone();
            let (fit, job) = if run.closed {
                efd_job(&path, config.harmonics)?
            } else {
                path_job(&densify(&path, SAMPLE_MM), false)?
            };
            let samples = fit.samples_mm(4096);
            let deviation_mm = plan::deviation(&samples, &path, run.closed)
                .max(plan::deviation(&path, &samples, run.closed));
            Ok(LaserPart {
                run: LaserRun {
                    path_mm: path,
                    ..run.clone()
                },
                fit: Some(fit),
                job,
                deviation_mm,
                settings: beam.settings(run),
            })
        })
        .collect()
}

/// The closed runs of `runs` moved off the drawn line by half the kerf to the scrap's
/// side, corners kept sharp ([`offset_polygon`]; the side alternates from an outline
/// to its holes, [`PlanConfig::kerf_side`]), each move at its feed; then, with a
/// lead-in, each closed run begins with a straight move of [`PlanConfig::lead_in_mm`]
/// from the scrap's side along its first corner's bisector (the run is then open, its
/// start point repeated at its end). Open runs are cut as drawn.
///
/// Errors: an offset that runs into the contour (a gap or neck narrower than the
/// kerf), or a run too small to have one.
fn kerf_and_lead_in(runs: Vec<LaserRun>, config: &PlanConfig) -> Result<Vec<LaserRun>, PlanError> {
    if config.kerf_mm <= 0.0 && config.lead_in_mm <= 0.0 {
        return Ok(runs);
    }
    let closed: Vec<usize> = (0..runs.len()).filter(|&i| runs[i].closed).collect();
    let rings: Vec<Vec<[f64; 2]>> = closed.iter().map(|&i| runs[i].path_mm.clone()).collect();
    let around = crate::parts::enclosing(&rings);
    let mut runs = runs;
    for (k, &i) in closed.iter().enumerate() {
        let depth = around[k].len();
        let run = &mut runs[i];
        let n = run.path_mm.len();
        // The feed of the move ending at corner j (corner 0's: the move back to it).
        let feed_to = |feeds: &[f64], j: usize| match j {
            0 => feeds.get(n).copied().unwrap_or(run.feed_m_s),
            j => feeds.get(j).copied().unwrap_or(run.feed_m_s),
        };
        if config.kerf_mm > 0.0 {
            let moved = offset_polygon(&run.path_mm, kerf_distance_mm(config, depth))?;
            let mut feeds: Vec<f64> = moved
                .iter()
                .map(|&(_, j)| feed_to(&run.feeds_m_s, j))
                .collect();
            let back = feeds.first().copied().unwrap_or(run.feed_m_s);
            if let Some(first) = feeds.first_mut() {
                *first = 0.0;
            }
            feeds.push(back);
            run.path_mm = moved.into_iter().map(|(p, _)| p).collect();
            run.feeds_m_s = feeds;
        }
        if config.lead_in_mm > 0.0 {
            let ring = &run.path_mm;
            let (Some(&start), Some(&next), Some(&before)) =
                (ring.first(), ring.get(1), ring.last())
            else {
                return Err(PlanError::TooSmall(ring.len()));
            };
            let unit = |a: [f64; 2], b: [f64; 2]| {
                let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                let length = dx.hypot(dy).max(f64::MIN_POSITIVE);
                [dx / length, dy / length]
            };
            let (t1, t2) = (unit(before, start), unit(start, next));
            // The outward normal of a counter-clockwise ring is its tangent turned
            // clockwise; the bisector of the two edges' normals, to the scrap's side.
            let outward = signed_area2(ring).signum() * kerf_sign(config, depth);
            let bisector = [t1[1] + t2[1], -(t1[0] + t2[0])];
            let b = unit([0.0; 2], bisector);
            let from = [
                start[0] + outward * config.lead_in_mm * b[0],
                start[1] + outward * config.lead_in_mm * b[1],
            ];
            let first_feed = run.feeds_m_s.get(1).copied().unwrap_or(run.feed_m_s);
            run.path_mm.insert(0, from);
            run.path_mm.push(start);
            run.feeds_m_s.insert(1, first_feed);
            run.closed = false;
        }
    }
    Ok(runs)
}

/// Points of the next piece a piece of a longer run carries as its look-ahead: room
/// to stop in, so the machine plans the piece to go on into the next at speed.
pub const LOOKAHEAD_POINTS: usize = 8;

/// `runs` as pieces of at most [`MOVE_POINTS`] points each. A run, with the runs joined
/// to it (its chain), is cut in pieces of one run each, the next beginning where one's
/// cut ends (a closed run's move back to its start included); a chain of one run that
/// fits one piece is one piece. Otherwise each piece but the chain's last carries up to
/// [`LOOKAHEAD_POINTS`] of the chain's next points after its own as its look-ahead, and
/// each but the first continues the one before (the machine goes on into it without a
/// stop when it has it in time).
fn pieces(runs: &[LaserRun]) -> Vec<(LaserRun, Continuity)> {
    let mut out = Vec::new();
    let mut first = 0;
    while first < runs.len() {
        let last = first + runs[first + 1..].iter().take_while(|r| r.joined).count();
        chain_pieces(&runs[first..=last], &mut out);
        first = last + 1;
    }
    out
}

/// The pieces of one chain of runs (see [`pieces`]) appended to `out`.
fn chain_pieces(chain: &[LaserRun], out: &mut Vec<(LaserRun, Continuity)>) {
    // The chain's path and feeds, and where each run's points begin in it.
    let (mut path, mut feeds, mut begins) = (Vec::new(), Vec::new(), Vec::new());
    for run in chain {
        let mut own = run.path_mm.clone();
        let mut own_feeds = run.feeds_m_s.clone();
        if run.closed {
            own.push(own[0]);
        }
        own_feeds.resize(own.len(), run.feed_m_s);
        // A joined run begins at the end of the one before: its first point is there.
        let skip = usize::from(!path.is_empty());
        begins.push(path.len().saturating_sub(skip));
        path.extend_from_slice(&own[skip..]);
        feeds.extend_from_slice(&own_feeds[skip..]);
    }
    begins.push(path.len() - 1);
    let whole = chain.len() == 1 && path.len() <= MOVE_POINTS;
    let cut_points = if whole {
        MOVE_POINTS
    } else {
        MOVE_POINTS - LOOKAHEAD_POINTS
    };
    for (k, run) in chain.iter().enumerate() {
        let (mut start, run_end) = (begins[k], begins[k + 1]);
        while start < run_end {
            let end = (start + cut_points).min(run_end + 1);
            let ahead = if whole {
                end
            } else {
                (end + LOOKAHEAD_POINTS).min(path.len())
            };
            let mut feeds_m_s = feeds[start..ahead].to_vec();
            feeds_m_s[0] = 0.0;
            let continuity = Continuity {
                lookahead_points: (ahead - end) as u8,
                continues: start > 0,
            };
            out.push((
                LaserRun {
                    path_mm: path[start..ahead].to_vec(),
                    feeds_m_s,
                    closed: run.closed && whole,
                    ..run.clone()
                },
                continuity,
            ));
            start = end - 1;
        }
    }
}

/// A piece of a run as a moves part: its settings the program's, at the speed of its
/// fastest move (its look-ahead's included), in its place in the run.
fn moves_part((run, continuity): (LaserRun, Continuity), beam: &Beam) -> LaserPart {
    let points = run
        .path_mm
        .iter()
        .zip(&run.feeds_m_s)
        .map(|(p, &feed)| [(p[0] * 1e-3) as f32, (p[1] * 1e-3) as f32, feed as f32])
        .collect();
    let fastest = run.feeds_m_s.iter().copied().fold(0.0, f64::max);
    let settings = CutSettings {
        speed_m_s: (fastest > 0.0).then_some(fastest as f32),
        continuity,
        ..beam.settings(&run)
    };
    LaserPart {
        run,
        fit: None,
        job: Job::Moves { points },
        deviation_mm: 0.0,
        settings,
    }
}

/// The job file of `parts`: their files back to back, each with its settings.
pub fn to_bytes(parts: &[LaserPart]) -> Result<Vec<u8>, JobFileError> {
    let mut out = Vec::new();
    for part in parts {
        out.extend(with_settings(&part.job.to_bytes()?, &part.settings)?);
    }
    Ok(out)
}

/// `points` with points added so that no segment is longer than `step`.
fn densify(points: &[[f64; 2]], step: f64) -> Vec<[f64; 2]> {
    let mut out: Vec<[f64; 2]> = points.first().copied().into_iter().collect();
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let n = ((b[0] - a[0]).hypot(b[1] - a[1]) / step).ceil().max(1.0) as usize;
        for k in 1..=n {
            let t = k as f64 / n as f64;
            out.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    }
    out
}
