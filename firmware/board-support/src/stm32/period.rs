//! The control period: the machine's supervisor step (`kerf::app::control_period`)
//! in the highest-priority interrupt, through the image's implementation of the HAL
//! traits, measured with the cycle counter and held to its deadline; then the
//! watchdog's refresh, the link task's tick and the status LED.
//!
//! The image binds the interrupt that starts its period (DMA1 channel 1's
//! transfer-complete when the period's samples come from the ADCs) and calls
//! [`on_samples`] from it with its [`Handoff`] and a [`Watch`] of its own. An image
//! whose inputs come from a bus binds two: TIM1's update opens the bus cycle
//! ([`on_tick`]), and TIM1's channel 3 compare, placed after the inputs have
//! arrived, runs the step ([`on_compare`]).

use super::adc::{self, Arrival};
use super::clocks::{CONTROL_PRIORITY, LINK_PRIORITY};
use super::fault::{self, Cause};
use super::pins::PinId;
use super::timer;
use super::timing::{self, KERF_STATUS};
use crate::timer_period::TimerPeriod;
use core::sync::atomic::{AtomicBool, AtomicPtr, AtomicU32, Ordering};
use embassy_stm32::pac;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::signal::Signal;
use kerf::app::supervisor::{Machine, Mode, Supervisor};
use kerf::app::PeriodClock;
use kerf::hal::{Monotonic, SampleInputs, WriteOutputs};

/// A board behind kerf's HAL traits for machine `M`, which also drives the enable
/// line of the machine's power stage.
pub trait BoardHal<M: Machine>:
    SampleInputs<M::Inputs> + WriteOutputs<M::Outputs> + Monotonic
{
    /// Whether the power stage may be enabled this period (false after a fault or a
    /// break); written with the outputs.
    fn set_enabled(&mut self, enabled: bool);
}

/// What the control interrupt owns.
pub struct Control<M: Machine + 'static, H> {
    /// The machine under its supervisor.
    pub supervisor: Supervisor<'static, M>,
    /// Late periods, on the cycle counter.
    pub clock: PeriodClock,
    /// The board.
    pub hal: H,
    /// The period as TIM1 counts it.
    pub period: TimerPeriod,
    /// The status LED (blinks at 1 Hz while periods run) and the fault LED.
    pub leds: Leds,
}

/// The status and fault LEDs.
#[derive(Copy, Clone, Debug)]
pub struct Leds {
    /// Blinks at 1 Hz while the control period runs.
    pub status: PinId,
    /// Lit when the last reset was a fault, or the break holds the outputs.
    pub fault: PinId,
}

impl Leds {
    /// The two LEDs as outputs, the fault LED lit when the last reset was a fault.
    pub fn new(status: PinId, fault: PinId, last_reset_was_fault: bool) -> Self {
        status.set_output(false);
        fault.set_output(last_reset_was_fault);
        Self { status, fault }
    }
}

/// The control state, handed from `main` to the interrupt once: `main` builds it in
/// a static cell and stores its address here before the interrupt is unmasked, and
/// never touches it again. One copy of the state, no critical section in the period.
pub struct Handoff<T>(AtomicPtr<T>);

impl<T> Handoff<T> {
    /// Empty.
    pub const fn new() -> Self {
        Self(AtomicPtr::new(core::ptr::null_mut()))
    }

    /// Hands the control state to the interrupt (before [`enable`]).
    pub fn hand_over(&self, control: &'static mut T) {
        self.0.store(control, Ordering::Release);
    }

    /// The state, in the one interrupt that owns it.
    ///
    /// # Safety
    ///
    /// Only the control interrupt, or an interrupt of the same priority (which
    /// neither preempts it nor is preempted by it), may call this, once per entry:
    /// `hand_over` stored a `&'static mut` whose owner gave it up, so the reference
    /// returned is then the only live one.
    #[allow(clippy::mut_from_ref)]
    unsafe fn get(&self) -> Option<&mut T> {
        // SAFETY: see the function's contract.
        unsafe { self.0.load(Ordering::Acquire).as_mut() }
    }
}

impl<T> Default for Handoff<T> {
    fn default() -> Self {
        Self::new()
    }
}

/// Wakes the link task every [`LINK_TICK_MS`] millisecond.
pub static LINK_TICK: Signal<CriticalSectionRawMutex, ()> = Signal::new();

/// Wakes a machine's device task (a slower context than the link's) every
/// millisecond, as [`LINK_TICK`] wakes the link task.
pub static DEVICE_TICK: Signal<CriticalSectionRawMutex, ()> = Signal::new();

/// The link task's tick, ms.
pub const LINK_TICK_MS: u32 = 1;

/// Counts the link task's runs: the watchdog is refreshed only while it moves.
pub static LINK_ALIVE: AtomicU32 = AtomicU32::new(0);

/// Set by the link task while it runs a calibration fit (a library call of unknown
/// length that cannot report progress): the watchdog then watches the control
/// interrupt alone.
pub static FIT_RUNNING: AtomicBool = AtomicBool::new(false);

/// The link task must have run within 200 ms for the control interrupt to refresh
/// the watchdog, so that a link task stuck in a loop resets the board as a hung
/// control period does. Longer than the longest wait of the task on the transmitter
/// (1 KB at 921 600 Bd: 11 ms); a calibration fit suspends the check while it runs.
pub const LINK_SILENCE_MS: u32 = 200;

/// What the interrupt keeps between periods beside the control state; the image
/// keeps one in its interrupt handler (`static mut`). Its counts in periods are
/// worked out once, from the control rate, not in every period.
pub struct Watch {
    link_seen: u32,
    link_seen_at: u32,
    periods: u32,
    /// Periods between the link task's ticks (one millisecond).
    tick_periods: u32,
    /// Periods the link task may stay silent before the watchdog is left to bite.
    silence_periods: u32,
    /// Periods of half the status LED's blink (1 Hz).
    blink_periods: u32,
}

impl Watch {
    /// For a control rate of `control_hz`.
    pub const fn new(control_hz: u32) -> Self {
        let per_ms = if control_hz / 1000 > 0 {
            control_hz / 1000
        } else {
            1
        };
        Self {
            link_seen: 0,
            link_seen_at: 0,
            periods: 0,
            tick_periods: per_ms * LINK_TICK_MS,
            silence_periods: per_ms * LINK_SILENCE_MS,
            blink_periods: if control_hz / 2 > 0 {
                control_hz / 2
            } else {
                1
            },
        }
    }
}

/// The period of an image whose samples come from the ADCs: call from DMA1 channel
/// 1's interrupt. A broken sample set ends in the fault path.
#[inline(always)]
pub fn on_samples<const A: usize, M: Machine + 'static, H: BoardHal<M>>(
    handoff: &Handoff<Control<M, H>>,
    watch: &mut Watch,
) {
    let entry = timing::cycles();
    if adc::arrival::<A>() == Arrival::Broken {
        fault::fail(Cause::Sampling, 0);
    }
    run(handoff, watch, entry);
}

/// The period's start of an image whose inputs come from a bus: call from TIM1's
/// update interrupt, at the control interrupt's priority (so that neither preempts
/// the other). `tick` gets the board (to send what opens the bus cycle, a SYNC).
#[inline(always)]
pub fn on_tick<M: Machine + 'static, H: BoardHal<M>>(
    handoff: &Handoff<Control<M, H>>,
    tick: impl FnOnce(&mut H),
) {
    timer::clear_update();
    // SAFETY: the tick and the control interrupt share the highest priority, so
    // neither preempts the other: this is then the only live reference.
    if let Some(control) = unsafe { handoff.get() } {
        tick(&mut control.hal);
    }
}

/// The period of an image whose inputs come from a bus: call from TIM1's channel 3
/// compare interrupt, placed in the period after the inputs have arrived. The
/// deadline is the period's end, as for [`on_samples`].
#[inline(always)]
pub fn on_compare<M: Machine + 'static, H: BoardHal<M>>(
    handoff: &Handoff<Control<M, H>>,
    watch: &mut Watch,
) {
    let entry = timing::cycles();
    timer::clear_compare();
    run(handoff, watch, entry);
}

#[inline(always)]
fn run<M: Machine + 'static, H: BoardHal<M>>(
    handoff: &Handoff<Control<M, H>>,
    watch: &mut Watch,
    entry: u32,
) {
    // SAFETY: `run` is reached only from the control interrupt ([`on_samples`],
    // [`on_compare`]), once per entry.
    let Some(control) = (unsafe { handoff.get() }) else {
        return;
    };
    // Cycles since the period's start: TIM1 counts from its update.
    let since_start = timer::cycles_into_period(&control.period);
    // The update flag marks a period that began during the step. An image whose
    // period starts with the DMA clears it here; one with a tick cleared it there.
    timer::clear_update();
    step(control);
    let step_cycles = timing::cycles().wrapping_sub(entry);
    let finish = since_start.saturating_add(step_cycles);
    // A second update during the step (UIF set again) or a finish past the period: the
    // next samples are already on their way, and the outputs came late.
    if timer::updated_again() || finish >= control.period.cycles() {
        fault::fail(Cause::MissedDeadline, step_cycles / 16);
    }
    timing::record(step_cycles, finish, control.clock.late_periods());
    supervise(watch, &control.leds);
}

/// One control period, out of line so that its stack shows as its own frame.
#[inline(never)]
fn step<M: Machine + 'static, H: BoardHal<M>>(control: &mut Control<M, H>) {
    let held = !timer::armed();
    if held {
        // The break input cut the outputs in hardware; hold the software side too,
        // and light the fault LED.
        KERF_STATUS
            .held_fault
            .store(Cause::Break as u32, Ordering::Relaxed);
        control.leds.fault.write(true);
    }
    let enabled = !held && !matches!(control.supervisor.mode(), Mode::Fault(_));
    control.hal.set_enabled(enabled);
    kerf::app::control_period(
        &mut control.supervisor,
        &mut control.clock,
        &mut control.hal,
    );
    if held {
        fault::outputs_safe();
    }
}

/// Watchdog, link tick and status LED.
fn supervise(watch: &mut Watch, leds: &Leds) {
    watch.periods = watch.periods.wrapping_add(1);
    let link = LINK_ALIVE.load(Ordering::Relaxed);
    if link != watch.link_seen {
        watch.link_seen = link;
        watch.link_seen_at = watch.periods;
    }
    if watch.periods.wrapping_sub(watch.link_seen_at) < watch.silence_periods
        || FIT_RUNNING.load(Ordering::Relaxed)
    {
        fault::refresh_watchdog();
    }
    if watch.periods % watch.tick_periods == 0 {
        // Waking a task calls through its waker's vtable; that happens in the tick
        // interrupt below this one, so that the period's code is all direct calls
        // (and its stack statically bounded, scripts/stack-bound).
        cortex_m::peripheral::NVIC::pend(TICK_INTERRUPT);
    }
    let blink = watch.blink_periods;
    if watch.periods % blink == 0 {
        leds.status.write((watch.periods / blink) % 2 == 0);
    }
}

/// The interrupt line that wakes the link task: FMAC's, a peripheral no image uses,
/// pended by the control interrupt every millisecond; its handler
/// ([`crate::bind_board_handlers!`]) calls [`on_tick_interrupt`].
pub const TICK_INTERRUPT: pac::Interrupt = pac::Interrupt::FMAC;

/// The tick interrupt's work: wake the link task and a device task.
pub fn on_tick_interrupt() {
    LINK_TICK.signal(());
    DEVICE_TICK.signal(());
}

/// Every line [`enable`] may make a control interrupt: the ADC image's DMA, the bus
/// image's tick and step.
const CONTROL_LINES: [pac::Interrupt; 3] = [
    pac::Interrupt::DMA1_CHANNEL1,
    pac::Interrupt::TIM1_UP_TIM16,
    pac::Interrupt::TIM1_CC,
];

/// Stops the control period for good (until the next reset): every control line and
/// the link's tick masked. For a settings save, before the outputs are put safe.
pub fn halt() {
    for line in CONTROL_LINES.into_iter().chain([TICK_INTERRUPT]) {
        cortex_m::peripheral::NVIC::mask(line);
    }
}

/// Enables the control interrupts `control` (one, or the tick and the step of a
/// bus image, of [`CONTROL_LINES`]) at the highest priority and the link's tick
/// interrupt below it.
pub fn enable(nvic: &mut cortex_m::peripheral::NVIC, control: &[pac::Interrupt]) {
    // SAFETY: the control state is in place before the interrupts are unmasked, and
    // no priority-based critical section in the images depends on these lines' levels.
    unsafe {
        nvic.set_priority(TICK_INTERRUPT, LINK_PRIORITY);
        cortex_m::peripheral::NVIC::unmask(TICK_INTERRUPT);
        for &line in control {
            nvic.set_priority(line, CONTROL_PRIORITY);
            cortex_m::peripheral::NVIC::unmask(line);
        }
    }
}
