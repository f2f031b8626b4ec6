//! QEMU host-link image of the autofocus stage (`FocusStage<f32>` on the simulated
//! zoom camera and focus axis), driven only by a host over the emulated UART0 with
//! the link protocol (`kerf_sim::linked_autofocus`, `kerf::machines::autofocus::link`):
//! the host uploads a zoom schedule, starts it, changes the focus law's settings,
//! streams the focus position, the sharpness, its gradient and the velocity
//! reference. Run it with QEMU's serial port on a socket
//! (`kerf run --qemu --image …/autofocus-link JOB`); the image runs until the host
//! ends QEMU.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use kerf_app::exit;
use kerf_app::uart::{serve_link, CmsdkUart, UART0_BASE};
use kerf_sim::linked_autofocus::{with_linked_autofocus, CAMERA_SEED};

/// The heartbeat timeout in machine time, as the other link images allow (2 s of
/// the emulated machine's time).
const HEARTBEAT_TIMEOUT_S: f64 = 2.0;

#[entry]
fn main() -> ! {
    // SAFETY: UART0 belongs to this image alone.
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    let built = with_linked_autofocus::<f32, _>(CAMERA_SEED, HEARTBEAT_TIMEOUT_S, |stage| {
        // Settings saved in an earlier run of this image (a file QEMU's host keeps).
        if let Some(store) = kerf_app::settings_file::store() {
            stage.link_mut().attach_store(store);
        }
        serve_link(&mut uart, |bytes, send| {
            stage.period(bytes, send);
            Ok::<(), core::convert::Infallible>(())
        })
    });
    let Err(e) = built;
    hprintln!("kerf qemu autofocus-link: the stage did not start: {:?}", e);
    exit(false)
}
