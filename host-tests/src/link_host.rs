//! An in-process host for the simulated slave (`kerf_sim::linked`): it numbers its
//! requests, encodes them, runs the slave's periods and reads what the machine sends.

use crate::link::{crc32, heard, request_frame, Heard};
use kerf::codec::link::{Event, JobKind, ModeCode, Request, TelemetrySample, MAX_CHUNK};
use kerf_sim::linked::LinkedSlave;
use kerf_sim::slave::SlaveScenario;

/// A host: numbers its requests, encodes them, reads what the machine sends.
#[derive(Default)]
pub struct Host {
    seq: u16,
    heard: Vec<Heard>,
}

impl Host {
    /// After three idle periods: uploads `job` as a `kind` file, asks for telemetry
    /// every `every_periods` and starts the job; each must be acknowledged.
    pub fn start_job(
        &mut self,
        slave: &mut LinkedSlave<'_, f64>,
        kind: JobKind,
        job: &[u8],
        every_periods: u32,
    ) {
        for _ in 0..3 {
            self.period(slave, &[]);
        }
        assert_eq!(self.upload_as(slave, kind, job), "Ack");
        let telemetry = Request::Telemetry { every_periods };
        assert_eq!(self.ask(slave, telemetry, 2), "Ack");
        assert_eq!(self.ask(slave, Request::Start, 5), "Ack");
    }

    /// The parts begun so far: the first, and one more for each [`Event::NextJob`].
    pub fn parts_begun(&self) -> usize {
        1 + self
            .events()
            .iter()
            .filter(|e| **e == Event::NextJob)
            .count()
    }

    /// Runs periods, a heartbeat every hundredth, until the job ends (running to
    /// ready) or `limit` periods have run; `before` is called before each period (a
    /// host that gives the next part).
    pub fn run_to_end(
        &mut self,
        slave: &mut LinkedSlave<'_, f64>,
        limit: u32,
        mut before: impl FnMut(&mut Self, &mut LinkedSlave<'_, f64>),
    ) {
        let end = Event::Mode {
            from: ModeCode::Running,
            to: ModeCode::Ready,
        };
        for k in 0..limit {
            before(self, slave);
            let bytes = match k % 100 {
                0 => self.frame(Request::Heartbeat).1,
                _ => Vec::new(),
            };
            self.period(slave, &bytes);
            if self.events().contains(&end) {
                break;
            }
        }
    }

    /// The next request number and `request`'s frame.
    pub fn frame(&mut self, request: Request<'_>) -> (u16, Vec<u8>) {
        self.seq = self.seq.wrapping_add(1);
        (self.seq, request_frame(self.seq, request))
    }

    /// Runs one period with `bytes` from the host.
    pub fn period(&mut self, slave: &mut LinkedSlave<'_, f64>, bytes: &[u8]) {
        let mut frames: Vec<Vec<u8>> = Vec::new();
        slave
            .period(bytes, &mut |f| {
                frames.push(f.to_vec());
                true
            })
            .unwrap();
        for f in frames {
            let mut raw = f[1..f.len() - 1].to_vec();
            self.heard.push(heard(&mut raw).expect("a machine message"));
        }
    }

    /// Sends `request` and runs periods until its reply (at most `limit`).
    pub fn ask(
        &mut self,
        slave: &mut LinkedSlave<'_, f64>,
        request: Request<'_>,
        limit: u32,
    ) -> String {
        let (seq, bytes) = self.frame(request);
        self.period(slave, &bytes);
        for _ in 0..limit {
            if let Some(r) = self.reply(seq) {
                return r;
            }
            self.period(slave, &[]);
        }
        panic!("no reply to {seq}")
    }

    /// The reply to request `seq`, once heard.
    pub fn reply(&self, seq: u16) -> Option<String> {
        self.heard.iter().find_map(|h| match h {
            Heard::Reply(s, r) if *s == seq => Some(r.clone()),
            _ => None,
        })
    }

    /// Uploads `job` as an EFD file; the commit must be acknowledged.
    pub fn upload(&mut self, slave: &mut LinkedSlave<'_, f64>, job: &[u8]) {
        assert_eq!(self.upload_as(slave, JobKind::Efd, job), "Ack");
    }

    /// Uploads `job` as a `kind` file; the commit's reply.
    pub fn upload_as(
        &mut self,
        slave: &mut LinkedSlave<'_, f64>,
        kind: JobKind,
        job: &[u8],
    ) -> String {
        let crc = crc32(job);
        let begin = Request::JobBegin {
            kind,
            total_bytes: job.len() as u32,
            crc32: crc,
        };
        assert_eq!(self.ask(slave, begin, 2), "Ack");
        for (i, chunk) in job.chunks(MAX_CHUNK).enumerate() {
            let r = self.ask(
                slave,
                Request::JobChunk {
                    offset: (i * MAX_CHUNK) as u32,
                    data: chunk,
                },
                2,
            );
            assert!(r.starts_with("JobProgress"), "{r}");
        }
        self.ask(slave, Request::JobCommit, 5)
    }

    /// The events heard, in order.
    pub fn events(&self) -> Vec<Event> {
        self.heard
            .iter()
            .filter_map(|h| match h {
                Heard::Event(e) => Some(*e),
                _ => None,
            })
            .collect()
    }

    /// The telemetry heard, in order.
    pub fn samples(&self) -> Vec<TelemetrySample> {
        self.heard
            .iter()
            .filter_map(|h| match h {
                Heard::Telemetry(t) => Some(t.clone()),
                _ => None,
            })
            .collect()
    }
}

/// The value of the slave's channel `name` in `sample`, as its description orders
/// the channels.
pub fn channel(sample: &TelemetrySample, name: &str) -> f32 {
    use kerf::app::host_link::LinkMachine;
    let channels = <kerf::machines::delta_slave::DeltaSlave<f64> as LinkMachine>::CHANNELS;
    let k = channels
        .iter()
        .position(|c| c.name == name)
        .expect("a channel of the slave");
    sample.values[k]
}

/// The machine time a job ran, s: from the first sample running to the first at rest
/// after it (to the telemetry's ten periods, 1 ms).
pub fn ran_s(samples: &[TelemetrySample]) -> f64 {
    let first = samples
        .iter()
        .find(|s| s.mode == ModeCode::Running)
        .expect("a sample running")
        .period;
    let rest = samples
        .iter()
        .find(|s| s.mode == ModeCode::Ready && s.period > first)
        .expect("a sample after the run")
        .period;
    f64::from(rest - first) * 1e-4
}

/// The slave of the link tests: the square scenario with the 16-bit sensors, one
/// plant step per period.
pub fn scenario() -> SlaveScenario {
    let mut s = SlaveScenario::square();
    s.sensors = [hal_mock::hall_sensor::HallSensorParams::LM1247_16BIT; 3];
    s.substeps = 1;
    s
}

/// The largest contour error of the samples while running, m.
pub fn worst_error(samples: &[TelemetrySample]) -> f32 {
    samples
        .iter()
        .filter(|s| s.mode == ModeCode::Running)
        .map(|s| channel(s, "error"))
        .fold(0.0f32, f32::max)
}
