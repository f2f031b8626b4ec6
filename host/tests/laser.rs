//! Laser programs for the Keops slave (`kerf_host::laser`, `kerf gcode --machine
//! keops-slave`): the runs with the beam on found where M3/M4, S, M5 and G0 put them;
//! a closed run an EFD part, an open one a spline part, each within a stated distance
//! of the programmed path; the laser rig's square from a public repository cut as the
//! slave checks it.

mod common;

use common::kerf;
use kerf_host::check::check;
use kerf_host::job::split;
use kerf_host::laser::{self, LaserProgram};
use kerf_host::plan::PlanConfig;

/// A square, a two-segment open path, a move with the beam off (M5), one with S0, and
/// an arc with the beam on again.
const PROGRAM: &str = "G21 G90 M3 S500\nG0 X0 Y0\nG1 X2 Y0 F600\nG1 X2 Y2\nG1 X0 Y2\nG1 X0 Y0\nG0 X5 Y0\nG1 X7 Y1\nG1 X8 Y3\nM5\nG1 X9 Y3\nM3 S0\nG1 X10 Y3\nS200\nG2 X12 Y3 I1 J0\n";

#[test]
fn the_runs_with_the_beam_on_are_the_parts() {
    let program: LaserProgram = laser::read(PROGRAM.as_bytes());
    assert!(!laser::has_errors(&program), "{:?}", program.diagnostics);
    let runs: Vec<(bool, usize, [u32; 2])> = program
        .runs
        .iter()
        .map(|r| (r.closed, r.path_mm.len(), r.lines))
        .collect();
    // The square (its closing point dropped), the open path from where the rapid
    // ended, and the arc from (10, 3) in chords.
    assert_eq!(runs[0], (true, 4, [3, 6]));
    assert_eq!(runs[1], (false, 3, [8, 9]));
    assert_eq!(runs.len(), 3);
    let arc = &program.runs[2];
    assert_eq!(arc.path_mm.first(), Some(&[10.0, 3.0]));
    let end = arc.path_mm.last().unwrap();
    assert!((end[0] - 12.0).hypot(end[1] - 3.0) < 1e-9);
    // Every chord point on the circle of radius 1 about (11, 3).
    for p in &arc.path_mm {
        assert!(
            ((p[0] - 11.0).hypot(p[1] - 3.0) - 1.0).abs() < 1e-9,
            "{p:?}"
        );
    }
    assert_eq!(program.notes.len(), 1, "{:?}", program.notes);
    let parts = laser::parts(&program, &PlanConfig::default(), false).unwrap();
    for p in &parts {
        println!(
            "lines {:?}: closed {}, the fit within {:.4} mm",
            p.run.lines, p.run.closed, p.deviation_mm
        );
    }
    // The square's EFD of 30 harmonics rounds its corners by a few hundredths of a
    // millimetre (2 mm side); the splines through up to 32 points of the open paths
    // stay within a few micrometres of a polyline corner's and an arc's path.
    assert!(parts[0].deviation_mm < 0.03, "{}", parts[0].deviation_mm);
    assert!(parts[1].deviation_mm < 0.01, "{}", parts[1].deviation_mm);
    assert!(parts[2].deviation_mm < 0.005, "{}", parts[2].deviation_mm);
    let bytes = laser::to_bytes(&parts).unwrap();
    assert_eq!(split(&bytes).unwrap().len(), 3);
}

#[test]
fn a_program_that_cuts_nothing_or_does_not_read_says_so() {
    let idle = laser::read(b"G21\nG0 X1 Y1\nM3 S0\nG1 X2 F100\n");
    assert!(idle.runs.is_empty());
    let e = laser::parts(&idle, &PlanConfig::default(), false).unwrap_err();
    assert!(e.to_string().contains("cuts nothing"), "{e}");
    let broken = laser::read(b"G1 X1 F100 #1\n");
    assert!(laser::has_errors(&broken));
    let z = laser::read(b"M3 S1\nG1 X1 Z1 F100\nG1 X2 Z2\n");
    assert!(z.notes.iter().any(|n| n.starts_with("Z is not followed")));
}

/// The laser rig's 4 mm square (fraktalcyber/lfi-rig, MIT; data/gcode/SOURCES.md) on
/// the Keops slave: one closed part, centred, that the slave takes.
#[test]
fn the_laser_rigs_square_is_a_part_the_slave_takes() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../data/gcode/blue-laser-4x4mm-square.gcode"
    );
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let job = dir.join("laser-square.kjob");
    let out = kerf(&[
        "gcode",
        path,
        "--machine",
        "keops-slave",
        "--centre",
        "--out",
        job.to_str().unwrap(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        said.contains("1 parts for keops-slave")
            && said.contains("closed (EFD), starts at (-2.00, -2.00) mm"),
        "{said}"
    );
    // Its comments and tool change are warnings on standard error.
    assert!(String::from_utf8_lossy(&out.stderr).contains("read as a comment"));
    let checked = check(&std::fs::read(&job).unwrap(), None).unwrap();
    // The 16 mm outline, its corners rounded: a little shorter.
    assert!(
        (checked.cut_length_m * 1e3 - 16.0).abs() < 0.2,
        "{}",
        checked.cut_length_m
    );
    // Not centred, the square lies 55 mm out, beyond the workspace: refused in words.
    let far = dir.join("laser-square-far.kjob");
    assert_eq!(
        kerf(&[
            "gcode",
            path,
            "--machine",
            "keops-slave",
            "--out",
            far.to_str().unwrap()
        ])
        .status
        .code(),
        Some(0)
    );
    let e = check(&std::fs::read(&far).unwrap(), None).unwrap_err();
    assert!(e.to_string().contains("leaves the workspace"), "{e}");
}
