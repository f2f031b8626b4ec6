//! The Keops slave's board: its wiring and the numbers of its drive chain.
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
//! 42.5 MHz, 2.6 µs (0.2 µm of travel at 75 mm/s). The ADCs leave 12-bit counts
//! left-aligned in 16 bits, which the decoders of `HallConfig::LM1247_16BIT` take
//! unchanged.
//!
//! The pins themselves are chosen in `main` in embassy's typed peripherals (a Hall
//! channel on the wrong ADC, a force output on a pin without a DAC, does not
//! compile); this module holds the machine's numbers.

use kerf_board_support::output_codes::ForceDac;

/// The control rate, Hz: the Keops slave's period of 100 µs
/// (`DeltaSlaveConfig::KEOPS.joints.period_s`; checked at start-up).
pub const CONTROL_HZ: u32 = 10_000;

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
