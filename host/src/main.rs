//! `kerf`: the operator's command line (see the `kerf_host` crate docs).
//!
//! Exit codes: 0 done; 1 bad input, an output that could not be written, or the
//! machine refused or faulted (the message says why); 2 a usage error (clap's); 3 the
//! machine could not be reached or the link failed.

use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use kerf::trajectory::gcode::MoveKind;
use kerf_host::gcode::{self, GcodeCheckError};
use kerf_host::job::Job;
use kerf_host::output::{io_words, OutputError, OutputFile};
use kerf_host::plan::{self, Fit, Format, PlanConfig};
use kerf_host::plot;
use report::{say, Report};
mod cli_check;
mod cli_cut;
mod cli_laser;
mod cli_machine;
mod cli_parts;
mod cli_serve;
mod report;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::str::FromStr;

/// Operator's tools for kerf machines: plan contour jobs from images, check G-code,
/// run jobs on a machine, change its settings and record its telemetry.
#[derive(Debug, Parser)]
#[command(name = "kerf", version, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Plan a contour job from an image (T 3.1): smoothing, Canny edges, gap closing,
    /// the contour walked from its start, scaled into the workspace and fitted.
    ///
    /// A closed contour (the default) starts at its rightmost point and runs
    /// counter-clockwise; give --start for an open one. The workspace's x points
    /// right and y up, the origin at the contour's centroid.
    Plan(PlanArgs),
    /// Check a G-code program with the machine's own loader and pack it as a job
    /// (ARROW by default; the grinding cell, the single axis), or (--machine
    /// keops-slave) turn a laser program into the parts of a Keops slave job. Errors
    /// are printed as FILE:LINE:COLUMN: message.
    Gcode(GcodeArgs),
    /// Check a job file as the machine will check it at load (its own loader and
    /// presets: workspace, carriage limits, curvature, length, capacity), with its
    /// duration and a preview; a job it would refuse is refused here, in its words.
    ///
    /// Exit 0 when the machine would accept the job, 1 when it would refuse it.
    Check(cli_check::CheckArgs),
    /// Upload a job to the machine, run it and follow it: telemetry (with a heartbeat
    /// per sample), settings changed at given times or typed during the run (set
    /// PATH VALUE, get PATH, stop), the summary, CSV and plot at the end.
    ///
    /// Exit 0 when the job ran to its end, 1 when the machine refused it, faulted or
    /// stopped it, 3 when the link failed.
    Run(cli_machine::RunArgs),
    /// Read a setting, such as /slave/dob/bandwidth_hz.
    Get {
        /// The setting's path in the machine's settings tree, or a branch of it (`/`
        /// for every setting).
        path: String,
        /// Print a JSON array of {path, value, unit, range} for scripts.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        machine: cli_machine::MachineArgs,
    },
    /// List every setting of the machine with its value, unit and range.
    Settings {
        /// Print a JSON array of {path, value, unit, range} for scripts.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        machine: cli_machine::MachineArgs,
    },
    /// Change a setting; the machine validates it as a configuration and applies it
    /// bumplessly, or refuses it and changes nothing.
    Set {
        /// The setting's path.
        path: String,
        /// Its value, JSON (a number: 120, 2.5e-3, -1).
        #[arg(allow_negative_numbers = true)]
        value: String,
        /// Then keep the settings as they are across resets (as `kerf save`).
        #[arg(long)]
        save: bool,
        #[command(flatten)]
        machine: cli_machine::MachineArgs,
    },
    /// Record the machine's telemetry for a span of machine time.
    Log(cli_machine::LogArgs),
    /// Keep the machine's settings as they are now across resets (a board in its flash,
    /// the emulated machine in a file of its state folder).
    Save {
        #[command(flatten)]
        machine: cli_machine::MachineArgs,
    },
    /// The machine's name, mode, last fault, upload and link counters.
    Status {
        /// Print the state as JSON for scripts (with --session: the station's).
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        machine: cli_machine::MachineArgs,
    },
    /// Hold a machine open and serve the operator's web console and an HTTP API on it;
    /// other commands reach the same machine with --session ADDR:PORT, so settings, a
    /// loaded job and the telemetry stay between them.
    Serve(cli_serve::ServeArgs),
}

/// Why a command failed, and its exit code.
#[derive(Debug)]
enum Failure {
    /// Bad input (exit 1).
    Input(String),
    /// The machine refused, faulted or stopped (exit 1).
    Refused(String),
    /// An output could not be written (exit 1): a file, or the report on a closed
    /// standard output.
    Output(String),
    /// The link failed (exit 3).
    Link(String),
}

impl From<String> for Failure {
    fn from(s: String) -> Self {
        Failure::Input(s)
    }
}

impl From<OutputError> for Failure {
    fn from(e: OutputError) -> Self {
        Failure::Output(e.to_string())
    }
}

/// Checks, before the long work, that `path` (if given) can be written.
fn prepare(path: Option<&Path>, what: &'static str) -> Result<Option<OutputFile>, Failure> {
    Ok(path.map(|p| OutputFile::prepare(p, what)).transpose()?)
}

/// Refuses two outputs named the same: the second would replace the first.
fn distinct(outputs: &[(&str, Option<&Path>)]) -> Result<(), Failure> {
    for (i, (a, pa)) in outputs.iter().enumerate() {
        for (b, pb) in &outputs[i + 1..] {
            if let (Some(pa), Some(pb)) = (pa, pb) {
                if pa == pb {
                    return Err(Failure::Input(format!(
                        "{}: given for both {a} and {b}; one would replace the other",
                        pa.display()
                    )));
                }
            }
        }
    }
    Ok(())
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum FormatArg {
    /// Elliptic Fourier descriptors (closed contours).
    Efd,
    /// Up to 32 points for the firmware's open-path spline.
    Points,
}

/// Two numbers `A,B`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Pair(f64, f64);

impl FromStr for Pair {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (a, b) = s
            .split_once(',')
            .ok_or_else(|| format!("expected two numbers A,B, got {s:?}"))?;
        let num = |v: &str| {
            v.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("{v:?} is not a finite number"))
        };
        Ok(Pair(num(a)?, num(b)?))
    }
}

#[derive(Debug, clap::Args)]
struct PlanArgs {
    /// The image (PNG or JPEG).
    image: PathBuf,
    /// Write the job file here (without it, nothing is written).
    #[arg(long, value_name = "JOB")]
    out: Option<PathBuf>,
    /// Start of an open contour, image pixels X,Y (x right, y down from the top-left
    /// corner); the walk begins at the contour's end nearest to it.
    #[arg(long, value_name = "X,Y")]
    start: Option<Pair>,
    /// EFD harmonics, 1 to 30 (the firmware's capacity).
    #[arg(long, value_name = "N", default_value_t = 30)]
    harmonics: usize,
    /// The contour's larger side in the workspace, mm (12 mm: the ±6 mm octagon job).
    #[arg(long, value_name = "W", default_value_t = 12.0)]
    width_mm: f64,
    /// What the job carries [default: efd for closed contours, points for open ones].
    #[arg(long, value_enum)]
    format: Option<FormatArg>,
    /// σ of the Gaussian smoothing, pixels.
    #[arg(long, value_name = "PX", default_value_t = 1.0)]
    sigma: f32,
    /// Canny's hysteresis thresholds LOW,HIGH on the Sobel magnitude (0 to ~1140).
    #[arg(long, value_name = "LOW,HIGH", default_value = "40,100")]
    canny: Pair,
    /// Radius of the gap closing (dilation, then erosion), pixels.
    #[arg(long, value_name = "PX", default_value_t = 3)]
    close_px: u8,
    /// Also draw the image, the traced contour and the fit into this SVG file.
    #[arg(long, value_name = "SVG")]
    svg: Option<PathBuf>,
    /// Which closed contour to cut, 1 for the largest, 2 for the next, ... (the
    /// report says how many the image has).
    #[arg(long, value_name = "K", default_value_t = 1, value_parser = clap::value_parser!(u16).range(1..))]
    contour: u16,
    /// Cut every closed contour, holes included, as the parts of one job: inner
    /// contours before the ones around them, then the nearest next.
    #[arg(long, conflicts_with_all = ["contour", "start"])]
    all: bool,
    /// With --all: leave out contours smaller than this across, mm (specks, noise).
    #[arg(long, value_name = "MM", default_value_t = 0.0, requires = "all")]
    min_size_mm: f64,
    /// Cut the picture into ink (darker than this grey level, 1 to 255) and paper
    /// before its edges are sought: for photographs and faint drawings.
    #[arg(long, value_name = "GREY", value_parser = clap::value_parser!(u8).range(1..))]
    threshold: Option<u8>,
    #[command(flatten)]
    kerf: cli_cut::KerfArgs,
    #[command(flatten)]
    cut: cli_cut::CutArgs,
}

#[derive(Debug, clap::Args)]
pub(crate) struct GcodeArgs {
    /// The G-code program.
    pub(crate) file: PathBuf,
    /// Write the job file here (without it, nothing is written).
    #[arg(long, value_name = "JOB")]
    pub(crate) out: Option<PathBuf>,
    /// The machine the program is for: ARROW, the grinding cell or the single axis
    /// (each machine's loader checks the program), or the Keops slave (a laser
    /// program: each run with the beam on becomes a part).
    #[arg(long, value_enum, default_value = "arrow")]
    pub(crate) machine: kerf_host::check::Machine,
    /// Move the program so that it is centred on the workspace's centre: for the Keops
    /// slave its cuts (a laser bed's origin is its corner), for ARROW the box around
    /// its points (a program written about its own zero).
    #[arg(long)]
    pub(crate) centre: bool,
    /// For ARROW: the program is written for a three-axis mill (Z its tool axis, its
    /// zero on the part): turned so that its Z runs along ARROW's tool (the machine's
    /// y) and its Y along the machine's z, its zero at the workspace's centre.
    #[arg(long)]
    pub(crate) mill: bool,
    /// For the Keops slave: the S value of full power (grbl's $30).
    #[arg(long, value_name = "S", default_value_t = kerf_host::laser::Beam::GRBL_S_MAX)]
    pub(crate) s_max: f64,
    /// For the Keops slave: cut the program's corners sharp, as straight moves each at
    /// its feed (planned by the machine's look-ahead planner), or fit each run with a
    /// smooth curve (an EFD or a spline) cut at one speed.
    #[arg(long, value_enum, default_value = "sharp")]
    pub(crate) corners: kerf_host::laser::Corners,
    #[command(flatten)]
    pub(crate) cut: cli_cut::CutArgs,
    #[command(flatten)]
    pub(crate) kerf: cli_cut::KerfArgs,
}

fn main() -> ExitCode {
    // clap's own errors (a usage error) exit with 2; its help and version exit with 0.
    let cli = Cli::parse();
    let mut report = Report::new();
    let r = &mut report;
    let result = match cli.command {
        Command::Plan(args) => run_plan(&args, r),
        Command::Gcode(args) if args.mill && args.machine != kerf_host::check::Machine::Arrow => {
            Err(Failure::Input(format!(
                "--mill turns a mill's program onto ARROW's tool axis; {} takes programs in its own axes",
                args.machine.name()
            )))
        }
        Command::Gcode(args) if args.machine == kerf_host::check::Machine::KeopsSlave => {
            cli_laser::run(&args, r)
        }
        Command::Gcode(args) => run_gcode(&args, r),
        Command::Check(args) => cli_check::run(&args, r),
        Command::Run(args) => cli_machine::run(&args, r),
        Command::Get {
            path,
            json,
            machine,
        } => cli_machine::get(&path, json, &machine, r),
        Command::Settings { json, machine } => cli_machine::settings(json, &machine, r),
        Command::Set {
            path,
            value,
            save,
            machine,
        } => cli_machine::set(&path, &value, save, &machine, r),
        Command::Log(args) => cli_machine::log(&args, r),
        Command::Save { machine } => cli_machine::save(&machine, r),
        Command::Status { json, machine } => cli_machine::status(json, &machine, r),
        Command::Serve(args) => cli_serve::run(&args, r),
    };
    let result = result.and_then(|()| report.lost().map_or(Ok(()), |m| Err(Failure::Output(m))));
    let (message, code) = match result {
        Ok(()) => return ExitCode::SUCCESS,
        Err(Failure::Input(m) | Failure::Refused(m) | Failure::Output(m)) => (m, 1),
        Err(Failure::Link(m)) => (m, 3),
    };
    // Standard error may be closed too: the exit code still says it.
    let _ = writeln!(std::io::stderr(), "{message}");
    ExitCode::from(code)
}

fn write_job(out: &OutputFile, job: &Job, report: &mut Report) -> Result<(), Failure> {
    let bytes = job
        .to_bytes()
        .map_err(|e| Failure::Input(format!("{}: {e}", out.shown())))?;
    out.write_bytes(&bytes)?;
    say!(report, "wrote {} ({} bytes)", out.shown(), bytes.len());
    Ok(())
}

fn run_plan(args: &PlanArgs, report: &mut Report) -> Result<(), Failure> {
    let config = PlanConfig {
        sigma_px: args.sigma,
        canny: (args.canny.0 as f32, args.canny.1 as f32),
        close_px: args.close_px,
        width_mm: args.width_mm,
        harmonics: args.harmonics,
        start_px: args.start.map(|p| [p.0, p.1]),
        contour: usize::from(args.contour) - 1,
        kerf_mm: args.kerf.kerf_mm,
        kerf_side: args.kerf.kerf_side,
        lead_in_mm: args.kerf.lead_in_mm,
        threshold: args.threshold,
        format: args.format.map(|f| match f {
            FormatArg::Efd => Format::Efd,
            FormatArg::Points => Format::Points,
        }),
        ..PlanConfig::default()
    };
    // Before the long work: where the files go.
    distinct(&[
        ("--out", args.out.as_deref()),
        ("--svg", args.svg.as_deref()),
    ])?;
    let out = prepare(args.out.as_deref(), "job file")?;
    let svg = prepare(args.svg.as_deref(), "picture")?;
    // Large photographs take seconds (thinning is one pass per pixel of the
    // thickest edge band): show the stage. Hidden when stderr is not a terminal.
    let bar = ProgressBar::new(5);
    if let Ok(style) = ProgressStyle::with_template("{bar:20} {pos}/{len} {msg}") {
        bar.set_style(style);
    }
    let name = args.image.display().to_string();
    if args.all {
        let gray = plan::read_grey(&args.image).map_err(|e| format!("{name}: {e}"))?;
        let set = kerf_host::parts::plan_all(&gray, &config, args.min_size_mm, &mut |stage| {
            bar.inc(1);
            bar.set_message(stage.to_string());
        })
        .map_err(|e| format!("{name}: {e}"))?;
        bar.finish_and_clear();
        let bytes = cli_parts::report_parts(&name, &gray, &set, &config, svg.as_ref(), report)?;
        return cli_cut::write_program(&name, &bytes, &args.cut, out.as_ref(), report);
    }
    let (gray, p) = plan::plan_file(&args.image, &config, &mut |stage| {
        bar.inc(1);
        bar.set_message(stage.to_string());
    })
    .map_err(|e| format!("{name}: {e}"))?;
    bar.finish_and_clear();
    let (w, h) = gray.dimensions();
    say!(report, "image      {name}: {w} x {h} px");
    say!(
        report,
        "contour    {}, {} points traced, start at pixel ({:.0}, {:.0})",
        if p.closed { "closed" } else { "open" },
        p.chain_px.len(),
        p.chain_px[0][0],
        p.chain_px[0][1]
    );
    if p.contours > 1 {
        say!(
            report,
            "note       the image has {} closed contours: this job cuts contour {} of them (largest first); \
             the others are not in it (--contour 1 to {} chooses)",
            p.contours,
            args.contour,
            p.contours
        );
    }
    say!(
        report,
        "workspace  {:.4} mm/px, centroid at pixel ({:.1}, {:.1}) -> origin, length {:.2} mm",
        p.mm_per_px,
        p.centroid_px[0],
        p.centroid_px[1],
        p.length_mm()
    );
    let fit = p.fit.samples_mm(2048);
    let off = plan::deviation(&fit, &p.contour_mm, p.closed).max(plan::deviation(
        &p.contour_mm,
        &fit,
        p.closed,
    ));
    match &p.fit {
        Fit::Efd(e) => say!(
            report,
            "job        EFD, {} harmonics, {:.3} mm from the traced contour at most",
            e.harmonics(),
            off
        ),
        Fit::Path { points_m, .. } => say!(
            report,
            "job        path, {} points, spline {:.3} mm from the traced contour at most",
            points_m.len(),
            off
        ),
    }
    kerf_line(&config, report);
    if let Some(svg) = &svg {
        let text = plot::svg(&name, &gray, &p, &[])
            .map_err(|e| Failure::Output(format!("{}: {e}", svg.shown())))?;
        svg.write_bytes(text.as_bytes())?;
        say!(report, "wrote {}", svg.shown());
    }
    let bytes = p
        .to_bytes()
        .map_err(|e| Failure::Input(format!("{name}: {e}")))?;
    cli_cut::write_program(&name, &bytes, &args.cut, out.as_ref(), report)
}

/// What the kerf offset and the lead-in did, when there are any.
pub(crate) fn kerf_line(config: &PlanConfig, report: &mut Report) {
    let (outline, holes) = match config.kerf_side {
        kerf_host::kerf_offset::KerfSide::Outside => ("outside", "inside"),
        kerf_host::kerf_offset::KerfSide::Inside => ("inside", "outside"),
    };
    if config.kerf_mm > 0.0 {
        say!(
            report,
            "kerf       {:.3} mm wide: the path {:.3} mm {outline} the drawn outline ({holes} its holes); the distances above include it",
            config.kerf_mm,
            config.kerf_mm / 2.0
        );
    }
    if config.lead_in_mm > 0.0 {
        say!(
            report,
            "lead-in    {:.2} mm straight to each contour's start from {outline} an outline ({holes} a hole), a part of its own before it",
            config.lead_in_mm
        );
    }
}

fn run_gcode(args: &GcodeArgs, report: &mut Report) -> Result<(), Failure> {
    let name = args.file.display().to_string();
    if args.centre && args.machine != kerf_host::check::Machine::Arrow {
        return Err(Failure::Input(format!(
            "--centre moves a laser program or ARROW's; {} takes programs where they are written",
            args.machine.name()
        )));
    }
    if args.cut.settings()? != kerf_host::job::CutSettings::MACHINE || args.kerf.is_set() {
        return Err(Failure::Input(format!(
            "{name}: a program for {} carries its own feeds and path; --speed-mm-s, \
             --power-w, --energy-j-per-mm, --beam-off, --passes, --kerf-mm and \
             --lead-in-mm are for the laser delta's parts",
            args.machine.name()
        )));
    }
    let out = prepare(args.out.as_deref(), "job file")?;
    let text = std::fs::read(&args.file)
        .map_err(|e| format!("{name}: cannot read the program: {}", io_words(&e)))?;
    // Every problem of the program first, one per line on standard error.
    let found = gcode::diagnose(&text);
    let listed: Vec<String> = found
        .iter()
        .map(|d| gcode::format_diagnostic(&name, d))
        .collect();
    if gcode::has_errors(&found) {
        return Err(Failure::Input(listed.join("\n")));
    }
    for line in &listed {
        // Standard error may be closed: the report still follows.
        let _ = writeln!(std::io::stderr(), "{line}");
    }
    let located = |e: GcodeCheckError| {
        if e.line == 0 {
            format!("{name}: error: {}", e.message)
        } else {
            format!("{name}:{}:{}: error: {}", e.line, e.column, e.message)
        }
    };
    if args.machine != kerf_host::check::Machine::Arrow {
        let checked = gcode::check_on(args.machine, &text).map_err(located)?;
        say!(
            report,
            "{name}: {} takes it: {:.1} mm of travel (from its first target), about {:.2} s",
            args.machine.name(),
            checked.cut_length_m * 1e3,
            checked.duration_s
        );
        if let Some(out) = &out {
            write_job(out, &Job::Gcode { text }, report)?;
        }
        return Ok(());
    }
    let placement = kerf_host::arrow_parts::Placement {
        centre: args.centre,
        mill: args.mill,
    };
    let program = kerf_host::arrow_parts::parts(&text, placement).map_err(located)?;
    let moves: usize = program.parts.iter().map(|p| p.report.moves.len()).sum();
    say!(
        report,
        "{name}: accepted, {moves} moves in {} part{}",
        program.parts.len(),
        if program.parts.len() == 1 { "" } else { "s" }
    );
    arrow_notes(&program, report);
    say!(
        report,
        "  part  move  line  kind   points  length mm  speed mm/s  time s"
    );
    for (k, part) in program.parts.iter().enumerate() {
        for (i, m) in part.report.moves.iter().enumerate() {
            say!(
                report,
                "  {:>4}  {:>4}  {:>4}  {:<5}  {:>6}  {:>9.1}  {:>10.1}  {:>6.2}",
                k + 1,
                i + 1,
                m.line,
                match m.kind {
                    MoveKind::Rapid => "rapid",
                    MoveKind::Feed => "feed",
                },
                m.points,
                m.length_m * 1e3,
                m.speed_m_s * 1e3,
                m.duration_s
            );
        }
    }
    say!(
        report,
        "  total length {:.1} mm, duration {:.2} s",
        program.length_m() * 1e3,
        program.duration_s()
    );
    if let Some(out) = &out {
        let bytes = program
            .job_file(&text)
            .map_err(|e| Failure::Input(format!("{name}: {e}")))?;
        out.write_bytes(&bytes)?;
        say!(report, "wrote {} ({} bytes)", out.shown(), bytes.len());
    }
    Ok(())
}

/// What was done to an ARROW program to run it, in lines of the report.
fn arrow_notes(program: &kerf_host::arrow_parts::ArrowProgram, report: &mut Report) {
    let lines = |l: &[u32]| {
        let shown: Vec<String> = l.iter().take(8).map(u32::to_string).collect();
        let more = if l.len() > 8 { ", …" } else { "" };
        format!("{}{more}", shown.join(", "))
    };
    if program.shift_m != [0.0; 3] {
        let [x, y, z] = program.shift_m.map(|v| v * 1e3);
        say!(
            report,
            "  centred: moved by ({x:.3}, {y:.3}, {z:.3}) mm to the workspace's centre"
        );
    }
    if program.mill {
        say!(
            report,
            "  a mill's program: its X Y Z are the machine's x, z and y0 − y (its Z along the tool)"
        );
    }
    if program.from_home {
        let [x, y, z, a, b] = kerf::machines::arrow::product::HOME;
        say!(
            report,
            "  starts from the machine's home (X {:.3} Y {:.3} Z {:.3} mm, A {:.1}° B {:.1}°): a rapid to the program's first point comes first",
            x * 1e3,
            y * 1e3,
            z * 1e3,
            a.to_degrees(),
            b.to_degrees()
        );
    }
    if !program.left_out.is_empty() {
        say!(
            report,
            "  left out: the moves of line {} go nowhere (to where the tool already is)",
            lines(&program.left_out)
        );
    }
    if !program.stops.is_empty() {
        say!(
            report,
            "  a move longer than a part is cut at line {}: the machine stops there",
            lines(&program.stops)
        );
    }
}
