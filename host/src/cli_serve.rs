//! `kerf serve`, and the commands' way to a machine that `kerf serve` holds open
//! (`--session URL`): the same words and exit codes as with the machine itself.

use crate::cli_machine::MachineArgs;
use crate::report::{say, Report};
use crate::Failure;
use kerf_host::description::SettingInfo;
use kerf_host::output::io_words;
use kerf_host::serve::client::{Client, ClientError};
use kerf_host::serve::{self, station::Station};
use std::io::BufRead;
use std::path::PathBuf;

/// `kerf serve`.
#[derive(Debug, clap::Args)]
pub struct ServeArgs {
    #[command(flatten)]
    machine: MachineArgs,
    /// Where the console listens: an address and port (the loopback only by default:
    /// anyone who reaches the page can move the machine).
    #[arg(long, value_name = "ADDR:PORT", default_value = "127.0.0.1:8080")]
    listen: String,
    /// Telemetry samples per second of machine time, during jobs and between them.
    #[arg(long, value_name = "HZ", default_value_t = 100.0)]
    telemetry_hz: f64,
}

/// `kerf serve`: opens the machine, then serves until the process is ended.
pub fn run(args: &ServeArgs, report: &mut Report) -> Result<(), Failure> {
    if args.machine.session().is_some() {
        return Err(Failure::Input(
            "--session: kerf serve holds the machine itself (give --qemu or --port)".into(),
        ));
    }
    let hz = crate::cli_machine::positive_rate(args.telemetry_hz)?;
    // The address first: a port in use is said before the machine is opened.
    let listener = std::net::TcpListener::bind(&args.listen).map_err(|e| {
        Failure::Input(format!(
            "--listen {}: cannot listen there: {}",
            args.listen,
            io_words(&e)
        ))
    })?;
    let address = listener
        .local_addr()
        .map_err(|e| Failure::Input(format!("--listen {}: {}", args.listen, io_words(&e))))?;
    let session = args.machine.open()?;
    let station = Station::start(session, hz).map_err(|e| Failure::Link(e.to_string()))?;
    say!(
        report,
        "machine    {} (link v{}, control period {:.0} µs)",
        station.info.name,
        station.info.version,
        station.info.period_s * 1e6
    );
    say!(report, "console    http://{address}/");
    say!(
        report,
        "commands   kerf get|set|settings|save|status|run --session {address}"
    );
    serve::run(station, listener, serve::ended())
        .map_err(|e| Failure::Link(format!("the console's server: {e}")))?;
    say!(report, "ended      the machine's session is closed");
    Ok(())
}

fn failure(e: ClientError) -> Failure {
    match e {
        ClientError::Unreachable { .. } => Failure::Link(e.to_string()),
        ClientError::Refused { status, .. } if status >= 500 => Failure::Link(e.to_string()),
        ClientError::Refused { .. } => Failure::Refused(e.to_string()),
    }
}

/// The settings at or under `path` as the station holds them.
pub(crate) fn listed(url: &str, path: &str) -> Result<Vec<(SettingInfo, String)>, Failure> {
    let query = format!("/api/settings?under={}", encode(path));
    let items = Client::new(url).get(&query).map_err(failure)?;
    let items = items.as_array().cloned().unwrap_or_default();
    Ok(items
        .iter()
        .map(|i| {
            let text = |k: &str| i[k].as_str().unwrap_or_default().to_owned();
            (
                SettingInfo {
                    path: text("path"),
                    unit: text("unit"),
                    range: text("range"),
                    preset: i["preset"].to_string(),
                },
                i["value"].to_string(),
            )
        })
        .collect())
}

/// A query's value with the characters a URL reserves escaped.
fn encode(text: &str) -> String {
    text.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'/' | b'_' | b'-' | b'.' => {
                (b as char).to_string()
            }
            _ => format!("%{b:02X}"),
        })
        .collect()
}

/// `kerf set PATH VALUE --session URL [--save]`.
pub fn set(
    url: &str,
    path: &str,
    value: &str,
    save: bool,
    report: &mut Report,
) -> Result<(), Failure> {
    let client = Client::new(url);
    let answer = client
        .post(
            "/api/set",
            &serde_json::json!({ "path": path, "value": value }),
        )
        .map_err(failure)?;
    say!(report, "{}", answer["answer"].as_str().unwrap_or_default());
    if save {
        self::save(url, report)?;
    }
    Ok(())
}

/// `kerf save --session URL`.
pub fn save(url: &str, report: &mut Report) -> Result<(), Failure> {
    let answer = Client::new(url)
        .post("/api/save", &serde_json::json!({}))
        .map_err(failure)?;
    say!(report, "{}", answer["answer"].as_str().unwrap_or_default());
    Ok(())
}

/// `kerf status --session URL [--json]`.
pub fn status(url: &str, json: bool, report: &mut Report) -> Result<(), Failure> {
    let client = Client::new(url);
    let machine = client.get("/api/machine").map_err(failure)?;
    let st = client.get("/api/status").map_err(failure)?;
    if json {
        say!(
            report,
            "{}",
            serde_json::json!({ "machine": machine["machine"], "status": st })
        );
        return Ok(());
    }
    let m = &machine["machine"];
    say!(
        report,
        "machine      {} (link v{}), held by kerf serve at {url}",
        text(&m["name"]),
        m["version"]
    );
    say!(report, "mode         {}", text(&st["mode"]));
    say!(
        report,
        "last fault   {}",
        st["last_fault"].as_str().unwrap_or("none")
    );
    match st["job"].as_object() {
        Some(j) => say!(
            report,
            "job          {}: {}, about {:.2} s{}",
            text(&j["name"]),
            text(&j["kind"]),
            j["duration_s"].as_f64().unwrap_or(0.0),
            if st["running"] == true {
                ", running"
            } else {
                ", loaded"
            }
        ),
        None => say!(report, "job          none loaded"),
    }
    say!(report, "settings     {}", text(&st["settings_origin"]));
    say!(
        report,
        "link         {} samples, {} bad frames from the machine, heard {} ms ago",
        st["samples"],
        st["bad_frames"],
        st["quiet_ms"]
    );
    Ok(())
}

fn text(v: &serde_json::Value) -> &str {
    v.as_str().unwrap_or_default()
}

/// `kerf run JOB --session URL`: loads the job into the station, starts it and
/// prints the machine's lines until it ends.
pub fn run_job(url: &str, job: &PathBuf, report: &mut Report) -> Result<(), Failure> {
    let name = job.display().to_string();
    let file_name = job
        .file_name()
        .map_or(name.clone(), |n| n.to_string_lossy().into_owned());
    let bytes = std::fs::read(job).map_err(|e| {
        Failure::Input(format!(
            "{name}: cannot read the job file: {}",
            io_words(&e)
        ))
    })?;
    let client = Client::new(url);
    let loaded = client
        .post_bytes(&format!("/api/job?name={}", encode(&file_name)), &bytes)
        .map_err(failure)?;
    say!(
        report,
        "checked    {}: {}, about {:.2} s",
        file_name,
        text(&loaded["kind"]),
        loaded["duration_s"].as_f64().unwrap_or(0.0)
    );
    // Listening before the start, so that no line of the run is missed.
    let reader = client.stream().map_err(failure)?;
    let runs_before = client.get("/api/status").map_err(failure)?["runs"].as_u64();
    let answer = client
        .post("/api/start", &serde_json::json!({}))
        .map_err(failure)?;
    say!(report, "started    {}", text(&answer["answer"]));
    for line in reader.lines() {
        let line =
            line.map_err(|e| Failure::Link(format!("the station's stream: {}", io_words(&e))))?;
        let Some(data) = line.strip_prefix("data: ") else {
            continue;
        };
        let Ok(update) = serde_json::from_str::<serde_json::Value>(data) else {
            continue;
        };
        match update["kind"].as_str() {
            Some("line") => match update["t"].as_f64() {
                Some(t) => say!(report, "{t:9.4} s   {}", text(&update["text"])),
                None => say!(report, "             {}", text(&update["text"])),
            },
            Some("state") => {
                let st = client.get("/api/status").map_err(failure)?;
                if st["running"] == false && st["runs"].as_u64() > runs_before {
                    return match st["last_run"].as_object() {
                        Some(o) if o.contains_key("Ok") => Ok(()),
                        Some(o) => Err(Failure::Refused(text(&o["Err"]).to_owned())),
                        None => Err(Failure::Refused("the job did not start".into())),
                    };
                }
            }
            _ => {}
        }
    }
    Err(Failure::Link(
        "the station's stream ended during the run".into(),
    ))
}
