//! The harness of the edge-value tests: a case is a command line run in a fresh folder,
//! with standard output read or closed, and what it must end in.

use kerf_host::job::Job;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const KERF: &str = env!("CARGO_BIN_EXE_kerf");

/// A pipe whose reader is closed: the write end of a finished process's input.
fn closed_pipe() -> Stdio {
    let mut reader = Command::new(KERF)
        .arg("--version")
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("run kerf");
    let writer = reader.stdin.take().expect("stdin");
    reader.wait().expect("wait");
    Stdio::from(writer)
}

/// A fresh, empty folder for one case's outputs.
fn fresh(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("edge_values")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn listing(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// What a case must end in.
#[derive(Clone, Copy, Debug)]
pub enum Expect {
    /// Done: exit 0 and these files written whole (with a closed standard output:
    /// exit 1, the report cut short, the files still written).
    Done(&'static [&'static str]),
    /// This exit code and a message containing this; no file written.
    Fails(i32, &'static str),
}

pub struct Inputs {
    /// A filled octagon, PNG.
    pub png: String,
    /// ARROW's pyramid, G-code.
    pub gcode: String,
    /// A circle as an EFD job.
    pub job: String,
    /// A text file.
    pub text: String,
    /// The folder they are in.
    pub folder: String,
}

pub fn inputs() -> Inputs {
    let d = fresh("inputs");
    let raster = super::Raster {
        size: 120,
        px_per_mm: 5.0,
    };
    let mm: Vec<[f64; 2]> = kerf::trajectory::shapes::octagon()
        .iter()
        .map(|p| [p[0] * 1e3, p[1] * 1e3])
        .collect();
    let png = d.join("octagon.png");
    raster.filled(&mm, 3).save(&png).unwrap();
    let job = d.join("octagon.kjob");
    let efd = Job::Efd {
        centre_m: [0.0, 0.0],
        coefficients: vec![[6e-3, 0.0, 0.0, 6e-3]],
    };
    std::fs::write(&job, efd.to_bytes().unwrap()).unwrap();
    let text = d.join("notes.txt");
    std::fs::write(&text, "not an image, not a job\n").unwrap();
    let s = |p: PathBuf| p.to_str().unwrap().to_owned();
    Inputs {
        png: s(png),
        gcode: s(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/pyramid.gcode")),
        job: s(job),
        text: s(text),
        folder: s(d),
    }
}

/// Runs one case in its own folder `OUT` (written `{}` in `args`), with standard
/// output read or closed; returns what went wrong, if anything.
pub fn check(name: &str, args: &[&str], expect: Expect, closed_stdout: bool) -> Option<String> {
    let d = fresh(&format!(
        "{name}{}",
        if closed_stdout { "-closed" } else { "" }
    ));
    let out_dir = d.to_str().unwrap();
    let args: Vec<String> = args.iter().map(|a| a.replace("{}", out_dir)).collect();
    let mut cmd = Command::new(KERF);
    cmd.args(&args).stdin(Stdio::null());
    cmd.stdout(if closed_stdout {
        closed_pipe()
    } else {
        Stdio::piped()
    });
    let out = cmd.output().expect("run kerf");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let code = out.status.code();
    let what = format!(
        "{name}{}: kerf {args:?}",
        if closed_stdout {
            " (stdout closed)"
        } else {
            ""
        }
    );
    if code == Some(101) || code.is_none() || stderr.contains("panicked") {
        return Some(format!("{what}: panicked ({code:?}): {stderr}"));
    }
    let files = listing(&d);
    let (want_code, says, want_files): (i32, &str, &[&str]) = match expect {
        Expect::Done(f) if closed_stdout => (1, "standard output was cut short", f),
        Expect::Done(f) => (0, "", f),
        Expect::Fails(c, s) => (c, s, &[]),
    };
    if code != Some(want_code) || !stderr.contains(says) {
        return Some(format!(
            "{what}: exit {code:?}, want {want_code} with {says:?}: {stderr}"
        ));
    }
    if files != want_files {
        return Some(format!("{what}: left {files:?}, want {want_files:?}"));
    }
    for f in want_files {
        let bytes = std::fs::read(d.join(f)).unwrap();
        let whole = if f.ends_with(".kjob") {
            kerf_host::job::split(&bytes).is_ok()
        } else {
            bytes.ends_with(b"</svg>\n") || bytes.ends_with(b"</svg>")
        };
        if !whole {
            return Some(format!("{what}: {f} is not whole"));
        }
    }
    None
}

/// Runs every case with standard output read and closed; fails with the list of the
/// cases that did not end as they must.
pub fn assert_all(cases: &[(&str, Vec<&str>, Expect)]) {
    let mut failures = Vec::new();
    for (name, args, expect) in cases {
        for closed in [false, true] {
            failures.extend(check(name, args, *expect, closed));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases:\n{}",
        failures.len(),
        2 * cases.len(),
        failures.join("\n")
    );
}
