//! The files the web console takes as jobs (`kerf_host::serve::job_file`) are the jobs
//! the command line makes of them with its defaults: a picture as `kerf plan --all`, a
//! laser program as `kerf gcode --machine keops-slave`, ARROW's and the grinding cell's
//! programs as `kerf gcode`; a job file is taken as it is; the rest is refused in words.

mod common;
use common::{kerf, text, tmp};
use kerf_host::check::Machine;
use kerf_host::serve::job_file;
use std::path::Path;

/// The job file `kerf ARGS… --out OUT` writes.
fn cli_job(args: &[&str], out: &str) -> Vec<u8> {
    let out = tmp(out);
    let out_text = out.to_str().unwrap();
    let mut all = args.to_vec();
    all.extend(["--out", out_text]);
    let run = kerf(&all);
    assert_eq!(run.status.code(), Some(0), "{}", text(&run.stderr));
    std::fs::read(&out).unwrap()
}

fn repo(path: &str) -> String {
    format!("{}/../{path}", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn the_console_makes_of_each_file_the_job_the_command_line_makes() {
    let square = tmp("console_square.nc");
    std::fs::write(
        &square,
        "G21 G90\nM3 S600\nG1 X4 Y-4 F600\nG1 X4 Y4\nG1 X-4 Y4\nG1 X-4 Y-4\nG1 X4 Y-4\nM5\n",
    )
    .unwrap();
    let square = square.to_str().unwrap().to_owned();
    let (horse, pyramid, pass) = (
        repo("host/tests/data/horse.png"),
        repo("data/pyramid.gcode"),
        repo("data/grinding_pass.gcode"),
    );
    // The file, the machine, the command that makes its job.
    let cases: [(&str, Machine, Vec<&str>); 4] = [
        (&horse, Machine::KeopsSlave, vec!["plan", &horse, "--all"]),
        (
            &square,
            Machine::KeopsSlave,
            vec!["gcode", &square, "--machine", "keops-slave"],
        ),
        (&pyramid, Machine::Arrow, vec!["gcode", &pyramid]),
        (
            &pass,
            Machine::Grinding,
            vec!["gcode", &pass, "--machine", "grinding"],
        ),
    ];
    for (k, (file, machine, command)) in cases.iter().enumerate() {
        let name = Path::new(file).file_name().unwrap().to_str().unwrap();
        let console = job_file(name, &std::fs::read(file).unwrap(), Some(*machine)).unwrap();
        let cli = cli_job(command, &format!("console_{k}.krfj"));
        assert_eq!(console, cli, "{name}");
        // A job file is taken as it is.
        assert_eq!(job_file("job.krfj", &cli, Some(*machine)).unwrap(), cli);
    }
}

#[test]
fn files_the_console_cannot_make_a_job_of_are_refused_in_words() {
    let horse = std::fs::read(Path::new(&repo("host/tests/data/horse.png"))).unwrap();
    for (name, body, machine, words) in [
        (
            "notes.txt",
            &b"hello"[..],
            Some(Machine::Arrow),
            "neither a job file",
        ),
        (
            "horse.png",
            &horse[..],
            Some(Machine::Arrow),
            "for the Keops slave only, not arrow",
        ),
        (
            "bad.ngc",
            b"G0 X0 Y500 Z0\nG1 X1 Q5\n",
            Some(Machine::Arrow),
            "bad.ngc:2:",
        ),
        (
            "bad.nc",
            b"G21\nG5 X1\n",
            Some(Machine::KeopsSlave),
            "bad.nc:2:",
        ),
        (
            "dark.nc",
            b"G21\nG1 X1 F100\n",
            Some(Machine::KeopsSlave),
            "dark.nc",
        ),
        (
            "any.gcode",
            b"G1 X1\n",
            None,
            "this machine takes no G-code programs",
        ),
    ] {
        let error = job_file(name, body, machine).unwrap_err();
        assert!(error.contains(words), "{name}: {error:?} lacks {words:?}");
    }
}
