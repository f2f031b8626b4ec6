//! The slower context: the host link on LPUART1 (received by DMA into a ring, sent by
//! DMA), driven by `kerf::app::host_link::HostLink` exactly as the QEMU link images
//! drive it, for any machine, plus what only a board has: the calibration run from
//! the user button (for a machine with a sweep, [`SweepFit`]), the cause of the last
//! reset told to the host, the status log and the watchdog's sign of life.
//!
//! The task wakes on received bytes and on the control interrupt's tick (every
//! millisecond); it never blocks the control interrupt, which preempts it.

use super::clocks::LINK_PRIORITY;
use super::clocks::SYSCLK_HZ;
use super::fault::{Cause, ResetCause};
use super::period::{FIT_RUNNING, LINK_ALIVE, LINK_TICK};
use super::pins::PinId;
use super::timing::{CycleClock, KERF_STATUS};
use core::sync::atomic::Ordering;
use embassy_futures::select::{select, Either};
use embassy_stm32::interrupt::typelevel::{Binding, Interrupt};
use embassy_stm32::interrupt::Priority;
use embassy_stm32::mode::Async;
use embassy_stm32::usart::{self, RingBufferedUartRx, UartTx};
use embassy_stm32::{dma, Peri};
use heapless::spsc::{Consumer, Producer};
use kerf::app::host_link::{HostLink, LinkMachine};
use kerf::app::supervisor::{Command, Machine, Mode, NoSweep, Report};
use kerf::codec::link::BOARD_FAULT;
use kerf::hal::Monotonic;

/// LPUART1's baud rate: the ST-LINK V3 virtual COM port carries it; a telemetry
/// sample every millisecond (about 70 bytes) needs 700 kBd.
pub const LINK_BAUD: u32 = 921_600;

/// The host link's received bytes: 1024 last 11 ms at 921 600 Bd, ten link ticks.
pub const RX_RING_BYTES: usize = 1024;

/// The host link's UART with DMA both ways, its interrupt below the control
/// interrupt, reception into `ring` (typed pins and DMA channels: only those that
/// serve this UART compile). The image binds the interrupts (`bind_interrupts!`).
///
/// Errors: the UART's configuration refused (a baud rate it cannot make).
#[allow(clippy::too_many_arguments)]
pub fn host_uart<T, D1, D2>(
    peri: Peri<'static, T>,
    rx: Peri<'static, impl usart::RxPin<T>>,
    tx: Peri<'static, impl usart::TxPin<T>>,
    tx_dma: Peri<'static, D1>,
    rx_dma: Peri<'static, D2>,
    irqs: impl Binding<T::Interrupt, usart::InterruptHandler<T>>
        + Binding<D1::Interrupt, dma::InterruptHandler<D1>>
        + Binding<D2::Interrupt, dma::InterruptHandler<D2>>
        + 'static,
    ring: &'static mut [u8],
) -> Result<(UartTx<'static, Async>, RingBufferedUartRx<'static>), usart::ConfigError>
where
    T: usart::Instance,
    D1: usart::TxDma<T>,
    D2: usart::RxDma<T>,
{
    let mut config = usart::Config::default();
    config.baudrate = LINK_BAUD;
    let uart = usart::Uart::new(peri, rx, tx, tx_dma, rx_dma, irqs, config)?;
    T::Interrupt::set_priority(Priority::from(LINK_PRIORITY));
    let (tx, rx) = uart.split();
    Ok((tx, rx.into_ring_buffered(ring)))
}

/// A machine's calibration sweep as the board runs it from the button: the samples
/// the sweep streams, then the fit, in the link task. A machine without a sweep uses
/// [`Stored`] (a sweep without samples: the calibration it finishes with is stored).
pub trait SweepFit<M: Machine> {
    /// Whether the machine has a sweep (the button starts one).
    const SWEEPS: bool;
    /// Forgets the samples of an earlier sweep.
    fn restart(&mut self);
    /// Keeps one sample; false when it is refused (logged).
    fn push(&mut self, sample: &M::SweepSample) -> bool;
    /// Fits the samples into a calibration (tens of kilobytes of stack, preempted by
    /// every control period) and hands it to `install`; nothing when the fit failed
    /// (logged by the fit). Handed on from the fit's frame rather than returned, so
    /// that the calibration (kilobytes) and the command it becomes are not held in
    /// the frame under the fit's deepest calls.
    fn fit(&mut self, install: &mut dyn FnMut(M::Calibration));
}

/// The sweep of a machine that streams no samples and needs no fit: what it
/// finishes with is stored (the grinding cell's bias capture, finished with the
/// tool's measured eccentricity; ARROW's empty sweep). The button runs it again.
pub struct Stored<C: Copy>(pub C);

impl<M: Machine<SweepSample = NoSweep>> SweepFit<M> for Stored<M::Calibration>
where
    M::Calibration: Copy,
{
    const SWEEPS: bool = true;
    fn restart(&mut self) {}
    fn push(&mut self, sample: &NoSweep) -> bool {
        match *sample {}
    }
    fn fit(&mut self, install: &mut dyn FnMut(M::Calibration)) {
        install(self.0);
    }
}

/// Queues a fitted calibration for the supervisor. Out of line: the command it builds
/// and the queue's copy of it are kilobytes that would otherwise sit in the frame of
/// the fit's caller, under the fit's deepest calls.
#[inline(never)]
fn queue_calibration<M: Machine>(
    commands: &mut Producer<'static, Command<M>>,
    calibration: M::Calibration,
) {
    if commands
        .enqueue(Command::FinishCalibration(calibration))
        .is_err()
    {
        defmt::warn!("calibration: command queue full, fit dropped");
    }
}

/// Bytes queued for the UART per wake-up: a telemetry sample, a few replies and
/// events (a frame is at most 262 bytes); 11 ms of the line at 921 600 Bd.
const OUT_BYTES: usize = 1024;

/// What the link task owns, for machine `M` with an uploaded job of up to `J` bytes
/// and its sweep fit `F`.
pub struct LinkTask<M: LinkMachine + 'static, F: SweepFit<M> + 'static, const J: usize> {
    /// The host link.
    pub link: HostLink<'static, M, J>,
    /// Commands to the supervisor.
    pub commands: Producer<'static, Command<M>>,
    /// Reports from it.
    pub reports: Consumer<'static, Report<M>>,
    /// Received bytes.
    pub rx: RingBufferedUartRx<'static>,
    /// The transmitter.
    pub tx: UartTx<'static, Async>,
    /// The calibration sweep's samples and fit (kept in a static).
    pub fit: &'static mut F,
    /// Why the board last reset.
    pub reset: ResetCause,
    /// The calibrate button (high while pressed).
    pub button: PinId,
    /// The control rate, Hz (for the fit's duration in the log).
    pub control_hz: u32,
}

/// Where the task is.
struct State<F> {
    mode: Mode<F>,
    /// The held board fault went to the link.
    held_told: bool,
    calibrating: bool,
    /// The sweep is done: the fit runs next, from the task's own frame.
    fit_due: bool,
    button_was: bool,
    ticks: u32,
}

/// Appends frames to `out`; false when it is full (the link counts it as unsent).
fn queue(out: &mut heapless::Vec<u8, OUT_BYTES>, frame: &[u8]) -> bool {
    out.extend_from_slice(frame).is_ok()
}

impl<M: LinkMachine + 'static, F: SweepFit<M> + 'static, const J: usize> LinkTask<M, F, J> {
    /// Runs the link for ever.
    pub async fn run(&mut self) -> ! {
        let mut clock = CycleClock::new();
        let mut out = heapless::Vec::<u8, OUT_BYTES>::new();
        let mut state = State {
            mode: Mode::Idle,
            held_told: false,
            calibrating: false,
            fit_due: false,
            button_was: false,
            ticks: 0,
        };
        let mut chunk = [0u8; 64];
        // The cause of the last reset, when it was a fault: sent now (a host may not
        // be listening yet) and kept by the link as the last fault that `Status`
        // reports, so that a host connecting later reads it.
        if let Some((code, detail)) = self.reset.event() {
            self.link
                .board_fault(code, detail, &mut |frame| queue(&mut out, frame));
        }
        loop {
            let now_s = clock.now() as f64 / f64::from(SYSCLK_HZ);
            LINK_ALIVE.fetch_add(1, Ordering::Relaxed);
            match select(self.rx.read(&mut chunk), LINK_TICK.wait()).await {
                Either::First(Ok(n)) => {
                    self.receive(chunk.get(..n).unwrap_or(&[]), now_s, &mut out);
                }
                // The ring overran (the task was held off longer than the ring
                // lasts): the frames in it are lost, and the next read restarts
                // the reception; the host repeats unanswered requests.
                Either::First(Err(e)) => defmt::warn!("link: receive error {}", e),
                Either::Second(()) => {
                    let mut send = |frame: &[u8]| queue(&mut out, frame);
                    self.tick(&mut state, now_s, &mut send);
                }
            }
            if state.fit_due {
                // Called here rather than from `tick`, whose frame would lie under the
                // fit's (tens of kilobytes).
                state.fit_due = false;
                self.finish_calibration(&mut state);
            }
            self.tell_held_fault(&mut state, &mut out);
            if !out.is_empty() {
                if self.tx.write(&out).await.is_err() {
                    defmt::warn!("link: transmit error");
                }
                out.clear();
            }
            if super::store::restart_due() {
                // A settings save stopped the control; its reply is out.
                defmt::info!("settings saved: restarting");
                cortex_m::peripheral::SCB::sys_reset();
            }
        }
    }

    /// The host's bytes into the link. Out of line, as [`LinkTask::tick`]: what the
    /// link builds on the stack (frames, an uploaded job, a command) stays out of the
    /// task's poll frame, which lies under the calibration fit's.
    #[inline(never)]
    fn receive(&mut self, bytes: &[u8], now_s: f64, out: &mut heapless::Vec<u8, OUT_BYTES>) {
        let mut send = |frame: &[u8]| queue(out, frame);
        for &b in bytes {
            self.link.receive(b, now_s, &mut self.commands, &mut send);
        }
    }

    /// The millisecond tick: reports, heartbeat, the button, the status log.
    #[inline(never)]
    fn tick(
        &mut self,
        state: &mut State<M::Fault>,
        now_s: f64,
        send: &mut dyn FnMut(&[u8]) -> bool,
    ) {
        while let Some(report) = self.reports.dequeue() {
            match &report {
                Report::ModeChanged { mode, .. } => state.mode = *mode,
                Report::CalibrationSample(sample) if !self.fit.push(sample) => {
                    defmt::warn!("calibration: sample refused");
                }
                Report::SweepDone => state.fit_due = true,
                _ => {}
            }
            self.link.report(&report, &mut *send);
        }
        self.link.tick(now_s, &mut self.commands, &mut *send);
        let pressed = self.button.read();
        let ready = matches!(state.mode, Mode::Idle | Mode::Ready);
        if F::SWEEPS && pressed && !state.button_was && ready && !state.calibrating {
            self.fit.restart();
            if self.commands.enqueue(Command::Calibrate).is_ok() {
                state.calibrating = true;
                defmt::info!("calibration: sweep started");
            }
        }
        state.button_was = pressed;
        state.ticks = state.ticks.wrapping_add(1);
        if state.ticks % 1000 == 0 {
            log_status(&self.link);
        }
    }

    /// The sweep is done: fit (in this task, preempted by every control period) and
    /// install the fit.
    #[inline(never)]
    fn finish_calibration(&mut self, state: &mut State<M::Fault>) {
        state.calibrating = false;
        FIT_RUNNING.store(true, Ordering::Relaxed);
        // Timed in control periods, which go on above the fit (the cycle counter
        // would wrap on a fit longer than 25 s).
        let start = KERF_STATUS.periods.load(Ordering::Relaxed);
        let commands = &mut self.commands;
        self.fit
            .fit(&mut |calibration| queue_calibration(commands, calibration));
        let periods = KERF_STATUS
            .periods
            .load(Ordering::Relaxed)
            .wrapping_sub(start);
        let fit_ms = periods / (self.control_hz / 1000).max(1);
        // A sign of life before the check resumes, which would otherwise find the
        // task silent since the fit began.
        LINK_ALIVE.fetch_add(1, Ordering::Relaxed);
        FIT_RUNNING.store(false, Ordering::Relaxed);
        defmt::info!("calibration: fit took {} ms", fit_ms);
    }

    /// A board fault that holds the outputs off without a reset (the break input),
    /// once: to the host as a fault event, kept as the last fault for `Status`.
    fn tell_held_fault(
        &mut self,
        state: &mut State<M::Fault>,
        out: &mut heapless::Vec<u8, OUT_BYTES>,
    ) {
        let held = KERF_STATUS.held_fault.load(Ordering::Relaxed);
        if held != 0 && !state.held_told {
            state.held_told = true;
            self.link
                .board_fault(BOARD_FAULT | held as u16, 0, &mut |frame| queue(out, frame));
            defmt::error!("outputs held off by {}", Cause::Break);
        }
    }
}

/// The status line, once a second.
fn log_status<M: LinkMachine, const J: usize>(link: &HostLink<M, J>) {
    let s = &KERF_STATUS;
    let counters = link.counters();
    defmt::info!(
        "status: periods {} step worst {} last {} cycles, finish worst {} of {} cycles, late {}, link bad {} unsent {}, stack used {} B",
        s.periods.load(Ordering::Relaxed),
        s.worst_step_cycles.load(Ordering::Relaxed),
        s.last_step_cycles.load(Ordering::Relaxed),
        s.worst_finish_cycles.load(Ordering::Relaxed),
        KERF_STATUS.period_cycles.load(Ordering::Relaxed),
        s.late_periods.load(Ordering::Relaxed),
        counters.bad_frames,
        counters.unsent,
        super::stack::used()
    );
}
