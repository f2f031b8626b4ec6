//! The winding's temperature rise estimated from its current (I²t), for a fault
//! before the coil is damaged (docs/control.md §30).
//!
//! The coil's copper loss is (3/2)·R·|i|² (|i| the amplitude of i_dq), and it heats
//! with one thermal time constant τ toward a rise proportional to that loss. In
//! units of the rated current I_c (the current the coil may carry for ever), the
//! normalised heat h = ΔT / ΔT_rated follows
//!
//! ```text
//! τ dh/dt = |i|² / I_c² − h,        discrete: h ← h + (|i|²/I_c² − h)·(1 − e^(−T/τ))
//! ```
//!
//! and the winding is too hot at h > 1: at the rated current h tends to 1, at twice
//! it (a peak force) it crosses 1 after τ·ln(4/3) (0.29 τ). Start-up assumes the
//! winding cold (h = 0); a board that restarts warm underestimates until τ has passed.

use crate::error::{positive, ConfigError};
use crate::scalar::{lit, Float};

/// The winding's thermal rating.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct WindingRating {
    /// Current amplitude the winding may carry for ever, A.
    pub continuous_a: f64,
    /// Thermal time constant of the winding, s.
    pub time_constant_s: f64,
}

impl WindingRating {
    /// The LM1247: 0.36 A for its 3.6 N continuous force at 9.9 N/A
    /// ([`super::MotorWindings::LM1247`]); a winding time constant of 20 s, an
    /// assumption of the order of a small ironless coil's.
    pub const LM1247: Self = Self {
        continuous_a: 0.36,
        time_constant_s: 20.0,
    };
}

/// The estimator's coefficients at an update period.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct WindingHeat<T> {
    /// 1/I_c², 1/A².
    inverse_rated2: T,
    /// 1 − e^(−T/τ).
    blend: T,
}

impl<T: Float> WindingHeat<T> {
    /// The estimator of `rating`, updated every `period_s`.
    ///
    /// Errors: a value not finite and positive; a coefficient `T` cannot hold (a
    /// period so short against τ that the blend rounds away).
    pub fn new(rating: &WindingRating, period_s: f64) -> Result<Self, ConfigError> {
        let rated = positive("continuous_a", rating.continuous_a)?;
        let tau = positive("time_constant_s", rating.time_constant_s)?;
        let period = positive("period_s", period_s)?;
        let blend = -libm::expm1(-period / tau);
        Ok(Self {
            inverse_rated2: crate::error::coefficient("continuous_a", 1.0 / (rated * rated))?,
            blend: crate::error::coefficient("period_s", blend)?,
        })
    }

    /// The heat `h` after a period at current `i_dq` (A); whether the winding is now
    /// too hot (h > 1). A current that is not finite counts as too hot and leaves
    /// `h` as it was.
    pub fn update(&self, heat: &mut T, i_dq: [T; 2]) -> bool {
        let load = (i_dq[0] * i_dq[0] + i_dq[1] * i_dq[1]) * self.inverse_rated2;
        if !load.is_finite() {
            return true;
        }
        *heat += (load - *heat) * self.blend;
        *heat > lit(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At twice the rated current the winding is too hot after τ·ln(4/3) (the
    /// closed form of the first-order rise, to one period); at the rated current it
    /// never is; a current that is not finite is a fault at once.
    #[test]
    fn the_winding_heats_as_its_first_order_model() {
        let period = 1e-3;
        let heat = WindingHeat::<f64>::new(&WindingRating::LM1247, period).unwrap();
        let mut h = 0.0;
        let mut periods = 0u32;
        while !heat.update(&mut h, [0.0, 0.72]) {
            periods += 1;
            assert!(periods < 100_000);
        }
        let expected = 20.0 * libm::log(4.0 / 3.0);
        let took = f64::from(periods + 1) * period;
        assert!(
            (took - expected).abs() <= period,
            "{took} against {expected}"
        );
        let mut rated = 0.0;
        for _ in 0..200_000 {
            assert!(!heat.update(&mut rated, [0.36 * 0.6, 0.36 * 0.8]));
        }
        assert!(rated > 0.99, "{rated}");
        let before = rated;
        assert!(heat.update(&mut rated, [f64::NAN, 0.0]));
        assert_eq!(rated, before);
        assert!(WindingHeat::<f32>::new(&WindingRating::LM1247, 0.0).is_err());
        // In f32 at 1 kHz the blend is 5e-5, well representable; the rise agrees.
        let heat32 = WindingHeat::<f32>::new(&WindingRating::LM1247, period).unwrap();
        let mut h32 = 0.0f32;
        let mut p32 = 0u32;
        while !heat32.update(&mut h32, [0.0, 0.72]) {
            p32 += 1;
        }
        assert!(p32.abs_diff(periods) <= 2, "{p32} against {periods}");
    }
}
