//! One test per row of the transition table (module docs), on a toy machine whose
//! every call is recorded, plus the refusals.

use super::*;
use crate::app::jobs::JobSlots;
use heapless::spsc::{Producer, Queue};
use std::vec::Vec;

/// Inputs of the toy machine: whether the sensors are healthy.
const OK: bool = true;
const BROKEN: bool = false;

/// Outputs: 0 is safe, 1 the sweep, 2 a job, 3 the stop ramp.
const SAFE: u8 = 0;
const SWEEP: u8 = 1;
const JOB: u8 = 2;
const RAMP: u8 = 3;

#[derive(Default)]
struct Toy {
    /// Periods left in the sweep, job or ramp.
    left: u32,
    /// Last coefficients installed.
    gain: u32,
    calibrated: Option<u32>,
    resets: u32,
}

impl From<super::NonFiniteOutput> for &'static str {
    fn from(_: super::NonFiniteOutput) -> Self {
        "output"
    }
}

impl Machine for Toy {
    type Inputs = bool;
    type Outputs = u8;
    type Job = u32;
    type JobError = &'static str;
    type Coefficients = u32;
    /// A toy sweep sample: the counts of axis 0.
    type SweepSample = [u16; 3];
    type Calibration = u32;
    type Fault = &'static str;
    type Telemetry = u32;

    fn safe_outputs(&self) -> u8 {
        SAFE
    }
    fn monitor(&mut self, ok: &bool) -> Result<(), &'static str> {
        if *ok {
            Ok(())
        } else {
            Err("sensor")
        }
    }
    fn begin_calibration(&mut self) {
        self.left = 2;
    }
    fn calibrate(
        &mut self,
        ok: &bool,
        record: &mut dyn FnMut([u16; 3]),
    ) -> Result<Step<u8>, &'static str> {
        self.monitor(ok)?;
        record([1, 2, 3]);
        self.left -= 1;
        Ok(if self.left == 0 {
            Step::Done(SWEEP)
        } else {
            Step::Continue(SWEEP)
        })
    }
    fn finish_calibration(&mut self, &calibration: &u32) {
        self.calibrated = Some(calibration);
    }
    fn check_job(&self, job: &u32) -> Result<(), &'static str> {
        if *job == 0 || *job > 100 {
            Err("does not fit")
        } else {
            Ok(())
        }
    }
    /// Job 99 fits but never begins (a start the machine refuses where it stands).
    fn begin_job(&mut self, job: &u32) -> Result<(), &'static str> {
        if *job == 99 {
            return Err("cannot begin here");
        }
        self.left = *job;
        Ok(())
    }
    fn run(&mut self, _: &u32, ok: &bool) -> Result<Step<u8>, &'static str> {
        self.monitor(ok)?;
        self.left -= 1;
        Ok(if self.left == 0 {
            Step::Done(JOB)
        } else {
            Step::Continue(JOB)
        })
    }
    fn begin_stop(&mut self) {
        self.left = 2;
    }
    fn stop(&mut self, _job: &Self::Job, ok: &bool) -> Result<Step<u8>, &'static str> {
        self.run(&0, ok).map(|s| match s {
            Step::Continue(_) => Step::Continue(RAMP),
            Step::Done(_) => Step::Done(RAMP),
        })
    }
    fn set_coefficients(&mut self, &gain: &u32) {
        self.gain = gain;
    }
    fn reset(&mut self) {
        self.resets += 1;
    }
    fn telemetry(&self) -> u32 {
        self.left
    }
}

/// A supervisor with its two queues, and helpers to drive it like the slower context.
struct Bench {
    commands: Queue<Command<Toy>, 8>,
    reports: Queue<Report<Toy>, 64>,
    jobs: JobSlots<u32>,
}

/// The slower context's side: the command queue and the job buffers.
struct To<'q> {
    commands: Producer<'q, Command<Toy>>,
    jobs: &'q JobSlots<u32>,
}

impl Bench {
    fn new() -> Self {
        Self {
            commands: Queue::new(),
            reports: Queue::new(),
            jobs: JobSlots::default(),
        }
    }
}

/// Runs `f` with a fresh supervisor, a command sender, and a report drain.
fn with_supervisor(
    f: impl FnOnce(&mut Supervisor<'_, Toy>, &mut To<'_>, &mut dyn FnMut() -> Vec<Report<Toy>>),
) {
    let mut bench = Bench::new();
    let (send, commands) = bench.commands.split();
    let (reports, mut receive) = bench.reports.split();
    let mut supervisor = Supervisor::new(Toy::default(), commands, reports, &bench.jobs);
    let mut send = To {
        commands: send,
        jobs: &bench.jobs,
    };
    supervisor.set_telemetry_decimation(0);
    let mut drain = move || core::iter::from_fn(|| receive.dequeue()).collect::<Vec<_>>();
    f(&mut supervisor, &mut send, &mut drain);
}

fn send(to: &mut To<'_>, command: Command<Toy>) {
    assert!(to.commands.enqueue(command).is_ok(), "command queue full");
}

/// Places `job` in a free buffer and sends `LoadJob` with its name.
fn load(to: &mut To<'_>, job: u32) {
    let slot = to.jobs.place(job).expect("a free job buffer");
    send(to, Command::LoadJob(slot));
}

/// `LoadJob` of `job`, placed in a free buffer.
fn load_command(to: &To<'_>, job: u32) -> Command<Toy> {
    Command::LoadJob(to.jobs.place(job).expect("a free job buffer"))
}

fn refusals(reports: &[Report<Toy>]) -> Vec<(CommandKind, CommandError<&'static str>)> {
    reports
        .iter()
        .filter_map(|r| match r {
            Report::Refused { command, error } => Some((*command, *error)),
            _ => None,
        })
        .collect()
}

/// Drives a fresh supervisor to Ready (rows 1, 3, 4).
fn to_ready(s: &mut Supervisor<'_, Toy>, to: &mut To<'_>) {
    send(to, Command::Calibrate);
    assert_eq!(s.step(&OK), SWEEP);
    assert_eq!(s.step(&OK), SWEEP);
    send(to, Command::FinishCalibration(7));
    assert_eq!(s.step(&OK), SAFE);
    assert_eq!(s.mode(), Mode::Ready);
}

#[test]
fn row_1_idle_calibrate_sweeps_and_streams_samples() {
    with_supervisor(|s, to, drain| {
        assert_eq!(s.step(&OK), SAFE);
        assert_eq!(s.mode(), Mode::Idle);
        send(to, Command::Calibrate);
        assert_eq!(s.step(&OK), SWEEP);
        assert_eq!(s.mode(), Mode::Calibrating);
        let samples = drain()
            .iter()
            .filter(|r| matches!(r, Report::CalibrationSample([1, 2, 3])))
            .count();
        assert_eq!(samples, 1);
    });
}

#[test]
fn row_2_ready_calibrate_recalibrates() {
    with_supervisor(|s, to, _| {
        to_ready(s, to);
        send(to, Command::Calibrate);
        assert_eq!(s.step(&OK), SWEEP);
        assert_eq!(s.mode(), Mode::Calibrating);
    });
}

#[test]
fn rows_3_and_4_sweep_done_waits_safe_for_the_fit_then_ready() {
    with_supervisor(|s, to, drain| {
        send(to, Command::Calibrate);
        s.step(&OK);
        s.step(&OK); // sweep done
        assert!(drain().iter().any(|r| matches!(r, Report::SweepDone)));
        for _ in 0..3 {
            assert_eq!(s.step(&OK), SAFE);
            assert_eq!(s.mode(), Mode::Calibrating);
        }
        send(to, Command::FinishCalibration(42));
        assert_eq!(s.step(&OK), SAFE);
        assert_eq!(s.mode(), Mode::Ready);
        assert_eq!(s.machine().calibrated, Some(42));
    });
}

#[test]
fn row_4_finish_before_the_sweep_is_over_is_refused() {
    with_supervisor(|s, to, drain| {
        send(to, Command::Calibrate);
        s.step(&OK);
        send(to, Command::FinishCalibration(1));
        assert_eq!(s.step(&OK), SWEEP);
        assert_eq!(s.mode(), Mode::Calibrating);
        assert_eq!(s.machine().calibrated, None);
        assert_eq!(
            refusals(&drain()),
            [(CommandKind::FinishCalibration, CommandError::InvalidInMode)]
        );
    });
}

#[test]
fn row_4b_a_stored_calibration_makes_idle_ready_without_a_sweep() {
    with_supervisor(|s, to, _| {
        send(to, Command::FinishCalibration(5));
        assert_eq!(s.step(&OK), SAFE);
        assert_eq!(s.mode(), Mode::Ready);
        assert_eq!(s.machine().calibrated, Some(5));
    });
}

#[test]
fn row_5_stop_aborts_the_sweep() {
    with_supervisor(|s, to, _| {
        send(to, Command::Calibrate);
        s.step(&OK);
        send(to, Command::Stop);
        assert_eq!(s.step(&OK), SAFE);
        assert_eq!(s.mode(), Mode::Idle);
    });
}

#[test]
fn row_6_load_job_checks_it_and_changes_nothing_else() {
    with_supervisor(|s, to, drain| {
        load(to, 5);
        s.step(&OK);
        assert_eq!(s.mode(), Mode::Idle);
        to_ready(s, to);
        load(to, 500);
        s.step(&OK);
        assert_eq!(
            refusals(&drain()),
            [(CommandKind::LoadJob, CommandError::Job("does not fit"))]
        );
        // The earlier job is still the loaded one: Start runs 5 periods.
        send(to, Command::Start);
        for _ in 0..5 {
            assert_eq!(s.step(&OK), JOB);
        }
        assert_eq!(s.mode(), Mode::Ready);
    });
}

#[test]
fn a_loaded_job_holds_its_buffer_and_a_replaced_or_refused_one_is_released() {
    use crate::app::jobs::JobSlot;
    with_supervisor(|s, to, drain| {
        to_ready(s, to);
        load(to, 4);
        s.step(&OK);
        // The loaded job's buffer is held: naming it again is refused, writing it is
        // not possible, and the other buffer is the free one.
        assert!(to.jobs.take(JobSlot::First).is_none());
        send(to, Command::LoadJob(JobSlot::First));
        s.step(&OK);
        assert_eq!(
            refusals(&drain()),
            [(CommandKind::LoadJob, CommandError::JobBufferBusy)]
        );
        // A job that does not fit releases its own buffer; the loaded one stays held.
        load(to, 500);
        s.step(&OK);
        assert!(to.jobs.take(JobSlot::Second).is_some());
        assert!(to.jobs.take(JobSlot::First).is_none());
        // A job that fits replaces the loaded one and releases its buffer.
        load(to, 2);
        s.step(&OK);
        assert!(to.jobs.take(JobSlot::First).is_some());
        assert!(to.jobs.take(JobSlot::Second).is_none());
        send(to, Command::Start);
        for _ in 0..2 {
            assert_eq!(s.step(&OK), JOB);
        }
        assert_eq!(s.mode(), Mode::Ready);
        assert_eq!(
            refusals(&drain())[..],
            [(CommandKind::LoadJob, CommandError::Job("does not fit"))]
        );
    });
}

#[test]
fn row_7_start_runs_the_job_and_without_one_is_refused() {
    with_supervisor(|s, to, drain| {
        to_ready(s, to);
        drain();
        send(to, Command::Start);
        assert_eq!(s.step(&OK), SAFE);
        assert_eq!(
            refusals(&drain()),
            [(CommandKind::Start, CommandError::NoJob)]
        );
        assert_eq!(s.mode(), Mode::Ready);
        load(to, 3);
        send(to, Command::Start);
        assert_eq!(s.step(&OK), JOB);
        assert_eq!(s.mode(), Mode::Running);
    });
}

#[test]
fn row_8_job_done_is_ready() {
    with_supervisor(|s, to, drain| {
        to_ready(s, to);
        load(to, 2);
        send(to, Command::Start);
        assert_eq!(s.step(&OK), JOB);
        assert_eq!(s.step(&OK), JOB);
        assert_eq!(s.mode(), Mode::Ready);
        assert_eq!(s.step(&OK), SAFE);
        assert!(drain().iter().any(|r| matches!(
            r,
            Report::ModeChanged {
                mode: Mode::Ready,
                period: 4
            }
        )));
    });
}

#[test]
fn rows_9_and_10_stop_ramps_to_rest_then_ready() {
    with_supervisor(|s, to, _| {
        to_ready(s, to);
        load(to, 100);
        send(to, Command::Start);
        s.step(&OK);
        send(to, Command::Stop);
        assert_eq!(s.step(&OK), RAMP);
        assert_eq!(s.mode(), Mode::Stopping);
        assert_eq!(s.step(&OK), RAMP);
        assert_eq!(s.mode(), Mode::Ready);
        assert_eq!(s.step(&OK), SAFE);
    });
}

#[test]
fn row_11_a_fault_in_any_mode_is_safe_in_the_same_period() {
    // Idle, Calibrating, Ready, Running, Stopping.
    type Setup = fn(&mut Supervisor<'_, Toy>, &mut To<'_>);
    let setups: [Setup; 5] = [
        |_, _| {},
        |s, to| {
            send(to, Command::Calibrate);
            s.step(&OK);
        },
        |s, to| to_ready(s, to),
        |s, to| {
            to_ready(s, to);
            load(to, 100);
            send(to, Command::Start);
            s.step(&OK);
        },
        |s, to| {
            to_ready(s, to);
            load(to, 100);
            send(to, Command::Start);
            s.step(&OK);
            send(to, Command::Stop);
            s.step(&OK);
        },
    ];
    for setup in setups {
        with_supervisor(|s, to, _| {
            setup(s, to);
            assert_eq!(s.step(&BROKEN), SAFE);
            assert_eq!(s.mode(), Mode::Fault("sensor"));
            // Latched: healthy inputs do not leave it.
            assert_eq!(s.step(&OK), SAFE);
            assert_eq!(s.mode(), Mode::Fault("sensor"));
        });
    }
}

#[test]
fn row_12_reset_fault_is_idle_and_resets_the_machine() {
    with_supervisor(|s, to, _| {
        s.step(&BROKEN);
        send(to, Command::ResetFault);
        assert_eq!(s.step(&OK), SAFE);
        assert_eq!(s.mode(), Mode::Idle);
        assert_eq!(s.machine().resets, 1);
    });
}

#[test]
fn row_13_settings_change_in_every_mode_keeps_the_mode() {
    with_supervisor(|s, to, _| {
        send(to, Command::ChangeSettings(1));
        s.step(&OK);
        assert_eq!((s.mode(), s.machine().gain), (Mode::Idle, 1));
        to_ready(s, to);
        load(to, 100);
        send(to, Command::Start);
        s.step(&OK);
        send(to, Command::ChangeSettings(2));
        assert_eq!(s.step(&OK), JOB);
        assert_eq!((s.mode(), s.machine().gain), (Mode::Running, 2));
        s.step(&BROKEN);
        send(to, Command::ChangeSettings(3));
        s.step(&OK);
        assert_eq!((s.mode(), s.machine().gain), (Mode::Fault("sensor"), 3));
    });
}

#[test]
fn row_14_commands_invalid_in_the_mode_are_refused_and_change_nothing() {
    use CommandKind as K;
    // (setup, command, mode it must stay in)
    with_supervisor(|s, to, drain| {
        // Idle: Start, Stop, ResetFault.
        for (command, kind) in [
            (Command::Start, K::Start),
            (Command::Stop, K::Stop),
            (Command::ResetFault, K::ResetFault),
        ] {
            send(to, command);
            assert_eq!(s.step(&OK), SAFE);
            assert_eq!(s.mode(), Mode::Idle);
            assert_eq!(refusals(&drain()), [(kind, CommandError::InvalidInMode)]);
        }
        assert_eq!(s.machine().calibrated, None);
        // Running: Calibrate, Start, ResetFault (a `LoadJob` queues: rows 6b, 8b).
        to_ready(s, to);
        load(to, 100);
        send(to, Command::Start);
        s.step(&OK);
        drain();
        for (command, kind) in [
            (Command::Calibrate, K::Calibrate),
            (Command::Start, K::Start),
            (Command::ResetFault, K::ResetFault),
        ] {
            let left = s.machine().left;
            send(to, command);
            assert_eq!(s.step(&OK), JOB);
            assert_eq!(s.mode(), Mode::Running);
            assert_eq!(s.machine().left, left - 1);
            assert_eq!(refusals(&drain()), [(kind, CommandError::InvalidInMode)]);
        }
        // Fault: Start, Calibrate, LoadJob, Stop.
        s.step(&BROKEN);
        drain();
        for (command, kind) in [
            (Command::Start, K::Start),
            (Command::Calibrate, K::Calibrate),
            (load_command(to, 3), K::LoadJob),
            (Command::Stop, K::Stop),
        ] {
            send(to, command);
            assert_eq!(s.step(&OK), SAFE);
            assert_eq!(s.mode(), Mode::Fault("sensor"));
            assert_eq!(refusals(&drain()), [(kind, CommandError::InvalidInMode)]);
        }
    });
}

#[test]
fn a_full_report_queue_drops_and_counts_instead_of_waiting() {
    let mut commands: Queue<Command<Toy>, 4> = Queue::new();
    let mut reports: Queue<Report<Toy>, 4> = Queue::new();
    let (_, from) = commands.split();
    let (to, mut drain) = reports.split();
    let jobs = JobSlots::default();
    let mut s = Supervisor::new(Toy::default(), from, to, &jobs);
    for _ in 0..100 {
        s.step(&OK);
    }
    // Telemetry each period into a queue nobody drains: heapless's 4-slot queue holds
    // 3 reports, every later one is dropped and counted once.
    assert_eq!(s.dropped_reports(), 97);
    assert_eq!(s.period(), 100);
    // Drained, the queue takes the next 3 again; the count resumes after them.
    while drain.dequeue().is_some() {}
    for _ in 0..5 {
        s.step(&OK);
    }
    assert_eq!(s.dropped_reports(), 99);
}

/// Telemetry comes every `every` periods from the period after the setting, at the
/// periods an independent count (period number modulo `every`) names; 0 stops it.
#[test]
fn telemetry_comes_every_decimation_periods() {
    with_supervisor(|s, _to, drain| {
        for every in [1u32, 3, 7] {
            s.set_telemetry_decimation(every);
            let first = s.period();
            for _ in 0..25 {
                s.step(&true);
            }
            let periods: Vec<u64> = drain()
                .iter()
                .filter_map(|r| match r {
                    Report::Telemetry { period, .. } => Some(*period),
                    _ => None,
                })
                .collect();
            let expected: Vec<u64> = (first..first + 25)
                .filter(|p| (p - first) % u64::from(every) == 0)
                .collect();
            assert_eq!(periods, expected, "every {every}");
        }
        s.set_telemetry_decimation(0);
        for _ in 0..5 {
            s.step(&true);
        }
        assert!(!drain()
            .iter()
            .any(|r| matches!(r, Report::Telemetry { .. })));
    });
}

/// Whether `reports` holds a mode change.
fn changed_mode(reports: &[Report<Toy>]) -> bool {
    reports
        .iter()
        .any(|r| matches!(r, Report::ModeChanged { .. }))
}

#[test]
fn rows_6b_and_8b_a_job_loaded_while_one_runs_follows_it_without_rest() {
    with_supervisor(|s, to, drain| {
        to_ready(s, to);
        load(to, 2);
        send(to, Command::Start);
        assert_eq!(s.step(&OK), JOB);
        drain();
        // Queued behind the running job, in the other buffer; the first ends in this
        // period, and the queued one begins at the next one's start and runs in it.
        load(to, 3);
        assert_eq!(s.step(&OK), JOB);
        assert_eq!((s.mode(), s.machine().left), (Mode::Running, 0));
        assert_eq!(s.step(&OK), JOB);
        assert_eq!((s.mode(), s.machine().left), (Mode::Running, 2));
        let reports = drain();
        assert!(reports
            .iter()
            .any(|r| matches!(r, Report::Accepted(CommandKind::LoadJob))));
        assert!(reports.iter().any(|r| matches!(r, Report::NextJob)));
        assert!(!changed_mode(&reports));
        // The finished job's buffer is free again: a third part can be queued, and
        // then both buffers are held.
        load(to, 1);
        assert_eq!(s.step(&OK), JOB);
        assert_eq!(to.jobs.place(5), None);
        assert_eq!(s.step(&OK), JOB);
        assert_eq!((s.mode(), s.machine().left), (Mode::Running, 0));
        // The third: one period, then the machine rests.
        assert_eq!(s.step(&OK), JOB);
        assert_eq!(s.mode(), Mode::Ready);
        let reports = drain();
        assert_eq!(
            reports
                .iter()
                .filter(|r| matches!(r, Report::NextJob))
                .count(),
            1
        );
        assert_eq!(s.step(&OK), SAFE);
        // Only the last job stays loaded: one buffer free, and only one.
        let free = to.jobs.take_free();
        assert!(free.is_some());
        assert!(to.jobs.take_free().is_none());
    });
}

#[test]
fn row_8c_a_queued_job_the_machine_cannot_begin_is_loaded_at_rest_and_refused_as_a_start() {
    with_supervisor(|s, to, drain| {
        to_ready(s, to);
        load(to, 2);
        send(to, Command::Start);
        s.step(&OK);
        load(to, 99);
        assert_eq!(s.step(&OK), JOB);
        // Refused at the next period's start: at rest in it.
        assert_eq!(s.step(&OK), SAFE);
        assert_eq!(s.mode(), Mode::Ready);
        let reports = drain();
        assert_eq!(
            refusals(&reports),
            [(CommandKind::Start, CommandError::Job("cannot begin here"))]
        );
        assert!(!reports.iter().any(|r| matches!(r, Report::NextJob)));
        // It is the loaded job now: a start is refused for the same reason.
        send(to, Command::Start);
        assert_eq!(s.step(&OK), SAFE);
        assert_eq!(
            refusals(&drain()),
            [(CommandKind::Start, CommandError::Job("cannot begin here"))]
        );
    });
}

#[test]
fn a_stop_or_a_fault_drops_the_queued_job_and_frees_its_buffer() {
    for fault in [false, true] {
        with_supervisor(|s, to, drain| {
            to_ready(s, to);
            load(to, 50);
            send(to, Command::Start);
            s.step(&OK);
            load(to, 3);
            s.step(&OK);
            assert_eq!(to.jobs.place(5), None);
            if fault {
                assert_eq!(s.step(&BROKEN), SAFE);
                assert_eq!(s.mode(), Mode::Fault("sensor"));
            } else {
                send(to, Command::Stop);
                assert_eq!(s.step(&OK), RAMP);
                assert_eq!(s.step(&OK), RAMP);
                assert_eq!(s.mode(), Mode::Ready);
            }
            // The dropped job's buffer is free; the stopped job is still loaded.
            let free = to.jobs.take_free();
            assert!(free.is_some());
            assert!(to.jobs.take_free().is_none());
            assert!(!drain().iter().any(|r| matches!(r, Report::NextJob)));
        });
    }
}
