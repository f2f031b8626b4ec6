//! The remote slave playing a recorded master session: the job the host link uploads
//! to it ([`super::link`]). A session is what reached a slave over the delayed link
//! ([`super::recording`]): each command frame with the period it arrived in, counted
//! from the master's start. The slave plays it as it plays a live link: it calibrates,
//! approaches the session's start and waits there ([`RemoteSlave`]); from the first
//! period it waits the master's clock runs, each frame reaches the slave's end of the
//! link ([`SlaveEnd`]: the stream's checks, the playout a margin behind the first
//! command) in its recorded period, and the command playing drives the slave. After the
//! session's recorded periods the slave ramps to rest and the job is done. Frames that
//! stop early leave the slave to its own timeouts: it holds, then faults with
//! [`RemoteSlaveFault::LinkLost`].

use super::product::{SlaveEnd, SESSION_FRAME_BYTES};
use super::recording::{FrameCursor, Recording, RecordingHeader, ReplayLink};
use super::{
    FollowJob, FollowJobError, FollowLaw, RemoteSlave, RemoteSlaveConfig, RemoteSlaveFault,
    RemoteSlaveInputs, RemoteSlaveTelemetry,
};
use crate::app::axis::{AxisLaw, HallAxis};
use crate::app::calibrate::{
    fit_sensors, CalibrationFailure, CalibrationFit, HallMachine, HallSample,
};
use crate::app::supervisor::{Machine, Step};
use crate::codec::sdct::{SdctConfig, Selection};
use crate::control::laser::LaserMode;
use crate::error::ConfigError;
use crate::hal::ForceAndLaser;
use crate::scalar::Float;
use crate::sensing::hall::{HallConfig, SelfCalibration};

/// A recorded master session as the slave holds it: the recording's header and its
/// frames (the master's positions, which only a tracking summary needs, are not kept).
/// The default is the empty session every slave refuses.
#[derive(Debug, Default)]
pub struct SessionJob {
    /// The recording's header: the stream's setup, the start, the beam, the periods.
    pub header: RecordingHeader,
    /// The frame section: each frame with its arrival period and length.
    pub frames: heapless::Vec<u8, SESSION_FRAME_BYTES>,
}

impl Clone for SessionJob {
    fn clone(&self) -> Self {
        Self {
            header: self.header,
            frames: self.frames.clone(),
        }
    }

    /// In place: the supervisor copies a job in the control period.
    fn clone_from(&mut self, source: &Self) {
        self.header = source.header;
        self.frames.clear();
        // The same capacity: it fits.
        let _ = self.frames.extend_from_slice(&source.frames);
    }
}

/// Why a session was not loaded or does not fit the slave.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SessionJobError {
    /// No frame, or no period to play.
    Empty,
    /// More frames than a session holds ([`SESSION_FRAME_BYTES`]).
    TooLong,
    /// The stream's setup is not one the slave's end takes (no period per command,
    /// a report coding outside the block).
    Stream,
    /// The follow job (the start, its approach, the beam).
    Follow(FollowJobError),
}

impl SessionJob {
    /// Loads `recording` in place (the slower context's work: the frames are copied).
    ///
    /// Errors: [`SessionJobError::Empty`], [`SessionJobError::TooLong`],
    /// [`SessionJobError::Stream`].
    pub fn load(&mut self, recording: &Recording<'_>) -> Result<(), SessionJobError> {
        let header = recording.header;
        if recording.frame_count() == 0 || header.periods == 0 {
            return Err(SessionJobError::Empty);
        }
        // The slave's end validates the setup as it will be built at the start.
        SlaveEnd::new(
            &stream_coding(&header),
            u32::from(header.samples_per_command),
            header.margin_periods,
        )
        .map_err(|_| SessionJobError::Stream)?;
        self.frames.clear();
        self.frames
            .extend_from_slice(recording.frames())
            .map_err(|_| SessionJobError::TooLong)?;
        self.header = header;
        Ok(())
    }

    /// The follow job: wait at the recorded start after the recorded approach, the
    /// beam at the recorded constant power (`None` for the empty session).
    pub fn follow(&self) -> FollowJob {
        let h = &self.header;
        FollowJob {
            start_m: h.start_m.map(f64::from),
            approach_s: f64::from(h.approach_s),
            laser: (!self.frames.is_empty()).then_some(LaserMode::ConstantPower {
                power_w: f64::from(h.laser_power_w),
            }),
        }
    }
}

/// The report stream's coding a header names (the reports go nowhere in a session,
/// but the end is the live one).
fn stream_coding(header: &RecordingHeader) -> SdctConfig {
    SdctConfig {
        m: usize::from(header.m),
        selection: Selection::Largest,
    }
}

/// The slave's coefficients: the carriages' law and the following's.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SessionLaw<T: Float> {
    /// The carriages' law.
    pub axis: AxisLaw<T>,
    /// The local loop and the link's timeouts.
    pub follow: FollowLaw<T>,
}

/// One period's telemetry.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SessionTelemetry<T> {
    /// The remote slave's.
    pub slave: RemoteSlaveTelemetry<T>,
    /// The master tick of the command playing (`None` before the first).
    pub master_tick: Option<u32>,
    /// Periods since the master's start (`None` before the slave waits at the start).
    pub session_period: Option<u32>,
    /// Frames delivered so far.
    pub frames: u32,
    /// Frames the slave's end refused so far.
    pub refused: u32,
    /// Commands that arrived after their play time so far.
    pub late: u32,
}

/// The remote slave with a session's frames for its link.
#[derive(Clone, Debug)]
pub struct SessionSlave<T: Float> {
    slave: RemoteSlave<T>,
    end: Option<SlaveEnd>,
    follow: FollowJob,
    cursor: FrameCursor,
    now: Option<u32>,
    ending: bool,
}

impl<T: Float> SessionSlave<T> {
    /// Validates `config` as [`RemoteSlave::new`] does.
    pub fn new(config: &RemoteSlaveConfig) -> Result<Self, ConfigError> {
        Ok(Self {
            slave: RemoteSlave::new(config)?,
            end: None,
            follow: FollowJob::default(),
            cursor: FrameCursor::default(),
            now: None,
            ending: false,
        })
    }

    /// The remote slave inside.
    pub fn slave(&self) -> &RemoteSlave<T> {
        &self.slave
    }

    /// The slave's end of the link (`None` before the first session).
    pub fn end(&self) -> Option<&SlaveEnd> {
        self.end.as_ref()
    }

    fn inputs(hall: &[[u16; 3]; 3]) -> RemoteSlaveInputs {
        RemoteSlaveInputs {
            hall: *hall,
            command: None,
            fresh: false,
        }
    }
}

impl<T: Float> Machine for SessionSlave<T> {
    type Inputs = [[u16; 3]; 3];
    type Outputs = ForceAndLaser<T, 3>;
    type Job = SessionJob;
    type JobError = SessionJobError;
    type Coefficients = SessionLaw<T>;
    type SweepSample = HallSample;
    type Calibration = [HallAxis<T>; 3];
    type Fault = RemoteSlaveFault;
    type Telemetry = SessionTelemetry<T>;

    fn safe_outputs(&self) -> ForceAndLaser<T, 3> {
        self.slave.safe_outputs()
    }

    fn monitor(&mut self, hall: &[[u16; 3]; 3]) -> Result<(), RemoteSlaveFault> {
        self.slave.monitor(&Self::inputs(hall))
    }

    fn begin_calibration(&mut self) {
        self.slave.begin_calibration();
    }

    fn calibrate(
        &mut self,
        hall: &[[u16; 3]; 3],
        record: &mut dyn FnMut(HallSample),
    ) -> Result<Step<ForceAndLaser<T, 3>>, RemoteSlaveFault> {
        self.slave.calibrate(&Self::inputs(hall), record)
    }

    fn finish_calibration(&mut self, sensors: &[HallAxis<T>; 3]) {
        self.slave.finish_calibration(sensors);
    }

    fn check_job(&self, job: &SessionJob) -> Result<(), SessionJobError> {
        if job.frames.is_empty() || job.header.periods == 0 {
            return Err(SessionJobError::Empty);
        }
        self.slave
            .check_job(&job.follow())
            .map_err(SessionJobError::Follow)
    }

    fn begin_job(&mut self, job: &SessionJob) -> Result<(), SessionJobError> {
        let header = &job.header;
        let follow = job.follow();
        self.slave
            .begin_job(&follow)
            .map_err(SessionJobError::Follow)?;
        // A fresh end: a session's playout anchors on its own first command.
        self.end = Some(
            SlaveEnd::new(
                &stream_coding(header),
                u32::from(header.samples_per_command),
                header.margin_periods,
            )
            .map_err(|_| SessionJobError::Stream)?,
        );
        self.follow = follow;
        self.cursor = FrameCursor::default();
        self.now = None;
        self.ending = false;
        Ok(())
    }

    fn run(
        &mut self,
        job: &SessionJob,
        hall: &[[u16; 3]; 3],
    ) -> Result<Step<ForceAndLaser<T, 3>>, RemoteSlaveFault> {
        if self.ending {
            return self.slave.stop(&self.follow, &Self::inputs(hall));
        }
        // The master's clock starts when the slave waits at the start (the recording
        // counts from the master's start, which the slave's first report allows).
        if self.now.is_none() && self.slave.phase() == Some(super::FollowPhase::Waiting) {
            self.now = Some(0);
        }
        let mut inputs = Self::inputs(hall);
        if let (Some(now), Some(end)) = (self.now, self.end.as_mut()) {
            let mut link = ReplayLink::resume(&job.frames, self.cursor, now);
            (inputs.command, inputs.fresh) = end.receive(now, &mut link);
            self.cursor = link.cursor();
        }
        let step = self.slave.run(&self.follow, &inputs)?;
        if let Some(now) = self.now {
            let next = now.saturating_add(1);
            self.now = Some(next);
            if next >= job.header.periods {
                // The session's periods are played: to rest, then done.
                self.slave.begin_stop();
                self.ending = true;
            }
        }
        Ok(step)
    }

    fn begin_stop(&mut self) {
        self.ending = true;
        self.slave.begin_stop();
    }

    fn stop(
        &mut self,
        _job: &SessionJob,
        hall: &[[u16; 3]; 3],
    ) -> Result<Step<ForceAndLaser<T, 3>>, RemoteSlaveFault> {
        self.slave.stop(&self.follow, &Self::inputs(hall))
    }

    fn set_coefficients(&mut self, law: &SessionLaw<T>) {
        self.slave.set_coefficients(&law.axis);
        self.slave.set_follow_law(&law.follow);
    }

    fn reset(&mut self) {
        self.slave.reset();
        self.now = None;
        self.ending = false;
    }

    fn telemetry(&self) -> SessionTelemetry<T> {
        let end = self.end.as_ref();
        SessionTelemetry {
            slave: self.slave.telemetry(),
            master_tick: end.and_then(|e| e.executing()),
            session_period: self.now,
            frames: self.cursor.delivered(),
            refused: end.map_or(0, |e| e.refused()),
            late: end.map_or(0, |e| e.late()),
        }
    }
}

impl<T: Float> HallMachine<3> for SessionSlave<T> {
    fn fit(
        hall: &[HallConfig; 3],
        samples: &CalibrationFit<3>,
    ) -> Result<([HallAxis<T>; 3], [SelfCalibration; 3]), CalibrationFailure> {
        fit_sensors(hall, samples)
    }
}
