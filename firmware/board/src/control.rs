//! The control interrupt: DMA1 channel 1's transfer-complete, raised when the
//! period's Hall samples are in memory. It runs the same machine step as the QEMU
//! images (`kerf::app::control_period` on the supervisor of `DeltaSlave<f32>`),
//! through the board's implementation of the HAL traits, measures itself with the
//! cycle counter and enforces the deadline.

use crate::board;
use crate::fault::{self, Cause};
use crate::outputs::{self, BoardOutputs};
use crate::sampling::{self, Arrival, Samples};
use crate::timing::{self, CycleClock, KERF_STATUS};
use core::sync::atomic::{AtomicBool, AtomicPtr, AtomicU32, Ordering};
use embassy_stm32::pac;
use embassy_stm32::pac::interrupt;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::signal::Signal;
use kerf::app::supervisor::{Mode, Supervisor};
use kerf::app::PeriodClock;
use kerf::hal::{Monotonic, SampleInputs, WriteOutputs};
use kerf::machines::delta_slave::{DeltaSlave, SlaveOutputs};

/// The machine the board runs.
pub type BoardMachine = DeltaSlave<f32>;

/// The board behind kerf's HAL traits: the DMA's samples in, DACs and TIM1 out, the
/// cycle counter as the clock.
pub struct BoardHal {
    clock: CycleClock,
    outputs: BoardOutputs,
}

impl SampleInputs<Samples> for BoardHal {
    #[inline]
    fn sample(&mut self) -> Samples {
        sampling::read()
    }
}

impl WriteOutputs<SlaveOutputs<f32>> for BoardHal {
    #[inline]
    fn write(&mut self, outputs: &SlaveOutputs<f32>) {
        self.outputs.write(outputs);
    }
}

impl Monotonic for BoardHal {
    fn tick_hz(&self) -> u64 {
        self.clock.tick_hz()
    }

    #[inline]
    fn now(&mut self) -> u64 {
        self.clock.now()
    }
}

/// What the control interrupt owns.
pub struct Control {
    /// The machine under its supervisor.
    pub supervisor: Supervisor<'static, BoardMachine>,
    /// Late periods, on the cycle counter.
    pub clock: PeriodClock,
    /// The board.
    pub hal: BoardHal,
}

impl Control {
    /// The control state, the board's outputs disabled until the first period.
    pub fn new(supervisor: Supervisor<'static, BoardMachine>, clock: PeriodClock) -> Self {
        Self {
            supervisor,
            clock,
            hal: BoardHal {
                clock: CycleClock::new(),
                outputs: BoardOutputs { enable: false },
            },
        }
    }
}

/// The control state, handed from `main` to the interrupt once: `main` builds it in
/// a static cell and stores its address here before the interrupt is unmasked, and
/// never touches it again. One copy of the state (ten kilobytes), no critical section
/// in the period.
static CONTROL: AtomicPtr<Control> = AtomicPtr::new(core::ptr::null_mut());

/// Hands the control state to the interrupt (before [`enable`]).
pub fn hand_over(control: &'static mut Control) {
    CONTROL.store(control, Ordering::Release);
}

/// Wakes the link task every [`LINK_TICK_PERIODS`] periods.
pub static LINK_TICK: Signal<CriticalSectionRawMutex, ()> = Signal::new();

/// Control periods per link tick (1 ms at 10 kHz).
pub const LINK_TICK_PERIODS: u32 = 10;

/// Counts the link task's runs: the watchdog is refreshed only while it moves.
pub static LINK_ALIVE: AtomicU32 = AtomicU32::new(0);

/// Set by the link task while it runs the calibration fit (a library call of unknown
/// length that cannot report progress): the watchdog then watches the control
/// interrupt alone.
pub static FIT_RUNNING: AtomicBool = AtomicBool::new(false);

/// The status LED's half-period in control periods (1 Hz blink).
const BLINK_PERIODS: u32 = board::CONTROL_HZ / 2;

/// What the interrupt keeps between periods beside the control state.
struct Watch {
    link_seen: u32,
    link_seen_at: u32,
    periods: u32,
}

#[interrupt]
fn DMA1_CHANNEL1() {
    // cortex-m-rt hands this handler the only reference to this: the period runs
    // without a critical section and masks nothing.
    static mut WATCH: Watch = Watch {
        link_seen: 0,
        link_seen_at: 0,
        periods: 0,
    };
    let entry = timing::cycles();
    let tim = pac::TIM1;
    // Cycles since the trigger: TIM1 counts core cycles from its update.
    let since_trigger = u32::from(tim.cnt().read().cnt());
    tim.sr().write_value(pac::timer::regs::SrAdv(!1));
    if sampling::arrival() == Arrival::Broken {
        fault::fail(Cause::Sampling, 0);
    }
    // SAFETY: `hand_over` stored a `&'static mut` whose owner gave it up; this
    // handler does not nest in itself, so this is the only live reference.
    let Some(control) = (unsafe { CONTROL.load(Ordering::Acquire).as_mut() }) else {
        return;
    };
    step(control);
    let step_cycles = timing::cycles().wrapping_sub(entry);
    let finish = since_trigger.saturating_add(step_cycles);
    // A second update during the step (UIF set again) or a finish past the period: the
    // next samples are already on their way, and the outputs came late.
    if tim.sr().read().uif() || finish >= board::PERIOD_CYCLES {
        fault::fail(Cause::MissedDeadline, step_cycles / 16);
    }
    timing::record(step_cycles, finish, control.clock.late_periods());
    supervise(WATCH);
}

/// One control period, out of line so that its stack shows as its own frame.
#[inline(never)]
fn step(control: &mut Control) {
    let held = !outputs::armed();
    if held {
        // The break input cut the outputs in hardware; hold the software side too,
        // and light the fault LED.
        KERF_STATUS
            .held_fault
            .store(Cause::Break as u32, Ordering::Relaxed);
        pac::GPIOC.bsrr().write(|w| w.set_bs(7, true));
    }
    control.hal.outputs.enable = !held && !matches!(control.supervisor.mode(), Mode::Fault(_));
    kerf::app::control_period(
        &mut control.supervisor,
        &mut control.clock,
        &mut control.hal,
    );
    if held {
        outputs::force_safe();
    }
}

/// Watchdog, link tick and status LED.
fn supervise(watch: &mut Watch) {
    watch.periods = watch.periods.wrapping_add(1);
    let link = LINK_ALIVE.load(Ordering::Relaxed);
    if link != watch.link_seen {
        watch.link_seen = link;
        watch.link_seen_at = watch.periods;
    }
    if watch.periods.wrapping_sub(watch.link_seen_at) < board::LINK_SILENCE_PERIODS
        || FIT_RUNNING.load(Ordering::Relaxed)
    {
        fault::refresh_watchdog();
    }
    if watch.periods % LINK_TICK_PERIODS == 0 {
        // Waking a task calls through its waker's vtable; that happens in the tick
        // interrupt below this one, so that the period's code is all direct calls
        // (and its stack statically bounded, scripts/stack-bound).
        cortex_m::peripheral::NVIC::pend(TICK_INTERRUPT);
    }
    if watch.periods % BLINK_PERIODS == 0 {
        let on = (watch.periods / BLINK_PERIODS) % 2 == 0;
        pac::GPIOC.bsrr().write(|w| {
            if on {
                w.set_bs(6, true);
            } else {
                w.set_br(6, true);
            }
        });
    }
}

/// The interrupt line that wakes the link task: FMAC's, a peripheral the image does
/// not use, pended by the control interrupt every [`LINK_TICK_PERIODS`].
const TICK_INTERRUPT: pac::Interrupt = pac::Interrupt::FMAC;

#[interrupt]
fn FMAC() {
    LINK_TICK.signal(());
}

/// Enables the control interrupt at the highest priority and the link's tick
/// interrupt below it.
pub fn enable(nvic: &mut cortex_m::peripheral::NVIC) {
    // SAFETY: the control state is in place before the interrupt is unmasked, and no
    // priority-based critical section in this image depends on this line's level.
    unsafe {
        nvic.set_priority(TICK_INTERRUPT, board::LINK_PRIORITY);
        cortex_m::peripheral::NVIC::unmask(TICK_INTERRUPT);
        nvic.set_priority(pac::Interrupt::DMA1_CHANNEL1, board::CONTROL_PRIORITY);
        cortex_m::peripheral::NVIC::unmask(pac::Interrupt::DMA1_CHANNEL1);
    }
}
