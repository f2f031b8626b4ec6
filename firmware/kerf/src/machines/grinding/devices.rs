//! The grinding cell's device link: the supervisor's slower task
//! turns the cell's outputs into the hexapod's PI GCS commands (docs/codec.md §31,
//! G app. D, [`crate::codec::gcs`]) and the spindle converter's frames (G 3.1.3,
//! app. B, [`crate::codec::spindle`]) once per tick, over the board's
//! [`Transact`] links, and checks every reply.
//!
//! # One tick
//!
//! Hexapod (a position device: MOV sets absolute targets, VLS the system velocity it
//! moves at, G app. D):
//! 1. The first tick, and the first after [`DeviceLinkState::reset`], reads the feed
//!    axis' position (POS?) as the path's origin.
//! 2. With a feed v > 0 the path p advances by v·T each tick of T: the link sends
//!    VLS v (when it changed by more than 1 %; at most the controller's limit) and
//!    MOV to the end of this tick's stretch, so the platform moves at v without
//!    stopping between ticks. With v = 0 nothing is sent: the last target is reached
//!    at the end of its tick and the platform stands.
//! 3. ERR? after the commands (GCS commands without '?' are not answered; a refused
//!    one sets the code ERR? reads and clears): a code other than 0 is
//!    [`HexapodFault::Controller`].
//! 4. POS? of the feed axis: farther from the path's start of the tick than the
//!    configured tolerance is [`HexapodFault::Following`] (a stalled or blocked
//!    platform). Any reply that does not parse is [`HexapodFault::Reply`].
//!
//! Spindle (binary frames, every request answered by three bytes, G app. B):
//! 1. A new speed (rounded to the protocol's 10 rpm) is sent as set speed, and a
//!    non-zero one is followed by start (G's sequence, app. B). The protocol has
//!    no stop request: the spindle stops on a set speed of 0.
//! 2. The spindle's measured rpm (0x43) is read every tick. A tick whose exchanges do
//!    not all answer in full counts as silent; `spindle_silent_ticks` silent ticks in a
//!    row are [`SpindleFault::Silent`]. Once `spindle_spin_up_s` has passed since the
//!    last speed change, a measured speed off the command by more than the tolerance
//!    for `spindle_speed_ticks` ticks in a row is [`SpindleFault::Speed`].
//!
//! # Faults
//!
//! A fault latches in the state and is returned by every later tick until
//! [`DeviceLinkState::reset`]. In the tick it happens the link sends the hexapod's
//! HLT (the halt the codec has; the controller answers it with error 10, which the
//! link then reads away) and the spindle's set speed 0. The slower task hands the
//! fault to the control period in [`super::GrindingInputs::device_fault`], where the
//! cell turns it into [`super::GrindingFault::Hexapod`] or
//! [`super::GrindingFault::Spindle`] and writes its safe outputs (piezo retracted,
//! feed 0, spindle off) in the same period. A cell that faults for its own reason
//! asks for the same halt through [`DeviceDemand::halt`].
//!
//! Everything is sized at compile time ([`MAX_COMMAND_LEN`], [`MAX_REPLY_LEN`] on
//! the stack), and no step can panic.

use super::GrindingOutputs;
use crate::codec::gcs::{
    self, Axis, AxisSet, AxisValues, Command, GcsError, MAX_COMMAND_LEN, MAX_REPLY_LEN,
};
use crate::codec::spindle::{SpindleError, SpindleReading, SpindleRequest, REPLY_BYTES};
use crate::error::{positive, ConfigError};
use crate::hal::{LinkError, Transact};
use crate::scalar::{to_f64, Float};

#[cfg(test)]
mod tests;

/// The device link's settings, in SI units (the hexapod's own units, mm and mm/s, only
/// where its protocol speaks them).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DeviceLinkConfig {
    /// Tick of the slower task, s.
    pub tick_s: f64,
    /// The hexapod axis the cell's feed moves along (+ in the feed's direction).
    pub feed_axis: Axis,
    /// Largest VLS the controller takes, mm/s.
    pub max_velocity_mm_s: f64,
    /// Largest distance between the platform and the path, mm.
    pub following_tolerance_mm: f64,
    /// Silent ticks in a row that fault the spindle.
    pub spindle_silent_ticks: u16,
    /// Time the spindle is given to reach a new speed, s.
    pub spindle_spin_up_s: f64,
    /// Largest |measured − commanded| as a fraction of the command.
    pub spindle_tolerance: f64,
    /// Smallest speed error that counts, rpm (near a command of 0).
    pub spindle_tolerance_floor_rpm: f64,
    /// Ticks in a row off speed (after the spin-up) that fault the spindle.
    pub spindle_speed_ticks: u16,
}

impl DeviceLinkConfig {
    /// G's cell: a 10 ms tick (ten control periods of 1 ms, G 7: fast enough
    /// for G's 0.1 mm/s feed, 1 µm of path a tick); the H-824 hexapod (G app.
    /// A: 1 mm/s at most) fed along X; a following tolerance of 20 µm (two ticks at the
    /// controller's largest velocity: a POS? may land anywhere in the tick's move, and
    /// G's 0.1 mm/s feed takes 0.2 s to leave it behind); a spindle fault after
    /// 5 silent ticks (50 ms: five chances for the 115200-baud converter, whose
    /// 3-byte reply takes 0.26 ms, to answer); and the speed checked 2 s after a
    /// change (G gives no spin-up time; 2 s is four time constants of the
    /// 0.5 s of `hal-mock`'s spindle, 98 % of a step) to 10 % of the command or
    /// 500 rpm, whichever is larger, for 10 ticks in a row.
    pub const PUBLISHED: Self = Self {
        tick_s: 0.01,
        feed_axis: Axis::X,
        max_velocity_mm_s: 1.0,
        following_tolerance_mm: 0.02,
        spindle_silent_ticks: 5,
        spindle_spin_up_s: 2.0,
        spindle_tolerance: 0.1,
        spindle_tolerance_floor_rpm: 500.0,
        spindle_speed_ticks: 10,
    };
}

/// Why the hexapod's link faulted.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HexapodFault {
    /// The controller reported this GCS error code (ERR? ≠ 0; PI's numbering,
    /// [`crate::codec::gcs::code`]).
    Controller(i32),
    /// A reply did not parse, or a command could not be written.
    Reply(GcsError),
    /// The link itself failed.
    Link(LinkError),
    /// The platform is this far from the path, mm.
    Following {
        /// Position minus path, mm.
        error_mm: f32,
    },
}

/// Why the spindle's link faulted.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SpindleFault {
    /// The converter left this many ticks in a row without a full answer.
    Silent {
        /// Silent ticks.
        ticks: u16,
    },
    /// The spindle stayed off its command after the spin-up time.
    Speed {
        /// Commanded, rpm.
        commanded_rpm: u32,
        /// Last measured, rpm.
        measured_rpm: u32,
    },
    /// A speed the protocol cannot carry (rpm/10 beyond 16 bits).
    Request(SpindleError),
    /// The link itself failed.
    Link(LinkError),
}

/// A device fault, as the slower task hands it to the cell.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DeviceFault {
    /// The hexapod.
    Hexapod(HexapodFault),
    /// The spindle.
    Spindle(SpindleFault),
}

/// What the devices are asked to do this tick.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DeviceDemand {
    /// Feed along the feed axis, m/s (≤ 0 or not finite: stand).
    pub feed_m_s: f64,
    /// Spindle speed, rpm (≤ 0 or not finite: stop).
    pub spindle_rpm: f64,
    /// The cell is in a fault: halt the hexapod and stop the spindle.
    pub halt: bool,
}

impl DeviceDemand {
    /// The demand of the cell's latest outputs; `halt` when its supervisor is in
    /// `Mode::Fault`.
    pub fn from_outputs<T: Float>(outputs: &GrindingOutputs<T>, halt: bool) -> Self {
        Self {
            feed_m_s: to_f64(outputs.hexapod_feed_m_s),
            spindle_rpm: to_f64(outputs.spindle_rpm),
            halt,
        }
    }
}

/// What a healthy tick saw.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DeviceReport {
    /// The feed axis' position read this tick, mm.
    pub position_mm: f64,
    /// The path's position at the end of this tick, mm (the last MOV).
    pub path_mm: f64,
    /// The spindle's measured speed, rpm, if it answered.
    pub spindle_rpm: Option<u32>,
    /// The hexapod is halted (the cell is in a fault).
    pub halted: bool,
}

/// The link's coefficients (validated settings).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DeviceLink {
    tick_s: f64,
    axis: Axis,
    max_velocity_mm_s: f64,
    following_mm: f64,
    silent_ticks: u16,
    spin_up_ticks: u32,
    tolerance: f64,
    tolerance_floor_rpm: f64,
    speed_ticks: u16,
}

/// The link's state: the path, the spindle's last command and counters, the latched
/// fault.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct DeviceLinkState {
    /// The path's position, mm (None: read it from the hexapod first).
    path_mm: Option<f64>,
    /// The last VLS sent, mm/s.
    velocity_mm_s: Option<f64>,
    /// HLT has been sent for the present halt.
    halted: bool,
    /// The last set speed sent, rpm (a multiple of 10).
    set_rpm: Option<u32>,
    started: bool,
    ticks_since_set: u32,
    silent: u16,
    off_speed: u16,
    fault: Option<DeviceFault>,
}

impl DeviceLinkState {
    /// A link that has sent nothing yet.
    pub const fn new() -> Self {
        Self {
            path_mm: None,
            velocity_mm_s: None,
            halted: false,
            set_rpm: None,
            started: false,
            ticks_since_set: 0,
            silent: 0,
            off_speed: 0,
            fault: None,
        }
    }

    /// The latched fault, if any.
    pub fn fault(&self) -> Option<DeviceFault> {
        self.fault
    }

    /// Leaves a fault (with the cell's `ResetFault`): the path restarts from where
    /// the hexapod stands, the spindle's speed is sent anew.
    pub fn reset(&mut self) {
        *self = Self::new();
    }
}

/// A GCS exchange: the command written, its reply (if it has one) read into `reply`.
fn exchange<'r>(
    link: &mut impl Transact,
    command: &Command,
    reply: &'r mut [u8; MAX_REPLY_LEN],
) -> Result<&'r [u8], HexapodFault> {
    let mut buf = [0u8; MAX_COMMAND_LEN];
    let len = command.encode(&mut buf).map_err(HexapodFault::Reply)?;
    let request = buf.get(..len).unwrap_or(&[]);
    let expected: &mut [u8] = if command.expects_reply() {
        reply
    } else {
        &mut []
    };
    let got = link
        .transact(request, expected)
        .map_err(HexapodFault::Link)?;
    Ok(expected.get(..got).unwrap_or(&[]))
}

/// ERR?, with the code as a fault unless it is 0 (or `allowed`).
fn check_errors(link: &mut impl Transact, allowed: i32) -> Result<(), HexapodFault> {
    let mut reply = [0u8; MAX_REPLY_LEN];
    let bytes = exchange(link, &Command::ErrQuery, &mut reply)?;
    let code = gcs::parse_error_code(bytes).map_err(HexapodFault::Reply)?;
    if code == allowed {
        return Ok(());
    }
    gcs::check_error(code).map_err(|_| HexapodFault::Controller(code))
}

/// One spindle exchange: `Ok(None)` when the converter did not answer in full.
fn ask_spindle(
    link: &mut impl Transact,
    request: SpindleRequest,
) -> Result<Option<SpindleReading>, SpindleFault> {
    let mut buf = [0u8; 3];
    let bytes = request.encode(&mut buf).map_err(SpindleFault::Request)?;
    let mut reply = [0u8; REPLY_BYTES];
    let got = link
        .transact(bytes, &mut reply)
        .map_err(SpindleFault::Link)?;
    Ok(request.decode(reply.get(..got).unwrap_or(&[])).ok())
}

impl DeviceLink {
    /// Validates `config`: positive tick, velocity, tolerances, spin-up and counts.
    pub fn new(config: &DeviceLinkConfig) -> Result<Self, ConfigError> {
        let tick_s = positive("tick_s", config.tick_s)?;
        let spin_up = positive("spindle_spin_up_s", config.spindle_spin_up_s)?;
        if config.spindle_silent_ticks == 0 {
            return Err(ConfigError::not_positive("spindle_silent_ticks"));
        }
        if config.spindle_speed_ticks == 0 {
            return Err(ConfigError::not_positive("spindle_speed_ticks"));
        }
        let ticks = libm::ceil(spin_up / tick_s);
        if ticks > f64::from(u32::MAX) {
            return Err(ConfigError::out_of_range("spindle_spin_up_s"));
        }
        Ok(Self {
            tick_s,
            axis: config.feed_axis,
            max_velocity_mm_s: positive("max_velocity_mm_s", config.max_velocity_mm_s)?,
            following_mm: positive("following_tolerance_mm", config.following_tolerance_mm)?,
            silent_ticks: config.spindle_silent_ticks,
            spin_up_ticks: ticks as u32,
            tolerance: positive("spindle_tolerance", config.spindle_tolerance)?,
            tolerance_floor_rpm: positive(
                "spindle_tolerance_floor_rpm",
                config.spindle_tolerance_floor_rpm,
            )?,
            speed_ticks: config.spindle_speed_ticks,
        })
    }

    /// One tick (module docs): the demand to the devices, their replies checked. A
    /// fault (new or latched) is returned after the halt and the stop are sent.
    pub fn tick(
        &self,
        state: &mut DeviceLinkState,
        demand: &DeviceDemand,
        hexapod: &mut impl Transact,
        spindle: &mut impl Transact,
    ) -> Result<DeviceReport, DeviceFault> {
        if let Some(fault) = state.fault {
            return Err(fault);
        }
        let result = self
            .hexapod_tick(state, demand, hexapod)
            .map_err(DeviceFault::Hexapod)
            .and_then(|(position_mm, path_mm)| {
                let rpm = if demand.halt { 0.0 } else { demand.spindle_rpm };
                self.spindle_tick(state, rpm, spindle)
                    .map_err(DeviceFault::Spindle)
                    .map(|spindle_rpm| DeviceReport {
                        position_mm,
                        path_mm,
                        spindle_rpm,
                        halted: demand.halt,
                    })
            });
        if let Err(fault) = result {
            state.fault = Some(fault);
            // The halt and the stop, whatever failed (a dead link refuses them too).
            if !state.halted {
                let _ = exchange(
                    hexapod,
                    &Command::Hlt(AxisSet::EMPTY),
                    &mut [0; MAX_REPLY_LEN],
                );
                let _ = check_errors(hexapod, gcs::code::STOPPED);
                state.halted = true;
            }
            let _ = ask_spindle(spindle, SpindleRequest::SetSpeed { rpm: 0 });
            state.set_rpm = Some(0);
        }
        result
    }

    /// The position read and the path at the end of the tick, mm.
    fn hexapod_tick(
        &self,
        state: &mut DeviceLinkState,
        demand: &DeviceDemand,
        link: &mut impl Transact,
    ) -> Result<(f64, f64), HexapodFault> {
        let mut reply = [0u8; MAX_REPLY_LEN];
        let axes = AxisSet::EMPTY.with(self.axis);
        if demand.halt {
            if !state.halted {
                exchange(link, &Command::Hlt(AxisSet::EMPTY), &mut reply)?;
                check_errors(link, gcs::code::STOPPED)?;
                state.halted = true;
                state.path_mm = None;
                state.velocity_mm_s = None;
            }
        } else if state.halted {
            state.halted = false;
        }
        let start = match state.path_mm {
            Some(p) => p,
            None => self.position(link, &mut reply)?,
        };
        let feed_mm_s = demand.feed_m_s * 1e3;
        let mut path = start;
        if !demand.halt && feed_mm_s > 0.0 && feed_mm_s.is_finite() {
            let v = feed_mm_s.min(self.max_velocity_mm_s);
            let changed = match state.velocity_mm_s {
                Some(last) => libm::fabs(v - last) > 0.01 * last,
                None => true,
            };
            if changed {
                exchange(link, &Command::Vls(v), &mut reply)?;
                state.velocity_mm_s = Some(v);
            }
            path = start + feed_mm_s * self.tick_s;
            let mut target = AxisValues::new();
            target.set(self.axis, path);
            exchange(link, &Command::Mov(target), &mut reply)?;
        }
        check_errors(link, gcs::code::NO_ERROR)?;
        let bytes = exchange(link, &Command::PosQuery(axes), &mut reply)?;
        let position = gcs::parse_axis_values(bytes)
            .map_err(HexapodFault::Reply)?
            .get(self.axis)
            .ok_or(HexapodFault::Reply(GcsError::Malformed))?;
        let error = position - start;
        if libm::fabs(error) > self.following_mm && state.path_mm.is_some() {
            return Err(HexapodFault::Following {
                error_mm: error as f32,
            });
        }
        state.path_mm = Some(if demand.halt { position } else { path });
        Ok((position, path))
    }

    /// POS? of the feed axis, mm.
    fn position(
        &self,
        link: &mut impl Transact,
        reply: &mut [u8; MAX_REPLY_LEN],
    ) -> Result<f64, HexapodFault> {
        let bytes = exchange(
            link,
            &Command::PosQuery(AxisSet::EMPTY.with(self.axis)),
            reply,
        )?;
        gcs::parse_axis_values(bytes)
            .map_err(HexapodFault::Reply)?
            .get(self.axis)
            .ok_or(HexapodFault::Reply(GcsError::Malformed))
    }

    /// The spindle's measured speed, if it answered.
    fn spindle_tick(
        &self,
        state: &mut DeviceLinkState,
        rpm: f64,
        link: &mut impl Transact,
    ) -> Result<Option<u32>, SpindleFault> {
        // Rounded to the protocol's 10 rpm; beyond u32 the request refuses it.
        let wanted = if rpm > 0.0 && rpm.is_finite() {
            (libm::round(rpm / 10.0).min(f64::from(u32::MAX / 10)) as u32) * 10
        } else {
            0
        };
        let mut answered = true;
        if state.set_rpm != Some(wanted) {
            let done = ask_spindle(link, SpindleRequest::SetSpeed { rpm: wanted })?;
            answered &= done.is_some();
            if done.is_some() {
                state.set_rpm = Some(wanted);
                state.started = false;
                state.ticks_since_set = 0;
                state.off_speed = 0;
            }
        }
        if answered && wanted > 0 && !state.started {
            let done = ask_spindle(link, SpindleRequest::Start)?;
            answered &= done.is_some();
            state.started = done.is_some();
        }
        let measured = match ask_spindle(link, SpindleRequest::SpindleRpm)? {
            Some(SpindleReading::Rpm(rpm)) => Some(rpm),
            _ => None,
        };
        answered &= measured.is_some();
        state.silent = if answered {
            0
        } else {
            state.silent.saturating_add(1)
        };
        if state.silent >= self.silent_ticks {
            return Err(SpindleFault::Silent {
                ticks: state.silent,
            });
        }
        state.ticks_since_set = state.ticks_since_set.saturating_add(1);
        if let (Some(measured), Some(set)) = (measured, state.set_rpm) {
            let error = libm::fabs(f64::from(measured) - f64::from(set));
            let allowed = (self.tolerance * f64::from(set)).max(self.tolerance_floor_rpm);
            let settled = state.ticks_since_set > self.spin_up_ticks;
            state.off_speed = if settled && error > allowed {
                state.off_speed.saturating_add(1)
            } else {
                0
            };
            if state.off_speed >= self.speed_ticks {
                return Err(SpindleFault::Speed {
                    commanded_rpm: set,
                    measured_rpm: measured,
                });
            }
        }
        Ok(measured)
    }
}
