//! Both ends over a loopback: blocks, headers, sessions, copies, latency.
use super::*;
use crate::app::stream::tests::Loopback;
extern crate std;
use crate::codec::sdct::Selection;
use std::vec::Vec;

const SDCT: SdctConfig = SdctConfig {
    m: 8,
    selection: Selection::Largest,
};

/// Sends 8 commands (one block) from tick `first`, the beam on for the odd ones.
fn block(master: &mut MasterLink<8>, link: &mut Loopback, first: u32) {
    beam_block(master, link, first, 0b1010_1010);
}

/// Sends 8 commands (one block) from tick `first`, ten ticks apart, the beam on
/// where `beam` has a bit set.
fn beam_block(master: &mut MasterLink<8>, link: &mut Loopback, first: u32, beam: u8) {
    for j in 0..8u32 {
        let command = RemoteCommand {
            acceleration_m_s2: [0.01 * j as f32, -0.02, 0.0],
            laser_on: beam >> j & 1 == 1,
        };
        master.send(Some((first + 10 * j, command)), link);
    }
}

/// Every bit of a command frame's header flipped in turn (session, tick, beam
/// mask): the slave refuses the frame, so the beam stays off for a block the
/// master sent dark, the session does not restart and no tick of the block plays.
#[test]
fn a_flipped_command_header_bit_is_refused_and_never_fires_the_beam() {
    let mut link = Loopback::default();
    let mut master = MasterLink::<8>::new(&SDCT, 7, 1e-3).unwrap();
    let mut slave = SlaveLink::<8, 64>::new(&SDCT, 10, 0).unwrap();
    beam_block(&mut master, &mut link, 1, 0);
    let (first, _) = slave.receive(0, &mut link);
    assert!(first.is_some_and(|c| !c.laser_on));
    beam_block(&mut master, &mut link, 81, 0);
    let frame = link.0.remove(0);
    // What the first block alone plays from period 1 on: ticks 11 to 71.
    let expected: Vec<u32> = (1..8).map(|j| 1 + 10 * j).collect();
    for bit in 0..8 * COMMAND_HEADER {
        let mut flipped = frame.clone();
        flipped[bit / 8] ^= 1 << (bit % 8);
        let mut slave = slave.clone();
        let mut bad = Loopback(std::vec![flipped]);
        let (mut beam, mut ticks) = (false, Vec::new());
        for now in 1..200u32 {
            let (command, fresh) = slave.receive(now, &mut bad);
            beam |= command.is_some_and(|c| c.laser_on);
            if fresh {
                ticks.extend(slave.executing());
            }
        }
        assert!(!beam, "bit {bit} fired the beam");
        assert_eq!((slave.refused(), slave.restarts()), (1, 0), "bit {bit}");
        assert_eq!(ticks, expected, "bit {bit}");
    }
}

/// Every bit of a report frame's header flipped in turn (echo tick, session,
/// flags): the master refuses the frame and reports nothing from it.
#[test]
fn a_flipped_report_header_bit_is_refused() {
    let (mut link, mut back) = (Loopback::default(), Loopback::default());
    let mut master = MasterLink::<8>::new(&SDCT, 3, 1e-3).unwrap();
    let mut slave = SlaveLink::<8, 64>::new(&SDCT, 1, 0).unwrap();
    block(&mut master, &mut link, 5);
    let _ = slave.receive(0, &mut link);
    for _ in 0..8 {
        slave.report(Some([0.001, 0.002, 0.05]), &mut back);
    }
    let frame = back.0.remove(0);
    for bit in 0..8 * REPORT_HEADER {
        let mut flipped = frame.clone();
        flipped[bit / 8] ^= 1 << (bit % 8);
        let mut master = master.clone();
        let report = master.receive(&mut Loopback(std::vec![flipped]));
        assert_eq!((report, master.refused()), (None, 1), "bit {bit}");
    }
    let report = master.receive(&mut Loopback(std::vec![frame])).unwrap();
    assert_eq!((report.echo_tick, master.refused()), (Some(5), 0));
}

#[test]
fn commands_play_in_order_and_a_second_master_is_dropped_until_the_first_falls_silent() {
    let mut link = Loopback::default();
    let mut master = MasterLink::<8>::new(&SDCT, 7, 1e-3).unwrap();
    let mut slave = SlaveLink::<8, 64>::new(&SDCT, 10, 0).unwrap();
    block(&mut master, &mut link, 1);
    // Anchored at arrival: tick 1 plays at period 0, tick 11 at 10, ...
    let mut played = Vec::new();
    for now in 0..80u32 {
        let (command, fresh) = slave.receive(now, &mut link);
        if fresh {
            played.push((now, command.unwrap(), slave.executing().unwrap()));
        }
    }
    assert_eq!(played.len(), 8);
    for (j, (now, command, tick)) in played.iter().enumerate() {
        assert_eq!((*now, *tick), (10 * j as u32, 1 + 10 * j as u32));
        assert_eq!(command.laser_on, j % 2 == 1);
        let want = 0.01 * j as f32;
        assert!((command.acceleration_m_s2[0] - want).abs() < 1e-3);
    }
    // Another session while the first is heard (within two block periods, 160
    // periods, of its last frame): a second master, dropped and counted.
    let mut restarted = MasterLink::<8>::new(&SDCT, 8, 1e-3).unwrap();
    for first in [1, 81, 161] {
        block(&mut restarted, &mut link, first);
    }
    let (_, fresh) = slave.receive(100, &mut link);
    assert!(!fresh);
    assert_eq!((slave.foreign(), slave.restarts()), (3, 0));
    // The first session silent for 160 periods: the new one is the master that
    // restarted. Its sequence runs on from the old stream's, and the new session
    // restarts the playout, which would otherwise refuse its ticks as stale.
    for first in [241, 321] {
        block(&mut restarted, &mut link, first);
    }
    let (command, fresh) = slave.receive(200, &mut link);
    assert!(fresh && command.is_some());
    assert_eq!(
        (slave.refused(), slave.repeats(), slave.foreign()),
        (0, 0, 3)
    );
    assert_eq!((slave.restarts(), slave.executing()), (1, Some(241)));
}

/// Five blocks sent three times each, with the link losing blocks 1 and 2's frames
/// and first copies: every tick still plays, in order, with its
/// value, and the copies of blocks already taken are counted as repeats. Sent
/// once, the same losses leave blocks 1 and 2 out.
#[test]
fn copies_of_each_frame_fill_what_the_link_lost() {
    for (copies, expected_ticks, expected_repeats) in [(3usize, 40usize, 4u32), (1, 24, 0)] {
        let mut link = Loopback::default();
        let mut master = MasterLink::<8>::new(&SDCT, 7, 1e-3)
            .and_then(|m| m.with_copies(copies))
            .unwrap();
        let mut slave = SlaveLink::<8, 64>::new(&SDCT, 10, 0).unwrap();
        let mut frames = Vec::new();
        for k in 0..5u32 {
            block(&mut master, &mut link, 1 + 80 * k);
            frames.append(&mut link.0);
        }
        assert_eq!(frames.len(), if copies == 3 { 5 + 2 * 4 } else { 5 });
        // On the wire: f0 | c0 c0 f1 | c1 c1 f2 | c2 c2 f3 | c3 c3 f4 (three copies).
        // Lost: f1, its first copy, f2 and its first copy.
        let lost = |i: usize| {
            if copies == 3 {
                [3, 4, 6, 7].contains(&i)
            } else {
                [1, 2].contains(&i)
            }
        };
        link.0 = frames
            .into_iter()
            .enumerate()
            .filter(|(i, _)| !lost(*i))
            .map(|(_, f)| f)
            .collect();
        let mut played = Vec::new();
        for now in 0..500u32 {
            let (command, fresh) = slave.receive(now, &mut link);
            if fresh {
                played.push((slave.executing().unwrap(), command.unwrap()));
            }
        }
        assert_eq!(played.len(), expected_ticks, "{copies} copies");
        assert_eq!((slave.refused(), slave.repeats()), (0, expected_repeats));
        for pair in played.windows(2) {
            assert!(pair[0].0 < pair[1].0);
        }
        for (tick, command) in &played {
            let j = (tick - 1) % 80 / 10;
            let want = 0.01 * j as f32;
            assert!((command.acceleration_m_s2[0] - want).abs() < 1e-3, "{tick}");
        }
    }
    for copies in [0, MAX_COPIES + 1] {
        let link = MasterLink::<8>::new(&SDCT, 7, 1e-3).unwrap();
        assert!(link.with_copies(copies).is_err());
    }
}

/// The latency the slave reports is the one its playout keeps: every command plays
/// `latency_periods` after its master tick (measured here as play period − tick),
/// first anchored at the first arrival plus the margin (12 − 1 + 5 periods), then
/// re-anchored by a block that arrives late (150 − 81 + 5). `None` before any
/// command.
#[test]
fn the_latency_is_the_delay_each_command_plays_at() {
    let mut link = Loopback::default();
    let mut master = MasterLink::<8>::new(&SDCT, 7, 1e-3).unwrap();
    let mut slave = SlaveLink::<8, 64>::new(&SDCT, 10, 5).unwrap();
    assert_eq!(slave.latency_periods(), None);
    let mut delays = Vec::new();
    for (first, arrival) in [(1u32, 12u32), (81, 150)] {
        for now in arrival - 12..arrival {
            let _ = slave.receive(now, &mut link);
        }
        assert_eq!(slave.latency_periods().is_some(), first > 1);
        block(&mut master, &mut link, first);
        for now in arrival..arrival + 100 {
            let (_, fresh) = slave.receive(now, &mut link);
            let tick = slave.executing().unwrap_or(0);
            if fresh && tick >= first {
                assert_eq!(slave.latency_periods(), Some(now - tick), "tick {tick}");
                delays.push(now - tick);
            }
        }
    }
    // Both anchors were met by played commands (8 of each block).
    assert_eq!(delays.len(), 16, "{delays:?}");
    assert_eq!((delays[0], delays[15]), (16, 74));
}

#[test]
fn reports_carry_the_echo_only_within_the_masters_session() {
    let mut link = Loopback::default();
    let mut back = Loopback::default();
    let mut master = MasterLink::<8>::new(&SDCT, 3, 1e-3).unwrap();
    let mut slave = SlaveLink::<8, 64>::new(&SDCT, 1, 0).unwrap();
    // Before any command: reports with no echo.
    for _ in 0..8 {
        slave.report(Some([0.001, 0.002, 0.05]), &mut back);
    }
    let report = master.receive(&mut back).unwrap();
    assert_eq!(report.echo_tick, None);
    assert!((report.position_m[2] - 0.05).abs() < 1e-4);
    block(&mut master, &mut link, 5);
    let _ = slave.receive(0, &mut link);
    for _ in 0..8 {
        slave.report(Some([0.001, 0.002, 0.05]), &mut back);
    }
    assert_eq!(master.receive(&mut back).unwrap().echo_tick, Some(5));
    // Another master (session) sees the report without an echo.
    let mut other = MasterLink::<8>::new(&SDCT, 4, 1e-3).unwrap();
    for _ in 0..8 {
        slave.report(Some([0.001, 0.002, 0.05]), &mut back);
    }
    assert_eq!(other.receive(&mut back).unwrap().echo_tick, None);
    // A cut frame is refused and counted.
    for _ in 0..8 {
        slave.report(Some([0.001, 0.002, 0.05]), &mut back);
    }
    if let Some(frame) = back.0.first_mut() {
        frame.truncate(frame.len() - 3);
    }
    assert!(master.receive(&mut back).is_none());
    assert_eq!(master.refused(), 1);
}

/// Raw samples: each command plays as soon as it arrives, with no block to wait for
/// (the SDCT ends play nothing before a block's last sample is sent); the reports
/// carry the echo and give the velocity from consecutive positions. A frame with a
/// flipped bit is refused; a copy of a played command is a repeat.
#[test]
fn raw_samples_play_at_once_and_report_each_sample() {
    let (mut link, mut back) = (Loopback::default(), Loopback::default());
    let mut master = MasterLink::<8>::new(&SDCT, 5, 1e-3)
        .unwrap()
        .with_raw_samples();
    let mut slave = SlaveLink::<8, 64>::new(&SDCT, 10, 0)
        .unwrap()
        .with_raw_samples();
    let mut coded = MasterLink::<8>::new(&SDCT, 5, 1e-3).unwrap();
    let mut coded_link = Loopback::default();
    for j in 0..4u32 {
        let now = 10 * j;
        let command = RemoteCommand {
            acceleration_m_s2: [0.5 * j as f32, -0.25, 1.0],
            laser_on: j % 2 == 0,
        };
        master.send(Some((1 + now, command)), &mut link);
        coded.send(Some((1 + now, command)), &mut coded_link);
        let (played, fresh) = slave.receive(now, &mut link);
        assert_eq!((played, fresh), (Some(command), true), "sample {j}");
        assert_eq!(slave.executing(), Some(1 + now));
        // A period's report (one every ten periods: this one).
        slave.report(Some([0.001 * j as f32, 0.0, 0.05]), &mut back);
        let report = master.receive(&mut back).unwrap();
        assert_eq!(report.echo_tick, Some(1 + now));
        let want = if j == 0 { 0.0 } else { 1.0 };
        assert!((report.velocity_m_s[0] - want).abs() < 1e-3, "{report:?}");
        for _ in 1..10 {
            slave.report(Some([0.0; 3]), &mut back);
        }
        assert!(back.0.is_empty());
    }
    // The coded end has sent nothing yet: half a block.
    assert!(coded_link.0.is_empty());
    assert_eq!(link.0.len(), 0);
    // One flipped bit: refused; the same command again: a repeat.
    let command = RemoteCommand::default();
    master.send(Some((41, command)), &mut link);
    let mut frame = link.0.remove(0);
    let good = frame.clone();
    frame[3] ^= 0x10;
    link.0.push(frame);
    link.0.push(good.clone());
    link.0.push(good);
    let _ = slave.receive(40, &mut link);
    assert_eq!((slave.refused(), slave.repeats()), (1, 1));
}
