//! The board's fault path: a HardFault (bound by the image,
//! [`crate::bind_board_handlers!`]), a panic or a missed control deadline puts the
//! outputs in their safe state (in hardware through TIM1's break, then in software),
//! writes the reason into a RAM word that survives the reset, and resets; the
//! independent watchdog resets a board whose control interrupt or link task stopped.
//! After the reset the reason is read once ([`take_reset_cause`]), logged, and given to
//! the host link as a fault in the board's code range (`kerf::codec::link::BOARD_FAULT`
//! and `board_fault`): sent as an event and kept as the last fault `Status` reports.
//!
//! The record lives in cortex-m-rt's `.uninit` section: neither zeroed nor
//! initialised at start-up, so a software or watchdog reset leaves it as it was; a
//! power cycle leaves garbage, which the magic word and the check word reject.

use super::timer;
use crate::fault_record::{reset_cause, FaultRecord, ResetFlags};
pub use crate::fault_record::{Cause, ResetCause};
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use embassy_stm32::pac;

/// IWDG: LSI 32 kHz / 4 = 8 kHz, reload 80: the image resets 10 ms after the control
/// interrupt or the link task stopped (RM0440, IWDG "Window option" and the timeout table).
const IWDG_PRESCALER: u8 = 0;
/// See [`IWDG_PRESCALER`].
const IWDG_RELOAD: u16 = 80;

#[link_section = ".uninit.kerf_fault_record"]
static mut RECORD: MaybeUninit<FaultRecord> = MaybeUninit::uninit();

/// Register writes that put the machine's own outputs safe (zero on its DACs), at
/// most [`SAFE_WRITES`]: a list of (address, value) the image registers once at
/// start-up ([`set_safe_writes`]) rather than a function to call, so that the fault
/// path stays direct code a static stack bound can follow, from any context.
static SAFE_ADDRESSES: [AtomicU32; SAFE_WRITES] = [const { AtomicU32::new(0) }; SAFE_WRITES];
static SAFE_VALUES: [AtomicU32; SAFE_WRITES] = [const { AtomicU32::new(0) }; SAFE_WRITES];

/// Register writes an image can register for its safe outputs.
pub const SAFE_WRITES: usize = 4;

/// Registers the writes (address, word) that put the machine's outputs safe after
/// TIM1's hardware break; the first [`SAFE_WRITES`] are kept. Call before the
/// outputs start, with addresses of peripheral registers (`reg.as_ptr()`).
pub fn set_safe_writes(writes: &[(*mut u32, u32)]) {
    for ((address, value), (a, v)) in SAFE_ADDRESSES.iter().zip(&SAFE_VALUES).zip(writes) {
        value.store(*v, Ordering::Relaxed);
        address.store(*a as u32, Ordering::Release);
    }
}

/// All outputs safe: TIM1's break in hardware (its PWM and enable lines low within a
/// timer clock), then the machine's registered writes in software.
#[inline]
pub fn outputs_safe() {
    timer::force_safe();
    for (address, value) in SAFE_ADDRESSES.iter().zip(&SAFE_VALUES) {
        let address = address.load(Ordering::Acquire);
        if address != 0 {
            // SAFETY: the only addresses stored are peripheral registers an image
            // registered for this purpose ([`set_safe_writes`]); a word write to
            // them has no effect but the output's.
            unsafe { (address as *mut u32).write_volatile(value.load(Ordering::Relaxed)) };
        }
    }
}

/// Reads and clears the fault record and the reset flags (RCC_CSR, RM0440 "Control/
/// status register"): call once at start-up.
pub fn take_reset_cause() -> ResetCause {
    let csr = pac::RCC.csr().read();
    // SAFETY: start-up, before any interrupt: nothing else touches the record; it is
    // read as plain words, and a power-on's garbage is rejected by magic and check.
    let record = unsafe {
        core::ptr::addr_of!(RECORD)
            .cast::<FaultRecord>()
            .read_volatile()
    };
    // SAFETY: as above; cleared so that the next reset without a fault shows as one.
    unsafe {
        core::ptr::addr_of_mut!(RECORD)
            .cast::<FaultRecord>()
            .write_volatile(FaultRecord::CLEARED)
    };
    pac::RCC.csr().modify(|w| w.set_rmvf(true));
    let flags = ResetFlags {
        watchdog: csr.iwdgrstf(),
        software: csr.sftrstf(),
        brown_out: csr.borrstf(),
        pin: csr.pinrstf(),
    };
    reset_cause(flags, &record)
}

/// The fault path: outputs safe (hardware break, then software), the cause recorded,
/// a reset. Never returns; callable from any context, the HardFault handler included.
pub fn fail(cause: Cause, detail: u32) -> ! {
    outputs_safe();
    cortex_m::interrupt::disable();
    let record = FaultRecord::new(cause, detail);
    // SAFETY: interrupts are off and this path never returns: nothing else writes the
    // record until the next start-up reads it.
    unsafe {
        core::ptr::addr_of_mut!(RECORD)
            .cast::<FaultRecord>()
            .write_volatile(record)
    };
    cortex_m::asm::dsb();
    cortex_m::peripheral::SCB::sys_reset()
}

/// Starts the independent watchdog (RM0440, IWDG "Software watchdog mode"): it cannot
/// be stopped afterwards. Stopped while the core is halted by the debugger
/// (DBGMCU_APB1FZR1.DBG_IWDG_STOP), so that a breakpoint does not reset the board.
pub fn start_watchdog() {
    pac::DBGMCU.apb1lfzr().modify(|w| w.set_iwdg(true));
    let iwdg = pac::IWDG;
    iwdg.kr().write(|w| w.set_key(pac::iwdg::vals::Key::START));
    iwdg.kr().write(|w| w.set_key(pac::iwdg::vals::Key::ENABLE));
    iwdg.pr()
        .write(|w| w.set_pr(pac::iwdg::vals::Pr::from_bits(IWDG_PRESCALER)));
    iwdg.rlr().write(|w| w.set_rl(IWDG_RELOAD));
    // Bounded: the registers update within a few LSI periods (RM0440 IWDG_SR).
    let _ = (0..100_000).any(|_| iwdg.sr().read().0 & 0x7 == 0);
    refresh_watchdog();
}

/// IWDG prescaler /64 (register value 4): 500 Hz, so [`IWDG_RELOAD`] lasts 160 ms.
const IWDG_PRESCALER_LONG: u8 = 4;

/// Gives the watchdog 160 ms from now instead of 10 ms: for a flash erase (up to
/// 40 ms) with the control interrupt stopped, before a restart. The prescaler takes
/// a write only when the previous one has reached the watchdog's clock (IWDG_SR.PVU).
pub fn lengthen_watchdog() {
    let iwdg = pac::IWDG;
    refresh_watchdog();
    iwdg.kr().write(|w| w.set_key(pac::iwdg::vals::Key::ENABLE));
    // Bounded: the registers update within a few LSI periods (RM0440 IWDG_SR).
    let _ = (0..100_000).any(|_| iwdg.sr().read().0 & 0x1 == 0);
    iwdg.pr()
        .write(|w| w.set_pr(pac::iwdg::vals::Pr::from_bits(IWDG_PRESCALER_LONG)));
    let _ = (0..100_000).any(|_| iwdg.sr().read().0 & 0x1 == 0);
    refresh_watchdog();
}

/// Reloads the watchdog's counter.
#[inline]
pub fn refresh_watchdog() {
    pac::IWDG
        .kr()
        .write(|w| w.set_key(pac::iwdg::vals::Key::RESET));
}

/// Set by the first panic: a panic inside the panic's own log line (defmt refuses to
/// be entered twice) goes straight to the reset instead of recursing.
static PANICKING: AtomicBool = AtomicBool::new(false);

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // Outputs first, before anything that could fail again.
    outputs_safe();
    let line = info.location().map_or(0, |l| l.line());
    if !PANICKING.swap(true, Ordering::Relaxed) {
        defmt::error!("panic at line {}", line);
    }
    fail(Cause::Panic, line)
}
