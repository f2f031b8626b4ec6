//! Instruction counting on QEMU's emulated Cortex-M4, and the markers the cycle
//! estimate (`scripts/cycles`) reads from an execution trace.
//!
//! Under `qemu-system-arm -icount shift=0,align=off,sleep=off` every guest instruction
//! advances virtual time by 1 ns, and SysTick (core clock, 25 MHz on mps2-an386)
//! ticks once per 40 ns. [`Counter::new`] does not assume the 40: it measures the
//! ticks of a loop with 64 extra `nop`s per iteration against the same loop without
//! them, so the instructions per tick come from a known instruction count. A kernel is
//! then timed over many calls, minus a baseline loop with the same input and output
//! handling (the same copies and `black_box` moves, without the kernel), and divided
//! by the call count. These are instruction counts, not Cortex-M4 cycles.
//!
//! Every timed loop runs between calls of [`kerf_trace_begin`] and [`kerf_trace_end`].
//! When `scripts/bench` starts the same image with QEMU's execution trace, it stores
//! [`TRACE_MAGIC`] in [`KERF_TRACE`] before reset; the image then times [`TRACE_CALLS`]
//! calls per loop (one pass over the inputs) instead of [`CALLS`], and names each
//! timed loop on the semihosting output (`@ base|kernel <calls> <key>`), in the order
//! the trace meets the markers. `scripts/cycles` weights the traced instructions of
//! each loop by the Cortex-M4 cycle table.

use core::hint::black_box;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_semihosting::hprintln;

/// Calls per measurement: enough that one SysTick tick (40 instructions) is < 0.02
/// instructions per call, few enough to stay inside SysTick's 24-bit range.
pub const CALLS: u32 = 4096;

/// Calls per measurement in a traced run: one pass over the 64 inputs the benchmarks
/// cycle through, so the traced loop sees the same inputs in the same proportion.
pub const TRACE_CALLS: u32 = 64;

/// The value `scripts/bench` stores in [`KERF_TRACE`] for a traced run.
pub const TRACE_MAGIC: u32 = 0x5452_4143;

/// Set by the emulator before reset (`-device loader`) for a traced run; in `.uninit`
/// so that start-up leaves it alone (QEMU's RAM starts zeroed otherwise).
#[no_mangle]
#[used]
#[link_section = ".uninit.KERF_TRACE"]
pub static mut KERF_TRACE: u32 = 0;

/// Whether this run is traced (see the module docs).
pub fn traced() -> bool {
    // SAFETY: a plain word read of a static nothing else writes while the image runs.
    unsafe { core::ptr::addr_of!(KERF_TRACE).read_volatile() == TRACE_MAGIC }
}

/// Start of a timed region in the execution trace.
#[no_mangle]
#[inline(never)]
pub extern "C" fn kerf_trace_begin() {
    // SAFETY: one `nop`; it also keeps the two markers distinct functions.
    unsafe { core::arch::asm!("nop", options(nomem, nostack, preserves_flags)) }
}

/// End of a timed region in the execution trace.
#[no_mangle]
#[inline(never)]
pub extern "C" fn kerf_trace_end() {
    // SAFETY: two `nop`s (see `kerf_trace_begin`).
    unsafe { core::arch::asm!("nop", "nop", options(nomem, nostack, preserves_flags)) }
}

/// SysTick-based instruction counter.
pub struct Counter {
    syst: SYST,
    instructions_per_tick: f64,
    calls: u32,
    traced: bool,
}

impl Counter {
    /// Starts SysTick free-running and calibrates it against a known instruction count.
    pub fn new(mut syst: SYST) -> Self {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(0x00FF_FFFF);
        syst.clear_current();
        syst.enable_counter();
        let traced = traced();
        let mut counter = Self {
            syst,
            instructions_per_tick: 1.0,
            calls: if traced { TRACE_CALLS } else { CALLS },
            traced,
        };
        let plain = counter.ticks("base", "calibration", |i| {
            black_box(i);
        });
        let padded = counter.ticks("kernel", "calibration", |i| {
            black_box(i);
            nop64();
        });
        counter.instructions_per_tick =
            f64::from(64 * counter.calls) / f64::from(padded.saturating_sub(plain).max(1));
        counter
    }

    /// Instructions per SysTick tick found by the calibration (40 expected).
    pub fn instructions_per_tick(&self) -> f64 {
        self.instructions_per_tick
    }

    /// Whether this run is traced (fewer calls; its timings are not instruction counts).
    pub fn is_traced(&self) -> bool {
        self.traced
    }

    fn ticks(&mut self, kind: &str, key: &str, mut body: impl FnMut(u32)) -> u32 {
        kerf_trace_begin();
        let start = SYST::get_current();
        for i in 0..self.calls {
            body(i);
        }
        let end = SYST::get_current();
        kerf_trace_end();
        let _ = &mut self.syst;
        self.label(kind, self.calls, key);
        start.wrapping_sub(end) & 0x00FF_FFFF
    }

    fn label(&self, kind: &str, calls: u32, key: &str) {
        if self.traced {
            hprintln!("@ {} {} {}", kind, calls, key);
        }
    }

    /// Instructions of one call of `body`, net of an empty call; resolution one
    /// SysTick tick (40 instructions), for calls that cannot be repeated on the same
    /// input (a machine's period advances its state). `key` names it in a traced run.
    pub fn once(&mut self, key: &str, body: &mut dyn FnMut()) -> f64 {
        kerf_trace_begin();
        let start = SYST::get_current();
        black_box(0);
        let empty = start.wrapping_sub(SYST::get_current()) & 0x00FF_FFFF;
        kerf_trace_end();
        self.label("base", 1, key);
        kerf_trace_begin();
        let start = SYST::get_current();
        body();
        let full = start.wrapping_sub(SYST::get_current()) & 0x00FF_FFFF;
        kerf_trace_end();
        self.label("kernel", 1, key);
        f64::from(full.saturating_sub(empty)) * self.instructions_per_tick
    }

    /// Instructions per call of `kernel` (called with the iteration index), net of
    /// `baseline`: the same loop with the kernel's input and output handling (copies,
    /// `black_box` moves) but not the kernel. `key` names both loops in a traced run.
    pub fn per_call(
        &mut self,
        key: &str,
        kernel: impl FnMut(u32),
        baseline: impl FnMut(u32),
    ) -> f64 {
        let empty = self.ticks("base", key, baseline);
        let full = self.ticks("kernel", key, kernel);
        f64::from(full.saturating_sub(empty)) * self.instructions_per_tick / f64::from(self.calls)
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
