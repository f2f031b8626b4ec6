//! The remote slave behind the host link: the slave that plays a recorded master
//! session ([`SessionSlave`], `kerf::machines::delta_slave::remote::session`) on the simulated
//! Keops delta of the remote scenarios (the realistic plant, the imperfect Hall
//! sensors, [`keops_site`]), with commands coming from [`HostLink`] only, so a host (a
//! test's, or the host tool over the QEMU image's serial port) uploads a session,
//! starts it, retunes the slave and follows it with frames alone.
//!
//! At power-up the slave calibrates its Hall sensors, as the replay's does (the sweep,
//! 0.8 s, and the fit in this slower context), serving the link meanwhile, and is then
//! Ready (a fit that fails stops the calibration: the slave stays Idle). A session's
//! approach takes the carriages to its start; from there the recorded frames play as
//! they arrived.

use crate::remote::{keops_site, RemoteSimError};
use crate::slave::simulated_delta;
use hal_mock::delta::SimulatedDelta;
use hal_mock::delta_plant::DeltaPlantParams;
use heapless::spsc::{Consumer, Producer, Queue};
use kerf::app::calibrate::{CalibrationFit, HallMachine};
use kerf::app::host_link::{HostLink, HostLinkConfig};
use kerf::app::jobs::JobSlots;
use kerf::app::supervisor::{Command, Report, Supervisor};
use kerf::hal::{ForceAndLaser, SampleInputs, WriteOutputs};
use kerf::kinematics::delta::KinematicsError;
use kerf::machines::delta_slave::remote::link::RemoteSlaveSettings;
use kerf::machines::delta_slave::remote::product::{
    CONFIG, LINK_JOB_BYTES, PERIOD_S, TELEMETRY_DECIMATION,
};
use kerf::machines::delta_slave::remote::recording::Recording;
use kerf::machines::delta_slave::remote::session::SessionSlave;
use kerf::scalar::Float;

/// The recorded master session of the remote scenario (4 s, `data/remote_commands.krfr`).
pub const RECORDING: &[u8] = include_bytes!("../../../data/remote_commands.krfr");

/// Master periods of the recording a session job carries: the first 2 s, what the
/// slave's session buffer holds (`product::SESSION_FRAME_BYTES`).
pub const SESSION_PERIODS: u32 = 20_000;

/// The session of [`RECORDING`]'s first [`SESSION_PERIODS`] into `out` (the
/// recording's own bytes, no master references); its length, `None` when `out` is too
/// small or the recording unreadable.
pub fn session(out: &mut [u8]) -> Option<usize> {
    Recording::parse(RECORDING)
        .ok()?
        .write_session(SESSION_PERIODS, out)
}

/// The slave, its plant and its host link.
pub struct LinkedRemoteSlave<'q, T: Float> {
    supervisor: Supervisor<'q, SessionSlave<T>>,
    plant: SimulatedDelta,
    link: HostLink<'q, SessionSlave<T>, LINK_JOB_BYTES>,
    commands: Producer<'q, Command<SessionSlave<T>>>,
    reports: Consumer<'q, Report<SessionSlave<T>>>,
    /// The calibration sweep's samples, for the fit.
    samples: CalibrationFit<3>,
    now_s: f64,
}

impl<'q, T: Float> LinkedRemoteSlave<'q, T> {
    /// The host link: to attach the machine's settings store
    /// ([`HostLink::attach_store`]) before the first period.
    pub fn link_mut(&mut self) -> &mut HostLink<'q, SessionSlave<T>, LINK_JOB_BYTES> {
        &mut self.link
    }

    /// One control period: the host's bytes read, the period run on the plant's Hall
    /// counts, the plant moved, the reports answered and forwarded through `to_host`,
    /// the heartbeat checked. Returns the outputs written.
    ///
    /// Errors: the simulated mechanism left the region where it assembles.
    pub fn period(
        &mut self,
        from_host: &[u8],
        to_host: &mut dyn FnMut(&[u8]) -> bool,
    ) -> Result<ForceAndLaser<T, 3>, KinematicsError> {
        for &b in from_host {
            self.link
                .receive(b, self.now_s, &mut self.commands, &mut *to_host);
        }
        let outputs = self.step()?;
        while let Some(report) = self.reports.dequeue() {
            self.calibration(&report);
            self.link.report(&report, &mut *to_host);
        }
        self.now_s += PERIOD_S;
        self.link
            .tick(self.now_s, &mut self.commands, &mut *to_host);
        Ok(outputs)
    }

    fn step(&mut self) -> Result<ForceAndLaser<T, 3>, KinematicsError> {
        let hall = self.plant.sample();
        let outputs = self.supervisor.step(&hall);
        self.plant.write(&outputs);
        match self.plant.error {
            Some(e) => Err(e),
            None => Ok(outputs),
        }
    }

    /// The supervisor.
    pub fn supervisor(&self) -> &Supervisor<'_, SessionSlave<T>> {
        &self.supervisor
    }

    /// The simulated delta.
    pub fn plant(&self) -> &SimulatedDelta {
        &self.plant
    }
}

/// Builds the slave as flashed ([`CONFIG`], its settings) on the remote scenarios'
/// simulated delta behind the link, its calibration begun (module docs), and hands it
/// to `f`. The link stops a job after `heartbeat_timeout_s` of machine time without a
/// frame from the host: a simulation that runs faster than real time needs more than
/// a board's.
///
/// Errors: a configuration the slave or the link refuses; a plant that does not
/// assemble.
pub fn with_linked_remote_slave<T: Float, R>(
    heartbeat_timeout_s: f64,
    f: impl FnOnce(&mut LinkedRemoteSlave<'_, T>) -> R,
) -> Result<R, RemoteSimError> {
    let jobs = JobSlots::default();
    let mut commands = Queue::<Command<SessionSlave<T>>, 2>::new();
    let mut reports = Queue::<Report<SessionSlave<T>>, 16>::new();
    let (to_machine, from_sender) = commands.split();
    let (to_link, from_machine) = reports.split();
    let config = RemoteSimError::Config;
    let machine = SessionSlave::<T>::new(&CONFIG).map_err(config)?;
    let mut supervisor = Supervisor::new(machine, from_sender, to_link, &jobs);
    supervisor.set_telemetry_decimation(TELEMETRY_DECIMATION);
    // The remote scenarios' plant, sensors and noise (their stream setup is the
    // session's, not the site's).
    let site = keops_site(DeltaPlantParams::SLAVE_REALISTIC, 1, 1, 0);
    let joints = &CONFIG.slave.joints;
    let plant = simulated_delta(
        &CONFIG.slave.delta,
        site.plant,
        site.sensors,
        PERIOD_S,
        site.seed,
        joints.home_m,
        site.substeps,
    )
    .map_err(RemoteSimError::Plant)?;
    let link_config = HostLinkConfig {
        period_s: PERIOD_S,
        heartbeat_timeout_s,
    };
    let link = HostLink::new(&link_config, RemoteSlaveSettings::of_product(), (), &jobs)
        .map_err(config)?;
    let mut commands = to_machine;
    commands
        .enqueue(Command::Calibrate)
        .map_err(|_| RemoteSimError::Timeout)?;
    let mut slave = LinkedRemoteSlave {
        supervisor,
        plant,
        link,
        commands,
        reports: from_machine,
        samples: CalibrationFit::default(),
        now_s: 0.0,
    };
    Ok(f(&mut slave))
}

impl<T: Float> LinkedRemoteSlave<'_, T> {
    /// The slower context's part of the calibration at power-up: the sweep's samples
    /// kept, fitted when the sweep is done and the decoders installed (or, should the
    /// fit fail, the calibration stopped).
    fn calibration(&mut self, report: &Report<SessionSlave<T>>) {
        match report {
            // Too many samples: none kept, so that the fit refuses.
            Report::CalibrationSample(sample) if self.samples.push(*sample).is_err() => {
                self.samples = CalibrationFit::default();
            }
            Report::SweepDone => {
                let command = match SessionSlave::<T>::fit(&CONFIG.slave.joints.hall, &self.samples)
                {
                    Ok((sensors, _)) => Command::FinishCalibration(sensors),
                    Err(_) => Command::Stop,
                };
                // The queue is empty at power-up: nothing else is sent before Ready.
                let _ = self.commands.enqueue(command);
            }
            _ => {}
        }
    }
}
