//! The stream frames of `app::stream` (`stream_frame`) and the remote machining link's
//! two ends behind them (`remote_link`, headers included).
//!
//! Every seed frame is made by the public senders ([`StreamSender`], [`MasterLink`],
//! `SlaveLink`), and the harnesses also let the fuzzer drive those senders, so the
//! targets follow a change of the frame format (a header CRC, say) without change;
//! only the committed corpus must be written again (`gen_corpus`).

use crate::input::{Input, Seed};
use kerf::app::remote_link::MasterLink;
use kerf::app::remote_link::RemoteCommand;
use kerf::app::stream::{StreamReceiver, StreamSender, MAX_FRAME_HEADER};
use kerf::codec::packet::MAX_SAMPLE_ABS;
use kerf::codec::sdct::{SdctConfig, Selection};
use kerf::hal::{FrameLink, LinkBusy};
use kerf_sim::remote::{SiteLink, BLOCK};
use std::collections::VecDeque;

/// A link whose frames are queued in order.
#[derive(Default)]
pub struct Queued(pub VecDeque<Vec<u8>>);

impl FrameLink for Queued {
    fn send(&mut self, frame: &[u8]) -> Result<(), LinkBusy> {
        self.0.push_back(frame.to_vec());
        Ok(())
    }
    fn receive(&mut self, buf: &mut [u8]) -> Option<usize> {
        let frame = self.0.pop_front()?;
        // A frame longer than the buffer is dropped, as a link drops it.
        let into = buf.get_mut(..frame.len())?;
        into.copy_from_slice(&frame);
        Some(frame.len())
    }
}

fn in_range(x: f32) -> bool {
    x.is_finite() && x.abs() <= MAX_SAMPLE_ABS
}

/// The step kinds of a `stream_frame` input.
mod stream_step {
    /// A frame as received.
    pub const FRAME: u8 = 0;
    /// Samples for the sender (f32 each, one per channel per sample).
    pub const SAMPLES: u8 = 1;
}

/// What the receiver took so far.
struct Received {
    accepted: usize,
    last: Option<u64>,
    /// Only the sender's frames were accepted so far.
    clean: bool,
}

/// Polls every frame on `link`; `sent_blocks` is the sender's block count when the
/// frames are its own.
fn poll<const C: usize, const N: usize>(
    receiver: &mut StreamReceiver<C, N>,
    link: &mut Queued,
    header: &mut [u8],
    sent_blocks: Option<u64>,
    state: &mut Received,
) {
    const UNTOUCHED: u32 = 0x7FC0_1234;
    let mut out = [[f32::from_bits(UNTOUCHED); N]; C];
    while let Some(result) = receiver.poll_frame(link, header, &mut out) {
        let Ok(block) = result else {
            // A refused frame leaves the output alone.
            assert!(out.iter().flatten().all(|x| x.to_bits() == UNTOUCHED));
            if sent_blocks.is_some() && state.clean {
                panic!("the receiver refused its sender's frame: {result:?}");
            }
            continue;
        };
        state.accepted += 1;
        assert!(out.iter().flatten().all(|&x| in_range(x)), "{out:?}");
        if !block.resynchronised {
            let last = state.last;
            assert!(
                last.is_none_or(|l| block.first_sample >= l),
                "{block:?} after {last:?}"
            );
        }
        state.last = Some(block.first_sample);
        match sent_blocks {
            Some(sent) if state.clean => {
                // Only the sender's frames so far: every block in order, none lost but
                // those it dropped (non-finite samples).
                assert!(header.iter().all(|&b| b == 0xA5));
                assert_eq!(block.sequence, (sent - 1) as u16);
                assert_eq!(block.first_sample, (sent - 1) * N as u64);
            }
            _ => state.clean = false,
        }
        out = [[f32::from_bits(UNTOUCHED); N]; C];
    }
}

fn stream<const C: usize, const N: usize>(
    input: &mut Input<'_>,
    header_len: usize,
    m: usize,
) -> usize {
    let config = SdctConfig {
        m: m.clamp(1, N),
        selection: Selection::Largest,
    };
    let mut sender = StreamSender::<C, N>::new(&config).expect("a valid stream");
    let mut receiver = StreamReceiver::<C, N>::new().expect("a valid stream");
    let mut link = Queued::default();
    let mut header = [0u8; MAX_FRAME_HEADER];
    let header = &mut header[..header_len];
    let tag = [0xA5u8; MAX_FRAME_HEADER];
    let mut state = Received {
        accepted: 0,
        last: None,
        clean: true,
    };
    let mut sent_blocks = 0u64;
    while let (Some(kind), Some(record)) = (input.u8(), input.record()) {
        if kind % 2 == stream_step::SAMPLES {
            let mut samples = Input::new(record);
            while let Some(sample) = samples.bytes(4 * C) {
                let frame: [f32; C] = core::array::from_fn(|c| {
                    f32::from_le_bytes(sample[4 * c..4 * c + 4].try_into().unwrap())
                });
                let before = link.0.len();
                let sent = sender.push_frame(frame, &tag[..header_len], &mut link);
                if link.0.len() > before || sent.is_err() {
                    sent_blocks += 1;
                }
                poll(
                    &mut receiver,
                    &mut link,
                    header,
                    Some(sent_blocks),
                    &mut state,
                );
            }
        } else {
            link.0.push_back(record.to_vec());
            poll(&mut receiver, &mut link, header, None, &mut state);
        }
    }
    state.accepted
}

/// `stream_frame`: a `StreamReceiver` of the layout the first byte picks (channels,
/// block length; the second byte: header length in its low four bits, SDCT m / 4 in
/// its high four) fed steps of
/// [`stream_step`]'s kinds: frames as received, or samples its own `StreamSender`
/// frames. A frame accepted reconstructs to finite samples within `MAX_SAMPLE_ABS`
/// and moves the sample index forward (unless it resynchronises); a frame refused
/// leaves the output alone; while only the sender's frames were accepted, each of
/// them is accepted in order. Returns the frames accepted.
pub fn stream_frame(data: &[u8]) -> usize {
    let mut input = Input::new(data);
    let (Some(layout), Some(coding)) = (input.u8(), input.u8()) else {
        return 0;
    };
    let header_len = usize::from(coding & 0x0F) % (MAX_FRAME_HEADER + 1);
    let m = usize::from(coding >> 4) * 4;
    match layout % 4 {
        0 => stream::<1, 8>(&mut input, header_len, m),
        1 => stream::<3, 16>(&mut input, header_len, m),
        2 => stream::<2, 32>(&mut input, header_len, m),
        _ => stream::<4, 64>(&mut input, header_len, m),
    }
}

fn samples_record(channels: usize, count: usize, phase: f32) -> Vec<u8> {
    (0..count)
        .flat_map(|k| (0..channels).map(move |c| (phase + 0.05 * k as f32 + c as f32).sin() * 1e-2))
        .flat_map(f32::to_le_bytes)
        .collect()
}

/// Seeds of [`stream_frame`]: for each layout, the sender's frames as received, and
/// the samples for the harness's sender.
pub fn stream_frame_seeds() -> Vec<Vec<u8>> {
    fn frames<const C: usize, const N: usize>(header_len: usize, m: usize) -> Vec<Vec<u8>> {
        let config = SdctConfig {
            m,
            selection: Selection::Largest,
        };
        let mut sender = StreamSender::<C, N>::new(&config).unwrap();
        let mut link = Queued::default();
        let header = [0x5Au8; MAX_FRAME_HEADER];
        for k in 0..3 * N {
            let x: [f32; C] = core::array::from_fn(|c| (0.05 * k as f32 + c as f32).sin() * 1e-2);
            sender
                .push_frame(x, &header[..header_len], &mut link)
                .unwrap();
        }
        link.0.into_iter().collect()
    }
    let layouts: [(u8, u8, usize, Vec<Vec<u8>>); 4] = [
        (0, 0x20, 1, frames::<1, 8>(0, 8)),
        (1, 0x48, 3, frames::<3, 16>(8, 16)),
        (2, 0x37, 2, frames::<2, 32>(7, 12)),
        (3, 0x84, 4, frames::<4, 64>(4, 32)),
    ];
    let mut seeds = Vec::new();
    for (layout, coding, channels, frames) in layouts {
        let received = frames
            .iter()
            .fold(Seed::new().u8(layout).u8(coding), |s, f| {
                s.u8(stream_step::FRAME).record(f)
            });
        seeds.push(received.0);
        let samples = samples_record(channels, 130, 0.0);
        let sent = Seed::new()
            .u8(layout)
            .u8(coding)
            .u8(stream_step::SAMPLES)
            .record(&samples);
        seeds.push(sent.0);
    }
    seeds
}

/// The remote link's coding in the seeds: 8 of 16 coefficients, as the recording.
pub const REMOTE_SDCT: SdctConfig = SdctConfig {
    m: 8,
    selection: Selection::Largest,
};

/// The step kinds of a `remote_link` input.
mod remote_step {
    /// A command frame for the slave, then one of its periods.
    pub const TO_SLAVE: u8 = 0;
    /// A report frame for the master.
    pub const TO_MASTER: u8 = 1;
    /// Local periods pass (the record's first byte), the slave playing and reporting.
    pub const WAIT: u8 = 2;
    /// Commands of the harness's master (x, y, z f32 and a beam byte each) to the slave.
    pub const MASTER: u8 = 3;
}

fn command_ok(c: &RemoteCommand) -> bool {
    c.acceleration_m_s2.iter().all(|&a| in_range(a))
}

/// `remote_link`: the slave's end (the remote site's `SlaveLink<16, 256>`) and the
/// master's (`MasterLink<16>`) fed steps of [`remote_step`]'s kinds. A command played
/// is finite and within `MAX_SAMPLE_ABS`, and once one played the slave knows its tick
/// and its latency; a report is finite (the slave's own reports, of positions within
/// `MAX_SAMPLE_ABS`, come back within it). Returns the commands and reports that came
/// through.
pub fn remote_link(data: &[u8]) -> usize {
    let mut input = Input::new(data);
    let (Some(session), Some(margin)) = (input.u16(), input.u8()) else {
        return 0;
    };
    let mut slave = SiteLink::new(&REMOTE_SDCT, 1, u32::from(margin)).expect("the site's link");
    let mut master = MasterLink::<BLOCK>::new(&REMOTE_SDCT, session, 1e-3).expect("a master");
    let mut own = MasterLink::<BLOCK>::new(&REMOTE_SDCT, session, 1e-3).unwrap();
    let (mut to_slave, mut to_master) = (Queued::default(), Queued::default());
    let (mut now, mut tick, mut through) = (0u32, 0u32, 0);
    let period =
        |slave: &mut SiteLink, to_slave: &mut Queued, to_master: &mut Queued, now: &mut u32| {
            let (command, _fresh) = slave.receive(*now, to_slave);
            if let Some(c) = command {
                assert!(command_ok(&c), "{c:?}");
                assert!(slave.executing().is_some() && slave.latency_periods().is_some());
            }
            slave.report(command.map(|c| c.acceleration_m_s2), to_master);
            *now = now.wrapping_add(1);
            usize::from(command.is_some())
        };
    while let (Some(kind), Some(record)) = (input.u8(), input.record()) {
        match kind % 4 {
            remote_step::TO_SLAVE => {
                to_slave.0.push_back(record.to_vec());
                through += period(&mut slave, &mut to_slave, &mut to_master, &mut now);
            }
            remote_step::TO_MASTER => {
                to_master.0.push_back(record.to_vec());
                if let Some(report) = master.receive(&mut to_master) {
                    through += 1;
                    let numbers = report.position_m.iter().chain(&report.velocity_m_s);
                    assert!(numbers.clone().all(|v| v.is_finite()), "{report:?}");
                }
            }
            remote_step::WAIT => {
                for _ in 0..record.first().copied().unwrap_or(1) {
                    through += period(&mut slave, &mut to_slave, &mut to_master, &mut now);
                }
                to_master.0.clear();
            }
            _ => {
                let mut commands = Input::new(record);
                while let (Some(x), Some(y), Some(z), Some(beam)) = (
                    commands.f32(),
                    commands.f32(),
                    commands.f32(),
                    commands.u8(),
                ) {
                    let c = RemoteCommand {
                        acceleration_m_s2: [x, y, z],
                        laser_on: beam & 1 == 1,
                    };
                    own.send(Some((tick, c)), &mut to_slave);
                    tick = tick.wrapping_add(1);
                }
                through += period(&mut slave, &mut to_slave, &mut to_master, &mut now);
            }
        }
        // The slave's reports back to the harness's master.
        while let Some(frame) = to_master.0.pop_front() {
            let mut one = Queued::default();
            one.0.push_back(frame);
            if let Some(report) = own.receive(&mut one) {
                assert!(report.position_m.iter().all(|&v| in_range(v)), "{report:?}");
            }
        }
    }
    through
}

/// The master's command frames of `blocks` blocks from tick `first`, beam on for the
/// odd ticks.
pub fn master_frames(session: u16, first: u32, blocks: usize) -> Vec<Vec<u8>> {
    let mut master = MasterLink::<BLOCK>::new(&REMOTE_SDCT, session, 1e-3).unwrap();
    let mut link = Queued::default();
    for k in 0..(blocks * BLOCK) as u32 {
        let t = 1e-3 * k as f32;
        let c = RemoteCommand {
            acceleration_m_s2: [t.sin(), t.cos() - 1.0, 0.1 * t],
            laser_on: k % 2 == 1,
        };
        master.send(Some((first + k, c)), &mut link);
    }
    link.0.into_iter().collect()
}

/// Seeds of [`remote_link`]: the master's frames to the slave with periods between
/// them, the slave's reports to the master, and commands for the harness's master.
pub fn remote_link_seeds() -> Vec<Vec<u8>> {
    let session = 0x1234;
    let frames = master_frames(session, 100, 3);
    let start = Seed::new().u16(session).u8(20);
    let to_slave = frames.iter().fold(start.clone(), |s, f| {
        s.u8(remote_step::TO_SLAVE)
            .record(f)
            .u8(remote_step::WAIT)
            .record(&[16])
    });
    let mut slave = SiteLink::new(&REMOTE_SDCT, 1, 20).unwrap();
    let (mut from_master, mut reports) = (Queued::default(), Queued::default());
    from_master.0.extend(frames.iter().cloned());
    for now in 0..80 {
        let (command, _) = slave.receive(now, &mut from_master);
        slave.report(command.map(|c| c.acceleration_m_s2), &mut reports);
    }
    let to_master = reports
        .0
        .iter()
        .fold(start.clone(), |s, f| s.u8(remote_step::TO_MASTER).record(f));
    let commands: Vec<u8> = (0..BLOCK as u32)
        .flat_map(|k| {
            let mut c = Vec::new();
            for v in [0.1 * k as f32, -0.2, 1e-3] {
                c.extend_from_slice(&v.to_le_bytes());
            }
            c.push((k % 2) as u8);
            c
        })
        .collect();
    let own = start
        .u8(remote_step::MASTER)
        .record(&commands)
        .u8(remote_step::WAIT)
        .record(&[40]);
    vec![to_slave.0, to_master.0, own.0]
}
