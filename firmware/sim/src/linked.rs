//! The Keops slave behind the host link: the simulated slave ([`crate::slave`]) with
//! its supervisor's commands coming from [`HostLink`] instead of an operator, so a
//! host (a test's, or the host tool over the QEMU image's serial port) drives it with
//! frames alone. The machine is switched on with its carriages at rest on their end
//! stops, where they stand unpowered, and homes there; the board's own task installs
//! the nominal Hall decoders as a stored calibration at power-up; everything after
//! comes from the host.

use crate::slave::{rest_unpowered, SlaveError, SlavePeriod, SlaveRig, SlaveScenario};
use heapless::spsc::{Consumer, Producer, Queue};
use kerf::app::host_link::{HostLink, HostLinkConfig};
use kerf::app::jobs::JobSlots;
use kerf::app::supervisor::{Command, Report};
use kerf::machines::delta_slave::link::SlaveSettings;
use kerf::machines::delta_slave::product::{
    contour_defaults, nominal_calibration, LINK_JOB_BYTES, TELEMETRY_DECIMATION,
};
use kerf::machines::delta_slave::DeltaSlave;
use kerf::scalar::Float;

/// Longest the carriages may take to come to rest, unpowered, before the machine is
/// switched on, s (the Keops slave's slide from its home takes about 0.1 s).
const POWER_UP_REST_S: f64 = 1.0;

/// The link's heartbeat timeout in these scenarios, s.
pub const HEARTBEAT_TIMEOUT_S: f64 = 0.05;

/// The slave, its plant and its host link.
pub struct LinkedSlave<'q, T: Float> {
    rig: SlaveRig<'q, T>,
    link: HostLink<'q, DeltaSlave<T>, LINK_JOB_BYTES>,
    commands: Producer<'q, Command<DeltaSlave<T>>>,
    reports: Consumer<'q, Report<DeltaSlave<T>>>,
    now_s: f64,
    period_s: f64,
}

impl<'q, T: Float> LinkedSlave<'q, T> {
    /// The host link: to attach the machine's settings store
    /// ([`HostLink::attach_store`]) before the first period.
    pub fn link_mut(&mut self) -> &mut HostLink<'q, DeltaSlave<T>, LINK_JOB_BYTES> {
        &mut self.link
    }

    /// One control period: the host's bytes of the period read first, then the
    /// period, then the reports answered and forwarded through `to_host` and the
    /// heartbeat checked.
    pub fn period(
        &mut self,
        from_host: &[u8],
        to_host: &mut dyn FnMut(&[u8]) -> bool,
    ) -> Result<SlavePeriod, SlaveError> {
        for &b in from_host {
            self.link
                .receive(b, self.now_s, &mut self.commands, &mut *to_host);
        }
        let period = self.rig.step()?;
        while let Some(report) = self.reports.dequeue() {
            self.link.report(&report, &mut *to_host);
        }
        self.now_s += self.period_s;
        self.link
            .tick(self.now_s, &mut self.commands, &mut *to_host);
        Ok(period)
    }

    /// The simulated slave.
    pub fn rig(&self) -> &SlaveRig<'q, T> {
        &self.rig
    }

    /// The link.
    pub fn link(&self) -> &HostLink<'q, DeltaSlave<T>, LINK_JOB_BYTES> {
        &self.link
    }
}

/// Builds the linked slave of `scenario` (nominal decoders installed, telemetry
/// reported as the product reports it for the link to decimate further, contours cut
/// for `laps` laps) and hands it to `f`.
pub fn with_linked_slave<T: Float, R>(
    scenario: &SlaveScenario,
    laps: f64,
    f: impl FnOnce(&mut LinkedSlave<'_, T>) -> R,
) -> Result<R, SlaveError> {
    let jobs = JobSlots::default();
    let mut commands = Queue::<Command<DeltaSlave<T>>, 4>::new();
    let mut reports = Queue::<Report<DeltaSlave<T>>, 64>::new();
    let (mut to_machine, from_sender) = commands.split();
    let (to_link, from_machine) = reports.split();
    // Switched on after standing: the carriages rest on their end stops, and the
    // Hall decoders, absolute within a pitch only, take that as home.
    let mut scenario = *scenario;
    scenario.machine.joints.home_m = rest_unpowered(&scenario, POWER_UP_REST_S)?;
    let scenario = &scenario;
    let mut rig = SlaveRig::<T>::new(scenario, from_sender, to_link, &jobs)?;
    rig.set_telemetry_decimation(TELEMETRY_DECIMATION);
    let machine = &scenario.machine;
    let stored = nominal_calibration::<T>(machine).map_err(SlaveError::Config)?;
    if to_machine
        .enqueue(Command::FinishCalibration(stored))
        .is_err()
    {
        return Err(SlaveError::Timeout);
    }
    let config = HostLinkConfig {
        period_s: machine.joints.period_s,
        heartbeat_timeout_s: HEARTBEAT_TIMEOUT_S,
    };
    let link = HostLink::new(
        &config,
        SlaveSettings::of(&machine.joints.axis),
        contour_defaults(machine, laps).into(),
        &jobs,
    )
    .map_err(SlaveError::Config)?;
    let mut slave = LinkedSlave {
        rig,
        link,
        commands: to_machine,
        reports: from_machine,
        now_s: 0.0,
        period_s: machine.joints.period_s,
    };
    Ok(f(&mut slave))
}
