//! The nine Hall channels: ADC1–3 each convert one carriage's three channels on
//! TIM1's trigger, and DMA1 channels 1–3 copy the results into [`SAMPLES`] in a
//! circle, so that each control period finds the period's nine samples in place.
//! Channel 1's transfer-complete interrupt is the control interrupt
//! (`DMA1_CHANNEL1`).
//!
//! Register sequences follow RM0440's ADC chapter ("ADC on-off control", "Calibration",
//! "Conversion on external trigger", "Managing conversions using the DMA") and the DMA
//! and DMAMUX chapters ("DMA channel configuration procedure").

use crate::board;
use core::cell::UnsafeCell;
use embassy_stm32::pac;
use pac::adc::vals::{Adcaldif, Dmacfg, Exten, Ovrmod, Res};
use pac::bdma::vals::{Dir, Pl, Size};

/// One period's raw samples, as the DMA leaves them: `[carriage][channel]`.
pub type Samples = [[u16; 3]; 3];

/// The DMA's destination: written by the DMA between periods, read by the control
/// interrupt after the transfers completed.
pub struct DmaBuffer(UnsafeCell<Samples>);

// SAFETY: the only writer is the DMA; the control interrupt reads it with volatile
// loads after transfer-complete, before the next trigger (one period later).
unsafe impl Sync for DmaBuffer {}

/// Where the DMA writes the samples. In `.bss`, which the linker places at the start
/// of RAM (SRAM1): the CCM SRAM at the top of the region holds the stack.
pub static SAMPLES: DmaBuffer = DmaBuffer(UnsafeCell::new([[0; 3]; 3]));

/// The three ADCs in carriage order.
const ADCS: [pac::adc::Adc; 3] = [pac::ADC1, pac::ADC2, pac::ADC3];

/// Why the sampling chain did not start.
#[derive(Copy, Clone, Debug, PartialEq, Eq, defmt::Format)]
pub enum SamplingError {
    /// An ADC's calibration or enable did not finish in its bound (ADC index).
    AdcTimeout(u8),
}

/// Busy-waits `cycles` core cycles (start-up only).
fn delay(cycles: u32) {
    cortex_m::asm::delay(cycles);
}

/// Waits for `done` with a bound of `polls` reads; true when it came.
fn wait(polls: u32, mut done: impl FnMut() -> bool) -> bool {
    (0..polls).any(|_| done())
}

/// Powers, calibrates and enables the three ADCs, points DMA1 channels 1–3 at
/// [`SAMPLES`], and arms the conversions on TIM1's trigger. The trigger itself
/// starts with TIM1 ([`crate::outputs::start`]).
pub fn start() -> Result<(), SamplingError> {
    let rcc = pac::RCC;
    rcc.ahb1enr().modify(|w| {
        w.set_dma1en(true);
        w.set_dmamux1en(true);
    });
    rcc.ahb2enr().modify(|w| {
        w.set_adc12en(true);
        w.set_adc345en(true);
    });
    for common in [pac::ADC12_COMMON, pac::ADC345_COMMON] {
        common.ccr().modify(|w| w.set_ckmode(board::ADC_CKMODE));
    }
    for (i, adc) in ADCS.iter().enumerate() {
        let index = i as u8;
        // ADC_CR is written whole, never read-modified: its start and enable bits are
        // set by software and cleared by hardware, and writing one back that is
        // already set is not allowed in every state (RM0440 ADC_CR). Out of deep
        // power-down, regulator on, then tADCVREG_STUP (20 µs, DS12288).
        adc.cr().write(|w| w.set_deeppwd(false));
        adc.cr().write(|w| w.set_advregen(true));
        delay(board::SYSCLK_HZ / 50_000);
        adc.cr().write(|w| {
            w.set_advregen(true);
            w.set_adcaldif(Adcaldif::SINGLE_ENDED);
            w.set_adcal(true);
        });
        if !wait(100_000, || !adc.cr().read().adcal()) {
            return Err(SamplingError::AdcTimeout(index));
        }
        // ADEN cannot be set until four ADC clocks after ADCAL cleared.
        delay(64);
        adc.isr().write(|w| w.set_adrdy(true));
        adc.cr().write(|w| {
            w.set_advregen(true);
            w.set_aden(true);
        });
        if !wait(100_000, || adc.isr().read().adrdy()) {
            return Err(SamplingError::AdcTimeout(index));
        }
        let channels = board::HALL_CHANNELS.get(i).copied().unwrap_or_default();
        adc.cfgr().write(|w| {
            w.set_dmaen(pac::adc::vals::Dmaen::ENABLE);
            w.set_dmacfg(Dmacfg::CIRCULAR);
            w.set_res(Res::BITS12);
            w.set_align(board::LEFT_ALIGNED);
            w.set_exten(Exten::RISING_EDGE);
            w.set_extsel(board::ADC_EXTSEL_TIM1_TRGO);
            // A late DMA must not freeze the ADC: the newest sample wins.
            w.set_ovrmod(Ovrmod::OVERWRITE);
        });
        adc.sqr1().write(|w| {
            w.set_l(2);
            for (rank, &channel) in channels.iter().enumerate() {
                w.set_sq(rank, channel);
            }
        });
        for &channel in &channels {
            let n = usize::from(channel);
            if n < 10 {
                adc.smpr().modify(|w| w.set_smp(n, board::SAMPLE_TIME));
            } else {
                adc.smpr2()
                    .modify(|w| w.set_smp(n - 10, board::SAMPLE_TIME));
            }
        }
        start_dma(i);
        adc.cr().write(|w| {
            w.set_advregen(true);
            w.set_adstart(true);
        });
    }
    Ok(())
}

/// DMA1 channel `i + 1` from ADC `i`'s data register into `SAMPLES[i]`, circular,
/// three half-words; only channel 1 interrupts.
fn start_dma(i: usize) {
    let dma = pac::DMA1;
    let Some((adc, &request)) = ADCS.get(i).zip(board::ADC_DMAMUX_REQUEST.get(i)) else {
        return;
    };
    pac::DMAMUX1.ccr(i).write(|w| w.set_dmareq_id(request));
    let ch = dma.ch(i);
    ch.cr().write(|w| w.set_en(false));
    ch.par().write_value(adc.dr().as_ptr() as u32);
    // SAFETY: only the address of the row is taken; the DMA is its one writer.
    let row = unsafe { (*SAMPLES.0.get()).as_mut_ptr().add(i) };
    ch.mar().write_value(row as u32);
    ch.ndtr().write(|w| w.set_ndt(3));
    ch.cr().write(|w| {
        w.set_dir(Dir::FROM_PERIPHERAL);
        w.set_psize(Size::BITS16);
        w.set_msize(Size::BITS16);
        w.set_minc(true);
        w.set_circ(true);
        w.set_pl(Pl::VERY_HIGH);
        w.set_tcie(i == 0);
        w.set_teie(i == 0);
        w.set_en(true);
    });
}

/// Transfer-complete flags of DMA1 channels 1–3 (ISR bits TCIFx, RM0440 DMA_ISR).
const TC_ALL: u32 = (1 << 1) | (1 << 5) | (1 << 9);
/// Transfer-error flags of the three channels.
const TE_ALL: u32 = (1 << 3) | (1 << 7) | (1 << 11);

/// What the control interrupt found in the DMA's flags.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Arrival {
    /// All three sequences arrived.
    Complete,
    /// A DMA transfer error, or an ADC whose sequence did not complete within the
    /// bound after ADC1's: the samples are not one period's.
    Broken,
}

/// Waits (bounded) for the three transfer-complete flags and clears them. The three
/// ADCs share trigger, clock and sequence length, so ADC2's and ADC3's transfers land
/// a few bus cycles after ADC1's, which raised this interrupt.
#[inline]
pub fn arrival() -> Arrival {
    let dma = pac::DMA1;
    let mut flags = dma.isr().read().0;
    let mut polls = 0;
    while flags & TC_ALL != TC_ALL && flags & TE_ALL == 0 && polls < 64 {
        flags = dma.isr().read().0;
        polls += 1;
    }
    dma.ifcr()
        .write_value(pac::bdma::regs::Isr(flags & (TC_ALL | TE_ALL)));
    if flags & TC_ALL == TC_ALL && flags & TE_ALL == 0 {
        Arrival::Complete
    } else {
        Arrival::Broken
    }
}

/// The period's samples (volatile: the DMA wrote them).
#[inline]
pub fn read() -> Samples {
    // SAFETY: the DMA completed this period's transfers (see `arrival`) and does not
    // write again until the next trigger, a period later.
    unsafe { core::ptr::read_volatile(SAMPLES.0.get()) }
}
