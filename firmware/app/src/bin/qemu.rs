//! QEMU smoke run: the single-axis firmware (Hall decode → velocity observer → PD →
//! DOB, f32) against the simulated LM1247 axis with imperfect Hall sensors (offsets,
//! gains, mounting errors, third harmonic, noise), at 10 kHz.
//!
//! The machine app (`Joints<f32, 1>` under the supervisor) and the simulated axis are
//! the scenario's `Rig`; the scenario's `Operator` is the slower context: it sends
//! `Calibrate`, fits the streamed samples, sends the decoders, loads the 1 s tracking
//! profile and starts it, all through the command queue. The run prints the fit and a
//! one-line summary and exits non-zero when a bound is missed or the axis faulted.
#![no_std]
#![no_main]

use cortex_m_semihosting::hprintln;
use embassy_executor::Spawner;
use hal_mock::hall_sensor::HallSensorParams;
use heapless::spsc::Queue;
use kerf::app::joints::Joints;
use kerf::app::supervisor::{Command, Report};
use kerf_app::exit;
use kerf_sim::scenario::{
    OperatorState, Outcome, Rig, Scenario, COMMAND_CAPACITY, MAX_ERROR_BOUND_M, REPORT_CAPACITY,
    RMS_ERROR_BOUND_M, TS_S,
};

type Machine = Joints<f32, 1>;

#[embassy_executor::task]
async fn smoke(scenario: Scenario) {
    let (Some(commands), Some(reports)) = (
        cortex_m::singleton!(: Queue<Command<Machine>, COMMAND_CAPACITY> = Queue::new()),
        cortex_m::singleton!(: Queue<Report<Machine>, REPORT_CAPACITY> = Queue::new()),
    ) else {
        exit(false)
    };
    let (mut send, from_sender) = commands.split();
    let (to_operator, mut receive) = reports.split();
    let mut rig = match Rig::<f32>::new(&scenario, from_sender, to_operator) {
        Ok(rig) => rig,
        Err(e) => {
            hprintln!("kerf qemu smoke: configuration rejected: {} -> FAIL", e);
            exit(false)
        }
    };
    let mut operator = match scenario.operator::<f32>() {
        Ok(operator) => operator,
        Err(e) => {
            hprintln!("kerf qemu smoke: configuration rejected: {} -> FAIL", e);
            exit(false)
        }
    };
    operator.start(&mut send);
    let mut outcome = Outcome::with_window(f64::INFINITY, f64::INFINITY);
    let mut printed_fit = false;
    let limit = 4 * scenario.periods + 20_000;
    let mut state = OperatorState::Calibrating;
    for _ in 0..limit {
        let period = rig.step();
        if period.in_job() {
            outcome.add(&period);
        }
        state = operator.poll(&mut receive, &mut send);
        if let (Some(fit), false) = (operator.fit(), printed_fit) {
            printed_fit = true;
            let c = &fit.model.channels;
            hprintln!(
                "kerf qemu smoke: calibrated: offsets {:.0} {:.0} {:.0} counts, gains {:.0} {:.0} {:.0} counts, third harmonic {:.2} {:.2} {:.2} %",
                c[0].offset_counts,
                c[1].offset_counts,
                c[2].offset_counts,
                c[0].amplitude_counts,
                c[1].amplitude_counts,
                c[2].amplitude_counts,
                c[0].harmonic3 * 100.0,
                c[1].harmonic3 * 100.0,
                c[2].harmonic3 * 100.0
            );
        }
        match state {
            OperatorState::Finished | OperatorState::Failed(_) => break,
            _ => {}
        }
        if outcome.periods >= scenario.periods {
            break;
        }
    }
    let ok = state == OperatorState::Finished
        && outcome.fault_period.is_none()
        && outcome.rms_error_m < RMS_ERROR_BOUND_M
        && outcome.max_error_m < MAX_ERROR_BOUND_M;
    hprintln!(
        "kerf qemu smoke: periods {} ({} s at 10 kHz) rms error {:.3} um (bound {:.1}) max error {:.3} um (bound {:.1}) peak force {:.3} N fault {} -> {}",
        outcome.periods,
        f64::from(outcome.periods) * TS_S,
        outcome.rms_error_m * 1e6,
        RMS_ERROR_BOUND_M * 1e6,
        outcome.max_error_m * 1e6,
        MAX_ERROR_BOUND_M * 1e6,
        outcome.peak_force_n,
        outcome.fault_period.is_some(),
        if ok { "PASS" } else { "FAIL" }
    );
    exit(ok)
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let mut scenario = Scenario::TRACKING;
    scenario.sensor = HallSensorParams::lm1247_imperfect(16, 4.0);
    scenario.calibrate = true;
    #[cfg(feature = "break-gain")]
    {
        // Deliberately detuned: 1 % of the position gain must miss the bounds.
        scenario.machine.axis.pd.kp_per_s2 *= 0.01;
    }
    spawner.spawn(smoke(scenario).unwrap());
}
