//! kerf on the STM32G474RE: the Keops delta as the remote slave playing a recorded
//! master session uploaded as a job (`SessionSlave<f32>`), as the QEMU
//! `remote-slave-link` image runs it.
//!
//! The Keops slave's wiring (`kerf_board::hall` for the Hall channels and forces, the
//! laser on TIM1 CH1 (PA8), the drivers' enable on TIM1 CH2 (PA9), the break on
//! PB12, the host link on LPUART1, the button and LEDs on PC13, PC6, PC7). The
//! nominal decoders are the stored calibration at power-up: the session's upload
//! buffer (12 KB) and a command queue that carries a session (18 KB a command) leave
//! 34 KB of RAM, and the Hall fit's stack needs 74 KB, so this image does not fit
//! the sensors (`kerf_board::hall::NoRoomToFit`; the Keops image does, from its
//! button).
#![no_std]
#![no_main]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use kerf::app::supervisor::Command;
use kerf::machines::delta_slave::product::nominal_calibration;
use kerf::machines::delta_slave::remote::link::RemoteSlaveSettings;
use kerf::machines::delta_slave::remote::product::{
    CONFIG, LINK_JOB_BYTES, PERIOD_S, TELEMETRY_DECIMATION,
};
use kerf::machines::delta_slave::remote::session::SessionSlave;
use kerf_board::hall::NoRoomToFit;

/// The nominal decoders as a stored calibration.
fn nominal() -> Option<Command<SessionSlave<f32>>> {
    nominal_calibration::<f32>(&CONFIG.slave)
        .ok()
        .map(Command::FinishCalibration)
}

kerf_board::hall_image! {
    name: "remote slave",
    machine: SessionSlave<f32>,
    carriages: 3,
    laser: true,
    job_bytes: LINK_JOB_BYTES,
    // Two at a time: a command carrying a session is 18 KB.
    commands: 3, reports: 24,
    control_hz: 10_000,
    period_s: PERIOD_S,
    telemetry_decimation: TELEMETRY_DECIMATION,
    fit: NoRoomToFit = NoRoomToFit,
    startup: nominal,
    link: (RemoteSlaveSettings::of_product(), ()),
    new: || SessionSlave::<f32>::new(&CONFIG).ok(),
}
