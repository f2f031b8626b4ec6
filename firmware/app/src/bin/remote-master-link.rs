//! QEMU host-link image of the remote machining master (`RemoteMaster<f32>` on the
//! simulated master delta, moved by an operator's hand, commanding a slave site over
//! a delayed network), driven only by a host over the emulated UART0 with the link
//! protocol (`kerf_sim::linked_master`, `kerf::machines::remote_master::link`): the host
//! uploads the fixture's contour as points, starts the session, changes the
//! fixture's poles, streams the master and the slave it commands. Run it with QEMU's
//! serial port on a socket (`kerf run --qemu --image …/remote-master-link JOB`); the
//! image runs until the host ends QEMU.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use kerf_app::exit;
use kerf_app::uart::{serve_link, CmsdkUart, UART0_BASE};
use kerf_sim::linked_master::{with_linked_master, SAMPLE_JOB};

/// The heartbeat timeout in machine time, as the other link images allow (2 s of
/// the emulated machine's time).
const HEARTBEAT_TIMEOUT_S: f64 = 2.0;

#[entry]
fn main() -> ! {
    // SAFETY: UART0 belongs to this image alone.
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    // The operator's drawing: the product's sample contour, which the host uploads.
    let built = with_linked_master::<f32, _>(SAMPLE_JOB, HEARTBEAT_TIMEOUT_S, |master| {
        // Settings saved in an earlier run of this image (a file QEMU's host keeps).
        if let Some(store) = kerf_app::settings_file::store() {
            master.link_mut().attach_store(store);
        }
        serve_link(&mut uart, |bytes, send| {
            master.period(bytes, send);
            Ok::<(), core::convert::Infallible>(())
        })
    });
    let Err(e) = built;
    hprintln!(
        "kerf qemu remote-master-link: the master did not start: {:?}",
        e
    );
    exit(false)
}
