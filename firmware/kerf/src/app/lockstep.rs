//! An emulated machine's end of a network that a host tool runs between two emulated
//! machines (the remote master and its slave, each on its own emulated processor):
//! the frames the machine sends and receives travel as messages on a byte stream (a
//! second serial port), and the two machines' clocks advance in lockstep.
//!
//! The tool runs the pair in rounds of W control periods, W at most the network's
//! smallest one-way delay: it grants each machine the periods before a tick, collects
//! the frames each sent with the tick it sent them at, passes them through its model of
//! the network (delay, jitter, loss) and hands each to the other machine with the tick
//! it is due at, which the machine keeps until its own clock reaches that tick. No
//! frame is due sooner than W periods after it was sent, so each machine holds every
//! frame due in a round before the round starts, and the pair runs exactly as on one
//! simulated network, however fast either emulator runs.
//!
//! Messages, little-endian:
//!
//! | from | byte | fields |
//! |---|---|---|
//! | machine | `F` | tick u32, length u16, the frame: sent in period `tick` |
//! | machine | `W` | tick u32: every period before `tick` has run; waiting for a grant |
//! | tool | `G` | tick u32: the periods before `tick` may run |
//! | tool | `D` | due tick u32, length u16, the frame: received in period `due` |
//!
//! The tool's half of the protocol is here too ([`parse_machine`], [`grant`],
//! [`delivery_head`]), tested against the machine's end; no image or host command uses
//! the pair yet.
//!
//! Sans-IO: the image feeds the bytes it reads ([`LockstepEnd::feed`]) and gives a
//! writer for the bytes to send. A frame longer than `FRAME` bytes or beyond `QUEUE`
//! waiting deliveries is dropped and counted; an unknown message byte is skipped and
//! counted (the stream resynchronises on the next message byte).

use crate::hal::{FrameLink, LinkBusy};
use heapless::Vec;

/// Message bytes.
const FRAME_SENT: u8 = b'F';
const WAITING: u8 = b'W';
const GRANT: u8 = b'G';
const DELIVER: u8 = b'D';

/// The tool's message being read.
#[derive(Clone, Debug)]
enum Reading<const FRAME: usize> {
    /// Between messages.
    Idle,
    /// A grant's tick, `have` of its 4 bytes.
    Grant { tick: [u8; 4], have: usize },
    /// A delivery's due tick and length, `have` of their 6 bytes.
    DeliveryHead { head: [u8; 6], have: usize },
    /// A delivery's frame: `read` of its `len` bytes, those that fit kept.
    Delivery {
        due: u32,
        len: usize,
        read: usize,
        frame: Vec<u8, FRAME>,
    },
}

/// The machine's end: its clock, the grant, the frames waiting to be due.
#[derive(Clone, Debug)]
pub struct LockstepEnd<const FRAME: usize, const QUEUE: usize> {
    tick: u32,
    granted: u32,
    waiting_said: bool,
    reading: Reading<FRAME>,
    pending: Vec<(u32, Vec<u8, FRAME>), QUEUE>,
    dropped: u32,
    garbled: u32,
}

impl<const FRAME: usize, const QUEUE: usize> Default for LockstepEnd<FRAME, QUEUE> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const FRAME: usize, const QUEUE: usize> LockstepEnd<FRAME, QUEUE> {
    /// At period 0, nothing granted.
    pub const fn new() -> Self {
        Self {
            tick: 0,
            granted: 0,
            waiting_said: false,
            reading: Reading::Idle,
            pending: Vec::new(),
            dropped: 0,
            garbled: 0,
        }
    }

    /// Reads the tool's bytes: grants and deliveries.
    pub fn feed(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.feed_byte(b);
        }
    }

    fn feed_byte(&mut self, b: u8) {
        let reading = core::mem::replace(&mut self.reading, Reading::Idle);
        self.reading = match reading {
            Reading::Idle => match b {
                GRANT => Reading::Grant {
                    tick: [0; 4],
                    have: 0,
                },
                DELIVER => Reading::DeliveryHead {
                    head: [0; 6],
                    have: 0,
                },
                _ => {
                    self.garbled = self.garbled.saturating_add(1);
                    Reading::Idle
                }
            },
            Reading::Grant { mut tick, have } => {
                if let Some(slot) = tick.get_mut(have) {
                    *slot = b;
                }
                if have + 1 == tick.len() {
                    // A grant never takes back periods already granted.
                    let granted = u32::from_le_bytes(tick);
                    if granted.wrapping_sub(self.granted) < 1 << 31 {
                        self.granted = granted;
                    }
                    Reading::Idle
                } else {
                    Reading::Grant {
                        tick,
                        have: have + 1,
                    }
                }
            }
            Reading::DeliveryHead { mut head, have } => {
                if let Some(slot) = head.get_mut(have) {
                    *slot = b;
                }
                if have + 1 == head.len() {
                    let [d0, d1, d2, d3, l0, l1] = head;
                    let len = usize::from(u16::from_le_bytes([l0, l1]));
                    let due = u32::from_le_bytes([d0, d1, d2, d3]);
                    if len == 0 {
                        self.deliver(due, len, Vec::new());
                        Reading::Idle
                    } else {
                        Reading::Delivery {
                            due,
                            len,
                            read: 0,
                            frame: Vec::new(),
                        }
                    }
                } else {
                    Reading::DeliveryHead {
                        head,
                        have: have + 1,
                    }
                }
            }
            Reading::Delivery {
                due,
                len,
                read,
                mut frame,
            } => {
                // A frame too long is read to its end; its bytes past FRAME are not
                // kept, and it is dropped.
                let _ = frame.push(b);
                if read + 1 >= len {
                    self.deliver(due, len, frame);
                    Reading::Idle
                } else {
                    Reading::Delivery {
                        due,
                        len,
                        read: read + 1,
                        frame,
                    }
                }
            }
        };
    }

    /// A delivery read whole: waits for its tick, unless it did not fit.
    fn deliver(&mut self, due: u32, len: usize, frame: Vec<u8, FRAME>) {
        if frame.len() != len || self.pending.push((due, frame)).is_err() {
            self.dropped = self.dropped.saturating_add(1);
        }
    }

    /// Whether the period at the machine's clock may run; when it may not, says once
    /// to the tool (through `write`) that the machine waits there.
    pub fn may_run(&mut self, write: &mut dyn FnMut(&[u8])) -> bool {
        if self.granted.wrapping_sub(self.tick).wrapping_sub(1) < 1 << 31 {
            return true;
        }
        if !self.waiting_said {
            let mut message = [WAITING, 0, 0, 0, 0];
            if let Some(t) = message.get_mut(1..5) {
                t.copy_from_slice(&self.tick.to_le_bytes());
            }
            write(&message);
            self.waiting_said = true;
        }
        false
    }

    /// The network as the period sees it: frames sent go out with this period's tick,
    /// frames due by now are received.
    pub fn link<'a>(
        &'a mut self,
        write: &'a mut dyn FnMut(&[u8]),
    ) -> LockstepLink<'a, FRAME, QUEUE> {
        LockstepLink { end: self, write }
    }

    /// The period has run: the clock advances.
    pub fn end_period(&mut self) {
        self.tick = self.tick.wrapping_add(1);
        self.waiting_said = false;
    }

    /// The machine's clock: periods run.
    pub fn tick(&self) -> u32 {
        self.tick
    }

    /// Frames dropped: too long, or no room to wait.
    pub fn dropped(&self) -> u32 {
        self.dropped
    }

    /// Bytes that were no message.
    pub fn garbled(&self) -> u32 {
        self.garbled
    }
}

/// What a machine says to the tool.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum MachineMessage<'a> {
    /// A frame sent in period `tick`.
    Sent {
        /// The period.
        tick: u32,
        /// The frame.
        frame: &'a [u8],
    },
    /// Every period before `tick` has run; waiting for a grant.
    Waiting {
        /// The first period not run.
        tick: u32,
    },
}

/// The first message of `bytes` and the bytes it took; `Ok(None)` while it is still
/// incomplete; `Err(n)` for `n` bytes that start no message (the tool skips them).
pub fn parse_machine(bytes: &[u8]) -> Result<Option<(MachineMessage<'_>, usize)>, usize> {
    let u32_at = |at: usize| {
        bytes
            .get(at..at + 4)
            .and_then(|b| b.try_into().ok())
            .map(u32::from_le_bytes)
    };
    match bytes.first() {
        None => Ok(None),
        Some(&WAITING) => Ok(u32_at(1).map(|tick| (MachineMessage::Waiting { tick }, 5))),
        Some(&FRAME_SENT) => {
            let (Some(tick), Some(len)) = (
                u32_at(1),
                bytes
                    .get(5..7)
                    .and_then(|l| l.try_into().ok())
                    .map(|l| usize::from(u16::from_le_bytes(l))),
            ) else {
                return Ok(None);
            };
            Ok(bytes
                .get(7..7 + len)
                .map(|frame| (MachineMessage::Sent { tick, frame }, 7 + len)))
        }
        Some(_) => Err(1),
    }
}

/// The tool's grant of the periods before `tick`.
pub fn grant(tick: u32) -> [u8; 5] {
    let t = tick.to_le_bytes();
    [GRANT, t[0], t[1], t[2], t[3]]
}

/// The head of the tool's delivery of a frame of `len` bytes due in period `due`
/// (the frame's bytes follow it); `None` for a frame longer than a length field holds.
pub fn delivery_head(due: u32, len: usize) -> Option<[u8; 7]> {
    let (d, l) = (due.to_le_bytes(), u16::try_from(len).ok()?.to_le_bytes());
    Some([DELIVER, d[0], d[1], d[2], d[3], l[0], l[1]])
}

/// The network for one period ([`LockstepEnd::link`]).
pub struct LockstepLink<'a, const FRAME: usize, const QUEUE: usize> {
    end: &'a mut LockstepEnd<FRAME, QUEUE>,
    write: &'a mut dyn FnMut(&[u8]),
}

impl<const FRAME: usize, const QUEUE: usize> FrameLink for LockstepLink<'_, FRAME, QUEUE> {
    /// The frame goes to the tool with this period's tick; one longer than a length
    /// field holds is refused.
    fn send(&mut self, frame: &[u8]) -> Result<(), LinkBusy> {
        let len = u16::try_from(frame.len()).map_err(|_| LinkBusy)?;
        let mut head = [FRAME_SENT, 0, 0, 0, 0, 0, 0];
        if let Some(t) = head.get_mut(1..5) {
            t.copy_from_slice(&self.end.tick.to_le_bytes());
        }
        if let Some(l) = head.get_mut(5..7) {
            l.copy_from_slice(&len.to_le_bytes());
        }
        (self.write)(&head);
        (self.write)(frame);
        Ok(())
    }

    /// The first frame (in the order the tool sent them) due by this period. One longer
    /// than `buf` is dropped and counted.
    fn receive(&mut self, buf: &mut [u8]) -> Option<usize> {
        let now = self.end.tick;
        loop {
            let index = self
                .end
                .pending
                .iter()
                .position(|(due, _)| now.wrapping_sub(*due) < 1 << 31)?;
            let copied = self.end.pending.get(index).and_then(|(_, frame)| {
                let dst = buf.get_mut(..frame.len())?;
                dst.copy_from_slice(frame);
                Some(frame.len())
            });
            let mut k = 0;
            self.end.pending.retain(|_| {
                k += 1;
                k != index + 1
            });
            match copied {
                Some(len) => return Some(len),
                None => self.end.dropped = self.end.dropped.saturating_add(1),
            }
        }
    }
}

#[cfg(test)]
mod tests;
