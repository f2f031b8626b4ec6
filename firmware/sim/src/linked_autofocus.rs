//! The autofocus stage behind the host link: the machine of
//! `kerf::machines::autofocus` on the simulated zoom camera and focus axis of
//! `hal_mock::focus`, with its supervisor's commands coming from [`HostLink`] only,
//! so a host (a test's, or the host tool over the QEMU image's serial port) uploads a
//! zoom schedule, starts, retunes and follows it with frames alone.
//!
//! The bench:
//! - the focus axis ([`FocusAxis`], hard stops at 0 and 10 mm) starts at rest at
//!   [`START_M`], 7 mm from the focus at m = 1; while the machine runs no job its
//!   drive holds the axis where it stands (the machine's safe outputs command no
//!   acceleration, and a double integrator would keep any velocity it had);
//! - the zoom drive follows the machine's magnification setpoint at
//!   [`ZOOM_RATE_PER_S`] (the host scenario's 1 → 2 in 0.5 s);
//! - the camera ([`ZoomCamera`], the inspection preset) exposes a frame every frame
//!   period and reads it out during the next one: in the period a frame is complete
//!   its window moments are computed, as a board's frame-complete interrupt does, and
//!   passed with the axis position latched at its exposure.
//!
//! The stage has no calibration: at power-up the board's task sends the empty one and
//! the stage is ready; everything after comes from the host.

use hal_mock::focus::{CameraParams, FocusAxis, ZoomCamera, FRAME_PIXELS, FRAME_SIDE};
use heapless::spsc::{Consumer, Producer, Queue};
use kerf::app::host_link::{HostLink, HostLinkConfig, LinkMachine};
use kerf::app::jobs::JobSlots;
use kerf::app::supervisor::{Command, Mode, Report, Supervisor};
use kerf::machines::autofocus::link::StageSettings;
use kerf::machines::autofocus::product::{
    CONFIG, FRAME_BYTES, FRAME_SIDE_PX, LINK_JOB_BYTES, PERIODS_PER_FRAME, PERIOD_S,
    TELEMETRY_DECIMATION, WINDOW,
};
use kerf::machines::autofocus::{FocusStage, Frame, StageInputs, StageOutputs};
use kerf::scalar::{Float, Real};
use kerf::sensing::sharpness::window_moments;
use kerf::ConfigError;

/// Where the focus axis stands at power-up, m.
pub const START_M: f64 = 9e-3;

/// The zoom drive's rate, magnification per second.
pub const ZOOM_RATE_PER_S: f64 = 2.0;

/// The camera's texture and noise seed.
pub const CAMERA_SEED: u64 = 3;

/// The zoom schedule of `data/autofocus_zoom.krfj` as (magnification, dwell s): a
/// cold start at m = 1, a zoom to 2 (the focus 3 mm further, the depth of field
/// halved), back to 1.5.
pub const ZOOM_SCHEDULE: [[f64; 2]; 3] = [[1.0, 5.0], [2.0, 3.0], [1.5, 3.0]];

// The product's frame is the simulated camera's.
const _: () = assert!(FRAME_SIDE_PX == FRAME_SIDE && FRAME_BYTES == FRAME_PIXELS);

/// What the bench does to the camera.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum CameraState {
    /// Frames as they come.
    On,
    /// No frames (a cable pulled).
    Silent,
    /// Every frame black (a capped lens).
    Dark,
}

/// The stage, its bench and its host link.
pub struct LinkedAutofocus<'q, T: Float> {
    supervisor: Supervisor<'q, FocusStage<T>>,
    axis: FocusAxis,
    camera: ZoomCamera,
    camera_state: CameraState,
    /// The frame being read out, and the position at its exposure.
    frame: [u8; FRAME_BYTES],
    exposed_at_m: Option<f64>,
    period_count: u32,
    link: HostLink<'q, FocusStage<T>, LINK_JOB_BYTES>,
    commands: Producer<'q, Command<FocusStage<T>>>,
    reports: Consumer<'q, Report<FocusStage<T>>>,
    now_s: f64,
}

impl<'q, T: Float> LinkedAutofocus<'q, T> {
    /// The host link: to attach the machine's settings store
    /// ([`HostLink::attach_store`]) before the first period.
    pub fn link_mut(&mut self) -> &mut HostLink<'q, FocusStage<T>, LINK_JOB_BYTES> {
        &mut self.link
    }

    /// One control period: the host's bytes read, the frame read out if one is
    /// complete, the period run, the axis moved under a job's command (held
    /// otherwise), the zoom moved toward its setpoint, the reports answered and
    /// forwarded through `to_host`, the heartbeat checked. Returns the outputs.
    pub fn period(
        &mut self,
        from_host: &[u8],
        to_host: &mut dyn FnMut(&[u8]) -> bool,
    ) -> StageOutputs<T> {
        for &b in from_host {
            self.link
                .receive(b, self.now_s, &mut self.commands, &mut *to_host);
        }
        let frame_due = self.period_count % PERIODS_PER_FRAME == 0;
        let mut frame = None;
        if frame_due {
            frame = self.read_out();
            self.expose();
        }
        self.period_count = self.period_count.wrapping_add(1);
        let inputs = StageInputs {
            position_m: <T as Real>::from_f64(self.axis.position_m),
            frame,
        };
        let outputs = self.supervisor.step(&inputs);
        if matches!(self.supervisor.mode(), Mode::Running | Mode::Stopping) {
            self.axis.step(Real::to_f64(outputs.acceleration_m_s2));
        } else {
            self.axis.velocity_m_s = 0.0;
        }
        let setpoint = Real::to_f64(outputs.magnification);
        let step = ZOOM_RATE_PER_S * PERIOD_S;
        let m = self.camera.magnification;
        self.camera.magnification = m + (setpoint - m).clamp(-step, step);
        while let Some(report) = self.reports.dequeue() {
            self.link.report(&report, &mut *to_host);
        }
        self.now_s += PERIOD_S;
        self.link
            .tick(self.now_s, &mut self.commands, &mut *to_host);
        outputs
    }

    /// The frame exposed a frame period ago, as the machine reads it.
    fn read_out(&mut self) -> Option<Frame<T>> {
        let exposed_at_m = self.exposed_at_m.take()?;
        let moments = window_moments(&self.frame, FRAME_SIDE_PX, &WINDOW).ok()?;
        Some(Frame {
            moments,
            exposure_position_m: <T as Real>::from_f64(exposed_at_m),
        })
    }

    /// The next frame's exposure at the axis' present position.
    fn expose(&mut self) {
        match self.camera_state {
            CameraState::On => {
                self.camera.capture(self.axis.position_m, &mut self.frame);
                self.exposed_at_m = Some(self.axis.position_m);
            }
            CameraState::Dark => {
                self.frame = [0; FRAME_BYTES];
                self.exposed_at_m = Some(self.axis.position_m);
            }
            CameraState::Silent => self.exposed_at_m = None,
        }
    }

    /// Sets what the camera does from the next frame on.
    pub fn set_camera(&mut self, state: CameraState) {
        self.camera_state = state;
    }

    /// The simulated focus axis.
    pub fn axis(&self) -> &FocusAxis {
        &self.axis
    }

    /// The simulated camera.
    pub fn camera(&self) -> &ZoomCamera {
        &self.camera
    }

    /// The supervisor.
    pub fn supervisor(&self) -> &Supervisor<'_, FocusStage<T>> {
        &self.supervisor
    }

    /// The link.
    pub fn link(&self) -> &HostLink<'q, FocusStage<T>, LINK_JOB_BYTES> {
        &self.link
    }
}

/// Builds the stage at its power-up settings on the bench (the axis at [`START_M`],
/// the camera of seed `seed`) behind the link, ready, and hands it to `f`. The link
/// stops a job after `heartbeat_timeout_s` of machine time without a frame from the
/// host: a simulation that runs faster than real time needs more than a board's.
///
/// Errors: a configuration that does not validate.
pub fn with_linked_autofocus<T: Float, R>(
    seed: u64,
    heartbeat_timeout_s: f64,
    f: impl FnOnce(&mut LinkedAutofocus<'_, T>) -> R,
) -> Result<R, ConfigError> {
    let jobs = JobSlots::default();
    let mut commands = Queue::<Command<FocusStage<T>>, 2>::new();
    let mut reports = Queue::<Report<FocusStage<T>>, 16>::new();
    let (mut to_machine, from_sender) = commands.split();
    let (to_link, mut from_machine) = reports.split();
    let settings = StageSettings::POWER_UP;
    let law = FocusStage::<T>::coefficients(&settings, PERIOD_S)?;
    let stage = FocusStage::new(&CONFIG, law)?;
    let mut supervisor = Supervisor::new(stage, from_sender, to_link, &jobs);
    supervisor.set_telemetry_decimation(TELEMETRY_DECIMATION);
    let config = HostLinkConfig {
        period_s: PERIOD_S,
        heartbeat_timeout_s,
    };
    let mut link = HostLink::new(&config, settings, CONFIG, &jobs)?;
    let axis = FocusAxis::new(START_M, CONFIG.stops_m, PERIOD_S);
    // Ready at power-up: the stage's calibration is empty (the link told of the mode).
    if to_machine.enqueue(Command::FinishCalibration(())).is_err() {
        return Err(ConfigError::out_of_range("commands"));
    }
    supervisor.step(&StageInputs {
        position_m: <T as Real>::from_f64(axis.position_m),
        frame: None,
    });
    while let Some(report) = from_machine.dequeue() {
        link.report(&report, &mut |_| true);
    }
    let mut camera = ZoomCamera::new(CameraParams::ZOOM_INSPECTION, seed);
    camera.magnification = CONFIG.power_up_magnification;
    let mut stage = LinkedAutofocus {
        supervisor,
        axis,
        camera,
        camera_state: CameraState::On,
        frame: [0; FRAME_BYTES],
        exposed_at_m: None,
        period_count: 0,
        link,
        commands: to_machine,
        reports: from_machine,
        now_s: 0.0,
    };
    Ok(f(&mut stage))
}
