//! Closed-loop scenarios of one LM1247 axis: Hall decode → DOB + PD → simulated plant.

use hal_mock::hall_sensor::{ChannelFault, HallSensorParams};
use host_tests::fixed_point::{axis_scenarios, joint_scenarios, with_open_wire};
use kerf::app::axis::AxisFault;
use kerf::app::jobs::JobSlots;
use kerf::sensing::hall::{HallDecoder, HallFault};
use kerf::{Real, Q31_32, Q6_25};
use kerf_sim::scenario::{
    run, run_into, run_with, Motion, Outcome, Scenario, MAX_ERROR_BOUND_M, RMS_ERROR_BOUND_M,
};

fn report(name: &str, o: &kerf_sim::scenario::Outcome) {
    println!(
        "{name:>4}: periods {} rms {:.3} um max {:.3} um  peaks: force {:.3} N dist {:.3} N vel {:.3} m/s pos {:.4} m",
        o.periods,
        o.rms_error_m * 1e6,
        o.max_error_m * 1e6,
        o.peak_force_n,
        o.peak_disturbance_n,
        o.peak_velocity_m_s,
        o.peak_position_m
    );
}

#[test]
fn tracking_profile_meets_bounds_in_every_scalar() {
    let s = Scenario::TRACKING;
    let r64 = run::<f64>(&s).unwrap();
    let r32 = run::<f32>(&s).unwrap();
    let rq = run::<Q31_32>(&s).unwrap();
    let r25 = run::<Q6_25>(&s).unwrap();
    report("f64", &r64);
    report("f32", &r32);
    report("Q31_32", &rq);
    report("Q6_25", &r25);
    for o in [&r64, &r32, &rq, &r25] {
        assert_eq!(o.periods, 10_000);
        assert!(o.fault_period.is_none());
        assert!(o.rms_error_m < RMS_ERROR_BOUND_M, "{o:?}");
        assert!(o.max_error_m < MAX_ERROR_BOUND_M, "{o:?}");
    }
}

/// A 1 N load step while holding position. The PD alone (DOB as monitor only) settles
/// at e = F/(An·Kp) = 1 N / (0.071 kg · 63165 s⁻²) = 223 µm and stays there; with the
/// DOB the residual disturbance decays as e^(−g t) (g = 2π·150 rad/s, 1.06 ms time
/// constant) and the error returns below 5 µm — 25× the 0.18 µm noise floor — within
/// 20 ms (the PD's double pole at 2π·40 rad/s, 4 ms, dominates that tail).
#[test]
fn load_step_is_rejected_with_dob_and_not_without() {
    const STEP_AT_S: f64 = 0.2;
    const SETTLE_BOUND_M: f64 = 5e-6;
    const SETTLE_TIME_S: f64 = 0.02;
    let mut s = Scenario::TRACKING;
    s.motion = Motion::Hold;
    s.periods = 5000;
    s.load_step = Some((STEP_AT_S, 1.0));
    let window = Outcome::with_window(STEP_AT_S + SETTLE_TIME_S, SETTLE_BOUND_M);
    let with = run_into::<f32>(&s, window).unwrap();
    s.machine.axis.dob.compensate = false;
    let without = run_into::<f32>(&s, window).unwrap();
    report("DOB", &with);
    report("PD", &without);
    println!(
        "load step: with DOB peak {:.1} um, last above {} um at {:.4} s; without DOB error after settling time {:.1} um",
        with.max_error_m * 1e6,
        SETTLE_BOUND_M * 1e6,
        with.last_violation_s,
        without.max_error_after_m * 1e6
    );
    assert!(
        with.last_violation_s < STEP_AT_S + SETTLE_TIME_S,
        "{with:?}"
    );
    assert!(
        with.last_violation_s >= STEP_AT_S,
        "the step must disturb the axis: {with:?}"
    );
    assert!(with.max_error_after_m < SETTLE_BOUND_M);
    // Without the DOB the error stays near the PD's static deflection.
    assert!(without.max_error_after_m > 150e-6, "{without:?}");
    assert!(without.last_violation_s > 0.49, "{without:?}");
}

/// Sensor faults mid-move: the decoder names the fault in the period it becomes
/// detectable and the loop commands exactly zero force from then on.
#[test]
fn sensor_faults_latch_zero_force() {
    let mut s = Scenario::TRACKING;
    // Open wire on channel 0 at 0.3 s: a rail reading, caught in that very period.
    s.sensor_fault = Some((0.3, ChannelFault::OpenWire(0)));
    for o in [
        run::<f32>(&s).unwrap(),
        run::<f64>(&s).unwrap(),
        run::<Q31_32>(&s).unwrap(),
        run::<Q6_25>(&s).unwrap(),
    ] {
        assert_eq!(o.fault_period, Some(3000), "{o:?}");
        assert_eq!(o.fault, Some(AxisFault::Sensor(HallFault::AdcRail(0))));
        assert_eq!(o.force_after_fault_n, 0.0);
    }
    // Channel 1 jumps to mid-scale: the channels no longer sum to zero, same period.
    s.sensor_fault = Some((0.3, ChannelFault::Stuck(1, 32768)));
    let o = run::<f32>(&s).unwrap();
    assert_eq!(
        (o.fault_period, o.fault),
        (
            Some(3000),
            Some(AxisFault::Sensor(HallFault::ResidualOutOfBand))
        ),
        "{o:?}"
    );
    // Channel 1 freezes at its last value at 0.3 s while the axis moves at ~0.14 m/s
    // (2.8° of phase per ms): caught once the true signal has moved 0.5 A (the sum
    // limit) away from the frozen value, which takes at most 60° of travel (21 ms),
    // and named as the stuck channel because it stopped changing.
    s.sensor_fault = Some((0.3, ChannelFault::Frozen(1)));
    let o = run::<f32>(&s).unwrap();
    let period = o.fault_period.expect("the stuck channel must be detected");
    assert!((3000..3210).contains(&period), "{o:?}");
    assert_eq!(
        o.fault,
        Some(AxisFault::Sensor(HallFault::StuckChannel(1))),
        "{o:?}"
    );
    assert_eq!(o.force_after_fault_n, 0.0);
    println!(
        "stuck channel detected {} periods after it froze",
        period - 3000
    );
}

/// The scenarios the fixed-point formats are checked over (`host_tests::fixed_point`),
/// and the single axis and the joint each with an open wire mid-move.
fn format_scenarios() -> Vec<(&'static str, Scenario)> {
    let [tracking, loaded, hold] = axis_scenarios();
    let [joint, joint_hold] = joint_scenarios();
    vec![
        tracking,
        loaded,
        hold,
        ("tracking, open wire", with_open_wire(tracking.1)),
        joint,
        joint_hold,
        ("Keops joint tracking, open wire", with_open_wire(joint.1)),
    ]
}

/// Every recorded signal of the fixed-point loops stays inside the design range the
/// table in `kerf::control` gives it, which is inside the Q6.25 format (±64): a
/// signal that saturated would read at the format's end, far beyond its range. The
/// Q31.32 loop is checked against the same ranges, and both against the f64 run's
/// peaks, which no format limits.
#[test]
fn fixed_point_signals_stay_in_their_formats() {
    const POSITION_M: f64 = 0.1;
    const VELOCITY_M_S: f64 = 2.0;
    const FORCE_N: f64 = 3.6;
    // 3.6 N on the 71 g nominal mass: beyond it the force clamps.
    const ACCELERATION_M_S2: f64 = 3.6 / 0.071;
    let format_limit = Q6_25::MAX.to_f64();
    for (name, s) in format_scenarios() {
        let reference = run::<f64>(&s).unwrap();
        for (scalar, o) in [
            ("Q6_25", run::<Q6_25>(&s).unwrap()),
            ("Q31_32", run::<Q31_32>(&s).unwrap()),
        ] {
            println!(
                "{name} <{scalar}>: peaks position {:.4} m velocity {:.3} m/s acceleration {:.2} m/s² force {:.3} N disturbance {:.3} N (f64: {:.4} {:.3} {:.2} {:.3} {:.3})",
                o.peak_position_m,
                o.peak_velocity_m_s,
                o.peak_acceleration_m_s2,
                o.peak_force_n,
                o.peak_disturbance_n,
                reference.peak_position_m,
                reference.peak_velocity_m_s,
                reference.peak_acceleration_m_s2,
                reference.peak_force_n,
                reference.peak_disturbance_n,
            );
            assert_eq!(o.fault, reference.fault, "{name} <{scalar}>");
            for (peak, range, f64_peak) in [
                (o.peak_position_m, POSITION_M, reference.peak_position_m),
                (
                    o.peak_velocity_m_s,
                    VELOCITY_M_S,
                    reference.peak_velocity_m_s,
                ),
                (
                    o.peak_acceleration_m_s2,
                    ACCELERATION_M_S2,
                    reference.peak_acceleration_m_s2,
                ),
                (o.peak_force_n, FORCE_N, reference.peak_force_n),
                (o.peak_disturbance_n, FORCE_N, reference.peak_disturbance_n),
            ] {
                assert!(range < format_limit);
                assert!(peak < range, "{name} <{scalar}>: {peak} beyond {range}");
                assert!(f64_peak < range, "{name} <f64>: {f64_peak} beyond {range}");
            }
        }
    }
}

/// The firmware's sensing flow on imperfect sensors (offsets ±3 % FS, gains ±5 %,
/// mounting errors to 1.5°, 2 % third harmonic, 4 LSB noise): calibration sweep in
/// closed loop with the nominal decoder, fit, then the tracking profile with the
/// calibrated decoder and its correction table meets the same bounds as ideal sensors;
/// with the nominal decoder it does not (its 300 µm periodic error is fed back).
#[test]
fn self_calibration_then_tracking_on_imperfect_sensors() {
    let mut s = Scenario::TRACKING;
    s.sensor = HallSensorParams::lm1247_imperfect(16, 4.0);
    let uncalibrated = run::<f32>(&s).unwrap();
    let mut calibrated = s;
    calibrated.calibrate = true;
    let (tracked, fit) = run_with::<f32>(
        &calibrated,
        Outcome::with_window(f64::INFINITY, f64::INFINITY),
        |_| {},
    )
    .unwrap();
    let fit = fit.expect("the scenario calibrates");
    report("raw", &uncalibrated);
    report("cal", &tracked);
    println!("fitted model: {:.4?}", fit.model);
    assert!(
        uncalibrated.max_error_m > 10.0 * MAX_ERROR_BOUND_M,
        "{uncalibrated:?}"
    );
    assert!(tracked.fault_period.is_none());
    assert!(tracked.rms_error_m < RMS_ERROR_BOUND_M, "{tracked:?}");
    assert!(tracked.max_error_m < MAX_ERROR_BOUND_M, "{tracked:?}");

    // With the healthy-residual table the residual check is tight: its limit follows
    // from the 20 µm fault-error budget (about 0.5 % of A for these sensors), so a
    // channel that freezes mid-move is caught once it is about 0.006 A off: within
    // 22 periods at this speed (4.9 mrad per period) even when it froze at its peak
    // (1 − cos nδ = 0.006), against 157 with the nominal 0.5 A limit (above).
    let config = s.machine.hall[0].with_self_calibration(&fit);
    let amplitude = config.amplitude_counts;
    let limit = HallDecoder::new(&config).unwrap().residual_limit_counts() / amplitude;
    println!(
        "residual limit {:.4} A (peak checked residual during calibration {:.1} counts)",
        limit, fit.peak_sum_residual_counts
    );
    assert!(limit < 0.01, "{limit}");
    let mut frozen = calibrated;
    frozen.sensor_fault = Some((0.3, ChannelFault::Frozen(1)));
    let o = run::<f32>(&frozen).unwrap();
    let period = o.fault_period.expect("the frozen channel must be detected");
    println!(
        "calibrated axis: frozen channel detected {} periods after it froze",
        period - 3000
    );
    assert_eq!(
        o.fault,
        Some(AxisFault::Sensor(HallFault::StuckChannel(1))),
        "{o:?}"
    );
    assert!((3000..3030).contains(&period), "{o:?}");
    assert_eq!(o.force_after_fault_n, 0.0);
}

/// The host-only trace writes one CSV line per period that parses back to the run.
#[test]
fn trace_writes_the_run_as_csv() {
    let mut s = Scenario::TRACKING;
    s.periods = 500;
    s.sensor_fault = Some((0.04, ChannelFault::OpenWire(2)));
    let mut recorder = kerf_sim::trace::Recorder::new();
    run_with::<f32>(&s, Outcome::default(), |p| {
        if p.in_job() {
            recorder.push(*p)
        }
    })
    .unwrap();
    let mut csv = Vec::new();
    recorder.write_csv(&mut csv).unwrap();
    let text = String::from_utf8(csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 501);
    assert!(lines[0].starts_with("t_s,error_m"));
    let row = |k: usize| lines[k + 1].split(',').collect::<Vec<_>>();
    assert_eq!(
        row(100)[0].parse::<f64>().unwrap(),
        recorder.periods()[100].t_s
    );
    assert_eq!(
        row(100)[6].parse::<u16>().unwrap(),
        recorder.periods()[100].hall_counts[0]
    );
    assert_eq!(row(399)[9], "");
    assert_eq!(row(400)[9], "Sensor(AdcRail(2))");
}

/// Gains changed through the command queue in the middle of the 30 mm move, at
/// 0.14 m/s: PD bandwidth 40 → 52 Hz (Kp ×1.69, Kd ×1.3), DOB bandwidth 150 → 100 Hz.
///
/// Stated bound on the force step at the change. The state (position, velocity,
/// disturbance estimate) is kept, so the command An (q̈ref + Kp e + Kd ė) + F̂dis
/// changes by An (ΔKp e + ΔKd ė) in the PD part, and the DOB's per-period change
/// g Ts (innovation) scales by g'/g ≤ 1. So
/// |ΔF| ≤ max(1, g'/g) · (largest step of the 200 periods before) + An (|ΔKp| |e| + |ΔKd| |ė|)
/// with e, ė what the law saw at the change. A restart (fresh state with the new law,
/// as a config reload that rebuilds the loop would do) must break the same bound.
#[test]
fn gain_change_mid_profile_is_bumpless() {
    use heapless::spsc::Queue;
    use kerf::app::axis::{AxisConfig, AxisLaw, AxisState, HallAxis};
    use kerf::app::joints::Joints;
    use kerf::app::supervisor::{Command, Machine, Mode, Report};
    use kerf_sim::scenario::{Rig, COMMAND_CAPACITY, REPORT_CAPACITY, TS_S};

    type M = Joints<f64, 1>;
    let scenario = Scenario::TRACKING;
    let jobs = JobSlots::default();
    let mut commands = Queue::<Command<M>, COMMAND_CAPACITY>::new();
    let mut reports = Queue::<Report<M>, REPORT_CAPACITY>::new();
    let (mut send, from_sender) = commands.split();
    let (to_operator, mut receive) = reports.split();
    let mut rig = Rig::<f64>::new(&scenario, from_sender, to_operator, &jobs).unwrap();
    let mut operator = scenario.operator::<f64>().unwrap();
    operator.start(&mut send, &jobs);

    let old = AxisConfig::LM1247_SLAVE;
    let mut new = old;
    let w = 2.0 * std::f64::consts::PI * 52.0;
    new.pd.kp_per_s2 = w * w;
    new.pd.kd_per_s = 2.0 * w;
    new.dob.bandwidth_rad_s = 2.0 * std::f64::consts::PI * 100.0;
    let new_law = AxisLaw::<f64>::new(&new, TS_S).unwrap();

    const CHANGE_AT_S: f64 = 0.25;
    let mut forces = Vec::new();
    let mut change = None;
    let mut outcome = Outcome::default();
    while outcome.periods < scenario.periods {
        let machine_before = rig.supervisor().machine().clone();
        let p = rig.step();
        operator.poll(&mut receive, &mut send, &jobs);
        if !p.in_job() {
            continue;
        }
        outcome.add(&p);
        forces.push(p.force_n);
        if change.is_some_and(|(n, _, _)| n + 1 == forces.len()) {
            // The period the new law first ran in: what it saw.
            let machine = rig.supervisor().machine();
            let r = machine.reference()[0];
            let out = machine.telemetry().axes[0];
            let e = r.position - out.position_m;
            let e_dot = r.velocity - out.velocity_m_s;
            // The restart: the same period from a fresh state (homed where the axis
            // was, nothing observed yet) with the new law and the same Hall counts.
            let before = machine_before.axes()[0];
            let mut fresh = AxisState::<f64>::homed_at(before.position_m());
            fresh.engage();
            let sensor = HallAxis::<f64>::new(&scenario.machine.hall[0]).unwrap();
            let restart = new_law.step(&sensor, &mut fresh, p.hall_counts, &r);
            change = change.map(|(n, _, _)| (n, (e, e_dot), restart.force_n));
        }
        if p.t_s >= CHANGE_AT_S && change.is_none() {
            // Picked up at the start of the next period.
            assert!(send.enqueue(Command::ChangeSettings(new_law)).is_ok());
            change = Some((forces.len(), (0.0, 0.0), 0.0));
        }
    }
    assert!(outcome.fault_period.is_none());
    assert_eq!(
        rig.supervisor().mode(),
        Mode::Ready,
        "the profile ran to its end"
    );
    let (n, (e, e_dot), restart_force) = change.unwrap();
    let step = |k: usize| (forces[k] - forces[k - 1]).abs();
    let normal = (n - 200..n).map(step).fold(0.0, f64::max);
    let an = old.dob.nominal_mass_kg;
    let pd_term = an
        * ((new.pd.kp_per_s2 - old.pd.kp_per_s2).abs() * e.abs()
            + (new.pd.kd_per_s - old.pd.kd_per_s).abs() * e_dot.abs());
    let g_ratio = (new.dob.bandwidth_rad_s / old.dob.bandwidth_rad_s).max(1.0);
    let bound = g_ratio * normal + pd_term;
    let restart_step = (restart_force - forces[n - 1]).abs();
    println!(
        "gain change at {:.4} s: force step {:.3} mN (bound {:.3} mN = {:.3} steady + {:.3} PD); a restart would step {:.1} mN",
        n as f64 * TS_S,
        step(n) * 1e3,
        bound * 1e3,
        normal * 1e3,
        pd_term * 1e3,
        restart_step * 1e3
    );
    assert!(step(n) <= bound, "{} > {bound}", step(n));
    assert!(
        restart_step > bound,
        "the bound does not tell a restart apart"
    );
    // The tracking still meets the scenario's bounds with the new gains.
    assert!(outcome.rms_error_m < RMS_ERROR_BOUND_M, "{outcome:?}");
    assert!(outcome.max_error_m < MAX_ERROR_BOUND_M, "{outcome:?}");
}
