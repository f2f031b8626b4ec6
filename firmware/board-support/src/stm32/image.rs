//! An image's start-up after its wiring: the machine under its supervisor handed to
//! the control interrupt, its start-up commands queued, the host link built, the
//! sampling and TIM1 started, the control interrupt enabled, the watchdog running.
//! Each image builds its statics, its pins and its HAL, calls [`start`], and runs the
//! returned link task in its executor (embassy tasks cannot be generic, so the task
//! function is the image's).

use super::adc::{self, AdcRow, DmaBuffer};
use super::clocks::SYSCLK_HZ;
use super::fault::{self, Cause, ResetCause};
use super::link::{LinkTask, SweepFit};
use super::period::{self, BoardHal, Control, Handoff, Leds};
use super::pins::PinId;
use super::store::{BoardStore, STORE};
use super::timer::{self, Tim1Pins, TimerError, TimerInterrupts};
use super::timing::KERF_STATUS;
use core::sync::atomic::Ordering;
use embassy_stm32::mode::Async;
use embassy_stm32::pac;
use embassy_stm32::peripherals::FLASH;
use embassy_stm32::usart::{RingBufferedUartRx, UartTx};
use embassy_stm32::Peri;
use heapless::spsc::{Consumer, Producer};
use kerf::app::host_link::{HostLink, HostLinkConfig, LinkMachine};
use kerf::app::jobs::JobSlots;
use kerf::app::supervisor::{Command, Report, Supervisor};
use kerf::app::PeriodClock;
use static_cell::StaticCell;

/// Where the period's samples come from and which interrupt runs the period.
pub enum Trigger<'a, const A: usize, const C: usize> {
    /// ADC1…A convert on TIM1's update into the buffer; DMA1 channel 1's
    /// transfer-complete runs the period.
    Adc(&'a [AdcRow<C>; A], &'static DmaBuffer<A, C>),
    /// The inputs come from a bus: TIM1's update opens the bus cycle, and its
    /// channel 3 compare `step_at_ticks` timer ticks later runs the period.
    Bus {
        /// Where the step starts in the period, timer ticks (after the bus's
        /// inputs have arrived).
        step_at_ticks: u16,
    },
}

/// What [`start`] is given.
pub struct Image<
    'a,
    M: LinkMachine + 'static,
    H,
    F: SweepFit<M> + 'static,
    const J: usize,
    const A: usize,
    const C: usize,
> {
    /// The machine's name in the log.
    pub name: &'static str,
    /// The control rate, Hz.
    pub control_hz: u32,
    /// The control period the machine was configured for, s (checked against the
    /// rate).
    pub period_s: f64,
    /// Telemetry every this many periods.
    pub telemetry_decimation: u32,
    /// The board behind the HAL traits.
    pub hal: H,
    /// The sampling and the period's interrupt.
    pub trigger: Trigger<'a, A, C>,
    /// TIM1's pins.
    pub tim1: Tim1Pins,
    /// The LEDs.
    pub leds: Leds,
    /// The calibrate button.
    pub button: PinId,
    /// The host link's UART halves ([`super::link::host_uart`]).
    pub uart: (UartTx<'static, Async>, RingBufferedUartRx<'static>),
    /// The command queue's two ends.
    pub commands: (Producer<'static, Command<M>>, Consumer<'static, Command<M>>),
    /// The report queue's two ends.
    pub reports: (Producer<'static, Report<M>>, Consumer<'static, Report<M>>),
    /// The machine's two job buffers, shared by the link and the supervisor.
    pub jobs: &'static JobSlots<M::Job>,
    /// Queued before the first period (a stored calibration, a calibration to run).
    pub startup: &'a [fn() -> Option<Command<M>>],
    /// The link's settings and job context as flashed.
    pub link: (M::Settings, M::JobContext),
    /// The sweep's fit.
    pub fit: &'static mut F,
    /// Why the board last reset.
    pub reset: ResetCause,
    /// The flash, for the settings store.
    pub flash: Peri<'static, FLASH>,
}

/// Starts an image (module docs) and returns its link task, or goes to the fault
/// path with a start-up code (2: the period is not the rate's; 3: TIM1 cannot count
/// it; 4: the machine refused its configuration; 6: a start-up command did not fit;
/// 7: the link refused its configuration; 10: the ADCs did not start; 11: TIM1 did
/// not start).
#[inline(never)]
// The link task comes out of its `StaticCell`, which hands out its one `&'static mut`.
#[allow(clippy::mut_from_ref)]
pub fn start<M, H, F, const J: usize, const A: usize, const C: usize>(
    image: Image<'_, M, H, F, J, A, C>,
    machine: impl FnOnce() -> Option<M>,
    control: &'static StaticCell<Control<M, H>>,
    handoff: &'static Handoff<Control<M, H>>,
    link: &'static StaticCell<LinkTask<M, F, J>>,
    nvic: &mut cortex_m::peripheral::NVIC,
) -> &'static mut LinkTask<M, F, J>
where
    M: LinkMachine + 'static,
    H: BoardHal<M> + 'static,
    F: SweepFit<M> + 'static,
{
    if libm::fabs(image.period_s * f64::from(image.control_hz) - 1.0) > 1e-9 {
        fault::fail(Cause::Startup, 2)
    }
    let period_cycles = SYSCLK_HZ / image.control_hz;
    let Ok(period) = timer::period_of(period_cycles) else {
        fault::fail(Cause::Startup, 3)
    };
    KERF_STATUS
        .period_cycles
        .store(period_cycles, Ordering::Relaxed);
    let Ok(clock) = PeriodClock::new(image.period_s, u64::from(SYSCLK_HZ)) else {
        fault::fail(Cause::Startup, 8)
    };
    let Some(machine) = machine() else {
        fault::fail(Cause::Startup, 4)
    };
    let (mut to_machine, from_sender) = image.commands;
    let (to_link, from_machine) = image.reports;
    let leds = image.leds;
    let hal = image.hal;
    let decimation = image.telemetry_decimation;
    let state = control.init_with(|| {
        let mut supervisor = Supervisor::new(machine, from_sender, to_link, image.jobs);
        supervisor.set_telemetry_decimation(decimation);
        Control {
            supervisor,
            clock,
            hal,
            period,
            leds,
        }
    });
    handoff.hand_over(state);
    for command in image.startup {
        let queued = command().map(|c| to_machine.enqueue(c).is_ok());
        if queued != Some(true) {
            fault::fail(Cause::Startup, 6)
        }
    }
    let link_config = HostLinkConfig {
        period_s: image.period_s,
        heartbeat_timeout_s: HostLinkConfig::DEFAULT_TIMEOUT_S,
    };
    let (settings, context) = image.link;
    let Ok(mut host_link) = HostLink::new(&link_config, settings, context, image.jobs) else {
        fault::fail(Cause::Startup, 7)
    };
    match BoardStore::new(image.flash).and_then(|s| STORE.try_init(s)) {
        Some(store) => {
            let origin = host_link.attach_store(store);
            defmt::info!("settings: {}", origin);
        }
        None => defmt::warn!("settings: flash not in dual-bank mode, none kept"),
    }
    let (tx, rx) = image.uart;
    let task = link.init_with(|| LinkTask {
        link: host_link,
        commands: to_machine,
        reports: from_machine,
        rx,
        tx,
        fit: image.fit,
        reset: image.reset,
        button: image.button,
        control_hz: image.control_hz,
    });
    let interrupts = match image.trigger {
        Trigger::Adc(rows, buffer) => {
            if let Err(e) = adc::start(rows, buffer) {
                defmt::error!("sampling: {}", e);
                fault::fail(Cause::Startup, 10)
            }
            period::enable(nvic, &[pac::Interrupt::DMA1_CHANNEL1]);
            TimerInterrupts::None
        }
        Trigger::Bus { step_at_ticks } => {
            period::enable(
                nvic,
                &[pac::Interrupt::TIM1_UP_TIM16, pac::Interrupt::TIM1_CC],
            );
            TimerInterrupts::UpdateAndCompare {
                at_ticks: step_at_ticks,
            }
        }
    };
    match timer::start(&image.tim1, period, interrupts) {
        Ok(()) => {}
        Err(TimerError::BreakActive) => {
            defmt::error!("break input active: outputs held off until reset");
        }
        Err(e) => {
            defmt::error!("outputs: {}", e);
            fault::fail(Cause::Startup, 11)
        }
    }
    fault::start_watchdog();
    defmt::info!(
        "kerf {} board: control at {} Hz, link at {} Bd",
        image.name,
        image.control_hz,
        super::link::LINK_BAUD
    );
    task
}
