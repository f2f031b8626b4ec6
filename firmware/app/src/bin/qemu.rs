//! QEMU smoke run: the single-axis firmware (Hall decode → velocity observer → PD →
//! DOB, f32) against the simulated LM1247 axis with imperfect Hall sensors (offsets,
//! gains, mounting errors, third harmonic, noise), at 10 kHz.
//!
//! The image has the shape of a board image:
//! - the control period runs in the SysTick exception, the highest priority in the
//!   image: the scenario's `Rig` samples the simulated axis, steps the supervisor
//!   (`Joints<f32, 1>`) and writes the force — what a board's ADC-complete interrupt
//!   does with its HAL. The handler owns the `Rig` (handed over once by `main`), keeps
//!   the job's statistics and ends the run; the period runs outside any critical
//!   section;
//! - the slower context is an embassy task on an `InterruptExecutor` at a lower
//!   priority (a spare NVIC line, dispatched from `DefaultHandler`): the scenario's
//!   `Operator` sends `Calibrate`, fits the streamed samples (the fit takes about 180
//!   control periods and is preempted by each), sends the decoders, loads the 1 s
//!   tracking profile and starts it, all through the command queue. It sleeps until
//!   the SysTick handler wakes it (which pends the executor's line) after each period,
//!   and reaches the control side only through the lock-free queues and atomics. Its
//!   only critical section is the waker's hand-over (a few instructions) and it prints
//!   without one, so it never holds the control period off;
//! - `main` sets the priorities, starts both and sleeps in `wfi`.
//!
//! The run prints the fit and a one-line summary and exits non-zero when a bound is
//! missed or the axis faulted. Run it with `-icount` (scripts/smoke does) so that the
//! interleaving of the two contexts, and with it the output, is the same every time.
#![no_std]
#![no_main]

use core::cell::RefCell;
use core::fmt::Write;
use core::future::poll_fn;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use core::task::{Poll, Waker};
use cortex_m::interrupt::{InterruptNumber, Mutex};
use cortex_m::peripheral::scb::SystemHandler;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{entry, exception};
use cortex_m_semihosting::{hio, hprintln};
use embassy_executor::InterruptExecutor;
use hal_mock::hall_sensor::HallSensorParams;
use heapless::spsc::{Consumer, Producer, Queue};
use kerf::app::jobs::JobSlots;
use kerf::app::joints::JointJob;
use kerf::app::joints::Joints;
use kerf::app::supervisor::{Command, Mode, Report};
use kerf_app::exit;
use kerf_app::stack::Painted;
use kerf_sim::scenario::{
    AxisOperator, OperatorState, Outcome, Rig, Scenario, COMMAND_CAPACITY, MAX_ERROR_BOUND_M,
    REPORT_CAPACITY, RMS_ERROR_BOUND_M, TS_S,
};

/// The machine the image runs: the single LM1247 axis.
type AxisMachine = Joints<f32, 1>;

/// SysTick reload in ticks of the 25 MHz model clock: 8 ms of guest time. Under
/// `-icount shift=0` one instruction takes 1 ns, so a tick is 40 instructions and a
/// period 8 M instructions. The guest's timer period is not the machine's 100 µs
/// (`TS_S`): the simulated plant (f64 in software, ten substeps) runs inside the same
/// handler, which costs 1 280 ticks on average (51 k instructions) and 1 525 at most
/// over the run, so at 100 µs (2 500 ticks) it would take half of the CPU or more.
/// With this reload the handler takes under 1 % and the operator gets the rest, as on a
/// board, where the control step alone (the axis law is about 400 instructions,
/// BENCHMARKS.md) leaves the slower context most of the 100 µs. The plant only sees
/// periods, never guest time: the reload changes nothing but how many periods the
/// operator's work spans, and with it the period the job starts in. That moves the
/// summary's error figures all the same, since the job then meets another stretch of
/// the sensor noise (the plant draws it per period).
const SYSTICK_RELOAD: u32 = 200_000;

/// Exception priorities, upper bits significant: SysTick highest, the operator's
/// executor below it. 0xE0 needs 3 implemented bits, which every Cortex-M4 has (the
/// STM32G4 implements 4; QEMU 7.2 keeps all 8).
const CONTROL_PRIORITY: u8 = 0x00;
const OPERATOR_PRIORITY: u8 = 0xE0;

/// A device interrupt line nothing on mps2-an386 raises; the operator's executor runs
/// on it. QEMU gives the board 32 lines and wires devices to 0–5, 8–13, 18–22 and 24
/// (hw/arm/mps2.c).
#[derive(Copy, Clone)]
struct OperatorIrq;

// SAFETY: 30 is below the model's 32 external lines, and no device drives it.
unsafe impl InterruptNumber for OperatorIrq {
    fn number(self) -> u16 {
        30
    }
}

static OPERATOR_EXECUTOR: InterruptExecutor = InterruptExecutor::new();

/// What the control interrupt owns: the machine and plant, and the run's statistics.
struct Control {
    rig: Rig<'static, f32>,
    outcome: Outcome,
    periods: u32,
    limit: u32,
    job_periods: u32,
    /// Deepest stack of a period in each mode, bytes below the handler's stack pointer.
    stack_by_mode: [usize; MODES],
}

/// Modes in the stack report, in `mode_index` order.
const MODES: usize = 6;
const MODE_NAMES: [&str; MODES] = [
    "idle",
    "calibrating",
    "ready",
    "running",
    "stopping",
    "fault",
];
/// Stack painted below the control handler's stack pointer each period, bytes: four
/// times the 2 KB budget of the control interrupt, so that a period over budget shows
/// its real depth.
const CONTROL_STACK_PAINT: usize = 8 * 1024;

fn mode_index<F>(mode: Mode<F>) -> usize {
    match mode {
        Mode::Idle => 0,
        Mode::Calibrating => 1,
        Mode::Ready => 2,
        Mode::Running => 3,
        Mode::Stopping => 4,
        Mode::Fault(_) => 5,
    }
}

/// The control state on its way from `main` to the SysTick handler, which takes it on
/// its first run and from then on owns it alone.
static CONTROL: Mutex<RefCell<Option<Control>>> = Mutex::new(RefCell::new(None));
/// Control periods run so far: the operator task waits for it to change.
static PERIODS: AtomicU32 = AtomicU32::new(0);
static PERIOD_WAKER: Mutex<RefCell<Option<Waker>>> = Mutex::new(RefCell::new(None));
/// The operator's verdict once it has one: finished (true) or failed.
static OPERATOR_DONE: AtomicBool = AtomicBool::new(false);
static OPERATOR_FINISHED: AtomicBool = AtomicBool::new(false);

#[exception]
fn SysTick() {
    // cortex-m-rt hands this handler the only reference to OWNED: the control period
    // runs without a critical section, so it masks nothing.
    static mut OWNED: Option<Control> = None;
    if OWNED.is_none() {
        // Swapped, not moved: `take` would pass the whole control state (kilobytes)
        // through this handler's stack frame.
        cortex_m::interrupt::free(|cs| {
            core::mem::swap(OWNED, &mut CONTROL.borrow(cs).borrow_mut())
        });
    }
    let Some(control) = OWNED.as_mut() else {
        return;
    };
    // The stack below this handler is free while it runs (nothing preempts it), so
    // it is painted every period and read back after the step: the period's depth.
    let painted = Painted::below_sp(CONTROL_STACK_PAINT);
    let mode = mode_index(control.rig.supervisor().mode());
    let period = step(&mut control.rig);
    let used = painted.used().unwrap_or(usize::MAX);
    if let Some(deepest) = control.stack_by_mode.get_mut(mode) {
        *deepest = (*deepest).max(used);
    }
    if period.in_job() && control.outcome.periods < control.job_periods {
        control.outcome.add(&period);
    }
    control.periods += 1;
    // The operator decides when the job is over (it sees the supervisor's reports);
    // the limit only ends a run that hangs.
    if OPERATOR_DONE.load(Ordering::Acquire) || control.periods >= control.limit {
        finish(&control.outcome, &control.stack_by_mode);
    }
    PERIODS.fetch_add(1, Ordering::Release);
    if let Some(waker) = cortex_m::interrupt::free(|cs| PERIOD_WAKER.borrow(cs).take()) {
        // Pends the operator's executor interrupt; it runs when this handler returns.
        waker.wake();
    }
}

/// One control period, kept out of the handler so that all of its stack lies below the
/// painted mark.
#[inline(never)]
fn step(rig: &mut Rig<'static, f32>) -> kerf_sim::scenario::Period {
    rig.step()
}

/// Prints the summary and ends the run.
fn finish(outcome: &Outcome, stack_by_mode: &[usize; MODES]) -> ! {
    hprintln!("kerf qemu smoke: control period stack, deepest per mode (bytes below the SysTick handler's frame, simulated plant included; 0 = mode not entered):");
    for (name, bytes) in MODE_NAMES.iter().zip(stack_by_mode) {
        if *bytes == usize::MAX {
            hprintln!(
                "  {}: over {} (painted stretch used up)",
                name,
                CONTROL_STACK_PAINT
            );
        } else {
            hprintln!("  {}: {}", name, bytes);
        }
    }
    let ok = OPERATOR_FINISHED.load(Ordering::Acquire)
        && outcome.fault_period.is_none()
        && outcome.rms_error_m < RMS_ERROR_BOUND_M
        && outcome.max_error_m < MAX_ERROR_BOUND_M;
    hprintln!(
        "kerf qemu smoke: periods {} ({} s at 10 kHz) rms error {:.3} um (bound {:.1}) max error {:.3} um (bound {:.1}) peak force {:.3} N fault {} -> {}",
        outcome.periods,
        f64::from(outcome.periods) * TS_S,
        outcome.rms_error_m * 1e6,
        RMS_ERROR_BOUND_M * 1e6,
        outcome.max_error_m * 1e6,
        MAX_ERROR_BOUND_M * 1e6,
        outcome.peak_force_n,
        outcome.fault_period.is_some(),
        if ok { "PASS" } else { "FAIL" }
    );
    exit(ok)
}

/// Resolves once the control interrupt has run a period after `seen`.
async fn next_period(seen: u32) -> u32 {
    poll_fn(|cx| {
        let now = PERIODS.load(Ordering::Acquire);
        if now != seen {
            return Poll::Ready(now);
        }
        cortex_m::interrupt::free(|cs| {
            PERIOD_WAKER.borrow(cs).replace(Some(cx.waker().clone()));
        });
        // A period may have ended between the load and the registration.
        let now = PERIODS.load(Ordering::Acquire);
        if now != seen {
            Poll::Ready(now)
        } else {
            Poll::Pending
        }
    })
    .await
}

/// The slower context's output: a semihosting handle of its own. `hprintln!` formats
/// inside a critical section, which would hold the control interrupt off while floats
/// are formatted; these writes mask nothing (each is one semihosting call, which an
/// interrupt cannot split).
struct Console(Option<hio::HostStream>);

impl Console {
    fn open() -> Self {
        Self(hio::hstdout().ok())
    }

    fn line(&mut self, args: core::fmt::Arguments<'_>) {
        if let Some(out) = self.0.as_mut() {
            // Nothing to do about a host that stopped listening.
            let _ = out.write_fmt(args).and_then(|()| out.write_str("\n"));
        }
    }
}

/// The slower context: the operator, woken once per control period.
#[embassy_executor::task]
async fn operator_task(
    mut operator: AxisOperator<f32>,
    mut send: Producer<'static, Command<AxisMachine>>,
    mut receive: Consumer<'static, Report<AxisMachine>>,
    jobs: &'static JobSlots<JointJob<1>>,
) {
    let mut console = Console::open();
    let mut printed_fit = false;
    let mut seen = PERIODS.load(Ordering::Acquire);
    operator.start(&mut send, jobs);
    loop {
        seen = next_period(seen).await;
        let state = operator.poll(&mut receive, &mut send, jobs);
        if let (Some(fit), false) = (operator.fit(), printed_fit) {
            printed_fit = true;
            let c = &fit.model.channels;
            console.line(format_args!(
                "kerf qemu smoke: calibrated: offsets {:.0} {:.0} {:.0} counts, gains {:.0} {:.0} {:.0} counts, third harmonic {:.2} {:.2} {:.2} %",
                c[0].offset_counts,
                c[1].offset_counts,
                c[2].offset_counts,
                c[0].amplitude_counts,
                c[1].amplitude_counts,
                c[2].amplitude_counts,
                c[0].harmonic3 * 100.0,
                c[1].harmonic3 * 100.0,
                c[2].harmonic3 * 100.0
            ));
        }
        match state {
            OperatorState::Finished => {
                OPERATOR_FINISHED.store(true, Ordering::Release);
                OPERATOR_DONE.store(true, Ordering::Release);
            }
            OperatorState::Failed(e) => {
                console.line(format_args!("kerf qemu smoke: operator gave up: {:?}", e));
                OPERATOR_DONE.store(true, Ordering::Release);
            }
            _ => {}
        }
    }
}

#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    if irqn == OperatorIrq.number() as i16 {
        // SAFETY: the executor was started on this line before it was unmasked.
        unsafe { OPERATOR_EXECUTOR.on_interrupt() }
    } else {
        // Only the operator's line is enabled: anything else is a bug, not a hang.
        hprintln!("kerf qemu smoke: unexpected exception {} -> FAIL", irqn);
        exit(false)
    }
}

#[entry]
fn main() -> ! {
    let mut scenario = Scenario::TRACKING;
    scenario.sensor = HallSensorParams::lm1247_imperfect(16, 4.0);
    scenario.calibrate = true;
    #[cfg(feature = "break-gain")]
    {
        // Deliberately detuned: 1 % of the position gain must miss the bounds.
        scenario.machine.axis.pd.kp_per_s2 *= 0.01;
    }
    let (Some(commands), Some(reports), Some(jobs)) = (
        cortex_m::singleton!(: Queue<Command<AxisMachine>, COMMAND_CAPACITY> = Queue::new()),
        cortex_m::singleton!(: Queue<Report<AxisMachine>, REPORT_CAPACITY> = Queue::new()),
        cortex_m::singleton!(: JobSlots<JointJob<1>> = JobSlots::new(JointJob::new(), JointJob::new())),
    ) else {
        exit(false)
    };
    let jobs: &'static JobSlots<JointJob<1>> = jobs;
    let (send, from_sender) = commands.split();
    let (to_operator, receive) = reports.split();
    let (rig, operator) = match (
        Rig::<f32>::new(&scenario, from_sender, to_operator, jobs),
        scenario.operator::<f32>(),
    ) {
        (Ok(rig), Ok(operator)) => (rig, operator),
        (Err(e), _) | (_, Err(e)) => {
            hprintln!("kerf qemu smoke: configuration rejected: {} -> FAIL", e);
            exit(false)
        }
    };
    cortex_m::interrupt::free(|cs| {
        CONTROL.borrow(cs).replace(Some(Control {
            rig,
            outcome: Outcome::with_window(f64::INFINITY, f64::INFINITY),
            periods: 0,
            limit: scenario.period_limit(),
            job_periods: scenario.periods,
            stack_by_mode: [0; MODES],
        }))
    });

    let Some(mut core) = cortex_m::Peripherals::take() else {
        exit(false)
    };
    // SAFETY: priorities are set before the executor starts and before SysTick runs.
    unsafe {
        core.SCB
            .set_priority(SystemHandler::SysTick, CONTROL_PRIORITY);
        core.NVIC.set_priority(OperatorIrq, OPERATOR_PRIORITY);
    }
    let spawner = OPERATOR_EXECUTOR.start(OperatorIrq);
    match operator_task(operator, send, receive, jobs) {
        Ok(task) => spawner.spawn(task),
        Err(_) => exit(false),
    }
    core.SYST.set_clock_source(SystClkSource::Core);
    core.SYST.set_reload(SYSTICK_RELOAD - 1);
    core.SYST.clear_current();
    core.SYST.enable_interrupt();
    core.SYST.enable_counter();
    loop {
        cortex_m::asm::wfi();
    }
}
