//! The G474's CORDIC co-processor as an atan2 for the Hall decoder, measured against
//! the library's integer path (`kerf::sensing::hall::atan2_turns`) at start-up.
//!
//! The PHASE function (RM0440, CORDIC "Phase" parameters) takes x and y in q1.31 and
//! returns atan2(y, x) / π in q1.31, which read as an unsigned word is the phase in
//! units of 2^-32 turn: the library's phase word, with no conversion. Configured for
//! 24 iterations (PRECISION = 6: four iterations per clock, six cycles); the RM's
//! precision table gives a residual error of about 2^-19 of π (2^-20 turn, 9.5e-7)
//! for the phase in q1.31, where the library's table path stays below 1e-7 turn. The
//! co-processor is therefore not used in the control period: its accuracy does not
//! reach the library's (see the Hall rows of BENCHMARKS.md for the figures). The
//! start-up measurement logs both on the board so that the claim can be checked.

use super::timing;
use embassy_stm32::pac;
use kerf::sensing::hall::atan2_turns;
use pac::cordic::vals::{Func, Num, Precision, Scale, Size};

/// Configures the co-processor for the phase of 32-bit x, y (two writes) with one
/// 32-bit result (one read, which waits for the result: no polling).
pub fn start() {
    pac::RCC.ahb1enr().modify(|w| w.set_cordicen(true));
    pac::CORDIC.csr().write(|w| {
        // FUNC = 2 (phase), PRECISION = 6 (24 iterations), no scaling (RM0440,
        // CORDIC_CSR).
        w.set_func(Func::PHASE);
        w.set_precision(Precision::ITERS24);
        w.set_scale(Scale::A1_R1);
        w.set_nargs(Num::NUM2);
        w.set_nres(Num::NUM1);
        w.set_argsize(Size::BITS32);
        w.set_ressize(Size::BITS32);
    });
}

/// atan2(y, x) as a phase word (full turn = 2^32) by the co-processor: both inputs
/// shifted left together until the larger magnitude lies in [2^29, 2^30), so that the
/// vector stays inside the unit circle of q1.31 (|v| < 2^30·√2 < 2^31), then x, y
/// written and the phase read. Inputs of magnitude 2^31 (i32::MIN) are outside the
/// unit circle; the Hall decoder's demodulated values stay far below. Branch-free;
/// not inlined so that its instructions can be counted in the image.
#[inline(never)]
pub fn phase(y: i32, x: i32) -> u32 {
    let magnitude = x.unsigned_abs() | y.unsigned_abs();
    let shift = magnitude.leading_zeros().saturating_sub(2) & 31;
    let cordic = pac::CORDIC;
    cordic
        .wdata()
        .write_value(((x as u32) << shift) as i32 as u32);
    cordic
        .wdata()
        .write_value(((y as u32) << shift) as i32 as u32);
    cordic.rdata().read()
}

/// The library's integer phase, out of line for the same comparison.
#[inline(never)]
pub fn library_phase(y: i32, x: i32) -> u32 {
    atan2_turns(y, x)
}

/// The comparison over a turn.
#[derive(Copy, Clone, Debug, defmt::Format)]
pub struct Comparison {
    /// Largest |CORDIC − library| over the sweep, in units of 2^-32 turn.
    pub worst_difference: u32,
    /// Cycles per call of [`phase`], with the call.
    pub cordic_cycles: u32,
    /// Cycles per call of [`library_phase`], with the call.
    pub library_cycles: u32,
}

/// Points of the start-up sweep.
const SWEEP: u32 = 1024;

/// Compares the two over a turn at the amplitude of a 16-bit Hall channel.
pub fn compare() -> Comparison {
    let radius = 26_214.0f32;
    let mut worst = 0u32;
    let mut cordic_cycles = 0u32;
    let mut library_cycles = 0u32;
    for k in 0..SWEEP {
        let angle = k as f32 * (core::f32::consts::TAU / SWEEP as f32);
        let (s, c) = kerf::scalar::sin_cos_f32(angle);
        let (y, x) = ((radius * s) as i32, (radius * c) as i32);
        let t0 = timing::cycles();
        let a = phase(y, x);
        let t1 = timing::cycles();
        let b = library_phase(y, x);
        let t2 = timing::cycles();
        cordic_cycles = cordic_cycles.wrapping_add(t1.wrapping_sub(t0));
        library_cycles = library_cycles.wrapping_add(t2.wrapping_sub(t1));
        worst = worst.max((a.wrapping_sub(b) as i32).unsigned_abs());
    }
    Comparison {
        worst_difference: worst,
        cordic_cycles: cordic_cycles / SWEEP,
        library_cycles: library_cycles / SWEEP,
    }
}
