//! kerf on the STM32G474RE: the Keops delta as the remote slave playing a recorded
//! master session uploaded as a job (`SessionSlave<f32>`), as the QEMU
//! `remote-slave-link` image runs it.
//!
//! The Keops slave's wiring (`kerf_board::hall` for the Hall channels and forces, the
//! laser on TIM1 CH1 (PA8), the drivers' enable on TIM1 CH2 (PA9), the break on
//! PB12, the host link on LPUART1, the button and LEDs on PC13, PC6, PC7). The
//! nominal decoders are the stored calibration at power-up: the session's upload
//! buffer (12 KB) and a command queue that carries a session (18 KB a command) leave
//! 34 KB of RAM, and the Hall fit's stack needs 74 KB, so this image does not fit
//! the sensors (`kerf_board::hall::NoRoomToFit`; the Keops image does, from its
//! button).
#![no_std]
#![no_main]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use defmt_rtt as _;
use embassy_executor::Executor;
use embassy_stm32::pac::interrupt;
use embassy_stm32::{bind_interrupts, dma, peripherals, usart};
use heapless::spsc::Queue;
use kerf::app::supervisor::{Command, Report};
use kerf::machines::delta_slave::product::nominal_calibration;
use kerf::machines::delta_slave::remote::link::RemoteSlaveSettings;
use kerf::machines::delta_slave::remote::product::{
    CONFIG, LINK_JOB_BYTES, PERIOD_S, TELEMETRY_DECIMATION,
};
use kerf::machines::delta_slave::remote::session::SessionSlave;
use kerf_board::hall::{HallHal, NoRoomToFit};
use kerf_board_support::stm32::adc::DmaBuffer;
use kerf_board_support::stm32::clocks::SYSCLK_HZ;
use kerf_board_support::stm32::fault::{self, Cause};
use kerf_board_support::stm32::image::{self, Image, Trigger};
use kerf_board_support::stm32::link::{host_uart, LinkTask, RX_RING_BYTES};
use kerf_board_support::stm32::period::{self, Control, Handoff, Leds, Watch};
use kerf_board_support::stm32::pins::PinId;
use kerf_board_support::stm32::{start_board, timer};
use static_cell::{ConstStaticCell, StaticCell};

kerf_board_support::bind_board_handlers!();

bind_interrupts!(struct Irqs {
    LPUART1 => usart::InterruptHandler<peripherals::LPUART1>;
    DMA1_CHANNEL4 => dma::InterruptHandler<peripherals::DMA1_CH4>;
    DMA1_CHANNEL5 => dma::InterruptHandler<peripherals::DMA1_CH5>;
});

/// The machine the board runs.
type Machine = SessionSlave<f32>;
/// The board behind the HAL traits.
type Hal = HallHal<3>;
/// No fit: the nominal decoders only.
type Fit = NoRoomToFit;
/// The link task of this image.
type Link = LinkTask<Machine, Fit, LINK_JOB_BYTES>;

/// The control rate, Hz: the slave's period of 100 µs (checked at start-up).
const CONTROL_HZ: u32 = 10_000;

/// Commands to the supervisor: two at a time (a command with a calibration is 5 KB).
static COMMANDS: ConstStaticCell<Queue<Command<Machine>, 3>> = ConstStaticCell::new(Queue::new());
/// Reports to the link task, drained every millisecond (ten periods).
static REPORTS: ConstStaticCell<Queue<Report<Machine>, 24>> = ConstStaticCell::new(Queue::new());
static FIT: StaticCell<Fit> = StaticCell::new();
static RX_RING: ConstStaticCell<[u8; RX_RING_BYTES]> = ConstStaticCell::new([0; RX_RING_BYTES]);
static EXECUTOR: StaticCell<Executor> = StaticCell::new();
static CONTROL: StaticCell<Control<Machine, Hal>> = StaticCell::new();
static LINK: StaticCell<Link> = StaticCell::new();
static HANDOFF: Handoff<Control<Machine, Hal>> = Handoff::new();
/// The nine Hall samples of a period, `[carriage][channel]`.
static SAMPLES: DmaBuffer<3, 3> = DmaBuffer::new();

/// The nominal decoders as a stored calibration.
fn nominal() -> Option<Command<Machine>> {
    nominal_calibration::<f32>(&CONFIG.slave)
        .ok()
        .map(Command::FinishCalibration)
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let (p, mut core, reset) = start_board();
    defmt::info!("kerf remote slave board: reset by {}", reset);
    let Ok(period) = timer::period_of(SYSCLK_HZ / CONTROL_HZ) else {
        fault::fail(Cause::Startup, 3)
    };
    let (rows, hal) = Hal::three(
        period,
        &SAMPLES,
        (
            (p.PC0, p.PC1, p.PC2),
            (p.PC4, p.PC5, p.PB2),
            (p.PB0, p.PB1, p.PB13),
        ),
        (p.DAC1, p.PA4, p.PA5, p.DAC2, p.PA6),
    );
    let Ok(uart) = host_uart(
        p.LPUART1,
        p.PA3,
        p.PA2,
        p.DMA1_CH4,
        p.DMA1_CH5,
        Irqs,
        RX_RING.take(),
    ) else {
        fault::fail(Cause::Startup, 9)
    };
    let image = Image {
        name: "remote slave",
        control_hz: CONTROL_HZ,
        period_s: PERIOD_S,
        telemetry_decimation: TELEMETRY_DECIMATION,
        hal,
        trigger: Trigger::Adc(&rows, &SAMPLES),
        tim1: timer::Tim1Pins::new(p.PA8, p.PA9, p.PB12),
        leds: Leds::new(
            PinId::of(&*p.PC6),
            PinId::of(&*p.PC7),
            reset.cause.is_fault(),
        ),
        button: PinId::input(&*p.PC13),
        uart,
        commands: COMMANDS.take().split(),
        reports: REPORTS.take().split(),
        startup: &[nominal],
        link: (RemoteSlaveSettings::of_product(), ()),
        fit: FIT.init_with(|| NoRoomToFit),
        reset,
    };
    let task = image::start(
        image,
        || Machine::new(&CONFIG).ok(),
        &CONTROL,
        &HANDOFF,
        &LINK,
        &mut core.NVIC,
    );
    let executor = EXECUTOR.init(Executor::new());
    executor.run(|spawner| match link_task(task) {
        Ok(token) => spawner.spawn(token),
        Err(_) => fault::fail(Cause::Startup, 12),
    })
}

#[interrupt]
fn DMA1_CHANNEL1() {
    // cortex-m-rt hands this handler the only reference to this.
    static mut WATCH: Watch = Watch::new(CONTROL_HZ);
    period::on_samples::<3, Machine, Hal>(&HANDOFF, WATCH);
}

#[embassy_executor::task]
async fn link_task(task: &'static mut Link) -> ! {
    task.run().await
}
