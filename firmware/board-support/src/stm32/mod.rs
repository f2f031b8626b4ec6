//! The STM32G474 layer of the board images: what every machine's image does the
//! same way, written once.
//!
//! | part | module | what it owns |
//! |---|---|---|
//! | clocks | [`clocks`] | 170 MHz from HSI16 through the PLL |
//! | pins | [`pins`] | a typed pin (embassy's pin traits) to its port, number and alternate function |
//! | sampling | [`adc`] | up to three ADCs converting on TIM1's trigger, copied by DMA1 |
//! | outputs | [`timer`] | TIM1: the period's trigger, a PWM channel, the enable line, the break (the DACs are embassy's typed channels) |
//! | control period | [`period`] | the supervisor step in the control interrupt, its deadline, the watchdog's refresh |
//! | host link | [`link`] | LPUART1 with DMA, the link task, the calibration sweep from the button |
//! | drive buses | [`can`] | a CAN FD bus carrying kerf's frames, its message RAM read and written by the control interrupts |
//! | devices | [`serial`] | a device's request/reply exchange on a polled UART |
//! | start-up | [`image`] | the machine handed to the control interrupt, the link built, sampling and outputs started |
//! | fault path | [`fault`] | outputs safe in hardware and software, the cause kept across a reset |
//! | settings store | [`store`] | the settings' two copies in the flash's last pages, a save at rest and the restart after it |
//! | timing | [`timing`] | the cycle counter as the period clock, the step's statistics |
//! | stack | [`stack`] | painting and the high-water mark |
//!
//! A machine's image adds its pin table (typed peripherals: a channel on the wrong
//! ADC or a DAC pin on the wrong DAC does not compile), its implementation of
//! `kerf::hal` on these parts, its start-up commands and its interrupt bindings
//! (a library cannot bind an interrupt reliably: [`bind_board_handlers!`] writes
//! the image's HardFault and link-tick handlers).

pub mod adc;
pub mod can;
pub mod clocks;
pub mod cordic;
pub mod fault;
pub mod image;
pub mod link;
pub mod period;
pub mod pins;
pub mod serial;
pub mod stack;
pub mod store;
pub mod timer;
pub mod timing;

/// What every image does first: the last reset's cause read (before anything can
/// overwrite the record), the stack painted, the clocks and embassy started, the
/// cycle counter running. Returns the peripherals, the core's, and the cause.
pub fn start_board() -> (
    embassy_stm32::Peripherals,
    cortex_m::Peripherals,
    fault::ResetCause,
) {
    let reset = fault::take_reset_cause();
    stack::paint();
    let p = embassy_stm32::init(clocks::config());
    let Some(mut core) = cortex_m::Peripherals::take() else {
        fault::fail(crate::fault_record::Cause::Startup, 1)
    };
    timing::start(&mut core.DCB, &mut core.DWT);
    (p, core, reset)
}

/// Writes the handlers every board image binds: the HardFault exception (the fault
/// path) and the link's tick interrupt ([`period::TICK_INTERRUPT`], woken by the
/// control period). Call once at the top level of the image's `main.rs`.
#[macro_export]
macro_rules! bind_board_handlers {
    () => {
        mod board_handlers {
            use embassy_stm32::pac::interrupt;

            #[cortex_m_rt::exception]
            unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
                $crate::stm32::fault::fail(
                    $crate::fault_record::Cause::HardFault,
                    frame.pc() & 0xFFFF,
                )
            }

            #[interrupt]
            fn FMAC() {
                $crate::stm32::period::on_tick_interrupt();
            }
        }
    };
}
