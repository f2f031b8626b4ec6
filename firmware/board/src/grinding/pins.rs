//! The grinding cell's board: its wiring and the numbers of its signal chains.
//!
//! The image targets a NUCLEO-G474RE wired to the cell (see docs/board.md): the F/T
//! sensor's six strain-gauge channels through a conditioning stage, the piezo
//! amplifier's command input and enable, and the two devices' serial lines. Channel
//! and alternate-function numbers are the datasheet's (DS12288, table 13 and the
//! alternate function tables).
//!
//! | signal | pin | peripheral | notes |
//! |---|---|---|---|
//! | gauges 1, 2, 3 | PC0, PC1, PC2 | ADC1 IN6, IN7, IN8 | ±10 V at the sensor onto 0–3.3 V, RC-filtered |
//! | gauges 4, 5, 6 | PC4, PC5, PB2 | ADC2 IN5, IN11, IN12 | |
//! | piezo command | PA4 | DAC1 OUT1 | 0–3.3 V over the stroke (the amplifier's input range) |
//! | piezo amplifier enable | PA9 | TIM1 CH2 | high = enabled; 10 kΩ pull-down at the amplifier |
//! | amplifier fault / E-stop in | PB12 | TIM1 BKIN | low (or open) = outputs off |
//! | hexapod controller (GCS) | PB6 (TX), PB7 (RX) | USART1 | RS-232 through a level shifter |
//! | spindle converter | PB10 (TX), PB11 (RX) | USART3 | RS-485 through a transceiver |
//! | host link | PA2 (TX), PA3 (RX) | LPUART1 | the ST-LINK's virtual COM port, 921 600 Bd 8N1 |
//! | calibrate button | PC13 | GPIO | the NUCLEO's B1: captures the sensor's bias again |
//! | status LED, fault LED | PC6, PC7 | GPIO | |
//!
//! The pins themselves are chosen in `main` in embassy's typed peripherals; this
//! module holds the cell's numbers.

use kerf::machines::grinding::product::CONFIG;
use kerf_board_support::input_codes::BipolarInput;
use kerf_board_support::output_codes::DacSpan;

/// The control rate, Hz: the cell's period of 1 ms (`product::PERIOD_S`; checked
/// at start-up).
pub const CONTROL_HZ: u32 = 1_000;

/// The gauges' conditioning: ±10 V at the sensor onto the ADC's 0–3.3 V.
pub const GAUGES: BipolarInput = BipolarInput::new(3.3, 10.0);

/// The piezo's stroke over the DAC: the configured range onto 0–3.3 V (set the
/// amplifier's gain so that 3.3 V is the top of the stroke).
pub const PIEZO: DacSpan = DacSpan::new(
    CONFIG.hybrid.piezo_min_m as f32,
    CONFIG.hybrid.piezo_max_m as f32,
);

/// The hexapod controller's baud rate (PI's GCS controllers default to 115 200).
pub const HEXAPOD_BAUD: u32 = 115_200;

/// The spindle converter's baud rate (set it to the converter's).
pub const SPINDLE_BAUD: u32 = 19_200;

/// Longest silence of a device before or within its reply, ms: a GCS reply of a few
/// dozen bytes takes 3 ms at 115 200 Bd, the spindle's three bytes 1.6 ms at 19 200 Bd.
pub const DEVICE_TIMEOUT_MS: u32 = 5;
