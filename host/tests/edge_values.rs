//! The `kerf` command line never panics. Every subcommand is driven with the edge
//! values of each of its options (0, negative, huge, NaN, infinite, empty, the wrong
//! type), unreadable inputs and unwritable outputs (a missing folder, a folder, a
//! full disk), once with standard output read and once with it a pipe whose reader
//! has gone. Each case ends in its exit code of host/README.md (0 done, 1 bad input
//! or an output not written, 2 a usage error, 3 the machine not reached) with a
//! message that names the problem, never a panic (exit 101, "panicked"), and leaves
//! no file behind but whole ones. The machine commands are given a port that does
//! not exist: what they check before opening it is checked; past that, exit 3.

mod common;

use common::edges::{assert_all, inputs, Expect};
use std::path::Path;

#[test]
fn every_subcommand_at_its_edges_ends_in_a_message_and_its_exit_code() {
    use Expect::{Done, Fails};
    let i = inputs();
    let (png, gcode, job, text, folder) = (&*i.png, &*i.gcode, &*i.job, &*i.text, &*i.folder);
    let full = "/dev/full";
    let nowhere = "/nonexistent/ttyKERF";
    let plan = |extra: &[&'static str]| -> Vec<&str> {
        let mut v = vec!["plan", png, "--out", "{}/p.kjob", "--svg", "{}/p.svg"];
        v.extend_from_slice(extra);
        v
    };
    let planned: &[&str] = &["p.kjob", "p.svg"];
    let bad_setting = "bad setting";
    let mut cases: Vec<(&str, Vec<&str>, Expect)> = vec![
        ("plan", plan(&[]), Done(planned)),
        (
            "plan-canny-0-0",
            plan(&["--canny", "0,0"]),
            Fails(1, "0 < LOW <= HIGH"),
        ),
        (
            "plan-canny-0-1",
            plan(&["--canny", "0,1"]),
            Fails(1, "0 < LOW <= HIGH"),
        ),
        (
            "plan-canny-neg",
            plan(&["--canny=-1,5"]),
            Fails(1, "0 < LOW <= HIGH"),
        ),
        (
            "plan-canny-swapped",
            plan(&["--canny", "5,1"]),
            Fails(1, "0 < LOW <= HIGH"),
        ),
        (
            "plan-canny-huge",
            plan(&["--canny", "2000,3000"]),
            Fails(1, "above 1140"),
        ),
        (
            "plan-canny-f32",
            plan(&["--canny", "1e39,1e39"]),
            Fails(1, bad_setting),
        ),
        (
            "plan-canny-nan",
            plan(&["--canny", "NaN,1"]),
            Fails(2, "not a finite number"),
        ),
        (
            "plan-canny-inf",
            plan(&["--canny", "inf,inf"]),
            Fails(2, "not a finite number"),
        ),
        (
            "plan-canny-empty",
            plan(&["--canny="]),
            Fails(2, "expected two numbers"),
        ),
        (
            "plan-canny-type",
            plan(&["--canny", "1,x"]),
            Fails(2, "not a finite number"),
        ),
        ("plan-contour-1", plan(&["--contour", "1"]), Done(planned)),
        (
            "plan-contour-0",
            plan(&["--contour", "0"]),
            Fails(2, "--contour"),
        ),
        (
            "plan-contour-past",
            plan(&["--contour", "9"]),
            Fails(1, "closed contours (--contour 1 to"),
        ),
        (
            "plan-contour-huge",
            plan(&["--contour", "99999999999"]),
            Fails(2, "--contour"),
        ),
        (
            "plan-contour-type",
            plan(&["--contour", "x"]),
            Fails(2, "--contour"),
        ),
        ("plan-sigma-0", plan(&["--sigma", "0"]), Done(planned)),
        (
            "plan-sigma-neg",
            plan(&["--sigma=-1"]),
            Fails(1, "sigma must be 0"),
        ),
        (
            "plan-sigma-tiny",
            plan(&["--sigma", "1e-30"]),
            Fails(1, "at least 0.2 px"),
        ),
        (
            "plan-sigma-huge",
            plan(&["--sigma", "1e30"]),
            Fails(1, "larger side"),
        ),
        (
            "plan-sigma-nan",
            plan(&["--sigma", "NaN"]),
            Fails(1, "sigma must be 0"),
        ),
        (
            "plan-sigma-inf",
            plan(&["--sigma", "inf"]),
            Fails(1, "sigma must be 0"),
        ),
        (
            "plan-sigma-type",
            plan(&["--sigma", "x"]),
            Fails(2, "invalid value"),
        ),
        (
            "plan-width-0",
            plan(&["--width-mm", "0"]),
            Fails(1, "width must be"),
        ),
        (
            "plan-width-neg",
            plan(&["--width-mm=-1"]),
            Fails(1, "width must be"),
        ),
        (
            "plan-width-nan",
            plan(&["--width-mm", "NaN"]),
            Fails(1, "width must be"),
        ),
        (
            "plan-width-inf",
            plan(&["--width-mm", "inf"]),
            Fails(1, "width must be"),
        ),
        (
            "plan-width-huge",
            plan(&["--width-mm", "1e30"]),
            Fails(1, "--width-mm"),
        ),
        (
            "plan-width-tiny",
            plan(&["--width-mm", "1e-300"]),
            Fails(1, "firmware refuses"),
        ),
        (
            "plan-width-type",
            plan(&["--width-mm", ""]),
            Fails(2, "invalid value"),
        ),
        (
            "plan-harmonics-0",
            plan(&["--harmonics", "0"]),
            Fails(1, "harmonics must be"),
        ),
        (
            "plan-harmonics-31",
            plan(&["--harmonics", "31"]),
            Fails(1, "harmonics must be"),
        ),
        (
            "plan-harmonics-max",
            plan(&["--harmonics", "18446744073709551615"]),
            Fails(1, "harmonics must be"),
        ),
        (
            "plan-harmonics-over",
            plan(&["--harmonics", "18446744073709551616"]),
            Fails(2, "too large"),
        ),
        (
            "plan-harmonics-neg",
            plan(&["--harmonics=-1"]),
            Fails(2, "invalid"),
        ),
        (
            "plan-close-256",
            plan(&["--close-px", "256"]),
            Fails(2, "0..=255"),
        ),
        (
            "plan-close-neg",
            plan(&["--close-px=-1"]),
            Fails(2, "0..=255"),
        ),
        (
            "plan-start-nan",
            plan(&["--start", "NaN,0"]),
            Fails(2, "not a finite number"),
        ),
        (
            "plan-start-huge",
            plan(&["--start=1e300,-1e300"]),
            Fails(1, "lies outside the image"),
        ),
        (
            "plan-start-past-the-edge",
            plan(&["--start=-0.5,3"]),
            Fails(1, "--start -0.5,3 lies outside the image ("),
        ),
        (
            "plan-format",
            plan(&["--format", "svg"]),
            Fails(2, "invalid value"),
        ),
        (
            "plan-min-size-nan",
            plan(&["--all", "--min-size-mm", "NaN"]),
            Fails(1, "smallest size"),
        ),
        (
            "plan-min-size-huge",
            plan(&["--all", "--min-size-mm=1e300"]),
            Fails(1, "give a smaller"),
        ),
        (
            "plan-no-image",
            vec!["plan", "/nonexistent/x.png", "--out", "{}/p.kjob"],
            Fails(1, "no such file"),
        ),
        (
            "plan-folder-image",
            vec!["plan", folder, "--out", "{}/p.kjob"],
            Fails(1, "cannot read the image"),
        ),
        (
            "plan-text-image",
            vec!["plan", text, "--out", "{}/p.kjob"],
            Fails(1, "PNG and JPEG"),
        ),
        // The outputs are checked before the image is read.
        (
            "plan-out-missing",
            vec!["plan", "/nonexistent/x.png", "--out", "/nonexistent/p.kjob"],
            Fails(1, "cannot write the job file there: no such file or folder"),
        ),
        (
            "plan-out-folder",
            vec!["plan", png, "--out", "{}"],
            Fails(1, "that is a folder"),
        ),
        (
            "plan-out-twice",
            vec!["plan", png, "--out", "{}/p", "--svg", "{}/p"],
            Fails(1, "given for both"),
        ),
        (
            "gcode",
            vec!["gcode", gcode, "--out", "{}/g.kjob"],
            Done(&["g.kjob"]),
        ),
        (
            "gcode-missing",
            vec!["gcode", "/nonexistent/p.gcode", "--out", "{}/g.kjob"],
            Fails(1, "cannot read the program: no such file"),
        ),
        (
            "gcode-folder",
            vec!["gcode", folder, "--out", "{}/g.kjob"],
            Fails(1, "cannot read the program"),
        ),
        (
            "gcode-out-missing",
            vec!["gcode", gcode, "--out", "/nonexistent/g.kjob"],
            Fails(1, "no such file or folder"),
        ),
        (
            "gcode-empty-out",
            vec!["gcode", gcode, "--out="],
            Fails(2, "a value is required"),
        ),
        (
            "check",
            vec!["check", job, "--preview", "{}/c.svg"],
            Done(&["c.svg"]),
        ),
        ("check-text", vec!["check", text], Fails(1, "bad magic")),
        (
            "check-folder",
            vec!["check", folder],
            Fails(1, "cannot read the job file"),
        ),
        (
            "check-preview-missing",
            vec!["check", "/nonexistent/j", "--preview", "/nonexistent/c.svg"],
            Fails(1, "cannot write the preview there"),
        ),
        (
            "check-machine",
            vec!["check", job, "--machine", "arrow"],
            Fails(1, "does not take"),
        ),
        (
            "check-machine-empty",
            vec!["check", job, "--machine="],
            Fails(2, "a value is required"),
        ),
    ];
    if Path::new(full).exists() {
        cases.push((
            "plan-out-full",
            vec!["plan", png, "--out", full],
            Fails(1, "the disk is full"),
        ));
        cases.push((
            "plan-svg-full",
            vec!["plan", png, "--svg", full, "--out", "{}/p.kjob"],
            Fails(1, "the disk is full"),
        ));
        cases.push((
            "check-preview-full",
            vec!["check", job, "--preview", full],
            Fails(1, "the disk is full"),
        ));
        cases.push((
            "gcode-out-full",
            vec!["gcode", gcode, "--out", full],
            Fails(1, "the disk is full"),
        ));
    }
    let machine: Vec<(&str, Vec<&str>, Expect)> = vec![
        (
            "run",
            vec![
                "run", job, "--port", nowhere, "--csv", "{}/r.csv", "--svg", "{}/r.svg",
            ],
            Fails(3, "cannot open the machine's port"),
        ),
        ("run-no-machine", vec!["run", job], Fails(2, "--port")),
        (
            "run-both-machines",
            vec!["run", job, "--port", nowhere, "--qemu"],
            Fails(2, "cannot be used with"),
        ),
        (
            "run-no-image",
            vec!["run", job, "--qemu", "--image", "/nonexistent/link"],
            Fails(3, "no firmware image"),
        ),
        (
            "run-port-empty",
            vec!["run", job, "--port", ""],
            Fails(1, "no device given"),
        ),
        (
            "run-baud-0",
            vec!["run", job, "--port", nowhere, "--baud", "0"],
            Fails(1, "--baud 0"),
        ),
        (
            "run-baud-neg",
            vec!["run", job, "--port", nowhere, "--baud=-1"],
            Fails(2, "invalid"),
        ),
        (
            "run-baud-huge",
            vec!["run", job, "--port", nowhere, "--baud", "4294967296"],
            Fails(2, "not in 0..=4294967295"),
        ),
        (
            "run-hz-0",
            vec!["run", job, "--port", nowhere, "--telemetry-hz", "0"],
            Fails(1, "positive rate"),
        ),
        (
            "run-hz-neg",
            vec!["run", job, "--port", nowhere, "--telemetry-hz=-1"],
            Fails(1, "positive rate"),
        ),
        (
            "run-hz-nan",
            vec!["run", job, "--port", nowhere, "--telemetry-hz", "NaN"],
            Fails(1, "positive rate"),
        ),
        (
            "run-hz-inf",
            vec!["run", job, "--port", nowhere, "--telemetry-hz", "inf"],
            Fails(1, "positive rate"),
        ),
        (
            "run-hz-type",
            vec!["run", job, "--port", nowhere, "--telemetry-hz", "fast"],
            Fails(2, "invalid value"),
        ),
        (
            "run-quiet-0",
            vec!["run", job, "--port", nowhere, "--quiet-s", "0"],
            Fails(1, "--quiet-s 0"),
        ),
        (
            "run-quiet-neg",
            vec!["run", job, "--port", nowhere, "--quiet-s=-1"],
            Fails(2, "invalid"),
        ),
        (
            "run-quiet-huge",
            vec![
                "run",
                job,
                "--port",
                nowhere,
                "--quiet-s",
                "18446744073709551616",
            ],
            Fails(2, "too large"),
        ),
        (
            "run-set-at-type",
            vec!["run", job, "--port", nowhere, "--set-at", "soon"],
            Fails(2, "T:PATH=VALUE"),
        ),
        (
            "run-set-at-neg",
            vec!["run", job, "--port", nowhere, "--set-at=-1:/a=1"],
            Fails(2, "T:PATH=VALUE"),
        ),
        (
            "run-set-at-nan",
            vec!["run", job, "--port", nowhere, "--set-at", "NaN:/a=1"],
            Fails(2, "T:PATH=VALUE"),
        ),
        (
            "run-set-at-empty",
            vec!["run", job, "--port", nowhere, "--set-at", "1:/a="],
            Fails(2, "T:PATH=VALUE"),
        ),
        (
            "run-job-missing",
            vec!["run", "/nonexistent/j.kjob", "--port", nowhere],
            Fails(1, "cannot read the job file: no such file"),
        ),
        (
            "run-job-folder",
            vec!["run", folder, "--port", nowhere],
            Fails(1, "cannot read the job file"),
        ),
        (
            "run-job-text",
            vec!["run", text, "--port", nowhere],
            Fails(1, "notes.txt"),
        ),
        (
            "run-csv-missing",
            vec!["run", job, "--port", nowhere, "--csv", "/nonexistent/r.csv"],
            Fails(1, "cannot write the telemetry there"),
        ),
        (
            "run-svg-folder",
            vec!["run", job, "--port", nowhere, "--svg", "{}"],
            Fails(1, "that is a folder"),
        ),
        (
            "run-csv-svg-same",
            vec![
                "run", job, "--port", nowhere, "--csv", "{}/r", "--svg", "{}/r",
            ],
            Fails(1, "given for both"),
        ),
        (
            "get",
            vec!["get", "/slave/dob/bandwidth_hz", "--port", nowhere],
            Fails(3, "cannot open the machine's port"),
        ),
        (
            "get-path-empty",
            vec!["get", "", "--port", nowhere],
            Fails(1, "begins with /"),
        ),
        (
            "get-path-relative",
            vec!["get", "slave/pd", "--port", nowhere],
            Fails(1, "begins with /"),
        ),
        (
            "get-path-spaces",
            vec!["get", "/slave/ pd", "--port", nowhere],
            Fails(1, "begins with /"),
        ),
        (
            "get-baud-0",
            vec![
                "get",
                "/slave/pd/bandwidth_hz",
                "--port",
                nowhere,
                "--baud",
                "0",
            ],
            Fails(1, "--baud 0"),
        ),
        (
            "get-no-path",
            vec!["get", "--port", nowhere],
            Fails(2, "PATH"),
        ),
        (
            "set",
            vec!["set", "/slave/pd/bandwidth_hz", "-1", "--port", nowhere],
            Fails(3, "cannot open the machine's port"),
        ),
        (
            "set-bool",
            vec!["set", "/slave/dob/compensate", "true", "--port", nowhere],
            Fails(3, "cannot open the machine's port"),
        ),
        (
            "set-value-empty",
            vec!["set", "/slave/pd/bandwidth_hz", "", "--port", nowhere],
            Fails(1, "not a value the machine takes"),
        ),
        (
            "set-value-nan",
            vec!["set", "/slave/pd/bandwidth_hz", "NaN", "--port", nowhere],
            Fails(1, "not a value the machine takes"),
        ),
        (
            "set-value-inf",
            vec!["set", "/slave/pd/bandwidth_hz", "inf", "--port", nowhere],
            Fails(1, "not a value the machine takes"),
        ),
        (
            "set-value-huge",
            vec!["set", "/slave/pd/bandwidth_hz", "1e999", "--port", nowhere],
            Fails(1, "not a value the machine takes"),
        ),
        (
            "set-value-type",
            vec!["set", "/slave/pd/bandwidth_hz", "fast", "--port", nowhere],
            Fails(1, "not a value the machine takes"),
        ),
        (
            "set-path-relative",
            vec!["set", "pd", "1", "--port", nowhere],
            Fails(1, "begins with /"),
        ),
        (
            "log",
            vec![
                "log", "--port", nowhere, "--csv", "{}/l.csv", "--svg", "{}/l.svg",
            ],
            Fails(3, "cannot open the machine's port"),
        ),
        (
            "log-seconds-0",
            vec!["log", "--port", nowhere, "--seconds", "0"],
            Fails(1, "positive span"),
        ),
        (
            "log-seconds-neg",
            vec!["log", "--port", nowhere, "--seconds=-1"],
            Fails(1, "positive span"),
        ),
        (
            "log-seconds-nan",
            vec!["log", "--port", nowhere, "--seconds", "NaN"],
            Fails(1, "positive span"),
        ),
        (
            "log-seconds-inf",
            vec!["log", "--port", nowhere, "--seconds", "inf"],
            Fails(1, "positive span"),
        ),
        (
            "log-seconds-huge",
            vec!["log", "--port", nowhere, "--seconds", "1e300"],
            Fails(1, "samples"),
        ),
        (
            "log-seconds-type",
            vec!["log", "--port", nowhere, "--seconds", "long"],
            Fails(2, "invalid value"),
        ),
        (
            "log-hz-0",
            vec!["log", "--port", nowhere, "--telemetry-hz", "0"],
            Fails(1, "positive rate"),
        ),
        (
            "log-hz-huge",
            vec!["log", "--port", nowhere, "--telemetry-hz", "1e300"],
            Fails(1, "samples"),
        ),
        (
            "log-csv-missing",
            vec!["log", "--port", nowhere, "--csv", "/nonexistent/l.csv"],
            Fails(1, "cannot write the telemetry there"),
        ),
        (
            "log-svg-folder",
            vec!["log", "--port", nowhere, "--svg", "{}"],
            Fails(1, "that is a folder"),
        ),
        (
            "status",
            vec!["status", "--port", nowhere],
            Fails(3, "cannot open the machine's port"),
        ),
        (
            "status-port-empty",
            vec!["status", "--port", ""],
            Fails(1, "no device given"),
        ),
        (
            "status-baud-0",
            vec!["status", "--port", nowhere, "--baud", "0"],
            Fails(1, "--baud 0"),
        ),
        (
            "status-baud-type",
            vec!["status", "--port", nowhere, "--baud", "fast"],
            Fails(2, "invalid value"),
        ),
        (
            "unknown",
            vec!["frobnicate"],
            Fails(2, "unrecognized subcommand"),
        ),
    ];
    cases.extend(machine);
    assert_all(&cases);
}
