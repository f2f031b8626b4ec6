//! One board image of a Hall-sensed machine, written once: [`hall_image!`] expands
//! to an image's statics, its `main`, its control interrupt (DMA1 channel 1) and its
//! link task, given the machine and what differs between machines.

/// A Hall-sensed machine's board image (`kerf_board::hall`'s wiring, the board
/// layer's start-up). Write it once at the top level of the image's `main.rs`:
///
/// ```text
/// kerf_board::hall_image! {
///     name: "single axis",            // in the log
///     machine: Axis<f32>,             // a LinkMachine
///     carriages: 1,                   // 1 (ADC1, DAC1 OUT1) or 3 (ADC1–3, DAC1–2)
///     laser: false,                   // TIM1 CH1 on PA8 as the laser's PWM
///     job_bytes: LINK_JOB_BYTES,      // the link's upload buffer
///     commands: 4, reports: 24,       // queue lengths (a queue of N holds N − 1)
///     control_hz: 10_000,
///     period_s: PERIOD_S,             // checked against control_hz at start-up
///     telemetry_decimation: TELEMETRY_DECIMATION,
///     fit: HallFit<Axis<f32>, 1> = HallFit::new(&CONFIG.hall),
///     startup: nominal,               // fn() -> Option<Command<machine>>
///     link: (AxisSettings::of(&CONFIG.axis), CONFIG),
///     new: || Axis::<f32>::new(&CONFIG).ok(),
/// }
/// ```
#[macro_export]
macro_rules! hall_image {
    (
        name: $name:expr,
        machine: $machine:ty,
        carriages: $n:tt,
        laser: $laser:tt,
        job_bytes: $job:expr,
        commands: $commands:expr, reports: $reports:expr,
        control_hz: $hz:expr,
        period_s: $period_s:expr,
        telemetry_decimation: $decimation:expr,
        fit: $fit:ty = $fit_new:expr,
        startup: $startup:expr,
        link: $link:expr,
        new: $new:expr $(,)?
    ) => {
        use defmt_rtt as _;
        use embassy_stm32::pac::interrupt;

        kerf_board_support::bind_board_handlers!();

        embassy_stm32::bind_interrupts!(struct Irqs {
            LPUART1 => embassy_stm32::usart::InterruptHandler<embassy_stm32::peripherals::LPUART1>;
            DMA1_CHANNEL4 => embassy_stm32::dma::InterruptHandler<embassy_stm32::peripherals::DMA1_CH4>;
            DMA1_CHANNEL5 => embassy_stm32::dma::InterruptHandler<embassy_stm32::peripherals::DMA1_CH5>;
        });

        /// The board behind the HAL traits.
        type Hal = $crate::hall::HallHal<$n>;
        /// The control state.
        type ImageControl = kerf_board_support::stm32::period::Control<$machine, Hal>;
        /// The link task.
        type ImageLink = kerf_board_support::stm32::link::LinkTask<$machine, $fit, { $job }>;

        /// The control rate, Hz (checked against the machine's period at start-up).
        const CONTROL_HZ: u32 = $hz;

        static COMMANDS: static_cell::ConstStaticCell<
            heapless::spsc::Queue<kerf::app::supervisor::Command<$machine>, { $commands }>,
        > = static_cell::ConstStaticCell::new(heapless::spsc::Queue::new());
        static REPORTS: static_cell::ConstStaticCell<
            heapless::spsc::Queue<kerf::app::supervisor::Report<$machine>, { $reports }>,
        > = static_cell::ConstStaticCell::new(heapless::spsc::Queue::new());
        static FIT: static_cell::StaticCell<$fit> = static_cell::StaticCell::new();
        static JOBS: static_cell::StaticCell<
            kerf::app::jobs::JobSlots<<$machine as kerf::app::supervisor::Machine>::Job>,
        > = static_cell::StaticCell::new();
        static RX_RING: static_cell::ConstStaticCell<
            [u8; kerf_board_support::stm32::link::RX_RING_BYTES],
        > = static_cell::ConstStaticCell::new([0; kerf_board_support::stm32::link::RX_RING_BYTES]);
        static EXECUTOR: static_cell::StaticCell<embassy_executor::Executor> =
            static_cell::StaticCell::new();
        static CONTROL: static_cell::StaticCell<ImageControl> = static_cell::StaticCell::new();
        static LINK: static_cell::StaticCell<ImageLink> = static_cell::StaticCell::new();
        static HANDOFF: kerf_board_support::stm32::period::Handoff<ImageControl> =
            kerf_board_support::stm32::period::Handoff::new();
        /// The Hall samples of a period, `[carriage][channel]`.
        static SAMPLES: kerf_board_support::stm32::adc::DmaBuffer<$n, 3> =
            kerf_board_support::stm32::adc::DmaBuffer::new();

        #[cortex_m_rt::entry]
        fn main() -> ! {
            use kerf_board_support::stm32::fault::{self, Cause};
            use kerf_board_support::stm32::pins::PinId;
            use kerf_board_support::stm32::{clocks, cordic, image, link, period, timer};
            let (p, mut core, reset) = kerf_board_support::stm32::start_board();
            defmt::info!("kerf {} board: reset by {}", $name, reset);
            cordic::start();
            let cmp = cordic::compare();
            defmt::info!(
                "cordic phase vs library atan2: worst difference {} (2^-32 turn), {} vs {} cycles per call",
                cmp.worst_difference,
                cmp.cordic_cycles,
                cmp.library_cycles
            );
            let Ok(period) = timer::period_of(clocks::SYSCLK_HZ / CONTROL_HZ) else {
                fault::fail(Cause::Startup, 3)
            };
            let (rows, hal) = $crate::hall_image!(@wire $n, p, period);
            let Ok(uart) = link::host_uart(
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
            let image = image::Image {
                name: $name,
                control_hz: CONTROL_HZ,
                period_s: $period_s,
                telemetry_decimation: $decimation,
                hal,
                trigger: image::Trigger::Adc(&rows, &SAMPLES),
                tim1: $crate::hall_image!(@tim1 $laser, p),
                leds: period::Leds::new(
                    PinId::of(&*p.PC6),
                    PinId::of(&*p.PC7),
                    reset.cause.is_fault(),
                ),
                button: PinId::input(&*p.PC13),
                uart,
                commands: COMMANDS.take().split(),
                reports: REPORTS.take().split(),
                jobs: JOBS.init_with(Default::default),
                startup: &[$startup],
                link: $link,
                fit: FIT.init_with(|| $fit_new),
                reset,
                flash: p.FLASH,
            };
            let task = image::start(image, $new, &CONTROL, &HANDOFF, &LINK, &mut core.NVIC);
            let executor = EXECUTOR.init(embassy_executor::Executor::new());
            executor.run(|spawner| match link_task(task) {
                Ok(token) => spawner.spawn(token),
                Err(_) => fault::fail(Cause::Startup, 12),
            })
        }

        #[interrupt]
        fn DMA1_CHANNEL1() {
            // cortex-m-rt hands this handler the only reference to this: the period
            // runs without a critical section and masks nothing.
            static mut WATCH: kerf_board_support::stm32::period::Watch =
                kerf_board_support::stm32::period::Watch::new(CONTROL_HZ);
            kerf_board_support::stm32::period::on_samples::<$n, $machine, Hal>(&HANDOFF, WATCH);
        }

        #[embassy_executor::task]
        async fn link_task(task: &'static mut ImageLink) -> ! {
            task.run().await
        }
    };
    (@wire 1, $p:ident, $period:ident) => {
        Hal::one($period, &SAMPLES, ($p.PC0, $p.PC1, $p.PC2), ($p.DAC1, $p.PA4))
    };
    (@wire 3, $p:ident, $period:ident) => {
        Hal::three(
            $period,
            &SAMPLES,
            (
                ($p.PC0, $p.PC1, $p.PC2),
                ($p.PC4, $p.PC5, $p.PB2),
                ($p.PB0, $p.PB1, $p.PB13),
            ),
            ($p.DAC1, $p.PA4, $p.PA5, $p.DAC2, $p.PA6),
        )
    };
    (@tim1 true, $p:ident) => {
        kerf_board_support::stm32::timer::Tim1Pins::new($p.PA8, $p.PA9, $p.PB12)
    };
    (@tim1 false, $p:ident) => {
        kerf_board_support::stm32::timer::Tim1Pins::without_pwm($p.PA9, $p.PB12)
    };
}
