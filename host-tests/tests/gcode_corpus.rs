//! Real programs (`data/gcode/`, sources in its SOURCES.md) read by the firmware's
//! G-code reader: none has an error, and the end point of every line that moves is
//! where a separate, simpler scan of the file puts it; they and random programs are
//! planned by the look-ahead planner within the machine's limits.

use kerf::trajectory::gcode::{Diagnostic, GcodePoint, MoveKind, Severity};
use kerf::trajectory::planner::{Block, Planner};
use kerf_host::gcode::read_all;
use std::path::PathBuf;

fn corpus() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/gcode");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e != "md"))
        .collect();
    files.sort();
    files
}

/// The scan: comments (and `#` comment lines) dropped, blanks removed, upper case; `G90`/`G91`, `G20`/`G21`
/// and `X Y Z` words tracked (`A B` only move) (the corpus uses no offsets); each line with an axis word
/// gives (line, end point in mm). Arcs end where their axis words say, as lines do.
fn scan(text: &str) -> Vec<(u32, [f64; 3])> {
    let (mut at, mut relative, mut inch) = ([0.0f64; 3], false, false);
    let mut ends = Vec::new();
    for (n, raw) in text.lines().enumerate() {
        // A hobby controller's comment line: `#` and no parameter after it.
        let trimmed = raw.trim_start();
        if trimmed.starts_with('#')
            && !trimmed[1..].starts_with(|c: char| c.is_ascii_digit() || c == '<' || c == '[')
        {
            continue;
        }
        let mut body = String::new();
        let mut depth = false;
        for c in raw.chars() {
            match c {
                ';' if !depth => break,
                '(' => depth = true,
                ')' => depth = false,
                c if !depth && !c.is_whitespace() => body.push(c.to_ascii_uppercase()),
                _ => {}
            }
        }
        let mut words: Vec<(char, f64)> = Vec::new();
        let mut chars = body.chars().peekable();
        while let Some(letter) = chars.next() {
            let mut number = String::new();
            while let Some(&c) = chars.peek().filter(|c| !c.is_ascii_alphabetic()) {
                number.push(c);
                chars.next();
            }
            words.push((letter, number.parse().unwrap_or(f64::NAN)));
        }
        for &(l, v) in &words {
            match (l, v) {
                ('G', 90.0) => relative = false,
                ('G', 91.0) => relative = true,
                ('G', 20.0) => inch = true,
                ('G', 21.0) => inch = false,
                ('G', 92.0 | 53.0 | 55.0 | 56.0 | 57.0 | 58.0 | 59.0) => panic!("offsets"),
                _ => {}
            }
        }
        let mut moved = false;
        for &(l, v) in &words {
            if let Some(i) = "XYZ".find(l) {
                let v = if inch { v * 25.4 } else { v };
                at[i] = if relative { at[i] + v } else { v };
            }
            moved |= "XYZAB".contains(l);
        }
        if words
            .iter()
            .any(|&(l, v)| l == 'M' && (v == 2.0 || v == 30.0))
        {
            break;
        }
        if moved {
            ends.push((n as u32 + 1, at));
        }
    }
    ends
}

#[test]
fn every_corpus_program_loads_without_an_error_and_ends_each_move_where_the_scan_does() {
    let files = corpus();
    assert!(files.len() >= 8, "{files:?}");
    for path in files {
        let text = std::fs::read(&path).unwrap();
        let (points, found) = read_all(&text);
        let name = path.file_name().unwrap().to_string_lossy();
        let errors: Vec<_> = found
            .iter()
            .filter(|d| d.severity() == Severity::Error)
            .collect();
        assert!(errors.is_empty(), "{name}: {errors:?}");
        let ends = scan(&String::from_utf8_lossy(&text));
        println!(
            "{name}: {} lines moving, {} points, {} warnings",
            ends.len(),
            points.len(),
            found.len()
        );
        // The last point of each moving line is the scan's end point.
        let mut lines: Vec<u32> = points.iter().map(|p| p.line).collect();
        lines.dedup();
        let scanned: Vec<u32> = ends.iter().map(|&(l, _)| l).collect();
        assert_eq!(lines, scanned, "{name}");
        for &(line, end) in &ends {
            let last = points.iter().rev().find(|p| p.line == line).unwrap();
            for (got, want) in last.position_m.iter().zip(end) {
                // mm → m: one rounding each side.
                assert!(
                    (got * 1e3 - want).abs() <= 1e-9 * want.abs().max(1.0),
                    "{name}:{line}"
                );
            }
        }
        // The bounding box holds every scanned end; equal to it when no arc bulges.
        for k in 0..3 {
            let lo = points
                .iter()
                .map(|p| p.position_m[k] * 1e3)
                .fold(f64::INFINITY, f64::min);
            let hi = points
                .iter()
                .map(|p| p.position_m[k] * 1e3)
                .fold(f64::NEG_INFINITY, f64::max);
            for &(_, end) in &ends {
                assert!(end[k] >= lo - 1e-9 && end[k] <= hi + 1e-9, "{name}");
            }
        }
    }
}

/// A move of a generated program: a line to (x, y), or an arc (clockwise or not)
/// about the centre at (i, j) from the start, sweeping `sweep` radians.
#[derive(Clone, Debug)]
enum Move {
    Line(f64, f64),
    Arc {
        cw: bool,
        i: f64,
        j: f64,
        sweep: f64,
    },
}

fn moves() -> impl proptest::strategy::Strategy<Value = Vec<Move>> {
    use proptest::prelude::*;
    let line = (-50.0f64..50.0, -50.0f64..50.0).prop_map(|(x, y)| Move::Line(x, y));
    let arc = (
        any::<bool>(),
        1.0f64..20.0,
        0.0f64..std::f64::consts::TAU,
        0.1f64..6.0,
    )
        .prop_map(|(cw, r, at, sweep)| Move::Arc {
            cw,
            i: r * at.cos(),
            j: r * at.sin(),
            sweep,
        });
    proptest::collection::vec(prop_oneof![line, arc], 1..12)
}

/// A generated move as printed: its line, its end point and, for an arc, its centre
/// and radius (mm).
type Printed = (u32, [f64; 2], Option<([f64; 2], f64)>);

/// The program's text (mm, absolute, four decimals as CAM writes them) and its moves
/// as printed.
fn program(moves: &[Move]) -> (String, Vec<Printed>) {
    let round = |v: f64| (v * 1e4).round() / 1e4;
    let mut text = String::from("G21 G90 G17\nG0 X0 Y0\n");
    let mut at = [0.0f64, 0.0];
    let mut ends = Vec::new();
    for (k, m) in moves.iter().enumerate() {
        let line = k as u32 + 3;
        match *m {
            Move::Line(x, y) => {
                let end = [round(x), round(y)];
                text += &format!("G1 X{:.4} Y{:.4} F600\n", end[0], end[1]);
                ends.push((line, end, None));
                at = end;
            }
            Move::Arc { cw, i, j, sweep } => {
                let (i, j) = (round(i), round(j));
                let centre = [at[0] + i, at[1] + j];
                let r = i.hypot(j);
                let start = (-j).atan2(-i);
                let end_angle = if cw { start - sweep } else { start + sweep };
                let end = [
                    round(centre[0] + r * end_angle.cos()),
                    round(centre[1] + r * end_angle.sin()),
                ];
                let code = if cw { 2 } else { 3 };
                text += &format!(
                    "G{code} X{:.4} Y{:.4} I{i:.4} J{j:.4} F600\n",
                    end[0], end[1]
                );
                ends.push((line, end, Some((centre, r))));
                at = end;
            }
        }
    }
    text += "M30\n";
    (text, ends)
}

/// The same program with blanks inside its words and in lower case, as grbl and
/// LinuxCNC accept it.
fn loosened(text: &str, seed: u64) -> String {
    let mut state = seed | 1;
    let mut out = String::new();
    for c in text.chars() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        out.push(if state % 2 == 0 {
            c.to_ascii_lowercase()
        } else {
            c
        });
        if c != '\n' && state % 5 == 0 {
            out.push(' ');
        }
    }
    out
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]

    /// Random valid programs of lines and arcs (I/J form, CW and CCW, up to nearly
    /// a full turn) read without an error; each move ends at its printed end point
    /// (1e-9 m); every point of an arc lies on its circle within the reader's arc
    /// tolerance (max(5 µm, 0.1 % of r), for the four-decimal rounding of the
    /// centre); and the same program loosened (blanks inside words, lower case) reads
    /// to the same points.
    #[test]
    fn random_programs_read_to_their_end_points(moves in moves(), seed in 1u64..u64::MAX) {
        let (text, ends) = program(&moves);
        let (points, found) = read_all(text.as_bytes());
        let errors: Vec<&Diagnostic> =
            found.iter().filter(|d| d.severity() == Severity::Error).collect();
        proptest::prop_assert!(errors.is_empty(), "{errors:?}\n{text}");
        for (line, end, arc) in &ends {
            let of_line: Vec<&GcodePoint> = points.iter().filter(|p| p.line == *line).collect();
            let last = of_line.last().expect("a move gives points");
            for (axis, e) in end.iter().enumerate() {
                proptest::prop_assert!(
                    (last.position_m[axis] - e * 1e-3).abs() < 1e-9,
                    "line {line}: {:?} vs {end:?}\n{text}", last.position_m
                );
            }
            if let Some((centre, r)) = arc {
                let tolerance = (5e-3f64).max(1e-3 * r) * 1e-3;
                for p in &of_line {
                    let d = (p.position_m[0] - centre[0] * 1e-3)
                        .hypot(p.position_m[1] - centre[1] * 1e-3);
                    proptest::prop_assert!((d - r * 1e-3).abs() <= tolerance, "line {line}: {d} vs {r} mm");
                }
            }
        }
        let (again, _) = read_all(loosened(&text, seed).as_bytes());
        proptest::prop_assert_eq!(again, points);
    }
}

/// A small mill's limits for planning the corpus: rapids and the largest feed at
/// 100 mm/s, 1 m/s² along the path, corners with grbl's default junction deviation
/// (0.01 mm).
const MILL: kerf::trajectory::planner::PlannerLimits = kerf::trajectory::planner::PlannerLimits {
    max_speed_m_s: 0.1,
    accel_m_s2: 1.0,
    junction_deviation_m: 0.01e-3,
    jerk_m_s3: f64::INFINITY,
};

/// A program's points through the look-ahead planner, streamed through 16 moves as a
/// controller's buffer holds them and with the whole program in view: the moves as
/// taken, their duration, the whole view's, and the time the feeds alone allow (each
/// move at its feed, acceleration unbounded).
fn plan_program(points: &[GcodePoint]) -> (Vec<Block<3>>, f64, f64, f64) {
    let feed_of = |p: &GcodePoint| match p.kind {
        MoveKind::Rapid => MILL.max_speed_m_s,
        MoveKind::Feed => p.feed_m_s,
    };
    let start = [0.0; 3];
    let mut streamed = Planner::<3, 16>::new(&MILL, start).unwrap();
    let mut whole = Box::new(Planner::<3, 8192>::new(&MILL, start).unwrap());
    let mut taken: Vec<Block<3>> = Vec::new();
    let mut feed_bound_s = 0.0;
    let mut at = start;
    for p in points {
        let feed = feed_of(p);
        let d: f64 = (0..3)
            .map(|k| (p.position_m[k] - at[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        feed_bound_s += d / feed.min(MILL.max_speed_m_s);
        at = p.position_m;
        if streamed.is_full() {
            taken.extend(streamed.pop());
        }
        streamed.push(p.position_m, feed).unwrap();
        whole.push(p.position_m, feed).unwrap();
    }
    while let Some(b) = streamed.pop() {
        taken.push(b);
    }
    let streamed_s = taken.iter().map(|b| b.profile(&MILL).duration_s()).sum();
    (taken, streamed_s, whole.duration_s(), feed_bound_s)
}

/// What a plan of `points` must be: the moves chained from the origin to the last
/// point, ending at rest, each speed within its feed and the machine's largest, every
/// change of speed within the acceleration over the move, every corner within its
/// junction speed; the stream no faster than the whole view, which is no faster than
/// the feeds alone.
fn plan_holds(points: &[GcodePoint]) -> Result<(), String> {
    let (taken, streamed_s, whole_s, feed_bound_s) = plan_program(points);
    let a = MILL.accel_m_s2;
    let ok = |c: bool, what: &str| if c { Ok(()) } else { Err(what.to_string()) };
    ok(
        whole_s >= feed_bound_s * (1.0 - 1e-9),
        "faster than the feeds",
    )?;
    ok(
        streamed_s >= whole_s * (1.0 - 1e-9),
        "the stream faster than the whole",
    )?;
    ok(
        taken.last().is_none_or(|b| b.exit_m_s == 0.0),
        "not at rest",
    )?;
    if let (Some(last), Some(end)) = (taken.last(), points.last()) {
        ok(last.end_m == end.position_m, "not at the last point")?;
    }
    for b in &taken {
        let slack = 1e-12 + 1e-9 * (b.entry_m_s + b.exit_m_s);
        ok(
            b.nominal_m_s <= MILL.max_speed_m_s,
            "a feed past the largest",
        )?;
        ok(
            b.entry_m_s <= b.nominal_m_s + slack && b.exit_m_s <= b.nominal_m_s + slack,
            "past the feed",
        )?;
        let room = 2.0 * a * b.length_m + 1e-12;
        ok(
            b.exit_m_s.powi(2) <= b.entry_m_s.powi(2) + room,
            "accelerates past the limit",
        )?;
        ok(
            b.entry_m_s.powi(2) <= b.exit_m_s.powi(2) + room,
            "brakes past the limit",
        )?;
    }
    for pair in taken.windows(2) {
        ok(pair[0].end_m == pair[1].start_m, "moves not chained")?;
        ok(
            (pair[0].exit_m_s - pair[1].entry_m_s).abs() < 1e-12,
            "speed jumps at a junction",
        )?;
        let corner = MILL.corner_speed_m_s(&pair[0].unit, &pair[1].unit);
        ok(
            pair[1].entry_m_s <= corner + 1e-12,
            "a corner past its junction speed",
        )?;
    }
    Ok(())
}

/// Every corpus program planned within the machine's limits ([`plan_holds`]).
/// Printed: the three durations.
#[test]
fn every_corpus_program_is_planned_within_the_machines_limits() {
    for path in corpus() {
        let text = std::fs::read(&path).unwrap();
        let (points, _) = read_all(&text);
        let name = path.file_name().unwrap().to_string_lossy();
        let (taken, streamed_s, whole_s, feed_bound_s) = plan_program(&points);
        println!(
            "{name}: {} moves, planned {streamed_s:.2} s through 16 (whole program in view {whole_s:.2} s), feeds alone {feed_bound_s:.2} s",
            taken.len()
        );
        if let Err(e) = plan_holds(&points) {
            panic!("{name}: {e}");
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// Random valid programs (lines and arcs, loosened as grbl accepts them) through
    /// the reader and then the planner: no error, no panic, and a plan that holds
    /// ([`plan_holds`]).
    #[test]
    fn random_programs_read_and_plan_within_the_limits(moves in moves(), seed in 1u64..u64::MAX) {
        let (text, _) = program(&moves);
        let (points, found) = read_all(loosened(&text, seed).as_bytes());
        proptest::prop_assert!(found.iter().all(|d| d.severity() != Severity::Error), "{found:?}");
        let held = plan_holds(&points);
        proptest::prop_assert!(held.is_ok(), "{held:?}\n{text}");
    }
}
