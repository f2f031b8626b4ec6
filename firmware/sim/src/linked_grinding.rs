//! The grinding cell behind the host link: the simulated cell of `hal-mock` (piezo,
//! workpiece, grinding forces, G's noise) with its F/T sensor, its hexapod on
//! PI GCS and its spindle on the converter's frames, the cell's supervisor and the
//! device link's slower task, with commands coming from [`HostLink`] only, so a host
//! (a test's, or the host tool over the QEMU image's serial port) uploads a pass,
//! starts it, retunes the force law and follows it with frames alone.
//!
//! At power-up the hexapod is referenced and stands at X = 0, and the cell captures
//! its sensor's bias at rest and takes the sensor's eccentricity as stored (the
//! simulated sensor's true offset, as the eccentricity fit measures it), so it is
//! Ready for a pass. Every [`device_tick_periods`] control periods the slower task
//! sends the latest outputs to the devices and checks their replies; a fault it finds
//! reaches the next control period, which faults the cell, and is cleared when the
//! cell accepts `ResetFault`. The hexapod's real motion carries the workpiece past the
//! tool. [`LinkedGrinding::hexapod_mut`] and [`LinkedGrinding::spindle_mut`] reach the
//! simulated devices to break them (a command the controller refuses, a converter
//! that stops answering).

use hal_mock::grinding_cell::{Cell, CellConfig, CellReading};
use hal_mock::hexapod::{HexapodLimits, SimHexapod, REFERENCE_TIME_S};
use hal_mock::spindle::SimSpindle;
use heapless::spsc::{Consumer, Producer, Queue};
use kerf::app::host_link::{HostLink, HostLinkConfig};
use kerf::app::jobs::JobSlots;
use kerf::app::supervisor::{Command, CommandKind, Mode, Report, Supervisor};
use kerf::control::adrc::FalPower;
use kerf::error::ConfigError;
use kerf::hal::{LinkError, Transact};
use kerf::machines::grinding::devices::{DeviceDemand, DeviceFault, DeviceLink, DeviceLinkState};
use kerf::machines::grinding::link::GrindingSettings;
use kerf::machines::grinding::product::{
    device_tick_periods, Cell as GrindingCell, CONFIG, DEVICES, LINK_JOB_BYTES, PASS, PERIOD_S,
    TELEMETRY_DECIMATION,
};
use kerf::machines::grinding::{GrindingCalibration, GrindingInputs, GrindingOutputs};
use kerf::scalar::{Float, Real};
use kerf::sensing::force::Eccentricity;
use nalgebra::{Matrix6, Vector6};

/// The cell's pass in G-code (0.5 mm along X at 0.1 mm/s, the spindle at 25,000 rpm),
/// as the host tests and scripts/smoke upload it.
pub const PASS_GCODE: &str = include_str!("../../../data/grinding_pass.gcode");

/// Samples of the workpiece (5 µm apart over 15 mm: the tool's 4 mm and a pass of
/// several mm).
pub const SAMPLES: usize = 3000;

/// Sample spacing, m.
pub const DX_M: f64 = 5e-6;

/// The sensor's bias, V (what the capture at rest finds).
pub const BIAS_V: [f64; 6] = [0.12, -0.31, 0.05, 0.22, -0.08, 0.17];

/// Longest the calibration at power-up may take, control periods (the capture takes
/// [`CONFIG`]'s 500).
const CALIBRATION_PERIODS: u32 = 2_000;

/// The hexapod's end of its serial link.
struct HexapodPort<'a>(&'a mut SimHexapod);

impl Transact for HexapodPort<'_> {
    fn transact(&mut self, request: &[u8], reply: &mut [u8]) -> Result<usize, LinkError> {
        Ok(self.0.handle(request, reply))
    }
}

/// The converter's end: nothing when it does not answer.
struct SpindlePort<'a>(&'a mut SimSpindle);

impl Transact for SpindlePort<'_> {
    fn transact(&mut self, request: &[u8], reply: &mut [u8]) -> Result<usize, LinkError> {
        match (self.0.transact(request), reply.get_mut(..3)) {
            (Some(bytes), Some(slot)) => {
                slot.copy_from_slice(&bytes);
                Ok(3)
            }
            _ => Ok(0),
        }
    }
}

/// The cell, its simulated process and devices, and its host link.
pub struct LinkedGrinding<'q, T: Float + FalPower> {
    supervisor: Supervisor<'q, GrindingCell<T>>,
    cell: Cell<SAMPLES>,
    cell_config: CellConfig,
    reading: CellReading,
    /// Gauge volts per unit of wrench (the sensor's calibration inverted).
    volts_per_wrench: Matrix6<f64>,
    hexapod: SimHexapod,
    spindle: SimSpindle,
    devices: DeviceLink,
    device_state: DeviceLinkState,
    tick_periods: u64,
    link: HostLink<'q, GrindingCell<T>, LINK_JOB_BYTES>,
    commands: Producer<'q, Command<GrindingCell<T>>>,
    reports: Consumer<'q, Report<GrindingCell<T>>>,
    period: u64,
    now_s: f64,
}

impl<'q, T: Float + FalPower> LinkedGrinding<'q, T> {
    /// The host link: to attach the machine's settings store
    /// ([`HostLink::attach_store`]) before the first period.
    pub fn link_mut(&mut self) -> &mut HostLink<'q, GrindingCell<T>, LINK_JOB_BYTES> {
        &mut self.link
    }

    /// The sensor's gauge voltages for the present reading.
    fn raw_v(&self) -> [T; 6] {
        let raw = self.volts_per_wrench * Vector6::from(self.reading.wrench);
        core::array::from_fn(|k| {
            let bias = BIAS_V.get(k).copied().unwrap_or(0.0);
            <T as Real>::from_f64(raw.get(k).copied().unwrap_or(0.0) + bias)
        })
    }

    /// One control period: the host's bytes read, the period run, the devices' tick
    /// (every [`device_tick_periods`]), the process moved, the reports answered and
    /// forwarded through `to_host`, the heartbeat checked. Returns the outputs written.
    pub fn period(
        &mut self,
        from_host: &[u8],
        to_host: &mut dyn FnMut(&[u8]) -> bool,
    ) -> GrindingOutputs<T> {
        for &b in from_host {
            self.link
                .receive(b, self.now_s, &mut self.commands, &mut *to_host);
        }
        let inputs = GrindingInputs {
            ft_raw_v: self.raw_v(),
            device_fault: self.device_state.fault(),
        };
        let outputs = self.supervisor.step(&inputs);
        while let Some(report) = self.reports.dequeue() {
            if matches!(report, Report::Accepted(CommandKind::ResetFault)) {
                // The slower task leaves the devices' fault with the cell's.
                self.device_state.reset();
            }
            self.link.report(&report, &mut *to_host);
        }
        if self.period % self.tick_periods == 0 {
            let halt = matches!(self.supervisor.mode(), Mode::Fault(_));
            let demand = DeviceDemand::from_outputs(&outputs, halt);
            // A fault stays latched in the state, which the next period reads.
            let _ = self.devices.tick(
                &mut self.device_state,
                &demand,
                &mut HexapodPort(&mut self.hexapod),
                &mut SpindlePort(&mut self.spindle),
            );
        }
        // The process: the hexapod carries the workpiece past the tool at its real
        // speed, the spindle carries the cut's torque.
        let before_mm = self.hexapod.position()[0];
        self.hexapod.step(PERIOD_S);
        let feed_m_s = (self.hexapod.position()[0] - before_mm) * 1e-3 / PERIOD_S;
        self.reading = self.cell.step(outputs.piezo_m.to_f64(), feed_m_s);
        self.spindle.advance(
            PERIOD_S,
            self.reading.tangential_force_n * self.cell_config.tool_radius_m,
        );
        self.period += 1;
        self.now_s += PERIOD_S;
        self.link
            .tick(self.now_s, &mut self.commands, &mut *to_host);
        outputs
    }

    /// The supervisor.
    pub fn supervisor(&self) -> &Supervisor<'_, GrindingCell<T>> {
        &self.supervisor
    }

    /// The simulated process's last reading (the true forces among them).
    pub fn reading(&self) -> &CellReading {
        &self.reading
    }

    /// The simulated hexapod (its controller takes commands of its own, as from a
    /// second client: one it refuses sets the error the next ERR? reads).
    pub fn hexapod_mut(&mut self) -> &mut SimHexapod {
        &mut self.hexapod
    }

    /// The simulated spindle and converter (`answering = false`: a dead converter).
    pub fn spindle_mut(&mut self) -> &mut SimSpindle {
        &mut self.spindle
    }

    /// The device link's latched fault, if any.
    pub fn device_fault(&self) -> Option<DeviceFault> {
        self.device_state.fault()
    }
}

/// Builds the cell as flashed ([`CONFIG`], its settings, [`PASS`]) on G's
/// simulated cell ([`CellConfig::PUBLISHED`]) behind the link, calibrated and Ready (module
/// docs), and hands it to `f`. The link stops a job after `heartbeat_timeout_s` of
/// machine time without a frame from the host: a simulation that runs faster than
/// real time needs more than a board's.
///
/// Errors: a configuration the cell or the link refuses; a calibration that does not
/// end Ready.
pub fn with_linked_grinding<T: Float + FalPower, R>(
    heartbeat_timeout_s: f64,
    f: impl FnOnce(&mut LinkedGrinding<'_, T>) -> R,
) -> Result<R, ConfigError> {
    let jobs = JobSlots::default();
    let mut commands = Queue::<Command<GrindingCell<T>>, 4>::new();
    let mut reports = Queue::<Report<GrindingCell<T>>, 16>::new();
    let (to_machine, from_sender) = commands.split();
    let (to_link, from_machine) = reports.split();
    let machine = GrindingCell::<T>::new(&CONFIG)?;
    let mut supervisor = Supervisor::new(machine, from_sender, to_link, &jobs);
    supervisor.set_telemetry_decimation(TELEMETRY_DECIMATION);
    let config = HostLinkConfig {
        period_s: PERIOD_S,
        heartbeat_timeout_s,
    };
    let link = HostLink::new(&config, GrindingSettings::CELL, PASS, &jobs)?;
    let calibration = Matrix6::from_fn(|r, c| CONFIG.sensor.calibration[r][c]);
    let volts_per_wrench = calibration
        .try_inverse()
        .ok_or(ConfigError::out_of_range("sensor.calibration"))?;
    let cell_config = CellConfig::PUBLISHED;
    let mut cell = Cell::<SAMPLES>::new(&cell_config, 0.0, DX_M);
    let reading = cell.step(0.0, 0.0);
    // Referenced at power-up: FRF, and the reference move's time.
    let mut hexapod = SimHexapod::new(HexapodLimits::H824);
    let mut reply = [0u8; kerf::codec::gcs::MAX_REPLY_LEN];
    hexapod.handle(b"FRF\n", &mut reply);
    hexapod.step(REFERENCE_TIME_S + 0.01);
    let tick_periods = u64::from(device_tick_periods().max(1));
    let mut cell = LinkedGrinding {
        supervisor,
        cell,
        cell_config,
        reading,
        volts_per_wrench,
        hexapod,
        spindle: SimSpindle::new(),
        devices: DeviceLink::new(&DEVICES)?,
        device_state: DeviceLinkState::new(),
        tick_periods,
        link,
        commands: to_machine,
        reports: from_machine,
        period: 0,
        now_s: 0.0,
    };
    let not_ready = ConfigError::out_of_range("calibration");
    cell.commands
        .enqueue(Command::Calibrate)
        .map_err(|_| not_ready)?;
    let eccentricity = Eccentricity {
        dx_m: cell_config.sensor_offset_m[0],
        dy_m: cell_config.sensor_offset_m[1],
    };
    let mut finishing = false;
    for _ in 0..CALIBRATION_PERIODS {
        cell.period(&[], &mut |_| true);
        let mode = cell.supervisor.mode();
        if mode == Mode::Ready {
            return Ok(f(&mut cell));
        }
        if mode == Mode::Calibrating && cell.supervisor.machine().bias().is_some() && !finishing {
            let finish = Command::FinishCalibration(GrindingCalibration { eccentricity });
            finishing = cell.commands.enqueue(finish).is_ok();
        }
        if matches!(mode, Mode::Fault(_)) {
            break;
        }
    }
    Err(not_ready)
}
