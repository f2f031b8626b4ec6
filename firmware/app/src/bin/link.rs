//! QEMU host-link image: the Keops slave (`DeltaSlave<f32>`) on the simulated delta,
//! driven only by a host over the emulated UART0 with the link protocol
//! (`kerf_sim::linked`, `kerf::app::host_link`). Run it with QEMU's serial port on a
//! socket (`-serial tcp:127.0.0.1:PORT,server=on,wait=on`) and connect a host: it
//! uploads a job, starts it, changes settings, streams telemetry. The image runs until
//! the host ends QEMU.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use hal_mock::hall_sensor::HallSensorParams;
use kerf::machines::delta_slave::product::JOB_LAPS;
use kerf_app::exit;
use kerf_app::uart::{serve_link, CmsdkUart, UART0_BASE};
use kerf_sim::linked::with_linked_slave;
use kerf_sim::slave::SlaveScenario;

#[entry]
fn main() -> ! {
    // SAFETY: UART0 belongs to this image alone.
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    let mut scenario = SlaveScenario::square();
    scenario.sensors = [HallSensorParams::LM1247_16BIT; 3];
    scenario.substeps = 1;
    let ended = with_linked_slave::<f32, _>(&scenario, JOB_LAPS, |slave| {
        // Settings saved in an earlier run of this image (a file QEMU's host keeps).
        if let Some(store) = kerf_app::settings_file::store() {
            slave.link_mut().attach_store(store);
        }
        serve_link(&mut uart, |bytes, send| {
            slave.period(bytes, send).map(|_| ())
        })
    });
    hprintln!("kerf qemu link: the simulation stopped: {:?}", ended);
    exit(false)
}
