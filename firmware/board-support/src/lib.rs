//! What every kerf board image for the STM32G474 shares, apart from the machine it
//! runs.
//!
//! - Always (host-tested): the parts that are pure functions of their inputs — the
//!   DAC code of a command, the timer compare value of a PWM duty, a CAN frame as
//!   the FDCAN's message RAM holds it, and the fault
//!   record that survives a reset with the decision of what ended the last run.
//! - With the `stm32` feature (the board target only): [`stm32`], the layer the
//!   images are written on — clocks, ADC sampling by DMA, DAC and timer outputs
//!   with the hardware break, the control-period interrupt with its deadline, the
//!   host link task, the fault path with the watchdog, the cycle counter and stack
//!   painting. A machine's image (`firmware/board`) adds its pin table, its HAL
//!   implementation and its `main`.
#![no_std]
#![cfg_attr(not(feature = "stm32"), forbid(unsafe_code))]

pub mod can_element;
pub mod fault_record;
pub mod input_codes;
pub mod output_codes;
pub mod reply_framing;
#[cfg(feature = "stm32")]
pub mod stm32;
pub mod timer_period;
