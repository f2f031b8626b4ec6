//! QEMU smoke run: the single-axis firmware (Hall decode → velocity observer → PD →
//! DOB, f32) against the simulated LM1247 axis with imperfect Hall sensors (offsets,
//! gains, mounting errors, third harmonic, noise), at 10 kHz.
//!
//! Two embassy tasks. `supervisor` runs the modes: first calibration (a closed-loop
//! sweep over 1.5 pitches with the nominal decoder, then the sensor-model fit), then
//! it starts `control` with the calibrated decoder. `control` steps the loop and the
//! plant once per period for 1 s of the tracking profile and hands each period's record
//! to `supervisor` over a channel; `supervisor` keeps the error statistics, prints a
//! one-line summary and exits non-zero when a bound is missed or the axis faulted.
#![no_std]
#![no_main]

use cortex_m_semihosting::hprintln;
use embassy_executor::Spawner;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use hal_mock::hall_sensor::HallSensorParams;
use hal_mock::scenario::{
    self_calibrate, Outcome, Period, Scenario, Simulation, MAX_ERROR_BOUND_M, RMS_ERROR_BOUND_M,
    TS_S,
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
async fn supervisor(spawner: Spawner, scenario: Scenario) {
    // Calibration mode.
    let (fit, calibrated) = match self_calibrate::<f32>(&scenario) {
        Ok(result) => result,
        Err(e) => {
            hprintln!("kerf qemu smoke: calibration failed: {:?} -> FAIL", e);
            exit(false)
        }
    };
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
    // Run mode.
    let simulation = match Simulation::<f32>::new(&calibrated) {
        Ok(s) => s,
        Err(e) => {
            hprintln!("kerf qemu smoke: configuration rejected: {:?} -> FAIL", e);
            exit(false)
        }
    };
    spawner.spawn(control(simulation).unwrap());
    let mut outcome = Outcome::with_window(f64::INFINITY, f64::INFINITY);
    for _ in 0..calibrated.periods {
        let period = PERIODS.receive().await;
        outcome.add(&period);
    }
    let ok = outcome.fault_period.is_none()
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
    #[cfg(feature = "break-gain")]
    {
        // Deliberately detuned: 1 % of the position gain must miss the bounds.
        scenario.axis.pd.kp_per_s2 *= 0.01;
    }
    spawner.spawn(supervisor(spawner, scenario).unwrap());
}
