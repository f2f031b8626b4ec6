//! What the board images of kerf's Hall-sensed linear-motor machines share beyond
//! `kerf_board_support`: the board behind the HAL traits for `N` carriages (their
//! Hall channels sampled by ADC1…N, their forces on the DACs, the laser on TIM1) and
//! the Hall calibration run from the button. The Keops slave (`board-keops`), the
//! remote slave (`board-remote-slave`) and the single axis (`board-axis`) are built
//! on it.
#![no_std]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

pub mod hall;
pub mod image;
