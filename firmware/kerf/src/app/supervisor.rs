//! The supervisor: how any machine runs, stepped once per control period.
//!
//! Commands come from a slower context (a task, the host link) through a bounded
//! lock-free queue ([`heapless::spsc`]); the supervisor takes at most the queue's
//! capacity of them at the start of a period, and each is a few copies and
//! comparisons, so nothing a command does can block or lengthen the period. A command
//! is handled where it lies in the queue, and a calibration of kilobytes is copied
//! once, into its place: nothing of its size passes through the control interrupt's
//! stack (BENCHMARKS.md, Stack). A job is not copied at all: the sender builds it in
//! one of the machine's two job buffers ([`super::jobs`]) and names the buffer; the
//! supervisor holds that buffer while the job is loaded and lends the job to
//! [`Machine::run`] each period. Anything
//! expensive — validating a configuration into coefficients, fitting a calibration —
//! is done by the sender, which enqueues the finished result. What the supervisor has
//! to say (command replies, mode changes, calibration samples, per-period telemetry)
//! goes back through a second queue; when it is full the report is dropped and
//! counted, never waited for.
//!
//! # Modes and transitions
//!
//! Outputs are the machine's safe value ([`Machine::safe_outputs`]: zero force, laser
//! off) in every mode except `Calibrating` while it sweeps, `Running`, and the
//! controlled `Stopping` ramp. In every mode the sensors are read and checked.
//!
//! | # | mode | event | next mode | outputs |
//! |---|---|---|---|---|
//! | 1 | Idle | `Calibrate` | Calibrating | sweep |
//! | 2 | Ready | `Calibrate` | Calibrating | sweep |
//! | 3 | Calibrating | sweep done | Calibrating (waits for the fit) | safe |
//! | 4 | Calibrating | `FinishCalibration(coefficients)` after the sweep | Ready | safe |
//! | 4b | Idle | `FinishCalibration(coefficients)`: a stored calibration, no sweep | Ready | safe |
//! | 5 | Calibrating | `Stop` | Idle | safe |
//! | 6 | Idle, Ready | `LoadJob(buffer)` whose job fits the machine | unchanged, job loaded (its buffer held, the replaced job's released) | safe |
//! | 7 | Ready | `Start` with a job loaded | Running | job |
//! | 6b | Running | `LoadJob(buffer)` whose job fits the machine, none queued yet | Running, the job queued to follow (its buffer held) | job |
//! | 8 | Running | job done | Ready | safe |
//! | 8b | Running | job done, a job queued whose start the machine takes (from where the last one ended) | Running, the queued job loaded and begun at the next period's start ([`Report::NextJob`]; the finished job's buffer released) | job |
//! | 8c | Running | job done, a job queued whose start the machine refuses | Ready, the queued job loaded, the refusal reported as `Start`'s | safe |
//! | 9 | Running | `Stop` | Stopping (a queued job dropped) | ramp to rest |
//! | 10 | Stopping | at rest | Ready | safe |
//! | 11 | any but Fault | machine fault (sensor, non-finite value, …), or a NaN or infinite output ([`NonFiniteOutput`]) | Fault(reason) (a queued job dropped) | safe in the same period |
//! | 12 | Fault | `ResetFault` | Idle | safe |
//! | 13 | any | `ChangeSettings(coefficients)` | unchanged, coefficients replaced (state kept: bumpless) | as the mode |
//! | 14 | any | any other command | unchanged, refused with [`CommandError::InvalidInMode`] | as the mode |
//!
//! A `LoadJob` whose job does not fit is refused with [`CommandError::Job`], one whose
//! buffer is still held (being written, or the loaded job's) with
//! [`CommandError::JobBufferBusy`], a `Start`
//! without a job with [`CommandError::NoJob`], a `FinishCalibration` before the sweep
//! is over with [`CommandError::InvalidInMode`]; none of them changes anything.
//!
//! A queue of one job behind the running one is how a program of many parts runs as
//! one: the sender builds the next part in the buffer the running job does not hold
//! while it runs, and the part begins in the period after the running one's last, its
//! approach (tool off) leading from where that one stopped. With both buffers held, a
//! third `LoadJob` is refused with [`CommandError::JobBufferBusy`] until the running
//! part ends.
//!
//! ```
//! use heapless::spsc::Queue;
//! use kerf::app::jobs::{JobSlot, JobSlots};
//! use kerf::app::supervisor::{Command, Mode, Report, Supervisor};
//! # use kerf::app::supervisor::{Machine, NoSweep, Step};
//! # /// A machine that needs no calibration data and runs jobs of `n` periods.
//! # struct Counter { left: u32 }
//! # #[derive(Copy, Clone, Debug, PartialEq)]
//! # enum Fault { Sensor, Output }
//! # impl From<kerf::app::supervisor::NonFiniteOutput> for Fault {
//! #     fn from(_: kerf::app::supervisor::NonFiniteOutput) -> Self { Fault::Output }
//! # }
//! # impl Machine for Counter {
//! #     type Inputs = bool; type Outputs = f32; type Job = u32; type JobError = ();
//! #     type Coefficients = (); type SweepSample = NoSweep; type Calibration = (); type Fault = Fault; type Telemetry = u32;
//! #     fn safe_outputs(&self) -> f32 { 0.0 }
//! #     fn monitor(&mut self, ok: &bool) -> Result<(), Fault> { if *ok { Ok(()) } else { Err(Fault::Sensor) } }
//! #     fn begin_calibration(&mut self) {}
//! #     fn calibrate(&mut self, ok: &bool, _: &mut dyn FnMut(NoSweep)) -> Result<Step<f32>, Fault> { self.monitor(ok)?; Ok(Step::Done(0.0)) }
//! #     fn finish_calibration(&mut self, _: &()) {}
//! #     fn check_job(&self, job: &u32) -> Result<(), ()> { if *job > 0 { Ok(()) } else { Err(()) } }
//! #     fn begin_job(&mut self, job: &u32) -> Result<(), ()> { self.left = *job; Ok(()) }
//! #     fn run(&mut self, _: &u32, ok: &bool) -> Result<Step<f32>, Fault> { self.monitor(ok)?; self.left -= 1; Ok(if self.left == 0 { Step::Done(1.0) } else { Step::Continue(1.0) }) }
//! #     fn begin_stop(&mut self) {}
//! #     fn stop(&mut self, _job: &Self::Job, ok: &bool) -> Result<Step<f32>, Fault> { self.monitor(ok)?; Ok(Step::Done(0.5)) }
//! #     fn set_coefficients(&mut self, _: &()) {}
//! #     fn reset(&mut self) {}
//! #     fn telemetry(&self) -> u32 { self.left }
//! # }
//! let jobs = JobSlots::<u32>::default();
//! let mut commands: Queue<Command<Counter>, 4> = Queue::new();
//! let mut reports: Queue<Report<Counter>, 16> = Queue::new();
//! let (mut to_machine, from_sender) = commands.split();
//! let (to_sender, mut from_machine) = reports.split();
//! let mut supervisor = Supervisor::new(Counter { left: 0 }, from_sender, to_sender, &jobs);
//!
//! // The slower context sends; the control period picks the commands up.
//! to_machine.enqueue(Command::Calibrate).ok();
//! supervisor.step(&true); // sweep (done at once here)
//! to_machine.enqueue(Command::FinishCalibration(())).ok();
//! // A job of three periods, built in a free buffer, which is then named.
//! let (slot, mut job) = jobs.take_free().unwrap();
//! *job = 3;
//! drop(job);
//! to_machine.enqueue(Command::LoadJob(slot)).ok();
//! to_machine.enqueue(Command::Start).ok();
//! supervisor.step(&true);
//! assert_eq!(supervisor.mode(), Mode::Running);
//! // A broken sensor: safe outputs in the same period, and a latched fault.
//! assert_eq!(supervisor.step(&false), 0.0);
//! assert_eq!(supervisor.mode(), Mode::Fault(Fault::Sensor));
//! // Refused: no start from Fault.
//! to_machine.enqueue(Command::Start).ok();
//! supervisor.step(&true);
//! assert!(core::iter::from_fn(|| from_machine.dequeue())
//!     .any(|r| matches!(r, Report::Refused { .. })));
//! ```

use super::jobs::{HeldJob, JobSlot, JobSlots};
use heapless::spsc::{Consumer, Producer};

mod outputs;
pub(crate) use outputs::first_non_finite_index;
pub use outputs::{FiniteOutputs, NonFiniteOutput};

/// What a machine's control step is asked to do in a period, and what it answers.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Step<O> {
    /// Keep going; these are the outputs.
    Continue(O),
    /// Finished in this period; these are the outputs.
    Done(O),
}

impl<O> Step<O> {
    fn outputs(self) -> O {
        match self {
            Self::Continue(o) | Self::Done(o) => o,
        }
    }

    /// The same step with its outputs mapped by `f` (a machine adding its own outputs
    /// to a part's).
    pub fn map<P>(self, f: impl FnOnce(O) -> P) -> Step<P> {
        match self {
            Self::Continue(o) => Step::Continue(f(o)),
            Self::Done(o) => Step::Done(f(o)),
        }
    }
}

/// A machine the supervisor can run: the per-period parts of each mode. Every method is
/// called from the control period, so each must be bounded in time and never panic.
pub trait Machine {
    /// One period's inputs, sampled together.
    type Inputs;
    /// One period's outputs, written together; checked finite by the supervisor
    /// before they are (a NaN or ∞ faults the machine: [`NonFiniteOutput`]).
    type Outputs: Copy + FiniteOutputs;
    /// What `Running` follows, built in one of the machine's two job buffers
    /// ([`JobSlots`]) and never copied: `Default` is the empty job a buffer holds
    /// before the first is built in it.
    type Job: Default;
    /// Why a job does not fit the machine.
    type JobError: Copy + core::fmt::Debug + PartialEq;
    /// Validated coefficients that replace the running ones bumplessly.
    type Coefficients;
    /// One sample the calibration sweep streams to the fit in the slower context
    /// ([`NoSweep`] for a machine without a sweep: no value of it exists).
    type SweepSample: Copy;
    /// The result of a calibration fit, computed in the slower context.
    type Calibration;
    /// Why the machine stopped; a non-finite output is one of the reasons.
    type Fault: Copy + core::fmt::Debug + PartialEq + From<NonFiniteOutput>;
    /// What the machine reports each period.
    type Telemetry: Copy;

    /// Outputs that are safe at any time.
    fn safe_outputs(&self) -> Self::Outputs;
    /// Reads and checks the inputs while the outputs are safe (Idle, Ready, waiting).
    fn monitor(&mut self, inputs: &Self::Inputs) -> Result<(), Self::Fault>;
    /// Prepares the calibration sweep from the present state.
    fn begin_calibration(&mut self);
    /// One period of the sweep; `record` streams the samples the fit needs to the
    /// slower context.
    fn calibrate(
        &mut self,
        inputs: &Self::Inputs,
        record: &mut dyn FnMut(Self::SweepSample),
    ) -> Result<Step<Self::Outputs>, Self::Fault>;
    /// Installs a finished calibration (copied from the command queue's slot).
    fn finish_calibration(&mut self, calibration: &Self::Calibration);
    /// Whether `job` fits the machine (limits, workspace, capacity).
    fn check_job(&self, job: &Self::Job) -> Result<(), Self::JobError>;
    /// A job was queued to follow the running one (transition 6b): a machine that can
    /// go on into it without stopping prepares for that here (nothing by default).
    fn queued(&mut self, _next: &Self::Job) {}
    /// Prepares `job` from the present state (for example: it must start where the
    /// machine is).
    fn begin_job(&mut self, job: &Self::Job) -> Result<(), Self::JobError>;
    /// One period of `job`: the job [`Machine::begin_job`] prepared, lent by the
    /// supervisor, which keeps the one copy of it (no `LoadJob` while it runs).
    fn run(
        &mut self,
        job: &Self::Job,
        inputs: &Self::Inputs,
    ) -> Result<Step<Self::Outputs>, Self::Fault>;
    /// Starts the controlled ramp to rest from the present motion.
    fn begin_stop(&mut self);
    /// One period of the ramp to rest, along the job (lent as to [`Machine::run`]).
    fn stop(
        &mut self,
        job: &Self::Job,
        inputs: &Self::Inputs,
    ) -> Result<Step<Self::Outputs>, Self::Fault>;
    /// Replaces the coefficients (copied from the command queue's slot), keeping every
    /// state.
    fn set_coefficients(&mut self, coefficients: &Self::Coefficients);
    /// Leaves a fault: states restart (position sensing is re-homed).
    fn reset(&mut self);
    /// This period's telemetry.
    fn telemetry(&self) -> Self::Telemetry;
}

/// The sweep sample of a machine that has no calibration sweep: an empty type, so
/// such a machine cannot record one, and its `calibrate` is done at once.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NoSweep {}

/// Supervisor modes.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode<F> {
    /// Outputs safe, sensors monitored; waiting for `Calibrate`.
    Idle,
    /// The calibration sweep, then safe outputs until the fit arrives.
    Calibrating,
    /// Calibrated and at rest: a job can be loaded and started.
    Ready,
    /// Following the loaded job.
    Running,
    /// Ramping to rest after `Stop`.
    Stopping,
    /// Latched fault with its reason: safe outputs until `ResetFault`.
    Fault(F),
}

/// A request from the slower context.
pub enum Command<M: Machine> {
    /// Start the calibration sweep.
    Calibrate,
    /// The fit of the streamed calibration samples (computed by the sender).
    FinishCalibration(M::Calibration),
    /// Load the job built in this buffer (checked against the machine before it is
    /// kept; the buffer is held while the job is loaded).
    LoadJob(JobSlot),
    /// Run the loaded job.
    Start,
    /// Ramp to rest (Running) or abort the sweep (Calibrating).
    Stop,
    /// Leave a latched fault.
    ResetFault,
    /// Replace the coefficients (validated by the sender), bumplessly.
    ChangeSettings(M::Coefficients),
}

/// Which command a reply is about.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CommandKind {
    /// [`Command::Calibrate`].
    Calibrate,
    /// [`Command::FinishCalibration`].
    FinishCalibration,
    /// [`Command::LoadJob`].
    LoadJob,
    /// [`Command::Start`].
    Start,
    /// [`Command::Stop`].
    Stop,
    /// [`Command::ResetFault`].
    ResetFault,
    /// [`Command::ChangeSettings`].
    ChangeSettings,
}

impl<M: Machine> Command<M> {
    /// The command's kind.
    pub fn kind(&self) -> CommandKind {
        match self {
            Self::Calibrate => CommandKind::Calibrate,
            Self::FinishCalibration(_) => CommandKind::FinishCalibration,
            Self::LoadJob(_) => CommandKind::LoadJob,
            Self::Start => CommandKind::Start,
            Self::Stop => CommandKind::Stop,
            Self::ResetFault => CommandKind::ResetFault,
            Self::ChangeSettings(_) => CommandKind::ChangeSettings,
        }
    }
}

/// Why a command was refused. A refused command changes nothing.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CommandError<J> {
    /// Not valid in the present mode (row 14 of the table).
    InvalidInMode,
    /// `Start` with no job loaded.
    NoJob,
    /// The job does not fit the machine, or cannot start from its present state.
    Job(J),
    /// `LoadJob` named a buffer that is still being written, or the loaded job's.
    JobBufferBusy,
}

/// What the supervisor reports to the slower context.
pub enum Report<M: Machine> {
    /// The mode changed at `period`.
    ModeChanged {
        /// Control period count at the change.
        period: u64,
        /// The new mode.
        mode: Mode<M::Fault>,
    },
    /// A command was carried out.
    Accepted(CommandKind),
    /// A command was refused and changed nothing.
    Refused {
        /// Which command.
        command: CommandKind,
        /// Why.
        error: CommandError<M::JobError>,
    },
    /// One sample of the calibration sweep for the fit.
    CalibrationSample(M::SweepSample),
    /// The calibration sweep is over: every sample has been sent, the fit can run.
    SweepDone,
    /// The job queued behind the running one has begun (the one before ended).
    NextJob,
    /// One period's telemetry.
    Telemetry {
        /// Control period count.
        period: u64,
        /// The mode in that period.
        mode: Mode<M::Fault>,
        /// The machine's telemetry.
        telemetry: M::Telemetry,
    },
}

/// Which job begins after a command.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
enum Begin {
    /// The loaded job, for a `Start`.
    Start,
    /// The queued job, the running one being done.
    Next,
}

/// Runs a [`Machine`] through the modes, one [`Supervisor::step`] per control period.
pub struct Supervisor<'q, M: Machine> {
    commands: Consumer<'q, Command<M>>,
    core: Core<'q, M>,
}

/// Everything but the command queue, so that a command can be handled where it lies in
/// the queue (borrowed from it) while the rest changes.
struct Core<'q, M: Machine> {
    machine: M,
    mode: Mode<M::Fault>,
    /// Whether the calibration sweep is over (Calibrating waits for the fit).
    swept: bool,
    /// The machine's job buffers.
    jobs: &'q JobSlots<M::Job>,
    /// The loaded job, held in its buffer (lent to the machine each period while it
    /// runs; released when another is loaded).
    job: Option<HeldJob<'q, M::Job>>,
    /// The job queued behind the running one, held in the other buffer.
    next: Option<HeldJob<'q, M::Job>>,
    /// A job to begin: after the command just handled (a `Start`), or at the next
    /// period's start (the queued one, where the running one ended).
    begin_due: Option<Begin>,
    reports: Producer<'q, Report<M>>,
    period: u64,
    dropped_reports: u32,
    telemetry_decimation: u32,
    /// Periods until the next telemetry report (a countdown: no 64-bit division of
    /// the period count in the control period).
    telemetry_due_in: u32,
}

impl<'q, M: Machine> Supervisor<'q, M> {
    /// A supervisor in Idle, reading `commands`, writing `reports` and loading jobs
    /// from `jobs`; telemetry every period until
    /// [`Supervisor::set_telemetry_decimation`] says otherwise.
    pub fn new(
        machine: M,
        commands: Consumer<'q, Command<M>>,
        reports: Producer<'q, Report<M>>,
        jobs: &'q JobSlots<M::Job>,
    ) -> Self {
        Self {
            commands,
            core: Core {
                machine,
                mode: Mode::Idle,
                swept: false,
                jobs,
                job: None,
                next: None,
                begin_due: None,
                reports,
                period: 0,
                dropped_reports: 0,
                telemetry_decimation: 1,
                telemetry_due_in: 0,
            },
        }
    }

    /// Telemetry every `every` periods (0: none), starting with the next period.
    pub fn set_telemetry_decimation(&mut self, every: u32) {
        self.core.telemetry_decimation = every;
        self.core.telemetry_due_in = 0;
    }

    /// The present mode.
    pub fn mode(&self) -> Mode<M::Fault> {
        self.core.mode
    }

    /// The machine (for inspection).
    pub fn machine(&self) -> &M {
        &self.core.machine
    }

    /// Control periods stepped (a `u64`: 58 million years at 10 kHz).
    pub fn period(&self) -> u64 {
        self.core.period
    }

    /// Reports dropped because the report queue was full.
    pub fn dropped_reports(&self) -> u32 {
        self.core.dropped_reports
    }

    /// One control period: commands, then the mode's step; returns the outputs to write.
    pub fn step(&mut self, inputs: &M::Inputs) -> M::Outputs {
        if self.commands.ready() || self.core.begin_due.is_some() {
            self.handle_commands();
        }
        self.core.step(inputs)
    }

    /// Handles the queued commands, entered only when one is queued: most periods
    /// have none, and unguarded, the loop's set-up (the addresses of everything a
    /// command can change) ran every period. Inlined, so that a command's frame is the
    /// period's own (out of line it stacked 440 bytes onto a session's deepest
    /// period).
    ///
    /// A job begins (a `Start`, or the queued job when the running one is done) at one
    /// place only, after the command that asked for it and before the next: with one
    /// call site the machine's `begin_job` is inlined into the period's frame, where a
    /// second site would stack its frame on top (300 bytes on the Keops slave).
    #[inline(always)]
    fn handle_commands(&mut self) {
        // At most the queue's capacity and one begin after the last: bounded, and each
        // command is O(1).
        for _ in 0..self.commands.capacity().saturating_add(2) {
            if let Some(begin) = self.core.begin_due.take() {
                self.core.begin(begin);
            }
            // Handled where it lies: a calibration or a job is kilobytes, and moving it
            // out of the queue would put a copy of it on the interrupt's stack.
            let Some(command) = self.commands.peek() else {
                break;
            };
            self.core.handle(command);
            // Frees the slot (the payload is plain data: nothing to drop or use).
            let _ = self.commands.dequeue();
        }
    }
}

impl<M: Machine> Core<'_, M> {
    /// The present mode's step, after the commands.
    fn step(&mut self, inputs: &M::Inputs) -> M::Outputs {
        let result = match self.mode {
            Mode::Idle | Mode::Ready | Mode::Fault(_) => self
                .machine
                .monitor(inputs)
                .map(|()| Step::Continue(self.machine.safe_outputs())),
            Mode::Calibrating if self.swept => self
                .machine
                .monitor(inputs)
                .map(|()| Step::Continue(self.machine.safe_outputs())),
            Mode::Calibrating => {
                let reports = &mut self.reports;
                let dropped = &mut self.dropped_reports;
                let mut record = |sample: M::SweepSample| {
                    if !enqueue(reports, Report::CalibrationSample(sample)) {
                        *dropped = dropped.saturating_add(1);
                    }
                };
                self.machine.calibrate(inputs, &mut record)
            }
            // `Start` needs a loaded job, and no `LoadJob` replaces it while it runs (with
            // none, which no command sequence leaves, the job is over).
            Mode::Running => match self.job.as_deref() {
                Some(job) => self.machine.run(job, inputs),
                None => Ok(Step::Done(self.machine.safe_outputs())),
            },
            Mode::Stopping => match self.job.as_deref() {
                Some(job) => self.machine.stop(job, inputs),
                None => Ok(Step::Done(self.machine.safe_outputs())),
            },
        };
        let outputs = match (self.mode, result) {
            // A latched fault stays; the monitor's own errors do not re-enter it.
            (Mode::Fault(_), _) => self.machine.safe_outputs(),
            (_, Err(fault)) => {
                self.enter(Mode::Fault(fault));
                self.machine.safe_outputs()
            }
            // The one check of every machine's outputs before they are written.
            (mode, Ok(step)) => match step.outputs().first_not_finite() {
                Some(index) => {
                    self.enter(Mode::Fault(NonFiniteOutput { index }.into()));
                    self.machine.safe_outputs()
                }
                None => {
                    if let Step::Done(_) = step {
                        match mode {
                            Mode::Calibrating => {
                                self.swept = true;
                                self.report(Report::SweepDone);
                            }
                            // The queued job begins at the next period's start, where
                            // a `Start` would (its frame not under this period's).
                            Mode::Running if self.next.is_some() => {
                                self.begin_due = Some(Begin::Next);
                            }
                            Mode::Running => self.enter(Mode::Ready),
                            Mode::Stopping => self.enter(Mode::Ready),
                            _ => {}
                        }
                    }
                    step.outputs()
                }
            },
        };
        let telemetry_due = self.telemetry_decimation != 0 && self.telemetry_due_in == 0;
        if self.telemetry_decimation != 0 {
            self.telemetry_due_in = match self.telemetry_due_in {
                0 => self.telemetry_decimation - 1,
                due_in => due_in - 1,
            };
        }
        if telemetry_due {
            let report = Report::Telemetry {
                period: self.period,
                mode: self.mode,
                telemetry: self.machine.telemetry(),
            };
            self.report(report);
        }
        self.period = self.period.wrapping_add(1);
        outputs
    }

    fn handle(&mut self, command: &Command<M>) {
        let kind = command.kind();
        let report = match self.apply(command) {
            // A start is answered when the job has begun (`begin`).
            Ok(()) if self.begin_due.is_some() => return,
            Ok(()) => Report::Accepted(kind),
            Err(error) => Report::Refused {
                command: kind,
                error,
            },
        };
        self.report(report);
    }

    /// One row of the transition table, or the refusal.
    fn apply(&mut self, command: &Command<M>) -> Result<(), CommandError<M::JobError>> {
        match (self.mode, command) {
            (Mode::Idle | Mode::Ready, Command::Calibrate) => {
                self.machine.begin_calibration();
                self.swept = false;
                self.enter(Mode::Calibrating);
                Ok(())
            }
            (Mode::Idle, Command::FinishCalibration(calibration)) => {
                self.machine.finish_calibration(calibration);
                self.enter(Mode::Ready);
                Ok(())
            }
            (Mode::Calibrating, Command::FinishCalibration(calibration)) if self.swept => {
                self.machine.finish_calibration(calibration);
                self.enter(Mode::Ready);
                Ok(())
            }
            (Mode::Calibrating, Command::Stop) => {
                self.enter(Mode::Idle);
                Ok(())
            }
            (Mode::Idle | Mode::Ready, Command::LoadJob(slot)) => {
                let job = self.jobs.take(*slot).ok_or(CommandError::JobBufferBusy)?;
                // Refused: the buffer is released as `job` goes, the loaded job stays.
                self.machine.check_job(&job).map_err(CommandError::Job)?;
                // Releases the buffer of the job this one replaces.
                self.job = Some(job);
                Ok(())
            }
            (Mode::Ready, Command::Start) => {
                // Begun (and answered) right after this command (`handle_commands`).
                self.begin_due = Some(Begin::Start);
                Ok(())
            }
            (Mode::Running, Command::LoadJob(slot)) if self.next.is_none() => {
                let job = self.jobs.take(*slot).ok_or(CommandError::JobBufferBusy)?;
                self.machine.check_job(&job).map_err(CommandError::Job)?;
                self.machine.queued(&job);
                self.next = Some(job);
                Ok(())
            }
            (Mode::Running, Command::Stop) => {
                self.machine.begin_stop();
                self.enter(Mode::Stopping);
                Ok(())
            }
            (Mode::Fault(_), Command::ResetFault) => {
                self.machine.reset();
                self.enter(Mode::Idle);
                Ok(())
            }
            (_, Command::ChangeSettings(coefficients)) => {
                self.machine.set_coefficients(coefficients);
                Ok(())
            }
            _ => Err(CommandError::InvalidInMode),
        }
    }

    /// Begins the loaded job for a `Start` (transition 7), or the queued one where the
    /// running one ended (8b; 8c when the machine refuses it there: at rest, refused
    /// as a `Start`), and reports it.
    #[inline(always)]
    fn begin(&mut self, begin: Begin) {
        let next = begin == Begin::Next;
        if next {
            if let Some(job) = self.next.take() {
                // Releases the finished job's buffer.
                self.job = Some(job);
            }
        }
        let begun = match self.job.as_deref() {
            Some(job) => self.machine.begin_job(job).map_err(CommandError::Job),
            None => Err(CommandError::NoJob),
        };
        match begun {
            Ok(()) if next => self.report(Report::NextJob),
            Ok(()) => {
                self.enter(Mode::Running);
                self.report(Report::Accepted(CommandKind::Start));
            }
            Err(error) => {
                if next {
                    self.enter(Mode::Ready);
                }
                self.report(Report::Refused {
                    command: CommandKind::Start,
                    error,
                });
            }
        }
    }

    fn enter(&mut self, mode: Mode<M::Fault>) {
        if mode != Mode::Running {
            // Only a running job has a successor.
            self.next = None;
            if self.begin_due == Some(Begin::Next) {
                self.begin_due = None;
            }
        }
        if mode != self.mode {
            self.mode = mode;
            self.report(Report::ModeChanged {
                period: self.period,
                mode,
            });
        }
    }

    fn report(&mut self, report: Report<M>) {
        if !enqueue(&mut self.reports, report) {
            self.dropped_reports = self.dropped_reports.saturating_add(1);
        }
    }
}

/// Enqueues `item`; `false` when the queue is full or has no storage at all. The queue
/// behind a producer is a view whose storage length is only known at run time, and
/// `enqueue` advances its index modulo that length: testing the length first (a queue
/// without storage reports a capacity of `usize::MAX`, the wrapped `0 − 1`) leaves no
/// division by zero, and so no panic, in the control period.
fn enqueue<T>(producer: &mut Producer<'_, T>, item: T) -> bool {
    producer.capacity() != usize::MAX && producer.enqueue(item).is_ok()
}

#[cfg(test)]
mod tests;
