//! The slower context's side of a scenario: what a supervisor task (QEMU, a board) or
//! a host does through the queues. Calibrates (or installs a stored calibration),
//! loads the job, starts it and watches the reports. One operator serves every machine
//! whose calibration is a fitted Hall decoder per axis ([`HallMachine`]).

use heapless::spsc::{Consumer, Producer};
use kerf::app::calibrate::{CalibrationFailure, CalibrationFit, HallMachine};
use kerf::app::jobs::JobSlots;
use kerf::app::supervisor::{Command, CommandKind, Mode, Report};
use kerf::sensing::hall::{CalibrationError, HallConfig, SelfCalibration};

/// Queue capacities of a scenario: commands (a few per phase) and reports (a
/// calibration sweep streams one sample per axis every 25 periods; the operator drains
/// every period or every few).
pub const COMMAND_CAPACITY: usize = 8;
/// See [`COMMAND_CAPACITY`].
pub const REPORT_CAPACITY: usize = 64;

/// Where the [`Operator`] is; `F` is the machine's fault.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum OperatorState<F> {
    /// Waiting for the calibration sweep's samples.
    Calibrating,
    /// Calibration (or the stored one) sent; waiting for Running.
    Calibrated,
    /// Job loaded and started.
    Running,
    /// The job ran to its end.
    Finished,
    /// The machine faulted, a command was refused, or the calibration failed.
    Failed(OperatorError<F>),
}

/// Why the operator gave up.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum OperatorError<F> {
    /// The machine entered Fault.
    Fault(F),
    /// A command was refused.
    Refused(CommandKind),
    /// The fit failed.
    Calibration(CalibrationFailure),
    /// The command queue was full.
    QueueFull,
}

/// The operator of a machine `M` of `N` Hall axes.
pub struct Operator<M: HallMachine<N>, const N: usize> {
    hall: [HallConfig; N],
    stored: Option<M::Calibration>,
    job: Option<M::Job>,
    state: OperatorState<M::Fault>,
    samples: CalibrationFit<N>,
    fits: Option<[SelfCalibration; N]>,
}

impl<M: HallMachine<N>, const N: usize> Operator<M, N> {
    /// An operator that calibrates the sensors described by `hall` (or installs
    /// `stored` when given), then loads and starts `job`.
    pub fn new(hall: [HallConfig; N], stored: Option<M::Calibration>, job: M::Job) -> Self {
        Self {
            hall,
            stored,
            job: Some(job),
            state: OperatorState::Calibrated,
            samples: CalibrationFit::default(),
            fits: None,
        }
    }

    /// The first commands: `Calibrate`, or the stored calibration then the job (placed
    /// in a free buffer of `jobs`).
    pub fn start(
        &mut self,
        commands: &mut Producer<'_, Command<M>>,
        jobs: &JobSlots<M::Job>,
    ) -> OperatorState<M::Fault> {
        match self.stored.take() {
            None => {
                self.state = OperatorState::Calibrating;
                self.send(commands, Command::Calibrate);
            }
            Some(calibration) => {
                self.send(commands, Command::FinishCalibration(calibration));
                self.send_job(commands, jobs);
            }
        }
        self.state
    }

    /// The fit of the first axis, once the calibration ran.
    pub fn fit(&self) -> Option<&SelfCalibration> {
        self.fits.as_ref().and_then(|f| f.first())
    }

    /// The fits of every axis, once the calibration ran.
    pub fn fits(&self) -> Option<&[SelfCalibration; N]> {
        self.fits.as_ref()
    }

    /// Where the operator is.
    pub fn state(&self) -> OperatorState<M::Fault> {
        self.state
    }

    /// Handles every pending report (the job placed in a free buffer of `jobs` when
    /// it is due); returns the state after them.
    pub fn poll(
        &mut self,
        reports: &mut Consumer<'_, Report<M>>,
        commands: &mut Producer<'_, Command<M>>,
        jobs: &JobSlots<M::Job>,
    ) -> OperatorState<M::Fault> {
        while let Some(report) = reports.dequeue() {
            match report {
                Report::CalibrationSample(sample) if self.samples.push(sample).is_err() => {
                    self.fail(OperatorError::Calibration(CalibrationFailure::Fit {
                        axis: usize::from(sample.axis),
                        error: CalibrationError::TooFewSamples,
                    }));
                }
                Report::SweepDone => match M::fit(&self.hall, &self.samples) {
                    Ok((calibration, fits)) => {
                        self.fits = Some(fits);
                        self.state = OperatorState::Calibrated;
                        self.send(commands, Command::FinishCalibration(calibration));
                        self.send_job(commands, jobs);
                    }
                    Err(e) => self.fail(OperatorError::Calibration(e)),
                },
                Report::Refused { command, .. } => self.fail(OperatorError::Refused(command)),
                Report::ModeChanged {
                    mode: Mode::Fault(f),
                    ..
                } => self.fail(OperatorError::Fault(f)),
                Report::ModeChanged {
                    mode: Mode::Running,
                    ..
                } if self.state == OperatorState::Calibrated => self.state = OperatorState::Running,
                Report::ModeChanged {
                    mode: Mode::Ready, ..
                } if self.state == OperatorState::Running => self.state = OperatorState::Finished,
                _ => {}
            }
        }
        self.state
    }

    fn send_job(&mut self, commands: &mut Producer<'_, Command<M>>, jobs: &JobSlots<M::Job>) {
        if let Some(job) = self.job.take() {
            match jobs.place(job) {
                Some(slot) => {
                    self.send(commands, Command::LoadJob(slot));
                    self.send(commands, Command::Start);
                }
                None => self.fail(OperatorError::QueueFull),
            }
        }
    }

    fn send(&mut self, commands: &mut Producer<'_, Command<M>>, command: Command<M>) {
        if commands.enqueue(command).is_err() {
            self.fail(OperatorError::QueueFull);
        }
    }

    fn fail(&mut self, error: OperatorError<M::Fault>) {
        if !matches!(self.state, OperatorState::Failed(_)) {
            self.state = OperatorState::Failed(error);
        }
    }
}
