//! QEMU host-link image of the single axis (`Joints<f32, 1>` on the simulated LM1247
//! axis with its payload), driven only by a host over the emulated UART0 with the link
//! protocol (`kerf_sim::linked_axis`, `kerf::machines::single_axis::link`): the host
//! uploads G-code moves along X, starts them, changes the axis law's gains, streams
//! position, reference, force and disturbance. Run it with QEMU's serial port on a
//! socket (`kerf run --qemu --image …/axis-link JOB`); the image runs until the host
//! ends QEMU.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use kerf_app::exit;
use kerf_app::uart::{serve_link, CmsdkUart, UART0_BASE};
use kerf_sim::linked_axis::with_linked_axis;
use kerf_sim::scenario::Scenario;

/// The heartbeat timeout in machine time, as the other link images allow (2 s of
/// the emulated machine's time).
const HEARTBEAT_TIMEOUT_S: f64 = 2.0;

#[entry]
fn main() -> ! {
    // SAFETY: UART0 belongs to this image alone.
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    let built = with_linked_axis::<f32, _>(&Scenario::TRACKING, HEARTBEAT_TIMEOUT_S, |axis| {
        // Settings saved in an earlier run of this image (a file QEMU's host keeps).
        if let Some(store) = kerf_app::settings_file::store() {
            axis.link_mut().attach_store(store);
        }
        serve_link(&mut uart, |bytes, send| {
            axis.period(bytes, send);
            Ok::<(), core::convert::Infallible>(())
        })
    });
    let Err(e) = built;
    hprintln!("kerf qemu axis-link: the axis did not start: {:?}", e);
    exit(false)
}
