//! The operator's side against the simulated Keops slave over the host link
//! (in simulation): a host that speaks only frames uploads the
//! octagon as an EFD job file in chunks, starts it, streams telemetry, changes a
//! setting during the cut, and hears the end; a sensor fault reaches it as an event;
//! a host that goes silent gets its job stopped. An open path (a points file) is cut
//! once from its first point to its last.

use host_tests::link::{efd_job_file, octagon_job_file};
use host_tests::link_host::{channel, ran_s, scenario, worst_error, Host};
use kerf::codec::link::{Event, JobKind, ModeCode, Request, TelemetrySample};
use kerf_sim::linked::with_linked_slave;

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
        host.start_job(slave, JobKind::Efd, &parts[0], 10);
        let mut given = 1;
        host.run_to_end(slave, 200_000, |host, slave| {
            if given < parts.len() && given == host.parts_begun() {
                assert_eq!(host.upload_as(slave, JobKind::Efd, &parts[given]), "Ack");
                given += 1;
                if given < parts.len() {
                    // Both buffers held (the running part's and the queued one's).
                    let refused = host.upload_as(slave, JobKind::Efd, &parts[given]);
                    assert!(refused.contains("Busy"), "{refused}");
                }
            }
        });
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
        let worst = worst_error(&samples);
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
