//! TIM1, the timer every image runs on: its update starts each control period (the
//! ADCs' trigger, or the control interrupt itself), channel 1 is a PWM output (the
//! laser's power on the Keops slave), channel 2 the enable line of the machine's
//! power stage, and its break input cuts both.
//!
//! What makes them safe without software: TIM1 is an advanced-control timer whose
//! break function (RM0440, TIM1 "Using the break function") clears the main output
//! enable MOE in hardware; its outputs then go to their idle level, low (OSSI = 1,
//! OISx = 0), which turns the PWM off and drops the enable. The break comes from the
//! BKIN pin (the power stage's fault line or an E-stop, active low), from software
//! ([`force_safe`] sets EGR.BG), and from the system break sources, among them the
//! core's LOCKUP (a fault inside the HardFault handler) once SYSCFG_CFGR2.CLL is set.
//! MOE is not re-armed automatically (AOE = 0): only a reset does that. With the MCU
//! in reset or unpowered the pins float and pull-downs on the enable and PWM lines
//! (at the receiving side) hold both low.

use super::pins::PinId;
use crate::output_codes::pwm_compare;
use crate::timer_period::TimerPeriod;
use embassy_stm32::peripherals::TIM1;
use embassy_stm32::timer::{BkIn1, BreakInputPin, Ch1, Ch2, TimerPin};
use embassy_stm32::{pac, Peri};
use pac::timer::vals::{Bkp, Mms, Ocm, Ossi, Ossr};

/// TIM1's pins: the PWM output (channel 1), the enable line (channel 2), the break
/// input. Typed: only pins that carry these functions of TIM1 are accepted.
pub struct Tim1Pins {
    pwm: Option<(PinId, u8)>,
    enable: PinId,
    enable_af: u8,
    brk: PinId,
    brk_af: u8,
}

impl Tim1Pins {
    /// The three pins.
    pub fn new<P, E, B>(
        pwm: Peri<'static, P>,
        enable: Peri<'static, E>,
        brk: Peri<'static, B>,
    ) -> Self
    where
        P: TimerPin<TIM1, Ch1>,
        E: TimerPin<TIM1, Ch2>,
        B: BreakInputPin<TIM1, BkIn1>,
    {
        Self {
            pwm: Some((PinId::of(&*pwm), pwm.af_num())),
            enable: PinId::of(&*enable),
            enable_af: enable.af_num(),
            brk: PinId::of(&*brk),
            brk_af: brk.af_num(),
        }
    }
}

impl Tim1Pins {
    /// The enable line and the break input, for a machine without a PWM output.
    pub fn without_pwm<E, B>(enable: Peri<'static, E>, brk: Peri<'static, B>) -> Self
    where
        E: TimerPin<TIM1, Ch2>,
        B: BreakInputPin<TIM1, BkIn1>,
    {
        Self {
            pwm: None,
            enable: PinId::of(&*enable),
            enable_af: enable.af_num(),
            brk: PinId::of(&*brk),
            brk_af: brk.af_num(),
        }
    }
}

/// Why TIM1 did not start.
#[derive(Copy, Clone, Debug, PartialEq, Eq, defmt::Format)]
pub enum TimerError {
    /// The control period is not a whole number of timer ticks.
    Period(u32),
    /// The break input holds the outputs off (power stage fault or E-stop).
    BreakActive,
}

/// Which of TIM1's interrupts an image takes.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum TimerInterrupts {
    /// None: the period is the ADC DMA's interrupt.
    None,
    /// The update (the period's start), and channel 3's compare `at_ticks` timer
    /// ticks into the period (a step that must wait for the period's inputs to
    /// arrive on a bus).
    UpdateAndCompare {
        /// The compare's place in the period, timer ticks.
        at_ticks: u16,
    },
}

/// TIM1 counting periods of `period` (update = the period's start, TRGO on update),
/// its `interrupts` enabled, the PWM at 0 and the enable line low, the break armed;
/// started.
pub fn start(
    pins: &Tim1Pins,
    period: TimerPeriod,
    interrupts: TimerInterrupts,
) -> Result<(), TimerError> {
    pac::RCC.apb2enr().modify(|w| {
        w.set_tim1en(true);
        w.set_syscfgen(true);
    });
    // The core's LOCKUP and a flash ECC error reach TIM1's break (RM0440,
    // SYSCFG_CFGR2 CLL and ECCL: lock bits, cleared only by a reset).
    pac::SYSCFG.cfgr2().modify(|w| {
        w.set_cll(true);
        w.set_eccl(true);
    });
    let tim = pac::TIM1;
    tim.psc().write_value(period.psc());
    tim.arr().write(|w| w.set_arr(period.arr()));
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
    if let TimerInterrupts::UpdateAndCompare { at_ticks } = interrupts {
        // Channel 3 frozen (no pin): its compare only raises CC3IF.
        tim.ccr(2).write(|w| w.set_ccr(at_ticks));
        tim.dier().write(|w| {
            w.set_uie(true);
            w.set_ccie(2, true);
        });
    }
    // The pins go to the timer only now that its outputs are defined and off; the
    // break line is pulled down inside too, so an unconnected one holds them off.
    if let Some((pwm, af)) = pins.pwm {
        pwm.set_alternate(af, false);
    }
    pins.enable.set_alternate(pins.enable_af, false);
    pins.brk.set_alternate(pins.brk_af, true);
    tim.bdtr().modify(|w| w.set_moe(true));
    tim.cr1().modify(|w| {
        w.set_arpe(true);
        w.set_cen(true);
    });
    if !armed() {
        return Err(TimerError::BreakActive);
    }
    Ok(())
}

/// The period as TIM1 counts it, or the error naming the period's cycles.
pub fn period_of(period_cycles: u32) -> Result<TimerPeriod, TimerError> {
    TimerPeriod::of(period_cycles).ok_or(TimerError::Period(period_cycles))
}

/// True while TIM1's main outputs are enabled (no break since start-up).
#[inline]
pub fn armed() -> bool {
    pac::TIM1.bdtr().read().moe()
}

/// Core cycles since the period's start (TIM1's counter times its prescale).
#[inline]
pub fn cycles_into_period(period: &TimerPeriod) -> u32 {
    u32::from(pac::TIM1.cnt().read().cnt()).wrapping_mul(period.cycles_per_tick)
}

/// Clears the update flag at the period's start.
#[inline]
pub fn clear_update() {
    pac::TIM1.sr().write_value(pac::timer::regs::SrAdv(!1));
}

/// Clears channel 3's compare flag (the compare interrupt's own).
#[inline]
pub fn clear_compare() {
    pac::TIM1
        .sr()
        .write_value(pac::timer::regs::SrAdv(!(1 << 3)));
}

/// True when the timer updated again since [`clear_update`].
#[inline]
pub fn updated_again() -> bool {
    pac::TIM1.sr().read().uif()
}

/// Writes the period's PWM duty in [0, 1] (preloaded: it takes effect at the next
/// update) and the enable line.
#[inline]
pub fn write(period: &TimerPeriod, duty: f32, enable: bool) {
    let tim = pac::TIM1;
    tim.ccr(0)
        .write(|w| w.set_ccr(pwm_compare(duty, period.arr().saturating_add(1))));
    let mode = if enable {
        Ocm::FORCE_ACTIVE
    } else {
        Ocm::FORCE_INACTIVE
    };
    tim.ccmr_output(0).modify(|w| w.set_ocm(1, mode));
}

/// TIM1's outputs to their safe state from any context (the fault path, a
/// HardFault): break in hardware first (MOE off: PWM and enable low within a timer
/// clock), then the enable forced inactive and the duty to 0 in software.
#[inline]
pub fn force_safe() {
    let tim = pac::TIM1;
    tim.egr().write(|w| w.set_bg(0, true));
    tim.bdtr().modify(|w| w.set_moe(false));
    tim.ccmr_output(0)
        .modify(|w| w.set_ocm(1, Ocm::FORCE_INACTIVE));
    tim.ccr(0).write(|w| w.set_ccr(0));
}
