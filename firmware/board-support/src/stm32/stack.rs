//! The stack's high-water mark on the board: the free RAM between the statics and the
//! stack pointer is painted once at start-up, and the deepest word overwritten since
//! shows how deep the stack went in every context together (main, the link task, the
//! control interrupt and the link's interrupts nested on top).

/// Fill pattern: unlikely as a saved register, return address or float.
const PATTERN: u32 = 0xA5C3_5A3C;
/// Bytes left unpainted below the stack pointer for the painting code itself.
const GAP: usize = 256;

extern "C" {
    /// End of the statics in RAM (cortex-m-rt's `link.x`).
    static __sheap: u32;
    /// Top of the stack (cortex-m-rt's `link.x`).
    static _stack_start: u32;
}

fn floor() -> usize {
    // Only the linker symbol's address is taken, never its value.
    (core::ptr::addr_of!(__sheap) as usize + 3) & !3
}

fn top() -> usize {
    core::ptr::addr_of!(_stack_start) as usize
}

/// Paints the free stack below the present stack pointer. Call once, early in `main`,
/// before any interrupt is enabled.
#[inline(never)]
pub fn paint() {
    let sp = cortex_m::register::msp::read() as usize;
    let mut address = floor();
    while address + GAP < sp {
        // SAFETY: [floor, sp - GAP) is free stack that nothing owns yet: the statics
        // end at the floor, and no interrupt runs before painting ends.
        unsafe { (address as *mut u32).write_volatile(PATTERN) };
        address += 4;
    }
}

/// Deepest stack use since [`paint`], bytes below the top of RAM.
pub fn used() -> usize {
    let mut address = floor();
    let top = top();
    // SAFETY: reads within [floor, top), RAM that `paint` wrote or the stack uses.
    while address < top && unsafe { (address as *const u32).read_volatile() } == PATTERN {
        address += 4;
    }
    top - address
}
