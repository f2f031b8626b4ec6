//! A typed pin, reduced to what the register-level parts need: its port, its number
//! and, for an alternate function, the function's number. The typed peripherals of
//! embassy (`TimerPin<TIM1, Ch1>`, `BreakInputPin<TIM1, BkIn1>`, `AdcChannel<ADC1>`,
//! `DacPin<DAC1, Ch1>`) are what an image's pin table is written in, so a pin that
//! cannot carry the signal does not compile; the parts here then program it.

use embassy_stm32::gpio::Pin;
use embassy_stm32::pac;
use pac::gpio::vals::{Moder, Pupdr};

/// A pin's place: port (0 = A) and number.
#[derive(Copy, Clone, Debug, PartialEq, Eq, defmt::Format)]
pub struct PinId {
    /// Port, 0 for A.
    pub port: u8,
    /// Pin within the port, 0–15.
    pub pin: u8,
}

impl PinId {
    /// Where `pin` is.
    pub fn of(pin: &impl Pin) -> Self {
        Self {
            port: pin.port(),
            pin: pin.pin(),
        }
    }

    fn gpio(self) -> pac::gpio::Gpio {
        match self.port {
            0 => pac::GPIOA,
            1 => pac::GPIOB,
            2 => pac::GPIOC,
            3 => pac::GPIOD,
            4 => pac::GPIOE,
            5 => pac::GPIOF,
            _ => pac::GPIOG,
        }
    }

    fn index(self) -> usize {
        usize::from(self.pin & 15)
    }

    /// Clocks the pin's port (RCC_AHB2ENR, GPIOxEN are bits 0–6).
    fn clock(self) {
        let bit = u32::from(self.port.min(6));
        pac::RCC.ahb2enr().modify(|w| w.0 |= 1 << bit);
    }

    /// `pin` as an input.
    pub fn input(pin: &impl Pin) -> Self {
        let id = Self::of(pin);
        id.set_input();
        id
    }

    /// The pin to alternate function `af`, optionally pulled down inside.
    pub fn set_alternate(self, af: u8, pull_down: bool) {
        self.clock();
        let gpio = self.gpio();
        let n = self.index();
        if pull_down {
            gpio.pupdr().modify(|w| w.set_pupdr(n, Pupdr::PULL_DOWN));
        }
        gpio.afr(n / 8).modify(|w| w.set_afr(n % 8, af));
        gpio.moder().modify(|w| w.set_moder(n, Moder::ALTERNATE));
    }

    /// The pin as a push-pull output at `high`.
    pub fn set_output(self, high: bool) {
        self.clock();
        self.write(high);
        self.gpio()
            .moder()
            .modify(|w| w.set_moder(self.index(), Moder::OUTPUT));
    }

    /// The pin as an input.
    pub fn set_input(self) {
        self.clock();
        self.gpio()
            .moder()
            .modify(|w| w.set_moder(self.index(), Moder::INPUT));
    }

    /// Drives an output pin (one atomic BSRR write: safe from any context).
    #[inline]
    pub fn write(self, high: bool) {
        let n = self.index();
        self.gpio().bsrr().write(|w| {
            if high {
                w.set_bs(n, true);
            } else {
                w.set_br(n, true);
            }
        });
    }

    /// Reads an input pin.
    #[inline]
    pub fn read(self) -> bool {
        self.gpio().idr().read().idr(self.index()) == pac::gpio::vals::Idr::HIGH
    }
}
