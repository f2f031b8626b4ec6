//! The host tool's run of a program of parts (`kerf_host::session::Session::run_parts`)
//! against the simulated Keops slave behind its host link, on a socket pair at twice
//! real time: the parts are uploaded while the one before runs, the machine goes on to
//! each without resting, and the run ends after the last with the parts' planned time.

use hal_mock::hall_sensor::HallSensorParams;
use host_tests::link::{efd_job_file, run_plan, serve, MachineThread, Pace};
use kerf::codec::link::JobKind;
use kerf_host::link::MachineLink;
use kerf_host::session::{Progress, Session};
use kerf_host::telemetry::TelemetryLog;
use kerf_sim::linked::with_linked_slave;
use kerf_sim::slave::SlaveScenario;
use std::os::unix::net::UnixStream;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

/// Two small circles (r 1 mm) left and right of the centre, as EFD files.
fn two_parts() -> Vec<Vec<u8>> {
    [-3e-3, 3e-3]
        .iter()
        .map(|&x| {
            let points: Vec<[f64; 2]> = (0..64)
                .map(|k| {
                    let a = std::f64::consts::TAU * f64::from(k) / 64.0;
                    [x + 1e-3 * a.cos(), 1e-3 * a.sin()]
                })
                .collect();
            efd_job_file(&points, 10)
        })
        .collect()
}

#[test]
fn run_parts_streams_a_program_and_ends_after_its_last_part() {
    let (host, far) = UnixStream::pair().unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let machine_stop = Arc::clone(&stop);
    let thread = std::thread::spawn(move || {
        let mut scenario = SlaveScenario::square();
        scenario.sensors = [HallSensorParams::LM1247_16BIT; 3];
        scenario.substeps = 1;
        with_linked_slave::<f64, _>(&scenario, 1.0, |slave| {
            let pace = Pace::Scaled {
                period_s: 1e-4,
                speedup: 2.0,
            };
            serve(far, &machine_stop, pace, |_, input, send| {
                slave.period(input, send).is_ok()
            });
        })
        .expect("the slave builds");
    });
    let _machine = MachineThread::new(stop, thread);
    let link = MachineLink::connect(
        Box::new(host.try_clone().unwrap()),
        Box::new(host),
        Duration::from_secs(5),
    )
    .expect("the simulated slave answers");
    let mut session = Session::over(link);
    let channels = session.machine.description().channels.clone();
    let parts = two_parts();
    let planned: f64 = parts
        .iter()
        .map(|p| kerf_host::check::check(p, None).unwrap().duration_s)
        .sum();
    let program: Vec<(JobKind, &[u8])> =
        parts.iter().map(|p| (JobKind::Efd, p.as_slice())).collect();
    let mut log = TelemetryLog::new(1e-4, &channels);
    let mut lines = Vec::new();
    session
        .run_parts(
            &program,
            &run_plan(100.0, 30, &[]),
            &mut log,
            None,
            &mut |p| {
                if let Progress::Line(t, text) = p {
                    lines.push(format!("{t:.3} {text}"));
                }
            },
        )
        .expect("the program runs to its end");
    let summary = log.summary();
    println!("parts session: {lines:?}\n{summary}; planned {planned:.3} s");
    // One part begun after the first, no rest between them, and the run's time the
    // parts' planned time, to the telemetry's 10 ms.
    assert_eq!(
        lines
            .iter()
            .filter(|l| l.contains("the next part begins"))
            .count(),
        1,
        "{lines:?}"
    );
    assert_eq!(
        lines
            .iter()
            .filter(|l| l.contains("running -> ready"))
            .count(),
        1,
        "{lines:?}"
    );
    assert!(
        (summary.cut_s - planned).abs() < 0.02,
        "{} s against {planned} s",
        summary.cut_s
    );
    assert!(summary.error_max_m < 5e-6, "{summary}");
}
