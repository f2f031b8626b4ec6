//! A CANopen master for N CiA 402 servo drives in cyclic synchronous torque mode
//! (mode 10) on up to [`MAX_BUSES`] CAN FD buses of one or two drives each
//! (docs/drives.md: frame layout, bus timing, objects).
//!
//! The master is frame-oriented and owns no peripheral. Each control period the
//! board calls, in this order:
//!
//! 1. [`DriveSet::start_period`] at the period's tick: it emits, per bus, the SYNC
//!    and the RPDO that carries both drives' controlword 0x6040 and target torque
//!    0x6071 (during bring-up: the NMT and SDO frames of the present step);
//! 2. [`DriveSet::receive`] for every frame the buses deliver (TPDOs, SDO
//!    responses, EMCY, heartbeats), whenever they arrive;
//! 3. [`DriveSet::feedback`] once the period's TPDOs are in: the positions in m,
//!    after checking that every drive's TPDO arrived since the SYNC and that every
//!    statusword 0x6041 says Operation enabled;
//! 4. [`DriveSet::command`] with the period's forces: they go out with the next
//!    period's SYNC, and the drives apply them at the SYNC after (transmission type
//!    1), two periods after the positions they were computed from were sampled.
//!
//! Bring-up ([`bring_up`]) runs in [`DriveSet::start_period`]: NMT reset node →
//! boot-up heard → SDO: mode 0x6060 = 10, read back 0x6061, the rated force 0x6076
//! read, max torque 0x6072 and heartbeat producer 0x1017 written → NMT start →
//! controlword 0x06 → 0x07 → 0x0F to Operation enabled (a drive in Fault gets one
//! fault reset, the rising edge of bit 7). Every step has a timeout in periods.
//!
//! Any fault ([`DriveFault`], printable in words) latches: from then on the RPDOs
//! carry the controlword Quick stop (0x02) and zero torque, and the SYNC keeps
//! running so the drives stay under their master's control.

pub mod bring_up;

use crate::codec::canopen::{cob, sync, CanFrame, Emergency, NmtState, Od, Received, SdoAbort};
use crate::codec::cia402::{self, cw, CstCommand, DriveState};
use crate::error::{positive, ConfigError};
use crate::scalar::Float;
use bring_up::BringUp;
pub use bring_up::BringUpStep;
use core::fmt;

/// Most buses a set spans.
pub const MAX_BUSES: usize = 8;

pub use crate::codec::canopen::DriveAddress;

/// A drive set as configured.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DriveSetConfig<const N: usize> {
    /// The drives; the first on a bus takes the RPDO's slot 0, the second slot 1.
    pub drives: [DriveAddress; N],
    /// The position encoder's increment (0x6064's unit), m.
    pub increment_m: f64,
    /// The force limit written to max torque 0x6072 (per mille of the rated force
    /// 0x6076 each drive reports), N.
    pub max_force_n: f64,
    /// Heartbeat producer time written to 0x1017, ms (0 = none).
    pub heartbeat_ms: u16,
    /// Periods to wait for a drive's boot-up after NMT reset node.
    pub boot_timeout_periods: u32,
    /// Periods to wait for an SDO response.
    pub sdo_timeout_periods: u32,
    /// Periods from NMT start to Operation enabled.
    pub enable_timeout_periods: u32,
    /// Consecutive periods without a drive's TPDO that are a fault (1 = the first).
    pub silent_periods: u8,
}

/// Why the set stopped (latched; [`fmt::Display`] gives it in words).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DriveFault {
    /// Drive `drive` (index in the set) left Operation enabled; its statusword now.
    LeftOperation {
        /// Index in the set.
        drive: u8,
        /// Statusword 0x6041.
        statusword: u16,
    },
    /// Drive `drive` is in Fault (or its reaction); the last EMCY it sent, if any.
    InFault {
        /// Index in the set.
        drive: u8,
        /// Its last emergency message.
        emcy: Option<Emergency>,
    },
    /// No TPDO from drive `drive` for `periods` consecutive periods.
    Silent {
        /// Index in the set.
        drive: u8,
        /// Periods without its TPDO.
        periods: u8,
    },
    /// Drive `drive` aborted an SDO transfer of `od`.
    SdoAbort {
        /// Index in the set.
        drive: u8,
        /// The object.
        od: Od,
        /// The abort code.
        code: SdoAbort,
    },
    /// Drive `drive` did not finish bring-up step `step` in time.
    BringUpTimeout {
        /// Index in the set.
        drive: u8,
        /// The step.
        step: BringUpStep,
    },
    /// Drive `drive` displays mode `displayed` in 0x6061 after 0x6060 = 10 was written.
    ModeRefused {
        /// Index in the set.
        drive: u8,
        /// 0x6061 as read.
        displayed: i8,
    },
    /// Drive `drive` reports a rated force 0x6076 (mN) under which the configured max
    /// force does not fit 0x6072 (0 or above 65,535 per mille).
    RatedForce {
        /// Index in the set.
        drive: u8,
        /// 0x6076 as read, mN.
        rated_mn: u32,
    },
    /// Drive `drive` answered an SDO about another object, or in a way the step does
    /// not expect.
    SdoProtocol {
        /// Index in the set.
        drive: u8,
        /// The object of the answer.
        od: Od,
    },
    /// Drive `drive` booted again (a boot-up message) after bring-up.
    Rebooted {
        /// Index in the set.
        drive: u8,
    },
    /// The set was stopped by its owner ([`DriveSet::stop`]).
    Stopped,
}

impl fmt::Display for DriveFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::LeftOperation { drive, statusword } => {
                let state = DriveState::from_statusword(statusword)
                    .map_or("an undefined state", DriveState::words);
                write!(
                    f,
                    "drive {drive} left Operation enabled: {state} (statusword 0x{statusword:04X})"
                )
            }
            Self::InFault { drive, emcy } => match emcy {
                Some(e) => write!(f, "drive {drive} in Fault: {e}"),
                None => write!(f, "drive {drive} in Fault (no EMCY received)"),
            },
            Self::Silent { drive, periods } => {
                write!(f, "drive {drive} silent: no TPDO for {periods} periods")
            }
            Self::SdoAbort { drive, od, code } => write!(
                f,
                "drive {drive} aborted SDO 0x{:04X}.{:02X}: {code}",
                od.index, od.sub
            ),
            Self::BringUpTimeout { drive, step } => {
                write!(f, "drive {drive}: bring-up timed out at {}", step.words())
            }
            Self::ModeRefused { drive, displayed } => write!(
                f,
                "drive {drive} refused cyclic synchronous torque: 0x6061 displays mode {displayed}"
            ),
            Self::RatedForce { drive, rated_mn } => write!(
                f,
                "drive {drive}: rated force 0x6076 = {rated_mn} mN leaves the max force outside 0x6072"
            ),
            Self::SdoProtocol { drive, od } => write!(
                f,
                "drive {drive}: unexpected SDO answer about 0x{:04X}.{:02X}",
                od.index, od.sub
            ),
            Self::Rebooted { drive } => write!(f, "drive {drive} booted again"),
            Self::Stopped => write!(f, "drives stopped by the master"),
        }
    }
}

/// Where the set is.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Phase {
    /// Bringing the drives up, at this step.
    BringingUp(BringUpStep),
    /// Every drive in Operation enabled, torques applied.
    Operational,
    /// Latched fault: Quick stop and zero torque sent.
    Faulted(DriveFault),
}

/// One drive's state in the master.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub(crate) struct Drive {
    pub(crate) address: Option<DriveAddress>,
    pub(crate) slot: u8,
    pub(crate) booted: bool,
    pub(crate) rated_mn: u32,
    /// Target torque per newton, per mille (1e6 / rated in mN).
    pub(crate) permille_per_n: f64,
    pub(crate) max_permille: u16,
    pub(crate) statusword: Option<u16>,
    pub(crate) tpdo_seen: bool,
    pub(crate) missed: u8,
    pub(crate) position: i32,
    pub(crate) emcy: Option<Emergency>,
    pub(crate) command: CstCommand,
    pub(crate) progress: bring_up::DriveProgress,
}

/// The master of N drives, position and force in the scalar `T`.
#[derive(Clone, Debug)]
pub struct DriveSet<T: Float, const N: usize> {
    config: DriveSetConfig<N>,
    pub(crate) drives: [Drive; N],
    pub(crate) bring_up: BringUp,
    phase: Phase,
    sync_counter: u8,
    increment: T,
}

/// The SYNC counter's overflow value (0x1019): 240, the largest the standard allows.
const SYNC_COUNTER_MAX: u8 = 240;

impl<T: Float, const N: usize> DriveSet<T, N> {
    /// A master for `config`'s drives, before bring-up. Refused (the field named): a
    /// bus index from [`MAX_BUSES`] up or a third drive on a bus (`drives[i].bus`), a
    /// node id outside 1–127 or twice on a bus (`drives[i].node`), a non-positive
    /// increment or force, a zero timeout or silent count.
    pub fn new(config: &DriveSetConfig<N>) -> Result<Self, ConfigError> {
        let mut drives = [Drive::default(); N];
        let mut per_bus = [0u8; MAX_BUSES];
        for (i, (d, a)) in drives.iter_mut().zip(config.drives.iter()).enumerate() {
            let count = per_bus
                .get_mut(usize::from(a.bus))
                .filter(|c| **c < 2)
                .ok_or_else(|| ConfigError::out_of_range("bus").at(i).within("drives"))?;
            let twice = config
                .drives
                .iter()
                .take(i)
                .any(|b| b.bus == a.bus && b.node == a.node);
            if !(1..=127).contains(&a.node) || twice {
                return Err(ConfigError::out_of_range("node").at(i).within("drives"));
            }
            d.slot = *count;
            *count = count.saturating_add(1);
            d.address = Some(*a);
        }
        positive("increment_m", config.increment_m)?;
        positive("max_force_n", config.max_force_n)?;
        for (name, v) in [
            ("boot_timeout_periods", config.boot_timeout_periods),
            ("sdo_timeout_periods", config.sdo_timeout_periods),
            ("enable_timeout_periods", config.enable_timeout_periods),
            ("silent_periods", u32::from(config.silent_periods)),
        ] {
            if v == 0 {
                return Err(ConfigError::not_positive(name));
            }
        }
        Ok(Self {
            config: *config,
            drives,
            bring_up: BringUp::default(),
            phase: Phase::BringingUp(BringUpStep::BootUp),
            sync_counter: 1,
            increment: crate::error::coefficient("increment_m", config.increment_m)?,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &DriveSetConfig<N> {
        &self.config
    }

    /// Where the set is.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The latched fault, if any.
    pub fn fault(&self) -> Option<DriveFault> {
        match self.phase {
            Phase::Faulted(f) => Some(f),
            _ => None,
        }
    }

    /// The RPDO's COB-ID on `bus`: 0x200 + the node id of its slot-0 drive (both
    /// drives of the bus take it as their RPDO1's COB-ID, 0x1400 sub 1).
    pub fn rpdo_id(&self, bus: u8) -> Option<u16> {
        self.drives
            .iter()
            .filter_map(|d| d.address)
            .find(|a| a.bus == bus)
            .map(|a| cob::RPDO1 | u16::from(a.node))
    }

    /// The statusword a drive last sent, if any.
    pub fn statusword(&self, drive: usize) -> Option<u16> {
        self.drives.get(drive).and_then(|d| d.statusword)
    }

    /// The controlword and target torque going to a drive with the next SYNC.
    pub fn drive_command(&self, drive: usize) -> Option<CstCommand> {
        self.drives.get(drive).map(|d| d.command)
    }

    /// Latches `fault` (the first one stays) and makes the outputs safe.
    pub(crate) fn latch(&mut self, fault: DriveFault) {
        if !matches!(self.phase, Phase::Faulted(_)) {
            self.phase = Phase::Faulted(fault);
        }
        for d in self.drives.iter_mut() {
            d.command = CstCommand {
                controlword: cw::QUICK_STOP_CMD,
                target_torque: 0,
            };
        }
    }

    pub(crate) fn enter(&mut self, phase: Phase) {
        if !matches!(self.phase, Phase::Faulted(_)) {
            self.phase = phase;
        }
    }

    /// Stops the drives as on a fault ([`DriveFault::Stopped`] unless one is latched):
    /// Quick stop and zero torque from the next period on.
    pub fn stop(&mut self) {
        self.latch(DriveFault::Stopped);
    }

    /// The drive at `bus` with `node`.
    fn find(&self, bus: u8, node: u8) -> Option<usize> {
        self.drives
            .iter()
            .position(|d| d.address == Some(DriveAddress { bus, node }))
    }

    /// A frame received on `bus`. Frames of other nodes, other objects and bad
    /// payloads are ignored (the bus is shared with nothing else, but a frame the
    /// master cannot read must not stop it: the checks of [`Self::feedback`] catch
    /// what is missing).
    pub fn receive(&mut self, bus: u8, frame: &CanFrame) {
        let Ok(received) = Received::parse(frame) else {
            return;
        };
        match received {
            Received::Tpdo(node) => {
                let Some(i) = self.find(bus, node) else {
                    return;
                };
                if let (Some(d), Some(fb)) =
                    (self.drives.get_mut(i), cia402::decode_tpdo(frame.payload()))
                {
                    d.statusword = Some(fb.statusword);
                    d.position = fb.position;
                    d.tpdo_seen = true;
                }
            }
            Received::Emcy(node, e) => {
                if let Some(d) = self.find(bus, node).and_then(|i| self.drives.get_mut(i)) {
                    d.emcy = (e.code != Emergency::NO_ERROR).then_some(e);
                }
            }
            Received::Heartbeat(node, state) => {
                let Some(i) = self.find(bus, node) else {
                    return;
                };
                if state == NmtState::BootUp {
                    if matches!(self.phase, Phase::BringingUp(BringUpStep::BootUp)) {
                        if let Some(d) = self.drives.get_mut(i) {
                            d.booted = true;
                        }
                    } else if !matches!(self.phase, Phase::Faulted(_)) {
                        self.latch(DriveFault::Rebooted { drive: i as u8 });
                    }
                }
            }
            Received::SdoResponse(node, response) => {
                if let Some(i) = self.find(bus, node) {
                    self.sdo_response(i, response);
                }
            }
            _ => {}
        }
    }

    /// The period's tick: bring-up's frames (at most one a drive), or per bus the
    /// SYNC and the RPDO with the commands set by [`Self::command`] in the period
    /// before (or Quick stop and zero torque after a fault). `tx(bus, frame)` queues
    /// a frame for sending; at most two a bus come in a period. (`tx` is generic, not
    /// `dyn`: a board calls this in its control interrupt, whose stack is bounded
    /// statically through direct calls only.)
    pub fn start_period(&mut self, tx: &mut impl FnMut(u8, &CanFrame)) {
        // A period carries bring-up frames or cyclic ones, never both: at most one
        // frame a drive, two a bus, within the FDCAN's three transmit buffers.
        let mut bring_up_frames = 0u32;
        if let Phase::BringingUp(step) = self.phase {
            self.bring_up_period(step, &mut |bus, frame| {
                bring_up_frames = bring_up_frames.saturating_add(1);
                tx(bus, frame);
            });
        }
        if bring_up_frames == 0
            && matches!(
                self.phase,
                Phase::BringingUp(BringUpStep::Enable) | Phase::Operational | Phase::Faulted(_)
            )
        {
            self.cyclic_frames(tx);
        }
    }

    fn cyclic_frames(&mut self, tx: &mut impl FnMut(u8, &CanFrame)) {
        let counter = self.sync_counter;
        self.sync_counter = crate::codec::canopen::next_sync_counter(counter, SYNC_COUNTER_MAX);
        for bus in 0..MAX_BUSES as u8 {
            let Some(id) = self.rpdo_id(bus) else {
                continue;
            };
            let mut pair = [CstCommand::default(); 2];
            for d in self
                .drives
                .iter()
                .filter(|d| d.address.map(|a| a.bus) == Some(bus))
            {
                if let Some(slot) = pair.get_mut(usize::from(d.slot)) {
                    *slot = d.command;
                }
            }
            tx(bus, &sync(Some(counter)));
            tx(
                bus,
                &CanFrame {
                    id,
                    len: cia402::RPDO_LEN,
                    data: cia402::encode_rpdo(&pair),
                },
            );
        }
        for d in self.drives.iter_mut() {
            d.tpdo_seen = false;
        }
    }

    /// The period's positions, m (the encoders' increments × [`DriveSetConfig::increment_m`]),
    /// once every drive's TPDO since the SYNC is in. Checks each drive: its TPDO
    /// arrived (a drive that missed one period keeps its last position until
    /// [`DriveSetConfig::silent_periods`] run out), its statusword says Operation
    /// enabled. `Ok(None)` while bringing up; the latched fault after one.
    pub fn feedback(&mut self) -> Result<Option<[T; N]>, DriveFault> {
        match self.phase {
            Phase::Faulted(f) => return Err(f),
            Phase::BringingUp(_) => return Ok(None),
            Phase::Operational => {}
        }
        let silent = self.config.silent_periods;
        let mut fault = None;
        for (i, d) in self.drives.iter_mut().enumerate() {
            let drive = i as u8;
            if d.tpdo_seen {
                d.missed = 0;
            } else {
                d.missed = d.missed.saturating_add(1);
                if d.missed >= silent {
                    fault = fault.or(Some(DriveFault::Silent {
                        drive,
                        periods: d.missed,
                    }));
                }
                continue;
            }
            let statusword = d.statusword.unwrap_or(0);
            match DriveState::from_statusword(statusword) {
                Some(DriveState::OperationEnabled) => {}
                Some(DriveState::Fault | DriveState::FaultReactionActive) => {
                    fault = fault.or(Some(DriveFault::InFault {
                        drive,
                        emcy: d.emcy,
                    }));
                }
                _ => fault = fault.or(Some(DriveFault::LeftOperation { drive, statusword })),
            }
        }
        if let Some(f) = fault {
            self.latch(f);
            return Err(f);
        }
        let mut positions = [T::zero(); N];
        for (p, d) in positions.iter_mut().zip(self.drives.iter()) {
            *p = <T as crate::scalar::Real>::from_f64(f64::from(d.position)) * self.increment;
        }
        Ok(Some(positions))
    }

    /// The period's forces, N: each drive's target torque for the next SYNC, per
    /// mille of its rated force rounded to nearest and clipped at its max torque
    /// (a value that is not finite commands zero). Returns whether one was clipped.
    /// Ignored unless [`Phase::Operational`].
    pub fn command(&mut self, forces_n: &[T; N]) -> bool {
        if self.phase != Phase::Operational {
            return false;
        }
        let mut clipped = false;
        for (d, f) in self.drives.iter_mut().zip(forces_n.iter()) {
            let (torque, c) = to_permille(f.to_f64(), d.permille_per_n, d.max_permille);
            clipped |= c;
            d.command = CstCommand {
                controlword: cw::ENABLE_OPERATION_CMD,
                target_torque: torque,
            };
        }
        clipped
    }
}

/// A force as target torque: per mille, rounded, clipped at ±`max` (and i16); NaN → 0.
/// Returns the value and whether it was clipped.
pub fn to_permille(force_n: f64, permille_per_n: f64, max: u16) -> (i16, bool) {
    let limit = f64::from(max.min(i16::MAX as u16));
    let v = libm::round(force_n * permille_per_n);
    if !v.is_finite() {
        return (0, !force_n.is_nan());
    }
    let clipped = v.abs() > limit;
    (v.clamp(-limit, limit) as i16, clipped)
}

#[cfg(test)]
mod tests;
