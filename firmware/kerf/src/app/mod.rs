//! Machines and their supervisor: how a machine runs, one step per control period.
//!
//! [`supervisor`] owns the modes (Idle → Calibrating → Ready → Running → Stopping →
//! Fault) and the command and report queues; a machine implements
//! [`supervisor::Machine`]. [`axis`] is one Hall-sensed linear-motor axis split into
//! coefficients and state; [`joints`] is the machine of N such axes that follow
//! joint-space jobs (the single LM1247 axis is its N = 1 case); [`calibrate`] is the
//! calibration sweep and the fit the slower context runs on the streamed samples.

pub mod axis;
pub mod calibrate;
pub mod delta_slave;
pub mod joints;
pub mod supervisor;

use crate::hal::{SampleInputs, WriteOutputs};
use supervisor::{Machine, Supervisor};

/// One control period on a board: sample every input, step the supervisor, write every
/// output. The control interrupt of the QEMU image and of a board image call this.
pub fn control_period<M, H>(supervisor: &mut Supervisor<'_, M>, hal: &mut H) -> M::Outputs
where
    M: Machine,
    H: SampleInputs<M::Inputs> + WriteOutputs<M::Outputs>,
{
    let inputs = hal.sample();
    let outputs = supervisor.step(&inputs);
    hal.write(&outputs);
    outputs
}
