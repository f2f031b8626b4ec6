//! The drive profile CiA 402 (IEC 61800-7-201) as far as cyclic synchronous torque
//! mode needs it: the objects, the controlword's commands, the statusword's states,
//! and the PDO layouts of a bus with two drives (docs/drives.md).
//!
//! States from the statusword 0x6041 (CiA 402 table "state coding", bits 6, 5, 3–0;
//! x = don't care):
//!
//! | statusword | state |
//! |---|---|
//! | xxxx xxxx x0xx 0000 | Not ready to switch on |
//! | xxxx xxxx x1xx 0000 | Switch on disabled |
//! | xxxx xxxx x01x 0001 | Ready to switch on |
//! | xxxx xxxx x01x 0011 | Switched on |
//! | xxxx xxxx x01x 0111 | Operation enabled |
//! | xxxx xxxx x00x 0111 | Quick stop active |
//! | xxxx xxxx x0xx 1111 | Fault reaction active |
//! | xxxx xxxx x0xx 1000 | Fault |
//!
//! Commands in the controlword 0x6040 (bits 7, 3–0; CiA 402 "device control
//! commands"):
//!
//! | command | bits 7 3 2 1 0 | transitions |
//! |---|---|---|
//! | Shutdown | 0 x 1 1 0 | 2, 6, 8 |
//! | Switch on | 0 0 1 1 1 | 3 |
//! | Switch on + enable operation | 0 1 1 1 1 | 3 + 4 |
//! | Disable voltage | 0 x x 0 x | 7, 9, 10, 12 |
//! | Quick stop | 0 x 0 1 x | 7, 10, 11 |
//! | Disable operation | 0 0 1 1 1 | 5 |
//! | Enable operation | 0 1 1 1 1 | 4, 16 |
//! | Fault reset | 0 → 1 edge | 15 |

/// Objects of the dictionary the master and the drives use (CiA 301, CiA 402).
pub mod od {
    use crate::codec::canopen::Od;

    /// Error register (u8), CiA 301.
    pub const ERROR_REGISTER: Od = Od::at(0x1001);
    /// Communication cycle period (u32, µs), CiA 301.
    pub const COMMUNICATION_CYCLE: Od = Od::at(0x1006);
    /// Producer heartbeat time (u16, ms; 0 = none), CiA 301.
    pub const HEARTBEAT_PRODUCER: Od = Od::at(0x1017);
    /// RPDO1 mapping (sub 1–4: u32 entries index << 16 | sub << 8 | bits), CiA 301.
    pub const RPDO1_MAPPING: u16 = 0x1600;
    /// TPDO1 mapping, CiA 301.
    pub const TPDO1_MAPPING: u16 = 0x1A00;
    /// Dummy mapping entry of an UNSIGNED16 (CiA 301 §7.4.7.1: index 0x0006).
    pub const DUMMY_U16: u16 = 0x0006;
    /// Error code of the last fault (u16), CiA 402.
    pub const ERROR_CODE: Od = Od::at(0x603F);
    /// Controlword (u16).
    pub const CONTROLWORD: Od = Od::at(0x6040);
    /// Statusword (u16).
    pub const STATUSWORD: Od = Od::at(0x6041);
    /// Modes of operation (i8).
    pub const MODES_OF_OPERATION: Od = Od::at(0x6060);
    /// Modes of operation display (i8).
    pub const MODES_DISPLAY: Od = Od::at(0x6061);
    /// Position actual value (i32, increments).
    pub const POSITION_ACTUAL: Od = Od::at(0x6064);
    /// Target torque (i16, per mille of the rated torque 0x6076).
    pub const TARGET_TORQUE: Od = Od::at(0x6071);
    /// Max torque (u16, per mille of the rated torque 0x6076).
    pub const MAX_TORQUE: Od = Od::at(0x6072);
    /// Motor rated torque (u32, mN·m; mN for a linear motor: its rated force).
    pub const RATED_TORQUE: Od = Od::at(0x6076);
    /// Torque actual value (i16, per mille).
    pub const TORQUE_ACTUAL: Od = Od::at(0x6077);

    /// The PDO mapping entry of an object (CiA 301: index, sub-index, length in bits).
    pub const fn mapping(od: Od, bits: u8) -> u32 {
        (od.index as u32) << 16 | (od.sub as u32) << 8 | bits as u32
    }
}

/// Mode of operation 0x6060 = 10: cyclic synchronous torque.
pub const MODE_CST: i8 = 10;

/// Statusword bits.
pub mod sw {
    /// Ready to switch on.
    pub const READY_TO_SWITCH_ON: u16 = 1 << 0;
    /// Switched on.
    pub const SWITCHED_ON: u16 = 1 << 1;
    /// Operation enabled.
    pub const OPERATION_ENABLED: u16 = 1 << 2;
    /// Fault.
    pub const FAULT: u16 = 1 << 3;
    /// Voltage enabled.
    pub const VOLTAGE_ENABLED: u16 = 1 << 4;
    /// Quick stop (0 = a quick stop is active).
    pub const QUICK_STOP: u16 = 1 << 5;
    /// Switch on disabled.
    pub const SWITCH_ON_DISABLED: u16 = 1 << 6;
    /// Warning.
    pub const WARNING: u16 = 1 << 7;
    /// Remote (the controlword is obeyed).
    pub const REMOTE: u16 = 1 << 9;
    /// Internal limit active (the torque was clipped).
    pub const INTERNAL_LIMIT: u16 = 1 << 11;
    /// CST: drive follows the command value.
    pub const FOLLOWS_COMMAND: u16 = 1 << 12;
}

/// Controlword words the master sends (CiA 402 "device control commands").
pub mod cw {
    /// Switch on bit.
    pub const SWITCH_ON: u16 = 1 << 0;
    /// Enable voltage bit.
    pub const ENABLE_VOLTAGE: u16 = 1 << 1;
    /// Quick stop bit (0 = quick stop).
    pub const QUICK_STOP: u16 = 1 << 2;
    /// Enable operation bit.
    pub const ENABLE_OPERATION: u16 = 1 << 3;
    /// Fault reset bit (acts on its rising edge).
    pub const FAULT_RESET: u16 = 1 << 7;
    /// Shutdown: 0xxx x110.
    pub const SHUTDOWN: u16 = 0x06;
    /// Switch on (and disable operation): 0xxx 0111.
    pub const SWITCH_ON_CMD: u16 = 0x07;
    /// Enable operation (and switch on + enable operation): 0xxx 1111.
    pub const ENABLE_OPERATION_CMD: u16 = 0x0F;
    /// Disable voltage: 0xxx xx0x.
    pub const DISABLE_VOLTAGE: u16 = 0x00;
    /// Quick stop: 0xxx x01x.
    pub const QUICK_STOP_CMD: u16 = 0x02;
}

/// The drive's state (CiA 402 power drive system finite state automaton).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DriveState {
    /// Not ready to switch on.
    NotReadyToSwitchOn,
    /// Switch on disabled.
    SwitchOnDisabled,
    /// Ready to switch on.
    ReadyToSwitchOn,
    /// Switched on.
    SwitchedOn,
    /// Operation enabled.
    OperationEnabled,
    /// Quick stop active.
    QuickStopActive,
    /// Fault reaction active.
    FaultReactionActive,
    /// Fault.
    Fault,
}

impl DriveState {
    /// The state a statusword codes (the table above), `None` for a coding the
    /// standard does not define.
    pub fn from_statusword(word: u16) -> Option<Self> {
        Some(match (word & 0x4F, word & 0x6F) {
            (0x00, _) => Self::NotReadyToSwitchOn,
            (0x40, _) => Self::SwitchOnDisabled,
            (0x0F, _) => Self::FaultReactionActive,
            (0x08, _) => Self::Fault,
            (_, 0x21) => Self::ReadyToSwitchOn,
            (_, 0x23) => Self::SwitchedOn,
            (_, 0x27) => Self::OperationEnabled,
            (_, 0x07) => Self::QuickStopActive,
            _ => return None,
        })
    }

    /// The state's bits 6, 5, 3–0 (what a drive reports; other bits zero).
    pub fn statusword(self) -> u16 {
        match self {
            Self::NotReadyToSwitchOn => 0x00,
            Self::SwitchOnDisabled => 0x40,
            Self::ReadyToSwitchOn => 0x21,
            Self::SwitchedOn => 0x23,
            Self::OperationEnabled => 0x27,
            Self::QuickStopActive => 0x07,
            Self::FaultReactionActive => 0x0F,
            Self::Fault => 0x08,
        }
    }

    /// The standard's name.
    pub fn words(self) -> &'static str {
        match self {
            Self::NotReadyToSwitchOn => "Not ready to switch on",
            Self::SwitchOnDisabled => "Switch on disabled",
            Self::ReadyToSwitchOn => "Ready to switch on",
            Self::SwitchedOn => "Switched on",
            Self::OperationEnabled => "Operation enabled",
            Self::QuickStopActive => "Quick stop active",
            Self::FaultReactionActive => "Fault reaction active",
            Self::Fault => "Fault",
        }
    }
}

/// A controlword's command (bits 3–0 with bit 7 clear; the fault reset edge is the
/// receiver's to detect from the previous word).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DriveCommand {
    /// Shutdown.
    Shutdown,
    /// Switch on, or disable operation (the same coding).
    SwitchOn,
    /// Enable operation, or switch on + enable operation.
    EnableOperation,
    /// Disable voltage.
    DisableVoltage,
    /// Quick stop.
    QuickStop,
}

impl DriveCommand {
    /// The command of a controlword (the table above, in the standard's precedence:
    /// disable voltage over quick stop over the rest).
    pub fn from_controlword(word: u16) -> Self {
        if word & cw::ENABLE_VOLTAGE == 0 {
            Self::DisableVoltage
        } else if word & cw::QUICK_STOP == 0 {
            Self::QuickStop
        } else if word & cw::SWITCH_ON == 0 {
            Self::Shutdown
        } else if word & cw::ENABLE_OPERATION == 0 {
            Self::SwitchOn
        } else {
            Self::EnableOperation
        }
    }
}

/// One drive's slot of the master's RPDO: controlword 0x6040 and target torque 0x6071.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CstCommand {
    /// Controlword.
    pub controlword: u16,
    /// Target torque, per mille of the rated torque.
    pub target_torque: i16,
}

/// What a drive's TPDO carries: statusword 0x6041 and position actual 0x6064.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CstFeedback {
    /// Statusword.
    pub statusword: u16,
    /// Position actual value, increments.
    pub position: i32,
}

/// Bytes of a drive's TPDO.
pub const TPDO_LEN: u8 = 6;
/// Bytes of the pair RPDO.
pub const RPDO_LEN: u8 = 8;

/// The RPDO mapping (0x1600 sub 1–4) of the drive in `slot` (0 or 1) of a pair: its
/// own controlword and target torque, the other drive's slot skipped with two
/// UNSIGNED16 dummy entries.
pub const fn rpdo_mapping(slot: usize) -> [u32; 4] {
    let own = [
        od::mapping(od::CONTROLWORD, 16),
        od::mapping(od::TARGET_TORQUE, 16),
    ];
    let dummy = od::mapping(crate::codec::canopen::Od::at(od::DUMMY_U16), 16);
    if slot == 0 {
        [own[0], own[1], dummy, dummy]
    } else {
        [dummy, dummy, own[0], own[1]]
    }
}

/// The TPDO mapping (0x1A00 sub 1–2): statusword and position actual.
pub const TPDO_MAPPING: [u32; 2] = [
    od::mapping(od::STATUSWORD, 16),
    od::mapping(od::POSITION_ACTUAL, 32),
];

/// The pair RPDO's payload: slot 0's controlword and torque, then slot 1's, little
/// endian.
pub fn encode_rpdo(pair: &[CstCommand; 2]) -> [u8; 8] {
    let [a, b] = pair;
    let [c0, c1] = a.controlword.to_le_bytes();
    let [t0, t1] = a.target_torque.to_le_bytes();
    let [c2, c3] = b.controlword.to_le_bytes();
    let [t2, t3] = b.target_torque.to_le_bytes();
    [c0, c1, t0, t1, c2, c3, t2, t3]
}

/// The slot `slot` (0 or 1) of a pair RPDO's payload, as the drive mapped to it
/// reads it; `None` for a short payload or another slot.
pub fn decode_rpdo(payload: &[u8], slot: usize) -> Option<CstCommand> {
    let start = slot.checked_mul(4)?;
    let bytes = payload.get(start..start.checked_add(4)?)?;
    match bytes {
        [c0, c1, t0, t1] => Some(CstCommand {
            controlword: u16::from_le_bytes([*c0, *c1]),
            target_torque: i16::from_le_bytes([*t0, *t1]),
        }),
        _ => None,
    }
}

/// A drive's TPDO payload.
pub fn encode_tpdo(feedback: &CstFeedback) -> [u8; TPDO_LEN as usize] {
    let [s0, s1] = feedback.statusword.to_le_bytes();
    let [p0, p1, p2, p3] = feedback.position.to_le_bytes();
    [s0, s1, p0, p1, p2, p3]
}

/// A TPDO payload read back; `None` unless it is exactly [`TPDO_LEN`] bytes.
pub fn decode_tpdo(payload: &[u8]) -> Option<CstFeedback> {
    match payload {
        [s0, s1, p0, p1, p2, p3] => Some(CstFeedback {
            statusword: u16::from_le_bytes([*s0, *s1]),
            position: i32::from_le_bytes([*p0, *p1, *p2, *p3]),
        }),
        _ => None,
    }
}

#[cfg(test)]
mod tests;
