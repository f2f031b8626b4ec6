//! What the application needs from a board: one period's inputs sampled together,
//! one period's outputs written together, a monotonic tick, and a link for frames.
//!
//! A board implements these with its ADC DMA buffer (every Hall channel of every axis
//! converted on the same timer trigger) and its current-loop or PWM outputs; `hal-mock`
//! implements them with simulated machines. [`crate::app::control_period`] is the one
//! place that calls them, from the control interrupt.

/// All inputs of a control period, sampled together: `I` is one period's samples (for
/// Hall axes, raw counts `[u1, u2, u3]` per axis).
pub trait SampleInputs<I> {
    /// The latest complete set of samples.
    fn sample(&mut self) -> I;
}

/// All outputs of a control period, written together: `O` is one period's commands
/// (for linear-motor axes, the force of each in N).
pub trait WriteOutputs<O> {
    /// Applies `outputs`. Must accept the machine's safe outputs at any time.
    fn write(&mut self, outputs: &O);
}

/// One period's commands to `N` force-driven axes and a laser, written together (the
/// laser cutting machines' outputs).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ForceAndLaser<T, const N: usize> {
    /// Force of each axis, N.
    pub force_n: [T; N],
    /// The laser's PWM duty in [0, 1] (power / the source's maximum power).
    pub laser_duty: T,
}

/// A tick counter that only counts up and never wraps in a machine's life: 64 bits
/// (a 170 MHz timer extended in software wraps after 3,400 years). The app reads it
/// once per control period to find periods that came late.
pub trait Monotonic {
    /// Ticks per second.
    fn tick_hz(&self) -> u64;
    /// The present tick.
    fn now(&mut self) -> u64;
}

/// A link that carries whole frames, one packet each, and never blocks: a UART or USB
/// CDC endpoint with framing, a network socket. [`crate::app::stream`] sends a
/// machine's signals over it.
pub trait FrameLink {
    /// Sends `frame`, or refuses it at once when the link cannot take it now.
    fn send(&mut self, frame: &[u8]) -> Result<(), LinkBusy>;
    /// Copies the next received frame into `buf` and returns its length. A frame
    /// longer than `buf` is dropped (the link counts it).
    fn receive(&mut self, buf: &mut [u8]) -> Option<usize>;
}

/// The link could not take a frame now (its queue is full, or the frame is longer
/// than it carries).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkBusy;

/// A request/reply byte link to a device on a serial line or a socket (the grinding
/// cell's hexapod controller and spindle converter, docs/codec.md §31): the
/// request is written whole, then the reply read until the device's framing says it
/// is complete or the link's reply timeout expires. Called from a slower task than
/// the control period; a board bounds the wait with its timeout.
pub trait Transact {
    /// Writes `request` and reads the reply into `reply`; returns the bytes received
    /// (0: the device stayed silent for the whole timeout; fewer than a full reply: it
    /// stopped mid-reply). An empty `reply` means no answer is expected: the call
    /// returns once the request is written.
    fn transact(&mut self, request: &[u8], reply: &mut [u8]) -> Result<usize, LinkError>;
}

/// The link itself failed (not the device: a silent device is `Ok(0)`).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinkError {
    /// The port or socket is not open (cable out, connection closed).
    Down,
    /// The request could not be written whole (the transmit queue is full).
    Busy,
    /// More bytes arrived than `reply` holds (the rest were dropped).
    Overrun,
}
