//! The period's outputs: three force commands on the DACs, the laser's PWM duty and
//! the driver enable on TIM1, all written by the control interrupt in the period
//! whose samples produced them.
//!
//! What makes them safe without software: TIM1 is an advanced-control timer whose
//! break function (RM0440, TIM1 "Using the break function") clears the main output
//! enable MOE in hardware; its outputs then go to their idle level, low (OSSI = 1,
//! OISx = 0), which turns the laser off and drops the driver enable. The break comes
//! from the BKIN pin (the driver's fault line or an E-stop, active low), from
//! software ([`force_safe`] sets EGR.BG), and from the system break sources, among
//! them the core's LOCKUP (a fault inside the HardFault handler) once SYSCFG_CFGR2.CLL
//! is set. MOE is not re-armed automatically (AOE = 0): only a reset does that. With
//! the MCU in reset or unpowered the pins float and the pull-downs on the enable and
//! laser lines hold both low.

use crate::board;
use embassy_stm32::pac;
use kerf::hal::{ForceAndLaser, WriteOutputs};
use kerf_board_support::output_codes::{pwm_compare, ForceDac};
use pac::gpio::vals::{Moder, Pupdr};
use pac::timer::vals::{Bkp, Mms, Ocm, Ossi, Ossr};

/// Alternate function 6 of PA8, PA9 and PB12: TIM1 CH1, CH2 and BKIN (DS12288).
const AF_TIM1: u8 = 6;

/// DAC_MCR.HFSEL for an AHB clock above 160 MHz (RM0440, DAC_MCR).
const DAC_HFSEL_ABOVE_160MHZ: u8 = 2;

/// Why the outputs did not start.
#[derive(Copy, Clone, Debug, PartialEq, Eq, defmt::Format)]
pub enum OutputError {
    /// A DAC channel did not report ready (DAC index, channel).
    DacTimeout(u8, u8),
    /// The break input holds the outputs off (driver fault or E-stop).
    BreakActive,
}

/// The drive chain from a force command to a DAC code (`board`'s driver, motor and DAC).
const FORCE_DAC: ForceDac = ForceDac::new(
    board::DAC_ZERO,
    board::FORCE_CONSTANT_N_PER_A,
    board::DRIVER_AMPS_PER_VOLT,
    board::DAC_VOLTS_PER_CODE,
);

/// The DAC code for `force_n` ([`ForceDac::code`]: saturated, NaN is zero force).
pub fn dac_code(force_n: f32) -> u16 {
    FORCE_DAC.code(force_n)
}

/// The CCR1 value for a laser duty in [0, 1] ([`pwm_compare`]: saturated, NaN is off).
pub fn laser_compare(duty: f32) -> u16 {
    pwm_compare(duty, board::PERIOD_CYCLES as u16)
}

/// Sets up the pins, the DACs at zero force and TIM1 (laser off, drivers disabled),
/// arms the break and starts the timer, whose update is the ADCs' trigger.
pub fn start() -> Result<(), OutputError> {
    let rcc = pac::RCC;
    rcc.ahb2enr().modify(|w| {
        w.set_gpioaen(true);
        w.set_gpioben(true);
        w.set_gpiocen(true);
        w.set_dac1en(true);
        w.set_dac2en(true);
    });
    rcc.apb2enr().modify(|w| {
        w.set_tim1en(true);
        w.set_syscfgen(true);
    });
    // The core's LOCKUP and a flash ECC error reach TIM1's break (RM0440,
    // SYSCFG_CFGR2 CLL and ECCL: lock bits, cleared only by a reset).
    pac::SYSCFG.cfgr2().modify(|w| {
        w.set_cll(true);
        w.set_eccl(true);
    });
    start_dacs()?;
    let tim = pac::TIM1;
    tim.psc().write_value(0);
    tim.arr()
        .write(|w| w.set_arr((board::PERIOD_CYCLES - 1) as u16));
    tim.ccr(0).write(|w| w.set_ccr(0));
    tim.ccmr_output(0).write(|w| {
        w.set_ocm(0, Ocm::PWM_MODE1);
        w.set_ocpe(0, true);
        w.set_ocm(1, Ocm::FORCE_INACTIVE);
    });
    tim.ccer().write(|w| {
        w.set_cce(0, true);
        w.set_cce(1, true);
    });
    tim.cr2().write(|w| {
        // TRGO on update: the ADCs start at the beginning of each period.
        w.set_mms(Mms::UPDATE);
        w.set_ois(0, false);
        w.set_ois(1, false);
    });
    tim.bdtr().write(|w| {
        w.set_ossi(Ossi::IDLE_LEVEL);
        w.set_ossr(Ossr::IDLE_LEVEL);
        w.set_bke(0, true);
        w.set_bkp(0, Bkp::ACTIVE_LOW);
        w.set_aoe(false);
        w.set_moe(false);
    });
    tim.egr().write(|w| w.set_ug(true));
    tim.sr().write_value(pac::timer::regs::SrAdv(0));
    // The pins go to the timer only now that its outputs are defined and off.
    let gpioa = pac::GPIOA;
    for pin in [8, 9] {
        gpioa.afr(pin / 8).modify(|w| w.set_afr(pin % 8, AF_TIM1));
        gpioa.moder().modify(|w| w.set_moder(pin, Moder::ALTERNATE));
    }
    let gpiob = pac::GPIOB;
    // Pulled down inside too: an unconnected break line holds the outputs off.
    gpiob.pupdr().modify(|w| w.set_pupdr(12, Pupdr::PULL_DOWN));
    gpiob.afr(1).modify(|w| w.set_afr(12 % 8, AF_TIM1));
    gpiob.moder().modify(|w| w.set_moder(12, Moder::ALTERNATE));
    tim.bdtr().modify(|w| w.set_moe(true));
    tim.cr1().modify(|w| {
        w.set_arpe(true);
        w.set_cen(true);
    });
    if !armed() {
        return Err(OutputError::BreakActive);
    }
    Ok(())
}

fn start_dacs() -> Result<(), OutputError> {
    for (index, dac, channels) in [(1u8, pac::DAC1, 2usize), (2, pac::DAC2, 1)] {
        dac.mcr().write(|w| {
            w.set_hfsel(DAC_HFSEL_ABOVE_160MHZ);
            for ch in 0..channels {
                w.set_mode(ch, pac::dac::vals::Mode::NORMAL_EXT_BUFEN);
            }
        });
        for ch in 0..channels {
            dac.dhr12r(ch).write(|w| w.set_dhr(board::DAC_ZERO));
        }
        dac.cr().write(|w| {
            for ch in 0..channels {
                w.set_en(ch, true);
            }
        });
        for ch in 0..channels {
            if !(0..100_000).any(|_| dac.sr().read().dacrdy(ch)) {
                return Err(OutputError::DacTimeout(index, ch as u8));
            }
        }
    }
    Ok(())
}

/// True while TIM1's main outputs are enabled (no break since start-up).
#[inline]
pub fn armed() -> bool {
    pac::TIM1.bdtr().read().moe()
}

/// The outputs of the machine as the board drives them.
pub struct BoardOutputs {
    /// Drivers enabled (false in the machine's fault mode: zero force and no torque).
    pub enable: bool,
}

impl WriteOutputs<ForceAndLaser<f32, 3>> for BoardOutputs {
    #[inline]
    fn write(&mut self, outputs: &ForceAndLaser<f32, 3>) {
        let [a, b, c] = outputs.force_n.map(dac_code);
        // Both DAC1 channels in one write (DAC_DHR12RD), so A and B change together.
        pac::DAC1.dhr12rd().write(|w| {
            w.set_dhr(0, a);
            w.set_dhr(1, b);
        });
        pac::DAC2.dhr12r(0).write(|w| w.set_dhr(c));
        let tim = pac::TIM1;
        // Preloaded: the duty takes effect at the next update, the start of the next
        // period, as the forces do once their DACs settle (1 µs, DS12288).
        tim.ccr(0)
            .write(|w| w.set_ccr(laser_compare(outputs.laser_duty)));
        let mode = if self.enable {
            Ocm::FORCE_ACTIVE
        } else {
            Ocm::FORCE_INACTIVE
        };
        tim.ccmr_output(0).modify(|w| w.set_ocm(1, mode));
    }
}

/// Outputs to their safe state from any context (the fault path, a HardFault): break
/// in hardware first (MOE off: laser and enable low within a timer clock), then zero
/// force on the DACs and the laser's compare value to 0 in software.
#[inline]
pub fn force_safe() {
    let tim = pac::TIM1;
    tim.egr().write(|w| w.set_bg(0, true));
    tim.bdtr().modify(|w| w.set_moe(false));
    tim.ccmr_output(0)
        .modify(|w| w.set_ocm(1, Ocm::FORCE_INACTIVE));
    tim.ccr(0).write(|w| w.set_ccr(0));
    pac::DAC1.dhr12rd().write(|w| {
        w.set_dhr(0, board::DAC_ZERO);
        w.set_dhr(1, board::DAC_ZERO);
    });
    pac::DAC2.dhr12r(0).write(|w| w.set_dhr(board::DAC_ZERO));
}
