//! QEMU host-link image of the remote slave (`SessionSlave<f32>` on the remote
//! scenarios' simulated Keops delta, calibrated at power-up), driven only by a host
//! over the emulated UART0 with the link protocol (`kerf_sim::linked_remote_slave`,
//! `kerf::machines::delta_slave::remote::link`): the host uploads a recorded master session
//! (`data/remote_session.krfj`: the first 2 s of `data/remote_commands.krfr`), starts
//! it, retunes the slave, streams its tracking. Run it with QEMU's serial port on a
//! socket (`kerf run --qemu --image …/remote-slave-link JOB`); the image runs until the
//! host ends QEMU.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use kerf_app::exit;
use kerf_app::uart::{serve_link, CmsdkUart, UART0_BASE};
use kerf_sim::linked_remote_slave::with_linked_remote_slave;

/// The heartbeat timeout in machine time, as the other link images allow (2 s of
/// the emulated machine's time).
const HEARTBEAT_TIMEOUT_S: f64 = 2.0;

#[entry]
fn main() -> ! {
    // SAFETY: UART0 belongs to this image alone.
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    let ended = with_linked_remote_slave::<f32, _>(HEARTBEAT_TIMEOUT_S, |slave| {
        // Settings saved in an earlier run of this image (a file QEMU's host keeps).
        if let Some(store) = kerf_app::settings_file::store() {
            slave.link_mut().attach_store(store);
        }
        serve_link(&mut uart, |bytes, send| {
            slave.period(bytes, send).map(|_| ())
        })
    });
    hprintln!(
        "kerf qemu remote-slave-link: the simulation stopped: {:?}",
        ended
    );
    exit(false)
}
