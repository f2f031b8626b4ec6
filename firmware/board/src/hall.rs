//! The board of a Hall-sensed linear-motor machine: `N` carriages, each with three
//! Hall channels on its own ADC (ADC1 for the first) and a force command on a DAC
//! channel through a current-input driver, a laser on TIM1's PWM for the cutting
//! machines, and the drivers' enable on TIM1 CH2.
//!
//! | carriage | Hall channels | force command |
//! |---|---|---|
//! | A | PC0, PC1, PC2 (ADC1 IN6, IN7, IN8) | PA4 (DAC1 OUT1) |
//! | B | PC4, PC5, PB2 (ADC2 IN5, IN11, IN12) | PA5 (DAC1 OUT2) |
//! | C | PB0, PB1, PB13 (ADC3 IN12, IN1, IN5) | PA6 (DAC2 OUT1) |
//!
//! The force commands assume a driver with an analog current input of 1 A/V about
//! mid-scale and the LM1247's 3.47 N/A ([`DRIVER_AMPS_PER_VOLT`],
//! [`FORCE_CONSTANT_N_PER_A`]: set both to the hardware's). The ADCs leave 12-bit
//! counts left-aligned in 16 bits, which the decoders of `HallConfig::LM1247_16BIT`
//! take unchanged.

use core::marker::PhantomData;
use embassy_stm32::adc::AdcChannel;
use embassy_stm32::dac::{Dac, DacChannel, DualValue, Value};
use embassy_stm32::mode::Blocking;
use embassy_stm32::pac;
use embassy_stm32::peripherals::{DAC1, DAC2, PA4, PA5, PA6, PB0, PB1, PB13, PB2, PC0, PC1};
use embassy_stm32::peripherals::{PC2, PC4, PC5};
use embassy_stm32::Peri;
use kerf::app::calibrate::{CalibrationFit, HallMachine, HallSample};
use kerf::app::supervisor::Machine;
use kerf::hal::{ForceAndLaser, Monotonic, SampleInputs, WriteOutputs};
use kerf::sensing::hall::HallConfig;
use kerf_board_support::output_codes::ForceDac;
use kerf_board_support::stm32::adc::{AdcRow, DmaBuffer};
use kerf_board_support::stm32::fault;
use kerf_board_support::stm32::link::SweepFit;
use kerf_board_support::stm32::period::BoardHal;
use kerf_board_support::stm32::timer;
use kerf_board_support::stm32::timing::CycleClock;
use kerf_board_support::timer_period::TimerPeriod;

/// The DAC code of zero force: mid-scale of 12 bits, 1.65 V at 3.3 V reference.
pub const DAC_ZERO: u16 = 2048;

/// The driver's transconductance at its command input, A per V (set it to the
/// driver's; the drivers of the Keops slave take ±1.65 V about mid-scale).
pub const DRIVER_AMPS_PER_VOLT: f32 = 1.0;

/// The motor's force constant, N per A (Faulhaber LM1247 datasheet: 3.47 N/A; set
/// it to the motor's).
pub const FORCE_CONSTANT_N_PER_A: f32 = 3.47;

/// DAC volts per code (3.3 V reference, 12 bits).
pub const DAC_VOLTS_PER_CODE: f32 = 3.3 / 4096.0;

/// The drive chain from a force command to a DAC code.
pub const FORCE_DAC: ForceDac = ForceDac::new(
    DAC_ZERO,
    FORCE_CONSTANT_N_PER_A,
    DRIVER_AMPS_PER_VOLT,
    DAC_VOLTS_PER_CODE,
);

/// The DAC channels of the carriages, held (dropping one disables it): built from
/// typed pins, written in the period through their registers with constant channel
/// numbers (embassy's `set` indexes the channel at run time, with a panic path the
/// period must not have).
pub enum ForceDacs {
    /// One carriage: DAC1 OUT1.
    One(DacChannel<'static, Blocking>),
    /// Three carriages: DAC1 OUT1 and OUT2 (written together), DAC2 OUT1.
    Three(Dac<'static, Blocking>, DacChannel<'static, Blocking>),
}

/// The board behind kerf's HAL traits for `N` carriages: the DMA's samples in, the
/// DACs and TIM1 out, the cycle counter as the clock.
pub struct HallHal<const N: usize> {
    clock: CycleClock,
    enabled: bool,
    period: TimerPeriod,
    samples: &'static DmaBuffer<N, 3>,
    _dacs: ForceDacs,
}

impl HallHal<1> {
    /// One carriage: its Hall channels' ADC row and its DAC at zero force.
    pub fn one(
        period: TimerPeriod,
        samples: &'static DmaBuffer<1, 3>,
        hall: (Peri<'static, PC0>, Peri<'static, PC1>, Peri<'static, PC2>),
        dac: (Peri<'static, DAC1>, Peri<'static, PA4>),
    ) -> ([AdcRow<3>; 1], Self) {
        let rows = [AdcRow::adc1([
            hall.0.degrade_adc(),
            hall.1.degrade_adc(),
            hall.2.degrade_adc(),
        ])];
        let mut a = DacChannel::new_blocking(dac.0, dac.1);
        a.set(Value::Bit12Right(DAC_ZERO));
        register_safe(1);
        (rows, Self::new(period, samples, ForceDacs::One(a)))
    }
}

/// The typed pins of three carriages' Hall channels.
pub type ThreeHallPins = (
    (Peri<'static, PC0>, Peri<'static, PC1>, Peri<'static, PC2>),
    (Peri<'static, PC4>, Peri<'static, PC5>, Peri<'static, PB2>),
    (Peri<'static, PB0>, Peri<'static, PB1>, Peri<'static, PB13>),
);

/// The typed DACs and pins of three carriages' force commands.
pub type ThreeDacPins = (
    Peri<'static, DAC1>,
    Peri<'static, PA4>,
    Peri<'static, PA5>,
    Peri<'static, DAC2>,
    Peri<'static, PA6>,
);

impl HallHal<3> {
    /// Three carriages: their Hall channels' ADC rows and their DACs at zero force.
    pub fn three(
        period: TimerPeriod,
        samples: &'static DmaBuffer<3, 3>,
        hall: ThreeHallPins,
        dacs: ThreeDacPins,
    ) -> ([AdcRow<3>; 3], Self) {
        let (a, b, c) = hall;
        let rows = [
            AdcRow::adc1([a.0.degrade_adc(), a.1.degrade_adc(), a.2.degrade_adc()]),
            AdcRow::adc2([b.0.degrade_adc(), b.1.degrade_adc(), b.2.degrade_adc()]),
            AdcRow::adc3([c.0.degrade_adc(), c.1.degrade_adc(), c.2.degrade_adc()]),
        ];
        let mut ab = Dac::new_blocking(dacs.0, dacs.1, dacs.2);
        ab.set(DualValue::Bit12Right(DAC_ZERO, DAC_ZERO));
        let mut c = DacChannel::new_blocking(dacs.3, dacs.4);
        c.set(Value::Bit12Right(DAC_ZERO));
        register_safe(3);
        (rows, Self::new(period, samples, ForceDacs::Three(ab, c)))
    }
}

/// Zero force on the carriages' DACs, as register writes for the fault path's
/// software half.
fn register_safe(carriages: usize) {
    let zero = u32::from(DAC_ZERO);
    if carriages == 1 {
        fault::set_safe_writes(&[(pac::DAC1.dhr12r(0).as_ptr().cast(), zero)]);
    } else {
        fault::set_safe_writes(&[
            (pac::DAC1.dhr12rd().as_ptr().cast(), zero | zero << 16),
            (pac::DAC2.dhr12r(0).as_ptr().cast(), zero),
        ]);
    }
}

impl<const N: usize> HallHal<N> {
    fn new(period: TimerPeriod, samples: &'static DmaBuffer<N, 3>, dacs: ForceDacs) -> Self {
        Self {
            clock: CycleClock::new(),
            enabled: false,
            period,
            samples,
            _dacs: dacs,
        }
    }

    /// The period as TIM1 counts it.
    pub fn period(&self) -> TimerPeriod {
        self.period
    }
}

impl<const N: usize> SampleInputs<[[u16; 3]; N]> for HallHal<N> {
    #[inline]
    fn sample(&mut self) -> [[u16; 3]; N] {
        self.samples.read()
    }
}

impl WriteOutputs<ForceAndLaser<f32, 3>> for HallHal<3> {
    #[inline]
    fn write(&mut self, outputs: &ForceAndLaser<f32, 3>) {
        let [a, b, c] = outputs.force_n.map(|f| FORCE_DAC.code(f));
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

impl WriteOutputs<[f32; 1]> for HallHal<1> {
    #[inline]
    fn write(&mut self, outputs: &[f32; 1]) {
        let [force_n] = *outputs;
        pac::DAC1
            .dhr12r(0)
            .write(|w| w.set_dhr(FORCE_DAC.code(force_n)));
        timer::write(&self.period, 0.0, self.enabled);
    }
}

impl<const N: usize> Monotonic for HallHal<N> {
    fn tick_hz(&self) -> u64 {
        self.clock.tick_hz()
    }

    #[inline]
    fn now(&mut self) -> u64 {
        self.clock.now()
    }
}

impl<M: Machine, const N: usize> BoardHal<M> for HallHal<N>
where
    Self: SampleInputs<M::Inputs> + WriteOutputs<M::Outputs>,
{
    fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }
}

/// The Hall sweep's samples and fit, for the calibrate button and a calibration at
/// power-up.
pub struct HallFit<M, const N: usize> {
    /// The Hall sensors as configured (the fit starts from them), in flash: five
    /// kilobytes the RAM does not hold for three carriages.
    pub hall: &'static [HallConfig; N],
    /// The sweep's samples (3 KB per carriage).
    pub samples: CalibrationFit<N>,
    machine: PhantomData<M>,
}

impl<M, const N: usize> HallFit<M, N> {
    /// Empty, fitting from the sensors as configured.
    pub fn new(hall: &'static [HallConfig; N]) -> Self {
        Self {
            hall,
            samples: CalibrationFit::default(),
            machine: PhantomData,
        }
    }
}

impl<M: HallMachine<N>, const N: usize> SweepFit<M> for HallFit<M, N> {
    const SWEEPS: bool = true;

    fn restart(&mut self) {
        self.samples = CalibrationFit::default();
    }

    fn push(&mut self, sample: &HallSample) -> bool {
        self.samples.push(*sample).is_ok()
    }

    // Out of line: its result (decoders and fits, kilobytes) in its own frame, not
    // in the link task's.
    #[inline(never)]
    fn fit(&mut self, install: &mut dyn FnMut(M::Calibration)) {
        match M::fit(self.hall, &self.samples) {
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
                install(decoders);
            }
            Err(e) => {
                defmt::error!("calibration failed: {}", defmt::Debug2Format(&e));
            }
        }
    }
}

/// The sweep of an image whose RAM has no room for the fit (the remote slave: its
/// session buffer and command queue leave 34 KB of the 74 KB the fit's stack needs):
/// the nominal decoders are stored at power-up, the button starts nothing, and a
/// sweep the host starts ends without a fit (the host stops it).
pub struct NoRoomToFit;

impl<M: Machine<SweepSample = HallSample>> SweepFit<M> for NoRoomToFit {
    const SWEEPS: bool = false;

    fn restart(&mut self) {}

    fn push(&mut self, _sample: &HallSample) -> bool {
        false
    }

    fn fit(&mut self, _: &mut dyn FnMut(M::Calibration)) {
        defmt::warn!("calibration: this image has no room for the fit; stop the sweep");
    }
}
