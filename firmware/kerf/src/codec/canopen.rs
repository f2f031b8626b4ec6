//! CANopen frames (CiA 301) as the servo drives' buses carry them: NMT, SYNC, SDO
//! expedited transfers, EMCY, heartbeat and the PDOs' identifiers, each a
//! [`CanFrame`] of at most 8 bytes (sent as a CAN FD frame with bit-rate switch:
//! docs/drives.md). The drive profile on top (CiA 402) is [`super::cia402`]; the
//! frames' duration on the bus is [`super::canfd_timing`].
//!
//! Identifiers follow CiA 301's predefined connection set: the function code in bits
//! 10–7, the node id (1–127) in bits 6–0.
//!
//! | object | COB-ID | payload |
//! |---|---|---|
//! | NMT | 0x000 | command, node (0 = all) |
//! | SYNC | 0x080 | counter 1–240 (optional, 1 byte) |
//! | EMCY | 0x080 + node | error code (u16 LE), error register 0x1001, 5 bytes vendor |
//! | TPDO1 | 0x180 + node | mapped objects |
//! | RPDO1 | 0x200 + node | mapped objects |
//! | SDO server → client | 0x580 + node | command specifier, index LE, sub-index, 4 data |
//! | SDO client → server | 0x600 + node | as above |
//! | heartbeat / boot-up | 0x700 + node | NMT state (0x00 = boot-up) |

/// A classical-length frame: 11-bit identifier, up to 8 data bytes.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CanFrame {
    /// 11-bit identifier (COB-ID).
    pub id: u16,
    /// Payload length, 0–8.
    pub len: u8,
    /// Payload; bytes past `len` are zero.
    pub data: [u8; 8],
}

/// Where a drive is: its bus (0-based) and node id (1–127).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DriveAddress {
    /// Bus index.
    pub bus: u8,
    /// CANopen node id.
    pub node: u8,
}

/// Why a frame was refused.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// The identifier does not fit 11 bits.
    IdTooLarge,
    /// More than 8 payload bytes, or fewer than the object needs.
    BadLength,
    /// A node id outside 1–127.
    BadNode,
    /// The identifier is no object of the predefined connection set this codec reads.
    UnknownId,
    /// The payload is not a valid object of its kind (an SDO command specifier, an
    /// NMT state, a SYNC counter).
    BadPayload,
}

impl CanFrame {
    /// A frame of `payload` (at most 8 bytes) on `id` (at most 0x7FF).
    pub fn new(id: u16, payload: &[u8]) -> Result<Self, FrameError> {
        if id > 0x7FF {
            return Err(FrameError::IdTooLarge);
        }
        let mut data = [0; 8];
        data.get_mut(..payload.len())
            .ok_or(FrameError::BadLength)?
            .copy_from_slice(payload);
        Ok(Self {
            id,
            len: payload.len() as u8,
            data,
        })
    }

    /// The payload (the first `len` bytes; empty when `len` is out of range).
    pub fn payload(&self) -> &[u8] {
        self.data.get(..usize::from(self.len)).unwrap_or(&[])
    }

    /// The function code (bits 10–7 of the identifier).
    pub fn function(&self) -> u16 {
        self.id & 0x780
    }

    /// The node id (bits 6–0 of the identifier).
    pub fn node(&self) -> u8 {
        (self.id & 0x7F) as u8
    }
}

/// Function codes of the predefined connection set (CiA 301 §7.3.5).
pub mod cob {
    /// NMT node control.
    pub const NMT: u16 = 0x000;
    /// SYNC (and EMCY's function code, with a node id).
    pub const SYNC: u16 = 0x080;
    /// EMCY base.
    pub const EMCY: u16 = 0x080;
    /// TPDO1 base.
    pub const TPDO1: u16 = 0x180;
    /// RPDO1 base.
    pub const RPDO1: u16 = 0x200;
    /// SDO server → client base.
    pub const SDO_TX: u16 = 0x580;
    /// SDO client → server base.
    pub const SDO_RX: u16 = 0x600;
    /// Heartbeat and boot-up base.
    pub const HEARTBEAT: u16 = 0x700;
}

/// A node id checked to 1–127.
pub fn node_id(node: u8) -> Result<u8, FrameError> {
    if (1..=127).contains(&node) {
        Ok(node)
    } else {
        Err(FrameError::BadNode)
    }
}

/// NMT node control commands (CiA 301 §7.2.8.3.1).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NmtCommand {
    /// Start remote node (→ Operational).
    Start = 0x01,
    /// Stop remote node (→ Stopped).
    Stop = 0x02,
    /// Enter pre-operational.
    PreOperational = 0x80,
    /// Reset node (application and communication; the node boots again).
    ResetNode = 0x81,
    /// Reset communication.
    ResetCommunication = 0x82,
}

impl NmtCommand {
    /// The command of a command specifier byte.
    pub fn from_byte(b: u8) -> Option<Self> {
        Some(match b {
            0x01 => Self::Start,
            0x02 => Self::Stop,
            0x80 => Self::PreOperational,
            0x81 => Self::ResetNode,
            0x82 => Self::ResetCommunication,
            _ => return None,
        })
    }

    /// The NMT frame addressing `node` (0 = every node).
    pub fn frame(self, node: u8) -> CanFrame {
        CanFrame {
            id: cob::NMT,
            len: 2,
            data: [self as u8, node & 0x7F, 0, 0, 0, 0, 0, 0],
        }
    }
}

/// NMT states as a heartbeat reports them (CiA 301 §7.2.8.3.2.2).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NmtState {
    /// Boot-up (the one heartbeat a node sends on entering pre-operational).
    BootUp = 0x00,
    /// Stopped.
    Stopped = 0x04,
    /// Operational.
    Operational = 0x05,
    /// Pre-operational.
    PreOperational = 0x7F,
}

impl NmtState {
    /// The state of a heartbeat byte (the toggle bit 7 masked off).
    pub fn from_byte(b: u8) -> Option<Self> {
        Some(match b & 0x7F {
            0x00 => Self::BootUp,
            0x04 => Self::Stopped,
            0x05 => Self::Operational,
            0x7F => Self::PreOperational,
            _ => return None,
        })
    }

    /// The heartbeat (or boot-up, for [`NmtState::BootUp`]) of `node`.
    pub fn heartbeat(self, node: u8) -> CanFrame {
        CanFrame {
            id: cob::HEARTBEAT | u16::from(node & 0x7F),
            len: 1,
            data: [self as u8, 0, 0, 0, 0, 0, 0, 0],
        }
    }
}

/// The SYNC frame; with a counter (1–240, CiA 301 object 0x1019) it carries one byte.
pub fn sync(counter: Option<u8>) -> CanFrame {
    match counter {
        Some(c) => CanFrame {
            id: cob::SYNC,
            len: 1,
            data: [c, 0, 0, 0, 0, 0, 0, 0],
        },
        None => CanFrame {
            id: cob::SYNC,
            ..CanFrame::default()
        },
    }
}

/// The SYNC counter after `c` (1 → 2 → … → `max` → 1; CiA 301: max is 0x1019, 2–240).
pub fn next_sync_counter(c: u8, max: u8) -> u8 {
    if c >= max.clamp(2, 240) {
        1
    } else {
        c.saturating_add(1)
    }
}

/// An object dictionary address.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Od {
    /// Index.
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
}

impl Od {
    /// Sub-index 0 of `index`.
    pub const fn at(index: u16) -> Self {
        Self { index, sub: 0 }
    }
}

/// An SDO request of the client (the master), expedited only (≤ 4 bytes).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SdoRequest {
    /// Initiate download (write) of `size` bytes (1–4) of `value`, little endian.
    Download {
        /// Object.
        od: Od,
        /// Value (its low `size` bytes are sent).
        value: u32,
        /// Bytes, 1–4.
        size: u8,
    },
    /// Initiate upload (read).
    Upload {
        /// Object.
        od: Od,
    },
}

/// An SDO response of the server (the drive).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SdoResponse {
    /// Download confirmed.
    Downloaded {
        /// Object.
        od: Od,
    },
    /// Expedited upload: `size` bytes (1–4) of `value`.
    Uploaded {
        /// Object.
        od: Od,
        /// Value, zero-extended.
        value: u32,
        /// Bytes, 1–4.
        size: u8,
    },
    /// Transfer aborted.
    Abort {
        /// Object.
        od: Od,
        /// Why.
        code: SdoAbort,
    },
}

/// An SDO abort code (CiA 301 §7.2.4.3.17, table 22), with words for the codes
/// the drives answer.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SdoAbort(pub u32);

impl SdoAbort {
    /// Toggle bit not alternated.
    pub const TOGGLE: Self = Self(0x0503_0000);
    /// SDO protocol timed out.
    pub const TIMEOUT: Self = Self(0x0504_0000);
    /// Client/server command specifier not valid or unknown.
    pub const COMMAND: Self = Self(0x0504_0001);
    /// Attempt to read a write-only object.
    pub const WRITE_ONLY: Self = Self(0x0601_0001);
    /// Attempt to write a read-only object.
    pub const READ_ONLY: Self = Self(0x0601_0002);
    /// Object does not exist in the object dictionary.
    pub const NO_OBJECT: Self = Self(0x0602_0000);
    /// Data type does not match, length of service parameter does not match.
    pub const LENGTH: Self = Self(0x0607_0010);
    /// Sub-index does not exist.
    pub const NO_SUB: Self = Self(0x0609_0011);
    /// Invalid value for parameter (download only).
    pub const INVALID_VALUE: Self = Self(0x0609_0030);
    /// Value of parameter written too high.
    pub const TOO_HIGH: Self = Self(0x0609_0031);
    /// Data cannot be transferred or stored because of the present device state.
    pub const DEVICE_STATE: Self = Self(0x0800_0022);
    /// General error.
    pub const GENERAL: Self = Self(0x0800_0000);

    /// The standard's words for the code.
    pub fn words(self) -> &'static str {
        match self {
            Self::TOGGLE => "toggle bit not alternated",
            Self::TIMEOUT => "SDO protocol timed out",
            Self::COMMAND => "command specifier not valid or unknown",
            Self::WRITE_ONLY => "attempt to read a write-only object",
            Self::READ_ONLY => "attempt to write a read-only object",
            Self::NO_OBJECT => "object does not exist in the object dictionary",
            Self::LENGTH => "data type does not match, length of service parameter does not match",
            Self::NO_SUB => "sub-index does not exist",
            Self::INVALID_VALUE => "invalid value for parameter (value range exceeded)",
            Self::TOO_HIGH => "value of parameter written too high",
            Self::DEVICE_STATE => "data cannot be transferred in the present device state",
            Self::GENERAL => "general error",
            _ => "abort code not known to the master",
        }
    }
}

impl core::fmt::Display for SdoAbort {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "0x{:08X} {}", self.0, self.words())
    }
}

fn sdo_frame(base: u16, node: u8, command: u8, od: Od, value: u32) -> CanFrame {
    let [i0, i1] = od.index.to_le_bytes();
    let [v0, v1, v2, v3] = value.to_le_bytes();
    CanFrame {
        id: base | u16::from(node & 0x7F),
        len: 8,
        data: [command, i0, i1, od.sub, v0, v1, v2, v3],
    }
}

/// The value masked to its low `size` bytes (1–4), or `None` for another size.
fn fit(value: u32, size: u8) -> Option<u32> {
    match size {
        1..=3 => Some(value & ((1u32 << (8 * u32::from(size))) - 1)),
        4 => Some(value),
        _ => None,
    }
}

/// Expedited command specifier with the size indicated: `base` | (4 − size) << 2 | e | s.
fn expedited(base: u8, size: u8) -> u8 {
    base | (4u8.saturating_sub(size) << 2) | 0x03
}

fn od_of(data: &[u8; 8]) -> Od {
    let [_, i0, i1, sub, ..] = *data;
    Od {
        index: u16::from_le_bytes([i0, i1]),
        sub,
    }
}

fn value_of(data: &[u8; 8]) -> u32 {
    let [_, _, _, _, v0, v1, v2, v3] = *data;
    u32::from_le_bytes([v0, v1, v2, v3])
}

/// Size of an expedited transfer from its command byte (size indicated) or 4.
fn size_of(command: u8) -> u8 {
    if command & 0x01 != 0 {
        4 - ((command >> 2) & 0x03)
    } else {
        4
    }
}

impl SdoRequest {
    /// The request frame to `node`'s SDO server (COB-ID 0x600 + node). A download's
    /// size outside 1–4 is refused.
    pub fn frame(&self, node: u8) -> Result<CanFrame, FrameError> {
        let node = node_id(node)?;
        Ok(match *self {
            Self::Download { od, value, size } => {
                let value = fit(value, size).ok_or(FrameError::BadPayload)?;
                sdo_frame(cob::SDO_RX, node, expedited(0x20, size), od, value)
            }
            Self::Upload { od } => sdo_frame(cob::SDO_RX, node, 0x40, od, 0),
        })
    }

    /// The request a server reads from an 0x600 + node frame.
    pub fn parse(frame: &CanFrame) -> Result<Self, FrameError> {
        if frame.function() != cob::SDO_RX {
            return Err(FrameError::UnknownId);
        }
        if frame.len != 8 {
            return Err(FrameError::BadLength);
        }
        let [command, ..] = frame.data;
        let od = od_of(&frame.data);
        match command >> 5 {
            // ccs 1: initiate download; expedited (e) only.
            1 if command & 0x02 != 0 => {
                let size = size_of(command);
                let value = fit(value_of(&frame.data), size).ok_or(FrameError::BadPayload)?;
                Ok(Self::Download { od, value, size })
            }
            2 => Ok(Self::Upload { od }),
            _ => Err(FrameError::BadPayload),
        }
    }
}

impl SdoResponse {
    /// The response frame of `node`'s server (COB-ID 0x580 + node).
    pub fn frame(&self, node: u8) -> Result<CanFrame, FrameError> {
        let node = node_id(node)?;
        Ok(match *self {
            Self::Downloaded { od } => sdo_frame(cob::SDO_TX, node, 0x60, od, 0),
            Self::Uploaded { od, value, size } => {
                let value = fit(value, size).ok_or(FrameError::BadPayload)?;
                sdo_frame(cob::SDO_TX, node, expedited(0x40, size), od, value)
            }
            Self::Abort { od, code } => sdo_frame(cob::SDO_TX, node, 0x80, od, code.0),
        })
    }

    /// The response a client reads from an 0x580 + node frame.
    pub fn parse(frame: &CanFrame) -> Result<Self, FrameError> {
        if frame.function() != cob::SDO_TX {
            return Err(FrameError::UnknownId);
        }
        if frame.len != 8 {
            return Err(FrameError::BadLength);
        }
        let [command, ..] = frame.data;
        let od = od_of(&frame.data);
        let value = value_of(&frame.data);
        match command >> 5 {
            3 => Ok(Self::Downloaded { od }),
            // scs 2: initiate upload response; only expedited transfers are read.
            2 if command & 0x02 != 0 => {
                let size = size_of(command);
                let value = fit(value, size).ok_or(FrameError::BadPayload)?;
                Ok(Self::Uploaded { od, value, size })
            }
            4 => Ok(Self::Abort {
                od,
                code: SdoAbort(value),
            }),
            _ => Err(FrameError::BadPayload),
        }
    }
}

/// An emergency message (CiA 301 §7.2.7): error code, error register (0x1001).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Emergency {
    /// Error code (CiA 301 table 21, CiA 402 annex for the drive codes); 0 = error reset.
    pub code: u16,
    /// Error register, object 0x1001.
    pub register: u8,
}

impl Emergency {
    /// Error reset or no error.
    pub const NO_ERROR: u16 = 0x0000;
    /// Continuous over-current (device output side).
    pub const OVERCURRENT: u16 = 0x2310;
    /// DC link over-voltage.
    pub const DC_LINK_OVERVOLTAGE: u16 = 0x3210;
    /// Mains/DC link under-voltage.
    pub const DC_LINK_UNDERVOLTAGE: u16 = 0x3220;
    /// Excess device temperature.
    pub const DEVICE_TEMPERATURE: u16 = 0x4310;
    /// Safety: power stage disabled by STO (safe torque off).
    pub const SAFE_TORQUE_OFF: u16 = 0x5441;
    /// Incremental sensor 1 fault (the position encoder).
    pub const ENCODER: u16 = 0x7305;
    /// Life guard error or heartbeat error (the communication watchdog).
    pub const HEARTBEAT: u16 = 0x8130;
    /// Following error.
    pub const FOLLOWING: u16 = 0x8611;

    /// Error register bits (0x1001): bit 0 generic, 1 current, 2 voltage,
    /// 3 temperature, 4 communication.
    pub const REG_GENERIC: u8 = 0x01;
    /// Current.
    pub const REG_CURRENT: u8 = 0x02;
    /// Voltage.
    pub const REG_VOLTAGE: u8 = 0x04;
    /// Communication.
    pub const REG_COMMUNICATION: u8 = 0x10;

    /// The standard's words for the error code (its class for a code not listed).
    pub fn words(self) -> &'static str {
        match self.code {
            Self::NO_ERROR => "error reset or no error",
            Self::OVERCURRENT => "continuous over-current",
            Self::DC_LINK_OVERVOLTAGE => "DC link over-voltage",
            Self::DC_LINK_UNDERVOLTAGE => "DC link under-voltage",
            Self::DEVICE_TEMPERATURE => "excess device temperature",
            Self::SAFE_TORQUE_OFF => "power stage disabled (safe torque off)",
            Self::ENCODER => "incremental sensor 1 fault",
            Self::HEARTBEAT => "life guard error or heartbeat error",
            Self::FOLLOWING => "following error",
            c => match c >> 12 {
                0x1 => "generic error",
                0x2 => "current",
                0x3 => "voltage",
                0x4 => "temperature",
                0x5 => "device hardware",
                0x6 => "device software",
                0x7 => "additional modules",
                0x8 => "monitoring",
                0x9 => "external error",
                _ => "error code not known to the master",
            },
        }
    }

    /// The EMCY frame of `node` (COB-ID 0x080 + node), vendor bytes zero.
    pub fn frame(self, node: u8) -> Result<CanFrame, FrameError> {
        let node = node_id(node)?;
        let [c0, c1] = self.code.to_le_bytes();
        Ok(CanFrame {
            id: cob::EMCY | u16::from(node),
            len: 8,
            data: [c0, c1, self.register, 0, 0, 0, 0, 0],
        })
    }

    /// The emergency of an 0x080 + node frame (at least 3 bytes).
    pub fn parse(frame: &CanFrame) -> Result<Self, FrameError> {
        if frame.function() != cob::EMCY || frame.node() == 0 {
            return Err(FrameError::UnknownId);
        }
        match frame.payload() {
            [c0, c1, register, ..] => Ok(Self {
                code: u16::from_le_bytes([*c0, *c1]),
                register: *register,
            }),
            _ => Err(FrameError::BadLength),
        }
    }
}

impl core::fmt::Display for Emergency {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "EMCY 0x{:04X} {} (error register 0x{:02X})",
            self.code,
            self.words(),
            self.register
        )
    }
}

/// What a received frame is, from its identifier (the predefined connection set).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Received {
    /// NMT command to `node` (0 = all).
    Nmt(NmtCommand, u8),
    /// SYNC with its counter, if any.
    Sync(Option<u8>),
    /// Emergency of a node.
    Emcy(u8, Emergency),
    /// TPDO1 of a node (payload in the frame).
    Tpdo(u8),
    /// RPDO1 addressed by a node's COB-ID (payload in the frame).
    Rpdo(u8),
    /// SDO response of a node's server.
    SdoResponse(u8, SdoResponse),
    /// SDO request to a node's server.
    SdoRequest(u8, SdoRequest),
    /// Heartbeat (or boot-up) of a node.
    Heartbeat(u8, NmtState),
}

impl Received {
    /// The object a frame carries, or why it is none of them.
    pub fn parse(frame: &CanFrame) -> Result<Self, FrameError> {
        let node = frame.node();
        match (frame.function(), node) {
            (cob::NMT, 0) => match frame.payload() {
                [command, target] => Ok(Self::Nmt(
                    NmtCommand::from_byte(*command).ok_or(FrameError::BadPayload)?,
                    *target & 0x7F,
                )),
                _ => Err(FrameError::BadLength),
            },
            (cob::SYNC, 0) => match frame.payload() {
                [] => Ok(Self::Sync(None)),
                [c @ 1..=240] => Ok(Self::Sync(Some(*c))),
                [_] => Err(FrameError::BadPayload),
                _ => Err(FrameError::BadLength),
            },
            (cob::EMCY, _) => Ok(Self::Emcy(node, Emergency::parse(frame)?)),
            (_, 0) => Err(FrameError::UnknownId),
            (cob::TPDO1, _) => Ok(Self::Tpdo(node)),
            (cob::RPDO1, _) => Ok(Self::Rpdo(node)),
            (cob::SDO_TX, _) => Ok(Self::SdoResponse(node, SdoResponse::parse(frame)?)),
            (cob::SDO_RX, _) => Ok(Self::SdoRequest(node, SdoRequest::parse(frame)?)),
            (cob::HEARTBEAT, _) => match frame.payload() {
                [state] => Ok(Self::Heartbeat(
                    node,
                    NmtState::from_byte(*state).ok_or(FrameError::BadPayload)?,
                )),
                _ => Err(FrameError::BadLength),
            },
            _ => Err(FrameError::UnknownId),
        }
    }
}

#[cfg(test)]
mod tests;
