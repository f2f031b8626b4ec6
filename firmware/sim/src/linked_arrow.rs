//! ARROW behind the host link: the simulated machine ([`crate::arrow`]'s plant, with
//! its geometric error) and the supervisor, with commands coming from
//! [`HostLink`] only, so a host (a test's, or the host tool over the QEMU image's
//! serial port) uploads G-code, starts, retunes and follows it with frames alone.
//!
//! The plate stands at ARROW's home, the pyramid's start
//! ([`HOME`], the first point of
//! `data/pyramid.gcode`: X 13.333, Y 464.604, Z −13.333 mm, θx −15°, θz 15°), where
//! a job must begin. While the machine does not run a job its outputs are the safe
//! ones (no force) and the actuators' brakes hold the plate: the plant moves only
//! under a running or stopping job's commands.

use crate::arrow::ArrowScenario;
use hal_mock::arrow::{ArrowPlant, ArrowReading};
use heapless::spsc::{Consumer, Producer, Queue};
use kerf::app::host_link::{HostLink, HostLinkConfig};
use kerf::app::jobs::JobSlots;
use kerf::app::supervisor::{Command, Mode, Report, Supervisor};
use kerf::kinematics::arrow::{ArrowError, Pose};
use kerf::machines::arrow::link::ArrowSettings;
use kerf::machines::arrow::machine::{ArrowInputs, ArrowLimits, ArrowOutputs};
use kerf::machines::arrow::product::{Arrow, HOME, LINK_JOB_BYTES, PERIOD_S, TELEMETRY_DECIMATION};
use kerf::scalar::{Float, Real};

/// Where the plate stands at power-up, [`HOME`] (pose in m and rad, the table's θx in
/// rad).
pub fn home() -> (Pose<f64>, f64) {
    let [x, y, z, theta_x, theta_z] = HOME;
    (Pose::new(x, y, z, theta_z), theta_x)
}

/// ARROW, its plant and its host link.
pub struct LinkedArrow<'q, T: Float> {
    supervisor: Supervisor<'q, Arrow<T>>,
    plant: ArrowPlant<T>,
    reading: ArrowReading<T>,
    link: HostLink<'q, Arrow<T>, LINK_JOB_BYTES>,
    commands: Producer<'q, Command<Arrow<T>>>,
    reports: Consumer<'q, Report<Arrow<T>>>,
    now_s: f64,
}

impl<'q, T: Float> LinkedArrow<'q, T> {
    /// The host link: to attach the machine's settings store
    /// ([`HostLink::attach_store`]) before the first period.
    pub fn link_mut(&mut self) -> &mut HostLink<'q, Arrow<T>, LINK_JOB_BYTES> {
        &mut self.link
    }

    /// One control period: the host's bytes read, the period run, the plant moved
    /// under a job's commands (held otherwise), the reports answered and forwarded
    /// through `to_host`, the heartbeat checked. Returns the outputs written.
    ///
    /// Errors: the plate driven out of the model's reach.
    pub fn period(
        &mut self,
        from_host: &[u8],
        to_host: &mut dyn FnMut(&[u8]) -> bool,
    ) -> Result<ArrowOutputs<T>, ArrowError> {
        for &b in from_host {
            self.link
                .receive(b, self.now_s, &mut self.commands, &mut *to_host);
        }
        let inputs = ArrowInputs {
            joints_m: self.reading.joints_m,
            table_rad: self.reading.turntable_rad,
            drive_fault: None,
        };
        let outputs = self.supervisor.step(&inputs);
        if matches!(self.supervisor.mode(), Mode::Running | Mode::Stopping) {
            self.reading = self.plant.step(&outputs.forces_n, outputs.torques_n_m)?;
        }
        while let Some(report) = self.reports.dequeue() {
            self.link.report(&report, &mut *to_host);
        }
        self.now_s += PERIOD_S;
        self.link
            .tick(self.now_s, &mut self.commands, &mut *to_host);
        Ok(outputs)
    }

    /// The supervisor.
    pub fn supervisor(&self) -> &Supervisor<'_, Arrow<T>> {
        &self.supervisor
    }

    /// The simulated machine.
    pub fn plant(&self) -> &ArrowPlant<T> {
        &self.plant
    }
}

/// Builds ARROW of `scenario` (its gains, its plant) behind the link, at [`home`],
/// ready (ARROW has no calibration run), and hands it to `f`. The link stops a job
/// after `heartbeat_timeout_s` of machine time without a frame from the host: a
/// simulation that runs faster than real time needs more than a board's.
///
/// Errors: a scenario whose law or plant cannot be built.
pub fn with_linked_arrow<T: Float, R>(
    scenario: &ArrowScenario,
    heartbeat_timeout_s: f64,
    f: impl FnOnce(&mut LinkedArrow<'_, T>) -> R,
) -> Result<R, ArrowError> {
    let jobs = JobSlots::default();
    let mut commands = Queue::<Command<Arrow<T>>, 2>::new();
    let mut reports = Queue::<Report<Arrow<T>>, 16>::new();
    let (mut to_machine, from_sender) = commands.split();
    let (to_link, from_machine) = reports.split();
    let law = scenario.law::<T>()?;
    let machine = Arrow::<T>::new(law, scenario.plant.period_s, &ArrowLimits::ARROW)
        .map_err(|_| ArrowError::NotFinite)?;
    let (pose, theta_x) = home();
    let plant = ArrowPlant::<T>::new(
        &scenario.plant,
        pose.map(<T as Real>::from_f64),
        <T as Real>::from_f64(theta_x),
    )?;
    let reading = plant.read()?;
    let mut supervisor = Supervisor::new(machine, from_sender, to_link, &jobs);
    supervisor.set_telemetry_decimation(TELEMETRY_DECIMATION);
    let config = HostLinkConfig {
        period_s: scenario.plant.period_s,
        heartbeat_timeout_s,
    };
    let settings = ArrowSettings::of(
        &scenario.parallel,
        &scenario.turntable,
        scenario.feedforward,
    );
    let mut link =
        HostLink::new(&config, settings, (), &jobs).map_err(|_| ArrowError::NotFinite)?;
    // Ready at power-up: ARROW's calibration is empty. One command a period (the queue
    // holds one job-sized command), the link told of the modes.
    let inputs = ArrowInputs {
        joints_m: reading.joints_m,
        table_rad: reading.turntable_rad,
        drive_fault: None,
    };
    let mut from_machine = from_machine;
    for command in [Command::Calibrate, Command::FinishCalibration(())] {
        if to_machine.enqueue(command).is_err() {
            return Err(ArrowError::NotFinite);
        }
        supervisor.step(&inputs);
        while let Some(report) = from_machine.dequeue() {
            link.report(&report, &mut |_| true);
        }
    }
    let mut arrow = LinkedArrow {
        supervisor,
        plant,
        reading,
        link,
        commands: to_machine,
        reports: from_machine,
        now_s: 0.0,
    };
    Ok(f(&mut arrow))
}
