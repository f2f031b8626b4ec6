//! The supervisor's last check before outputs are written: every output finite.
//!
//! A machine's step can produce a NaN or an infinity from finite inputs (a gain, a
//! model term or an estimate that overflows its scalar, ∞ − ∞ in a projection); a
//! clamp passes NaN, and a NaN force or duty reaching a PWM is undefined. So the
//! supervisor checks each period's outputs through [`FiniteOutputs`] once, for every
//! machine, before it returns them: a non-finite output enters
//! `Mode::Fault(NonFiniteOutput.into())` and the machine's safe outputs are written in
//! the same period (row 11 of the supervisor's transition table).

use crate::app::arrow::machine::{ArrowFault, ArrowOutputs};
use crate::app::axis::AxisFault;
use crate::app::delta_slave::DeltaFault;
use crate::app::grinding::{GrindingFault, GrindingOutputs};
use crate::app::joints::JointFault;
use crate::app::remote_master::{MasterOutputs, RemoteMasterFault};
use crate::app::remote_slave::RemoteSlaveFault;
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
fn first<T: Real>(values: impl IntoIterator<Item = T>) -> Option<u8> {
    values
        .into_iter()
        .position(|v| !v.is_finite())
        .map(|i| u8::try_from(i).unwrap_or(u8::MAX))
}

/// A single output.
impl<T: Real> FiniteOutputs for T {
    fn first_not_finite(&self) -> Option<u8> {
        first([*self])
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
        first(*self)
    }
}

/// The forces 0 to N − 1, the laser duty N.
impl<T: Real, const N: usize> FiniteOutputs for ForceAndLaser<T, N> {
    fn first_not_finite(&self) -> Option<u8> {
        first(self.force_n.iter().chain([&self.laser_duty]).copied())
    }
}

/// The piezo 0, the hexapod feed 1, the spindle speed 2.
impl<T: Real> FiniteOutputs for GrindingOutputs<T> {
    fn first_not_finite(&self) -> Option<u8> {
        first([self.piezo_m, self.hexapod_feed_m_s, self.spindle_rpm])
    }
}

/// The carriage forces 0–2, the slave command's accelerations 3–5 (f32, as sent).
impl<T: Real> FiniteOutputs for MasterOutputs<T> {
    fn first_not_finite(&self) -> Option<u8> {
        let command = self.command.map_or([0.0; 3], |(_, c)| c.acceleration_m_s2);
        first(self.force_n).or_else(|| first(command).map(|i| i + 3))
    }
}

/// The actuator forces 0–5, the table torques 6–7.
impl<T: crate::scalar::Float> FiniteOutputs for ArrowOutputs<T> {
    fn first_not_finite(&self) -> Option<u8> {
        first(self.forces_n.iter().chain(&self.torques_n_m).copied())
    }
}

/// Output `index` is axis `index`'s force: that axis, a value not finite.
impl From<NonFiniteOutput> for JointFault {
    fn from(output: NonFiniteOutput) -> Self {
        Self {
            axis: output.index,
            fault: AxisFault::NotFinite,
        }
    }
}

impl From<NonFiniteOutput> for DeltaFault {
    fn from(output: NonFiniteOutput) -> Self {
        Self::Output(output)
    }
}

/// The remote slave's outputs are its delta slave's.
impl From<NonFiniteOutput> for RemoteSlaveFault {
    fn from(output: NonFiniteOutput) -> Self {
        Self::Slave(DeltaFault::Output(output))
    }
}

impl From<NonFiniteOutput> for RemoteMasterFault {
    fn from(_: NonFiniteOutput) -> Self {
        Self::NotFinite
    }
}

impl From<NonFiniteOutput> for GrindingFault {
    fn from(output: NonFiniteOutput) -> Self {
        Self::Output(output)
    }
}

impl From<NonFiniteOutput> for ArrowFault {
    fn from(output: NonFiniteOutput) -> Self {
        Self::Output(output)
    }
}

#[cfg(test)]
mod tests;
