//! The slave's playout of the master's commands: what arrives over a jittering,
//! reordering, lossy link is executed in the master's order and at the master's pace,
//! a fixed latency behind it.
//!
//! Commands carry the master's tick (its control period count). The first command
//! anchors the playout: a command of tick t plays at local period t + offset, with
//! offset = (its arrival − t) + `margin_periods`. So every command that arrives with
//! at most `margin_periods` more delay than the first plays on time and in order, and
//! the slave executes exactly the sequence the master's model of it executed (the
//! delay observer's premise, `control::delay_observer`), only later. A command that
//! arrives after its play time re-anchors the offset to its own delay plus the margin
//! (the link got slower: the latency grows once, rather than every later command
//! being late), and is counted. Between commands the newest played one holds; a
//! missing command (lost) leaves the previous one holding for its periods too, and
//! [`Playout::next`] says for how long nothing new has played.
//!
//! Ticks and local periods are `u32` compared by wrapping difference (5 days at 10 kHz
//! per wrap): the playout works across the wrap. That order is total only among ticks
//! less than 2^31 apart, so the playout holds commands within [`TICK_WINDOW`] of each
//! other and refuses a tick farther from them (a corrupted or forged tick; a master
//! that restarts opens a new session, which restarts the playout).

use heapless::Vec;

/// Why an arriving command was not queued.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PlayoutRejected {
    /// Its tick is at or before a command already played or queued: overtaken by a
    /// newer one that has played, a duplicate or a replay.
    Stale,
    /// The queue is full.
    Full,
    /// Its tick is more than [`TICK_WINDOW`] from a command played or queued.
    OutOfWindow,
}

/// Most ticks between the oldest and the newest command the playout holds, 2^30 (1.2
/// days at 10 kHz): every tick it holds is then within 2^31 of every other, where the
/// wrapping order is total.
pub const TICK_WINDOW: u32 = 1 << 30;

/// What plays in a local period.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Playing<V> {
    /// No command has played yet.
    Waiting,
    /// The command of master tick `tick`; `fresh` when it started this period, else
    /// held for `held_periods`.
    Command {
        /// Its master tick.
        tick: u32,
        /// The command.
        value: V,
        /// Local periods since a new command last started (0: this period).
        held_periods: u32,
    },
}

/// The playout: queued commands in master order, the anchor, and counts.
#[derive(Clone, Debug)]
pub struct Playout<V: Copy, const CAP: usize> {
    margin_periods: u32,
    /// Local period minus master tick at which commands play.
    offset: Option<u32>,
    /// Queued commands, ascending tick.
    queue: Vec<(u32, V), CAP>,
    playing: Option<(u32, V)>,
    held_periods: u32,
    late: u32,
}

impl<V: Copy, const CAP: usize> Playout<V, CAP> {
    /// A playout that allows `margin_periods` of delay variation over the first command's.
    pub const fn new(margin_periods: u32) -> Self {
        Self {
            margin_periods,
            offset: None,
            queue: Vec::new(),
            playing: None,
            held_periods: 0,
            late: 0,
        }
    }

    /// Forgets everything (a new session: the master restarted, or the slave stopped).
    pub fn restart(&mut self) {
        *self = Self::new(self.margin_periods);
    }

    /// A command of master tick `tick` arrived in local period `now`.
    pub fn push(&mut self, now: u32, tick: u32, value: V) -> Result<(), PlayoutRejected> {
        // Wrapping order relative to the newest command played or queued.
        let newest = self.queue.last().map(|q| q.0).or(self.playing.map(|p| p.0));
        let after = |a: u32, b: u32| a.wrapping_sub(b).wrapping_sub(1) < 1 << 31;
        if let Some(p) = self.playing {
            if !after(tick, p.0) {
                return Err(PlayoutRejected::Stale);
            }
        }
        if self.queue.iter().any(|q| q.0 == tick) {
            return Err(PlayoutRejected::Stale);
        }
        // Within the window of the oldest and the newest held, the new span stays in it.
        let oldest = self.playing.or(self.queue.first().copied()).map(|p| p.0);
        let near = |t: u32| t.wrapping_sub(tick).min(tick.wrapping_sub(t)) <= TICK_WINDOW;
        if !oldest.into_iter().chain(newest).all(near) {
            return Err(PlayoutRejected::OutOfWindow);
        }
        let anchored = now.wrapping_sub(tick).wrapping_add(self.margin_periods);
        match self.offset {
            None => self.offset = Some(anchored),
            Some(offset) if tick.wrapping_add(offset).wrapping_sub(now) >= 1 << 31 => {
                // Past its play time: the link is slower than the anchor allowed.
                self.late = self.late.saturating_add(1);
                self.offset = Some(anchored);
            }
            Some(_) => {}
        }
        let at = match newest {
            Some(n) if after(tick, n) => self.queue.len(),
            _ => self
                .queue
                .iter()
                .position(|q| after(q.0, tick))
                .unwrap_or(self.queue.len()),
        };
        self.queue
            .push((tick, value))
            .map_err(|_| PlayoutRejected::Full)?;
        // Into its place in tick order (an overtaken command lands before the newer).
        // The tail holds the command just pushed, so it is never empty (which
        // `rotate_right` would refuse with a panic).
        if let Some(tail) = self.queue.get_mut(at..).filter(|t| !t.is_empty()) {
            tail.rotate_right(1);
        }
        Ok(())
    }

    /// What plays in local period `now`: the newest queued command whose play time has
    /// come (older ones behind it are skipped), else the one playing.
    pub fn next(&mut self, now: u32) -> Playing<V> {
        let Some(offset) = self.offset else {
            return Playing::Waiting;
        };
        let due = |tick: u32| now.wrapping_sub(tick.wrapping_add(offset)) < 1 << 31;
        let ready = self.queue.iter().take_while(|q| due(q.0)).count();
        if let Some(newest_due) = ready.checked_sub(1) {
            self.playing = self.queue.get(newest_due).copied();
            // Ascending order: the due ones are the front of the queue.
            self.queue.retain(|q| !due(q.0));
            self.held_periods = 0;
        } else {
            self.held_periods = self.held_periods.saturating_add(1);
        }
        match self.playing {
            None => Playing::Waiting,
            Some((tick, value)) => Playing::Command {
                tick,
                value,
                held_periods: self.held_periods,
            },
        }
    }

    /// Commands that arrived after their play time so far.
    pub fn late(&self) -> u32 {
        self.late
    }

    /// The present latency, local periods behind the master's tick (once anchored).
    pub fn offset(&self) -> Option<u32> {
        self.offset
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::vec::Vec as StdVec;

    /// Commands every 10 ticks with delays 40–60 periods in a scrambled order, from a
    /// master clock just short of the u32 wrap: with a 30-period margin all play, in
    /// order, each for 10 periods, at the first one's delay plus the margin.
    #[test]
    fn jittered_commands_play_in_order_at_a_fixed_latency_across_the_wrap() {
        let start = u32::MAX - 205;
        let mut playout = Playout::<u32, 16>::new(30);
        let delays = [50u32, 60, 40, 55, 41, 59, 45, 52, 48, 57, 43, 50];
        let mut arrivals: StdVec<(u32, u32)> = delays
            .iter()
            .enumerate()
            .map(|(i, d)| {
                let tick = start.wrapping_add(10 * i as u32);
                (tick.wrapping_add(*d).wrapping_sub(start), tick)
            })
            .collect();
        arrivals.sort();
        let mut played = StdVec::new();
        for now in 0..300u32 {
            for &(_, tick) in arrivals.iter().filter(|a| a.0 == now) {
                // Local clock: periods since the master's `start`.
                playout.push(now, tick, tick).unwrap();
            }
            if let Playing::Command {
                tick,
                value,
                held_periods,
            } = playout.next(now)
            {
                assert_eq!(tick, value);
                if held_periods == 0 {
                    played.push((now, tick));
                }
            }
        }
        let expected: StdVec<(u32, u32)> = (0..12u32)
            .map(|i| (10 * i + 50 + 30, start.wrapping_add(10 * i)))
            .collect();
        assert_eq!(played, expected);
        assert_eq!(playout.late(), 0);
    }

    /// A command later than the margin re-anchors the latency (counted), a duplicate
    /// and one overtaken by a played newer one are stale; nothing plays before the
    /// first command.
    #[test]
    fn late_stale_and_duplicate_commands() {
        let mut playout = Playout::<u8, 8>::new(5);
        assert_eq!(playout.next(0), Playing::Waiting);
        playout.push(10, 0, 0).unwrap(); // delay 10: plays at 15
        assert_eq!(playout.offset(), Some(15));
        assert_eq!(playout.push(11, 0, 9), Err(PlayoutRejected::Stale));
        playout.push(20, 10, 1).unwrap(); // plays at 25
        for now in 11..=25 {
            playout.next(now);
        }
        // Tick 20 arrives at 50, 25 periods after its play time at 35: the latency grows.
        playout.push(50, 20, 2).unwrap();
        assert_eq!((playout.late(), playout.offset()), (1, Some(35)));
        assert_eq!(playout.push(51, 5, 7), Err(PlayoutRejected::Stale));
        let mut seen = StdVec::new();
        for now in 26..60 {
            if let Playing::Command {
                value,
                held_periods: 0,
                ..
            } = playout.next(now)
            {
                seen.push((now, value));
            }
        }
        assert_eq!(seen, std::vec![(55, 2)]);
    }

    /// A tick half the range away from the commands held (one flipped top bit) used to
    /// land in front of them and play, and the next command then played "after" it
    /// 2^31 ticks back: refused, and the stream plays on in order.
    #[test]
    fn a_tick_outside_the_window_is_refused() {
        let mut playout = Playout::<u32, 8>::new(35);
        playout.push(0, 1000, 1).unwrap();
        playout.push(1, 1001, 2).unwrap();
        let forged = (1 << 31) + 1002;
        assert_eq!(
            playout.push(2, forged, 3),
            Err(PlayoutRejected::OutOfWindow)
        );
        assert_eq!(
            playout.push(2, 1001 + TICK_WINDOW + 1, 3),
            Err(PlayoutRejected::OutOfWindow)
        );
        playout.push(3, 1004, 4).unwrap();
        let mut started = StdVec::new();
        for now in 0..100 {
            if let Playing::Command {
                tick,
                held_periods: 0,
                ..
            } = playout.next(now)
            {
                started.push(tick);
            }
        }
        assert_eq!(started, [1000, 1001, 1004]);
        // Across the wrap, the window holds on both sides.
        let mut wrap = Playout::<u32, 8>::new(0);
        wrap.push(0, u32::MAX - 5, 1).unwrap();
        wrap.push(0, 4, 2).unwrap();
        assert_eq!(
            wrap.push(0, TICK_WINDOW + 10, 3),
            Err(PlayoutRejected::OutOfWindow)
        );
    }
}
