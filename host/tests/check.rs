//! `kerf check` and its library (`kerf_host::check`, `kerf_host::preview`): the
//! workspace's edge found where the inverse kinematics stops, the preview of an
//! accepted job, the machine chosen by the job's kind or by name, and the command's
//! exit codes with nothing written for a refused job.

mod common;

use kerf::kinematics::delta::DeltaGeometry;
use kerf::machines::delta_slave::product::CUT_HEIGHT_M;
use kerf::machines::delta_slave::DeltaSlaveConfig;
use kerf_host::check::{check, workspace_outline, CheckError, Machine, OUTLINE_DIRECTIONS};
use kerf_host::job::Job;
use nalgebra::Vector3;
use std::path::PathBuf;

use common::{kerf, text, tmp};

/// The letter 's' (25 points, 16 mm tall) as a points job, scaled by `scale`.
fn letter_job(scale: f32) -> Vec<u8> {
    let points_m = kerf::trajectory::shapes::letter_s()
        .iter()
        .map(|p| [p[0] as f32 * scale, p[1] as f32 * scale])
        .collect();
    Job::Path { points_m }.to_bytes().unwrap()
}

/// Each point of the outline is reached, and one 2 µm farther out in its direction is
/// not (the search stops within 1 µm of the edge); the outline goes all the way round.
#[test]
fn the_workspace_edge_is_where_the_inverse_kinematics_stops() {
    let machine = DeltaSlaveConfig::KEOPS;
    let geometry = DeltaGeometry::<f64>::new(&machine.delta).unwrap();
    let reaches = |p: [f64; 2]| {
        geometry
            .inverse(&Vector3::new(p[0], p[1], CUT_HEIGHT_M))
            .is_ok()
    };
    let outline = workspace_outline(&machine, [0.0, 0.0], CUT_HEIGHT_M);
    assert_eq!(outline.len(), OUTLINE_DIRECTIONS);
    let (mut nearest, mut farthest) = (f64::INFINITY, 0.0f64);
    for (k, p) in outline.iter().enumerate() {
        let r = p[0].hypot(p[1]);
        let phi = std::f64::consts::TAU * k as f64 / OUTLINE_DIRECTIONS as f64;
        assert!((p[1].atan2(p[0]) - phi).sin().abs() < 1e-9, "direction {k}");
        let out = [(r + 2e-6) * phi.cos(), (r + 2e-6) * phi.sin()];
        assert!(reaches(*p) && !reaches(out), "direction {k}: r = {r}");
        nearest = nearest.min(r);
        farthest = farthest.max(r);
    }
    println!(
        "Keops workspace at z = 50 mm: {:.2} to {:.2} mm from the axis",
        nearest * 1e3,
        farthest * 1e3
    );
    // The three-fold shape of the picture: well inside 100 mm, well outside 5 mm.
    assert!(nearest > 5e-3 && farthest < 0.1 && farthest > 1.5 * nearest);
    // A centre out of reach has no outline.
    assert!(workspace_outline(&machine, [1.0, 0.0], CUT_HEIGHT_M).is_empty());
}

/// An accepted job's preview: the cut from the job's start, the travel from the
/// centre to it, all inside the workspace's edge; an open path's cut ends at its last
/// point; the SVG names what it draws.
#[test]
fn an_accepted_job_has_a_preview_inside_the_workspace() {
    let checked = check(&letter_job(1.0), None).expect("the letter fits");
    assert_eq!(checked.machine, Machine::KeopsSlave);
    let preview = checked.preview.clone().expect("the laser delta draws one");
    assert_eq!(preview.closed, [false]);
    assert_eq!(preview.travels_m.len(), 1);
    assert_eq!(preview.travels_m[0][0], [0.0, 0.0]);
    assert_eq!(Some(&preview.travels_m[0][1]), preview.cuts_m[0].first());
    // The letter's first and last points, where the file puts them (f32).
    let letter = kerf::trajectory::shapes::letter_s().map(|p| p.map(|v| f64::from(v as f32)));
    let cut = &preview.cuts_m[0];
    let (start, end) = (cut[0], *cut.last().unwrap());
    let last = letter[letter.len() - 1];
    assert!((start[0] - letter[0][0]).hypot(start[1] - letter[0][1]) < 1e-12);
    assert!((end[0] - last[0]).hypot(end[1] - last[1]) < 1e-12);
    // Every point of the cut is inside the edge: nearer the centre than the edge in
    // its direction (the edge is star-shaped about the centre).
    let edge = &preview.workspace_m;
    for p in cut {
        let k = (p[1].atan2(p[0]).rem_euclid(std::f64::consts::TAU) / std::f64::consts::TAU
            * OUTLINE_DIRECTIONS as f64)
            .round() as usize
            % OUTLINE_DIRECTIONS;
        assert!(p[0].hypot(p[1]) < edge[k][0].hypot(edge[k][1]));
    }
    let svg = kerf_host::preview::svg("letter", &checked)
        .unwrap()
        .unwrap();
    for words in [
        "workspace at z = 50.0 mm",
        "travel, beam off",
        "cut, beam on",
        "start",
        "open path on keops-slave",
    ] {
        assert!(svg.contains(words), "{words}");
    }
}

/// The machine follows the job's kind unless named; a machine named for a kind it
/// does not take says what it takes.
#[test]
fn the_machine_is_the_one_that_takes_the_kind_or_the_one_named() {
    let pyramid =
        std::fs::read(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/pyramid.gcode"))
            .unwrap();
    let gcode = Job::Gcode { text: pyramid }.to_bytes().unwrap();
    let arrow = check(&gcode, None).expect("ARROW takes its pyramid");
    assert_eq!(arrow.machine, Machine::Arrow);
    assert!(arrow.duration_s > 0.0 && arrow.cut_length_m > 0.0);
    match check(&gcode, Some(Machine::KeopsSlave)) {
        Err(e @ CheckError::Kind { .. }) => {
            assert_eq!(e.to_string(), "keops-slave does not take G-code jobs (it takes EFD (closed contour), points (open path), moves (sharp corners))")
        }
        other => panic!("{other:?}"),
    }
    let schedule = Job::Schedule {
        steps: vec![[0.0, 1.0]],
    }
    .to_bytes()
    .unwrap();
    assert!(matches!(
        check(&schedule, None),
        Err(CheckError::NoMachineFor(_))
    ));
    assert!(matches!(
        check(b"not a job", None),
        Err(CheckError::File(_))
    ));
    for m in kerf_host::check::MACHINES {
        assert_eq!(Machine::from_name(m.name()), Some(m));
    }
    use kerf_host::check::kind_words;
    use kerf_host::job::JobKind;
    assert_eq!(
        Machine::for_kind(JobKind::Points),
        Some(Machine::KeopsSlave)
    );
    assert_eq!(Machine::for_kind(JobKind::Gcode), Some(Machine::Arrow));
    assert_eq!(Machine::for_kind(JobKind::Moves), Some(Machine::KeopsSlave));
    assert_eq!(Machine::for_kind(JobKind::Recording), None);
    let kinds = [
        JobKind::Efd,
        JobKind::Points,
        JobKind::Gcode,
        JobKind::Recording,
        JobKind::Schedule,
        JobKind::Moves,
    ];
    let words: std::collections::BTreeSet<&str> = kinds.iter().map(|&k| kind_words(k)).collect();
    assert_eq!(words.len(), kinds.len());
}

/// `kerf check`: exit 0 with the duration and the preview written; exit 1 for a job
/// the machine would refuse, in its words, and no preview left behind; a machine
/// named by `--machine` is the one checked.
#[test]
fn kerf_check_exits_by_the_machines_verdict_and_writes_nothing_for_a_refusal() {
    let good = tmp("check-letter.kjob");
    let big = tmp("check-letter-x8.kjob");
    std::fs::write(&good, letter_job(1.0)).unwrap();
    std::fs::write(&big, letter_job(8.0)).unwrap();
    let svg = tmp("check-letter.svg");
    let _ = std::fs::remove_file(&svg);
    let out = kerf(&[
        "check",
        good.to_str().unwrap(),
        "--preview",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let said = text(&out.stdout);
    assert!(
        said.contains("keops-slave accepts it") && said.contains("about 4.58 s"),
        "{said}"
    );
    assert!(std::fs::read_to_string(&svg)
        .unwrap()
        .contains("cut, beam on"));

    let refused = tmp("check-refused.svg");
    let _ = std::fs::remove_file(&refused);
    let out = kerf(&[
        "check",
        big.to_str().unwrap(),
        "--preview",
        refused.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert!(err.contains("keops-slave would refuse this job: job code 0x0009: a point of the contour leaves the workspace"), "{err}");
    assert!(!refused.exists());

    let out = kerf(&["check", good.to_str().unwrap(), "--machine", "arrow"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        text(&out.stderr).contains("arrow does not take points (open path) jobs"),
        "{}",
        text(&out.stderr)
    );
    for args in [&["check"][..], &["check", "x", "--machine", "lathe"]] {
        assert_eq!(kerf(args).status.code(), Some(2), "{args:?}");
    }
    let out = kerf(&["check", "/nonexistent/job"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("cannot read the job file"));
}

/// ARROW's preview, seen along its tool (x right, z up): the pyramid's programmed
/// points (a scan of the file's X and Z words) are points of its drawn path (the
/// spline passes through them), and the workspace's edge is where A eq. 25 ends: every
/// edge point passes the machine's workspace check and one 2 µm farther out does not;
/// the edge spans z ±150 mm, eq. 25's z limits.
#[test]
fn arrows_preview_draws_its_program_inside_its_workspace() {
    use kerf::kinematics::arrow::{ArrowConfig, ArrowGeometry, Pose};
    let text = std::fs::read_to_string(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/pyramid.gcode"),
    )
    .unwrap();
    let gcode = Job::Gcode {
        text: text.clone().into_bytes(),
    }
    .to_bytes()
    .unwrap();
    let preview = check(&gcode, None)
        .unwrap()
        .preview
        .expect("ARROW draws one");
    let word = |line: &str, letter: char| -> Option<f64> {
        let code = line.split('(').next()?;
        let at = code.find(letter)?;
        let rest = &code[at + 1..];
        let end = rest.find(|c: char| c.is_whitespace()).unwrap_or(rest.len());
        rest[..end].parse().ok()
    };
    let drawn: Vec<[f64; 2]> = preview
        .cuts_m
        .iter()
        .chain(&preview.travels_m)
        .flatten()
        .copied()
        .collect();
    let mut targets = 0;
    for line in text.lines().filter(|l| !l.starts_with('(')) {
        let (Some(x), Some(z)) = (word(line, 'X'), word(line, 'Z')) else {
            continue;
        };
        targets += 1;
        let p = [x * 1e-3, z * 1e-3];
        let nearest = drawn
            .iter()
            .map(|d| (d[0] - p[0]).hypot(d[1] - p[1]))
            .fold(f64::INFINITY, f64::min);
        assert!(nearest < 1e-9, "{line}: {nearest}");
    }
    assert!(targets > 20, "{targets}");
    let svg = kerf_host::preview::svg("pyramid", &check(&gcode, None).unwrap())
        .unwrap()
        .unwrap();
    for words in ["z, mm", "seen along the tool", "feed, tool cutting"] {
        assert!(svg.contains(words), "{words}");
    }
    let config = ArrowConfig::ARROW;
    let geometry = ArrowGeometry::<f64>::new(&config).unwrap();
    let y0 = config.workspace.y0_m;
    let fits = |p: [f64; 2]| {
        geometry
            .check_workspace(&Pose::new(p[0], y0, p[1], 0.0), 0.0)
            .is_ok()
    };
    assert_eq!(preview.workspace_m.len(), OUTLINE_DIRECTIONS);
    assert_eq!(
        preview.workspace_m,
        kerf_host::check::arrow_outline(&config)
    );
    for p in &preview.workspace_m {
        let r = p[0].hypot(p[1]);
        let farther = [p[0] * (r + 2e-6) / r, p[1] * (r + 2e-6) / r];
        assert!(fits(*p) && !fits(farther), "{p:?}");
    }
    let top = preview
        .workspace_m
        .iter()
        .map(|p| p[1])
        .fold(f64::MIN, f64::max);
    assert!((top - config.workspace.z_half_m).abs() < 1e-6, "{top}");
}

/// `kerf check` says how each part will be cut: the LightBurn-style plate's two layers
/// each at its own speed and energy per length, the same settings over the command
/// line for every part, and a part that leaves them to the machine with the
/// machine's own values.
#[test]
fn kerf_check_says_how_each_part_is_cut() {
    let plate = tmp("check-plate.kjob");
    let program = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../data/gcode/lightburn-style-plate.gcode"
    );
    let out = kerf(&[
        "gcode",
        program,
        "--machine",
        "keops-slave",
        "--centre",
        "--out",
        plate.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let said = text(&kerf(&["check", plate.to_str().unwrap()]).stdout);
    assert!(
        said.contains("settings   part 1: 8.0 mm/s, 1.000 J/mm (M4)"),
        "{said}"
    );
    assert!(
        said.contains("settings   part 2: 6.0 mm/s, 2.000 J/mm (M4)"),
        "{said}"
    );
    let over = text(
        &kerf(&[
            "check",
            plate.to_str().unwrap(),
            "--power-w",
            "3",
            "--passes",
            "2",
        ])
        .stdout,
    );
    assert!(
        over.contains("settings   part 1: 8.0 mm/s, 3.00 W (M3), 2 passes"),
        "{over}"
    );
    let letter = tmp("check-letter-settings.kjob");
    std::fs::write(&letter, letter_job(1.0)).unwrap();
    let said = text(&kerf(&["check", letter.to_str().unwrap()]).stdout);
    assert!(
        said.contains("settings   8.0 mm/s (the machine's), 1.250 J/mm (the machine's)"),
        "{said}"
    );
}

/// The grinding cell and the single axis check G-code with their own loaders: a pass
/// of 0.5 mm at F6 (0.1 mm/s) takes 5 s; the axis' moves are accepted; a program a
/// machine cannot run is refused in its words at the line its loader names, on the
/// command line as FILE:LINE:COLUMN.
#[test]
fn every_gcode_machine_checks_its_programs() {
    use kerf_host::gcode::check_on;
    let data = |name: &str| {
        std::fs::read(
            PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("../data")
                .join(name),
        )
        .unwrap()
    };
    let pass = check_on(Machine::Grinding, &data("grinding_pass.gcode")).unwrap();
    assert!((pass.cut_length_m - 0.5e-3).abs() < 1e-12);
    assert!(
        (pass.duration_s - 0.5 / 0.1).abs() < 1e-9,
        "{}",
        pass.duration_s
    );
    assert!(pass.preview.is_none());
    let moves = check_on(Machine::SingleAxis, &data("axis_moves.gcode")).unwrap();
    assert_eq!(moves.machine, Machine::SingleAxis);
    assert!(moves.duration_s > 0.0 && moves.cut_length_m > 0.0);
    let rapid = check_on(Machine::Grinding, &data("axis_moves.gcode")).unwrap_err();
    assert_eq!(rapid.line, 4);
    assert!(rapid.message.starts_with("a rapid move (G0)"), "{rapid}");
    let off_axis = check_on(Machine::SingleAxis, &data("gcode/cap.ngc")).unwrap_err();
    assert_eq!((off_axis.line, off_axis.column), (7, 1));
    assert!(off_axis.message.contains("X axis only"), "{off_axis}");
    assert!(check_on(Machine::Arrow, b"G1 X1 F60\n").is_err());
    assert_eq!(Machine::from_name("grinding"), Some(Machine::Grinding));
    assert_eq!(Machine::from_name("single-axis"), Some(Machine::SingleAxis));
    // A G-code job with no machine named is ARROW's.
    assert_eq!(
        Machine::for_kind(kerf_host::job::JobKind::Gcode),
        Some(Machine::Arrow)
    );
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/gcode/cap.ngc");
    let out = kerf(&["gcode", path.to_str().unwrap(), "--machine", "single-axis"]);
    assert_eq!(out.status.code(), Some(1));
    let said = text(&out.stderr);
    assert!(
        said.contains("cap.ngc:7:1: error: a move of Y, Z, A or B"),
        "{said}"
    );
    let kerfed = kerf(&[
        "gcode",
        path.to_str().unwrap(),
        "--machine",
        "grinding",
        "--kerf-mm",
        "1",
    ]);
    assert!(text(&kerfed.stderr).contains("a program for grinding carries its own feeds"));
}
