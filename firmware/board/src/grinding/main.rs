//! kerf on the STM32G474RE: the force-controlled grinding cell (`GrindingCell<f32>`)
//! behind the host link, as the QEMU `grinding-link` image runs it, on real
//! peripherals.
//!
//! - The control period (1 kHz) is DMA1 channel 1's transfer-complete interrupt:
//!   TIM1's update triggers ADC1–2, the DMA puts the six gauge samples in RAM, the
//!   interrupt runs the cell's supervisor step and writes the piezo command (DAC1)
//!   and the amplifier's enable (TIM1 CH2).
//! - The host link runs in an embassy task on an interrupt executor below the
//!   control period; the devices (the hexapod's GCS controller and the spindle's
//!   converter) are exchanged with in thread mode every device tick (10 ms), on
//!   polled UARTs, below both: a device slow to answer holds up neither the period
//!   nor the host.
//! - A device's fault (an error reply, a silent spindle) reaches the next period's
//!   inputs and stops the cell with its words; the host hears it as the cell's fault.
//! - At power-up the sensor's bias is captured (the calibration, again from button
//!   B1), and the hexapod is referenced.
//!
//! Everything but the cell's pins, signal chains and start-up is
//! `kerf_board_support::stm32`; the wiring is in [`pins`].
#![no_std]
#![no_main]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod pins;

use core::cell::Cell;
use defmt_rtt as _;
use embassy_executor::{Executor, InterruptExecutor};
use embassy_stm32::adc::AdcChannel;
use embassy_stm32::dac::{DacChannel, Value};
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::mode::Blocking;
use embassy_stm32::pac::interrupt;
use embassy_stm32::{bind_interrupts, dma, pac, peripherals, usart};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use heapless::spsc::Queue;
use kerf::app::jobs::JobSlots;
use kerf::app::supervisor::{Command, Report};
use kerf::hal::{Monotonic, SampleInputs, Transact, WriteOutputs};
use kerf::machines::grinding::devices::{DeviceDemand, DeviceFault, DeviceLink, DeviceLinkState};
use kerf::machines::grinding::link::GrindingSettings;
use kerf::machines::grinding::product::{
    CONFIG, DEVICES, LINK_JOB_BYTES, PASS, PERIOD_S, TELEMETRY_DECIMATION,
};
use kerf::machines::grinding::{
    GrindingCalibration, GrindingCell, GrindingInputs, GrindingJob, GrindingOutputs,
};
use kerf::sensing::force::Eccentricity;
use kerf_board_support::reply_framing::ReplyEnd;
use kerf_board_support::stm32::adc::{AdcRow, DmaBuffer};
use kerf_board_support::stm32::fault::{self, Cause};
use kerf_board_support::stm32::image::{self, Image, Trigger};
use kerf_board_support::stm32::link::{host_uart, LinkTask, Stored, RX_RING_BYTES};
use kerf_board_support::stm32::period::{
    self, BoardHal, Control, Handoff, Leds, Watch, DEVICE_TICK,
};
use kerf_board_support::stm32::pins::PinId;
use kerf_board_support::stm32::serial::PolledPort;
use kerf_board_support::stm32::timing::CycleClock;
use kerf_board_support::stm32::{clocks, start_board, timer};
use kerf_board_support::timer_period::TimerPeriod;
use static_cell::{ConstStaticCell, StaticCell};

kerf_board_support::bind_board_handlers!();

bind_interrupts!(struct Irqs {
    LPUART1 => usart::InterruptHandler<peripherals::LPUART1>;
    DMA1_CHANNEL4 => dma::InterruptHandler<peripherals::DMA1_CH4>;
    DMA1_CHANNEL5 => dma::InterruptHandler<peripherals::DMA1_CH5>;
});

/// The machine the board runs.
type Machine = GrindingCell<f32>;

/// The board's control state.
type CellControl = Control<Machine, CellHal>;

/// The link task of this image: the sweep (the bias capture) finishes with the
/// tool's eccentricity as stored.
type CellLink = LinkTask<Machine, Stored<GrindingCalibration>, LINK_JOB_BYTES>;

static COMMANDS: ConstStaticCell<Queue<Command<Machine>, 4>> = ConstStaticCell::new(Queue::new());
/// Reports to the link task, drained every millisecond (one period): 15 hold the
/// telemetry of the link task's longest wait on the transmitter (11 ms).
static REPORTS: ConstStaticCell<Queue<Report<Machine>, 16>> = ConstStaticCell::new(Queue::new());
static FIT: StaticCell<Stored<GrindingCalibration>> = StaticCell::new();
static JOBS: StaticCell<JobSlots<GrindingJob>> = StaticCell::new();
static RX_RING: ConstStaticCell<[u8; RX_RING_BYTES]> = ConstStaticCell::new([0; RX_RING_BYTES]);
static THREAD: StaticCell<Executor> = StaticCell::new();
static LINK_EXECUTOR: InterruptExecutor = InterruptExecutor::new();
static CONTROL: StaticCell<CellControl> = StaticCell::new();
static LINK: StaticCell<CellLink> = StaticCell::new();
static HANDOFF: Handoff<CellControl> = Handoff::new();
/// The six gauge samples of a period, `[adc][channel]`.
static SAMPLES: DmaBuffer<2, 3> = DmaBuffer::new();

/// What the control period and the device task share: the period's demand to the
/// devices, and the devices' latched fault for the next period.
#[derive(Copy, Clone)]
struct DeviceShare {
    demand: DeviceDemand,
    fault: Option<DeviceFault>,
}

static DEVICES_SHARE: Mutex<CriticalSectionRawMutex, Cell<DeviceShare>> =
    Mutex::new(Cell::new(DeviceShare {
        demand: DeviceDemand {
            feed_m_s: 0.0,
            spindle_rpm: 0.0,
            halt: true,
        },
        fault: None,
    }));

/// The board behind kerf's HAL traits.
struct CellHal {
    clock: CycleClock,
    enabled: bool,
    period: TimerPeriod,
    /// The piezo's DAC channel, held (dropping it disables it); written through its
    /// register with a constant channel number in the period.
    _piezo: DacChannel<'static, Blocking>,
}

impl SampleInputs<GrindingInputs<f32>> for CellHal {
    #[inline]
    fn sample(&mut self) -> GrindingInputs<f32> {
        let [a, b] = SAMPLES.read();
        let counts = [a[0], a[1], a[2], b[0], b[1], b[2]];
        let fault = DEVICES_SHARE.lock(|share| share.get().fault);
        GrindingInputs {
            ft_raw_v: counts.map(|c| pins::GAUGES.volts(c)),
            device_fault: fault,
        }
    }
}

impl WriteOutputs<GrindingOutputs<f32>> for CellHal {
    #[inline]
    fn write(&mut self, outputs: &GrindingOutputs<f32>) {
        pac::DAC1
            .dhr12r(0)
            .write(|w| w.set_dhr(pins::PIEZO.code(outputs.piezo_m)));
        timer::write(&self.period, 0.0, self.enabled);
        // The demand the device task sends at its next tick; a cell that may not run
        // (fault, break) halts the hexapod and stops the spindle.
        let demand = DeviceDemand::from_outputs(outputs, !self.enabled);
        DEVICES_SHARE.lock(|share| {
            let mut s = share.get();
            s.demand = demand;
            share.set(s);
        });
    }
}

impl Monotonic for CellHal {
    fn tick_hz(&self) -> u64 {
        self.clock.tick_hz()
    }

    #[inline]
    fn now(&mut self) -> u64 {
        self.clock.now()
    }
}

impl BoardHal<Machine> for CellHal {
    fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }
}

/// The piezo retracted (code 0: the stroke's low end), as a register write for the
/// fault path's software half.
fn register_safe_piezo() {
    fault::set_safe_writes(&[(pac::DAC1.dhr12r(0).as_ptr().cast(), 0)]);
}

/// The devices' side: the two ports and the device link.
struct Devices {
    hexapod: PolledPort,
    spindle: PolledPort,
    link: DeviceLink,
    state: DeviceLinkState,
}

/// The bias capture at power-up; the link task finishes it when the sweep is done.
fn capture_bias() -> Option<Command<Machine>> {
    Some(Command::Calibrate)
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let (p, mut core, reset) = start_board();
    defmt::info!("kerf grinding board: reset by {}", reset);
    let Ok(period) = timer::period_of(clocks::SYSCLK_HZ / pins::CONTROL_HZ) else {
        fault::fail(Cause::Startup, 3)
    };
    // The wiring (pins.rs), typed.
    let gauges = [
        AdcRow::adc1([
            p.PC0.degrade_adc(),
            p.PC1.degrade_adc(),
            p.PC2.degrade_adc(),
        ]),
        AdcRow::adc2([
            p.PC4.degrade_adc(),
            p.PC5.degrade_adc(),
            p.PB2.degrade_adc(),
        ]),
    ];
    let mut piezo = DacChannel::new_blocking(p.DAC1, p.PA4);
    piezo.set(Value::Bit12Right(0));
    register_safe_piezo();
    let hal = CellHal {
        clock: CycleClock::new(),
        enabled: false,
        period,
        _piezo: piezo,
    };
    let mut hexapod_config = usart::Config::default();
    hexapod_config.baudrate = pins::HEXAPOD_BAUD;
    let mut spindle_config = usart::Config::default();
    spindle_config.baudrate = pins::SPINDLE_BAUD;
    let (Ok(hexapod), Ok(spindle)) = (
        usart::Uart::new_blocking(p.USART1, p.PB7, p.PB6, hexapod_config),
        usart::Uart::new_blocking(p.USART3, p.PB11, p.PB10, spindle_config),
    ) else {
        fault::fail(Cause::Startup, 13)
    };
    let Ok(device_link) = DeviceLink::new(&DEVICES) else {
        fault::fail(Cause::Startup, 14)
    };
    let devices = DEVICES_TASK.init(Devices {
        hexapod: PolledPort::new(hexapod, ReplyEnd::Line, pins::DEVICE_TIMEOUT_MS),
        spindle: PolledPort::new(spindle, ReplyEnd::Fixed, pins::DEVICE_TIMEOUT_MS),
        link: device_link,
        state: DeviceLinkState::new(),
    });
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
    // No eccentricity until one is measured (the configuration's tool).
    let stored = GrindingCalibration {
        eccentricity: Eccentricity {
            dx_m: 0.0,
            dy_m: 0.0,
        },
    };
    let image = Image {
        name: "grinding cell",
        control_hz: pins::CONTROL_HZ,
        period_s: PERIOD_S,
        telemetry_decimation: TELEMETRY_DECIMATION,
        hal,
        trigger: Trigger::Adc(&gauges, &SAMPLES),
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
        jobs: JOBS.init_with(Default::default),
        startup: &[capture_bias],
        link: (GrindingSettings::CELL, PASS),
        fit: FIT.init_with(|| Stored(stored)),
        reset,
        flash: p.FLASH,
    };
    let task = image::start(
        image,
        || Machine::new(&CONFIG).ok(),
        &CONTROL,
        &HANDOFF,
        &LINK,
        &mut core.NVIC,
    );
    // The link on an interrupt executor at the link's priority (its UART's), above the
    // devices in thread mode.
    pac::Interrupt::UCPD1.set_priority(Priority::from(clocks::LINK_PRIORITY));
    let link_spawner = LINK_EXECUTOR.start(pac::Interrupt::UCPD1);
    match link_task(task) {
        Ok(token) => link_spawner.spawn(token),
        Err(_) => fault::fail(Cause::Startup, 12),
    }
    let thread = THREAD.init(Executor::new());
    thread.run(|spawner| match device_task(devices) {
        Ok(token) => spawner.spawn(token),
        Err(_) => fault::fail(Cause::Startup, 15),
    })
}

static DEVICES_TASK: StaticCell<Devices> = StaticCell::new();

#[interrupt]
fn DMA1_CHANNEL1() {
    // cortex-m-rt hands this handler the only reference to this: the period runs
    // without a critical section and masks nothing.
    static mut WATCH: Watch = Watch::new(pins::CONTROL_HZ);
    period::on_samples::<2, Machine, CellHal>(&HANDOFF, WATCH);
}

#[interrupt]
unsafe fn UCPD1() {
    // SAFETY: the interrupt executor's own interrupt, bound to nothing else.
    unsafe { LINK_EXECUTOR.on_interrupt() }
}

#[embassy_executor::task]
async fn link_task(task: &'static mut CellLink) -> ! {
    task.run().await
}

/// The devices' tick (every `DEVICES.tick_s`, 10 ms): the hexapod referenced
/// first, then the period's demand sent and the replies checked; a fault is latched
/// for the next control period. A fault is cleared here once the cell runs again
/// (the demand no longer halts): the operator reset the cell's fault, which is what
/// the link's `ResetFault` did.
#[embassy_executor::task]
async fn device_task(devices: &'static mut Devices) -> ! {
    // Referenced at power-up, as the controller requires before a move.
    // A GCS command without `?` has no answer: nothing to wait for.
    if devices.hexapod.transact(b"FRF\n", &mut []).is_err() {
        defmt::warn!("hexapod: reference command not sent");
    }
    // The device tick in the milliseconds `DEVICE_TICK` counts (10).
    let tick = (libm::round(DEVICES.tick_s * 1000.0) as u32).max(1);
    let mut ticks = 0u32;
    loop {
        DEVICE_TICK.wait().await;
        ticks = ticks.wrapping_add(1);
        if ticks % tick != 0 {
            continue;
        }
        let demand = DEVICES_SHARE.lock(|share| share.get().demand);
        if !demand.halt && devices.state.fault().is_some() {
            devices.state.reset();
        }
        let result = devices.link.tick(
            &mut devices.state,
            &demand,
            &mut devices.hexapod,
            &mut devices.spindle,
        );
        let fault = result.err();
        if let Some(f) = fault {
            defmt::warn!("devices: {}", defmt::Debug2Format(&f));
        }
        DEVICES_SHARE.lock(|share| {
            let mut s = share.get();
            s.fault = fault;
            share.set(s);
        });
    }
}
