//! The state and command codings against CiA 402's tables (the bit patterns written
//! out in the module docs), and the PDO layouts byte by byte.

use super::*;

/// Every statusword of the state coding table with its don't-care bits set both
/// ways decodes to the table's state.
#[test]
fn statusword_state_table() {
    // (pattern, mask of the bits the table fixes, state)
    let table = [
        (0b0000_0000, 0b0100_1111, DriveState::NotReadyToSwitchOn),
        (0b0100_0000, 0b0100_1111, DriveState::SwitchOnDisabled),
        (0b0010_0001, 0b0110_1111, DriveState::ReadyToSwitchOn),
        (0b0010_0011, 0b0110_1111, DriveState::SwitchedOn),
        (0b0010_0111, 0b0110_1111, DriveState::OperationEnabled),
        (0b0000_0111, 0b0110_1111, DriveState::QuickStopActive),
        (0b0000_1111, 0b0100_1111, DriveState::FaultReactionActive),
        (0b0000_1000, 0b0100_1111, DriveState::Fault),
    ];
    for (pattern, mask, state) in table {
        for free in [0x0000u16, 0xFFFF, 0x0210, 0x1E90] {
            let word = pattern | (free & !mask);
            assert_eq!(
                DriveState::from_statusword(word),
                Some(state),
                "{word:#06x}"
            );
        }
        assert_eq!(state.statusword() & mask, pattern);
    }
    // Codings the table leaves out.
    for word in [0x0001u16, 0x0003, 0x0025, 0x0002, 0x0004] {
        assert_eq!(DriveState::from_statusword(word), None, "{word:#06x}");
    }
    assert_eq!(DriveState::OperationEnabled.words(), "Operation enabled");
}

#[test]
fn controlword_command_table() {
    use DriveCommand::*;
    // Bits 3 2 1 0 of the command table, with the don't-cares both ways.
    let cases: [(u16, DriveCommand); 12] = [
        (0b0110, Shutdown),
        (0b1110, Shutdown),
        (0b0111, SwitchOn),
        (0b1111, EnableOperation),
        (0b0000, DisableVoltage),
        (0b1101, DisableVoltage),
        (0b0101, DisableVoltage),
        (0b0010, QuickStop),
        (0b1011, QuickStop),
        (0b0011, QuickStop),
        (0x0006, Shutdown),
        (0x000F, EnableOperation),
    ];
    for (word, command) in cases {
        assert_eq!(DriveCommand::from_controlword(word), command, "{word:#06b}");
    }
    assert_eq!(cw::SHUTDOWN, 0x06);
    assert_eq!(cw::SWITCH_ON_CMD, 0x07);
    assert_eq!(cw::ENABLE_OPERATION_CMD, 0x0F);
    assert_eq!(cw::FAULT_RESET, 0x80);
}

#[test]
fn pdo_layouts() {
    let pair = [
        CstCommand {
            controlword: 0x000F,
            target_torque: -2,
        },
        CstCommand {
            controlword: 0x0006,
            target_torque: 1000,
        },
    ];
    // 0x000F, 0xFFFE, 0x0006, 0x03E8 little endian.
    let bytes = encode_rpdo(&pair);
    assert_eq!(bytes, [0x0F, 0x00, 0xFE, 0xFF, 0x06, 0x00, 0xE8, 0x03]);
    assert_eq!(decode_rpdo(&bytes, 0), Some(pair[0]));
    assert_eq!(decode_rpdo(&bytes, 1), Some(pair[1]));
    assert_eq!(decode_rpdo(&bytes, 2), None);
    assert_eq!(decode_rpdo(&bytes[..6], 1), None);
    let fb = CstFeedback {
        statusword: 0x0237,
        position: -3,
    };
    let t = encode_tpdo(&fb);
    assert_eq!(t, [0x37, 0x02, 0xFD, 0xFF, 0xFF, 0xFF]);
    assert_eq!(decode_tpdo(&t), Some(fb));
    assert_eq!(decode_tpdo(&t[..5]), None);
    // Mapping entries: index << 16 | sub << 8 | bits; the dummy is 0x0006 (u16).
    assert_eq!(
        rpdo_mapping(0),
        [0x6040_0010, 0x6071_0010, 0x0006_0010, 0x0006_0010]
    );
    assert_eq!(
        rpdo_mapping(1),
        [0x0006_0010, 0x0006_0010, 0x6040_0010, 0x6071_0010]
    );
    assert_eq!(TPDO_MAPPING, [0x6041_0010, 0x6064_0020]);
}
