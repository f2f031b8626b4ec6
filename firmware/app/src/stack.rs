//! Stack use measured by painting: the free stack below the stack pointer is filled
//! with a pattern before the code under test runs, and afterwards the lowest word that
//! no longer holds the pattern shows how deep the stack went.
//!
//! The stack grows down from the top of RAM towards the statics (cortex-m-rt's
//! `__sheap`, the end of `.bss`/`.uninit`), so painting never goes below that.

/// Fill pattern: unlikely as a saved register, return address or float.
const PATTERN: u32 = 0xA5C3_5A3C;
/// Bytes left unpainted just below the stack pointer, for the painting code itself.
const GAP: usize = 64;

extern "C" {
    /// End of the statics in RAM (cortex-m-rt's `link.x`).
    static __sheap: u32;
}

/// A stretch of painted stack below the stack pointer.
pub struct Painted {
    sp: usize,
    bottom: usize,
}

impl Painted {
    /// Paints up to `depth` bytes below the present stack pointer (less if the statics
    /// come first). Inlined so that it runs in its caller's frame.
    #[inline(always)]
    pub fn below_sp(depth: usize) -> Self {
        let sp = cortex_m::register::msp::read() as usize;
        // Only the linker symbol's address is taken, never its value.
        let floor = core::ptr::addr_of!(__sheap) as usize;
        let top = sp - GAP;
        let bottom = top.saturating_sub(depth).max(floor) & !3;
        let mut address = bottom;
        while address < top {
            // SAFETY: [bottom, top) lies between the statics and the stack pointer:
            // free stack that nothing owns until a call goes that deep.
            unsafe { (address as *mut u32).write_volatile(PATTERN) };
            address += 4;
        }
        Self { sp, bottom }
    }

    /// Deepest stack use since painting, in bytes below the stack pointer at painting
    /// time; `None` when the whole painted stretch was used (the measurement saturated).
    pub fn used(&self) -> Option<usize> {
        let top = self.sp - GAP;
        let mut address = self.bottom;
        // SAFETY: the same stretch that `below_sp` painted.
        while address < top && unsafe { (address as *const u32).read_volatile() } == PATTERN {
            address += 4;
        }
        (address > self.bottom).then_some(self.sp - address)
    }
}
