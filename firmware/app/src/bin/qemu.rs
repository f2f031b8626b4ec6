//! QEMU smoke run: the single-axis firmware loop (Hall decode → velocity observer →
//! PD → DOB, f32) against the simulated LM1247 axis for 1 s at 10 kHz.
//!
//! Two embassy tasks: `control` steps the loop and the plant once per period and hands
//! each period's record to `supervisor` over a channel; `supervisor` keeps the error
//! statistics, prints a one-line summary and exits non-zero when a bound is missed or
//! the axis faulted.
#![no_std]
#![no_main]

use cortex_m_semihosting::hprintln;
use embassy_executor::Spawner;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use hal_mock::scenario::{
    Outcome, Period, Scenario, Simulation, MAX_ERROR_BOUND_M, RMS_ERROR_BOUND_M,
};
use kerf_app::exit;

static PERIODS: Channel<CriticalSectionRawMutex, Period, 16> = Channel::new();

#[embassy_executor::task]
async fn control(mut simulation: Simulation<f32>) {
    while let Some(period) = simulation.step() {
        PERIODS.send(period).await;
    }
}

#[embassy_executor::task]
async fn supervisor(periods: u32) {
    let mut outcome = Outcome::with_window(f64::INFINITY, f64::INFINITY);
    for _ in 0..periods {
        let period = PERIODS.receive().await;
        outcome.add(&period);
    }
    let ok = outcome.fault_period.is_none()
        && outcome.rms_error_m < RMS_ERROR_BOUND_M
        && outcome.max_error_m < MAX_ERROR_BOUND_M;
    hprintln!(
        "kerf qemu smoke: periods {} ({} s at 10 kHz) rms error {:.3} um (bound {:.1}) max error {:.3} um (bound {:.1}) peak force {:.3} N fault {} -> {}",
        outcome.periods,
        f64::from(outcome.periods) * hal_mock::scenario::TS_S,
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
    #[allow(unused_mut)]
    let mut scenario = Scenario::TRACKING;
    #[cfg(feature = "break-gain")]
    {
        // Deliberately detuned: 1 % of the position gain must miss the bounds.
        scenario.axis.pd.kp_per_s2 *= 0.01;
    }
    let simulation = match Simulation::<f32>::new(&scenario) {
        Ok(s) => s,
        Err(e) => {
            hprintln!("configuration rejected: {:?}", e);
            exit(false)
        }
    };
    spawner.spawn(control(simulation).unwrap());
    spawner.spawn(supervisor(scenario.periods).unwrap());
}
