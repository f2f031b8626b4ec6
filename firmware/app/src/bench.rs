//! Instruction counting on QEMU's emulated Cortex-M4.
//!
//! Under `qemu-system-arm -icount shift=0,align=off,sleep=off` every guest instruction
//! advances virtual time by 1 ns, and SysTick (core clock, 25 MHz on mps2-an386)
//! ticks once per 40 ns. [`Counter::new`] does not assume the 40: it measures the
//! ticks of a loop with 64 extra `nop`s per iteration against the same loop without
//! them, so the instructions per tick come from a known instruction count. A kernel is
//! then timed over many calls, minus an empty loop with the same input handling, and
//! divided by the call count. These are instruction counts, not Cortex-M4 cycles.

use core::hint::black_box;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;

/// Calls per measurement: enough that one SysTick tick (40 instructions) is < 0.02
/// instructions per call, few enough to stay inside SysTick's 24-bit range.
pub const CALLS: u32 = 4096;

/// SysTick-based instruction counter.
pub struct Counter {
    syst: SYST,
    instructions_per_tick: f64,
}

impl Counter {
    /// Starts SysTick free-running and calibrates it against a known instruction count.
    pub fn new(mut syst: SYST) -> Self {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(0x00FF_FFFF);
        syst.clear_current();
        syst.enable_counter();
        let mut counter = Self {
            syst,
            instructions_per_tick: 1.0,
        };
        let plain = counter.ticks(|i| {
            black_box(i);
        });
        let padded = counter.ticks(|i| {
            black_box(i);
            nop64();
        });
        counter.instructions_per_tick = f64::from(64 * CALLS) / f64::from(padded - plain);
        counter
    }

    /// Instructions per SysTick tick found by the calibration (40 expected).
    pub fn instructions_per_tick(&self) -> f64 {
        self.instructions_per_tick
    }

    fn ticks(&mut self, mut body: impl FnMut(u32)) -> u32 {
        let start = SYST::get_current();
        for i in 0..CALLS {
            body(i);
        }
        let end = SYST::get_current();
        let _ = &mut self.syst;
        start.wrapping_sub(end) & 0x00FF_FFFF
    }

    /// Instructions of one call of `body`, net of an empty call; resolution one
    /// SysTick tick (40 instructions), for calls that cannot be repeated on the same
    /// input (a machine's period advances its state).
    pub fn once(&mut self, body: &mut dyn FnMut()) -> f64 {
        let start = SYST::get_current();
        black_box(0);
        let empty = start.wrapping_sub(SYST::get_current()) & 0x00FF_FFFF;
        let start = SYST::get_current();
        body();
        let full = start.wrapping_sub(SYST::get_current()) & 0x00FF_FFFF;
        f64::from(full.saturating_sub(empty)) * self.instructions_per_tick
    }

    /// Instructions per call of `kernel` (called with the iteration index), net of the
    /// loop and of `black_box` on the index.
    pub fn per_call(&mut self, kernel: impl FnMut(u32)) -> f64 {
        let empty = self.ticks(|i| {
            black_box(i);
        });
        let full = self.ticks(kernel);
        f64::from(full.saturating_sub(empty)) * self.instructions_per_tick / f64::from(CALLS)
    }
}

#[inline(always)]
fn nop64() {
    // SAFETY: 64 `nop`s: no memory, stack or flag effects. This is the calibration's
    // known instruction count, so it must not be a loop.
    unsafe {
        core::arch::asm!(
            ".rept 64",
            "nop",
            ".endr",
            options(nomem, nostack, preserves_flags)
        )
    }
}
