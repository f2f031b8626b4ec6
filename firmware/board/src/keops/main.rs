//! kerf on the STM32G474RE: the Keops delta slave (`DeltaSlave<f32>`) behind the host
//! link, as the QEMU `link` image runs it, on real peripherals.
//!
//! - The control period (10 kHz) is DMA1 channel 1's transfer-complete interrupt at
//!   the highest priority: TIM1's update triggers ADC1–3, the DMA puts the nine Hall
//!   samples in RAM, the interrupt calls `kerf::app::control_period` and writes the
//!   three forces (DACs) and the laser (TIM1 PWM) in the same period.
//! - The host link runs in an embassy task in thread mode on LPUART1 with DMA,
//!   preempted by every period; the calibrate button (B1) runs the Hall sweep and
//!   its fit in that task. At power-up the nominal decoders are installed as a
//!   stored calibration.
//! - A HardFault, a panic, a missed deadline, a broken sample set or the watchdog
//!   end in the fault path: outputs off in hardware and software, the cause kept
//!   across the reset and told to the host.
//!
//! | signal | pin | peripheral |
//! |---|---|---|
//! | Hall channels, forces | see `kerf_board::hall` | ADC1–3, DAC1–2 |
//! | laser power PWM | PA8 | TIM1 CH1 (10 kHz; 10 kΩ pull-down at the source) |
//! | driver enable | PA9 | TIM1 CH2 (10 kΩ pull-down at the driver) |
//! | driver fault / E-stop in | PB12 | TIM1 BKIN (low or open = outputs off) |
//! | host link | PA2 (TX), PA3 (RX) | LPUART1, the ST-LINK's virtual COM port |
//! | calibrate button, status LED, fault LED | PC13, PC6, PC7 | GPIO |
#![no_std]
#![no_main]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use kerf::app::supervisor::Command;
use kerf::machines::delta_slave::link::SlaveSettings;
use kerf::machines::delta_slave::product::{
    contour_defaults, nominal_calibration, JOB_LAPS, LINK_JOB_BYTES, TELEMETRY_DECIMATION,
};
use kerf::machines::delta_slave::{DeltaSlave, DeltaSlaveConfig};
use kerf_board::hall::HallFit;

/// The nominal decoders as a stored calibration (as the QEMU link image installs
/// them; the calibration run, button B1, replaces them).
fn nominal() -> Option<Command<DeltaSlave<f32>>> {
    nominal_calibration::<f32>(&DeltaSlaveConfig::KEOPS)
        .ok()
        .map(Command::FinishCalibration)
}

kerf_board::hall_image! {
    name: "Keops slave",
    machine: DeltaSlave<f32>,
    carriages: 3,
    laser: true,
    job_bytes: LINK_JOB_BYTES,
    // Two at a time: a command with a calibration is 5 KB. The supervisor takes them
    // within a period; the link answers `Busy` to a third.
    commands: 3,
    // Drained every millisecond (ten periods): 23 hold the telemetry and calibration
    // samples of twice the link task's longest wait on the transmitter (11 ms).
    reports: 24,
    control_hz: 10_000,
    period_s: DeltaSlaveConfig::KEOPS.joints.period_s,
    telemetry_decimation: TELEMETRY_DECIMATION,
    // The Hall configuration is read from flash by the fit.
    fit: HallFit<DeltaSlave<f32>, 3> = HallFit::new(&DeltaSlaveConfig::KEOPS.joints.hall),
    startup: nominal,
    link: (
        SlaveSettings::of(&DeltaSlaveConfig::KEOPS.joints.axis),
        contour_defaults(&DeltaSlaveConfig::KEOPS, JOB_LAPS).into(),
    ),
    new: || DeltaSlave::<f32>::new(&DeltaSlaveConfig::KEOPS).ok(),
}
