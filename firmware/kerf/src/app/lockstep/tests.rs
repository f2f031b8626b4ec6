//! The machine's end against a tool written from the message table (module docs).

use super::*;
extern crate std;
use std::vec::Vec as StdVec;

type End = LockstepEnd<64, 8>;

/// Every message in `bytes`, as the tool parses them.
fn messages(bytes: &[u8]) -> StdVec<(u8, u32, StdVec<u8>)> {
    let mut out = StdVec::new();
    let mut rest = bytes;
    while !rest.is_empty() {
        match parse_machine(rest) {
            Ok(Some((MachineMessage::Sent { tick, frame }, n))) => {
                out.push((FRAME_SENT, tick, frame.to_vec()));
                rest = &rest[n..];
            }
            Ok(Some((MachineMessage::Waiting { tick }, n))) => {
                out.push((WAITING, tick, StdVec::new()));
                rest = &rest[n..];
            }
            Ok(None) => panic!("incomplete: {rest:?}"),
            Err(n) => rest = &rest[n..],
        }
    }
    out
}

fn delivery(due: u32, frame: &[u8]) -> StdVec<u8> {
    let mut out = delivery_head(due, frame.len()).unwrap().to_vec();
    out.extend_from_slice(frame);
    out
}

#[test]
fn periods_run_only_as_granted_and_the_wait_is_said_once() {
    let mut end = End::new();
    let mut said = StdVec::new();
    for _ in 0..3 {
        assert!(!end.may_run(&mut |b| said.extend_from_slice(b)));
    }
    end.feed(&grant(3));
    let mut ran = 0;
    for _ in 0..10 {
        if end.may_run(&mut |b| said.extend_from_slice(b)) {
            ran += 1;
            end.end_period();
        }
    }
    assert_eq!((ran, end.tick()), (3, 3));
    assert_eq!(
        messages(&said),
        [(WAITING, 0, StdVec::new()), (WAITING, 3, StdVec::new())]
    );
    // A grant behind the one held takes nothing back.
    end.feed(&grant(5));
    end.feed(&grant(4));
    assert!(end.may_run(&mut |_| {}));
}

#[test]
fn frames_go_out_with_their_period_and_come_in_when_due() {
    let mut end = End::new();
    end.feed(&grant(10));
    let mut said = StdVec::new();
    // Two deliveries out of due order, fed a byte at a time.
    let mut bytes = delivery(5, b"late");
    bytes.extend(delivery(3, b"early"));
    bytes.extend(delivery(3, b"second"));
    for b in bytes {
        end.feed(&[b]);
    }
    let mut got = StdVec::new();
    for _ in 0..8 {
        assert!(end.may_run(&mut |b| said.extend_from_slice(b)));
        let tick = end.tick();
        let mut write = |b: &[u8]| said.extend_from_slice(b);
        let mut link = end.link(&mut write);
        link.send(&[tick as u8, 0xAA]).unwrap();
        let mut buf = [0u8; 16];
        while let Some(n) = link.receive(&mut buf) {
            got.push((tick, buf[..n].to_vec()));
        }
        end.end_period();
    }
    assert_eq!(
        got,
        [
            (3, b"early".to_vec()),
            (3, b"second".to_vec()),
            (5, b"late".to_vec())
        ]
    );
    let sent: StdVec<_> = messages(&said);
    assert_eq!(sent.len(), 8);
    for (k, (kind, tick, frame)) in sent.iter().enumerate() {
        assert_eq!(
            (*kind, *tick, frame.as_slice()),
            (FRAME_SENT, k as u32, &[k as u8, 0xAA][..])
        );
    }
}

/// A frame longer than the end keeps is read to its end and dropped, a stray byte is
/// skipped, and the messages after both are read as they came; a frame longer than
/// the receiver's buffer is dropped too.
#[test]
fn damage_is_counted_and_the_stream_goes_on() {
    let mut end = LockstepEnd::<4, 8>::new();
    let mut bytes = std::vec![0x55];
    bytes.extend(delivery(0, b"too long"));
    bytes.extend(delivery(0, b"ok"));
    bytes.extend(delivery(0, b"four"));
    bytes.extend(grant(1));
    end.feed(&bytes);
    assert_eq!((end.garbled(), end.dropped()), (1, 1));
    assert!(end.may_run(&mut |_| {}));
    let mut write = |_: &[u8]| {};
    let mut link = end.link(&mut write);
    let mut small = [0u8; 3];
    assert_eq!(link.receive(&mut small), Some(2));
    assert_eq!(&small[..2], b"ok");
    assert_eq!(link.receive(&mut small), None);
    assert_eq!(end.dropped(), 2);
    // The tool's parser: incomplete messages wait, stray bytes are skipped.
    assert_eq!(parse_machine(&[WAITING, 1, 0]), Ok(None));
    assert_eq!(parse_machine(&[FRAME_SENT, 1, 0, 0, 0, 3, 0, 9]), Ok(None));
    assert_eq!(parse_machine(&[0x00, WAITING]), Err(1));
    assert_eq!(delivery_head(0, 70_000), None);
}

/// Two machines and a tool in rounds of W = 7 periods over a constant delay of 7: each
/// machine sends a frame every period carrying its tick, and every frame is received
/// exactly 7 periods after it was sent, whichever machine the tool serves first.
#[test]
fn two_machines_in_lockstep_see_the_delay_exactly() {
    const W: u32 = 7;
    let mut ends = [End::new(), End::new()];
    let mut to_tool: [StdVec<u8>; 2] = [StdVec::new(), StdVec::new()];
    let mut received: [StdVec<(u32, u32)>; 2] = [StdVec::new(), StdVec::new()];
    let mut granted = 0;
    for round in 0..20 {
        granted += W;
        for end in &mut ends {
            end.feed(&grant(granted));
        }
        // Each machine runs until it waits (the second first on odd rounds).
        for k in [round % 2, 1 - round % 2] {
            let (end, out) = (&mut ends[k], &mut to_tool[k]);
            while end.may_run(&mut |b| out.extend_from_slice(b)) {
                let tick = end.tick();
                let mut write = |b: &[u8]| out.extend_from_slice(b);
                let mut link = end.link(&mut write);
                link.send(&tick.to_le_bytes()).unwrap();
                let mut buf = [0u8; 4];
                while let Some(4) = link.receive(&mut buf) {
                    received[k].push((tick, u32::from_le_bytes(buf)));
                }
                end.end_period();
            }
        }
        // The tool: each frame to the other machine, due W after it was sent.
        for k in 0..2 {
            let bytes = std::mem::take(&mut to_tool[k]);
            for (kind, tick, frame) in messages(&bytes) {
                if kind == FRAME_SENT {
                    ends[1 - k].feed(&delivery(tick + W, &frame));
                }
            }
        }
    }
    for r in &received {
        assert_eq!(r.len(), (20 * W - W) as usize);
        assert!(r.iter().all(|(at, sent)| at - sent == W), "{r:?}");
    }
}
