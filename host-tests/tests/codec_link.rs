//! The app's signal stream (SDCT encoder → packets) → simulated link → receiver
//! (docs/codec.md §30, T 7.2.3): reconstruction over
//! a clean link, and over a lossy, reordering one where every lost or late packet must
//! show up as a sequence gap or a `SequenceBackwards` rejection, never be used late.

use std::collections::BTreeSet;

use hal_mock::link::{FrameEnd, LinkConfig};
use host_tests::signals::{self, snr_db};
use kerf::app::stream::{SignalReceiver, SignalSender, StreamError, FRAME_CRC_LEN, MAX_FRAME_LEN};
use kerf::codec::packet::{self, PacketError};
use kerf::codec::sdct::{SdctConfig, SdctDecoder, Selection};
use kerf::hal::{FrameLink, LinkBusy};

const N: usize = 32;
const M: usize = 8;

/// What the receiver saw.
struct Outcome {
    /// Reconstruction, NaN where no block was accepted.
    samples: Vec<f64>,
    accepted: Vec<u16>,
    rejected_backwards: BTreeSet<u16>,
    lost: BTreeSet<u16>,
    gaps: u64,
    direct: Vec<f64>,
}

/// The simulated link end, recording what went in: each frame's sequence number,
/// whether the link lost it, and its block decoded directly (no link).
struct Tap {
    end: FrameEnd<MAX_FRAME_LEN, 64>,
    lost: BTreeSet<u16>,
    direct: Vec<f64>,
}

impl FrameLink for Tap {
    fn send(&mut self, frame: &[u8]) -> Result<(), LinkBusy> {
        // One channel and no header: the frame is one packet and the frame's CRC.
        let p = packet::parse(&frame[..frame.len() - FRAME_CRC_LEN]).unwrap();
        let mut y = [0.0f32; N];
        SdctDecoder::<N>::new()
            .unwrap()
            .decode(&p.to_block().unwrap(), &mut y);
        self.direct.extend(y.iter().map(|&v| f64::from(v)));
        let lost_before = self.end.link.lost();
        self.end.send(frame)?;
        if self.end.link.lost() > lost_before {
            self.lost.insert(p.sequence);
        }
        Ok(())
    }
    fn receive(&mut self, buf: &mut [u8]) -> Option<usize> {
        self.end.receive(buf)
    }
}

/// The signal through the app's stream ends over the simulated link, one tick per
/// sample.
fn stream(x: &[f64], config: &LinkConfig) -> Outcome {
    let mut sender = SignalSender::<N>::new(&SdctConfig {
        m: M,
        selection: Selection::Largest,
    })
    .unwrap();
    let mut receiver = SignalReceiver::<N>::new().unwrap();
    let mut link = Tap {
        end: FrameEnd::new(config).unwrap(),
        lost: BTreeSet::new(),
        direct: Vec::new(),
    };
    let mut out = Outcome {
        samples: vec![f64::NAN; x.len()],
        accepted: Vec::new(),
        rejected_backwards: BTreeSet::new(),
        lost: BTreeSet::new(),
        gaps: 0,
        direct: Vec::new(),
    };
    let blocks = x.len() / N;
    for tick in 0..(x.len() as u64 + 1000) {
        link.end.set_now(tick);
        if let Some(&sample) = x
            .get(tick as usize)
            .filter(|_| (tick as usize) < blocks * N)
        {
            sender.push(sample as f32, &mut link).unwrap();
        }
        let mut y = [0.0f32; N];
        while let Some(result) = receiver.poll(&mut link, &mut y) {
            match result {
                Ok(block) => {
                    out.gaps += u64::from(block.gap);
                    out.accepted.push(block.sequence);
                    let start = block.first_sample as usize;
                    for (dst, &v) in out.samples[start..start + N].iter_mut().zip(&y) {
                        *dst = f64::from(v);
                    }
                }
                Err(StreamError::Packet(PacketError::SequenceBackwards { got, .. })) => {
                    out.rejected_backwards.insert(got);
                }
                Err(e) => panic!("unexpected {e:?}"),
            }
        }
    }
    assert_eq!(link.end.link.in_flight(), 0);
    assert_eq!(sender.dropped(), 0);
    out.lost = link.lost;
    out.direct = link.direct;
    out
}

#[test]
fn clean_but_delayed_link_reconstructs_like_no_link() {
    let x = &signals::all()[0].samples;
    let cfg = LinkConfig {
        delay_ticks: 40,
        random_delay_ticks: 30,
        jitter_ticks: 5.0,
        seed: 1,
        ..LinkConfig::IDEAL
    };
    let out = stream(x, &cfg);
    assert_eq!(out.accepted.len(), x.len() / N);
    assert_eq!(out.gaps, 0);
    assert!(out.rejected_backwards.is_empty());
    // Same packets, same decoder: identical samples; the SNR is the codec's alone.
    assert_eq!(out.samples, out.direct);
    let snr = snr_db(x, &out.samples);
    println!("clean link, N = {N}, m = {M}: SNR {snr:.1} dB");
    // The equal-m report gives 30.8 dB for this signal; the bound leaves 1 dB.
    assert!(snr > 29.8, "{snr}");
}

#[test]
fn lost_and_reordered_packets_are_reported_not_used() {
    let x = &signals::all()[2].samples;
    let cfg = LinkConfig {
        delay_ticks: 20,
        random_delay_ticks: 80, // > 2 blocks: packets overtake each other
        jitter_ticks: 10.0,
        loss_probability: 0.1,
        reorder: true,
        seed: 7,
    };
    let out = stream(x, &cfg);
    let blocks = (x.len() / N) as u16;
    println!(
        "lossy link: {} blocks, {} lost, {} late (rejected), {} accepted, gaps {}",
        blocks,
        out.lost.len(),
        out.rejected_backwards.len(),
        out.accepted.len(),
        out.gaps
    );
    assert!(!out.lost.is_empty(), "the seed must exercise loss");
    assert!(
        !out.rejected_backwards.is_empty(),
        "the seed must exercise reordering"
    );
    // Accepted sequence numbers strictly increase.
    assert!(out.accepted.windows(2).all(|w| w[0] < w[1]));
    // Every sequence number between the first and last accepted one is exactly one
    // of: accepted, lost on the link, rejected as late — and the decoder's gap count
    // is the number of the latter two.
    let (first, last) = (out.accepted[0], *out.accepted.last().unwrap());
    let accepted: BTreeSet<u16> = out.accepted.iter().copied().collect();
    for seq in first..=last {
        let classes = [
            accepted.contains(&seq),
            out.lost.contains(&seq),
            out.rejected_backwards.contains(&seq),
        ];
        assert_eq!(
            classes.iter().filter(|&&c| c).count(),
            1,
            "seq {seq}: {classes:?}"
        );
    }
    let missing = u64::from(last - first + 1) - accepted.len() as u64;
    assert_eq!(out.gaps, missing);
    // Accepted blocks are exactly the direct reconstruction; the others stay empty
    // (a late packet was not slipped in).
    for k in 0..usize::from(blocks) {
        let got = &out.samples[k * N..(k + 1) * N];
        if accepted.contains(&(k as u16)) {
            assert_eq!(got, &out.direct[k * N..(k + 1) * N], "block {k}");
        } else {
            assert!(got.iter().all(|v| v.is_nan()), "block {k} was used");
        }
    }
}

/// The master restarts after 100 blocks (a new sender: sequence numbers and sample
/// indices from 0 again) while the slave's receiver keeps running, on a delayed,
/// jittery link. The receiver takes the new sequence within the stated number of
/// packets and every later block is accepted.
#[test]
fn a_restarted_sender_is_accepted_again_within_the_stated_bound() {
    use kerf::codec::packet::RESTART_ACCEPTED_WITHIN;
    let x = &signals::all()[0].samples;
    let config = LinkConfig {
        delay_ticks: 40,
        random_delay_ticks: 30,
        jitter_ticks: 5.0,
        seed: 3,
        ..LinkConfig::IDEAL
    };
    let sdct = SdctConfig {
        m: M,
        selection: Selection::Largest,
    };
    let mut link = FrameEnd::<MAX_FRAME_LEN, 64>::new(&config).unwrap();
    let mut receiver = SignalReceiver::<N>::new().unwrap();
    let mut y = [0.0f32; N];
    // (sequences seen so far, sequence, resynchronised) of every accepted block: the
    // receiver's own view, counting a new sequence at each resynchronisation.
    let mut accepted: Vec<(u32, u16, bool)> = Vec::new();
    let mut sequences = 0u32;
    let mut tick = 0u64;
    for _restart in 0..2 {
        let mut sender = SignalSender::<N>::new(&sdct).unwrap();
        for &sample in &x[..100 * N] {
            tick += 1;
            link.set_now(tick);
            sender.push(sample as f32, &mut link).unwrap();
            while let Some(result) = receiver.poll(&mut link, &mut y) {
                if let Ok(block) = result {
                    sequences += u32::from(block.resynchronised);
                    accepted.push((sequences, block.sequence, block.resynchronised));
                }
            }
        }
    }
    for _ in 0..1000 {
        tick += 1;
        link.set_now(tick);
        while let Some(result) = receiver.poll(&mut link, &mut y) {
            if let Ok(block) = result {
                sequences += u32::from(block.resynchronised);
                accepted.push((sequences, block.sequence, block.resynchronised));
            }
        }
    }
    assert_eq!(sequences, 1, "one restart, one resynchronisation");
    // Until the restart, all 100 blocks; after it, the first accepted block of the new
    // sender is the resynchronising one, at most RESTART_ACCEPTED_WITHIN − 1 in.
    let before: Vec<u16> = accepted.iter().filter(|a| a.0 == 0).map(|a| a.1).collect();
    assert_eq!(before, (0..100).collect::<Vec<u16>>());
    let after: Vec<(u16, bool)> = accepted
        .iter()
        .filter(|a| a.0 == 1)
        .map(|a| (a.1, a.2))
        .collect();
    let (first, resync) = after[0];
    assert!(resync, "{after:?}");
    assert!(usize::from(first) < RESTART_ACCEPTED_WITHIN, "{first}");
    // From there on every block, in order.
    let rest: Vec<u16> = after.iter().map(|a| a.0).collect();
    assert_eq!(rest, (first..100).collect::<Vec<u16>>());
    println!(
        "restarted sender: accepted again at its packet {} (bound {RESTART_ACCEPTED_WITHIN})",
        first + 1
    );
}
