//! The supervisor's last check before outputs are written: every output finite.
//!
//! A machine's step can produce a NaN or an infinity from finite inputs (a gain, a
//! model term or an estimate that overflows its scalar, ∞ − ∞ in a projection); a
//! clamp passes NaN, and a NaN force or duty reaching a PWM is undefined. So the
//! supervisor checks each period's outputs through [`FiniteOutputs`] once, for every
//! machine, before it returns them: a non-finite output enters
//! `Mode::Fault(NonFiniteOutput.into())` and the machine's safe outputs are written in
//! the same period (row 11 of the supervisor's transition table).

use crate::hal::ForceAndLaser;
use crate::scalar::Real;

/// A machine's outputs as the supervisor checks them before they are written.
pub trait FiniteOutputs {
    /// The index of the first output that is NaN or infinite (in the order each
    /// implementation documents), or `None` when all are finite.
    fn first_not_finite(&self) -> Option<u8>;
}

/// Why the supervisor stopped a machine whose step produced a NaN or infinite output:
/// which output (the index [`FiniteOutputs::first_not_finite`] gave).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NonFiniteOutput {
    /// The output's index.
    pub index: u8,
}

/// The position of the first non-finite value of `values`.
pub(crate) fn first_non_finite_index<T: Real>(values: impl IntoIterator<Item = T>) -> Option<u8> {
    values
        .into_iter()
        .position(|v| !v.is_finite())
        .map(|i| u8::try_from(i).unwrap_or(u8::MAX))
}

/// A single output.
impl<T: Real> FiniteOutputs for T {
    fn first_not_finite(&self) -> Option<u8> {
        first_non_finite_index([*self])
    }
}

/// A count (a compare value, a digital output): always finite.
impl FiniteOutputs for u8 {
    fn first_not_finite(&self) -> Option<u8> {
        None
    }
}

/// One output per axis, index = axis.
impl<T: Real, const N: usize> FiniteOutputs for [T; N] {
    fn first_not_finite(&self) -> Option<u8> {
        first_non_finite_index(*self)
    }
}

/// The forces 0 to N − 1, the laser duty N.
impl<T: Real, const N: usize> FiniteOutputs for ForceAndLaser<T, N> {
    fn first_not_finite(&self) -> Option<u8> {
        first_non_finite_index(self.force_n.iter().chain([&self.laser_duty]).copied())
    }
}

#[cfg(test)]
mod tests;
