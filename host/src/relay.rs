//! The network between two emulated machines (the remote master and its slave, each on
//! its own emulated processor): the tool's side of `kerf::app::lockstep`. Each round
//! grants both machines the next W control periods, reads the frames each sends until
//! both wait, and hands every frame to the other machine with the period it is due in,
//! drawn by the simulated link of the host scenarios (`hal_mock::link`: a delay, a
//! uniform jitter, a loss probability, seeded). W is the smallest delay the profile can
//! draw, so no frame is due inside the round it was sent in and the pair runs exactly as
//! on that simulated network, however fast either emulator runs.
//!
//! Not yet used by a command: the emulated images that speak the protocol on a second
//! serial port are the next step.

use hal_mock::link::{Link, LinkConfig, Sent};
use kerf::app::lockstep::{delivery_head, grant, parse_machine, MachineMessage};
use std::io::{Read, Write};

/// The network between the two machines, as an operator states it.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct NetworkProfile {
    /// Mean one-way delay, ms.
    pub delay_ms: u32,
    /// ± this much, uniform, ms (at most the delay).
    pub jitter_ms: u32,
    /// Probability that a frame is lost, each way.
    pub loss: f64,
    /// Seed of the draws (the way back uses seed + 1).
    pub seed: u64,
}

/// Why the relay stopped.
#[derive(Debug, thiserror::Error)]
pub enum RelayError {
    /// The profile cannot be drawn.
    #[error("network profile: {0}")]
    Profile(&'static str),
    /// A machine's stream failed or closed.
    #[error("the {machine} machine's network port: {source}")]
    Io {
        /// Which machine.
        machine: &'static str,
        /// What failed.
        source: std::io::Error,
    },
}

/// Frames and bytes one way.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct WayCounts {
    /// Frames the sender sent.
    pub frames: u64,
    /// Frames the network lost.
    pub lost: u64,
    /// Bytes of the frames sent.
    pub bytes: u64,
}

/// The relay: the two ways' draws and the clock.
pub struct Relay {
    /// Control periods per round (the smallest delay, at least one).
    round_periods: u32,
    /// Periods granted so far.
    granted: u32,
    /// A → B and B → A.
    ways: [Link<(), 256>; 2],
    counts: [WayCounts; 2],
}

impl Relay {
    /// The relay for machines of control period `period_s`.
    pub fn new(profile: &NetworkProfile, period_s: f64) -> Result<Self, RelayError> {
        if profile.jitter_ms > profile.delay_ms {
            return Err(RelayError::Profile("the jitter is larger than the delay"));
        }
        if !(period_s > 0.0 && period_s.is_finite()) {
            return Err(RelayError::Profile("the control period is not positive"));
        }
        let periods = |ms: u32| (f64::from(ms) * 1e-3 / period_s).round() as u32;
        let (min, span) = (
            periods(profile.delay_ms - profile.jitter_ms),
            periods(2 * profile.jitter_ms),
        );
        let way = |seed| {
            Link::new(&LinkConfig {
                delay_ticks: min,
                random_delay_ticks: span,
                jitter_ticks: 0.0,
                loss_probability: profile.loss,
                reorder: false,
                seed,
            })
            .map_err(|_| RelayError::Profile("the loss is not a probability"))
        };
        Ok(Self {
            round_periods: min.max(1),
            granted: 0,
            ways: [way(profile.seed)?, way(profile.seed.wrapping_add(1))?],
            counts: [WayCounts::default(); 2],
        })
    }

    /// Control periods per round.
    pub fn round_periods(&self) -> u32 {
        self.round_periods
    }

    /// Periods both machines have run.
    pub fn periods(&self) -> u32 {
        self.granted
    }

    /// Frames and bytes each way: A → B, B → A.
    pub fn counts(&self) -> [WayCounts; 2] {
        self.counts
    }

    /// One round: both machines granted the next W periods, their frames carried until
    /// both wait at the end of them.
    pub fn round(
        &mut self,
        a: &mut (impl Read + Write),
        b: &mut (impl Read + Write),
    ) -> Result<(), RelayError> {
        self.granted = self.granted.wrapping_add(self.round_periods);
        let message = grant(self.granted);
        write(a, "first", &message)?;
        write(b, "second", &message)?;
        let mut frames = Vec::new();
        read_until_waiting(a, "first", self.granted, &mut |tick, frame| {
            frames.push((0, tick, frame.to_vec()));
        })?;
        read_until_waiting(b, "second", self.granted, &mut |tick, frame| {
            frames.push((1, tick, frame.to_vec()));
        })?;
        for (from, tick, frame) in frames {
            let (way, counts) = (&mut self.ways[from], &mut self.counts[from]);
            counts.frames += 1;
            counts.bytes += frame.len() as u64;
            let sent = way.send(u64::from(tick), ());
            // The draw is all the relay needs: nothing stays in flight.
            while way.poll(u64::MAX).is_some() {}
            let due = match sent {
                Ok(Sent::Queued { due }) => due as u32,
                Ok(Sent::Lost) | Err(_) => {
                    counts.lost += 1;
                    continue;
                }
            };
            let Some(head) = delivery_head(due, frame.len()) else {
                counts.lost += 1;
                continue;
            };
            if from == 0 {
                write(b, "second", &head)?;
                write(b, "second", &frame)?;
            } else {
                write(a, "first", &head)?;
                write(a, "first", &frame)?;
            }
        }
        Ok(())
    }
}

fn write(stream: &mut impl Write, machine: &'static str, bytes: &[u8]) -> Result<(), RelayError> {
    stream
        .write_all(bytes)
        .map_err(|source| RelayError::Io { machine, source })
}

/// Reads the machine's messages, each frame to `frame`, until it waits at `tick`.
fn read_until_waiting(
    stream: &mut impl Read,
    machine: &'static str,
    tick: u32,
    frame: &mut dyn FnMut(u32, &[u8]),
) -> Result<(), RelayError> {
    let mut buffer: Vec<u8> = Vec::new();
    let mut chunk = [0u8; 4096];
    loop {
        let mut used = 0;
        loop {
            match parse_machine(&buffer[used..]) {
                Ok(Some((MachineMessage::Sent { tick, frame: f }, n))) => {
                    frame(tick, f);
                    used += n;
                }
                Ok(Some((MachineMessage::Waiting { tick: at }, n))) => {
                    used += n;
                    if at == tick {
                        // Nothing follows a wait until the next grant.
                        return Ok(());
                    }
                }
                Ok(None) => break,
                Err(n) => used += n,
            }
        }
        buffer.drain(..used);
        let n = stream
            .read(&mut chunk)
            .map_err(|source| RelayError::Io { machine, source })?;
        if n == 0 {
            return Err(RelayError::Io {
                machine,
                source: std::io::ErrorKind::UnexpectedEof.into(),
            });
        }
        buffer.extend_from_slice(&chunk[..n]);
    }
}

#[cfg(test)]
mod tests;
