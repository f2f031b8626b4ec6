//! kerf on the STM32G474RE: ARROW (`Arrow<f32>`) behind the host link, as the QEMU
//! `arrow-link` image runs it, with its six linear actuators as CANopen CiA 402 servo
//! drives in cyclic synchronous torque on three CAN FD buses (docs/drives.md).
//!
//! - TIM1's update (5 kHz) opens each bus cycle: the master (`kerf::app::drive_set`)
//!   writes the SYNC and the RPDO with the forces of the period before into each
//!   bus's transmit buffers (`kerf_board_support::stm32::can`: the FDCAN's message
//!   RAM, read and written by the control interrupts themselves).
//!   The drives answer the SYNC with their positions (TPDOs), all in within 130 µs;
//!   TIM1's channel 3 compare at 140 µs runs the supervisor step on them, and its
//!   forces go out at the next update. Both interrupts share the highest priority.
//! - The two turntable motors are local: quadrature encoders on TIM3 and TIM4, torque
//!   commands on DAC1 through current-input amplifiers.
//! - The drives are brought up (NMT, the CiA 402 state machine to Operation
//!   enabled: 15 periods) before the first control period; a drive that does not
//!   come up is the machine's fault from the first period, in words.
//! - TIM1 CH2 is the enable of the drives' safe torque off inputs and of the
//!   turntable amplifiers: the break (PB12) and the fault path drop it in hardware;
//!   the drives' own SYNC watchdog takes their torque off when the board stops.
//! - Not yet: jobs. Planning a G-code program on this board does not fit its RAM
//!   ([`UPLOAD_BYTES`]); calibration, settings, telemetry, status and faults work as
//!   on the QEMU image.
//!
//! | signal | pin | peripheral |
//! |---|---|---|
//! | drive bus 1 (actuators 1, 2) | PB8 (RX), PB9 (TX) | FDCAN1 |
//! | drive bus 2 (actuators 3, 4) | PB5 (RX), PB6 (TX) | FDCAN2 |
//! | drive bus 3 (actuators 5, 6) | PA8 (RX), PA15 (TX) | FDCAN3 |
//! | turntable encoder 1, 2 | PA6/PA7, PA11/PA12 | TIM3, TIM4 (quadrature) |
//! | turntable torque 1, 2 | PA4, PA5 | DAC1 OUT1, OUT2 (mid-scale = zero torque) |
//! | drives' STO and amplifiers' enable | PA9 | TIM1 CH2 (pull-downs at the receivers) |
//! | E-stop / fault in | PB12 | TIM1 BKIN (low or open = outputs off) |
//! | host link | PA2 (TX), PA3 (RX) | LPUART1 |
//! | button, status LED, fault LED | PC13, PC6, PC7 | GPIO |
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
use embassy_stm32::dac::{Dac, DualValue};
use embassy_stm32::mode::Blocking;
use embassy_stm32::pac::{self, interrupt};
use embassy_stm32::peripherals::{TIM3, TIM4};
use embassy_stm32::timer::qei::{Config as QeiConfig, Qei};
use embassy_stm32::{bind_interrupts, can, dma, peripherals, usart};
use heapless::spsc::Queue;
use kerf::app::drive_set::Phase;
use kerf::app::jobs::JobSlots;
use kerf::app::supervisor::{Command, Report};
use kerf::codec::canopen::CanFrame;
use kerf::control::redundant_pid::RedundantPidConfig;
use kerf::hal::{Monotonic, SampleInputs, WriteOutputs};
use kerf::machines::arrow::drives::{forces, joints, ArrowDrives, ARROW_DRIVES};
use kerf::machines::arrow::link::ArrowSettings;
use kerf::machines::arrow::machine::{ArrowInputs, ArrowLimits, ArrowOutputs};
use kerf::machines::arrow::product::{law, Arrow, Job, PERIOD_S, TELEMETRY_DECIMATION};
use kerf_board_support::output_codes::ForceDac;
use kerf_board_support::stm32::can::FdBus;
use kerf_board_support::stm32::clocks::SYSCLK_HZ;
use kerf_board_support::stm32::fault::{self, Cause};
use kerf_board_support::stm32::image::{self, Image, Trigger};
use kerf_board_support::stm32::link::{host_uart, LinkTask, Stored, RX_RING_BYTES};
use kerf_board_support::stm32::period::{self, BoardHal, Control, Handoff, Leds, Watch};
use kerf_board_support::stm32::pins::PinId;
use kerf_board_support::stm32::timing::{self, CycleClock};
use kerf_board_support::stm32::{start_board, timer};
use kerf_board_support::timer_period::TimerPeriod;
use static_cell::{ConstStaticCell, StaticCell};

kerf_board_support::bind_board_handlers!();

bind_interrupts!(struct Irqs {
    LPUART1 => usart::InterruptHandler<peripherals::LPUART1>;
    DMA1_CHANNEL4 => dma::InterruptHandler<peripherals::DMA1_CH4>;
    DMA1_CHANNEL5 => dma::InterruptHandler<peripherals::DMA1_CH5>;
    FDCAN1_IT0 => can::IT0InterruptHandler<peripherals::FDCAN1>;
    FDCAN1_IT1 => can::IT1InterruptHandler<peripherals::FDCAN1>;
    FDCAN2_IT0 => can::IT0InterruptHandler<peripherals::FDCAN2>;
    FDCAN2_IT1 => can::IT1InterruptHandler<peripherals::FDCAN2>;
    FDCAN3_IT0 => can::IT0InterruptHandler<peripherals::FDCAN3>;
    FDCAN3_IT1 => can::IT1InterruptHandler<peripherals::FDCAN3>;
});

/// The machine the board runs.
type Machine = Arrow<f32>;
/// The link task of this image: ARROW's calibration is empty (its scales are
/// absolute), finished with nothing.
type Link = LinkTask<Machine, Stored<()>, UPLOAD_BYTES>;

/// Bytes of an uploaded job this image holds: none. Planning a G-code program into
/// ARROW's job (parse buffer, splines in f64, the moves) takes 93 KB of the link
/// task's stack, and the 41 KB the statics leave (two 34 KB job buffers among them)
/// cannot hold it: an upload is refused as too large before anything is planned
/// (docs/board.md). The product's own capacity, for the QEMU image and the host, is
/// `kerf::machines::arrow::product::LINK_JOB_BYTES`.
const UPLOAD_BYTES: usize = 0;

/// The control rate, Hz: ARROW's period of 200 µs (A §5.1; checked at start-up).
const CONTROL_HZ: u32 = 5_000;

/// Where the step starts in the period, timer ticks (core cycles: no prescale at
/// 5 kHz): 140 µs, after the TPDOs of the period's SYNC are in (130 µs at the
/// buses' 1 / 8 Mbit/s, docs/drives.md); the step (some 7,200 cycles, 42 µs) ends
/// before the period does.
const STEP_AT_TICKS: u16 = 23_800;

/// The buses' rates: 1 Mbit/s arbitration, 8 Mbit/s data (docs/drives.md: 5 Mbit/s
/// does not fit the period).
const NOMINAL_BPS: u32 = 1_000_000;
/// See [`NOMINAL_BPS`].
const DATA_BPS: u32 = 8_000_000;

/// Turntable encoder counts per motor turn: 5,000 lines counted in quadrature (A §5.1).
const TABLE_COUNTS_PER_TURN: f32 = 20_000.0;

/// The turntable amplifiers' transconductance, A per V about mid-scale, and the
/// motors' torque constant, N·m per A (set both to the hardware's).
const TABLE_AMPS_PER_VOLT: f32 = 2.0;
/// See [`TABLE_AMPS_PER_VOLT`].
const TABLE_TORQUE_CONSTANT_NM_PER_A: f32 = 0.5;

/// The DAC code of zero torque (mid-scale).
const DAC_ZERO: u16 = 2048;

/// The chain from a turntable torque to a DAC code.
const TABLE_DAC: ForceDac = ForceDac::new(
    DAC_ZERO,
    TABLE_TORQUE_CONSTANT_NM_PER_A,
    TABLE_AMPS_PER_VOLT,
    3.3 / 4096.0,
);

/// Periods the drives are given to come up before the machine starts: 1.2 s, beyond
/// the master's own bring-up timeouts (1 s for the boot-up).
const BRING_UP_PERIODS: u32 = 6_000;

static COMMANDS: ConstStaticCell<Queue<Command<Machine>, 3>> = ConstStaticCell::new(Queue::new());
/// Reports to the link task, drained every millisecond (five periods).
static REPORTS: ConstStaticCell<Queue<Report<Machine>, 16>> = ConstStaticCell::new(Queue::new());
static FIT: StaticCell<Stored<()>> = StaticCell::new();
/// The two job buffers (34 KB each: a job is built in one and runs from it).
static JOBS: StaticCell<JobSlots<Job<f32>>> = StaticCell::new();
static RX_RING: ConstStaticCell<[u8; RX_RING_BYTES]> = ConstStaticCell::new([0; RX_RING_BYTES]);
static EXECUTOR: StaticCell<Executor> = StaticCell::new();
static CONTROL: StaticCell<Control<Machine, ArrowHal>> = StaticCell::new();
static LINK: StaticCell<Link> = StaticCell::new();
static HANDOFF: Handoff<Control<Machine, ArrowHal>> = Handoff::new();

/// The board behind kerf's HAL traits: the drive set on its buses, the turntable's
/// encoders and amplifiers, the cycle counter as the clock.
struct ArrowHal {
    clock: CycleClock,
    enabled: bool,
    period: TimerPeriod,
    drives: ArrowDrives<f32>,
    buses: [FdBus; 3],
    /// The actuators' last positions (held through a bridged TPDO).
    joints_m: [f32; 6],
    table: (Qei<'static, TIM3>, Qei<'static, TIM4>),
    /// The turntable's counts, extended past the counters' 16 bits.
    table_counts: [i32; 2],
    table_last: [u16; 2],
    /// The turntable's DAC channels, held (dropping one disables it); written through
    /// their register in the period.
    _table_dac: Dac<'static, Blocking>,
}

impl ArrowHal {
    /// Every frame the buses received, to the master.
    fn drain(&mut self) {
        let drives = &mut self.drives;
        for (bus, port) in (0u8..).zip(self.buses.iter_mut()) {
            port.drain(|frame: &CanFrame| drives.receive(bus, frame));
        }
    }

    /// The period's start: what arrived since, then the SYNC and the RPDOs (or the
    /// bring-up's frames) queued on the buses.
    fn tick(&mut self) {
        self.drain();
        let buses = &mut self.buses;
        self.drives.start_period(&mut |bus, frame: &CanFrame| {
            if let Some(port) = buses.get_mut(usize::from(bus)) {
                port.transmit(frame);
            }
        });
    }

    /// The turntable's counts since start-up (16-bit counters, read at least once a
    /// period: far fewer than 32,768 counts a period at any speed the table reaches).
    fn table_rad(&mut self) -> [f32; 2] {
        let now = [self.table.0.count(), self.table.1.count()];
        let mut rad = [0.0; 2];
        for ((count, last), (total, out)) in now
            .iter()
            .zip(self.table_last.iter_mut())
            .zip(self.table_counts.iter_mut().zip(rad.iter_mut()))
        {
            *total = total.wrapping_add(i32::from(count.wrapping_sub(*last) as i16));
            *last = *count;
            *out = *total as f32 * (core::f32::consts::TAU / TABLE_COUNTS_PER_TURN);
        }
        rad
    }
}

impl SampleInputs<ArrowInputs<f32>> for ArrowHal {
    fn sample(&mut self) -> ArrowInputs<f32> {
        self.drain();
        let drive_fault = match self.drives.feedback() {
            Ok(Some(p)) => {
                self.joints_m = p;
                None
            }
            Ok(None) => None,
            Err(f) => Some(f),
        };
        ArrowInputs {
            joints_m: joints(&self.joints_m),
            table_rad: self.table_rad(),
            drive_fault,
        }
    }
}

impl WriteOutputs<ArrowOutputs<f32>> for ArrowHal {
    fn write(&mut self, outputs: &ArrowOutputs<f32>) {
        if self.enabled {
            self.drives.command(&forces(&outputs.forces_n));
        } else {
            // Quick stop and zero torque from the next tick.
            self.drives.stop();
        }
        let [a, b] = outputs.torques_n_m.map(|t| TABLE_DAC.code(t));
        pac::DAC1.dhr12rd().write(|w| {
            w.set_dhr(0, a);
            w.set_dhr(1, b);
        });
        timer::write(&self.period, 0.0, self.enabled);
    }
}

impl Monotonic for ArrowHal {
    fn tick_hz(&self) -> u64 {
        self.clock.tick_hz()
    }

    #[inline]
    fn now(&mut self) -> u64 {
        self.clock.now()
    }
}

impl BoardHal<Machine> for ArrowHal {
    fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }
}

/// Brings the drives up before the first control period, one bus cycle per period
/// on the cycle counter (the control interrupts are not running yet).
fn bring_up(hal: &mut ArrowHal, period_cycles: u32) {
    let mut next = timing::cycles();
    for _ in 0..BRING_UP_PERIODS {
        while timing::cycles().wrapping_sub(next) >= period_cycles {}
        while (timing::cycles().wrapping_sub(next) as i32) < 0 {}
        next = next.wrapping_add(period_cycles);
        hal.tick();
        match hal.drives.phase() {
            Phase::Operational => {
                defmt::info!("drives: Operation enabled");
                return;
            }
            Phase::Faulted(f) => {
                defmt::error!("drives: {}", defmt::Debug2Format(&f));
                return;
            }
            Phase::BringingUp(_) => {}
        }
    }
    defmt::error!("drives: not up after {} periods", BRING_UP_PERIODS);
}

/// ARROW's empty calibration at power-up (its scales are absolute): the link task
/// finishes it with nothing when the sweep is done.
fn calibrate() -> Option<Command<Machine>> {
    Some(Command::Calibrate)
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let (p, mut core, reset) = start_board();
    defmt::info!("kerf ARROW board: reset by {}", reset);
    let period_cycles = SYSCLK_HZ / CONTROL_HZ;
    let Ok(period) = timer::period_of(period_cycles) else {
        fault::fail(Cause::Startup, 3)
    };
    let Ok(drives) = ArrowDrives::<f32>::new(&ARROW_DRIVES) else {
        fault::fail(Cause::Startup, 16)
    };
    let buses = [
        FdBus::open(
            p.FDCAN1,
            p.PB8,
            p.PB9,
            Irqs,
            (pac::FDCAN1, pac::FDCANRAM1),
            NOMINAL_BPS,
            DATA_BPS,
        ),
        FdBus::open(
            p.FDCAN2,
            p.PB5,
            p.PB6,
            Irqs,
            (pac::FDCAN2, pac::FDCANRAM2),
            NOMINAL_BPS,
            DATA_BPS,
        ),
        FdBus::open(
            p.FDCAN3,
            p.PA8,
            p.PA15,
            Irqs,
            (pac::FDCAN3, pac::FDCANRAM3),
            NOMINAL_BPS,
            DATA_BPS,
        ),
    ];
    let table = (
        Qei::new(p.TIM3, p.PA6, p.PA7, QeiConfig::default()),
        Qei::new(p.TIM4, p.PA11, p.PA12, QeiConfig::default()),
    );
    let mut table_dac = Dac::new_blocking(p.DAC1, p.PA4, p.PA5);
    table_dac.set(DualValue::Bit12Right(DAC_ZERO, DAC_ZERO));
    let zero = u32::from(DAC_ZERO);
    fault::set_safe_writes(&[(pac::DAC1.dhr12rd().as_ptr().cast(), zero | zero << 16)]);
    let table_last = [table.0.count(), table.1.count()];
    let mut hal = ArrowHal {
        clock: CycleClock::new(),
        enabled: false,
        period,
        drives,
        buses,
        joints_m: [0.0; 6],
        table,
        table_counts: [0; 2],
        table_last,
        _table_dac: table_dac,
    };
    bring_up(&mut hal, period_cycles);
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
    let image = Image::<_, _, _, UPLOAD_BYTES, 0, 0> {
        name: "ARROW",
        control_hz: CONTROL_HZ,
        period_s: PERIOD_S,
        telemetry_decimation: TELEMETRY_DECIMATION,
        hal,
        trigger: Trigger::Bus {
            step_at_ticks: STEP_AT_TICKS,
        },
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
        startup: &[calibrate],
        link: (ArrowSettings::ARROW, ()),
        fit: FIT.init_with(|| Stored(())),
        reset,
        flash: p.FLASH,
    };
    let task = image::start(
        image,
        || {
            let law = law::<f32>(
                &RedundantPidConfig::ARROW_PARALLEL,
                &RedundantPidConfig::ARROW_TURNTABLE,
                true,
                PERIOD_S,
            )
            .ok()?;
            Machine::new(law, PERIOD_S, &ArrowLimits::ARROW).ok()
        },
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
fn TIM1_UP_TIM16() {
    period::on_tick::<Machine, ArrowHal>(&HANDOFF, ArrowHal::tick);
}

#[interrupt]
fn TIM1_CC() {
    // cortex-m-rt hands this handler the only reference to this.
    static mut WATCH: Watch = Watch::new(CONTROL_HZ);
    period::on_compare::<Machine, ArrowHal>(&HANDOFF, WATCH);
}

#[embassy_executor::task]
async fn link_task(task: &'static mut Link) -> ! {
    task.run().await
}
