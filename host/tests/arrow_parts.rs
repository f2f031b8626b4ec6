//! ARROW's programs as parts (`kerf_host::arrow_parts`): a real program longer than
//! the machine holds, read back part by part, is the program read whole (turned,
//! moved and started from home as asked, computed here on its own); every part fits
//! the machine's buffers, counted here from its text; a refusal in a later part names
//! the line of the original; the parts' continuity is checked as the machine checks
//! a start; the options of other machines are refused.

mod common;

use common::{kerf, tmp};
use kerf::kinematics::arrow::ArrowConfig;
use kerf::machines::arrow::job::ArrowJobConfig;
use kerf::machines::arrow::product::{HOME, JOB_MOVES, JOB_POINTS, LINK_JOB_BYTES, PROGRAM_POINTS};
use kerf::trajectory::gcode::{GcodePoint, MoveKind};
use kerf_host::arrow_parts::{parts, Placement};
use kerf_host::check::{check, CheckError, Machine};
use std::path::PathBuf;

fn corpus(name: &str) -> Vec<u8> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../data/gcode")
        .join(name);
    std::fs::read(path).unwrap()
}

/// Every point of `text`, through the reader line by line.
fn read(text: &[u8]) -> Vec<GcodePoint> {
    kerf_host::gcode::read_all(text).0
}

fn axes(p: &GcodePoint) -> [f64; 5] {
    let ([x, y, z], [a, b]) = (p.position_m, p.angles_rad);
    [x, y, z, a, b]
}

/// The moves of one part's points (its start, then its targets): the loader's rule,
/// a change of kind or of feed starts a move. Returns each move's targets.
fn moves_of(points: &[GcodePoint]) -> Vec<usize> {
    let mut moves: Vec<usize> = Vec::new();
    for (i, p) in points.iter().enumerate().skip(1) {
        let q = &points[i - 1];
        let same =
            i > 1 && p.kind == q.kind && (p.kind == MoveKind::Rapid || p.feed_m_s == q.feed_m_s);
        match moves.last_mut() {
            Some(n) if same => *n += 1,
            _ => moves.push(1),
        }
    }
    moves
}

#[test]
fn a_long_mill_program_read_back_from_its_parts_is_the_program() {
    let text = corpus("arcspiral.ngc");
    let program = parts(
        &text,
        Placement {
            centre: true,
            mill: true,
        },
    )
    .expect("ARROW takes the spiral as parts");
    assert!(program.parts.len() > 10, "{}", program.parts.len());
    assert!(program.mill && program.from_home);
    // The reference: the program read whole, turned (x, y0 − z, y), repeated points
    // dropped, its box centred on (0, y0, 0), home first.
    let y0 = ArrowConfig::ARROW.workspace.y0_m;
    let mut want: Vec<([f64; 5], MoveKind, f64)> = Vec::new();
    for p in read(&text) {
        let [x, y, z, a, b] = axes(&p);
        let turned = [x, y0 - z, y, a, b];
        if want.last().is_none_or(|w| w.0 != turned) {
            want.push((turned, p.kind, p.feed_m_s));
        }
    }
    for k in 0..3 {
        let lo = want.iter().map(|w| w.0[k]).fold(f64::INFINITY, f64::min);
        let hi = want
            .iter()
            .map(|w| w.0[k])
            .fold(f64::NEG_INFINITY, f64::max);
        let centre = [0.0, y0, 0.0][k];
        for w in &mut want {
            w.0[k] += centre - (lo + hi) / 2.0;
        }
    }
    want.insert(0, (HOME, MoveKind::Rapid, 0.0));
    let mut got: Vec<([f64; 5], MoveKind, f64)> = Vec::new();
    let mut cut_moves = 0;
    for (k, part) in program.parts.iter().enumerate() {
        // What the machine's buffers hold, counted from the text.
        assert!(part.text.len() <= LINK_JOB_BYTES - 64, "part {k}");
        let points = read(&part.text);
        assert!(points.len() <= PROGRAM_POINTS, "part {k}: {}", points.len());
        let moves = moves_of(&points);
        assert!(moves.len() <= JOB_MOVES, "part {k}: {moves:?}");
        assert!(moves.iter().all(|&n| n < JOB_POINTS), "part {k}: {moves:?}");
        assert_eq!(moves.len(), part.report.moves.len(), "part {k}");
        let (first, rest) = points.split_first().unwrap();
        match got.last() {
            // Each part starts exactly where the one before ends.
            Some(end) => {
                assert_eq!(end.0, axes(first), "part {k}");
                // A move cut between parts: the same kind and feed on both sides.
                let next = rest[0];
                if next.kind == end.1 && next.feed_m_s == end.2 && next.kind == MoveKind::Feed {
                    cut_moves += 1;
                }
            }
            None => got.push((axes(first), first.kind, first.feed_m_s)),
        }
        got.extend(rest.iter().map(|p| (axes(p), p.kind, p.feed_m_s)));
    }
    assert_eq!(cut_moves, program.stops.len());
    assert!(!program.stops.is_empty());
    assert_eq!(got.len(), want.len());
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        // Written to 1 nm and 1e-6°, read back through mm → m.
        for k in 0..3 {
            assert!((g.0[k] - w.0[k]).abs() < 1e-9, "point {i}: {g:?} {w:?}");
        }
        for k in 3..5 {
            assert!((g.0[k] - w.0[k]).abs() < 1e-7, "point {i}: {g:?} {w:?}");
        }
        assert_eq!(g.1, w.1, "point {i}");
        if i > 0 && g.1 == MoveKind::Feed {
            assert!(
                (g.2 - w.2).abs() <= 1e-9 * w.2,
                "point {i}: {} {}",
                g.2,
                w.2
            );
        }
    }
    // The file the parts make is checked as one program: its parts in order.
    let bytes = program.to_bytes().unwrap();
    let checked = check(&bytes, Some(Machine::Arrow)).expect("its parts continue");
    assert_eq!(checked.parts, program.parts.len());
    assert!((checked.duration_s - program.duration_s()).abs() < 1e-9);
    // Its preview is seen along the tool: the plane of x and z, where the spiral lies
    // (turned from the mill's x and y), spans the feed moves' paths in it.
    let [a, b] = Machine::Arrow.path_plane();
    assert_eq!([a, b], [0, 2]);
    let preview = checked.preview.unwrap();
    let feed_paths = program.parts.iter().flat_map(|p| {
        p.report
            .moves
            .iter()
            .zip(&p.report.paths_m)
            .filter(|(m, _)| m.kind == MoveKind::Feed)
            .flat_map(|(_, path)| path.iter().map(|q| [q[a], q[b]]))
    });
    let cuts = preview.cuts_m.iter().flatten().copied();
    let span = |points: &mut dyn Iterator<Item = [f64; 2]>| {
        points.fold(
            [
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
            ],
            |s, p| {
                [
                    s[0].min(p[0]),
                    s[1].max(p[0]),
                    s[2].min(p[1]),
                    s[3].max(p[1]),
                ]
            },
        )
    };
    let (want, got) = (span(&mut feed_paths.clone()), span(&mut cuts.clone()));
    assert_eq!(want, got);
    // The spiral's 4-inch width lies in that plane.
    assert!(
        want[1] - want[0] > 0.09 && want[3] - want[2] > 0.09,
        "{want:?}"
    );
}

#[test]
fn a_program_the_machine_holds_is_one_part_and_the_pyramid_starts_at_home() {
    let text =
        std::fs::read(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/pyramid.gcode"))
            .unwrap();
    let program = parts(&text, Placement::default()).unwrap();
    assert_eq!(program.parts.len(), 1);
    assert!(!program.from_home && program.stops.is_empty() && program.left_out.is_empty());
    assert_eq!(program.shift_m, [0.0; 3]);
    let whole = kerf_host::gcode::check(&text).unwrap();
    assert_eq!(program.parts[0].report.moves.len(), whole.moves.len());
    assert!((program.duration_s() - whole.duration_s).abs() < 1e-9);
}

#[test]
fn a_refusal_in_a_later_part_names_the_line_of_the_program() {
    // 600 feed points along x at y = 500 mm; line 452 leaves the workspace in y.
    let mut text =
        String::from("G21 G90\nG0 X13.333 Y464.604 Z-13.333 A-15 B15\nG1 X0 Y500 Z0 A0 B0 F600\n");
    for i in 1..=600 {
        let y = if i == 449 { 700.0 } else { 500.0 };
        text.push_str(&format!("X{:.1} Y{y}\n", f64::from(i) * 0.5));
    }
    assert!(text.lines().nth(451).unwrap().contains("Y700"));
    let e = parts(text.as_bytes(), Placement::default()).unwrap_err();
    assert_eq!((e.line, e.column), (452, 1), "{e}");
    assert!(
        e.message.contains("Y must stay between 350 and 650 mm"),
        "{e}"
    );
    // Without it the program goes as parts: a move too long for one is cut.
    let fine = text.replace("Y700", "Y500");
    let program = parts(fine.as_bytes(), Placement::default()).unwrap();
    assert!(program.parts.len() >= 3, "{}", program.parts.len());
    assert!(!program.stops.is_empty());
}

#[test]
fn a_feed_above_the_rapid_speed_is_followed_at_the_rapid_speed() {
    let text = b"G21 G90\nG0 X13.333 Y464.604 Z-13.333 A-15 B15\nG1 X300 F999999\nX13.333 F600\n";
    let program = parts(text, Placement::default()).unwrap();
    let moves = &program.parts[0].report.moves;
    let rapid = ArrowJobConfig::ARROW.rapid_m_s;
    // The plan ends on a whole period, which lowers a cruise by less than 1e-4 of it
    // here; without the hold the 287 mm move would reach some 0.75 m/s at 2 m/s².
    assert!(
        (moves[0].speed_m_s / rapid - 1.0).abs() < 1e-4,
        "{:?}",
        moves[0]
    );
    assert!(
        (moves[1].speed_m_s / 0.01 - 1.0).abs() < 1e-4,
        "{:?}",
        moves[1]
    );
    // Each move named by its line in the program.
    assert_eq!([moves[0].line, moves[1].line], [3, 4]);
}

#[test]
fn parts_out_of_order_are_refused_as_the_machine_would_refuse_their_start() {
    let program = parts(
        &corpus("cap.ngc"),
        Placement {
            centre: true,
            mill: true,
        },
    )
    .unwrap();
    assert!(program.parts.len() >= 3);
    let mut swapped = program.clone();
    swapped.parts.swap(1, 2);
    match check(&swapped.to_bytes().unwrap(), Some(Machine::Arrow)) {
        Err(CheckError::Part { part: 2, of, error }) => {
            assert_eq!(of, program.parts.len());
            let CheckError::ArrowStart { gap_mm, .. } = *error else {
                panic!("{error}")
            };
            assert!(gap_mm > 0.5, "{gap_mm}");
            assert!(
                error
                    .to_string()
                    .contains("from where the part before ends"),
                "{error}"
            );
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn placing_options_of_other_machines_are_refused_and_nothing_is_written() {
    let program = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/grinding_pass.gcode");
    let out = tmp("refused-placement.krfj");
    let _ = std::fs::remove_file(&out);
    for (machine, option, words) in [
        (
            "keops-slave",
            "--mill",
            "--mill turns a mill's program onto ARROW's tool axis",
        ),
        (
            "grinding",
            "--mill",
            "--mill turns a mill's program onto ARROW's tool axis",
        ),
        (
            "grinding",
            "--centre",
            "--centre moves a laser program or ARROW's",
        ),
    ] {
        let run = kerf(&[
            "gcode",
            program.to_str().unwrap(),
            "--machine",
            machine,
            option,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(run.status.code(), Some(1), "{machine} {option}");
        let said = String::from_utf8_lossy(&run.stderr);
        assert!(said.contains(words), "{said}");
        assert!(!out.exists());
    }
}

#[test]
fn every_corpus_program_for_a_mill_or_a_laser_loads_on_arrow_as_parts() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/gcode");
    let mut loaded = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "md") {
            continue;
        }
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let placement = Placement {
            centre: true,
            mill: true,
        };
        match (
            name.as_str(),
            parts(&std::fs::read(&path).unwrap(), placement),
        ) {
            // Written for a six-axis arm: A and B turn with the tool point still.
            ("puma_seam_weld.ngc", Err(e)) => {
                assert_eq!(e.line, 7, "{e}");
                assert!(e.message.contains("a move of A or B alone"), "{e}");
            }
            (_, Ok(program)) => {
                assert!(program.duration_s() > 0.0, "{name}");
                // A rest-to-rest move is no faster than its length at the rapid speed.
                let rapid = ArrowJobConfig::ARROW.rapid_m_s;
                assert!(program.duration_s() >= program.length_m() / rapid, "{name}");
                loaded += 1;
            }
            (_, Err(e)) => panic!("{name}: {e}"),
        }
    }
    assert_eq!(loaded, 12);
}
