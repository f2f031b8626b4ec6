//! The Keops delta slave as a machine app: the operator calibrates the three carriages
//! together (imperfect Hall sensors, different on each carriage), plans a square,
//! loads and starts it through the supervisor's queues; the Lagrangian plant with
//! gravity is read back only through the Hall sensors.

use hal_mock::hall_sensor::ChannelFault;
use kerf::app::axis::AxisFault;
use kerf::app::joints::JointFault;
use kerf::machines::delta_slave::DeltaFault;
use kerf::sensing::hall::HallFault;
use kerf_sim::scenario::{MAX_ERROR_BOUND_M, RMS_ERROR_BOUND_M};
use kerf_sim::slave::{run_slave, run_slave_job, SlaveOutcome, SlaveScenario};

fn square<T: kerf::Float>() -> SlaveOutcome {
    let scenario = SlaveScenario::square();
    let outcome = run_slave::<T>(&scenario, 0, |_, _| {}).unwrap();
    println!(
        "Keops slave, 20 mm square at 40 mm/s mean ({} periods on the lines): effector error RMS {:.3} µm, max {:.3} µm; max ‖Jx‖∞ {:.2}",
        outcome.periods,
        outcome.rms_effector_error_m * 1e6,
        outcome.max_effector_error_m * 1e6,
        outcome.max_jacobian_gain
    );
    outcome
}

/// Each carriage loop meets the single-axis bounds (its motion is slower than that
/// scenario's; gravity and the arms' coupling are left to the DOB); a joint error
/// vector e moves the effector by at most ‖Jx‖∞ |e|∞ per axis, √3 of that in norm.
fn check(outcome: &SlaveOutcome) {
    let scenario = SlaveScenario::square();
    let expected = (4.0 * scenario.side_s / scenario.machine.joints.period_s) as u32;
    assert_eq!(outcome.periods, expected, "every period of the four sides");
    assert!(outcome.fault.is_none(), "{outcome:?}");
    assert_eq!(outcome.late_periods, 0);
    let gain = 3f64.sqrt() * outcome.max_jacobian_gain;
    assert!(
        outcome.rms_effector_error_m < gain * RMS_ERROR_BOUND_M,
        "{outcome:?}"
    );
    assert!(
        outcome.max_effector_error_m < gain * MAX_ERROR_BOUND_M,
        "{outcome:?}"
    );
}

#[test]
fn keops_slave_calibrates_and_cuts_a_square_in_f32() {
    check(&square::<f32>());
}

#[test]
fn keops_slave_calibrates_and_cuts_a_square_in_f64() {
    check(&square::<f64>());
}

/// An open wire on carriage 2 half-way through: the machine names the carriage and the
/// channel, and all three forces are zero from that period on.
#[test]
fn a_broken_sensor_on_one_carriage_stops_all_three() {
    let mut scenario = SlaveScenario::square();
    scenario.sensor_fault = Some((1.0, 2, ChannelFault::OpenWire(1)));
    let outcome = run_slave::<f32>(&scenario, 100, |_, _| {}).unwrap();
    assert_eq!(
        outcome.fault,
        Some(DeltaFault::Joint(JointFault {
            axis: 2,
            fault: AxisFault::Sensor(HallFault::AdcRail(1)),
        })),
        "{outcome:?}"
    );
    let at = outcome.fault_at_s.unwrap();
    assert!((at - 1.0).abs() < 1.5e-4, "{at}");
    assert_eq!(outcome.force_after_fault_n, 0.0);
}

/// A contour job's duration is the periods the machine runs it, to the period: the
/// approach, the ramps and the cruise, the approach's hand-over period and the
/// preview window's drain (counted here period by period as the supervisor's mode).
#[test]
fn a_contour_jobs_duration_is_the_periods_it_runs() {
    use kerf::app::supervisor::Mode;
    use kerf::machines::delta_slave::{ContourLaw, DeltaSlaveConfig};
    use kerf_sim::contour::octagon_job;
    let mut scenario = SlaveScenario::square();
    scenario.sensors = [hal_mock::hall_sensor::HallSensorParams::LM1247_16BIT; 3];
    scenario.stored_nominal_calibration = true;
    scenario.substeps = 1;
    for laps in [0.25, 1.0] {
        let job = octagon_job(&DeltaSlaveConfig::KEOPS, laps, 30, ContourLaw::Contouring).unwrap();
        let planned = job.duration_s();
        let mut running = 0u32;
        run_slave_job::<f64>(&scenario, job, planned + 0.5, 0, |period, _| {
            running += u32::from(period.mode == Mode::Running);
        })
        .unwrap();
        let ran = f64::from(running) * 1e-4;
        println!("{laps} laps: planned {planned:.4} s, ran {running} periods");
        assert!(
            (ran - planned).abs() < 1e-9,
            "planned {planned} s, ran {ran} s"
        );
    }
}
