//! The host link end to end against the emulated MCU (issue 16 item 4): the QEMU
//! image `link` (the Keops slave in f32 with its simulated delta, `kerf_sim::linked`)
//! speaks the protocol on its UART, which QEMU connects to this test's TCP socket. The
//! test is the host: it uploads the octagon as an EFD job file, starts it, streams
//! telemetry with a heartbeat per sample, retunes the DOB during the cut, hears the
//! end; then cuts again and lowers the force limit until the machine faults, and hears
//! the fault as an event.
//!
//! Needs the image built first, so it is run by `scripts/smoke`
//! (`cargo test -p host-tests --test qemu_link -- --ignored`) after
//! `cargo build … --bin link`; `KERF_LINK_ELF` names the image.

use host_tests::link::{crc32, heard, octagon_job_file, request_frame, Heard};
use kerf::codec::link::{
    Event, FrameReader, JobKind, ModeCode, Request, TelemetrySample, MAX_CHUNK, MAX_FRAME,
};
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::process::{Child, Command};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

struct Qemu(Child);

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

struct Host {
    stream: TcpStream,
    heard: Receiver<Heard>,
    seq: u16,
    log: Vec<Heard>,
}

impl Host {
    fn send(&mut self, request: Request<'_>) -> u16 {
        self.seq = self.seq.wrapping_add(1);
        let frame = request_frame(self.seq, request);
        self.stream.write_all(&frame).unwrap();
        self.seq
    }

    /// The next message, or None after `timeout`.
    fn next(&mut self, timeout: Duration) -> Option<Heard> {
        let h = self.heard.recv_timeout(timeout).ok()?;
        self.log.push(h.clone());
        Some(h)
    }

    fn ask(&mut self, request: Request<'_>) -> String {
        let seq = self.send(request);
        let deadline = Instant::now() + Duration::from_secs(60);
        while Instant::now() < deadline {
            if let Some(Heard::Reply(s, r)) = self.next(Duration::from_secs(1)) {
                if s == seq {
                    return r;
                }
            }
        }
        panic!("no reply to request {seq}")
    }

    fn upload(&mut self, job: &[u8]) {
        let crc = crc32(job);
        let begin = Request::JobBegin {
            kind: JobKind::Efd,
            total_bytes: job.len() as u32,
            crc32: crc,
        };
        assert_eq!(self.ask(begin), "Ack");
        for (i, chunk) in job.chunks(MAX_CHUNK).enumerate() {
            let offset = (i * MAX_CHUNK) as u32;
            let r = self.ask(Request::JobChunk {
                offset,
                data: chunk,
            });
            assert!(r.starts_with("JobProgress"), "{r}");
        }
        assert_eq!(self.ask(Request::JobCommit), "Ack");
    }

    /// Runs until `until` is heard, with a heartbeat per telemetry sample; `each`
    /// may send a request after the n-th sample.
    fn run_until(
        &mut self,
        until: Event,
        mut each: impl FnMut(&mut Host, usize),
    ) -> Vec<TelemetrySample> {
        let mut samples = Vec::new();
        let deadline = Instant::now() + Duration::from_secs(240);
        while Instant::now() < deadline {
            match self.next(Duration::from_secs(5)) {
                Some(Heard::Telemetry(t)) => {
                    samples.push(t);
                    self.send(Request::Heartbeat);
                    each(self, samples.len());
                }
                Some(Heard::Event(e)) if e == until => return samples,
                Some(_) => {}
                None => panic!(
                    "the machine went quiet; heard {:?}",
                    self.log.iter().rev().take(5).collect::<Vec<_>>()
                ),
            }
        }
        panic!("{until:?} never came")
    }
}

fn connect() -> (Qemu, Host) {
    let elf = std::env::var("KERF_LINK_ELF")
        .expect("KERF_LINK_ELF: the link image (scripts/smoke builds it)");
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let qemu = Qemu(
        Command::new("qemu-system-arm")
            .args([
                "-cpu",
                "cortex-m4",
                "-machine",
                "mps2-an386",
                "-nographic",
                "-monitor",
                "none",
            ])
            .args(["-serial", &format!("tcp:127.0.0.1:{port}")])
            .args(["-icount", "shift=0,align=off,sleep=off"])
            .args([
                "-semihosting-config",
                "enable=on,target=native",
                "-kernel",
                &elf,
            ])
            .spawn()
            .expect("qemu-system-arm"),
    );
    listener.set_nonblocking(false).unwrap();
    let (stream, _) = listener.accept().unwrap();
    stream.set_nodelay(true).unwrap();
    let mut reader = stream.try_clone().unwrap();
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        let mut frames = FrameReader::<MAX_FRAME>::new();
        let mut buf = [0u8; 512];
        while let Ok(n) = reader.read(&mut buf) {
            if n == 0 {
                return;
            }
            for &b in &buf[..n] {
                if let Some(Ok(frame)) = frames.push(b) {
                    let Some(message) = heard(frame) else {
                        continue;
                    };
                    if tx.send(message).is_err() {
                        return;
                    }
                }
            }
        }
    });
    let host = Host {
        stream,
        heard: rx,
        seq: 0,
        log: Vec::new(),
    };
    (qemu, host)
}

#[test]
#[ignore = "needs the QEMU link image: scripts/smoke builds it and runs this test"]
fn a_host_cuts_retunes_and_hears_a_fault_over_the_emulated_serial_port() {
    let (_qemu, mut host) = connect();
    let hello = host.ask(Request::Hello);
    assert!(hello.contains("keops-slave"), "{hello}");
    let job = octagon_job_file();
    host.upload(&job);
    assert_eq!(host.ask(Request::Telemetry { every_periods: 100 }), "Ack");
    assert_eq!(host.ask(Request::Start), "Ack");
    let mut retune = None;
    let samples = host.run_until(
        Event::Mode {
            from: ModeCode::Running,
            to: ModeCode::Ready,
        },
        |h, n| {
            if n == 20 {
                retune = Some(h.send(Request::Set {
                    path: "/slave/dob/bandwidth_hz",
                    value: b"120",
                }));
            }
        },
    );
    let retuned = retune.and_then(|seq| {
        host.log.iter().find_map(|h| match h {
            Heard::Reply(s, r) if *s == seq => Some(r.clone()),
            _ => None,
        })
    });
    assert_eq!(retuned.as_deref(), Some("Ack"));
    let cutting: Vec<&TelemetrySample> = samples
        .iter()
        .filter(|s| s.mode == ModeCode::Running)
        .collect();
    let worst = cutting.iter().map(|s| s.error_m).fold(0.0f32, f32::max);
    println!(
        "qemu link: {} telemetry samples while cutting, contour error ≤ {:.2} µm, DOB retuned to 120 Hz mid-cut",
        cutting.len(),
        worst * 1e6
    );
    assert!(cutting.len() > 10);
    assert!(worst < 5e-6, "{worst}");

    // Again, and the force limit lowered until the carriages cannot hold the cut.
    host.upload(&job);
    assert_eq!(host.ask(Request::Start), "Ack");
    host.run_until(
        Event::Mode {
            from: ModeCode::Running,
            to: ModeCode::Fault,
        },
        |h, n| {
            if n == 10 {
                h.send(Request::Set {
                    path: "/slave/dob/force_limit_n",
                    value: b"0.05",
                });
            }
        },
    );
    // The fault's reason follows the mode change.
    let mut fault = None;
    while fault.is_none() {
        match host.next(Duration::from_secs(10)) {
            Some(Heard::Event(Event::Fault { code, detail })) => fault = Some((code, detail)),
            Some(_) => {}
            None => break,
        }
    }
    println!("qemu link: the fault the host heard: {fault:?}");
    assert!(fault.is_some());
    assert!(host.ask(Request::ResetFault).contains("Ack"));
}
