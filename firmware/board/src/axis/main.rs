//! kerf on the STM32G474RE: one LM1247 axis (`Joints<f32, 1>`, the single-axis
//! product) behind the host link, as the QEMU `axis-link` image runs it.
//!
//! The carriage's three Hall channels on ADC1 (PC0, PC1, PC2), its force on DAC1
//! OUT1 (PA4) (`kerf_board::hall`); the driver's enable on TIM1 CH2 (PA9), its fault
//! line or an E-stop on TIM1 BKIN (PB12); the host link on LPUART1 (PA2, PA3); the
//! calibrate button and LEDs on PC13, PC6, PC7. The control period (10 kHz) is DMA1
//! channel 1's transfer-complete; the nominal decoder is the stored calibration at
//! power-up, button B1 runs the sweep and its fit.
#![no_std]
#![no_main]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use kerf::app::supervisor::Command;
use kerf::machines::single_axis::link::AxisSettings;
use kerf::machines::single_axis::product::{
    nominal_calibration, Axis, CONFIG, LINK_JOB_BYTES, PERIOD_S, TELEMETRY_DECIMATION,
};
use kerf_board::hall::HallFit;

/// The nominal decoder as a stored calibration (button B1 replaces it).
fn nominal() -> Option<Command<Axis<f32>>> {
    nominal_calibration::<f32>(&CONFIG)
        .ok()
        .map(Command::FinishCalibration)
}

kerf_board::hall_image! {
    name: "single axis",
    machine: Axis<f32>,
    carriages: 1,
    laser: false,
    job_bytes: LINK_JOB_BYTES,
    commands: 4, reports: 24,
    control_hz: 10_000,
    period_s: PERIOD_S,
    telemetry_decimation: TELEMETRY_DECIMATION,
    fit: HallFit<Axis<f32>, 1> = HallFit::new(&CONFIG.hall),
    startup: nominal,
    link: (AxisSettings::of(&CONFIG.axis), CONFIG),
    new: || Axis::<f32>::new(&CONFIG).ok(),
}
