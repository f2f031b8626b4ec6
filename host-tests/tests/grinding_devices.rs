//! The grinding cell with its devices on their protocols:
//! the cell's control period at 1 ms, the device link's tick every 10 periods
//! speaking PI GCS to `hal-mock`'s hexapod and the converter's frames to its spindle,
//! and the simulated cell's workpiece carried along by the hexapod's real motion.
//! Faults of the devices and a drifting F/T bias must stop the cell in its safe state.

use hal_mock::grinding_cell::{Cell, CellConfig, CellReading};
use hal_mock::hexapod::{HexapodLimits, SimHexapod, REFERENCE_TIME_S};
use hal_mock::spindle::SimSpindle;
use heapless::spsc::Queue;
use host_tests::grinding::{raw_for, seed_pass, PassSetup, DX_M, SAMPLES};
use kerf::app::jobs::{JobSlot, JobSlots};
use kerf::app::supervisor::{Command, Machine, Mode, Report, Supervisor};
use kerf::codec::gcs::{self, Axis, AxisValues};
use kerf::codec::spindle::{SpindleReading, SpindleRequest};
use kerf::hal::{LinkError, Transact};
use kerf::machines::grinding::devices::{
    DeviceDemand, DeviceFault, DeviceLink, DeviceLinkConfig, DeviceLinkState, HexapodFault,
    SpindleFault,
};
use kerf::machines::grinding::{
    ForceLawKind, GrindingCalibration, GrindingCell, GrindingConfig, GrindingFault, GrindingInputs,
    GrindingOutputs,
};

/// Control periods per device tick (1 ms and 10 ms).
const TICK: usize = 10;
const TS: f64 = 1e-3;

/// The hexapod's end of the link, logging each request with its period.
struct HexapodPort {
    sim: SimHexapod,
    log: Vec<(usize, String)>,
    period: usize,
}

impl Transact for HexapodPort {
    fn transact(&mut self, request: &[u8], reply: &mut [u8]) -> Result<usize, LinkError> {
        self.log.push((
            self.period,
            String::from_utf8_lossy(request).trim_end().to_string(),
        ));
        Ok(self.sim.handle(request, reply))
    }
}

/// The converter's end, logging likewise; silent (0 bytes) when the simulated
/// converter does not answer.
struct SpindlePort {
    sim: SimSpindle,
    log: Vec<(usize, Vec<u8>)>,
    period: usize,
}

impl Transact for SpindlePort {
    fn transact(&mut self, request: &[u8], reply: &mut [u8]) -> Result<usize, LinkError> {
        self.log.push((self.period, request.to_vec()));
        match (self.sim.transact(request), reply.get_mut(..3)) {
            (Some(bytes), Some(slot)) => {
                slot.copy_from_slice(&bytes);
                Ok(3)
            }
            _ => Ok(0),
        }
    }
}

/// What to run.
struct Scenario {
    setup: PassSetup,
    /// Where the hexapod's X stands before the pass, mm.
    start_x_mm: f64,
    /// Run the pass (else stay at rest after the calibration).
    pass: bool,
    /// Mute the converter this long after the pass starts, s.
    mute_spindle_after_s: Option<f64>,
    /// Periods to run at most (from the first).
    periods: usize,
}

/// What happened.
struct Outcome {
    mode: Mode<GrindingFault>,
    /// The period the pass started.
    start: usize,
    /// The period the supervisor entered its fault, and the fault.
    fault: Option<(usize, GrindingFault)>,
    /// The period the link's tick found a device fault.
    device_fault: Option<(usize, DeviceFault)>,
    /// Every period's outputs.
    outputs: Vec<GrindingOutputs<f64>>,
    /// Every period's cell reading and the hexapod's X, mm.
    readings: Vec<(CellReading, f64)>,
    /// The last path a healthy tick reported, mm.
    last_path_mm: f64,
    fed_m: f64,
    hexapod: HexapodPort,
    spindle: SpindlePort,
}

fn referenced_hexapod(start_x_mm: f64) -> SimHexapod {
    let mut sim = SimHexapod::new(HexapodLimits::H824);
    let mut out = [0u8; gcs::MAX_REPLY_LEN];
    sim.handle(b"FRF\n", &mut out);
    sim.step(REFERENCE_TIME_S + 0.01);
    let mut buf = [0u8; gcs::MAX_COMMAND_LEN];
    let mut target = AxisValues::new();
    target.set(Axis::X, start_x_mm);
    let n = gcs::Command::Mov(target).encode(&mut buf).unwrap();
    sim.handle(&buf[..n], &mut out);
    sim.step(100.0);
    sim.handle(b"ERR?\n", &mut out);
    assert_eq!(sim.position()[0], start_x_mm);
    sim
}

fn run(s: &Scenario) -> Outcome {
    let setup = &s.setup;
    let jobs = JobSlots::new(setup.job, Default::default());
    let mut commands = Queue::<Command<GrindingCell<f64>>, 4>::new();
    let mut reports = Queue::<Report<GrindingCell<f64>>, 8>::new();
    let (mut to, from) = commands.split();
    let (report_to, mut report_from) = reports.split();
    let machine = GrindingCell::<f64>::new(&setup.config).unwrap();
    let mut sup = Supervisor::new(machine, from, report_to, &jobs);
    sup.set_telemetry_decimation(0);
    let mut cell = Cell::<SAMPLES>::new(&setup.cell, 0.0, DX_M);
    let link = DeviceLink::new(&DeviceLinkConfig::PUBLISHED).unwrap();
    let mut state = DeviceLinkState::new();
    let mut hexapod = HexapodPort {
        sim: referenced_hexapod(s.start_x_mm),
        log: Vec::new(),
        period: 0,
    };
    let mut spindle = SpindlePort {
        sim: SimSpindle::new(),
        log: Vec::new(),
        period: 0,
    };
    let mut reading = cell.step(0.0, 0.0);
    let mut device_fault = None;
    let mut latched: Option<DeviceFault> = None;
    let mut fault = None;
    let mut start = usize::MAX;
    let mut last_path_mm = f64::NAN;
    let (mut outputs, mut readings) = (Vec::new(), Vec::new());
    let _ = to.enqueue(Command::Calibrate);
    for k in 0..s.periods {
        let inputs = GrindingInputs {
            ft_raw_v: raw_for(&setup.config, reading.wrench),
            device_fault: latched,
        };
        let out = sup.step(&inputs);
        while report_from.dequeue().is_some() {}
        let mode = sup.mode();
        if let (Mode::Fault(f), None) = (mode, fault) {
            fault = Some((k, f));
        }
        if mode == Mode::Calibrating && sup.machine().bias().is_some() {
            let _ = to.enqueue(Command::FinishCalibration(GrindingCalibration {
                eccentricity: setup.eccentricity,
            }));
        }
        if mode == Mode::Ready && s.pass && start == usize::MAX {
            let _ = to.enqueue(Command::LoadJob(JobSlot::First));
            let _ = to.enqueue(Command::Start);
            start = k + 1;
        }
        if let Some(after) = s.mute_spindle_after_s {
            if start.checked_add((after / TS) as usize) == Some(k) {
                spindle.sim.answering = false;
            }
        }
        // The slower task: every tick, the latest outputs to the devices.
        if k % TICK == 0 {
            hexapod.period = k;
            spindle.period = k;
            let demand = DeviceDemand::from_outputs(&out, matches!(mode, Mode::Fault(_)));
            match link.tick(&mut state, &demand, &mut hexapod, &mut spindle) {
                Ok(report) => last_path_mm = report.path_mm,
                Err(f) => {
                    device_fault.get_or_insert((k, f));
                    latched = Some(f);
                }
            }
        }
        // The plant: the hexapod carries the workpiece past the tool at its real speed.
        let before = hexapod.sim.position()[0];
        hexapod.sim.step(TS);
        let feed_m_s = (hexapod.sim.position()[0] - before) * 1e-3 / TS;
        reading = cell.step(out.piezo_m, feed_m_s);
        spindle
            .sim
            .advance(TS, reading.tangential_force_n * setup.cell.tool_radius_m);
        outputs.push(out);
        readings.push((reading, hexapod.sim.position()[0]));
    }
    Outcome {
        mode: sup.mode(),
        start,
        fault,
        device_fault,
        outputs,
        readings,
        last_path_mm,
        fed_m: sup.machine().telemetry().fed_m,
        hexapod,
        spindle,
    }
}

/// Asks the simulated converter, through the protocol, for its set speed.
fn duty_rpm(spindle: &mut SimSpindle) -> u32 {
    let mut buf = [0u8; 3];
    let request = SpindleRequest::DutyRpm;
    let reply = spindle.transact(request.encode(&mut buf).unwrap()).unwrap();
    match request.decode(&reply) {
        Ok(SpindleReading::Rpm(rpm)) => rpm,
        other => panic!("{other:?}"),
    }
}

/// After the fault period: every output safe (piezo retracted, feed 0, spindle off),
/// and no output anywhere NaN.
fn assert_safe_after(o: &Outcome, fault_period: usize) {
    assert!(o.outputs.iter().all(|x| x.piezo_m.is_finite()
        && x.hexapod_feed_m_s.is_finite()
        && x.spindle_rpm.is_finite()));
    for x in &o.outputs[fault_period..] {
        assert_eq!(
            (x.piezo_m, x.hexapod_feed_m_s, x.spindle_rpm),
            (0.0, 0.0, 0.0),
            "{x:?}"
        );
    }
}

/// G's pass with the tuned PID (`GrindingConfig::TUNED`: it reaches the force
/// within the first second).
fn pass_setup(length_m: f64) -> PassSetup {
    PassSetup {
        config: GrindingConfig::TUNED,
        ..seed_pass(ForceLawKind::Pid, 7.5, length_m)
    }
}

/// A 1 mm pass at 0.1 mm/s with the tuned PID at 7.5 N, the hexapod and the spindle
/// on their protocols: the pass grinds (true force above 5 N) and ends Ready with no
/// fault; the hexapod's X moved by the length the cell fed (to 2 µm: the link samples
/// the feed once a tick, 1 µm of path) at the set 0.1 mm/s (to 5 %), and the
/// workpiece went by under the tool as far; the spindle got set speed, start and set
/// speed 0 and stayed within 10 % of 25,000 rpm after its spin-up (no Speed fault);
/// no HLT was sent; then more than 30 s at rest with the drift watch on raise no
/// false alarm.
#[test]
fn a_pass_moves_the_hexapod_as_commanded() {
    let setup = pass_setup(1e-3);
    let o = run(&Scenario {
        setup,
        start_x_mm: 0.0,
        pass: true,
        mute_spindle_after_s: None,
        periods: 45_000,
    });
    assert_eq!(o.mode, Mode::Ready);
    assert_eq!(o.fault, None);
    assert_eq!(o.device_fault, None);
    let end = o
        .outputs
        .iter()
        .skip(o.start)
        .position(|x| x.hexapod_feed_m_s == 0.0 && x.spindle_rpm == 0.0)
        .map(|p| p + o.start)
        .unwrap();
    let moved_mm = o.hexapod.sim.position()[0];
    println!(
        "pass: {:.2} s, cell fed {:.4} mm, hexapod X moved {moved_mm:.4} mm (path {:.4} mm), spindle {:.0} rpm",
        (end - o.start) as f64 * TS,
        o.fed_m * 1e3,
        o.last_path_mm,
        o.spindle.sim.rpm()
    );
    assert!(o.fed_m >= 1e-3);
    assert!((moved_mm - o.fed_m * 1e3).abs() < 2e-3, "{moved_mm}");
    // In the steady part of the pass the hexapod moves at the set feed.
    let (a, b) = (o.start + 5_000, o.start + 8_000);
    let v = (o.readings[b].1 - o.readings[a].1) / ((b - a) as f64 * TS);
    assert!((v - 0.1).abs() < 0.005, "{v} mm/s");
    // The workpiece went by under the tool as far as the hexapod moved.
    let x_moved_mm = (o.readings[end].0.x_m - o.readings[o.start].0.x_m) * 1e3;
    assert!((x_moved_mm - moved_mm).abs() < 2e-3, "{x_moved_mm}");
    let peak = o.readings[o.start..end]
        .iter()
        .map(|(r, _)| r.normal_force_n)
        .fold(0.0, f64::max);
    println!("largest true normal force {peak:.2} N");
    assert!(peak > 5.0, "{peak}");
    // The spindle got G's set speed and start, and was set to 0 at the end.
    let frames: Vec<&Vec<u8>> = o
        .spindle
        .log
        .iter()
        .filter(|(_, f)| f[0] != 0x43)
        .map(|(_, f)| f)
        .collect();
    assert_eq!(
        frames,
        [
            &vec![0x01, 0, 0],
            &vec![0x01, 0xC4, 0x09],
            &vec![0x24],
            &vec![0x01, 0, 0]
        ]
    );
    // No HLT: nothing faulted.
    assert!(!o.hexapod.log.iter().any(|(_, c)| c == "HLT"));
    assert!((o.outputs.len() - end) as f64 * TS > 30.0);
}

/// The pass runs into the hexapod's X travel (22.5 mm, G app. A) 0.3 mm after it
/// starts: the controller refuses that MOV (GCS error 7), the tick reading ERR? faults
/// with `Hexapod(Controller(7))` in the tick whose target first passes 22.5 mm, the
/// cell goes safe in the next period, HLT and the spindle's set speed 0 go out in
/// the same tick, the platform stands and the spindle spins down.
#[test]
fn a_gcs_error_mid_pass_stops_the_cell() {
    let o = run(&Scenario {
        setup: pass_setup(1e-3),
        start_x_mm: 22.2,
        pass: true,
        mute_spindle_after_s: None,
        periods: 12_000,
    });
    let (tick, device) = o.device_fault.unwrap();
    assert_eq!(
        device,
        DeviceFault::Hexapod(HexapodFault::Controller(gcs::code::POS_OUT_OF_LIMITS))
    );
    let (period, fault) = o.fault.unwrap();
    assert_eq!(
        fault,
        GrindingFault::Hexapod(HexapodFault::Controller(gcs::code::POS_OUT_OF_LIMITS))
    );
    // The tick before was the last inside the travel: its path plus one tick's feed
    // (0.1 mm/s × 10 ms = 1 µm) leaves it.
    assert!(o.last_path_mm <= 22.5 && o.last_path_mm + 0.001 + 1e-6 > 22.5);
    assert_eq!(period, tick + 1);
    println!(
        "GCS error 7 at tick {} ({:.2} s into the pass), path {:.4} mm; cell fault at period {period}",
        tick / TICK,
        (tick - o.start) as f64 * TS,
        o.last_path_mm
    );
    assert_safe_after(&o, period);
    let sent_in_tick: Vec<&str> = o
        .hexapod
        .log
        .iter()
        .filter(|(p, _)| *p == tick)
        .map(|(_, c)| c.as_str())
        .collect();
    assert_eq!(
        &sent_in_tick[sent_in_tick.len() - 2..],
        ["HLT", "ERR?"],
        "{sent_in_tick:?}"
    );
    assert!(o
        .spindle
        .log
        .iter()
        .any(|(p, f)| *p == tick && f == &[0x01, 0, 0]));
    let mut sim = o.spindle.sim.clone();
    assert_eq!(duty_rpm(&mut sim), 0);
    // The platform stands from the fault on; the spindle spins down.
    let x_at_fault = o.readings[tick].1;
    assert!(o.readings[tick..].iter().all(|(_, x)| *x == x_at_fault));
    assert!(o.spindle.sim.rpm() < 0.5 * 25_000.0);
}

/// The converter goes silent 3 s into the pass: the fifth silent tick (50 ms, the
/// configured five) faults `Spindle(Silent { ticks: 5 })`, the cell goes safe the
/// next period, and the hexapod gets its HLT in that tick.
#[test]
fn a_silent_spindle_stops_the_cell() {
    let o = run(&Scenario {
        setup: pass_setup(1e-3),
        start_x_mm: 0.0,
        pass: true,
        mute_spindle_after_s: Some(3.0),
        periods: 10_000,
    });
    let muted = o.start + 3_000;
    let (tick, device) = o.device_fault.unwrap();
    assert_eq!(
        device,
        DeviceFault::Spindle(SpindleFault::Silent { ticks: 5 })
    );
    // The first tick at or after the mute is silent tick 1; the fifth faults.
    let first_silent = muted.div_ceil(TICK) * TICK;
    assert_eq!(tick, first_silent + 4 * TICK);
    let (period, fault) = o.fault.unwrap();
    assert_eq!(
        fault,
        GrindingFault::Spindle(SpindleFault::Silent { ticks: 5 })
    );
    assert_eq!(period, tick + 1);
    println!(
        "spindle muted at period {muted}, fault at tick {} ({} ms after the mute), cell safe at period {period}",
        tick / TICK,
        tick - muted
    );
    assert_safe_after(&o, period);
    assert!(o.hexapod.log.iter().any(|(p, c)| *p == tick && c == "HLT"));
    let x_at_fault = o.readings[tick].1;
    assert!(o.readings[tick..].iter().all(|(_, x)| *x == x_at_fault));
}

/// A bias that drifts along Fy (the normal direction on the flat) from 1 s after the
/// start, with the cell calibrated and at rest: the drift watch faults `BiasDrift`
/// on Fy at the end of the first window whose mean passes the bound of 0.294 N
/// (6σ_d, σ_d = 0.894 N · √(1/1000 + 1/500) = 0.049 N: a 1 s mean against a 0.5 s
/// capture under G 5.2's 0.8 N²). The window mean is the drift since the capture
/// plus the capture's and the window's noise, so the drift (the normal force's
/// error it causes) at detection is at most the bound, 1.5 windows of drift and 3σ_d
/// of noise (0.591 N at 0.1 N/s, 0.456 N at 0.01 N/s), and more than the bound less
/// 3σ_d (0.147 N: the watch does not fire early); the fault comes at a window's end.
#[test]
fn a_drifting_bias_faults_before_the_force_error_grows() {
    let sigma_d = 0.894 * (1.0f64 / 1000.0 + 1.0 / 500.0).sqrt();
    let bound = 6.0 * sigma_d;
    for rate in [0.1, 0.01] {
        let limit = bound + 1.5 * rate + 3.0 * sigma_d;
        let mut setup = pass_setup(1e-3);
        setup.cell = CellConfig {
            bias_drift_per_s: [0.0, rate, 0.0, 0.0, 0.0, 0.0],
            bias_drift_start_s: 1.0,
            ..setup.cell
        };
        let o = run(&Scenario {
            setup,
            start_x_mm: 0.0,
            pass: false,
            mute_spindle_after_s: None,
            periods: 60_000,
        });
        let (period, fault) = o.fault.unwrap();
        let GrindingFault::BiasDrift(drift) = fault else {
            panic!("{fault:?}");
        };
        assert_eq!(drift.component, 1);
        assert!((f64::from(drift.bound_n) - 0.2938).abs() < 1e-3);
        let drift_n = rate * ((period + 1) as f64 * TS - 1.0);
        println!(
            "drift {rate} N/s: BiasDrift on Fy at {:.3} s, window mean {:.3} N, bound {:.3} N, force error at detection {drift_n:.3} N (limit {limit:.3} N)",
            period as f64 * TS,
            drift.mean_n,
            drift.bound_n
        );
        assert!(drift_n <= limit, "{drift_n}");
        assert!(drift_n > bound - 3.0 * sigma_d, "{drift_n}");
        // The capture's 500 periods end at period 499; 500 periods of settling, then
        // windows of 1000: each ends at a period ending in 999.
        assert_eq!(period % 1000, 999, "{period}");
        assert_safe_after(&o, period);
        assert_eq!(o.device_fault, None);
    }
}
