//! The board's fault path: a HardFault, a panic or a missed control deadline puts the
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

use crate::outputs;
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicBool, Ordering};
use embassy_stm32::pac;
use kerf::codec::link::{board_fault, BOARD_FAULT};

/// What ended the last run.
#[derive(Copy, Clone, Debug, PartialEq, Eq, defmt::Format)]
#[repr(u8)]
pub enum Cause {
    /// Power-on or brown-out: nothing went wrong.
    PowerOn = 0,
    /// The reset pin (the probe, the NUCLEO's reset button).
    Pin = 1,
    /// A software reset without a fault record (the probe's reset request).
    Software = 2,
    /// A HardFault; detail: the stacked program counter's low 16 bits.
    HardFault = board_fault::HARD_FAULT as u8,
    /// A panic; detail: the source line.
    Panic = board_fault::PANIC as u8,
    /// A control period did not finish within its period; detail: its cycles / 16.
    MissedDeadline = board_fault::MISSED_DEADLINE as u8,
    /// The independent watchdog expired (the control interrupt or the link task
    /// stopped running).
    Watchdog = board_fault::WATCHDOG as u8,
    /// The three ADC sequences of a period did not arrive together, or a DMA
    /// transfer error.
    Sampling = board_fault::SAMPLING as u8,
    /// The break input (driver fault, E-stop) switched the outputs off; no reset.
    Break = board_fault::BREAK as u8,
    /// Start-up failed (a peripheral did not come ready); detail: which.
    Startup = board_fault::STARTUP as u8,
}

impl Cause {
    /// Whether this cause is a fault the host should hear about.
    pub fn is_fault(self) -> bool {
        !matches!(self, Cause::PowerOn | Cause::Pin | Cause::Software)
    }

    /// The causes a fault record can hold (the watchdog's is read from the reset
    /// flags, and a break does not reset).
    fn from_u32(value: u32) -> Option<Self> {
        [
            Cause::HardFault,
            Cause::Panic,
            Cause::MissedDeadline,
            Cause::Sampling,
            Cause::Startup,
        ]
        .into_iter()
        .find(|c| *c as u32 == value)
    }
}

/// What is kept across the reset.
#[derive(Copy, Clone)]
#[repr(C)]
struct Record {
    magic: u32,
    cause: u32,
    detail: u32,
    /// `!(magic ^ cause ^ detail)`: catches a half-written record.
    check: u32,
}

const MAGIC: u32 = 0x6B65_7266;

#[link_section = ".uninit.kerf_fault_record"]
static mut RECORD: MaybeUninit<Record> = MaybeUninit::uninit();

/// The cause of the last reset and its detail.
#[derive(Copy, Clone, Debug, PartialEq, Eq, defmt::Format)]
pub struct ResetCause {
    /// What ended the last run.
    pub cause: Cause,
    /// Its detail (see [`Cause`]).
    pub detail: u32,
}

impl ResetCause {
    /// The host's fault event code and detail, for a fault.
    pub fn event(&self) -> Option<(u16, u16)> {
        self.cause
            .is_fault()
            .then_some((BOARD_FAULT | self.cause as u16, self.detail as u16))
    }
}

/// Reads and clears the fault record and the reset flags (RCC_CSR, RM0440 "Control/
/// status register"): call once at start-up.
pub fn take_reset_cause() -> ResetCause {
    let csr = pac::RCC.csr().read();
    // SAFETY: start-up, before any interrupt: nothing else touches the record; it is
    // read as plain words, and a power-on's garbage is rejected by magic and check.
    let record = unsafe { core::ptr::addr_of!(RECORD).cast::<Record>().read_volatile() };
    // SAFETY: as above; cleared so that the next reset without a fault shows as one.
    unsafe {
        core::ptr::addr_of_mut!(RECORD)
            .cast::<Record>()
            .write_volatile(Record {
                magic: 0,
                cause: 0,
                detail: 0,
                check: 0,
            })
    };
    pac::RCC.csr().modify(|w| w.set_rmvf(true));
    let valid =
        record.magic == MAGIC && record.check == !(record.magic ^ record.cause ^ record.detail);
    let (cause, detail) = if csr.iwdgrstf() {
        (Cause::Watchdog, 0)
    } else if csr.sftrstf() {
        match Cause::from_u32(record.cause).filter(|_| valid) {
            Some(cause) => (cause, record.detail),
            None => (Cause::Software, 0),
        }
    } else if csr.borrstf() {
        (Cause::PowerOn, 0)
    } else if csr.pinrstf() {
        (Cause::Pin, 0)
    } else {
        (Cause::PowerOn, 0)
    };
    ResetCause { cause, detail }
}

/// The fault path: outputs safe (hardware break, then software), the cause recorded,
/// a reset. Never returns; callable from any context, the HardFault handler included.
pub fn fail(cause: Cause, detail: u32) -> ! {
    outputs::force_safe();
    cortex_m::interrupt::disable();
    let record = Record {
        magic: MAGIC,
        cause: cause as u32,
        detail,
        check: !(MAGIC ^ cause as u32 ^ detail),
    };
    // SAFETY: interrupts are off and this path never returns: nothing else writes the
    // record until the next start-up reads it.
    unsafe {
        core::ptr::addr_of_mut!(RECORD)
            .cast::<Record>()
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
        .write(|w| w.set_pr(pac::iwdg::vals::Pr::from_bits(crate::board::IWDG_PRESCALER)));
    iwdg.rlr().write(|w| w.set_rl(crate::board::IWDG_RELOAD));
    // Bounded: the registers update within a few LSI periods (RM0440 IWDG_SR).
    let _ = (0..100_000).any(|_| iwdg.sr().read().0 & 0x7 == 0);
    refresh_watchdog();
}

/// Reloads the watchdog's counter.
#[inline]
pub fn refresh_watchdog() {
    pac::IWDG
        .kr()
        .write(|w| w.set_key(pac::iwdg::vals::Key::RESET));
}

#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    fail(Cause::HardFault, frame.pc() & 0xFFFF)
}

/// Set by the first panic: a panic inside the panic's own log line (defmt refuses to
/// be entered twice) goes straight to the reset instead of recursing.
static PANICKING: AtomicBool = AtomicBool::new(false);

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // Outputs first, before anything that could fail again.
    outputs::force_safe();
    let line = info.location().map_or(0, |l| l.line());
    if !PANICKING.swap(true, Ordering::Relaxed) {
        defmt::error!("panic at line {}", line);
    }
    fail(Cause::Panic, line)
}
