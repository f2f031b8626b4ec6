//! Laser programs for the Keops slave (`kerf_host::laser`, `kerf gcode --machine
//! keops-slave`): the runs with the beam on found where M3/M4, S, M5 and G0 put them;
//! as moves (the default) each run its programmed points and feeds, a long run in
//! pieces that meet; fitted, a closed run an EFD part, an open one a spline part, each
//! within a stated distance of the programmed path; the laser rig's square from a
//! public repository cut as the slave checks it.

mod common;

use common::kerf;
use kerf::codec::job::JobFile;
use kerf_host::check::check;
use kerf_host::job::{split, Continuity, CutLaser, CutSettings};
use kerf_host::laser::{self, Beam, Corners, LaserProgram};
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
    // F and S stay the same along each run: nothing to say.
    assert!(program.notes.is_empty(), "{:?}", program.notes);
    let parts = laser::parts(&program, &PlanConfig::default(), false, &BEAM, Corners::Fit).unwrap();
    // F600 is 10 mm/s; M3 S500 of 1000 half the 20 W source, S200 a fifth.
    let square = CutSettings {
        speed_m_s: Some(0.01),
        laser: Some(CutLaser::PowerW(10.0)),
        ..CutSettings::MACHINE
    };
    assert_eq!(parts[0].settings, square);
    assert_eq!(parts[2].settings.laser, Some(CutLaser::PowerW(4.0)));
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
    let files = split(&bytes).unwrap();
    assert_eq!(files.len(), 3);
    // Each part's file carries its settings.
    for (file, part) in files.iter().zip(&parts) {
        assert_eq!(JobFile::read(file).unwrap().settings(), part.settings);
    }
}

/// The grbl laser's source of full power at S1000.
const BEAM: Beam = Beam {
    s_max: 1000.0,
    max_power_w: 20.0,
};

/// `M4` is energy per length (the power at the programmed feed over that feed); a
/// power change within a run (`S300` on the third move) ends the part there and the
/// next part, at its own power, goes on from it without a stop: the first carries the
/// second's points as its look-ahead (its speed the fastest feed among them), the
/// second continues it; fitted, each power is a part of its own.
#[test]
fn m4_is_energy_per_length_and_a_power_change_is_a_joined_part() {
    // F300 = 5 mm/s; S250 of 1000 = 5 W at 5 mm/s: 1,000 J/m; S300 at F600: 600 J/m.
    let program = laser::read(b"G21 M4 S250\nG1 X1 F300\nG1 X1 Y1\nG1 X0 Y1\nG1 X0 Y2 F600 S300\nG1 X2 Y2\nM5\nG0 X5\nM3 S2000\nG1 X6 F300\nG1 X7 Y1\n");
    assert!(!laser::has_errors(&program), "{:?}", program.diagnostics);
    assert!(program.notes.is_empty(), "{:?}", program.notes);
    assert!(!program.runs[0].joined && program.runs[1].joined && !program.runs[2].joined);
    let energy = |settings: &CutSettings| match settings.laser {
        Some(CutLaser::EnergyJPerM(e)) => e,
        other => panic!("{other:?}"),
    };
    let moves = laser::parts(
        &program,
        &PlanConfig::default(),
        false,
        &BEAM,
        Corners::Sharp,
    )
    .unwrap();
    assert_eq!(moves.len(), 3);
    assert!((energy(&moves[0].settings) - 1000.0).abs() < 1e-3);
    assert!((energy(&moves[1].settings) - 600.0).abs() < 1e-3);
    assert_eq!(moves[2].settings.laser, Some(CutLaser::PowerW(20.0)));
    let (first, second) = (moves[0].settings.continuity, moves[1].settings.continuity);
    assert_eq!((first.lookahead_points, first.continues), (2, false));
    assert_eq!((second.lookahead_points, second.continues), (0, true));
    assert_eq!(moves[0].settings.speed_m_s, Some(0.01));
    assert_eq!(moves[2].settings.continuity, Continuity::NONE);
    let bytes = laser::to_bytes(&moves).unwrap();
    let files = split(&bytes).unwrap();
    let points = |k: usize| -> Vec<[f32; 3]> {
        let file = JobFile::read(files[k]).unwrap();
        (0..file.count())
            .filter_map(|i| file.move_point(i))
            .collect()
    };
    // The run begins at its first move's end: no move put the tool anywhere before;
    // the second part begins where the first's cut ends.
    assert_eq!(
        points(0),
        [
            [1e-3, 0.0, 0.0],
            [1e-3, 1e-3, 5e-3],
            [0.0, 1e-3, 5e-3],
            [0.0, 2e-3, 1e-2],
            [2e-3, 2e-3, 1e-2]
        ]
    );
    assert_eq!(
        points(1),
        [[0.0, 1e-3, 0.0], [0.0, 2e-3, 1e-2], [2e-3, 2e-3, 1e-2]]
    );
    // The machine takes the second from the first's join.
    assert_eq!(check(&bytes, None).unwrap().parts, 3);
    let fitted =
        laser::parts(&program, &PlanConfig::default(), false, &BEAM, Corners::Fit).unwrap();
    assert_eq!(fitted.len(), 3);
    assert_eq!(fitted[0].settings.speed_m_s, Some(0.005));
    assert!(fitted
        .iter()
        .all(|p| p.settings.continuity == Continuity::NONE));
}

/// A run longer than a moves job holds is cut in pieces of at most 32 points, each
/// beginning where the one before's cut ends and continuing it; each but the last
/// carries the next one's first points as its look-ahead; a closed run's last piece
/// ends at its start, and only a run in one piece is closed.
#[test]
fn a_long_run_is_cut_in_pieces_that_meet() {
    use kerf::machines::delta_slave::MOVE_POINTS;
    let mut text = String::from("G21 M3 S100 G0 X0 Y0\nG1 X10 Y0 F600\n");
    // A circle of radius 10 about the origin from (10, 0), 72 chords.
    text.push_str("G2 X10 Y0 I-10 J0\n");
    let program = laser::read(text.as_bytes());
    assert!(!laser::has_errors(&program), "{:?}", program.diagnostics);
    let run = &program.runs[0];
    let parts = laser::parts(
        &program,
        &PlanConfig::default(),
        false,
        &BEAM,
        Corners::Sharp,
    )
    .unwrap();
    assert!(parts.iter().all(|p| p.run.path_mm.len() <= MOVE_POINTS));
    // The points each piece cuts, and those it carries ahead.
    let cut = |p: &laser::LaserPart| {
        let ahead = usize::from(p.settings.continuity.lookahead_points);
        let path = &p.run.path_mm;
        (
            path[..path.len() - ahead].to_vec(),
            path[path.len() - ahead..].to_vec(),
        )
    };
    let pieces: Vec<Vec<[f64; 2]>> = parts.iter().map(|p| cut(p).0).collect();
    assert!(pieces.len() >= 2, "{}", pieces.len());
    for (k, w) in parts.windows(2).enumerate() {
        let ((cut_before, ahead), (cut_next, _)) = (cut(&w[0]), cut(&w[1]));
        assert_eq!(cut_before.last(), cut_next.first());
        assert_eq!(ahead.len(), laser::LOOKAHEAD_POINTS.min(cut_next.len() - 1));
        assert_eq!(ahead[..], cut_next[1..=ahead.len()], "piece {k}");
        assert!(w[1].settings.continuity.continues && !parts[0].settings.continuity.continues);
    }
    assert_eq!(
        parts.last().unwrap().settings.continuity.lookahead_points,
        0
    );
    assert_eq!(pieces[0].first(), Some(&[0.0, 0.0]));
    // Every programmed point once (the meeting points twice), the run's end last.
    let total: usize = pieces.iter().map(|p| p.len()).sum();
    let end = if run.closed {
        run.path_mm[0]
    } else {
        *run.path_mm.last().unwrap()
    };
    assert_eq!(pieces.last().unwrap().last(), Some(&end));
    assert_eq!(
        total - (pieces.len() - 1),
        run.path_mm.len() + usize::from(run.closed)
    );
    assert!(parts.iter().all(|p| !p.run.closed));
}

#[test]
fn a_program_that_cuts_nothing_or_does_not_read_says_so() {
    let idle = laser::read(b"G21\nG0 X1 Y1\nM3 S0\nG1 X2 F100\n");
    assert!(idle.runs.is_empty());
    let e = laser::parts(&idle, &PlanConfig::default(), false, &BEAM, Corners::Sharp).unwrap_err();
    assert!(e.to_string().contains("cuts nothing"), "{e}");
    let broken = laser::read(b"G1 X1 F100 #1\n");
    assert!(laser::has_errors(&broken));
    let z = laser::read(b"M3 S1\nG1 X1 Z1 F100\nG1 X2 Z2\n");
    assert!(z.notes.iter().any(|n| n.starts_with("Z is not followed")));
}

/// The laser rig's 4 mm square (fraktalcyber/lfi-rig, MIT; data/gcode/SOURCES.md) on
/// the Keops slave: one closed part, centred, at the program's M4 S100 (a tenth of
/// full power at F6000, 100 mm/s: 20 J/m). Fitted with a curve, the slave cannot turn
/// its rounded corners at 100 mm/s: refused in its words and nothing written; at
/// 8 mm/s given on the command line it takes the part, which keeps the program's
/// energy per length. As moves (the default) it takes the program as it is: the
/// planner slows for each corner.
#[test]
fn the_laser_rigs_square_is_a_part_the_slave_takes() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../data/gcode/blue-laser-4x4mm-square.gcode"
    );
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let job = dir.join("laser-square.kjob");
    let _ = std::fs::remove_file(&job);
    let gcode = |extra: &[&str]| {
        let mut args = vec!["gcode", path, "--machine", "keops-slave", "--out"];
        args.push(job.to_str().unwrap());
        args.extend_from_slice(extra);
        kerf(&args)
    };
    let sharp = gcode(&["--centre"]);
    let said = String::from_utf8_lossy(&sharp.stdout);
    assert_eq!(sharp.status.code(), Some(0), "{said}");
    assert!(
        said.contains("4 moves, sharp corners, starts at (-2.00, -2.00) mm; 100.0 mm/s"),
        "{said}"
    );
    assert!(!said.contains("--centre moves them"), "{said}");
    let moves = std::fs::read(&job).unwrap();
    let cut_mm = check(&moves, None).unwrap().cut_length_m * 1e3;
    // Where the bed's corner is the origin, the refusal comes with the option to use.
    let cornered = gcode(&[]);
    let said = String::from_utf8_lossy(&cornered.stdout);
    assert_eq!(cornered.status.code(), Some(1), "{said}");
    assert!(
        said.contains(
            "note       the cuts span X 55.5 to 59.5 mm, Y 55.5 to 59.5 mm, away from the \
             workspace's centre (0, 0): --centre moves them there"
        ),
        "{said}"
    );
    assert!((cut_mm - 16.0).abs() < 0.01, "{cut_mm}");
    std::fs::remove_file(&job).unwrap();
    let fast = gcode(&["--centre", "--corners", "fit"]);
    assert_eq!(fast.status.code(), Some(1));
    let said = String::from_utf8_lossy(&fast.stdout);
    assert!(said.contains("100.0 mm/s, 0.020 J/mm (M4)"), "{said}");
    let e = String::from_utf8_lossy(&fast.stderr);
    assert!(e.contains("would refuse this job: job code 0x0008"), "{e}");
    assert!(!job.exists());
    let out = gcode(&["--centre", "--speed-mm-s", "8", "--corners", "fit"]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        said.contains("1 part for keops-slave")
            && said.contains(
                "closed (EFD), the fit within 0.038 mm of the program, starts at (-2.00, -2.00) mm"
            )
            && said.contains("check      keops-slave takes it"),
        "{said}"
    );
    // Its comments and tool change are warnings on standard error.
    assert!(String::from_utf8_lossy(&out.stderr).contains("read as a comment"));
    let bytes = std::fs::read(&job).unwrap();
    let settings = JobFile::read(&bytes).unwrap().settings();
    assert_eq!(settings.speed_m_s, Some(8e-3));
    assert_eq!(settings.laser, Some(CutLaser::EnergyJPerM(20.0)));
    let checked = check(&bytes, None).unwrap();
    // The 16 mm outline, its corners rounded: a little shorter.
    assert!(
        (checked.cut_length_m * 1e3 - 16.0).abs() < 0.2,
        "{}",
        checked.cut_length_m
    );
    // Not centred, the square lies 55 mm out, beyond the workspace: refused in words,
    // the file left as it was.
    let far = gcode(&["--speed-mm-s", "8", "--corners", "fit"]);
    assert_eq!(far.status.code(), Some(1));
    let e = String::from_utf8_lossy(&far.stderr);
    assert!(e.contains("leaves the workspace"), "{e}");
    assert_eq!(std::fs::read(&job).unwrap(), bytes);
}

/// A LightBurn-style program (data/gcode/lightburn-style-plate.gcode): two layers,
/// each part at its own layer's speed and power (M4: the energy per length S gives at
/// F), the hole first as in the file, and a program the slave takes.
#[test]
fn each_layer_of_a_lightburn_style_program_keeps_its_settings() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../data/gcode/lightburn-style-plate.gcode"
    );
    let program = laser::read(&std::fs::read(path).unwrap());
    assert!(!laser::has_errors(&program), "{:?}", program.diagnostics);
    let parts = laser::parts(
        &program,
        &PlanConfig::default(),
        true,
        &BEAM,
        Corners::Sharp,
    )
    .unwrap();
    assert_eq!(parts.len(), 2);
    // S400 of 1000 is 8 W, at F480 (8 mm/s) 1 J/mm; S600 is 12 W, at F360 2 J/mm.
    let expect = [(8e-3f32, 1000.0f32), (6e-3, 2000.0)];
    for (part, (speed, energy)) in parts.iter().zip(expect) {
        assert!(part.run.closed);
        assert_eq!(part.settings.speed_m_s, Some(speed));
        let Some(CutLaser::EnergyJPerM(e)) = part.settings.laser else {
            panic!("{:?}", part.settings)
        };
        assert!((e - energy).abs() < 1e-2, "{e}");
    }
    // The hexagon (3 mm about the centre) before the 12 mm outline.
    assert!(parts[0]
        .run
        .path_mm
        .iter()
        .all(|p| p[0].hypot(p[1]) < 3.0 + 1e-9));
    let checked = check(&laser::to_bytes(&parts).unwrap(), None).unwrap();
    assert_eq!(checked.parts, 2);
}

/// With a kerf, the hexagonal hole shrinks and the outline grows by half of it, corners
/// sharp (a regular hexagon's corner moves by d / cos 30°, a square's by d √2), each
/// move keeping its feed; a lead-in enters each from the scrap's side, 1 mm along its
/// first corner's bisector, as the part's first move; the slave takes them.
#[test]
fn the_kerf_and_lead_in_move_a_programs_closed_runs_to_the_scrap() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../data/gcode/lightburn-style-plate.gcode"
    );
    let program = laser::read(&std::fs::read(path).unwrap());
    let (kerf_mm, lead_in_mm) = (0.2, 1.0);
    let d = kerf_mm / 2.0;
    let config = |lead_in_mm| PlanConfig {
        kerf_mm,
        lead_in_mm,
        ..PlanConfig::default()
    };
    let parts = laser::parts(&program, &config(0.0), true, &BEAM, Corners::Sharp).unwrap();
    let hole = &parts[0].run;
    // A closed part's path comes back to its start.
    assert!(hole.closed && hole.path_mm.len() == 7 && hole.path_mm[0] == hole.path_mm[6]);
    let corner_r = 3.0 - d / 30f64.to_radians().cos();
    // The program writes 3 sin 60° = 2.5981 as 2.598: its corners lie within 0.1 µm
    // of 3 mm, and the moved ones within twice that of theirs.
    for p in &hole.path_mm {
        assert!((p[0].hypot(p[1]) - corner_r).abs() < 2e-4, "{p:?}");
    }
    let outline = &parts[1].run;
    for p in &outline.path_mm {
        assert!(
            (p[0].abs() - 6.1).abs() < 1e-9 && (p[1].abs() - 6.1).abs() < 1e-9,
            "{p:?}"
        );
    }
    assert_eq!(outline.feeds_m_s.len(), 5);
    assert!(outline.feeds_m_s[1..]
        .iter()
        .all(|&f| (f - 6e-3).abs() < 1e-12));
    // Inside, with the kerf's side turned: the hole grows, the outline shrinks.
    let inside = PlanConfig {
        kerf_side: kerf_host::kerf_offset::KerfSide::Inside,
        ..config(0.0)
    };
    let turned = laser::parts(&program, &inside, true, &BEAM, Corners::Sharp).unwrap();
    let grown = 3.0 + d / 30f64.to_radians().cos();
    let hole_start = turned[0].run.path_mm[0];
    assert!((hole_start[0].hypot(hole_start[1]) - grown).abs() < 2e-4);
    assert!((turned[1].run.path_mm[0][0].abs() - 5.9).abs() < 1e-9);
    let led = laser::parts(&program, &config(lead_in_mm), true, &BEAM, Corners::Sharp).unwrap();
    for (with, without) in led.iter().zip(&parts) {
        let (from, start) = (with.run.path_mm[0], without.run.path_mm[0]);
        assert!(!with.run.closed);
        assert_eq!(with.run.path_mm[1], start);
        assert_eq!(with.run.path_mm.last(), Some(&start));
        assert_eq!(with.run.feeds_m_s.len(), with.run.path_mm.len());
        let gap = (from[0] - start[0]).hypot(from[1] - start[1]);
        assert!((gap - lead_in_mm).abs() < 1e-9, "{gap}");
    }
    // Into the hole (towards its centre), out of the outline (away from its corner).
    let (hole_from, hole_start) = (led[0].run.path_mm[0], parts[0].run.path_mm[0]);
    assert!(hole_from[0].hypot(hole_from[1]) < hole_start[0].hypot(hole_start[1]));
    assert!((led[1].run.path_mm[0][0] - (-6.1 - lead_in_mm / 2f64.sqrt())).abs() < 1e-9);
    let checked = check(&laser::to_bytes(&led).unwrap(), None).unwrap();
    assert_eq!(checked.parts, 2);
}

/// The Keops slave's beam: S as a fraction of `s_max` of the machine's laser power.
#[test]
fn the_keops_beam_gives_s_as_a_share_of_its_full_power() {
    let program = laser::read(b"G21 G90\nM3 S250\nG1 X1 F600\nG1 Y1\nM5\n");
    let full_w = kerf::machines::delta_slave::DeltaSlaveConfig::KEOPS
        .laser
        .max_power_w;
    for (s_max, share) in [(Beam::GRBL_S_MAX, 0.25), (500.0, 0.5), (100.0, 1.0)] {
        let settings = Beam::keops(s_max).settings(&program.runs[0]);
        assert_eq!(
            settings.laser,
            Some(CutLaser::PowerW((share * full_w) as f32)),
            "S250 of {s_max}"
        );
    }
}
