//! A host's side of the link for the tests (`host_link` in simulation, `qemu_link`
//! against the emulated MCU): requests as frames, what the machine sends as owned
//! values, and the octagon as the job file the planner writes.

use kerf::codec::job::write_efd;
use kerf::codec::link::{
    decode, encode, Event, HostFrame, MachineMessage, Request, TelemetrySample, MAX_FRAME,
};
use kerf::machines::delta_slave::CONTOUR_HARMONICS;
use kerf::trajectory::efd::Efd;
use kerf_host::session::{RunPlan, TimedChange};
use kerf_sim::contour::octagon_efd;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

/// What the host heard, owned.
#[derive(Clone, Debug, PartialEq)]
pub enum Heard {
    /// A reply to request `seq`, as its debug text.
    Reply(u16, String),
    /// A telemetry sample.
    Telemetry(TelemetrySample),
    /// An event.
    Event(Event),
}

/// Request `seq` as a frame between delimiters.
pub fn request_frame(seq: u16, request: Request<'_>) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    let n = encode(&HostFrame { seq, request }, &mut out).expect("a request fits a frame");
    out[..n].to_vec()
}

/// A machine frame (its COBS bytes, without delimiters) as an owned value.
pub fn heard(frame: &mut [u8]) -> Option<Heard> {
    Some(match decode::<MachineMessage>(frame).ok()? {
        MachineMessage::Reply { seq, reply } => Heard::Reply(seq, format!("{reply:?}")),
        MachineMessage::Telemetry(t) => Heard::Telemetry(t),
        MachineMessage::Event(e) => Heard::Event(e),
    })
}

pub use kerf::codec::link::crc32;

/// The octagon (±6 mm, 30 harmonics) as the job file the planner writes.
pub fn octagon_job_file() -> Vec<u8> {
    efd_job(&octagon_efd(30).expect("the stored octagon"))
}

/// The closed polygon `points` (m, where the program puts them) fitted with
/// `harmonics` harmonics, as the job file the planner writes (its centre the fit's).
pub fn efd_job_file(points: &[[f64; 2]], harmonics: usize) -> Vec<u8> {
    efd_job(&Efd::from_polygon(points, harmonics).expect("a closed polygon"))
}

fn efd_job(efd: &Efd<f64, CONTOUR_HARMONICS>) -> Vec<u8> {
    let c = efd.centre();
    let mut buf = [0u8; 1024];
    let n = write_efd([c.x, c.y], efd.coefficients(), &mut buf).expect("504 bytes at most");
    buf[..n].to_vec()
}

/// A run's plan: telemetry at `telemetry_hz`, the host giving up after `quiet_s` of
/// silence, and `changes` as (time in s, setting path, value).
pub fn run_plan(telemetry_hz: f64, quiet_s: u64, changes: &[(f64, &str, &str)]) -> RunPlan {
    RunPlan {
        telemetry_hz,
        changes: changes
            .iter()
            .map(|(at_s, path, value)| TimedChange {
                at_s: *at_s,
                path: (*path).into(),
                value: (*value).into(),
            })
            .collect(),
        quiet_s,
    }
}

/// A simulated machine on its own thread, told to stop by `stop` and joined when this
/// is dropped (so that a test that fails leaves no machine running).
pub struct MachineThread {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl MachineThread {
    /// The machine `thread`, which returns once `stop` is set.
    pub fn new(stop: Arc<AtomicBool>, thread: JoinHandle<()>) -> Self {
        Self {
            stop,
            thread: Some(thread),
        }
    }
}

impl Drop for MachineThread {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// How fast a simulated machine runs its periods.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Pace {
    /// As fast as it can.
    Free,
    /// `speedup` times real time, for a control period of `period_s`.
    Scaled {
        /// The machine's control period, s.
        period_s: f64,
        /// Machine time over wall time.
        speedup: f64,
    },
}

/// The far end of a host test's link: the host's bytes from `socket` through a reader
/// thread (so a period never waits for them), then per turn one `period` with the
/// bytes that arrived, its period count (from 1) and a sender that writes frames
/// back, at `pace`; until `stop` is set, the host hangs up, a write fails or `period`
/// returns false.
pub fn serve(
    socket: std::os::unix::net::UnixStream,
    stop: &AtomicBool,
    pace: Pace,
    mut period: impl FnMut(u32, &[u8], &mut dyn FnMut(&[u8]) -> bool) -> bool,
) {
    use std::io::{Read, Write};
    use std::sync::mpsc::{channel, TryRecvError};
    let (tx, rx) = channel::<Vec<u8>>();
    let Ok(mut reader) = socket.try_clone() else {
        return;
    };
    std::thread::spawn(move || {
        let mut buf = [0u8; 512];
        while let Ok(n) = reader.read(&mut buf) {
            if n == 0 || tx.send(buf[..n].to_vec()).is_err() {
                return;
            }
        }
    });
    let mut out = socket;
    let start = std::time::Instant::now();
    let mut periods = 0u32;
    while !stop.load(Ordering::Relaxed) {
        if let Pace::Scaled { period_s, speedup } = pace {
            let ahead = f64::from(periods) * period_s / speedup - start.elapsed().as_secs_f64();
            if ahead > 1e-3 {
                std::thread::sleep(std::time::Duration::from_secs_f64(ahead));
            }
        }
        periods += 1;
        let input = match rx.try_recv() {
            Ok(bytes) => bytes,
            Err(TryRecvError::Empty) => Vec::new(),
            Err(TryRecvError::Disconnected) => return,
        };
        let mut failed = false;
        let go_on = period(periods, &input, &mut |frame| {
            failed |= out.write_all(frame).is_err();
            true
        });
        if failed || !go_on {
            return;
        }
    }
}

/// The control period of the simulated axis, s (10 kHz).
pub const AXIS_PERIOD_S: f64 = 1e-4;

/// The simulated axis of `scenario` on the far end of `socket`, at five times real
/// time, until `stop` is set or the host hangs up. Bytes from the host come through a
/// reader thread, so a period never waits for them. Paced, not as fast as it can: a
/// setting the host sends at a machine time reaches the machine within a few
/// milliseconds of machine time even on a loaded host (as fast as it could, the
/// machine ran tenths of a second past it while the tests shared two cores).
pub fn axis_machine(
    scenario: kerf_sim::scenario::Scenario,
    socket: std::os::unix::net::UnixStream,
    stop: Arc<AtomicBool>,
) -> JoinHandle<()> {
    std::thread::spawn(move || {
        // The heartbeat (tested with the link itself) must not take a busy host for a
        // lost one.
        kerf_sim::linked_axis::with_linked_axis::<f64, _>(&scenario, 1e4, |axis| {
            let pace = Pace::Scaled {
                period_s: AXIS_PERIOD_S,
                speedup: 5.0,
            };
            serve(socket, &stop, pace, |_, input, send| {
                axis.period(input, send);
                true
            })
        })
        .expect("the axis builds");
    })
}
