//! The simulated drive against CiA 402's state table and CiA 301's SDO aborts.

use super::*;
use kerf::codec::canopen::{cob, sync};
use std::vec::Vec;

fn config(node: u8, slot: u8) -> SimDriveConfig {
    SimDriveConfig {
        bus: 0,
        node,
        rpdo_id: 0x201,
        slot,
        rated_mn: 1_250_000,
        peak_permille: 2400,
        increment_m: 50e-9,
        watchdog_periods: 3,
    }
}

fn pair() -> SimDriveSet<2> {
    SimDriveSet::new([config(1, 0), config(2, 1)])
}

fn drain(set: &mut SimDriveSet<2>) -> Vec<CanFrame> {
    core::iter::from_fn(|| set.next_frame().map(|(_, f)| f)).collect()
}

fn rpdo(a: u16, ta: i16, b: u16, tb: i16) -> CanFrame {
    let pair = [
        CstCommand {
            controlword: a,
            target_torque: ta,
        },
        CstCommand {
            controlword: b,
            target_torque: tb,
        },
    ];
    CanFrame::new(0x201, &cia402::encode_rpdo(&pair)).unwrap()
}

/// Both drives booted, mode 10 set, operational.
fn started() -> SimDriveSet<2> {
    let mut set = pair();
    set.deliver(0, &NmtCommand::ResetNode.frame(0));
    let boot = drain(&mut set);
    assert_eq!(
        boot,
        [NmtState::BootUp.heartbeat(1), NmtState::BootUp.heartbeat(2)]
    );
    for node in [1, 2] {
        let write = SdoRequest::Download {
            od: od_at(0x6060),
            value: 10,
            size: 1,
        };
        set.deliver(0, &write.frame(node).unwrap());
    }
    assert_eq!(drain(&mut set).len(), 2);
    set.deliver(0, &NmtCommand::Start.frame(0));
    set
}

fn od_at(index: u16) -> Od {
    Od::at(index)
}

/// One period: the RPDO latched, then the SYNC that applies it; the TPDOs' states.
fn period(set: &mut SimDriveSet<2>, frame: CanFrame) -> Vec<Option<DriveState>> {
    set.deliver(0, &frame);
    set.deliver(0, &sync(Some(1)));
    drain(set)
        .iter()
        .filter(|f| f.function() == cob::TPDO1)
        .map(|f| {
            cia402::decode_tpdo(f.payload())
                .and_then(|fb| DriveState::from_statusword(fb.statusword))
        })
        .collect()
}

#[test]
fn the_controlword_walk_and_ignored_commands() {
    use DriveState::*;
    let mut set = started();
    // Enable operation in Switch on disabled is no transition: ignored.
    assert_eq!(
        period(&mut set, rpdo(0x0F, 0, 0x0F, 0)),
        [Some(SwitchOnDisabled); 2]
    );
    // Shutdown → Ready to switch on (T2); Switch on → Switched on (T3); Enable
    // operation → Operation enabled (T4). Drive 2 takes "switch on + enable
    // operation" from Ready to switch on (T3 + T4).
    assert_eq!(
        period(&mut set, rpdo(0x06, 0, 0x06, 0)),
        [Some(ReadyToSwitchOn); 2]
    );
    assert_eq!(
        period(&mut set, rpdo(0x07, 0, 0x0F, 0)),
        [Some(SwitchedOn), Some(OperationEnabled)]
    );
    assert_eq!(
        period(&mut set, rpdo(0x0F, 400, 0x0F, -3000)),
        [Some(OperationEnabled); 2]
    );
    // 400 ‰ of 1,250 N; -3,000 ‰ clipped at the default max torque 1,000 ‰.
    assert_eq!(set.forces_n(), [500.0, -1250.0]);
    // Quick stop → Quick stop active (T11), no force; Disable voltage → Switch on
    // disabled (T12).
    assert_eq!(
        period(&mut set, rpdo(0x02, 400, 0x0F, 0)),
        [Some(QuickStopActive), Some(OperationEnabled)]
    );
    assert_eq!(set.forces_n()[0], 0.0);
    assert_eq!(
        period(&mut set, rpdo(0x00, 0, 0x07, 0)),
        [Some(SwitchOnDisabled), Some(SwitchedOn)]
    );
}

#[test]
fn sdo_aborts_for_bad_objects() {
    let mut set = started();
    let write = |index, sub, value, size| SdoRequest::Download {
        od: Od { index, sub },
        value,
        size,
    };
    let code = |r: Option<SdoResponse>| match r {
        Some(SdoResponse::Abort { code, .. }) => Some(code.0),
        _ => None,
    };
    assert_eq!(code(set.sdo(0, write(0x6060, 1, 10, 1))), Some(0x0609_0011));
    assert_eq!(code(set.sdo(0, write(0x2345, 0, 10, 1))), Some(0x0602_0000));
    assert_eq!(code(set.sdo(0, write(0x6060, 0, 3, 1))), Some(0x0609_0030));
    assert_eq!(
        code(set.sdo(0, write(0x6072, 0, 2401, 2))),
        Some(0x0609_0030)
    );
    assert_eq!(code(set.sdo(0, write(0x6061, 0, 10, 1))), Some(0x0601_0002));
    assert_eq!(code(set.sdo(0, write(0x6072, 0, 10, 4))), Some(0x0607_0010));
    assert_eq!(
        set.read(0, Od::at(0x6076)),
        Some(SdoResponse::Uploaded {
            od: Od::at(0x6076),
            value: 1_250_000,
            size: 4
        })
    );
    set.inject(1, Injection::RefuseCst);
    assert_eq!(code(set.sdo(1, write(0x6060, 0, 10, 1))), Some(0x0609_0030));
    assert_eq!(code(set.sdo(1, write(0x6060, 0, 9, 1))), None);
}

#[test]
fn watchdog_heartbeat_and_injected_faults() {
    let mut set = started();
    for frame in [
        rpdo(0x06, 0, 0x06, 0),
        rpdo(0x0F, 0, 0x0F, 0),
        rpdo(0x0F, 0, 0x0F, 0),
    ] {
        period(&mut set, frame);
    }
    assert_eq!(set.state(0), Some(DriveState::OperationEnabled));
    // Over-current on drive 1: EMCY 0x2310 at once, Fault, no force.
    set.inject(1, Injection::Overcurrent);
    let emcy = drain(&mut set);
    assert_eq!(
        emcy.first().map(Emergency::parse),
        Some(Ok(Emergency {
            code: 0x2310,
            register: 0x03
        }))
    );
    assert_eq!(set.state(1), Some(DriveState::Fault));
    assert_eq!(set.forces_n()[1], 0.0);
    // Three ticks without SYNC are allowed, the fourth trips drive 0's watchdog.
    for _ in 0..3 {
        set.tick(2e-4);
    }
    assert!(drain(&mut set).is_empty());
    set.tick(2e-4);
    let frames = drain(&mut set);
    assert_eq!(frames.len(), 1);
    assert_eq!(Emergency::parse(&frames[0]).map(|e| e.code), Ok(0x8130));
    assert_eq!(set.state(0), Some(DriveState::Fault));
    // A fault reset (bit 7's rising edge) clears the over-current.
    period(&mut set, rpdo(0x00, 0, 0x00, 0));
    assert_eq!(
        period(&mut set, rpdo(0x80, 0, 0x80, 0)),
        [Some(DriveState::SwitchOnDisabled); 2]
    );
    // Heartbeat every 1 ms: 5 ticks of 0.2 ms.
    let hb = SdoRequest::Download {
        od: Od::at(0x1017),
        value: 1,
        size: 2,
    };
    set.deliver(0, &hb.frame(1).unwrap());
    drain(&mut set);
    for k in 1..=10 {
        set.deliver(0, &sync(None));
        drain(&mut set);
        set.tick(2e-4);
        let beats = drain(&mut set);
        assert_eq!(beats.len(), usize::from(k % 5 == 0), "tick {k}");
    }
    // An encoder fault: EMCY 0x7305 at the next SYNC; a fault reset does not clear it.
    set.inject(0, Injection::EncoderFault);
    set.deliver(0, &sync(None));
    let frames = drain(&mut set);
    assert_eq!(Emergency::parse(&frames[0]).map(|e| e.code), Ok(0x7305));
    period(&mut set, rpdo(0x00, 0, 0x00, 0));
    assert_eq!(
        period(&mut set, rpdo(0x80, 0, 0x80, 0))[0],
        Some(DriveState::Fault)
    );
    // A silent drive sends nothing.
    set.inject(1, Injection::Silent);
    assert_eq!(period(&mut set, rpdo(0x06, 0, 0x06, 0)).len(), 1);
}

/// Each drive's NMT state follows the master's commands (CiA 301 §7.3.2.2: nothing
/// before boot-up, pre-operational after it), to its own node or to all.
#[test]
fn nmt_states_follow_the_commands() {
    let mut set = pair();
    assert_eq!([set.nmt(0), set.nmt(1)], [None, None]);
    // Before boot-up a Start changes nothing.
    set.deliver(0, &NmtCommand::Start.frame(0));
    assert_eq!(set.nmt(0), None);
    set.deliver(0, &NmtCommand::ResetNode.frame(0));
    drain(&mut set);
    assert_eq!(set.nmt(0), Some(NmtState::PreOperational));
    // Node 2 alone started, then all stopped.
    set.deliver(0, &NmtCommand::Start.frame(2));
    assert_eq!(
        [set.nmt(0), set.nmt(1)],
        [Some(NmtState::PreOperational), Some(NmtState::Operational)]
    );
    set.deliver(0, &NmtCommand::Stop.frame(0));
    assert_eq!([set.nmt(0), set.nmt(1)], [Some(NmtState::Stopped); 2]);
    assert_eq!(set.nmt(2), None);
}

/// The encoders see the positions set, in whole increments of 50 nm, rounded: read
/// back as 0x6064 and in the TPDO of the next SYNC.
#[test]
fn positions_are_seen_in_whole_increments() {
    let mut set = started();
    // 1.00000 mm is 20 000 increments; −0.12345 mm is −2469.0 increments,
    // 1.23458 mm is 24 691.6 (up to 24 692: rounded, not cut).
    set.set_positions_m(&[1e-3, -0.12345e-3]);
    let read = |set: &mut SimDriveSet<2>, i| match set.read(i, od_at(0x6064)) {
        Some(SdoResponse::Uploaded { value, size: 4, .. }) => Some(value as i32),
        _ => None,
    };
    assert_eq!(read(&mut set, 0), Some(20_000));
    assert_eq!(read(&mut set, 1), Some(-2469));
    set.set_positions_m(&[1.23458e-3, 0.0]);
    set.deliver(0, &sync(Some(1)));
    let positions: Vec<i32> = drain(&mut set)
        .iter()
        .filter(|f| f.function() == cob::TPDO1)
        .filter_map(|f| cia402::decode_tpdo(f.payload()).map(|fb| fb.position))
        .collect();
    assert_eq!(positions, [24_692, 0]);
}
