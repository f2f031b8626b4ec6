//! Real programs (`data/gcode/`, sources in its SOURCES.md) read by the firmware's
//! G-code reader: none has an error, and the end point of every line that moves is
//! where a separate, simpler scan of the file puts it.

use kerf::trajectory::gcode::{Diagnostic, GcodePoint, Parser, Severity};
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

/// Every point and diagnostic of `text`, through the line reader (no buffer limit).
fn read(text: &[u8]) -> (Vec<GcodePoint>, Vec<Diagnostic>) {
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

/// The scan: comments dropped, blanks removed, upper case; `G90`/`G91`, `G20`/`G21`
/// and `X Y Z` words tracked (`A B` only move) (the corpus uses no offsets); each line with an axis word
/// gives (line, end point in mm). Arcs end where their axis words say, as lines do.
fn scan(text: &str) -> Vec<(u32, [f64; 3])> {
    let (mut at, mut relative, mut inch) = ([0.0f64; 3], false, false);
    let mut ends = Vec::new();
    for (n, raw) in text.lines().enumerate() {
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
        let (points, found) = read(&text);
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
