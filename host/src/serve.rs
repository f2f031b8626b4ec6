//! `kerf serve`: one process holds a machine open ([`station`]) and serves the
//! operator's web console and an HTTP API to it, so that settings, a loaded job and
//! the telemetry persist between commands and several clients share one machine.
//!
//! The server is axum on a single-threaded tokio runtime: a well-kept stack whose
//! server-sent events carry the live telemetry with no extra protocol. The console is
//! one HTML page, one stylesheet and one script without libraries (the plots are
//! drawn on canvases), compiled into the binary: nothing is fetched at run time, and
//! the page is the same for every machine, built from what the machine announces.
//!
//! The API (JSON unless said otherwise; errors are `{"error": words}` with a 4xx or
//! 5xx status):
//!
//! | request | answer |
//! |---|---|
//! | `GET /api/machine` | name, link version, period, channels, job kinds, settings (unit, range) |
//! | `GET /api/status` | mode, last fault, running job, upload, settings' values and origin, link health, event log |
//! | `GET /api/recent` | the last samples: `[[t, [values…]], …]` |
//! | `GET /api/settings?under=/x` | `[{path, value, unit, range}]` |
//! | `POST /api/set` `{path, value}` | the value read back, or the machine's refusal (409) |
//! | `POST /api/save`, `/api/start`, `/api/stop`, `/api/reset` | the machine's answer in words |
//! | `POST /api/job?name=FILE` (the file as the body) | the job checked and loaded: kind, parts, duration |
//! | `GET /api/job/preview` | the loaded job's preview, SVG |
//! | `GET /api/stream` | server-sent events: `sample`, `line`, `upload`, `state` ([`station::Update`]) |

pub mod client;
pub mod station;

use crate::check::Machine;
use axum::extract::{Query, State};
use axum::http::{header, StatusCode};
use axum::response::sse::{Event as SseEvent, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::Deserialize;
use station::Station;
use std::sync::Arc;
use tokio_stream::wrappers::BroadcastStream;
use tokio_stream::StreamExt;

/// An error the API answers with: a status and words.
#[derive(Debug)]
pub struct ApiError(StatusCode, String);

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        (self.0, Json(serde_json::json!({ "error": self.1 }))).into_response()
    }
}

type Answer = Result<Json<serde_json::Value>, ApiError>;

/// The console's router over `station`.
fn router(station: Arc<Station>) -> Router {
    Router::new()
        .route("/", get(|| async { asset("text/html", PAGE) }))
        .route(
            "/console.js",
            get(|| async { asset("text/javascript", SCRIPT) }),
        )
        .route("/console.css", get(|| async { asset("text/css", STYLE) }))
        .route("/api/machine", get(machine))
        .route("/api/status", get(status))
        .route("/api/recent", get(recent))
        .route("/api/settings", get(settings))
        .route("/api/set", post(set))
        .route("/api/save", post(|s| command(s, "save")))
        .route("/api/start", post(|s| command(s, "start")))
        .route("/api/stop", post(|s| command(s, "stop")))
        .route("/api/reset", post(|s| command(s, "reset")))
        .route("/api/job", post(load_job))
        .route("/api/job/preview", get(preview))
        .route("/api/stream", get(stream))
        .fallback(|| async {
            ApiError(
                StatusCode::NOT_FOUND,
                "no such page or request (the API is under /api: machine, status, recent, settings, set, save, start, stop, reset, job, stream)".into(),
            )
        })
        .with_state(station)
}

/// The page, its style and script, compiled in.
const PAGE: &str = include_str!("serve/console.html");
const STYLE: &str = include_str!("serve/console.css");
const SCRIPT: &str = include_str!("serve/console.js");

fn asset(kind: &'static str, body: &'static str) -> Response {
    ([(header::CONTENT_TYPE, kind)], body).into_response()
}

/// Serves the console on `listener` until `until` completes; then the station's last
/// handle goes, and with it the machine's session (a job that runs is stopped first,
/// the emulated machine ends).
pub fn run(
    station: Arc<Station>,
    listener: std::net::TcpListener,
    until: impl std::future::Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    listener.set_nonblocking(true)?;
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?;
    runtime.block_on(async move {
        let listener = tokio::net::TcpListener::from_std(listener)?;
        // Not a graceful shutdown: the live streams never end by themselves.
        tokio::select! {
            served = axum::serve(listener, router(station)) => served,
            () = until => Ok(()),
        }
    })
}

/// A console served from a thread of its own ([`spawn`]); it ends, and its machine's
/// session with it, when this is dropped.
pub struct Served {
    /// Where it listens.
    pub address: std::net::SocketAddr,
    end: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<std::io::Result<()>>>,
}

/// Serves `station` on `listener` from a new thread (a test's console, a tool's).
pub fn spawn(station: Arc<Station>, listener: std::net::TcpListener) -> std::io::Result<Served> {
    let address = listener.local_addr()?;
    let (end, ended) = tokio::sync::oneshot::channel::<()>();
    let thread = std::thread::spawn(move || {
        run(station, listener, async {
            let _ = ended.await;
        })
    });
    Ok(Served {
        address,
        end: Some(end),
        thread: Some(thread),
    })
}

impl Drop for Served {
    fn drop(&mut self) {
        if let Some(end) = self.end.take() {
            let _ = end.send(());
        }
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// Completes when the process is asked to end (Ctrl-C, SIGTERM).
pub async fn ended() {
    let terminate = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    tokio::select! {
        _ = tokio::signal::ctrl_c() => {}
        () = terminate => {}
    }
}

async fn machine(State(s): State<Arc<Station>>) -> Answer {
    let settings: Vec<_> = s
        .description
        .settings
        .iter()
        .map(|i| i.json(None))
        .collect();
    Ok(Json(serde_json::json!({
        "machine": s.info,
        "settings": settings,
    })))
}

async fn status(State(s): State<Arc<Station>>) -> Answer {
    to_json(&s.snapshot())
}

async fn recent(State(s): State<Arc<Station>>) -> Answer {
    to_json(&s.recent())
}

fn to_json(value: &impl serde::Serialize) -> Answer {
    serde_json::to_value(value)
        .map(Json)
        .map_err(|e| ApiError(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))
}

#[derive(Deserialize)]
struct Under {
    under: Option<String>,
}

async fn settings(State(s): State<Arc<Station>>, Query(q): Query<Under>) -> Answer {
    let under = q.under.unwrap_or_else(|| "/".into());
    let values = s.snapshot().values;
    let listed: Vec<_> = s
        .description
        .settings_under(&under)
        .into_iter()
        .map(|i| {
            let value = values
                .iter()
                .find(|(p, _)| *p == i.path)
                .map(|(_, v)| v.as_str())
                .unwrap_or("null");
            i.json(Some(value))
        })
        .collect();
    if listed.is_empty() {
        return Err(ApiError(
            StatusCode::NOT_FOUND,
            format!("{under}: the machine has no setting there"),
        ));
    }
    Ok(Json(serde_json::Value::Array(listed)))
}

#[derive(Deserialize)]
struct SetBody {
    path: String,
    value: serde_json::Value,
}

async fn set(
    State(s): State<Arc<Station>>,
    body: Result<Json<SetBody>, axum::extract::rejection::JsonRejection>,
) -> Answer {
    let Json(body) = body.map_err(|e| {
        ApiError(
            StatusCode::BAD_REQUEST,
            format!(
                "{}: send {{\"path\": \"/a/setting\", \"value\": 120}}",
                e.body_text()
            ),
        )
    })?;
    let Some(info) = s.description.setting(&body.path) else {
        let known: Vec<&str> = s
            .description
            .settings
            .iter()
            .map(|i| i.path.as_str())
            .collect();
        return Err(ApiError(
            StatusCode::NOT_FOUND,
            format!(
                "{}: the machine has no such setting (it has {})",
                body.path,
                known.join(", ")
            ),
        ));
    };
    let value = match &body.value {
        serde_json::Value::String(text) => text.trim().to_owned(),
        v @ (serde_json::Value::Number(_) | serde_json::Value::Bool(_)) => v.to_string(),
        _ => String::new(),
    };
    if value.is_empty() || value.contains(char::is_whitespace) {
        return Err(ApiError(
            StatusCode::BAD_REQUEST,
            format!(
                "{}: the value must be a number or true/false{}",
                info.path,
                if info.range.is_empty() {
                    String::new()
                } else {
                    format!(" ({})", info.range)
                }
            ),
        ));
    }
    let line = format!("set {} {value}", info.path);
    order(s, line).await
}

async fn command(State(s): State<Arc<Station>>, what: &'static str) -> Answer {
    order(s, what.to_owned()).await
}

/// Gives the station an order off the event loop; a refusal is a conflict with the
/// machine's state (409), a link that ended is 503.
async fn order(s: Arc<Station>, line: String) -> Answer {
    let outcome = tokio::task::spawn_blocking(move || {
        let answer = s.order(&line);
        (answer, s.snapshot().closed.is_some())
    })
    .await
    .map_err(|e| ApiError(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))?;
    match outcome {
        (Ok(text), _) => Ok(Json(serde_json::json!({ "answer": text }))),
        (Err(text), true) => Err(ApiError(StatusCode::SERVICE_UNAVAILABLE, text)),
        (Err(text), false) => Err(ApiError(StatusCode::CONFLICT, text)),
    }
}

#[derive(Deserialize)]
struct JobName {
    name: Option<String>,
}

async fn load_job(
    State(s): State<Arc<Station>>,
    Query(q): Query<JobName>,
    body: axum::body::Bytes,
) -> Answer {
    let name = q.name.unwrap_or_else(|| "job".into());
    if body.is_empty() {
        return Err(ApiError(
            StatusCode::BAD_REQUEST,
            format!("{name}: the file is empty (send the job file or picture as the body)"),
        ));
    }
    let job = tokio::task::spawn_blocking(move || {
        let file = job_file(&name, &body, s.machine)?;
        s.load(&name, file)
    })
    .await
    .map_err(|e| ApiError(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))?
    .map_err(|e| ApiError(StatusCode::UNPROCESSABLE_ENTITY, e))?;
    to_json(&job)
}

/// The job file of a file the operator gave `machine` (named `name`, for the words):
/// a job file as it is; a G-code program (`.gcode`, `.ngc`, `.nc`, `.tap`, `.cnc`) as
/// `kerf gcode --machine M` writes it with its defaults (ARROW's in parts where it is
/// long, the Keops slave's a laser program's parts); a picture planned as `kerf plan
/// --all` plans it (every closed contour) for the Keops slave.
///
/// Errors, in words: a file that is none of these; a program's errors with their
/// lines; a picture for a machine that does not cut contours.
pub fn job_file(name: &str, body: &[u8], machine: Option<Machine>) -> Result<Vec<u8>, String> {
    let machine_name = machine.map_or("this machine", Machine::name);
    if crate::job::split(body).is_ok() {
        return Ok(body.to_vec());
    }
    let lower = name.to_ascii_lowercase();
    let program = [".gcode", ".ngc", ".nc", ".tap", ".cnc"]
        .iter()
        .any(|e| lower.ends_with(e));
    if program {
        let located = |e: crate::gcode::GcodeCheckError| match e.line {
            0 => format!("{name}: {}", e.message),
            line => format!("{name}:{line}:{}: {}", e.column, e.message),
        };
        return match machine {
            Some(Machine::Arrow) => {
                crate::arrow_parts::parts(body, crate::arrow_parts::Placement::default())
                    .map_err(located)?
                    .job_file(body)
                    .map_err(|e| format!("{name}: {e}"))
            }
            Some(Machine::Grinding | Machine::SingleAxis) => crate::job::Job::Gcode {
                text: body.to_vec(),
            }
            .to_bytes()
            .map_err(|e| format!("{name}: {e}")),
            Some(Machine::KeopsSlave) => laser_job(name, body),
            None => Err(format!("{name}: {machine_name} takes no G-code programs")),
        };
    }
    let picture = image::load_from_memory(body).map_err(|_| {
        format!("{name}: neither a job file (kerf plan --out, kerf gcode --out) nor a picture (PNG, JPEG)")
    })?;
    if machine != Some(Machine::KeopsSlave) {
        return Err(format!(
            "{name}: pictures are planned for the Keops slave only, not {machine_name}"
        ));
    }
    let grey = crate::plan::grey_on_background(&picture);
    let config = crate::plan::PlanConfig::default();
    let set = crate::parts::plan_all(&grey, &config, 0.0, &mut |_| {})
        .map_err(|e| format!("{name}: {e}"))?;
    set.to_bytes().map_err(|e| format!("{name}: {e}"))
}

/// A laser program as `kerf gcode --machine keops-slave` makes it with its defaults
/// (where it is written, sharp corners, `S` of full power at grbl's default).
fn laser_job(name: &str, body: &[u8]) -> Result<Vec<u8>, String> {
    use crate::laser;
    let program = laser::read(body);
    if laser::has_errors(&program) {
        let errors: Vec<String> = program
            .diagnostics
            .iter()
            .filter(|d| d.severity() == kerf::trajectory::gcode::Severity::Error)
            .map(|d| format!("{name}:{d}"))
            .collect();
        return Err(errors.join("; "));
    }
    let beam = laser::Beam::keops(laser::Beam::GRBL_S_MAX);
    let config = crate::plan::PlanConfig::default();
    let parts = laser::parts(&program, &config, false, &beam, laser::Corners::Sharp)
        .map_err(|e| format!("{name}: {e}"))?;
    laser::to_bytes(&parts).map_err(|e| format!("{name}: {e}"))
}

async fn preview(State(s): State<Arc<Station>>) -> Response {
    match s.snapshot().job.and_then(|j| j.preview_svg) {
        Some(svg) => ([(header::CONTENT_TYPE, "image/svg+xml")], svg).into_response(),
        None => ApiError(
            StatusCode::NOT_FOUND,
            "no preview: no job is loaded, or the machine has none".into(),
        )
        .into_response(),
    }
}

async fn stream(State(s): State<Arc<Station>>) -> impl IntoResponse {
    let updates = BroadcastStream::new(s.listen()).filter_map(|u| {
        // A listener too slow for the telemetry skips samples, not the connection.
        let u = u.ok()?;
        let kind = match &u {
            station::Update::Sample { .. } => "sample",
            station::Update::Line(_) => "line",
            station::Update::Upload { .. } => "upload",
            station::Update::State => "state",
        };
        let data = serde_json::to_string(&u).ok()?;
        Some(Ok::<_, std::convert::Infallible>(
            SseEvent::default().event(kind).data(data),
        ))
    });
    Sse::new(updates).keep_alive(KeepAlive::default())
}
