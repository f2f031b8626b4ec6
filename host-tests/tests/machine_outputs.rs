//! Machines never write a NaN or an infinity: gains the control scalar cannot hold are
//! refused where they are configured, and a command that leaves the range of what the
//! link carries faults the machine with its safe outputs in the same period.

use heapless::spsc::Queue;
use host_tests::arrow::{scenario, ArrowRunConfig};
use host_tests::remote::{master_config, RemoteCase, MASTER_HOME_M};
use kerf::app::jobs::{JobSlot, JobSlots};
use kerf::app::remote_link::SlaveReport;
use kerf::app::supervisor::{Command, Mode, Report, Supervisor};
use kerf::control::redundant_pid::RedundantPidConfig;
use kerf::kinematics::Vector3;
use kerf::machines::remote_master::{
    FixtureJob, RemoteMaster, RemoteMasterFault, RemoteMasterInputs,
};

/// ARROW's parallel module with K_D (or K_I) beyond what `f32` holds once divided
/// (multiplied) by the 0.2 ms period: the law is refused for the `f32` machine (its
/// first period's forces were NaN: ∞ × a zero first difference), and builds for the
/// `f64` reference, where the same coefficients are finite.
#[test]
fn arrow_gains_beyond_f32_are_refused_for_the_f32_machine() {
    for (kd, ki) in [(4e38, 2e7), (1e300, 2e7), (8070.0, 1e300)] {
        let mut config = ArrowRunConfig::published(true, true, 0);
        config.parallel = RedundantPidConfig {
            kd,
            ki,
            ..config.parallel
        };
        let scenario = scenario(&config);
        assert!(scenario.law::<f32>().is_err(), "kd {kd} ki {ki}");
        assert!(scenario.law::<f64>().is_ok(), "kd {kd} ki {ki}");
    }
}

type Master = RemoteMaster<f64>;

/// The remote master (`f64`) on a fixture circle through its home effector, with the
/// slave's tracking law at `bandwidth_rad_s` (both poles), stepped `periods` periods
/// with the slave reported 10 mm off; returns the supervisor's mode and every
/// period's outputs.
fn master_run(
    bandwidth_rad_s: f64,
    periods: usize,
) -> (
    Mode<RemoteMasterFault>,
    Vec<kerf::machines::remote_master::MasterOutputs<f64>>,
) {
    let mut config = master_config(&RemoteCase::nominal(), [0.0; 3], [0.0, 0.0, -0.2]);
    config.tracking.surface_slope_per_s = bandwidth_rad_s;
    config.tracking.reaching_rate_per_s = bandwidth_rad_s;
    let machine = Master::new(&config).unwrap();
    let home = machine
        .geometry()
        .forward(&Vector3::from(MASTER_HOME_M))
        .unwrap();
    // A 5 mm circle through the effector, 64 points counter-clockwise.
    let points: Vec<[f64; 2]> = (0..64)
        .map(|k| {
            let a = std::f64::consts::TAU * f64::from(k) / 64.0;
            [home.x - 0.005 + 0.005 * a.cos(), home.y + 0.005 * a.sin()]
        })
        .collect();
    let job = FixtureJob::new(&points, &config.constraint, home.z, false).unwrap();
    let jobs: &'static JobSlots<_> = Box::leak(Box::new(JobSlots::new(job, Default::default())));
    let commands: &'static mut Queue<Command<Master>, 4> = Box::leak(Box::new(Queue::new()));
    let reports: &'static mut Queue<Report<Master>, 64> = Box::leak(Box::new(Queue::new()));
    let (mut to_machine, from_sender) = commands.split();
    let (to_sender, mut from_machine) = reports.split();
    let mut supervisor = Supervisor::new(machine, from_sender, to_sender, jobs);
    supervisor.set_telemetry_decimation(0);
    for command in [
        Command::FinishCalibration(()),
        Command::LoadJob(JobSlot::First),
        Command::Start,
    ] {
        assert!(to_machine.enqueue(command).is_ok());
    }
    let inputs = RemoteMasterInputs {
        encoder_counts: [0; 3],
        report: Some(SlaveReport {
            echo_tick: None,
            position_m: [0.01, 0.0, -0.2],
            velocity_m_s: [0.0; 3],
        }),
    };
    let mut outputs = Vec::new();
    for _ in 0..periods {
        outputs.push(supervisor.step(&inputs));
        while from_machine.dequeue().is_some() {}
    }
    (supervisor.mode(), outputs)
}

/// With the tracking law's poles at 1e150 rad/s (K_P = 1e300: finite in the master's
/// `f64`), the slave's command is ~1e298 m/s², ∞ in the link's `f32`: the master
/// faults instead of sending it, in that period, with zero forces and no command.
/// With the scenario's 15 Hz poles the same run sends finite commands.
#[test]
fn remote_master_refuses_a_command_the_link_cannot_carry() {
    let (mode, outputs) = master_run(1e150, 30);
    assert_eq!(mode, Mode::Fault(RemoteMasterFault::NotFinite));
    for o in &outputs {
        if let Some((_, command)) = o.command {
            assert!(
                command.acceleration_m_s2.iter().all(|a| a.is_finite()),
                "{command:?}"
            );
        }
    }
    let last = outputs.last().unwrap();
    assert_eq!((last.force_n, last.command), ([0.0; 3], None));
    let (mode, outputs) = master_run(2.0 * std::f64::consts::PI * 15.0, 30);
    assert_eq!(mode, Mode::Running);
    assert!(outputs.iter().any(|o| o.command.is_some()));
}
