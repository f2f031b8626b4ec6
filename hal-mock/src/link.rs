//! Simulated one-way network link between master and slave (T 7.2.3, ch. 5: the
//! network between the two sites delays, jitters and drops packets).
//!
//! Time is in integer ticks (the caller's sample periods). Each packet gets a delay
//! d = constant + U·random + jitter·z, with U uniform in [0, 1] and z standard normal
//! from the seeded [`Noise`], rounded to whole ticks and clamped at zero; it is lost with
//! the configured probability. Without reordering a packet is never delivered before an
//! earlier one (its due time is at least the previous due time, as on one TCP stream);
//! with reordering each packet keeps its own delay, so later packets can overtake (UDP).
//! At most `CAP` packets are in flight; a send beyond that is refused.

use heapless::Vec;

use crate::noise::Noise;
use kerf::hal::{FrameLink, LinkBusy};

/// Link behaviour. Delays are in ticks.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct LinkConfig {
    /// Constant one-way delay.
    pub delay_ticks: u32,
    /// Upper bound of the extra delay drawn uniformly per packet.
    pub random_delay_ticks: u32,
    /// Standard deviation of the Gaussian jitter added per packet (≥ 0).
    pub jitter_ticks: f64,
    /// Probability that a packet is lost, in [0, 1].
    pub loss_probability: f64,
    /// Whether a packet may overtake an earlier one.
    pub reorder: bool,
    /// Seed of the delay and loss draws.
    pub seed: u64,
}

impl LinkConfig {
    /// A perfect link: no delay, no jitter, no loss.
    pub const IDEAL: Self = Self {
        delay_ticks: 0,
        random_delay_ticks: 0,
        jitter_ticks: 0.0,
        loss_probability: 0.0,
        reorder: false,
        seed: 0,
    };
}

/// Why the link refused a configuration or a packet.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum LinkError {
    /// The named field is out of range (negative or non-finite jitter, loss outside
    /// [0, 1]).
    BadConfig(&'static str),
    /// `CAP` packets are already in flight.
    Full,
}

/// What happened to a sent packet.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Sent {
    /// Queued for delivery at tick `due`.
    Queued {
        /// Tick at or after which [`Link::poll`] returns it.
        due: u64,
    },
    /// Dropped by the link.
    Lost,
}

#[derive(Clone, Debug)]
struct InFlight<T> {
    due: u64,
    order: u64,
    item: T,
}

/// A link carrying packets of type `T`, at most `CAP` in flight.
#[derive(Clone, Debug)]
pub struct Link<T, const CAP: usize> {
    config: LinkConfig,
    noise: Noise,
    in_flight: Vec<InFlight<T>, CAP>,
    next_order: u64,
    last_due: u64,
    sent: u64,
    lost: u64,
}

impl<T, const CAP: usize> Link<T, CAP> {
    /// Validates `config` and returns an empty link.
    pub fn new(config: &LinkConfig) -> Result<Self, LinkError> {
        if !config.jitter_ticks.is_finite() || config.jitter_ticks < 0.0 {
            return Err(LinkError::BadConfig("jitter_ticks"));
        }
        if !(0.0..=1.0).contains(&config.loss_probability) {
            return Err(LinkError::BadConfig("loss_probability"));
        }
        Ok(Self {
            config: *config,
            noise: Noise::new(config.seed),
            in_flight: Vec::new(),
            next_order: 0,
            last_due: 0,
            sent: 0,
            lost: 0,
        })
    }

    /// Sends `item` at tick `now`.
    pub fn send(&mut self, now: u64, item: T) -> Result<Sent, LinkError> {
        if self.in_flight.is_full() {
            return Err(LinkError::Full);
        }
        self.sent += 1;
        // Draw every random number for every packet, so that switching loss on or off
        // does not shift the delays of the other packets.
        // uniform() is in (0, 1]: P(u ≤ p) = p, never for p = 0, always for p = 1.
        let lose = self.noise.uniform() <= self.config.loss_probability;
        let extra = self.noise.uniform() * f64::from(self.config.random_delay_ticks);
        let jitter = self.noise.normal() * self.config.jitter_ticks;
        if lose {
            self.lost += 1;
            return Ok(Sent::Lost);
        }
        let delay = libm::round(f64::from(self.config.delay_ticks) + extra + jitter).max(0.0);
        let mut due = now.saturating_add(delay as u64);
        if !self.config.reorder {
            due = due.max(self.last_due);
        }
        self.last_due = self.last_due.max(due);
        let entry = InFlight {
            due,
            order: self.next_order,
            item,
        };
        self.next_order += 1;
        self.in_flight.push(entry).map_err(|_| LinkError::Full)?;
        Ok(Sent::Queued { due })
    }

    /// The earliest packet due at or before `now` (ties in send order), if any.
    pub fn poll(&mut self, now: u64) -> Option<T> {
        let (index, _) = self
            .in_flight
            .iter()
            .enumerate()
            .filter(|(_, p)| p.due <= now)
            .min_by_key(|(_, p)| (p.due, p.order))?;
        Some(self.in_flight.swap_remove(index).item)
    }

    /// Packets sent so far (including lost ones).
    pub fn sent(&self) -> u64 {
        self.sent
    }

    /// Packets lost so far.
    pub fn lost(&self) -> u64 {
        self.lost
    }

    /// Packets currently in flight.
    pub fn in_flight(&self) -> usize {
        self.in_flight.len()
    }
}

/// One end of a simulated link as kerf's [`FrameLink`]: frames of at most `FRAME`
/// bytes, at most `CAP` in flight, on the caller's clock ([`FrameEnd::set_now`]).
#[derive(Clone, Debug)]
pub struct FrameEnd<const FRAME: usize, const CAP: usize> {
    /// The link underneath (its counts of sent and lost frames).
    pub link: Link<Vec<u8, FRAME>, CAP>,
    now: u64,
    oversized: u64,
}

impl<const FRAME: usize, const CAP: usize> FrameEnd<FRAME, CAP> {
    /// A link end with `config`, at tick 0.
    pub fn new(config: &LinkConfig) -> Result<Self, LinkError> {
        Ok(Self {
            link: Link::new(config)?,
            now: 0,
            oversized: 0,
        })
    }

    /// Moves the link's clock to tick `now`: frames due by then can be received.
    pub fn set_now(&mut self, now: u64) {
        self.now = now;
    }

    /// Frames dropped at the receiver because they did not fit its buffer.
    pub fn oversized(&self) -> u64 {
        self.oversized
    }
}

impl<const FRAME: usize, const CAP: usize> FrameLink for FrameEnd<FRAME, CAP> {
    /// A frame the link loses counts as sent: the sender cannot know.
    fn send(&mut self, frame: &[u8]) -> Result<(), LinkBusy> {
        let frame = Vec::from_slice(frame).map_err(|_| LinkBusy)?;
        self.link
            .send(self.now, frame)
            .map(|_| ())
            .map_err(|_| LinkBusy)
    }

    fn receive(&mut self, buf: &mut [u8]) -> Option<usize> {
        loop {
            let frame = self.link.poll(self.now)?;
            match buf.get_mut(..frame.len()) {
                Some(dst) => {
                    dst.copy_from_slice(&frame);
                    return Some(frame.len());
                }
                None => self.oversized += 1,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drain<const CAP: usize>(
        link: &mut Link<u32, CAP>,
        until: u64,
    ) -> heapless::Vec<(u64, u32), 256> {
        let mut out = heapless::Vec::new();
        for t in 0..until {
            while let Some(p) = link.poll(t) {
                out.push((t, p)).unwrap();
            }
        }
        out
    }

    #[test]
    fn constant_delay_delivers_in_order() {
        let cfg = LinkConfig {
            delay_ticks: 5,
            ..LinkConfig::IDEAL
        };
        let mut link = Link::<u32, 16>::new(&cfg).unwrap();
        for i in 0..10 {
            assert_eq!(
                link.send(u64::from(i) * 2, i),
                Ok(Sent::Queued {
                    due: u64::from(i) * 2 + 5
                })
            );
        }
        let got = drain(&mut link, 40);
        assert_eq!(got.len(), 10);
        for (i, &(t, p)) in got.iter().enumerate() {
            assert_eq!((t, p), (i as u64 * 2 + 5, i as u32));
        }
    }

    #[test]
    fn reordering_only_when_allowed() {
        let base = LinkConfig {
            delay_ticks: 3,
            random_delay_ticks: 20,
            jitter_ticks: 2.0,
            seed: 11,
            ..LinkConfig::IDEAL
        };
        for reorder in [false, true] {
            let mut link = Link::<u32, 64>::new(&LinkConfig { reorder, ..base }).unwrap();
            for i in 0..50 {
                link.send(u64::from(i), i).unwrap();
            }
            let got = drain(&mut link, 200);
            assert_eq!(got.len(), 50);
            let in_order = got.windows(2).all(|w| w[0].1 < w[1].1);
            // 50 uniform delays over 20 ticks with packets 1 tick apart: overtaking is
            // certain for this seed and would be for any reasonable one.
            assert_eq!(in_order, !reorder, "reorder = {reorder}");
        }
    }

    #[test]
    fn loss_rate_matches_the_configuration() {
        let cfg = LinkConfig {
            loss_probability: 0.2,
            seed: 3,
            ..LinkConfig::IDEAL
        };
        let mut link = Link::<u32, 4>::new(&cfg).unwrap();
        for i in 0..10_000 {
            let _ = link.send(i, 0);
            let _ = link.poll(i);
        }
        // Binomial(10000, 0.2): σ = 40, so ±200 is 5σ.
        assert!((link.lost() as i64 - 2000).abs() < 200, "{}", link.lost());
        assert_eq!(link.sent(), 10_000);
    }

    #[test]
    fn capacity_and_config_are_enforced() {
        let cfg = LinkConfig {
            delay_ticks: 100,
            ..LinkConfig::IDEAL
        };
        let mut link = Link::<u8, 2>::new(&cfg).unwrap();
        assert!(link.send(0, 1).is_ok());
        assert!(link.send(0, 2).is_ok());
        assert_eq!(link.send(0, 3), Err(LinkError::Full));
        assert_eq!(link.in_flight(), 2);
        let bad = LinkConfig {
            loss_probability: 1.5,
            ..LinkConfig::IDEAL
        };
        assert_eq!(
            Link::<u8, 2>::new(&bad).err(),
            Some(LinkError::BadConfig("loss_probability"))
        );
        let bad = LinkConfig {
            jitter_ticks: f64::NAN,
            ..LinkConfig::IDEAL
        };
        assert_eq!(
            Link::<u8, 2>::new(&bad).err(),
            Some(LinkError::BadConfig("jitter_ticks"))
        );
    }
}
