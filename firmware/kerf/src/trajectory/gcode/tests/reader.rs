//! The tolerant reader: real programs' text, arcs against circles computed here,
//! offsets, and every problem in one pass at its line and column.

use super::*;
use std::vec::Vec as StdVec;

/// Reads `text` with `config`: the points and every diagnostic.
fn read_all(text: &str, config: &ReaderConfig) -> (StdVec<GcodePoint>, StdVec<Diagnostic>) {
    let mut points: Vec<GcodePoint, 4096> = Vec::new();
    let mut found = StdVec::new();
    read(text.as_bytes(), config, &mut points, &mut |d| {
        found.push(*d)
    })
    .unwrap();
    (points.iter().copied().collect(), found)
}

fn points_of(text: &str) -> StdVec<GcodePoint> {
    let (points, found) = read_all(text, &ReaderConfig::DEFAULT);
    assert!(found.is_empty(), "{found:?}");
    points
}

fn mm(p: &GcodePoint) -> [f64; 3] {
    p.position_m.map(|v| v * 1e3)
}

fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
}

#[test]
fn a_byte_order_mark_crlf_and_blanks_inside_words_are_read() {
    let points = points_of("\u{FEFF}g 1 x 1 . 5 Y - 2 F 600\r\nZ 1.000\r\n");
    assert_eq!(points.len(), 2);
    assert!(close(mm(&points[0]), [1.5, -2.0, 0.0], 1e-12));
    assert!(close(mm(&points[1]), [1.5, -2.0, 1.0], 1e-12));
    // Columns count from after the mark, in characters.
    let (_, found) = read_all("\u{FEFF}T1\n(é) G0 Q1\n", &ReaderConfig::DEFAULT);
    let at: StdVec<_> = found.iter().map(|d| (d.line, d.column)).collect();
    assert_eq!(at, [(1, 1), (2, 8)]);
    assert_eq!(found[1].kind, GcodeErrorKind::UnknownWord(b'Q'));
}

/// The circle of an arc, worked out here: every point at the radius from the centre,
/// the angle moving one way by the expected sweep, the last point at the end, and
/// each chord's sagitta r − |centre − chord midpoint| within the tolerance.
fn check_arc(
    start: [f64; 2],
    points: &[GcodePoint],
    center: [f64; 2],
    radius: f64,
    sweep_deg: f64,
    tol_mm: f64,
) {
    let mut prev = start;
    let mut turned = 0.0;
    for p in points {
        let q = [mm(p)[0], mm(p)[1]];
        let r = ((q[0] - center[0]).powi(2) + (q[1] - center[1]).powi(2)).sqrt();
        assert!((r - radius).abs() < 1e-9, "{q:?} at {r}");
        let mid = [(q[0] + prev[0]) / 2.0, (q[1] + prev[1]) / 2.0];
        let sagitta = radius - ((mid[0] - center[0]).powi(2) + (mid[1] - center[1]).powi(2)).sqrt();
        assert!(
            sagitta <= tol_mm * (1.0 + 1e-6) && sagitta > 0.0,
            "{sagitta}"
        );
        let a0 = (prev[1] - center[1]).atan2(prev[0] - center[0]);
        let a1 = (q[1] - center[1]).atan2(q[0] - center[0]);
        let mut d = a1 - a0;
        if d > std::f64::consts::PI {
            d -= 2.0 * std::f64::consts::PI;
        }
        if d < -std::f64::consts::PI {
            d += 2.0 * std::f64::consts::PI;
        }
        assert!(d * sweep_deg > 0.0, "turns the wrong way");
        turned += d;
        prev = q;
    }
    assert!((turned.to_degrees() - sweep_deg).abs() < 1e-9, "{turned}");
    // As many chords as ⌈sweep / (2·acos(1 − t/r))⌉.
    let max = 2.0 * (1.0 - tol_mm / radius).acos();
    let n = (sweep_deg.to_radians().abs() / max).ceil() as usize;
    assert_eq!(points.len(), n);
}

#[test]
fn arcs_by_centre_and_by_radius_follow_their_circle() {
    let head = "G21 G17 G0 X10 Y0\nF600\n";
    // Quarter, counter-clockwise, about the origin: by centre and by radius.
    for arc in ["G3 X0 Y10 I-10 J0", "G3 X0 Y10 R10"] {
        let points = points_of(&format!("{head}{arc}\n"));
        check_arc([10.0, 0.0], &points[1..], [0.0, 0.0], 10.0, 90.0, 1e-3);
        assert_eq!(mm(points.last().unwrap()), [0.0, 10.0, 0.0]);
    }
    // Clockwise the longer way (negative R): three quarters about the origin.
    let points = points_of(&format!("{head}G2 X0 Y10 R-10\n"));
    check_arc([10.0, 0.0], &points[1..], [0.0, 0.0], 10.0, -270.0, 1e-3);
    // Clockwise the shorter way: a quarter about (10, 10).
    let points = points_of(&format!("{head}G2 X0 Y10 R10\n"));
    check_arc([10.0, 0.0], &points[1..], [10.0, 10.0], 10.0, -90.0, 1e-3);
    // A full circle by centre alone, and one with two turns (P2).
    let points = points_of(&format!("{head}G2 X10 Y0 I-10\n"));
    check_arc([10.0, 0.0], &points[1..], [0.0, 0.0], 10.0, -360.0, 1e-3);
    let points = points_of(&format!("{head}G3 I-10 J0 X10 P2\n"));
    check_arc([10.0, 0.0], &points[1..], [0.0, 0.0], 10.0, 720.0, 1e-3);
    // Absolute centre (G90.1), at (5, 0) in mm: a half circle to (0, 0).
    let points = points_of(&format!("{head}G90.1 G3 X0 Y0 I5 J0\n"));
    check_arc([10.0, 0.0], &points[1..], [5.0, 0.0], 5.0, 180.0, 1e-3);
}

#[test]
fn the_chord_tolerance_is_the_callers() {
    let mut config = ReaderConfig::DEFAULT;
    for tol_mm in [1e-4, 1e-2, 0.5] {
        config.chord_tolerance_m = tol_mm * 1e-3;
        let (points, found) = read_all("G0 X25 Y0\nG2 X-25 Y0 R25 F100\n", &config);
        assert!(found.is_empty());
        check_arc([25.0, 0.0], &points[1..], [0.0, 0.0], 25.0, -180.0, tol_mm);
    }
}

#[test]
fn arcs_in_the_other_planes_are_helical_on_the_normal() {
    // G18 (ZX): Z, X in the plane, Y along. G19 (YZ): Y, Z in the plane, X along.
    let points = points_of("G0 X0 Y0 Z10\nG18 G3 X10 Z0 Y4 K-10 F100\n");
    for p in &points[1..] {
        let [x, _, z] = mm(p);
        assert!(((x * x + z * z).sqrt() - 10.0).abs() < 1e-9);
    }
    let last = mm(points.last().unwrap());
    assert_eq!(last, [10.0, 4.0, 0.0]);
    let ys: StdVec<f64> = points[1..].iter().map(|p| mm(p)[1]).collect();
    assert!(ys.windows(2).all(|w| w[1] > w[0]), "{ys:?}");
    let points = points_of("G0 X2 Y10 Z0\nG19 G2 Y0 Z10 J-10 F100\n");
    for p in &points[1..] {
        let [x, y, z] = mm(p);
        assert!(((y * y + z * z).sqrt() - 10.0).abs() < 1e-9 && x == 2.0);
    }
}

#[test]
fn arcs_that_miss_their_end_are_refused_at_their_code() {
    use GcodeErrorKind::*;
    let cases: &[(&str, u32, GcodeErrorKind)] = &[
        // The end 2 mm off the circle through the start.
        ("G2 X0 Y12 I-10", 1, ArcRadiusMismatch),
        // A radius of 5 mm to an end 20 mm away.
        ("G2 X-10 Y0 R5", 1, ArcRadiusMismatch),
        ("G3 X0 Y10 R10 I-10", 1, ArcUndefined),
        ("G3 X0 Y10", 1, ArcUndefined),
        ("G3 X10 R10", 1, ArcUndefined),
        ("G3 X0 Y10 I-10 K1", 16, UnusedWord(b'K')),
    ];
    for &(arc, column, kind) in cases {
        let (points, found) = read_all(&format!("G0 X10 Y0\nF100 {arc}\n"), &ReaderConfig::DEFAULT);
        assert_eq!(points.len(), 1, "{arc}");
        let at: StdVec<_> = found.iter().map(|d| (d.line, d.column, d.kind)).collect();
        assert_eq!(at, [(2, column + 5, kind)], "{arc}");
    }
    // Within grbl's 0.005 mm: read.
    assert_eq!(
        read_all("G0 X10\nG2 X0 Y10.004 I-10 F1\n", &ReaderConfig::DEFAULT).1,
        []
    );
}

#[test]
fn incremental_moves_and_offsets_land_where_the_machine_is() {
    let mut config = ReaderConfig::DEFAULT;
    config.work_offsets[1] = [0.1, 0.2, 0.0, 0.0, 0.0];
    let (points, found) = read_all(
        "G0 X1 Y1\nG91 X2 Y-3\nG90 G55 X1\nG92 X0 Y0\nX5\nG92.1 X5\nG53 X1\nG54 G20 X1\n",
        &config,
    );
    assert!(found.is_empty(), "{found:?}");
    let got: StdVec<[f64; 3]> = points.iter().map(mm).collect();
    let want = [
        [1.0, 1.0, 0.0],
        [3.0, -2.0, 0.0],
        // G55's origin at (100, 200) mm.
        [101.0, -2.0, 0.0],
        // G92 made (101, -2) the origin.
        [106.0, -2.0, 0.0],
        // G92.1: back to G55 alone.
        [105.0, -2.0, 0.0],
        // G53: the machine's own coordinates.
        [1.0, -2.0, 0.0],
        // G54 in inches.
        [25.4, -2.0, 0.0],
    ];
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(want) {
        assert!(close(*g, w, 1e-9), "{g:?} != {w:?}");
    }
}

#[test]
fn every_problem_is_reported_in_one_pass_at_its_line_and_column() {
    use GcodeErrorKind::*;
    let config = ReaderConfig {
        axes: [true, true, false, false, false],
        ..ReaderConfig::DEFAULT
    };
    let text = "%\n\
                O1000 (program)\n\
                T1 M6 (tool (one)\n\
                G1 X1\n\
                G0 Q1 X2\n\
                G0 Z1\n\
                G0 G1 X3\n\
                G64 M8 G0 X4 Y4\n\
                G1 X5 F0\n\
                o100 sub\n\
                #1 = 2\n\
                G28\n\
                G4 P-1\n\
                M0\n\
                G93 G1 X6 F10\n\
                G94 G1 X7 F10 R2\n\
                M30\n\
                G0 X8\n";
    let (points, found) = read_all(text, &config);
    let got: StdVec<_> = found.iter().map(|d| (d.line, d.column, d.kind)).collect();
    let want = [
        (2, 1, ProgramNumber),
        (3, 13, NestedComment),
        (
            3,
            1,
            Ignored {
                letter: b'T',
                code_x10: 10,
            },
        ),
        (
            3,
            4,
            Ignored {
                letter: b'M',
                code_x10: 60,
            },
        ),
        (4, 1, MissingFeed),
        (5, 4, UnknownWord(b'Q')),
        (6, 4, AxisNotOnMachine(b'Z')),
        (
            7,
            4,
            ModalConflict {
                letter: b'G',
                code_x10: 10,
            },
        ),
        (
            8,
            5,
            Ignored {
                letter: b'M',
                code_x10: 80,
            },
        ),
        (
            8,
            1,
            Ignored {
                letter: b'G',
                code_x10: 640,
            },
        ),
        (9, 7, BadFeed),
        // Line 4 set no feed: still none.
        (9, 1, MissingFeed),
        (10, 1, FlowControl),
        (11, 1, UnexpectedByte(b'#')),
        (
            12,
            1,
            NotRead {
                letter: b'G',
                code_x10: 280,
            },
        ),
        (13, 1, BadDwell),
        (
            14,
            1,
            NotRead {
                letter: b'M',
                code_x10: 0,
            },
        ),
        (15, 1, InverseTimeMode),
        (15, 5, InverseTimeMove),
        (16, 15, UnusedWord(b'R')),
        (18, 0, AfterEnd),
    ];
    assert_eq!(got, want);
    // The clean lines moved: line 8 only (the others had errors).
    let lines: StdVec<u32> = points.iter().map(|p| p.line).collect();
    assert_eq!(lines, [8]);
    let warnings = found
        .iter()
        .filter(|d| d.severity() == Severity::Warning)
        .count();
    assert_eq!(warnings, 8);
}

#[test]
fn spindle_laser_mode_and_dwell_ride_on_the_points() {
    let points = points_of("M4 S800 G0 X1\nG4 P1.5\nG1 X2 F100\nM3 S200 X3\nM5 X4\n");
    let got: StdVec<_> = points
        .iter()
        .map(|p| (p.spindle, p.spindle_s, p.dwell_s))
        .collect();
    assert_eq!(
        got,
        [
            (Spindle::CounterClockwise, 800.0, 0.0),
            (Spindle::CounterClockwise, 800.0, 1.5),
            (Spindle::Clockwise, 200.0, 0.0),
            (Spindle::Off, 200.0, 0.0),
        ]
    );
}

#[test]
fn the_line_by_line_reader_refuses_arcs_and_keeps_its_state() {
    let mut parser = Parser::new();
    assert!(parser.parse_line(b"G0 X10").unwrap().is_some());
    let e = parser.parse_line(b"G2 X0 Y10 I-10 F100").unwrap_err();
    assert_eq!(
        (e.line, e.column, e.kind),
        (2, 1, GcodeErrorKind::ArcNotLineByLine)
    );
    // Still in G0 at X10.
    let p = parser.parse_line(b"Y1").unwrap().unwrap();
    assert_eq!((p.kind, mm(&p)), (MoveKind::Rapid, [10.0, 1.0, 0.0]));
}

#[test]
fn a_bad_configuration_names_its_field() {
    let mut config = ReaderConfig::DEFAULT;
    config.chord_tolerance_m = 0.0;
    assert_eq!(
        Parser::with_config(&config).unwrap_err().field(),
        "chord_tolerance_m"
    );
    config.chord_tolerance_m = 1e-6;
    config.work_offsets[3][1] = f64::NAN;
    assert_eq!(
        Parser::with_config(&config).unwrap_err().field(),
        "work_offsets"
    );
}

/// A line starting with `#` where no parameter follows is a comment (a warning); a
/// parameter (`#1=`, `#<name>`, `#[`) and a `#` inside a line stay refused; a tool
/// change's own `P` goes with it.
#[test]
fn hash_comment_lines_and_a_tool_changes_words_are_warnings() {
    use super::super::GcodeErrorKind::{HashComment, Ignored, UnexpectedByte};
    let text = "# a laser rig's comment\n  #Laser Blue\nG1 X1 F100\nM6 P1\n#1=5\n#<depth>=2\n#[1]\nG1 X2 #3\n";
    let (points, found) = read_all(text, &ReaderConfig::DEFAULT);
    let got: StdVec<_> = found.iter().map(|d| (d.line, d.column, d.kind)).collect();
    assert_eq!(
        got,
        [
            (1, 1, HashComment),
            (2, 3, HashComment),
            (
                4,
                1,
                Ignored {
                    letter: b'M',
                    code_x10: 60
                }
            ),
            (5, 1, UnexpectedByte(b'#')),
            (6, 1, UnexpectedByte(b'#')),
            (7, 1, UnexpectedByte(b'#')),
            (8, 7, UnexpectedByte(b'#')),
        ]
    );
    assert_eq!(points.len(), 1);
    assert!(close(mm(&points[0]), [1.0, 0.0, 0.0], 1e-12));
}
