//! The supervisor's output check: a machine whose step returns a NaN or ∞ output is
//! faulted with its safe outputs written in the same period, and each machine's
//! outputs are indexed and named as documented.

use super::*;
use crate::app::axis::AxisFault;
use crate::app::joints::JointFault;
use crate::app::supervisor::NoSweep;
use crate::app::supervisor::{Command, Machine, Mode, Report, Step, Supervisor};
use crate::kinematics::arrow::ActuatorVector;
use crate::machines::arrow::machine::{ArrowFault, ArrowOutputs};
use crate::machines::delta_slave::remote::RemoteSlaveFault;
use crate::machines::delta_slave::DeltaFault;
use crate::machines::grinding::{GrindingFault, GrindingOutputs};
use crate::machines::remote_master::{MasterOutputs, RemoteMasterFault};
use heapless::spsc::Queue;

/// A machine whose running step returns the force it is given as input.
struct Passthrough;

#[derive(Copy, Clone, Debug, PartialEq)]
enum Fault {
    Output(u8),
}

impl From<NonFiniteOutput> for Fault {
    fn from(output: NonFiniteOutput) -> Self {
        Self::Output(output.index)
    }
}

impl Machine for Passthrough {
    type Inputs = [f32; 2];
    type Outputs = [f32; 2];
    type Job = u8;
    type JobError = ();
    type Coefficients = ();
    type SweepSample = NoSweep;
    type Calibration = ();
    type Fault = Fault;
    type Telemetry = ();
    fn safe_outputs(&self) -> [f32; 2] {
        [0.0; 2]
    }
    fn monitor(&mut self, _: &[f32; 2]) -> Result<(), Fault> {
        Ok(())
    }
    fn begin_calibration(&mut self) {}
    fn calibrate(
        &mut self,
        _: &[f32; 2],
        _: &mut dyn FnMut(NoSweep),
    ) -> Result<Step<[f32; 2]>, Fault> {
        Ok(Step::Done([0.0; 2]))
    }
    fn finish_calibration(&mut self, _: &()) {}
    fn check_job(&self, _: &u8) -> Result<(), ()> {
        Ok(())
    }
    fn begin_job(&mut self, _: &u8) -> Result<(), ()> {
        Ok(())
    }
    fn run(&mut self, _: &u8, force: &[f32; 2]) -> Result<Step<[f32; 2]>, Fault> {
        Ok(Step::Continue(*force))
    }
    fn begin_stop(&mut self) {}
    fn stop(&mut self, _: &u8, _: &[f32; 2]) -> Result<Step<[f32; 2]>, Fault> {
        Ok(Step::Done([0.0; 2]))
    }
    fn set_coefficients(&mut self, _: &()) {}
    fn reset(&mut self) {}
    fn telemetry(&self) {}
}

/// Running, a finite force passes; a NaN in output 1 faults the machine with its
/// index and the safe outputs are what the period returns; the fault latches.
#[test]
fn a_non_finite_output_faults_with_safe_outputs_in_the_same_period() {
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let mut commands: Queue<Command<Passthrough>, 4> = Queue::new();
        let mut reports: Queue<Report<Passthrough>, 16> = Queue::new();
        let (mut to_machine, from_sender) = commands.split();
        let (to_sender, _) = reports.split();
        let jobs = crate::app::jobs::JobSlots::default();
        let mut supervisor = Supervisor::new(Passthrough, from_sender, to_sender, &jobs);
        for command in [
            Command::FinishCalibration(()),
            Command::LoadJob(jobs.place(1).expect("a free job buffer")),
            Command::Start,
        ] {
            assert!(to_machine.enqueue(command).is_ok());
        }
        assert_eq!(supervisor.step(&[1.5, -2.0]), [1.5, -2.0]);
        assert_eq!(supervisor.mode(), Mode::Running);
        assert_eq!(supervisor.step(&[1.0, bad]), [0.0, 0.0]);
        assert_eq!(supervisor.mode(), Mode::Fault(Fault::Output(1)));
        assert_eq!(supervisor.step(&[1.0, 1.0]), [0.0, 0.0]);
    }
}

/// Each machine's outputs are indexed in the documented order, and the index reaches
/// the machine's fault.
#[test]
fn outputs_are_indexed_and_named_per_machine() {
    let nan = f64::NAN;
    assert_eq!([1.0, nan, nan].first_not_finite(), Some(1));
    assert_eq!([1.0f32, 2.0].first_not_finite(), None);
    let laser = ForceAndLaser {
        force_n: [0.0, 1.0, 2.0],
        laser_duty: f64::INFINITY,
    };
    assert_eq!(laser.first_not_finite(), Some(3));
    let grinding = GrindingOutputs {
        piezo_m: 0.0,
        hexapod_feed_m_s: 0.0,
        spindle_rpm: nan,
    };
    assert_eq!(grinding.first_not_finite(), Some(2));
    let mut command = crate::app::remote_link::RemoteCommand {
        acceleration_m_s2: [0.0, 0.0, f32::INFINITY],
        laser_on: false,
    };
    let master = |command| MasterOutputs {
        force_n: [0.0f64; 3],
        command: Some((0, command)),
    };
    assert_eq!(master(command).first_not_finite(), Some(5));
    command.acceleration_m_s2 = [0.0; 3];
    assert_eq!(master(command).first_not_finite(), None);
    let mut forces_n = ActuatorVector::<f64>::zeros();
    forces_n[4] = nan;
    let arrow = ArrowOutputs {
        forces_n,
        torques_n_m: [0.0; 2],
    };
    assert_eq!(arrow.first_not_finite(), Some(4));
    let output = NonFiniteOutput { index: 2 };
    assert_eq!(
        JointFault::from(output),
        JointFault {
            axis: 2,
            fault: AxisFault::NotFinite
        }
    );
    assert_eq!(DeltaFault::from(output), DeltaFault::Output(output));
    assert_eq!(
        RemoteSlaveFault::from(output),
        RemoteSlaveFault::Slave(DeltaFault::Output(output))
    );
    assert_eq!(
        RemoteMasterFault::from(output),
        RemoteMasterFault::NotFinite
    );
    assert_eq!(GrindingFault::from(output), GrindingFault::Output(output));
    assert_eq!(ArrowFault::from(output), ArrowFault::Output(output));
}
