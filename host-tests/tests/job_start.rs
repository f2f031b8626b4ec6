//! The first periods of a job are the same whenever it starts. The Keops slave's
//! drives are off outside a job (safe outputs), so carriages left where a job ended,
//! or where the simulation used to switch the machine on (its home, 10 mm up), slide
//! to their lower end stops in about 0.1 s. A job started in that window planned its
//! approach from a carriage taken to be at rest and met the 3.6 N force limit for
//! 20 ms. Now the machine is switched on resting on its stops and homes there, and a
//! `Start` while a carriage slides is refused with `JOB_NOT_AT_REST` until it rests.

use host_tests::link::{crc32, heard, octagon_job_file, request_frame, Heard};
use kerf::codec::link::{JobKind, Request, JOB_NOT_AT_REST, MAX_CHUNK};
use kerf_sim::linked::{with_linked_slave, LinkedSlave};
use kerf_sim::slave::SlaveScenario;

fn scenario() -> SlaveScenario {
    let mut s = SlaveScenario::square();
    s.sensors = [hal_mock::hall_sensor::HallSensorParams::LM1247_16BIT; 3];
    s.substeps = 1;
    s
}

/// A host that answers nothing but keeps what the machine says.
#[derive(Default)]
struct Host {
    seq: u16,
    heard: Vec<Heard>,
}

impl Host {
    /// One period with `request` (if any); the period's forces, N.
    fn period(
        &mut self,
        slave: &mut LinkedSlave<'_, f64>,
        request: Option<Request<'_>>,
    ) -> [f64; 3] {
        let bytes = request.map_or(Vec::new(), |r| {
            self.seq += 1;
            request_frame(self.seq, r)
        });
        let mut frames = Vec::new();
        let period = slave
            .period(&bytes, &mut |f| {
                frames.push(f.to_vec());
                true
            })
            .expect("the simulation runs");
        for f in frames {
            let mut raw = f[1..f.len() - 1].to_vec();
            self.heard.extend(heard(&mut raw));
        }
        period.force_n
    }

    fn reply(&self, seq: u16) -> Option<&str> {
        self.heard.iter().find_map(|h| match h {
            Heard::Reply(s, r) if *s == seq => Some(r.as_str()),
            _ => None,
        })
    }

    /// Sends `request`, then runs periods until its reply.
    fn ask(&mut self, slave: &mut LinkedSlave<'_, f64>, request: Request<'_>) -> String {
        self.period(slave, Some(request));
        let seq = self.seq;
        for _ in 0..10 {
            if let Some(r) = self.reply(seq) {
                return r.to_string();
            }
            self.period(slave, None);
        }
        panic!("no reply to {seq}")
    }
}

/// Uploads the octagon, waits `wait` periods, starts (again every 2 ms while refused
/// as moving): the refusals and the forces of the job's first 0.3 s.
fn start(host: &mut Host, slave: &mut LinkedSlave<'_, f64>, wait: u32) -> (u32, Vec<[f64; 3]>) {
    let job = octagon_job_file();
    let begin = Request::JobBegin {
        kind: JobKind::Efd,
        total_bytes: job.len() as u32,
        crc32: crc32(&job),
    };
    assert_eq!(host.ask(slave, begin), "Ack");
    for (i, data) in job.chunks(MAX_CHUNK).enumerate() {
        let offset = (i * MAX_CHUNK) as u32;
        assert!(host
            .ask(slave, Request::JobChunk { offset, data })
            .starts_with("JobProgress"));
    }
    assert_eq!(host.ask(slave, Request::JobCommit), "Ack");
    for _ in 0..wait {
        host.period(slave, None);
    }
    let mut refused = 0;
    loop {
        let reply = host.ask(slave, Request::Start);
        if reply == "Ack" {
            break;
        }
        assert_eq!(reply, format!("Refused(Job({JOB_NOT_AT_REST}))"));
        refused += 1;
        assert!(refused < 500, "the carriages never came to rest");
        for _ in 0..20 {
            host.period(slave, None);
        }
    }
    let forces = (0..3000)
        .map(|k| host.period(slave, (k % 100 == 0).then_some(Request::Heartbeat)))
        .collect();
    (refused, forces)
}

/// [`start`] on a slave switched on for it.
fn start_after(wait: u32) -> (u32, Vec<[f64; 3]>) {
    let mut host = Host::default();
    with_linked_slave::<f64, _>(&scenario(), 0.25, |slave| start(&mut host, slave, wait))
        .expect("the linked slave builds")
}

#[test]
fn a_job_starts_the_same_whenever_it_starts_after_power_up() {
    let peak = |f: &[[f64; 3]]| f.iter().flatten().fold(0.0f64, |a, x| a.max(x.abs()));
    let (_, reference) = start_after(20_000);
    let diff = |forces: &[[f64; 3]]| {
        forces
            .iter()
            .zip(&reference)
            .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
            .fold(0.0f64, f64::max)
    };
    // Two starts from the same rest differ by the sensors' noise alone (a different
    // stretch of it): the yardstick for "the same".
    let noise = diff(&start_after(20_100).1);
    for wait in [0, 50, 200, 1_000, 5_000] {
        let (refused, forces) = start_after(wait);
        let worst = diff(&forces);
        println!(
            "start {wait} periods after power-up: {refused} refusals, force peak {:.3} N \
             (2 s after power-up: {:.3} N), largest difference {:.3} N (noise alone {noise:.3} N)",
            peak(&forces),
            peak(&reference),
            worst
        );
        assert_eq!(refused, 0, "{wait}: the carriages rest from power-up");
        assert!(peak(&forces) < 1.6, "{wait}: {:.3} N", peak(&forces));
        assert!(
            worst < 1.5 * noise,
            "{wait}: {worst:.3} N against {noise:.3} N"
        );
    }
}

#[test]
fn a_start_while_a_carriage_slides_is_refused_until_it_rests() {
    let mut host = Host::default();
    with_linked_slave::<f64, _>(&scenario(), 0.25, |slave| {
        let (refused, _) = start(&mut host, slave, 0);
        assert_eq!(refused, 0);
        // Stop mid-air: the ramp to rest, then the drives off and the carriages slide.
        assert_eq!(host.ask(slave, Request::Stop), "Ack");
        let mut waited = 0;
        let mut refusals = 0;
        loop {
            for _ in 0..20 {
                host.period(slave, (waited % 100 == 0).then_some(Request::Heartbeat));
                waited += 1;
            }
            match host.ask(slave, Request::Start).as_str() {
                "Ack" => break,
                r if r == format!("Refused(Job({JOB_NOT_AT_REST}))") => refusals += 1,
                r => assert!(r.contains("InvalidInMode"), "{r}"),
            }
            assert!(waited < 20_000, "never started again");
        }
        println!("started again {waited} periods after the stop, {refusals} refusals as moving");
        assert!(refusals > 0);
    })
    .expect("the linked slave builds");
}
