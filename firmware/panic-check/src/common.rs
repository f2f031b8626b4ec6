//! What both check images share: the panic handler that makes a reachable panic a
//! link error, the values the optimiser cannot see through, and a link whose frames
//! it cannot predict.

use core::hint::black_box;
use kerf::hal::{FrameLink, LinkBusy};

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    extern "Rust" {
        // Defined nowhere: referencing it makes any reachable panic a link error.
        fn kerf_panic_is_reachable() -> !;
    }
    // SAFETY: never executed in an image that links; the call exists to be resolved.
    unsafe { kerf_panic_is_reachable() }
}

/// A value the optimiser must treat as unknown.
#[inline(always)]
pub fn opaque<T>(value: T) -> T {
    black_box(value)
}

/// Keeps a result alive so that the call producing it is not removed.
#[inline(always)]
pub fn sink<T>(value: T) {
    black_box(value);
}

/// A link whose frames and readiness the optimiser cannot predict.
pub struct OpaqueLink;

impl FrameLink for OpaqueLink {
    fn send(&mut self, frame: &[u8]) -> Result<(), LinkBusy> {
        sink(frame);
        if opaque(false) {
            Err(LinkBusy)
        } else {
            Ok(())
        }
    }

    fn receive(&mut self, buf: &mut [u8]) -> Option<usize> {
        for b in buf.iter_mut() {
            *b = opaque(0);
        }
        opaque(Some(buf.len()))
    }
}
