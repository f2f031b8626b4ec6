//! kerf on the STM32G474RE: the Keops delta slave (`DeltaSlave<f32>`) behind the host
//! link, as the QEMU `link` image runs it, on real peripherals.
//!
//! - The control period is DMA1 channel 1's transfer-complete interrupt at the
//!   highest priority: TIM1's update triggers ADC1–3, the DMA puts the nine Hall
//!   samples in RAM, the interrupt calls `kerf::app::control_period` and writes the
//!   three forces (DACs) and the laser (TIM1 PWM) in the same period.
//! - The host link runs in an embassy task in thread mode on LPUART1 with DMA,
//!   preempted by every period; the calibrate button (B1) runs the Hall sweep and
//!   its fit in that task.
//! - A HardFault, a panic, a missed deadline, a broken sample set or the watchdog
//!   end in the fault path: outputs off in hardware and software, the cause kept
//!   across the reset and told to the host.
//!
//! Everything but the machine's pins, outputs and start-up is
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

use defmt_rtt as _;
use embassy_executor::Executor;
use embassy_stm32::adc::AdcChannel;
use embassy_stm32::dac::{Dac, DacChannel, DualValue, Value};
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::mode::Blocking;
use embassy_stm32::pac::interrupt;
use embassy_stm32::{bind_interrupts, dma, pac, peripherals, usart};
use heapless::spsc::{Consumer, Producer, Queue};
use kerf::app::calibrate::{CalibrationFit, HallMachine};
use kerf::app::host_link::{HostLink, HostLinkConfig};
use kerf::app::supervisor::{Command, Report, Supervisor};
use kerf::app::PeriodClock;
use kerf::hal::{Monotonic, SampleInputs, WriteOutputs};
use kerf::machines::delta_slave::link::SlaveSettings;
use kerf::machines::delta_slave::product::{
    contour_defaults, nominal_calibration, JOB_LAPS, LINK_JOB_BYTES, TELEMETRY_DECIMATION,
};
use kerf::machines::delta_slave::{DeltaSlave, DeltaSlaveConfig, SlaveOutputs};
use kerf::sensing::hall::HallConfig;
use kerf_board_support::stm32::adc::{self, AdcRow, DmaBuffer};
use kerf_board_support::stm32::fault::{self, Cause, ResetCause};
use kerf_board_support::stm32::link::{LinkTask, SweepFit, LINK_BAUD, RX_RING_BYTES};
use kerf_board_support::stm32::period::{self, BoardHal, Control, Handoff, Leds, Watch};
use kerf_board_support::stm32::pins::PinId;
use kerf_board_support::stm32::timing::{self, CycleClock, KERF_STATUS};
use kerf_board_support::stm32::{clocks, cordic, stack, timer};
use kerf_board_support::timer_period::TimerPeriod;
use static_cell::{ConstStaticCell, StaticCell};

kerf_board_support::bind_board_handlers!();

bind_interrupts!(struct Irqs {
    LPUART1 => usart::InterruptHandler<peripherals::LPUART1>;
    DMA1_CHANNEL4 => dma::InterruptHandler<peripherals::DMA1_CH4>;
    DMA1_CHANNEL5 => dma::InterruptHandler<peripherals::DMA1_CH5>;
});

/// The machine the board runs.
type Machine = DeltaSlave<f32>;

/// The board's control state.
type KeopsControl = Control<Machine, KeopsHal>;

/// The link task of this image.
type KeopsLink = LinkTask<Machine, HallFit, LINK_JOB_BYTES>;

/// Commands to the supervisor: two at a time (a queue of N holds N − 1; a command with
/// a calibration is 5 KB). The supervisor takes them within a period; the link answers
/// `Busy` to a third.
static COMMANDS: ConstStaticCell<Queue<Command<Machine>, 3>> = ConstStaticCell::new(Queue::new());
/// Reports to the link task, drained every millisecond (ten periods): 23 hold the
/// telemetry and calibration samples of twice the link task's longest wait on the
/// transmitter (11 ms).
static REPORTS: ConstStaticCell<Queue<Report<Machine>, 24>> = ConstStaticCell::new(Queue::new());
static FIT: StaticCell<HallFit> = StaticCell::new();
static RX_RING: ConstStaticCell<[u8; RX_RING_BYTES]> = ConstStaticCell::new([0; RX_RING_BYTES]);
static EXECUTOR: StaticCell<Executor> = StaticCell::new();
static CONTROL: StaticCell<KeopsControl> = StaticCell::new();
static LINK: StaticCell<KeopsLink> = StaticCell::new();
static HANDOFF: Handoff<KeopsControl> = Handoff::new();
/// The nine Hall samples of a period, `[carriage][channel]`.
static SAMPLES: DmaBuffer<3, 3> = DmaBuffer::new();

/// The board behind kerf's HAL traits: the DMA's samples in, DACs and TIM1 out, the
/// cycle counter as the clock.
struct KeopsHal {
    clock: CycleClock,
    enabled: bool,
    period: TimerPeriod,
    /// The DAC channels, held (dropping one disables it): built from typed pins,
    /// written in the period through their registers with constant channel numbers
    /// (embassy's `set` indexes the channel at run time, with a panic path the
    /// period must not have).
    _dacs: (Dac<'static, Blocking>, DacChannel<'static, Blocking>),
}

impl SampleInputs<[[u16; 3]; 3]> for KeopsHal {
    #[inline]
    fn sample(&mut self) -> [[u16; 3]; 3] {
        SAMPLES.read()
    }
}

impl WriteOutputs<SlaveOutputs<f32>> for KeopsHal {
    #[inline]
    fn write(&mut self, outputs: &SlaveOutputs<f32>) {
        let [a, b, c] = outputs.force_n.map(|f| pins::FORCE_DAC.code(f));
        // Both DAC1 channels in one write (DAC_DHR12RD), so A and B change together.
        pac::DAC1.dhr12rd().write(|w| {
            w.set_dhr(0, a);
            w.set_dhr(1, b);
        });
        pac::DAC2.dhr12r(0).write(|w| w.set_dhr(c));
        // Preloaded: the duty takes effect at the next update, the start of the next
        // period, as the forces do once their DACs settle (1 µs, DS12288).
        timer::write(&self.period, outputs.laser_duty, self.enabled);
    }
}

impl Monotonic for KeopsHal {
    fn tick_hz(&self) -> u64 {
        self.clock.tick_hz()
    }

    #[inline]
    fn now(&mut self) -> u64 {
        self.clock.now()
    }
}

impl BoardHal<Machine> for KeopsHal {
    fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }
}

/// Zero force on the three DACs, as register writes for the fault path's software
/// half: DAC1's dual register (both channels at once) and DAC2 channel 1.
fn register_safe_dacs() {
    let zero = u32::from(pins::DAC_ZERO);
    fault::set_safe_writes(&[
        (pac::DAC1.dhr12rd().as_ptr().cast(), zero | zero << 16),
        (pac::DAC2.dhr12r(0).as_ptr().cast(), zero),
    ]);
}

/// The Hall sweep's samples and fit, for the calibrate button.
struct HallFit {
    /// The Hall sensors as configured (the fit starts from them), in flash: five
    /// kilobytes the RAM does not hold.
    hall: &'static [HallConfig; 3],
    /// The sweep's samples (9 KB).
    samples: CalibrationFit<3>,
}

impl SweepFit<Machine> for HallFit {
    const SWEEPS: bool = true;

    fn restart(&mut self) {
        self.samples = CalibrationFit::default();
    }

    fn push(&mut self, sample: &kerf::app::calibrate::HallSample) -> bool {
        self.samples.push(*sample).is_ok()
    }

    fn fit(&mut self) -> Option<<Machine as kerf::app::supervisor::Machine>::Calibration> {
        match Machine::fit(self.hall, &self.samples) {
            Ok((decoders, fits)) => {
                for (axis, fit) in fits.iter().enumerate() {
                    defmt::info!(
                        "calibration: axis {} offsets {} counts, residual {} counts RMS",
                        axis,
                        fit.calibration.offset_counts,
                        fit.residual_rms_counts
                    );
                    if let Some(raised) = fit.fault_budget_raised {
                        defmt::warn!(
                            "calibration: axis {} fault budget {} um (configured {} um: more than its noise allows)",
                            axis,
                            raised.installed_m * 1e6,
                            raised.requested_m * 1e6
                        );
                    }
                }
                Some(decoders)
            }
            Err(e) => {
                defmt::error!("calibration failed: {}", defmt::Debug2Format(&e));
                None
            }
        }
    }
}

/// The machine and its supervisor, built into their static and handed to the control
/// interrupt. Out of line: its frame holds copies of the machine (kilobytes each)
/// while it runs and is released before the executor starts; `main`'s own frame
/// stays for ever.
#[inline(never)]
fn start_machine(
    machine: &DeltaSlaveConfig,
    hal: KeopsHal,
    leds: Leds,
    from_sender: Consumer<'static, Command<Machine>>,
    to_link: Producer<'static, Report<Machine>>,
) {
    let Ok(clock) = PeriodClock::new(machine.joints.period_s, u64::from(clocks::SYSCLK_HZ)) else {
        fault::fail(Cause::Startup, 8)
    };
    let Ok(slave) = Machine::new(machine) else {
        fault::fail(Cause::Startup, 4)
    };
    let period = hal.period;
    let control = CONTROL.init_with(|| {
        let mut supervisor = Supervisor::new(slave, from_sender, to_link);
        supervisor.set_telemetry_decimation(TELEMETRY_DECIMATION);
        Control {
            supervisor,
            clock,
            hal,
            period,
            leds,
        }
    });
    HANDOFF.hand_over(control);
}

/// Queues the nominal decoders as a stored calibration (as the QEMU link image does;
/// the calibration run, button B1, replaces them). Out of line, as [`start_machine`].
#[inline(never)]
fn store_nominal_calibration(
    machine: &DeltaSlaveConfig,
    commands: &mut Producer<'static, Command<Machine>>,
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

/// What the link task is given besides its own state.
struct LinkParts {
    commands: Producer<'static, Command<Machine>>,
    reports: Consumer<'static, Report<Machine>>,
    rx: usart::RingBufferedUartRx<'static>,
    tx: usart::UartTx<'static, embassy_stm32::mode::Async>,
    button: PinId,
}

/// The host link's state, built into its static (out of line, as [`start_machine`]).
#[inline(never)]
fn start_link(
    machine: &DeltaSlaveConfig,
    parts: LinkParts,
    reset: ResetCause,
) -> &'static mut KeopsLink {
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
    let fit = FIT.init_with(|| HallFit {
        hall: &DeltaSlaveConfig::KEOPS.joints.hall,
        samples: CalibrationFit::default(),
    });
    LINK.init_with(|| LinkTask {
        link: host_link,
        commands: parts.commands,
        reports: parts.reports,
        rx: parts.rx,
        tx: parts.tx,
        fit,
        reset,
        button: parts.button,
        control_hz: pins::CONTROL_HZ,
    })
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let reset = fault::take_reset_cause();
    stack::paint();
    let p = embassy_stm32::init(clocks::config());
    let Some(mut core) = cortex_m::Peripherals::take() else {
        fault::fail(Cause::Startup, 1)
    };
    timing::start(&mut core.DCB, &mut core.DWT);
    register_safe_dacs();
    let leds = Leds {
        status: PinId::of(&*p.PC6),
        fault: PinId::of(&*p.PC7),
    };
    leds.status.set_output(false);
    leds.fault.set_output(reset.cause.is_fault());
    let button = PinId::of(&*p.PC13);
    button.set_input();
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
    if libm::fabs(machine.joints.period_s * f64::from(pins::CONTROL_HZ) - 1.0) > 1e-9 {
        fault::fail(Cause::Startup, 2)
    }
    let Ok(period) = timer::period_of(clocks::SYSCLK_HZ / pins::CONTROL_HZ) else {
        fault::fail(Cause::Startup, 3)
    };
    KERF_STATUS.period_cycles.store(
        clocks::SYSCLK_HZ / pins::CONTROL_HZ,
        core::sync::atomic::Ordering::Relaxed,
    );

    // The wiring (pins.rs): typed, so a channel on the wrong ADC does not compile.
    let hall = [
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
        AdcRow::adc3([
            p.PB0.degrade_adc(),
            p.PB1.degrade_adc(),
            p.PB13.degrade_adc(),
        ]),
    ];
    let tim1 = timer::Tim1Pins::new(p.PA8, p.PA9, p.PB12);
    let mut dac_ab = Dac::new_blocking(p.DAC1, p.PA4, p.PA5);
    dac_ab.set(DualValue::Bit12Right(pins::DAC_ZERO, pins::DAC_ZERO));
    let mut dac_c = DacChannel::new_blocking(p.DAC2, p.PA6);
    dac_c.set(Value::Bit12Right(pins::DAC_ZERO));
    let hal = KeopsHal {
        clock: CycleClock::new(),
        enabled: false,
        period,
        _dacs: (dac_ab, dac_c),
    };

    // Constant-initialised cells: in .bss, never built on the stack.
    let (mut to_machine, from_sender) = COMMANDS.take().split();
    let (to_link, from_machine) = REPORTS.take().split();
    start_machine(&machine, hal, leds, from_sender, to_link);
    store_nominal_calibration(&machine, &mut to_machine);

    let mut uart_config = usart::Config::default();
    uart_config.baudrate = LINK_BAUD;
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
    pac::Interrupt::LPUART1.set_priority(Priority::from(clocks::LINK_PRIORITY));
    let (tx, rx) = uart.split();
    let rx = rx.into_ring_buffered(RX_RING.take());
    let parts = LinkParts {
        commands: to_machine,
        reports: from_machine,
        rx,
        tx,
        button,
    };
    let task = start_link(&machine, parts, reset);

    if let Err(e) = adc::start(&hall, &SAMPLES) {
        defmt::error!("sampling: {}", e);
        fault::fail(Cause::Startup, 10)
    }
    period::enable(&mut core.NVIC, pac::Interrupt::DMA1_CHANNEL1);
    match timer::start(&tim1, period, false) {
        Ok(()) => {}
        Err(timer::TimerError::BreakActive) => {
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
        pins::CONTROL_HZ,
        LINK_BAUD
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
    static mut WATCH: Watch = Watch::new(pins::CONTROL_HZ);
    period::on_samples::<3, Machine, KeopsHal>(&HANDOFF, WATCH);
}

#[embassy_executor::task]
async fn link_task(task: &'static mut KeopsLink) -> ! {
    task.run().await
}
