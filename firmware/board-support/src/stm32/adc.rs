//! Sampling: up to three ADCs (ADC1–3), each converting a sequence of `C` channels
//! on TIM1's trigger, and DMA1 channels 1–3 copying the results into a
//! [`DmaBuffer`] in a circle, so that each control period finds the period's samples
//! in place. Channel 1's transfer-complete interrupt (`DMA1_CHANNEL1`) can be the
//! control interrupt: the Keops slave's nine Hall channels (3 × 3) and the grinding
//! cell's six strain gauges (2 × 3) are sampled so.
//!
//! The ADCs share trigger, clock and sequence length, so the samples of a period are
//! taken within one sequence of each other: C × (24.5 + 12.5) ADC clocks at 42.5 MHz,
//! 2.6 µs for three channels.
//!
//! Register sequences follow RM0440's ADC chapter ("ADC on-off control", "Calibration",
//! "Conversion on external trigger", "Managing conversions using the DMA") and the DMA
//! and DMAMUX chapters ("DMA channel configuration procedure").

use super::clocks::SYSCLK_HZ;
use core::cell::UnsafeCell;
use embassy_stm32::adc::AnyAdcChannel;
use embassy_stm32::pac;
use embassy_stm32::peripherals::{ADC1, ADC2, ADC3};
use pac::adc::vals::{Adcaldif, Dmacfg, Exten, Ovrmod, Res, SampleTime};
use pac::bdma::vals::{Dir, Pl, Size};

/// ADC sampling time (RM0440, ADC "Channel-wise programmable sampling time"): 24.5
/// ADC clock cycles charge the 5 pF sampling capacitor through up to 1 kΩ of source
/// and filter resistance to 12 bits.
const SAMPLE_TIME: SampleTime = SampleTime::CYCLES24_5;

/// The ADC clock: the synchronous AHB clock divided by 4 (CKMODE = 3, RM0440
/// ADC_CCR), 42.5 MHz, within the 60 MHz limit of DS12288 table 66; synchronous so
/// that the ADCs start on the same cycle after the trigger.
const ADC_CKMODE: pac::adccommon::vals::Ckmode = pac::adccommon::vals::Ckmode::SYNC_DIV4;

/// ADC external trigger 9 is TIM1_TRGO for ADC1/2 and ADC3/4/5 alike (RM0440, ADC
/// "Conversion on external trigger", the regular trigger tables).
const ADC_EXTSEL_TIM1_TRGO: u8 = 9;

/// DMAMUX request lines of ADC1, ADC2, ADC3 (RM0440, DMAMUX
/// "DMAMUX1 request line multiplexer" table).
const ADC_DMAMUX_REQUEST: [u8; 3] = [5, 36, 37];

/// The ADCs in order.
const ADCS: [pac::adc::Adc; 3] = [pac::ADC1, pac::ADC2, pac::ADC3];

/// Counts of a 12-bit conversion, left-aligned in 16 bits (ADC_CFGR.ALIGN = 1,
/// RM0440, ADC "Data management"): full scale is 65,520 with 16 codes per 12-bit
/// step, the form the 16-bit Hall decoders take unchanged.
const LEFT_ALIGNED: bool = true;

/// One ADC's conversion sequence, built only from channels typed for that ADC.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct AdcRow<const C: usize> {
    adc: usize,
    channels: [u8; C],
}

impl<const C: usize> AdcRow<C> {
    /// ADC1 converting `pins` in order.
    pub fn adc1(pins: [AnyAdcChannel<'_, ADC1>; C]) -> Self {
        Self {
            adc: 0,
            channels: pins.map(|p| p.get_hw_channel()),
        }
    }

    /// ADC2 converting `pins` in order.
    pub fn adc2(pins: [AnyAdcChannel<'_, ADC2>; C]) -> Self {
        Self {
            adc: 1,
            channels: pins.map(|p| p.get_hw_channel()),
        }
    }

    /// ADC3 converting `pins` in order.
    pub fn adc3(pins: [AnyAdcChannel<'_, ADC3>; C]) -> Self {
        Self {
            adc: 2,
            channels: pins.map(|p| p.get_hw_channel()),
        }
    }
}

/// The DMA's destination, `[adc][channel]` raw counts: written by the DMA between
/// periods, read by the control interrupt after the transfers completed. An image
/// keeps one in a static.
pub struct DmaBuffer<const A: usize, const C: usize>(UnsafeCell<[[u16; C]; A]>);

// SAFETY: the only writer is the DMA; the control interrupt reads it with volatile
// loads after transfer-complete, before the next trigger (one period later).
unsafe impl<const A: usize, const C: usize> Sync for DmaBuffer<A, C> {}

impl<const A: usize, const C: usize> DmaBuffer<A, C> {
    /// Zeroed.
    pub const fn new() -> Self {
        Self(UnsafeCell::new([[0; C]; A]))
    }

    /// The period's samples (volatile: the DMA wrote them).
    #[inline]
    pub fn read(&self) -> [[u16; C]; A] {
        // SAFETY: the DMA completed this period's transfers (see `arrival`) and does not
        // write again until the next trigger, a period later.
        unsafe { core::ptr::read_volatile(self.0.get()) }
    }
}

impl<const A: usize, const C: usize> Default for DmaBuffer<A, C> {
    fn default() -> Self {
        Self::new()
    }
}

/// Why the sampling chain did not start.
#[derive(Copy, Clone, Debug, PartialEq, Eq, defmt::Format)]
pub enum SamplingError {
    /// An ADC's calibration or enable did not finish in its bound (ADC index).
    AdcTimeout(u8),
    /// Row `i` is not ADC `i + 1` (row 0 must be ADC1, whose DMA channel interrupts).
    RowOrder(u8),
}

/// Busy-waits `cycles` core cycles (start-up only).
fn delay(cycles: u32) {
    cortex_m::asm::delay(cycles);
}

/// Waits for `done` with a bound of `polls` reads; true when it came.
fn wait(polls: u32, mut done: impl FnMut() -> bool) -> bool {
    (0..polls).any(|_| done())
}

/// Powers, calibrates and enables the ADCs of `rows` (row `i` is ADC `i + 1`), points
/// DMA1 channels 1… at `buffer`, and arms the conversions on TIM1's trigger. The
/// trigger itself starts with TIM1 ([`super::timer::start`]).
pub fn start<const A: usize, const C: usize>(
    rows: &[AdcRow<C>; A],
    buffer: &'static DmaBuffer<A, C>,
) -> Result<(), SamplingError> {
    for (i, row) in rows.iter().enumerate() {
        if row.adc != i {
            return Err(SamplingError::RowOrder(i as u8));
        }
    }
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
        common.ccr().modify(|w| w.set_ckmode(ADC_CKMODE));
    }
    for (i, (adc, row)) in ADCS.iter().zip(rows).enumerate() {
        let index = i as u8;
        // ADC_CR is written whole, never read-modified: its start and enable bits are
        // set by software and cleared by hardware, and writing one back that is
        // already set is not allowed in every state (RM0440 ADC_CR). Out of deep
        // power-down, regulator on, then tADCVREG_STUP (20 µs, DS12288).
        adc.cr().write(|w| w.set_deeppwd(false));
        adc.cr().write(|w| w.set_advregen(true));
        delay(SYSCLK_HZ / 50_000);
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
        let channels = row.channels;
        adc.cfgr().write(|w| {
            w.set_dmaen(pac::adc::vals::Dmaen::ENABLE);
            w.set_dmacfg(Dmacfg::CIRCULAR);
            w.set_res(Res::BITS12);
            w.set_align(LEFT_ALIGNED);
            w.set_exten(Exten::RISING_EDGE);
            w.set_extsel(ADC_EXTSEL_TIM1_TRGO);
            // A late DMA must not freeze the ADC: the newest sample wins.
            w.set_ovrmod(Ovrmod::OVERWRITE);
        });
        adc.sqr1().write(|w| {
            w.set_l(C.saturating_sub(1) as u8);
            for (rank, &channel) in channels.iter().enumerate() {
                w.set_sq(rank, channel);
            }
        });
        for &channel in &channels {
            let n = usize::from(channel);
            if n < 10 {
                adc.smpr().modify(|w| w.set_smp(n, SAMPLE_TIME));
            } else {
                adc.smpr2().modify(|w| w.set_smp(n - 10, SAMPLE_TIME));
            }
        }
        start_dma(i, buffer);
        adc.cr().write(|w| {
            w.set_advregen(true);
            w.set_adstart(true);
        });
    }
    Ok(())
}

/// DMA1 channel `i + 1` from ADC `i`'s data register into row `i` of `buffer`,
/// circular, `C` half-words; only channel 1 interrupts.
fn start_dma<const A: usize, const C: usize>(i: usize, buffer: &'static DmaBuffer<A, C>) {
    let dma = pac::DMA1;
    let Some((adc, &request)) = ADCS.get(i).zip(ADC_DMAMUX_REQUEST.get(i)) else {
        return;
    };
    pac::DMAMUX1.ccr(i).write(|w| w.set_dmareq_id(request));
    let ch = dma.ch(i);
    ch.cr().write(|w| w.set_en(false));
    ch.par().write_value(adc.dr().as_ptr() as u32);
    // SAFETY: only the address of the row is taken; the DMA is its one writer.
    let row = unsafe { (*buffer.0.get()).as_mut_ptr().add(i) };
    ch.mar().write_value(row as u32);
    ch.ndtr().write(|w| w.set_ndt(C as u16));
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

/// Transfer-complete and transfer-error flags of DMA1 channels 1…`adcs` (ISR bits
/// TCIFx at 4x + 1, TEIFx at 4x + 3, RM0440 DMA_ISR).
const fn flags(adcs: usize) -> (u32, u32) {
    let mut tc = 0;
    let mut te = 0;
    let mut x = 0;
    while x < adcs {
        tc |= 1 << (4 * x + 1);
        te |= 1 << (4 * x + 3);
        x += 1;
    }
    (tc, te)
}

/// What the control interrupt found in the DMA's flags.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Arrival {
    /// Every ADC's sequence arrived.
    Complete,
    /// A DMA transfer error, or an ADC whose sequence did not complete within the
    /// bound after ADC1's: the samples are not one period's.
    Broken,
}

/// Waits (bounded) for the transfer-complete flags of the `A` ADCs and clears them.
/// The ADCs share trigger, clock and sequence length, so ADC2's and ADC3's transfers
/// land a few bus cycles after ADC1's, which raised this interrupt.
#[inline]
pub fn arrival<const A: usize>() -> Arrival {
    let (tc_all, te_all) = const { flags(A) };
    let dma = pac::DMA1;
    let mut flags = dma.isr().read().0;
    let mut polls = 0;
    while flags & tc_all != tc_all && flags & te_all == 0 && polls < 64 {
        flags = dma.isr().read().0;
        polls += 1;
    }
    dma.ifcr()
        .write_value(pac::bdma::regs::Isr(flags & (tc_all | te_all)));
    if flags & tc_all == tc_all && flags & te_all == 0 {
        Arrival::Complete
    } else {
        Arrival::Broken
    }
}
