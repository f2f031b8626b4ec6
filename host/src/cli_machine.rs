//! The `kerf` commands that talk to a machine: run, get, set, log, status.

use crate::report::{say, Report};
use crate::{distinct, prepare, Failure};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use kerf::codec::link::Request;
use kerf_host::description::{job_kind_words, mode_words, settings_origin_words, SettingInfo};
use kerf_host::job::{Job, JobKind};
use kerf_host::link::{Heard, LinkError};
use kerf_host::output::{io_words, OutputFile};
use kerf_host::qemu;
use kerf_host::session::{Order, Progress, RunPlan, Session, SessionError, Target, TimedChange};
use kerf_host::telemetry::TelemetryLog;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

/// Which machine.
#[derive(Debug, Args)]
pub struct MachineArgs {
    /// A board's serial port (a UART adapter or USB CDC), such as /dev/ttyACM0.
    #[arg(
        long,
        value_name = "DEVICE",
        required_unless_present_any = ["qemu", "session"],
        conflicts_with = "qemu"
    )]
    port: Option<String>,
    /// The machine that `kerf serve` holds open at this address (such as
    /// 127.0.0.1:8080): its settings, loaded job and telemetry stay between commands.
    #[arg(long, value_name = "ADDR:PORT", conflicts_with_all = ["port", "qemu", "image"])]
    session: Option<String>,
    /// The port's speed, bits per second: the board image's LPUART1 runs at 921 600
    /// (USB CDC ignores it).
    #[arg(long, value_name = "BAUD", default_value_t = 921_600)]
    baud: u32,
    /// The emulated machine: the firmware's QEMU link image (the Keops slave on its
    /// simulated delta) on qemu-system-arm, started for this command.
    #[arg(long)]
    qemu: bool,
    /// The QEMU link image [default: $KERF_LINK_ELF, else the link image under
    /// $CARGO_TARGET_DIR or ./target].
    #[arg(long, value_name = "ELF", conflicts_with = "port")]
    image: Option<PathBuf>,
}

impl MachineArgs {
    /// The options' values, before anything is opened.
    fn check(&self) -> Result<(), Failure> {
        if self.port.as_deref().is_some_and(|p| p.trim().is_empty()) {
            return Err(Failure::Input(
                "--port: no device given (such as /dev/ttyACM0)".into(),
            ));
        }
        if self.baud == 0 {
            return Err(Failure::Input(
                "--baud 0: the port needs a speed above 0 bits per second".into(),
            ));
        }
        Ok(())
    }

    /// The emulated machine's settings file (none for a board: its flash keeps them).
    fn settings_file(&self) -> Option<PathBuf> {
        let image = qemu::image_path(self.image.as_deref());
        let image = std::fs::canonicalize(&image).unwrap_or(image);
        self.port
            .is_none()
            .then(|| qemu::state_dir(&image).join(qemu::SETTINGS_FILE))
    }

    /// The `kerf serve` to ask instead of the machine.
    pub fn session(&self) -> Option<&str> {
        self.session.as_deref()
    }

    pub(crate) fn open(&self) -> Result<Session, Failure> {
        if let Some(url) = &self.session {
            return Err(Failure::Input(format!(
                "--session {url}: this command opens the machine itself (give --qemu or --port)"
            )));
        }
        self.check()?;
        let target = match &self.port {
            Some(device) => Target::Port {
                device: device.clone(),
                baud: self.baud,
            },
            None => Target::Qemu {
                image: qemu::image_path(self.image.as_deref()),
            },
        };
        Session::open(&target).map_err(session_failure)
    }
}

/// A setting change during a run: `T:PATH=VALUE`.
#[derive(Debug, Clone, PartialEq)]
struct Change(TimedChange);

impl FromStr for Change {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("expected T:PATH=VALUE (seconds after the cut begins), got {s:?}");
        let (t, rest) = s.split_once(':').ok_or_else(bad)?;
        let (path, value) = rest.split_once('=').ok_or_else(bad)?;
        let at_s = t
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|t| t.is_finite() && *t >= 0.0)
            .ok_or_else(bad)?;
        if !path.starts_with('/') || value.is_empty() {
            return Err(bad());
        }
        Ok(Change(TimedChange {
            at_s,
            path: path.to_owned(),
            value: value.to_owned(),
        }))
    }
}

/// `kerf run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The job file (`kerf plan --out`, `kerf gcode --out`).
    job: PathBuf,
    #[command(flatten)]
    machine: MachineArgs,
    /// Telemetry samples per second of machine time.
    #[arg(long, value_name = "HZ", default_value_t = 100.0)]
    telemetry_hz: f64,
    /// Change a setting T seconds (machine time) after the cut begins:
    /// T:PATH=VALUE, such as 0.2:/slave/dob/bandwidth_hz=120. Repeatable.
    #[arg(long = "set-at", value_name = "T:PATH=VALUE")]
    changes: Vec<Change>,
    /// Write the telemetry here as CSV.
    #[arg(long, value_name = "CSV")]
    csv: Option<PathBuf>,
    /// Draw the run here as SVG: path, contour error, forces.
    #[arg(long, value_name = "SVG")]
    svg: Option<PathBuf>,
    /// Give up after the machine is silent this long, s.
    #[arg(long, value_name = "S", default_value_t = 30)]
    quiet_s: u64,
    #[command(flatten)]
    cut: crate::cli_cut::CutArgs,
}

/// `kerf log`.
#[derive(Debug, Args)]
pub struct LogArgs {
    #[command(flatten)]
    machine: MachineArgs,
    /// Machine time to record, s.
    #[arg(long, value_name = "S", default_value_t = 1.0)]
    seconds: f64,
    /// Telemetry samples per second of machine time.
    #[arg(long, value_name = "HZ", default_value_t = 100.0)]
    telemetry_hz: f64,
    /// Write the telemetry here as CSV (standard output without it).
    #[arg(long, value_name = "CSV")]
    csv: Option<PathBuf>,
    /// Draw it here as SVG.
    #[arg(long, value_name = "SVG")]
    svg: Option<PathBuf>,
}

fn session_failure(e: SessionError) -> Failure {
    match e {
        SessionError::Link(LinkError::Refused { .. }) | SessionError::Fault(_) => {
            Failure::Refused(e.to_string())
        }
        SessionError::Stopped | SessionError::HostLost | SessionError::ChangeRefused(_) => {
            Failure::Refused(e.to_string())
        }
        SessionError::UnknownSetting { .. } => Failure::Input(e.to_string()),
        other => Failure::Link(other.to_string()),
    }
}

fn link_failure(e: LinkError) -> Failure {
    session_failure(SessionError::Link(e))
}

/// A setting's path as the machine's tree names it (the machine checks that it exists).
fn setting_path(path: &str) -> Result<(), Failure> {
    if path.starts_with('/') && !path.contains(char::is_whitespace) {
        Ok(())
    } else {
        Err(Failure::Input(format!(
            "{path:?}: a setting's path begins with / and has no spaces (such as /slave/dob/bandwidth_hz)"
        )))
    }
}

/// A setting's value as JSON the machine parses: a finite number, true or false, or a
/// string in quotes (the machine checks its range).
fn setting_value(value: &str) -> Result<(), Failure> {
    let v = value.trim();
    let number = || {
        let digits = v.strip_prefix('-').unwrap_or(v);
        let json_form = digits.starts_with(|c: char| c.is_ascii_digit())
            && digits
                .chars()
                .all(|c| c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '+' | '-'));
        json_form && v.parse::<f64>().is_ok_and(f64::is_finite)
    };
    let string = v.len() >= 2 && v.starts_with('"') && v.ends_with('"');
    if matches!(v, "true" | "false") || string || number() {
        Ok(())
    } else {
        Err(Failure::Input(format!(
            "{value:?}: not a value the machine takes (a finite number such as 120 or 2.5e-3, true or false)"
        )))
    }
}

/// The most samples `kerf log` keeps (in memory until it writes them).
const MAX_LOG_SAMPLES: f64 = 1e7;

pub(crate) fn positive_rate(hz: f64) -> Result<f64, Failure> {
    if hz.is_finite() && hz > 0.0 {
        Ok(hz)
    } else {
        Err(Failure::Input(format!(
            "--telemetry-hz {hz:?}: must be a positive rate"
        )))
    }
}

/// Lines the operator types during a run, when standard input is a terminal.
fn console() -> Option<Receiver<Order>> {
    if !std::io::stdin().is_terminal() {
        return None;
    }
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        for line in std::io::stdin().lines().map_while(Result::ok) {
            if tx.send(Order::logged(line)).is_err() {
                return;
            }
        }
    });
    Some(rx)
}

/// Where the telemetry goes, checked before the machine is asked for anything.
struct Outputs {
    csv: Option<OutputFile>,
    svg: Option<OutputFile>,
}

impl Outputs {
    fn prepare(csv: Option<&Path>, svg: Option<&Path>) -> Result<Self, Failure> {
        distinct(&[("--csv", csv), ("--svg", svg)])?;
        Ok(Outputs {
            csv: prepare(csv, "telemetry")?,
            svg: prepare(svg, "picture")?,
        })
    }

    fn write(&self, log: &TelemetryLog, title: &str, report: &mut Report) -> Result<(), Failure> {
        if let Some(f) = &self.csv {
            f.write(|w| log.write_csv(w))?;
            say!(
                report,
                "wrote {} ({} samples)",
                f.shown(),
                log.entries().len()
            );
        }
        if let Some(f) = &self.svg {
            let text = log
                .svg(title)
                .map_err(|e| Failure::Output(format!("{}: {e}", f.shown())))?;
            f.write_bytes(text.as_bytes())?;
            say!(report, "wrote {}", f.shown());
        }
        Ok(())
    }
}

/// An empty log for `machine`'s telemetry, its path drawn in the machine's plane.
fn new_log(machine: &kerf_host::link::MachineLink) -> TelemetryLog {
    let hello = machine.hello();
    let plane = kerf_host::check::Machine::from_name(&hello.machine)
        .map_or([0, 1], kerf_host::check::Machine::path_plane);
    TelemetryLog::new(hello.period_s, &machine.description().channels).with_plane(plane)
}

/// `kerf run JOB`: upload, start, follow to the end; the summary, CSV and SVG are
/// written whatever the end.
pub fn run(args: &RunArgs, report: &mut Report) -> Result<(), Failure> {
    if let Some(url) = args.machine.session() {
        return crate::cli_serve::run_job(url, &args.job, report);
    }
    let name = args.job.display().to_string();
    let file_name = args
        .job
        .file_name()
        .map_or(name.clone(), |n| n.to_string_lossy().into_owned());
    let bytes = std::fs::read(&args.job).map_err(|e| {
        Failure::Input(format!(
            "{name}: cannot read the job file: {}",
            io_words(&e)
        ))
    })?;
    let bytes = crate::cli_cut::apply(&name, &bytes, &args.cut)?;
    // One job file, or the parts of a program back to back.
    let parts: Vec<(JobKind, &[u8])> = kerf_host::job::split(&bytes)
        .and_then(|parts| {
            parts
                .into_iter()
                .map(|p| Job::from_bytes(p).map(|job| (job.kind(), p)))
                .collect()
        })
        .map_err(|e| Failure::Input(format!("{name}: {e}")))?;
    if args.quiet_s == 0 {
        return Err(Failure::Input(
            "--quiet-s 0: give the machine at least 1 s to answer".into(),
        ));
    }
    let outputs = Outputs::prepare(args.csv.as_deref(), args.svg.as_deref())?;
    let mut changes: Vec<TimedChange> = args.changes.iter().map(|c| c.0.clone()).collect();
    changes.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
    let plan = RunPlan {
        telemetry_hz: positive_rate(args.telemetry_hz)?,
        changes,
        quiet_s: args.quiet_s,
    };
    let mut session = args.machine.open()?;
    let hello = session.machine.hello().clone();
    say!(
        report,
        "machine    {} (link v{}, control period {:.0} µs)",
        hello.machine,
        hello.version,
        hello.period_s * 1e6
    );
    // A job the machine would refuse is refused before the upload, in its words.
    let mut planned_s = None;
    if let Some(machine) = kerf_host::check::Machine::from_name(&hello.machine) {
        let checked = kerf_host::check::check(&bytes, Some(machine))
            .map_err(|e| Failure::Refused(format!("{name}: {e}")))?;
        say!(
            report,
            "checked    {} accepts it (its own load check, here): about {:.2} s",
            hello.machine,
            checked.duration_s
        );
        planned_s = Some(checked.duration_s);
    }
    let first_len = parts.first().map_or(0, |p| p.1.len());
    let bar = ProgressBar::new(first_len as u64);
    if let Ok(style) = ProgressStyle::with_template("{msg:12} {bar:30} {pos}/{len}") {
        bar.set_style(style);
    }
    bar.set_message("upload");
    let mut log = new_log(&session.machine);
    let lines = console();
    if lines.is_some() {
        let _ = writeln!(
            std::io::stderr(),
            "during the run: set PATH VALUE, get PATH, stop"
        );
    }
    let kinds: Vec<&str> = parts
        .iter()
        .map(|&(k, _)| kerf_host::check::kind_words(k))
        .collect();
    let uploaded = match kinds.as_slice() {
        [one] => format!("uploaded   {name}: {} bytes, {one} job", bytes.len()),
        many => format!(
            "uploaded   {name}: {first_len} of {} bytes, the first of {} parts ({}); the others while it runs",
            bytes.len(),
            many.len(),
            kinds[0]
        ),
    };
    let mut cutting = false;
    let mut sampled = false;
    // Said once the machine has taken the upload (its commit answered: the run goes
    // on to what follows it), not when the last chunk is sent.
    let mut untold = Some(uploaded);
    let mut sent = false;
    let ended = session.run_parts(&parts, &plan, &mut log, lines.as_ref(), &mut |p| {
        if sent && !matches!(p, Progress::Uploaded(_)) {
            if let Some(text) = untold.take() {
                bar.suspend(|| say!(report, "{text}"));
            }
        }
        match p {
            Progress::Uploaded(n) => {
                bar.set_position(u64::from(n));
                sent |= n as usize == first_len;
            }
            Progress::Sample(t, _) => {
                sampled = true;
                if !cutting {
                    cutting = true;
                    bar.set_style(
                        ProgressStyle::with_template("{msg:12} {spinner} {prefix}")
                            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
                    );
                    bar.set_message("running");
                }
                bar.set_prefix(match planned_s {
                    Some(d) => format!(
                        "cut {t:.1} s of about {d:.1} s, {:.1} s left",
                        (d - t).max(0.0)
                    ),
                    None => format!("cut {t:.1} s"),
                });
                bar.tick();
            }
            // Machine time, as the plots; before the first sample there is none.
            Progress::Line(t, text) if sampled => {
                bar.suspend(|| say!(report, "{t:9.4} s   {text}"))
            }
            Progress::Line(_, text) => bar.suspend(|| say!(report, "             {text}")),
        }
    });
    bar.finish_and_clear();
    if log.entries().is_empty() {
        // Refused, or lost before it ran: there is nothing to write.
        return match ended {
            Ok(()) => Err(Failure::Link("the machine sent no telemetry".into())),
            Err(e) => Err(session_failure(e)),
        };
    }
    say!(report, "summary    {}", log.summary());
    outputs.write(
        &log,
        &format!("kerf run {file_name} on {}", hello.machine),
        report,
    )?;
    match ended {
        Ok(()) => {
            say!(report, "done       the job ran to its end");
            Ok(())
        }
        Err(e) => Err(session_failure(e)),
    }
}

/// `kerf get PATH [--json]`: one setting, or every setting under a branch (`/` for
/// all of them).
pub fn get(
    path: &str,
    json: bool,
    machine: &MachineArgs,
    report: &mut Report,
) -> Result<(), Failure> {
    setting_path(path)?;
    let listed = match machine.session() {
        Some(url) => crate::cli_serve::listed(url, path)?,
        None => read_settings(&mut machine.open()?.machine, path)?,
    };
    if json {
        say!(report, "{}", settings_json(&listed));
    } else {
        for (info, value) in &listed {
            say!(report, "{} = {value}", info.path);
        }
    }
    Ok(())
}

/// `kerf settings [--json]`: every setting with its value, preset, unit and range.
pub fn settings(json: bool, machine: &MachineArgs, report: &mut Report) -> Result<(), Failure> {
    let listed = match machine.session() {
        Some(url) => crate::cli_serve::listed(url, "/")?,
        None => read_settings(&mut machine.open()?.machine, "/")?,
    };
    if json {
        say!(report, "{}", settings_json(&listed));
        return Ok(());
    }
    let width = listed
        .iter()
        .map(|(i, _)| i.path.chars().count())
        .max()
        .unwrap_or(4);
    let value_width = listed
        .iter()
        .map(|(_, v)| v.chars().count())
        .max()
        .unwrap_or(5)
        .max(5);
    let preset_width = listed.iter().map(|(i, _)| i.preset.chars().count());
    let preset_width = preset_width.max().unwrap_or(6).max(6);
    say!(
        report,
        "{:width$}  {:>value_width$}  {:>preset_width$}  {:8}  range",
        "path",
        "value",
        "preset",
        "unit"
    );
    for (info, value) in &listed {
        say!(
            report,
            "{:width$}  {value:>value_width$}  {:>preset_width$}  {:8}  {}",
            info.path,
            info.preset,
            info.unit,
            if info.range.is_empty() {
                "any"
            } else {
                &info.range
            }
        );
    }
    Ok(())
}

/// The settings at or under `path` with the values the machine reads back.
fn read_settings(
    machine: &mut kerf_host::link::MachineLink,
    path: &str,
) -> Result<Vec<(SettingInfo, String)>, Failure> {
    let chosen: Vec<SettingInfo> = machine
        .description()
        .settings_under(path)
        .into_iter()
        .cloned()
        .collect();
    if chosen.is_empty() {
        let known: Vec<&str> = machine
            .description()
            .settings
            .iter()
            .map(|s| s.path.as_str())
            .collect();
        return Err(Failure::Refused(format!(
            "{path}: the machine has no setting there (it has {})",
            known.join(", ")
        )));
    }
    chosen
        .into_iter()
        .map(|info| {
            let value = machine.get(&info.path).map_err(link_failure)?;
            Ok((info, value))
        })
        .collect()
}

/// Settings and values as a JSON array ([`SettingInfo::json`]).
fn settings_json(listed: &[(SettingInfo, String)]) -> String {
    let items = listed.iter().map(|(info, value)| info.json(Some(value)));
    serde_json::Value::Array(items.collect()).to_string()
}

/// `kerf set PATH VALUE`.
pub fn set(
    path: &str,
    value: &str,
    save_too: bool,
    machine: &MachineArgs,
    report: &mut Report,
) -> Result<(), Failure> {
    setting_path(path)?;
    setting_value(value)?;
    if let Some(url) = machine.session() {
        return crate::cli_serve::set(url, path, value, save_too, report);
    }
    let mut s = machine.open()?;
    s.machine.set(path, value).map_err(link_failure)?;
    let now = s.machine.get(path).map_err(link_failure)?;
    say!(report, "{path} = {now}");
    if save_too {
        s.machine.command(Request::Save).map_err(link_failure)?;
        saved(machine, report);
    }
    Ok(())
}

/// Says where the settings were kept.
fn saved(machine: &MachineArgs, report: &mut Report) {
    say!(
        report,
        "saved      the machine keeps its settings as they are now"
    );
    if let Some(file) = machine.settings_file() {
        say!(report, "           in {}", file.display());
    }
}

/// `kerf save`: the machine keeps its settings as they are across resets.
pub fn save(machine: &MachineArgs, report: &mut Report) -> Result<(), Failure> {
    if let Some(url) = machine.session() {
        return crate::cli_serve::save(url, report);
    }
    let mut s = machine.open()?;
    s.machine.command(Request::Save).map_err(link_failure)?;
    saved(machine, report);
    Ok(())
}

/// `kerf status`.
pub fn status(json: bool, machine: &MachineArgs, report: &mut Report) -> Result<(), Failure> {
    if let Some(url) = machine.session() {
        return crate::cli_serve::status(url, json, report);
    }
    let mut s = machine.open()?;
    let hello = s.machine.hello().clone();
    let st = s.machine.status().map_err(link_failure)?;
    if json {
        let fault = st
            .last_fault
            .map(|(code, detail)| s.machine.description().fault_words(code, detail));
        say!(
            report,
            "{}",
            serde_json::json!({
                "machine": {"name": hello.machine, "version": hello.version, "period_s": hello.period_s},
                "status": {
                    "mode": mode_words(st.mode),
                    "last_fault": fault,
                    "machine_time_s": st.period as f64 * hello.period_s,
                    "upload_received": st.upload_received,
                    "settings_origin": settings_origin_words(st.settings),
                    "bad_frames": st.bad_frames,
                    "unsent": st.unsent,
                },
            })
        );
        return Ok(());
    }
    say!(
        report,
        "machine      {} (link v{})",
        hello.machine,
        hello.version
    );
    say!(
        report,
        "period       {:.0} µs, largest chunk {} bytes",
        hello.period_s * 1e6,
        hello.max_chunk
    );
    say!(report, "mode         {}", mode_words(st.mode));
    say!(
        report,
        "machine time {:.4} s (period {})",
        st.period as f64 * hello.period_s,
        st.period
    );
    match st.last_fault {
        Some((code, detail)) => say!(
            report,
            "last fault   {code}: {}",
            s.machine.description().fault_words(code, detail)
        ),
        None => say!(report, "last fault   none"),
    }
    match st.upload_received {
        Some(n) => say!(report, "upload       {n} bytes received, not committed"),
        None => say!(report, "upload       none in progress"),
    }
    say!(
        report,
        "settings     {}",
        settings_origin_words(st.settings)
    );
    if let Some(file) = machine.settings_file() {
        say!(report, "             kept in {}", file.display());
    }
    say!(
        report,
        "link         {} bad frames from the host, {} messages unsent; {} bad frames from the machine",
        st.bad_frames,
        st.unsent,
        s.machine.bad_frames()
    );
    let description = s.machine.description();
    let channels: Vec<String> = description
        .channels
        .iter()
        .map(|c| format!("{} ({})", c.name, c.unit))
        .collect();
    say!(report, "telemetry    {}", channels.join(", "));
    let kinds: Vec<String> = description
        .job_kinds
        .iter()
        .map(|&k| job_kind_words(k).to_owned())
        .collect();
    say!(report, "job kinds    {}", kinds.join(", "));
    for setting in &description.settings {
        say!(
            report,
            "setting      {} {} {} (preset {})",
            setting.path,
            setting.unit,
            setting.range,
            setting.preset
        );
    }
    Ok(())
}

/// `kerf log`: telemetry for a span of machine time.
pub fn log(args: &LogArgs, report: &mut Report) -> Result<(), Failure> {
    let hz = positive_rate(args.telemetry_hz)?;
    if !(args.seconds.is_finite() && args.seconds > 0.0) {
        return Err(Failure::Input(format!(
            "--seconds {:?}: must be a positive span of machine time",
            args.seconds
        )));
    }
    if args.seconds * hz > MAX_LOG_SAMPLES {
        return Err(Failure::Input(format!(
            "--seconds {:?} at --telemetry-hz {hz:?} asks for more than {MAX_LOG_SAMPLES:.0} samples (the log is kept in memory until it is written)",
            args.seconds
        )));
    }
    let outputs = Outputs::prepare(args.csv.as_deref(), args.svg.as_deref())?;
    let mut s = args.machine.open()?;
    s.machine.telemetry(hz).map_err(link_failure)?;
    let mut log = new_log(&s.machine);
    let bar = ProgressBar::new_spinner();
    let mut last_heard = Instant::now();
    loop {
        match s
            .machine
            .next(Duration::from_millis(100))
            .map_err(link_failure)?
        {
            Some(Heard::Telemetry(t)) => {
                last_heard = Instant::now();
                let e = log.push(t);
                let span = e.time_s - log.entries()[0].time_s;
                bar.set_message(format!("machine time {span:.3} s"));
                if span >= args.seconds {
                    break;
                }
            }
            Some(Heard::Event(e)) => bar.println(s.machine.description().event_words(&e)),
            _ => {}
        }
        if last_heard.elapsed() > Duration::from_secs(30) {
            return Err(Failure::Link(
                "the machine sent no telemetry for 30 s".into(),
            ));
        }
    }
    s.machine
        .command(Request::Telemetry { every_periods: 0 })
        .map_err(link_failure)?;
    bar.finish_and_clear();
    if outputs.csv.is_none() {
        report.with(|w| log.write_csv(w));
    }
    outputs.write(&log, "kerf log", report)
}
