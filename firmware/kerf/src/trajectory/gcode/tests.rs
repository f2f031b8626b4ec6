use super::*;
use core::f64::consts::PI;
use proptest::prelude::*;
use std::format;
use std::string::String;
use std::vec;

/// XOR of the bytes, written here without the parser's tokenizer: the RepRap checksum
/// of a line body.
fn xor(body: &str) -> u8 {
    body.bytes().fold(0, |a, b| a ^ b)
}

fn parse_str<const N: usize>(text: &str) -> Result<(Vec<GcodePoint, N>, Program), GcodeError> {
    let mut points = Vec::new();
    let program = parse(text.as_bytes(), &mut points)?;
    Ok((points, program))
}

fn error_of(text: &str) -> GcodeError {
    match parse_str::<16>(text) {
        Err(e) => e,
        Ok(p) => panic!("accepted: {p:?}"),
    }
}

/// A hand-written file with every feature; the expected points are worked out by hand
/// below (mm → m × 1e-3, in → m × 0.0254, deg → rad × π/180, mm/min → m/s ÷ 60000).
const HAND_FILE: &str = "%
(pyramid test, written by hand)
N10 G21 G90 G17 G94 ; metric, absolute
N20 M3 S12000
N30 G0 X10 Y500 Z50
N40 G1 Z-1.5 F600 (plunge)
N50 X20.25 A-30 B45
N60 Y510
N70 G91 X-5 Y+2.5 B-15
N80 G90 G20 X1 Y20 Z0 F10
N90 G21
N100 G0 Z5.
N110 M5
N120 M30
G1 X999 this line is never read
";

#[test]
fn hand_written_file_gives_the_points_worked_out_by_hand() {
    let (points, program) = parse_str::<16>(HAND_FILE).unwrap();
    let mm = 1e-3;
    let deg = PI / 180.0;
    let f600 = 600.0 * mm / 60.0;
    let f10in = 10.0 * 0.0254 / 60.0;
    // (x, y, z in mm; A, B in degrees; feed m/s; kind; line)
    let expected = [
        ([10.0, 500.0, 50.0], [0.0, 0.0], 0.0, MoveKind::Rapid, 5),
        ([10.0, 500.0, -1.5], [0.0, 0.0], f600, MoveKind::Feed, 6),
        ([20.25, 500.0, -1.5], [-30.0, 45.0], f600, MoveKind::Feed, 7),
        ([20.25, 510.0, -1.5], [-30.0, 45.0], f600, MoveKind::Feed, 8),
        ([15.25, 512.5, -1.5], [-30.0, 30.0], f600, MoveKind::Feed, 9),
        ([25.4, 508.0, 0.0], [-30.0, 30.0], f10in, MoveKind::Feed, 10),
        (
            [25.4, 508.0, 5.0],
            [-30.0, 30.0],
            f10in,
            MoveKind::Rapid,
            12,
        ),
    ];
    assert_eq!(points.len(), expected.len());
    for (p, (xyz, ab, f, kind, line)) in points.iter().zip(expected) {
        for (got, want) in p.position_m.iter().zip(xyz) {
            // One rounding in the conversion, a few more in incremental sums.
            assert!((got - want * mm).abs() < 1e-15, "{p:?}");
        }
        for (got, want) in p.angles_rad.iter().zip(ab) {
            assert!((got - want * deg).abs() < 1e-15, "{p:?}");
        }
        assert!((p.feed_m_s - f).abs() < 1e-18, "{p:?}");
        assert_eq!((p.kind, p.line), (kind, line));
    }
    assert_eq!(
        program,
        Program {
            lines: 14,
            ended: true,
            spindle_on: false,
            spindle_rpm: 12000.0,
            errors: 0,
            // The line after M30.
            warnings: 1,
        }
    );
}

#[test]
fn crlf_lines_lower_case_and_checksums_are_read() {
    let body = "N1 g1 x1.5 y-2 f1200 (c)";
    let text = format!("{body}*{}\r\nN2 X3*{}\r\n", xor(body), xor("N2 X3"));
    let (points, program) = parse_str::<4>(&text).unwrap();
    assert_eq!(points.len(), 2);
    assert_eq!(points[0].position_m, [1.5e-3, -2e-3, 0.0]);
    assert_eq!(points[1].position_m, [3e-3, -2e-3, 0.0]);
    assert_eq!(points[1].line, 2);
    assert_eq!(program.lines, 2);
    assert!(!program.ended);
}

#[test]
fn refusals_name_their_line_and_column() {
    use GcodeErrorKind::*;
    let cases: &[(&str, u32, u32, GcodeErrorKind)] = &[
        ("G1 X1 F100\nG1 Q2", 2, 4, UnknownWord(b'Q')),
        ("G1 X1 F100\n  Q1", 2, 3, UnknownWord(b'Q')),
        (
            "G5 X1 Y1 I1 J0 F100",
            1,
            1,
            Unsupported {
                letter: b'G',
                code_x10: 50,
            },
        ),
        (
            "G1 F100\nM48",
            2,
            1,
            Unsupported {
                letter: b'M',
                code_x10: 480,
            },
        ),
        (
            "G43.4 H1",
            1,
            1,
            Unsupported {
                letter: b'G',
                code_x10: 434,
            },
        ),
        ("G1 X- F100", 1, 5, MalformedNumber),
        ("G1 X F100", 1, 5, MalformedNumber),
        ("G1 X1e3 F100", 1, 6, UnknownWord(b'E')),
        ("G1 X1.2.3 F100", 1, 8, UnexpectedByte(b'.')),
        ("G1 Xnan F100", 1, 5, MalformedNumber),
        ("G0 X1\nG1 X2", 2, 1, MissingFeed),
        ("X1", 1, 1, NoMotionMode),
        ("G1 X1 X2 F100", 1, 7, DuplicateWord(b'X')),
        (
            "G0 G1 X1 F100",
            1,
            4,
            ModalConflict {
                letter: b'G',
                code_x10: 10,
            },
        ),
        ("G1 X1 F0", 1, 7, BadFeed),
        ("G1 X1 F-5", 1, 7, BadFeed),
        ("G1 X1 F100 (open", 1, 12, UnclosedComment),
        ("G1 X1 F100 )", 1, 12, UnclosedComment),
        ("G1 X1 F100 #1", 1, 12, UnexpectedByte(b'#')),
        ("G1 X1 F100 *72 X", 1, 16, UnexpectedByte(b'X')),
        ("N3 G1 X1 F100*", 1, 15, MalformedNumber),
        ("N3 G1 X1 F100*256", 1, 15, MalformedNumber),
    ];
    for &(text, line, column, kind) in cases {
        let e = error_of(text);
        assert_eq!(e, GcodeError { line, column, kind }, "{text}");
    }
}

#[test]
fn a_wrong_checksum_is_refused_with_both_values() {
    let body = "N7 G1 X1 F100";
    let good = xor(body);
    let text = format!("{body}*{}", good ^ 1);
    assert_eq!(
        error_of(&text),
        GcodeError {
            line: 1,
            column: 14,
            kind: GcodeErrorKind::BadChecksum {
                given: good ^ 1,
                computed: good,
            },
        }
    );
}

#[test]
fn long_lines_are_read_and_full_buffers_are_refused() {
    let mut long = String::from("G1 X1 F100 ;");
    while long.len() <= 2000 {
        long.push('-');
    }
    assert!(parse_str::<4>(&format!("G0 X0\n{long}")).is_ok());

    let mut points: Vec<GcodePoint, 2> = Vec::new();
    let e = parse(b"G0 X1\nX2\nX3\n", &mut points).unwrap_err();
    assert_eq!(
        e,
        GcodeError {
            line: 3,
            column: 0,
            kind: GcodeErrorKind::TooManyPoints,
        }
    );
    assert_eq!(points.len(), 2);
}

#[test]
fn coordinates_that_overflow_are_refused_and_the_state_kept() {
    // G54 at −max and G55 at +max: `G92 X0` in G54 puts the G92 offset at +max, so a
    // move in G55 lands at 2·max, past the f64 range.
    let mut config = ReaderConfig::DEFAULT;
    config.work_offsets[0][0] = -f64::MAX;
    config.work_offsets[1][0] = f64::MAX;
    let mut parser = Parser::with_config(&config).unwrap();
    assert!(parser.parse_line(b"G92 X0").unwrap().is_none());
    let e = parser.parse_line(b"G55 G0 Y1 X1").unwrap_err();
    assert_eq!(
        (e.line, e.column, e.kind),
        (2, 11, GcodeErrorKind::NotFinite)
    );
    // Still usable after the refusal, in G54 (the refused line's G55 not kept).
    let p = parser.parse_line(b"G0 X2").unwrap().unwrap();
    assert_eq!((p.position_m, p.line), ([2e-3, 0.0, 0.0], 3));
}

#[test]
fn comments_blank_lines_and_tape_marks_give_no_points() {
    let (points, program) =
        parse_str::<4>("%\n\n   \n(only a comment)\n; another\nN5 (x) ; y\nG21 G90\n%\n").unwrap();
    assert!(points.is_empty());
    assert_eq!(program.lines, 8);
}

proptest! {
    /// A number formatted with d decimals reads back as the f64 nearest to the same
    /// text (std's parser, an independent implementation over the same string), and
    /// within half a unit of the last decimal of the value formatted.
    #[test]
    fn formatted_numbers_round_trip(v in -2.0e3f64..2.0e3, d in 0usize..9, unit in 0usize..2) {
        let text = format!("{v:.d$}");
        let line = format!("{} G1 X{text} A{text} F100", ["G21", "G20"][unit]);
        let mut parser = Parser::new();
        let p = parser.parse_line(line.as_bytes()).unwrap().unwrap();
        let decimal: f64 = text.parse().unwrap();
        let scale = [1e-3, 0.0254][unit];
        prop_assert_eq!(p.position_m[0], decimal * scale);
        prop_assert_eq!(p.angles_rad[0], decimal * (PI / 180.0));
        // 0.5·10^-d from formatting, plus rounding of |v| ≤ 2e3 (2e3·2^-52 < 1e-12).
        prop_assert!((decimal - v).abs() <= 0.5 * libm::pow(10.0, -(d as f64)) + 1e-12);
    }

    /// A line with its correct checksum is accepted; any other checksum is refused.
    #[test]
    fn checksums_accept_only_the_xor(x in -500.0f64..500.0, n in 0u32..100_000, wrong in 0u8..=255) {
        let body = format!("N{n} G1 X{x:.3} Y2 F1500 (cut)");
        let good = xor(&body);
        let mut parser = Parser::new();
        let ok = parser.parse_line(format!("{body}*{good}").as_bytes());
        prop_assert!(ok.is_ok());
        let mut parser = Parser::new();
        let bad = parser.parse_line(format!("{body}*{wrong}").as_bytes());
        prop_assert_eq!(bad.is_ok(), wrong == good);
    }

    /// Arbitrary bytes: no panic, and every accepted point finite.
    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let mut points: Vec<GcodePoint, 32> = Vec::new();
        if parse(&bytes, &mut points).is_ok() {
            for p in &points {
                prop_assert!(p.position_m.iter().chain(&p.angles_rad).all(|v| v.is_finite()));
                prop_assert!(p.feed_m_s.is_finite() && p.feed_m_s >= 0.0);
            }
        }
    }

    /// Word soup from the accepted alphabet: same guarantees.
    #[test]
    fn gcode_like_lines_never_panic(
        words in proptest::collection::vec(
            (prop_oneof![Just("G"), Just("M"), Just("X"), Just("Y"), Just("Z"), Just("A"),
                         Just("B"), Just("F"), Just("N"), Just("S"), Just("*"), Just("(")],
             -1.0e6f64..1.0e6, 0usize..4),
            0..12),
        newline in any::<bool>(),
    ) {
        let mut line = String::new();
        for (letter, v, d) in words {
            line.push_str(&format!("{letter}{v:.d$} "));
            if newline { line.push('\n'); }
        }
        let mut points: Vec<GcodePoint, 32> = Vec::new();
        if parse(line.as_bytes(), &mut points).is_ok() {
            for p in &points {
                prop_assert!(p.position_m.iter().chain(&p.angles_rad).all(|v| v.is_finite()));
            }
        }
    }
}

#[test]
fn feed_runs_split_at_rapids_and_feed_changes() {
    let (points, _) =
        parse_str::<16>("G0 X1\nG1 X2 F60\nX3\nX4 F120\nG0 X5\nG1 X6\nX7\nG0 X8\n").unwrap();
    let runs: std::vec::Vec<std::vec::Vec<u32>> = feed_runs(&points)
        .map(|r| r.iter().map(|p| p.line).collect())
        .collect();
    // Each run starts at the point before its first feed move.
    assert_eq!(runs, [vec![1, 2, 3], vec![3, 4], vec![5, 6, 7]]);
    let (points, _) = parse_str::<4>("G1 X1 F60\nX2\n").unwrap();
    assert_eq!(feed_runs(&points).next().map(<[_]>::len), Some(2));
}

mod reader;
