//! Remote machining's slave site (T ch. 5, 8.3) as the host scenario and the QEMU image
//! both run it: the `RemoteSlave` machine under its supervisor on the simulated Keops
//! delta, with its end of the link ([`SlaveSite`]). The host scenario closes the loop
//! through a master image; the emulated MCU, which has room for one machine, replays
//! the command frames a host run recorded ([`replay`]).
//!
//! A recording ([`Recording`], its format and reader in
//! `kerf::machines::delta_slave::remote::recording`) holds what reached the slave: each command
//! frame as it arrived (after the network's delay and loss) with its arrival period
//! counted from the master's start, and, for the tracking summary, the scaled master
//! position of every command tick. Replayed open loop — the reports go nowhere — the
//! slave still tracks as it did in the closed loop: the commands fix the nominal model
//! it follows (`machines::delta_slave::remote`), so only its own local loop differs between the two
//! runs.

use crate::operator::{Operator, OperatorError, OperatorState};
use crate::slave::{simulated_delta, SlaveScenario, SLAVE_COMMAND_CAPACITY, SLAVE_REPORT_CAPACITY};
use hal_mock::delta::SimulatedDelta;
use hal_mock::delta_plant::DeltaPlantParams;
use hal_mock::hall_sensor::HallSensorParams;
use heapless::spsc::{Consumer, Producer, Queue};
use kerf::app::jobs::JobSlots;
use kerf::app::supervisor::{Command, Mode, Report, Supervisor};
use kerf::codec::sdct::{SdctConfig, Selection};
use kerf::control::laser::LaserMode;
use kerf::hal::{ForceAndLaser, FrameLink, LinkBusy, SampleInputs, WriteOutputs};
use kerf::kinematics::delta::KinematicsError;
use kerf::kinematics::Vector3;
use kerf::machines::delta_slave::remote::{
    FollowJob, FollowPhase, RemoteSlave, RemoteSlaveConfig, RemoteSlaveFault, RemoteSlaveInputs,
};
use kerf::scalar::Float;
use kerf::ConfigError;

pub use kerf::machines::delta_slave::remote::product::{
    SlaveEnd as SiteLink, BLOCK, PLAYOUT_CAPACITY,
};
pub use kerf::machines::delta_slave::remote::recording::{
    header_bytes, Recording, RecordingError, RecordingHeader, ReplayLink, RECORDING_HEADER_LEN,
    RECORDING_MAGIC, RECORDING_VERSION, REFERENCE_LEN,
};

/// The slave site: machine, plant, sensors and link settings.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SlaveSiteConfig {
    /// The machine.
    pub machine: RemoteSlaveConfig,
    /// The plant's masses, friction and drive.
    pub plant: DeltaPlantParams,
    /// Each carriage's Hall sensors.
    pub sensors: [HallSensorParams; 3],
    /// Noise seed (carriage k uses `seed + k`).
    pub seed: u64,
    /// RK4 steps of the plant per control period.
    pub substeps: u32,
    /// The report stream's coding (the command stream's is the master's).
    pub sdct: SdctConfig,
    /// Control periods per link sample.
    pub samples_per_command: u32,
    /// The playout's margin behind the first command's arrival, periods.
    pub margin_periods: u32,
    /// Every link sample in its own uncoded frame (`remote_link::raw`), both ways.
    pub raw_samples: bool,
}

/// Why a slave site could not run.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum RemoteSimError {
    /// A configuration was rejected.
    Config(ConfigError),
    /// The simulated mechanism left the region where it assembles.
    Plant(KinematicsError),
    /// The recording is not one this replay reads.
    Recording(RecordingError),
    /// The operator gave up (refused command, fault before the master started).
    Operator(OperatorError<RemoteSlaveFault>),
    /// The slave did not reach its waiting point in time.
    Timeout,
}

/// The remote slave machine and the simulated delta: what the control interrupt owns.
pub struct SlaveSite<'q, T: Float> {
    supervisor: Supervisor<'q, RemoteSlave<T>>,
    plant: SimulatedDelta,
    link: SiteLink,
}

impl<'q, T: Float> SlaveSite<'q, T> {
    /// The machine (config validated), the plant at rest at the machine's home, the
    /// link's end.
    pub fn new(
        config: &SlaveSiteConfig,
        commands: Consumer<'q, Command<RemoteSlave<T>>>,
        reports: Producer<'q, Report<RemoteSlave<T>>>,
        jobs: &'q JobSlots<<RemoteSlave<T> as kerf::app::supervisor::Machine>::Job>,
    ) -> Result<Self, RemoteSimError> {
        let machine = RemoteSlave::<T>::new(&config.machine).map_err(RemoteSimError::Config)?;
        let mut supervisor = Supervisor::new(machine, commands, reports, jobs);
        supervisor.set_telemetry_decimation(0);
        let slave = &config.machine.slave;
        let plant = simulated_delta(
            &slave.delta,
            config.plant,
            config.sensors,
            slave.joints.period_s,
            config.seed,
            slave.joints.home_m,
            config.substeps,
        )
        .map_err(RemoteSimError::Plant)?;
        let link = SiteLink::new(
            &config.sdct,
            config.samples_per_command,
            config.margin_periods,
        )
        .map_err(RemoteSimError::Config)?;
        let link = if config.raw_samples {
            link.with_raw_samples()
        } else {
            link
        };
        Ok(Self {
            supervisor,
            plant,
            link,
        })
    }

    /// One control period at local period `now`: the playout takes what arrived on
    /// `commands`, the machine runs on the Hall counts and the command playing, the
    /// plant advances, and every link sample the slave's position goes out on
    /// `reports`.
    pub fn step(
        &mut self,
        now: u32,
        commands: &mut impl FrameLink,
        reports: &mut impl FrameLink,
    ) -> Result<ForceAndLaser<T, 3>, KinematicsError> {
        let (command, fresh) = self.link.receive(now, commands);
        let inputs = RemoteSlaveInputs {
            hall: self.plant.sample(),
            command,
            fresh,
        };
        let outputs = self.supervisor.step(&inputs);
        self.plant.write(&outputs);
        if let Some(e) = self.plant.error {
            return Err(e);
        }
        let position = self
            .supervisor
            .machine()
            .report_position_m()
            .map(|p| p.map(|c| c.to_f64() as f32));
        self.link.report(position, reports);
        Ok(outputs)
    }

    /// The supervisor.
    pub fn supervisor(&self) -> &Supervisor<'q, RemoteSlave<T>> {
        &self.supervisor
    }

    /// The simulated delta.
    pub fn plant(&self) -> &SimulatedDelta {
        &self.plant
    }

    /// The link's end.
    pub fn link(&self) -> &SiteLink {
        &self.link
    }
}

/// Builds a recording (host side).
#[cfg(feature = "std")]
#[derive(Clone, Debug)]
pub struct RecordingWriter {
    header: RecordingHeader,
    references: std::vec::Vec<u8>,
    ticks: u32,
    last_tick: Option<u32>,
    frames: std::vec::Vec<u8>,
    frame_count: u32,
}

#[cfg(feature = "std")]
impl RecordingWriter {
    /// An empty recording with `header`.
    pub fn new(header: RecordingHeader) -> Self {
        Self {
            header,
            references: std::vec::Vec::new(),
            ticks: 0,
            last_tick: None,
            frames: std::vec::Vec::new(),
            frame_count: 0,
        }
    }

    /// The scaled master position of master tick `tick`: the ticks must rise
    /// (`false`, and nothing kept, when one does not).
    pub fn reference(&mut self, tick: u32, position_m: [f32; 3]) -> bool {
        if self.last_tick.is_some_and(|last| tick <= last) {
            return false;
        }
        self.last_tick = Some(tick);
        self.references.extend_from_slice(&tick.to_le_bytes());
        for c in position_m {
            self.references.extend_from_slice(&c.to_le_bytes());
        }
        self.ticks += 1;
        true
    }

    /// A command frame that reached the slave at period `arrival` after the master's
    /// start.
    pub fn frame(&mut self, arrival: u32, frame: &[u8]) {
        self.frames.extend_from_slice(&arrival.to_le_bytes());
        self.frames
            .extend_from_slice(&(frame.len() as u16).to_le_bytes());
        self.frames.extend_from_slice(frame);
        self.frame_count += 1;
    }

    /// The recording's bytes.
    pub fn finish(&self) -> std::vec::Vec<u8> {
        let mut out = header_bytes(&self.header, self.ticks, self.frame_count).to_vec();
        out.extend_from_slice(&self.references);
        out.extend_from_slice(&self.frames);
        out
    }
}

/// What a replay measured from the header's `measure_from` on.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ReplaySummary {
    /// Periods with a command playing and its reference known.
    pub periods: u32,
    /// Largest |slave − scaled master|, m.
    pub max_m: f64,
    /// RMS of it, m.
    pub rms_m: f64,
    /// Frames the recording delivered.
    pub frames: u32,
    /// Frames the slave's link refused.
    pub refused: u32,
    /// Commands that arrived after their play time (the playout re-anchored).
    pub late: u32,
    /// The slave's fault, if any.
    pub fault: Option<RemoteSlaveFault>,
}

/// The remote scenarios' slave site: the Keops slave on `plant` with the slave
/// scenarios' imperfect 16-bit Hall sensors (it calibrates them itself), 4 RK4 steps
/// per period, reports coded with `m` of [`BLOCK`] coefficients.
pub fn keops_site(
    plant: DeltaPlantParams,
    m: usize,
    samples_per_command: u32,
    margin_periods: u32,
) -> SlaveSiteConfig {
    SlaveSiteConfig {
        machine: RemoteSlaveConfig::KEOPS,
        plant,
        sensors: SlaveScenario::square().sensors,
        seed: 7,
        substeps: 4,
        sdct: SdctConfig {
            m,
            selection: Selection::Largest,
        },
        samples_per_command,
        margin_periods,
        raw_samples: false,
    }
}

/// Replays `recording` to the slave machine in scalar `T` on the site the host
/// scenario records with ([`keops_site`] on the realistic plant): the slave calibrates
/// its sensors, runs the header's follow job to its start, then the recorded periods
/// with the frames as they arrived; tracking measured against the recorded scaled
/// master. The slave's inputs are then what they were in the recorded run, so in f64
/// it repeats that run's slave.
pub fn replay<T: Float>(recording: &[u8]) -> Result<ReplaySummary, RemoteSimError> {
    let recording = Recording::parse(recording).map_err(RemoteSimError::Recording)?;
    let header = recording.header;
    let config = keops_site(
        DeltaPlantParams::SLAVE_REALISTIC,
        usize::from(header.m),
        u32::from(header.samples_per_command),
        header.margin_periods,
    );
    let jobs = JobSlots::default();
    let mut commands = Queue::<Command<RemoteSlave<T>>, SLAVE_COMMAND_CAPACITY>::new();
    let mut reports = Queue::<Report<RemoteSlave<T>>, SLAVE_REPORT_CAPACITY>::new();
    let (mut send, from_operator) = commands.split();
    let (to_operator, mut receive) = reports.split();
    let mut site = SlaveSite::<T>::new(&config, from_operator, to_operator, &jobs)?;
    let hall = config.machine.slave.joints.hall;
    let job = FollowJob {
        start_m: header.start_m.map(f64::from),
        approach_s: f64::from(header.approach_s),
        laser: Some(LaserMode::ConstantPower {
            power_w: f64::from(header.laser_power_w),
        }),
    };
    let mut operator = Operator::<RemoteSlave<T>, 3>::new(hall, None, job);
    operator.start(&mut send, &jobs);
    let mut link = ReplayLink::new(recording);
    // Calibration and approach: nothing arrives before the master starts.
    let mut now = 0u32;
    let period_s = config.machine.slave.joints.period_s;
    let approach_limit = ((f64::from(header.approach_s) + 2.0) / period_s) as u32;
    while site.supervisor().machine().phase() != Some(FollowPhase::Waiting) {
        site.step(now, &mut link, &mut ReportSink)
            .map_err(RemoteSimError::Plant)?;
        if let OperatorState::Failed(e) = operator.poll(&mut receive, &mut send, &jobs) {
            return Err(RemoteSimError::Operator(e));
        }
        now += 1;
        if now > approach_limit {
            return Err(RemoteSimError::Timeout);
        }
    }
    let (mut count, mut max_m, mut sum_sq_m2) = (0u32, 0.0f64, 0.0f64);
    let mut fault = None;
    for k in 0..header.periods {
        link.now = k;
        site.step(now.wrapping_add(k), &mut link, &mut ReportSink)
            .map_err(RemoteSimError::Plant)?;
        let _ = operator.poll(&mut receive, &mut send, &jobs);
        if let Mode::Fault(f) = site.supervisor().mode() {
            fault.get_or_insert(f);
        }
        let reference = site
            .link()
            .executing()
            .and_then(|tick| recording.reference_m(tick));
        if let (true, Some(r)) = (k >= header.measure_from, reference) {
            let p = site
                .plant()
                .plant
                .effector_m()
                .map_err(RemoteSimError::Plant)?;
            let error = (Vector3::from(r.map(f64::from)) - p).norm();
            count += 1;
            max_m = max_m.max(error);
            sum_sq_m2 += error * error;
        }
    }
    Ok(ReplaySummary {
        periods: count,
        max_m,
        rms_m: libm::sqrt(sum_sq_m2 / f64::from(count.max(1))),
        frames: link.delivered(),
        refused: site.link().refused(),
        late: site.link().late(),
        fault,
    })
}

/// Where the replayed slave's reports go: nowhere.
struct ReportSink;

impl FrameLink for ReportSink {
    fn send(&mut self, _frame: &[u8]) -> Result<(), LinkBusy> {
        Ok(())
    }

    fn receive(&mut self, _buf: &mut [u8]) -> Option<usize> {
        None
    }
}

/// Tracking bounds of the replay (max, RMS), m: the closed loop's figures on the
/// nominal case of the `remote_machining` host test (22–32 µm max, 9–11 µm RMS over
/// the delays and scales) with room for another noise draw.
pub const REPLAY_BOUNDS_M: (f64, f64) = (40e-6, 15e-6);

/// How far the f32 slave's replay figures may lie from the f64 slave's, m. Replayed
/// open loop, the slave has no master to correct it: whatever its f32 rounding (ulp of
/// 60 mm, 3.7 nm, on positions; the decoders' and loops' terms alike) moves it stays
/// in its tracking. Measured on the host: 1 nm on the maximum, 41 nm on the RMS; the
/// bound leaves a factor of about 7.
pub const REPLAY_F32_TOLERANCE_M: f64 = 300e-9;
