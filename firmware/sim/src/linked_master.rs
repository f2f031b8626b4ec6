//! The remote machining master behind the host link: the master as flashed
//! ([`kerf::machines::remote_master::product`]) on the simulated horizontal master delta
//! behind its 0.5 µm encoders (`hal_mock::master`), moved by an operator's hand, with
//! its end of the remote link to a slave site over a delayed network, and with its
//! supervisor's commands coming from [`HostLink`] only, so a host (a test's, or the
//! host tool over the QEMU image's serial port) uploads the fixture's contour,
//! starts it, retunes the fixture and follows the master and the slave it commands
//! with frames alone.
//!
//! The operator: a hand that, once the master runs a job, pushes the effector along
//! its drawing of the contour (the same points the host uploads: the person has the
//! drawing the fixture was made from) towards a speed that varies along it (a damper
//! of [`HAND_N_S_PER_M`] to the mean ± 50 % twice per lap, ramped in over half a
//! second), with a steady 0.5 N outwards across it, 0.3 N of tremor at 8.7 and
//! 11.3 Hz in the plane and 0.5 N down, as in the host's remote scenarios. While the
//! master does not run a job the hand holds the handle where it stands, carrying the
//! effector's weight (the master then puts out no force). After [`SESSION_LAPS`] of the
//! contour the operator presses the handle's stop button, which the image's own task
//! queues as the supervisor's `Stop` (the host hears the mode change; the session
//! ran to its end). A host's `Stop` ends it earlier.
//!
//! The slave site: the slave as its disturbance observer makes it (T eq. 93), the
//! nominal double integrator ẍs = u (the master's delay observer then corrects only
//! what the network's delay and jitter and the reports' SDCT coding leave), behind the slave's end of the remote link
//! ([`kerf::app::remote_link::SlaveLink`]: the playout, the reports); the network
//! delays each frame by [`DELAY_MS`] ± [`JITTER_MS`], in order; the master sends each
//! command frame [`COMMAND_COPIES`] times (against loss). The slave starts at
//! rest at the mapping's centre, where the master's rest point maps.
//!
//! The master is switched on at rest at its homing stops and takes its (empty)
//! encoder calibration at power-up: it is Ready for a job.

use hal_mock::delta_plant::DeltaPlantParams;
use hal_mock::link::{FrameEnd, LinkConfig};
use hal_mock::master::SimulatedMaster;
use heapless::spsc::{Consumer, Producer, Queue};
use kerf::app::host_link::{HostLink, HostLinkConfig};
use kerf::app::jobs::JobSlots;
use kerf::app::remote_link::{MasterLink, SlaveLink};
use kerf::app::stream::MAX_FRAME_LEN;
use kerf::app::supervisor::{Command, Mode, Report, Supervisor};
use kerf::codec::job::JobFile;
use kerf::codec::sdct::{SdctConfig, Selection};
use kerf::error::ConfigError;
use kerf::kinematics::delta::DeltaConfig;
use kerf::kinematics::Vector3;
use kerf::machines::remote_master::link::MasterSettings;
use kerf::machines::remote_master::product::{
    config, session, Master, BLOCK, COMMAND_COPIES, HOME_M, LINK_JOB_BYTES, PERIOD_S,
    SAMPLES_PER_COMMAND, TELEMETRY_DECIMATION,
};
use kerf::machines::remote_master::{RemoteMasterInputs, FIXTURE_POINTS};
use kerf::scalar::Float;
use kerf::sensing::encoder::EncoderConfig;

/// The product's sample contour as the job file the host uploads (written by the job
/// writer from `product::sample_contour`; host test `remote_master_link` checks it).
pub const SAMPLE_JOB: &[u8] = include_bytes!("../../../data/remote_master_fixture.krfj");

/// The hand's damping towards its wanted speed, N·s/m.
pub const HAND_N_S_PER_M: f64 = 30.0;

/// The operator's mean speed along the contour, m/s.
pub const OPERATOR_SPEED_M_S: f64 = 0.010;

/// The network's mean one-way delay, ms.
pub const DELAY_MS: u32 = 20;

/// ± this much, uniform, ms.
pub const JITTER_MS: u32 = 10;

/// Laps of the contour the operator follows before pressing the stop button.
pub const SESSION_LAPS: f64 = 1.0;

/// SDCT coefficients kept of each block of [`BLOCK`] samples, both ways.
pub const SDCT_M: usize = 6;

/// Segments either side of the last one the hand's search looks at.
const SEARCH_SEGMENTS: usize = 4;

/// The hand's grip on the handle while the fixture holds nothing: its stiffness, N/m,
/// and damping, N·s/m (a relaxed hand's).
const GRIP: (f64, f64) = (2000.0, 50.0);

/// Commands the slave's playout holds: 256 ms of 1 kHz samples, past the delay.
const PLAYOUT: usize = 256;

/// Frames in flight on each way of the network (three frames every 16 ms, the
/// command's and two copies, each at most 30 ms on the way).
const IN_FLIGHT: usize = 16;

/// Slots of the scaled master kept per command tick for the slave's tracking, by
/// tick modulo this: ticks count control periods, so 102.4 ms of them, past the
/// one-way delay and the playout's margin (61.5 ms at most).
const REFERENCES: usize = 1024;

/// Why the linked master could not be built.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum LinkedMasterError {
    /// A configuration was refused.
    Config(ConfigError),
    /// The drawing is not a points job file of at least two points.
    Drawing,
    /// The simulated master did not assemble at its home.
    Plant,
}

impl From<ConfigError> for LinkedMasterError {
    fn from(e: ConfigError) -> Self {
        Self::Config(e)
    }
}

/// The operator's drawing: the contour's points and the arc length at each.
struct Drawing {
    points: heapless::Vec<[f64; 2], FIXTURE_POINTS>,
    arc_m: heapless::Vec<f64, { FIXTURE_POINTS + 1 }>,
}

impl Drawing {
    /// The points of a points job file, closed.
    fn read(job: &[u8]) -> Result<Self, LinkedMasterError> {
        let file = JobFile::read(job).map_err(|_| LinkedMasterError::Drawing)?;
        let JobFile::Points { .. } = file else {
            return Err(LinkedMasterError::Drawing);
        };
        let mut points = heapless::Vec::new();
        for k in 0..file.count() {
            let p = file.point(k).ok_or(LinkedMasterError::Drawing)?;
            points
                .push(p.map(f64::from))
                .map_err(|_| LinkedMasterError::Drawing)?;
        }
        if points.len() < 2 {
            return Err(LinkedMasterError::Drawing);
        }
        let mut arc_m = heapless::Vec::new();
        let mut s = 0.0;
        for i in 0..=points.len() {
            if i > 0 {
                let (a, b) = (segment_start(&points, i - 1), segment_start(&points, i));
                s += libm::hypot(b[0] - a[0], b[1] - a[1]);
            }
            arc_m.push(s).map_err(|_| LinkedMasterError::Drawing)?;
        }
        Ok(Self { points, arc_m })
    }

    /// The lap's length, m.
    fn length_m(&self) -> f64 {
        self.arc_m.last().copied().unwrap_or(0.0)
    }

    /// The nearest point of the drawing to `x`: (arc length, unit tangent, outward
    /// normal, signed distance outwards, segment). With a `hint` (the segment found
    /// a period before) only the segments within [`SEARCH_SEGMENTS`] of it are
    /// searched: the hand moves far less than a segment in a period.
    fn frame(&self, x: [f64; 2], hint: Option<usize>) -> (f64, [f64; 2], [f64; 2], f64, usize) {
        let n = self.points.len();
        let (first, count) = match hint {
            Some(h) if n > 2 * SEARCH_SEGMENTS + 1 => {
                (h + n - SEARCH_SEGMENTS, 2 * SEARCH_SEGMENTS + 1)
            }
            _ => (0, n),
        };
        let mut best = (f64::MAX, 0, 0.0);
        for i in (first..first + count).map(|i| i % n.max(1)) {
            let (a, b) = (
                segment_start(&self.points, i),
                segment_start(&self.points, i + 1),
            );
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
        let (a, b) = (
            segment_start(&self.points, i),
            segment_start(&self.points, i + 1),
        );
        let d = [b[0] - a[0], b[1] - a[1]];
        let len = libm::hypot(d[0], d[1]);
        let t = [d[0] / len, d[1] / len];
        // Counter-clockwise contour: outwards is the tangent turned clockwise.
        let normal = [t[1], -t[0]];
        let across = (x[0] - a[0]) * normal[0] + (x[1] - a[1]) * normal[1];
        let s = self.arc_m.get(i).copied().unwrap_or(0.0) + u * len;
        (s, t, normal, across, i)
    }
}

/// Point `i` of the closed contour (wrapping).
fn segment_start(points: &[[f64; 2]], i: usize) -> [f64; 2] {
    points
        .get(i % points.len().max(1))
        .copied()
        .unwrap_or([0.0; 2])
}

/// The operator's wanted speed at arc length `s` of a lap of `length_m`, `t` after
/// the hand started: the mean ± 50 % twice per lap, ramped in over half a second.
pub fn wanted_speed_m_s(s: f64, length_m: f64, t: f64) -> f64 {
    let ramp = (t / 0.5).min(1.0);
    let phase = 4.0 * core::f64::consts::PI * s / length_m;
    ramp * OPERATOR_SPEED_M_S * (1.0 + 0.5 * libm::sin(phase))
}

/// The slave site: the nominal double integrator behind its link end.
struct NominalSlave {
    link: SlaveLink<BLOCK, PLAYOUT>,
    position_m: Vector3<f64>,
    velocity_m_s: Vector3<f64>,
}

/// The master, its plant and hand, the network, the slave site, and its host link.
pub struct LinkedMaster<'q, T: Float> {
    supervisor: Supervisor<'q, Master<T>>,
    plant: SimulatedMaster,
    drawing: Drawing,
    master_link: MasterLink<BLOCK>,
    forward: FrameEnd<MAX_FRAME_LEN, IN_FLIGHT>,
    backward: FrameEnd<MAX_FRAME_LEN, IN_FLIGHT>,
    slave: NominalSlave,
    /// (tick, scaled master) of each command sent, by tick modulo [`REFERENCES`].
    references: [(u32, [f64; 3]); REFERENCES],
    /// The mapping: master centre, slave centre, scale.
    mapping: ([f64; 3], [f64; 3], f64),
    link: HostLink<'q, Master<T>, LINK_JOB_BYTES>,
    commands: Producer<'q, Command<Master<T>>>,
    reports: Consumer<'q, Report<Master<T>>>,
    period: u64,
    /// The period the hand started in (it moves while a job runs).
    hand_from: Option<u64>,
    /// Arc length the hand has gone along the drawing in this session, m.
    went_m: f64,
    /// The drawing's segment the hand was nearest a period before.
    segment: Option<usize>,
    /// Where the hand holds the handle while no job runs, m.
    hold_m: Option<Vector3<f64>>,
    /// The operator pressed the stop button in this session.
    pressed_stop: bool,
    glitch: Option<(usize, u16)>,
}

impl<'q, T: Float> LinkedMaster<'q, T> {
    /// The host link: to attach the machine's settings store
    /// ([`HostLink::attach_store`]) before the first period.
    pub fn link_mut(&mut self) -> &mut HostLink<'q, Master<T>, LINK_JOB_BYTES> {
        &mut self.link
    }

    /// The hand's force on the effector for this period, N: while no job runs it
    /// holds the handle where it stands, carrying the effector's weight (the master's
    /// safe outputs are no force); while one runs it moves along the drawing (module
    /// docs).
    fn hand(&mut self) -> Vector3<f64> {
        let running = self.supervisor.mode() == Mode::Running;
        let plant = &self.plant.plant;
        let (Ok(x), Ok(v)) = (plant.effector_m(), plant.effector_velocity_m_s()) else {
            return Vector3::zeros();
        };
        let from = match (running, self.hand_from) {
            (false, _) => {
                self.hand_from = None;
                let hold = *self.hold_m.get_or_insert(x);
                let params = DeltaPlantParams::MASTER;
                let weight =
                    Vector3::new(0.0, 0.0, -params.effector_mass_kg * params.gravity_z_m_s2);
                return (hold - x) * GRIP.0 - v * GRIP.1 + weight;
            }
            (true, None) => {
                (self.went_m, self.pressed_stop, self.segment, self.hold_m) =
                    (0.0, false, None, None);
                *self.hand_from.insert(self.period)
            }
            (true, Some(from)) => from,
        };
        let t = (self.period - from) as f64 * PERIOD_S;
        let (s, tangent, normal, _, segment) = self.drawing.frame([x.x, x.y], self.segment);
        self.segment = Some(segment);
        let along = v.x * tangent[0] + v.y * tangent[1];
        self.went_m += along * PERIOD_S;
        if self.went_m >= SESSION_LAPS * self.drawing.length_m() && !self.pressed_stop {
            // The stop button: a full queue leaves it for the next period.
            self.pressed_stop = self.commands.enqueue(Command::Stop).is_ok();
        }
        let wanted = wanted_speed_m_s(s, self.drawing.length_m(), t);
        let hand_along = HAND_N_S_PER_M * (wanted - along);
        let push = 0.5;
        let tau = 2.0 * core::f64::consts::PI * t;
        let tremor = 0.3 * (libm::sin(8.7 * tau) + libm::sin(11.3 * tau)) / 2.0;
        Vector3::new(
            hand_along * tangent[0] + push * normal[0] + tremor,
            hand_along * tangent[1] + push * normal[1] + tremor * 0.7,
            -0.5,
        )
    }

    /// The slave's period at `now`: the command playing, the model advanced, the
    /// report sent every link sample.
    fn slave_period(&mut self, now: u32) {
        let s = &mut self.slave;
        if let (Some(command), _) = s.link.receive(now, &mut self.forward) {
            let u = Vector3::from(command.acceleration_m_s2.map(f64::from));
            // Semi-implicit Euler, as the master's model of it (`control::delay_observer`).
            s.velocity_m_s += u * PERIOD_S;
            s.position_m += s.velocity_m_s * PERIOD_S;
        }
        let report = s.position_m.map(|c| c as f32);
        s.link.report(Some(report.into()), &mut self.backward);
    }

    /// One control period: the host's bytes read, the hand's push, the slave's report
    /// taken, the master's period, its command sent, the slave's period, the reports
    /// answered and forwarded through `to_host`, the heartbeat checked.
    pub fn period(&mut self, from_host: &[u8], to_host: &mut dyn FnMut(&[u8]) -> bool) {
        let now_s = self.period as f64 * PERIOD_S;
        for &b in from_host {
            self.link
                .receive(b, now_s, &mut self.commands, &mut *to_host);
        }
        self.plant.plant.effector_force_n = self.hand();
        self.forward.set_now(self.period);
        self.backward.set_now(self.period);
        let report = self.master_link.receive(&mut self.backward);
        let mut counts = self.plant.counts();
        if let Some((axis, jump)) = self.glitch.take() {
            if let Some(c) = counts.get_mut(axis) {
                *c = c.wrapping_add(jump);
            }
        }
        let outputs = self.supervisor.step(&RemoteMasterInputs {
            encoder_counts: counts,
            report,
        });
        self.plant.step(outputs.force_n.map(|f| f.to_f64()));
        if let (Some((tick, _)), Ok(x)) = (outputs.command, self.plant.plant.effector_m()) {
            let (cm, cs, scale) = self.mapping;
            let scaled = Vector3::from(cs) + (x - Vector3::from(cm)) * scale;
            if let Some(slot) = self.references.get_mut(tick as usize % REFERENCES) {
                *slot = (tick, scaled.into());
            }
        }
        self.master_link.send(outputs.command, &mut self.forward);
        self.slave_period(self.period as u32);
        while let Some(report) = self.reports.dequeue() {
            self.link.report(&report, &mut *to_host);
        }
        self.period += 1;
        self.link.tick(
            self.period as f64 * PERIOD_S,
            &mut self.commands,
            &mut *to_host,
        );
    }

    /// The supervisor.
    pub fn supervisor(&self) -> &Supervisor<'_, Master<T>> {
        &self.supervisor
    }

    /// The link.
    pub fn link(&self) -> &HostLink<'q, Master<T>, LINK_JOB_BYTES> {
        &self.link
    }

    /// The master's true distance across the drawing, outwards, m (`None` once the
    /// plant left where it assembles).
    pub fn across_m(&self) -> Option<f64> {
        let x = self.plant.plant.effector_m().ok()?;
        Some(self.drawing.frame([x.x, x.y], None).3)
    }

    /// The slave's true distance from the scaled master at the tick it executes, m
    /// (`None` before its first command).
    pub fn slave_tracking_m(&self) -> Option<f64> {
        let tick = self.slave.link.executing()?;
        let (at, reference) = *self.references.get(tick as usize % REFERENCES)?;
        (at == tick).then(|| (Vector3::from(reference) - self.slave.position_m).norm())
    }

    /// The slave's position, m.
    pub fn slave_m(&self) -> [f64; 3] {
        self.slave.position_m.into()
    }

    /// The master's true effector, m.
    pub fn master_m(&self) -> Option<[f64; 3]> {
        self.plant.plant.effector_m().ok().map(Into::into)
    }

    /// At the next period carriage `axis`'s counter reads `jump` counts off, once (a
    /// glitch on its cable).
    pub fn glitch_encoder(&mut self, axis: usize, jump: u16) {
        self.glitch = Some((axis, jump));
    }
}

/// Builds the master as flashed on its simulated plant, hand and slave site behind
/// the link (module docs), the operator's drawing read from the points job file
/// `drawing`, and hands it to `f`. The link stops a job after `heartbeat_timeout_s`
/// of machine time without a frame from the host.
///
/// Errors: a configuration the master or the link refuses; a drawing that is not a
/// points file; a plant that does not assemble at its home.
pub fn with_linked_master<T: Float, R>(
    drawing: &[u8],
    heartbeat_timeout_s: f64,
    f: impl FnOnce(&mut LinkedMaster<'_, T>) -> R,
) -> Result<R, LinkedMasterError> {
    let jobs = JobSlots::default();
    let mut commands = Queue::<Command<Master<T>>, 4>::new();
    let mut reports = Queue::<Report<Master<T>>, 16>::new();
    let (mut to_machine, from_sender) = commands.split();
    let (to_link, from_machine) = reports.split();
    let config = config()?;
    let machine = Master::<T>::new(&config)?;
    let mut supervisor = Supervisor::new(machine, from_sender, to_link, &jobs);
    supervisor.set_telemetry_decimation(TELEMETRY_DECIMATION);
    // Encoders need no sweep: the stored (empty) calibration at power-up.
    to_machine
        .enqueue(Command::FinishCalibration(()))
        .map_err(|_| ConfigError::out_of_range("calibration"))?;
    let link = HostLink::new(
        &HostLinkConfig {
            period_s: PERIOD_S,
            heartbeat_timeout_s,
        },
        MasterSettings::MASTER,
        session()?,
        &jobs,
    )?;
    let plant = SimulatedMaster::new(
        &DeltaConfig::MASTER_HORIZONTAL,
        DeltaPlantParams::MASTER,
        PERIOD_S,
        HOME_M,
        EncoderConfig::MASTER_0_5_UM.resolution_m,
        [12_345, 40_000, 65_000],
    )
    .map_err(|_| LinkedMasterError::Plant)?;
    let sdct = SdctConfig {
        m: SDCT_M,
        selection: Selection::Largest,
    };
    let sample_period_s = PERIOD_S * f64::from(SAMPLES_PER_COMMAND);
    let network = |seed| {
        // On the clock of control periods (0.1 ms): the delay uniform in
        // [delay − jitter, delay + jitter], in order.
        let ticks = |ms: u32| ms * 10;
        FrameEnd::new(&LinkConfig {
            delay_ticks: ticks(DELAY_MS - JITTER_MS),
            random_delay_ticks: ticks(2 * JITTER_MS),
            jitter_ticks: 0.0,
            loss_probability: 0.0,
            reorder: false,
            seed,
        })
        .map_err(|_| ConfigError::out_of_range("network"))
    };
    // The playout's margin behind the first command: the jitter and a half, 0.5 ms,
    // and a block period for the command frames' copies.
    let margin = JITTER_MS * 10 * 3 / 2 + 5 + SAMPLES_PER_COMMAND * BLOCK as u32;
    let tracking = &config.tracking;
    let slave = NominalSlave {
        link: SlaveLink::new(&sdct, SAMPLES_PER_COMMAND, margin)?,
        position_m: Vector3::from(tracking.slave_centre_m),
        velocity_m_s: Vector3::zeros(),
    };
    let mut master = LinkedMaster {
        supervisor,
        plant,
        drawing: Drawing::read(drawing)?,
        master_link: MasterLink::new(&sdct, 1, sample_period_s)?.with_copies(COMMAND_COPIES)?,
        forward: network(1)?,
        backward: network(2)?,
        slave,
        references: [(u32::MAX, [0.0; 3]); REFERENCES],
        mapping: (
            tracking.master_centre_m,
            tracking.slave_centre_m,
            tracking.scale,
        ),
        link,
        commands: to_machine,
        reports: from_machine,
        period: 0,
        hand_from: None,
        went_m: 0.0,
        segment: None,
        hold_m: None,
        pressed_stop: false,
        glitch: None,
    };
    Ok(f(&mut master))
}
