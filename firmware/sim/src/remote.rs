//! Remote machining's slave site (T ch. 5, 8.3) as the host scenario and the QEMU image
//! both run it: the `RemoteSlave` machine under its supervisor on the simulated Keops
//! delta, with its end of the link ([`SlaveSite`]). The host scenario closes the loop
//! through a master image; the emulated MCU, which has room for one machine, replays
//! the command frames a host run recorded ([`replay`]).
//!
//! A recording ([`Recording`]) holds what reached the slave: each command frame as it
//! arrived (after the network's delay and loss) with its arrival period counted from
//! the master's start, and, for the tracking summary, the scaled master position of
//! every command tick. Replayed open loop — the reports go nowhere — the slave still
//! tracks as it did in the closed loop: the commands fix the nominal model it follows
//! (`app::remote_slave`), so only its own local loop differs between the two runs.
//!
//! Format, version 1, little-endian:
//!
//! ```text
//! "KRFR" version:u16 m:u8 block:u8 samples_per_command:u16 margin_periods:u32
//! start_m:[f32;3] laser_power_w:f32 approach_s:f32 periods:u32 measure_from:u32
//! ticks:u32 frames:u32
//! ticks × (tick:u32 [f32;3])           scaled master position per command tick, ticks rising, m
//! frames × (arrival:u32 len:u16 bytes) in arrival order
//! ```

use crate::operator::{Operator, OperatorError, OperatorState};
use crate::slave::{simulated_delta, SlaveScenario, SLAVE_COMMAND_CAPACITY, SLAVE_REPORT_CAPACITY};
use hal_mock::delta::SimulatedDelta;
use hal_mock::delta_plant::DeltaPlantParams;
use hal_mock::hall_sensor::HallSensorParams;
use heapless::spsc::{Consumer, Producer, Queue};
use kerf::app::remote_link::SlaveLink;
use kerf::app::remote_slave::{
    FollowJob, FollowPhase, RemoteSlave, RemoteSlaveConfig, RemoteSlaveFault, RemoteSlaveInputs,
};
use kerf::app::stream::MAX_FRAME_LEN;
use kerf::app::supervisor::{Command, Mode, Report, Supervisor};
use kerf::codec::sdct::{SdctConfig, Selection};
use kerf::control::laser::LaserMode;
use kerf::hal::{ForceAndLaser, FrameLink, LinkBusy, SampleInputs, WriteOutputs};
use kerf::kinematics::delta::KinematicsError;
use kerf::kinematics::Vector3;
use kerf::scalar::Float;
use kerf::ConfigError;

/// Link samples per SDCT block of the command and report streams.
pub const BLOCK: usize = 16;

/// Commands the slave's playout holds: 256 ms of 1 kHz samples, past any delay the
/// scenarios use.
pub const PLAYOUT_CAPACITY: usize = 256;

/// The slave's end of the link.
pub type SiteLink = SlaveLink<BLOCK, PLAYOUT_CAPACITY>;

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
    ) -> Result<Self, RemoteSimError> {
        let machine = RemoteSlave::<T>::new(&config.machine).map_err(RemoteSimError::Config)?;
        let mut supervisor = Supervisor::new(machine, commands, reports);
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

/// Magic of a recording.
pub const RECORDING_MAGIC: [u8; 4] = *b"KRFR";
/// The format version this module writes and reads.
pub const RECORDING_VERSION: u16 = 1;
/// Bytes of a recording's header.
pub const RECORDING_HEADER_LEN: usize = 50;
/// Bytes of one reference: the tick and the position.
const REFERENCE_LEN: usize = 16;

/// Why a recording was not read.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum RecordingError {
    /// It does not start with [`RECORDING_MAGIC`].
    Magic,
    /// Another format version.
    Version(u16),
    /// A block length other than [`BLOCK`].
    Block(u8),
    /// It ends inside the header, the references or frame `.0`.
    Truncated(u32),
    /// Frame `.0` is longer than a stream frame can be.
    FrameTooLong(u32),
    /// Frame `.0` arrived before the one before it.
    OutOfOrder(u32),
    /// Bytes follow the last frame.
    TrailingBytes,
    /// A reference's tick is not above the one before it.
    TicksNotRising,
}

/// What a recording's header says.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct RecordingHeader {
    /// SDCT coefficients kept per block (the report stream's coding).
    pub m: u8,
    /// Control periods per link sample.
    pub samples_per_command: u16,
    /// The playout's margin, periods.
    pub margin_periods: u32,
    /// Where the slave waits for the master (the master's start, scaled), m.
    pub start_m: [f32; 3],
    /// The beam's constant power, W.
    pub laser_power_w: f32,
    /// The slave's approach to `start_m`, s.
    pub approach_s: f32,
    /// Control periods recorded from the master's start.
    pub periods: u32,
    /// The period from which the tracking summary counts.
    pub measure_from: u32,
}

fn u16_at(bytes: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(bytes.get(at..at + 2)?.try_into().ok()?))
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?))
}

fn f32_at(bytes: &[u8], at: usize) -> Option<f32> {
    u32_at(bytes, at).map(f32::from_bits)
}

fn vector_at(bytes: &[u8], at: usize) -> Option<[f32; 3]> {
    Some([
        f32_at(bytes, at)?,
        f32_at(bytes, at + 4)?,
        f32_at(bytes, at + 8)?,
    ])
}

/// A validated recording, read in place.
#[derive(Copy, Clone, Debug)]
pub struct Recording<'a> {
    /// The header.
    pub header: RecordingHeader,
    references: &'a [u8],
    frames: &'a [u8],
    frame_count: u32,
}

impl<'a> Recording<'a> {
    /// Checks the header and walks every frame once.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, RecordingError> {
        let truncated = RecordingError::Truncated(0);
        if bytes.get(..4) != Some(&RECORDING_MAGIC[..]) {
            return Err(RecordingError::Magic);
        }
        let version = u16_at(bytes, 4).ok_or(truncated)?;
        if version != RECORDING_VERSION {
            return Err(RecordingError::Version(version));
        }
        let field = |at| u32_at(bytes, at).ok_or(truncated);
        let block = *bytes.get(7).ok_or(truncated)?;
        if usize::from(block) != BLOCK {
            return Err(RecordingError::Block(block));
        }
        let header = RecordingHeader {
            m: *bytes.get(6).ok_or(truncated)?,
            samples_per_command: u16_at(bytes, 8).ok_or(truncated)?,
            margin_periods: field(10)?,
            start_m: vector_at(bytes, 14).ok_or(truncated)?,
            laser_power_w: f32_at(bytes, 26).ok_or(truncated)?,
            approach_s: f32_at(bytes, 30).ok_or(truncated)?,
            periods: field(34)?,
            measure_from: field(38)?,
        };
        let (ticks, frame_count) = (field(42)?, field(46)?);
        let body = bytes.get(RECORDING_HEADER_LEN..).ok_or(truncated)?;
        let references_len = (ticks as usize)
            .checked_mul(REFERENCE_LEN)
            .ok_or(truncated)?;
        let (references, frames) = body.split_at_checked(references_len).ok_or(truncated)?;
        let recording = Self {
            header,
            references,
            frames,
            frame_count,
        };
        // The ticks rise (the lookup is a binary search).
        let mut previous = None;
        for tick in references
            .chunks_exact(REFERENCE_LEN)
            .filter_map(|r| u32_at(r, 0))
        {
            if previous.is_some_and(|p| tick <= p) {
                return Err(RecordingError::TicksNotRising);
            }
            previous = Some(tick);
        }
        // Every frame complete, in arrival order, nothing after the last.
        let mut cursor = 0;
        let mut last_arrival = 0;
        for i in 0..frame_count {
            let (arrival, frame, next) = recording
                .frame_at(cursor)
                .ok_or(RecordingError::Truncated(i))?;
            if frame.len() > MAX_FRAME_LEN {
                return Err(RecordingError::FrameTooLong(i));
            }
            if arrival < last_arrival {
                return Err(RecordingError::OutOfOrder(i));
            }
            last_arrival = arrival;
            cursor = next;
        }
        if cursor != frames.len() {
            return Err(RecordingError::TrailingBytes);
        }
        Ok(recording)
    }

    /// The frame at byte `at` of the frame section: (arrival, bytes, next offset).
    fn frame_at(&self, at: usize) -> Option<(u32, &'a [u8], usize)> {
        let arrival = u32_at(self.frames, at)?;
        let len = usize::from(u16_at(self.frames, at + 4)?);
        let frame = self.frames.get(at + 6..at + 6 + len)?;
        Some((arrival, frame, at + 6 + len))
    }

    /// The scaled master position of master tick `tick`, m (a binary search: the
    /// ticks rise).
    pub fn reference_m(&self, tick: u32) -> Option<[f32; 3]> {
        let (mut low, mut high) = (0, self.references.len() / REFERENCE_LEN);
        while low < high {
            let middle = low + (high - low) / 2;
            let at = middle * REFERENCE_LEN;
            match u32_at(self.references, at)?.cmp(&tick) {
                core::cmp::Ordering::Less => low = middle + 1,
                core::cmp::Ordering::Greater => high = middle,
                core::cmp::Ordering::Equal => return vector_at(self.references, at + 4),
            }
        }
        None
    }

    /// Command frames recorded.
    pub fn frame_count(&self) -> u32 {
        self.frame_count
    }
}

/// The recorded command stream as the slave's link: each frame arrives at its
/// recorded period; nothing can be sent back.
pub struct ReplayLink<'a> {
    recording: Recording<'a>,
    cursor: usize,
    /// Control periods since the master's start.
    pub now: u32,
    /// Frames delivered.
    pub delivered: u32,
}

impl<'a> ReplayLink<'a> {
    /// The link at the master's start.
    pub fn new(recording: Recording<'a>) -> Self {
        Self {
            recording,
            cursor: 0,
            now: 0,
            delivered: 0,
        }
    }
}

impl FrameLink for ReplayLink<'_> {
    fn send(&mut self, _frame: &[u8]) -> Result<(), LinkBusy> {
        Err(LinkBusy)
    }

    fn receive(&mut self, buf: &mut [u8]) -> Option<usize> {
        let (arrival, frame, next) = self.recording.frame_at(self.cursor)?;
        if arrival > self.now {
            return None;
        }
        self.cursor = next;
        self.delivered += 1;
        let into = buf.get_mut(..frame.len())?;
        into.copy_from_slice(frame);
        Some(frame.len())
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
        let h = &self.header;
        let mut out = std::vec::Vec::new();
        out.extend_from_slice(&RECORDING_MAGIC);
        out.extend_from_slice(&RECORDING_VERSION.to_le_bytes());
        out.push(h.m);
        out.push(BLOCK as u8);
        out.extend_from_slice(&h.samples_per_command.to_le_bytes());
        out.extend_from_slice(&h.margin_periods.to_le_bytes());
        for c in h.start_m {
            out.extend_from_slice(&c.to_le_bytes());
        }
        for v in [h.laser_power_w, h.approach_s] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in [h.periods, h.measure_from, self.ticks, self.frame_count] {
            out.extend_from_slice(&v.to_le_bytes());
        }
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
    let mut commands = Queue::<Command<RemoteSlave<T>>, SLAVE_COMMAND_CAPACITY>::new();
    let mut reports = Queue::<Report<RemoteSlave<T>>, SLAVE_REPORT_CAPACITY>::new();
    let (mut send, from_operator) = commands.split();
    let (to_operator, mut receive) = reports.split();
    let mut site = SlaveSite::<T>::new(&config, from_operator, to_operator)?;
    let hall = config.machine.slave.joints.hall;
    let job = FollowJob {
        start_m: header.start_m.map(f64::from),
        approach_s: f64::from(header.approach_s),
        laser: Some(LaserMode::ConstantPower {
            power_w: f64::from(header.laser_power_w),
        }),
    };
    let mut operator = Operator::<RemoteSlave<T>, 3>::new(hall, None, job);
    operator.start(&mut send);
    let mut link = ReplayLink::new(recording);
    // Calibration and approach: nothing arrives before the master starts.
    let mut now = 0u32;
    let period_s = config.machine.slave.joints.period_s;
    let approach_limit = ((f64::from(header.approach_s) + 2.0) / period_s) as u32;
    while site.supervisor().machine().phase() != Some(FollowPhase::Waiting) {
        site.step(now, &mut link, &mut ReportSink)
            .map_err(RemoteSimError::Plant)?;
        if let OperatorState::Failed(e) = operator.poll(&mut receive, &mut send) {
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
        let _ = operator.poll(&mut receive, &mut send);
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
        frames: link.delivered,
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
