//! The core clock: 170 MHz from HSI16 / 4 × 85 / 2 (RM0440, RCC "PLL"; above 150 MHz
//! the core needs range 1 boost mode, PWR "Dynamic voltage scaling management"). No
//! crystal is needed, so every image runs on a bare NUCLEO-G474RE.

use embassy_stm32::interrupt::Priority;

/// Core clock, Hz.
pub const SYSCLK_HZ: u32 = 170_000_000;

/// NVIC priority of the control interrupt (the highest: 0) and of the link's UART and
/// DMA interrupts and its tick (below it; the G474 implements four priority bits).
pub const CONTROL_PRIORITY: u8 = 0;
/// See [`CONTROL_PRIORITY`].
pub const LINK_PRIORITY: u8 = 0x40;

/// The clock tree, with embassy's DMA interrupts below the control interrupt.
pub fn config() -> embassy_stm32::Config {
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
