//! QEMU host-link image of the grinding cell (`GrindingCell<f32>` on the simulated
//! cell with its hexapod and spindle on their protocols), driven only by a host over
//! the emulated UART0 with the link protocol (`kerf_sim::linked_grinding`,
//! `kerf::machines::grinding::link`): the host uploads a pass in G-code, starts it,
//! changes the force law's gains, streams the forces. Run it with QEMU's serial port
//! on a socket (`kerf run --qemu --image …/grinding-link JOB`); the image runs until
//! the host ends QEMU.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use kerf_app::exit;
use kerf_app::uart::{serve_link, CmsdkUart, UART0_BASE};
use kerf_sim::linked_grinding::with_linked_grinding;

/// The heartbeat timeout in machine time, as the other link images allow (2 s of
/// the emulated machine's time).
const HEARTBEAT_TIMEOUT_S: f64 = 2.0;

#[entry]
fn main() -> ! {
    // SAFETY: UART0 belongs to this image alone.
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    let built = with_linked_grinding::<f32, _>(HEARTBEAT_TIMEOUT_S, |cell| {
        // Settings saved in an earlier run of this image (a file QEMU's host keeps).
        if let Some(store) = kerf_app::settings_file::store() {
            cell.link_mut().attach_store(store);
        }
        serve_link(&mut uart, |bytes, send| {
            cell.period(bytes, send);
            Ok::<(), core::convert::Infallible>(())
        })
    });
    let Err(e) = built;
    hprintln!("kerf qemu grinding-link: the cell did not start: {:?}", e);
    exit(false)
}
