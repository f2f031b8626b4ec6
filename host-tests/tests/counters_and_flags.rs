//! Counters and flags a user reads, each driven both ways: a counter must count every
//! event once (not zero, not twice) and a flag must set and clear where its
//! documentation says.

use hal_mock::axis::SimulatedAxis;
use hal_mock::delta_plant::DeltaPlantParams;
use hal_mock::hall_sensor::HallSensorParams;
use hal_mock::linear_motor::LinearMotorParams;
use hal_mock::link::{FrameEnd, LinkConfig};
use heapless::spsc::Queue;
use kerf::app::host_link::mode_code;
use kerf::app::jobs::JobSlots;
use kerf::app::joints::{Joints, JointsConfig};
use kerf::app::stream::{SignalSender, StreamError};
use kerf::app::supervisor::{Command, Mode, Report, Supervisor};
use kerf::app::{control_period, PeriodClock};
use kerf::codec::link::ModeCode;
use kerf::codec::sdct::{SdctConfig, Selection};
use kerf::control::dob::{Dob, DobConfig, DobOutput, DobState};
use kerf::control::laser::LaserMode;
use kerf::hal::{FrameLink, LinkBusy, Monotonic};
use kerf::kinematics::delta::DeltaGeometry;
use kerf::kinematics::Vector3;
use kerf::machines::delta_slave::remote::{FollowJob, FollowPhase, RemoteSlave, RemoteSlaveConfig};
use kerf::trajectory::gcode::{self, GcodePoint, Parser};
use kerf_sim::operator::{Operator, OperatorState};
use kerf_sim::remote::{keops_site, SlaveSite};

/// A late period is one that starts more than 1.5 periods after the last: each stall
/// is counted once, exactly 1.5 periods is on time and one tick more is late; every
/// `control_period` writes once (the simulated clock advances one period a write).
#[test]
fn control_period_counts_each_late_period_once() {
    let config = JointsConfig::LM1247;
    let machine = Joints::<f64, 1>::new(&config).unwrap();
    let jobs = JobSlots::default();
    let mut commands: Queue<Command<Joints<f64, 1>>, 4> = Queue::new();
    let mut reports: Queue<Report<Joints<f64, 1>>, 4> = Queue::new();
    let (_, from) = commands.split();
    let (to, _) = reports.split();
    let mut supervisor = Supervisor::new(machine, from, to, &jobs);
    supervisor.set_telemetry_decimation(0);
    let mut plant = SimulatedAxis::new(
        LinearMotorParams::LM1247_WITH_PAYLOAD,
        HallSensorParams::LM1247_16BIT,
        config.period_s,
        1,
        config.home_m[0],
    );
    let mut clock = PeriodClock::new(config.period_s, plant.tick_hz()).unwrap();
    let period_ns = 100_000u64;
    assert_eq!(clock.period_ticks(), period_ns);
    let (mut stalled_ns, mut late) = (0u64, 0u32);
    for k in 0..60u64 {
        let (stall, is_late) = match k {
            10 => (period_ns, true),
            20 => (period_ns / 2, false),
            30 => (period_ns / 2 + 1, true),
            40 => (5 * period_ns, true),
            _ => (0, false),
        };
        plant.clock.stall(stall);
        stalled_ns += stall;
        late += u32::from(is_late);
        let outputs = control_period(&mut supervisor, &mut clock, &mut plant);
        assert_eq!(outputs, [0.0], "idle: safe outputs");
        assert_eq!(plant.now(), (k + 1) * period_ns + stalled_ns);
        assert_eq!(clock.late_periods(), late, "period {k}");
    }
    assert_eq!(late, 3);
    assert_eq!(clock.longest_ticks(), 6 * period_ns);
}

/// The simulated axis under a held force against the closed form of its plant
/// (`hal_mock::linear_motor` module docs, m ẍ = F − b ẋ − Fc from rest):
/// v(t) = v∞ (1 − e^(−t/τ)), x(t) = x0 + v∞ (t − τ (1 − e^(−t/τ))), v∞ = (F − Fc)/b,
/// τ = m/b. The plant solves each substep exactly, so only rounding separates them:
/// its 1 − e^(−h/τ) at h/τ = 4e-5 keeps 2.2e-16/4e-5 ≈ 6e-12 relative, which each
/// substep's displacement carries on its v∞·h = 1.8e-5 m terms: 1.1e-16 m a substep,
/// 2.2e-14 m over the 200.
#[test]
fn apply_force_advances_the_plant_and_the_clock_one_period() {
    let p = LinearMotorParams::LM1247_WITH_PAYLOAD;
    let ts = 1e-4;
    let mut axis = SimulatedAxis::new(p, HallSensorParams::LM1247_16BIT, ts, 1, 0.01);
    let force = 1.0;
    let (v_inf, tau) = (
        (force - p.coulomb_n) / p.viscous_n_s_per_m,
        p.mass_kg / p.viscous_n_s_per_m,
    );
    for k in 1..=20u32 {
        axis.apply_force(force);
        let t = f64::from(k) * ts;
        let decay = (-t / tau).exp_m1();
        let v = -v_inf * decay;
        let x = 0.01 + v_inf * (t + tau * decay);
        assert!(
            (axis.motor.velocity_m_s - v).abs() < 1e-10 * v,
            "{k}: {} {v}",
            axis.motor.velocity_m_s
        );
        assert!(
            (axis.motor.position_m - x).abs() < 3e-14,
            "{k}: {} {x}",
            axis.motor.position_m
        );
        assert_eq!(axis.clock.now(), u64::from(k) * 100_000);
    }
    // Past the driver's limit: the limit is applied.
    axis.apply_force(5.0);
    assert_eq!(axis.motor.applied_force_n(), p.force_limit_n);
    assert_eq!(axis.motor.params(), &p);
}

/// Frames that do not fit the receiver's buffer are dropped and counted, one each;
/// frames that fit are delivered and not counted.
#[test]
fn oversized_frames_are_counted_once_each() {
    let mut end = FrameEnd::<64, 8>::new(&LinkConfig::IDEAL).unwrap();
    let mut buf = [0u8; 16];
    end.send(&[1; 40]).unwrap();
    end.send(&[2; 10]).unwrap();
    assert_eq!(end.receive(&mut buf), Some(10));
    assert_eq!(buf[..10], [2; 10]);
    assert_eq!(end.oversized(), 1);
    end.send(&[3; 16]).unwrap();
    assert_eq!(end.receive(&mut buf), Some(16));
    assert_eq!(end.oversized(), 1);
    for _ in 0..3 {
        end.send(&[4; 17]).unwrap();
    }
    assert_eq!(end.receive(&mut buf), None);
    assert_eq!(end.oversized(), 4);
    // A large enough buffer gets everything: nothing more is counted.
    end.send(&[5; 64]).unwrap();
    assert_eq!(end.receive(&mut [0u8; 64]), Some(64));
    assert_eq!(end.oversized(), 4);
}

/// A link that refuses the sends whose (1-based) number is listed.
struct Refusing {
    sends: usize,
    refuse: &'static [usize],
}

impl FrameLink for Refusing {
    fn send(&mut self, _: &[u8]) -> Result<(), LinkBusy> {
        self.sends += 1;
        if self.refuse.contains(&self.sends) {
            Err(LinkBusy)
        } else {
            Ok(())
        }
    }
    fn receive(&mut self, _: &mut [u8]) -> Option<usize> {
        None
    }
}

/// Every block the link refuses is one dropped block, reported as `Busy` by the push
/// that completed it; blocks that go out are not counted.
#[test]
fn stream_sender_counts_each_refused_block() {
    const N: usize = 8;
    let config = SdctConfig {
        m: 4,
        selection: Selection::Largest,
    };
    let mut sender = SignalSender::<N>::new(&config).unwrap();
    let mut link = Refusing {
        sends: 0,
        refuse: &[2, 5, 6],
    };
    let mut busy = 0;
    for i in 0..7 * N {
        let sample = (i as f32 * 0.3).sin();
        match sender.push(sample, &mut link) {
            Ok(()) => {}
            Err(StreamError::Busy(_)) => {
                assert_eq!(i % N, N - 1, "only a block's last sample sends");
                busy += 1;
            }
            Err(e) => panic!("{e:?}"),
        }
        assert_eq!(sender.dropped(), busy);
    }
    assert_eq!((link.sends, sender.dropped()), (7, 3));
}

const DOB: DobConfig = DobConfig {
    nominal_mass_kg: 0.1,
    bandwidth_rad_s: 600.0,
    force_limit_n: 3.6,
    compensate: true,
};

/// The saturation flag is set exactly when the command reaches the limit, on either
/// side, and clears when the command comes back inside.
#[test]
fn dob_saturation_sets_at_the_limit_and_clears_inside() {
    let dob = Dob::<f64>::new(&DOB, 1e-4).unwrap();
    let out = |force_n| DobOutput {
        force_n,
        disturbance_n: 0.0,
    };
    for (force, saturated) in [
        (0.0, false),
        (3.599_999, false),
        (-3.599_999, false),
        (3.6, true),
        (-3.6, true),
    ] {
        assert_eq!(dob.is_saturated(&out(force)), saturated, "{force}");
    }
    // Through the observer: An·q̈des of 1 N, 10 N (clipped), then 1 N again.
    let mut state = DobState::at(0.0);
    let mut flags = Vec::new();
    for a in [10.0, 100.0, -100.0, 10.0] {
        let o = dob.update(&mut state, a, 0.0);
        flags.push((o.force_n.abs() == 3.6, dob.is_saturated(&o)));
    }
    assert_eq!(
        flags,
        [(false, false), (true, true), (true, true), (false, false)]
    );
}

/// `M2` and `M30` end a program (the move on the same line still counts), later lines
/// are counted and skipped; `M3` or a plain move does not end it.
#[test]
fn gcode_ended_sets_at_m2_or_m30_only() {
    for end in ["M2", "M30"] {
        let mut parser = Parser::new();
        assert!(!parser.ended());
        for line in ["G21 G90", "G1 X1 F600", "M3 S1000", "G0 Z2"] {
            parser.parse_line(line.as_bytes()).unwrap();
            assert!(!parser.ended(), "{line}");
        }
        let last = parser
            .parse_line(format!("G1 X2 {end}").as_bytes())
            .unwrap();
        assert!(last.is_some(), "the move on the ending line is kept");
        assert!(parser.ended());
        assert_eq!(parser.parse_line(b"G1 X9").unwrap(), None);
        assert!(parser.ended() && parser.program().ended);
        assert_eq!(parser.lines(), 6);
    }
    let mut points: heapless::Vec<GcodePoint, 8> = heapless::Vec::new();
    let program = gcode::parse(b"G1 X1 F600\nM30\nG1 X5\n", &mut points).unwrap();
    assert!(program.ended);
    assert_eq!(points.len(), 1);
    let program = gcode::parse(b"G1 X1 F600\nG1 X5\n", &mut points).unwrap();
    assert!(!program.ended);
}

/// Every supervisor mode has the wire code of the same name.
#[test]
fn mode_code_names_each_mode() {
    let modes: [(Mode<u8>, ModeCode); 6] = [
        (Mode::Idle, ModeCode::Idle),
        (Mode::Calibrating, ModeCode::Calibrating),
        (Mode::Ready, ModeCode::Ready),
        (Mode::Running, ModeCode::Running),
        (Mode::Stopping, ModeCode::Stopping),
        (Mode::Fault(3), ModeCode::Fault),
    ];
    for (mode, code) in modes {
        assert_eq!(mode_code(&mode), code, "{mode:?}");
    }
}

/// A link that carries nothing (no master yet; reports go nowhere).
struct Silent;

impl FrameLink for Silent {
    fn send(&mut self, _: &[u8]) -> Result<(), LinkBusy> {
        Ok(())
    }
    fn receive(&mut self, _: &mut [u8]) -> Option<usize> {
        None
    }
}

/// The remote slave reports no position while it approaches the job's start and the
/// measured effector otherwise (none before the first measurement; waiting at the
/// start, the effector): checked against the simulated plant's true effector. The operator's fits
/// are there once the calibration ran, one per carriage.
#[test]
fn remote_slave_reports_its_position_except_during_the_approach() {
    let site_config = keops_site(DeltaPlantParams::SLAVE_REALISTIC, 8, 10, 20);
    let slave = RemoteSlaveConfig::KEOPS;
    let jobs = JobSlots::default();
    let mut commands: Queue<Command<RemoteSlave<f64>>, 8> = Queue::new();
    let mut reports: Queue<Report<RemoteSlave<f64>>, 64> = Queue::new();
    let (mut send, from_operator) = commands.split();
    let (to_operator, mut receive) = reports.split();
    let mut site = SlaveSite::<f64>::new(&site_config, from_operator, to_operator, &jobs).unwrap();
    let centre: [f64; 3] = DeltaGeometry::<f64>::new(&slave.slave.delta)
        .unwrap()
        .forward(&Vector3::new(0.02, 0.02, 0.02))
        .unwrap()
        .into();
    let job = FollowJob {
        start_m: centre,
        approach_s: 0.3,
        laser: Some(LaserMode::ConstantPower { power_w: 1.0 }),
    };
    let mut operator = Operator::<RemoteSlave<f64>, 3>::new(slave.slave.joints.hall, None, job);
    assert!(operator.fits().is_none());
    operator.start(&mut send, &jobs);
    let (mut approach, mut waiting, mut outside) = (0, 0, 0);
    for now in 0..30_000u32 {
        site.step(now, &mut Silent, &mut Silent).unwrap();
        let state = operator.poll(&mut receive, &mut send, &jobs);
        assert!(!matches!(state, OperatorState::Failed(_)), "{state:?}");
        let machine = site.supervisor().machine();
        let report = machine.report_position_m();
        let truth = site.plant().plant.effector_m().unwrap();
        match machine.phase() {
            Some(FollowPhase::Approach) => {
                assert_eq!(report, None, "period {now}");
                approach += 1;
            }
            phase => {
                assert_eq!(report, machine.effector_m(), "period {now}");
                // None only before the first measurement, never while waiting.
                let Some(report) = report else {
                    assert_eq!(phase, None, "period {now}");
                    continue;
                };
                // The Hall decoders measure the carriages to micrometres.
                let error = (Vector3::from(report) - truth).norm();
                assert!(error < 50e-6, "period {now} {phase:?}: {error}");
                if phase == Some(FollowPhase::Waiting) {
                    waiting += 1;
                    if waiting == 100 {
                        break;
                    }
                } else {
                    outside += 1;
                }
            }
        }
    }
    // The approach lasts its 0.3 s (3,000 periods, the first one entering it).
    assert!(approach >= 2990, "{approach}");
    assert!(outside < 100_000);
    assert_eq!(waiting, 100);
    let fits = operator.fits().expect("calibrated");
    assert_eq!(operator.fit(), Some(&fits[0]));
    assert!(
        fits.iter()
            .all(|f| f.residual_rms_counts <= f.residual_limit_counts),
        "{fits:?}"
    );
}
