//! The cut settings (`--speed-mm-s`, `--power-w`, `--energy-j-per-mm`, `--beam-off`,
//! `--passes`), the kerf offset (`--kerf-mm`, `--kerf-side`), the lead-in and the
//! threshold at their edges, on every
//! command that takes them, as `edge_values` drives the other options: each case ends
//! in its exit code with a message that names the problem, never a panic, and leaves
//! no file but whole ones. A setting the slave cannot cut (25 W of its 20 W, a speed its
//! corners cannot take) is refused by its own load check, in its words, before any file
//! is written.

mod common;

use common::edges::{assert_all, inputs, Expect};

#[test]
fn cut_settings_and_the_kerf_at_their_edges() {
    use Expect::{Done, Fails};
    let i = inputs();
    let (png, gcode, job) = (&*i.png, &*i.gcode, &*i.job);
    let gcode_job = format!("{}/pyramid.kjob", i.folder);
    let written = common::kerf(&["gcode", gcode, "--out", &gcode_job]);
    assert_eq!(written.status.code(), Some(0));
    let plan = |extra: &[&'static str]| -> Vec<&str> {
        let mut v = vec!["plan", png, "--out", "{}/p.kjob"];
        v.extend_from_slice(extra);
        v
    };
    let check = |extra: &[&'static str]| -> Vec<&str> {
        let mut v = vec!["check", job];
        v.extend_from_slice(extra);
        v
    };
    let plate = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../data/gcode/lightburn-style-plate.gcode"
    );
    let laser = |extra: &[&'static str]| -> Vec<&str> {
        let mut v = vec!["gcode", plate, "--machine", "keops-slave", "--centre"];
        v.extend_from_slice(extra);
        v
    };
    let planned: &[&str] = &["p.kjob"];
    let cases: Vec<(&str, Vec<&str>, Expect)> = vec![
        ("speed", plan(&["--speed-mm-s", "4"]), Done(planned)),
        (
            "speed-0",
            plan(&["--speed-mm-s", "0"]),
            Fails(1, "--speed-mm-s 0: a speed above zero"),
        ),
        (
            "speed-neg",
            plan(&["--speed-mm-s=-3"]),
            Fails(1, "a speed above zero"),
        ),
        (
            "speed-nan",
            plan(&["--speed-mm-s", "NaN"]),
            Fails(1, "a speed above zero"),
        ),
        (
            "speed-inf",
            plan(&["--speed-mm-s", "inf"]),
            Fails(1, "a speed above zero"),
        ),
        (
            "speed-huge",
            plan(&["--speed-mm-s", "1e45"]),
            Fails(1, "too large for the job file"),
        ),
        (
            "speed-1e40",
            plan(&["--speed-mm-s", "1e40"]),
            Fails(1, "0x0208"),
        ),
        (
            "speed-fast",
            plan(&["--speed-mm-s", "500"]),
            Fails(1, "would refuse this job"),
        ),
        (
            "speed-type",
            plan(&["--speed-mm-s", "x"]),
            Fails(2, "invalid value"),
        ),
        ("power", plan(&["--power-w", "5"]), Done(planned)),
        ("power-0", plan(&["--power-w", "0"]), Done(planned)),
        (
            "power-over",
            plan(&["--power-w", "25"]),
            Fails(1, "0x000b: the laser setting is out of range"),
        ),
        (
            "power-neg",
            plan(&["--power-w=-1"]),
            Fails(1, "a power of zero or more"),
        ),
        (
            "power-nan",
            plan(&["--power-w", "NaN"]),
            Fails(1, "a power of zero or more"),
        ),
        ("energy", plan(&["--energy-j-per-mm", "1"]), Done(planned)),
        (
            "energy-over",
            plan(&["--energy-j-per-mm", "3"]),
            Fails(1, "0x0208"),
        ),
        (
            "energy-neg",
            plan(&["--energy-j-per-mm=-1"]),
            Fails(1, "an energy per length of zero or more"),
        ),
        (
            "energy-inf",
            plan(&["--energy-j-per-mm", "inf"]),
            Fails(1, "an energy per length"),
        ),
        (
            "power-and-energy",
            plan(&["--power-w", "1", "--energy-j-per-mm", "1"]),
            Fails(2, "cannot be used with"),
        ),
        ("beam-off", plan(&["--beam-off"]), Done(planned)),
        (
            "beam-off-and-power",
            plan(&["--beam-off", "--power-w", "1"]),
            Fails(2, "cannot be used with"),
        ),
        ("passes", plan(&["--passes", "3"]), Done(planned)),
        (
            "passes-0",
            plan(&["--passes", "0"]),
            Fails(2, "invalid value"),
        ),
        (
            "passes-256",
            plan(&["--passes", "256"]),
            Fails(2, "invalid value"),
        ),
        ("kerf", plan(&["--kerf-mm", "0.2"]), Done(planned)),
        ("threshold", plan(&["--threshold", "128"]), Done(planned)),
        (
            "threshold-0",
            plan(&["--threshold", "0"]),
            Fails(2, "invalid value"),
        ),
        (
            "threshold-256",
            plan(&["--threshold", "256"]),
            Fails(2, "invalid value"),
        ),
        (
            "threshold-1",
            plan(&["--threshold", "1"]),
            Fails(1, "--threshold"),
        ),
        ("lead-in", plan(&["--lead-in-mm", "1.5"]), Done(planned)),
        (
            "lead-in-short",
            plan(&["--lead-in-mm", "0.2"]),
            Fails(1, "0x0008"),
        ),
        (
            "lead-in-neg",
            plan(&["--lead-in-mm=-1"]),
            Fails(1, "the lead-in must be"),
        ),
        (
            "lead-in-inf",
            plan(&["--lead-in-mm", "inf"]),
            Fails(1, "the lead-in must be"),
        ),
        (
            "lead-in-open",
            plan(&["--lead-in-mm", "1", "--start", "0,0"]),
            Fails(1, "closed contours"),
        ),
        (
            "kerf-inside",
            plan(&["--kerf-mm", "0.2", "--kerf-side", "inside"]),
            Done(planned),
        ),
        (
            "kerf-neg",
            plan(&["--kerf-mm=-0.2"]),
            Fails(1, "the kerf must be"),
        ),
        (
            "kerf-nan",
            plan(&["--kerf-mm", "NaN"]),
            Fails(1, "the kerf must be"),
        ),
        (
            "kerf-wide",
            plan(&["--kerf-mm", "6"]),
            Fails(1, "the kerf must be"),
        ),
        (
            "kerf-side-alone",
            plan(&["--kerf-side", "inside"]),
            Done(planned),
        ),
        (
            "kerf-side-bad",
            plan(&["--kerf-mm", "0.2", "--kerf-side", "up"]),
            Fails(2, "invalid value"),
        ),
        (
            "kerf-open",
            plan(&["--kerf-mm", "0.2", "--start", "0,0"]),
            Fails(1, "closed contours"),
        ),
        (
            "check-settings",
            check(&["--passes", "2", "--power-w", "3"]),
            Done(&[]),
        ),
        (
            "check-over",
            check(&["--power-w", "21"]),
            Fails(1, "would refuse this job"),
        ),
        (
            "gcode-arrow-settings",
            vec!["gcode", gcode, "--speed-mm-s", "4"],
            Fails(1, "a program for arrow carries its own feeds"),
        ),
        (
            "gcode-s-max-0",
            vec!["gcode", gcode, "--machine", "keops-slave", "--s-max", "0"],
            Fails(1, "--s-max 0"),
        ),
        (
            "gcode-kerf-lead-in",
            laser(&[
                "--kerf-mm",
                "0.2",
                "--lead-in-mm",
                "1",
                "--out",
                "{}/k.kjob",
            ]),
            Done(&["k.kjob"]),
        ),
        (
            "gcode-kerf-neg",
            laser(&["--kerf-mm=-0.1"]),
            Fails(1, "--kerf-mm -0.1: a length of 0 or more, mm"),
        ),
        (
            "gcode-lead-in-nan",
            laser(&["--lead-in-mm", "NaN"]),
            Fails(1, "--lead-in-mm NaN: a length of 0 or more"),
        ),
        (
            "gcode-kerf-wider-than-the-hole",
            laser(&["--kerf-mm", "7", "--out", "{}/k2.kjob"]),
            Fails(1, "runs into the contour"),
        ),
        (
            "gcode-lead-in-passes",
            laser(&["--lead-in-mm", "1", "--passes", "2"]),
            Fails(1, "--passes with --lead-in-mm"),
        ),
        (
            "gcode-arrow-kerf",
            vec!["gcode", gcode, "--kerf-mm", "0.1"],
            Fails(
                1,
                "--kerf-mm and --lead-in-mm are for the laser delta's parts",
            ),
        ),
        (
            "run-gcode-settings",
            vec![
                "run",
                &gcode_job,
                "--port",
                "/nonexistent/ttyKERF",
                "--passes",
                "2",
            ],
            Fails(1, "a G-code job takes no cut settings"),
        ),
    ];
    assert_all(&cases);
}
