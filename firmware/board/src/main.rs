//! kerf on the STM32G474RE: the Keops delta slave (`DeltaSlave<f32>`) behind the host
//! link, as the QEMU `link` image runs it, on real peripherals.
//!
//! - The control period is DMA1 channel 1's transfer-complete interrupt at the
//!   highest priority ([`control`]): TIM1's update triggers ADC1–3, the DMA puts the
//!   nine Hall samples in RAM ([`sampling`]), the interrupt calls
//!   `kerf::app::control_period` and writes the three forces (DACs) and the laser
//!   (TIM1 PWM) in the same period ([`outputs`]).
//! - The host link runs in an embassy task in thread mode on LPUART1 with DMA
//!   ([`link`]), preempted by every period; commands reach the supervisor through its
//!   queue, reports come back through the other.
//! - A HardFault, a panic, a missed deadline, a broken sample set or the watchdog
//!   end in the fault path ([`fault`]): outputs off in hardware and software, the
//!   cause kept across the reset and told to the host.
//! - Pins and peripherals: [`board`].
#![no_std]
#![no_main]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod board;
mod control;
mod cordic;
mod fault;
mod link;
mod outputs;
mod sampling;
mod stack;
mod timing;

use defmt_rtt as _;
use embassy_executor::Executor;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::{bind_interrupts, dma, pac, peripherals, usart};
use fault::Cause;
use heapless::spsc::{Consumer, Producer, Queue};
use kerf::app::calibrate::CalibrationFit;
use kerf::app::host_link::{HostLink, HostLinkConfig};
use kerf::app::supervisor::{Command, Report, Supervisor};
use kerf::app::PeriodClock;
use kerf::machines::delta_slave::link::SlaveSettings;
use kerf::machines::delta_slave::product::{
    contour_defaults, nominal_calibration, JOB_LAPS, TELEMETRY_DECIMATION,
};
use kerf::machines::delta_slave::DeltaSlaveConfig;
use static_cell::{ConstStaticCell, StaticCell};

bind_interrupts!(struct Irqs {
    LPUART1 => usart::InterruptHandler<peripherals::LPUART1>;
    DMA1_CHANNEL4 => dma::InterruptHandler<peripherals::DMA1_CH4>;
    DMA1_CHANNEL5 => dma::InterruptHandler<peripherals::DMA1_CH5>;
});

/// Commands to the supervisor: two at a time (a queue of N holds N − 1; a command with
/// a calibration is 5 KB). The supervisor takes them within a period; the link answers
/// `Busy` to a third.
static COMMANDS: ConstStaticCell<Queue<Command<control::BoardMachine>, 3>> =
    ConstStaticCell::new(Queue::new());
/// Reports to the link task, drained every millisecond (ten periods): 23 hold the
/// telemetry and calibration samples of twice the link task's longest wait on the
/// transmitter (11 ms).
static REPORTS: ConstStaticCell<Queue<Report<control::BoardMachine>, 24>> =
    ConstStaticCell::new(Queue::new());
static FIT: StaticCell<CalibrationFit<3>> = StaticCell::new();
static RX_RING: ConstStaticCell<[u8; RX_RING_BYTES]> = ConstStaticCell::new([0; RX_RING_BYTES]);
static EXECUTOR: StaticCell<Executor> = StaticCell::new();
static CONTROL: StaticCell<control::Control> = StaticCell::new();
static LINK: StaticCell<link::LinkTask> = StaticCell::new();

/// The host link's received bytes: 1024 last 11 ms at 921 600 Bd, ten link ticks.
const RX_RING_BYTES: usize = 1024;

/// Clocks: 170 MHz from HSI16 through the PLL, boost mode; the DMA interrupts of the
/// link below the control interrupt.
fn clocks() -> embassy_stm32::Config {
    use embassy_stm32::rcc::{Pll, PllMul, PllPreDiv, PllRDiv, PllSource, Sysclk};
    let mut config = embassy_stm32::Config::default();
    config.rcc.pll = Some(Pll {
        source: PllSource::HSI,
        prediv: PllPreDiv::DIV4,
        mul: PllMul::MUL85,
        divp: None,
        divq: None,
        divr: Some(PllRDiv::DIV2),
    });
    config.rcc.sys = Sysclk::PLL1_R;
    config.rcc.boost = true;
    config.bdma_interrupt_priority = Priority::P4;
    config
}

/// Status LED (PC6), fault LED (PC7) as outputs, the button (PC13) as an input.
fn leds_and_button(fault_led: bool) {
    use pac::gpio::vals::Moder;
    let gpioc = pac::GPIOC;
    pac::RCC.ahb2enr().modify(|w| w.set_gpiocen(true));
    gpioc.bsrr().write(|w| {
        if fault_led {
            w.set_bs(7, true);
        } else {
            w.set_br(7, true);
        }
    });
    gpioc.moder().modify(|w| {
        w.set_moder(6, Moder::OUTPUT);
        w.set_moder(7, Moder::OUTPUT);
        w.set_moder(13, Moder::INPUT);
    });
}

/// The machine and its supervisor, built into their static and handed to the control
/// interrupt. Out of line: its frame holds copies of the machine (kilobytes each)
/// while it runs and is released before the executor starts; `main`'s own frame
/// stays for ever.
#[inline(never)]
fn start_machine(
    machine: &DeltaSlaveConfig,
    from_sender: Consumer<'static, Command<control::BoardMachine>>,
    to_link: Producer<'static, Report<control::BoardMachine>>,
) {
    let Ok(clock) = PeriodClock::new(machine.joints.period_s, u64::from(board::SYSCLK_HZ)) else {
        fault::fail(Cause::Startup, 8)
    };
    let Ok(slave) = control::BoardMachine::new(machine) else {
        fault::fail(Cause::Startup, 4)
    };
    let control = CONTROL.init_with(|| {
        let mut supervisor = Supervisor::new(slave, from_sender, to_link);
        supervisor.set_telemetry_decimation(TELEMETRY_DECIMATION);
        control::Control::new(supervisor, clock)
    });
    control::hand_over(control);
}

/// Queues the nominal decoders as a stored calibration (as the QEMU link image does;
/// the calibration run, button B1, replaces them). Out of line, as [`start_machine`].
#[inline(never)]
fn store_nominal_calibration(
    machine: &DeltaSlaveConfig,
    commands: &mut Producer<'static, Command<control::BoardMachine>>,
) {
    let Ok(stored) = nominal_calibration::<f32>(machine) else {
        fault::fail(Cause::Startup, 5)
    };
    if commands
        .enqueue(Command::FinishCalibration(stored))
        .is_err()
    {
        fault::fail(Cause::Startup, 6)
    }
}

/// The host link's state, built into its static (out of line, as [`start_machine`]).
#[inline(never)]
fn start_link(
    machine: &DeltaSlaveConfig,
    parts: LinkParts,
    reset: fault::ResetCause,
) -> &'static mut link::LinkTask {
    let link_config = HostLinkConfig {
        period_s: machine.joints.period_s,
        heartbeat_timeout_s: HostLinkConfig::DEFAULT_TIMEOUT_S,
    };
    let Ok(host_link) = HostLink::new(
        &link_config,
        SlaveSettings::of(&machine.joints.axis),
        contour_defaults(machine, JOB_LAPS),
    ) else {
        fault::fail(Cause::Startup, 7)
    };
    let fit = FIT.init_with(CalibrationFit::default);
    LINK.init_with(|| link::LinkTask {
        link: host_link,
        commands: parts.commands,
        reports: parts.reports,
        rx: parts.rx,
        tx: parts.tx,
        hall: &DeltaSlaveConfig::KEOPS.joints.hall,
        fit,
        reset,
    })
}

/// What the link task is given besides its own state.
struct LinkParts {
    commands: Producer<'static, Command<control::BoardMachine>>,
    reports: Consumer<'static, Report<control::BoardMachine>>,
    rx: usart::RingBufferedUartRx<'static>,
    tx: usart::UartTx<'static, embassy_stm32::mode::Async>,
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let reset = fault::take_reset_cause();
    stack::paint();
    let p = embassy_stm32::init(clocks());
    let Some(mut core) = cortex_m::Peripherals::take() else {
        fault::fail(Cause::Startup, 1)
    };
    timing::start(&mut core.DCB, &mut core.DWT);
    leds_and_button(reset.cause.is_fault());
    defmt::info!("kerf board: reset by {}", reset);

    cordic::start();
    let cmp = cordic::compare();
    defmt::info!(
        "cordic phase vs library atan2: worst difference {} (2^-32 turn), {} vs {} cycles per call",
        cmp.worst_difference,
        cmp.cordic_cycles,
        cmp.library_cycles
    );

    // The Keops slave: its Hall configuration is read from flash by the link task.
    let machine = DeltaSlaveConfig::KEOPS;
    if libm::fabs(machine.joints.period_s * f64::from(board::CONTROL_HZ) - 1.0) > 1e-9 {
        fault::fail(Cause::Startup, 2)
    }
    // Constant-initialised cells: in .bss, never built on the stack.
    let (mut to_machine, from_sender) = COMMANDS.take().split();
    let (to_link, from_machine) = REPORTS.take().split();
    start_machine(&machine, from_sender, to_link);
    store_nominal_calibration(&machine, &mut to_machine);

    let mut uart_config = usart::Config::default();
    uart_config.baudrate = board::LINK_BAUD;
    let Ok(uart) = usart::Uart::new(
        p.LPUART1,
        p.PA3,
        p.PA2,
        p.DMA1_CH4,
        p.DMA1_CH5,
        Irqs,
        uart_config,
    ) else {
        fault::fail(Cause::Startup, 9)
    };
    let link_priority = Priority::from(board::LINK_PRIORITY);
    pac::Interrupt::LPUART1.set_priority(link_priority);
    let (tx, rx) = uart.split();
    let rx = rx.into_ring_buffered(RX_RING.take());
    let parts = LinkParts {
        commands: to_machine,
        reports: from_machine,
        rx,
        tx,
    };
    let task = start_link(&machine, parts, reset);

    if let Err(e) = sampling::start() {
        defmt::error!("sampling: {}", e);
        fault::fail(Cause::Startup, 10)
    }
    control::enable(&mut core.NVIC);
    match outputs::start() {
        Ok(()) => {}
        Err(outputs::OutputError::BreakActive) => {
            defmt::error!("break input active: outputs held off until reset");
        }
        Err(e) => {
            defmt::error!("outputs: {}", e);
            fault::fail(Cause::Startup, 11)
        }
    }
    fault::start_watchdog();
    defmt::info!(
        "kerf board: control at {} Hz, link at {} Bd",
        board::CONTROL_HZ,
        board::LINK_BAUD
    );
    let executor = EXECUTOR.init(Executor::new());
    executor.run(|spawner| match link_task(task) {
        Ok(token) => spawner.spawn(token),
        Err(_) => fault::fail(Cause::Startup, 12),
    })
}

#[embassy_executor::task]
async fn link_task(task: &'static mut link::LinkTask) -> ! {
    task.run().await
}
