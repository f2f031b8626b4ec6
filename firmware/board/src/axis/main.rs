//! kerf on the STM32G474RE: one LM1247 axis (`Joints<f32, 1>`, the single-axis
//! product) behind the host link, as the QEMU `axis-link` image runs it.
//!
//! The carriage's three Hall channels on ADC1 (PC0, PC1, PC2), its force on DAC1
//! OUT1 (PA4) (`kerf_board::hall`); the driver's enable on TIM1 CH2 (PA9), its fault
//! line or an E-stop on TIM1 BKIN (PB12); the host link on LPUART1 (PA2, PA3); the
//! calibrate button and LEDs on PC13, PC6, PC7. The control period (10 kHz) is DMA1
//! channel 1's transfer-complete; the nominal decoder is the stored calibration at
//! power-up, button B1 runs the sweep and its fit.
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
use kerf::machines::single_axis::link::AxisSettings;
use kerf::machines::single_axis::product::{
    nominal_calibration, Axis, CONFIG, LINK_JOB_BYTES, PERIOD_S, TELEMETRY_DECIMATION,
};
use kerf_board::hall::{HallFit, HallHal};
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
type Machine = Axis<f32>;
/// The board behind the HAL traits.
type Hal = HallHal<1>;
/// The Hall calibration from the button.
type Fit = HallFit<Machine, 1>;
/// The link task of this image.
type Link = LinkTask<Machine, Fit, LINK_JOB_BYTES>;

/// The control rate, Hz: the axis's period of 100 µs (checked at start-up).
const CONTROL_HZ: u32 = 10_000;

static COMMANDS: ConstStaticCell<Queue<Command<Machine>, 4>> = ConstStaticCell::new(Queue::new());
/// Reports to the link task, drained every millisecond (ten periods).
static REPORTS: ConstStaticCell<Queue<Report<Machine>, 24>> = ConstStaticCell::new(Queue::new());
static FIT: StaticCell<Fit> = StaticCell::new();
static RX_RING: ConstStaticCell<[u8; RX_RING_BYTES]> = ConstStaticCell::new([0; RX_RING_BYTES]);
static EXECUTOR: StaticCell<Executor> = StaticCell::new();
static CONTROL: StaticCell<Control<Machine, Hal>> = StaticCell::new();
static LINK: StaticCell<Link> = StaticCell::new();
static HANDOFF: Handoff<Control<Machine, Hal>> = Handoff::new();
/// The three Hall samples of a period.
static SAMPLES: DmaBuffer<1, 3> = DmaBuffer::new();

/// The nominal decoder as a stored calibration (button B1 replaces it).
fn nominal() -> Option<Command<Machine>> {
    nominal_calibration::<f32>(&CONFIG)
        .ok()
        .map(Command::FinishCalibration)
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let (p, mut core, reset) = start_board();
    defmt::info!("kerf axis board: reset by {}", reset);
    let Ok(period) = timer::period_of(SYSCLK_HZ / CONTROL_HZ) else {
        fault::fail(Cause::Startup, 3)
    };
    let (rows, hal) = Hal::one(period, &SAMPLES, (p.PC0, p.PC1, p.PC2), (p.DAC1, p.PA4));
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
        name: "single axis",
        control_hz: CONTROL_HZ,
        period_s: PERIOD_S,
        telemetry_decimation: TELEMETRY_DECIMATION,
        hal,
        trigger: Trigger::Adc(&rows, &SAMPLES),
        tim1: timer::Tim1Pins::without_pwm(p.PA9, p.PB12),
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
        link: (AxisSettings::of(&CONFIG.axis), CONFIG),
        fit: FIT.init_with(|| HallFit::new(&CONFIG.hall)),
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
    period::on_samples::<1, Machine, Hal>(&HANDOFF, WATCH);
}

#[embassy_executor::task]
async fn link_task(task: &'static mut Link) -> ! {
    task.run().await
}
