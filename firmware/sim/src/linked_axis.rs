//! The single axis behind the host link: the simulated LM1247 axis of
//! [`crate::scenario`] with its supervisor's commands coming from [`HostLink`] only, so
//! a host (a test's, or the host tool over the QEMU image's serial port) uploads
//! G-code moves, starts, retunes and follows them with frames alone. The board's own
//! task installs the nominal Hall decoder as a stored calibration at power-up (the
//! axis needs one before a job: a calibration run is the board's, not the link's);
//! everything after comes from the host.

use crate::scenario::{Period, Rig, Scenario};
use heapless::spsc::{Consumer, Producer, Queue};
use kerf::app::host_link::{HostLink, HostLinkConfig};
use kerf::app::jobs::JobSlots;
use kerf::app::supervisor::{Command, Report};
use kerf::machines::single_axis::link::AxisSettings;
use kerf::machines::single_axis::product::{
    nominal_calibration, Axis, LINK_JOB_BYTES, TELEMETRY_DECIMATION,
};
use kerf::{ConfigError, Real};

/// The moves of `data/axis_moves.gcode`, as the image and the host tests run them.
pub const AXIS_MOVES_GCODE: &str = include_str!("../../../data/axis_moves.gcode");

/// The axis, its plant and its host link.
pub struct LinkedAxis<'q, T: Real> {
    rig: Rig<'q, T>,
    link: HostLink<'q, Axis<T>, LINK_JOB_BYTES>,
    commands: Producer<'q, Command<Axis<T>>>,
    reports: Consumer<'q, Report<Axis<T>>>,
    now_s: f64,
    period_s: f64,
}

impl<'q, T: Real> LinkedAxis<'q, T> {
    /// The host link: to attach the machine's settings store
    /// ([`HostLink::attach_store`]) before the first period.
    pub fn link_mut(&mut self) -> &mut HostLink<'q, Axis<T>, LINK_JOB_BYTES> {
        &mut self.link
    }

    /// One control period: the host's bytes read, the period run, the reports
    /// answered and forwarded through `to_host`, the heartbeat checked.
    pub fn period(&mut self, from_host: &[u8], to_host: &mut dyn FnMut(&[u8]) -> bool) -> Period {
        for &b in from_host {
            self.link
                .receive(b, self.now_s, &mut self.commands, &mut *to_host);
        }
        let period = self.rig.step();
        while let Some(report) = self.reports.dequeue() {
            self.link.report(&report, &mut *to_host);
        }
        self.now_s += self.period_s;
        self.link
            .tick(self.now_s, &mut self.commands, &mut *to_host);
        period
    }

    /// The simulated axis and its supervisor.
    pub fn rig(&self) -> &Rig<'q, T> {
        &self.rig
    }

    /// The link.
    pub fn link(&self) -> &HostLink<'q, Axis<T>, LINK_JOB_BYTES> {
        &self.link
    }
}

/// Builds the axis of `scenario` (its machine, plant, sensors and any load step or
/// sensor fault, timed from the first job's start) behind the link, its nominal
/// decoder installed, and hands it to `f`. The link stops a job after
/// `heartbeat_timeout_s` of machine time without a frame from the host: a simulation
/// that runs faster than real time needs more than a board's.
///
/// Errors: a configuration that does not validate.
pub fn with_linked_axis<T: Real, R>(
    scenario: &Scenario,
    heartbeat_timeout_s: f64,
    f: impl FnOnce(&mut LinkedAxis<'_, T>) -> R,
) -> Result<R, ConfigError> {
    let jobs = JobSlots::default();
    let mut commands = Queue::<Command<Axis<T>>, 4>::new();
    let mut reports = Queue::<Report<Axis<T>>, 64>::new();
    let (mut to_machine, from_sender) = commands.split();
    let (to_link, from_machine) = reports.split();
    let mut rig = Rig::<T>::new(scenario, from_sender, to_link, &jobs)?;
    rig.set_telemetry_decimation(TELEMETRY_DECIMATION);
    let machine = &scenario.machine;
    let stored = nominal_calibration::<T>(machine)?;
    if to_machine
        .enqueue(Command::FinishCalibration(stored))
        .is_err()
    {
        return Err(ConfigError::out_of_range("commands"));
    }
    let config = HostLinkConfig {
        period_s: machine.period_s,
        heartbeat_timeout_s,
    };
    let link = HostLink::new(&config, AxisSettings::of(&machine.axis), *machine, &jobs)?;
    let mut axis = LinkedAxis {
        rig,
        link,
        commands: to_machine,
        reports: from_machine,
        now_s: 0.0,
        period_s: machine.period_s,
    };
    Ok(f(&mut axis))
}
