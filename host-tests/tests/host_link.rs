//! The operator's side against the simulated Keops slave over the host link
//! (in simulation): a host that speaks only frames uploads the
//! octagon as an EFD job file in chunks, starts it, streams telemetry, changes a
//! setting during the cut, and hears the end; a sensor fault reaches it as an event;
//! a host that goes silent gets its job stopped. An open path (a points file) is cut
//! once from its first point to its last.

use host_tests::link::{crc32, efd_job_file, heard, octagon_job_file, request_frame, Heard};
use kerf::codec::link::{Event, JobKind, ModeCode, Request, TelemetrySample, MAX_CHUNK};
use kerf_sim::linked::{with_linked_slave, LinkedSlave};
use kerf_sim::slave::SlaveScenario;

/// A host: numbers its requests, encodes them, reads what the machine sends.
#[derive(Default)]
struct Host {
    seq: u16,
    heard: Vec<Heard>,
}

impl Host {
    fn frame(&mut self, request: Request<'_>) -> (u16, Vec<u8>) {
        self.seq = self.seq.wrapping_add(1);
        (self.seq, request_frame(self.seq, request))
    }

    /// Runs one period with `bytes` from the host.
    fn period(&mut self, slave: &mut LinkedSlave<'_, f64>, bytes: &[u8]) {
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
    fn ask(
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

    fn reply(&self, seq: u16) -> Option<String> {
        self.heard.iter().find_map(|h| match h {
            Heard::Reply(s, r) if *s == seq => Some(r.clone()),
            _ => None,
        })
    }

    fn upload(&mut self, slave: &mut LinkedSlave<'_, f64>, job: &[u8]) {
        assert_eq!(self.upload_as(slave, JobKind::Efd, job), "Ack");
    }

    /// Uploads `job` as a `kind` file; the commit's reply.
    fn upload_as(&mut self, slave: &mut LinkedSlave<'_, f64>, kind: JobKind, job: &[u8]) -> String {
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

    fn events(&self) -> Vec<Event> {
        self.heard
            .iter()
            .filter_map(|h| match h {
                Heard::Event(e) => Some(*e),
                _ => None,
            })
            .collect()
    }

    fn samples(&self) -> Vec<TelemetrySample> {
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
fn channel(sample: &TelemetrySample, name: &str) -> f32 {
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
fn ran_s(samples: &[TelemetrySample]) -> f64 {
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

fn scenario() -> SlaveScenario {
    let mut s = SlaveScenario::square();
    s.sensors = [hal_mock::hall_sensor::HallSensorParams::LM1247_16BIT; 3];
    s.substeps = 1;
    s
}

#[test]
fn a_host_uploads_runs_retunes_and_hears_the_end_of_a_contour() {
    let mut host = Host::default();
    with_linked_slave::<f64, _>(&scenario(), 0.25, |slave| {
        // Power-up: the stored calibration makes the slave ready.
        for _ in 0..3 {
            host.period(slave, &[]);
        }
        let hello = host.ask(slave, Request::Hello, 2);
        assert!(hello.contains("keops-slave"), "{hello}");
        host.upload(slave, &octagon_job_file());
        assert_eq!(host.ask(slave, Request::Telemetry { every_periods: 100 }, 2), "Ack");
        assert_eq!(host.ask(slave, Request::Start, 5), "Ack");
        // Cut with a heartbeat every 10 ms; retune the DOB 0.5 s in.
        let mut retuned = None;
        for k in 0..30_000u32 {
            let bytes = if k == 5_000 {
                let (seq, b) = host.frame(Request::Set {
                    path: "/slave/dob/bandwidth_hz",
                    value: b"120",
                });
                retuned = Some(seq);
                b
            } else if k % 100 == 0 {
                host.frame(Request::Heartbeat).1
            } else {
                Vec::new()
            };
            host.period(slave, &bytes);
            if host.events().contains(&Event::Mode {
                from: ModeCode::Running,
                to: ModeCode::Ready,
            }) {
                break;
            }
        }
        assert_eq!(host.reply(retuned.unwrap()).as_deref(), Some("Ack"));
        let value = host.ask(slave, Request::Get { path: "/slave/dob/bandwidth_hz" }, 2);
        assert!(value.contains("[49, 50, 48"), "{value}"); // "120"
        let samples = host.samples();
        let running: Vec<&TelemetrySample> =
            samples.iter().filter(|s| s.mode == ModeCode::Running).collect();
        let worst = running.iter().map(|s| channel(s, "error")).fold(0.0f32, f32::max);
        println!(
            "host link: {} telemetry samples while cutting, contour error ≤ {:.2} µm, laser up to {:.1} W, {} bad frames",
            running.len(),
            worst * 1e6,
            running.iter().map(|s| channel(s, "laser")).fold(0.0f32, f32::max),
            slave.link().counters().bad_frames
        );
        assert!(running.len() > 10);
        assert!(running.windows(2).all(|w| w[1].period - w[0].period >= 100));
        // The contour smoke's bound (kerf_sim::contour::CONTOUR_BOUNDS_M).
        assert!(worst < 5e-6, "{worst}");
        assert!(host.events().contains(&Event::Mode {
            from: ModeCode::Ready,
            to: ModeCode::Running
        }));
    })
    .unwrap();
}

#[test]
fn a_sensor_fault_reaches_the_host_and_a_silent_host_stops_the_job() {
    // A Hall channel's wire breaks 0.4 s into the job.
    let mut faulty = scenario();
    faulty.sensor_fault = Some((0.4, 1, hal_mock::hall_sensor::ChannelFault::OpenWire(0)));
    let mut host = Host::default();
    with_linked_slave::<f64, _>(&faulty, 0.25, |slave| {
        for _ in 0..3 {
            host.period(slave, &[]);
        }
        host.upload(slave, &octagon_job_file());
        assert_eq!(host.ask(slave, Request::Start, 5), "Ack");
        for k in 0..10_000u32 {
            let bytes = if k % 100 == 0 {
                host.frame(Request::Heartbeat).1
            } else {
                Vec::new()
            };
            host.period(slave, &bytes);
            if host
                .events()
                .iter()
                .any(|e| matches!(e, Event::Fault { .. }))
            {
                break;
            }
        }
        let events = host.events();
        assert!(
            events.contains(&Event::Fault { code: 1, detail: 0 }),
            "a joint fault: {events:?}"
        );
        assert!(events.contains(&Event::Mode {
            from: ModeCode::Running,
            to: ModeCode::Fault
        }));
    })
    .unwrap();

    let mut host = Host::default();
    with_linked_slave::<f64, _>(&scenario(), 1.0, |slave| {
        for _ in 0..3 {
            host.period(slave, &[]);
        }
        host.upload(slave, &octagon_job_file());
        assert_eq!(host.ask(slave, Request::Start, 5), "Ack");
        // Heartbeats for 0.3 s, then nothing.
        for k in 0..3_000u32 {
            let bytes = if k % 100 == 0 { host.frame(Request::Heartbeat).1 } else { Vec::new() };
            host.period(slave, &bytes);
        }
        let mut stopped_at = None;
        for k in 0..5_000u32 {
            host.period(slave, &[]);
            if host.events().contains(&Event::HostLost) && stopped_at.is_none() {
                stopped_at = Some(k);
            }
            if host.events().contains(&Event::Mode { from: ModeCode::Stopping, to: ModeCode::Ready }) {
                break;
            }
        }
        // The last heartbeat went out in period 2,900 of the loop above: the 50 ms
        // timeout (500 periods of 0.1 ms) runs out 400 periods into the silence.
        let lost = stopped_at.expect("HostLost");
        println!("host silent: stopped {lost} periods into the silence (timeout 500 periods after the last frame)");
        assert!((398..=402).contains(&lost), "{lost}");
        assert!(host.events().contains(&Event::Mode { from: ModeCode::Running, to: ModeCode::Stopping }));
    })
    .unwrap();
}

/// A points file is an open path: the slave cuts it once, from its first point to its
/// last (where the file puts them), within the contour bound, the beam
/// on along the cut and off at its end; one repeated point or a 33rd point is refused
/// by its own code.
#[test]
fn an_open_path_is_cut_from_its_first_point_to_its_last() {
    use kerf::codec::job::write_points;
    use kerf::machines::delta_slave::link::load_codes;
    use kerf::trajectory::shapes::letter_s;
    // Off the cut's centre (3 mm right, 2 mm down): the file says where the path is.
    let points = letter_s().map(|p| [p[0] + 3e-3, p[1] - 2e-3]);
    let file = |points: &[[f64; 2]]| {
        let mut buf = [0u8; 1024];
        let n = write_points(points, &mut buf).expect("room for 33 points");
        buf[..n].to_vec()
    };
    // The file's coordinates are the workspace's (f32, as the file holds them).
    let at = |p: [f64; 2]| p.map(|v| f64::from(v as f32));
    let (first, last) = (at(points[0]), at(points[points.len() - 1]));
    let mut host = Host::default();
    with_linked_slave::<f64, _>(&scenario(), 1.0, |slave| {
        for _ in 0..3 {
            host.period(slave, &[]);
        }
        // Refused, each in its own words, before anything is planned.
        let mut repeated = points.to_vec();
        repeated[5] = repeated[4];
        let mut long = points.to_vec();
        long.extend((0..8).map(|k| [0.02, 1e-3 * k as f64]));
        for (bad, code) in [(repeated, load_codes::BAD_PATH), (long, load_codes::TOO_MANY_POINTS)] {
            let reply = host.upload_as(slave, JobKind::Points, &file(&bad));
            assert!(reply.contains(&format!("{code}")), "{reply}");
        }
        assert_eq!(host.upload_as(slave, JobKind::Points, &file(&points)), "Ack");
        assert_eq!(host.ask(slave, Request::Telemetry { every_periods: 10 }, 2), "Ack");
        assert_eq!(host.ask(slave, Request::Start, 5), "Ack");
        for k in 0..100_000u32 {
            let bytes = if k % 100 == 0 { host.frame(Request::Heartbeat).1 } else { Vec::new() };
            host.period(slave, &bytes);
            if host.events().contains(&Event::Mode { from: ModeCode::Running, to: ModeCode::Ready }) {
                break;
            }
        }
        let events = host.events();
        assert!(events.contains(&Event::Mode { from: ModeCode::Running, to: ModeCode::Ready }), "{events:?}");
        let samples = host.samples();
        let running: Vec<&TelemetrySample> =
            samples.iter().filter(|s| s.mode == ModeCode::Running).collect();
        // The cut: the samples with the beam on.
        let cutting: Vec<&&TelemetrySample> = running.iter().filter(|s| channel(s, "laser") > 0.0).collect();
        let reference = |s: &TelemetrySample| [channel(s, "x_ref"), channel(s, "y_ref")].map(f64::from);
        let distance = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
        // At rest after the job: the reference stopped at the path's end, the beam off.
        for _ in 0..100 {
            host.period(slave, &[]);
        }
        let samples = host.samples();
        let rest = samples.last().expect("a sample after the job");
        let end = reference(rest);
        // The approach ends at the path's start, where the reference rests a few
        // periods before its ramp: the sample nearest it.
        let start = running
            .iter()
            .map(|s| distance(reference(s), first))
            .fold(f64::INFINITY, f64::min);
        let worst = running.iter().map(|s| channel(s, "error")).fold(0.0f32, f32::max);
        println!(
            "open path: {} samples with the beam on; the reference passes {:.3} µm from the path's start and rests {:.3} µm from its end; contour error ≤ {:.2} µm",
            cutting.len(),
            start * 1e6,
            distance(end, last) * 1e6,
            worst * 1e6
        );
        // Both to the f32 telemetry's rounding (under 1 nm at 7 mm) and, at the start,
        // a 1 ms sample's travel at the foot of a ramp of jerk 10 m/s³ (2 nm). The stop
        // ramp starts at a whole period, so the reference comes to rest within half a
        // period's step of the end (8 mm/s · 0.1 ms / 2 = 0.4 µm).
        assert!(start < 10e-9, "{start}");
        assert!(distance(end, last) < 0.41e-6, "{end:?} {last:?}");
        assert!(worst < 5e-6, "{worst}");
        assert_eq!((rest.mode, channel(rest, "laser")), (ModeCode::Ready, 0.0));
        // The job's duration as planned (approach, ramps, cruise) is the time the
        // machine ran it: from the first sample running to the first at rest, to the
        // telemetry's ten periods (1 ms).
        let planned = planned_open_path_s(&points);
        let ran = ran_s(&samples);
        println!("open path: planned {planned:.4} s, ran {ran:.4} s");
        assert!((ran - planned).abs() <= 1.1e-3, "planned {planned} s, ran {ran} s");
    })
    .unwrap();
}

/// The duration of `points` cut as an open path on the Keops slave with the link's
/// contour defaults (one lap), as its job reports it.
fn planned_open_path_s(points: &[[f64; 2]]) -> f64 {
    use kerf::machines::delta_slave::product::contour_defaults;
    use kerf::machines::delta_slave::{ContourCurve, DeltaJob, DeltaSlaveConfig, OPEN_PATH_POINTS};
    use kerf::trajectory::open_path::OpenPath;
    let path = OpenPath::<f64, OPEN_PATH_POINTS>::from_points(points).unwrap();
    let defaults = contour_defaults(&DeltaSlaveConfig::KEOPS, 1.0);
    let mut plan = defaults.plan(ContourCurve::Open(&path));
    plan.centre_m[0] += path.centre().x;
    plan.centre_m[1] += path.centre().y;
    let job = DeltaJob::plan_contour(&defaults.machine, &plan).unwrap();
    assert_eq!(job.contour_is_closed(), Some(false));
    let end = job.contour_point_m(1.0).unwrap();
    let last = points[points.len() - 1];
    assert!((end[0] - last[0]).hypot(end[1] - last[1]) < 1e-12);
    assert_eq!(job.contour_point_m(1.5), None);
    job.duration_s()
}

/// Three octagons of ±3 mm where the program puts them (left, top, right), as EFD files.
fn three_parts() -> Vec<Vec<u8>> {
    [[-6e-3, 0.0], [0.0, 5e-3], [6e-3, 0.0]]
        .iter()
        .map(|c| {
            let points: Vec<[f64; 2]> = kerf::trajectory::shapes::octagon()
                .iter()
                .map(|p| [c[0] + 0.3 * p[0], c[1] + 0.3 * p[1]])
                .collect();
            efd_job_file(&points, 30)
        })
        .collect()
}

/// A program of three parts runs as one job: each part uploaded while the one before
/// runs is queued (a fourth finds both buffers held: busy), begins in the period
/// after the one before ends ([`Event::NextJob`], no rest between), and its approach
/// leads to its own start where the file puts it; the whole takes the parts' planned
/// durations added up, the host's own check's.
#[test]
fn the_parts_of_a_program_follow_each_other_without_rest() {
    let parts = three_parts();
    let starts: Vec<[f64; 2]> = parts
        .iter()
        .map(|p| {
            kerf_host::check::check(p, None)
                .unwrap()
                .preview
                .unwrap()
                .cuts_m[0][0]
        })
        .collect();
    let planned: f64 = parts
        .iter()
        .map(|p| kerf_host::check::check(p, None).unwrap().duration_s)
        .sum();
    let mut host = Host::default();
    with_linked_slave::<f64, _>(&scenario(), 1.0, |slave| {
        for _ in 0..3 {
            host.period(slave, &[]);
        }
        host.upload(slave, &parts[0]);
        assert_eq!(
            host.ask(slave, Request::Telemetry { every_periods: 10 }, 2),
            "Ack"
        );
        assert_eq!(host.ask(slave, Request::Start, 5), "Ack");
        let mut given = 1;
        for k in 0..200_000u32 {
            let begun = 1 + host
                .events()
                .iter()
                .filter(|e| **e == Event::NextJob)
                .count();
            if given < parts.len() && given == begun {
                assert_eq!(host.upload_as(slave, JobKind::Efd, &parts[given]), "Ack");
                given += 1;
                if given < parts.len() {
                    // Both buffers held (the running part's and the queued one's).
                    let refused = host.upload_as(slave, JobKind::Efd, &parts[given]);
                    assert!(refused.contains("Busy"), "{refused}");
                }
            }
            let bytes = if k % 100 == 0 {
                host.frame(Request::Heartbeat).1
            } else {
                Vec::new()
            };
            host.period(slave, &bytes);
            if host.events().contains(&Event::Mode {
                from: ModeCode::Running,
                to: ModeCode::Ready,
            }) {
                break;
            }
        }
        let events = host.events();
        let modes: Vec<&Event> = events
            .iter()
            .filter(|e| matches!(e, Event::Mode { .. }))
            .collect();
        assert_eq!(
            events.iter().filter(|e| **e == Event::NextJob).count(),
            2,
            "{events:?}"
        );
        // Idle → Ready at power-up, one start, one end: no rest between the parts.
        assert_eq!(modes.len(), 3, "{modes:?}");
        let samples = host.samples();
        let reference =
            |s: &TelemetrySample| [channel(s, "x_ref"), channel(s, "y_ref")].map(f64::from);
        for (k, start) in starts.iter().enumerate() {
            let nearest = samples
                .iter()
                .map(|s| (reference(s)[0] - start[0]).hypot(reference(s)[1] - start[1]))
                .fold(f64::INFINITY, f64::min);
            println!(
                "part {}: the reference passes {:.1} nm from its start",
                k + 1,
                nearest * 1e9
            );
            assert!(nearest < 10e-9, "part {}: {nearest}", k + 1);
        }
        for _ in 0..20 {
            host.period(slave, &[]);
        }
        let samples = host.samples();
        let ran = ran_s(&samples);
        println!("three parts: planned {planned:.4} s, ran {ran:.4} s");
        // Each part's periods as planned, to the telemetry's ten periods.
        assert!(
            (ran - planned).abs() <= 1.1e-3,
            "planned {planned} s, ran {ran} s"
        );
        let worst = samples
            .iter()
            .filter(|s| s.mode == ModeCode::Running)
            .map(|s| channel(s, "error"))
            .fold(0.0f32, f32::max);
        assert!(worst < 5e-6, "{worst}");
    })
    .unwrap();
}

/// A part's cut settings are how the machine cuts it: a circle of 3 mm radius at
/// 5 mm/s, at a constant 4 W for two passes, then at 800 J/m (the power following the
/// measured speed) for one. From the telemetry at 1 ms: the reference's speed at
/// cruise (median of the steps between samples; f32 positions, 0.2 nm, and the chord
/// of a 5 µm step: both under 10⁻⁴ of it), the length cut with the beam on (two laps
/// of 18.85 mm, to 1 %: the ramps are inside it), the power (4 W in every cutting
/// sample; or power over the reference's speed, median, 800 J/m to 2 %: the measured
/// velocity is filtered and noisy), and the duration the host's check planned.
#[test]
fn a_parts_cut_settings_are_how_the_machine_cuts_it() {
    use kerf::codec::job::{with_settings, CutLaser, CutSettings};
    let radius = 3e-3;
    let circle: Vec<[f64; 2]> = (0..64)
        .map(|k| {
            let a = std::f64::consts::TAU * f64::from(k) / 64.0;
            [radius * a.cos(), radius * a.sin()]
        })
        .collect();
    let plain = efd_job_file(&circle, 10);
    let speed = 5e-3;
    for (laser, passes) in [
        (CutLaser::PowerW(4.0), 2u8),
        (CutLaser::EnergyJPerM(800.0), 1),
    ] {
        let settings = CutSettings {
            speed_m_s: Some(speed as f32),
            laser: Some(laser),
            passes: Some(passes),
            ..CutSettings::MACHINE
        };
        let mut buf = vec![0u8; plain.len() + 12];
        let n = with_settings(&plain, &settings, &mut buf).unwrap();
        let job = &buf[..n];
        let planned = kerf_host::check::check(job, None).unwrap().duration_s;
        let mut host = Host::default();
        with_linked_slave::<f64, _>(&scenario(), 1.0, |slave| {
            for _ in 0..3 {
                host.period(slave, &[]);
            }
            host.upload(slave, job);
            assert_eq!(host.ask(slave, Request::Telemetry { every_periods: 10 }, 2), "Ack");
            assert_eq!(host.ask(slave, Request::Start, 5), "Ack");
            let end = Event::Mode { from: ModeCode::Running, to: ModeCode::Ready };
            for k in 0..400_000u32 {
                let bytes = if k % 100 == 0 { host.frame(Request::Heartbeat).1 } else { Vec::new() };
                host.period(slave, &bytes);
                if host.events().contains(&end) {
                    break;
                }
            }
            for _ in 0..20 {
                host.period(slave, &[]);
            }
            let samples = host.samples();
            let cutting: Vec<&TelemetrySample> = samples
                .iter()
                .filter(|s| s.mode == ModeCode::Running && channel(s, "laser") > 0.0)
                .collect();
            let at = |s: &TelemetrySample| [channel(s, "x_ref"), channel(s, "y_ref")].map(f64::from);
            let steps: Vec<(f64, &TelemetrySample)> = cutting
                .windows(2)
                .filter(|w| w[1].period == w[0].period + 10)
                .map(|w| {
                    let (a, b) = (at(w[0]), at(w[1]));
                    ((b[0] - a[0]).hypot(b[1] - a[1]), w[1])
                })
                .collect();
            let median = |mut v: Vec<f64>| {
                v.sort_by(f64::total_cmp);
                v[v.len() / 2]
            };
            let cruise = median(steps.iter().map(|(d, _)| d / 1e-3).collect());
            let length: f64 = steps.iter().map(|(d, _)| d).sum();
            let lap = std::f64::consts::TAU * radius;
            let ran = ran_s(&samples);
            println!(
                "{laser:?}, {passes} passes: cruise {:.4} mm/s, cut {:.3} mm with the beam on, planned {planned:.4} s, ran {ran:.4} s",
                cruise * 1e3,
                length * 1e3
            );
            assert!((cruise - speed).abs() < 1e-3 * speed, "{cruise}");
            let laps = f64::from(passes);
            assert!((length - laps * lap).abs() < 0.01 * laps * lap, "{length}");
            assert!((ran - planned).abs() <= 1.1e-3, "planned {planned} s, ran {ran} s");
            match laser {
                CutLaser::PowerW(w) => {
                    assert!(cutting.iter().all(|s| channel(s, "laser") == w));
                }
                CutLaser::EnergyJPerM(e) => {
                    let per_length = median(
                        steps
                            .iter()
                            .filter(|(d, _)| d / 1e-3 > 1e-3)
                            .map(|(d, s)| f64::from(channel(s, "laser")) / (d / 1e-3))
                            .collect(),
                    );
                    println!("energy per length: median {per_length:.1} J/m");
                    assert!((per_length - f64::from(e)).abs() < 0.02 * f64::from(e), "{per_length}");
                }
                CutLaser::Off => unreachable!(),
            }
        })
        .unwrap();
    }
}

/// A 10 mm circle programmed as one arc (158 chords) and its parts: each of 24 points
/// and the next part's 8 as its look-ahead, each after the first continuing the one
/// before (`kerf_host::laser`).
fn streamed_circle() -> Vec<Vec<u8>> {
    let program = "G21 G90\nG0 X5 Y0\nM4 S500\nG2 X5 Y0 I-5 J0 F480\nM5\n";
    let read = kerf_host::laser::read(program.as_bytes());
    let beam = kerf_host::laser::Beam {
        s_max: 1000.0,
        max_power_w: 20.0,
    };
    let config = kerf_host::plan::PlanConfig::default();
    let corners = kerf_host::laser::Corners::Sharp;
    kerf_host::laser::parts(&read, &config, false, &beam, corners)
        .unwrap()
        .iter()
        .map(|p| kerf_host::job::with_settings(&p.job.to_bytes().unwrap(), &p.settings).unwrap())
        .collect()
}

/// A run longer than a part is cut without a stop: each part queued while the one
/// before runs is taken at that one's join at speed, the reference going on with no
/// gap (one mode change into the run and one out, the steps between samples within
/// the feed's, the speed above 95 % of the feed from the first part's ramp to the last
/// part's), as long as the host's check planned; a part that comes after its join is
/// refused (code 12), and taken again as one that starts at rest. In the look-ahead the
/// part before stopped in, the beam is off.
#[test]
fn a_run_streamed_in_parts_goes_on_at_its_joins() {
    let parts = streamed_circle();
    assert_eq!(parts.len(), 7);
    let planned = kerf_host::check::check(&parts.concat(), None)
        .unwrap()
        .duration_s;
    let mut host = Host::default();
    with_linked_slave::<f64, _>(&scenario(), 1.0, |slave| {
        for _ in 0..3 {
            host.period(slave, &[]);
        }
        assert_eq!(host.upload_as(slave, JobKind::Moves, &parts[0]), "Ack");
        assert_eq!(
            host.ask(slave, Request::Telemetry { every_periods: 10 }, 2),
            "Ack"
        );
        assert_eq!(host.ask(slave, Request::Start, 5), "Ack");
        let mut given = 1;
        for k in 0..200_000u32 {
            let begun = 1 + host
                .events()
                .iter()
                .filter(|e| **e == Event::NextJob)
                .count();
            if given < parts.len() && given == begun {
                assert_eq!(host.upload_as(slave, JobKind::Moves, &parts[given]), "Ack");
                given += 1;
            }
            let bytes = match k % 100 {
                0 => host.frame(Request::Heartbeat).1,
                _ => Vec::new(),
            };
            host.period(slave, &bytes);
            let end = Event::Mode {
                from: ModeCode::Running,
                to: ModeCode::Ready,
            };
            if host.events().contains(&end) {
                break;
            }
        }
        let events = host.events();
        let next_jobs = events.iter().filter(|e| **e == Event::NextJob).count();
        assert_eq!(next_jobs, parts.len() - 1, "{events:?}");
        let modes = events.iter().filter(|e| matches!(e, Event::Mode { .. }));
        assert_eq!(modes.count(), 3, "{events:?}");
        for _ in 0..20 {
            host.period(slave, &[]);
        }
        let samples = host.samples();
        let ran = ran_s(&samples);
        println!("streamed circle: planned {planned:.4} s, ran {ran:.4} s");
        assert!(
            (ran - planned).abs() <= 1.1e-3,
            "planned {planned} s, ran {ran} s"
        );
        // The cut, from where the approach reaches the circle's start (5, 0) mm.
        let cut: Vec<[f64; 2]> = samples
            .iter()
            .filter(|s| s.mode == ModeCode::Running)
            .map(|s| [channel(s, "x_ref"), channel(s, "y_ref")].map(f64::from))
            .skip_while(|r| (r[0] - 5e-3).hypot(r[1]) > 1e-6)
            .collect();
        let speeds: Vec<f64> = cut
            .windows(2)
            .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]) / 1e-3)
            .collect();
        // The feed at most (f32 positions: 0.2 nm of a 8 µm step).
        let feed = 8e-3;
        let fastest = speeds.iter().copied().fold(0.0, f64::max);
        assert!(fastest <= feed * 1.0001, "{fastest}");
        // From where the first part reaches its feed to where the last one leaves it.
        let at_feed: Vec<usize> = (0..speeds.len())
            .filter(|&i| speeds[i] > 0.95 * feed)
            .collect();
        let (first, last) = (at_feed[0], *at_feed.last().unwrap());
        let slowest = speeds[first..=last]
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
        println!(
            "streamed circle: slowest {:.3} mm/s between its ramps",
            slowest * 1e3
        );
        assert!(slowest > 0.95 * feed, "{slowest}");
        // The cut: 98 % of its length at speed (the circle is 31.4 mm).
        let at_speed_m: f64 = speeds[first..=last].iter().map(|v| v * 1e-3).sum();
        assert!(
            at_speed_m > 0.9 * std::f64::consts::TAU * 5e-3,
            "{at_speed_m}"
        );
        let worst = samples
            .iter()
            .filter(|s| s.mode == ModeCode::Running)
            .map(|s| channel(s, "error"))
            .fold(0.0f32, f32::max);
        assert!(worst < 5e-6, "{worst}");
    })
    .unwrap();
}

/// A part that comes after the one before has passed its join: that one stops in its
/// look-ahead with the beam off, the late part is refused at its start in the
/// machine's words (code 12), and the same part made to start at rest is taken.
#[test]
fn a_part_too_late_for_its_join_starts_at_rest() {
    let parts = streamed_circle();
    let mut host = Host::default();
    with_linked_slave::<f64, _>(&scenario(), 1.0, |slave| {
        for _ in 0..3 {
            host.period(slave, &[]);
        }
        assert_eq!(host.upload_as(slave, JobKind::Moves, &parts[0]), "Ack");
        assert_eq!(
            host.ask(slave, Request::Telemetry { every_periods: 1 }, 2),
            "Ack"
        );
        assert_eq!(host.ask(slave, Request::Start, 5), "Ack");
        let end = Event::Mode {
            from: ModeCode::Running,
            to: ModeCode::Ready,
        };
        for k in 0..100_000u32 {
            let bytes = match k % 100 {
                0 => host.frame(Request::Heartbeat).1,
                _ => Vec::new(),
            };
            host.period(slave, &bytes);
            if host.events().contains(&end) {
                break;
            }
        }
        // Where the first part's cut ends: the second part's first point.
        let join = kerf::codec::job::JobFile::read(&parts[1])
            .unwrap()
            .move_point(0)
            .unwrap();
        let join = [f64::from(join[0]), f64::from(join[1])];
        let samples = host.samples();
        let past: Vec<&TelemetrySample> = samples
            .iter()
            .filter(|s| s.mode == ModeCode::Running)
            .skip_while(|s| {
                let r = [channel(s, "x_ref"), channel(s, "y_ref")].map(f64::from);
                // Half a sample's step at the feed (the samples are 1 ms apart).
                (r[0] - join[0]).hypot(r[1] - join[1]) > 4.5e-6
            })
            // The beam goes off two periods after the reference passes the join.
            .skip(1)
            .collect();
        assert!(past.len() > 10, "{}", past.len());
        assert!(past.iter().all(|s| channel(s, "laser") == 0.0));
        assert_eq!(host.upload_as(slave, JobKind::Moves, &parts[1]), "Ack");
        let refused = host.ask(slave, Request::Start, 5);
        assert!(refused.contains("Job(12)"), "{refused}");
        let fresh = kerf_host::job::starting_at_rest(&parts[1]).unwrap();
        assert_ne!(fresh, parts[1]);
        assert_eq!(host.upload_as(slave, JobKind::Moves, &fresh), "Ack");
        assert_eq!(host.ask(slave, Request::Start, 5), "Ack");
    })
    .unwrap();
}
