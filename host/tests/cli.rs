//! The `kerf` binary: help, usage errors (exit 2), refused input (exit 1), a planned
//! job file, and `kerf gcode` on ARROW's pyramid program and broken copies of it.

mod common;

use kerf_host::job::Job;
use std::path::PathBuf;

use common::{kerf, text, tmp};

fn pyramid() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/pyramid.gcode")
}

#[test]
fn help_is_everywhere_and_usage_errors_exit_2() {
    for args in [
        &["--help"][..],
        &["plan", "--help"],
        &["gcode", "--help"],
        &["--version"],
    ] {
        let out = kerf(args);
        assert_eq!(out.status.code(), Some(0), "{args:?}");
        assert!(!out.stdout.is_empty());
    }
    for args in [
        &[][..],
        &["plan"],
        &["frobnicate"],
        &["plan", "x.png", "--harmonics", "many"],
        &["plan", "x.png", "--start", "3"],
        &["plan", "x.png", "--format", "svg"],
        &["gcode"],
    ] {
        assert_eq!(kerf(args).status.code(), Some(2), "{args:?}");
    }
}

fn octagon_png() -> PathBuf {
    let raster = common::Raster {
        size: 240,
        px_per_mm: 10.0,
    };
    let mm: Vec<[f64; 2]> = kerf::trajectory::shapes::octagon()
        .iter()
        .map(|p| [p[0] * 1e3, p[1] * 1e3])
        .collect();
    let path = tmp("octagon.png");
    raster.filled(&mm, 3).save(&path).unwrap();
    path
}

#[test]
fn plan_writes_an_efd_job_and_refuses_bad_input_with_exit_1() {
    let png = octagon_png();
    let job = tmp("octagon.kjob");
    let svg = tmp("octagon.svg");
    let png_s = png.to_str().unwrap();
    let out = kerf(&[
        "plan",
        png_s,
        "--out",
        job.to_str().unwrap(),
        "--harmonics",
        "20",
        "--svg",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains("closed") && stdout.contains("EFD, 20 harmonics"),
        "{stdout}"
    );
    let Job::Efd { coefficients, .. } = Job::from_bytes(&std::fs::read(&job).unwrap()).unwrap()
    else {
        panic!("not an EFD job");
    };
    assert_eq!(coefficients.len(), 20);
    // The first harmonic of a 12 mm octagon is a circle of about 6 mm radius.
    let c = coefficients[0];
    let r = ((c[0] * c[0] + c[1] * c[1] + c[2] * c[2] + c[3] * c[3]) / 2.0).sqrt();
    assert!((r - 5.8e-3).abs() < 0.3e-3, "{r}");
    assert!(std::fs::metadata(&svg).unwrap().len() > 1000);

    for (args, says) in [
        (vec!["plan", png_s, "--harmonics", "31"], "harmonics"),
        (vec!["plan", png_s, "--width-mm", "0"], "width"),
        (vec!["plan", png_s, "--start", "10,10"], "closed"),
        (vec!["plan", "/nonexistent/x.png"], "cannot read"),
        (vec!["plan", file!()], "cannot read"),
    ] {
        let out = kerf(&args);
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        assert!(
            text(&out.stderr).contains(says),
            "{args:?}: {}",
            text(&out.stderr)
        );
    }
}

#[test]
fn plan_writes_a_path_job_for_an_open_contour() {
    let raster = common::Raster {
        size: 300,
        px_per_mm: 20.0,
    };
    let mm: Vec<[f64; 2]> = kerf::trajectory::shapes::letter_s()
        .iter()
        .map(|p| [p[0] * 1e3, p[1] * 1e3])
        .collect();
    let png = tmp("letter_s.png");
    raster.stroke(&mm, 3.0, 5).save(&png).unwrap();
    let start = raster.px(mm[0]);
    let start = format!("{:.0},{:.0}", start[0], start[1]);
    let job = tmp("letter_s.kjob");
    let png_s = png.to_str().unwrap();
    let out = kerf(&[
        "plan",
        png_s,
        "--start",
        &start,
        "--out",
        job.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let Job::Path { points_m } = Job::from_bytes(&std::fs::read(&job).unwrap()).unwrap() else {
        panic!("not a path job");
    };
    assert!((3..=32).contains(&points_m.len()));
    // An open contour has no EFD, and a letter has no closed contour.
    let out = kerf(&["plan", png_s, "--start", &start, "--format", "efd"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        text(&out.stderr).contains("open contour"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn gcode_accepts_the_pyramid_and_packs_it() {
    let job = tmp("pyramid.kjob");
    let out = kerf(&[
        "gcode",
        pyramid().to_str().unwrap(),
        "--out",
        job.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    println!("{stdout}");
    assert!(
        stdout.contains("accepted") && stdout.contains("total length"),
        "{stdout}"
    );
    let back = Job::from_bytes(&std::fs::read(&job).unwrap()).unwrap();
    assert_eq!(
        back,
        Job::Gcode {
            text: std::fs::read(pyramid()).unwrap()
        }
    );
}

/// Runs `kerf gcode` on the pyramid with `from` replaced by `to` (once) and returns
/// its first error after checking exit 1 and the FILE:LINE:COLUMN prefix: (line, column,
/// message).
fn broken(name: &str, from: &str, to: &str) -> (u32, u32, String) {
    let original = std::fs::read_to_string(pyramid()).unwrap();
    assert!(original.contains(from));
    let path = tmp(name);
    std::fs::write(&path, original.replacen(from, to, 1)).unwrap();
    let out = kerf(&["gcode", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = text(&out.stderr);
    println!("{stderr}");
    let prefix = format!("{}:", path.display());
    // Warnings (the pyramid's lines after M30) come before the error.
    let first_error = stderr
        .lines()
        .find(|l| l.contains(": error: "))
        .expect("an error");
    let rest = first_error.strip_prefix(&prefix).expect("FILE: prefix");
    let mut parts = rest.splitn(3, ':');
    let line = parts.next().unwrap().parse().expect("LINE");
    let column = parts.next().unwrap().parse().expect("COLUMN");
    (line, column, parts.next().unwrap().trim().to_string())
}

fn line_of(needle: &str) -> u32 {
    let original = std::fs::read_to_string(pyramid()).unwrap();
    1 + original.lines().position(|l| l.contains(needle)).unwrap() as u32
}

#[test]
fn gcode_reports_file_line_and_column_and_exits_1() {
    // A second decimal point: the parser's line and the column of the stray '.'.
    let (line, column, message) = broken("bad_number.gcode", "N70 X13.333", "N70 X13.3.33");
    assert_eq!((line, column), (line_of("N70 X13.333"), 10));
    assert!(message.contains("unexpected '.'"), "{message}");
    // An arc without its centre or radius, at its G2.
    let (line, column, message) = broken("arc.gcode", "N100 X-7.333", "N100 G2 X-7.333");
    assert_eq!((line, column), (line_of("N100 X-7.333"), 6));
    assert!(message.contains("error: arc needs"), "{message}");
    // A point far outside ARROW's workspace: the loader names the line.
    let (line, column, message) = broken("outside.gcode", "N90 X7.333", "N90 X1900.0");
    assert_eq!((line, column), (line_of("N90 X7.333"), 1));
    assert!(
        message.contains("workspace") || message.contains("reach"),
        "{message}"
    );
}

#[test]
fn the_machine_commands_check_their_arguments_and_report_an_unreachable_machine() {
    for args in [
        &["run", "--help"][..],
        &["get", "--help"],
        &["set", "--help"],
        &["log", "--help"],
        &["status", "--help"],
    ] {
        assert_eq!(kerf(args).status.code(), Some(0), "{args:?}");
    }
    // No machine named, two named, an image without --qemu, a bad --set-at: usage.
    for args in [
        &["status"][..],
        &["status", "--qemu", "--port", "/dev/null"],
        &["status", "--image", "x.elf", "--port", "/dev/null"],
        &["get", "--qemu"],
        &["set", "/slave/dob/bandwidth_hz", "--qemu"],
        &[
            "run",
            "job.krfj",
            "--qemu",
            "--set-at",
            "soon:/slave/dob/bandwidth_hz=1",
        ],
        &["run", "job.krfj", "--qemu", "--set-at", "1:slave=1"],
        &[
            "run",
            "job.krfj",
            "--qemu",
            "--set-at",
            "-1:/slave/dob/bandwidth_hz=1",
        ],
    ] {
        assert_eq!(kerf(args).status.code(), Some(2), "{args:?}");
    }
    // A job file that is not one: bad input, before any machine is started.
    let junk = tmp("junk.krfj");
    std::fs::write(&junk, b"KRFJ not a job").unwrap();
    let out = kerf(&[
        "run",
        junk.to_str().unwrap(),
        "--qemu",
        "--image",
        "/nonexistent/link",
    ]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stderr));
    // No image, no port: the machine cannot be reached.
    let out = kerf(&["status", "--qemu", "--image", "/nonexistent/link"]);
    assert_eq!(out.status.code(), Some(3));
    assert!(
        text(&out.stderr).contains("no firmware image"),
        "{}",
        text(&out.stderr)
    );
    let out = kerf(&[
        "get",
        "/slave/dob/bandwidth_hz",
        "--port",
        "/nonexistent/ttyACM9",
    ]);
    assert_eq!(out.status.code(), Some(3));
    assert!(
        text(&out.stderr).contains("/nonexistent/ttyACM9"),
        "{}",
        text(&out.stderr)
    );
}

/// A faint disc (grey 120 on 136: a Sobel step of 64, under Canny's upper 100) has no
/// edge as it is, and the refusal names `--threshold`; cut into ink and paper at 128
/// it is a clean circle: the fit 6 mm from its centre all round (the 12 mm width), to
/// 0.1 mm (the traced chain is a digital circle, within about a pixel of the true one,
/// and a pixel is 0.075 mm). A threshold of 0 is refused in words.
#[test]
fn a_threshold_finds_a_faint_shape() {
    use kerf_host::plan::{plan_image, PlanConfig};
    let (size, r) = (200u32, 80.0f64);
    let gray = image::GrayImage::from_fn(size, size, |x, y| {
        let d = (f64::from(x) - 100.0).hypot(f64::from(y) - 100.0);
        image::Luma([if d < r { 120 } else { 136 }])
    });
    let e = plan_image(&gray, &PlanConfig::default(), &mut |_| {}).unwrap_err();
    assert!(e.to_string().contains("--threshold 128"), "{e}");
    let config = PlanConfig {
        threshold: Some(128),
        ..PlanConfig::default()
    };
    let plan = plan_image(&gray, &config, &mut |_| {}).unwrap();
    for p in plan.fit.samples_mm(256) {
        let radius = p[0].hypot(p[1]);
        assert!((radius - 6.0).abs() < 0.1, "{radius}");
    }
    let zero = PlanConfig {
        threshold: Some(0),
        ..PlanConfig::default()
    };
    let e = plan_image(&gray, &zero, &mut |_| {}).unwrap_err();
    assert!(e.to_string().contains("threshold must be 1 to 255"), "{e}");
}

#[test]
fn session_commands_without_a_station_and_serve_misuse_are_refused_in_words() {
    // Nothing listens at port 1: the link's exit code, in words.
    for args in [
        &["get", "/slave/dob", "--session", "127.0.0.1:1"][..],
        &["status", "--json", "--session", "127.0.0.1:1"],
        &["set", "/a/b", "1", "--session", "127.0.0.1:1"],
    ] {
        let out = kerf(args);
        assert_eq!(out.status.code(), Some(3), "{args:?}");
        assert!(
            text(&out.stderr).contains("127.0.0.1:1: no kerf serve answers there"),
            "{}",
            text(&out.stderr)
        );
    }
    for (args, words) in [
        (
            &["serve", "--session", "127.0.0.1:1"][..],
            "kerf serve holds the machine itself",
        ),
        (
            &["serve", "--qemu", "--listen", "nowhere"],
            "--listen nowhere: cannot listen there",
        ),
        (&["serve", "--qemu", "--telemetry-hz", "0"], "positive rate"),
        (
            &["log", "--session", "127.0.0.1:1"],
            "this command opens the machine itself",
        ),
    ] {
        let out = kerf(args);
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        assert!(text(&out.stderr).contains(words), "{}", text(&out.stderr));
    }
    // A session and a machine of its own at once: a usage error.
    assert_eq!(
        kerf(&["get", "/x", "--session", "127.0.0.1:1", "--qemu"])
            .status
            .code(),
        Some(2)
    );
}
