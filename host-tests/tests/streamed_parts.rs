//! A run longer than a part on the simulated Keops slave over its host link: the
//! parts of a streamed program taken at their joins at speed, and a part that comes
//! too late taken again from rest.

use host_tests::link_host::{channel, ran_s, scenario, worst_error, Host};
use kerf::codec::link::{Event, JobKind, ModeCode, Request, TelemetrySample};
use kerf_sim::linked::with_linked_slave;

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
        host.start_job(slave, JobKind::Moves, &parts[0], 10);
        let mut given = 1;
        host.run_to_end(slave, 200_000, |host, slave| {
            if given < parts.len() && given == host.parts_begun() {
                assert_eq!(host.upload_as(slave, JobKind::Moves, &parts[given]), "Ack");
                given += 1;
            }
        });
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
        let worst = worst_error(&samples);
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
        host.start_job(slave, JobKind::Moves, &parts[0], 1);
        host.run_to_end(slave, 100_000, |_, _| {});
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
