//! The one thread that talks to the machine while `kerf serve` holds it open.
//!
//! Every client's request (the console's, a command's) becomes an [`Order`] on one
//! queue, taken in arrival order: two clients never interleave on the link. Between
//! jobs the thread answers orders itself, reads telemetry and events and keeps the
//! machine's state ([`Snapshot`]); during a job it hands the queue to the session's
//! run ([`Session::run_parts`]), which answers `set`, `get` and `stop` between
//! samples and refuses the rest. What the machine says goes out to every listener as
//! an [`Update`]. Clients that go away change nothing on the machine; only the
//! machine's own rule (no heartbeat: it stops the job) acts when this process ends.

use crate::check::{self, Machine};
use crate::description::{job_kind_words, mode_words, settings_origin_words, MachineDescription};
use crate::link::{Heard, LinkError};
use crate::session::{Order, Progress, RunPlan, Session};
use crate::telemetry::TelemetryLog;
use kerf::codec::link::{Event, ModeCode, Request};
use serde::Serialize;
use std::collections::VecDeque;
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use tokio::sync::broadcast;

/// Lines of the event log kept for a client that connects later.
const LOG_LINES: usize = 200;
/// Samples kept for a client that connects later (its plots' history).
const RECENT_SAMPLES: usize = 2000;
/// Longest a client waits for the machine's answer to an order.
pub const ANSWER_WAIT: Duration = Duration::from_secs(20);

/// Who the machine is and what it announced, fixed for the session.
#[derive(Clone, Debug, Serialize)]
pub struct MachineInfo {
    /// Its name (`keops-slave`, `arrow`).
    pub name: String,
    /// Link version.
    pub version: u8,
    /// Control period, s.
    pub period_s: f64,
    /// Telemetry channels: name and unit, in a sample's order.
    pub channels: Vec<(String, String)>,
    /// The job kinds it takes, in words.
    pub job_kinds: Vec<&'static str>,
    /// Samples per second of machine time the station asks for.
    pub telemetry_hz: f64,
}

/// A loaded job: checked on the host as the machine will check it.
#[derive(Clone, Debug, Serialize)]
pub struct LoadedJob {
    /// The file's name.
    pub name: String,
    /// Bytes of the job file.
    pub bytes: usize,
    /// The (first) part's kind, in words.
    pub kind: &'static str,
    /// Parts of the program.
    pub parts: usize,
    /// Planned duration, s.
    pub duration_s: f64,
    /// Length of the cut, m.
    pub cut_length_m: f64,
    /// The preview (SVG), where the machine has one.
    #[serde(skip)]
    pub preview_svg: Option<String>,
    /// The job file.
    #[serde(skip)]
    pub file: Vec<u8>,
}

/// A line of the event log.
#[derive(Clone, Debug, Serialize)]
pub struct LogLine {
    /// Machine time of the latest sample, s (`None` before any).
    pub t: Option<f64>,
    /// What happened.
    pub text: String,
}

/// The machine's state as the station last heard it.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Snapshot {
    /// Mode, in words.
    pub mode: &'static str,
    /// The last fault, in words (kept after a reset).
    pub last_fault: Option<String>,
    /// Whether a job runs.
    pub running: bool,
    /// The job loaded in the station (not yet on the machine until it starts).
    pub job: Option<LoadedJob>,
    /// Bytes of the running job the machine holds, and of how many.
    pub uploaded: Option<(u32, u32)>,
    /// Runs begun since the station started.
    pub runs: u32,
    /// How the last run ended: `Ok` with its summary, or why it did not reach its end.
    pub last_run: Option<Result<String, String>>,
    /// Where the machine's settings came from at power-up, in words.
    pub settings_origin: String,
    /// Every setting's value as the machine reads it back, in the description's order.
    pub values: Vec<(String, String)>,
    /// Samples heard.
    pub samples: u64,
    /// Frames the host could not read.
    pub bad_frames: u32,
    /// Milliseconds since the machine was last heard.
    pub quiet_ms: u64,
    /// Why the link ended (`None`: it is up).
    pub closed: Option<String>,
    /// The event log's last lines.
    pub log: VecDeque<LogLine>,
}

/// What the worker keeps and clients read: the state, and apart from it (a status
/// does not copy it) the samples of the last seconds.
#[derive(Default)]
struct Shared {
    state: Snapshot,
    /// Oldest first: machine time, s, and values.
    recent: VecDeque<(f64, Vec<f32>)>,
    /// When the machine last sent a sample or an event.
    last_heard: Option<Instant>,
}

impl std::ops::Deref for Shared {
    type Target = Snapshot;
    fn deref(&self) -> &Snapshot {
        &self.state
    }
}

impl std::ops::DerefMut for Shared {
    fn deref_mut(&mut self) -> &mut Snapshot {
        &mut self.state
    }
}

/// What the station tells every listener.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Update {
    /// A telemetry sample.
    Sample {
        /// Machine time, s.
        t: f64,
        /// Mode, in words.
        mode: &'static str,
        /// One value per channel.
        values: Vec<f32>,
        /// When the host read it, ms since the Unix epoch (the console's latency).
        host_ms: f64,
    },
    /// A line of the event log.
    Line(LogLine),
    /// Upload progress of the running job.
    Upload {
        /// Bytes the machine holds.
        bytes: u32,
        /// Of how many.
        of: u32,
    },
    /// The state changed (mode, fault, job, settings): read `/api/status` again.
    State,
}

/// The station's shared half: what clients read without asking the machine.
pub struct Station {
    /// `None` once the station closes.
    orders: Option<Sender<Order>>,
    worker: Option<std::thread::JoinHandle<()>>,
    shared: Arc<Mutex<Shared>>,
    updates: broadcast::Sender<Update>,
    /// Who the machine is.
    pub info: MachineInfo,
    /// What it announced: its settings with units and ranges, its words.
    pub description: MachineDescription,
    /// The machine, for the host's own job check.
    pub machine: Option<Machine>,
}

/// Milliseconds since the Unix epoch.
fn wall_ms() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64() * 1e3)
}

impl Station {
    /// Takes over `session`'s machine in a thread of its own; telemetry at
    /// `telemetry_hz` samples per second of machine time, during jobs and between.
    pub fn start(mut session: Session, telemetry_hz: f64) -> Result<Arc<Self>, LinkError> {
        let m = &mut session.machine;
        let hello = m.hello().clone();
        let description = m.description().clone();
        let values = description
            .settings
            .iter()
            .map(|s| Ok((s.path.clone(), m.get(&s.path)?)))
            .collect::<Result<Vec<_>, LinkError>>()?;
        m.telemetry(telemetry_hz)?;
        let info = MachineInfo {
            name: hello.machine.clone(),
            version: hello.version,
            period_s: hello.period_s,
            channels: description
                .channels
                .iter()
                .map(|c| (c.name.clone(), c.unit.clone()))
                .collect(),
            job_kinds: description
                .job_kinds
                .iter()
                .map(|&k| job_kind_words(k))
                .collect(),
            telemetry_hz,
        };
        let (orders, queue) = channel();
        let (updates, _) = broadcast::channel(4096);
        let mut station = Station {
            orders: Some(orders),
            worker: None,
            shared: Arc::new(Mutex::new(Shared {
                state: Snapshot {
                    values,
                    mode: mode_words(ModeCode::Idle),
                    ..Snapshot::default()
                },
                recent: VecDeque::new(),
                last_heard: None,
            })),
            updates,
            description: description.clone(),
            machine: Machine::from_name(&hello.machine),
            info,
        };
        let mut worker = Worker {
            session,
            queue,
            shared: Arc::clone(&station.shared),
            updates: station.updates.clone(),
            description,
            telemetry_hz,
            idle_log: None,
        };
        worker.refresh_status();
        station.worker = Some(std::thread::spawn(move || worker.serve()));
        Ok(Arc::new(station))
    }

    /// The state as last heard.
    pub fn snapshot(&self) -> Snapshot {
        let shared = lock(&self.shared);
        let mut state = shared.state.clone();
        state.quiet_ms = shared
            .last_heard
            .map_or(0, |t| t.elapsed().as_millis() as u64);
        state
    }

    /// The samples of the last seconds (machine time, values), oldest first.
    pub fn recent(&self) -> Vec<(f64, Vec<f32>)> {
        lock(&self.shared).recent.iter().cloned().collect()
    }

    /// Listens to what the machine says from now on.
    pub fn listen(&self) -> broadcast::Receiver<Update> {
        self.updates.subscribe()
    }

    /// Gives `line` to the machine (`set PATH VALUE`, `get PATH`, `save`, `start`,
    /// `stop`, `reset`, `status`) after the orders before it, and waits for the answer
    /// in words. Blocks: call it off the server's event loop.
    pub fn order(&self, line: &str) -> Result<String, String> {
        let (answer, heard) = channel();
        self.orders
            .as_ref()
            .ok_or_else(|| self.gone())?
            .send(Order {
                line: line.to_owned(),
                answer: Some(answer),
            })
            .map_err(|_| self.gone())?;
        match heard.recv_timeout(ANSWER_WAIT) {
            Ok(outcome) => {
                // A value the running job's session took (between jobs the worker
                // reads it back itself).
                if let (Ok(_), ["set", path, value]) = (
                    &outcome,
                    line.split_whitespace().collect::<Vec<_>>().as_slice(),
                ) {
                    let mut s = lock(&self.shared);
                    if let Some(v) = s.values.iter_mut().find(|(p, _)| p == path) {
                        if v.1.parse::<f64>().ok() != value.parse::<f64>().ok() {
                            v.1 = (*value).to_owned();
                        }
                    }
                }
                outcome
            }
            Err(RecvTimeoutError::Timeout) => Err(format!(
                "the machine did not answer {line:?} within {} s",
                ANSWER_WAIT.as_secs()
            )),
            Err(RecvTimeoutError::Disconnected) => Err(self.gone()),
        }
    }

    fn gone(&self) -> String {
        lock(&self.shared)
            .closed
            .clone()
            .unwrap_or_else(|| "the link to the machine has ended".into())
    }

    /// Checks the job file `file` as the machine will and keeps it as the job to run
    /// (replacing one loaded before, not one that runs).
    pub fn load(&self, name: &str, file: Vec<u8>) -> Result<LoadedJob, String> {
        let checked = check::check(&file, self.machine).map_err(|e| format!("{name}: {e}"))?;
        if self.machine.is_some_and(|m| m != checked.machine) {
            return Err(format!(
                "{name}: a job for {}, not for this machine ({})",
                checked.machine.name(),
                self.info.name
            ));
        }
        let job = LoadedJob {
            name: name.to_owned(),
            bytes: file.len(),
            kind: check::kind_words(checked.kind),
            parts: checked.parts,
            duration_s: checked.duration_s,
            cut_length_m: checked.cut_length_m,
            preview_svg: crate::preview::svg(name, &checked).ok().flatten(),
            file,
        };
        let mut s = lock(&self.shared);
        if s.running {
            return Err(format!(
                "{name}: a job is running; load the next one when it has ended"
            ));
        }
        s.job = Some(job.clone());
        drop(s);
        let _ = self.updates.send(Update::State);
        Ok(job)
    }
}

impl Drop for Station {
    /// The last handle: a job that runs is stopped, the session closes (the emulated
    /// machine ends) before the drop returns.
    fn drop(&mut self) {
        if let Some(orders) = self.orders.take() {
            if lock(&self.shared).running {
                let _ = orders.send(Order::logged("stop".into()));
            }
        }
        if let Some(worker) = self.worker.take() {
            let _ = worker.join();
        }
    }
}

fn lock(shared: &Mutex<Shared>) -> MutexGuard<'_, Shared> {
    // A listener that panicked holding the lock left a state worth showing anyway.
    shared.lock().unwrap_or_else(|p| p.into_inner())
}

/// The thread's half.
struct Worker {
    session: Session,
    queue: Receiver<Order>,
    shared: Arc<Mutex<Shared>>,
    updates: broadcast::Sender<Update>,
    description: MachineDescription,
    telemetry_hz: f64,
    /// Between jobs: the samples' time axis.
    idle_log: Option<TelemetryLog>,
}

/// Keeps a sample for the plots of a client that connects later, and counts it.
fn keep_recent(s: &mut Shared, t: f64, values: Vec<f32>) {
    if s.recent.len() == RECENT_SAMPLES {
        s.recent.pop_front();
    }
    s.recent.push_back((t, values));
    s.samples += 1;
    s.last_heard = Some(Instant::now());
}

impl Worker {
    fn shared(&self) -> MutexGuard<'_, Shared> {
        lock(&self.shared)
    }

    fn say(&self, t: Option<f64>, text: &str) {
        say(&self.shared, &self.updates, t, text);
    }

    /// Orders and the machine's messages until every client's handle is gone or the
    /// link ends.
    fn serve(mut self) {
        let mut last_heartbeat = Instant::now();
        loop {
            match self.queue.recv_timeout(Duration::from_millis(10)) {
                Ok(order) => self.idle_order(order),
                Err(RecvTimeoutError::Disconnected) => return,
                Err(RecvTimeoutError::Timeout) => {}
            }
            if let Err(e) = self.drain() {
                self.close(e);
                return;
            }
            if last_heartbeat.elapsed() > Duration::from_millis(100) {
                if let Err(e) = self.session.machine.send(Request::Heartbeat) {
                    self.close(e);
                    return;
                }
                last_heartbeat = Instant::now();
            }
        }
    }

    fn close(&self, e: LinkError) {
        let text = format!("the link ended: {e}");
        self.say(None, &text);
        self.shared().closed = Some(text);
        let _ = self.updates.send(Update::State);
    }

    /// What the machine said since the last look.
    fn drain(&mut self) -> Result<(), LinkError> {
        while let Some(heard) = self.session.machine.next(Duration::ZERO)? {
            match heard {
                Heard::Telemetry(sample) => {
                    let log = self.idle_log.get_or_insert_with(|| {
                        TelemetryLog::new(
                            self.session.machine.hello().period_s,
                            &self.description.channels,
                        )
                    });
                    // The time axis only needs the latest entry.
                    if log.entries().len() > 10_000 {
                        *log = TelemetryLog::new(
                            self.session.machine.hello().period_s,
                            &self.description.channels,
                        );
                    }
                    let entry = log.push(sample).clone();
                    sampled(&self.shared, &self.updates, &entry);
                }
                Heard::Event(e) => {
                    let t = self.idle_log.as_ref().map(TelemetryLog::latest_s);
                    event(&self.shared, &self.updates, &self.description, t, &e);
                }
                Heard::Reply(..) | Heard::OtherVersion(_) => {}
            }
        }
        Ok(())
    }

    fn refresh_status(&mut self) {
        if let Ok(st) = self.session.machine.status() {
            let bad = self.session.machine.bad_frames();
            let mut s = self.shared();
            s.mode = mode_words(st.mode);
            s.last_fault = st
                .last_fault
                .map(|(code, detail)| self.description.fault_words(code, detail));
            s.settings_origin = settings_origin_words(st.settings);
            s.bad_frames = bad;
        }
        let _ = self.updates.send(Update::State);
    }

    /// An order between jobs.
    fn idle_order(&mut self, order: Order) {
        let words: Vec<&str> = order.line.split_whitespace().collect();
        let m = &mut self.session.machine;
        let outcome = match words.as_slice() {
            ["set", path, value] => m
                .set(path, value)
                .and_then(|()| m.get(path))
                .map(|now| {
                    let mut s = lock(&self.shared);
                    if let Some(v) = s.values.iter_mut().find(|(p, _)| p == path) {
                        v.1 = now.clone();
                    }
                    format!("{path} = {now}")
                })
                .map_err(|e| e.to_string()),
            ["get", path] => m
                .get(path)
                .map(|v| format!("{path} = {v}"))
                .map_err(|e| e.to_string()),
            ["save"] => m
                .command(Request::Save)
                .map(|()| "saved: the machine keeps its settings as they are now".into())
                .map_err(|e| e.to_string()),
            ["reset"] => m
                .command(Request::ResetFault)
                .map(|()| "fault reset".into())
                .map_err(|e| e.to_string()),
            ["stop"] => Err("no job is running".into()),
            ["status"] => Ok("status read".into()),
            ["start"] => {
                // Answered once the job runs (or fails to start), not at its end.
                self.start(order.answer);
                self.refresh_status();
                return;
            }
            _ => Err(format!(
                "not understood: {:?} (set PATH VALUE, get PATH, save, start, stop, reset, status)",
                order.line
            )),
        };
        if !matches!(words.as_slice(), ["get", _] | ["status"]) {
            let text = match &outcome {
                Ok(s) => s.clone(),
                Err(e) => e.clone(),
            };
            self.say(self.idle_log.as_ref().map(TelemetryLog::latest_s), &text);
        }
        self.refresh_status();
        if let Some(answer) = order.answer {
            let _ = answer.send(outcome);
        }
    }

    /// Runs the loaded job to its end; the orders that come meanwhile go to the run.
    /// `answer` is told when the first sample of the run comes, or why it did not.
    fn start(&mut self, mut answer: Option<Sender<Result<String, String>>>) {
        let mut tell = |outcome: Result<String, String>| {
            if let Some(a) = answer.take() {
                let _ = a.send(outcome);
            }
        };
        let Some(job) = self.shared().job.clone() else {
            self.say(None, "start: no job is loaded");
            return tell(Err("no job is loaded: load one first".into()));
        };
        let parts = crate::job::split(&job.file).and_then(|parts| {
            parts
                .into_iter()
                .map(|p| crate::job::Job::from_bytes(p).map(|j| (j.kind(), p)))
                .collect::<Result<Vec<_>, _>>()
        });
        let parts = match parts {
            Ok(p) => p,
            // It was read when it was loaded.
            Err(e) => return tell(Err(format!("{}: {e}", job.name))),
        };
        let first_len = parts.first().map_or(0, |p| p.1.len()) as u32;
        {
            let mut s = self.shared();
            s.running = true;
            s.runs += 1;
            s.last_run = None;
            s.uploaded = Some((0, first_len));
        }
        self.say(None, &format!("{}: starting", job.name));
        let plan = RunPlan {
            telemetry_hz: self.telemetry_hz,
            changes: Vec::new(),
            quiet_s: 30,
        };
        let mut log = TelemetryLog::new(
            self.session.machine.hello().period_s,
            &self.description.channels,
        );
        let (shared, updates) = (&self.shared, &self.updates);
        let ended =
            self.session.run_parts(
                &parts,
                &plan,
                &mut log,
                Some(&self.queue),
                &mut |p| match p {
                    Progress::Uploaded(n) => {
                        lock(shared).uploaded = Some((n, first_len));
                        let _ = updates.send(Update::Upload {
                            bytes: n,
                            of: first_len,
                        });
                    }
                    Progress::Sample(_, entry) => {
                        tell(Ok(format!("{}: running", job.name)));
                        sampled(shared, updates, entry)
                    }
                    Progress::Line(t, text) => say(shared, updates, Some(t), text),
                },
            );
        let t = Some(log.latest_s());
        let text = match &ended {
            Ok(()) => format!("{}: the job ran to its end ({})", job.name, log.summary()),
            Err(e) => format!("{}: {e}", job.name),
        };
        {
            let mut s = self.shared();
            s.running = false;
            s.last_run = Some(match &ended {
                Ok(()) => Ok(text.clone()),
                Err(_) => Err(text.clone()),
            });
        }
        self.idle_log = None;
        self.say(t, &text);
        tell(ended.map(|()| text.clone()).map_err(|_| text));
    }
}

/// A sample heard: kept and told.
fn sampled(
    shared: &Mutex<Shared>,
    updates: &broadcast::Sender<Update>,
    entry: &crate::telemetry::Entry,
) {
    let values = entry.sample.values.to_vec();
    let mode = mode_words(entry.sample.mode);
    let mut s = lock(shared);
    let changed = s.mode != mode;
    s.mode = mode;
    keep_recent(&mut s, entry.time_s, values.clone());
    drop(s);
    let _ = updates.send(Update::Sample {
        t: entry.time_s,
        mode,
        values,
        host_ms: wall_ms(),
    });
    if changed {
        let _ = updates.send(Update::State);
    }
}

/// An event heard between jobs: its words in the log, a fault kept.
fn event(
    shared: &Mutex<Shared>,
    updates: &broadcast::Sender<Update>,
    description: &MachineDescription,
    t: Option<f64>,
    e: &Event,
) {
    if let Event::Fault { code, detail } = e {
        lock(shared).last_fault = Some(description.fault_words(*code, *detail));
    }
    {
        let mut s = lock(shared);
        s.last_heard = Some(Instant::now());
        if let Event::Mode { to, .. } = e {
            s.mode = mode_words(*to);
        }
    }
    say(shared, updates, t, &description.event_words(e));
    let _ = updates.send(Update::State);
}

/// A line of the event log: kept and told.
fn say(shared: &Mutex<Shared>, updates: &broadcast::Sender<Update>, t: Option<f64>, text: &str) {
    let line = LogLine {
        t,
        text: text.to_owned(),
    };
    let mut s = lock(shared);
    if s.log.len() == LOG_LINES {
        s.log.pop_front();
    }
    s.log.push_back(line.clone());
    drop(s);
    let _ = updates.send(Update::Line(line));
}
