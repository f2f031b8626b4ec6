//! QEMU host-link image of ARROW (`Arrow<f32>` on its simulated plant with the
//! geometric error), driven only by a host over the emulated UART0 with the link
//! protocol (`kerf_sim::linked_arrow`, `kerf::machines::arrow::link`): the host uploads a
//! G-code job (the pyramid), starts it, changes gains, streams telemetry. Run it with
//! QEMU's serial port on a socket (`kerf run --qemu --image …/arrow-link JOB`); the
//! image runs until the host ends QEMU.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use kerf_app::exit;
use kerf_app::uart::{serve_link, CmsdkUart, UART0_BASE};
use kerf_sim::arrow::ArrowScenario;
use kerf_sim::linked_arrow::with_linked_arrow;

/// The heartbeat timeout in machine time: the emulated ARROW runs at about twice
/// real time, so 2 s of its time is at least a second of the host's.
const HEARTBEAT_TIMEOUT_S: f64 = 2.0;

#[entry]
fn main() -> ! {
    // SAFETY: UART0 belongs to this image alone.
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    // One RK4 step per period: what the emulated MCU pays for (`ArrowScenario::smoke`).
    let scenario = ArrowScenario::smoke();
    let ended = with_linked_arrow::<f32, _>(&scenario, HEARTBEAT_TIMEOUT_S, |arrow| {
        // Settings saved in an earlier run of this image (a file QEMU's host keeps).
        if let Some(store) = kerf_app::settings_file::store() {
            arrow.link_mut().attach_store(store);
        }
        serve_link(&mut uart, |bytes, send| {
            arrow.period(bytes, send).map(|_| ())
        })
    });
    hprintln!("kerf qemu arrow-link: the simulation stopped: {:?}", ended);
    exit(false)
}
