//! Remote machining end to end (T ch. 5, 8.3): two machine images — the master
//! (`RemoteMaster` on the horizontal master plant, its encoders, an operator's hand)
//! and the slave (`RemoteSlave` on the realistic Keops plant with imperfect Hall
//! sensors it calibrates itself) — each under its own supervisor, exchanging SDCT
//! frames only through two `hal_mock::link::FrameEnd`s. Nothing else passes between
//! them: the scenario reads each plant's true state only to measure.
//!
//! The operator: a hand that pushes the master's effector along the fixture's contour
//! towards a speed that varies along it (a damper of `HAND_N_S_PER_M` to the wanted
//! speed), a steady push across it with a 2 N step inside a window (the fixture's
//! stiffness), 0.3 N of tremor at 8.7 and 11.3 Hz in the plane, 0.5 N down.

use hal_mock::delta_plant::DeltaPlantParams;
use hal_mock::link::{FrameEnd, LinkConfig};
use hal_mock::master::SimulatedMaster;
use heapless::spsc::Queue;
use kerf::app::jobs::{JobSlot, JobSlots};
use kerf::app::remote_link::MasterLink;
use kerf::app::stream::MAX_FRAME_LEN;
use kerf::app::supervisor::{Command, Machine, Mode, Report, Supervisor};
use kerf::codec::sdct::{SdctConfig, Selection};
use kerf::control::bilateral::BilateralConfig;
use kerf::control::constraint::FixtureConfig;
use kerf::control::dob::DobConfig;
use kerf::control::laser::LaserMode;
use kerf::control::preview::PreviewConfig;
use kerf::hal::{FrameLink, LinkBusy};
use kerf::kinematics::delta::{DeltaConfig, DeltaGeometry};
use kerf::kinematics::Vector3;
use kerf::machines::delta_slave::remote::{FollowJob, FollowPhase, RemoteSlave, RemoteSlaveConfig};
use kerf::machines::remote_master::{
    FixtureJob, HapticConfig, RemoteMaster, RemoteMasterConfig, RemoteMasterInputs, SlaveEstimate,
};
use kerf::sensing::encoder::EncoderConfig;
use kerf::sensing::velocity::TrackingObserverConfig;
use kerf::trajectory::constraint::ConstraintConfig;
use kerf::trajectory::shapes::ellipse;
use kerf_sim::operator::Operator;
use kerf_sim::remote::{
    keops_site, RecordingHeader, RecordingWriter, SlaveSite, SlaveSiteConfig, BLOCK,
};
use std::f64::consts::PI;

/// Control period of both machines, s.
pub const TS: f64 = 1e-4;
/// Control periods per link sample (1 kHz samples).
pub const D: u32 = 10;
/// Samples per SDCT block.
pub const N: usize = BLOCK;
/// The master's carriages at power-up (its homing stops), m.
pub const MASTER_HOME_M: [f64; 3] = [0.07; 3];
/// Contour points.
const POINTS: usize = 128;
/// The master's contour: an ellipse of these semi-axes, m.
pub const CONTOUR_SEMI_AXES_M: [f64; 2] = [0.015, 0.011];
/// The hand's damping towards its wanted speed, N·s/m.
pub const HAND_N_S_PER_M: f64 = 30.0;
/// The operator's mean speed along the master's contour, m/s.
pub const OPERATOR_SPEED_M_S: f64 = 0.010;
/// Beam power of the constant-power mode, W; the constant-energy mode cuts the depth
/// this power cuts at the slave's mean speed.
pub const LASER_POWER_W: f64 = 5.0;

/// The link between the sites.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Network {
    /// Mean one-way delay, ms.
    pub delay_ms: u32,
    /// ± this much, uniform, ms.
    pub jitter_ms: u32,
    /// Frame loss probability.
    pub loss: f64,
}

impl Network {
    /// The simulated link on a clock of control periods (0.1 ms): the delay uniform in
    /// [delay − jitter, delay + jitter], one stream in order (a frame overtaken by a
    /// later one would be dropped by the receiver as late).
    pub fn link_config(&self, seed: u64) -> LinkConfig {
        let ticks = |ms: u32| ms * 10;
        LinkConfig {
            delay_ticks: ticks(self.delay_ms.saturating_sub(self.jitter_ms)),
            random_delay_ticks: ticks(2 * self.jitter_ms),
            jitter_ticks: 0.0,
            loss_probability: self.loss,
            reorder: false,
            seed,
        }
    }
}

/// Faults injected on the master → slave link or the master.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Faults {
    /// From this time on (s after the master's start) nothing gets through.
    pub silence_from_s: Option<f64>,
    /// At this time the frame sent is sent again 50 ms later (a replay), and the
    /// next one is corrupted (one byte flipped).
    pub replay_and_corrupt_at_s: Option<f64>,
    /// At this time the master image restarts (a power cycle: new machine, new link
    /// end, new session; the operator's hand keeps going).
    pub master_restart_at_s: Option<f64>,
    /// From this time on a second master (another session) sends the slave a steady
    /// 1 m/s² along x on the same network, a command every link sample.
    pub second_master_from_s: Option<f64>,
}

/// One scenario.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct RemoteCase {
    /// Slave displacement per master displacement.
    pub scale: f64,
    /// The link.
    pub network: Network,
    /// What the master's law closes on: kerf's delay observer, T's network
    /// disturbance observer or the newest report.
    pub estimate: SlaveEstimate,
    /// The haptic speed band on.
    pub haptic: bool,
    /// The slave's beam.
    pub laser: LaserMode,
    /// SDCT coefficients kept of N.
    pub m: usize,
    /// Seconds of the master's job.
    pub seconds: f64,
    /// (from, to, N): an extra push across the contour, outwards.
    pub push_window: Option<(f64, f64, f64)>,
    /// Faults.
    pub faults: Faults,
    /// The slave's plant.
    pub slave_plant: DeltaPlantParams,
    /// The tracking law's poles, Hz.
    pub tracking_hz: f64,
    /// The delay observer's correction, Hz.
    pub observer_hz: f64,
    /// Every link sample in its own uncoded frame both ways (`remote_link::raw`): no
    /// block latency, four times the bytes.
    pub raw_samples: bool,
    /// Times the master sends each command frame (`MasterLink::with_copies`); the
    /// slave's playout margin holds a block period more when it is above 1.
    pub command_copies: usize,
}

impl RemoteCase {
    /// 20 ± 10 ms, the observer on, scale 0.5, constant power, m = 6, 10 s, a 2 N push
    /// from 3 to 4 s.
    pub fn nominal() -> Self {
        Self {
            scale: 0.5,
            network: Network {
                delay_ms: 20,
                jitter_ms: 10,
                loss: 0.0,
            },
            estimate: SlaveEstimate::EchoedTicks,
            haptic: false,
            laser: LaserMode::ConstantPower {
                power_w: LASER_POWER_W,
            },
            m: 6,
            seconds: 10.0,
            push_window: Some((3.0, 4.0, 2.0)),
            faults: Faults::default(),
            slave_plant: DeltaPlantParams::SLAVE_REALISTIC,
            tracking_hz: 15.0,
            observer_hz: 5.0,
            command_copies: 1,
            raw_samples: false,
        }
    }
}

/// One period as measured on the plants (after the slave's job started).
#[derive(Copy, Clone, Debug, Default)]
pub struct RemoteSample {
    /// Time since the master's start, s.
    pub t_s: f64,
    /// The master's true effector, m.
    pub master_m: [f64; 3],
    /// Its distance across the contour (outwards positive), m.
    pub master_across_m: f64,
    /// Its speed along the contour, m/s.
    pub master_speed_m_s: f64,
    /// The operator's push across the contour, N.
    pub push_across_n: f64,
    /// The operator's hand along the contour (towards the wanted speed), N.
    pub hand_along_n: f64,
    /// The haptic force the master rendered, N.
    pub haptic_n: f64,
    /// The slave's true effector, m.
    pub slave_m: [f64; 3],
    /// The scaled master at the tick the slave executes (`None` before the first).
    pub slave_reference_m: Option<[f64; 3]>,
    /// The slave's speed in the plane, m/s.
    pub slave_speed_m_s: f64,
    /// The beam's power, W.
    pub laser_w: f64,
    /// Periods between the master computing the command the slave executes and the
    /// slave executing it.
    pub latency_periods: Option<u64>,
}

/// What a run did.
#[derive(Clone, Debug)]
pub struct RemoteRun {
    /// Every period from the master's start.
    pub samples: Vec<RemoteSample>,
    /// Frame bytes per second, master → slave and back.
    pub bytes_per_s: [f64; 2],
    /// Frames lost on the links.
    pub lost_frames: u64,
    /// Command frames the slave refused as bad (corrupt, cut).
    pub refused_frames: u32,
    /// Command frames of blocks the slave had taken (copies, replays), dropped.
    pub repeated_frames: u32,
    /// Master restarts the slave saw.
    pub restarts: u32,
    /// Frames of another master's session the slave dropped.
    pub foreign_frames: u32,
    /// Modes at the end.
    pub slave_mode: Mode<kerf::machines::delta_slave::remote::RemoteSlaveFault>,
    /// The master's.
    pub master_mode: Mode<kerf::machines::remote_master::RemoteMasterFault>,
    /// The slave's centre of the mapping, m.
    pub slave_centre_m: [f64; 3],
    /// The master's centre of the mapping, m.
    pub master_centre_m: [f64; 3],
    /// The contour the master follows (x, y), m.
    pub contour_m: Vec<[f64; 2]>,
    /// What reached the slave (`kerf_sim::remote::Recording`), tracking counted from
    /// [`RECORDING_MEASURE_FROM_S`].
    pub recording: Vec<u8>,
}

/// Where a recording's tracking summary starts, s after the master's start: where the
/// scenario's own tracking figures start (past the start from rest).
pub const RECORDING_MEASURE_FROM_S: f64 = 2.0;

impl RemoteRun {
    /// |slave − scaled master| over samples with `t_s ≥ from_s`: (max, RMS), m;
    /// `None` if the slave never followed.
    pub fn tracking_m(&self, from_s: f64) -> Option<(f64, f64)> {
        let errors: Vec<f64> = self
            .samples
            .iter()
            .filter(|s| s.t_s >= from_s)
            .filter_map(|s| {
                let r = s.slave_reference_m?;
                Some((Vector3::from(r) - Vector3::from(s.slave_m)).norm())
            })
            .collect();
        if errors.is_empty() {
            return None;
        }
        let max = errors.iter().copied().fold(0.0, f64::max);
        let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
        Some((max, rms))
    }

    /// The tracking error of a run of `case` from `from_s` on, µm (max, RMS); a run that
    /// ended early (the mechanism ran away) or whose slave is not running at the end
    /// (a fault) is infinite.
    pub fn tracking_um(&self, case: &RemoteCase, from_s: f64) -> (f64, f64) {
        let complete = self.samples.len() as f64 * TS >= case.seconds - 2.0 * TS;
        match (complete, self.slave_mode, self.tracking_m(from_s)) {
            (true, Mode::Running, Some((max, rms))) => (max * 1e6, rms * 1e6),
            _ => (f64::INFINITY, f64::INFINITY),
        }
    }

    /// Mean latency from the master's command to the slave's execution over samples
    /// with `t_s ≥ from_s`, ms.
    pub fn latency_ms(&self, from_s: f64) -> Option<f64> {
        let l: Vec<f64> = self
            .samples
            .iter()
            .filter(|s| s.t_s >= from_s)
            .filter_map(|s| s.latency_periods)
            .map(|p| p as f64 * TS * 1e3)
            .collect();
        (!l.is_empty()).then(|| l.iter().sum::<f64>() / l.len() as f64)
    }
}

/// Why a run stopped early.
#[derive(Clone, Debug, PartialEq)]
pub enum RemoteError {
    /// Setup failed (a config, a plant, the slave's calibration).
    Setup(String),
}

/// A link end that counts bytes and can be silenced, replay and corrupt.
struct Wire {
    end: FrameEnd<MAX_FRAME_LEN, 256>,
    bytes: usize,
    silent: bool,
    corrupt_next: bool,
    replay: Option<(u64, Vec<u8>)>,
    capture_next: bool,
    now: u64,
}

impl Wire {
    fn new(network: &Network, seed: u64) -> Self {
        let end =
            FrameEnd::new(&network.link_config(seed)).unwrap_or_else(|e| panic!("link: {e:?}"));
        Self {
            end,
            bytes: 0,
            silent: false,
            corrupt_next: false,
            replay: None,
            capture_next: false,
            now: 0,
        }
    }

    fn set_now(&mut self, now: u64) {
        self.now = now;
        self.end.set_now(now);
        if let Some((_, frame)) = self.replay.take_if(|(at, _)| *at <= now) {
            let _ = self.end.send(&frame);
        }
    }
}

impl FrameLink for Wire {
    fn send(&mut self, frame: &[u8]) -> Result<(), LinkBusy> {
        self.bytes += frame.len();
        if self.silent {
            return Ok(());
        }
        if self.capture_next {
            self.capture_next = false;
            self.corrupt_next = true;
            self.replay = Some((self.now + 500, frame.to_vec()));
        } else if self.corrupt_next {
            self.corrupt_next = false;
            let mut bad = frame.to_vec();
            let middle = bad.len() / 2;
            bad[middle] ^= 0x5a;
            return self.end.send(&bad);
        }
        self.end.send(frame)
    }

    fn receive(&mut self, buf: &mut [u8]) -> Option<usize> {
        self.end.receive(buf)
    }
}

/// The command link as the slave's end reads it, every frame recorded with its
/// arrival period after the master's start.
struct Tap<'a> {
    wire: &'a mut Wire,
    recording: Option<(&'a mut RecordingWriter, u32)>,
}

impl FrameLink for Tap<'_> {
    fn send(&mut self, frame: &[u8]) -> Result<(), LinkBusy> {
        self.wire.send(frame)
    }

    fn receive(&mut self, buf: &mut [u8]) -> Option<usize> {
        let len = self.wire.receive(buf)?;
        if let (Some((writer, arrival)), Some(frame)) = (self.recording.as_mut(), buf.get(..len)) {
            writer.frame(*arrival, frame);
        }
        Some(len)
    }
}

/// The master's image: its supervisor over its own queues, its link end.
struct MasterImage {
    supervisor: Supervisor<'static, RemoteMaster<f64>>,
    link: MasterLink<N>,
}

impl MasterImage {
    fn new(
        config: &RemoteMasterConfig,
        sdct: &SdctConfig,
        session: u16,
        case: &RemoteCase,
        job: FixtureJob<f64>,
    ) -> Result<Self, RemoteError> {
        let machine = RemoteMaster::<f64>::new(config)
            .map_err(|e| RemoteError::Setup(format!("master: {e}")))?;
        let commands: &'static mut Queue<Command<RemoteMaster<f64>>, 8> =
            Box::leak(Box::new(Queue::new()));
        let reports: &'static mut Queue<Report<RemoteMaster<f64>>, 64> =
            Box::leak(Box::new(Queue::new()));
        let (mut to_machine, from_sender) = commands.split();
        let (to_sender, _) = reports.split();
        let jobs: &'static JobSlots<FixtureJob<f64>> =
            Box::leak(Box::new(JobSlots::new(job, FixtureJob::default())));
        let mut supervisor = Supervisor::new(machine, from_sender, to_sender, jobs);
        supervisor.set_telemetry_decimation(0);
        // Encoders need no sweep: the stored (empty) calibration, the job, start.
        for command in [
            Command::FinishCalibration(()),
            Command::LoadJob(JobSlot::First),
            Command::Start,
        ] {
            to_machine
                .enqueue(command)
                .map_err(|_| RemoteError::Setup("master queue".into()))?;
        }
        let link = MasterLink::new(sdct, session, TS * f64::from(D))
            .and_then(|l| l.with_copies(case.command_copies))
            .map(|l| {
                if case.raw_samples {
                    l.with_raw_samples()
                } else {
                    l
                }
            })
            .map_err(|e| RemoteError::Setup(format!("master link: {e}")))?;
        Ok(Self { supervisor, link })
    }
}

/// The master's configuration for `case`, with the mapping's centres.
pub fn master_config(case: &RemoteCase, cm: [f64; 3], cs: [f64; 3]) -> RemoteMasterConfig {
    let row = PreviewConfig {
        surface_slope_per_s: 2.0 * PI * 20.0,
        reaching_rate_per_s: 2.0 * PI * 40.0,
    };
    RemoteMasterConfig {
        period_s: TS,
        delta: DeltaConfig::MASTER_HORIZONTAL,
        encoders: [EncoderConfig::MASTER_0_5_UM; 3],
        home_m: MASTER_HOME_M,
        velocity: TrackingObserverConfig {
            bandwidth_rad_s: 2.0 * PI * 300.0,
        },
        dob: DobConfig {
            nominal_mass_kg: 0.335,
            bandwidth_rad_s: 2.0 * PI * 40.0,
            force_limit_n: 10.0,
            compensate: true,
        },
        fixture: FixtureConfig {
            normal: row,
            vertical: row,
        },
        constraint: ConstraintConfig::closed_contour(),
        tracking: BilateralConfig::critically_damped(
            case.scale,
            cm,
            cs,
            2.0 * PI * case.tracking_hz,
        ),
        observer_bandwidth_rad_s: 2.0 * PI * case.observer_hz,
        slave_estimate: case.estimate,
        samples_per_command: D,
        haptic: case.haptic.then_some(HapticConfig {
            speed_band_m_s: [0.0, 1.1 * OPERATOR_SPEED_M_S],
            gain_n_s_per_m: 200.0,
            max_force_n: 2.0,
        }),
    }
}

/// The contour and the hand's frame along it.
struct Contour {
    points: Vec<[f64; 2]>,
    length_m: f64,
    /// Arc length at each point.
    arc_m: Vec<f64>,
}

impl Contour {
    /// Nearest point: (arc length, unit tangent, outward normal, signed distance
    /// outwards).
    fn frame(&self, x: [f64; 2]) -> (f64, [f64; 2], [f64; 2], f64) {
        let n = self.points.len();
        let mut best = (f64::MAX, 0, 0.0);
        for i in 0..n {
            let (a, b) = (self.points[i], self.points[(i + 1) % n]);
            let d = [b[0] - a[0], b[1] - a[1]];
            let len2 = d[0] * d[0] + d[1] * d[1];
            let u = (((x[0] - a[0]) * d[0] + (x[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0);
            let p = [a[0] + u * d[0] - x[0], a[1] + u * d[1] - x[1]];
            let dist2 = p[0] * p[0] + p[1] * p[1];
            if dist2 < best.0 {
                best = (dist2, i, u);
            }
        }
        let (_, i, u) = best;
        let (a, b) = (self.points[i], self.points[(i + 1) % n]);
        let d = [b[0] - a[0], b[1] - a[1]];
        let len = d[0].hypot(d[1]);
        let t = [d[0] / len, d[1] / len];
        // Counter-clockwise contour: outwards is the tangent turned clockwise.
        let normal = [t[1], -t[0]];
        let across = (x[0] - a[0]) * normal[0] + (x[1] - a[1]) * normal[1];
        (self.arc_m[i] + u * len, t, normal, across)
    }
}

/// The operator's wanted speed at arc length `s` and time `t`: the mean ± 50 % twice
/// per lap, ramped in over the first half second.
pub fn wanted_speed_m_s(s: f64, length_m: f64, t: f64) -> f64 {
    let ramp = (t / 0.5).min(1.0);
    ramp * OPERATOR_SPEED_M_S * (1.0 + 0.5 * (4.0 * PI * s / length_m).sin())
}

/// Runs `case`.
pub fn run(case: &RemoteCase) -> Result<RemoteRun, RemoteError> {
    let setup = |what: &str| {
        let what = what.to_string();
        move |e: kerf::kinematics::delta::KinematicsError| {
            RemoteError::Setup(format!("{what}: {e:?}"))
        }
    };
    // The master's contour starts where its effector rests at power-up.
    let master_geometry = DeltaGeometry::<f64>::new(&DeltaConfig::MASTER_HORIZONTAL)
        .map_err(|e| RemoteError::Setup(e.to_string()))?;
    let home = master_geometry
        .forward(&Vector3::from(MASTER_HOME_M))
        .map_err(setup("master home"))?;
    let [a, b] = CONTOUR_SEMI_AXES_M;
    let shape: [[f64; 2]; POINTS] = ellipse(a, b);
    let points: Vec<[f64; 2]> = shape
        .iter()
        .map(|p| [p[0] - a + home.x, p[1] + home.y])
        .collect();
    let cm = [home.x - a, home.y, home.z];
    let mut arc_m = vec![0.0];
    for i in 1..=POINTS {
        let (p, q) = (points[i - 1], points[i % POINTS]);
        arc_m.push(arc_m[i - 1] + (q[0] - p[0]).hypot(q[1] - p[1]));
    }
    let contour = Contour {
        length_m: arc_m[POINTS],
        arc_m,
        points: points.clone(),
    };
    let job = FixtureJob::new(&points, &ConstraintConfig::closed_contour(), home.z, true)
        .map_err(|e| RemoteError::Setup(format!("fixture job: {e:?}")))?;

    // The slave: calibrated at its preset home; the mapping's centre is the middle of
    // its travel (every carriage at 20 mm), and its job approaches the master's start
    // mapped there.
    let slave_config = RemoteSlaveConfig::KEOPS;
    let slave_geometry = DeltaGeometry::<f64>::new(&slave_config.slave.delta)
        .map_err(|e| RemoteError::Setup(e.to_string()))?;
    let cs: [f64; 3] = slave_geometry
        .forward(&Vector3::new(0.02, 0.02, 0.02))
        .map_err(setup("slave centre"))?
        .into();
    let slave_start = [cs[0] + case.scale * a, cs[1], cs[2]];
    let master_config = master_config(case, cm, cs);
    let sdct = SdctConfig {
        m: case.m,
        selection: Selection::Largest,
    };

    // The jitter and a half, 0.5 ms, and a frame's period (a block's, or a sample's
    // when raw) for the copies of a frame.
    let copies_margin = match (case.command_copies > 1, case.raw_samples) {
        (false, _) => 0,
        (true, false) => D * N as u32,
        (true, true) => D,
    };
    let margin = case.network.jitter_ms * 10 * 3 / 2 + 5 + copies_margin;
    let site = SlaveSiteConfig {
        raw_samples: case.raw_samples,
        ..keops_site(case.slave_plant, case.m, D, margin)
    };
    let jobs = JobSlots::default();
    let mut slave_commands: Queue<Command<RemoteSlave<f64>>, 8> = Queue::new();
    let mut slave_reports: Queue<Report<RemoteSlave<f64>>, 64> = Queue::new();
    let (mut to_slave, slave_in) = slave_commands.split();
    let (slave_out, mut from_slave) = slave_reports.split();
    let mut slave = SlaveSite::<f64>::new(&site, slave_in, slave_out, &jobs)
        .map_err(|e| RemoteError::Setup(format!("slave: {e:?}")))?;
    let follow = FollowJob {
        start_m: slave_start,
        approach_s: 0.5,
        laser: Some(case.laser),
    };
    let mut operator =
        Operator::<RemoteSlave<f64>, 3>::new(slave_config.slave.joints.hall, None, follow);
    operator.start(&mut to_slave, &jobs);
    let periods = (case.seconds / TS) as u64;
    let mut recording = RecordingWriter::new(RecordingHeader {
        m: case.m as u8,
        samples_per_command: D as u16,
        margin_periods: margin,
        start_m: slave_start.map(|c| c as f32),
        laser_power_w: match case.laser {
            LaserMode::ConstantPower { power_w } => power_w as f32,
            _ => 0.0,
        },
        approach_s: follow.approach_s as f32,
        periods: periods as u32,
        measure_from: (RECORDING_MEASURE_FROM_S / TS) as u32,
    });

    let mut master_plant = SimulatedMaster::new(
        &DeltaConfig::MASTER_HORIZONTAL,
        DeltaPlantParams::MASTER,
        TS,
        MASTER_HOME_M,
        EncoderConfig::MASTER_0_5_UM.resolution_m,
        [12_345, 40_000, 65_000],
    )
    .map_err(setup("master plant"))?;
    let mut forward = Wire::new(&case.network, 1);
    let mut backward = Wire::new(&case.network, 2);

    // The slave calibrates and starts its follow job first (the master's hand waits).
    let mut now = 0u64;
    while slave.supervisor().machine().phase() != Some(FollowPhase::Waiting) {
        forward.set_now(now);
        backward.set_now(now);
        let mut tap = Tap {
            wire: &mut forward,
            recording: None,
        };
        slave
            .step(now as u32, &mut tap, &mut backward)
            .map_err(setup("slave plant"))?;
        operator.poll(&mut from_slave, &mut to_slave, &jobs);
        now += 1;
        if now > 200_000 {
            return Err(RemoteError::Setup(format!(
                "slave did not start: {:?}",
                operator.state()
            )));
        }
    }

    let mut master = MasterImage::new(&master_config, &sdct, 1, case, job.clone())?;
    let mut second_master = case
        .faults
        .second_master_from_s
        .map(|_| MasterLink::<N>::new(&sdct, 0x5EC0, TS * f64::from(D)))
        .transpose()
        .map_err(|e| RemoteError::Setup(format!("second master: {e}")))?;
    let mut samples = Vec::new();
    // Each command's tick: the scaled master then, and the period it was computed.
    let mut tick_reference: std::collections::HashMap<u32, ([f64; 3], u64)> = Default::default();
    let mut session = 1;
    for k in 0..periods {
        let t = k as f64 * TS;
        // Faults.
        if case.faults.silence_from_s.is_some_and(|at| t >= at) {
            forward.silent = true;
            backward.silent = true;
        }
        if case
            .faults
            .replay_and_corrupt_at_s
            .is_some_and(|at| (t - at).abs() < TS / 2.0)
        {
            forward.capture_next = true;
        }
        if case
            .faults
            .master_restart_at_s
            .is_some_and(|at| (t - at).abs() < TS / 2.0)
        {
            // A firmware reset: the carriages re-homed from absolute reference marks
            // (here, where the plant is), a new session; the hand keeps going.
            session += 1;
            let rehomed = RemoteMasterConfig {
                home_m: master_plant.plant.q_m.into(),
                ..master_config
            };
            master = MasterImage::new(&rehomed, &sdct, session, case, job.clone())?;
            tick_reference.clear();
        }
        // The operator's hand.
        let q = master_plant.plant.q_m;
        let x = master_geometry.forward(&q).map_err(setup("master plant"))?;
        let v = master_plant
            .plant
            .effector_velocity_m_s()
            .map_err(setup("master plant"))?;
        let (s, tangent, normal, across) = contour.frame([x.x, x.y]);
        let along = v.x * tangent[0] + v.y * tangent[1];
        let push = case
            .push_window
            .filter(|(from, to, _)| t >= *from && t < *to)
            .map_or(0.5, |(_, _, f)| 0.5 + f);
        let hand_along = HAND_N_S_PER_M * (wanted_speed_m_s(s, contour.length_m, t) - along);
        let tremor = 0.3 * ((2.0 * PI * 8.7 * t).sin() + (2.0 * PI * 11.3 * t).sin()) / 2.0;
        master_plant.plant.effector_force_n = Vector3::new(
            hand_along * tangent[0] + push * normal[0] + tremor,
            hand_along * tangent[1] + push * normal[1] + tremor * 0.7,
            -0.5,
        );

        // The master's period.
        forward.set_now(now);
        backward.set_now(now);
        let report = master.link.receive(&mut backward);
        let outputs = master.supervisor.step(&RemoteMasterInputs {
            encoder_counts: master_plant.counts(),
            report,
        });
        master_plant.step(outputs.force_n);
        if let Some((tick, _)) = outputs.command {
            let scaled = Vector3::from(cs) + (x - Vector3::from(cm)) * case.scale;
            tick_reference.insert(tick, (scaled.into(), now));
            // The recording holds the first session (a restarted master's ticks start
            // again).
            if session == 1 && !recording.reference(tick, scaled.map(|c| c as f32).into()) {
                return Err(RemoteError::Setup(format!("tick {tick} does not rise")));
            }
        }
        master.link.send(outputs.command, &mut forward);
        if let (Some(from), Some(second)) = (case.faults.second_master_from_s, &mut second_master) {
            if t >= from && k % u64::from(D) == 0 {
                let command = kerf::app::remote_link::RemoteCommand {
                    acceleration_m_s2: [1.0, 0.0, 0.0],
                    laser_on: true,
                };
                second.send(Some((k as u32, command)), &mut forward);
            }
        }

        // The slave's period.
        let mut tap = Tap {
            wire: &mut forward,
            recording: Some((&mut recording, k as u32)),
        };
        let slave_out = slave.step(now as u32, &mut tap, &mut backward);
        operator.poll(&mut from_slave, &mut to_slave, &jobs);
        let (Ok(slave_out), None) = (slave_out, master_plant.error) else {
            // The mechanism ran away (a loop that diverged): the run ends here.
            break;
        };
        let executed = slave
            .link()
            .executing()
            .and_then(|tick| tick_reference.get(&tick).copied());
        let slave_plant = &slave.plant().plant;
        let p = slave_plant.effector_m().map_err(setup("slave plant"))?;
        let pv = slave_plant
            .effector_velocity_m_s()
            .map_err(setup("slave plant"))?;
        samples.push(RemoteSample {
            t_s: t,
            master_m: x.into(),
            master_across_m: across,
            master_speed_m_s: along,
            push_across_n: push,
            hand_along_n: hand_along,
            haptic_n: master.supervisor.machine().telemetry().haptic_n,
            slave_m: p.into(),
            slave_reference_m: executed.map(|(r, _)| r),
            latency_periods: executed.map(|(_, sent)| now - sent),
            slave_speed_m_s: pv.x.hypot(pv.y),
            laser_w: slave_out.laser_duty * slave_config.slave.laser.max_power_w,
        });
        now += 1;
    }
    let seconds = samples.len() as f64 * TS;
    Ok(RemoteRun {
        samples,
        bytes_per_s: [
            forward.bytes as f64 / seconds,
            backward.bytes as f64 / seconds,
        ],
        lost_frames: forward.end.link.lost() + backward.end.link.lost(),
        refused_frames: slave.link().refused(),
        repeated_frames: slave.link().repeats(),
        restarts: slave.link().restarts(),
        foreign_frames: slave.link().foreign(),
        slave_mode: slave.supervisor().mode(),
        master_mode: master.supervisor.mode(),
        slave_centre_m: cs,
        master_centre_m: cm,
        contour_m: points,
        recording: recording.finish(),
    })
}
