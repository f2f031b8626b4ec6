//! Time on the board: the core's DWT cycle counter (ARMv7-M ARM, C1.8 "The Data
//! Watchpoint and Trace unit"; CYCCNT counts core cycles, 170 per µs) as the
//! [`Monotonic`] tick of the period clock, and the control step's cycle statistics
//! that the status log and [`STATUS`] carry.

use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::DWT;
use kerf::hal::Monotonic;

/// The control step's timing, readable by the link task and by a debugger (the
/// symbol `KERF_STATUS`: `probe-rs read b32 <address> 6`, the address from
/// `nm` on the image, symbol `KERF_STATUS`).
#[repr(C)]
pub struct Status {
    /// Control periods run.
    pub periods: AtomicU32,
    /// The longest control step so far, cycles (interrupt entry to the outputs
    /// written).
    pub worst_step_cycles: AtomicU32,
    /// The last period's step, cycles.
    pub last_step_cycles: AtomicU32,
    /// The latest finish of a step after its period's trigger, cycles: the margin to
    /// the deadline is the period minus this.
    pub worst_finish_cycles: AtomicU32,
    /// Periods the kerf period clock found late (more than half a period).
    pub late_periods: AtomicU32,
    /// The board fault that holds the outputs off without a reset ([`crate::fault_record::Cause`]
    /// as a number; 0 = none).
    pub held_fault: AtomicU32,
    /// The control period, core cycles (set once at start-up).
    pub period_cycles: AtomicU32,
}

/// See [`Status`].
#[no_mangle]
pub static KERF_STATUS: Status = Status {
    periods: AtomicU32::new(0),
    worst_step_cycles: AtomicU32::new(0),
    last_step_cycles: AtomicU32::new(0),
    worst_finish_cycles: AtomicU32::new(0),
    late_periods: AtomicU32::new(0),
    held_fault: AtomicU32::new(0),
    period_cycles: AtomicU32::new(0),
};

/// Starts the cycle counter (DEMCR.TRCENA, then DWT_CTRL.CYCCNTENA).
pub fn start(dcb: &mut cortex_m::peripheral::DCB, dwt: &mut DWT) {
    dcb.enable_trace();
    DWT::unlock();
    dwt.enable_cycle_counter();
}

/// The cycle counter now.
#[inline(always)]
pub fn cycles() -> u32 {
    DWT::cycle_count()
}

/// CYCCNT extended to 64 bits: read at least once per wrap (25 s at 170 MHz), which
/// the control period does 10 000 times a second.
pub struct CycleClock {
    last: u32,
    high: u64,
}

impl CycleClock {
    /// From the counter's present value.
    pub fn new() -> Self {
        Self {
            last: cycles(),
            high: 0,
        }
    }
}

impl Default for CycleClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Monotonic for CycleClock {
    fn tick_hz(&self) -> u64 {
        u64::from(super::clocks::SYSCLK_HZ)
    }

    #[inline]
    fn now(&mut self) -> u64 {
        let now = cycles();
        if now < self.last {
            self.high += 1 << 32;
        }
        self.last = now;
        self.high | u64::from(now)
    }
}

/// Records one step's timing.
#[inline]
pub fn record(step_cycles: u32, finish_cycles: u32, late_periods: u32) {
    let s = &KERF_STATUS;
    s.periods.fetch_add(1, Ordering::Relaxed);
    s.last_step_cycles.store(step_cycles, Ordering::Relaxed);
    s.worst_step_cycles
        .fetch_max(step_cycles, Ordering::Relaxed);
    s.worst_finish_cycles
        .fetch_max(finish_cycles, Ordering::Relaxed);
    s.late_periods.store(late_periods, Ordering::Relaxed);
}
