//! Frames checked byte by byte against CiA 301's tables (the command specifiers
//! of §7.2.4.3, the NMT and heartbeat codings of §7.2.8.3) written out here, not
//! against the encoder.

use super::*;

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::new(id, data).unwrap()
}

#[test]
fn nmt_commands_are_the_tables_bytes() {
    // NMT: COB-ID 0, byte 0 the command specifier, byte 1 the node (0 = all).
    assert_eq!(NmtCommand::Start.frame(0), frame(0x000, &[0x01, 0x00]));
    assert_eq!(NmtCommand::Stop.frame(3), frame(0x000, &[0x02, 0x03]));
    assert_eq!(
        NmtCommand::PreOperational.frame(4),
        frame(0x000, &[0x80, 0x04])
    );
    assert_eq!(NmtCommand::ResetNode.frame(5), frame(0x000, &[0x81, 0x05]));
    assert_eq!(
        NmtCommand::ResetCommunication.frame(6),
        frame(0x000, &[0x82, 0x06])
    );
    assert_eq!(
        Received::parse(&frame(0x000, &[0x81, 0x05])),
        Ok(Received::Nmt(NmtCommand::ResetNode, 5))
    );
    assert_eq!(
        Received::parse(&frame(0x000, &[0x7E, 0x05])),
        Err(FrameError::BadPayload)
    );
}

#[test]
fn heartbeat_boot_up_and_sync() {
    assert_eq!(NmtState::BootUp.heartbeat(2), frame(0x702, &[0x00]));
    assert_eq!(NmtState::Operational.heartbeat(2), frame(0x702, &[0x05]));
    assert_eq!(NmtState::PreOperational.heartbeat(9), frame(0x709, &[0x7F]));
    assert_eq!(NmtState::Stopped.heartbeat(9), frame(0x709, &[0x04]));
    assert_eq!(
        Received::parse(&frame(0x705, &[0x85])),
        Ok(Received::Heartbeat(5, NmtState::Operational)),
        "bit 7 is the toggle bit of node guarding"
    );
    assert_eq!(sync(None), frame(0x080, &[]));
    assert_eq!(sync(Some(7)), frame(0x080, &[7]));
    assert_eq!(
        Received::parse(&sync(Some(240))),
        Ok(Received::Sync(Some(240)))
    );
    assert_eq!(
        Received::parse(&frame(0x080, &[0])),
        Err(FrameError::BadPayload),
        "the counter runs 1-240"
    );
    assert_eq!(next_sync_counter(240, 240), 1);
    assert_eq!(next_sync_counter(4, 4), 1);
    assert_eq!(next_sync_counter(1, 240), 2);
}

#[test]
fn sdo_expedited_bytes() {
    // Download 0x6060.00 = 10 (1 byte): ccs 1, n 3, e 1, s 1 = 0x2F.
    let write_mode = SdoRequest::Download {
        od: Od::at(0x6060),
        value: 10,
        size: 1,
    };
    assert_eq!(
        write_mode.frame(1),
        Ok(frame(0x601, &[0x2F, 0x60, 0x60, 0x00, 0x0A, 0, 0, 0]))
    );
    // 2 bytes: n 2 = 0x2B; 4 bytes: n 0 = 0x23; 3 bytes: 0x27.
    let heartbeat = SdoRequest::Download {
        od: Od::at(0x1017),
        value: 100,
        size: 2,
    };
    assert_eq!(
        heartbeat.frame(6),
        Ok(frame(0x606, &[0x2B, 0x17, 0x10, 0x00, 100, 0, 0, 0]))
    );
    let four = SdoRequest::Download {
        od: Od {
            index: 0x1600,
            sub: 3,
        },
        value: 0x6071_0010,
        size: 4,
    };
    assert_eq!(
        four.frame(2),
        Ok(frame(
            0x602,
            &[0x23, 0x00, 0x16, 0x03, 0x10, 0x00, 0x71, 0x60]
        ))
    );
    let three = SdoRequest::Download {
        od: Od::at(0x2000),
        value: 0xFF12_3456,
        size: 3,
    };
    assert_eq!(
        three.frame(2),
        Ok(frame(0x602, &[0x27, 0x00, 0x20, 0x00, 0x56, 0x34, 0x12, 0]))
    );
    // Upload request: ccs 2 = 0x40.
    let read = SdoRequest::Upload { od: Od::at(0x6061) };
    assert_eq!(
        read.frame(1),
        Ok(frame(0x601, &[0x40, 0x61, 0x60, 0x00, 0, 0, 0, 0]))
    );
    // Responses: download 0x60; upload of 1 byte 0x4F, 2 bytes 0x4B, 4 bytes 0x43.
    let up = frame(0x581, &[0x4F, 0x61, 0x60, 0x00, 0x0A, 0, 0, 0]);
    assert_eq!(
        SdoResponse::parse(&up),
        Ok(SdoResponse::Uploaded {
            od: Od::at(0x6061),
            value: 10,
            size: 1
        })
    );
    let up4 = frame(0x581, &[0x43, 0x76, 0x60, 0x00, 0xD0, 0x12, 0x13, 0x00]);
    assert_eq!(
        SdoResponse::parse(&up4),
        Ok(SdoResponse::Uploaded {
            od: Od::at(0x6076),
            value: 1_250_000,
            size: 4
        })
    );
    let done = frame(0x581, &[0x60, 0x60, 0x60, 0x00, 0, 0, 0, 0]);
    assert_eq!(
        SdoResponse::parse(&done),
        Ok(SdoResponse::Downloaded { od: Od::at(0x6060) })
    );
    assert_eq!(
        SdoResponse::Downloaded { od: Od::at(0x6060) }.frame(1),
        Ok(done)
    );
    // Abort: 0x80, the code little endian in bytes 4-7.
    let abort = frame(0x583, &[0x80, 0x60, 0x60, 0x00, 0x30, 0x00, 0x09, 0x06]);
    let parsed = SdoResponse::parse(&abort);
    assert_eq!(
        parsed,
        Ok(SdoResponse::Abort {
            od: Od::at(0x6060),
            code: SdoAbort::INVALID_VALUE
        })
    );
    assert_eq!(
        SdoRequest::parse(&write_mode.frame(1).unwrap()),
        Ok(write_mode)
    );
    assert_eq!(SdoRequest::parse(&read.frame(1).unwrap()), Ok(read));
    assert_eq!(
        SdoRequest::parse(&three.frame(2).unwrap()),
        Ok(SdoRequest::Download {
            od: Od::at(0x2000),
            value: 0x12_3456,
            size: 3
        }),
        "three bytes sent, the fourth dropped"
    );
}

#[test]
fn sdo_refusals() {
    let bad_size = SdoRequest::Download {
        od: Od::at(0x6060),
        value: 1,
        size: 5,
    };
    assert_eq!(bad_size.frame(1), Err(FrameError::BadPayload));
    assert_eq!(
        SdoRequest::Upload { od: Od::at(1) }.frame(0),
        Err(FrameError::BadNode)
    );
    assert_eq!(
        SdoRequest::Upload { od: Od::at(1) }.frame(128),
        Err(FrameError::BadNode)
    );
    // A segmented download initiation (e = 0) is not read.
    let segmented = frame(0x601, &[0x21, 0x00, 0x20, 0x00, 8, 0, 0, 0]);
    assert_eq!(SdoRequest::parse(&segmented), Err(FrameError::BadPayload));
    let short = frame(0x581, &[0x60, 0x60, 0x60]);
    assert_eq!(SdoResponse::parse(&short), Err(FrameError::BadLength));
    assert_eq!(CanFrame::new(0x800, &[]), Err(FrameError::IdTooLarge));
    assert_eq!(CanFrame::new(1, &[0; 9]), Err(FrameError::BadLength));
}

#[test]
fn abort_codes_in_words() {
    assert_eq!(SdoAbort(0x0609_0011).words(), "sub-index does not exist");
    assert_eq!(
        SdoAbort(0x0602_0000).words(),
        "object does not exist in the object dictionary"
    );
    assert_eq!(
        SdoAbort(0x0609_0030).words(),
        "invalid value for parameter (value range exceeded)"
    );
    assert_eq!(
        std::format!("{}", SdoAbort(0x0601_0002)),
        "0x06010002 attempt to write a read-only object"
    );
}

#[test]
fn emergency_bytes_and_words() {
    // EMCY of node 3: 0x083, code 0x2310 little endian, error register 0x03
    // (generic + current).
    let raw = frame(0x083, &[0x10, 0x23, 0x03, 0, 0, 0, 0, 0]);
    let e = Emergency {
        code: 0x2310,
        register: 0x03,
    };
    assert_eq!(Received::parse(&raw), Ok(Received::Emcy(3, e)));
    assert_eq!(e.frame(3), Ok(raw));
    assert_eq!(e.words(), "continuous over-current");
    let words = |code| Emergency { code, register: 0 }.words();
    assert_eq!(words(0x3210), "DC link over-voltage");
    assert_eq!(words(0x7305), "incremental sensor 1 fault");
    assert_eq!(words(0x8130), "life guard error or heartbeat error");
    assert_eq!(words(0x8611), "following error");
    assert_eq!(words(0x5441), "power stage disabled (safe torque off)");
    assert_eq!(
        words(0x4210),
        "temperature",
        "the class of an unlisted code"
    );
    assert_eq!(
        std::format!("{e}"),
        "EMCY 0x2310 continuous over-current (error register 0x03)"
    );
}

#[test]
fn identifiers_of_the_connection_set() {
    let tpdo = frame(0x184, &[0; 6]);
    assert_eq!(Received::parse(&tpdo), Ok(Received::Tpdo(4)));
    assert_eq!(
        Received::parse(&frame(0x201, &[0; 8])),
        Ok(Received::Rpdo(1))
    );
    assert_eq!(
        Received::parse(&frame(0x300, &[])),
        Err(FrameError::UnknownId)
    );
    assert_eq!(
        Received::parse(&frame(0x281, &[])),
        Err(FrameError::UnknownId),
        "TPDO2 is not used"
    );
}

/// Node ids are 1–127 (CiA 301 §7.3.2.2; 0 addresses all nodes in NMT only): the
/// edges of the range pass, one past either edge is refused as a bad node.
#[test]
fn node_ids_are_one_to_127() {
    for node in [1u8, 2, 64, 126, 127] {
        assert_eq!(node_id(node), Ok(node));
    }
    for node in [0u8, 128, 200, 255] {
        assert_eq!(node_id(node), Err(FrameError::BadNode), "{node}");
    }
}
