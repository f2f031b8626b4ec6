//! Every pin and peripheral choice of the board image, in one place.
//!
//! The image targets a NUCLEO-G474RE (STM32G474RE, LQFP64) wired to a three-axis
//! linear-motor driver with analog current-command inputs and one enable line, and a
//! laser source with a PWM power input. Channel and alternate-function numbers are the
//! datasheet's (DS12288, table 13 "STM32G474xB/C/E pin definition" and the alternate
//! function tables); register fields cite RM0440.
//!
//! | signal | pin | peripheral | notes |
//! |---|---|---|---|
//! | Hall A1, A2, A3 (carriage A) | PC0, PC1, PC2 | ADC1 IN6, IN7, IN8 | 0–3.3 V, RC-filtered at the connector |
//! | Hall B1, B2, B3 (carriage B) | PC4, PC5, PB2 | ADC2 IN5, IN11, IN12 | |
//! | Hall C1, C2, C3 (carriage C) | PB0, PB1, PB13 | ADC3 IN12, IN1, IN5 | |
//! | force command A | PA4 | DAC1 OUT1 | mid-scale (1.65 V) = zero force |
//! | force command B | PA5 | DAC1 OUT2 | NUCLEO LED LD2 sits on PA5: open its solder bridge (UM2505) |
//! | force command C | PA6 | DAC2 OUT1 | |
//! | laser power PWM | PA8 | TIM1 CH1 (AF6) | 10 kHz, duty = power / maximum; 10 kΩ pull-down at the source |
//! | driver enable | PA9 | TIM1 CH2 (AF6) | high = enabled; 10 kΩ pull-down at the driver |
//! | driver fault / E-stop in | PB12 | TIM1 BKIN (AF6) | active low: pulls the timer into break |
//! | host link TX, RX | PA2, PA3 | LPUART1 (AF12) | the ST-LINK's virtual COM port, 921 600 Bd 8N1 |
//! | calibrate button | PC13 | GPIO in | NUCLEO user button B1 (pressed = high) |
//! | status LED | PC6 | GPIO out | blinks at 1 Hz while the control period runs |
//! | fault LED | PC7 | GPIO out | lit when the last reset was a fault |
//! | SWD, SWO | PA13, PA14, PB3 | debug | probe-rs, defmt over RTT |
//!
//! Each carriage's three Hall channels are converted in sequence by its own ADC; the
//! three ADCs start together on TIM1's update (TRGO), so the nine samples of a period
//! are taken within one sequence of each other: 3 × (24.5 + 12.5) ADC clocks at
//! 42.5 MHz, 2.6 µs (0.2 µm of travel at 75 mm/s).

use embassy_stm32::pac;

/// Core clock, Hz: HSI16 / 4 × 85 / 2 (RM0440, RCC "PLL"; above 150 MHz the core
/// needs range 1 boost mode, PWR "Dynamic voltage scaling management").
pub const SYSCLK_HZ: u32 = 170_000_000;

/// The control rate, Hz: the Keops slave's period of 100 µs
/// (`DeltaSlaveConfig::KEOPS.joints.period_s`; checked at start-up).
pub const CONTROL_HZ: u32 = 10_000;

/// Timer ticks (= core cycles: TIM1 runs on the 170 MHz APB2 timer clock with
/// prescaler 1) per control period.
pub const PERIOD_CYCLES: u32 = SYSCLK_HZ / CONTROL_HZ;

/// ADC regular channels of each carriage, in conversion order (ADC1, ADC2, ADC3).
pub const HALL_CHANNELS: [[u8; 3]; 3] = [[6, 7, 8], [5, 11, 12], [12, 1, 5]];

/// ADC sampling time (RM0440, ADC "Channel-wise programmable sampling time"): 24.5 ADC clock cycles charge the 5 pF
/// sampling capacitor through up to 1 kΩ of source and filter resistance to 12 bits.
pub const SAMPLE_TIME: pac::adc::vals::SampleTime = pac::adc::vals::SampleTime::CYCLES24_5;

/// The ADC clock: the synchronous AHB clock divided by 4 (CKMODE = 3, RM0440
/// ADC_CCR), 42.5 MHz, within the 60 MHz limit of DS12288 table 66; synchronous so
/// that the three ADCs start on the same cycle after the trigger.
pub const ADC_CKMODE: pac::adccommon::vals::Ckmode = pac::adccommon::vals::Ckmode::SYNC_DIV4;

/// ADC external trigger 9 is TIM1_TRGO for ADC1/2 and ADC3/4/5 alike (RM0440, ADC
/// "Conversion on external trigger", the regular trigger tables).
pub const ADC_EXTSEL_TIM1_TRGO: u8 = 9;

/// DMAMUX request lines of ADC1, ADC2, ADC3 (RM0440, DMAMUX
/// "DMAMUX1 request line multiplexer" table), on DMA1 channels 1–3
/// (DMAMUX channels 0–2).
pub const ADC_DMAMUX_REQUEST: [u8; 3] = [5, 36, 37];

/// Counts of a 12-bit conversion, left-aligned in 16 bits (ADC_CFGR.ALIGN = 1,
/// RM0440, ADC "Data management"): the decoders of `HallConfig::LM1247_16BIT` take them unchanged,
/// with 16 codes per 12-bit step.
pub const LEFT_ALIGNED: bool = true;

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

/// LPUART1 baud rate: the ST-LINK V3 virtual COM port carries it; a telemetry sample
/// every 10 periods (about 70 bytes per ms) needs 700 kBd.
pub const LINK_BAUD: u32 = 921_600;

/// IWDG: LSI 32 kHz / 4 = 8 kHz, reload 80: the image resets 10 ms after the control
/// interrupt or the link task stopped (RM0440, IWDG "Window option" and the timeout table).
pub const IWDG_PRESCALER: u8 = 0;
/// See [`IWDG_PRESCALER`].
pub const IWDG_RELOAD: u16 = 80;

/// The link task must have run within this many control periods (200 ms) for the
/// control interrupt to refresh the watchdog, so that a link task stuck in a loop
/// resets the board as a hung control period does. Longer than the longest wait of
/// the task on the transmitter (1 KB at 921 600 Bd: 11 ms); the calibration fit, which
/// runs in the task for longer, suspends the check while it runs.
pub const LINK_SILENCE_PERIODS: u32 = 2_000;

/// NVIC priority of the control interrupt (the highest: 0) and of the link's UART and
/// DMA interrupts (below it; the G474 implements four priority bits).
pub const CONTROL_PRIORITY: u8 = 0;
/// See [`CONTROL_PRIORITY`].
pub const LINK_PRIORITY: u8 = 0x40;
