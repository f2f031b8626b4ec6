//! kerf on the STM32G474RE: the Keops delta slave (`DeltaSlave<f32>`) behind the host
//! link, as the QEMU `link` image runs it, on real peripherals.
//!
//! - The control period (10 kHz) is DMA1 channel 1's transfer-complete interrupt at
//!   the highest priority: TIM1's update triggers ADC1–3, the DMA puts the nine Hall
//!   samples in RAM, the interrupt calls `kerf::app::control_period` and writes the
//!   three forces (DACs) and the laser (TIM1 PWM) in the same period.
//! - The host link runs in an embassy task in thread mode on LPUART1 with DMA,
//!   preempted by every period; the calibrate button (B1) runs the Hall sweep and
//!   its fit in that task. At power-up the nominal decoders are installed as a
//!   stored calibration.
//! - A HardFault, a panic, a missed deadline, a broken sample set or the watchdog
//!   end in the fault path: outputs off in hardware and software, the cause kept
//!   across the reset and told to the host.
//!
//! | signal | pin | peripheral |
//! |---|---|---|
//! | Hall channels, forces | see `kerf_board::hall` | ADC1–3, DAC1–2 |
//! | laser power PWM | PA8 | TIM1 CH1 (10 kHz; 10 kΩ pull-down at the source) |
//! | driver enable | PA9 | TIM1 CH2 (10 kΩ pull-down at the driver) |
//! | driver fault / E-stop in | PB12 | TIM1 BKIN (low or open = outputs off) |
//! | host link | PA2 (TX), PA3 (RX) | LPUART1, the ST-LINK's virtual COM port |
//! | calibrate button, status LED, fault LED | PC13, PC6, PC7 | GPIO |
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
use kerf::machines::delta_slave::link::SlaveSettings;
use kerf::machines::delta_slave::product::{
    contour_defaults, nominal_calibration, JOB_LAPS, LINK_JOB_BYTES, TELEMETRY_DECIMATION,
};
use kerf::machines::delta_slave::{DeltaSlave, DeltaSlaveConfig};
use kerf_board::hall::{HallFit, HallHal};
use kerf_board_support::stm32::adc::DmaBuffer;
use kerf_board_support::stm32::fault::{self, Cause};
use kerf_board_support::stm32::image::{self, Image, Trigger};
use kerf_board_support::stm32::link::{host_uart, LinkTask, RX_RING_BYTES};
use kerf_board_support::stm32::period::{self, Control, Handoff, Leds, Watch};
use kerf_board_support::stm32::pins::PinId;
use kerf_board_support::stm32::{cordic, start_board, timer};
use static_cell::{ConstStaticCell, StaticCell};

kerf_board_support::bind_board_handlers!();

bind_interrupts!(struct Irqs {
    LPUART1 => usart::InterruptHandler<peripherals::LPUART1>;
    DMA1_CHANNEL4 => dma::InterruptHandler<peripherals::DMA1_CH4>;
    DMA1_CHANNEL5 => dma::InterruptHandler<peripherals::DMA1_CH5>;
});

/// The machine the board runs.
type Machine = DeltaSlave<f32>;
/// The board behind the HAL traits.
type Hal = HallHal<3>;
/// The Hall calibration from the button.
type Fit = HallFit<Machine, 3>;
/// The link task of this image.
type Link = LinkTask<Machine, Fit, LINK_JOB_BYTES>;

/// The control rate, Hz: the Keops slave's period of 100 µs (checked at start-up).
const CONTROL_HZ: u32 = 10_000;

/// Commands to the supervisor: two at a time (a queue of N holds N − 1; a command with
/// a calibration is 5 KB). The supervisor takes them within a period; the link answers
/// `Busy` to a third.
static COMMANDS: ConstStaticCell<Queue<Command<Machine>, 3>> = ConstStaticCell::new(Queue::new());
/// Reports to the link task, drained every millisecond (ten periods): 23 hold the
/// telemetry and calibration samples of twice the link task's longest wait on the
/// transmitter (11 ms).
static REPORTS: ConstStaticCell<Queue<Report<Machine>, 24>> = ConstStaticCell::new(Queue::new());
static FIT: StaticCell<Fit> = StaticCell::new();
static RX_RING: ConstStaticCell<[u8; RX_RING_BYTES]> = ConstStaticCell::new([0; RX_RING_BYTES]);
static EXECUTOR: StaticCell<Executor> = StaticCell::new();
static CONTROL: StaticCell<Control<Machine, Hal>> = StaticCell::new();
static LINK: StaticCell<Link> = StaticCell::new();
static HANDOFF: Handoff<Control<Machine, Hal>> = Handoff::new();
/// The nine Hall samples of a period, `[carriage][channel]`.
static SAMPLES: DmaBuffer<3, 3> = DmaBuffer::new();

/// The nominal decoders as a stored calibration (as the QEMU link image installs
/// them; the calibration run, button B1, replaces them).
fn nominal() -> Option<Command<Machine>> {
    nominal_calibration::<f32>(&DeltaSlaveConfig::KEOPS)
        .ok()
        .map(Command::FinishCalibration)
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let (p, mut core, reset) = start_board();
    defmt::info!("kerf board: reset by {}", reset);
    cordic::start();
    let cmp = cordic::compare();
    defmt::info!(
        "cordic phase vs library atan2: worst difference {} (2^-32 turn), {} vs {} cycles per call",
        cmp.worst_difference,
        cmp.cordic_cycles,
        cmp.library_cycles
    );
    let machine = DeltaSlaveConfig::KEOPS;
    let Ok(period) = timer::period_of(kerf_board_support::stm32::clocks::SYSCLK_HZ / CONTROL_HZ)
    else {
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
        name: "Keops slave",
        control_hz: CONTROL_HZ,
        period_s: machine.joints.period_s,
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
        link: (
            SlaveSettings::of(&machine.joints.axis),
            contour_defaults(&machine, JOB_LAPS),
        ),
        // The Hall configuration is read from flash by the fit.
        fit: FIT.init_with(|| HallFit::new(&DeltaSlaveConfig::KEOPS.joints.hall)),
        reset,
    };
    let task = image::start(
        image,
        || Machine::new(&DeltaSlaveConfig::KEOPS).ok(),
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
    // cortex-m-rt hands this handler the only reference to this: the period runs
    // without a critical section and masks nothing.
    static mut WATCH: Watch = Watch::new(CONTROL_HZ);
    period::on_samples::<3, Machine, Hal>(&HANDOFF, WATCH);
}

#[embassy_executor::task]
async fn link_task(task: &'static mut Link) -> ! {
    task.run().await
}
