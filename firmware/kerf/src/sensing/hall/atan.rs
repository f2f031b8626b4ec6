//! Integer atan2 into a phase word (full turn = 2^32).

mod tables {
    include!(concat!(env!("OUT_DIR"), "/tables.rs"));
}
use tables::{ATAN_INTERVALS, ATAN_TURN_Q32};

/// atan2(y, x) as a phase word (full turn = 2^32), integer only.
///
/// Octant reduction to a ratio r = min(|x|,|y|) / max(|x|,|y|) in [0, 1], computed as
/// an exact Q22 floor by long division in two 11-bit steps (32-bit hardware divisions;
/// inputs are scaled below 2^20 first, so 20-bit vectors keep every bit), then linear
/// interpolation in a 512-interval atan table made by `build.rs`.
/// Error budget: interpolation h²/8·max|atan″| = 3.1e-7 rad, ratio floor 2^-22 rad,
/// table rounding 2^-33 turn: below 1e-7 turn in all (1.8 nm at an 18 mm pitch),
/// checked against `f64::atan2` in the tests. Inputs beyond 2^20 lose their low bits
/// to the scaling (relative 2^-20, i.e. 2.4e-7 turn more at worst).
#[inline]
pub fn atan2_turns(y: i32, x: i32) -> u32 {
    let (ax, ay) = (x.unsigned_abs(), y.unsigned_abs());
    // Keep the larger magnitude below 2^20 so that (remainder << 11) fits in 32 bits.
    let excess = (32 - ax.max(ay).leading_zeros()).saturating_sub(20);
    atan2_turns_below_2_20(y < 0, x < 0, ay >> excess, ax >> excess)
}

/// [`atan2_turns`] for magnitudes `ay`, `ax` already below 2^20 (callers that bound
/// their inputs skip the scaling), with the signs of y and x given separately.
#[inline]
pub(crate) fn atan2_turns_below_2_20(y_negative: bool, x_negative: bool, ay: u32, ax: u32) -> u32 {
    const FRACTION_BITS: u32 = 22 - ATAN_INTERVALS.trailing_zeros();
    let (num, den) = if ay <= ax { (ay, ax) } else { (ax, ay) };
    if den == 0 {
        return 0;
    }
    // r = num/den ≤ 1 to 22 fraction bits, 11 bits per step (remainder < den < 2^20).
    let high = (num << 11) / den;
    // The remainder of that division (< den), as `%` rather than `num << 11 − high·den`:
    // the same value without a subtraction the optimiser would have to prove.
    let low = (((num << 11) % den) << 11) / den;
    let ratio_q22 = (high << 11) | low;
    let index = (ratio_q22 >> FRACTION_BITS) as usize;
    // The fraction as a Q32 word (the index bits shift out): the interpolation's
    // product then ends in the upper word, (d·f) >> FRACTION_BITS without a shift.
    let fraction_q32 = ratio_q22 << (32 - FRACTION_BITS);
    // Ratio ≤ 1 keeps index ≤ ATAN_INTERVALS, which the padded table covers.
    let Some(&[lo, hi]) = ATAN_TURN_Q32
        .get(index..)
        .and_then(<[u32]>::first_chunk::<2>)
    else {
        return 0;
    };
    // Phase words in turns (2^32 to the turn): their arithmetic is modular, so the
    // interpolation and the octant and quadrant folds below wrap by meaning. (The
    // table increases and its entries stay below a quarter turn, so none does wrap.)
    let octant =
        lo.wrapping_add(((u64::from(hi.wrapping_sub(lo)) * u64::from(fraction_q32)) >> 32) as u32);
    const QUARTER: u32 = 1 << 30;
    const HALF: u32 = 1 << 31;
    let first_quadrant = if ay <= ax {
        octant
    } else {
        QUARTER.wrapping_sub(octant)
    };
    let half_plane = if x_negative {
        HALF.wrapping_sub(first_quadrant)
    } else {
        first_quadrant
    };
    if y_negative {
        half_plane.wrapping_neg()
    } else {
        half_plane
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    fn turns_error(phase: u32, y: f64, x: f64) -> f64 {
        let exact = y.atan2(x) / (2.0 * PI); // (-0.5, 0.5]
        let got = phase as i32 as f64 / 4_294_967_296.0;
        let mut d = got - exact;
        d -= d.round();
        d.abs()
    }

    #[test]
    fn atan2_matches_f64_over_a_turn() {
        // Worst case over a dense sweep, at 12-bit and 16-bit amplitudes.
        for amplitude in [3.0 * 800.0, 3.0 * 26214.0] {
            let mut worst = 0.0f64;
            for k in 0..100_000 {
                let phi = 2.0 * PI * (k as f64 + 0.37) / 100_000.0;
                let (y, x) = (
                    (amplitude * phi.sin()).round(),
                    (amplitude * phi.cos()).round(),
                );
                worst = worst.max(turns_error(atan2_turns(y as i32, x as i32), y, x));
            }
            // Error budget in the function's docs: 1e-7 turn.
            assert!(worst < 1e-7, "amplitude {amplitude}: {worst} turn");
        }
    }

    #[test]
    fn atan2_handles_axes_octant_edges_and_extremes() {
        for (y, x) in [
            (1, 0),
            (0, 1),
            (-1, 0),
            (0, -1),
            (i32::MAX / 2, -i32::MAX / 2),
            (-5, -5),
        ] {
            assert!(
                turns_error(atan2_turns(y, x), y as f64, x as f64) < 4.0e-8,
                "{y},{x}"
            );
        }
        assert_eq!(atan2_turns(0, 0), 0);
    }

    proptest::proptest! {
        #[test]
        fn atan2_matches_f64_for_any_vector_below_2_pow_20(y in -(1i32 << 20)..(1 << 20), x in -(1i32 << 20)..(1 << 20)) {
            proptest::prop_assume!(x != 0 || y != 0);
            proptest::prop_assert!(turns_error(atan2_turns(y, x), f64::from(y), f64::from(x)) < 1e-7);
        }
    }
}
