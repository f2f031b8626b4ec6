//! The parts of a kerf board image that are pure functions of their inputs, apart from
//! the registers they end up in: the DAC code of a force command, the timer compare
//! value of a PWM duty, and the fault record that survives a reset with the decision of
//! what ended the last run. The board images (`firmware/board`) write these values to
//! the peripherals; the host tests here check them against the formulas written out.
#![no_std]
#![forbid(unsafe_code)]

pub mod fault_record;
pub mod output_codes;
