//! The machine's two job buffers, shared by whoever builds jobs (the host link) and
//! the supervisor that runs them, so that a job is built once, where it will run, and
//! never copied.
//!
//! A job of ARROW is 34 KB; carried by value it would be built on the link's stack,
//! moved into a command queue slot (every slot sized for it), and copied into the
//! supervisor in the control period. Here a job stays in one of two buffers:
//!
//! 1. the sender takes the buffer the supervisor does not hold
//!    ([`JobSlots::take_free`]), builds the job in it, lets it go, and queues
//!    [`Command::LoadJob`] with the buffer's name ([`JobSlot`]);
//! 2. the supervisor takes that buffer ([`JobSlots::take`]), checks the job, and holds
//!    it while the job is loaded, releasing the buffer of the job it replaces (a
//!    refused job releases its own buffer and leaves the loaded one loaded).
//!
//! Each buffer has an exclusive lock that is only ever tried, never waited for (one
//! compare-and-swap to take, one store to release; on a core without
//! compare-and-swap, a critical section of a few instructions; no panic path): a
//! context that finds a buffer taken is told so and goes on. The sender never writes
//! the job that runs, because the supervisor holds that buffer for as long as it is
//! loaded.
//!
//! [`Command::LoadJob`]: super::supervisor::Command::LoadJob

use spin::mutex::{SpinMutex, SpinMutexGuard};

/// One of the two job buffers.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum JobSlot {
    /// The first buffer.
    First,
    /// The second buffer.
    Second,
}

/// A buffer taken by one context: the job in it, to read or write, until it is
/// dropped.
pub type HeldJob<'a, J> = SpinMutexGuard<'a, J>;

/// The machine's two job buffers (see the module docs).
pub struct JobSlots<J> {
    first: SpinMutex<J>,
    second: SpinMutex<J>,
}

impl<J> JobSlots<J> {
    /// Two buffers holding `first` and `second` (empty jobs).
    pub const fn new(first: J, second: J) -> Self {
        Self {
            first: SpinMutex::new(first),
            second: SpinMutex::new(second),
        }
    }

    fn lock(&self, slot: JobSlot) -> &SpinMutex<J> {
        match slot {
            JobSlot::First => &self.first,
            JobSlot::Second => &self.second,
        }
    }

    /// Takes `slot`; `None` while the other context holds it.
    pub fn take(&self, slot: JobSlot) -> Option<HeldJob<'_, J>> {
        self.lock(slot).try_lock()
    }

    /// Takes a buffer nobody holds, the first one first; `None` when both are held.
    pub fn take_free(&self) -> Option<(JobSlot, HeldJob<'_, J>)> {
        [JobSlot::First, JobSlot::Second]
            .into_iter()
            .find_map(|slot| self.take(slot).map(|job| (slot, job)))
    }
}

impl<J> JobSlots<J> {
    /// Moves `job` into a free buffer and names it, for a sender that has the job as a
    /// value (a simulation, a test); `None` when both buffers are held. The sender
    /// queues `LoadJob` with the name and places no other job until that one is
    /// answered (until the supervisor takes it, its buffer looks free).
    #[must_use]
    pub fn place(&self, job: J) -> Option<JobSlot> {
        let (slot, mut held) = self.take_free()?;
        *held = job;
        Some(slot)
    }
}

impl<J: Default> Default for JobSlots<J> {
    fn default() -> Self {
        Self::new(J::default(), J::default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_held_buffer_is_refused_to_the_other_context_until_released() {
        let slots = JobSlots::new(1u32, 2u32);
        let held = slots.take(JobSlot::First).expect("free at the start");
        assert_eq!(*held, 1);
        assert!(slots.take(JobSlot::First).is_none(), "held: refused");
        let (free, mut other) = slots.take_free().expect("the second is free");
        assert_eq!(free, JobSlot::Second);
        *other = 7;
        assert!(slots.take_free().is_none(), "both held");
        drop(other);
        drop(held);
        assert_eq!(
            slots.take(JobSlot::Second).map(|j| *j),
            Some(7),
            "written in place"
        );
        assert_eq!(
            slots.take_free().map(|(s, j)| (s, *j)),
            Some((JobSlot::First, 1))
        );
    }
}
